#version 310 es
// taau_lr_pack_pass: one invocation per 32-bit word of the NPU input tensor.
//   in   color        LR rgba16f     jittered LR colour, display values
//        reprojected  HR rgba16f     taau_reproject_pass (not read on a reset: the history is zero,
//                                    as the model's cut state)
//        evidence     LR rgba32f     taau_lr_evidence_pass
//   out  npu_input    std430 uint[]  int8 NHWC (1, h', w', 8), h' and w' the LR size rounded up to
//                                    even (edge pixels repeated): the LR colour, the clamped
//                                    history's luma minus the colour's, the clamp distance, the
//                                    history weight / u_max_weight (each the mean over the s x s HR
//                                    block; u_scale 0: any scale, the HR texels nearest the LR one),
//                                    the depth change, the motion spread (at most 4); with
//                                    u_scale_input != 0 a 9th channel, that value (1 / scale); with
//                                    u_detail != 0 (an integer scale) then u_scale^2 channels, the
//                                    clamped history's luma at HR texel (dx, dy) of the block in
//                                    channel dy * u_scale + dx (torch's pixel_unshuffle order)
precision highp float;
precision highp int;
precision highp sampler2D;

layout(local_size_x = 64) in;

layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D reprojected;
layout(binding = 2) uniform highp sampler2D evidence;
layout(std430, binding = 0) writeonly buffer NpuInput { uint npu_input[]; };

uniform int u_scale;
uniform int u_reset;
uniform float u_max_weight;
uniform int u_word_count;
uniform float u_q_scale;
uniform float u_q_reciprocal;
uniform int u_q_use_reciprocal;
uniform int u_q_rounding;
uniform int u_q_zero_point;
uniform float u_scale_input;  // 0: the 8 features; else a 9th channel of this value (1 / scale)
uniform int u_detail;  // 1: the detail branch's u_scale^2 input channels follow

#include "quant.glsl"
#include "taau_lr.glsl"

const int CHANNELS = 8;

// The clamp box of LR texel `p`: the YCoCg min and max of its 3x3 colours (ops.taau.neighbourhood_box).
void colour_box(ivec2 p, out vec3 lo, out vec3 hi) {
    ivec2 last = textureSize(color, 0) - 1;
    lo = vec3(1e30);
    hi = vec3(-1e30);
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            vec3 v = rgb_to_ycocg(colour_texel(color, clamp(p + ivec2(dx, dy), ivec2(0), last)));
            lo = min(lo, v);
            hi = max(hi, v);
        }
    }
}

// The mean over LR texel `p`'s HR block of the clamped history's luma (x), the clamp distance (y)
// and the history weight (z) (ops.taau_lr.steering_features).
vec3 block_means(ivec2 p) {
    vec3 lo;
    vec3 hi;
    colour_box(p, lo, hi);
    // the HR block: s x s texels at an integer scale; at any scale (u_scale 0) the texels whose
    // nearest LR texel is p (ops.taau_lr.block_mean)
    ivec2 first = p * u_scale;
    ivec2 end = first + u_scale;
    if (u_scale == 0) {
        ivec2 lr_size = textureSize(color, 0);
        ivec2 hr_size = textureSize(reprojected, 0);
        first = first_hr_texel(p, lr_size, hr_size);
        end = first_hr_texel(p + 1, lr_size, hr_size);
        if (u_reset != 0) {
            end = first + 1;  // a zero history: every texel of the block gives the same values
        }
    }
    vec3 sum = vec3(0.0);
    for (int y = first.y; y < end.y; y++) {
        for (int x = first.x; x < end.x; x++) {
            vec4 history = u_reset != 0 ? vec4(0.0) : texelFetch(reprojected, ivec2(x, y), 0);
            vec3 clamped = min(max(history.rgb, lo), hi);
            vec3 d = abs(history.rgb - clamped);
            sum += vec3(clamped.x, d.x + d.y + d.z, history.a);
        }
    }
    return sum / float((end.x - first.x) * (end.y - first.y));
}

// The four channels of LR texel `p` in word `half` (0: channels 0-3, 1: channels 4-7); `p` is
// already clamped into the image (the padding repeats the edge).
vec4 features(ivec2 p, int half_index) {
    vec3 colour = colour_texel(color, p);
    vec3 means = block_means(p);
    if (half_index == 0) {
        return vec4(colour, means.x - rgb_to_ycocg(colour).x);
    }
    vec4 e = texelFetch(evidence, p, 0);
    return vec4(means.y, means.z / u_max_weight, e.r, min(e.g, SPREAD_CAP));
}

// The clamped history's luma at HR texel `k` (row-major) of LR texel `p`'s block: a detail input.
float clamped_luma(ivec2 p, int k) {
    vec3 lo;
    vec3 hi;
    colour_box(p, lo, hi);
    ivec2 hr = p * u_scale + ivec2(k % u_scale, k / u_scale);
    float luma = u_reset != 0 ? 0.0 : texelFetch(reprojected, hr, 0).x;
    return min(max(luma, lo.x), hi.x);
}

// Channel `c` of LR texel `p` (ops.taau_lr.steering_features): the 8 features, then with a scale
// input (u_scale_input != 0) the constant 1 / scale, then with u_detail the detail inputs.
float feature_at(ivec2 p, int c) {
    if (c < CHANNELS) {
        return features(p, c / 4)[c % 4];
    }
    if (u_scale_input != 0.0) {
        if (c == CHANNELS) {
            return u_scale_input;
        }
        c -= 1;
    }
    return clamped_luma(p, c - CHANNELS);
}

void main() {
    int i = int(gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x + gl_GlobalInvocationID.x);
    if (i >= u_word_count) {
        return;
    }
    QuantParams q = QuantParams(u_q_scale, u_q_reciprocal, u_q_use_reciprocal != 0, u_q_rounding, u_q_zero_point);
    ivec2 lr_size = textureSize(color, 0);
    int padded_width = lr_size.x + lr_size.x % 2;
    int channels = CHANNELS + (u_scale_input != 0.0 ? 1 : 0) + (u_detail != 0 ? u_scale * u_scale : 0);
    if (channels != CHANNELS) {  // a word may hold two pixels' channels; bytes past the tensor stay 0
        int total = padded_width * (lr_size.y + lr_size.y % 2) * channels;
        uint bits = 0u;
        for (int k = 0; k < 4; k++) {
            int b = i * 4 + k;
            if (b < total) {
                int at = b / channels;
                ivec2 p = min(ivec2(at % padded_width, at / padded_width), lr_size - 1);
                bits |= word_of_int8(quantize_int8(feature_at(p, b % channels), q), k);
            }
        }
        npu_input[i] = bits;
        return;
    }
    int pixel = i / (CHANNELS / 4);  // CHANNELS is a multiple of 4: a word holds channels of one pixel
    ivec2 p = min(ivec2(pixel % padded_width, pixel / padded_width), lr_size - 1);
    vec4 v = features(p, i % (CHANNELS / 4));
    uint word = 0u;
    for (int k = 0; k < 4; k++) {
        word |= word_of_int8(quantize_int8(v[k], q), k);
    }
    npu_input[i] = word;
}
