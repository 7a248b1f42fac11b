/* twoscale_log and twoscale_exp, the reference BRDF's inline ln and exp (runtimes/c/twoscale_brdf.h), against libm:
 * 4 million random arguments each, log over x in [1e-300, 1e300] (log-uniform) and in [0.5, 2],
 * exp over [-708, 709] and [-1, 1]; the ends and the special values. Exit 1 and one line on failure. */
#include <stdio.h>
#include <stdlib.h>

#include "twoscale_brdf.h"

static double uniform(unsigned long long *s) {
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ULL) >> 11) * (1.0 / 9007199254740992.0);
}

/* |a - b| in units of the last place of b */
static double ulps(double a, double b) {
    const double ulp = nextafter(fabs(b), HUGE_VAL) - fabs(b);
    return fabs(a - b) / ulp;
}

int main(void) {
    twoscale_math m;
    unsigned long long s = 1;
    double worst_log = 0.0, worst_log_abs = 0.0, worst_exp = 0.0, x_log = 0.0, x_exp = 0.0;
    int i;
    twoscale_math_init(&m);
    for (i = 0; i < 4000000; i++) {
        const double x = i % 2 ? exp((2.0 * uniform(&s) - 1.0) * 690.0) : 0.5 + 1.5 * uniform(&s);
        const double y = i % 2 ? -708.0 + 1417.0 * uniform(&s) : 2.0 * uniform(&s) - 1.0;
        const double l = log(x), e = exp(y);
        const double dl = fabs(twoscale_log(&m, x) - l), de = ulps(twoscale_exp(&m, y), e);
        /* log: within 1 ulp of the result plus 2.3e-16 absolute (near x = 1 ln x -> 0 and the absolute error counts) */
        const double rl = dl / (nextafter(fabs(l), HUGE_VAL) - fabs(l) + 2.3e-16);
        if (rl > worst_log) worst_log = rl, x_log = x;
        if (dl > worst_log_abs && fabs(l) < 1.0) worst_log_abs = dl;
        if (de > worst_exp) worst_exp = de, x_exp = y;
    }
    printf("log: worst %.3g (1 ulp + 2.3e-16) at x = %.17g, absolute near 1 %.3g; exp: worst %.3g ulp at x = %.17g\n", worst_log, x_log, worst_log_abs, worst_exp, x_exp);
    if (worst_log > 1.0 || worst_exp > 1.0) return 1;
    if (fabs(twoscale_log(&m, 1.0)) > 2.3e-16 || twoscale_exp(&m, 0.0) != 1.0 || twoscale_exp(&m, -709.0) != 0.0 || twoscale_exp(&m, 710.0) != HUGE_VAL ||
        !(twoscale_exp(&m, 709.0) > 8.2e307) || twoscale_exp(&m, NAN) == twoscale_exp(&m, NAN)) {
        printf("log/exp: a special value is wrong\n");
        return 1;
    }
    return 0;
}
