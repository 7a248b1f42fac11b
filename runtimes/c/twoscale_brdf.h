/* twoscale_brdf.h: the reference two-scale BRDF (docs/maths.md section 7) over one material's
 * tables, with exactly the semantics of docs/runtimes.md (eval, the sampling mixture, the exact
 * pdf). C99, header-only, no allocation, usable from C++; compute in double.
 *
 * The data come from
 *   twoscale export --format c-header --dir MATERIAL_FOLDER --out DIR
 * which writes one data header per table and twoscale_material_<preset>.h defining
 *   static const twoscale_material twoscale_material_<preset>;
 * (<preset> = the folder's preset with non-identifier characters as _, e.g.
 * scene_test_materials_chi5). Usage:
 *
 *   #include "twoscale_material_scene_test_materials_chi5.h"   (includes this header)
 *
 *   twoscale_brdf brdf;
 *   const char *err = twoscale_brdf_init(&brdf, &twoscale_material_scene_test_materials_chi5, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE);
 *   if (err) { fprintf(stderr, "%s\n", err); exit(1); }
 *   double rho = twoscale_brdf_eval(&brdf, wi, wo, 0.55, twoscale_fresnel_conductor(1.6, 3.2));
 *
 *   cc -std=c99 -O2 -I pipeline/tables/c -I runtimes/c -I DIR app.c -lm     (or c++ -O2 ...)
 *
 * Conventions: directions are unit vectors in the shading frame (z = normal), wi towards the
 * viewer, wo towards the light; lambda in micrometres. twoscale_brdf_eval returns rho, WITHOUT the
 * cosine: Mitsuba's BSDF::eval is twoscale_brdf_eval(...) * wo[2]. twoscale_brdf_sample's weight
 * is rho cos theta_o / pdf, Mitsuba's sample() weight. Sampling and pdf are driven by the hero
 * wavelength lambda_0 the caller passes; the weight at another wavelength lambda of the same
 * sample is twoscale_brdf_eval(.., lambda, ..) * wo[2] / pdf.
 *
 * The tables are read as the Rust and Mitsuba runtimes read them: linear interpolation in each
 * axis' encoded coordinate, clamped to the table's range. Every per-material axis is uniform in its
 * encoding, so a cell is found as floor((e - e0) / step), without search (init checks it).
 */
#ifndef TWOSCALE_BRDF_H
#define TWOSCALE_BRDF_H

#include <float.h>

#include "twoscale_tables.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The material models (docs/maths.md sections 7, 10 and 11). */
#define TWOSCALE_MODEL_CONDUCTOR 0
#define TWOSCALE_MODEL_PLASTIC 1
#define TWOSCALE_MODEL_SUBSURFACE 2

/* A material: the manifests' `material` section and its tables (an exported
 * twoscale_material_<preset>.h fills it). Without diffraction (sigma_s = 0)
 * kcorr_renorm, zh_lobe, zh_lobe_sampling and zh_convolution are NULL and b, c, the
 * wavelengths are unused. The fields after albedo are a layered model's (zero for a conductor): the
 * interface's index and the layer's albedo (a plastic's diffuse albedo d, a subsurface medium's reduced
 * albedo alpha'), layer_n samples (one: a constant) read linearly in lambda, clamped; a subsurface
 * medium's Henyey-Greenstein g and its single-scattering bound single_max (docs/maths.md section 11). */
typedef struct {
    const char *name;
    double beta, p, sigma_s, b, c; /* lengths in micrometres */
    double n_p;                    /* N(p) = p / (pi Gamma(1/p)) */
    double wavelength_min, wavelength_max;
    const twoscale_table *epd_g1, *epd_sampling, *kcorr_renorm, *zh_lobe, *zh_lobe_sampling, *zh_convolution;
    const twoscale_table *albedo; /* albedo and energy compensation (NULL: TWOSCALE_ENERGY_SINGLE only, conductors) */
    int model;                    /* TWOSCALE_MODEL_CONDUCTOR, _PLASTIC or _SUBSURFACE */
    double ior;
    int layer_n;
    const double *layer_wavelengths, *layer_values;
    const twoscale_table *interface_albedo; /* E_F and E_Fc of the dielectric interface (plastic, subsurface) */
    double phase_g, single_max;             /* subsurface */
} twoscale_material;

/* Which C(theta_h) the diffraction part uses (docs/runtimes.md): zh_lobe, or zh_convolution's fitted cos lobe. */
typedef enum { TWOSCALE_LOBE_EXACT, TWOSCALE_LOBE_FIT } twoscale_lobe;

/* The paper's single-scattering BRDF, or the reciprocal energy-compensated one (docs/runtimes.md). */
typedef enum { TWOSCALE_ENERGY_SINGLE, TWOSCALE_ENERGY_COMPENSATED } twoscale_energy;

/* F = 1, or the unpolarised Fresnel reflectance of a conductor of complex index eta + i k or of a
 * dielectric of real index eta, with its average F_avg = 2 int_0^1 F(mu) mu dmu (the compensated
 * BRDF's multiple-scattering factor). */
typedef enum { TWOSCALE_FRESNEL_ONE, TWOSCALE_FRESNEL_CONDUCTOR, TWOSCALE_FRESNEL_DIELECTRIC } twoscale_fresnel_kind;
typedef struct {
    twoscale_fresnel_kind kind;
    double eta, k, avg;
} twoscale_fresnel;

/* Unpolarised conductor Fresnel reflectance at cos_t, index eta + i k (real arithmetic:
 * a^2 + b^2 = |n^2 - sin^2|, r_s = (a^2 + b^2 + cos^2 - 2a cos) / (a^2 + b^2 + cos^2 + 2a cos), a = Re sqrt(n^2 - sin^2),
 * r_p = r_s (t3 - t4) / (t3 + t4), t3 = |..| cos^2 + sin^4, t4 = 2a cos sin^2; (r_s + r_p) / 2 = r_s t3 / (t3 + t4)). */
static inline double twoscale_fresnel_eval(twoscale_fresnel f, double cos_t) {
    double c2, s2, t1, ab, a, t3;
    if (f.kind == TWOSCALE_FRESNEL_ONE) return 1.0;
    if (f.kind == TWOSCALE_FRESNEL_DIELECTRIC) {
        /* g^2 = eta^2 - 1 + c^2; F = 1/2 ((g - c)/(g + c))^2 (1 + ((c (g + c) - 1)/(c (g - c) + 1))^2) (Walter et al. 2007) */
        const double c = fabs(cos_t), g2 = f.eta * f.eta - 1.0 + c * c;
        double g, x, y;
        if (g2 <= 0.0) return 1.0;
        g = sqrt(g2);
        x = (g - c) / (g + c);
        y = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        return 0.5 * x * x * (1.0 + y * y);
    }
    c2 = cos_t * cos_t;
    s2 = 1.0 - c2;
    t1 = f.eta * f.eta - f.k * f.k - s2;
    ab = sqrt(t1 * t1 + 4.0 * f.eta * f.eta * f.k * f.k);
    a = 0.5 * (ab + t1);
    a = a > 0.0 ? sqrt(a) : 0.0;
    t3 = ab * c2 + s2 * s2;
    return (ab + c2 - 2.0 * cos_t * a) * t3 / ((ab + c2 + 2.0 * cos_t * a) * (t3 + 2.0 * cos_t * a * s2));
}

static inline twoscale_fresnel twoscale_fresnel_one(void) {
    twoscale_fresnel f;
    f.kind = TWOSCALE_FRESNEL_ONE;
    f.eta = 1.0;
    f.k = 0.0;
    f.avg = 1.0;
    return f;
}

