#version 310 es
// sharpen_pass: one invocation per HR texel (optional; only with enhancement on).
//   in   image    HR rgba16f  I_SS (the history written by unpack_history_pass)
//   out  display  HR rgba8    sharpened 8-bit display codes
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D image;
layout(rgba8, binding = 0) uniform writeonly highp image2D display;

uniform float u_beta;

#include "sharpen.glsl"
#include "display.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(image, 0)))) {
        return;
    }
    imageStore(display, p, encode_unorm8(vec4(unsharp_at(image, p, u_beta), 1.0)));
}
