/* twoscale_tables.h: the C reader of twoscale's tables (C99, header-only, no allocation).
 *
 * The lookup code lives here; the data of a table come from
 *   twoscale export --format c-header --table T [--preset P | --dir D] [--out DIR]
 * which writes twoscale_<table>_<preset>.h: that header includes this one and defines
 *   static const twoscale_table twoscale_<table>_<preset>;
 * (axes, derived axes, stored values, outputs, data checksums). Put this
 * header's folder (pipeline/tables/c) on the include path and link with -lm.
 *
 * A lookup is the one of the Rust reader (crate twoscale-tables, `Lookup`) and
 * of `twoscale lookup`, to ~1e-12 relative (docs/file_contract.md):
 *   1. point[a] is the physical coordinate of axis a (t->axes[a].coordinate);
 *      a derived axis takes its physical coordinate (theta_h) and stores a
 *      coordinate computed from it and other coordinates (v_theta);
 *   2. every axis encodes its coordinate, e = e(x), and finds the cell i with
 *      e_i <= e <= e_i+1 (or the reverse on a decreasing axis) and the weight
 *      t = (e - e_i) / (e_i+1 - e_i);
 *   3. every stored value is interpolated with the same nodes and weights,
 *      I[values]: multilinearly over the 2^N corners of the cells, weights
 *      prod_d (1 - t_d or t_d); or, in a cubic table (t->interpolation ==
 *      TWOSCALE_CUBIC: every axis uniform in e with >= 4 nodes, N <= 4, no
 *      derived axes, outputs not decoded), over 4^N nodes: on each axis the
 *      nodes s..s+3, s = min(max(i, 1), n-3) - 1, at tau = t + (i - s) - 1
 *      (in node spacings from node s+1), with the Lagrange weights through
 *      -1, 0, 1, 2 (twoscale_cubic_weights), multiplied across axes;
 *   4. each output is decoded: none (I[s]), ln (exp(I[s])), or ln with
 *      zh_lobe's control variates, exp(I[s] + sum_j alpha_j (t_j(q) - I[cv_j])).
 *
 * Usage:
 *   #include "twoscale_zh_lobe_scene_merl_nickel.h"   (includes this header)
 *
 *   const twoscale_table *t = &twoscale_zh_lobe_scene_merl_nickel;
 *   double point[5] = {0.5, 2.3, 0.9, 0.03, 0.2};  (u, c, p, beta, theta_h: t->axes[a].coordinate)
 *   double out[1];                                 (c_lobe: t->outputs[o].name, t->noutputs of them)
 *   if (twoscale_lookup(t, point, out) == 0)
 *       printf("%s = %g\n", t->outputs[0].name, out[0]);
 *   else
 *       printf("outside the table's domain\n");
 *
 *   cc -std=c99 -O2 -I pipeline/tables/c -I DIR app.c -lm
 *
 * Every function is static inline and reentrant, except that lgamma (zh_lobe's
 * decoding) may set the global signgam.
 */
#ifndef TWOSCALE_TABLES_H
#define TWOSCALE_TABLES_H

#include <math.h>
#include <stddef.h>
#include <string.h>

/* The most axes a table has in this reader (a cell has 2^dims corners). */
#define TWOSCALE_MAX_DIMS 8

#define TWOSCALE_PI 3.14159265358979323846264338327950288
#define TWOSCALE_PI_2 1.57079632679489661923132169163975144
#define TWOSCALE_LN_2 0.693147180559945309417232121458176568

/* ---------------------------------------------------------------------------
 * The table description (filled by an exported data header).
 * ------------------------------------------------------------------------- */

/* Axis encodings e(x), in which a lookup interpolates linearly (Rust: AxisEncoding).
 * param[] holds the encoding's parameters in the order given. */
