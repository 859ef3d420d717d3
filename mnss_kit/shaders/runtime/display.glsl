// Display encoding: 8-bit codes for an rgba8 (UNORM) display image.  Binding-free.

#include "quant.glsl"

// Display value in [0, 1] -> 8-bit code: rint(clamp(v, 0, 1) * 255) (mnss_kit.gpu.reference.encode_unorm8),
// returned as code / 255 so an rgba8 store reproduces the code under any conversion rounding.
vec4 encode_unorm8(vec4 v) {
    vec4 codes;
    for (int c = 0; c < 4; c++) {
        float t = pack_float(mul_rne(unpack_float(clamp(v[c], 0.0, 1.0)), unpack_float(255.0)));
        codes[c] = roundEven(t);
    }
    return codes / 255.0;
}
