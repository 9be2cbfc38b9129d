/* Per-block pieces of every sample loop (synth_block.h). */
#include "synth_block.h"

#include <string.h>

/* d > hi ? d : hi and d < lo ? d : lo lane by lane (as maxpd / minpd with d first). Macros: no vector arguments
 * cross a function boundary (-Wpsabi). */
#define VSEL_MAX(VL, a, b) ((__typeof__(a))((((a) > (b)) & (VL)(a)) | (~((a) > (b)) & (VL)(b))))
#define VSEL_MIN(VL, a, b) ((__typeof__(a))((((a) < (b)) & (VL)(a)) | (~((a) < (b)) & (VL)(b))))

/* Running moments of rows x[0 .. nb-1] (row stride C) of channels c0 .. c0+W-1 into acc, in W-lane double vectors 
 * VD (the compiler does not vectorise loop-carried sums by itself: that would reorder them). */
#define MOMENTS_GROUP(T, SUF, NAME, W, VD, VL, VT, ATTR)                                                           \
ATTR void moments_##NAME##_##SUF(const int C, int c0, int nb, const T *restrict x, const double *restrict off, \
                                      double *restrict acc)                                                         \
{                                                                                                                   \
    VD s1, s2, s3, s4, hi, lo, o;                                                                                   \
    for (int l = 0; l < W; ++l) {                                                                                   \
        const double *a = acc + 6 * (int64_t)(c0 + l);                                                                       \
        s1[l] = a[0], s2[l] = a[1], s3[l] = a[2], s4[l] = a[3], hi[l] = a[4], lo[l] = a[5], o[l] = off[c0 + l];     \
    }                                                                                                               \
    for (int k = 0; k < nb; ++k) {                                                                                  \
        VD d;                                                                                                       \
        LOADV_##SUF(d, VT, x + (int64_t)k * C + c0);                                                                \
        d -= o;                                                                                                     \
        VD d2 = d * d;                                                                                              \
        s1 += d;                                                                                                    \
        s2 += d2;                                                                                                   \
        s3 += d2 * d;                                                                                               \
        s4 += d2 * d2;                                                                                              \
        hi = VSEL_MAX(VL, d, hi);                                                                                   \
        lo = VSEL_MIN(VL, d, lo);                                                                                   \
    }                                                                                                               \
    for (int l = 0; l < W; ++l) {                                                                                   \
        double *a = acc + 6 * (int64_t)(c0 + l);                                                                             \
        a[0] = s1[l], a[1] = s2[l], a[2] = s3[l], a[3] = s4[l], a[4] = hi[l], a[5] = lo[l];                         \
    }                                                                                                               \
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define MOMENTS_AVX2(T, SUF)                                                                                        \
    MOMENTS_GROUP(T, SUF, quad, 4, v4d, v4l, v4##SUF, static inline __attribute__((always_inline, target("avx2")))) \
    NOINLINE __attribute__((target("avx2"))) void moments_avx2_##SUF(                                        \
        const int C, int nb, const T *restrict x, const double *restrict off, double *restrict acc)                \
    {                                                                                                               \
        int c = 0;                                                                                                  \
        for (; c + 4 <= C; c += 4) moments_quad_##SUF(C, c, nb, x, off, acc);                                       \
        for (; c + 2 <= C; c += 2) moments_pair_##SUF(C, c, nb, x, off, acc);                                       \
        for (; c < C; ++c) moments_one_##SUF(C, c, nb, x, off, acc);                                                \
    }
#else
#define MOMENTS_AVX2(T, SUF) void moments_avx2_##SUF(const int C, int nb, const T *restrict x,                 \
                                                            const double *restrict off, double *restrict acc)        \
    { moments_base_##SUF(C, nb, x, off, acc); }
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#include <immintrin.h>
/* The common case, 8 float32 channels with AVX2, in one 8-lane float vector per moment: a block's sums (<= BLOCK
 * samples of d = x - (float) off) are taken in float and added to the double accumulators once per block, shifted
 * by e = (float) off - off exactly (binomial expansion in double): relative round-off ~1e-6 of a sum (why not the
 * double path: docs/performance.md). Extremes are those of x itself, so max/min of d are exact:
 * (double) max x - off. */
typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));
NOINLINE __attribute__((target("avx2"))) void moments8_f32_avx2(int nb, const float *restrict x,
                                                                      const double *restrict off,
                                                                      double *restrict acc)
{
    v8f o, s1 = {0}, s2 = {0}, s3 = {0}, s4 = {0}, hi, lo;
    for (int l = 0; l < 8; ++l) o[l] = (float)off[l];
    memcpy(&hi, x, sizeof hi);
    lo = hi;
    for (int k = 0; k < nb; ++k) {
        v8f v;
        memcpy(&v, x + 8 * (int64_t)k, sizeof v);
        v8f d = v - o;
        v8f d2 = d * d;
        s1 += d;
        s2 += d2;
        s3 += d2 * d;
        s4 += d2 * d2;
        /* maxps / minps: v > hi ? v : hi and v < lo ? v : lo exactly (the second operand where either is NaN or
         * both are zeros), one instruction each instead of the 4 of VSEL_MAX: the loop is bound by its vector
         * operations (16 -> 10 per sample) */
        hi = (v8f)_mm256_max_ps((__m256)v, (__m256)hi);
        lo = (v8f)_mm256_min_ps((__m256)v, (__m256)lo);
    }
    for (int l = 0; l < 8; ++l) {
        double *a = acc + 6 * l;
        double h = (double)hi[l] - off[l], w = (double)lo[l] - off[l];
        double e = (double)o[l] - off[l], n = nb;          /* sum (d + e)^p from the sums of d^p */
        double t1 = s1[l], t2 = s2[l], t3 = s3[l], t4 = s4[l];
        a[0] += t1 + n * e;
        a[1] += t2 + e * (2.0 * t1 + n * e);
        a[2] += t3 + e * (3.0 * t2 + e * (3.0 * t1 + n * e));
        a[3] += t4 + e * (4.0 * t3 + e * (6.0 * t2 + e * (4.0 * t1 + n * e)));
        a[4] = h > a[4] ? h : a[4];
        a[5] = w < a[5] ? w : a[5];
    }
}
#else
void moments8_f32_avx2(int nb, const float *x, const double *off, double *acc) { (void)nb, (void)x, (void)off, (void)acc; }
#endif

