// TAAU steered at LR (the ntaau_lr family): the evidence gathered at LR (depth change, motion
// spread, trust), the steering mapped from LR values upsampled to HR, and the blend with a spatial
// fallback.  Binding-free; mirrors mnss_kit/ops/taau_lr.py (the definition; the torch form is
// mnss_kit/model/ntaau_lr/net.py) and ops.taau.blend.

#include "taau.glsl"

const float DEPTH_FLOOR = 1e-4;  // ops.taau_lr.DEPTH_FLOOR
const float SPREAD_CAP = 4.0;    // ops.taau_lr.SPREAD_CAP

// The nearest (smallest) of the 3x3 depths around LR texel `p`, edges repeated (ops.taau_lr.nearest_depth).
float nearest_depth_at(highp sampler2D depth, ivec2 p) {
    ivec2 last = textureSize(depth, 0) - 1;
    float nearest = 1e30;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            nearest = min(nearest, depth_texel(depth, clamp(p + ivec2(dx, dy), ivec2(0), last)));
        }
    }
    return nearest;
}

// The last frame's nearest depth fetched bilinearly where LR texel `p` was (motion `m`, LR pixels).
float reprojected_nearest_depth(highp sampler2D previous, ivec2 p, vec2 m) {
    BilinearTaps t = bilinear_taps(vec2(p) + 0.5 + m, textureSize(previous, 0));
    float a = nearest_depth_at(previous, t.lo);
    float b = nearest_depth_at(previous, ivec2(t.hi.x, t.lo.y));
    float c = nearest_depth_at(previous, ivec2(t.lo.x, t.hi.y));
    float d = nearest_depth_at(previous, t.hi);
    return bilinear_blend(vec4(a), vec4(b), vec4(c), vec4(d), t.frac).x;
}

// Relative depth change in [-1, 1] (ops.taau_lr.depth_change): > 0 where a surface appeared.
float depth_change(float depth, float reprojected) {
    return clamp((depth - reprojected) / max(depth, DEPTH_FLOOR), -1.0, 1.0);
}

// The largest L1 motion difference to one of the 8 neighbours of LR texel `p` (ops.taau_lr.motion_spread).
float motion_spread_at(highp sampler2D motion, ivec2 p) {
    ivec2 last = textureSize(motion, 0) - 1;
    vec2 centre = motion_texel(motion, p);
    float spread = 0.0;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            vec2 d = abs(motion_texel(motion, clamp(p + ivec2(dx, dy), ivec2(0), last)) - centre);
            spread = max(spread, d.x + d.y);
        }
    }
    return spread;
}

// History trust above TAAU's the evidence allows, in [0, 1] (ops.taau_lr.trust).
float trust_of(float change, float spread, float trust_depth, float trust_spread_px) {
    return clamp(1.0 - max(change, 0.0) / trust_depth - spread / trust_spread_px, 0.0, 1.0);
}

// The bilinear taps of the LR -> HR upsample at HR texel `hr` over an LR image of `lr_size`
// (ops.resample.upsample_bilinear: texel centres, clamp-to-edge).
BilinearTaps upsample_taps(ivec2 hr, int scale, ivec2 lr_size) {
    return bilinear_taps((vec2(hr) + 0.5) / float(scale), lr_size);
}

// -- any scale (u_scale 0: a quality mode such as 1.5x) ------------------------------------------
// HR texel X maps to LR position (X + 0.5) lr / hr per axis (the exact ratio of the two sizes,
// ops.taau); its LR texel is floor((2X + 1) lr / (2 hr)), in integers (ops.taau.nearest_index).

ivec2 lr_texel_of(ivec2 hr, ivec2 lr_size, ivec2 hr_size) {
    return ((2 * hr + 1) * lr_size) / (2 * hr_size);
}

// The first HR texel (per axis) whose LR texel is `lr` or later: ceil((2 lr hr - lr_n) / (2 lr_n)).
ivec2 first_hr_texel(ivec2 lr, ivec2 lr_size, ivec2 hr_size) {
    return (2 * lr * hr_size + lr_size - 1) / (2 * lr_size);
}

// The bilinear taps of the LR -> HR resize at HR texel `hr` (ops.scale.resize_bilinear).
BilinearTaps resize_taps(ivec2 hr, ivec2 lr_size, ivec2 hr_size) {
    return bilinear_taps((vec2(hr) + 0.5) * (vec2(lr_size) / vec2(hr_size)), lr_size);
}

// HR motion at HR texel `hr`: the LR motion resized bilinearly, times each axis's ratio (ops.taau.hr_motion_of).
vec2 resized_motion_at(highp sampler2D motion, ivec2 hr, ivec2 hr_size) {
    vec2 lr = vec2(textureSize(motion, 0));
    return motion_bilinear(motion, (vec2(hr) + 0.5) * (lr / vec2(hr_size))) * (vec2(hr_size) / lr);
}