typedef enum {
    TWOSCALE_LINEAR,                /* e = x */
    TWOSCALE_LOG,                   /* e = ln x */
    TWOSCALE_RECIPROCAL,            /* e = 1/x */
    TWOSCALE_EXP_NEG_POWER,         /* {k}: e = exp(-x^(-1/k)) */
    TWOSCALE_BOUNDED_LOG,           /* {eps, delta}: e = ln((x + eps) / (1 + delta x)), e(+inf) = -ln delta */
    TWOSCALE_SHIFTED_RECIPROCAL,    /* {shift}: e = 1/(x + shift) */
    TWOSCALE_SHIFTED_LOG,           /* {shift}: e = ln(x - shift) */
    TWOSCALE_LOG_GAP,               /* {end, eps}: e = -ln(end + eps - x) */
    TWOSCALE_LOG_PLUS_LOG_LOG1P_SQ, /* e = ln x + ln(ln(1 + x^2)) */
    TWOSCALE_LOG1P_SQ,              /* {scale}: e = ln(1 + (x/scale)^2) */
    TWOSCALE_BOUNDED_LOG_TAN,       /* {eps, delta}: bounded_log of tan x */
    TWOSCALE_ASIN_SQRT              /* e = asin(sqrt x) */
} twoscale_axis_encoding;

typedef struct {
    const char *name;              /* the stored axis */
    const char *coordinate;        /* what point[] holds for it: the name, or a derived axis' physical coordinate */
    int size;                      /* nodes */
    twoscale_axis_encoding encoding;
    double param[2];               /* the encoding's parameters (see twoscale_axis_encoding), unused ones 0 */
    const double *nodes;           /* physical node coordinates (size) */
    const double *encoded;         /* e(nodes), finite and strictly monotone (size) */
} twoscale_axis;

/* Derived axes (Rust: Derivation): the stored coordinate v of a lobe angle theta.
 * Both kinds: a = the lobe's edge angle; v = v_anchor ln(1 + theta/a) / ln 2 if
 * theta <= a, else v_anchor + (1 - v_anchor) ln(theta/a) / ln((pi/2)/a). */
typedef enum {
    TWOSCALE_ANCHORED_LOBE_ANGLE, /* inputs (u, p, beta): a = min(sqrt(1/(1 + 4u^2) + atan(beta k^(1/(2p)))^2), theta_cap) */
    TWOSCALE_MATERIAL_LOBE_ANGLE  /* inputs (u): a = min(sqrt(1/(1 + 4u^2) + edge_d^2), theta_cap) */
} twoscale_derivation;

typedef struct {
    int axis;                 /* the stored axis; point[axis] holds the physical coordinate */
    double min, max;          /* the physical coordinate's range */
    twoscale_derivation kind;
    double k;                 /* ANCHORED: the EPD's edge is where it has fallen to e^-k */
    double edge_d;            /* MATERIAL: the material's atan(beta k^(1/(2p))) */
    double v_anchor;          /* the stored coordinate of the edge */
    double theta_cap;         /* the largest edge angle */
    int ninputs;              /* 3 (ANCHORED) or 1 (MATERIAL) */
    int inputs[3];            /* indices in point[] of the inputs, in the order above */
} twoscale_derived_axis;

/* How a table interpolates its stored values (manifest `interpolation`): an
 * exported data header sets twoscale_table.interpolation (a header written
 * before twoscale 0.10.0 leaves it unset: 0, multilinear). */
typedef enum {
    TWOSCALE_MULTILINEAR = 0, /* the 2^dims corners of the cell */
    TWOSCALE_CUBIC = 1        /* tensor-product cubic over 4^dims nodes (step 3 above), dims <= 4 */
} twoscale_interpolation;

/* How an output decodes its interpolated stored value s (Rust: ValueEncoding). */
typedef enum {
    TWOSCALE_VALUE_NONE,  /* value = I[s] */
    TWOSCALE_VALUE_LN,    /* stored ln value: value = exp(I[s]) */
    TWOSCALE_VALUE_LN_CV  /* zh_lobe: value = exp(I[s] + sum_j alpha_j (t_j(q) - I[cv_j])), see below */
} twoscale_value_encoding;

typedef struct {
    const char *name;    /* a stored value (dataset) */
    const float *data;   /* C order over the axes: prod(size) numbers */
} twoscale_values;

