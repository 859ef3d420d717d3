#version 310 es
// fsr2_accumulate_pass: one invocation per HR texel (FSR2 steps 3 and 4, locks and accumulation).
//   in   color           LR rgba16f     jittered LR colour, display values
//        dilated         LR rgba32f     fsr2_reconstruct_pass (motion in yz, upsampled bilinearly)
//        analysis        LR rgba32f     fsr2_depth_clip_pass
//        history         HR rgba16f     the previous output (rgb) and its accumulated weight (a)
//        locks           HR rgba16f     the previous lock lifetime (x) and locked luma (y)
//        reactive        LR r32f        optional reactive mask in [0, 1] (read when u_use_reactive)
//   out  next_history    HR rgba16f     this frame's output (rgb, in [0, 1]) and its weight (a)
//        next_locks      HR rgba16f     the locks after this frame
//        previous_depth  std430 uint[]  cleared (0) for the next frame's fsr2_reconstruct_pass
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp image2D;

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform highp sampler2D color;
layout(binding = 1) uniform highp sampler2D dilated;
layout(binding = 2) uniform highp sampler2D analysis;
layout(binding = 3) uniform highp sampler2D history;
layout(binding = 4) uniform highp sampler2D locks;
layout(binding = 5) uniform highp sampler2D reactive;
layout(rgba16f, binding = 0) uniform writeonly highp image2D next_history;
layout(rgba16f, binding = 1) uniform writeonly highp image2D next_locks;
layout(std430, binding = 0) writeonly buffer PreviousDepth { uint previous_depth[]; };

uniform int u_scale;
uniform vec2 u_jitter;
uniform int u_reset;
uniform int u_use_reactive;
uniform float u_max_weight;
uniform float u_gamma;
uniform float u_resample_penalty;
uniform float u_kernel_width;
uniform float u_prior_weight;
uniform float u_lock_decay;
uniform float u_lock_luma_tolerance;

#include "fsr2.glsl"

void main() {
    ivec2 hr = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(next_history);
    if (any(greaterThanEqual(hr, size))) {
        return;
    }
    ivec2 lr_size = textureSize(color, 0);
    if (all(lessThan(hr, lr_size))) {
        previous_depth[hr.y * lr_size.x + hr.x] = 0u;
    }
    ivec2 cell = hr / u_scale;
    SamplePlace place = sample_place(hr, lr_size, u_jitter, u_scale);
    vec4 samples = reconstruct_samples_at(color, place, u_scale, u_kernel_width);
    float sample_weight = samples.a;
    vec3 upsampled = lanczos_upsample_at(color, place);
    Box box = variance_box_at(color, place.nearest, u_gamma);
    Reprojected r = reproject_at(history, locks, bilinear_sample(dilated, (vec2(hr) + 0.5) / float(u_scale)).yz * float(u_scale), hr, u_reset != 0);
    float weight = r.weight * max(1.0 - u_resample_penalty * r.spread, 0.0);
    float disoccluded = texelFetch(analysis, cell, 0).x;
    float reactivity = u_use_reactive != 0 ? texelFetch(reactive, cell, 0).x : 0.0;
    bool thin = texelFetch(analysis, place.nearest, 0).y > 0.5;
    vec2 lock = update_lock(r.lock, samples.x, disoccluded, thin, place.owner, u_lock_decay, u_lock_luma_tolerance);
    float trust = lock.x * (1.0 - disoccluded);
    vec3 clamped = min(max(r.colour, box.lo), box.hi);
    vec3 previous = clamped + trust * (r.colour - clamped);
    weight = weight * (1.0 - disoccluded) * (1.0 - reactivity);
    float prior = u_prior_weight * exp(-PRIOR_FADE * weight);
    vec3 blended = (weight * previous + sample_weight * samples.rgb + prior * upsampled) / (weight + sample_weight + prior);
    vec3 rgb = clamp(ycocg_to_rgb(blended), 0.0, 1.0);
    imageStore(next_history, hr, round_to_half(vec4(rgb, min(weight + sample_weight, u_max_weight))));
    imageStore(next_locks, hr, round_to_half(vec4(lock, 0.0, 0.0)));
}
