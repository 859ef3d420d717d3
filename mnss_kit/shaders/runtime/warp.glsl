// Warp (MNSS): backward bilinear warp of the previous output and of the upsampled previous LR
// depth by the upsampled current motion.  Binding-free; mirrors mnss_kit/gpu/reference.py
// (ops.warp.upsample_motion, ops.subpixel.jittered_upsample, ops.warp.warp_bilinear).

#include "common.glsl"

// HR motion at HR texel `hr`: LR motion resized bilinearly (no jitter: motion is rendered
// without it), times the scale because motion is in pixels of its own resolution.  Sanitized
// (common.glsl's motion_bilinear).
vec2 upsampled_motion_at(highp sampler2D motion, ivec2 hr, int scale) {
    return motion_bilinear(motion, (vec2(hr) + 0.5) / float(scale)) * float(scale);
}

// Where HR texel `hr`'s surface was in the previous frame, in HR pixel coordinates.
vec2 warp_source(highp sampler2D motion, ivec2 hr, int scale) {
    return vec2(hr) + 0.5 + upsampled_motion_at(motion, hr, scale);
}

// I_W: the previous output (HR) sampled at `source`.
vec3 warp_history(highp sampler2D history, vec2 source) {
    return bilinear_sample(history, source).rgb;
}

// ops.warp.OFFSCREEN_DEPTH: D_W where the surface was outside the previous frame (no history there).
const float OFFSCREEN_DEPTH = -1.0;

bool is_offscreen(vec2 source, ivec2 hr_size) {
    return any(lessThan(source, vec2(0.0))) || any(greaterThanEqual(source, vec2(hr_size)));
}

// D_W: the previous LR depth, upsampled with the previous frame's jitter, sampled at `source`;
// OFFSCREEN_DEPTH when `source` lies outside the frame.
float warp_depth(highp sampler2D prev_depth, vec2 source, ivec2 hr_size, vec2 prev_jitter, ivec2 prev_subpixel,
                 int scale) {
    if (is_offscreen(source, hr_size)) {
        return OFFSCREEN_DEPTH;
    }
    BilinearTaps t = bilinear_taps(source, hr_size);
    float a = jittered_upsample_input_at(prev_depth, t.lo, prev_jitter, prev_subpixel, scale, INPUT_DEPTH).x;
    float b = jittered_upsample_input_at(prev_depth, ivec2(t.hi.x, t.lo.y), prev_jitter, prev_subpixel, scale, INPUT_DEPTH).x;
    float c = jittered_upsample_input_at(prev_depth, ivec2(t.lo.x, t.hi.y), prev_jitter, prev_subpixel, scale, INPUT_DEPTH).x;
    float d = jittered_upsample_input_at(prev_depth, t.hi, prev_jitter, prev_subpixel, scale, INPUT_DEPTH).x;
    return bilinear_blend(vec4(a), vec4(b), vec4(c), vec4(d), t.frac).x;
}