/* F_avg by 8-point Gauss-Legendre in mu (conductors: error < 1e-5 for k >= 1, 5e-5 for k >= 0.3). */
static inline twoscale_fresnel twoscale_fresnel_averaged(twoscale_fresnel_kind kind, double eta, double k) {
    static const double x[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363};
    static const double w[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
    twoscale_fresnel f;
    int j;
    f.kind = kind;
    f.eta = eta;
    f.k = k;
    f.avg = 0.0;
    for (j = 0; j < 4; j++) { /* nodes (1 -+ x)/2 on [0, 1], weights w/2; F_avg = sum 2 (w/2) mu F(mu) */
        const double lo = 0.5 * (1.0 - x[j]), hi = 0.5 * (1.0 + x[j]);
        f.avg += w[j] * (lo * twoscale_fresnel_eval(f, lo) + hi * twoscale_fresnel_eval(f, hi));
    }
    return f;
}

static inline twoscale_fresnel twoscale_fresnel_conductor(double eta, double k) {
    return twoscale_fresnel_averaged(TWOSCALE_FRESNEL_CONDUCTOR, eta, k);
}

/* A dielectric of real index eta (a layered model's interface: twoscale_brdf_init takes it from the material). */
static inline twoscale_fresnel twoscale_fresnel_dielectric(double eta) {
    return twoscale_fresnel_averaged(TWOSCALE_FRESNEL_DIELECTRIC, eta, 0.0);
}

/* ---------------------------------------------------------------------------
 * ln and exp, inline. Through libm's calls, eval's 7 logs and 2 exps were 40 % of its instructions;
 * inline they make eval 4-10 % faster (docs/runtimes.md). Accurate to about 1 ulp (tests/c/log_exp.c).
 * ------------------------------------------------------------------------- */

/* The tables of twoscale_log and twoscale_exp (twoscale_math_init). */
typedef struct {
    double log_invc[128], log_c[128]; /* twoscale_log: 1/c_j and -ln(1/c_j) of its 128 intervals */
    double exp2_j[128];               /* twoscale_exp: 2^(j/128) */
} twoscale_math;

static inline unsigned long long twoscale_bits(double x) {
    unsigned long long u;
    memcpy(&u, &x, sizeof u);
    return u;
}

static inline double twoscale_from_bits(unsigned long long u) {
    double x;
    memcpy(&x, &u, sizeof x);
    return x;
}

/* twoscale_log writes x = 2^k z with z in [0.6875, 1.375) (k = 0 near 1) and splits z's range into 128
 * intervals j, uniform in the bits (2^-8 wide below 1, 2^-7 above); c_j is an interval's midpoint. */
#define TWOSCALE_LOG_OFF 0x3fe6000000000000ULL

static inline void twoscale_math_init(twoscale_math *m) {
    int j;
    for (j = 0; j < 128; j++) {
        const double lo = twoscale_from_bits(TWOSCALE_LOG_OFF + ((unsigned long long)j << 45));
        const double hi = twoscale_from_bits(TWOSCALE_LOG_OFF + ((unsigned long long)(j + 1) << 45));
        m->log_invc[j] = 2.0 / (lo + hi);
        m->log_c[j] = -log(m->log_invc[j]);
        m->exp2_j[j] = exp2((double)j / 128.0);
    }
}

/* ln x for normal finite x > 0 (anything else gives a meaningless value, without a fault):
 * k ln 2 + ln c_j + ln(1 + r), r = z / c_j - 1, |r| < 2^-8, the series of ln(1 + r) to r^6 (error < 4e-18),
 * ln 2 in two parts (fdlibm's). */
static inline double twoscale_log(const twoscale_math *m, double x) {
    const unsigned long long u = twoscale_bits(x), tmp = u - TWOSCALE_LOG_OFF;
    const int j = (int)((tmp >> 45) & 127);
    const double k = (double)((long long)tmp >> 52); /* an arithmetic shift: k < 0 below 0.6875 */
    const double z = twoscale_from_bits(u - (tmp & 0xfff0000000000000ULL));
    const double r = z * m->log_invc[j] - 1.0, r2 = r * r;
    const double series = r - r2 * (0.5 - r * (1.0 / 3.0 - r * 0.25)) + r2 * r2 * r * (0.2 - r * (1.0 / 6.0));
    return k * 6.93147180369123816490e-01 + (m->log_c[j] + (series + k * 1.90821492927058770002e-10));
}

/* exp x (0 below -708, +inf above 709, NaN for NaN): x = (128 k + j) ln2/128 + r with |r| <= ln2/256,
 * exp x = 2^k 2^(j/128) (1 + r + .. + r^5/120) (series error < 1e-18), the 1 added last. */
static inline double twoscale_exp(const twoscale_math *m, double x) {
    const double shift = 6755399441055744.0; /* 1.5 2^52: adding it rounds x 128/ln2 to an integer n in the low bits */
    const double kd = x * (128.0 / TWOSCALE_LN_2) + shift, n = kd - shift;
    const unsigned long long bits = twoscale_bits(kd);
    const double r = (x - n * 5.41521234663378e-03) - n * 1.4907929134926466e-12; /* n ln2/128 in two parts (the first exact) */
    const double r2 = r * r, series = r + r2 * (0.5 + r * (1.0 / 6.0)) + r2 * r2 * (1.0 / 24.0 + r * (1.0 / 120.0)); /* e^r - 1 */
    const double scale = twoscale_from_bits(twoscale_bits(m->exp2_j[bits & 127]) + ((bits >> 7) << 52)); /* 2^(j/128) 2^k */
    return x < -708.0 ? 0.0 : (x > 709.0 ? HUGE_VAL : scale + scale * series);
}

/* x^p = exp(p ln x) for x >= 0 (x below DBL_MIN taken as DBL_MIN: the logs want a normal number). */
static inline double twoscale_pow(const twoscale_math *m, double x, double p) {
    return twoscale_exp(m, p * twoscale_log(m, x > DBL_MIN ? x : DBL_MIN));
}

/* An axis uniform in its encoding e: node i at e0 + i / inv_step; p0, p1 the encoding's parameters. */
typedef struct {
    int n, last_cell; /* nodes, n - 2 */
    double e0, inv_step, p0, p1, last; /* last = n - 1 */
} twoscale_grid;

/* The BRDF of one material, ready to evaluate (twoscale_brdf_init). Read only afterwards: any
 * number of threads may share it. */
typedef struct {
    const twoscale_material *m;
    twoscale_lobe lobe;
    int diffracting;
    double spec_scale;  /* N(p) / (4 beta^2): D G2 / (4 cos_i cos_o) without the exp */
    double inv_beta2;   /* 1 / beta^2 */
    double d_cut;       /* exp(-(tan^2 theta_h / beta^2)^p) < e^-104, 0 in float32, beyond tan^2 theta_h / beta^2 = d_cut */
    double k_scale;     /* (c - 1) / (2 pi) N(p) / beta^2 */
    double lobe_power;  /* -(c + 1) / 2 */
    double sigma4pi;    /* 4 pi sigma_s */
    double inv_u_scale; /* 1 / the scale of zh_lobe's u axis (log1p_sq) */
    double edge_d2;     /* zh_lobe's angle: edge_d^2 */
    double inv_theta_cap; /* zh_lobe's angle: 1 / theta_cap */
    double v_ln2;       /* v_anchor / ln 2 */
    twoscale_grid g1_theta, samp_xi, kc_s, kc_b, lobe_u, lobe_v, ls_u, ls_xi, conv_u;
    const float *g1, *samp, *kc, *lobe_data, *ls, *s_cos, *g_cos;
    const twoscale_derived_axis *lobe_angle; /* zh_lobe's v_theta from (u, theta_h) */
    twoscale_math math;
    twoscale_energy energy;
    int albedo_lambda;                       /* the albedo tables have a wavelength axis (diffracting materials) */
    twoscale_grid alb_mu, alb_lam;
    const float *alb_g, *alb_e, *alb_avg;
    int layered;                             /* a dielectric interface over a layer: plastic or subsurface (docs/maths.md sections 10, 11) */
    twoscale_fresnel interface;              /* its Fresnel factor, from the material's ior */
    const float *ia_e, *ia_avg;              /* interface_albedo: e_f and e_f_avg, or e_fc and e_fc_avg (compensated) */
} twoscale_brdf;

/* ---------------------------------------------------------------------------
 * Table access.
 * ------------------------------------------------------------------------- */

/* The cell i (nodes i, i + 1) of the encoded coordinate e, clamped to the axis, and the weight t of node i + 1. */
static inline int twoscale_grid_cell(const twoscale_grid *g, double e, double *t) {
    double f = (e - g->e0) * g->inv_step;
    int i;
    f = f > 0.0 ? f : 0.0; /* NaN too */
    f = f < g->last ? f : g->last;
    i = (int)f;
    i = i < g->last_cell ? i : g->last_cell;
    *t = f - (double)i;
    return i;
}

/* Linear interpolation of data[] (one value per node) at e. */
static inline double twoscale_grid_lerp(const twoscale_grid *g, const float *data, double e) {
    double t;
    const int i = twoscale_grid_cell(g, e, &t);
    return (1.0 - t) * (double)data[i] + t * (double)data[i + 1];
}

/* Bilinear interpolation of data[a][b] (C order, b->n per row) at (ea, eb). */
static inline double twoscale_grid_lerp2(const twoscale_grid *a, const twoscale_grid *b, const float *data, double ea, double eb) {
    double ta, tb;
    const int i = twoscale_grid_cell(a, ea, &ta), j = twoscale_grid_cell(b, eb, &tb);
    const float *r0 = data + (size_t)i * (size_t)b->n, *r1 = r0 + b->n;
    return (1.0 - ta) * ((1.0 - tb) * (double)r0[j] + tb * (double)r0[j + 1]) + ta * ((1.0 - tb) * (double)r1[j] + tb * (double)r1[j + 1]);
}

/* The uniform grid of axis a of table t with encoding `enc`; NULL, or what is wrong. */
static inline const char *twoscale_grid_init(twoscale_grid *g, const twoscale_table *t, int a, twoscale_axis_encoding enc) {
    const twoscale_axis *axis = &t->axes[a];
    const int n = axis->size;
    double step;
    int i;
    if (axis->encoding != enc) return "twoscale_brdf_init: a table's axis has another encoding than docs/material_tables.md gives";
    if (n < 2) return "twoscale_brdf_init: a table's axis has fewer than 2 nodes";
    step = (axis->encoded[n - 1] - axis->encoded[0]) / (double)(n - 1);
    for (i = 0; i < n; i++)
        if (fabs(axis->encoded[i] - (axis->encoded[0] + (double)i * step)) > 1e-9 * fabs(step) * (double)(n - 1))
            return "twoscale_brdf_init: a table's axis is not uniform in its encoding (not a per-material table)";
    g->n = n;
    g->e0 = axis->encoded[0];
    g->inv_step = 1.0 / step;
    g->last = (double)(n - 1);
    g->last_cell = n - 2;
    g->p0 = axis->param[0];
    g->p1 = axis->param[1];
    return NULL;
}

/* The data of value `name` of table t, or NULL. */
static inline const float *twoscale_brdf_values(const twoscale_table *t, const char *name) {
    int v;
    for (v = 0; v < t->nvalues; v++)
        if (strcmp(t->values[v].name, name) == 0) return t->values[v].data;
    return NULL;
}

/* The table `t` is `name` with `dims` axes, multilinear; NULL, or the error. */
static inline const char *twoscale_brdf_check(const twoscale_table *t, const char *name, int dims) {
    if (t == NULL) return "twoscale_brdf_init: the material lacks a table it needs (export the whole material folder)";
    if (strcmp(t->table, name) != 0 || t->dims != dims) return "twoscale_brdf_init: a table pointer of the material names another table";
    if (t->interpolation != TWOSCALE_MULTILINEAR) return "twoscale_brdf_init: a table is not multilinear (per-material tables are; this BRDF reads them bilinearly)";
    return NULL;
}

/* The albedo table of energy = compensated: g, e_comp and e_comp_avg over theta_i (bounded_log_tan) and
 * lambda (log) where the material diffracts. */
static inline const char *twoscale_brdf_init_energy(twoscale_brdf *brdf, const twoscale_material *m) {
    const char *err;
    if ((err = twoscale_brdf_check(m->albedo, "albedo", brdf->diffracting ? 2 : 1)) || (err = twoscale_grid_init(&brdf->alb_mu, m->albedo, 0, TWOSCALE_BOUNDED_LOG_TAN)))
        return err;
    brdf->albedo_lambda = brdf->diffracting;
    if (brdf->albedo_lambda && (err = twoscale_grid_init(&brdf->alb_lam, m->albedo, 1, TWOSCALE_LOG))) return err;
    brdf->alb_g = twoscale_brdf_values(m->albedo, "g");
    brdf->alb_e = twoscale_brdf_values(m->albedo, "e_comp");
    brdf->alb_avg = twoscale_brdf_values(m->albedo, "e_comp_avg");
    if (!brdf->alb_g || !brdf->alb_e || !brdf->alb_avg) return "twoscale_brdf_init: albedo lacks g, e_comp or e_comp_avg";
    return NULL;
}

/* A layered model's interface_albedo, on the albedo grid (the same axes): e_f and e_f_avg, or e_fc and e_fc_avg. */
static inline const char *twoscale_brdf_init_layered(twoscale_brdf *brdf, const twoscale_material *m) {
    const twoscale_table *t = m->interface_albedo;
    const int compensated = brdf->energy == TWOSCALE_ENERGY_COMPENSATED;
    twoscale_grid mu, lam;
    const char *err;
    if (!(m->ior > 1.0) || m->layer_n < 1 || !m->layer_values || (m->layer_n > 1 && !m->layer_wavelengths))
        return "twoscale_brdf_init: a plastic or subsurface material needs ior > 1 and its layer's albedo";
    if (m->model == TWOSCALE_MODEL_SUBSURFACE && !(fabs(m->phase_g) < 1.0 && m->single_max >= 0.0))
        return "twoscale_brdf_init: a subsurface material needs |g| < 1 and single_max >= 0";
    if ((err = twoscale_brdf_check(t, "interface_albedo", brdf->diffracting ? 2 : 1)) || (err = twoscale_grid_init(&mu, t, 0, TWOSCALE_BOUNDED_LOG_TAN)))
        return err;
    if (!compensated) brdf->alb_mu = mu;
    brdf->albedo_lambda = brdf->diffracting;
    if (brdf->diffracting) {
        if ((err = twoscale_grid_init(&lam, t, 1, TWOSCALE_LOG))) return err;
        if (!compensated) brdf->alb_lam = lam;
        if (lam.n != brdf->alb_lam.n || lam.e0 != brdf->alb_lam.e0 || lam.inv_step != brdf->alb_lam.inv_step)
            return "twoscale_brdf_init: interface_albedo and albedo have different axes";
    }
    if (mu.n != brdf->alb_mu.n || mu.e0 != brdf->alb_mu.e0 || mu.inv_step != brdf->alb_mu.inv_step || mu.p0 != brdf->alb_mu.p0 || mu.p1 != brdf->alb_mu.p1)
        return "twoscale_brdf_init: interface_albedo and albedo have different axes";
    brdf->layered = 1;
    brdf->interface = twoscale_fresnel_dielectric(m->ior);
    brdf->ia_e = twoscale_brdf_values(t, compensated ? "e_fc" : "e_f");
    brdf->ia_avg = twoscale_brdf_values(t, compensated ? "e_fc_avg" : "e_f_avg");
    if (!brdf->ia_e || !brdf->ia_avg) return "twoscale_brdf_init: interface_albedo lacks e_f, e_fc or their averages";
    return NULL;
}

/* Prepares brdf for material m with the lobe and energy choices; NULL, or a one-line reason. */
static inline const char *twoscale_brdf_init(twoscale_brdf *brdf, const twoscale_material *m, twoscale_lobe lobe, twoscale_energy energy) {
    const char *err;
    memset(brdf, 0, sizeof *brdf);
    brdf->m = m;
    brdf->lobe = lobe;
    brdf->energy = energy;
    brdf->diffracting = m->sigma_s > 0.0;
    brdf->inv_beta2 = 1.0 / (m->beta * m->beta);
    brdf->spec_scale = 0.25 * m->n_p * brdf->inv_beta2;
    brdf->d_cut = pow(104.0, 1.0 / m->p); /* e^-104 = 6.8e-46 rounds to 0 in float32 (its smallest subnormal is 1.4e-45) */
    brdf->k_scale = (m->c - 1.0) / (2.0 * TWOSCALE_PI) * m->n_p * brdf->inv_beta2;
    brdf->lobe_power = -0.5 * (m->c + 1.0);
    brdf->sigma4pi = 4.0 * TWOSCALE_PI * m->sigma_s;
    twoscale_math_init(&brdf->math);
    if ((err = twoscale_brdf_check(m->epd_g1, "epd_g1", 1)) || (err = twoscale_grid_init(&brdf->g1_theta, m->epd_g1, 0, TWOSCALE_BOUNDED_LOG_TAN))) return err;
    if ((err = twoscale_brdf_check(m->epd_sampling, "epd_sampling", 1)) || (err = twoscale_grid_init(&brdf->samp_xi, m->epd_sampling, 0, TWOSCALE_ASIN_SQRT))) return err;
    brdf->g1 = twoscale_brdf_values(m->epd_g1, "g1");
    brdf->samp = twoscale_brdf_values(m->epd_sampling, "theta_m");
    if (!brdf->g1 || !brdf->samp) return "twoscale_brdf_init: epd_g1 or epd_sampling lacks its value";
    if (energy == TWOSCALE_ENERGY_COMPENSATED && (err = twoscale_brdf_init_energy(brdf, m))) return err;
    if (m->model != TWOSCALE_MODEL_CONDUCTOR && m->model != TWOSCALE_MODEL_PLASTIC && m->model != TWOSCALE_MODEL_SUBSURFACE)
        return "twoscale_brdf_init: unknown material model";
    if (m->model != TWOSCALE_MODEL_CONDUCTOR && (err = twoscale_brdf_init_layered(brdf, m))) return err;
    if (!brdf->diffracting) return NULL;
    if ((err = twoscale_brdf_check(m->kcorr_renorm, "kcorr_renorm", 2)) || (err = twoscale_grid_init(&brdf->kc_s, m->kcorr_renorm, 0, TWOSCALE_LOG_GAP)) ||
        (err = twoscale_grid_init(&brdf->kc_b, m->kcorr_renorm, 1, TWOSCALE_LOG)))
        return err;
    if ((err = twoscale_brdf_check(m->zh_lobe, "zh_lobe", 2)) || (err = twoscale_grid_init(&brdf->lobe_u, m->zh_lobe, 0, TWOSCALE_LOG1P_SQ)) ||
        (err = twoscale_grid_init(&brdf->lobe_v, m->zh_lobe, 1, TWOSCALE_LINEAR)))
        return err;
    if ((err = twoscale_brdf_check(m->zh_lobe_sampling, "zh_lobe_sampling", 2)) || (err = twoscale_grid_init(&brdf->ls_u, m->zh_lobe_sampling, 0, TWOSCALE_LOG1P_SQ)) ||
        (err = twoscale_grid_init(&brdf->ls_xi, m->zh_lobe_sampling, 1, TWOSCALE_ASIN_SQRT)))
        return err;
    if ((err = twoscale_brdf_check(m->zh_convolution, "zh_convolution", 1)) || (err = twoscale_grid_init(&brdf->conv_u, m->zh_convolution, 0, TWOSCALE_SHIFTED_LOG))) return err;
    /* zh_lobe's angle: v_theta derived from (u, theta_h), in that order (material_lobe_angle). */
    if (m->zh_lobe->nderived != 1 || m->zh_lobe->derived[0].kind != TWOSCALE_MATERIAL_LOBE_ANGLE || m->zh_lobe->derived[0].axis != 1 ||
        m->zh_lobe->derived[0].inputs[0] != 0)
        return "twoscale_brdf_init: zh_lobe's angle axis is not the material_lobe_angle of (u, theta_h)";
    brdf->lobe_angle = &m->zh_lobe->derived[0];
    brdf->inv_u_scale = 1.0 / brdf->lobe_u.p0;
    brdf->edge_d2 = brdf->lobe_angle->edge_d * brdf->lobe_angle->edge_d;
    brdf->inv_theta_cap = 1.0 / brdf->lobe_angle->theta_cap;
    brdf->v_ln2 = brdf->lobe_angle->v_anchor / TWOSCALE_LN_2;
    brdf->kc = twoscale_brdf_values(m->kcorr_renorm, "r");
    brdf->lobe_data = twoscale_brdf_values(m->zh_lobe, "c_lobe");
    brdf->ls = twoscale_brdf_values(m->zh_lobe_sampling, "theta_h");
    brdf->s_cos = twoscale_brdf_values(m->zh_convolution, "s_cos");
    brdf->g_cos = twoscale_brdf_values(m->zh_convolution, "g_cos");
    if (!brdf->kc || !brdf->lobe_data || !brdf->ls || !brdf->s_cos || !brdf->g_cos) return "twoscale_brdf_init: a diffraction table lacks its value";
    return NULL;
}

/* ---------------------------------------------------------------------------
 * The factors of rho.
 * ------------------------------------------------------------------------- */

/* atan(y / x) for y >= 0, x > 0: Cephes' atan (reduced to |t| <= 0.66 by atan(y/x) = pi/2 - atan(x/y) or
 * pi/4 + atan((y - x)/(y + x)), then t + t z P(z)/Q(z), z = t^2; relative error < 2.4e-16 against atan2), written
 * without branches: half the cost of libm's atan2 on random angles. */
static inline double twoscale_atan_ratio(double y, double x) {
    const int big = y > 2.41421356237309504880 * x, mid = y > 0.66 * x; /* tan(3 pi/8) */
    const double num = big ? -x : (mid ? y - x : y), den = big ? y : (mid ? y + x : x);
    const double base = big ? TWOSCALE_PI_2 : (mid ? 0.5 * TWOSCALE_PI_2 : 0.0);
    const double more = big ? 6.123233995736765886130e-17 : (mid ? 3.061616997868382943065e-17 : 0.0); /* pi/2 - (double)(pi/2), halved */
    const double t = num / den, z = t * t;
    const double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z - 7.500855792314704667340e1) * z - 1.228866684490136173410e2) * z -
                     6.485021904942025371773e1;
    const double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z + 4.328810604912902668951e2) * z + 4.853903996359136964868e2) * z +
                     1.945506571482613964425e2;
    return base + (t + (t * z * p / q + more));
}

