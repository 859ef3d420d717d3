// Insert + pack (MNSS): I_AA written into the rectified history at this frame's sampled
// sub-pixels, quantized to the int8 NPU input, NHWC (1, H, W, 3), four bytes per 32-bit word
// (little-endian, so the buffer's bytes are the tensor).  Binding-free; mirrors
// ops.subpixel.insert_valid_samples (an I_AA texel of NO_SAMPLE, below 0, is not inserted) and
// ops.int8.quantize.quantize.

#include "common.glsl"
#include "quant.glsl"

// Channel `c` of the NPU input's HR pixel `hr`.
float npu_input_value(highp sampler2D rectified, highp sampler2DArray aa, ivec2 hr, int c, ivec2 subpixel, int scale) {
    if (is_sampled(hr, subpixel, scale)) {
        vec4 value = texelFetch(aa, ivec3(hr / scale, 0), 0);
        if (value.r >= 0.0) {
            return value[c];
        }
    }
    return texelFetch(rectified, hr, 0)[c];
}

// Word `i` of the packed tensor: bytes 4i .. 4i+3 of the NHWC layout (bytes past the end are 0).
uint npu_input_word(highp sampler2D rectified, highp sampler2DArray aa, int i, ivec2 subpixel, int scale,
                    QuantParams q) {
    ivec2 size = textureSize(rectified, 0);
    int total = size.x * size.y * NPU_CHANNELS;
    uint word = 0u;
    for (int k = 0; k < 4; k++) {
        int b = 4 * i + k;
        if (b >= total) {
            break;
        }
        int pixel = b / NPU_CHANNELS;
        ivec2 hr = ivec2(pixel % size.x, pixel / size.x);
        float x = npu_input_value(rectified, aa, hr, b % NPU_CHANNELS, subpixel, scale);
        word |= word_of_int8(quantize_int8(x, q), k);
    }
    return word;
}
