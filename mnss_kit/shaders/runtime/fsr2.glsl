// FSR2-class temporal upscaler: dilation, previous-depth reconstruction, depth clip, thin-feature
// locks, Lanczos-2 reconstruction, YCoCg variance clamp, accumulation, RCAS.  Binding-free;
// mirrors mnss_kit/ops/fsr2.py (the definition; its docstring describes the steps).

#include "taau.glsl"

const float FSR2_LUMA_R = 0.25;
const float FSR2_LUMA_G = 0.5;
const float FSR2_LUMA_B = 0.25;
const float RCAS_LOBE_LIMIT = 0.1875;
const float PRIOR_FADE = 3.0;
const float PI = 3.14159265358979;

float fsr2_luma(vec3 rgb) {
    return FSR2_LUMA_R * rgb.r + FSR2_LUMA_G * rgb.g + FSR2_LUMA_B * rgb.b;
}

// -- 1. reconstruct and dilate ----------------------------------------------------------------
// Depth (x) and motion (yz) of the nearest surface in the 3x3 neighbourhood of LR texel `lr`,
// the first in scan order on a tie, where it is nearer than the texel's own depth by more than
// `edge` times that depth; else the texel's own (ops.fsr2.dilate).
vec3 dilated_at(highp sampler2D depth, highp sampler2D motion, ivec2 lr, float edge) {
    ivec2 last = textureSize(depth, 0) - 1;
    float best = 0.0;
    ivec2 nearest = lr;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 p = clamp(lr + ivec2(dx, dy), ivec2(0), last);
            float d = depth_texel(depth, p);
            if ((dx == -1 && dy == -1) || d < best) {
                best = d;
                nearest = p;
            }
        }
    }
    float centre = depth_texel(depth, lr);
    if (centre - best <= edge * centre) {
        return vec3(centre, motion_texel(motion, lr));
    }
    return vec3(best, motion_texel(motion, nearest));
}

// ops.fsr2.encode_depth / decode_depth: atomicMax on the bits of 2 - depth keeps the nearest; a
// cleared word (0) is no surface, the far plane.
uint encode_depth(float depth) {
    return floatBitsToUint(2.0 - depth);
}

float decode_depth(uint bits) {
    return bits == 0u ? 1.0 : 2.0 - uintBitsToFloat(bits);
}

// -- 2. depth clip and thin features ----------------------------------------------------------
// The surface's depth step per LR pixel (ops.fsr2.depth_slope).
float depth_slope_at(highp sampler2D dilated, ivec2 lr) {
    ivec2 last = textureSize(dilated, 0) - 1;
    float c = texelFetch(dilated, lr, 0).x;
    float left = texelFetch(dilated, clamp(lr - ivec2(1, 0), ivec2(0), last), 0).x;
    float right = texelFetch(dilated, clamp(lr + ivec2(1, 0), ivec2(0), last), 0).x;
    float up = texelFetch(dilated, clamp(lr - ivec2(0, 1), ivec2(0), last), 0).x;
    float down = texelFetch(dilated, clamp(lr + ivec2(0, 1), ivec2(0), last), 0).x;
    return max(min(abs(c - left), abs(c - right)), min(abs(c - up), abs(c - down)));
}

bool is_ridge(float c, float a, float b, float t) {
    return (c - a >= t && c - b >= t) || (a - c >= t && b - c >= t);
}

// 1.0 where LR texel `lr`'s luma is a strict local extreme across its row or column (ops.fsr2.thin_features).
float thin_feature_at(highp sampler2D color, ivec2 lr, float lock_contrast) {
    ivec2 last = textureSize(color, 0) - 1;
    float c = fsr2_luma(colour_texel(color, lr));
    float left = fsr2_luma(colour_texel(color, clamp(lr - ivec2(1, 0), ivec2(0), last)));
    float right = fsr2_luma(colour_texel(color, clamp(lr + ivec2(1, 0), ivec2(0), last)));
    float up = fsr2_luma(colour_texel(color, clamp(lr - ivec2(0, 1), ivec2(0), last)));
    float down = fsr2_luma(colour_texel(color, clamp(lr + ivec2(0, 1), ivec2(0), last)));
    return (is_ridge(c, left, right, lock_contrast) || is_ridge(c, up, down, lock_contrast)) ? 1.0 : 0.0;
}

// -- 4. accumulate ----------------------------------------------------------------------------
float lanczos2(float x) {
    if (abs(x) >= 2.0) {
        return 0.0;
    }
    if (x == 0.0) {
        return 1.0;
    }
    float p = PI * x;
    return sin(p) * sin(0.5 * p) / (0.5 * p * p);
}

