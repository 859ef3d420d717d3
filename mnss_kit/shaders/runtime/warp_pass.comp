#version 310 es
// warp_pass: one invocation per HR texel.
//   in   history       HR rgba16f  previous output I_SS (rgb)
//        prev_depth    LR r32f     previous frame's LR depth
//        motion        LR rg32f    current LR motion, LR pixels
//   out  warped        HR rgba16f  I_W (rgb; a = 1)
//        warped_depth  LR r32f     D_W at this frame's sampled sub-pixels (all the inpainting reads)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D history;
layout(binding = 1) uniform highp sampler2D prev_depth;
layout(binding = 2) uniform highp sampler2D motion;
layout(rgba16f, binding = 0) uniform writeonly highp image2D warped;
layout(r32f, binding = 1) uniform writeonly highp image2D warped_depth;

uniform int u_scale;
uniform ivec2 u_subpixel;       // this frame's sampled sub-pixel (dx, dy)
uniform vec2 u_prev_jitter;     // previous frame's jitter, LR pixels
uniform ivec2 u_prev_subpixel;  // previous frame's sampled sub-pixel

#include "warp.glsl"

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 hr_size = textureSize(history, 0);
    if (any(greaterThanEqual(hr, hr_size))) {
        return;
    }
    vec2 source = warp_source(motion, hr, u_scale);
    imageStore(warped, hr, round_to_half(vec4(warp_history(history, source), 1.0)));
    if (is_sampled(hr, u_subpixel, u_scale)) {
        float d = warp_depth(prev_depth, source, hr_size, u_prev_jitter, u_prev_subpixel, u_scale);
        imageStore(warped_depth, hr / u_scale, vec4(d, 0.0, 0.0, 0.0));
    }
}
