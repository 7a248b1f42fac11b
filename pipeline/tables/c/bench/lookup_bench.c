/* The C reader's lookup cost: twoscale_lookup of a zh_lobe table (ln with the
 * four control variates) at random points, against its peer, the same
 * header's plain multilinear interpolation of c_lobe alone (cell search and
 * interpolation at the stored point, no derived axis, no decoding).
 *
 * `make bench-c` builds the merl_nickel scene's sub-domain zh_lobe, exports it and runs
 *   cc -std=c99 -O2 -Wall -Wextra -Werror -I pipeline/tables/c
 *      -include twoscale_zh_lobe_scene_merl_nickel.h -DTABLE=twoscale_zh_lobe_scene_merl_nickel
 *      pipeline/tables/c/bench/lookup_bench.c -lm
 * Points: u, c, p, beta uniform between their end nodes, theta_h uniform in
 * [0, pi/2]. Times are process CPU time (clock()), the best of a few rounds. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "twoscale_tables.h"

#ifndef N
#define N 1000000
#endif
#ifndef ROUNDS
#define ROUNDS 5
#endif

static double point[N][5], stored[N][5];

/* xorshift64*, uniform in [0, 1). */
static double uniform(unsigned long long *s) {
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    return (double)((*s * 2685821657736338717ULL) >> 11) * (1.0 / 9007199254740992.0);
}

static double seconds(clock_t a, clock_t b) { return (double)(b - a) / CLOCKS_PER_SEC; }

int main(void) {
    const twoscale_table *t = &TABLE;
    unsigned long long seed = 7;
    double best_lookup = 1e300, best_plain = 1e300, best_stored = 1e300, sum = 0.0;
    int i, a, r, outside = 0, c_lobe = -1;
    if (t->dims != 5 || t->nderived != 1 || t->noutputs != 1 || t->outputs[0].encoding != TWOSCALE_VALUE_LN_CV) {
        fprintf(stderr, "%s: not a zh_lobe table with control variates\n", t->table);
        return 2;
    }
    c_lobe = t->outputs[0].value;
    for (i = 0; i < N; i++) {
        for (a = 0; a < 4; a++) {
            const twoscale_axis *x = &t->axes[a];
            point[i][a] = x->nodes[0] + (x->nodes[x->size - 1] - x->nodes[0]) * uniform(&seed);
        }
        point[i][4] = t->derived[0].min + (t->derived[0].max - t->derived[0].min) * uniform(&seed);
        if (twoscale_stored_point(t, point[i], stored[i])) return 2;
    }
    for (r = 0; r < ROUNDS; r++) {
        clock_t t0, t1, t2, t3;
        twoscale_cell cell;
        double out[1], s[5];
        t0 = clock();
        for (i = 0; i < N; i++) {
            if (twoscale_lookup(t, point[i], out)) outside++;
            else sum += out[0];
        }
        t1 = clock();
        /* The peer: plain multilinear interpolation of c_lobe at the stored point. */
        for (i = 0; i < N; i++) {
            if (twoscale_find_cell(t, stored[i], &cell)) outside++;
            else sum += twoscale_interpolate(t, &cell, c_lobe);
        }
        t2 = clock();
        /* The peer with the derived axis: stored point from the physical one, then as above. */
        for (i = 0; i < N; i++) {
            if (twoscale_stored_point(t, point[i], s) || twoscale_find_cell(t, s, &cell)) outside++;
            else sum += twoscale_interpolate(t, &cell, c_lobe);
        }
        t3 = clock();
        if (seconds(t0, t1) < best_lookup) best_lookup = seconds(t0, t1);
        if (seconds(t1, t2) < best_plain) best_plain = seconds(t1, t2);
        if (seconds(t2, t3) < best_stored) best_stored = seconds(t2, t3);
    }
    printf("%s: %d random points, best of %d rounds (checksum %g, %d outside)\n", t->table, N, ROUNDS, sum, outside);
    printf("  twoscale_lookup (ln + control variates)        %7.1f ns per lookup\n", best_lookup / N * 1e9);
    printf("  peer: plain interpolation of c_lobe            %7.1f ns per lookup\n", best_plain / N * 1e9);
    printf("  peer with the derived axis (theta_h -> v)      %7.1f ns per lookup\n", best_stored / N * 1e9);
    return outside ? 1 : 0;
}