vec4 lanczos2_taps(float t) {  // taps at -1, 0, 1, 2 for fractional position t, normalised
    vec4 w = vec4(lanczos2(t + 1.0), lanczos2(t), lanczos2(t - 1.0), lanczos2(t - 2.0));
    return w / (w.x + w.y + w.z + w.w);
}

vec4 catmull_rom_weights(float t) {
    float t2 = t * t;
    float t3 = t * t * t;
    return vec4(-0.5 * t + t2 - 0.5 * t3, 1.0 - 2.5 * t2 + 1.5 * t3, 0.5 * t + 2.0 * t2 - 1.5 * t3, -0.5 * t2 + 0.5 * t3);
}

// Where HR texel `hr` stands among this frame's samples (ops.fsr2._sample_axis, sample_owner).
struct SamplePlace {
    vec2 u;         // sample coordinate: sample i sits at i + 0.5
    ivec2 nearest;  // the LR index of the nearest sample
    vec2 distance;  // from the pixel centre to it, HR pixels
    bool owner;     // the nearest sample landed in this HR texel
};

SamplePlace sample_place(ivec2 hr, ivec2 lr_size, vec2 jitter, int scale) {
    SamplePlace s;
    float fs = float(scale);
    vec2 centre = vec2(hr) + 0.5;
    s.u = centre / fs - jitter;
    s.nearest = ivec2(clamp(floor(s.u), vec2(0.0), vec2(lr_size - 1)));
    vec2 position = fs * (vec2(s.nearest) + 0.5 + jitter);
    s.distance = centre - position;
    s.owner = all(equal(ivec2(floor(position)), hr));
    return s;
}

// The Lanczos-2 upsampling of the LR colour at HR texel `hr`, YCoCg, deringed to the 2x2 nearest
// samples (ops.fsr2.lanczos_upsample).
vec3 lanczos_upsample_at(highp sampler2D color, SamplePlace s) {
    ivec2 last = textureSize(color, 0) - 1;
    vec2 base = floor(s.u - 0.5);
    vec2 t = s.u - 0.5 - base;
    vec4 wx = lanczos2_taps(t.x);
    vec4 wy = lanczos2_taps(t.y);
    ivec2 b = ivec2(clamp(base, vec2(-2.0), vec2(last + 1)));
    vec3 acc = vec3(0.0);
    vec3 lo = vec3(1e30);
    vec3 hi = vec3(-1e30);
    for (int a = 0; a < 4; a++) {
        int row = clamp(b.y + a - 1, 0, last.y);
        for (int c = 0; c < 4; c++) {
            int col = clamp(b.x + c - 1, 0, last.x);
            vec3 tap = rgb_to_ycocg(colour_texel(color, ivec2(col, row)));
            acc += (wy[a] * wx[c]) * tap;
            if (a >= 1 && a <= 2 && c >= 1 && c <= 2) {
                lo = min(lo, tap);
                hi = max(hi, tap);
            }
        }
    }
    return clamp(acc, lo, hi);
}

// This frame's samples at HR texel `hr`: the mean of the 3x3 samples around the nearest one
// weighted by Lanczos-2's main lobe on their HR distance over `kernel_width`, YCoCg (rgb), and the
// total weight (a) (ops.fsr2.reconstruct_samples).
float main_lobe(float x) {
    return abs(x) < 1.0 ? lanczos2(x) : 0.0;
}

vec4 reconstruct_samples_at(highp sampler2D color, SamplePlace s, int scale, float kernel_width) {
    ivec2 last = textureSize(color, 0) - 1;
    float fs = float(scale);
    vec3 acc = vec3(0.0);
    float total = 0.0;
    for (int a = 0; a < 3; a++) {
        float wy = main_lobe((s.distance.y - fs * float(a - 1)) / kernel_width);
        int row = clamp(s.nearest.y + a - 1, 0, last.y);
        for (int c = 0; c < 3; c++) {
            float wx = main_lobe((s.distance.x - fs * float(c - 1)) / kernel_width);
            int col = clamp(s.nearest.x + c - 1, 0, last.x);
            acc += (wy * wx) * rgb_to_ycocg(colour_texel(color, ivec2(col, row)));
            total += wy * wx;
        }
    }
    vec3 nearest = rgb_to_ycocg(colour_texel(color, s.nearest));
    return vec4(total > 0.0 ? acc / total : nearest, total);
}

// The YCoCg clamp box: mean +- gamma std of the 3x3 LR samples around `lr` (ops.fsr2.variance_box).
struct Box {
    vec3 lo;
    vec3 hi;
};

