#version 330
// Camera-facing additive particles (no depth write, no motion vectors).
uniform mat4 view_proj;        // jittered
uniform vec3 camera_right;
uniform vec3 camera_up;
in vec2 in_corner;             // per vertex: quad corner in [-1, 1]^2
in vec4 in_center_size;        // per instance: world centre, radius
in vec3 in_color;              // per instance: emitted radiance
out vec2 v_corner;
out vec3 v_color;
void main() {
    vec3 p = in_center_size.xyz + (camera_right * in_corner.x + camera_up * in_corner.y) * in_center_size.w;
    v_corner = in_corner;
    v_color = in_color;
    gl_Position = view_proj * vec4(p, 1.0);
}
