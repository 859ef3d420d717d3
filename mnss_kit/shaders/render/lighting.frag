#version 330
// Deferred lighting.  With diffuse albedo a = albedo (1 - metallic), specular
// term s = F0 A + B (split-sum LUT at N.V, roughness) and F_beta = a + s:
//   Ld = sky irradiance + sun E (N.L) shadow / pi                 (diffuse light)
//   Ls = prefiltered sky + sun GGX lobe (D Vis F) E (N.L) shadow / s (specular light)
//   colour = emissive + a Ld + s Ls = emissive + F_beta L,  L = (a Ld + s Ls) / F_beta
// Sky pixels have F_beta = 0 and colour = emissive (the sky radiance).
#include "sky.glsl"
uniform sampler2D g_albedo;
uniform sampler2D g_normal_rough;
uniform sampler2D g_emissive_metal;
uniform sampler2D g_position;
uniform sampler2D brdf_lut;        // (A, B); u = N.V, v = roughness
uniform sampler2DShadow shadow_map;
uniform mat4 shadow_matrix;        // world -> shadow texture [0,1]^3
uniform float shadow_texel;        // world size of one shadow texel
uniform vec3 camera_position;

layout(location = 0) out vec4 out_color;
#ifndef COLOUR_ONLY  // the reference supersamples need colour only
layout(location = 1) out vec4 out_fbeta;
layout(location = 2) out vec4 out_emissive;
#endif

const float PI = 3.14159265358979;

float shadow_visibility(vec3 p, vec3 n) {
    vec3 q = p + n * (1.5 * shadow_texel);
    vec4 s = shadow_matrix * vec4(q, 1.0);
    if (s.x <= 0.0 || s.x >= 1.0 || s.y <= 0.0 || s.y >= 1.0 || s.z >= 1.0) return 1.0;
    // four bilinear depth-compare taps half a texel apart: a 3x3-texel tent filter
    vec2 texel = 0.5 / vec2(textureSize(shadow_map, 0));
    float ref = s.z - 0.0005;
    float sum = texture(shadow_map, vec3(s.xy + vec2(-texel.x, -texel.y), ref))
              + texture(shadow_map, vec3(s.xy + vec2(texel.x, -texel.y), ref))
              + texture(shadow_map, vec3(s.xy + vec2(-texel.x, texel.y), ref))
              + texture(shadow_map, vec3(s.xy + vec2(texel.x, texel.y), ref));
    return 0.25 * sum;
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 position = texelFetch(g_position, px, 0);
    vec4 em = texelFetch(g_emissive_metal, px, 0);
    if (position.w == 0.0) {  // sky
        out_color = vec4(em.rgb, 1.0);
#ifndef COLOUR_ONLY
        out_fbeta = vec4(0.0);
        out_emissive = vec4(em.rgb, 0.0);
#endif
        return;
    }
    vec3 albedo = texelFetch(g_albedo, px, 0).rgb;
    vec4 nr = texelFetch(g_normal_rough, px, 0);
    vec3 n = nr.xyz / max(length(nr.xyz), 1e-6);
    float rough = clamp(nr.w, 0.03, 1.0);
    float metal = em.w;
    vec3 v = normalize(camera_position - position.xyz);
    float nv = clamp(dot(n, v), 1e-4, 1.0);

    vec3 diffuse_albedo = albedo * (1.0 - metal);
    vec3 f0 = mix(vec3(0.04), albedo, metal);
    vec2 ab = texture(brdf_lut, vec2(nv, rough)).rg;
    vec3 spec_term = f0 * ab.x + ab.y;

    vec3 l = sun_direction;
    float nl = max(dot(n, l), 0.0);
    vec3 sun = sun_color * nl * (nl > 0.0 ? shadow_visibility(position.xyz, n) : 0.0);
    vec3 h = (v + l) / max(length(v + l), 1e-6);
    float nh = max(dot(n, h), 0.0);
    float a2 = rough * rough * rough * rough;  // GGX alpha^2, alpha = roughness^2
    float dd = nh * nh * (a2 - 1.0) + 1.0;
    float D = a2 / (PI * dd * dd);
    float vis = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2) + 1e-7);
    float fc = clamp(1.0 - dot(v, h), 0.0, 1.0);
    float fc2 = fc * fc;
    vec3 F = f0 + (1.0 - f0) * (fc2 * fc2 * fc);

    vec3 diffuse_light = sky_irradiance(n) + sun / PI;
    vec3 specular_radiance = sky_prefiltered(reflect(-v, n), rough) * spec_term + D * vis * F * sun;
    vec3 fbeta = diffuse_albedo + spec_term;
    out_color = vec4(em.rgb + diffuse_albedo * diffuse_light + specular_radiance, 1.0);
#ifndef COLOUR_ONLY
    out_fbeta = vec4(fbeta, 0.0);
    out_emissive = vec4(em.rgb, 0.0);
#endif
}
