#version 310 es
// insert_pack_pass: one invocation per 32-bit word of the NPU input tensor.
//   in   rectified  HR rgba16f        I_R (inpaint_blend_pass)
//        aa         LR rgba16f array  I_AA in layer 0 (last conv3x3_pass of the AA net)
//   out  npu_input  std430 uint[]     int8 NHWC (1, H, W, 3), ceil(3 H W / 4) words
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp sampler2DArray;

layout(local_size_x = 64) in;

layout(binding = 0) uniform highp sampler2D rectified;
layout(binding = 1) uniform highp sampler2DArray aa;
layout(std430, binding = 0) writeonly buffer NpuInput { uint npu_input[]; };

uniform int u_scale;
uniform ivec2 u_subpixel;
uniform int u_word_count;
uniform float u_q_scale;
uniform float u_q_reciprocal;
uniform int u_q_use_reciprocal;
uniform int u_q_rounding;
uniform int u_q_zero_point;

#include "insert_pack.glsl"

void main() {
    // A 2D grid of workgroups covers large tensors (the x count is limited to 65535).
    int i = int(gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x);
    if (i >= u_word_count) {
        return;
    }
    QuantParams q = QuantParams(u_q_scale, u_q_reciprocal, u_q_use_reciprocal != 0, u_q_rounding, u_q_zero_point);
    npu_input[i] = npu_input_word(rectified, aa, i, u_subpixel, u_scale, q);
}
