/*
 * Sensor noise of the synthesiser: standard normal numbers that are a function of (key, absolute sample, channel)
 * alone, made inside the sample loops (synth_block.c adds them block by block) and for the broadband floor's frames
 * (synth_floor.c).
 *
 * Stream. Sample n (absolute sample index of the run) belongs to noise block b = n / NOISE_BLOCK (256 samples).
 * Block b has its own xoshiro256++ generators (Blackman & Vigna 2018), NOISE_LANES = 4 of them, seeded from
 * x = mix64(key ^ mix64(b + golden)) by 16 consecutive splitmix64 outputs (lane l word i = output 4 l + i). One
 * step of the four generators makes four 64-bit words = eight 32-bit words (32-bit word k = half k % 2 of lane
 * k / 2, low half first: the words' order in memory); a sample with C channels takes S = ceil(C / 8) steps, its
 * channel c the 32-bit word c % 8 of step c / 8. (xoshiro256++ and not 256+: the low bits of 256+ are weak linear
 * bits, and here the low bits of each half pick the layer.)
 *
 * Normals: the ziggurat of Marsaglia & Tsang (2000, "The ziggurat method for generating random variables") with
 * 1024 layers of equal area V under f(x) = exp(-x^2 / 2) (R = 4.038849846109505 closes them; V = R f(R) +
 * sqrt(pi/2) erfc(R / sqrt 2); x_0 = V / f(R) the base strip's width, x_1 = R, x_{i+1} from V = x_i (f(x_{i+1}) -
 * f(x_i)), x_1024 = 0), in Doornik's (2005) form with the layer and the uniform from different bits of one word w
 * (32 bits):
 *     i = w & 1023,   U = (2 j + 1) 2^-22 with j = (int32) w >> 10   (U in (-1, 1), symmetric, exact in float)
 *     fast:  |U| < r_i = x_{i+1} / x_i (float)   ->   z = U x_i (float)              (99.57 % of the words)
 * and otherwise, in double, with uniforms from a second stream seeded by the sample and channel alone
 * (h = mix64(key ^ (64 n + c) salt), then splitmix64: so the value still depends on (key, n, c) only, any
 * chunking or segment split gives the same noise):
 *     i = 0 (base strip beyond R): the tail by Marsaglia's method, a = -ln(u1) / R, b = -ln(u2) until 2 b > a^2,
 *                                  z = +-(R + a) with the sign of U;
 *     i > 0 (the wedge): x = U x_i, accepted if f(x_{i+1}) + u (f(x_i) - f(x_{i+1})) < f(x), z = x;
 *     rejected: the next word of the second stream (its top 32 bits) starts again from the fast test.
 * Exact: the law is the normal's up to the 22-bit grid of U in each layer (steps of x_i 2^-21: 2e-6 at the base
 * edge, 4x float32's ulp there; far below what any record of sensor noise resolves) and the float rounding of r_i
 * (a sliver of relative width 2^-24 on a layer's edge). The AVX2 code and the scalar code take the same
 * operations, so they give the same bits (tested; and against a numpy transcription,
 * bkabem_core/synth/noise.py). Why the layers and the lanes are as they are: docs/performance.md.
 */
#ifndef BKABEM_SYNTH_NOISE_H
#define BKABEM_SYNTH_NOISE_H

#include <stdint.h>

#define NOISE_BLOCK 256                 /* samples per seeded noise block (absolute sample index / 256) */
#define NOISE_LANES 4                   /* xoshiro256++ generators per block, one 64-bit word each per step */
#define NOISE_MAX_C 64                  /* channels a noisy call may have (the block buffer is on the stack) */

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define HAVE_NOISE_AVX2 (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
#else
#define HAVE_NOISE_AVX2 0
#endif

/* Normals of samples n0 .. n0 + nb - 1 (absolute indices), C channels, into Z (nb x C, row-major). */
void noise_fill_scalar(uint64_t key, int64_t n0, int nb, int C, float *Z);
/* The same for C = 8 with AVX2 (HAVE_NOISE_AVX2), the same bits. */
void noise_fill8_avx2(uint64_t key, int64_t n0, int nb, float *Z);
/* The same for any C <= 8 with AVX2: the 8 normals of each sample's step, the first C kept. */
void noise_fill_narrow_avx2(uint64_t key, int64_t n0, int nb, int C, float *Z);
/* x[i][c] = (x[i][c] + sigma[c] z[i][c]) (+ extra[i][c]) for 8 (4) float32 channels, nb samples from absolute sample
 * n0 within one noise block, with AVX2: the product, then the sums, without a buffer of normals. */
void noise_add8_avx2(uint64_t key, int64_t n0, int nb, const float *sigma, float *x, const float *extra);
void noise_add4_avx2(uint64_t key, int64_t n0, int nb, const float *sigma, float *x, const float *extra);

#endif
