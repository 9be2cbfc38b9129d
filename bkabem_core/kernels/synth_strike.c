/* The random strength of a race pit's strikes (synth_strike.h). */
#include "synth_strike.h"

#include <math.h>
#include <stddef.h>

#include "synth_common.h"

/* SplitMix64's finaliser (Steele, Lea & Flood, OOPSLA 2014): a bijection of 64-bit words whose outputs pass BigCrush
 * for consecutive inputs, so strike n's draw needs no state but (key, n). */
static inline uint64_t mix64(uint64_t z)
{
    z += UINT64_C(0x9E3779B97F4A7C15);
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

double strike_gain(uint64_t key, int64_t n, double sigma)
{
    if (sigma == 0.0) return 1.0;
    const uint64_t a = mix64(key ^ mix64((uint64_t)n));
    const uint64_t b = mix64(a);
    const double u1 = ((double)(a >> 11) + 0.5) * 0x1.0p-53;           /* (0, 1): the logarithm is finite */
    const double u2 = (double)(b >> 11) * 0x1.0p-53;
    const double xi = sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);  /* Box-Muller */
    return exp(0.5 * sigma * xi - 0.25 * sigma * sigma);
}

/* 1 / sqrt(1 - z) for z in [0, 1/2] (the blend's normalisation: z = mix x (1 - x), mix <= 2): a second-order Taylor
 * start and three Newton steps, float32 (the relative error of the start, <= 5 %, squares at each step), in
 * multiplications and additions only so that the block's loop vectorises. */
static inline float rsqrt_one_minus(float z)
{
    const float a = 1.0f - z, h = 0.5f * a;
    float y = 1.0f + z * (0.5f + 0.375f * z);
    y = y * (1.5f - h * y * y);
    y = y * (1.5f - h * y * y);
    y = y * (1.5f - h * y * y);
    return y;
}

/* The strikes' gain over samples j0 .. j1 - 1 that lie between strikes n and n + 1 (one run of the struck phase's
 * turn): the blend of the two strikes' gains, a and b = g_{n+1} - g_n, and its normalisation (vectorised). */
static inline void strike_run(int j0, int j1, const int32_t *frac, float a, float b, float mix, float *gain)
{
    for (int j = j0; j < j1; ++j) {
        const float x = (float)frac[j] * 0x1p-24f;
        gain[j] = (a + b * x) * rsqrt_one_minus(mix * x * (1.0f - x));
    }
}

CLONES void strike_block(int nb, uint64_t u, uint64_t d, uint64_t dd, const int64_t *warp, StrikeState *s,
                         float *gain)
{
    int32_t turn[BLOCK], frac[BLOCK];
    uint64_t pu = u - s->offset, pd = d;          /* the struck phase less the offset: turns from the strikes */
    if (warp != NULL) phase_block(1, nb, &pu, &pd, dd, warp, 62, 3, turn, frac);
    else phase_block(0, nb, &pu, &pd, dd, NULL, 62, 3, turn, frac);
    const float mix = (float)s->mix;
    int64_t n = s->n;
    int last = s->turn;
    for (int j = 0, e; j < nb; j = e) {           /* runs of one turn: a strike or two per block */
        for (e = j + 1; e < nb && turn[e] == turn[j]; ++e) {}
        const int step = (turn[j] - last) & 3;   /* turns passed since the last sample: 0, 1 (or -1: 3) */
        last = turn[j];
        n += step == 3 ? -1 : step;
        if (n != s->cached) {
            s->g0 = n == s->cached + 1 ? s->g1 : strike_gain(s->key, n, s->sigma);
            s->g1 = strike_gain(s->key, n + 1, s->sigma);
            s->cached = n;
        }
        strike_run(j, e, frac, (float)s->g0, (float)(s->g1 - s->g0), mix, gain);
    }
    s->n = n;
    s->turn = last;
}