typedef struct {
    const char *name;                 /* the output, the name of its stored value */
    int value;                        /* its stored value: index in values[] */
    twoscale_value_encoding encoding;
    int cv[4];                        /* LN_CV: indices in values[] of cv_ln_m_s, cv_b, cv_epd_core, cv_tail */
} twoscale_output;

typedef struct {
    const char *name;    /* axes/<axis> or values/<value> */
    const char *sha256;  /* of the little-endian C-order data (float64 axes, float32 values) */
} twoscale_checksum;

typedef struct {
    const char *table, *preset;
    int dims;                             /* axes = coordinates of a point, <= TWOSCALE_MAX_DIMS */
    const twoscale_axis *axes;            /* in the order of the values' dimensions */
    int nderived;
    const twoscale_derived_axis *derived; /* NULL when none */
    int nvalues;
    const twoscale_values *values;        /* every stored value, control variates included */
    int noutputs;
    const twoscale_output *outputs;       /* what a lookup returns: the values that are no control variate */
    int nchecksums;
    const twoscale_checksum *checksums;
    int interpolation;                    /* twoscale_interpolation; 0 (multilinear) when unset */
} twoscale_table;

/* ---------------------------------------------------------------------------
 * Axes: encoding and cell location.
 * ------------------------------------------------------------------------- */

/* ln((x + eps) / (1 + delta x)), and -ln(delta) at x = +inf. */
static inline double twoscale_bounded_log(double x, double eps, double delta) {
    if (isinf(x) && x > 0.0) return -log(delta);
    return log((x + eps) / (1.0 + delta * x));
}

/* e(x) of axis a. */
static inline double twoscale_encode(const twoscale_axis *a, double x) {
    const double p0 = a->param[0], p1 = a->param[1];
    double r;
    switch (a->encoding) {
    case TWOSCALE_LINEAR: return x;
    case TWOSCALE_LOG: return log(x);
    case TWOSCALE_RECIPROCAL: return 1.0 / x;
    case TWOSCALE_EXP_NEG_POWER: return exp(-pow(x, -1.0 / p0));
    case TWOSCALE_BOUNDED_LOG: return twoscale_bounded_log(x, p0, p1);
    case TWOSCALE_SHIFTED_RECIPROCAL: return 1.0 / (x + p0);
    case TWOSCALE_SHIFTED_LOG: return log(x - p0);
    case TWOSCALE_LOG_GAP: return -log(p0 + p1 - x);
    case TWOSCALE_LOG_PLUS_LOG_LOG1P_SQ: return log(x) + log(log1p(x * x));
    case TWOSCALE_LOG1P_SQ: r = x / p0; return log1p(r * r);
    case TWOSCALE_BOUNDED_LOG_TAN: return twoscale_bounded_log(tan(x), p0, p1);
    case TWOSCALE_ASIN_SQRT: return asin(sqrt(x));
    }
    return NAN;
}

/* The cell i (nodes i, i+1) holding x on axis a and the weight t in [0, 1] of
 * its upper node; 0, or -1 when x is NaN or outside the axis. */
static inline int twoscale_locate(const twoscale_axis *a, double x, int *cell, double *t) {
    const double *enc = a->encoded;
    const int n = a->size;
    const double e = twoscale_encode(a, x);
    const double sign = enc[n - 1] > enc[0] ? 1.0 : -1.0, se = sign * e;
    int lo = 0, hi = n, i;
    double w;
    if (isnan(x) || isnan(e) || se < sign * enc[0] || se > sign * enc[n - 1]) return -1;
    /* lo = the first node strictly beyond e, clamped so that the cell [i, i+1] exists. */
    while (lo < hi) {
        int mid = lo + (hi - lo) / 2;
        if (sign * enc[mid] <= se) lo = mid + 1;
        else hi = mid;
    }
    i = (lo < 1 ? 1 : (lo > n - 1 ? n - 1 : lo)) - 1;
    w = (e - enc[i]) / (enc[i + 1] - enc[i]);
    *cell = i;
    *t = w < 0.0 ? 0.0 : (w > 1.0 ? 1.0 : w);
    return 0;
}

