/* Cubic interpolation in the C reader (twoscale_tables.h, TWOSCALE_CUBIC) on
 * tables written here by hand: axes x (log, [0.1, 10], 6 nodes), y (reciprocal,
 * [0.5, 4], 5 nodes: e decreasing) and z (linear, [-1, 2], 7 nodes), uniform in
 * their encodings, and the value v = P(e_x, e_y, e_z) stored as float, P of
 * degree 3 in each encoded coordinate. Checks: every node reproduced exactly,
 * P to 1e-6 relative at random points and in the edge cells, the domain refused
 * outside and at NaN, a 4-axis cubic table (256 nodes), refusal of a cubic
 * table of 5 axes or with an axis of 3 nodes, and the same data without
 * .interpolation (multilinear) interpolating as before. Built with no table
 * header:
 *   cc -std=c99 -pedantic -Wall -Wextra -Werror -O2 -I pipeline/tables/c tests/c/cubic.c -lm
 * Prints each failure and "cubic: N checks, F failed"; exit status 1 when one failed. */
#include <stdio.h>
#include "twoscale_tables.h"

#define NX 6
#define NY 5
#define NZ 7

static double x_nodes[NX], x_enc[NX], y_nodes[NY], y_enc[NY], z_nodes[NZ], z_enc[NZ];
static float v_data[NX * NY * NZ];
static double coef[4][4][4]; /* of (e_x/2.3)^a (e_y/2)^b (e_z/2)^c */

static const twoscale_axis axes[3] = {
    {"x", "x", NX, TWOSCALE_LOG, {0.0, 0.0}, x_nodes, x_enc},
    {"y", "y", NY, TWOSCALE_RECIPROCAL, {0.0, 0.0}, y_nodes, y_enc},
    {"z", "z", NZ, TWOSCALE_LINEAR, {0.0, 0.0}, z_nodes, z_enc},
};
static const twoscale_values values[1] = {{"v", v_data}};
static const twoscale_output outputs[1] = {{"v", 0, TWOSCALE_VALUE_NONE, {0, 0, 0, 0}}};

/* As an exported data header writes them: the multilinear one leaves .interpolation unset. */
static const twoscale_table cubic = {
    .table = "cubic_test", .preset = "test",
    .dims = 3, .axes = axes,
    .nvalues = 1, .values = values,
    .noutputs = 1, .outputs = outputs,
    .interpolation = TWOSCALE_CUBIC,
};
static const twoscale_table linear = {
    .table = "cubic_test", .preset = "test",
    .dims = 3, .axes = axes,
    .nvalues = 1, .values = values,
    .noutputs = 1, .outputs = outputs,
};