Box variance_box_at(highp sampler2D color, ivec2 lr, float gamma) {
    ivec2 last = textureSize(color, 0) - 1;
    vec3 sum = vec3(0.0);
    vec3 sum2 = vec3(0.0);
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            vec3 c = rgb_to_ycocg(colour_texel(color, clamp(lr + ivec2(dx, dy), ivec2(0), last)));
            sum += c;
            sum2 += c * c;
        }
    }
    vec3 mean = sum / 9.0;
    vec3 std = sqrt(max(sum2 / 9.0 - mean * mean, 0.0));
    Box box;
    box.lo = mean - gamma * std;
    box.hi = mean + gamma * std;
    return box;
}

// The state at HR texel `hr` warped by the HR `motion` (the dilated motion upsampled; ops.fsr2.reproject).
struct Reprojected {
    vec3 colour;    // YCoCg, Catmull-Rom
    float weight;   // bilinear; 0 on a reset or from off-screen
    vec2 lock;      // lifetime, locked luma (nearest texel); 0 like the weight
    float spread;   // the fetch's blur: t (1 - t) summed over the axes
};

Reprojected reproject_at(highp sampler2D history, highp sampler2D locks, vec2 motion, ivec2 hr, bool reset) {
    ivec2 size = textureSize(history, 0);
    ivec2 last = size - 1;
    vec2 p = vec2(hr) + 0.5 + motion;
    bool keep = !reset && !is_offscreen(p, size);
    vec2 f = p - 0.5;
    vec2 base = floor(f);
    vec2 t = f - base;
    vec4 wx = catmull_rom_weights(t.x);
    vec4 wy = catmull_rom_weights(t.y);
    ivec2 b = ivec2(clamp(base, vec2(-2.0), vec2(size)));
    vec3 acc = vec3(0.0);
    for (int a = 0; a < 4; a++) {
        int row = clamp(b.y + a - 1, 0, last.y);
        for (int c = 0; c < 4; c++) {
            int col = clamp(b.x + c - 1, 0, last.x);
            acc += (wy[a] * wx[c]) * texelFetch(history, ivec2(col, row), 0).rgb;
        }
    }
    ivec2 nearest = ivec2(clamp(floor(p), vec2(0.0), vec2(last)));
    Reprojected r;
    r.colour = rgb_to_ycocg(acc);
    r.weight = keep ? bilinear_sample(history, p).a : 0.0;
    r.lock = keep ? texelFetch(locks, nearest, 0).xy : vec2(0.0);
    r.spread = t.x * (1.0 - t.x) + t.y * (1.0 - t.y);
    return r;
}

// The lock after this frame: lifetime (x) and locked luma (y) (ops.fsr2.update_locks).
vec2 update_lock(vec2 lock, float sample_luma, float disoccluded, bool thin, bool owner, float lock_decay,
                 float lock_luma_tolerance) {
    float lifetime = lock.x * (1.0 - disoccluded);
    bool unstable = owner && abs(sample_luma - lock.y) > lock_luma_tolerance;
    lifetime = unstable ? 0.0 : max(lifetime - lock_decay, 0.0);
    if (owner && thin) {
        return vec2(1.0, sample_luma);
    }
    return vec2(lifetime, lifetime > 0.0 ? lock.y : 0.0);
}

// -- 5. RCAS ----------------------------------------------------------------------------------
// The sharpened RGB at HR texel `p` of `image` (ops.fsr2.rcas); `sharpness` 0 returns the texel.
vec3 rcas_at(highp sampler2D image, ivec2 p, float sharpness) {
    vec3 c = texelFetch(image, p, 0).rgb;
    if (sharpness <= 0.0) {
        return c;
    }
    ivec2 last = textureSize(image, 0) - 1;
    vec3 up = texelFetch(image, clamp(p - ivec2(0, 1), ivec2(0), last), 0).rgb;
    vec3 left = texelFetch(image, clamp(p - ivec2(1, 0), ivec2(0), last), 0).rgb;
    vec3 right = texelFetch(image, clamp(p + ivec2(1, 0), ivec2(0), last), 0).rgb;
    vec3 down = texelFetch(image, clamp(p + ivec2(0, 1), ivec2(0), last), 0).rgb;
    vec3 lo = min(min(up, left), min(right, down));
    vec3 hi = max(max(up, left), max(right, down));
    vec3 bound = max(-lo / (4.0 * hi + 1e-6), (hi - 1.0) / (4.0 * (1.0 - lo) + 1e-6));
    float lobe = max(max(max(bound.r, bound.g), bound.b), -RCAS_LOBE_LIMIT) * sharpness;
    return clamp((c + lobe * (up + left + right + down)) / (1.0 + 4.0 * lobe), 0.0, 1.0);
}
