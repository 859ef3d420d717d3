package io.mnsskit.core;

/**
 * The picture the app shows, as ARGB pixels ({@code 0xAARRGGBB}, row 0 at the top, as
 * {@code Bitmap.setPixels} takes them): two RGB code images of the same size side by side, or one
 * over the other cut by a vertical split line.  The codes are display values already (the model's
 * {@code display} and {@link Bilinear#displayCodes}), so they are shown as they are.
 */
public final class Compositor {
    private Compositor() {
    }

    /** {@code left} and {@code right} (each {@code (h, w, 3)} codes) next to each other: {@code 2w x h}. */
    public static int[] sideBySide(byte[] left, byte[] right, int w, int h) {
        check(left, w, h);
        check(right, w, h);
        int[] out = new int[2 * w * h];
        for (int y = 0; y < h; y++) {
            for (int x = 0; x < w; x++) {
                out[y * 2 * w + x] = argb(left, y * w + x);
                out[y * 2 * w + w + x] = argb(right, y * w + x);
            }
        }
        return out;
    }

    /** {@code w x h}: columns left of {@code splitX} from {@code left}, the rest from {@code right}. */
    public static int[] split(byte[] left, byte[] right, int w, int h, int splitX) {
        check(left, w, h);
        check(right, w, h);
        int cut = Math.max(0, Math.min(w, splitX));
        int[] out = new int[w * h];
        for (int p = 0; p < w * h; p++) {
            out[p] = argb(p % w < cut ? left : right, p);
        }
        return out;
    }

    /** {@code (h, w, 3)} codes repeated {@code fx x fy} times per pixel (nearest): {@code (h*fy, w*fx, 3)}. */
    public static byte[] nearest(byte[] rgb, int w, int h, int fx, int fy) {
        check(rgb, w, h);
        int ow = w * fx;
        byte[] out = new byte[ow * h * fy * 3];
        for (int y = 0; y < h * fy; y++) {
            for (int x = 0; x < ow; x++) {
                System.arraycopy(rgb, ((y / fy) * w + x / fx) * 3, out, (y * ow + x) * 3, 3);
            }
        }
        return out;
    }

    private static int argb(byte[] rgb, int pixel) {
        int o = pixel * 3;
        return 0xFF000000 | (rgb[o] & 0xFF) << 16 | (rgb[o + 1] & 0xFF) << 8 | (rgb[o + 2] & 0xFF);
    }

    private static void check(byte[] rgb, int w, int h) {
        if (rgb.length != w * h * 3) {
            throw new IllegalArgumentException(rgb.length + " bytes are not a " + w + "x" + h + " RGB image");
        }
    }
}
