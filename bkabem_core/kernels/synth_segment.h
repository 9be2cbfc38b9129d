/*
 * The per-family sample loop of the synthesiser and its companions (synth_segment.c): the samples of one family's
 * tables, noise added to a finished block, feature accumulation, the carrier mix, and the chunk features from the
 * accumulators.
 *
 * Phase: fixed-point uint64 with wrap-around arithmetic, one turn of the family's phase = 2^62 units, one table
 * step = 2^fb units (fb = 62 - log2 N). For sample j = 0 .. m-1 of a call (all uint64 arithmetic modulo 2^64):
 *   U_0 = phase0, D_0 = dphase0;  U_{j+1} = U_j + D_j,  D_{j+1} = D_j + ddphase
 *   V_j = U_j [+ (uint64) warp[j]];  i = (V_j >> fb) & (N - 1);  q = (V_j >> (fb - 24)) & (2^24 - 1)
 * Interpolation: cubic uniform B-spline of a coefficient table with wrap padding, (N + 3) x C, row n holding
 * coefficient (n - 1) mod N, weights from the fraction t = (T) q 2^-24 of the table step by the fixed sequence of
 * WEIGHT_BLOCK (synth_common.h):
 *   va[c] = ((w0 A[i][c] + w1 A[i+1][c]) + w2 A[i+2][c]) + w3 A[i+3][c]     in T, every operation rounded in T
 * Time blend (table b given): vb likewise from B; xi = j + xi0 (double);
 *   s = (T) (clip((int64) (xi * blend_scale), 0, 2^16) / 2^16);  out = va + (vb - va) * s      (in T)
 * else out = va.
 *
 * Layout (all C-contiguous): tables ta, tb (N + 3) x C; out m x C (row stride C); warp m int64 (optional);
 * feature accumulators acc C x 6 doubles per channel [sum d, sum d^2, sum d^3, sum d^4, max d, min d] of
 * d = (double) out - off[c], updated in place (the caller starts them at 0, 0, 0, 0, -inf, +inf).
 */
#ifndef BKABEM_SYNTH_SEGMENT_H
#define BKABEM_SYNTH_SEGMENT_H

#include <stdint.h>

#include "synth_block.h"

/* m samples x C channels of one call into out (warp, tb, acc/off and na optional). Returns 0, or -1 if the
 * arguments are unusable. */
int synth_segment_f32(int64_t m, int64_t C, int64_t N, int fb, uint64_t phase0, uint64_t dphase0, uint64_t ddphase,
                      const int64_t *warp, const float *ta, const float *tb, double xi0, double blend_scale,
                      float *out, double *acc, const double *off, const NoiseArgs *na);
int synth_segment_f64(int64_t m, int64_t C, int64_t N, int fb, uint64_t phase0, uint64_t dphase0, uint64_t ddphase,
                      const int64_t *warp, const double *ta, const double *tb, double xi0, double blend_scale,
                      double *out, double *acc, const double *off, const NoiseArgs *na);
/* x (n x C) += sigma z (+ extra), noise of the stream key from absolute sample n0, and with acc its moments. */
int synth_noise_add_f32(int64_t n, int64_t C, float *x, uint64_t key, int64_t n0, const float *sigma,
                        const float *extra, const double *off, double *acc);
int synth_noise_add_f64(int64_t n, int64_t C, double *x, uint64_t key, int64_t n0, const double *sigma,
                        const double *extra, const double *off, double *acc);
/* The moments of an existing n x C block into acc. */
int synth_accumulate_f32(int64_t n, int64_t C, const float *x, const double *off, double *acc);
int synth_accumulate_f64(int64_t n, int64_t C, const double *x, const double *off, double *acc);
/* out[i][c] += cs[i][0] re[i][c] - cs[i][1] im[i][c]. */
int synth_carrier_mix_f32(int64_t m, int64_t C, const float *cs, const float *re, const float *im, float *out);
int synth_carrier_mix_f64(int64_t m, int64_t C, const double *cs, const double *re, const double *im, double *out);
/* Chunk features (6 x C: mean, rms, peak, peak_to_peak, crest_factor, kurtosis) from the accumulators of n samples. */
int synth_features(int64_t C, int64_t n, const double *acc, const double *off, double *out);

#endif
