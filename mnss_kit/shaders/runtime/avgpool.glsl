// Anti-aliasing net input (MNSS): [avgpool(I_R) to LR, LR colour], six channels in two layers of
// four: (pool.r, pool.g, pool.b, color.r), (color.g, color.b, 0, 0).  Binding-free; mirrors
// ops.resample.avgpool.

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