/* ---------------------------------------------------------------------------
 * Derived axes.
 * ------------------------------------------------------------------------- */

/* The lobe's edge angle a from the physical point. */
static inline double twoscale_lobe_anchor(const twoscale_derived_axis *d, const double *point) {
    const double u = point[d->inputs[0]];
    double wd;
    if (d->kind == TWOSCALE_ANCHORED_LOBE_ANGLE) {
        const double p = point[d->inputs[1]], beta = point[d->inputs[2]];
        wd = atan(beta * pow(d->k, 0.5 / p)); /* atan(beta k^(1/(2p))) */
    } else {
        wd = d->edge_d;
    }
    return fmin(sqrt(1.0 / (1.0 + 4.0 * u * u) + wd * wd), d->theta_cap);
}

/* The stored coordinate v of the angle theta = point[d->axis]. */
static inline double twoscale_derive(const twoscale_derived_axis *d, const double *point) {
    const double theta = point[d->axis], va = d->v_anchor;
    const double a = twoscale_lobe_anchor(d, point);
    if (theta <= a) return va * log1p(theta / a) / TWOSCALE_LN_2;
    return va + (1.0 - va) * log(theta / a) / log(TWOSCALE_PI_2 / a);
}

/* The point in stored coordinates of the physical point[]: derived axes
 * computed; 0, or -1 when a derived axis' coordinate is NaN or outside its range. */
static inline int twoscale_stored_point(const twoscale_table *t, const double *point, double *stored) {
    int a;
    for (a = 0; a < t->dims; a++) stored[a] = point[a];
    for (a = 0; a < t->nderived; a++) {
        const twoscale_derived_axis *d = &t->derived[a];
        const double x = point[d->axis];
        if (isnan(x) || x < d->min || x > d->max) return -1;
        stored[d->axis] = twoscale_derive(d, point);
    }
    return 0;
}

/* ---------------------------------------------------------------------------
 * Interpolation (multilinear or cubic): one cell search for every value.
 * ------------------------------------------------------------------------- */

/* The nodes a stored point reads, of nonzero weight: multilinear, the corners
 * of its cell in the order corner = 0 .. 2^dims - 1 (bit d set: the upper node
 * on axis d); cubic, the 4^dims nodes of its stencil in C order (axis 0 slowest). */
typedef struct {
    int corners;
    double weight[1 << TWOSCALE_MAX_DIMS];  /* prod_d (t_d or 1 - t_d); cubic: prod_d w_d[a_d] */
    size_t offset[1 << TWOSCALE_MAX_DIMS];  /* C-order index of the node */
} twoscale_cell;

/* The cubic weights of the nodes -1, 0, 1, 2 at tau (Lagrange; exactly 0 or 1
 * at an integer tau). All readers write them in this form and order. */
static inline void twoscale_cubic_weights(double tau, double w[4]) {
    w[0] = -tau * (tau - 1.0) * (tau - 2.0) / 6.0;
    w[1] = (tau + 1.0) * (tau - 1.0) * (tau - 2.0) / 2.0;
    w[2] = -(tau + 1.0) * tau * (tau - 2.0) / 2.0;
    w[3] = (tau + 1.0) * tau * (tau - 1.0) / 6.0;
}

/* The cubic stencil of the cells index[] (weights w[] of their upper nodes):
 * on axis a the nodes s..s+3, s = min(max(i, 1), n-3) - 1, at tau = t + (i - s) - 1,
 * node (a_0, a_1, ...) of weight prod_a w_a[a_a] (multiplied in axis order);
 * -1 when dims > 4 (4^dims nodes must fit the cell) or an axis has < 4 nodes. */
