/*
 * The broadband floor's frames per seed (synth_floor.py, FloorTransfer.frames), included by _synthloop.c after
 * _synthnoise.h, whose generator it uses unchanged (a new caller of noise_fill8_avx2 / noise_fill_scalar).
 *
 * Why: a data set renders one run per seed, and each seed needs 4 new frames of 2^15 samples. Made with numpy
 * (float64 normals, four complex vector passes, float64 inverse FFTs, a float64 scale pass) they took ~12 ms of a
 * ~35-ms run at 4 channels. Here:
 *   synth_floor_spectrum  the complex amplitudes of the four force pairs at every line, A = s (z_re + i z_im), from the
 *                         sensor noise's ziggurat (8 normals a line: the 8 "channels" of sample k - 1 of the frame's
 *                         stream, z[0..3] the real parts of force pairs 0..3, z[4..7] the imaginary parts), times the
 *                         transfer and summed over the pairs in the same pass, float32 (complex64 out);
 *   synth_floor_quantise  max |x| per channel over all frames, scale = max / 32767, q = rint(x / scale) in double,
 *                         inv = 32767 / max (double, rounded to float), q = rint(x inv) in float32, clipped to
 *                         +-32767 (the numpy path's operations, bit for bit): two passes, no float64 copy.
 * The inverse FFT between them stays scipy.fft's (float32 in, float32 out).
 */
#ifndef BKABEM_SYNTHFLOOR_H
#define BKABEM_SYNTHFLOOR_H

#include "_synthbase.h"
#include "_synthnoise.h"

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
/* The lines k0 .. k0 + nb - 1 of synth_floor_spectrum for C a multiple of 4, four channels (8 floats: re, im pairs)
 * a 256-bit register: P = T ar (tr ar, ti ar), Q = swap(T) ai (ti ai, tr ai), addsub(P, Q) = (tr ar - ti ai,
 * ti ar + tr ai): the scalar loop's re and im of one pair (an addition's operands commute exactly), and the sum over
 * the pairs in its order j = 0, 1, 2, 3, so the same bits; the scalar loop over a variable C ran one product at a
 * time (~8 of ~18 ns a line at 4 channels). */
static NOINLINE __attribute__((target("avx2"))) void floor_lines_avx2(int64_t k0, int nb, int64_t F, int64_t C,
                                                                      const float *T, float sf, const float *Z,
                                                                      float *out)
{
    for (int i = 0; i < nb; ++i) {
        const int64_t k = k0 + i;
        __m256 ar[4], ai[4];
        for (int j = 0; j < 4; ++j) {
            ar[j] = _mm256_set1_ps(sf * Z[8 * i + j]);
            ai[j] = _mm256_set1_ps(sf * Z[8 * i + 4 + j]);
        }
        const float *t0 = T + 2 * (k * C), *t1 = T + 2 * ((F + k) * C);
        const float *t2 = T + 2 * ((2 * F + k) * C), *t3 = T + 2 * ((3 * F + k) * C);
        float *o = out + 2 * k * C;
        for (int64_t c = 0; c < 2 * C; c += 8) {
#define PAIR(t, j)                                                                                                  \
    _mm256_addsub_ps(_mm256_mul_ps(_mm256_loadu_ps((t) + c), ar[j]),                                               \
                     _mm256_mul_ps(_mm256_permute_ps(_mm256_loadu_ps((t) + c), 0xB1), ai[j]))
            __m256 acc = PAIR(t0, 0);
            acc = _mm256_add_ps(acc, PAIR(t1, 1));
            acc = _mm256_add_ps(acc, PAIR(t2, 2));
            acc = _mm256_add_ps(acc, PAIR(t3, 3));
#undef PAIR
            _mm256_storeu_ps(o + c, acc);
        }
    }
}
#define HAVE_FLOOR_AVX2 1
#else
#define HAVE_FLOOR_AVX2 0
static void floor_lines_avx2(int64_t k0, int nb, int64_t F, int64_t C, const float *T, float sf, const float *Z,
                             float *out)
{
    (void)k0, (void)nb, (void)F, (void)C, (void)T, (void)sf, (void)Z, (void)out;
}
#endif

/* out[k][c] = sum_j T[j][k][c] a_j(k), a_j(k) = s z[k][j] + i s z[k][4 + j], k = 0 .. F-1, complex64 as float pairs
 * (T: 4 x F x C, out: F x C), z the normals of stream key at "samples" 0 .. F-1, 8 "channels" (noise_fill8). Every
 * operation float32 in this order: ar = s zr, ai = s zi; re = tr ar - ti ai, im = tr ai + ti ar (numpy's complex64
 * product), summed j = 0, 1, 2, 3. avx2 = 0: the scalar generator (the same bits). */
