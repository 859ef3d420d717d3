#version 330
// Deferred G-buffer pass: material and geometry attributes into five targets.
#include "motion.glsl"
uniform sampler2D base_texture;
uniform vec3 base_color;       // linear, multiplies the texture
uniform float roughness;
uniform float metallic;
uniform vec3 emissive;
uniform int alpha_test;        // 1: discard below alpha_cutoff (fences, foliage)
uniform float alpha_cutoff;
uniform float mip_bias;        // log2(1 / scale) at LR so texture detail matches HR
uniform vec2 target_size;      // pixels of this target

in vec3 v_world;
in vec3 v_normal;
in vec2 v_uv;
in vec4 v_cur_clip;
in vec4 v_prev_clip;

layout(location = 0) out vec4 out_albedo;          // rgb linear albedo
layout(location = 1) out vec4 out_normal_rough;    // world normal, roughness
layout(location = 2) out vec4 out_emissive_metal;  // emissive radiance, metallic
layout(location = 3) out vec4 out_position;        // world position, 1 = surface
layout(location = 4) out vec4 out_motion_depth;    // motion (px, +y down, to previous), depth

void main() {
    vec4 tex = texture(base_texture, v_uv, mip_bias);  // sRGB texture: decoded to linear
    if (alpha_test == 1 && tex.a < alpha_cutoff) discard;
    float len = length(v_normal);
    vec3 n = len > 1e-8 ? v_normal / len : vec3(0.0, 1.0, 0.0);  // degenerate (pole) normals
    if (!gl_FrontFacing) n = -n;
    vec2 motion = motion_to_previous(v_cur_clip, v_prev_clip, target_size);
    out_albedo = vec4(base_color * tex.rgb, 1.0);
    out_normal_rough = vec4(n, roughness);
    out_emissive_metal = vec4(emissive, metallic);
    out_position = vec4(v_world, 1.0);
    out_motion_depth = vec4(motion, gl_FragCoord.z, 0.0);
}