/* A = exp(-(4 pi sigma_s cos_d / lambda)^2), given 1 / lambda. */
static inline double twoscale_brdf_coherent(const twoscale_brdf *f, double cos_d, double inv_lambda) {
    const double x = f->sigma4pi * cos_d * inv_lambda;
    return twoscale_exp(&f->math, -x * x);
}

/* Bilinear interpolation of data[a][b] at the cells (i, j) and weights (ta, tb) of twoscale_grid_cell. */
static inline double twoscale_grid_at2(const float *data, int nb, int i, int j, double ta, double tb) {
    const float *r0 = data + (size_t)i * (size_t)nb, *r1 = r0 + nb;
    return (1.0 - ta) * ((1.0 - tb) * (double)r0[j] + tb * (double)r0[j + 1]) + ta * ((1.0 - tb) * (double)r1[j] + tb * (double)r1[j + 1]);
}

/* (g, E_c) of `albedo` (energy compensated) at its encoded theta coordinate e_mu (bounded_log_tan) and
 * ln lambda: one cell for both values. */
static inline void twoscale_brdf_albedo(const twoscale_brdf *f, double e_mu, double ln_lambda, double *g, double *e) {
    double ta, tb;
    const int i = twoscale_grid_cell(&f->alb_mu, e_mu, &ta);
    if (f->albedo_lambda) {
        const int j = twoscale_grid_cell(&f->alb_lam, ln_lambda, &tb);
        *g = twoscale_grid_at2(f->alb_g, f->alb_lam.n, i, j, ta, tb);
        *e = twoscale_grid_at2(f->alb_e, f->alb_lam.n, i, j, ta, tb);
    } else {
        *g = (1.0 - ta) * (double)f->alb_g[i] + ta * (double)f->alb_g[i + 1];
        *e = (1.0 - ta) * (double)f->alb_e[i] + ta * (double)f->alb_e[i + 1];
    }
}