CLONES int synth_floor_spectrum(uint64_t key, int64_t F, int64_t C, const float *T, double s, float *out, int avx2)
{
    if (F < 0 || C < 1 || T == NULL || out == NULL) return -1;
    const float sf = (float)s;
    float Z[NOISE_BLOCK * 8];
    for (int64_t k0 = 0; k0 < F; k0 += NOISE_BLOCK) {
        const int nb = F - k0 < NOISE_BLOCK ? (int)(F - k0) : NOISE_BLOCK;
        if (avx2 && HAVE_NOISE_AVX2) noise_fill8_avx2(key, k0, nb, Z);
        else noise_fill_scalar(key, k0, nb, 8, Z);
        if (avx2 && HAVE_FLOOR_AVX2 && HAVE_NOISE_AVX2 && C % 4 == 0) {
            floor_lines_avx2(k0, nb, F, C, T, sf, Z, out);
            continue;
        }
        for (int i = 0; i < nb; ++i) {
            const int64_t k = k0 + i;
            float ar[4], ai[4];
            for (int j = 0; j < 4; ++j) ar[j] = sf * Z[8 * i + j], ai[j] = sf * Z[8 * i + 4 + j];
            const float *restrict t0 = T + 2 * (k * C), *restrict t1 = T + 2 * ((F + k) * C);
            const float *restrict t2 = T + 2 * ((2 * F + k) * C), *restrict t3 = T + 2 * ((3 * F + k) * C);
            float *restrict o = out + 2 * k * C;
            for (int64_t c = 0; c < C; ++c) {
                float re = t0[2 * c] * ar[0] - t0[2 * c + 1] * ai[0];
                float im = t0[2 * c] * ai[0] + t0[2 * c + 1] * ar[0];
                re += t1[2 * c] * ar[1] - t1[2 * c + 1] * ai[1];
                im += t1[2 * c] * ai[1] + t1[2 * c + 1] * ar[1];
                re += t2[2 * c] * ar[2] - t2[2 * c + 1] * ai[2];
                im += t2[2 * c] * ai[2] + t2[2 * c + 1] * ar[2];
                re += t3[2 * c] * ar[3] - t3[2 * c + 1] * ai[3];
                im += t3[2 * c] * ai[3] + t3[2 * c + 1] * ar[3];
                o[2 * c] = re, o[2 * c + 1] = im;
            }
        }
    }
    return 0;
}

/* x: n x C float32 (all frames, rows of C), q: n x C int16, scale: C float32, written: scale[c] = max_k |x[k][c]|
 * / 32767 (1 where the channel is all zero), q = clip(rint(x inv), -32767, 32767) in float32 with inv = 32767 / max
 * rounded to float (a float32 product, not a double division: 8 lanes and no divider; it moves x inv by < 2^-24
 * relative, < 0.002 of a step at the top, so the rounding error stays <= ~0.5 step). Both passes run
 * over rows of W = 8 C values (the channels' scales repeated 8 times), so that the loops vectorise whatever C is
 * (a loop over the C values of a sample does not: ~3 ns a value, ~1.5 ms a seed at 4 channels). */
CLONES int synth_floor_quantise(int64_t n, int64_t C, const float *x, int16_t *q, float *scale)
{
    if (n < 1 || C < 1 || C > 64 || x == NULL || q == NULL || scale == NULL) return -1;
    const int64_t W = 8 * C, rows = n / 8, tail = n * C - rows * W;
    float topw[8 * 64];
    for (int64_t j = 0; j < W; ++j) topw[j] = 0.0f;
    for (int64_t r = 0; r < rows; ++r) {
        const float *restrict xr = x + r * W;
        for (int64_t j = 0; j < W; ++j) {
            const float a = fabsf(xr[j]);
            topw[j] = a > topw[j] ? a : topw[j];
        }
    }
    for (int64_t j = 0; j < tail; ++j) {
        const float a = fabsf(x[rows * W + j]);
        topw[j] = a > topw[j] ? a : topw[j];
    }
    float iw[8 * 64];
    for (int64_t c = 0; c < C; ++c) {
        float top = 0.0f;
        for (int64_t k = 0; k < 8; ++k) top = topw[k * C + c] > top ? topw[k * C + c] : top;
        scale[c] = top > 0.0f ? (float)((double)top / 32767.0) : 1.0f;
        const float inv = top > 0.0f ? (float)(32767.0 / (double)top) : 1.0f;
        for (int64_t k = 0; k < 8; ++k) iw[k * C + c] = inv;
    }
    for (int64_t r = 0; r <= rows; ++r) {
        const float *restrict xr = x + r * W;
        int16_t *restrict qr = q + r * W;
        const int64_t m = r < rows ? W : tail;
        for (int64_t j = 0; j < m; ++j) {
            float v = rintf(xr[j] * iw[j]);
            v = v > 32767.0f ? 32767.0f : v;
            v = v < -32767.0f ? -32767.0f : v;
            qr[j] = (int16_t)(int32_t)v;
        }
    }
    return 0;
}

#endif
