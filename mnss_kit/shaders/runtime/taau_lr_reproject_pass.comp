#version 310 es
// taau_lr_reproject_pass: taau_reproject_pass at any scale (ntaau_lr at a quality mode such as
// 1.5x): the LR motion resized to the history's size and scaled by each axis's ratio.  One
// invocation per HR texel.
//   in   history      HR rgba16f  the previous output (rgb) and its accumulated weight (a)
//        motion       LR rg32f    current LR motion, LR pixels
//   out  reprojected  HR rgba16f  the history warped to this frame, its bilinear blur undone, in
//                                 YCoCg (rgb), and its weight (a: 0 off-screen and on a reset)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D history;
layout(binding = 1) uniform highp sampler2D motion;
layout(rgba16f, binding = 0) uniform writeonly highp image2D reprojected;

uniform int u_reset;
uniform float u_blur_penalty;

#include "taau_lr.glsl"

vec4 warped_at(ivec2 hr, ivec2 size) {
    return bilinear_sample(history, vec2(hr) + 0.5 + resized_motion_at(motion, hr, size));
}

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(history, 0);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    vec2 m = resized_motion_at(motion, hr, size);
    vec4 centre = bilinear_sample(history, vec2(hr) + 0.5 + m);
    // the 3-tap second derivatives of the warped image, edge texels repeated (ops.taau.undo_bilinear_blur)
    vec3 left = warped_at(max(hr - ivec2(1, 0), ivec2(0)), size).rgb;
    vec3 right = warped_at(min(hr + ivec2(1, 0), size - 1), size).rgb;
    vec3 up = warped_at(max(hr - ivec2(0, 1), ivec2(0)), size).rgb;
    vec3 down = warped_at(min(hr + ivec2(0, 1), size - 1), size).rgb;
    vec2 spread = resample_spread(m);
    vec3 dxx = left + right - 2.0 * centre.rgb;
    vec3 dyy = up + down - 2.0 * centre.rgb;
    vec3 colour = centre.rgb - 0.5 * (spread.x * dxx + spread.y * dyy);
    bool keep = u_reset == 0 && !is_offscreen(vec2(hr) + 0.5 + m, size);
    float weight = keep ? centre.a * exp(-u_blur_penalty * (spread.x + spread.y)) : 0.0;
    imageStore(reprojected, hr, round_to_half(vec4(rgb_to_ycocg(colour), weight)));
}
