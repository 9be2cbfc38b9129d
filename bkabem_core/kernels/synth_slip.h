/*
 * The random-slip warp of a segment: the random walk of the ball-pass phase at every sample, as fixed-point phase
 * offsets of the sample loops, for up to 8 slip factors at once (synth_slip.c).
 */
#ifndef BKABEM_SYNTH_SLIP_H
#define BKABEM_SYNTH_SLIP_H

#include <stdint.h>

/* For sample i < m at xi = j0 + i: the ball passes u = (c2 xi + c1) xi + u_frac since the knot, the walk W at u (a
 * C1 cubic Hermite of its values w[k] at passes jw0 + k, nw of them), and per factor kappa[q] (K <= 8) the offset
 * out[q m + i] = rint(y 2^52) 2^10, y = kappa W - rint(kappa W). Returns 0, or -1 if a sample falls outside w. */
int synth_slip_warp(int64_t m, double j0, double c1, double c2, double u_frac, const double *w, int64_t nw,
                    int64_t jw0, const double *kappa, int64_t K, int64_t *out);

/* The walk W itself (the spline of synth_slip_warp, in passes) at xi samples after the knot, into *out. Returns 0, or
 * -1 if xi falls outside w. */
int synth_slip_value(double xi, double c1, double c2, double u_frac, const double *w, int64_t nw, int64_t jw0,
                     double *out);

#endif
