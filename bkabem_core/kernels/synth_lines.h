/*
 * The line-set kernel's segment (synth_lines.c): every family of a line set rendered in one pass over a segment
 * between two knots, at its own fixed-point phase, with the static part, sensor noise, the broadband floor and the
 * chunk features. The families and their tables are described once by a LinesPlan (bkabem_core/synth/lines.py:
 * families k p + q of a phase p and a carrier q).
 */
#ifndef BKABEM_SYNTH_LINES_H
#define BKABEM_SYNTH_LINES_H

#include <stdint.h>

#define LINES_MAX_C 64                  /* channels (the block buffers are on the stack) */
#define LINES_MAX_F 64                  /* families */

/* The constant arrays of a line set's segments. Per family f < F: log2 of its table size lg[f], carrier[f], the
 * offset of its table(s) in a knot's buffer offset[f] (floats; one (N + 3) x C table, two for a carrier family),
 * its slip rows wp[f] (phase) and wq[f] (carrier) among the K distinct slip rows (-1: none), the constants
 * of its phase and carrier consts[8 f ..] = (rate / BPFO, fixed, rate, rate / 2) x 2 (rate: turns per shaft turn,
 * fixed: turns per second), and csrc[2 f ..]: the two families of its group whose carriers add up to its own, or
 * -1, -1 (its carrier from its own phase). Slip row k is kappas[k] times the walk walks[k] (0: the cage's random
 * slip; 1: the cage's and the balls' spin slip together) of the n_walks = max(walks) + 1 walks. The families of a
 * race pit's strikes (strike[f] = 1; all of one phase, strike_family the first of them, -1: none) are multiplied by
 * the strikes' random gain (synth_strike.h) of log-standard deviation strike_sigma, the strike at strike_offset
 * turns of their phase (in [0, 1)). */
typedef struct {
    int64_t F, K, n_walks, strike_family;
    const int64_t *lg, *carrier, *offset, *wp, *wq, *csrc, *walks, *strike;
    const double *consts, *kappas;
    double strike_sigma, strike_offset;
} LinesPlan;

/* The broadband floor's source, rendered per block inside the pass (synth_floor.h): frames n_frames x
 * frame_length x C int16 times scale[c], the sine window win (2 half), grains (n_grains x 3: grain, frame, offset). */
typedef struct {
    const int16_t *frames;
    const float *win, *scale;
    const int64_t *grains;
    int64_t n_grains, half, frame_length;
} FloorSource;

/* NULL if the plan can be rendered, else why not (lengths, slip rows, carrier sources and their cycles, the struck
 * families' phase); sets strike_family. */
const char *lines_plan_check(LinesPlan *p);

/* Samples j .. j + m - 1 after knot a (at sample xa, speed fa, ball passes ua) of the segment to knot b (speed fb,
 * length samples on) into out (m x C float32): the knots' tables ta and tb (NULL: no blend), the slip walk's
 * values w (nw of them, from pass jw0; NULL: no slip) at the ball passes (c2u xi + c1u) xi + u_frac since the knot,
 * warp a K x m work buffer, dc the static part (C), acc / off the features (optional), the noise of stream key from
 * absolute sample n0 with sigma (C, or NULL), extra (m x C, or NULL) or the floor fl (or NULL) added. With several
 * walks w holds each walk's nw / n_walks values in turn, from the same pass jw0. strike_key: the run's strike stream
 * (the plan's struck families; synth_strike.h). Returns 0, -1 for
 * unusable arguments, -2 for a phase increment beyond 2^63 units, -3 if the walk's values do not cover the
 * segment. */
int lines_render(const LinesPlan *p, int64_t m, int64_t C, int64_t j, double fa, double fb, int64_t xa,
                 int64_t length, double ua, double fs, const float *ta, const float *tb, const double *w, int64_t nw,
                 int64_t jw0, double c1u, double c2u, double u_frac, int64_t *warp, const float *dc, float *out,
                 double *acc, const double *off, uint64_t key, int64_t n0, const float *sigma, const float *extra,
                 const FloorSource *fl, uint64_t strike_key);

#endif