/* An average of the albedo grid (E_c_avg, E_F_avg) at ln lambda, read at theta = 0 (node 0: it does not depend on theta). */
static inline double twoscale_brdf_albedo_avg(const twoscale_brdf *f, const float *avg, double ln_lambda) {
    return f->albedo_lambda ? twoscale_grid_lerp(&f->alb_lam, avg, ln_lambda) : (double)avg[0];
}

/* A value of the albedo grid (a layered model's E_F) at (e_mu, ln lambda). */
static inline double twoscale_brdf_albedo_value(const twoscale_brdf *f, const float *data, double e_mu, double ln_lambda) {
    return f->albedo_lambda ? twoscale_grid_lerp2(&f->alb_mu, &f->alb_lam, data, e_mu, ln_lambda) : twoscale_grid_lerp(&f->alb_mu, data, e_mu);
}

/* The multiple-scattering lobe's Fresnel factor (Kulla and Conty): F_avg^2 E_c_avg / (1 - F_avg (1 - E_c_avg)). */
static inline double twoscale_brdf_ms_factor(double e_c_avg, double f_avg) {
    return f_avg * f_avg * e_c_avg / (1.0 - f_avg * (1.0 - e_c_avg));
}

/* The layer's albedo at lambda (a plastic's d, a subsurface medium's alpha'): its samples read linearly, clamped. */
static inline double twoscale_brdf_layer_value(const twoscale_material *m, double lambda) {
    const double *w = m->layer_wavelengths, *v = m->layer_values;
    int k = 1;
    double t;
    if (m->layer_n == 1 || lambda <= w[0]) return v[0];
    if (lambda >= w[m->layer_n - 1]) return v[m->layer_n - 1];
    while (w[k] < lambda) k++;
    t = (lambda - w[k - 1]) / (w[k] - w[k - 1]);
    return (1.0 - t) * v[k - 1] + t * v[k];
}

