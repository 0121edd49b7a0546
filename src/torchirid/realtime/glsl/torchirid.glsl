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
// The BRDF is Fourneau et al. 2024 eq. 17-19 (torchirid.microfacet.microfacet_brdf): GGX D, separable
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

// Optical path difference (nm) of a film's two first reflections, 2 d sqrt(n_f² − n0² sin²θ)
// (torchirid.realtime.path_difference): the "thin_film_path" texture's second axis.
float tirid_path_difference(float cos_theta, float thickness, float n_film, float n0) {
    float s2 = n0 * n0 * (1.0 - cos_theta * cos_theta);
    return 2.0 * thickness * sqrt(max(n_film * n_film - s2, 0.0));
}

// Films of any index on one base (family "thin_film_path", one texture per base): a 3-D
// texture, x = n_film, y = path difference (nm), z = sqrt(cos θ).
vec3 tirid_thin_film_path_rgb(mediump sampler3D tex, vec3 axis_sqrt_cos, vec3 axis_path, vec3 axis_n_film,
                              float cos_theta, float thickness, float n_film, float n0) {
    float c = clamp(cos_theta, 0.0, 1.0);
    vec3 uvw = vec3(tirid_texcoord(n_film, axis_n_film),
                    tirid_texcoord(tirid_path_difference(c, thickness, n_film, n0), axis_path),
                    tirid_texcoord(sqrt(c), axis_sqrt_cos));
    return texture(tex, uvw).rgb;
}

// A rough film under uniform light (family "rough_thin_film"): a 3-D texture,
// x = thickness (nm), y = GGX α, z = sqrt(cos θ_o).
vec3 tirid_rough_thin_film_rgb(mediump sampler3D tex, vec3 axis_sqrt_cos, vec3 axis_alpha, vec3 axis_thickness,
                               float cos_theta_o, float alpha, float thickness) {
    vec3 uvw = vec3(tirid_texcoord(thickness, axis_thickness), tirid_texcoord(alpha, axis_alpha),
                    tirid_texcoord(sqrt(clamp(cos_theta_o, 0.0, 1.0)), axis_sqrt_cos));
    return texture(tex, uvw).rgb;
}

// --- spectral reflectance (for plots such as R(θ, λ); float32, unpolarised = mean of s and p) ---

// (sin x, cos x) to ~1e-7 absolute for |x| up to ~10³: quadrant reduction (Cody–Waite, two
// constants) and Taylor polynomials on [−π/4, π/4]. The built-in sin/cos are not enough for
// the phases of thick stacks: SwiftShader's (Chrome's software WebGL) are off by 2e-4, and near
// a band edge of N cells R moves by ~N² times that.
vec2 tirid_sincos(float x) {
    float q = floor(x * 0.63661977236758134 + 0.5);  // x / (π/2), nearest
    float r = (x - q * 1.5703125) - q * 4.8382679489661923e-4;
    float r2 = r * r;
    float s = r * (1.0 + r2 * (-1.0 / 6.0 + r2 * (1.0 / 120.0 + r2 * (-1.0 / 5040.0 + r2 * (1.0 / 362880.0)))));
    float c = 1.0 + r2 * (-0.5 + r2 * (1.0 / 24.0 + r2 * (-1.0 / 720.0 + r2 * (1.0 / 40320.0))));
    float k = mod(q, 4.0);
    if (k < 0.5) return vec2(s, c);
    if (k < 1.5) return vec2(c, -s);
    if (k < 2.5) return vec2(-s, -c);
    return vec2(-c, s);
}

