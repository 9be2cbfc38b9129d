/* The broadband floor's kernels (synth_floor.h). */
#include "synth_floor.h"

#include <math.h>
#include <string.h>

#include "synth_common.h"
#include "synth_noise.h"

/* The floor render: each sample is (0 + w_1 f_1 + w_2 f_2) scale in the grains' order, f the int16 taps as float
 * (synth_floor_render, the per-block render of the line-set kernel and the numpy fallback round alike). */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
/* The next run of samples from lo on (at most to n0 + m) that reads both of its grains contiguously, for C channels:
 * the two frame rows f1 (the older grain), f2, their windows w1, w2 and the run's length; 0 if the grains of lo are
 * not consecutive in grains (then the generic loop runs). Shared by floor_pair8_avx2 and floor_pair4_avx2. */
static inline int floor_pair_run(int64_t lo, int64_t end, int64_t S, int64_t L, int64_t C, const int16_t *frames,
                                 const float *win, int64_t G, const int64_t *grains, const int16_t **f1,
                                 const int16_t **f2, const float **w1, const float **w2, int64_t *run)
{
    const int64_t g2 = lo / S, g1 = g2 - 1, q1 = g1 - grains[0];
    if (q1 < 0 || q1 + 1 >= G || grains[3 * q1] != g1 || grains[3 * q1 + 3] != g2) return 0;
    const int64_t t1 = lo - g1 * S, t2 = lo - g2 * S;
    const int64_t s1 = (t1 + grains[3 * q1 + 2]) % L, s2 = (t2 + grains[3 * q1 + 5]) % L;
    int64_t r = end - lo;
    if (r > (g2 + 1) * S - lo) r = (g2 + 1) * S - lo;                  /* the next grain border */
    if (r > L - s1) r = L - s1;
    if (r > L - s2) r = L - s2;
    *f1 = frames + (grains[3 * q1 + 1] * L + s1) * C, *f2 = frames + (grains[3 * q1 + 4] * L + s2) * C;
    *w1 = win + t1, *w2 = win + t2, *run = r;
    return 1;
}

/* The floor of m samples from n0 for 8 channels with AVX2, both grains of a sample in one pass: out = (w_1 f_1 +
 * w_2 f_2) scale, the older grain first (floor_block_f32's value: 0 + a is a), each int16 tap one 128-bit load,
 * widened; no zeroing pass, no second pass over out, no scale pass. Pieces between grain borders and frame ends
 * (where a source wraps) have two contiguous sources. Needs the grains of floor(n0 / S) - 1 .. consecutive from
 * grains[0]; returns 0 if they are not (then the generic loop runs). */
static NOINLINE __attribute__((target("avx2"))) int floor_pair8_avx2(int64_t m, int64_t n0, int64_t S, int64_t L,
                                                                     const int16_t *frames, const float *scale,
                                                                     const float *win, int64_t G,
                                                                     const int64_t *grains, float *out)
{
    const __m256 sc = _mm256_loadu_ps(scale);
    for (int64_t lo = n0, run; lo < n0 + m; lo += run) {
        const int16_t *f1, *f2;
        const float *w1, *w2;
        if (!floor_pair_run(lo, n0 + m, S, L, 8, frames, win, G, grains, &f1, &f2, &w1, &w2, &run)) return 0;
        float *o = out + (lo - n0) * 8;
        for (int64_t i = 0; i < run; ++i) {
            const __m256 a = _mm256_mul_ps(_mm256_broadcast_ss(w1 + i),
                                           _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(_mm_loadu_si128((const __m128i *)(f1 + 8 * i)))));
            const __m256 b = _mm256_mul_ps(_mm256_broadcast_ss(w2 + i),
                                           _mm256_cvtepi32_ps(_mm256_cvtepi16_epi32(_mm_loadu_si128((const __m128i *)(f2 + 8 * i)))));
            _mm256_storeu_ps(o + 8 * i, _mm256_mul_ps(_mm256_add_ps(a, b), sc));
        }
    }
    return 1;
}
/* floor_pair8_avx2 for 4 channels (acc4): the same operations per lane in 128-bit registers, so the same bits. */
static NOINLINE __attribute__((target("avx2"))) int floor_pair4_avx2(int64_t m, int64_t n0, int64_t S, int64_t L,
                                                                     const int16_t *frames, const float *scale,
                                                                     const float *win, int64_t G,
                                                                     const int64_t *grains, float *out)
{
    const __m128 sc = _mm_loadu_ps(scale);
    for (int64_t lo = n0, run; lo < n0 + m; lo += run) {
        const int16_t *f1, *f2;
        const float *w1, *w2;
        if (!floor_pair_run(lo, n0 + m, S, L, 4, frames, win, G, grains, &f1, &f2, &w1, &w2, &run)) return 0;
        float *o = out + (lo - n0) * 4;
        for (int64_t i = 0; i < run; ++i) {
            const __m128 a = _mm_mul_ps(_mm_broadcast_ss(w1 + i),
                                        _mm_cvtepi32_ps(_mm_cvtepi16_epi32(_mm_loadl_epi64((const __m128i *)(f1 + 4 * i)))));
            const __m128 b = _mm_mul_ps(_mm_broadcast_ss(w2 + i),
                                        _mm_cvtepi32_ps(_mm_cvtepi16_epi32(_mm_loadl_epi64((const __m128i *)(f2 + 4 * i)))));
            _mm_storeu_ps(o + 4 * i, _mm_mul_ps(_mm_add_ps(a, b), sc));
        }
    }
    return 1;
}
#define FLOOR8_AVX2 (synth_isa_cap >= 1 && __builtin_cpu_supports("avx2"))
#else
#define FLOOR8_AVX2 0
static int floor_pair8_avx2(int64_t m, int64_t n0, int64_t S, int64_t L, const int16_t *frames, const float *scale,
                            const float *win, int64_t G, const int64_t *grains, float *out)
{
    (void)m, (void)n0, (void)S, (void)L, (void)frames, (void)scale, (void)win, (void)G, (void)grains, (void)out;
    return 0;
}
static int floor_pair4_avx2(int64_t m, int64_t n0, int64_t S, int64_t L, const int16_t *frames, const float *scale,
                            const float *win, int64_t G, const int64_t *grains, float *out)
{
    (void)m, (void)n0, (void)S, (void)L, (void)frames, (void)scale, (void)win, (void)G, (void)grains, (void)out;
    return 0;
}
#endif

