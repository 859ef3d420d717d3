#version 310 es
// conv3x3_pass: one invocation per LR texel and output layer (z); chain it for a conv stack.
//   in   x         LR rgba16f array  input channels, 4 per layer (unused channels 0)
//        residual  LR rgba16f        added by EPILOGUE_RESIDUAL_CLAMP (the LR colour; where it is
//                                    not finite the output is NO_SAMPLE, common.glsl)
//        weights   std430 vec4[]     packed float32 bias and weights (conv3x3.glsl)
//   out  y         LR rgba16f array  output channels, 4 per layer
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp sampler2DArray;
precision highp image2DArray;

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

layout(binding = 0) uniform highp sampler2DArray x;
layout(binding = 1) uniform highp sampler2D residual;
layout(std430, binding = 0) readonly buffer Weights { vec4 weights[]; };
layout(rgba16f, binding = 0) uniform writeonly highp image2DArray y;

uniform int u_in_layers;
uniform int u_out_layers;
uniform int u_epilogue;

vec4 conv_weight(int i) {
    return weights[i];
}

#include "conv3x3.glsl"

void main() {
    ivec3 id = ivec3(gl_GlobalInvocationID);
    if (any(greaterThanEqual(id.xy, textureSize(x, 0).xy)) || id.z >= u_out_layers) {
        return;
    }
    vec4 acc = conv3x3_at(x, id.xy, id.z, u_in_layers, u_out_layers);
    vec4 raw = u_epilogue == EPILOGUE_RESIDUAL_CLAMP ? texelFetch(residual, id.xy, 0) : vec4(0.0);
    vec4 v = conv3x3_epilogue(acc, u_epilogue, sanitize_colour(raw));
    if (u_epilogue == EPILOGUE_RESIDUAL_CLAMP && colour_not_finite(raw.rgb)) {
        v = vec4(NO_SAMPLE);
    }
    imageStore(y, id, round_to_half(v));
}
