#version 330
// Shadow map pass: depth only, with the same alpha test as the G-buffer pass.
uniform sampler2D base_texture;
uniform int alpha_test;
uniform float alpha_cutoff;
in vec2 v_uv;
void main() {
    if (alpha_test == 1 && texture(base_texture, v_uv).a < alpha_cutoff) discard;
}