/* What a layered model's interface lets into the layer (docs/maths.md section 10): T = max(1 - E_F, 0) from its albedo e at the
 * incidence, or with energy compensated T = max(1 - E_Fc - (1 - E_c) m, 0), loss = 1 - E_c (clamped at 0), m = ms_factor. */
static inline double twoscale_brdf_transmitted(double e, double loss, double ms) {
    const double t = 1.0 - e - loss * ms;
    return t > 0.0 ? t : 0.0;
}

/* The share of the light let in that leaves as a Lambertian lobe T(o) / (pi T_avg), with r = 1 - T_avg / eta^2 the
 * interface's internal reflectance: a plastic's d_eff = d (1 - r) / (1 - d r) (section 10); a subsurface medium's
 * R_d (1 - alpha s_max) (section 11), and *single = alpha (the single-scattering albedo). */
static inline double twoscale_brdf_diffuse_share(const twoscale_brdf *f, double t_avg, double lambda, double *single) {
    const twoscale_material *m = f->m;
    const double a = twoscale_brdf_layer_value(m, lambda), r = 1.0 - t_avg / (m->ior * m->ior);
    double alpha, big_a, s3;
    *single = 0.0;
    if (m->model == TWOSCALE_MODEL_PLASTIC) return a * (1.0 - r) / (1.0 - a * r);
    /* alpha = alpha' / (alpha' + (1 - alpha')(1 - g)); R_d = alpha'/2 (1 + e^(-4/3 A sqrt(3(1 - alpha')))) e^(-sqrt(3(1 - alpha'))) */
    alpha = a / (a + (1.0 - a) * (1.0 - m->phase_g));
    big_a = (1.0 + r) / (1.0 - r);
    s3 = sqrt(3.0 * (1.0 - a));
    *single = alpha;
    return 0.5 * a * (1.0 + exp(-4.0 / 3.0 * big_a * s3)) * exp(-s3) * (1.0 - alpha * m->single_max);
}

/* The layer's lobes, layer[] = T(i), T(o), T_avg: a plastic's d_eff T(i) T(o) / (pi T_avg); a subsurface medium's
 * f_multi = R_d (1 - alpha s_max) T(i) T(o) / (pi T_avg) plus f_single = alpha T(i) T(o) p_g(t_i . o') / (eta^2 (mu_i' + mu_o')),
 * mu' the cosines refracted through the mean surface, t_i . o' = -(i_x o_x + i_y o_y) / eta^2 - mu_i' mu_o'. */
static inline double twoscale_brdf_layer(const twoscale_brdf *f, const double layer[3], double lambda, const double wi[3], const double wo[3]) {
    const double eta = f->m->ior, g = f->m->phase_g;
    double alpha, rho, mi, mo, c, q;
    if (!(layer[2] > 0.0)) return 0.0;
    rho = twoscale_brdf_diffuse_share(f, layer[2], lambda, &alpha) * layer[0] * layer[1] / (TWOSCALE_PI * layer[2]);
    if (f->m->model != TWOSCALE_MODEL_SUBSURFACE) return rho;
    mi = sqrt(1.0 - (1.0 - wi[2] * wi[2]) / (eta * eta));
    mo = sqrt(1.0 - (1.0 - wo[2] * wo[2]) / (eta * eta));
    c = -(wi[0] * wo[0] + wi[1] * wo[1]) / (eta * eta) - mi * mo;
    q = 1.0 + g * g - 2.0 * g * c;
    return rho + alpha * layer[0] * layer[1] * (1.0 - g * g) / (4.0 * TWOSCALE_PI * q * sqrt(q)) / (eta * eta * (mi + mo));
}

/* C(theta_h; u) of zh_convolution's fitted cos lobe s_cos (1 + 4 g_cos^2 sin^2 theta_h)^(-(c+1)/2) cos^2 theta_h,
 * at u's encoded coordinate e_u (shifted_log). */
static inline double twoscale_brdf_fit_lobe(const twoscale_brdf *f, double e_u, double sin2_h, double cos2_h) {
    double t;
    const int i = twoscale_grid_cell(&f->conv_u, e_u, &t);
    const double s = (1.0 - t) * (double)f->s_cos[i] + t * (double)f->s_cos[i + 1];
    const double g = (1.0 - t) * (double)f->g_cos[i] + t * (double)f->g_cos[i + 1];
    return s * twoscale_pow(&f->math, 1.0 + 4.0 * g * g * sin2_h, f->lobe_power) * cos2_h;
}

/* ---------------------------------------------------------------------------
 * rho in three stages: geometry and the arguments of the logs (prepare), the logs that give the
 * tables' encoded coordinates (encode, zh_lobe's first: its chain log -> table read -> exp is the
 * longest), the table reads and exps (combine).
 * ------------------------------------------------------------------------- */

/* One (wi, wo, lambda) between the stages. The coordinate fields hold a log's argument after
 * prepare and the encoded coordinate after encode. */
typedef struct {
    double lambda, inv_lambda, bb;   /* B = b / lambda */
    double cos_d;                    /* i.h / |h| = sqrt((1 + i.o)/2), in [0, 1] */
    double y, sec2_h, cos_io;        /* tan^2 theta_h / beta^2, 1/cos^2 theta_h, cos_i cos_o */
    double sin2_h;                   /* lobe fit: sin^2 theta_h */
    double g1_i, g1_o;               /* epd_g1's theta at theta_i, theta_o */
    double kc_i, kc_o, kc_b;         /* kcorr_renorm's s at sin_i (and sin_o, compensated), its B */
    double lobe_u, lobe_v;           /* zh_lobe's (u, v_theta); lobe fit: zh_convolution's u */
    double theta_h, inv_a;           /* lobe exact: theta_h, and 1/a of zh_lobe's derived angle */
    double alb_i, alb_o, ln_lambda;  /* albedo's theta at theta_i, theta_o, and its lambda (compensated) */
} twoscale_brdf_point;

/* The arguments x of the bounded_log_tan coordinates e = ln x = ln((s + eps c)/(c + delta s)) of grid g
 * (finite at c = 0) at the angles (s_i, c_i) and (s_o, c_o), over one division: x_i = n_i d_o / (d_i d_o). */
static inline void twoscale_brdf_log_tan_args(const twoscale_grid *g, double s_i, double c_i, double s_o, double c_o, double *x_i, double *x_o) {
    const double n_i = s_i + g->p0 * c_i, d_i = c_i + g->p1 * s_i, n_o = s_o + g->p0 * c_o, d_o = c_o + g->p1 * s_o;
    const double r = 1.0 / (d_i * d_o);
    *x_i = n_i * d_o * r;
    *x_o = n_o * d_i * r;
}

