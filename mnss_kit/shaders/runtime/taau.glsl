// TAAU accumulation (the ntaau family): reprojection, the nearby jittered samples, the
// jitter-aware bicubic frame, the clamp box and the steered blend.  Binding-free; mirrors
// mnss_kit/ops/taau.py (the definition; mnss_kit/model/taau.py is its torch form).

#include "warp.glsl"

vec3 rgb_to_ycocg(vec3 c) {
    return vec3(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b, -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}

vec3 ycocg_to_rgb(vec3 c) {
    return vec3(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z);
}

// The history (rgb) and its weight (a) bilinearly fetched where HR texel `hr`'s surface was.
vec4 warped_history_at(highp sampler2D history, highp sampler2D motion, ivec2 hr, int scale) {
    return bilinear_sample(history, warp_source(motion, hr, scale));
}

// ops.taau.CUBIC_A: the bicubic kernel's free parameter.
const float CUBIC_A = -0.75;

// Weights of the taps at -1, 0, 1, 2 for fractional position t (ops.taau.cubic_weights).
vec4 cubic_weights(float t) {
    vec4 d = vec4(t + 1.0, t, 1.0 - t, 2.0 - t);
    vec4 near = ((CUBIC_A + 2.0) * d - (CUBIC_A + 3.0)) * d * d + 1.0;
    vec4 far = ((CUBIC_A * d - 5.0 * CUBIC_A) * d + 8.0 * CUBIC_A) * d - 4.0 * CUBIC_A;
    return mix(far, near, vec4(lessThanEqual(d, vec4(1.0))));
}

// Bicubic (CUBIC_A) of the LR colour at `u` in LR pixels from the first texel centre, 4x4 taps
// clamped to the edge, YCoCg: the spatial fallback of every TAAU at every scale.
vec3 bicubic_lr_at(highp sampler2D color, vec2 u) {
    ivec2 size = textureSize(color, 0);
    vec2 base = floor(u);
    vec4 wx = cubic_weights(u.x - base.x);
    vec4 wy = cubic_weights(u.y - base.y);
    ivec2 b = ivec2(base);
    vec3 acc = vec3(0.0);
    for (int a = 0; a < 4; a++) {
        int row = clamp(b.y + a - 1, 0, size.y - 1);
        for (int c = 0; c < 4; c++) {
            int col = clamp(b.x + c - 1, 0, size.x - 1);
            acc += (wy[a] * wx[c]) * colour_texel(color, ivec2(col, row));
        }
    }
    return rgb_to_ycocg(acc);
}

// Jitter-aware bicubic of the LR colour at HR texel `hr` (ops.taau.bicubic_upsample), YCoCg.
vec3 spatial_at(highp sampler2D color, ivec2 hr, vec2 jitter, int scale) {
    return bicubic_lr_at(color, (vec2(hr) + 0.5) / float(scale) - jitter - 0.5);
}

// The Gaussian-weighted mean of the 3x3 LR samples around HR texel `hr` (YCoCg, rgb) and their
// total weight (a) (ops.taau.nearby_samples); the clamp box of the same neighbourhood.
struct Neighbourhood {
    vec4 samples;
    vec3 lo;
    vec3 hi;
};

Neighbourhood neighbourhood_at(highp sampler2D color, ivec2 hr, vec2 jitter, int scale, float sigma) {
    ivec2 size = textureSize(color, 0);
    ivec2 lr = hr / scale;
    float s = float(scale);
    vec2 centre = vec2(hr) + 0.5;
    Neighbourhood n;
    vec3 acc = vec3(0.0);
    float total = 0.0;
    n.lo = vec3(1e30);
    n.hi = vec3(-1e30);
    for (int dy = -1; dy <= 1; dy++) {
        float ey = ((float(lr.y) + 0.5 + float(dy) + jitter.y) * s - centre.y) / sigma;
        float wy = exp(-0.5 * ey * ey);
        for (int dx = -1; dx <= 1; dx++) {
            float ex = ((float(lr.x) + 0.5 + float(dx) + jitter.x) * s - centre.x) / sigma;
            float w = wy * exp(-0.5 * ex * ex);
            vec3 c = rgb_to_ycocg(colour_texel(color, clamp(lr + ivec2(dx, dy), ivec2(0), size - 1)));
            acc += w * c;
            total += w;
            n.lo = min(n.lo, c);
            n.hi = max(n.hi, c);
        }
    }
    n.samples = vec4(acc / max(total, 1e-12), total);
    return n;
}

// The steering of one HR pixel from the net's first six raw values (ops.taau.steer_from_raw).
struct Steer {
    float history_gain;
    float sample_gain;
    float box_widen;
    vec3 correction;
};

// The YCoCg correction from raw values 3-5, and a display filter weight from raw value 6 or 7.
vec3 correction_from_raw(vec3 raw, float correction_bound) {
    return correction_bound * vec3(tanh(raw.x), tanh(raw.y), tanh(raw.z));
}

float filter_weight_from_raw(float raw, float filter_bound) {
    return filter_bound * tanh(raw);
}

// f (1 - f) per axis for the fractional part f of the HR motion `m` (ops.taau.resample_spread).
vec2 resample_spread(vec2 m) {
    vec2 f = m - floor(m);
    return f * (1.0 - f);
}

// The display filter's weight scale at HR texel `hr` (ops.taau.filter_gain): it fades with the
// history's resample spread; the motion is read only when it does.
float filter_gain(highp sampler2D motion, ivec2 hr, int scale, float falloff) {
    if (falloff <= 0.0) {
        return 1.0;
    }
    vec2 spread = resample_spread(upsampled_motion_at(motion, hr, scale));
    return exp(-falloff * (spread.x + spread.y));
}

// The least history gain where the HR motion is `hr_motion` (ops.taau.history_floor), still_motion_px > 0.
float history_floor_of(vec2 hr_motion, float history_gain_min, float still_motion_px) {
    return history_gain_min * clamp(1.0 - length(hr_motion) / still_motion_px, 0.0, 1.0);
}

// The least history gain at HR texel `hr` (ops.taau.history_floor); the motion is read only when
// the floor fades with it.
float history_floor(highp sampler2D motion, ivec2 hr, int scale, float history_gain_min, float still_motion_px) {
    if (still_motion_px <= 0.0) {
        return history_gain_min;
    }
    return history_floor_of(upsampled_motion_at(motion, hr, scale), history_gain_min, still_motion_px);
}

Steer steer_from_raw(float raw[6], float correction_bound, float history_gain_min, float box_bound) {
    Steer s;
    s.history_gain = max(2.0 / (1.0 + exp(-raw[0])), history_gain_min);
    s.sample_gain = 2.0 / (1.0 + exp(-raw[1]));
    float t = tanh(raw[2]);
    s.box_widen = (t > 0.0 ? box_bound : 0.5) * t;  // narrowing stops at the box's centre (ops.taau.box_widening)
    s.correction = correction_from_raw(vec3(raw[3], raw[4], raw[5]), correction_bound);
    return s;
}

// The displayed RGB (ops.taau.display): the blend (RGB), after the display filter if any, plus the
// YCoCg correction, clamped.
vec3 corrected(vec3 blend_rgb, vec3 correction) {
    return clamp(blend_rgb + ycocg_to_rgb(correction), 0.0, 1.0);
}

// One steered TAAU step (ops.taau.blend).  `history` is the reprojected YCoCg history (rgb) and
// its weight (a).  The correction goes to the display only: the next history is the blend before it.
struct Blended {
    vec3 display;  // RGB in [0, 1], without the display filter
    vec4 history;  // the uncorrected blend, RGB in [0, 1] (rgb), and the accumulated weight (a)
};

Blended steered_blend(Neighbourhood n, vec3 spatial, vec4 history, Steer s, float prior_weight, float max_weight) {
    vec3 span = n.hi - n.lo;
    vec3 clamped = min(max(history.rgb, n.lo - s.box_widen * span), n.hi + s.box_widen * span);
    float weight = history.a * s.history_gain;
    float current = n.samples.a * s.sample_gain;
    vec3 mixed = (weight * clamped + current * n.samples.rgb + prior_weight * spatial) / (weight + current + prior_weight);
    Blended b;
    b.history = vec4(clamp(ycocg_to_rgb(mixed), 0.0, 1.0), min(weight + current, max_weight));
    b.display = corrected(b.history.rgb, s.correction);
    return b;
}

// The display filter at HR texel `hr` of the blend `image` (rgb; ops.taau.display_filter): the
// texel plus `axis` times each axis neighbour's difference to it and `diagonal` times each
// diagonal one's, clamp-to-edge.
vec3 display_filter_at(highp sampler2D image, ivec2 hr, float axis, float diagonal) {
    ivec2 last = textureSize(image, 0) - 1;
    vec3 centre = texelFetch(image, hr, 0).rgb;
    vec3 axial = -4.0 * centre;
    vec3 diagonals = -4.0 * centre;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            vec3 c = texelFetch(image, clamp(hr + ivec2(dx, dy), ivec2(0), last), 0).rgb;
            if (dx != 0 && dy != 0) {
                diagonals += c;
            } else if (dx != 0 || dy != 0) {
                axial += c;
            }
        }
    }
    return centre + axis * axial + diagonal * diagonals;
}
