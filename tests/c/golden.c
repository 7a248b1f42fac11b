/* The golden vectors (pipeline/tables/golden/vectors.json) through the C
 * reader. Built and fed by tests/readers.rs (`c_golden`):
 *   cc -std=c99 -pedantic -Wall -Wextra -Werror -I pipeline/tables/c -I WORK
 *      -include golden_tables.h golden.c -lm
 * where WORK/golden_tables.h includes the exported data header of every table
 * the vectors name and lists them, X(folder, table) for each:
 *   #define GOLDEN_TABLES X("paper", twoscale_epd_g1_paper) ...
 * stdin holds one vector per line, whitespace-separated:
 *   folder table n name_1 x_1 ... name_n x_n m output_1 y_1 ... output_m y_m
 * (the point's physical coordinates, then the expected values). Every value
 * must hold to 1e-12 relative (or 1e-300 absolute). Prints each failure and
 * "checked N vectors, F failed"; exit status 1 when one failed. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "twoscale_tables.h"

typedef struct {
    const char *folder;
    const twoscale_table *table;
} golden_table;

#define X(folder, table) {folder, &table},
static const golden_table tables[] = {GOLDEN_TABLES};
#undef X

#define NTABLES ((int)(sizeof tables / sizeof tables[0]))
#define MAX_OUTPUTS 64

static const twoscale_table *find(const char *folder, const char *table) {
    int i;
    for (i = 0; i < NTABLES; i++)
        if (strcmp(tables[i].folder, folder) == 0 && strcmp(tables[i].table->table, table) == 0) return tables[i].table;
    return NULL;
}

/* Reads "n name x ...": into point[] by coordinate (or out[] by output) index;
 * the number of pairs, or -1 on a malformed line or an unknown name. */
static int read_pairs(const twoscale_table *t, int outputs, double *x, int *seen) {
    char name[256];
    double value;
    int n, k, i;
    if (scanf("%d", &n) != 1) return -1;
    for (k = 0; k < n; k++) {
        if (scanf("%255s %lf", name, &value) != 2) return -1;
        i = outputs ? twoscale_output_index(t, name) : twoscale_coordinate_index(t, name);
        if (i < 0) {
            printf("%s: no %s %s\n", t->table, outputs ? "output" : "coordinate", name);
            return -1;
        }
        x[i] = value;
        seen[i] = 1;
    }
    return n;
}

int main(void) {
    char folder[256], table[256];
    int checked = 0, failed = 0;
    while (scanf("%255s %255s", folder, table) == 2) {
        const twoscale_table *t = find(folder, table);
        double point[TWOSCALE_MAX_DIMS], expected[MAX_OUTPUTS], out[MAX_OUTPUTS];
        int has_coordinate[TWOSCALE_MAX_DIMS] = {0}, has_value[MAX_OUTPUTS] = {0};
        int a, o, bad = 0;
        if (!t || t->noutputs > MAX_OUTPUTS) {
            printf("%s/%s: no such table among the exported headers\n", folder, table);
            return 1;
        }
        if (read_pairs(t, 0, point, has_coordinate) != t->dims || read_pairs(t, 1, expected, has_value) < 0) {
            printf("%s/%s: malformed vector %d\n", folder, table, checked + 1);
            return 1;
        }
        for (a = 0; a < t->dims; a++)
            if (!has_coordinate[a]) bad = 1;
        if (bad || twoscale_lookup(t, point, out)) {
            printf("%s/%s: vector %d: %s\n", folder, table, checked + 1, bad ? "a coordinate is missing" : "outside the domain");
            failed++;
        } else {
            for (o = 0; o < t->noutputs; o++) {
                double d = fabs(out[o] - expected[o]);
                if (has_value[o] && !(d <= 1e-12 * fabs(expected[o]) || d <= 1e-300)) {
                    printf("%s/%s: vector %d: %s = %.17g, expected %.17g\n", folder, table, checked + 1, t->outputs[o].name, out[o], expected[o]);
                    bad = 1;
                }
            }
            failed += bad;
        }
        checked++;
    }
    printf("checked %d vectors, %d failed\n", checked, failed);
    return failed ? 1 : 0;
}
