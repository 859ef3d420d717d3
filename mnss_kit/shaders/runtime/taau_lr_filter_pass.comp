#version 310 es
// taau_lr_filter_pass: one invocation per HR texel, after taau_lr_accumulate_pass, in models whose
// net steers a display filter.
//   in   npu_output   std430 uint[]  int8 NHWC (1, h', w', 6 + u_detail_channels): the steering net's
//                                    raw output at LR (channels 4-5: the filter weights, upsampled
//                                    here; 6-9 with a detail branch: its patch)
//        history      HR rgba16f     this frame's blend (rgb), as taau_lr_accumulate_pass wrote it
//   out  display      HR rgba8       the blend through the steered 3x3 filter, plus the detail patch
//                                    when u_detail_bound > 0
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer NpuOutput { uint npu_output[]; };
layout(binding = 0) uniform highp sampler2D history;
layout(rgba8, binding = 0) uniform writeonly highp image2D display;

uniform int u_scale;  // 2, 3, 4; 0 at a fractional scale: the LR size is u_lr_size
uniform ivec2 u_lr_size;
uniform float u_q_scale;
uniform int u_q_zero_point;
uniform float u_filter_bound;
uniform int u_detail_channels;  // the npu_output's channels after the steering's: 0, or 4 (a detail branch)
uniform float u_detail_bound;   // > 0: the display gets the detail patch, each value at most this

#include "display.glsl"
#include "taau_lr.glsl"

const int STEER_CHANNELS = 6;

float raw_at(ivec2 p, int padded_width, int c) {
    int b = (p.y * padded_width + p.x) * (STEER_CHANNELS + u_detail_channels) + c;
    return dequantize_int8(int8_of_word(npu_output[b / 4], b % 4), u_q_scale, u_q_zero_point);
}

// The filter weight of raw channel `c`, upsampled to HR texel `hr` and mapped (ops.taau_lr.filter_weights).
float filter_weight_at(BilinearTaps t, int padded_width, int c) {
    float raw = upsampled(raw_at(t.lo, padded_width, c), raw_at(ivec2(t.hi.x, t.lo.y), padded_width, c),
                          raw_at(ivec2(t.lo.x, t.hi.y), padded_width, c), raw_at(t.hi, padded_width, c), t.frac);
    return filter_weight_from_raw(raw, u_filter_bound);
}

// The detail patch's luma at HR texel `hr` (ops.taau_lr.detail_luma).
float detail_luma(ivec2 hr, ivec2 lr_size, ivec2 hr_size, int padded_width) {
    ivec2 lr = lr_texel_of(hr, lr_size, hr_size);
    vec4 raw = vec4(raw_at(lr, padded_width, STEER_CHANNELS), raw_at(lr, padded_width, STEER_CHANNELS + 1),
                    raw_at(lr, padded_width, STEER_CHANNELS + 2), raw_at(lr, padded_width, STEER_CHANNELS + 3));
    return detail_luma_at(raw, hr, lr, lr_size, hr_size, u_detail_bound);
}

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    ivec2 lr_size = u_scale == 0 ? u_lr_size : size / u_scale;
    BilinearTaps t = u_scale == 0 ? resize_taps(hr, lr_size, size) : upsample_taps(hr, u_scale, lr_size);
    int padded_width = lr_size.x + lr_size.x % 2;
    float axis = filter_weight_at(t, padded_width, 4);
    float diagonal = filter_weight_at(t, padded_width, 5);
    vec3 filtered = display_filter_at(history, hr, axis, diagonal);
    if (u_detail_bound > 0.0) {  // luma only: (Y, 0, 0) in YCoCg adds Y to each of R, G and B
        filtered += detail_luma(hr, lr_size, size, padded_width);
    }
    imageStore(display, hr, encode_unorm8(vec4(clamp(filtered, 0.0, 1.0), 1.0)));
}