/* 4 and 5 axes of 4 linear nodes on [0, 3] (node k at k), and a table with an axis of 3 nodes. */
static const double four_nodes[4] = {0.0, 1.0, 2.0, 3.0};
static const twoscale_axis axes4[5] = {
    {"a", "a", 4, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
    {"b", "b", 4, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
    {"c", "c", 4, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
    {"d", "d", 4, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
    {"e", "e", 4, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
};
static const twoscale_axis axes3[2] = {
    {"a", "a", 4, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
    {"b", "b", 3, TWOSCALE_LINEAR, {0.0, 0.0}, four_nodes, four_nodes},
};
static float data5[1024];
static const twoscale_values values5[1] = {{"v", data5}};
static const twoscale_table cubic4 = {.table = "t4", .preset = "test", .dims = 4, .axes = axes4, .nvalues = 1, .values = values5, .noutputs = 1, .outputs = outputs, .interpolation = TWOSCALE_CUBIC};
static const twoscale_table cubic5 = {.table = "t5", .preset = "test", .dims = 5, .axes = axes4, .nvalues = 1, .values = values5, .noutputs = 1, .outputs = outputs, .interpolation = TWOSCALE_CUBIC};
static const twoscale_table linear5 = {.table = "t5", .preset = "test", .dims = 5, .axes = axes4, .nvalues = 1, .values = values5, .noutputs = 1, .outputs = outputs};
static const twoscale_table cubic_3nodes = {.table = "t3", .preset = "test", .dims = 2, .axes = axes3, .nvalues = 1, .values = values5, .noutputs = 1, .outputs = outputs, .interpolation = TWOSCALE_CUBIC};

static int checks, failures;

static void check(int ok, const char *what, double x) {
    checks++;
    if (!ok) {
        failures++;
        printf("FAIL  %s (%.17g)\n", what, x);
    }
}

/* A uniform number in [0, 1) (a fixed LCG: the same points on every run). */
static double uniform01(void) {
    static unsigned long long state = 88172645463325252ULL;
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(state >> 11) / 9007199254740992.0;
}

/* e -> x of each axis of the 3-axis tables. */
static double decode(int a, double e) {
    return a == 0 ? exp(e) : (a == 1 ? 1.0 / e : e);
}

/* P at the encoded point e[3]: 5 + sum coef[a][b][c] (e_x/2.3)^a (e_y/2)^b (e_z/2)^c, in [4, 6]. */
static double poly(const double *e) {
    double sum = 5.0, px = 1.0;
    int a, b, c;
    for (a = 0; a < 4; a++, px *= e[0] / 2.3) {
        double py = 1.0;
        for (b = 0; b < 4; b++, py *= e[1] / 2.0) {
            double pz = 1.0;
            for (c = 0; c < 4; c++, pz *= e[2] / 2.0) sum += coef[a][b][c] * px * py * pz;
        }
    }
    return sum;
}

/* The relative error of the cubic lookup at the physical point x[3] against P. */
static double cubic_error(const double *x) {
    double e[3], out[1];
    int a;
    if (twoscale_lookup(&cubic, x, out)) return INFINITY;
    for (a = 0; a < 3; a++) e[a] = twoscale_encode(&axes[a], x[a]);
    return fabs(out[0] / poly(e) - 1.0);
}

/* The trilinear interpolation at x[3], written out: corner bit d the upper node on
 * axis d, weights multiplied in axis order, the sum corner after corner. */
static double trilinear(const double *x) {
    int cell[3], corner, a;
    double t[3], sum = 0.0;
    for (a = 0; a < 3; a++) twoscale_locate(&axes[a], x[a], &cell[a], &t[a]);
    for (corner = 0; corner < 8; corner++) {
        double w = 1.0;
        int i[3];
        for (a = 0; a < 3; a++) {
            int bit = (corner >> a) & 1;
            w *= bit ? t[a] : 1.0 - t[a];
            i[a] = cell[a] + bit;
        }
        if (w != 0.0) sum += w * (double)v_data[(i[0] * NY + i[1]) * NZ + i[2]];
    }
    return sum;
}

int main(void) {
    const double lo[3] = {0.1, 0.5, -1.0}, hi[3] = {10.0, 4.0, 2.0};
    const int n[3] = {NX, NY, NZ};
    double *nodes[3] = {x_nodes, y_nodes, z_nodes}, *enc[3] = {x_enc, y_enc, z_enc};
    double worst = 0.0, worst_edge = 0.0, worst_linear = 0.0, cubic_vs_linear = 0.0, x[5], out[1];
    int a, i, j, k, p;
    twoscale_cell cell;

    /* The tables: nodes uniform in e (ends exact), encoded as the reader encodes, v = P(e) as float. */
    for (a = 0; a < 3; a++) {
        const double e0 = twoscale_encode(&axes[a], lo[a]), e1 = twoscale_encode(&axes[a], hi[a]);
        for (i = 0; i < n[a]; i++) {
            nodes[a][i] = i == 0 ? lo[a] : (i == n[a] - 1 ? hi[a] : decode(a, e0 + (e1 - e0) * i / (n[a] - 1)));
            enc[a][i] = twoscale_encode(&axes[a], nodes[a][i]);
        }
    }
    for (i = 0; i < 64; i++) coef[i / 16][(i / 4) % 4][i % 4] = (2.0 * uniform01() - 1.0) / 64.0;
    for (i = 0; i < NX; i++)
        for (j = 0; j < NY; j++)
            for (k = 0; k < NZ; k++) {
                const double e[3] = {x_enc[i], y_enc[j], z_enc[k]};
                v_data[(i * NY + j) * NZ + k] = (float)poly(e);
            }

    /* Nodes: exactly the stored float, one node read, in both tables. */
    for (i = 0; i < NX; i++)
        for (j = 0; j < NY; j++)
            for (k = 0; k < NZ; k++) {
                const double node[3] = {x_nodes[i], y_nodes[j], z_nodes[k]}, stored = v_data[(i * NY + j) * NZ + k];
                check(twoscale_lookup(&cubic, node, out) == 0 && out[0] == stored, "cubic: a node is reproduced exactly", out[0] - stored);
                check(twoscale_find_cell(&cubic, node, &cell) == 0 && cell.corners == 1, "cubic: a node reads one node", cell.corners);
                check(twoscale_lookup(&linear, node, out) == 0 && out[0] == stored, "multilinear: a node is reproduced exactly", out[0] - stored);
            }

    /* Random points, uniform in e: P to f32 rounding; the multilinear table as written out above. */
    for (p = 0; p < 20000; p++) {
        double y;
        for (a = 0; a < 3; a++) {
            const double e0 = enc[a][0], e1 = enc[a][n[a] - 1];
            x[a] = decode(a, e0 + (e1 - e0) * uniform01());
        }
        worst = fmax(worst, cubic_error(x));
        if (twoscale_lookup(&linear, x, out)) worst_linear = INFINITY;
        y = trilinear(x);
        worst_linear = fmax(worst_linear, fabs(out[0] - y) / fabs(y));
        cubic_vs_linear = fmax(cubic_vs_linear, fabs(out[0] / poly((double[3]){twoscale_encode(&axes[0], x[0]), twoscale_encode(&axes[1], x[1]), twoscale_encode(&axes[2], x[2])}) - 1.0));
        if (p == 0) check(twoscale_find_cell(&cubic, x, &cell) == 0 && cell.corners == 64, "cubic: a point between nodes reads 4^3 nodes", cell.corners);
    }
    check(worst < 1e-6, "cubic: P is reproduced at random points (worst relative error)", worst);
    check(worst_linear <= 1e-15, "multilinear: the trilinear interpolation (worst relative difference)", worst_linear);
    check(cubic_vs_linear > 1e-4, "multilinear: does not reproduce P (it is not the cubic)", cubic_vs_linear);

    /* Every axis in its first or last cell: each of the 8 combinations, 500 points each. */
    for (p = 0; p < 8 * 500; p++) {
        for (a = 0; a < 3; a++) {
            const int c = ((p / 500) >> a) & 1 ? n[a] - 2 : 0;
            x[a] = decode(a, enc[a][c] + (enc[a][c + 1] - enc[a][c]) * uniform01());
        }
        worst_edge = fmax(worst_edge, cubic_error(x));
    }
    check(worst_edge < 1e-6, "cubic: P is reproduced in the edge cells (worst relative error)", worst_edge);

    /* The domain: outside any axis, or NaN, is refused as in a multilinear table. */
    for (a = 0; a < 3; a++) {
        const double bad[3] = {lo[a] - 1e-3 * (hi[a] - lo[a]), hi[a] + 1e-3 * (hi[a] - lo[a]), NAN};
        for (i = 0; i < 3; i++) {
            x[0] = 1.0, x[1] = 1.0, x[2] = 0.0;
            x[a] = bad[i];
            check(twoscale_lookup(&cubic, x, out) == -1, "cubic: a point outside the domain (or NaN) is refused", x[a]);
            check(twoscale_lookup(&linear, x, out) == -1, "multilinear: a point outside the domain (or NaN) is refused", x[a]);
        }
        x[0] = 1.0, x[1] = 1.0, x[2] = 0.0;
        x[a] = lo[a];
        check(twoscale_lookup(&cubic, x, out) == 0, "cubic: the domain's ends are inside", x[a]);
        x[a] = hi[a];
        check(twoscale_lookup(&cubic, x, out) == 0, "cubic: the domain's ends are inside", x[a]);
    }

    /* 4 axes (256 nodes, the cell's capacity): v = prod_d (1 + x_d - x_d^3/4) reproduced; 5 axes or 3 nodes refused. */
    for (i = 0; i < 256; i++) {
        double v = 1.0;
        for (a = 0; a < 4; a++) {
            const double xd = (i >> (2 * (3 - a))) & 3;
            v *= 1.0 + xd - xd * xd * xd / 4.0;
        }
        data5[i] = (float)v;
    }
    for (p = 0; p < 1000; p++) {
        double v = 1.0;
        for (a = 0; a < 4; a++) {
            x[a] = 3.0 * uniform01();
            v *= 1.0 + x[a] - x[a] * x[a] * x[a] / 4.0;
        }
        check(twoscale_lookup(&cubic4, x, out) == 0 && fabs(out[0] - v) <= 1e-6 * 64.0, "cubic: 4 axes reproduce a product of cubics (to 1e-6 of 2.75^4 < 64)", out[0] - v);
    }
    x[0] = x[1] = x[2] = x[3] = x[4] = 1.5;
    check(twoscale_lookup(&cubic5, x, out) == -1, "cubic: a table of 5 axes is refused", 5);
    check(twoscale_lookup(&linear5, x, out) == 0, "multilinear: a table of 5 axes is read", 5);
    check(twoscale_lookup(&cubic_3nodes, x, out) == -1, "cubic: an axis of 3 nodes is refused", 3);

    printf("cubic: %d checks, %d failed (worst relative error %.1e, in the edge cells %.1e)\n", checks, failures, worst, worst_edge);
    return failures ? 1 : 0;
}
