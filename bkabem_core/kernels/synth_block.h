/*
 * Per-block pieces of every sample loop (the per-family loop of synth_segment.c and the line-set loop of
 * synth_lines.c): the running moments of the chunk features (moments_f32 / _f64), the sensor noise and the extra
 * part added to a block (noise_add_block_f32 / _f64, NoiseArgs), and the block lengths aligned to the noise blocks.
 */
#ifndef BKABEM_SYNTH_BLOCK_H
#define BKABEM_SYNTH_BLOCK_H

#include <stdint.h>

#include "synth_common.h"
#include "synth_noise.h"

/* Sensor noise added inside a segment call (synth_noise.h): stream key, absolute index of the call's sample 0, and
 * the standard deviation per channel (float for float32 output, double for float64). With noise, the loop's blocks
 * are aligned to the noise blocks (absolute multiples of BLOCK = NOISE_BLOCK), so each block seeds its generators
 * once; the per-sample work does not depend on the block position, so the samples do not change. */
typedef struct {
    uint64_t key;
    int64_t n0;
    const float *sigma_f;         /* NULL (both): no noise, only the extra part */
    const double *sigma_d;
    const void *extra;            /* optional m x C block (out's dtype) added too, row 0 = the call's sample 0: the
                                   * broadband floor (synth_floor.h) */
    const int16_t *frames;        /* or (float32, the line-set kernel) the floor itself, rendered per block from its */
    const float *win;             /* frames (F x L x C int16), sine window (2 S), grains (G x 3: grain, frame, */
    const int64_t *grains;        /* offset) and scale per channel, as synth_floor_render: no m x C buffer written */
    int64_t n_grains, half, frame_length;   /* and read back */
    const float *floor_scale;
} NoiseArgs;


/* Samples of the next block: up to BLOCK, and with noise up to the next absolute multiple of BLOCK. */
INLINE int64_t block_length(const int noise, int64_t left, int64_t n_abs)
{
    int64_t nb = left < BLOCK ? left : BLOCK;
    if (noise) {
        const int64_t r = BLOCK - (int64_t)(((uint64_t)n_abs) % BLOCK);
        nb = nb < r ? nb : r;
    }
    return nb;
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define HAVE_AVX2 __builtin_cpu_supports("avx2")
#define HAVE_MOMENTS8_F32 __builtin_cpu_supports("avx2")
#else
#define HAVE_AVX2 0
#define HAVE_MOMENTS8_F32 0
#endif

/* The moments' workers (synth_block.c): 8 float32 channels in one 8-lane float vector per moment, channel groups
 * of 4 in 256-bit double vectors, and the baseline (groups of 2). */
void moments8_f32_avx2(int nb, const float *x, const double *off, double *acc);
void moments_avx2_f32(int C, int nb, const float *x, const double *off, double *acc);
void moments_avx2_f64(int C, int nb, const double *x, const double *off, double *acc);
void moments_base_f32(int C, int nb, const float *x, const double *off, double *acc);
void moments_base_f64(int C, int nb, const double *x, const double *off, double *acc);

/* x[j][c] += sigma[c] z[j][c] (+ extra[j][c]) for the nb samples of a block from absolute sample n (one noise block
 * at most): the product in T, then the sums (the numpy reference's order). */
void noise_add_block_f32(int C, int nb, const NoiseArgs *na, int64_t n, float *x, const float *extra);
void noise_add_block_f64(int C, int nb, const NoiseArgs *na, int64_t n, double *x, const double *extra);

/* Running moments of rows x[0 .. nb-1] (row stride C) into the accumulators acc (C x 6 doubles: sum d, sum d^2,
 * sum d^3, sum d^4, max d, min d of d = x - off[c]), dispatched on the channel count and the CPU. */
#define MOMENTS_DISPATCH(T, SUF)                                                                                    \
    INLINE void moments_##SUF(const int C, int nb, const T *restrict x, const double *restrict off,                 \
                              double *restrict acc)                                                                 \
    {                                                                                                               \
        if (sizeof(T) == 4 && C == 8 && nb > 0 && HAVE_MOMENTS8_F32)                                               \
            moments8_f32_avx2(nb, (const float *)(const void *)x, off, acc);                                        \
        else if (HAVE_AVX2) moments_avx2_##SUF(C, nb, x, off, acc);                                                 \
        else moments_base_##SUF(C, nb, x, off, acc);                                                                \
    }
MOMENTS_DISPATCH(float, f32)
MOMENTS_DISPATCH(double, f64)
#undef MOMENTS_DISPATCH

#endif
