#version 330
in vec2 v_corner;
in vec3 v_color;
layout(location = 0) out vec4 out_color;
layout(location = 1) out vec4 out_fbeta;
layout(location = 2) out vec4 out_emissive;
void main() {
    float r2 = dot(v_corner, v_corner);
    if (r2 >= 1.0) discard;
    float falloff = (1.0 - r2) * (1.0 - r2);
    vec3 c = v_color * falloff;
    out_color = vec4(c, 0.0);
    out_fbeta = vec4(0.0);
    out_emissive = vec4(c, 0.0);  // additive light: keeps colour = emissive + F_beta L
}