/* W consecutive values of x (T) as a W-lane double vector d; VT the W-lane vector of T. */
#define LOADV_f32(d, VT, p) do { VT t_; memcpy(&t_, (p), sizeof t_); (d) = __builtin_convertvector(t_, __typeof__(d)); } while (0)
#define LOADV_f64(d, VT, p) memcpy(&(d), (p), sizeof(d))

/* The block kernels, written once for T = float and T = double. */
#define SYNTH_BLOCK_KERNELS(T, SUF)                                                                                 \
                                                                                                                    \
/* The same for the single channel c (the channels left over by the quads). */                                      \
INLINE void moments_one_##SUF(const int C, int c, int nb, const T *restrict x, const double *restrict off,           \
                              double *restrict acc)                                                                 \
{                                                                                                                   \
    double *a = acc + 6 * (int64_t)c;                                                                                      \
    double s1 = a[0], s2 = a[1], s3 = a[2], s4 = a[3], hi = a[4], lo = a[5];                                        \
    for (int k = 0; k < nb; ++k) {                                                                                  \
        double d = (double)x[(int64_t)k * C + c] - off[c];                                                          \
        double d2 = d * d;                                                                                          \
        s1 += d;                                                                                                    \
        s2 += d2;                                                                                                   \
        s3 += d2 * d;                                                                                               \
        s4 += d2 * d2;                                                                                              \
        hi = d > hi ? d : hi;                                                                                       \
        lo = d < lo ? d : lo;                                                                                       \
    }                                                                                                               \
    a[0] = s1, a[1] = s2, a[2] = s3, a[3] = s4, a[4] = hi, a[5] = lo;                                               \
}                                                                                                                   \
                                                                                                                    \