static inline int twoscale_cubic_cell(const twoscale_table *t, const int *index, const double *w, const size_t *stride, twoscale_cell *cell) {
    const int dims = t->dims;
    double cw[4][4];
    size_t base = 0;
    unsigned node;
    int a;
    if (dims > 4) return -1;
    for (a = 0; a < dims; a++) {
        const int n = t->axes[a].size, i = index[a];
        int s;
        if (n < 4) return -1;
        s = (i < 1 ? 1 : (i > n - 3 ? n - 3 : i)) - 1;
        twoscale_cubic_weights(w[a] + (double)(i - s) - 1.0, cw[a]);
        base += (size_t)s * stride[a];
    }
    cell->corners = 0;
    for (node = 0; node < (1u << (2 * dims)); node++) {
        double weight = 1.0;
        size_t offset = base;
        for (a = 0; a < dims; a++) {
            const unsigned k = (node >> (2 * (dims - 1 - a))) & 3u; /* a_a */
            weight *= cw[a][k];
            offset += k * stride[a];
        }
        if (weight != 0.0) {
            cell->weight[cell->corners] = weight;
            cell->offset[cell->corners] = offset;
            cell->corners++;
        }
    }
    return 0;
}

/* Locates stored[] on every axis and fills the nodes it reads (the table's
 * interpolation); 0, or -1 when outside the domain or NaN (or when the table
 * has more than TWOSCALE_MAX_DIMS axes, or is a cubic table this reader cannot read). */
static inline int twoscale_find_cell(const twoscale_table *t, const double *stored, twoscale_cell *cell) {
    const int dims = t->dims;
    int index[TWOSCALE_MAX_DIMS], a;
    double w[TWOSCALE_MAX_DIMS];
    size_t stride[TWOSCALE_MAX_DIMS], base = 0;
    unsigned corner;
    if (dims < 1 || dims > TWOSCALE_MAX_DIMS) return -1;
    if (t->interpolation != TWOSCALE_MULTILINEAR && t->interpolation != TWOSCALE_CUBIC) return -1;
    for (a = 0; a < dims; a++)
        if (twoscale_locate(&t->axes[a], stored[a], &index[a], &w[a])) return -1;
    /* C-order strides: the offset of a corner is sum_d (index_d + bit_d) stride_d. */
    stride[dims - 1] = 1;
    for (a = dims - 2; a >= 0; a--) stride[a] = stride[a + 1] * (size_t)t->axes[a + 1].size;
    if (t->interpolation == TWOSCALE_CUBIC) return twoscale_cubic_cell(t, index, w, stride, cell);
    for (a = 0; a < dims; a++) base += (size_t)index[a] * stride[a];
    cell->corners = 0;
    for (corner = 0; corner < (1u << dims); corner++) {
        double weight = 1.0;
        size_t offset = base;
        for (a = 0; a < dims; a++) {
            if ((corner >> a) & 1u) {
                weight *= w[a];
                offset += stride[a];
            } else {
                weight *= 1.0 - w[a];
            }
        }
        if (weight != 0.0) {
            cell->weight[cell->corners] = weight;
            cell->offset[cell->corners] = offset;
            cell->corners++;
        }
    }
    return 0;
}

/* I[values[v]]: sum over the cell's nodes of weight * value, in double. */
static inline double twoscale_interpolate(const twoscale_table *t, const twoscale_cell *cell, int v) {
    const float *data = t->values[v].data;
    double sum = 0.0;
    int k;
    for (k = 0; k < cell->corners; k++) sum += cell->weight[k] * (double)data[cell->offset[k]];
    return sum;
}

/* ---------------------------------------------------------------------------
 * zh_lobe's control variates (docs/maths.md section 4b; Rust: lobe.rs).
 * q = (theta, u, c, p, beta): theta = theta_h, the other the lobe's parameters.
 * ------------------------------------------------------------------------- */

/* ln m_S: m_S = pi (1 - (1 + 4u^2)^((1-c)/2)) / (4u^2 (c-1)/2), pi where 4u^2 < 1e-12. */
static inline double twoscale_ln_m_s(double u, double c) {
    const double a = 4.0 * u * u;
    double mass_inside;
    if (a < 1e-12) return log(TWOSCALE_PI);
    mass_inside = -expm1(0.5 * (1.0 - c) * log1p(a));
    return log(TWOSCALE_PI * mass_inside / (0.5 * a * (c - 1.0)));
}

