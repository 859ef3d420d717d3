#version 330
// G-buffer and shadow pass vertex stage.  Motion uses the unjittered current and
// previous view-projection so the jitter never shows up in the motion vectors.
uniform mat4 model;
uniform mat4 prev_model;
uniform mat3 normal_matrix;
uniform mat4 view_proj;       // jittered (what is rasterised)
uniform mat4 cur_view_proj;   // unjittered
uniform mat4 prev_view_proj;  // unjittered, previous frame

in vec3 in_position;
in vec3 in_normal;
in vec2 in_uv;

out vec3 v_world;
out vec3 v_normal;
out vec2 v_uv;
out vec4 v_cur_clip;
out vec4 v_prev_clip;

void main() {
    vec4 world = model * vec4(in_position, 1.0);
    v_world = world.xyz;
    v_normal = normal_matrix * in_normal;
    v_uv = in_uv;
    v_cur_clip = cur_view_proj * world;
    v_prev_clip = prev_view_proj * (prev_model * vec4(in_position, 1.0));
    gl_Position = view_proj * world;
}
