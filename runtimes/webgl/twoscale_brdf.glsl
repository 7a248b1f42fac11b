// twoscale_brdf.glsl: the two-scale BRDF (docs/maths.md section 7, docs/runtimes.md) on the GPU, from one
// material's tables. GLSL ES 3.00 (WebGL2), also valid as desktop `#version 330`: prepend the #version line
// and highp precisions for float, int and sampler2D (twoscale.js' fragmentShader does). A port of the C
// reference runtimes/c/twoscale_brdf.h with exactly its semantics, in float32; comments give the formula or
// the reason, the C gives the derivations. Every global is prefixed ts_ / Ts.
//
//   TsFresnel ts_fresnel_one();
//   TsFresnel ts_fresnel_conductor(float eta, float k);           // with F_avg (8-point Gauss-Legendre)
//   float ts_eval(vec3 wi, vec3 wo, float lambda, TsFresnel f);  // rho, WITHOUT the cosine; 0 below the surface
//   float ts_pdf(vec3 wi, vec3 wo, float lambda0);               // solid angle density of ts_sample
//   vec3  ts_sample(vec3 wi, float lambda0, vec2 xi, TsFresnel f, out float pdf, out float weight);
//
// Directions are unit vectors in the shading frame (z = normal), wi towards the viewer, wo towards the light;
// lambda in micrometres. A plastic or subsurface material uses its interface's Fresnel factor (from ior) and
// ignores f, as the C does. The uniforms below are set by twoscale.js' bindMaterial.
//
// Tables: every value plane the BRDF reads is packed into ONE RGBA32F texture, ts_data, 2048 texels a row (the
// WebGL2 minimum of MAX_TEXTURE_SIZE, so the 4097-node epd_sampling fits anywhere); a plane starts at texel
// index ts_off_*, node (i, j) of an (n0 x n1) table at offset + i n1 + j, its texel holding the nodes (i, j),
// (i, j + 1), (i + 1, j), (i + 1, j + 1) (ts_at4). The shader reads nodes with
// texelFetch and interpolates itself, as the C does (cell = floor((e - e0) / step), clamped, weight t). Not
// with the hardware's linear filtering: GPUs compute its weights in fixed point with about 8 bits of fraction
// (D3D requires 8, and most GPUs give no more), so a filtered read is off by up to 2^-9 of a node difference:
// measured with the weights rounded so, eval moves by 8e-5 relative, and ts_pdf (the quantile rows) by 1.1e-3.
// texelFetch needs no OES_texture_float_linear either.

const float ts_pi = 3.14159265358979323846;
const float ts_pi_2 = 1.57079632679489661923;

// An axis uniform in its encoding e: node i at e0 + i / inv_step, n nodes; p0, p1 the encoding's parameters
// (bounded_log_tan: eps, delta; log_gap: end, eps; log1p_sq: scale; shifted_log: shift).
struct TsGrid {
    float e0;
    float inv_step;
    int n;
    float p0;
    float p1;
};

uniform highp sampler2D ts_data;
uniform TsGrid ts_g1_theta, ts_samp_xi, ts_kc_s, ts_kc_b, ts_lobe_u, ts_lobe_v, ts_ls_u, ts_ls_xi, ts_conv_u, ts_alb_mu, ts_alb_lam;
// where each value plane starts in ts_data (ts_off_ia_*: e_f and e_f_avg with energy single, e_fc and e_fc_avg compensated)
uniform int ts_off_g1, ts_off_samp, ts_off_alb_g, ts_off_alb_e, ts_off_alb_avg, ts_off_ia_e, ts_off_ia_avg;
uniform int ts_off_kc, ts_off_lobe, ts_off_ls, ts_off_s_cos, ts_off_g_cos, ts_off_layer_w, ts_off_layer_v, ts_layer_n;
// The material's and the mode's choices: uniforms, or constants where the program is compiled for one material and
// mode (twoscale.js' shaderModes defines TS_MODEL etc. before this file). Constants cost nothing: SwiftShader (and
// any SIMD GPU that does not skip a branch its lanes all leave) runs both sides of a uniform branch, which made
// ts_eval 2.3x slower in the explorer's sphere pass (all the layered models' and compensated work for a conductor).
#ifdef TS_MODEL
const int ts_model = TS_MODEL;  // 0 conductor, 1 plastic, 2 subsurface
const bool ts_exact = TS_EXACT, ts_compensated = TS_COMPENSATED, ts_diffracting = TS_DIFFRACTING, ts_layered = TS_MODEL != 0;
#else
uniform int ts_model;  // 0 conductor, 1 plastic, 2 subsurface
uniform bool ts_exact, ts_compensated, ts_diffracting, ts_layered;
#endif
uniform float ts_inv_beta2;   // 1 / beta^2
uniform float ts_spec_scale;  // N(p) / (4 beta^2)
uniform float ts_d_cut;       // 104^(1/p): exp(-y^p) < e^-104 is 0 in float32 beyond y = d_cut
uniform float ts_p;
uniform float ts_k_scale;     // (c - 1) / (2 pi) N(p) / beta^2
uniform float ts_lobe_power;  // -(c + 1) / 2
uniform float ts_sigma4pi;    // 4 pi sigma_s
uniform float ts_b;           // b (micrometres)
uniform float ts_inv_u_scale, ts_edge_d2, ts_inv_theta_cap, ts_v_anchor, ts_v_ln2;  // zh_lobe's derived angle
uniform float ts_ior, ts_interface_avg, ts_phase_g, ts_single_max;               // layered models

// ---------------------------------------------------------------------------------------------------------
// Table access.

// Texel i holds node i's bilinear footprint (v[i], v[i + 1], v[i + nb], v[i + nb + 1]) of its plane (nb its row
// length): one texelFetch reads the 2 or 4 nodes of an interpolation, the fetch being what ts_eval spent most on.
vec4 ts_at4(int i) {
    return texelFetch(ts_data, ivec2(i & 2047, i >> 11), 0);
}

float ts_at(int i) {
    return ts_at4(i).r;
}

// The cell i (nodes i, i + 1) of the encoded coordinate e, clamped to the axis, and the weight t of node i + 1.
int ts_cell(TsGrid g, float e, out float t) {
    float f = (e - g.e0) * g.inv_step;
    f = f > 0.0 ? f : 0.0;  // NaN too, where the GPU honours it
    f = min(f, float(g.n - 1));
    int i = min(int(f), g.n - 2);
    t = f - float(i);
    return i;
}

float ts_lerp(TsGrid g, int off, float e) {
    float t;
    int i = ts_cell(g, e, t);
    vec4 q = ts_at4(off + i);
    return (1.0 - t) * q.r + t * q.g;
}

// Bilinear in a footprint texel q = nodes (i, j), (i, j + 1), (i + 1, j), (i + 1, j + 1) at the weights (ta, tb).
float ts_footprint(vec4 q, float ta, float tb) {
    return (1.0 - ta) * ((1.0 - tb) * q.r + tb * q.g) + ta * ((1.0 - tb) * q.b + tb * q.a);
}

// Bilinear in the plane at off (a x b nodes, C order) at the cells (i, j) and weights (ta, tb).
float ts_at2(int off, int nb, int i, int j, float ta, float tb) {
    return ts_footprint(ts_at4(off + i * nb + j), ta, tb);
}

float ts_lerp2(TsGrid a, TsGrid b, int off, float ea, float eb) {
    float ta, tb;
    int i = ts_cell(a, ea, ta), j = ts_cell(b, eb, tb);
    return ts_at2(off, b.n, i, j, ta, tb);
}

// ---------------------------------------------------------------------------------------------------------
// Fresnel.

// kind 0: F = 1; 1: a conductor of index eta + i k; 2: a dielectric of real index eta (a layered model's
// interface). avg = F_avg = 2 int_0^1 F(mu) mu dmu, the compensated BRDF's multiple-scattering factor.
struct TsFresnel {
    int kind;
    float eta;
    float k;
    float avg;
};

float ts_fresnel_eval(TsFresnel f, float cos_t) {
    if (f.kind == 0) return 1.0;
    if (f.kind == 2) {
        // g^2 = eta^2 - 1 + c^2; F = 1/2 ((g - c)/(g + c))^2 (1 + ((c (g + c) - 1)/(c (g - c) + 1))^2) (Walter et al. 2007)
        float c = abs(cos_t), g2 = f.eta * f.eta - 1.0 + c * c;
        if (g2 <= 0.0) return 1.0;
        float g = sqrt(g2), x = (g - c) / (g + c), y = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        return 0.5 * x * x * (1.0 + y * y);
    }
    // The C's conductor formula, rearranged against float32 cancellation: sqrt(n^2 - sin^2) = a + i b with
    // a^2 = (|..| + t1)/2 and b^2 = (|..| - t1)/2, each taken in the form without cancellation (a^2 b^2 = eta^2 k^2);
    // r_s = ((a - c)^2 + b^2) / ((a + c)^2 + b^2) (the C's (ab + c^2 - 2 a c) / (ab + c^2 + 2 a c), ab = a^2 + b^2),
    // (r_s + r_p)/2 = r_s t3 / (t3 + t4), t3 = ab c^2 + s^4, t4 = 2 a c s^2.
    float c = cos_t, c2 = c * c, s2 = 1.0 - c2;
    float t1 = f.eta * f.eta - f.k * f.k - s2, ek2 = f.eta * f.eta * f.k * f.k;
    float ab = sqrt(t1 * t1 + 4.0 * ek2);
    float a2 = t1 >= 0.0 ? 0.5 * (ab + t1) : 2.0 * ek2 / (ab - t1);
    float b2 = t1 > 0.0 ? 2.0 * ek2 / (ab + t1) : 0.5 * (ab - t1); // t1 = 0 = k: 0, not 0/0
    float a = sqrt(a2);
    float t3 = ab * c2 + s2 * s2;
    return ((a - c) * (a - c) + b2) * t3 / (((a + c) * (a + c) + b2) * (t3 + 2.0 * c * a * s2));
}

TsFresnel ts_fresnel_one() {
    return TsFresnel(0, 1.0, 0.0, 1.0);
}

