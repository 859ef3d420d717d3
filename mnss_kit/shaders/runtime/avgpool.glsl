// Anti-aliasing net input (MNSS): [avgpool(I_R) to LR, LR colour], six channels in two layers of
// four: (pool.rgb, color.r), (color.gb, 0, 0).  With the history at the samples (not in the
// paper), [avgpool(I_R), I_R at this frame's sampled sub-pixels, LR colour], nine channels in three
// layers: (pool.rgb, sample.r), (sample.gb, color.rg), (color.b, 0, 0, 0).  Binding-free; mirrors
// ops.resample.avgpool and ops.subpixel.extract_samples.

#include "common.glsl"

// Mean of the s x s tile of HR texels over LR texel `p`.
vec3 tile_mean(highp sampler2D hr, ivec2 p, int scale) {
    vec3 sum = vec3(0.0);
    for (int dy = 0; dy < scale; dy++) {
        for (int dx = 0; dx < scale; dx++) {
            sum += texelFetch(hr, p * scale + ivec2(dx, dy), 0).rgb;
        }
    }
    return sum / float(scale * scale);
}

// The HR texel of LR texel `p` that this frame samples.
vec3 sampled_texel(highp sampler2D hr, ivec2 p, ivec2 subpixel, int scale) {
    return texelFetch(hr, p * scale + subpixel, 0).rgb;
}
