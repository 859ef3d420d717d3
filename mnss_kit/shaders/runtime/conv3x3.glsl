// Generic 3x3 convolution (stride 1, zero padding 1, bias) on images stored as layers of four
// channels.  Binding-free: the entry file defines `vec4 conv_weight(int i)`, which reads the
// packed float32 weights (mnss_kit/gpu/weights.py, pack_conv3x3):
//
//   vec4 [0, out_layers)                      bias of output channels 4*og .. 4*og+3
//   vec4 out_layers + conv_weight_index(...)  weights of one input channel to 4 output channels

#include "common.glsl"

int conv_weight_index(int og, int tap, int il, int k, int in_layers, int out_layers) {
    return out_layers + ((og * 9 + tap) * in_layers + il) * 4 + k;
}

// Accumulator (bias + taps) of output channels 4*og .. 4*og+3 at LR texel `p`.
vec4 conv3x3_at(highp sampler2DArray x, ivec2 p, int og, int in_layers, int out_layers) {
    ivec2 size = textureSize(x, 0).xy;
    vec4 acc = conv_weight(og);
    for (int tap = 0; tap < 9; tap++) {
        ivec2 q = p + ivec2(tap % 3 - 1, tap / 3 - 1);
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) {
            continue;  // zero padding
        }
        for (int il = 0; il < in_layers; il++) {
            vec4 v = texelFetch(x, ivec3(q, il), 0);
            int w = conv_weight_index(og, tap, il, 0, in_layers, out_layers);
            acc += conv_weight(w) * v.x;
            acc += conv_weight(w + 1) * v.y;
            acc += conv_weight(w + 2) * v.z;
            acc += conv_weight(w + 3) * v.w;
        }
    }
    return acc;
}

const int EPILOGUE_NONE = 0;
const int EPILOGUE_RELU = 1;
const int EPILOGUE_RESIDUAL_CLAMP = 2;  // clamp(residual + acc, 0, 1): the AA net's last layer

vec4 conv3x3_epilogue(vec4 acc, int epilogue, vec4 residual) {
    if (epilogue == EPILOGUE_RELU) {
        return max(acc, vec4(0.0));
    }
    if (epilogue == EPILOGUE_RESIDUAL_CLAMP) {
        return clamp(residual + acc, 0.0, 1.0);
    }
    return acc;
}
