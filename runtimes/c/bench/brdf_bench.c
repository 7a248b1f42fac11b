/* The reference BRDF's cost (runtimes/c/twoscale_brdf.h): twoscale_brdf_eval, _pdf and
 * _sample (and eval and sample with TWOSCALE_ENERGY_COMPENSATED) of one material (lobe exact, conductor Fresnel) at random (wi, wo, lambda), against a
 * peer in the same run: a plain GGX BRDF (closed-form D and height-correlated Smith G2, the same
 * Fresnel factor), the cost of an analytic microfacet model.
 *
 * `make bench-brdf` builds the merl_nickel scene's material folder, exports it and runs
 *   cc -std=c99 -O2 -Wall -Wextra -Werror -I pipeline/tables/c -I runtimes/c -I DIR
 *      -include twoscale_material_scene_merl_nickel_nickel.h -DMATERIAL=twoscale_material_scene_merl_nickel_nickel
 *      runtimes/c/bench/brdf_bench.c -lm
 * wi, wo uniform over the hemisphere in solid angle, lambda uniform over the material's range.
 * Times are process CPU time (clock()), the best of ROUNDS rounds, per call. The machine's speed can
 * drift between rounds, so eval's cost is also given as a ratio to the peer's paired chunk by chunk:
 * CHUNK pairs through eval, then the same pairs through the peer, the median of the ratios. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#ifndef N
#define N 1000000
#endif
#ifndef ROUNDS
#define ROUNDS 9
#endif
#define CHUNK (N < 10000 ? N : 10000)
#define NCHUNK (ROUNDS * (N / CHUNK))

static double wi[N][3], wo[N][3], lam[N], xi[N][2];

/* xorshift64*, uniform in [0, 1). */
static double uniform(unsigned long long *s) {
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ULL) >> 11) * (1.0 / 9007199254740992.0);
}

/* Uniform in solid angle over the upper hemisphere: z uniform in (0, 1]. */
static void hemisphere(unsigned long long *s, double v[3]) {
    const double z = 1.0 - uniform(s), r = sqrt(fmax(0.0, 1.0 - z * z)), phi = 2.0 * TWOSCALE_PI * uniform(s);
    v[0] = r * cos(phi);
    v[1] = r * sin(phi);
    v[2] = z;
}

/* GGX: D = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2), Lambda = (sqrt(1 + alpha^2 tan^2) - 1)/2,
 * rho = F(cos_d) D G2 / (4 cos_i cos_o). */
static double ggx_eval(double alpha, const double i[3], const double o[3], twoscale_fresnel fresnel) {
    const double hx = i[0] + o[0], hy = i[1] + o[1], hz = i[2] + o[2];
    const double t2 = hx * hx + hy * hy, h2 = t2 + hz * hz, a2 = alpha * alpha;
    const double tan2_h = t2 / (hz * hz), cos2_h = hz * hz / h2;
    const double ti = (i[0] * i[0] + i[1] * i[1]) / (i[2] * i[2]), to = (o[0] * o[0] + o[1] * o[1]) / (o[2] * o[2]);
    double d, g2, cos_d, x;
    if (!(i[2] > 0.0 && o[2] > 0.0)) return 0.0;
    x = a2 + tan2_h;
    d = a2 / (TWOSCALE_PI * cos2_h * cos2_h * x * x);
    g2 = 1.0 / (0.5 + 0.5 * sqrt(1.0 + a2 * ti) + 0.5 * sqrt(1.0 + a2 * to) - 0.5);
    cos_d = fmin(fmax((i[0] * hx + i[1] * hy + i[2] * hz) / sqrt(h2), 0.0), 1.0);
    return twoscale_fresnel_eval(fresnel, cos_d) * d * g2 / (4.0 * i[2] * o[2]);
}

static double seconds(clock_t a, clock_t b) { return (double)(b - a) / CLOCKS_PER_SEC; }

