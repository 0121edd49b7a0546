// torchirid shader functions — GLSL ES 3.00 (WebGL2); plain GLSL, copy it into any engine.
//
// Colour textures fitted by torchirid.realtime.fit_texture (luts/build_shader_textures.py):
// linear sRGB (D65, white Y = 1), sampled with LINEAR filtering and CLAMP_TO_EDGE. A texture's
// axes are those of its LUT; texel i of an axis of n texels over [lo, hi] (of the axis' warped
// coordinate: sqrt(cos θ) for cosines) sits at the texture coordinate (i + 0.5) / n, which is
// what tirid_texcoord computes. Upload the LUT's values (C order) as they are: the LAST LUT axis
// is the texture's x (width), the one before it y, the first of three z (depth).
//
// Each axis is passed as vec3(lo, hi, n): the LUT's first and last node and its size.
//
// The BRDF is Fourneau et al. 2024 eq. 17-19 (torchirid.microfacet_brdf): GGX D, separable
// Smith G, the reflectance R looked up at cos θ_d = i·h, in the local frame or with any normal.

#ifndef TORCHIRID_GLSL
#define TORCHIRID_GLSL

const float TIRID_PI = 3.14159265358979;

// The texture coordinate of x on an axis vec3(lo, hi, n): x clamped to [lo, hi], texel centres.
float tirid_texcoord(float x, vec3 axis) {
    float t = clamp((x - axis.x) / (axis.y - axis.x), 0.0, 1.0);
    return (t * (axis.z - 1.0) + 0.5) / axis.z;
}

// Thin film on a base (family "thin_film"): a 2-D texture, x = thickness (nm), y = sqrt(cos θ).
vec3 tirid_thin_film_rgb(sampler2D tex, vec3 axis_sqrt_cos, vec3 axis_thickness, float cos_theta, float thickness) {
    vec2 uv = vec2(tirid_texcoord(thickness, axis_thickness),
                   tirid_texcoord(sqrt(clamp(cos_theta, 0.0, 1.0)), axis_sqrt_cos));
    return texture(tex, uv).rgb;
}

// First-order Bragg wavelength (nm) of a mirror of period Λ (nm), δ the fraction of Λ in n2,
// lit from the medium n0 at cos θ: 2Λ[(1 − δ) n1 cos θ1 + δ n2 cos θ2] (torchirid.realtime.bragg_wavelength).
float tirid_bragg_wavelength(float cos_theta, float period, float delta, float n1, float n2, float n0) {
    float s2 = n0 * n0 * (1.0 - cos_theta * cos_theta);
    float q1 = sqrt(max(n1 * n1 - s2, 0.0));
    float q2 = sqrt(max(n2 * n2 - s2, 0.0));
    return 2.0 * period * ((1.0 - delta) * q1 + delta * q2);
}

// Bragg mirror of N cells (family "bragg", one texture per N): a 3-D texture,
// x = δ, y = λ_B (nm), z = sqrt(cos θ).
vec3 tirid_bragg_rgb(mediump sampler3D tex, vec3 axis_sqrt_cos, vec3 axis_bragg_wavelength, vec3 axis_delta,
                     float cos_theta, float period, float delta, float n1, float n2, float n0) {
    float c = clamp(cos_theta, 0.0, 1.0);
    float lb = tirid_bragg_wavelength(c, period, delta, n1, n2, n0);
    vec3 uvw = vec3(tirid_texcoord(delta, axis_delta), tirid_texcoord(lb, axis_bragg_wavelength),
                    tirid_texcoord(sqrt(c), axis_sqrt_cos));
    return texture(tex, uvw).rgb;
}

// GGX normal distribution D (eq. 18), summed as sin² + α² cos² (no cancellation at the peak).
float tirid_ggx_d(float cos_m, float alpha) {
    if (cos_m <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float denom = (1.0 - cos_m) * (1.0 + cos_m) + a2 * cos_m * cos_m;
    return a2 / (TIRID_PI * denom * denom);
}

// Smith G1(c) / c (eq. 19 with the 1/cos of eq. 17 folded in: finite at grazing).
float tirid_g1_over_cos(float c, float alpha) {
    float c2 = min(c * c, 1.0);
    return 2.0 / (c + sqrt(c2 + alpha * alpha * (1.0 - c2)));
}

// The microfacet BRDF (sr⁻¹) times R: D G1(i) G1(o) R / (4 (i·n)(o·n)); 0 below the horizon.
// wi, wo: unit directions away from the surface; n: the unit normal.
vec3 tirid_microfacet_brdf(vec3 n, vec3 wi, vec3 wo, float alpha, vec3 reflectance) {
    float ci = dot(wi, n), co = dot(wo, n);
    if (ci <= 0.0 || co <= 0.0) return vec3(0.0);
    vec3 h = normalize(wi + wo);
    return reflectance * (tirid_ggx_d(dot(h, n), alpha) * tirid_g1_over_cos(ci, alpha)
                          * tirid_g1_over_cos(co, alpha) / 4.0);
}

// cos θ_d = i·h, the angle at which the microfacets reflect (the texture lookup's cos θ).
float tirid_cos_d(vec3 wi, vec3 wo) {
    return clamp(dot(wi, normalize(wi + wo)), 0.0, 1.0);
}

// The sRGB transfer function (IEC 61966-2-1) of linear RGB in [0, 1] (clamped).
vec3 tirid_linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    vec3 lo = 12.92 * c;
    vec3 hi = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
    return mix(hi, lo, vec3(lessThanEqual(c, vec3(0.0031308))));
}

#endif
