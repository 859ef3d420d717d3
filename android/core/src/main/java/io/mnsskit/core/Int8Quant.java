package io.mnsskit.core;

/**
 * int8 quantize / dequantize at the GPU-NPU boundary and the packing of int8 NHWC tensors into
 * 32-bit words, bit for bit as the toolkit ({@code mnss_kit.ops.int8.quantize.quantize} and
 * {@code dequantize}, {@code quant.glsl}, {@code mnss_kit.export.boundary}).
 *
 * <p>An int8 tensor with scale {@code s} and zero point {@code z} holds codes {@code q} for the
 * real values {@code r = s * (q - z)}.  Java float arithmetic is IEEE float32 with
 * round-to-nearest-even for every operation (strict since Java 17), so a division, a product
 * and a float-to-double widening here round exactly as numpy's float32 does.
 */
public final class Int8Quant {
    public static final int MIN = -128;
    public static final int MAX = 127;

    private Int8Quant() {
    }

    /** Tie rules of the QUANTIZE op; {@code code} is the value of the shaders' {@code u_q_rounding}. */
    public enum Rounding {
        AWAY_FROM_ZERO(0), HALF_EVEN(1), HALF_UP(2);

        public final int code;

        Rounding(int code) {
            this.code = code;
        }

        public static Rounding fromCode(int code) {
            for (Rounding r : values()) {
                if (r.code == code) {
                    return r;
                }
            }
            throw new BundleException("unknown rounding code " + code + " (0 away from zero, 1 half even, 2 half up)");
        }
    }

    /**
     * How one runtime quantizes: the float32 scale, its float32 reciprocal, whether the runtime
     * multiplies by the reciprocal instead of dividing, the tie rule and the zero point.  The
     * bundle's {@code insert_pack_pass} step carries exactly these as {@code u_q_*} uniforms.
     */
    public static final class Params {
        public final float scale;
        public final float reciprocal;
        public final boolean useReciprocal;
        public final Rounding rounding;
        public final int zeroPoint;

        public Params(float scale, float reciprocal, boolean useReciprocal, Rounding rounding, int zeroPoint) {
            if (!(scale > 0f) || Float.isInfinite(scale)) {
                throw new BundleException("quantization scale must be a positive finite number, got " + scale);
            }
            this.scale = scale;
            this.reciprocal = reciprocal;
            this.useReciprocal = useReciprocal;
            this.rounding = rounding;
            this.zeroPoint = zeroPoint;
        }

        /** Parameters with the reciprocal computed as the runtimes do: {@code float32(1 / scale)}. */
        public static Params of(float scale, int zeroPoint, boolean useReciprocal, Rounding rounding) {
            return new Params(scale, 1.0f / scale, useReciprocal, rounding, zeroPoint);
        }
    }

    /** {@code clamp(round(x / scale) + zero_point, -128, 127)}; NaN maps to the zero point (as quant.glsl). */
    public static byte quantize(float x, Params p) {
        if (Float.isNaN(x)) {
            return (byte) clamp(p.zeroPoint);
        }
        float scaled = p.useReciprocal ? x * p.reciprocal : x / p.scale; // one float32 rounding
        double rounded = round(scaled, p.rounding);
        double q = rounded + p.zeroPoint;
        return (byte) (q <= MIN ? MIN : (q >= MAX ? MAX : (int) q));
    }

    /** Real value of code {@code q}: {@code float32(scale * (q - zero_point))}, one rounding. */
    public static float dequantize(int q, float scale, int zeroPoint) {
        return (float) (q - zeroPoint) * scale;
    }

    /** The float value rounded to an integer (as a double, exact) with the given tie rule. */
    public static double round(float x, Rounding rounding) {
        double v = x; // widening is exact; the rest is the toolkit's float64 arithmetic (round_float), step for step
        switch (rounding) {
            case HALF_EVEN:
                return Math.rint(v);
            case HALF_UP:
                return Math.floor(v + 0.5);
            case AWAY_FROM_ZERO:
            default:
                return Math.copySign(Math.floor(Math.abs(v) + 0.5), v);
        }
    }

    public static byte[] quantizeAll(float[] x, Params p) {
        byte[] out = new byte[x.length];
        for (int i = 0; i < x.length; i++) {
            out[i] = quantize(x[i], p);
        }
        return out;
    }

    public static float[] dequantizeAll(byte[] q, float scale, int zeroPoint) {
        float[] out = new float[q.length];
        for (int i = 0; i < q.length; i++) {
            out[i] = dequantize(q[i], scale, zeroPoint);
        }
        return out;
    }

    /** Number of 32-bit words holding {@code count} int8 values: {@code ceil(count / 4)}. */
    public static int wordCount(int count) {
        return (count + 3) / 4;
    }

    /**
     * Packs int8 values into words: byte {@code k} of word {@code i} is element {@code 4i + k}
     * (little-endian, so the words' memory is the tensor's bytes); the tail is zero-filled.
     */
    public static int[] pack(byte[] values) {
        int[] words = new int[wordCount(values.length)];
        for (int b = 0; b < values.length; b++) {
            words[b >> 2] |= (values[b] & 0xFF) << (8 * (b & 3));
        }
        return words;
    }

    /** The first {@code count} int8 values of packed words (inverse of {@link #pack}). */
    public static byte[] unpack(int[] words, int count) {
        if (count > 4L * words.length) {
            throw new IllegalArgumentException(count + " values do not fit " + words.length + " words");
        }
        byte[] out = new byte[count];
        for (int b = 0; b < count; b++) {
            out[b] = (byte) (words[b >> 2] >>> (8 * (b & 3)));
        }
        return out;
    }

    private static int clamp(int q) {
        return Math.max(MIN, Math.min(MAX, q));
    }
}
