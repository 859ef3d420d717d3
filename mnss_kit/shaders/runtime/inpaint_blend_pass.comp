#version 310 es
// inpaint_blend_pass: one invocation per HR texel.
//   in   color      LR rgba16f  current jittered colour
//        warped     HR rgba16f  I_W (warp_pass); not read on a reset frame
//        lr_weight  LR r32f     inpaint_weights_pass; not read on a reset frame
//   out  rectified  HR rgba16f  I_R = M_w I_U + (1 - M_w) I_W (rgb; a = 1); I_U on a reset frame
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D warped;
layout(binding = 2) uniform highp sampler2D lr_weight;
layout(rgba16f, binding = 0) uniform writeonly highp image2D rectified;

uniform int u_scale;
uniform vec2 u_jitter;
uniform ivec2 u_subpixel;
uniform int u_weight_upsample;  // WEIGHT_UPSAMPLE_BILINEAR or WEIGHT_UPSAMPLE_NEAREST
uniform int u_reset;            // 1: camera cut or first frame, the history is ignored (M_w = 1)

#include "inpaint.glsl"

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(hr, imageSize(rectified)))) {
        return;
    }
    vec3 upsampled = jittered_upsample_input_at(color, hr, u_jitter, u_subpixel, u_scale, INPUT_COLOUR).rgb;
    vec3 result = upsampled;
    if (u_reset == 0) {
        float weight = inpaint_weight_map(lr_weight, hr, u_jitter, u_scale, u_weight_upsample);
        result = rectify(upsampled, texelFetch(warped, hr, 0).rgb, weight);
    }
    imageStore(rectified, hr, round_to_half(vec4(result, 1.0)));
}
