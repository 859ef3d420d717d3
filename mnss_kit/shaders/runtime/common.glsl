// Helpers shared by the runtime passes (binding-free; included by the algorithm files).
//
// Conventions of mnss_kit/ops/conventions.py: pixel centres at +0.5, clamp-to-edge on texel
// indices, motion in pixels pointing to the previous frame.  Arithmetic is highp float32 in the
// order of the numpy references (mnss_kit/ops/resample.py); textures are read with texelFetch
// only, because hardware filtering precision is implementation-defined.

// The four texels and weights of a bilinear sample at pixel coordinate `p` of an image of
// `size` texels (ops.resample.bilinear_sample).
struct BilinearTaps {
    ivec2 lo;    // top-left texel, clamped to the image
    ivec2 hi;    // bottom-right texel, clamped to the image
    vec2 frac;   // weight of the right / lower texel, in [0, 1)
};

BilinearTaps bilinear_taps(vec2 p, ivec2 size) {
    vec2 f = p - 0.5;
    vec2 f0 = floor(f);
    BilinearTaps t;
    t.frac = f - f0;
    // Clamping before the int conversion keeps far off-screen samples defined; the texel
    // indices are the same as clamping after it.
    ivec2 i0 = ivec2(clamp(f0, vec2(-1.0), vec2(size)));
    t.lo = clamp(i0, ivec2(0), size - 1);
    t.hi = clamp(i0 + 1, ivec2(0), size - 1);
    return t;
}

// Blend of the texel values at (lo.x, lo.y), (hi.x, lo.y), (lo.x, hi.y), (hi.x, hi.y).
vec4 bilinear_blend(vec4 a, vec4 b, vec4 c, vec4 d, vec2 frac) {
    vec4 top = a * (1.0 - frac.x) + b * frac.x;
    vec4 bottom = c * (1.0 - frac.x) + d * frac.x;
    return top * (1.0 - frac.y) + bottom * frac.y;
}

vec4 bilinear_sample(highp sampler2D image, vec2 p) {
    BilinearTaps t = bilinear_taps(p, textureSize(image, 0));
    return bilinear_blend(texelFetch(image, t.lo, 0), texelFetch(image, ivec2(t.hi.x, t.lo.y), 0),
                          texelFetch(image, ivec2(t.lo.x, t.hi.y), 0), texelFetch(image, t.hi, 0), t.frac);
}

// True at the HR texels this frame sampled: sub-pixel (dx, dy) of every s x s tile
// (ops.subpixel; the host computes `subpixel` with ops.jitter.subpixel_index).
bool is_sampled(ivec2 hr, ivec2 subpixel, int scale) {
    return hr.x % scale == subpixel.x && hr.y % scale == subpixel.y;
}

// ops.subpixel.jittered_upsample at HR texel `hr`: the LR sample itself where it was taken,
// elsewhere bilinear at the LR position the HR pixel centre maps to, shifted by the jitter.
vec4 jittered_upsample_at(highp sampler2D lr, ivec2 hr, vec2 jitter, ivec2 subpixel, int scale) {
    if (is_sampled(hr, subpixel, scale)) {
        return texelFetch(lr, hr / scale, 0);
    }
    return bilinear_sample(lr, (vec2(hr) + 0.5) / float(scale) - jitter);
}

// IEEE binary16 bits of `x`, rounded to nearest, ties to even (numpy's float32 -> float16),
// computed on the integer bits.  GPUs convert on image stores with an implementation-defined
// rounding (Mesa llvmpipe truncates), so every fp16 store goes through round_to_half.
uint half_bits(float x) {
    uint bits = floatBitsToUint(x);
    uint sign = (bits >> 16) & 0x8000u;
    int exponent = int((bits >> 23) & 0xFFu) - 112;  // rebias 127 -> 15
    uint mantissa = bits & 0x7FFFFFu;
    if (exponent == 143) {  // inf or NaN (biased 255)
        return sign | 0x7C00u | (mantissa != 0u ? 0x200u : 0u);
    }
    if (exponent >= 31) {
        return sign | 0x7C00u;  // overflow to infinity
    }
    uint shift = 13u;
    uint base = uint(max(exponent, 0)) << 10;
    if (exponent <= 0) {  // subnormal half (or zero)
        if (exponent < -10) {
            return sign;
        }
        mantissa |= 0x800000u;
        shift = uint(14 - exponent);
    }
    uint kept = mantissa >> shift;
    uint rest = mantissa & ((1u << shift) - 1u);
    uint half_way = 1u << (shift - 1u);
    if (rest > half_way || (rest == half_way && (kept & 1u) == 1u)) {
        kept += 1u;  // a carry into the exponent field is the correct next value
    }
    return sign | (base + kept);
}

float round_to_half(float x) {
    return unpackHalf2x16(half_bits(x)).x;
}

vec4 round_to_half(vec4 v) {
    return vec4(round_to_half(v.x), round_to_half(v.y), round_to_half(v.z), round_to_half(v.w));
}

