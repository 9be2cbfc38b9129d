/*
 * The grouped AVX2 + FMA rows of the line-set kernel (synth_rows.c), used by synth_lines.c for 8 and 4 channels.
 */
#ifndef BKABEM_SYNTH_ROWS_H
#define BKABEM_SYNTH_ROWS_H

#include <stdint.h>

#include "synth_common.h"

#define GROUP_MAX 8                             /* families per group (their carriers' cos / sin on the stack) */

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define HAVE_GROUP8 HAVE_FMA_PATH
#else
#define HAVE_GROUP8 0
#endif

/* cos and sin of the carrier phases u_j (+ wc[j]) of a block of nb samples, u, d advanced to sample nb. */
void carrier8_avx2(int nb, uint64_t *pu, uint64_t *pd, uint64_t dd, const int64_t *wc, float *co, float *si);
/* One group of nf families with one phase (u, d, dd, slip row w, table step fb / mask) for a block of nb samples
 * from sample k0 of the call: every family's taps (A[k], B[k] the knots' tables or B NULL, NT[k] floats of one
 * table, car[k] with its carrier's CQ[k], SQ[k]) added to the block accumulator blk (lanes = 8 or 4 channels). */
void lines_group8_fma(int lanes, int nb, int64_t k0, uint64_t *u, uint64_t *d, uint64_t dd, const int64_t *w, int fb,
                      uint64_t mask, double xi0, double blend_scale, int nf, const float *const *A,
                      const float *const *B, const int64_t *NT, const int *car, float (*CQ)[BLOCK],
                      float (*SQ)[BLOCK], float *blk);
/* Groups of the families of a line set: families f and g are in one group if their phases (phase0, dphase0,
 * ddphase), table sizes and slip rows are equal, at most GROUP_MAX a group; group q holds start[q] .. start[q+1]-1
 * of member[]. Returns the number of groups. */
int lines_groups(int64_t F, const uint64_t *phases, const int64_t *lg, const int64_t *wp, int *start, int *member);

#endif