// Jitter-aware bicubic at HR texel `hr` of an `hr_size` image (ops.taau.bicubic_upsample at any scale), YCoCg.
vec3 spatial_ratio_at(highp sampler2D color, ivec2 hr, vec2 jitter, ivec2 hr_size) {
    vec2 size = vec2(textureSize(color, 0));
    return bicubic_lr_at(color, (vec2(hr) + 0.5) * (size / vec2(hr_size)) - jitter - 0.5);
}

// ops.taau.nearby_samples and the clamp box at any scale: the 3x3 LR samples around HR texel
// `hr`'s LR texel, each at (i + 0.5 + jitter) times the per-axis ratio in HR pixels.
Neighbourhood neighbourhood_ratio_at(highp sampler2D color, ivec2 hr, vec2 jitter, ivec2 hr_size, float sigma) {
    ivec2 size = textureSize(color, 0);
    ivec2 lr = lr_texel_of(hr, size, hr_size);
    vec2 r = vec2(hr_size) / vec2(size);
    vec2 centre = vec2(hr) + 0.5;
    Neighbourhood n;
    vec3 acc = vec3(0.0);
    float total = 0.0;
    n.lo = vec3(1e30);
    n.hi = vec3(-1e30);
    for (int dy = -1; dy <= 1; dy++) {
        float ey = ((float(lr.y) + 0.5 + float(dy) + jitter.y) * r.y - centre.y) / sigma;
        float wy = exp(-0.5 * ey * ey);
        for (int dx = -1; dx <= 1; dx++) {
            float ex = ((float(lr.x) + 0.5 + float(dx) + jitter.x) * r.x - centre.x) / sigma;
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

// The detail patch's luma at HR texel `hr` of an `hr_size` image (ops.taau_lr.detail_luma): `raw`,
// the raw values of its nearest LR texel `lr`, as bound tanh(raw), bilinear at the texel's offset
// from that LR texel's centre, the four values sitting at -1/4 and +1/4 LR pixels (0 and 1 here).
float detail_luma_at(vec4 raw, ivec2 hr, ivec2 lr, ivec2 lr_size, ivec2 hr_size, float bound) {
    vec4 v = bound * tanh(raw);
    vec2 t = 0.5 + 2.0 * ((vec2(hr) + 0.5) * (vec2(lr_size) / vec2(hr_size)) - (vec2(lr) + 0.5));
    float top = v.x + t.x * (v.y - v.x);
    float bottom = v.z + t.x * (v.w - v.z);
    return top + t.y * (bottom - top);
}

float upsampled(float a, float b, float c, float d, vec2 frac) {
    return bilinear_blend(vec4(a), vec4(b), vec4(c), vec4(d), frac).x;
}

// The steering of one HR pixel from its six upsampled raw values and trust (ops.taau_lr.steer_from_lr).
struct LrSteer {
    float history_gain;
    float sample_gain;
    float box_widen;
    float fallback;
};

LrSteer steer_from_lr(float raw[6], float allowed, float box_bound) {
    LrSteer s;
    s.history_gain = 2.0 / (1.0 + exp(-raw[0]));
    if (s.history_gain > 1.0) {
        s.history_gain = 1.0 + (s.history_gain - 1.0) * allowed;
    }
    s.sample_gain = 2.0 / (1.0 + exp(-raw[1]));
    float t = tanh(raw[2]);
    s.box_widen = (t > 0.0 ? box_bound : 0.5) * t;
    if (s.box_widen > 0.0) {
        s.box_widen *= allowed;
    }
    s.fallback = max(tanh(raw[3]), 0.0);
    return s;
}

// One steered TAAU step with a spatial fallback (ops.taau.blend without a correction): the
// blend (RGB in [0, 1], rgb) and its accumulated weight (a).
vec4 fallback_blend(Neighbourhood n, vec3 spatial, vec4 history, LrSteer s, float prior_weight, float max_weight) {
    vec3 span = n.hi - n.lo;
    vec3 clamped = min(max(history.rgb, n.lo - s.box_widen * span), n.hi + s.box_widen * span);
    float weight = history.a * s.history_gain;
    float current = n.samples.a * s.sample_gain;
    vec3 mixed = (weight * clamped + current * n.samples.rgb + prior_weight * spatial) / (weight + current + prior_weight);
    float accumulated = min(weight + current, max_weight);
    mixed = mixed + s.fallback * (spatial - mixed);
    accumulated = accumulated * (1.0 - s.fallback);
    return vec4(clamp(ycocg_to_rgb(mixed), 0.0, 1.0), accumulated);
}
