#version 310 es
// remodulate_pass: one invocation per HR texel.
//   in   npu_output  std430 uint[]  int8 NHWC (1, H, W, 3) from the NPU: the residual over the upsampled L
//        l           LR rgba16f     display-encoded L (layer 0 of demodulate_pass's output)
//        fbeta       HR rgba16f     F_beta
//        emissive    HR rgba16f     emission and sky (F_beta and emissive sanitized on read, common.glsl)
//   out  history     HR rgba16f     the output, the next frame's history (rgb; a = 1)
//        display     HR rgba8       the output as 8-bit display codes
// HR L = clamp(L at the LR pixel + residual, 0, 1) (ops.demodulation.add_upsampled, exact in float32).
// With u_demodulate = 0 the HR L is the colour itself (no remodulation).
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer NpuOutput { uint npu_output[]; };
layout(binding = 0) uniform highp sampler2D fbeta;
layout(binding = 1) uniform highp sampler2D emissive;
layout(binding = 2) uniform highp sampler2DArray l;
layout(rgba16f, binding = 0) uniform writeonly highp image2D history;
layout(rgba8, binding = 1) uniform writeonly highp image2D display;

uniform int u_scale;
uniform float u_q_scale;
uniform int u_q_zero_point;
uniform int u_demodulate;

#include "common.glsl"
#include "display.glsl"
#include "demodulation.glsl"

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(history);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    vec3 v;
    for (int c = 0; c < NPU_CHANNELS; c++) {
        int b = (hr.y * size.x + hr.x) * NPU_CHANNELS + c;
        v[c] = dequantize_int8(int8_of_word(npu_output[b / 4], b % 4), u_q_scale, u_q_zero_point);
    }
    v = clamp(texelFetch(l, ivec3(hr / u_scale, 0), 0).rgb + v, 0.0, 1.0);
    if (u_demodulate != 0) {
        v = remodulate(v, sanitize_gbuffer(texelFetch(fbeta, hr, 0).rgb), sanitize_gbuffer(texelFetch(emissive, hr, 0).rgb));
    }
    imageStore(history, hr, round_to_half(vec4(v, 1.0)));
    imageStore(display, hr, encode_unorm8(vec4(v, 1.0)));
}