// F_avg by 8-point Gauss-Legendre in mu: nodes (1 -+ x)/2 on [0, 1], weights w/2; F_avg = sum 2 (w/2) mu F(mu).
TsFresnel ts_fresnel_averaged(int kind, float eta, float k) {
    const vec4 x = vec4(0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363);
    const vec4 w = vec4(0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763);
    TsFresnel f = TsFresnel(kind, eta, k, 0.0);
    float avg = 0.0;
    for (int j = 0; j < 4; j++) {
        float lo = 0.5 * (1.0 - x[j]), hi = 0.5 * (1.0 + x[j]);
        avg += w[j] * (lo * ts_fresnel_eval(f, lo) + hi * ts_fresnel_eval(f, hi));
    }
    f.avg = avg;
    return f;
}

TsFresnel ts_fresnel_conductor(float eta, float k) {
    return ts_fresnel_averaged(1, eta, k);
}

TsFresnel ts_fresnel_dielectric(float eta) {
    return ts_fresnel_averaged(2, eta, 0.0);
}

// A layered model's interface (its F_avg computed once in double by twoscale.js).
TsFresnel ts_interface() {
    return TsFresnel(2, ts_ior, 0.0, ts_interface_avg);
}

// ---------------------------------------------------------------------------------------------------------
// The factors of rho.

// A = exp(-(4 pi sigma_s cos_d / lambda)^2), given 1 / lambda.
float ts_coherent(float cos_d, float inv_lambda) {
    float x = ts_sigma4pi * cos_d * inv_lambda;
    return exp(-x * x);
}

// (g, E_c) of `albedo` (energy compensated) at its encoded theta e_mu (bounded_log_tan) and ln lambda.
vec2 ts_albedo(float e_mu, float ln_lambda) {
    float ta, tb;
    int i = ts_cell(ts_alb_mu, e_mu, ta);
    if (ts_diffracting) {  // the albedo tables have a wavelength axis where the material diffracts
        int j = ts_cell(ts_alb_lam, ln_lambda, tb);
        return vec2(ts_at2(ts_off_alb_g, ts_alb_lam.n, i, j, ta, tb), ts_at2(ts_off_alb_e, ts_alb_lam.n, i, j, ta, tb));
    }
    vec4 g = ts_at4(ts_off_alb_g + i), e = ts_at4(ts_off_alb_e + i);
    return vec2((1.0 - ta) * g.r + ta * g.g, (1.0 - ta) * e.r + ta * e.g);
}

// An average of the albedo grid (E_c_avg, E_F_avg) at ln lambda, read at theta = 0 (node 0: it does not depend on theta).
float ts_albedo_avg(int off, float ln_lambda) {
    return ts_diffracting ? ts_lerp(ts_alb_lam, off, ln_lambda) : ts_at(off);
}

// A value of the albedo grid (a layered model's E_F) at (e_mu, ln lambda).
float ts_albedo_value(int off, float e_mu, float ln_lambda) {
    return ts_diffracting ? ts_lerp2(ts_alb_mu, ts_alb_lam, off, e_mu, ln_lambda) : ts_lerp(ts_alb_mu, off, e_mu);
}

// The multiple-scattering lobe's Fresnel factor (Kulla and Conty): F_avg^2 E_c_avg / (1 - F_avg (1 - E_c_avg)).
float ts_ms_factor(float e_c_avg, float f_avg) {
    return f_avg * f_avg * e_c_avg / (1.0 - f_avg * (1.0 - e_c_avg));
}

// The layer's albedo at lambda (a plastic's d, a subsurface medium's alpha'): its samples read linearly, clamped.
float ts_layer_value(float lambda) {
    int n = ts_layer_n;
    if (n == 1 || lambda <= ts_at(ts_off_layer_w)) return ts_at(ts_off_layer_v);
    if (lambda >= ts_at(ts_off_layer_w + n - 1)) return ts_at(ts_off_layer_v + n - 1);
    int k = 1;
    while (ts_at(ts_off_layer_w + k) < lambda) k++;
    float w0 = ts_at(ts_off_layer_w + k - 1), t = (lambda - w0) / (ts_at(ts_off_layer_w + k) - w0);
    return (1.0 - t) * ts_at(ts_off_layer_v + k - 1) + t * ts_at(ts_off_layer_v + k);
}

// What the interface lets into the layer: T = max(1 - E_F, 0), or compensated max(1 - E_Fc - (1 - E_c) m, 0).
float ts_transmitted(float e, float loss, float ms) {
    return max(1.0 - e - loss * ms, 0.0);
}

// The share of the light let in that leaves as a Lambertian lobe T(o) / (pi T_avg), r = 1 - T_avg / eta^2:
// a plastic's d_eff = d (1 - r) / (1 - d r); a subsurface medium's R_d (1 - alpha s_max), and single = alpha.
float ts_diffuse_share(float t_avg, float lambda, out float single) {
    float a = ts_layer_value(lambda), r = 1.0 - t_avg / (ts_ior * ts_ior);
    single = 0.0;
    if (ts_model == 1) return a * (1.0 - r) / (1.0 - a * r);
    // alpha = alpha' / (alpha' + (1 - alpha')(1 - g)); R_d = alpha'/2 (1 + e^(-4/3 A sqrt(3(1 - alpha')))) e^(-sqrt(3(1 - alpha'))), A = (1 + r)/(1 - r)
    float alpha = a / (a + (1.0 - a) * (1.0 - ts_phase_g));
    float big_a = (1.0 + r) / (1.0 - r), s3 = sqrt(3.0 * (1.0 - a));
    single = alpha;
    return 0.5 * a * (1.0 + exp(-4.0 / 3.0 * big_a * s3)) * exp(-s3) * (1.0 - alpha * ts_single_max);
}

// The layer's lobes, layer = (T(i), T(o), T_avg): a plastic's d_eff T(i) T(o) / (pi T_avg); a subsurface medium's
// f_multi = R_d (1 - alpha s_max) T(i) T(o) / (pi T_avg) plus f_single = alpha T(i) T(o) p_g(c) / (eta^2 (mu_i' + mu_o')),
// mu' = sqrt(1 - (1 - mu^2)/eta^2), c = -(i_x o_x + i_y o_y) / eta^2 - mu_i' mu_o'.
float ts_layer(vec3 layer, float lambda, vec3 wi, vec3 wo) {
    if (!(layer.z > 0.0)) return 0.0;
    float alpha, eta2 = ts_ior * ts_ior, g = ts_phase_g;
    float rho = ts_diffuse_share(layer.z, lambda, alpha) * layer.x * layer.y / (ts_pi * layer.z);
    if (ts_model != 2) return rho;
    float mi = sqrt(1.0 - (1.0 - wi.z * wi.z) / eta2), mo = sqrt(1.0 - (1.0 - wo.z * wo.z) / eta2);
    float c = -(wi.x * wo.x + wi.y * wo.y) / eta2 - mi * mo;
    float q = 1.0 + g * g - 2.0 * g * c;
    return rho + alpha * layer.x * layer.y * (1.0 - g * g) / (4.0 * ts_pi * q * sqrt(q)) / (eta2 * (mi + mo));
}

// C(theta_h; u) of zh_convolution's fitted cos lobe s_cos (1 + 4 g_cos^2 sin^2 theta_h)^(-(c+1)/2) cos^2 theta_h,
// at u's encoded coordinate e_u (shifted_log).
float ts_fit_lobe(float e_u, float sin2_h, float cos2_h) {
    float t;
    int i = ts_cell(ts_conv_u, e_u, t);
    vec4 qs = ts_at4(ts_off_s_cos + i), qg = ts_at4(ts_off_g_cos + i);
    float s = (1.0 - t) * qs.r + t * qs.g;
    float g = (1.0 - t) * qg.r + t * qg.g;
    return s * pow(1.0 + 4.0 * g * g * sin2_h, ts_lobe_power) * cos2_h;
}

// bounded_log_tan's coordinate e = ln((s + eps c)/(c + delta s)) = ln((tan + eps)/(1 + delta tan)), finite at c = 0.
float ts_log_tan(TsGrid g, float s, float c) {
    return log((s + g.p0 * c) / (c + g.p1 * s));
}

