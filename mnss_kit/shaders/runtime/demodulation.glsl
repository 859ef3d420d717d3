// BRDF demodulation and remodulation (reduced FuseSR), per RGB channel in linear light, as
// mnss_kit.ops.demodulation and mnss_kit.ops.colour (to_display / from_display, exposure 1).
// Binding-free.  pow() is the driver's: these are float paths, compared with the numpy
// reference within a stated tolerance (tests/gpu/test_fusesr_passes.py).

const float FBETA_EPSILON = 1e-3;  // ops.demodulation.FBETA_EPSILON: below it nothing is divided
const float TONEMAP_MAX = 0.999;   // ops.colour.TONEMAP_MAX: the largest tone-mapped value inverted

// Reinhard x / (1 + x), then the sRGB encoding (ops.colour.to_display).
vec3 to_display(vec3 linear) {
    vec3 x = max(linear, vec3(0.0));
    vec3 t = clamp(x / (1.0 + x), 0.0, 1.0);
    vec3 curve = 1.055 * pow(max(t, vec3(0.0031308)), vec3(1.0 / 2.4)) - 0.055;
    return mix(curve, 12.92 * t, lessThanEqual(t, vec3(0.0031308)));
}

// sRGB decoding, then the inverse Reinhard t / (1 - t) below TONEMAP_MAX (ops.colour.from_display).
vec3 from_display(vec3 display) {
    vec3 d = clamp(display, 0.0, 1.0);
    vec3 curve = pow((max(d, vec3(0.04045)) + 0.055) / 1.055, vec3(2.4));
    vec3 t = min(mix(curve, d / 12.92, lessThanEqual(d, vec3(0.04045))), vec3(TONEMAP_MAX));
    return t / (1.0 - t);
}

// Display-encoded L = (colour - emissive) / F_beta; 0 where F_beta < FBETA_EPSILON.
vec3 demodulate(vec3 color, vec3 fbeta, vec3 emissive) {
    vec3 lit = max(from_display(color) - emissive, vec3(0.0));
    vec3 l = to_display(lit / max(fbeta, vec3(FBETA_EPSILON)));
    return mix(l, vec3(0.0), lessThan(fbeta, vec3(FBETA_EPSILON)));
}

// Display colour of F_beta * L + emissive; emissive alone where F_beta < FBETA_EPSILON.
vec3 remodulate(vec3 l, vec3 fbeta, vec3 emissive) {
    vec3 reflected = mix(fbeta * from_display(l), vec3(0.0), lessThan(fbeta, vec3(FBETA_EPSILON)));
    return to_display(max(reflected + emissive, vec3(0.0)));
}
