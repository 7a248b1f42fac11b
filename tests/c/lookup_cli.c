/* Reads points (t->dims numbers each) from stdin and prints twoscale_lookup's
 * outputs at each (t->noutputs numbers, or "outside"). Built by
 * tests/common/c_lookup.rs with
 *   cc -std=c99 -pedantic -Wall -Wextra -Werror -I pipeline/tables/c
 *      -include twoscale_<table>_<preset>.h -DTABLE=twoscale_<table>_<preset> lookup_cli.c -lm */
#include <stdio.h>
#include "twoscale_tables.h"

#define MAX_OUTPUTS 64

int main(void) {
    const twoscale_table *t = &TABLE;
    double point[TWOSCALE_MAX_DIMS], out[MAX_OUTPUTS];
    int a, o;
    if (t->noutputs > MAX_OUTPUTS) return 2;
    for (;;) {
        for (a = 0; a < t->dims; a++)
            if (scanf("%lf", &point[a]) != 1) return 0;
        if (twoscale_lookup(t, point, out)) {
            printf("outside\n");
            continue;
        }
        for (o = 0; o < t->noutputs; o++) printf(o ? " %.17g" : "%.17g", out[o]);
        printf("\n");
    }
}