// rho's two parts with F = 1 (wi, wo above the surface): parts.x = A D G2 / (4 cos_i cos_o), parts.y = (1 - A) G2 K
// (docs/runtimes.md); returns cos_d. Energy compensated: R = sqrt(R(sin_i) R(sin_o)), parts.y times g(cos_i) g(cos_o),
// and e_c = (E_c(cos_i), E_c(cos_o), E_c_avg). A layered model: layer = (T(i), T(o), T_avg).
float ts_parts(vec3 wi, vec3 wo, float lambda, out vec2 parts, out vec3 e_c, out vec3 layer) {
    // geometry: h = wi + wo unnormalised. Near the mirror direction wi.xy + wo.xy is exact in float32 (Sterbenz),
    // so tan^2 theta_h = |h.xy|^2 / h.z^2 keeps its relative accuracy where D is steep.
    vec3 h = wi + wo;
    float t2 = dot(h.xy, h.xy), h2 = t2 + h.z * h.z;  // |h|^2 sin^2 theta_h, |h|^2
    float sin_i = length(wi.xy), sin_o = length(wo.xy);
    float inv_hz2 = 1.0 / (h.z * h.z);
    float inv_lambda = 1.0 / lambda, bb = ts_b * inv_lambda;  // B = b / lambda
    float y = t2 * inv_hz2 * ts_inv_beta2;                    // tan^2 theta_h / beta^2
    float sec2_h = h2 * inv_hz2;
    // cos_d = i.h / |h| = sqrt((1 + i.o) / 2) for unit i, o: no division, symmetric in (i, o)
    float cos_d = sqrt(clamp(0.5 + 0.5 * dot(wi, wo), 0.0, 1.0));
    float ln_lambda = log(lambda);
    parts = vec2(0.0);
    float a = 1.0;
    // G2 = 1 / (1/G1_i + 1/G1_o - 1) = G1_i G1_o / (G1_i + G1_o - G1_i G1_o)
    float g1i = ts_lerp(ts_g1_theta, ts_off_g1, ts_log_tan(ts_g1_theta, sin_i, wi.z));
    float g1o = ts_lerp(ts_g1_theta, ts_off_g1, ts_log_tan(ts_g1_theta, sin_o, wo.z));
    float e = g1i + g1o - g1i * g1o;
    float g2 = e > 0.0 ? g1i * g1o / e : 0.0;
    if (ts_diffracting) {
        // K = (c - 1) B^2 / (2 pi R) N(p)/beta^2 C(theta_h; u = B cos_d); R from kcorr_renorm at (s = sin theta_i, B):
        // log_gap e = -ln(end + eps - s), taken as (end - s) + eps, exact in float32 near s = end = 1 (Sterbenz)
        float u = bb * cos_d, kc_b = log(bb);
        float ln_r = ts_lerp2(ts_kc_s, ts_kc_b, ts_off_kc, -log((ts_kc_s.p0 - sin_i) + ts_kc_s.p1), kc_b);
        if (ts_compensated) ln_r = 0.5 * (ln_r + ts_lerp2(ts_kc_s, ts_kc_b, ts_off_kc, -log((ts_kc_s.p0 - sin_o) + ts_kc_s.p1), kc_b));
        float c_r;  // C / R
        if (ts_exact) {
            // zh_lobe at (u: log1p_sq, ln(1 + (u/scale)^2); v_theta: material_lobe_angle of (u, theta_h)):
            // a = min(sqrt(1/q + edge_d^2), theta_cap), q = 1 + 4 u^2, taken as 1/a = max(sqrt(q / (1 + edge_d^2 q)), 1/theta_cap);
            // v = v_anchor log2(1 + theta/a) if theta <= a, else v_anchor + (1 - v_anchor) ln(theta/a) / ln((pi/2)/a)
            float ru = u * ts_inv_u_scale, q = 1.0 + 4.0 * u * u;
            float inv_a = max(sqrt(q / (1.0 + ts_edge_d2 * q)), ts_inv_theta_cap);
            float theta_h = atan(sqrt(t2), h.z);  // not acos(h.z): that loses theta_h near the normal
            float ta = theta_h * inv_a;
            float v = ta <= 1.0 ? ts_v_ln2 * log(1.0 + ta) : ts_v_anchor + (1.0 - ts_v_anchor) * log(ta) / log(ts_pi_2 * inv_a);
            float ln_c = ts_lerp2(ts_lobe_u, ts_lobe_v, ts_off_lobe, log(1.0 + ru * ru), v);
            c_r = exp(ln_c - ln_r);
        } else {
            // zh_convolution at u (shifted_log: ln(u - shift))
            c_r = ts_fit_lobe(log(u - ts_conv_u.p0), t2 / h2, 1.0 / sec2_h) * exp(-ln_r);
        }
        a = ts_coherent(cos_d, inv_lambda);  // A = exp(-(4 pi sigma_s cos_d / lambda)^2)
        parts.y = (1.0 - a) * g2 * ts_k_scale * bb * bb * c_r;
    }
    // D = N(p)/beta^2 exp(-y^p) / cos^4 theta_h; 0 where exp(-y^p) < e^-104 (0 in float32), which also keeps
    // sec^4 theta_h (huge at grazing h) out of an inf * 0
    if (y < ts_d_cut) parts.x = a * ts_spec_scale * exp(-(y > 0.0 ? pow(y, ts_p) : 0.0)) * sec2_h * sec2_h * g2 / (wi.z * wo.z);
    e_c = vec3(1.0);
    layer = vec3(0.0);
    float alb_i = 0.0, alb_o = 0.0;
    if (ts_compensated || ts_layered) {
        alb_i = ts_log_tan(ts_alb_mu, sin_i, wi.z);
        alb_o = ts_log_tan(ts_alb_mu, sin_o, wo.z);
    }
    if (ts_compensated) {
        vec2 gi = ts_albedo(alb_i, ln_lambda), go = ts_albedo(alb_o, ln_lambda);
        e_c = vec3(gi.y, go.y, ts_albedo_avg(ts_off_alb_avg, ln_lambda));
        parts.y *= gi.x * go.x;
    }
    if (ts_layered) {
        float ms = ts_compensated ? ts_ms_factor(e_c.z, ts_interface_avg) : 0.0;
        layer.x = ts_transmitted(ts_albedo_value(ts_off_ia_e, alb_i, ln_lambda), max(1.0 - e_c.x, 0.0), ms);
        layer.y = ts_transmitted(ts_albedo_value(ts_off_ia_e, alb_o, ln_lambda), max(1.0 - e_c.y, 0.0), ms);
        layer.z = 1.0 - ts_albedo_avg(ts_off_ia_avg, ln_lambda) - (1.0 - e_c.z) * ms;
    }
    return cos_d;
}

// The multiple-scattering lobe of energy compensated (Kulla and Conty), e_c = E_c at cos_i, cos_o, and E_c_avg:
// (1 - E_c(i)) (1 - E_c(o)) / (pi (1 - E_c_avg)) F_avg^2 E_c_avg / (1 - F_avg (1 - E_c_avg)).
float ts_multiple(vec3 e_c, TsFresnel f) {
    float loss = 1.0 - e_c.z;
    if (!(loss > 1e-6)) return 0.0;
    return max(1.0 - e_c.x, 0.0) * max(1.0 - e_c.y, 0.0) / (ts_pi * loss) * ts_ms_factor(e_c.z, f.avg);
}

// rho(wi, wo) at lambda, without the cosine: F(cos_d) (specular + diffraction), plus the multiple-scattering
// lobe with energy compensated; a layered model's F is its interface's, and its layer's lobes are added.
float ts_eval(vec3 wi, vec3 wo, float lambda, TsFresnel f) {
    if (!(wi.z > 0.0 && wo.z > 0.0)) return 0.0;
    vec2 parts;
    vec3 e_c, layer;
    float cos_d = ts_parts(wi, wo, lambda, parts, e_c, layer);
    if (ts_layered) f = ts_interface();
    float rho = ts_fresnel_eval(f, cos_d) * (parts.x + parts.y);
    if (ts_compensated) rho += ts_multiple(e_c, f);
    if (ts_layered) rho += ts_layer(layer, lambda, wi, wo);
    return rho;
}

// ---------------------------------------------------------------------------------------------------------
// Sampling and its exact pdf (docs/runtimes.md).

// (sin x, cos x) to about 1 ulp for |x| < ~1e4 (here x in [0, 2 pi]): the built-in sin and cos are not required to
// be accurate, and are not (SwiftShader's err by up to 2e-4, which moved a sampled direction by 7e-4 and its
// weight by 6e-2 in a narrow lobe in the sampling test). Cody-Waite reduction by pi/2 in three parts (the first two with trailing zero
// bits, so k P is exact), then Cephes' sinf and cosf minimax polynomials on [-pi/4, pi/4].
vec2 ts_sincos(float x) {
    float k = floor(x * 0.63661977236758134 + 0.5);
    float r = ((x - k * 1.5703125) - k * 4.837512969970703125e-4) - k * 7.54978995489188216e-8;
    float z = r * r;
    float s = r + r * z * (-1.6666654611e-1 + z * (8.3321608736e-3 + z * -1.9515295891e-4));
    float c = 1.0 - 0.5 * z + z * z * (4.166664568298827e-2 + z * (-1.388731625493765e-3 + z * 2.443315711809948e-5));
    int q = int(k) & 3;
    vec2 sc = (q & 1) == 0 ? vec2(s, c) : vec2(c, -s);
    return q >= 2 ? -sc : sc;
}

// asin(sqrt(x)), the asin_sqrt coordinate, as atan(sqrt x, sqrt(1 - x)): 1 - x is exact in float32 near x = 1,
// where asin(sqrt(x)) would amplify sqrt's rounding (its slope is infinite there).
float ts_asin_sqrt(float x) {
    return atan(sqrt(x), sqrt(1.0 - x));
}

// w_d = clamp(1 - A(cos_d = cos_i, lambda_0), 0.1, 0.9) with diffraction, else 0.
float ts_mixture(float cos_i, float lambda0) {
    return ts_diffracting ? clamp(1.0 - ts_coherent(cos_i, 1.0 / lambda0), 0.1, 0.9) : 0.0;
}

// The cosine strategy's share (the C's twoscale_brdf_ms_share): a conductor, compensated: min(1 - E_c(cos_i), 0.9);
// a layered model: the albedo of its layer's lobes and f_ms over theirs plus the interface's, at most 0.9.
float ts_ms_share(vec3 wi, float lambda0) {
    if (!ts_compensated && !ts_layered) return 0.0;
    float e_mu = ts_log_tan(ts_alb_mu, length(wi.xy), wi.z), ln_lambda = log(lambda0);
    float e = 1.0, avg = 1.0, ms = 0.0, alpha = 0.0;
    if (ts_compensated) e = ts_albedo(e_mu, ln_lambda).y;
    float loss = max(1.0 - e, 0.0);
    if (!ts_layered) return min(loss, 0.9);
    if (ts_compensated) {
        avg = ts_albedo_avg(ts_off_alb_avg, ln_lambda);
        ms = ts_ms_factor(avg, ts_interface_avg);
    }
    float e_f = ts_albedo_value(ts_off_ia_e, e_mu, ln_lambda);
    float t_avg = 1.0 - ts_albedo_avg(ts_off_ia_avg, ln_lambda) - (1.0 - avg) * ms;
    float w = t_avg > 0.0 ? ts_diffuse_share(t_avg, lambda0, alpha) : 0.0;
    w = loss * ms + (w + alpha * ts_single_max) * ts_transmitted(e_f, loss, ms);
    w = w > 0.0 ? w / (w + max(e_f, 0.0)) : 0.0;
    return min(w, 0.9);
}

// zh_lobe_sampling's cell k and weight t at u_0 = (b / lambda_0) cos theta_i (log1p_sq).
int ts_lobe_row(float cos_i, float lambda0, out float t) {
    float r = ts_b / lambda0 * cos_i / ts_ls_u.p0;
    return ts_cell(ts_ls_u, log(1.0 + r * r), t);
}

