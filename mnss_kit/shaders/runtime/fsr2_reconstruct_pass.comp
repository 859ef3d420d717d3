#version 310 es
// fsr2_reconstruct_pass: one invocation per LR texel (FSR2 step 1, reconstruct and dilate).
//   in   depth           LR r32f    canonical depth (linear, [0, 1], larger is farther)
//        motion          LR rg32f   LR motion, LR pixels, pointing to the previous frame
//   out  dilated         LR rgba32f the nearest 3x3 neighbour's depth (x) and motion (yz) across
//                                   a depth edge (u_dilation_edge), else the texel's own
//        previous_depth  std430 uint[]  one word per LR texel, row-major: the reconstructed
//                                       previous depth (fsr2.glsl encode_depth), atomicMax of
//                                       every surface landing there; must hold 0 before the
//                                       pass (fsr2_accumulate_pass clears it for the next frame)
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D depth;
layout(binding = 1) uniform highp sampler2D motion;
layout(rgba32f, binding = 0) uniform writeonly highp image2D dilated;
layout(std430, binding = 0) buffer PreviousDepth { uint previous_depth[]; };

uniform float u_dilation_edge;

#include "fsr2.glsl"

void main() {
    ivec2 lr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = textureSize(depth, 0);
    if (any(greaterThanEqual(lr, size))) {
        return;
    }
    vec3 d = dilated_at(depth, motion, lr, u_dilation_edge);
    imageStore(dilated, lr, vec4(d, 0.0));
    // scatter to the four texels of the bilinear footprint in the previous frame (ops.fsr2.scatter_targets)
    vec2 f = vec2(lr) + 0.5 + d.yz - 0.5;
    vec2 base = floor(f);
    vec2 t = f - base;
    uint encoded = encode_depth(d.x);
    for (int oy = 0; oy <= 1; oy++) {
        float wy = oy == 0 ? 1.0 - t.y : t.y;
        for (int ox = 0; ox <= 1; ox++) {
            float wx = ox == 0 ? 1.0 - t.x : t.x;
            vec2 target = base + vec2(float(ox), float(oy));
            if (wy * wx > 0.0 && all(greaterThanEqual(target, vec2(0.0))) && all(lessThan(target, vec2(size)))) {
                ivec2 q = ivec2(target);
                atomicMax(previous_depth[q.y * size.x + q.x], encoded);
            }
        }
    }
}
