#version 310 es
// fsr2_rcas_pass: one invocation per HR texel (FSR2 step 5, RCAS; the history stays unsharpened).
//   in   image   HR rgba16f  fsr2_accumulate_pass's next_history
//   out  output  HR rgba16f  the sharpened output (rgb, in [0, 1])
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D image;
layout(rgba16f, binding = 0) uniform writeonly highp image2D output_image;

uniform float u_sharpness;

#include "fsr2.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(image, 0)))) {
        return;
    }
    imageStore(output_image, p, round_to_half(vec4(rcas_at(image, p, u_sharpness), 1.0)));
}