// The density over sin(theta) of the theta that interpolating the quantile row q_j = (1 - t) r0[j] + t r1[j]
// realises (n nodes uniform in e = asin(sqrt xi), H = (pi/2)/(n - 1)): with j the last node below n - 1 with
// q_j <= theta (binary search), e(theta) = (j + (theta - q_j)/(q_(j+1) - q_j)) H, q(theta) = sin(2 e) H / (q_(j+1) - q_j).
// q_(j+1) - q_j is taken as the interpolation of the rows' differences, exact in float32 (Sterbenz): the
// difference of two interpolated values would lose ~1e-4 of it.
float ts_quantile_density(int r0, int r1, float t, int n, float theta, float sin_theta) {
    float hstep = ts_pi_2 / float(n - 1);
    float q_lo = (1.0 - t) * ts_at(r0) + t * ts_at(r1), q_hi = (1.0 - t) * ts_at(r0 + n - 1) + t * ts_at(r1 + n - 1);
    if (!(theta >= q_lo && theta <= q_hi)) return 0.0;
    int lo = 0, len = n - 1;  // q_lo <= theta; j in [lo, lo + len)
    while (len > 1) {
        int half_len = len / 2, m = lo + half_len;
        lo = (1.0 - t) * ts_at(r0 + m) + t * ts_at(r1 + m) <= theta ? m : lo;
        len -= half_len;
    }
    float a0 = ts_at(r0 + lo), b0 = ts_at(r1 + lo);
    q_lo = (1.0 - t) * a0 + t * b0;
    float dq = (1.0 - t) * (ts_at(r0 + lo + 1) - a0) + t * (ts_at(r1 + lo + 1) - b0);
    if (!(dq > 0.0)) return 0.0;
    if (sin_theta > 0.0) return ts_sincos(2.0 * (float(lo) + (theta - q_lo) / dq) * hstep).x * hstep / dq / sin_theta;
    return 2.0 * hstep * hstep / (dq * dq);  // theta = 0 = q_0: sin(2e) / sin(theta) -> 2 H / dq
}

// The mixture's density in solid angle of wo at lambda0 with the weights w_d and w_ms of wi:
// (1 - w_ms) [(1 - w_d) q_epd(theta_h) + w_d q_lobe(theta_h; u_0)] / (2 pi sin theta_h) / (4 |i.h|) + w_ms cos_o / pi.
float ts_pdf_weighted(vec3 wi, vec3 wo, float lambda0, float w_d, float w_ms) {
    if (!(wi.z > 0.0 && wo.z > 0.0)) return 0.0;
    vec3 h = wi + wo;
    float hl = length(h), sxy = length(h.xy);
    float sin_h = sxy / hl, theta_h = atan(sxy, h.z), idoth = abs(dot(wi, h)) / hl;
    float q = (1.0 - w_d) * ts_quantile_density(ts_off_samp, ts_off_samp, 0.0, ts_samp_xi.n, theta_h, sin_h);
    if (w_d > 0.0) {
        float t;
        int k = ts_lobe_row(wi.z, lambda0, t), r0 = ts_off_ls + k * ts_ls_xi.n;
        q += w_d * ts_quantile_density(r0, r0 + ts_ls_xi.n, t, ts_ls_xi.n, theta_h, sin_h);
    }
    q = q / (2.0 * ts_pi) / (4.0 * idoth);
    if (ts_compensated || ts_layered) q = (1.0 - w_ms) * q + w_ms * wo.z / ts_pi;
    return q;
}

// The density in solid angle of wo that ts_sample realises at the hero wavelength lambda0.
float ts_pdf(vec3 wi, vec3 wo, float lambda0) {
    return ts_pdf_weighted(wi, wo, lambda0, ts_mixture(wi.z, lambda0), ts_ms_share(wi, lambda0));
}

// wo reflected about a half vector of the specular (xi1 >= w_d) or diffraction strategy at xi1, azimuth phi.
vec3 ts_reflected(vec3 wi, float lambda0, float xi1, float w_d, float phi) {
    float theta;
    if (xi1 < w_d) {
        // theta_h from zh_lobe_sampling at (u_0, xi = xi1 / w_d): bilinear
        float t, ft;
        int k = ts_lobe_row(wi.z, lambda0, t);
        int j = ts_cell(ts_ls_xi, ts_asin_sqrt(xi1 / w_d), ft);
        theta = ts_at2(ts_off_ls, ts_ls_xi.n, k, j, t, ft);
    } else {
        // theta_m from epd_sampling at xi = (xi1 - w_d)/(1 - w_d)
        theta = ts_lerp(ts_samp_xi, ts_off_samp, ts_asin_sqrt(clamp((xi1 - w_d) / (1.0 - w_d), 0.0, 1.0)));
    }
    // m = (sin theta cos phi, sin theta sin phi, cos theta), wo = 2 (i.m) m - i
    vec2 st = ts_sincos(theta), sp = ts_sincos(phi);
    vec3 m = vec3(st.x * sp.y, st.x * sp.x, st.y);
    return 2.0 * dot(wi, m) * m - wi;
}

// Samples wo for wi at the hero wavelength lambda0 with xi in [0, 1)^2: xi.x picks the strategy (energy
// compensated or a layered model: the cosine lobe if xi.x < w_ms, then xi.x -> (xi.x - w_ms)/(1 - w_ms);
// diffraction if xi.x < w_d) and is reused as its xi, phi = 2 pi xi.y. pdf = ts_pdf(wi, wo, lambda0); returns wo
// and weight = rho(wi, wo) cos theta_o / pdf at lambda0; a lost sample (wi or wo below the surface) has pdf 0, weight 0.
vec3 ts_sample(vec3 wi, float lambda0, vec2 xi, TsFresnel f, out float pdf, out float weight) {
    pdf = 0.0;
    weight = 0.0;
    if (!(wi.z > 0.0)) return vec3(0.0);
    float w_d = ts_mixture(wi.z, lambda0), w_ms = ts_ms_share(wi, lambda0), phi = 2.0 * ts_pi * xi.y;
    vec3 wo;
    if (xi.x < w_ms) {  // cosine-weighted: sin^2 theta_o = xi.x / w_ms
        float r2 = xi.x / w_ms, r = sqrt(r2);
        vec2 sp = ts_sincos(phi);
        wo = vec3(r * sp.y, r * sp.x, sqrt(1.0 - r2));
    } else {
        wo = ts_reflected(wi, lambda0, (xi.x - w_ms) / (1.0 - w_ms), w_d, phi);
    }
    if (!(wo.z > 0.0)) return wo;
    pdf = ts_pdf_weighted(wi, wo, lambda0, w_d, w_ms);
    if (!(pdf > 0.0)) return wo;
    weight = ts_eval(wi, wo, lambda0, f) * wo.z / pdf;
    return wo;
}

#ifdef TS_GENERAL
// ---------------------------------------------------------------------------------------------------------
// General mode: the default preset's general tables (twoscale.js' loadTables, runtimes/webgl/README.md "The
// general export"), the material's parameters per fragment (TsParams), the same arithmetic as the Mitsuba BSDF's
// general mode (docs/runtimes.md "General mode"). twoscale.js defines TS_GENERAL before this file.
//
//   float ts_general_eval(vec3 wi, vec3 wo, float lambda, TsParams m, TsFresnel f, bool exact, bool compensated);
//   float ts_general_pdf(vec3 wi, vec3 wo, float lambda0, TsParams m, bool compensated);
//   vec3  ts_general_sample(vec3 wi, float lambda0, vec2 xi, TsParams m, TsFresnel f, bool exact, bool compensated,
//                           out float pdf, out float weight);
//
// exact: zh_lobe's C, else zh_convolution's fitted cos lobe; compensated: epd_albedo's E_c for the microfacet part
// (docs/runtimes.md "General mode": the diffraction part is made reciprocal, R = sqrt(R_i R_o), but not scaled).
//
// Tables: the float32 planes in ts_gdata (R32F, 2048 x 2048 texels a layer, plane k at texel ts_goff_k), zh_lobe's
// float16 residual in ts_globe (R16F, the same layout); one texelFetch a node.

struct TsParams {
    float beta;
    float p;
    float sigma_s;
    float b;  // micrometres
    float c;
};

uniform highp sampler2DArray ts_gdata, ts_globe;
// epd_norm (p), epd_g1 (p, a), kcorr_renorm (s, B, c), zh_convolution (u, c, p, beta), zh_lobe (u, c, p, beta, v)
uniform TsGrid ts_gn_p, ts_gg_p, ts_gg_a, ts_gk_s, ts_gk_b, ts_gk_c, ts_gz_u, ts_gz_c, ts_gz_p, ts_gz_beta;
uniform TsGrid ts_gl_u, ts_gl_c, ts_gl_p, ts_gl_beta, ts_gl_v;
// epd_quantile (p, xi), epd_albedo (p, beta, theta_i) and epd_albedo_avg (p, beta): both cubic
uniform TsGrid ts_gq_p, ts_gq_xi, ts_ga_p, ts_ga_beta, ts_ga_theta;
// plane offsets; ts_goff_nodes: zh_lobe's nodes per axis (u, c, p, beta, v, float32 of the decoded double)
uniform int ts_goff_norm, ts_goff_g1, ts_goff_kc, ts_goff_s_cos, ts_goff_g_cos, ts_goff_g, ts_goff_q, ts_goff_alb, ts_goff_alb_avg;
uniform int ts_goff_nodes;
uniform float ts_gl_k, ts_gl_v_anchor, ts_gl_theta_cap;  // zh_lobe's anchored_lobe_angle
uniform float ts_gp_diff_lo, ts_gp_diff_hi;                // p's domain where the diffraction tables read it

float ts_gat(int i) {
    return texelFetch(ts_gdata, ivec3(i & 2047, (i >> 11) & 2047, i >> 22), 0).r;
}

