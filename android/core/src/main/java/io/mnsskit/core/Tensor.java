package io.mnsskit.core;

import java.io.File;
import java.io.IOException;
import java.nio.file.Files;
import java.util.Arrays;

/**
 * A named array as the bundle's golden files and the dumps store it: raw little-endian bytes in
 * C order, a dtype, a shape and, for quantized integers, a scale and zero point
 * ({@code real = scale * (q - zero_point)}).
 */
public final class Tensor {
    /** Element types of golden and dump files, named as numpy names them. */
    public enum DType {
        INT8("int8", 1, true), UINT8("uint8", 1, true), INT16("int16", 2, true), UINT16("uint16", 2, true),
        INT32("int32", 4, true), FLOAT16("float16", 2, false), FLOAT32("float32", 4, false);

        public final String id;
        public final int size;
        public final boolean integer;

        DType(String id, int size, boolean integer) {
            this.id = id;
            this.size = size;
            this.integer = integer;
        }

        public static DType of(String id) {
            for (DType d : values()) {
                if (d.id.equals(id)) {
                    return d;
                }
            }
            throw new BundleException("unknown dtype '" + id + "'");
        }
    }

    public final String name;
    public final DType dtype;
    public final int[] shape;
    /** Scale of a quantized integer tensor, or null. */
    public final Float scale;
    public final int zeroPoint;
    public final byte[] data;

    public Tensor(String name, DType dtype, int[] shape, Float scale, int zeroPoint, byte[] data) {
        long expected = count(shape) * dtype.size;
        if (data.length != expected) {
            throw new BundleException("tensor '" + name + "': " + data.length + " bytes, " + dtype.id + " "
                    + Arrays.toString(shape) + " needs " + expected);
        }
        this.name = name;
        this.dtype = dtype;
        this.shape = shape.clone();
        this.scale = scale;
        this.zeroPoint = zeroPoint;
        this.data = data;
    }

    /** Reads a raw file, checking its size against dtype and shape. */
    public static Tensor read(File file, String name, DType dtype, int[] shape, Float scale, int zeroPoint) {
        byte[] data;
        try {
            data = Files.readAllBytes(file.toPath());
        } catch (IOException e) {
            throw new BundleException(file + ": cannot read (" + e.getMessage() + ")", e);
        }
        long expected = count(shape) * dtype.size;
        if (data.length != expected) {
            throw new BundleException(file + ": " + data.length + " bytes, " + dtype.id + " " + Arrays.toString(shape)
                    + " needs " + expected);
        }
        return new Tensor(name, dtype, shape, scale, zeroPoint, data);
    }

    /** An int8 tensor from values (e.g. the unpacked NPU input). */
    public static Tensor int8(String name, int[] shape, byte[] values, Float scale, int zeroPoint) {
        return new Tensor(name, DType.INT8, shape, scale, zeroPoint, values.clone());
    }

    public static long count(int[] shape) {
        long n = 1;
        for (int d : shape) {
            if (d < 0) {
                throw new BundleException("negative dimension in shape " + Arrays.toString(shape));
            }
            n *= d;
        }
        return n;
    }

    public int count() {
        return (int) count(shape);
    }

    /** Element {@code i} of an integer tensor (signed or unsigned as its dtype says). */
    public long intAt(int i) {
        int o = i * dtype.size;
        switch (dtype) {
            case INT8: return data[o];
            case UINT8: return data[o] & 0xFF;
            case INT16: return (short) u16(o);
            case UINT16: return u16(o);
            case INT32: return u16(o) | (u16(o + 2) << 16);
            default: throw new IllegalStateException("tensor '" + name + "' is " + dtype.id + ", not an integer type");
        }
    }

    /** Element {@code i} as a float: the stored float, or the integer itself (not dequantized). */
    public float floatAt(int i) {
        int o = i * dtype.size;
        switch (dtype) {
            case FLOAT16: return halfToFloat(u16(o));
            case FLOAT32: return Float.intBitsToFloat((int) (u16(o) | (u16(o + 2) << 16)));
            default: return intAt(i);
        }
    }

    /** Element {@code i} as a real value: dequantized when the tensor has a scale. */
    public double realAt(int i) {
        if (dtype.integer && scale != null) {
            return Int8Quant.dequantize((int) intAt(i), scale, zeroPoint);
        }
        return floatAt(i);
    }

    public String describe() {
        return name + " " + dtype.id + " " + Arrays.toString(shape) + (scale == null ? "" : " scale " + scale + " zp " + zeroPoint);
    }

    private long u16(int o) {
        return (data[o] & 0xFF) | ((data[o + 1] & 0xFF) << 8);
    }

    /** IEEE binary16 bits to float (exact: every half is a float). */
    public static float halfToFloat(long bits) {
        int h = (int) bits & 0xFFFF;
        int sign = (h & 0x8000) << 16;
        int exponent = (h >>> 10) & 0x1F;
        int mantissa = h & 0x3FF;
        if (exponent == 0x1F) {
            return Float.intBitsToFloat(sign | 0x7F800000 | (mantissa << 13));
        }
        if (exponent == 0) {
            float magnitude = mantissa * 0x1p-24f; // subnormal half: exact in float
            return sign != 0 ? -magnitude : magnitude;
        }
        return Float.intBitsToFloat(sign | ((exponent + 112) << 23) | (mantissa << 13));
    }
}
