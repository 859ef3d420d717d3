package io.mnsskit.core;

import static org.junit.Assert.assertEquals;
import static org.junit.Assume.assumeTrue;

import io.mnsskit.core.Int8Quant.Params;
import io.mnsskit.core.Int8Quant.Rounding;
import java.io.File;
import java.util.List;
import org.junit.BeforeClass;
import org.junit.Test;

/**
 * Golden vectors from the Python toolkit ({@code mnss_kit.ops.int8}): quantize under every
 * numerics profile, dequantize and the NHWC word packing, compared bit for bit.  The vectors
 * file is written by {@code tests/android/test_quant_vectors.py} and named by the system
 * property {@code mnss.quantVectors}; without it the test is skipped.
 *
 * <pre>
 * {"quantize":   [{"profile", "u_q_scale_bits", "u_q_reciprocal_bits", "u_q_use_reciprocal", "u_q_rounding",
 *                  "u_q_zero_point", "x_bits": [...], "q": [...]}, ...],
 *  "dequantize": [{"scale_bits", "zero_point", "q": [...], "r_bits": [...]}, ...],
 *  "pack":       [{"values": [...], "words": [...]}, ...]}
 * </pre>
 * Floats travel as their IEEE bit patterns so no decimal conversion stands between the sides.
 */
public class QuantVectorsTest {
    private static Json vectors;

    @BeforeClass
    public static void load() {
        String path = System.getProperty("mnss.quantVectors");
        assumeTrue("set -Dmnss.quantVectors=FILE (tests/android/test_quant_vectors.py writes it)", path != null);
        vectors = Json.parse(Manifest.readText(new File(path)), path);
    }

    @Test
    public void quantizeMatchesEveryProfileBitForBit() {
        int checked = 0;
        for (Json c : vectors.get("quantize").items()) {
            Params p = new Params(Float.intBitsToFloat(c.get("u_q_scale_bits").asInt()),
                    Float.intBitsToFloat(c.get("u_q_reciprocal_bits").asInt()), c.get("u_q_use_reciprocal").asInt() != 0,
                    Rounding.fromCode(c.get("u_q_rounding").asInt()), c.get("u_q_zero_point").asInt());
            List<Json> xs = c.get("x_bits").items();
            List<Json> qs = c.get("q").items();
            for (int i = 0; i < xs.size(); i++) {
                float x = Float.intBitsToFloat(xs.get(i).asInt());
                int expected = qs.get(i).asInt();
                int actual = Int8Quant.quantize(x, p);
                if (actual != expected) {
                    throw new AssertionError(c.get("profile").asString() + " scale " + p.scale + " zp " + p.zeroPoint + ": x = "
                            + x + " (" + Float.toHexString(x) + ") quantizes to " + actual + ", the toolkit says " + expected);
                }
                checked++;
            }
        }
        assertEquals(true, checked > 1000);
    }

    @Test
    public void dequantizeMatchesBitForBit() {
        for (Json c : vectors.get("dequantize").items()) {
            float scale = Float.intBitsToFloat(c.get("scale_bits").asInt());
            int zp = c.get("zero_point").asInt();
            List<Json> qs = c.get("q").items();
            List<Json> rs = c.get("r_bits").items();
            for (int i = 0; i < qs.size(); i++) {
                int q = qs.get(i).asInt();
                assertEquals("q " + q + " scale " + scale + " zp " + zp, rs.get(i).asInt(),
                        Float.floatToRawIntBits(Int8Quant.dequantize(q, scale, zp)));
            }
        }
    }

    @Test
    public void packMatchesTheBufferLayout() {
        for (Json c : vectors.get("pack").items()) {
            List<Json> vs = c.get("values").items();
            byte[] values = new byte[vs.size()];
            for (int i = 0; i < values.length; i++) {
                values[i] = (byte) vs.get(i).asInt();
            }
            int[] words = Int8Quant.pack(values);
            List<Json> expected = c.get("words").items();
            assertEquals(expected.size(), words.length);
            for (int i = 0; i < words.length; i++) {
                assertEquals("word " + i, expected.get(i).asLong(), words[i] & 0xFFFFFFFFL);
            }
            assertEquals(java.util.Arrays.toString(values), java.util.Arrays.toString(Int8Quant.unpack(words, values.length)));
        }
    }
}
