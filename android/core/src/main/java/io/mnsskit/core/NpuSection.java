package io.mnsskit.core;

import java.util.ArrayList;
import java.util.Collections;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

/**
 * The NPU part of a manifest: the int8 model file, its input/output and activation tensors, and
 * the tensors crossing the GPU-NPU boundary with their byte packing and texture remaps.
 */
public final class NpuSection {
    /** The {@code .tflite} file (int8, NHWC) and its QDQ ONNX twin, relative to the bundle. */
    public final String model;
    public final String onnx;
    public final String layout;
    public final List<String> inputs;
    public final List<String> outputs;
    public final Map<String, NpuTensor> tensors;
    /** The CPU kernel set whose rounding the golden frames and the GPU pack reproduce. */
    public final String requantizationProfile;
    public final Json quantization;

    /** A quantized activation tensor of the NPU model; {@code shape} NHWC. */
    public static final class NpuTensor {
        public final String name;
        public final int[] shape;
        public final String dtype;
        public final float scale;
        public final int zeroPoint;

        NpuTensor(Json j) {
            name = j.get("name").asString();
            shape = Manifest.shape(j.get("shape"));
            dtype = j.get("dtype").asString();
            scale = positive(j.get("scale"));
            zeroPoint = j.get("zero_point").asInt();
        }
    }

    /** Affine map {@code y = multiply * x + add}. */
    public static final class Affine {
        public final double multiply;
        public final double add;

        Affine(Json j) {
            multiply = j.get("multiply").asDouble();
            add = j.get("add").asDouble();
        }

        public double apply(double x) {
            return multiply * x + add;
        }
    }

    /**
     * How a shader reaches a boundary tensor through a texture instead of the packed buffer
     * ({@code mnss_kit/export/boundary.py} derives them): integer texels are exact, SNORM8 cannot
     * write the code -128, UNORM8 bytes are the tensor's bytes read as two's complement.
     */
    public static final class TextureRemap {
        public final boolean rgba8iExact;
        public final Affine rgba8iRealFromCode;
        public final boolean snorm8Exact;
        public final Affine snorm8RealFromTexel;
        public final Affine snorm8TexelFromReal;
        public final int[] snorm8WritableCodes;
        public final int snorm8UnreachableCode;
        public final boolean unorm8Exact;
        /** Byte ranges of the two pieces ({@code [0, 127]} and {@code [128, 255]}). */
        public final int[][] unorm8PieceBytes;
        /** Real from the texel value, per piece. */
        public final Affine[] unorm8Pieces;

        TextureRemap(Json j) {
            Json rgba8i = j.get("rgba8i");
            rgba8iExact = rgba8i.get("exact").asBool();
            rgba8iRealFromCode = new Affine(rgba8i.get("real_from_code"));
            Json snorm = j.get("snorm8");
            snorm8Exact = snorm.get("exact").asBool();
            snorm8RealFromTexel = new Affine(snorm.get("real_from_texel"));
            snorm8TexelFromReal = new Affine(snorm.get("texel_from_real"));
            snorm8WritableCodes = snorm.get("writable_codes").asIntArray();
            snorm8UnreachableCode = snorm.get("unreachable_code").asInt();
            Json unorm = j.get("unorm8");
            unorm8Exact = unorm.get("exact").asBool();
            Json pieces = unorm.get("pieces");
            if (pieces.size() != 2) {
                throw new BundleException(pieces.path() + " needs 2 pieces");
            }
            unorm8PieceBytes = new int[2][];
            unorm8Pieces = new Affine[2];
            for (int i = 0; i < 2; i++) {
                unorm8PieceBytes[i] = Manifest.pair(pieces.at(i).get("bytes")).asIntArray();
                unorm8Pieces[i] = new Affine(pieces.at(i).get("real_from_texel"));
            }
        }

        /** Real value of a UNORM8 texel value {@code v} (the byte is {@code round(255 v)}). */
        public double realFromUnorm8(double v) {
            long u = Math.round(v * 255.0);
            return unorm8Pieces[u <= unorm8PieceBytes[0][1] ? 0 : 1].apply(v);
        }
    }

    /** A tensor crossing the boundary: {@code npu_input} (GPU writes) or {@code npu_output} (GPU reads). */
    public static final class Boundary {
        public final String role;
        /** Its name in the NPU model. */
        public final String tensor;
        public final String direction;
        public final String layout;
        public final String dtype;
        public final int[] shape;
        public final float scale;
        public final int zeroPoint;
        public final double[] realRange;
        public final long bytes;
        /** The schedule resource (an SSBO of packed words) that carries it. */
        public final String bufferResource;
        public final String packing;
        public final long words;
        public final TextureRemap textureRemap;

        Boundary(Json j) {
            role = j.get("role").asString();
            tensor = j.get("tensor").asString();
            direction = j.get("direction").asString();
            layout = j.get("layout").asString();
            dtype = j.get("dtype").asString();
            shape = Manifest.shape(j.get("shape"));
            scale = positive(j.get("scale"));
            zeroPoint = j.get("zero_point").asInt();
            Json range = Manifest.pair(j.get("real_range"));
            realRange = new double[] {range.at(0).asDouble(), range.at(1).asDouble()};
            bytes = j.get("bytes").asLong();
            Json buffer = j.get("buffer");
            bufferResource = buffer.get("resource").asString();
            packing = buffer.get("packing").asString();
            words = buffer.get("words").asLong();
            textureRemap = new TextureRemap(j.get("texture_remap"));
            if (!"NHWC".equals(layout) || !"int8".equals(dtype)) {
                throw new BundleException(j.path() + " boundary tensors are int8 NHWC, got " + dtype + " " + layout);
            }
            if (Tensor.count(shape) != bytes || Int8Quant.wordCount((int) bytes) != words) {
                throw new BundleException(j.path() + " bytes/words do not match shape");
            }
        }

        public int count() {
            return (int) bytes;
        }
    }

    NpuSection(Json j) {
        model = j.get("model").asString();
        onnx = j.get("onnx").asString();
        layout = j.get("layout").asString();
        inputs = j.get("inputs").asStringList();
        outputs = j.get("outputs").asStringList();
        Map<String, NpuTensor> map = new LinkedHashMap<>();
        for (Json t : j.get("tensors").items()) {
            NpuTensor tensor = new NpuTensor(t);
            map.put(tensor.name, tensor);
        }
        tensors = Collections.unmodifiableMap(map);
        requantizationProfile = j.get("requantization_profile").asString();
        quantization = j.get("quantization");
    }

    static List<Boundary> readBoundary(Json j) {
        List<Boundary> out = new ArrayList<>();
        for (Json b : j.items()) {
            out.add(new Boundary(b));
        }
        return Collections.unmodifiableList(out);
    }

    private static float positive(Json j) {
        float v = j.asFloat();
        if (!(v > 0f) || Float.isInfinite(v)) {
            throw new BundleException(j.path() + " must be a positive finite number");
        }
        return v;
    }
}
