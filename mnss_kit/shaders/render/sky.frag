#version 330
// Sky in the G-buffer pass: drawn at the far plane where no geometry is, writes the
// sky radiance as emissive and the rotation-only motion of a point at infinity.
#include "sky.glsl"
#include "motion.glsl"
uniform mat4 inv_view_proj_rot;   // inverse of jittered proj * rotation-only view
uniform mat4 cur_view_proj_rot;   // unjittered, rotation only
uniform mat4 prev_view_proj_rot;
uniform vec2 target_size;

layout(location = 0) out vec4 out_albedo;
layout(location = 1) out vec4 out_normal_rough;
layout(location = 2) out vec4 out_emissive_metal;
layout(location = 3) out vec4 out_position;
layout(location = 4) out vec4 out_motion_depth;

void main() {
    vec2 ndc = gl_FragCoord.xy / target_size * 2.0 - 1.0;
    vec4 p = inv_view_proj_rot * vec4(ndc, 1.0, 1.0);
    vec3 d = normalize(p.xyz / p.w);
    vec2 motion = motion_to_previous(cur_view_proj_rot * vec4(d, 0.0), prev_view_proj_rot * vec4(d, 0.0), target_size);
    out_albedo = vec4(0.0);
    out_normal_rough = vec4(0.0);
    out_emissive_metal = vec4(sky_radiance(d, true), 0.0);
    out_position = vec4(0.0);
    out_motion_depth = vec4(motion, 1.0, 0.0);
}
