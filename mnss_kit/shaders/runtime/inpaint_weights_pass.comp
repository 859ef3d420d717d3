#version 310 es
// inpaint_weights_pass: one invocation per LR texel; skipped on a reset frame.
//   in   color         LR rgba16f      current jittered colour
//        depth         LR r32f         current depth
//        warped        HR rgba16f      I_W (warp_pass)
//        warped_depth  LR r32f         D_W at the sampled sub-pixels (warp_pass)
//        weights       std430 vec4[]   the learned 3x3 conv, 4 -> 1 channels (conv3x3.glsl)
//   out  lr_weight     LR r32f         LR weights in [0, 1] (ES 3.10 has no r16f image format); 0
//                                      where the colour is not finite (no sample: keep the history)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D depth;
layout(binding = 2) uniform highp sampler2D warped;
layout(binding = 3) uniform highp sampler2D warped_depth;
layout(std430, binding = 0) readonly buffer Weights { vec4 weights[]; };
layout(r32f, binding = 0) uniform writeonly highp image2D lr_weight;

uniform int u_scale;
uniform ivec2 u_subpixel;
uniform int u_activation;  // ACTIVATION_SIGMOID or ACTIVATION_TANH

vec4 conv_weight(int i) {
    return weights[i];
}

#include "inpaint_weights.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(color, 0)))) {
        return;
    }
    float w = inpaint_lr_weight(color, depth, warped, warped_depth, p, u_subpixel, u_scale, u_activation);
    if (colour_not_finite(texelFetch(color, p, 0).rgb)) {
        w = 0.0;
    }
    imageStore(lr_weight, p, vec4(w, 0.0, 0.0, 0.0));
}
