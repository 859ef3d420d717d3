#version 310 es
// gbuffer_pack_pass: one invocation per 32-bit word of the NPU input tensor (gbuffer_pack.glsl).
//   in   l         LR rgba16f array  L or the colour in layer 0 (demodulate_pass)
//        features  LR rgba16f array  encoder features (conv3x3_pass)
//        warped    HR rgba16f        the warped history (warp_pass), with u_history
//        fbeta, normal, albedo  HR rgba16f, depth HR r32f: the G-buffers of u_gbuffers
//   out  npu_input std430 uint[]     int8 NHWC (1, h, w, C)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp sampler2DArray;

layout(local_size_x = 64) in;

layout(binding = 0) uniform highp sampler2DArray l;
layout(binding = 1) uniform highp sampler2DArray features;
layout(binding = 2) uniform highp sampler2D warped;
layout(binding = 3) uniform highp sampler2D fbeta;
layout(binding = 4) uniform highp sampler2D normal;
layout(binding = 5) uniform highp sampler2D depth;
layout(binding = 6) uniform highp sampler2D albedo;
layout(std430, binding = 0) writeonly buffer NpuInput { uint npu_input[]; };

uniform int u_scale;
uniform int u_features;
uniform int u_history;
uniform int u_reset;
uniform int u_gbuffers;
uniform int u_word_count;
uniform float u_q_scale;
uniform float u_q_reciprocal;
uniform int u_q_use_reciprocal;
uniform int u_q_rounding;
uniform int u_q_zero_point;

#include "gbuffer_pack.glsl"

void main() {
    int i = int(gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x);
    if (i >= u_word_count) {
        return;
    }
    QuantParams q = QuantParams(u_q_scale, u_q_reciprocal, u_q_use_reciprocal != 0, u_q_rounding, u_q_zero_point);
    ivec2 lr_size = textureSize(l, 0).xy;
    npu_input[i] = npu_input_word(i, lr_size, u_features, u_scale, u_history, u_reset, u_gbuffers, q);
}