/* Moments of a block: channel groups of 4 in 256-bit vectors where AVX2 is there, else of 2 (4-lane vectors would  \
 * spill in the SSE2 build), then single channels. Not inlined: called once per block, dispatched on the CPU.  \
 * Written for C = 8 and any C. */                                                                                  \
MOMENTS_GROUP(T, SUF, pair, 2, v2d, v2l, v2##SUF, INLINE)                                                           \
NOINLINE void moments_base_##SUF(const int C, int nb, const T *restrict x, const double *restrict off,       \
                                        double *restrict acc)                                                       \
{                                                                                                                   \
    int c = 0;                                                                                                      \
    for (; c + 2 <= C; c += 2) moments_pair_##SUF(C, c, nb, x, off, acc);                                           \
    for (; c < C; ++c) moments_one_##SUF(C, c, nb, x, off, acc);                                                    \
}                                                                                                                   \
MOMENTS_AVX2(T, SUF)                                                                                                \
                                                                                                                    \
/* x[j][c] += sigma[c] z[j][c] for the nb samples of a block from absolute sample n (one noise block at most): the  \
 * product in T, then the sum (the numpy reference's order). */                                                     \
void noise_add_block_##SUF(const int C, int nb, const NoiseArgs *na, int64_t n, T *restrict x,              \
                                  const T *restrict extra)                                                          \
{                                                                                                                   \
    const T *sig = sizeof(T) == 4 ? (const T *)(const void *)na->sigma_f : (const T *)(const void *)na->sigma_d;   \
    if (sig != NULL && sizeof(T) == 4 && C == 8 && synth_isa_cap >= 1 && HAVE_NOISE_AVX2) {  /* fused, no buffer */     \
        noise_add8_avx2(na->key, n, nb, (const float *)(const void *)sig, (float *)(void *)x,                      \
                        (const float *)(const void *)extra);                                                        \
        return;                                                                                                     \
    }                                                                                                               \
    if (sig != NULL && sizeof(T) == 4 && C == 4 && synth_isa_cap >= 1 && HAVE_NOISE_AVX2) {        \
        noise_add4_avx2(na->key, n, nb, (const float *)(const void *)sig, (float *)(void *)x,                      \
                        (const float *)(const void *)extra);                                                        \
        return;                                                                                                     \
    }                                                                                                               \
    if (sig != NULL) {                                                                                              \
        float Z[BLOCK * NOISE_MAX_C];                                                                               \
        if (C == 8 && synth_isa_cap >= 1 && HAVE_NOISE_AVX2) noise_fill8_avx2(na->key, n, nb, Z);                        \
        else if (C < 8 && synth_isa_cap >= 1 && HAVE_NOISE_AVX2) noise_fill_narrow_avx2(na->key, n, nb, C, Z);           \
        else noise_fill_scalar(na->key, n, nb, C, Z);                                                               \
        for (int j = 0; j < nb; ++j)                                                                                \
            for (int c = 0; c < C; ++c) {                                                                           \
                const T p = sig[c] * (T)Z[(int64_t)j * C + c];                                                      \
                x[(int64_t)j * C + c] = x[(int64_t)j * C + c] + p;                                                  \
            }                                                                                                       \
    }                                                                                                               \
    if (extra != NULL)                                                                                              \
        for (int64_t i = 0; i < (int64_t)nb * C; ++i) x[i] = x[i] + extra[i];                                       \
}

SYNTH_BLOCK_KERNELS(float, f32)
SYNTH_BLOCK_KERNELS(double, f64)