/* Stage 1 (wi and wo above the surface, as every stage). */
static inline void twoscale_brdf_prepare(const twoscale_brdf *f, const double wi[3], const double wo[3], double lambda, twoscale_brdf_point *pt) {
    const double hx = wi[0] + wo[0], hy = wi[1] + wo[1], hz = wi[2] + wo[2];
    const double t2 = hx * hx + hy * hy, h2 = t2 + hz * hz; /* |h|^2 sin^2 theta_h, |h|^2 */
    const double sin_i = sqrt(wi[0] * wi[0] + wi[1] * wi[1]), sin_o = sqrt(wo[0] * wo[0] + wo[1] * wo[1]);
    const double inv_hz2 = 1.0 / (hz * hz);
    const int comp = f->energy == TWOSCALE_ENERGY_COMPENSATED;
    double cos_d;
    /* the fields another mode uses are defined too (compilers cannot tell which are read) */
    pt->sin2_h = pt->kc_i = pt->kc_o = pt->kc_b = pt->lobe_u = pt->lobe_v = pt->theta_h = pt->inv_a = pt->alb_i = pt->alb_o = pt->ln_lambda = 0.0;
    pt->lambda = lambda;
    pt->inv_lambda = 1.0 / lambda;
    pt->bb = f->m->b * pt->inv_lambda;
    pt->y = t2 * inv_hz2 * f->inv_beta2;
    pt->sec2_h = h2 * inv_hz2;
    pt->cos_io = wi[2] * wo[2];
    /* i.h / |h| = sqrt((1 + i.o) / 2) for unit i, o: no division, and rho(i, o) = rho(o, i) to the bit */
    cos_d = 0.5 + 0.5 * (wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]);
    pt->cos_d = cos_d = sqrt(cos_d < 0.0 ? 0.0 : (cos_d > 1.0 ? 1.0 : cos_d));
    twoscale_brdf_log_tan_args(&f->g1_theta, sin_i, wi[2], sin_o, wo[2], &pt->g1_i, &pt->g1_o);
    if (f->diffracting) {
        const double u = pt->bb * cos_d;
        pt->kc_i = f->kc_s.p0 + f->kc_s.p1 - sin_i;
        if (comp) pt->kc_o = f->kc_s.p0 + f->kc_s.p1 - sin_o;
        pt->kc_b = pt->bb;
        if (f->lobe == TWOSCALE_LOBE_EXACT) {
            /* material_lobe_angle: a = min(sqrt(1/q + edge_d^2), theta_cap), q = 1 + 4u^2 */
            const double ru = u * f->inv_u_scale, q = 1.0 + 4.0 * u * u, inv_a = sqrt(q / (1.0 + f->edge_d2 * q));
            pt->lobe_u = 1.0 + ru * ru;
            pt->theta_h = twoscale_atan_ratio(sqrt(t2), hz);
            pt->inv_a = inv_a > f->inv_theta_cap ? inv_a : f->inv_theta_cap;
        } else {
            pt->lobe_u = u - f->conv_u.p0;
            pt->sin2_h = t2 / h2;
        }
    }
    if (comp || f->layered) twoscale_brdf_log_tan_args(&f->alb_mu, sin_i, wi[2], sin_o, wo[2], &pt->alb_i, &pt->alb_o);
}

/* Stage 2: the logs. zh_lobe's u is log1p_sq and its v_theta the derived angle of twoscale_derive
 * (material_lobe_angle): v = v_anchor log2(1 + theta/a) if theta <= a, else
 * v_anchor + (1 - v_anchor) ln(theta/a) / ln((pi/2)/a). log(1 + x) for log1p: its absolute error in the
 * encoded coordinates is ~2e-16. */
static inline void twoscale_brdf_encode(const twoscale_brdf *f, twoscale_brdf_point *pt) {
    const int comp = f->energy == TWOSCALE_ENERGY_COMPENSATED;
    if (f->diffracting) { /* zh_lobe's first: the longest chain (log, table read, exp) */
        pt->lobe_u = twoscale_log(&f->math, pt->lobe_u);
        if (f->lobe == TWOSCALE_LOBE_EXACT) {
            const twoscale_derived_axis *d = f->lobe_angle;
            const double ta = pt->theta_h * pt->inv_a;
            pt->lobe_v = ta <= 1.0 ? f->v_ln2 * twoscale_log(&f->math, 1.0 + ta) : d->v_anchor + (1.0 - d->v_anchor) * twoscale_log(&f->math, ta) * (1.0 / twoscale_log(&f->math, TWOSCALE_PI_2 * pt->inv_a));
        }
        pt->kc_i = -twoscale_log(&f->math, pt->kc_i);
        if (comp) pt->kc_o = -twoscale_log(&f->math, pt->kc_o);
        pt->kc_b = twoscale_log(&f->math, pt->kc_b);
    }
    pt->g1_i = twoscale_log(&f->math, pt->g1_i);
    pt->g1_o = twoscale_log(&f->math, pt->g1_o);
    if (comp || f->layered) {
        pt->alb_i = twoscale_log(&f->math, pt->alb_i);
        pt->alb_o = twoscale_log(&f->math, pt->alb_o);
        pt->ln_lambda = twoscale_log(&f->math, pt->lambda);
    }
}

/* Stage 3: rho's two parts with F = 1, parts[0] = A D G2 / (4 cos_i cos_o) and parts[1] = (1 - A) G2 K
 * (docs/runtimes.md); returns cos_d. Energy compensated:
 * R = sqrt(R(sin_i) R(sin_o)), parts[1] times g(cos_i) g(cos_o), and e_c[] = E_c(cos_i), E_c(cos_o),
 * E_c_avg (all at lambda). A layered model: layer[] = T(i), T(o), T_avg (twoscale_brdf_transmitted). */
static inline double twoscale_brdf_combine(const twoscale_brdf *f, const twoscale_brdf_point *pt, double parts[2], double e_c[3], double layer[3]) {
    const int comp = f->energy == TWOSCALE_ENERGY_COMPENSATED, exact = f->lobe == TWOSCALE_LOBE_EXACT;
    double ln_c = 0.0, g1i, g1o, e, g2, a = 1.0;
    parts[0] = parts[1] = 0.0;
    /* zh_lobe first: its table read, often a cache miss, then overlaps the work below */
    if (f->diffracting && exact) ln_c = twoscale_grid_lerp2(&f->lobe_u, &f->lobe_v, f->lobe_data, pt->lobe_u, pt->lobe_v);
    /* G2 = 1 / (1/G1_i + 1/G1_o - 1) */
    g1i = twoscale_grid_lerp(&f->g1_theta, f->g1, pt->g1_i);
    g1o = twoscale_grid_lerp(&f->g1_theta, f->g1, pt->g1_o);
    e = g1i + g1o - g1i * g1o;
    g2 = e > 0.0 ? g1i * g1o / e : 0.0;
    if (f->diffracting) {
        /* K = (c - 1) B^2 / (2 pi R) N(p)/beta^2 C(theta_h; u = B cos_d), R from kcorr_renorm at (sin theta_i, B); A = exp(-x^2) */
        double ln_r = twoscale_grid_lerp2(&f->kc_s, &f->kc_b, f->kc, pt->kc_i, pt->kc_b), c_r;
        if (comp) ln_r = 0.5 * (ln_r + twoscale_grid_lerp2(&f->kc_s, &f->kc_b, f->kc, pt->kc_o, pt->kc_b));
        c_r = exact ? twoscale_exp(&f->math, ln_c - ln_r) : twoscale_brdf_fit_lobe(f, pt->lobe_u, pt->sin2_h, 1.0 / pt->sec2_h) * twoscale_exp(&f->math, -ln_r); /* C / R */
        a = twoscale_brdf_coherent(f, pt->cos_d, pt->inv_lambda);
        parts[1] = (1.0 - a) * g2 * f->k_scale * pt->bb * pt->bb * c_r;
    }
    /* D = N(p)/beta^2 exp(-y^p) / cos^4 theta_h, y = tan^2 theta_h / beta^2; 0 where exp(-y^p) rounds to 0 in float32 */
    if (pt->y < f->d_cut) parts[0] = a * f->spec_scale * twoscale_exp(&f->math, -twoscale_pow(&f->math, pt->y, f->m->p)) * pt->sec2_h * pt->sec2_h * g2 / pt->cos_io;
    e_c[0] = e_c[1] = e_c[2] = 1.0;
    layer[0] = layer[1] = layer[2] = 0.0;
    if (comp) {
        double g_i, g_o;
        twoscale_brdf_albedo(f, pt->alb_i, pt->ln_lambda, &g_i, &e_c[0]);
        twoscale_brdf_albedo(f, pt->alb_o, pt->ln_lambda, &g_o, &e_c[1]);
        e_c[2] = twoscale_brdf_albedo_avg(f, f->alb_avg, pt->ln_lambda);
        parts[1] *= g_i * g_o;
    }
    if (f->layered) {
        const double ms = comp ? twoscale_brdf_ms_factor(e_c[2], f->interface.avg) : 0.0;
        layer[0] = twoscale_brdf_transmitted(twoscale_brdf_albedo_value(f, f->ia_e, pt->alb_i, pt->ln_lambda), e_c[0] < 1.0 ? 1.0 - e_c[0] : 0.0, ms);
        layer[1] = twoscale_brdf_transmitted(twoscale_brdf_albedo_value(f, f->ia_e, pt->alb_o, pt->ln_lambda), e_c[1] < 1.0 ? 1.0 - e_c[1] : 0.0, ms);
        layer[2] = 1.0 - twoscale_brdf_albedo_avg(f, f->ia_avg, pt->ln_lambda) - (1.0 - e_c[2]) * ms;
    }
    return pt->cos_d;
}

