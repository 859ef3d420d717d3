package io.mnsskit.core;

import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The GPU part of a manifest: the compute shaders (entry file, workgroup size, bindings,
 * uniforms), the weight file's blocks and the resources (textures and buffers) a phone keeps.
 * The app creates GL objects from this data only; no binding, format or size is written in code.
 */
public final class GpuSection {
    public final String language;
    public final Map<String, Pass> passes;
    public final Weights weights;

    /** Where a resource binds: {@code sampler} (texelFetch input), {@code image} (imageStore output), {@code buffer} (SSBO). */
    public enum BindingKind {
        SAMPLER, IMAGE, BUFFER;

        static BindingKind read(Json j) {
            switch (j.asString()) {
                case "sampler": return SAMPLER;
                case "image": return IMAGE;
                case "buffer": return BUFFER;
                default: throw new BundleException(j.path() + " unknown binding kind '" + j.asString() + "'");
            }
        }
    }

    public static final class Binding {
        public final String name;
        public final BindingKind kind;
        /** The {@code layout(binding = unit)} of the declaration, in its kind's namespace. */
        public final int unit;
        /** GL sized format ({@code rgba16f}) or SSBO element type ({@code uint[]}). */
        public final String format;
        /** A 2D array texture (channels in layers of four). */
        public final boolean array;

        Binding(Json j) {
            name = j.get("name").asString();
            kind = BindingKind.read(j.get("kind"));
            unit = j.get("unit").asInt();
            format = j.get("format").asString();
            Json a = j.opt("array");
            array = a != null && a.asBool();
        }
    }

    /** One compute shader of the bundle. */
    public static final class Pass {
        public final String name;
        /** Path of the flattened GLSL ES 3.10 file, relative to the bundle. */
        public final String file;
        public final int[] workgroupSize;
        /** What one invocation covers: {@code hr}, {@code lr}, {@code lr_layers} or {@code words}. */
        public final String grid;
        public final Map<String, Binding> bindings;
        public final List<String> uniforms;
        /** Bit for bit the reference on an IEEE float32 GPU; false: a float path through pow(), within one code. */
        public final boolean exact;

        Pass(Json j) {
            name = j.get("name").asString();
            file = j.get("file").asString();
            workgroupSize = j.get("workgroup_size").asIntArray();
            if (workgroupSize.length != 3) {
                throw new BundleException(j.path() + " workgroup_size needs 3 values");
            }
            grid = j.get("grid").asString();
            Map<String, Binding> map = new LinkedHashMap<>();
            for (Json b : j.get("bindings").items()) {
                Binding binding = new Binding(b);
                map.put(binding.name, binding);
            }
            bindings = Collections.unmodifiableMap(map);
            uniforms = j.get("uniforms").asStringList();
            Json e = j.opt("exact");
            exact = e == null || e.asBool();
        }
    }

    /** A block of the weight file, bound as an SSBO range ({@code weights:NAME} in a step). */
    public static final class WeightBlock {
        public final String name;
        public final long offset;
        public final long bytes;
        public final int[] shape;
        public final String sha256;

        WeightBlock(Json j) {
            name = j.get("name").asString();
            offset = j.get("offset").asLong();
            bytes = j.get("bytes").asLong();
            shape = Manifest.shape(j.get("shape"));
            sha256 = j.get("sha256").asString();
        }
    }

    public static final class Weights {
        public final String file;
        public final String dtype;
        public final String byteOrder;
        /** Every block offset is a multiple of this (a valid SSBO offset alignment on any GL ES device). */
        public final int alignment;
        public final Map<String, WeightBlock> blocks;

        Weights(Json j) {
            file = j.get("file").asString();
            dtype = j.get("dtype").asString();
            byteOrder = j.get("byte_order").asString();
            alignment = j.get("alignment").asInt();
            Map<String, WeightBlock> map = new LinkedHashMap<>();
            for (Json b : j.get("blocks").items()) {
                WeightBlock block = new WeightBlock(b);
                if (alignment < 1 || block.offset % alignment != 0) {
                    throw new BundleException(b.path() + " offset " + block.offset + " is not a multiple of " + alignment);
                }
                map.put(block.name, block);
            }
            blocks = Collections.unmodifiableMap(map);
        }
    }

    public enum ResourceKind {
        TEXTURE2D, TEXTURE2D_ARRAY, BUFFER;

        static ResourceKind read(Json j) {
            switch (j.asString()) {
                case "texture2d": return TEXTURE2D;
                case "texture2d_array": return TEXTURE2D_ARRAY;
                case "buffer": return BUFFER;
                default: throw new BundleException(j.path() + " unknown resource kind '" + j.asString() + "'");
            }
        }
    }

    /** A texture or buffer the schedule binds; {@code role} says who writes it (input, state, ...). */
    public static final class Resource {
        public final String name;
        public final ResourceKind kind;
        public final String role;
        /** {@code [width, height]} of a texture; null for a buffer. */
        public final int[] size;
        /** GL sized format of a texture; null for a buffer. */
        public final String format;
        /** Layers of an array texture (1 otherwise). */
        public final int layers;
        /** Size of a buffer in bytes (0 for a texture). */
        public final long bytes;
        /** Channels a texture holds (of its format's components); 0 when the manifest does not say. */
        public final int channels;

        Resource(Json j) {
            name = j.get("name").asString();
            kind = ResourceKind.read(j.get("kind"));
            role = j.get("role").asString();
            if (kind == ResourceKind.BUFFER) {
                size = null;
                format = null;
                layers = 1;
                bytes = j.get("bytes").asLong();
                channels = 0;
            } else {
                size = Manifest.size(j.get("size"));
                format = j.get("format").asString();
                Json l = j.opt("layers");
                layers = l == null ? 1 : l.asInt();
                bytes = 0;
                Json c = j.opt("channels");
                channels = c == null ? 0 : c.asInt();
            }
        }
    }

    GpuSection(Json j) {
        language = j.get("language").asString();
        Map<String, Pass> map = new LinkedHashMap<>();
        for (Json p : j.get("passes").items()) {
            Pass pass = new Pass(p);
            map.put(pass.name, pass);
        }
        passes = Collections.unmodifiableMap(map);
        weights = new Weights(j.get("weights"));
    }

    static List<Resource> readResources(Json j) {
        List<Resource> out = new ArrayList<>();
        for (Json r : j.items()) {
            out.add(new Resource(r));
        }
        return Collections.unmodifiableList(out);
    }
}
