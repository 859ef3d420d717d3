package io.mnsskit.core;

import static org.junit.Assert.assertArrayEquals;
import static org.junit.Assert.assertEquals;
import static org.junit.Assert.assertThrows;

import io.mnsskit.core.Int8Quant.Params;
import io.mnsskit.core.Int8Quant.Rounding;
import org.junit.Test;

public class Int8QuantTest {
    private static Params params(Rounding rounding, int zeroPoint) {
        return Params.of(0.5f, zeroPoint, false, rounding); // x / 0.5 is exact: ties land exactly on .5
    }

    @Test
    public void tiesFollowTheProfilesRule() {
        float[] x = {0.25f, 0.75f, -0.25f, -0.75f, 1.25f};      // scaled: 0.5, 1.5, -0.5, -1.5, 2.5
        assertArrayEquals(new byte[] {1, 2, -1, -2, 3}, Int8Quant.quantizeAll(x, params(Rounding.AWAY_FROM_ZERO, 0)));
        assertArrayEquals(new byte[] {0, 2, 0, -2, 2}, Int8Quant.quantizeAll(x, params(Rounding.HALF_EVEN, 0)));
        assertArrayEquals(new byte[] {1, 2, 0, -1, 3}, Int8Quant.quantizeAll(x, params(Rounding.HALF_UP, 0)));
    }

    @Test
    public void saturatesAndMapsNanToTheZeroPoint() {
        Params p = params(Rounding.HALF_EVEN, -128);
        assertEquals(127, Int8Quant.quantize(1e30f, p));
        assertEquals(127, Int8Quant.quantize(Float.POSITIVE_INFINITY, p));
        assertEquals(-128, Int8Quant.quantize(-1.0f, p));
        assertEquals(-128, Int8Quant.quantize(Float.NEGATIVE_INFINITY, p));
        assertEquals(-128, Int8Quant.quantize(Float.NaN, p));
        assertEquals(5, Int8Quant.quantize(Float.NaN, params(Rounding.HALF_EVEN, 5)));
    }

    @Test
    public void reciprocalAndDivisionRoundDifferentlyNearTies() {
        // scale float32(0.0123): x / scale and x * float32(1 / scale) fall on either side of 80.5.
        float s = 0x1.930bep-7f;
        float x = 0x1.faf4f0p-1f;
        assertEquals(80 - 128, Int8Quant.quantize(x, Params.of(s, -128, false, Rounding.HALF_EVEN)));
        assertEquals(81 - 128, Int8Quant.quantize(x, Params.of(s, -128, true, Rounding.HALF_EVEN)));
        assertEquals(1.0f / s, Params.of(s, 0, true, Rounding.HALF_EVEN).reciprocal, 0);
    }

    @Test
    public void dequantizeIsOneFloat32Product() {
        float s = 0.0123f;
        assertEquals((float) (5 - (-3)) * s, Int8Quant.dequantize(5, s, -3), 0);
        assertEquals(0.0f, Int8Quant.dequantize(7, s, 7), 0);
    }

    @Test
    public void packIsLittleEndianWithAZeroTail() {
        byte[] values = {1, -1, 2, -128, 127, 3};
        int[] words = Int8Quant.pack(values);
        assertEquals(2, words.length);
        assertEquals(0x80_02_FF_01, words[0]);
        assertEquals(0x00_00_03_7F, words[1]);
        assertArrayEquals(values, Int8Quant.unpack(words, values.length));
        assertThrows(IllegalArgumentException.class, () -> Int8Quant.unpack(words, 9));
    }

    @Test
    public void packRoundTripsEveryByteValue() {
        byte[] all = new byte[256 + 3];
        for (int i = 0; i < all.length; i++) {
            all[i] = (byte) (i * 7 + 3);
        }
        assertArrayEquals(all, Int8Quant.unpack(Int8Quant.pack(all), all.length));
    }

    @Test
    public void roundingCodesMatchTheShaders() {
        assertEquals(Rounding.AWAY_FROM_ZERO, Rounding.fromCode(0));
        assertEquals(Rounding.HALF_EVEN, Rounding.fromCode(1));
        assertEquals(Rounding.HALF_UP, Rounding.fromCode(2));
        assertThrows(BundleException.class, () -> Rounding.fromCode(3));
        assertThrows(BundleException.class, () -> Params.of(0f, 0, false, Rounding.HALF_EVEN));
    }
}