static int by_value(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double ratio[NCHUNK];

int main(void) {
    const twoscale_material *m = &MATERIAL;
    const twoscale_fresnel fresnel = twoscale_fresnel_conductor(1.7, 3.1);
    twoscale_brdf brdf, comp;
    unsigned long long seed = 7;
    double best[6] = {1e300, 1e300, 1e300, 1e300, 1e300, 1e300}, sum = 0.0;
    const char *names[6] = {"twoscale_brdf_eval", "twoscale_brdf_pdf", "twoscale_brdf_sample", "eval, compensated", "sample, compensated", "peer: GGX eval"};
    const char *err = twoscale_brdf_init(&brdf, m, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE);
    int i, r, k;
    if (!err) err = twoscale_brdf_init(&comp, m, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_COMPENSATED);
    if (err) {
        fprintf(stderr, "%s: %s\n", m->name, err);
        return 2;
    }
    for (i = 0; i < N; i++) {
        hemisphere(&seed, wi[i]);
        hemisphere(&seed, wo[i]);
        lam[i] = m->wavelength_min + (m->wavelength_max - m->wavelength_min) * uniform(&seed);
        xi[i][0] = uniform(&seed);
        xi[i][1] = uniform(&seed);
    }
    for (r = 0; r < ROUNDS; r++) {
        clock_t t[7];
        double o[3], pdf;
        t[0] = clock();
        for (i = 0; i < N; i++) sum += twoscale_brdf_eval(&brdf, wi[i], wo[i], lam[i], fresnel);
        t[1] = clock();
        for (i = 0; i < N; i++) sum += twoscale_brdf_pdf(&brdf, wi[i], wo[i], lam[i]);
        t[2] = clock();
        for (i = 0; i < N; i++) sum += twoscale_brdf_sample(&brdf, wi[i], lam[i], xi[i][0], xi[i][1], fresnel, o, &pdf) + pdf;
        t[3] = clock();
        for (i = 0; i < N; i++) sum += twoscale_brdf_eval(&comp, wi[i], wo[i], lam[i], fresnel);
        t[4] = clock();
        for (i = 0; i < N; i++) sum += twoscale_brdf_sample(&comp, wi[i], lam[i], xi[i][0], xi[i][1], fresnel, o, &pdf) + pdf;
        t[5] = clock();
        for (i = 0; i < N; i++) sum += ggx_eval(m->beta, wi[i], wo[i], fresnel);
        t[6] = clock();
        for (k = 0; k < 6; k++)
            if (seconds(t[k], t[k + 1]) < best[k]) best[k] = seconds(t[k], t[k + 1]);
    }
    for (r = 0, k = 0; r < ROUNDS; r++)
        for (i = 0; i + CHUNK <= N; i += CHUNK) {
            const clock_t t0 = clock();
            double t_eval;
            int j;
            for (j = i; j < i + CHUNK; j++) sum += twoscale_brdf_eval(&brdf, wi[j], wo[j], lam[j], fresnel);
            t_eval = seconds(t0, clock());
            {
                const clock_t t1 = clock();
                for (j = i; j < i + CHUNK; j++) sum += ggx_eval(m->beta, wi[j], wo[j], fresnel);
                ratio[k++] = t_eval / seconds(t1, clock());
            }
        }
    qsort(ratio, (size_t)k, sizeof ratio[0], by_value);
    printf("material %s (beta %g, p %g, sigma_s %g um, b %g um, c %g), lobe exact, conductor Fresnel: %d random (wi, wo, lambda), best of %d rounds (checksum %g)\n",
           m->name, m->beta, m->p, m->sigma_s, m->b, m->c, N, ROUNDS, sum);
    for (k = 0; k < 6; k++) printf("  %-22s %7.1f ns per call (%.2f x the peer)\n", names[k], 1e9 * best[k] / N, best[k] / best[5]);
    printf("  twoscale_brdf_eval against the peer over the same %d pairs, %d times: median %.2f x (quartiles %.2f-%.2f)\n", CHUNK, NCHUNK,
           ratio[NCHUNK / 2], ratio[NCHUNK / 4], ratio[3 * NCHUNK / 4]);
    return 0;
}