/* ln m_D = ln(pi beta^2 Gamma(1 + 1/p)) = 2 ln beta + ln pi + ln Gamma(1/p) - ln p. */
static inline double twoscale_ln_m_d(double p, double beta) {
    return 2.0 * log(beta) + log(TWOSCALE_PI) + lgamma(1.0 / p) - log(p);
}

/* The EPD's slope variance per axis: s2 = beta^2 Gamma(2/p) / (2 Gamma(1/p)). */
static inline double twoscale_slope_variance(double p, double beta) {
    return 0.5 * beta * beta * exp(lgamma(2.0 / p) - lgamma(1.0 / p));
}

/* lambda = (wd2 / (ws2 + wd2))^2, ws2 = 1/(1 + 4u^2), wd2 = (beta/(2p))^2. */
static inline double twoscale_lobe_lambda(double u, double p, double beta) {
    const double ws2 = 1.0 / (1.0 + 4.0 * u * u);
    const double r = beta / (2.0 * p), wd2 = r * r;
    const double f = wd2 / (ws2 + wd2);
    return f * f;
}

/* ln D(e) = -(tan e / beta)^(2p) - 4 ln max(sin(pi/2 - e), 1e-300),
 * e = min(sqrt(theta^2 + 1/(4 (1 + 4u^2))), pi/2). */
static inline double twoscale_ln_d_smoothed(double theta, double u, double p, double beta) {
    const double e = fmin(sqrt(theta * theta + 0.25 / (1.0 + 4.0 * u * u)), TWOSCALE_PI_2);
    return -pow(tan(e) / beta, 2.0 * p) - 4.0 * log(fmax(sin(TWOSCALE_PI_2 - e), 1e-300));
}

/* ln(e^x + e^y) = m + ln(e^(x-m) + e^(y-m)), m = max(x, y). */
static inline double twoscale_logaddexp(double x, double y) {
    const double m = fmax(x, y);
    return m + log(exp(x - m) + exp(y - m));
}

/* 3s^2 - 2s^3 of s = (y - from)/(to - from) clamped to [0, 1]. */
static inline double twoscale_smoothstep(double y, double from, double to) {
    double s = (y - from) / (to - from);
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    return s * s * (3.0 - 2.0 * s);
}

/* g = -2/p + 2 ln(1 + beta^2 (2/p)^(1/p)): the EPD's grazing peak. */
static inline double twoscale_epd_grazing_peak(double p, double beta) {
    return -2.0 / p + 2.0 * log1p(beta * beta * pow(2.0 / p, 1.0 / p));
}

/* The weights alpha_j of the terms (ln_m_s, b, epd_core, tail) at (u, p, beta)
 * and stored angle v: ((1-w)(lambda-mu), (1-w)(1-lambda), (1-w) mu, w),
 * mu = lambda^2 smoothstep(p, 0.3, 0.5),
 * w = smoothstep(v, 0.2, 0.5) (1 - smoothstep(g, -4, -1)). */
static inline void twoscale_lobe_weights(double u, double p, double beta, double v, double alpha[4]) {
    const double lambda = twoscale_lobe_lambda(u, p, beta);
    const double mu = lambda * lambda * twoscale_smoothstep(p, 0.3, 0.5);
    const double w = twoscale_smoothstep(v, 0.2, 0.5) * (1.0 - twoscale_smoothstep(twoscale_epd_grazing_peak(p, beta), -4.0, -1.0));
    alpha[0] = (1.0 - w) * (lambda - mu);
    alpha[1] = (1.0 - w) * (1.0 - lambda);
    alpha[2] = (1.0 - w) * mu;
    alpha[3] = w;
}

/* The terms t_j at q, those of zero weight alpha_j left 0 (ln_m_s and b always computed):
 *   ln_m_s   = ln m_S(u, c)
 *   b        = ln m_D + ln((cos^2 theta + s2)/(1 + s2)) - (c+1)/2 ln(1 + 4u^2 sin^2 theta)
 *   epd_core = logaddexp(ln m_S + ln D, b'), b' = b with sin^2 theta + 2 s2/(1 + 2 s2) in the last term
 *   tail     = logaddexp(ln m_S + ln D, b) */