float ts_globe_at(int i) {
    return texelFetch(ts_globe, ivec3(i & 2047, (i >> 11) & 2047, i >> 22), 0).r;
}

float ts_g_lerp1(TsGrid a, int off, float ea) {
    float t;
    int i = ts_cell(a, ea, t);
    return (1.0 - t) * ts_gat(off + i) + t * ts_gat(off + i + 1);
}

float ts_g_lerp2(TsGrid a, TsGrid b, int off, float ea, float eb) {
    float ta, tb;
    int i = ts_cell(a, ea, ta), j = ts_cell(b, eb, tb), k = off + i * b.n + j;
    return (1.0 - ta) * ((1.0 - tb) * ts_gat(k) + tb * ts_gat(k + 1)) + ta * ((1.0 - tb) * ts_gat(k + b.n) + tb * ts_gat(k + b.n + 1));
}

float ts_g_lerp3(TsGrid a, TsGrid b, TsGrid c, int off, float ea, float eb, float ec) {
    float ta, tb, tc;
    int i = ts_cell(a, ea, ta), j = ts_cell(b, eb, tb), k = ts_cell(c, ec, tc);
    float s = 0.0;
    for (int q = 0; q < 8; q++) {
        int di = q >> 2, dj = (q >> 1) & 1, dk = q & 1;
        float w = (di == 1 ? ta : 1.0 - ta) * (dj == 1 ? tb : 1.0 - tb) * (dk == 1 ? tc : 1.0 - tc);
        s += w * ts_gat(off + ((i + di) * b.n + j + dj) * c.n + k + dk);
    }
    return s;
}

// zh_convolution's (ln s_cos, g_cos) at (u, c, p, beta), one cell for both.
vec2 ts_g_fit(float u, float c, float p, float beta) {
    float t0, t1, t2, t3;
    int i0 = ts_cell(ts_gz_u, log(u - ts_gz_u.p0), t0), i1 = ts_cell(ts_gz_c, c, t1);
    int i2 = ts_cell(ts_gz_p, log(p), t2), i3 = ts_cell(ts_gz_beta, log(beta), t3);
    vec2 s = vec2(0.0);
    for (int q = 0; q < 16; q++) {
        int d0 = q >> 3, d1 = (q >> 2) & 1, d2 = (q >> 1) & 1, d3 = q & 1;
        float w = (d0 == 1 ? t0 : 1.0 - t0) * (d1 == 1 ? t1 : 1.0 - t1) * (d2 == 1 ? t2 : 1.0 - t2) * (d3 == 1 ? t3 : 1.0 - t3);
        int k = (((i0 + d0) * ts_gz_c.n + i1 + d1) * ts_gz_p.n + i2 + d2) * ts_gz_beta.n + i3 + d3;
        s += w * vec2(ts_gat(ts_goff_s_cos + k), ts_gat(ts_goff_g_cos + k));
    }
    return s;
}

// ln(1 + x) and exp(x) - 1 accurate for small x (Goldberg's and Kahan's corrections; GLSL has neither).
float ts_log1p(float x) {
    float u = 1.0 + x;
    return u == 1.0 ? x : log(u) * (x / (u - 1.0));
}

float ts_expm1(float x) {
    float u = exp(x);
    if (u == 1.0) return x;
    float um1 = u - 1.0;
    return um1 == -1.0 ? -1.0 : um1 * x / log(u);
}

// ln Gamma(x), x > 0: shifted up to z >= 6, then Stirling's series to 1/z^5 (error < 1e-8 there).
float ts_lgamma(float x) {
    float z = x, prod = 1.0;
    for (int i = 0; i < 8 && z < 6.0; i++) {
        prod *= z;
        z += 1.0;
    }
    float iz = 1.0 / z, iz2 = iz * iz;
    return (z - 0.5) * log(z) - z + 0.91893853320467274 + iz * (1.0 / 12.0 - iz2 * (1.0 / 360.0 - iz2 / 1260.0)) - log(prod);
}

float ts_smoothstep(float y, float lo, float hi) {
    float x = clamp((y - lo) / (hi - lo), 0.0, 1.0);
    return x * x * (3.0 - 2.0 * x);
}

float ts_logaddexp(float a, float b) {
    float m = max(a, b);
    return m + log(exp(a - m) + exp(b - m));
}

// zh_lobe's derived angle (docs/maths.md section 4b): the edge theta_a of (u, p, beta), v of theta, theta of v.
float ts_g_edge(float u, float p, float beta) {
    float wd = atan(beta * pow(ts_gl_k, 0.5 / p));
    return min(sqrt(1.0 / (1.0 + 4.0 * u * u) + wd * wd), ts_gl_theta_cap);
}

float ts_g_v(float theta, float a) {
    float va = ts_gl_v_anchor;
    return theta <= a ? va * ts_log1p(theta / a) / 0.69314718055994531 : va + (1.0 - va) * log(theta / a) / log(ts_pi_2 / a);
}

float ts_g_theta(float v, float a) {
    float va = ts_gl_v_anchor;
    float theta = v <= va ? a * ts_expm1(v / va * 0.69314718055994531) : a * exp((v - va) / (1.0 - va) * log(ts_pi_2 / a));
    return min(theta, ts_pi_2);
}

// The control-variate terms t_j (ln m_S, b, epd_core, tail) and weights alpha_j (docs/maths.md section 4b), split
// by what they depend on, so that ts_g_lobe computes each piece once per distinct corner: the EPD's grazing peak
// per (p, beta), the edge per (u, p, beta), the angle's terms per (u, p, beta, v), then per c only what c changes.

// lambda (u, p, beta) and mu: the weights' shares; w (v, grazing): the tail's weight.
vec4 ts_g_weights(float u, float p, float beta, float v, float grazing) {
    float ws2 = 1.0 / (1.0 + 4.0 * u * u), wd = beta / (2.0 * p), wd2 = wd * wd, r = wd2 / (ws2 + wd2);
    float lam = r * r, mu = lam * lam * ts_smoothstep(p, 0.3, 0.5);
    float w = ts_smoothstep(v, 0.2, 0.5) * (1.0 - ts_smoothstep(grazing, -4.0, -1.0));
    return vec4((1.0 - w) * (lam - mu), (1.0 - w) * (1.0 - lam), (1.0 - w) * mu, w);
}

// g = -2/p + 2 ln(1 + beta^2 (2/p)^(1/p)), the EPD's grazing peak.
float ts_g_grazing(float p, float beta) {
    return -2.0 / p + 2.0 * ts_log1p(beta * beta * pow(2.0 / p, 1.0 / p));
}

// What the terms take from the angle (c aside): (base, ln(1 + 4u^2 sin^2), ln(1 + 4u^2 (sin^2 + 2 s2/(1 + 2 s2))),
// ln D(theta_eff)), base = ln m_D + ln((cos^2 + s2)/(1 + s2)), ln D at e = min(sqrt(theta^2 + 1/(4 (1 + 4u^2))), pi/2)
// with cos e as sin(pi/2 - e), at least 1e-30.
vec4 ts_g_angle_terms(float theta, float u, float p, float beta, vec2 md_s2) {
    float sn = sin(theta), cs = cos(theta), sin2 = sn * sn, a4 = 4.0 * u * u, s2 = md_s2.y;
    float base = md_s2.x + log((cs * cs + s2) / (1.0 + s2));
    float e = min(sqrt(theta * theta + 0.25 / (1.0 + a4)), ts_pi_2), ce = max(sin(ts_pi_2 - e), 1e-30);
    return vec4(base, ts_log1p(a4 * sin2), ts_log1p(a4 * (sin2 + 2.0 * s2 / (1.0 + 2.0 * s2))), -pow(sin(e) / ce / beta, 2.0 * p) - 4.0 * log(ce));
}

// The terms from the angle's (ts_g_angle_terms), c and ln m_S(u, c): b = base - k L1, narrow = ln m_S + ln D,
// epd_core = logaddexp(narrow, base - k L2), tail = logaddexp(narrow, b), k = (c + 1)/2.
vec4 ts_g_terms_c(vec4 at, float c, float ms) {
    float k = 0.5 * (c + 1.0), b = at.x - k * at.y, narrow = ms + at.w;
    return vec4(ms, b, ts_logaddexp(narrow, at.x - k * at.z), ts_logaddexp(narrow, b));
}

// ln m_S(u, c) = ln(pi (1 - (1 + 4u^2)^((1-c)/2)) / (2 u^2 (c - 1))), ln pi where 4u^2 < 1e-12.
float ts_g_ln_ms(float u, float c) {
    float a = 4.0 * u * u;
    if (a < 1e-12) return log(ts_pi);
    return log(ts_pi * -ts_expm1(0.5 * (1.0 - c) * ts_log1p(a)) / (0.5 * a * (c - 1.0)));
}

// (ln m_D, s2) of (p, beta): ln(pi beta^2 Gamma(1 + 1/p)), beta^2 Gamma(2/p) / (2 Gamma(1/p)).
vec2 ts_g_md_s2(float p, float beta) {
    float lg1 = ts_lgamma(1.0 / p);
    return vec2(2.0 * log(beta) + log(ts_pi) + lg1 - log(p), 0.5 * beta * beta * exp(ts_lgamma(2.0 / p) - lg1));
}

// What ts_g_lobe reads that u and theta do not change (a pixel's, for all its wavelengths): the (c, p, beta) cells
// and nodes, (ln m_D, s2) and the grazing peak at their (p, beta) corners and at the point.
struct TsLobePrep {
    int i1, i2, i3;
    float t1, t2, t3;
    vec2 nc, np, nb;
    vec2 mds[4];
    vec4 grazing;  // per (p, beta) corner, index d2 * 2 + d3
    vec2 md;
    float grazing_x;
};

