// Inpainting (MNSS), LR part: the learned 3x3 conv (4 -> 1 channels, with bias) on the
// disagreement of this frame's samples with the warped history, then sigmoid or tanh clipped to
// [0, 1].  Binding-free; mirrors mnss_kit/ops/inpaint.py (lr_weights).  The entry file defines
// `vec4 conv_weight(int i)` reading the conv packed as in conv3x3.glsl (only .x is used).

#include "common.glsl"
#include "conv3x3.glsl"
#include "inpaint.glsl"

// |current - warped history| at LR texel `p`: (r, g, b, depth), the history read at this
// frame's sampled sub-pixel.
vec4 inpaint_difference(highp sampler2D color, highp sampler2D depth, highp sampler2D warped,
                        highp sampler2D warped_depth, ivec2 p, ivec2 subpixel, int scale) {
    vec3 past = texelFetch(warped, p * scale + subpixel, 0).rgb;
    float past_depth = texelFetch(warped_depth, p, 0).x;
    return vec4(abs(colour_texel(color, p) - past), abs(depth_texel(depth, p) - past_depth));
}

// LR weight in [0, 1] at LR texel `p` (1 = take the current frame, 0 = keep the history).
float inpaint_lr_weight(highp sampler2D color, highp sampler2D depth, highp sampler2D warped,
                        highp sampler2D warped_depth, ivec2 p, ivec2 subpixel, int scale, int activation) {
    ivec2 size = textureSize(color, 0);
    float acc = conv_weight(0).x;
    for (int tap = 0; tap < 9; tap++) {
        ivec2 q = p + ivec2(tap % 3 - 1, tap / 3 - 1);
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) {
            continue;  // the conv zero-pads the difference image
        }
        vec4 v = inpaint_difference(color, depth, warped, warped_depth, q, subpixel, scale);
        int w = conv_weight_index(0, tap, 0, 0, 1, 1);
        acc += conv_weight(w).x * v.x;
        acc += conv_weight(w + 1).x * v.y;
        acc += conv_weight(w + 2).x * v.z;
        acc += conv_weight(w + 3).x * v.w;
    }
    if (activation == ACTIVATION_TANH) {
        return clamp(tanh(acc), 0.0, 1.0);
    }
    return 1.0 / (1.0 + exp(-acc));
}

