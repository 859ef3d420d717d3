#version 310 es
// taau_accumulate_pass: one invocation per HR texel.
//   in   npu_output   std430 uint[]  int8 NHWC (1, H, W, u_steer_channels): the steering net's raw
//                                    output (the first six here; two more steer taau_filter_pass)
//        color        LR rgba16f     jittered LR colour, display values
//        reprojected  HR rgba16f     taau_reproject_pass
//        motion       LR rg32f       LR motion (the history-gain floor holds where it is small)
//   out  history      HR rgba16f     the blend before the correction (rgb) and its accumulated weight (a)
//        display      HR rgba8       the corrected output as 8-bit display codes (taau_filter_pass
//                                    replaces it in models with a display filter)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer NpuOutput { uint npu_output[]; };
layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D reprojected;
layout(binding = 2) uniform highp sampler2D motion;
layout(rgba16f, binding = 0) uniform writeonly highp image2D history;
layout(rgba8, binding = 1) uniform writeonly highp image2D display;

uniform int u_scale;
uniform int u_steer_channels;
uniform vec2 u_jitter;
uniform float u_q_scale;
uniform int u_q_zero_point;
uniform float u_correction_bound;
uniform float u_box_bound;
uniform float u_history_gain_min;
uniform float u_still_motion_px;
uniform float u_sample_sigma;
uniform float u_prior_weight;
uniform float u_max_weight;

#include "display.glsl"
#include "taau.glsl"

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(history);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    float raw[6];
    for (int c = 0; c < 6; c++) {
        int b = (hr.y * size.x + hr.x) * u_steer_channels + c;
        raw[c] = dequantize_int8(int8_of_word(npu_output[b / 4], b % 4), u_q_scale, u_q_zero_point);
    }
    Neighbourhood n = neighbourhood_at(color, hr, u_jitter, u_scale, u_sample_sigma);
    vec3 spatial = spatial_at(color, hr, u_jitter, u_scale);
    float floor_gain = history_floor(motion, hr, u_scale, u_history_gain_min, u_still_motion_px);
    Blended b = steered_blend(n, spatial, texelFetch(reprojected, hr, 0), steer_from_raw(raw, u_correction_bound, floor_gain, u_box_bound),
                              u_prior_weight, u_max_weight);
    imageStore(history, hr, round_to_half(b.history));
    imageStore(display, hr, encode_unorm8(vec4(b.display, 1.0)));
}
