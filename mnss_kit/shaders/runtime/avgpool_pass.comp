#version 310 es
// avgpool_pass: one invocation per LR texel.
//   in   rectified  HR rgba16f        I_R (inpaint_blend_pass)
//        color      LR rgba16f        current jittered colour
//   out  aa_input   LR rgba16f array  2 layers: (pool.rgb, color.r), (color.gb, 0, 0); or with
//                                     u_history_at_samples 3 layers: (pool.rgb, sample.r),
//                                     (sample.gb, color.rg), (color.b, 0, 0, 0)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2DArray;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D rectified;
layout(binding = 1) uniform highp sampler2D color;
layout(rgba16f, binding = 0) uniform writeonly highp image2DArray aa_input;

uniform int u_scale;
uniform ivec2 u_subpixel;           // the HR texel within each LR texel sampled this frame
uniform int u_history_at_samples;   // 1: the net also reads I_R at the sampled texels

#include "avgpool.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(color, 0)))) {
        return;
    }
    vec3 pooled = tile_mean(rectified, p, u_scale);
    vec3 c = colour_texel(color, p);
    if (u_history_at_samples == 0) {
        imageStore(aa_input, ivec3(p, 0), round_to_half(vec4(pooled, c.r)));
        imageStore(aa_input, ivec3(p, 1), round_to_half(vec4(c.g, c.b, 0.0, 0.0)));
        return;
    }
    vec3 sampled = sampled_texel(rectified, p, u_subpixel, u_scale);
    imageStore(aa_input, ivec3(p, 0), round_to_half(vec4(pooled, sampled.r)));
    imageStore(aa_input, ivec3(p, 1), round_to_half(vec4(sampled.g, sampled.b, c.r, c.g)));
    imageStore(aa_input, ivec3(p, 2), round_to_half(vec4(c.b, 0.0, 0.0, 0.0)));
}