/* rho's two parts with F = 1 (twoscale_brdf_combine) at one (wi, wo, lambda); cos_d, or -1 (parts 0) when wi or wo is below the surface. */
static inline double twoscale_brdf_parts(const twoscale_brdf *f, const double wi[3], const double wo[3], double lambda, double parts[2], double e_c[3],
                                         double layer[3]) {
    twoscale_brdf_point pt;
    if (!(wi[2] > 0.0 && wo[2] > 0.0)) {
        parts[0] = parts[1] = 0.0;
        return -1.0;
    }
    twoscale_brdf_prepare(f, wi, wo, lambda, &pt);
    twoscale_brdf_encode(f, &pt);
    return twoscale_brdf_combine(f, &pt, parts, e_c, layer);
}

/* The two parts of rho with F = 1 (twoscale_brdf_parts): for a layered model, its interface's. */
static inline double twoscale_brdf_eval_parts(const twoscale_brdf *f, const double wi[3], const double wo[3], double lambda, double parts[2]) {
    double e_c[3], layer[3];
    return twoscale_brdf_parts(f, wi, wo, lambda, parts, e_c, layer);
}

/* The multiple-scattering lobe of energy compensated (Kulla and Conty), e_c[] = E_c at cos_i, cos_o, and E_c_avg:
 * (1 - E_c(i)) (1 - E_c(o)) / (pi (1 - E_c_avg)) F_avg^2 E_c_avg / (1 - F_avg (1 - E_c_avg)). */
static inline double twoscale_brdf_multiple(const double e_c[3], twoscale_fresnel fresnel) {
    const double avg = e_c[2], loss = 1.0 - avg;
    const double li = e_c[0] < 1.0 ? 1.0 - e_c[0] : 0.0, lo = e_c[1] < 1.0 ? 1.0 - e_c[1] : 0.0;
    if (!(loss > 1e-6)) return 0.0;
    return li * lo / (TWOSCALE_PI * loss) * twoscale_brdf_ms_factor(avg, fresnel.avg);
}

/* rho(wi, wo) at lambda (micrometres), without the cosine: F(cos_d) (specular + diffraction), plus the
 * multiple-scattering lobe with energy compensated. A layered model's F is its interface's (the argument is
 * unused), and its layer's lobes are added (twoscale_brdf_layer; docs/maths.md sections 10, 11). */
static inline double twoscale_brdf_eval(const twoscale_brdf *f, const double wi[3], const double wo[3], double lambda, twoscale_fresnel fresnel) {
    double parts[2], e_c[3], layer[3], rho;
    const double cos_d = twoscale_brdf_parts(f, wi, wo, lambda, parts, e_c, layer);
    if (cos_d < 0.0) return 0.0;
    if (f->layered) fresnel = f->interface;
    rho = twoscale_fresnel_eval(fresnel, cos_d) * (parts[0] + parts[1]);
    if (f->energy == TWOSCALE_ENERGY_COMPENSATED) rho += twoscale_brdf_multiple(e_c, fresnel);
    if (f->layered) rho += twoscale_brdf_layer(f, layer, lambda, wi, wo);
    return rho;
}

/* ---------------------------------------------------------------------------
 * Sampling and its exact pdf.
 * ------------------------------------------------------------------------- */

/* w_d = clamp(1 - A(cos_d = cos_i, lambda_0), 0.1, 0.9) with diffraction, else 0. */
static inline double twoscale_brdf_mixture(const twoscale_brdf *f, double cos_i, double lambda0) {
    double w;
    if (!f->diffracting) return 0.0;
    w = 1.0 - twoscale_brdf_coherent(f, cos_i, 1.0 / lambda0);
    return w < 0.1 ? 0.1 : (w > 0.9 ? 0.9 : w);
}

/* The cosine strategy's share. A conductor with energy compensated: the multiple-scattering lobe's albedo
 * with F = 1, 1 - E_c(cos_i) at lambda0, at most 0.9; 0 with energy single. A layered model: the albedo of
 * its layer's lobes (T(i) times d_eff, or R_d (1 - alpha s_max) + alpha s_max, a bound of the subsurface
 * lobes') and f_ms's (1 - E_c) m over theirs plus the interface's (E_F or E_Fc), at most 0.9. */
static inline double twoscale_brdf_ms_share(const twoscale_brdf *f, const double wi[3], double lambda0) {
    const twoscale_grid *a = &f->alb_mu;
    const double s = sqrt(wi[0] * wi[0] + wi[1] * wi[1]);
    const int comp = f->energy == TWOSCALE_ENERGY_COMPENSATED;
    double g, e = 1.0, e_mu, ln_lambda, avg = 1.0, loss, ms = 0.0, t_avg, e_f, w, alpha = 0.0;
    if (!comp && !f->layered) return 0.0;
    e_mu = twoscale_log(&f->math, (s + a->p0 * wi[2]) / (wi[2] + a->p1 * s));
    ln_lambda = twoscale_log(&f->math, lambda0);
    if (comp) twoscale_brdf_albedo(f, e_mu, ln_lambda, &g, &e);
    loss = e < 1.0 ? 1.0 - e : 0.0;
    if (!f->layered) return loss > 0.9 ? 0.9 : loss;
    if (comp) {
        avg = twoscale_brdf_albedo_avg(f, f->alb_avg, ln_lambda);
        ms = twoscale_brdf_ms_factor(avg, f->interface.avg);
    }
    e_f = twoscale_brdf_albedo_value(f, f->ia_e, e_mu, ln_lambda);
    t_avg = 1.0 - twoscale_brdf_albedo_avg(f, f->ia_avg, ln_lambda) - (1.0 - avg) * ms;
    w = t_avg > 0.0 ? twoscale_brdf_diffuse_share(f, t_avg, lambda0, &alpha) : 0.0;
    w = loss * ms + (w + alpha * f->m->single_max) * twoscale_brdf_transmitted(e_f, loss, ms);
    w = w > 0.0 ? w / (w + (e_f > 0.0 ? e_f : 0.0)) : 0.0;
    return w > 0.9 ? 0.9 : w;
}

/* zh_lobe_sampling's cell k and weight t at u_0 = (b / lambda_0) cos theta_i (log1p_sq). */
static inline int twoscale_brdf_lobe_row(const twoscale_brdf *f, double cos_i, double lambda0, double *t) {
    const double r = f->m->b / lambda0 * cos_i / f->ls_u.p0;
    return twoscale_grid_cell(&f->ls_u, twoscale_log(&f->math, 1.0 + r * r), t); /* log for log1p: absolute error ~2e-16 */
}