TsLobePrep ts_g_lobe_prep(float c, float p, float beta) {
    TsLobePrep L;
    L.i1 = ts_cell(ts_gl_c, c, L.t1);
    L.i2 = ts_cell(ts_gl_p, log(p - ts_gl_p.p0), L.t2);
    L.i3 = ts_cell(ts_gl_beta, log(beta), L.t3);
    int oc = ts_goff_nodes + ts_gl_u.n, op = oc + ts_gl_c.n, ob = op + ts_gl_p.n;
    L.nc = vec2(ts_gat(oc + L.i1), ts_gat(oc + L.i1 + 1));
    L.np = vec2(ts_gat(op + L.i2), ts_gat(op + L.i2 + 1));
    L.nb = vec2(ts_gat(ob + L.i3), ts_gat(ob + L.i3 + 1));
    for (int q = 0; q < 4; q++) {
        L.mds[q] = ts_g_md_s2(L.np[q >> 1], L.nb[q & 1]);
        L.grazing[q] = ts_g_grazing(L.np[q >> 1], L.nb[q & 1]);
    }
    L.md = ts_g_md_s2(p, beta);
    L.grazing_x = ts_g_grazing(p, beta);
    return L;
}

// ln C(theta_h; u, c, p, beta) of zh_lobe from its float16 residual r = ln C - M (M = sum_j alpha_j t_j at the node):
// ln C = I[r] + sum_k w_k M_k + sum_j alpha_j(x) (t_j(x) - sum_k w_k t_jk), the terms at the cell's 32 corners.
float ts_g_ln_lobe_at(TsLobePrep L, float u, float c, float p, float beta, float theta) {
    float a = ts_g_edge(u, p, beta), v = ts_g_v(theta, a);
    float t0, t4, ru = u / ts_gl_u.p0;
    int i0 = ts_cell(ts_gl_u, ts_log1p(ru * ru), t0), i4 = ts_cell(ts_gl_v, v, t4);
    int ou = ts_goff_nodes, ov = ou + ts_gl_u.n + ts_gl_c.n + ts_gl_p.n + ts_gl_beta.n;
    vec2 nu = vec2(ts_gat(ou + i0), ts_gat(ou + i0 + 1)), nv = vec2(ts_gat(ov + i4), ts_gat(ov + i4 + 1));
    vec4 ms = vec4(ts_g_ln_ms(nu.x, L.nc.x), ts_g_ln_ms(nu.x, L.nc.y), ts_g_ln_ms(nu.y, L.nc.x), ts_g_ln_ms(nu.y, L.nc.y));
    float ln_c = 0.0;
    vec4 iq = vec4(0.0);
    for (int q = 0; q < 8; q++) {  // (u, p, beta) corners
        int d0 = q >> 2, d2 = (q >> 1) & 1, d3 = q & 1;
        float uk = nu[d0], pk = L.np[d2], bk = L.nb[d3], w3 = (d0 == 1 ? t0 : 1.0 - t0) * (d2 == 1 ? L.t2 : 1.0 - L.t2) * (d3 == 1 ? L.t3 : 1.0 - L.t3);
        float edge = ts_g_edge(uk, pk, bk);
        vec2 md = L.mds[d2 * 2 + d3];
        for (int d4 = 0; d4 < 2; d4++) {
            float vk = nv[d4], w4 = w3 * (d4 == 1 ? t4 : 1.0 - t4);
            vec4 at = ts_g_angle_terms(ts_g_theta(vk, edge), uk, pk, bk, md);
            vec4 al = ts_g_weights(uk, pk, bk, vk, L.grazing[d2 * 2 + d3]);
            for (int d1 = 0; d1 < 2; d1++) {
                float w = w4 * (d1 == 1 ? L.t1 : 1.0 - L.t1);
                vec4 t = ts_g_terms_c(at, L.nc[d1], ms[d0 * 2 + d1]);
                float m = 0.0;  // M = sum_j alpha_j t_j, a term of weight 0 left out (as the export computed it)
                for (int j = 0; j < 4; j++) m += al[j] != 0.0 ? al[j] * t[j] : 0.0;
                int k = ((((i0 + d0) * ts_gl_c.n + L.i1 + d1) * ts_gl_p.n + L.i2 + d2) * ts_gl_beta.n + L.i3 + d3) * ts_gl_v.n + i4 + d4;
                ln_c += w * (ts_globe_at(k) + m);
                iq += w * t;
            }
        }
    }
    vec4 al = ts_g_weights(u, p, beta, v, L.grazing_x);
    vec4 t = ts_g_terms_c(ts_g_angle_terms(theta, u, p, beta, L.md), c, ts_g_ln_ms(u, c));
    for (int j = 0; j < 4; j++) {
        if (al[j] != 0.0) ln_c += al[j] * (t[j] - iq[j]);
    }
    return ln_c;
}

// The bake (twoscale_general.js' bakeTables): what the diffraction part reads, at one (c, p, b) and beta over a range
// [beta_lo, beta_hi], tabulated on the GPU when they change, so that a fragment reads a few nodes instead of zh_lobe's
// 32 corners and their terms (runtimes/webgl/README.md "The bake"). Planes, C order, one value a node (pass 1, ts_bake_value),
// then packed as ts_data is (texel i = nodes i, i + 1, i + nb, i + nb + 1 of its plane, nb its row length):
//   lobe:   ln C at (beta layer l, u node j, v node k): the general lookup at theta = ts_g_theta(v_k, edge(u_j, p, beta_l));
//   fit_s, fit_g: zh_convolution's (ln s_cos, g_cos) at (l, j);
//   kc:     kcorr_renorm at its own (s, B) nodes, linear in c's cell (so bilinear here is its trilinear lookup).
// u: log1p_sq (p0 = scale) over [0, b / lambda_min], beta: log over the range, v: linear over [0, 1], ts_bk_nv nodes.
uniform TsGrid ts_bk_u, ts_bk_beta;
uniform int ts_bk_nv, ts_bk_off_fs, ts_bk_off_fg, ts_bk_off_kc, ts_bk_total;
uniform float ts_bk_c, ts_bk_p;  // p clamped to the diffraction tables' domain

// Node i's encoded coordinate (u_j = scale sqrt(expm1(e_j)), beta_l = exp(e_l)); e0 on an axis of one value (inv_step 0).
float ts_bk_node(TsGrid g, int i) {
    return g.inv_step > 0.0 ? g.e0 + float(i) / g.inv_step : g.e0;
}

float ts_bake_value(int i) {
    int nu = ts_bk_u.n, nv = ts_bk_nv;
    if (i < ts_bk_off_fs) {
        int l = i / (nu * nv), j = (i / nv) % nu, k = i % nv;
        float u = ts_bk_u.p0 * sqrt(ts_expm1(ts_bk_node(ts_bk_u, j))), beta = exp(ts_bk_node(ts_bk_beta, l));
        float theta = ts_g_theta(float(k) / float(nv - 1), ts_g_edge(u, ts_bk_p, beta));
        return ts_g_ln_lobe_at(ts_g_lobe_prep(ts_bk_c, ts_bk_p, beta), u, ts_bk_c, ts_bk_p, beta, theta);
    }
    if (i < ts_bk_off_kc) {
        int r = i < ts_bk_off_fg ? i - ts_bk_off_fs : i - ts_bk_off_fg, l = r / nu, j = r % nu;
        vec2 fit = ts_g_fit(ts_bk_u.p0 * sqrt(ts_expm1(ts_bk_node(ts_bk_u, j))), ts_bk_c, ts_bk_p, exp(ts_bk_node(ts_bk_beta, l)));
        return i < ts_bk_off_fg ? fit.x : fit.y;
    }
    int r = min(i, ts_bk_total - 1) - ts_bk_off_kc, nc = ts_gk_c.n;
    float tc;
    int ic = ts_cell(ts_gk_c, log(ts_bk_c - ts_gk_c.p0), tc), k = ts_goff_kc + r * nc + ic;
    return (1.0 - tc) * ts_gat(k) + tc * ts_gat(k + 1);
}

// The row length of texel i's plane (pass 2's packing).
int ts_bake_row(int i) {
    return i < ts_bk_off_fs ? ts_bk_nv : i < ts_bk_off_kc ? ts_bk_u.n : ts_gk_b.n;
}

#ifdef TS_G_BAKED
uniform highp sampler2D ts_gbake;  // the packed bake, RGBA32F, 2048 texels a row

vec4 ts_bk_at4(int i) {
    return texelFetch(ts_gbake, ivec2(i & 2047, i >> 11), 0);
}

// ln C at (u, beta, theta): the table's own interpolation, v at the point shared by the four (beta, u) corners.
float ts_bk_ln_lobe(float u, float beta, float theta) {
    float tu, tb, tv, ru = u / ts_bk_u.p0;
    int j = ts_cell(ts_bk_u, ts_log1p(ru * ru), tu), l = ts_cell(ts_bk_beta, log(beta), tb);
    int k = ts_cell(TsGrid(0.0, float(ts_bk_nv - 1), ts_bk_nv, 0.0, 0.0), ts_g_v(theta, ts_g_edge(u, ts_bk_p, beta)), tv);
    int at = (l * ts_bk_u.n + j) * ts_bk_nv + k;
    return ts_footprint(mix(ts_bk_at4(at), ts_bk_at4(at + ts_bk_u.n * ts_bk_nv), tb), tu, tv);  // footprints over (u, v)
}

// zh_convolution's (ln s_cos, g_cos) at (u, beta).
vec2 ts_bk_fit(float u, float beta) {
    float tu, tb, ru = u / ts_bk_u.p0;
    int at = ts_cell(ts_bk_beta, log(beta), tb) * ts_bk_u.n + ts_cell(ts_bk_u, ts_log1p(ru * ru), tu);
    vec4 w = vec4((1.0 - tb) * (1.0 - tu), (1.0 - tb) * tu, tb * (1.0 - tu), tb * tu);  // (l, j), (l, j + 1), (l + 1, j), (l + 1, j + 1)
    return vec2(dot(w, ts_bk_at4(ts_bk_off_fs + at)), dot(w, ts_bk_at4(ts_bk_off_fg + at)));
}

// kcorr_renorm at (e_s, e_B) and the bake's c.
float ts_bk_kcorr(float es, float eb) {
    float ts, tb;
    int i = ts_cell(ts_gk_s, es, ts), j = ts_cell(ts_gk_b, eb, tb);
    return ts_footprint(ts_bk_at4(ts_bk_off_kc + i * ts_gk_b.n + j), ts, tb);
}
#endif

