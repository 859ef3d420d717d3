#version 330
// Shadow map pass: positions into the light's orthographic clip space.
uniform mat4 model;
uniform mat4 light_view_proj;
in vec3 in_position;
in vec2 in_uv;
out vec2 v_uv;
void main() {
    v_uv = in_uv;
    gl_Position = light_view_proj * (model * vec4(in_position, 1.0));
}
