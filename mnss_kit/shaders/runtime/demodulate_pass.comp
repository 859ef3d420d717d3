#version 310 es
// demodulate_pass: one invocation per LR texel.
//   in   color     LR rgba16f        jittered colour, display values
//        fbeta     LR rgba16f        F_beta (linear)
//        emissive  LR rgba16f        emission and sky (linear)
//        (every input texel sanitized on read: common.glsl, ops.sanitize)
//   out  l         LR rgba16f array  layer 0: display-encoded L (demodulation.glsl), or the
//                                    colour itself with u_demodulate = 0
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2DArray;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D fbeta;
layout(binding = 2) uniform highp sampler2D emissive;
layout(rgba16f, binding = 0) uniform writeonly highp image2DArray l;

uniform int u_demodulate;

#include "common.glsl"
#include "demodulation.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(color, 0)))) {
        return;
    }
    vec3 c = colour_texel(color, p);
    vec3 v = u_demodulate != 0 ? demodulate(c, sanitize_gbuffer(texelFetch(fbeta, p, 0).rgb),
                                             sanitize_gbuffer(texelFetch(emissive, p, 0).rgb)) : c;
    imageStore(l, ivec3(p, 0), round_to_half(vec4(v, 0.0)));
}
