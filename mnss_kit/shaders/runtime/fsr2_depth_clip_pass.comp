#version 310 es
// fsr2_depth_clip_pass: one invocation per LR texel (FSR2 step 2, depth clip; and the thin
// features that create locks).
//   in   dilated         LR rgba32f     fsr2_reconstruct_pass
//        color           LR rgba16f     jittered LR colour, display values
//        previous_depth  std430 uint[]  fsr2_reconstruct_pass
//   out  analysis        LR rgba32f     disocclusion in [0, 1] (x), thin feature 0 or 1 (y)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D dilated;
layout(binding = 1) uniform highp sampler2D color;
layout(std430, binding = 0) readonly buffer PreviousDepth { uint previous_depth[]; };
layout(rgba32f, binding = 0) uniform writeonly highp image2D analysis;

uniform float u_depth_tolerance;
uniform float u_slope_factor;
uniform float u_lock_contrast;

#include "fsr2.glsl"

void main() {
    ivec2 lr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(dilated, 0);
    if (any(greaterThanEqual(lr, size))) {
        return;
    }
    vec3 d = texelFetch(dilated, lr, 0).xyz;
    float tolerance = max(u_depth_tolerance * d.x + u_slope_factor * depth_slope_at(dilated, lr), 1e-6);
    // the bilinear mix of the clip over the footprint at the previous position (ops.fsr2.disocclusion)
    vec2 f = vec2(lr) + 0.5 + d.yz - 0.5;
    vec2 base = floor(f);
    vec2 t = f - base;
    float clip = 0.0;
    for (int oy = 0; oy <= 1; oy++) {
        float wy = oy == 0 ? 1.0 - t.y : t.y;
        for (int ox = 0; ox <= 1; ox++) {
            float wx = ox == 0 ? 1.0 - t.x : t.x;
            ivec2 q = ivec2(clamp(base + vec2(float(ox), float(oy)), vec2(0.0), vec2(size - 1)));
            float previous = decode_depth(previous_depth[q.y * size.x + q.x]);
            clip += (wy * wx) * clamp((d.x - previous - tolerance) / tolerance, 0.0, 1.0);
        }
    }
    imageStore(analysis, lr, vec4(clip, thin_feature_at(color, lr, u_lock_contrast), 0.0, 0.0));
}
