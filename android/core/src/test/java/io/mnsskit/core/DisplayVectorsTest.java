package io.mnsskit.core;

import static org.junit.Assert.assertEquals;
import static org.junit.Assume.assumeTrue;

import java.io.File;
import java.util.List;
import org.junit.BeforeClass;
import org.junit.Test;

/**
 * Vectors from the Python toolkit for what the playback screen shows: the bilinear upscale
 * ({@code mnss_kit.ops.resample.upsample_bilinear}) and the display codes
 * ({@code mnss_kit.gpu.reference.encode_unorm8}), bit for bit, and the composed ARGB pixels.
 * Written by {@code tests/android/test_display_vectors.py}, named by {@code mnss.displayVectors}.
 *
 * <pre>
 * {"bilinear":  [{"h", "w", "c", "scale", "offset_bits": [x, y], "lr_half": [...], "hr_bits": [...], "codes": [...]}, ...],
 *  "encode":    {"v_bits": [...], "codes": [...]},
 *  "composite": [{"w", "h", "left": [...], "right": [...], "side_by_side": [...], "splits": [{"x", "argb": [...]}, ...]}, ...]}
 * </pre>
 */
public class DisplayVectorsTest {
    private static Json vectors;

    @BeforeClass
    public static void load() {
        String path = System.getProperty("mnss.displayVectors");
        assumeTrue("set -Dmnss.displayVectors=FILE (tests/android/test_display_vectors.py writes it)", path != null);
        vectors = Json.parse(Manifest.readText(new File(path)), path);
    }

    private static byte[] bytes(Json list) {
        List<Json> items = list.items();
        byte[] out = new byte[items.size()];
        for (int i = 0; i < out.length; i++) {
            out[i] = (byte) items.get(i).asInt();
        }
        return out;
    }

    @Test
    public void bilinearMatchesTheToolkitBitForBit() {
        int checked = 0;
        for (Json c : vectors.get("bilinear").items()) {
            int h = c.get("h").asInt();
            int w = c.get("w").asInt();
            int ch = c.get("c").asInt();
            int scale = c.get("scale").asInt();
            float ox = Float.intBitsToFloat(c.get("offset_bits").at(0).asInt());
            float oy = Float.intBitsToFloat(c.get("offset_bits").at(1).asInt());
            List<Json> half = c.get("lr_half").items();
            byte[] data = new byte[half.size() * 2];
            for (int i = 0; i < half.size(); i++) {
                int bits = half.get(i).asInt();
                data[2 * i] = (byte) bits;
                data[2 * i + 1] = (byte) (bits >> 8);
            }
            Tensor lr = new Tensor("color", Tensor.DType.FLOAT16, new int[] {h, w, ch}, null, 0, data);
            float[] hr = Bilinear.upsample(lr, scale, ox, oy);
            List<Json> expected = c.get("hr_bits").items();
            assertEquals(expected.size(), hr.length);
            for (int i = 0; i < hr.length; i++) {
                if (Float.floatToRawIntBits(hr[i]) != expected.get(i).asInt()) {
                    throw new AssertionError(w + "x" + h + "x" + ch + " x" + scale + " offset (" + ox + ", " + oy + "): value " + i + " is "
                            + hr[i] + ", the toolkit says " + Float.intBitsToFloat(expected.get(i).asInt()));
                }
            }
            byte[] codes = Bilinear.displayCodes(lr, scale, new Manifest.JitterEntry(0, ox, oy, 0, 0));
            byte[] expectedCodes = bytes(c.get("codes"));
            for (int i = 0; i < codes.length; i++) {
                if (codes[i] != expectedCodes[i]) {
                    throw new AssertionError("display code " + i + " is " + (codes[i] & 0xFF) + ", the toolkit says " + (expectedCodes[i] & 0xFF));
                }
            }
            checked += hr.length;
        }
        assertEquals(true, checked > 10000);
    }

    @Test
    public void displayCodesMatchTheToolkit() {
        Json e = vectors.get("encode");
        List<Json> values = e.get("v_bits").items();
        List<Json> codes = e.get("codes").items();
        for (int i = 0; i < values.size(); i++) {
            float v = Float.intBitsToFloat(values.get(i).asInt());
            if (Bilinear.encodeUnorm8(v) != codes.get(i).asInt()) {
                throw new AssertionError(v + " (" + Float.toHexString(v) + ") encodes to " + Bilinear.encodeUnorm8(v) + ", the toolkit says "
                        + codes.get(i).asInt());
            }
        }
    }

    @Test
    public void compositesMatch() {
        for (Json c : vectors.get("composite").items()) {
            int w = c.get("w").asInt();
            int h = c.get("h").asInt();
            byte[] left = bytes(c.get("left"));
            byte[] right = bytes(c.get("right"));
            assertArgb(c.get("side_by_side"), Compositor.sideBySide(left, right, w, h), "side by side");
            for (Json s : c.get("splits").items()) {
                assertArgb(s.get("argb"), Compositor.split(left, right, w, h, s.get("x").asInt()), "split at " + s.get("x").asInt());
            }
        }
    }

    private static void assertArgb(Json expected, int[] actual, String what) {
        List<Json> e = expected.items();
        assertEquals(what, e.size(), actual.length);
        for (int i = 0; i < actual.length; i++) {
            if (actual[i] != (int) e.get(i).asLong()) {
                throw new AssertionError(what + ": pixel " + i + " is " + Integer.toHexString(actual[i]) + ", expected " + Long.toHexString(e.get(i).asLong()));
            }
        }
    }
}
