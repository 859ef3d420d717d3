#version 310 es
// taau_filter_pass: one invocation per HR texel, after taau_accumulate_pass, in models whose net
// steers a display filter.
//   in   npu_output   std430 uint[]  int8 NHWC (1, H, W, 8): the steering net's raw output
//                                    (channels 3-5: the correction, 6-7: the filter weights)
//        history      HR rgba16f     this frame's blend (rgb), as taau_accumulate_pass wrote it
//        motion       LR rg32f       LR motion (the filter fades where the history was resampled)
//   out  display      HR rgba8       the blend through the steered 3x3 filter, plus the correction
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer NpuOutput { uint npu_output[]; };
layout(binding = 0) uniform highp sampler2D history;
layout(binding = 1) uniform highp sampler2D motion;
layout(rgba8, binding = 0) uniform writeonly highp image2D display;

uniform int u_scale;
uniform float u_q_scale;
uniform int u_q_zero_point;
uniform float u_correction_bound;
uniform float u_filter_bound;
uniform float u_filter_falloff;

#include "display.glsl"
#include "taau.glsl"

const int STEER_CHANNELS = 8;

float raw_at(ivec2 hr, int width, int c) {
    int b = (hr.y * width + hr.x) * STEER_CHANNELS + c;
    return dequantize_int8(int8_of_word(npu_output[b / 4], b % 4), u_q_scale, u_q_zero_point);
}

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(display);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    vec3 correction = correction_from_raw(vec3(raw_at(hr, size.x, 3), raw_at(hr, size.x, 4), raw_at(hr, size.x, 5)),
                                          u_correction_bound);
    float gain = filter_gain(motion, hr, u_scale, u_filter_falloff);
    float axis = filter_weight_from_raw(raw_at(hr, size.x, 6), u_filter_bound) * gain;
    float diagonal = filter_weight_from_raw(raw_at(hr, size.x, 7), u_filter_bound) * gain;
    vec3 filtered = display_filter_at(history, hr, axis, diagonal);
    imageStore(display, hr, encode_unorm8(vec4(corrected(filtered, correction), 1.0)));
}