// Input sanitization (ops.sanitize): every read of an engine input (colour, depth, motion, G-buffers) goes
// through these, so a NaN or Inf in one frame cannot reach the history.  Identity on finite values
// of the input formats.  NaN and Inf are told apart on the bits: drivers may fold isnan / isinf
// and x != x away under fast-math, integer tests they keep.
const float COLOUR_MAX = 65504.0;  // ops.sanitize.COLOUR_MAX, the largest finite fp16
const float FAR_DEPTH = 1.0;       // ops.sanitize.FAR_DEPTH

bool is_not_finite(float x) {
    return (floatBitsToUint(x) & 0x7F800000u) == 0x7F800000u;
}

bool is_nan_bits(float x) {
    uint bits = floatBitsToUint(x);
    return (bits & 0x7F800000u) == 0x7F800000u && (bits & 0x007FFFFFu) != 0u;
}

float sanitize_colour(float x) {
    if (is_nan_bits(x)) return 0.0;
    if (is_not_finite(x)) return (floatBitsToUint(x) >> 31) != 0u ? -COLOUR_MAX : COLOUR_MAX;
    return clamp(x, -COLOUR_MAX, COLOUR_MAX);
}

vec3 sanitize_colour(vec3 c) {
    return vec3(sanitize_colour(c.x), sanitize_colour(c.y), sanitize_colour(c.z));
}

// A material G-buffer value (F_beta, emissive, normal, albedo: ops.sanitize.sanitize_gbuffer):
// NaN -> 0, +-Inf -> +-COLOUR_MAX, finite values unchanged (an fp16 texel holds none beyond it).
float sanitize_gbuffer(float x) {
    if (is_nan_bits(x)) return 0.0;
    if (is_not_finite(x)) return (floatBitsToUint(x) >> 31) != 0u ? -COLOUR_MAX : COLOUR_MAX;
    return x;
}

vec3 sanitize_gbuffer(vec3 g) {
    return vec3(sanitize_gbuffer(g.x), sanitize_gbuffer(g.y), sanitize_gbuffer(g.z));
}

float sanitize_depth(float d) {
    return is_not_finite(d) ? FAR_DEPTH : d;
}

float sanitize_motion(float m) {
    return is_not_finite(m) ? 0.0 : m;
}

vec2 sanitize_motion(vec2 m) {
    return vec2(sanitize_motion(m.x), sanitize_motion(m.y));
}

// A colour texel with NaN or +-Inf in r, g or b (ops.sanitize.colour_not_finite): its sanitized
// value is a guess, not a sample.  MNSS keeps the history there: inpainting weight 0, and the AA
// pass writes NO_SAMPLE, which insert + pack does not insert.
const float NO_SAMPLE = -1.0;  // ops.sanitize.NO_SAMPLE

bool colour_not_finite(vec3 c) {
    return is_not_finite(c.x) || is_not_finite(c.y) || is_not_finite(c.z);
}

// The sanitized LR colour (rgb), depth and motion at texel `p`.
vec3 colour_texel(highp sampler2D color, ivec2 p) {
    return sanitize_colour(texelFetch(color, p, 0).rgb);
}

float depth_texel(highp sampler2D depth, ivec2 p) {
    return sanitize_depth(texelFetch(depth, p, 0).x);
}

vec2 motion_texel(highp sampler2D motion, ivec2 p) {
    return sanitize_motion(texelFetch(motion, p, 0).xy);
}

// bilinear_sample of the sanitized motion (each texel sanitized before the blend).
vec2 motion_bilinear(highp sampler2D motion, vec2 p) {
    BilinearTaps t = bilinear_taps(p, textureSize(motion, 0));
    vec4 a = vec4(motion_texel(motion, t.lo), 0.0, 0.0);
    vec4 b = vec4(motion_texel(motion, ivec2(t.hi.x, t.lo.y)), 0.0, 0.0);
    vec4 c = vec4(motion_texel(motion, ivec2(t.lo.x, t.hi.y)), 0.0, 0.0);
    vec4 d = vec4(motion_texel(motion, t.hi), 0.0, 0.0);
    return bilinear_blend(a, b, c, d, t.frac).xy;
}

vec4 sanitize_colour(vec4 c) {
    return vec4(sanitize_colour(c.rgb), sanitize_colour(c.a));
}

// jittered_upsample_at of an engine input, each texel sanitized before the blend: `kind`
// INPUT_COLOUR (rgb) or INPUT_DEPTH (x).
const int INPUT_COLOUR = 0;
const int INPUT_DEPTH = 1;

vec4 input_texel(highp sampler2D lr, ivec2 p, int kind) {
    vec4 v = texelFetch(lr, p, 0);
    return kind == INPUT_DEPTH ? vec4(sanitize_depth(v.x), v.yzw) : vec4(sanitize_colour(v.rgb), v.a);
}

vec4 jittered_upsample_input_at(highp sampler2D lr, ivec2 hr, vec2 jitter, ivec2 subpixel, int scale, int kind) {
    if (is_sampled(hr, subpixel, scale)) {
        return input_texel(lr, hr / scale, kind);
    }
    BilinearTaps t = bilinear_taps((vec2(hr) + 0.5) / float(scale) - jitter, textureSize(lr, 0));
    return bilinear_blend(input_texel(lr, t.lo, kind), input_texel(lr, ivec2(t.hi.x, t.lo.y), kind),
                          input_texel(lr, ivec2(t.lo.x, t.hi.y), kind), input_texel(lr, t.hi, kind), t.frac);
}