CLONES void floor_block_f32(int64_t m, int64_t C, int64_t n0, int64_t S, int64_t L, const int16_t *frames,
                                   const float *scale, const float *win, int64_t G, const int64_t *grains,
                                   float *out)
{
    if (C == 8 && FLOOR8_AVX2 && G > 0 && floor_pair8_avx2(m, n0, S, L, frames, scale, win, G, grains, out)) return;
    if (C == 4 && FLOOR8_AVX2 && G > 0 && floor_pair4_avx2(m, n0, S, L, frames, scale, win, G, grains, out)) return;
    memset(out, 0, sizeof(float) * (size_t)(m * C));
    for (int64_t q = 0; q < G; ++q) {
        const int64_t g = grains[3 * q], fr = grains[3 * q + 1], off = grains[3 * q + 2];
        const int16_t *F = frames + fr * L * C;
        int64_t lo = g * S > n0 ? g * S : n0, hi = g * S + 2 * S < n0 + m ? g * S + 2 * S : n0 + m;
        while (lo < hi) {                                  /* runs that do not wrap around the frame */
            const int64_t t0 = lo - g * S, src0 = (t0 + off) % L;
            const int64_t run = hi - lo < L - src0 ? hi - lo : L - src0;
            const int16_t *restrict src = F + src0 * C;
            const float *restrict w = win + t0;
            float *restrict o = out + (lo - n0) * C;
            if (C == 8)
                for (int64_t i = 0; i < run; ++i)
                    for (int c = 0; c < 8; ++c) o[8 * i + c] += w[i] * (float)src[8 * i + c];
            else
                for (int64_t i = 0; i < run; ++i)
                    for (int64_t c = 0; c < C; ++c) o[i * C + c] += w[i] * (float)src[i * C + c];
            lo += run;
        }
    }
    if (C == 8)
        for (int64_t i = 0; i < m; ++i)
            for (int c = 0; c < 8; ++c) out[8 * i + c] *= scale[c];
    else
        for (int64_t i = 0; i < m; ++i)
            for (int64_t c = 0; c < C; ++c) out[i * C + c] *= scale[c];
}

CLONES int synth_floor_render(int64_t m, int64_t C, int64_t n0, int64_t S, int64_t L, const int16_t *frames,
                              const float *win, int64_t G, const int64_t *grains, float *out, const float *scale)
{
    if (m < 0 || C < 1 || S < 1 || L < 2 * S / 2 || G < 0 || scale == NULL) return -1;
    floor_block_f32(m, C, n0, S, L, frames, scale, win, G, grains, out);
    return 0;
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
/* The lines k0 .. k0 + nb - 1 of synth_floor_spectrum for C a multiple of 4, four channels (8 floats: re, im pairs)
 * a 256-bit register: P = T ar (tr ar, ti ar), Q = swap(T) ai (ti ai, tr ai), addsub(P, Q) = (tr ar - ti ai,
 * ti ar + tr ai): the scalar loop's re and im of one pair (an addition's operands commute exactly), and the sum over
 * the pairs in its order j = 0, 1, 2, 3, so the same bits; */
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
 * over rows of W = 8 C values (the channels' scales repeated 8 times), so that the loops vectorise whatever C is. */
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
