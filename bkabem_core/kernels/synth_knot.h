/*
 * A line set's knot in one call (synth_knot.c): channel amplitudes, ISO velocities and the families' spline tables
 * from the displacement combinations of every line at the knot's speed.
 */
#ifndef BKABEM_SYNTH_KNOT_H
#define BKABEM_SYNTH_KNOT_H

#include <stdint.h>

#define KNOT_MAX_C 64                   /* channels */

/* The constant arrays of a line set's knots. Per family f < F: its lines n_lines[f] (line[], slot[] = k mod N[f]
 * and factor[] = pre-emphasis, negative where the line enters conjugated, concatenated over the families), table
 * size N[f], twiddles tw + tw_off[f] (tw[2 j] = cos(2 pi j / N), tw[2 j + 1] = sin), carrier[f], the offset of its
 * table(s) in the output buffer offset[f]. Per line l < L: nu[l], mu[l] (frequency nu f + mu [Hz]). Per channel
 * c < C: the combination it reads cindex[c], its power of (i omega) power[c] and unit scale[c]; iso[4] the
 * combinations of the housing displacements DE/NDE x vertical/horizontal. two_pi: 2 pi as the caller rounds it.
 * table_floats and max_n: knot_plan_sizes. */
typedef struct {
    int64_t F, C, L, max_n, table_floats;
    double two_pi;
    const int64_t *n_lines, *line, *slot, *N, *tw_off, *carrier, *offset, *cindex, *power, *iso;
    const double *factor, *tw, *nu, *mu, *scale;
} KnotPlan;

/* NULL if the plan is usable for combinations of U columns (n_line_entries entries of line, slot, factor; n_tw
 * twiddle values), else why not. */
const char *knot_plan_check(const KnotPlan *p, int64_t n_line_entries, int64_t n_tw, int64_t U);
/* table_floats (the output buffer's size) and max_n (the largest table) of a checked plan. */
void knot_plan_sizes(KnotPlan *p);

/* y (L x C complex), viso (L x 8: Re of the 4 ISO rows | Im) and the families' tables (table, table_floats floats)
 * at shaft speed f [Hz], with the low-speed fade and the taper (L, or NULL): x L x U complex (scaled in place by
 * spow, L, if given), work >= 2 max_n C doubles, nz >= max_n bytes. */
void lines_knot(const KnotPlan *p, int64_t U, double *x, double f, double fade, const double *taper,
                const double *spow, double *y, double *viso, float *table, double *work, uint8_t *nz);

#endif