// What rho takes from the directions and the parameters alone, shared by every wavelength of a pixel
// (ts_general_geometry): the half vector's t2 = |h.xy|^2, h2 = |h|^2, sec^2 theta_h, theta_h, cos_d, sin theta_i and
// theta_o, G2, N(p)/beta^2, the specular part without A (D G2 / (4 cos_i cos_o)), the lobe's prepared cells, and
// with energy compensated e_c = (E_c(i), E_c(o), E_c_avg).
struct TsGeneralGeom {
    float t2, h2, sec2_h, theta_h, cos_d, sin_i, sin_o, g2, np_b2, spec;
    vec3 e_c;
    TsLobePrep lobe;
};

float ts_g_albedo(TsParams m, float sin_t, float cos_t);
float ts_g_albedo_avg(TsParams m);

TsGeneralGeom ts_general_geometry(vec3 wi, vec3 wo, TsParams m, bool exact_lobe, bool compensated) {
    TsGeneralGeom g;
    vec3 h = wi + wo;
    g.t2 = dot(h.xy, h.xy);
    g.h2 = g.t2 + h.z * h.z;
    float inv_hz2 = 1.0 / (h.z * h.z), inv_b2 = 1.0 / (m.beta * m.beta);
    g.sec2_h = g.h2 * inv_hz2;
    g.theta_h = atan(sqrt(g.t2), h.z);
    g.sin_i = length(wi.xy);
    g.sin_o = length(wo.xy);
    g.cos_d = sqrt(clamp(0.5 + 0.5 * dot(wi, wo), 0.0, 1.0));
    g.np_b2 = ts_g_lerp1(ts_gn_p, ts_goff_norm, 1.0 / m.p) * inv_b2;
    // G1(p, a = beta tan theta): the a axis's bounded_log ln((a + eps)/(1 + delta a)) in (sin, cos)
    float gp = 1.0 / m.p;
    float g1i = ts_g_lerp2(ts_gg_p, ts_gg_a, ts_goff_g1, gp, log((m.beta * g.sin_i + ts_gg_a.p0 * wi.z) / (wi.z + ts_gg_a.p1 * m.beta * g.sin_i)));
    float g1o = ts_g_lerp2(ts_gg_p, ts_gg_a, ts_goff_g1, gp, log((m.beta * g.sin_o + ts_gg_a.p0 * wo.z) / (wo.z + ts_gg_a.p1 * m.beta * g.sin_o)));
    float e = g1i + g1o - g1i * g1o;
    g.g2 = e > 0.0 ? g1i * g1o / e : 0.0;
    // D = N(p)/beta^2 exp(-y^p) sec^4 theta_h, y = tan^2 theta_h / beta^2; 0 where exp(-y^p) < e^-104
    float y = g.t2 * inv_hz2 * inv_b2;
    g.spec = y < pow(104.0, 1.0 / m.p) ? 0.25 * g.np_b2 * exp(-(y > 0.0 ? pow(y, m.p) : 0.0)) * g.sec2_h * g.sec2_h * g.g2 / (wi.z * wo.z) : 0.0;
#ifndef TS_G_BAKED
    if (exact_lobe && m.sigma_s > 0.0) g.lobe = ts_g_lobe_prep(m.c, clamp(m.p, ts_gp_diff_lo, ts_gp_diff_hi), m.beta);
#endif
    g.e_c = compensated ? vec3(ts_g_albedo(m, g.sin_i, wi.z), ts_g_albedo(m, g.sin_o, wo.z), ts_g_albedo_avg(m)) : vec3(1.0);
    return g;
}

// (specular, diffraction) parts of rho / F at lambda: A D G2 / (4 cos_i cos_o) and (1 - A) G2 K,
// K = (c - 1) B^2 / (2 pi R) N(p)/beta^2 C, R = kcorr_renorm(sin theta_i, B, c) (compensated: sqrt(R_i R_o)),
// u = B cos_d; exact: C of zh_lobe, else zh_convolution's s_cos (1 + 4 g_cos^2 sin^2 theta_h)^(-(c+1)/2) cos^2 theta_h.
// p enters the diffraction tables clamped to their domain (where sigma_s = 0 they are not read).
vec2 ts_general_parts_at(TsGeneralGeom g, float lambda, TsParams m, bool exact_lobe, bool compensated) {
    if (!(m.sigma_s > 0.0)) return vec2(g.spec, 0.0);
    float bb = m.b / lambda, u = bb * g.cos_d, pd = clamp(m.p, ts_gp_diff_lo, ts_gp_diff_hi);
    float x = m.sigma_s * 4.0 * ts_pi * g.cos_d / lambda, a = exp(-x * x);
    // kcorr_renorm: s log_gap -ln((end - s) + eps); B log_plus_log_log1p_sq ln B + ln ln(1 + B^2); c shifted_log
    float eb = log(bb) + log(ts_log1p(bb * bb)), lobe;
#ifdef TS_G_BAKED
    // the bake's c, p and b are m's (bakeTables), its beta range holds m.beta
    float r = ts_bk_kcorr(-log((ts_gk_s.p0 - g.sin_i) + ts_gk_s.p1), eb);
    if (compensated) r = sqrt(r * ts_bk_kcorr(-log((ts_gk_s.p0 - g.sin_o) + ts_gk_s.p1), eb));
    if (exact_lobe) {
        lobe = exp(ts_bk_ln_lobe(u, m.beta, g.theta_h));
    } else {
        vec2 fit = ts_bk_fit(u, m.beta);
        lobe = exp(fit.x) * pow(1.0 + 4.0 * fit.y * fit.y * g.t2 / g.h2, -0.5 * (m.c + 1.0)) / g.sec2_h;
    }
#else
    float ec = log(m.c - ts_gk_c.p0);
    float r = ts_g_lerp3(ts_gk_s, ts_gk_b, ts_gk_c, ts_goff_kc, -log((ts_gk_s.p0 - g.sin_i) + ts_gk_s.p1), eb, ec);
    if (compensated) r = sqrt(r * ts_g_lerp3(ts_gk_s, ts_gk_b, ts_gk_c, ts_goff_kc, -log((ts_gk_s.p0 - g.sin_o) + ts_gk_s.p1), eb, ec));
    if (exact_lobe) {
        lobe = exp(ts_g_ln_lobe_at(g.lobe, u, m.c, pd, m.beta, g.theta_h));
    } else {
        vec2 fit = ts_g_fit(u, m.c, pd, m.beta);
        lobe = exp(fit.x) * pow(1.0 + 4.0 * fit.y * fit.y * g.t2 / g.h2, -0.5 * (m.c + 1.0)) / g.sec2_h;
    }
#endif
    return vec2(a * g.spec, (1.0 - a) * g.g2 * (m.c - 1.0) * bb * bb / (2.0 * ts_pi * r) * g.np_b2 * lobe);
}

vec2 ts_general_parts(vec3 wi, vec3 wo, float lambda, TsParams m, bool exact_lobe, bool compensated) {
    return ts_general_parts_at(ts_general_geometry(wi, wo, m, exact_lobe, compensated), lambda, m, exact_lobe, compensated);
}

// 4-point Lagrange weights along an axis (docs/file_contract.md "Interpolation"): the stencil's first node s
// (the cell's, shifted inwards at the ends) and the weights of nodes s..s+3.
int ts_g_stencil(TsGrid g, float e, out vec4 w) {
    float t;
    int i = ts_cell(g, e, t), s = clamp(i, 1, g.n - 3) - 1;
    float tau = t + float(i - s) - 1.0;
    w = vec4(-tau * (tau - 1.0) * (tau - 2.0) / 6.0, (tau + 1.0) * (tau - 1.0) * (tau - 2.0) / 2.0,
             -(tau + 1.0) * tau * (tau - 2.0) / 2.0, (tau + 1.0) * tau * (tau - 1.0) / 6.0);
    return s;
}

// E_c(mu) of epd_albedo (cubic over p reciprocal, beta log, theta bounded_log_tan in (sin, cos)).
float ts_g_albedo(TsParams m, float sin_t, float cos_t) {
    vec4 wp, wb, wt;
    int sp = ts_g_stencil(ts_ga_p, 1.0 / m.p, wp), sb = ts_g_stencil(ts_ga_beta, log(m.beta), wb);
    int st = ts_g_stencil(ts_ga_theta, ts_log_tan(ts_ga_theta, sin_t, cos_t), wt);
    float e = 0.0;
    for (int i = 0; i < 4; i++) {
        for (int j = 0; j < 4; j++) {
            int row = ts_goff_alb + ((sp + i) * ts_ga_beta.n + sb + j) * ts_ga_theta.n + st;
            e += wp[i] * wb[j] * dot(wt, vec4(ts_gat(row), ts_gat(row + 1), ts_gat(row + 2), ts_gat(row + 3)));
        }
    }
    return e;
}

float ts_g_albedo_avg(TsParams m) {
    vec4 wp, wb;
    int sp = ts_g_stencil(ts_ga_p, 1.0 / m.p, wp), sb = ts_g_stencil(ts_ga_beta, log(m.beta), wb);
    float e = 0.0;
    for (int i = 0; i < 4; i++) {
        int row = ts_goff_alb_avg + (sp + i) * ts_ga_beta.n + sb;
        e += wp[i] * dot(wb, vec4(ts_gat(row), ts_gat(row + 1), ts_gat(row + 2), ts_gat(row + 3)));
    }
    return e;
}

// rho at lambda without the cosine from a pixel's geometry (wi, wo above the surface): F(cos_d) (spec + diff), plus
// with energy compensated (1 - E_c(i)) (1 - E_c(o)) / (pi (1 - E_c_avg)) F_avg^2 E_c_avg / (1 - F_avg (1 - E_c_avg)).
float ts_general_eval_at(TsGeneralGeom g, float lambda, TsParams m, TsFresnel f, bool exact_lobe, bool compensated) {
    vec2 parts = ts_general_parts_at(g, lambda, m, exact_lobe, compensated);
    float rho = ts_fresnel_eval(f, g.cos_d) * (parts.x + parts.y);
    return compensated ? rho + ts_multiple(g.e_c, f) : rho;
}

