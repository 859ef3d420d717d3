package io.mnsskit.core;

/**
 * The bilinear upscale shown beside the model: {@code mnss_kit.ops.resample.upsample_bilinear}
 * of the LR colour at its jitter, then the GPU's display encoding
 * ({@code mnss_kit.gpu.reference.encode_unorm8}), operation for operation in float32 so the codes
 * are the toolkit's.  The bundle's colour is display values in [0, 1] (manifest
 * {@code conventions.colour}), as the model's output is, so no tone mapping comes between.
 */
public final class Bilinear {
    private Bilinear() {
    }

    /**
     * {@code (h, w, c)} float tensor to {@code (h*s, w*s, c)} float32 values: the HR pixel at LR
     * position {@code u} reads the LR image at {@code u - offset} (LR pixels, the jitter), pixel
     * centres at +0.5, taps clamped to the edge.
     */
    public static float[] upsample(Tensor lr, int scale, float offsetX, float offsetY) {
        int h = lr.shape[0];
        int w = lr.shape[1];
        int c = lr.shape[2];
        int hw = w * scale;
        float[] out = new float[h * scale * hw * c];
        float[] image = new float[h * w * c];
        for (int i = 0; i < image.length; i++) {
            image[i] = lr.floatAt(i);
        }
        float s = scale;
        for (int y = 0; y < h * scale; y++) {
            float fy = ((y + 0.5f) / s - offsetY) - 0.5f;
            float y0 = (float) Math.floor(fy);
            float ay = fy - y0;
            int ya = clamp((int) y0, h) * w;
            int yb = clamp((int) y0 + 1, h) * w;
            for (int x = 0; x < hw; x++) {
                float fx = ((x + 0.5f) / s - offsetX) - 0.5f;
                float x0 = (float) Math.floor(fx);
                float ax = fx - x0;
                int xa = clamp((int) x0, w);
                int xb = clamp((int) x0 + 1, w);
                int o = (y * hw + x) * c;
                for (int k = 0; k < c; k++) {
                    float top = image[(ya + xa) * c + k] * (1 - ax) + image[(ya + xb) * c + k] * ax;
                    float bottom = image[(yb + xa) * c + k] * (1 - ax) + image[(yb + xb) * c + k] * ax;
                    out[o + k] = top * (1 - ay) + bottom * ay;
                }
            }
        }
        return out;
    }

    /**
     * {@code (h, w, c)} float tensor to {@code (outH, outW, c)} float32 values at any scale
     * ({@code mnss_kit.ops.scale.resize_bilinear}): HR pixel centre {@code X + 0.5} reads the LR image
     * at {@code (X + 0.5) * w / outW - offset}; an integer scale is {@link #upsample(Tensor, int, float, float)}.
     */
    public static float[] resize(Tensor lr, int outW, int outH, float offsetX, float offsetY) {
        int h = lr.shape[0];
        int w = lr.shape[1];
        int c = lr.shape[2];
        if (outW % w == 0 && outH % h == 0 && outW / w == outH / h) {
            return upsample(lr, outW / w, offsetX, offsetY);
        }
        float[] out = new float[outH * outW * c];
        float[] image = new float[h * w * c];
        for (int i = 0; i < image.length; i++) {
            image[i] = lr.floatAt(i);
        }
        for (int y = 0; y < outH; y++) {
            float fy = (float) ((y + 0.5) * ((double) h / outH) - offsetY) - 0.5f;
            float y0 = (float) Math.floor(fy);
            float ay = fy - y0;
            int ya = clamp((int) y0, h) * w;
            int yb = clamp((int) y0 + 1, h) * w;
            for (int x = 0; x < outW; x++) {
                float fx = (float) ((x + 0.5) * ((double) w / outW) - offsetX) - 0.5f;
                float x0 = (float) Math.floor(fx);
                float ax = fx - x0;
                int xa = clamp((int) x0, w);
                int xb = clamp((int) x0 + 1, w);
                int o = (y * outW + x) * c;
                for (int k = 0; k < c; k++) {
                    float top = image[(ya + xa) * c + k] * (1 - ax) + image[(ya + xb) * c + k] * ax;
                    float bottom = image[(yb + xa) * c + k] * (1 - ax) + image[(yb + xb) * c + k] * ax;
                    out[o + k] = top * (1 - ay) + bottom * ay;
                }
            }
        }
        return out;
    }

    /** The bilinear resize of {@code lr}'s first three channels to {@code outW x outH} as display codes. */
    public static byte[] displayCodes(Tensor lr, int outW, int outH, Manifest.JitterEntry jitter) {
        int c = lr.shape[2];
        if (c < 3) {
            throw new BundleException("tensor " + lr.describe() + " has fewer than 3 colour channels");
        }
        float[] hr = resize(lr, outW, outH, jitter.offsetX, jitter.offsetY);
        byte[] out = new byte[hr.length / c * 3];
        for (int p = 0; p < out.length / 3; p++) {
            for (int k = 0; k < 3; k++) {
                out[p * 3 + k] = (byte) encodeUnorm8(hr[p * c + k]);
            }
        }
        return out;
    }

    private static int clamp(int i, int n) {
        return Math.max(0, Math.min(n - 1, i));
    }

    /** A display value to its 8-bit code: {@code rint(clamp(v, 0, 1) * 255)}, float32 product, ties to even. */
    public static int encodeUnorm8(float v) {
        float clamped = Math.max(0f, Math.min(1f, v));
        return (int) Math.rint(clamped * 255f);
    }

    /** The bilinear upscale of {@code lr}'s first three channels as display codes {@code (h*s, w*s, 3)}. */
    public static byte[] displayCodes(Tensor lr, int scale, Manifest.JitterEntry jitter) {
        int c = lr.shape[2];
        if (c < 3) {
            throw new BundleException("tensor " + lr.describe() + " has fewer than 3 colour channels");
        }
        float[] hr = upsample(lr, scale, jitter.offsetX, jitter.offsetY);
        byte[] out = new byte[hr.length / c * 3];
        for (int p = 0; p < out.length / 3; p++) {
            for (int k = 0; k < 3; k++) {
                out[p * 3 + k] = (byte) encodeUnorm8(hr[p * c + k]);
            }
        }
        return out;
    }
}
