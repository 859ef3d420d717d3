// int8 quantize / dequantize at the GPU <-> NPU boundary, bit for bit as mnss_kit.ops.int8.quantize
// (quantize, dequantize) for every numerics profile.  Binding-free.
//
// quantize: q = clamp(round(x / scale) + zero_point, -128, 127), where x / scale is a correctly
// rounded float32 division (or x * float32(1 / scale), a correctly rounded product, in profiles
// with quantize_reciprocal), and round() breaks ties as the profile says.  GLSL division is only
// accurate to 2.5 ULP and a compiler may fuse a product into an FMA, so both are done here on the
// integer significands: exact, then rounded once to nearest-even, as IEEE float32 does.
// dequantize: float32(scale * (q - zero_point)), the same exact product.
//
// Float32 subnormal results are flushed to zero; they only occur for values far below one
// quantization step, which round to 0 either way.

const int NPU_CHANNELS = 3;  // the NPU input and output are (1, H, W, 3)

const int ROUND_AWAY_FROM_ZERO = 0;  // C round(): ties away from zero
const int ROUND_HALF_EVEN = 1;       // rint(): ties to even
const int ROUND_HALF_UP = 2;         // floor(x + 0.5): ties toward +infinity

// A finite float32 as (-1)^negative * m * 2^e with m in [2^23, 2^24), or m = 0 for zero.
struct Unpacked {
    bool negative;
    uint m;
    int e;
};

Unpacked unpack_float(float x) {
    uint bits = floatBitsToUint(x);
    Unpacked u;
    u.negative = (bits >> 31) != 0u;
    uint biased = (bits >> 23) & 0xFFu;
    u.m = bits & 0x7FFFFFu;
    u.e = int(biased) - 150;
    if (biased != 0u) {
        u.m |= 0x800000u;
    } else if (u.m != 0u) {  // subnormal: normalise
        int shift = 23 - findMSB(u.m);
        u.m <<= uint(shift);
        u.e = -149 - shift;
    }
    return u;
}

float pack_float(Unpacked v) {
    int biased = v.e + 150;
    uint sign = v.negative ? 0x80000000u : 0u;
    if (v.m == 0u || biased <= 0) {
        return uintBitsToFloat(sign);
    }
    if (biased >= 255) {
        return uintBitsToFloat(sign | 0x7F800000u);
    }
    return uintBitsToFloat(sign | (uint(biased) << 23) | (v.m & 0x7FFFFFu));
}

// Round `kept` (the significand cut to 24 bits) to nearest-even given the cut-off part
// compared with half an ULP: rest_vs_half < 0, == 0, > 0.
Unpacked round_significand(bool negative, uint kept, int e, int rest_vs_half) {
    if (rest_vs_half > 0 || (rest_vs_half == 0 && (kept & 1u) == 1u)) {
        kept += 1u;
        if (kept == 0x1000000u) {
            kept = 0x800000u;
            e += 1;
        }
    }
    return Unpacked(negative, kept, e);
}

int compare_u(uint a, uint b) {
    return a > b ? 1 : (a == b ? 0 : -1);
}

// float32(a * b), rounded to nearest-even.
Unpacked mul_rne(Unpacked a, Unpacked b) {
    bool negative = a.negative != b.negative;
    if (a.m == 0u || b.m == 0u) {
        return Unpacked(negative, 0u, 0);
    }
    uint hi, lo;
    umulExtended(a.m, b.m, hi, lo);      // exact product in [2^46, 2^48)
    int k = hi >= 0x8000u ? 24 : 23;     // bits to drop so 24 remain
    uint kept = (hi << uint(32 - k)) | (lo >> uint(k));
    uint rest = lo & ((1u << uint(k)) - 1u);
    return round_significand(negative, kept, a.e + b.e + k, compare_u(rest, 1u << uint(k - 1)));
}

// float32(a / b), rounded to nearest-even (b != 0).
Unpacked div_rne(Unpacked a, Unpacked b) {
    bool negative = a.negative != b.negative;
    if (a.m == 0u) {
        return Unpacked(negative, 0u, 0);
    }
    uint r = a.m;
    int e = a.e - b.e - 23;
    if (r < b.m) {  // so that the quotient's first bit is 1
        r <<= 1u;
        e -= 1;
    }
    uint q = 0u;
    for (int i = 0; i < 24; i++) {  // restoring long division, one quotient bit per step
        q <<= 1u;
        if (r >= b.m) {
            r -= b.m;
            q |= 1u;
        }
        r <<= 1u;  // r < 2^25
    }
    return round_significand(negative, q, e, compare_u(r, b.m));  // r is twice the remainder
}

// The integer nearest to `v` under `rounding`, saturated to +-2^24.
int round_to_int(Unpacked v, int rounding) {
    if (v.m == 0u || v.e < -31) {
        return 0;  // below 2^-8: rounds to 0
    }
    uint magnitude;
    if (v.e >= 0) {
        magnitude = 0x1000000u;
    } else {
        uint n = uint(-v.e);
        uint kept = v.m >> n;
        uint rest = v.m & ((1u << n) - 1u);
        uint half_way = 1u << (n - 1u);
        bool tie_up = rounding == ROUND_AWAY_FROM_ZERO || (rounding == ROUND_HALF_EVEN && (kept & 1u) == 1u) ||
                      (rounding == ROUND_HALF_UP && !v.negative);
        magnitude = kept + ((rest > half_way || (rest == half_way && tie_up)) ? 1u : 0u);
    }
    return v.negative ? -int(magnitude) : int(magnitude);
}

struct QuantParams {
    float scale;
    float reciprocal;     // float32(1 / scale), computed on the host
    bool use_reciprocal;  // the profile multiplies by the reciprocal instead of dividing
    int rounding;         // ROUND_*
    int zero_point;
};

int quantize_int8(float x, QuantParams p) {
    uint bits = floatBitsToUint(x);
    if ((bits & 0x7F800000u) == 0x7F800000u) {  // inf saturates; NaN maps to the zero point
        return (bits & 0x7FFFFFu) != 0u ? p.zero_point : ((bits >> 31) != 0u ? -128 : 127);
    }
    Unpacked u = unpack_float(x);
    Unpacked scaled = p.use_reciprocal ? mul_rne(u, unpack_float(p.reciprocal)) : div_rne(u, unpack_float(p.scale));
    return clamp(round_to_int(scaled, p.rounding) + p.zero_point, -128, 127);
}

float dequantize_int8(int q, float scale, int zero_point) {
    return pack_float(mul_rne(unpack_float(float(q - zero_point)), unpack_float(scale)));
}

// Byte k (0..3, little-endian) of a packed word, as a signed int8 value.
int int8_of_word(uint word, int k) {
    int v = int((word >> uint(8 * k)) & 0xFFu);
    return v >= 128 ? v - 256 : v;
}

uint word_of_int8(int v, int k) {
    return (uint(v + 256) & 0xFFu) << uint(8 * k);
}