// rho(wi, wo) at lambda without the cosine; 0 below the surface.
float ts_general_eval(vec3 wi, vec3 wo, float lambda, TsParams m, TsFresnel f, bool exact_lobe, bool compensated) {
    if (!(wi.z > 0.0 && wo.z > 0.0)) return 0.0;
    return ts_general_eval_at(ts_general_geometry(wi, wo, m, exact_lobe, compensated), lambda, m, f, exact_lobe, compensated);
}

// ---------------------------------------------------------------------------------------------------------
// General mode's sampling and its exact pdf (docs/runtimes.md "General mode"): the EPD by epd_quantile at beta = 1
// (tan theta_m = beta tan theta_1), the diffraction part by zh_convolution's plain fitted lobe inverted in closed
// form, mixed as ts_sample mixes them (w_d, and the cosine lobe's w_ms with energy compensated).

// The density in theta_1 of epd_quantile's row interpolated in p (rows r0, r1, weight t): ts_quantile_density's
// binary search over ts_gdata.
float ts_g_quantile_density(int r0, int r1, float t, int n, float theta, float sin_theta) {
    float hstep = ts_pi_2 / float(n - 1);
    float q_lo = (1.0 - t) * ts_gat(r0) + t * ts_gat(r1), q_hi = (1.0 - t) * ts_gat(r0 + n - 1) + t * ts_gat(r1 + n - 1);
    if (!(theta >= q_lo && theta <= q_hi)) return 0.0;
    int lo = 0, len = n - 1;
    while (len > 1) {
        int half_len = len / 2, k = lo + half_len;
        lo = (1.0 - t) * ts_gat(r0 + k) + t * ts_gat(r1 + k) <= theta ? k : lo;
        len -= half_len;
    }
    float a0 = ts_gat(r0 + lo), b0 = ts_gat(r1 + lo);
    q_lo = (1.0 - t) * a0 + t * b0;
    float dq = (1.0 - t) * (ts_gat(r0 + lo + 1) - a0) + t * (ts_gat(r1 + lo + 1) - b0);
    if (!(dq > 0.0)) return 0.0;
    if (sin_theta > 0.0) return ts_sincos(2.0 * (float(lo) + (theta - q_lo) / dq) * hstep).x * hstep / dq / sin_theta;
    return 2.0 * hstep * hstep / (dq * dq);
}

// The EPD strategy's density over sin(theta_m) at theta_m: theta_1 = atan2(sin, beta cos), times
// d theta_1 / d theta_m = beta / (beta^2 cos^2 + sin^2), and sin theta_1 / sin theta_m.
float ts_g_epd_density(TsParams m, float sin_h, float cos_h) {
    float t;
    int i = ts_cell(ts_gq_p, log(m.p), t), r0 = ts_goff_q + i * ts_gq_xi.n;
    float th1 = atan(sin_h, m.beta * cos_h), s1 = sin(th1);
    float q = ts_g_quantile_density(r0, r0 + ts_gq_xi.n, t, ts_gq_xi.n, th1, s1);
    float jac = m.beta / (m.beta * m.beta * cos_h * cos_h + sin_h * sin_h);
    return sin_h > 0.0 ? q * s1 * jac / sin_h : q * jac / m.beta;  // theta -> 0: sin theta_1 / sin theta_m -> 1 / beta
}

// (a, k) of the diffraction strategy at u_0 = (b / lambda_0) cos theta_i: a = 4 g^2 of zh_convolution's plain lobe,
// k = (c - 1)/2; its density in theta_h is 2 sin cos (1 + a sin^2)^-(k+1) / Z, Z = (1 - (1 + a)^-k) / (a k).
vec2 ts_g_lobe_shape(TsParams m, float cos_i, float lambda0) {
    float u0 = m.b / lambda0 * cos_i, pd = clamp(m.p, ts_gp_diff_lo, ts_gp_diff_hi);
    float t0, t1, t2, t3;
    int i0 = ts_cell(ts_gz_u, log(u0 - ts_gz_u.p0), t0), i1 = ts_cell(ts_gz_c, m.c, t1);
    int i2 = ts_cell(ts_gz_p, log(pd), t2), i3 = ts_cell(ts_gz_beta, log(m.beta), t3);
    float g = 0.0;
    for (int q = 0; q < 16; q++) {
        int d0 = q >> 3, d1 = (q >> 2) & 1, d2 = (q >> 1) & 1, d3 = q & 1;
        float w = (d0 == 1 ? t0 : 1.0 - t0) * (d1 == 1 ? t1 : 1.0 - t1) * (d2 == 1 ? t2 : 1.0 - t2) * (d3 == 1 ? t3 : 1.0 - t3);
        g += w * ts_gat(ts_goff_g + (((i0 + d0) * ts_gz_c.n + i1 + d1) * ts_gz_p.n + i2 + d2) * ts_gz_beta.n + i3 + d3);
    }
    return vec2(max(4.0 * g * g, 1e-12), 0.5 * (m.c - 1.0));
}

// The diffraction strategy's density over sin(theta_h): 2 cos (1 + a sin^2)^-(k+1) a k / (1 - (1 + a)^-k).
float ts_g_lobe_density(vec2 ak, float sin_h, float cos_h) {
    float a = ak.x, k = ak.y;
    return 2.0 * cos_h * exp(-(k + 1.0) * ts_log1p(a * sin_h * sin_h)) * a * k / -ts_expm1(-k * ts_log1p(a));
}

float ts_g_mixture(TsParams m, float cos_i, float lambda0) {
    if (!(m.sigma_s > 0.0)) return 0.0;
    float x = m.sigma_s * 4.0 * ts_pi * cos_i / lambda0;
    return clamp(1.0 - exp(-x * x), 0.1, 0.9);
}

float ts_g_ms_share(TsParams m, vec3 wi, bool compensated) {
    return compensated ? clamp(1.0 - ts_g_albedo(m, length(wi.xy), wi.z), 0.0, 0.9) : 0.0;
}

float ts_general_pdf_weighted(vec3 wi, vec3 wo, float lambda0, TsParams m, float w_d, float w_ms) {
    if (!(wi.z > 0.0 && wo.z > 0.0)) return 0.0;
    vec3 h = wi + wo;
    float hl = length(h), sin_h = length(h.xy) / hl, cos_h = h.z / hl, idoth = abs(dot(wi, h)) / hl;
    float q = (1.0 - w_d) * ts_g_epd_density(m, sin_h, cos_h);
    if (w_d > 0.0) q += w_d * ts_g_lobe_density(ts_g_lobe_shape(m, wi.z, lambda0), sin_h, cos_h);
    q = q / (2.0 * ts_pi) / (4.0 * idoth);
    return (1.0 - w_ms) * q + w_ms * wo.z / ts_pi;
}

float ts_general_pdf(vec3 wi, vec3 wo, float lambda0, TsParams m, bool compensated) {
    return ts_general_pdf_weighted(wi, wo, lambda0, m, ts_g_mixture(m, wi.z, lambda0), ts_g_ms_share(m, wi, compensated));
}

vec3 ts_general_sample(vec3 wi, float lambda0, vec2 xi, TsParams m, TsFresnel f, bool exact_lobe, bool compensated,
                       out float pdf, out float weight) {
    pdf = 0.0;
    weight = 0.0;
    if (!(wi.z > 0.0)) return vec3(0.0);
    float w_d = ts_g_mixture(m, wi.z, lambda0), w_ms = ts_g_ms_share(m, wi, compensated), phi = 2.0 * ts_pi * xi.y;
    vec2 sp = ts_sincos(phi);
    vec3 wo;
    if (xi.x < w_ms) {  // cosine-weighted: sin^2 theta_o = xi.x / w_ms
        float r2 = xi.x / w_ms, r = sqrt(r2);
        wo = vec3(r * sp.y, r * sp.x, sqrt(1.0 - r2));
    } else {
        float x1 = (xi.x - w_ms) / (1.0 - w_ms), theta;
        if (x1 < w_d) {
            // sin^2 theta_h = ((1 - xi (1 - (1 + a)^-k))^(-1/k) - 1) / a, the inverse of the CDF in sin^2
            vec2 ak = ts_g_lobe_shape(m, wi.z, lambda0);
            float z = -ts_expm1(-ak.y * ts_log1p(ak.x)), s2 = clamp(ts_expm1(-ts_log1p(-(x1 / w_d) * z) / ak.y) / ak.x, 0.0, 1.0);
            theta = atan(sqrt(s2), sqrt(1.0 - s2));
        } else {
            // theta_1 = epd_quantile(p, xi) bilinear, tan theta_m = beta tan theta_1
            float t, tx;
            int i = ts_cell(ts_gq_p, log(m.p), t), j = ts_cell(ts_gq_xi, ts_asin_sqrt(clamp((x1 - w_d) / (1.0 - w_d), 0.0, 1.0)), tx);
            int r = ts_goff_q + i * ts_gq_xi.n + j;
            float th1 = (1.0 - t) * ((1.0 - tx) * ts_gat(r) + tx * ts_gat(r + 1)) + t * ((1.0 - tx) * ts_gat(r + ts_gq_xi.n) + tx * ts_gat(r + ts_gq_xi.n + 1));
            vec2 s1 = ts_sincos(th1);
            theta = atan(m.beta * s1.x, max(s1.y, 0.0));
        }
        vec2 st = ts_sincos(theta);
        vec3 h = vec3(st.x * sp.y, st.x * sp.x, st.y);
        wo = 2.0 * dot(wi, h) * h - wi;
    }
    if (!(wo.z > 0.0)) return wo;
    pdf = ts_general_pdf_weighted(wi, wo, lambda0, m, w_d, w_ms);
    if (!(pdf > 0.0)) return wo;
    weight = ts_general_eval(wi, wo, lambda0, m, f, exact_lobe, compensated) * wo.z / pdf;
    return wo;
}
#endif
