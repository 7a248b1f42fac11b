/* Reads points (DIMS numbers each) from stdin and prints the header's lookup
 * (NV numbers, or "outside"). Built by tests/readers.rs with
 *   cc -std=c99 -include twoscale_<table>_<preset>.h -DLOOKUP=twoscale_<table>_<preset>_lookup
 *      -DDIMS=<axes> -DNV=<values> lookup_cli.c -lm */
#include <stdio.h>

int main(void) {
    double point[DIMS], out[NV];
    int a, v;
    for (;;) {
        for (a = 0; a < DIMS; a++)
            if (scanf("%lf", &point[a]) != 1) return 0;
        if (LOOKUP(point, out)) {
            printf("outside\n");
            continue;
        }
        for (v = 0; v < NV; v++) printf(v ? " %.17g" : "%.17g", out[v]);
        printf("\n");
    }
}
