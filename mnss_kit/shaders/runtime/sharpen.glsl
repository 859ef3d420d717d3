// Enhancement (MNSS): the unsharp kernel of ops.sharpen on the displayed output,
//   [[-b, 0, -b], [0, 1 + 4b, 0], [-b, 0, -b]], border texels repeated, clamped to [0, 1].
// Binding-free.

#include "common.glsl"

vec3 unsharp_at(highp sampler2D image, ivec2 p, float beta) {
    ivec2 last = textureSize(image, 0) - 1;
    vec3 centre = texelFetch(image, p, 0).rgb;
    vec3 diagonals = texelFetch(image, clamp(p + ivec2(-1, -1), ivec2(0), last), 0).rgb
                   + texelFetch(image, clamp(p + ivec2(1, -1), ivec2(0), last), 0).rgb
                   + texelFetch(image, clamp(p + ivec2(-1, 1), ivec2(0), last), 0).rgb
                   + texelFetch(image, clamp(p + ivec2(1, 1), ivec2(0), last), 0).rgb;
    return clamp((1.0 + 4.0 * beta) * centre - beta * diagonals, 0.0, 1.0);
}