/* The density over sin(theta) of the theta that interpolating the quantile row q_j = (1 - t) r0[j] + t r1[j]
 * (n nodes, uniform in e = asin(sqrt xi), H = (pi/2)/(n - 1)) realises: with j the last node below n - 1 with
 * q_j <= theta (binary search without branches: they would be mispredicted), e(theta) = (j + (theta - q_j)/(q_(j+1) - q_j)) H, q(theta) = sin(2 e) H / (q_(j+1) - q_j). */
static inline double twoscale_quantile_density(const float *r0, const float *r1, double t, int n, double theta, double sin_theta) {
    const double hstep = TWOSCALE_PI_2 / (double)(n - 1);
    int lo = 0, len = n - 1; /* q_lo <= theta; j in [lo, lo + len) */
    double q_lo, q_hi, dq;
#define TWOSCALE_ROW(j) ((1.0 - t) * (double)r0[j] + t * (double)r1[j])
    q_lo = TWOSCALE_ROW(0);
    q_hi = TWOSCALE_ROW(n - 1);
    if (!(theta >= q_lo && theta <= q_hi)) return 0.0;
    while (len > 1) {
        const int half = len / 2;
        lo = TWOSCALE_ROW(lo + half) <= theta ? lo + half : lo;
        len -= half;
    }
    q_lo = TWOSCALE_ROW(lo);
    q_hi = TWOSCALE_ROW(lo + 1);
#undef TWOSCALE_ROW
    dq = q_hi - q_lo;
    if (!(dq > 0.0)) return 0.0;
    if (sin_theta > 0.0) return sin(2.0 * ((double)lo + (theta - q_lo) / dq) * hstep) * hstep / dq / sin_theta;
    /* theta = 0 = q_0: sin(2e) / sin(theta) -> 2 H / dq */
    return 2.0 * hstep * hstep / (dq * dq);
}

/* The mixture's density in solid angle of wo at the hero wavelength lambda0 with the weights w_d
 * (twoscale_brdf_mixture) and w_ms (twoscale_brdf_ms_share) of wi:
 * (1 - w_ms) [(1 - w_d) q_epd(theta_h) + w_d q_lobe(theta_h; u_0)] / (2 pi sin theta_h) / (4 |i.h|) + w_ms cos_o / pi. */
static inline double twoscale_brdf_pdf_weighted(const twoscale_brdf *f, const double wi[3], const double wo[3], double lambda0, double w_d, double w_ms) {
    const double hx = wi[0] + wo[0], hy = wi[1] + wo[1], hz = wi[2] + wo[2];
    double h, sin_h, theta_h, q, idoth;
    if (!(wi[2] > 0.0 && wo[2] > 0.0)) return 0.0;
    h = sqrt(hx * hx + hy * hy + hz * hz);
    sin_h = sqrt(hx * hx + hy * hy) / h;
    theta_h = twoscale_atan_ratio(sqrt(hx * hx + hy * hy), hz);
    idoth = fabs(wi[0] * hx + wi[1] * hy + wi[2] * hz) / h;
    q = (1.0 - w_d) * twoscale_quantile_density(f->samp, f->samp, 0.0, f->samp_xi.n, theta_h, sin_h);
    if (w_d > 0.0) {
        double t;
        const int k = twoscale_brdf_lobe_row(f, wi[2], lambda0, &t);
        const float *r0 = f->ls + (size_t)k * (size_t)f->ls_xi.n;
        q += w_d * twoscale_quantile_density(r0, r0 + f->ls_xi.n, t, f->ls_xi.n, theta_h, sin_h);
    }
    q = q / (2.0 * TWOSCALE_PI) / (4.0 * idoth);
    if (f->energy == TWOSCALE_ENERGY_COMPENSATED || f->layered) q = (1.0 - w_ms) * q + w_ms * wo[2] / TWOSCALE_PI;
    return q;
}

/* The density in solid angle of wo that twoscale_brdf_sample realises at the hero wavelength lambda0
 * (twoscale_brdf_pdf_weighted with the mixture's weights at wi). */
static inline double twoscale_brdf_pdf(const twoscale_brdf *f, const double wi[3], const double wo[3], double lambda0) {
    return twoscale_brdf_pdf_weighted(f, wi, wo, lambda0, twoscale_brdf_mixture(f, wi[2], lambda0), twoscale_brdf_ms_share(f, wi, lambda0));
}

/* wo reflected about a half vector of the mixture's specular (xi >= w_d) or diffraction strategy at xi,
 * with azimuth phi. */
static inline void twoscale_brdf_reflected(const twoscale_brdf *f, const double wi[3], double lambda0, double xi1, double w_d, double phi, double wo[3]) {
    double theta, s, idotm;
    if (xi1 < w_d) {
        /* theta_h from zh_lobe_sampling at (u_0, xi = xi1 / w_d): bilinear */
        double t, ft;
        const int k = twoscale_brdf_lobe_row(f, wi[2], lambda0, &t);
        const float *r0 = f->ls + (size_t)k * (size_t)f->ls_xi.n, *r1 = r0 + f->ls_xi.n;
        const int j = twoscale_grid_cell(&f->ls_xi, asin(sqrt(xi1 / w_d)), &ft);
        theta = (1.0 - t) * ((1.0 - ft) * (double)r0[j] + ft * (double)r0[j + 1]) + t * ((1.0 - ft) * (double)r1[j] + ft * (double)r1[j + 1]);
    } else {
        /* theta_m from epd_sampling at xi = (xi1 - w_d)/(1 - w_d) */
        const double xi = (xi1 - w_d) / (1.0 - w_d);
        theta = twoscale_grid_lerp(&f->samp_xi, f->samp, asin(sqrt(xi < 0.0 ? 0.0 : (xi > 1.0 ? 1.0 : xi))));
    }
    /* m = (sin theta cos phi, sin theta sin phi, cos theta), wo = 2 (i.m) m - i */
    s = sin(theta);
    {
        const double m[3] = {s * cos(phi), s * sin(phi), cos(theta)};
        idotm = wi[0] * m[0] + wi[1] * m[1] + wi[2] * m[2];
        wo[0] = 2.0 * idotm * m[0] - wi[0];
        wo[1] = 2.0 * idotm * m[1] - wi[1];
        wo[2] = 2.0 * idotm * m[2] - wi[2];
    }
}

/* Samples wo for wi at the hero wavelength lambda0 with two uniform numbers in [0, 1): xi1 picks the
 * strategy (energy compensated or a layered model: the cosine lobe if xi1 < w_ms, then xi1 -> (xi1 - w_ms)/(1 - w_ms);
 * diffraction if xi1 < w_d) and is reused as its xi, phi = 2 pi xi2. Writes wo and *pdf
 * (twoscale_brdf_pdf) and returns the weight rho(wi, wo) cos theta_o / pdf at lambda0; a lost sample
 * (wi or wo below the surface) has pdf 0 and weight 0. */
static inline double twoscale_brdf_sample(const twoscale_brdf *f, const double wi[3], double lambda0, double xi1, double xi2, twoscale_fresnel fresnel,
                                          double wo[3], double *pdf) {
    const double w_d = twoscale_brdf_mixture(f, wi[2], lambda0), w_ms = twoscale_brdf_ms_share(f, wi, lambda0);
    const double phi = 2.0 * TWOSCALE_PI * xi2;
    wo[0] = wo[1] = wo[2] = 0.0;
    *pdf = 0.0;
    if (!(wi[2] > 0.0)) return 0.0;
    if (xi1 < w_ms) { /* cosine-weighted: sin^2 theta_o = xi1 / w_ms */
        const double r2 = xi1 / w_ms, r = sqrt(r2);
        wo[0] = r * cos(phi);
        wo[1] = r * sin(phi);
        wo[2] = sqrt(1.0 - r2);
    } else {
        twoscale_brdf_reflected(f, wi, lambda0, (xi1 - w_ms) / (1.0 - w_ms), w_d, phi, wo);
    }
    if (!(wo[2] > 0.0)) return 0.0;
    *pdf = twoscale_brdf_pdf_weighted(f, wi, wo, lambda0, w_d, w_ms); /* twoscale_brdf_pdf without computing the weights again */
    if (!(*pdf > 0.0)) return 0.0;
    return twoscale_brdf_eval(f, wi, wo, lambda0, fresnel) * wo[2] / *pdf;
}

#ifdef __cplusplus
}
#endif

#endif
