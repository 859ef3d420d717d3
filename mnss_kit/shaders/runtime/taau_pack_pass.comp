#version 310 es
// taau_pack_pass: one invocation per 32-bit word of the NPU input tensor.
//   in   color        LR rgba16f     jittered LR colour, display values
//        reprojected  HR rgba16f     taau_reproject_pass
//   out  npu_input    std430 uint[]  int8 NHWC (1, h, w, 3 + 5 s^2): the LR colour, then the HR
//                                    clamped history (YCoCg), its weight / u_max_weight and the clamp
//                                    distance, pixel-unshuffled (channel k s^2 + dy s + dx)
precision highp float;
precision highp int;
precision highp sampler2D;

layout(local_size_x = 64) in;

layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D reprojected;
layout(std430, binding = 0) writeonly buffer NpuInput { uint npu_input[]; };

uniform int u_scale;
uniform float u_max_weight;
uniform int u_word_count;
uniform float u_q_scale;
uniform float u_q_reciprocal;
uniform int u_q_use_reciprocal;
uniform int u_q_rounding;
uniform int u_q_zero_point;

#include "quant.glsl"
#include "taau.glsl"

const int HR_FEATURES = 5;  // clamped history (3), weight, clamp distance

// Channel `c` of LR texel `p` (the model's ntaau Gather, ops.taau's clamp box).
float feature(ivec2 p, int c, int scale) {
    if (c < 3) return colour_texel(color, p)[c];
    c -= 3;
    int s2 = scale * scale;
    int sub = c % s2;
    ivec2 hr = p * scale + ivec2(sub % scale, sub / scale);
    ivec2 size = textureSize(color, 0);
    vec3 lo = vec3(1e30);
    vec3 hi = vec3(-1e30);
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            vec3 v = rgb_to_ycocg(colour_texel(color, clamp(p + ivec2(dx, dy), ivec2(0), size - 1)));
            lo = min(lo, v);
            hi = max(hi, v);
        }
    }
    vec4 history = texelFetch(reprojected, hr, 0);
    vec3 clamped = min(max(history.rgb, lo), hi);
    int f = c / s2;
    if (f < 3) return clamped[f];
    if (f == 3) return history.a / u_max_weight;
    vec3 d = abs(history.rgb - clamped);
    return d.x + d.y + d.z;
}

void main() {
    int i = int(gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x);
    if (i >= u_word_count) {
        return;
    }
    QuantParams q = QuantParams(u_q_scale, u_q_reciprocal, u_q_use_reciprocal != 0, u_q_rounding, u_q_zero_point);
    ivec2 lr_size = textureSize(color, 0);
    int channels = 3 + HR_FEATURES * u_scale * u_scale;
    int total = lr_size.x * lr_size.y * channels;
    uint word = 0u;
    for (int k = 0; k < 4; k++) {
        int b = 4 * i + k;
        if (b >= total) {
            break;
        }
        int pixel = b / channels;
        ivec2 p = ivec2(pixel % lr_size.x, pixel / lr_size.x);
        word |= word_of_int8(quantize_int8(feature(p, b % channels, u_scale), q), k);
    }
    npu_input[i] = word;
}