vec2 tirid_cmul(vec2 a, vec2 b) { return vec2(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
vec2 tirid_cdiv(vec2 a, vec2 b) { return vec2(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y) / dot(b, b); }
vec2 tirid_csqrt(vec2 z) {  // principal branch (Im ≥ 0 for the absorbing media of this file)
    float r = length(z);
    float re = sqrt(max(0.5 * (r + z.x), 0.0));
    float im = sqrt(max(0.5 * (r - z.x), 0.0));
    return vec2(re, z.y < 0.0 ? -im : im);
}

// R of a film (n_film, d nm) on a base n_sub = vec2(n, κ), lit from the medium n0 at cos θ
// (Airy sum; torchirid.thin_film_reflectance). n_film ≥ n0 sin θ (no total internal reflection).
float tirid_thin_film_reflectance(float wavelength, float cos_theta, float n0, float n_film, float thickness, vec2 n_sub) {
    float s2 = n0 * n0 * (1.0 - cos_theta * cos_theta);
    float q0 = n0 * cos_theta;
    float q1 = sqrt(max(n_film * n_film - s2, 0.0));
    vec2 e2 = tirid_cmul(n_sub, n_sub);
    vec2 q2 = tirid_csqrt(e2 - vec2(s2, 0.0));
    // the round-trip phase 2β = 4π q1 d / λ, reduced to [0, 2π) first: GPU sin/cos lose accuracy on large arguments
    float two_beta = 2.0 * TIRID_PI * mod(2.0 * thickness * q1 / wavelength, 1.0);
    vec2 phase = tirid_sincos(two_beta).yx;
    float R = 0.0;
    for (int pol = 0; pol < 2; pol++) {
        float r01;
        vec2 r12;
        if (pol == 0) {  // s
            r01 = (q0 - q1) / (q0 + q1);
            r12 = tirid_cdiv(vec2(q1, 0.0) - q2, vec2(q1, 0.0) + q2);
        } else {  // p
            float a = n_film * n_film;
            r01 = (a * q0 - n0 * n0 * q1) / (a * q0 + n0 * n0 * q1);
            vec2 num = q1 * e2 - a * q2;
            vec2 den = q1 * e2 + a * q2;
            r12 = tirid_cdiv(num, den);
        }
        vec2 t = tirid_cmul(r12, phase);
        vec2 r = tirid_cdiv(vec2(r01, 0.0) + t, vec2(1.0, 0.0) + r01 * t);
        R += 0.5 * dot(r, r);
    }
    return R;
}

// The characteristic matrix of one cell, an n2 layer then an n1 layer (Born & Wolf):
// M = M2 M1 = [[A, −iB], [−iC, D]], returned as vec4(A, B, C, D) (real for lossless layers), from
// (sin, cos) of the layers' phases k q d and their admittances η = q (s) or n²/q (p).
vec4 tirid_bragg_cell(vec2 sc1, vec2 sc2, float h1, float h2) {
    float c1 = sc1.y, s1 = sc1.x, c2 = sc2.y, s2 = sc2.x;
    return vec4(c2 * c1 - s2 * s1 * h1 / h2, c2 * s1 / h1 + s2 * c1 / h2,
                h2 * s2 * c1 + c2 * h1 * s1, c2 * c1 - s2 * s1 * h2 / h1);
}

// (U_{N−1}(a), U_{N−2}(a)), Chebyshev polynomials of the second kind by their recurrence; N ≤ 256.
vec2 tirid_chebyshev_u(float a, int cells) {
    float um2 = 0.0, um1 = 1.0;  // U_{−1}, U_0
    for (int j = 1; j < 256; j++) {
        if (j >= cells) break;
        float u = 2.0 * a * um1 - um2;
        um2 = um1;
        um1 = u;
    }
    return vec2(um1, um2);
}

// R of a Bragg mirror n0 | (n2, d2), (n1, d1) × N | n1 of real indices (d in nm), lit from n0
// at cos θ (torchirid.bragg_reflectance; n0 = n1 is the embedded mirror). Characteristic
// matrices (Born & Wolf), the N-th power of the cell's by Chebyshev polynomials (Yeh); N ≤ 256.
// n0 sin θ below n1 and n2 (no total internal reflection).
float tirid_bragg_reflectance(float wavelength, float cos_theta, float n0, float n1, float n2, float d1, float d2, int cells) {
    float s2 = n0 * n0 * (1.0 - cos_theta * cos_theta);
    float q0 = n0 * cos_theta;
    float q1 = sqrt(max(n1 * n1 - s2, 1e-12));
    float q2 = sqrt(max(n2 * n2 - s2, 1e-12));
    float k = 2.0 * TIRID_PI / wavelength;
    vec2 sc1 = tirid_sincos(k * q1 * d1), sc2 = tirid_sincos(k * q2 * d2);  // the phases: the same for s and p
    float R = 0.0;
    for (int pol = 0; pol < 2; pol++) {
        // admittances η = q (s) or n²/q (p)
        float h0 = pol == 0 ? q0 : n0 * n0 / max(q0, 1e-12);
        float h1 = pol == 0 ? q1 : n1 * n1 / q1;
        float h2 = pol == 0 ? q2 : n2 * n2 / q2;
        vec4 M = tirid_bragg_cell(sc1, sc2, h1, h2);
        // M^N = U_{N−1}(a) M − U_{N−2}(a) I, a = (A + D)/2
        vec2 U = tirid_chebyshev_u(0.5 * (M.x + M.w), cells);
        float An = U.x * M.x - U.y, Bn = U.x * M.y, Cn = U.x * M.z, Dn = U.x * M.w - U.y;
        // [E; H] = M^N [1; η_sub], η_sub = h1; r = (h0 E − H) / (h0 E + H)
        vec2 E = vec2(An, -Bn * h1), H = vec2(Dn * h1, -Cn);
        vec2 num = h0 * E - H, den = h0 * E + H;
        R += 0.5 * dot(num, num) / dot(den, den);
    }
    return R;
}

// --- Bragg colour without a texture: the envelope method (torchirid.spectral.bragg_xyz_envelope) ---
//
// A lossless mirror embedded in n1 (cos θ in n1; n2 ≥ n1 sin θ): its spectrum replaced by the
// fringe-averaged model — 1 − sqrt(1 − R^e), R^e = |C|²/(|C|² + sin²KΛ) (Fourneau et al. eq. 11)
// in the pass bands, Yeh's finite-N R in the band gaps — sampled at `samples` nodes uniform in
// ω = 2π/λ over omega_range and integrated exactly against the CMFs × D65 with hat-function
// weights: texel k of `weights` (an RGB32F texture of samples × 1, read with texelFetch) is row k
// of torchirid.spectral.envelope_weights(samples) (X, Y, Z; Y sums to 1). Returns XYZ, Y = 1 for
// a perfect reflector. Cost per sample: two sincos, then per polarisation the cell and, in gaps, the N-loop.

vec3 tirid_bragg_envelope_xyz(sampler2D weights, int samples, vec2 omega_range, float cos_theta, float n1, float n2,
                              float d1, float d2, int cells) {
    float c = clamp(cos_theta, 0.0, 1.0);
    float s2 = n1 * n1 * (1.0 - c * c);
    float q1 = max(n1 * c, 1e-6);
    float q2 = sqrt(max(n2 * n2 - s2, 1e-12));
    vec3 xyz = vec3(0.0);
    for (int k = 0; k < 1024; k++) {
        if (k >= samples) break;
        float omega = mix(omega_range.x, omega_range.y, float(k) / float(samples - 1));
        vec2 sc1 = tirid_sincos(omega * q1 * d1), sc2 = tirid_sincos(omega * q2 * d2);
        float R = 0.0;
        for (int pol = 0; pol < 2; pol++) {
            float h1 = pol == 0 ? q1 : n1 * n1 / q1;
            float h2 = pol == 0 ? q2 : n2 * n2 / q2;
            vec4 M = tirid_bragg_cell(sc1, sc2, h1, h2);
            // r_N = U_{N−1} (x + iy) / (…) with x = h1(A − D), y = C − B h1²: |C|² = (x² + y²) / 4h1²
            float x = h1 * (M.x - M.w), y = M.z - M.y * h1 * h1;
            float C2 = (x * x + y * y) / (4.0 * h1 * h1), a = 0.5 * (M.x + M.w);
            if (abs(a) < 1.0) {  // pass band: the fringe average
                float Re = C2 / (C2 + 1.0 - a * a);
                R += 0.5 * (1.0 - sqrt(max(1.0 - Re, 0.0)));
            } else {  // band gap: Yeh's finite N
                float U2 = tirid_chebyshev_u(a, cells).x;
                U2 *= U2;
                R += 0.5 * C2 * U2 / (C2 * U2 + 1.0);
            }
        }
        xyz += R * texelFetch(weights, ivec2(k, 0), 0).rgb;
    }
    return xyz;
}

// CIE XYZ (D65 white at Y = 1) → linear sRGB (torchirid.color.xyz_to_linear_srgb's matrix).
vec3 tirid_xyz_to_linear_srgb(vec3 xyz) {
    return mat3(3.2404813, -0.9692549, 0.0556466,
                -1.5371515, 1.8759900, -0.2040413,
                -0.4985363, 0.0415559, 1.0573111) * xyz;
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
