// Inpainting (MNSS), HR part: the weight map M_w from the LR weights and the rectified history
// M_w I_U + (1 - M_w) I_W.  Binding-free; mirrors mnss_kit/ops/inpaint.py.

#include "common.glsl"

const int ACTIVATION_SIGMOID = 0;
const int ACTIVATION_TANH = 1;  // tanh clipped to [0, 1]
const int WEIGHT_UPSAMPLE_BILINEAR = 0;  // bilinear at the jittered sample positions
const int WEIGHT_UPSAMPLE_NEAREST = 1;   // replicate over the s x s tile

// M_w at HR texel `hr` from the LR weights.
float inpaint_weight_map(highp sampler2D lr_weight, ivec2 hr, vec2 jitter, int scale, int mode) {
    if (mode == WEIGHT_UPSAMPLE_NEAREST) {
        return texelFetch(lr_weight, hr / scale, 0).x;
    }
    return bilinear_sample(lr_weight, (vec2(hr) + 0.5) / float(scale) - jitter).x;
}

// I_R = M_w I_U + (1 - M_w) I_W.
vec3 rectify(vec3 upsampled, vec3 warped, float weight) {
    return weight * upsampled + (1.0 - weight) * warped;
}
