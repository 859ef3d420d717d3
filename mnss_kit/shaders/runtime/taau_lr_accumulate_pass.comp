#version 310 es
// taau_lr_accumulate_pass: one invocation per HR texel.
//   in   npu_output   std430 uint[]  int8 NHWC (1, h', w', 6 + u_detail_channels): the steering net's
//                                    raw output at LR (h', w' the even size; the first h x w pixels
//                                    are read), with a detail branch its 4 raw patch values last
//        color        LR rgba16f     jittered LR colour, display values
//        reprojected  HR rgba16f     taau_reproject_pass
//        evidence     LR rgba32f     taau_lr_evidence_pass (the trust, b)
//        motion       LR rg32f       LR motion (the history-gain floor holds where it is small)
//   out  history      HR rgba16f     the blend (rgb) and its accumulated weight (a)
//        display      HR rgba8       the blend, plus the detail patch when u_detail_bound > 0, as
//                                    8-bit display codes (taau_lr_filter_pass replaces it in models
//                                    with a display filter, and draws the patch there)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, binding = 0) readonly buffer NpuOutput { uint npu_output[]; };
layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D reprojected;
layout(binding = 2) uniform highp sampler2D evidence;
layout(binding = 3) uniform highp sampler2D motion;
layout(rgba16f, binding = 0) uniform writeonly highp image2D history;
layout(rgba8, binding = 1) uniform writeonly highp image2D display;

uniform int u_scale;  // 2, 3, 4; 0 at a fractional scale (the sizes of color and history give the ratio)
uniform vec2 u_jitter;
uniform float u_q_scale;
uniform int u_q_zero_point;
uniform float u_box_bound;
uniform float u_history_gain_min;
uniform float u_still_motion_px;
uniform float u_sample_sigma;
uniform float u_prior_weight;
uniform float u_max_weight;
uniform int u_detail_channels;  // the npu_output's channels after the steering's: 0, or 4 (a detail branch)
uniform float u_detail_bound;   // > 0: the display gets the detail patch, each value at most this

#include "display.glsl"
#include "taau_lr.glsl"

const int STEER_CHANNELS = 6;

// Raw value `c` of LR texel `p` in the NPU output.
float npu_value(ivec2 p, int c) {
    ivec2 lr_size = textureSize(color, 0);
    int b = (p.y * (lr_size.x + lr_size.x % 2) + p.x) * (STEER_CHANNELS + u_detail_channels) + c;
    return dequantize_int8(int8_of_word(npu_output[b / 4], b % 4), u_q_scale, u_q_zero_point);
}

// Raw value `c` of LR texel `p` (c < 6), or its trust (c == 6).
float lr_value(ivec2 p, int c) {
    return c == STEER_CHANNELS ? texelFetch(evidence, p, 0).b : npu_value(p, c);
}

// The detail patch's luma at HR texel `hr` of an `hr_size` image (ops.taau_lr.detail_luma).
float detail_luma(ivec2 hr, ivec2 hr_size) {
    ivec2 lr_size = textureSize(color, 0);
    ivec2 lr = lr_texel_of(hr, lr_size, hr_size);
    vec4 raw = vec4(npu_value(lr, STEER_CHANNELS), npu_value(lr, STEER_CHANNELS + 1), npu_value(lr, STEER_CHANNELS + 2),
                    npu_value(lr, STEER_CHANNELS + 3));
    return detail_luma_at(raw, hr, lr, lr_size, hr_size, u_detail_bound);
}

float upsampled_at(BilinearTaps t, int c) {
    return upsampled(lr_value(t.lo, c), lr_value(ivec2(t.hi.x, t.lo.y), c), lr_value(ivec2(t.lo.x, t.hi.y), c),
                     lr_value(t.hi, c), t.frac);
}

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(history);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    // u_scale 0: any scale, HR texels mapped to LR by the ratio of the two sizes
    BilinearTaps t = u_scale == 0 ? resize_taps(hr, textureSize(color, 0), size) : upsample_taps(hr, u_scale, textureSize(color, 0));
    float raw[6];
    for (int c = 0; c < 6; c++) {
        raw[c] = upsampled_at(t, c);
    }
    LrSteer s = steer_from_lr(raw, upsampled_at(t, STEER_CHANNELS), u_box_bound);
    float floor_gain = u_history_gain_min;
    if (u_still_motion_px > 0.0) {  // the motion is read only when the floor fades with it
        vec2 m = u_scale == 0 ? resized_motion_at(motion, hr, size) : upsampled_motion_at(motion, hr, u_scale);
        floor_gain = history_floor_of(m, u_history_gain_min, u_still_motion_px);
    }
    s.history_gain = max(s.history_gain, floor_gain);
    Neighbourhood n;
    vec3 spatial;
    if (u_scale == 0) {
        n = neighbourhood_ratio_at(color, hr, u_jitter, size, u_sample_sigma);
        spatial = spatial_ratio_at(color, hr, u_jitter, size);
    } else {
        n = neighbourhood_at(color, hr, u_jitter, u_scale, u_sample_sigma);
        spatial = spatial_at(color, hr, u_jitter, u_scale);
    }
    vec4 blended = fallback_blend(n, spatial, texelFetch(reprojected, hr, 0), s, u_prior_weight, u_max_weight);
    imageStore(history, hr, round_to_half(blended));
    vec3 shown = blended.rgb;
    if (u_detail_bound > 0.0) {  // luma only: (Y, 0, 0) in YCoCg adds Y to each of R, G and B
        shown = clamp(shown + detail_luma(hr, size), 0.0, 1.0);
    }
    imageStore(display, hr, encode_unorm8(vec4(shown, 1.0)));
}
