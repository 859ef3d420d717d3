#version 310 es
// unpack_history_pass: one invocation per HR texel.
//   in   npu_output  std430 uint[]  int8 NHWC (1, H, W, 3) from the NPU (I_SS)
//   out  history     HR rgba16f     dequantized I_SS, the next frame's history (rgb; a = 1)
//        display     HR rgba8       the same as 8-bit display codes (overwritten by sharpen_pass
//                                   when enhancement is on)
precision highp float;
precision highp int;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer NpuOutput { uint npu_output[]; };
layout(rgba16f, binding = 0) uniform writeonly highp image2D history;
layout(rgba8, binding = 1) uniform writeonly highp image2D display;

uniform float u_q_scale;
uniform int u_q_zero_point;

#include "unpack_history.glsl"

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(history);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    vec4 v = vec4(1.0);
    for (int c = 0; c < NPU_CHANNELS; c++) {
        int b = (hr.y * size.x + hr.x) * NPU_CHANNELS + c;
        v[c] = dequantize_int8(int8_of_word(npu_output[b / 4], b % 4), u_q_scale, u_q_zero_point);
    }
    imageStore(history, hr, round_to_half(v));
    imageStore(display, hr, encode_unorm8(v));
}
