// G-buffer unshuffle + pack (FuseSR): the int8 NPU input at LR, NHWC (1, h, w, C), four bytes
// per 32-bit word (little-endian).  Channels, in order (ops.demodulation.pixel_unshuffle for
// the HR images: channel k*s*s + dy*s + dx of LR texel (i, j) is HR texel (s*j + dx, s*i + dy)):
//   3            L (layer 0 of `l`)
//   F            encoder features (layers of `features`)
//   3 s^2        the warped history, with u_history (0 on a reset frame)
//   3 s^2 ...    the HR G-buffers of u_gbuffers, bit 0 F_beta, 1 normal, 2 depth (1 channel),
//                3 albedo
// Binding-free: the entry file declares the samplers named here.

#include "common.glsl"
#include "quant.glsl"

const int GBUFFER_COUNT = 4;

int gbuffer_channels(int g) {
    return g == 2 ? 1 : 3;
}

float gbuffer_value(int g, ivec2 hr, int c) {
    // every G-buffer sanitized on read (common.glsl, ops.sanitize)
    if (g == 0) return sanitize_gbuffer(texelFetch(fbeta, hr, 0)[c]);
    if (g == 1) return sanitize_gbuffer(texelFetch(normal, hr, 0)[c]);
    if (g == 2) return depth_texel(depth, hr);
    return sanitize_gbuffer(texelFetch(albedo, hr, 0)[c]);
}

// Channel `c` of unshuffled HR image texel p: (channel, sub-pixel) of the HR texel it holds.
ivec3 unshuffled(int c, ivec2 p, int scale) {
    int s2 = scale * scale;
    int sub = c % s2;
    return ivec3(p * scale + ivec2(sub % scale, sub / scale), c / s2);
}

int npu_channels(int n_features, int scale, int history, int gbuffers) {
    int n = 3 + n_features + (history != 0 ? 3 * scale * scale : 0);
    for (int g = 0; g < GBUFFER_COUNT; g++) {
        if ((gbuffers & (1 << g)) != 0) n += gbuffer_channels(g) * scale * scale;
    }
    return n;
}

float npu_input_value(ivec2 p, int c, int n_features, int scale, int history, int reset, int gbuffers) {
    if (c < 3) return texelFetch(l, ivec3(p, 0), 0)[c];
    c -= 3;
    if (c < n_features) return texelFetch(features, ivec3(p, c / 4), 0)[c % 4];
    c -= n_features;
    int s2 = scale * scale;
    if (history != 0) {
        if (c < 3 * s2) {
            ivec3 at = unshuffled(c, p, scale);
            return reset != 0 ? 0.0 : texelFetch(warped, at.xy, 0)[at.z];
        }
        c -= 3 * s2;
    }
    for (int g = 0; g < GBUFFER_COUNT; g++) {
        if ((gbuffers & (1 << g)) == 0) continue;
        int n = gbuffer_channels(g) * s2;
        if (c < n) {
            ivec3 at = unshuffled(c, p, scale);
            return gbuffer_value(g, at.xy, at.z);
        }
        c -= n;
    }
    return 0.0;
}

uint npu_input_word(int i, ivec2 lr_size, int n_features, int scale, int history, int reset, int gbuffers, QuantParams q) {
    int channels = npu_channels(n_features, scale, history, gbuffers);
    int total = lr_size.x * lr_size.y * channels;
    uint word = 0u;
    for (int k = 0; k < 4; k++) {
        int b = 4 * i + k;
        if (b >= total) {
            break;
        }
        int pixel = b / channels;
        ivec2 p = ivec2(pixel % lr_size.x, pixel / lr_size.x);
        float x = npu_input_value(p, b % channels, n_features, scale, history, reset, gbuffers);
        word |= word_of_int8(quantize_int8(x, q), k);
    }
    return word;
}