static inline void twoscale_lobe_terms(double theta, double u, double c, double p, double beta, const double alpha[4], double term[4]) {
    const double ms = twoscale_ln_m_s(u, c);
    const double s2 = twoscale_slope_variance(p, beta);
    const double sn = sin(theta), cs = cos(theta);
    const double a = 4.0 * u * u, k = 0.5 * (c + 1.0);
    const double base = twoscale_ln_m_d(p, beta) + log((cs * cs + s2) / (1.0 + s2));
    const double b = base - k * log1p(a * sn * sn);
    const double narrow = alpha[2] != 0.0 || alpha[3] != 0.0 ? ms + twoscale_ln_d_smoothed(theta, u, p, beta) : 0.0;
    term[0] = ms;
    term[1] = b;
    term[2] = alpha[2] != 0.0 ? twoscale_logaddexp(narrow, base - k * log1p(a * (sn * sn + 2.0 * s2 / (1.0 + 2.0 * s2)))) : 0.0;
    term[3] = alpha[3] != 0.0 ? twoscale_logaddexp(narrow, b) : 0.0;
}

/* ---------------------------------------------------------------------------
 * The lookup.
 * ------------------------------------------------------------------------- */

/* The decoded outputs at the physical point[] (t->dims coordinates, in the
 * order of t->axes[a].coordinate): out[o] for o < t->noutputs, in the order of
 * t->outputs. Returns 0, or -1 when the point is outside the domain or NaN. */
static inline int twoscale_lookup(const twoscale_table *t, const double *point, double *out) {
    double stored[TWOSCALE_MAX_DIMS] = {0.0};
    twoscale_cell cell;
    int o, j;
    if (t->dims < 1 || t->dims > TWOSCALE_MAX_DIMS) return -1;
    if (twoscale_stored_point(t, point, stored) || twoscale_find_cell(t, stored, &cell)) return -1;
    for (o = 0; o < t->noutputs; o++) {
        const twoscale_output *y = &t->outputs[o];
        const double s = twoscale_interpolate(t, &cell, y->value);
        switch (y->encoding) {
        case TWOSCALE_VALUE_NONE:
            out[o] = s;
            break;
        case TWOSCALE_VALUE_LN:
            out[o] = exp(s);
            break;
        case TWOSCALE_VALUE_LN_CV: {
            /* The contract fixes the coordinates of a table with control variates:
             * point = (u, c, p, beta, theta_h), theta_h derived, stored[4] = v_theta.
             * value = exp(I[s] + sum_j alpha_j (t_j(q) - I[cv_j])), terms of zero weight skipped. */
            double alpha[4], term[4], sum = 0.0;
            if (t->dims != 5) return -1; /* not zh_lobe's layout */
            twoscale_lobe_weights(point[0], point[2], point[3], stored[4], alpha);
            twoscale_lobe_terms(point[4], point[0], point[1], point[2], point[3], alpha, term);
            for (j = 0; j < 4; j++)
                if (alpha[j] != 0.0) sum += alpha[j] * (term[j] - twoscale_interpolate(t, &cell, y->cv[j]));
            out[o] = exp(s + sum);
            break;
        }
        }
    }
    return 0;
}

/* The index in point[] of the coordinate `name`, or -1. */
static inline int twoscale_coordinate_index(const twoscale_table *t, const char *name) {
    int a;
    for (a = 0; a < t->dims; a++)
        if (strcmp(t->axes[a].coordinate, name) == 0) return a;
    return -1;
}

/* The index in out[] of the output `name`, or -1. */
static inline int twoscale_output_index(const twoscale_table *t, const char *name) {
    int o;
    for (o = 0; o < t->noutputs; o++)
        if (strcmp(t->outputs[o].name, name) == 0) return o;
    return -1;
}

#endif
