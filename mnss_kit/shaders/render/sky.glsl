// Procedural sky: the environment for image-based lighting and the background.
uniform vec3 sky_zenith;
uniform vec3 sky_horizon;
uniform vec3 sky_ground;
uniform vec3 sun_direction;    // unit, towards the sun
uniform vec3 sun_color;        // irradiance of the directional light

vec3 sky_radiance(vec3 d, bool with_sun) {
    float h = d.y;
    vec3 c = h >= 0.0 ? mix(sky_horizon, sky_zenith, sqrt(sqrt(max(h, 0.0))) * 0.4 + max(h, 0.0) * 0.6)
                      : mix(sky_horizon, sky_ground, clamp(-h * 6.0, 0.0, 1.0));
    float s = max(dot(d, sun_direction), 0.0);
    float s4 = s * s * s * s;  // s^12 by multiplication: pow() is costly on a CPU rasteriser
    c += sun_color * (0.08 * s4 * s4 * s4);
    if (with_sun && s > 0.9995) c += sun_color * 8.0;
    return c;
}

// Cosine-weighted sky irradiance / pi for normal n: a hemisphere blend.
vec3 sky_irradiance(vec3 n) {
    float t = 0.5 + 0.5 * n.y;
    return mix(sky_ground * 0.9 + sky_horizon * 0.1, 0.5 * (sky_zenith + sky_horizon), t);
}

// Pre-filtered environment along reflection r for perceptual roughness.
vec3 sky_prefiltered(vec3 r, float roughness) {
    return mix(sky_radiance(r, false), sky_irradiance(r), clamp(roughness * 1.3, 0.0, 1.0));
}
