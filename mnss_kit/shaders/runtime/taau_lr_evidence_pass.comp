#version 310 es
// taau_lr_evidence_pass: one invocation per LR texel.
//   in   depth       LR r32f     this frame's depth
//        prev_depth  LR r32f     the last frame's depth (not read on a reset: this depth stands in)
//        motion      LR rg32f    LR motion, LR pixels
//   out  evidence    LR rgba32f  the depth change (r), the motion spread (g), the trust (b), 0 (a)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D depth;
layout(binding = 1) uniform highp sampler2D prev_depth;
layout(binding = 2) uniform highp sampler2D motion;
layout(rgba32f, binding = 0) uniform writeonly highp image2D evidence;

uniform int u_reset;
uniform float u_trust_depth;
uniform float u_trust_spread_px;

#include "taau_lr.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, textureSize(depth, 0)))) {
        return;
    }
    vec2 m = motion_texel(motion, p);
    float reprojected = u_reset != 0 ? reprojected_nearest_depth(depth, p, m) : reprojected_nearest_depth(prev_depth, p, m);
    float change = depth_change(depth_texel(depth, p), reprojected);
    float spread = motion_spread_at(motion, p);
    imageStore(evidence, p, vec4(change, spread, trust_of(change, spread, u_trust_depth, u_trust_spread_px), 0.0));
}
