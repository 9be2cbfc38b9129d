/*
 * The random strength of a race pit's strikes (synth_strike.c; the model: bkabem_core/synth/strikes.py): strike n of
 * a run has the amplitude gain g_n = exp(sigma xi_n / 2 - sigma^2 / 4), xi_n a standard normal drawn from (key, n)
 * alone, so its energy g_n^2 is lognormal with mean 1 and relative standard deviation sqrt(exp(sigma^2) - 1). The
 * gain of a sample is linear in its struck phase x between the strikes around it (strike n at the family phase
 * n + offset turns, slip included, so a chunk border anywhere gives the same samples), over
 * sqrt(1 - 2 x (1 - x) (1 - E[g]^2)), E[g]^2 = exp(-sigma^2 / 4): the mean square of a blend of two independent
 * gains, so that every sample keeps the mean power of strikes all alike. x has 24 bits, the blend and its
 * normalisation are float32 (bkabem_core/synth/strikes.py, strike_gains_reference: the same operations).
 */
#ifndef BKABEM_SYNTH_STRIKE_H
#define BKABEM_SYNTH_STRIKE_H

#include <stdint.h>

/* Where a run's strikes stand in a segment's sample loop: the strike n last passed (its phase's integer turns less
 * the offset), the top two bits of the loop's fixed-point struck phase at the last sample (to count the turns
 * passed), and the gains of strikes n and n + 1. */
typedef struct {
    uint64_t key;           /* the run's strike stream */
    uint64_t offset;        /* the strike's place in the family's turn, in the loop's fixed point (2^62 a turn) */
    double sigma;           /* log-standard deviation of a strike's energy */
    double mix;             /* 2 (1 - E[g]^2) = 2 (1 - exp(-sigma^2 / 4)): the blend's loss of mean square */
    int64_t n;              /* the strike last passed */
    int turn;               /* (phase - offset) >> 62 at the last sample */
    int64_t cached;         /* the strike whose gains g0, g1 (of it and the next) are held; INT64_MIN: none */
    double g0, g1;
} StrikeState;

/* The amplitude gain of strike n of stream key (header). */
double strike_gain(uint64_t key, int64_t n, double sigma);

/* Gains of the nb samples of a block (gain[j]) from the struck family's phase u, its increment d and second
 * difference dd at the block's first sample (the loop's recurrence U_{j+1} = U_j + D_j, D_{j+1} = D_j + dd) and its
 * slip offsets warp (nb of them, or NULL), advancing s to the block's last sample. */
void strike_block(int nb, uint64_t u, uint64_t d, uint64_t dd, const int64_t *warp, StrikeState *s, float *gain);

#endif
