package io.mnsskit.core;

import java.io.File;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.Collections;
import java.util.HashMap;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The golden frames of a bundle: a few consecutive frames' inputs (as the input textures hold
 * them) and the tensors a phone reads back, computed on a desk by the reference GPU passes and
 * the NPU model under {@link #profile}'s kernels.  What a frame holds follows the manifest's
 * resources, as {@code mnss_kit/export/golden.py} writes it: every {@code input} resource (dtype
 * from its texture format, shape {@code (h, w, channels)}), every {@code boundary} buffer (int8,
 * the boundary tensor's NHWC shape) and the {@code output} resource (uint8 codes).  Arrays are
 * raw little-endian files.
 */
public final class Golden {
    /** Texture format to the dtype of its golden array (as {@code golden.FORMAT_DTYPES}). */
    static final Map<String, Tensor.DType> FORMAT_DTYPES = formatDtypes();

    public final String profile;
    public final String source;
    /** {@code npu_input_lsb}, {@code npu_output_lsb}, {@code display_codes}, {@code note}. */
    public final Json tolerances;
    /** The {@code input} resources, in manifest order: what the GPU steps are fed each frame. */
    public final List<String> inputs;
    /** The {@code boundary} buffers, in manifest order: compared in LSBs. */
    public final List<String> boundaries;
    /** The {@code output} resource: compared in codes. */
    public final String output;
    public final List<Frame> frames;
    private final Map<String, NpuSection.Boundary> boundaryByResource;

    public static final class Array {
        public final String file;
        public final Tensor.DType dtype;
        public final int[] shape;

        Array(Json j) {
            file = j.get("file").asString();
            dtype = Tensor.DType.of(j.get("dtype").asString());
            shape = Manifest.shape(j.get("shape"));
        }
    }

    public static final class Frame {
        public final int index;
        public final boolean reset;
        public final float[] jitter;
        public final int[] subpixel;
        /** Index of the matching jitter table entry, or null if the frame's jitter is not in the table. */
        public final Integer jitterIndex;
        /** Resource name to its stored array. */
        public final Map<String, Array> arrays;
        private final Golden golden;

        Frame(Json j, Golden golden, Map<String, GpuSection.Resource> expected) {
            this.golden = golden;
            index = j.get("index").asInt();
            reset = j.get("reset").asBool();
            jitter = Manifest.pair(j.get("jitter")).asFloatArray();
            subpixel = Manifest.pair(j.get("subpixel")).asIntArray();
            Json ji = j.get("jitter_index");
            jitterIndex = ji.isNull() ? null : ji.asInt();
            Map<String, Array> map = new LinkedHashMap<>();
            Json aj = j.get("arrays");
            for (GpuSection.Resource r : expected.values()) {
                if (!aj.has(r.name)) {
                    throw new BundleException(aj.path() + " missing golden array '" + r.name + "' (" + r.role + " resource)");
                }
                Array a = new Array(aj.get(r.name));
                golden.checkArray(aj.get(r.name).path(), r, a);
                map.put(r.name, a);
            }
            arrays = Collections.unmodifiableMap(map);
        }

        /** The frame's jitter as a table entry (sub-pixel as stored with the frame). */
        public Manifest.JitterEntry jitterEntry() {
            return new Manifest.JitterEntry(jitterIndex == null ? -1 : jitterIndex, jitter[0], jitter[1], subpixel[0], subpixel[1]);
        }

        /** Reads the array of resource {@code name}; a boundary buffer gets its boundary tensor's scale and zero point. */
        public Tensor read(File bundle, String name) {
            Array a = arrays.get(name);
            if (a == null) {
                throw new BundleException("golden frame " + index + " has no array '" + name + "'");
            }
            NpuSection.Boundary b = golden.boundaryByResource.get(name);
            Float scale = b == null ? null : b.scale;
            int zeroPoint = b == null ? 0 : b.zeroPoint;
            return Tensor.read(new File(bundle, a.file), name, a.dtype, a.shape, scale, zeroPoint);
        }

        /** Reads the arrays of resources {@code names}, by name, in that order. */
        public Map<String, Tensor> read(File bundle, List<String> names) {
            Map<String, Tensor> out = new LinkedHashMap<>();
            for (String name : names) {
                out.put(name, read(bundle, name));
            }
            return out;
        }
    }

    Golden(Json j, List<GpuSection.Resource> resources, List<NpuSection.Boundary> boundary) {
        profile = j.get("profile").asString();
        source = j.get("source").asString();
        tolerances = j.get("tolerances");
        Map<String, NpuSection.Boundary> byResource = new LinkedHashMap<>();
        for (NpuSection.Boundary b : boundary) {
            byResource.put(b.bufferResource, b);
        }
        boundaryByResource = Collections.unmodifiableMap(byResource);
        Map<String, GpuSection.Resource> expected = new LinkedHashMap<>();
        List<String> in = new ArrayList<>();
        List<String> buffers = new ArrayList<>();
        List<String> out = new ArrayList<>();
        for (String role : Arrays.asList("input", "boundary", "output")) {
            for (GpuSection.Resource r : resources) {
                if (r.role.equals(role)) {
                    expected.put(r.name, r);
                    (role.equals("input") ? in : role.equals("boundary") ? buffers : out).add(r.name);
                }
            }
        }
        if (out.size() != 1) {
            throw new BundleException("manifest.json: resources has " + out.size() + " resources with role 'output'; the self-test reads exactly one");
        }
        inputs = Collections.unmodifiableList(in);
        boundaries = Collections.unmodifiableList(buffers);
        output = out.get(0);
        List<Frame> list = new ArrayList<>();
        for (Json f : j.get("frames").items()) {
            list.add(new Frame(f, this, expected));
        }
        frames = Collections.unmodifiableList(list);
    }

    // Map.of would need Android 11 (API 30); the app runs from API 26.
    private static Map<String, Tensor.DType> formatDtypes() {
        Map<String, Tensor.DType> m = new HashMap<>();
        for (String f : new String[] {"rgba16f", "rg16f", "r16f"}) {
            m.put(f, Tensor.DType.FLOAT16);
        }
        for (String f : new String[] {"rgba32f", "rg32f", "r32f"}) {
            m.put(f, Tensor.DType.FLOAT32);
        }
        m.put("rgba8", Tensor.DType.UINT8);
        return Collections.unmodifiableMap(m);
    }

    /** The array must have the dtype and shape the resource gives it. */
    private void checkArray(String where, GpuSection.Resource r, Array a) {
        Tensor.DType dtype;
        int[] shape;
        if (r.kind == GpuSection.ResourceKind.BUFFER) {
            NpuSection.Boundary b = boundaryByResource.get(r.name);
            if (b == null) {
                throw new BundleException("manifest.json: boundary resource '" + r.name + "' carries no boundary tensor");
            }
            dtype = Tensor.DType.INT8;
            shape = b.shape;
        } else {
            dtype = FORMAT_DTYPES.get(r.format);
            if (dtype == null) {
                throw new BundleException("manifest.json: resource '" + r.name + "' has format '" + r.format + "', which has no golden dtype");
            }
            shape = new int[] {r.size[1], r.size[0], r.channels == 0 ? a.shape[a.shape.length - 1] : r.channels};
        }
        if (a.dtype != dtype || !Arrays.equals(a.shape, shape)) {
            throw new BundleException(where + " is " + a.dtype.id + " " + Arrays.toString(a.shape) + "; resource '" + r.name
                    + "' needs " + dtype.id + " " + Arrays.toString(shape));
        }
    }

    /** Allowed difference for a golden tensor: LSBs for a boundary buffer (by its role), codes for the output. */
    public int toleranceFor(String resource) {
        NpuSection.Boundary b = boundaryByResource.get(resource);
        String name = b != null ? b.role + "_lsb" : resource.equals(output) ? "display_codes" : null;
        if (name == null) {
            throw new BundleException("golden tensor '" + resource + "' is neither a boundary buffer nor the output");
        }
        Json t = tolerances.opt(name);
        return t == null ? 0 : t.asInt();
    }

    /** The boundary tensor a boundary buffer carries (its NPU tensor name, scale, zero point). */
    public NpuSection.Boundary boundaryOf(String resource) {
        NpuSection.Boundary b = boundaryByResource.get(resource);
        if (b == null) {
            throw new BundleException("manifest.json: resource '" + resource + "' carries no boundary tensor");
        }
        return b;
    }
}
