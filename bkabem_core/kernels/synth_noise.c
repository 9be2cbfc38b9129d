/* The sensor noise's generator (synth_noise.h). */
#include "synth_noise.h"

#include <math.h>
#include <string.h>

#include "synth_common.h"

static inline uint64_t noise_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* Seed of block b: s[i][l] is word i of lane l (the lanes of one word are contiguous: one AVX2 vector). */
static inline void noise_seed(uint64_t key, uint64_t b, uint64_t s[4][NOISE_LANES])
{
    uint64_t x = noise_mix64(key ^ noise_mix64(b + UINT64_C(0x9E3779B97F4A7C15)));
    for (int l = 0; l < NOISE_LANES; ++l)
        for (int i = 0; i < 4; ++i) {
            x += UINT64_C(0x9E3779B97F4A7C15);                          /* splitmix64 */
            s[i][l] = noise_mix64(x);
        }
}

static inline uint64_t noise_rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

/* One step of the four xoshiro256++ generators: w[l] = rotl(s0 + s3, 23) + s0 of lane l, then the state update. */
static inline void noise_step(uint64_t s[4][NOISE_LANES], uint64_t w[NOISE_LANES])
{
    for (int l = 0; l < NOISE_LANES; ++l) {
        w[l] = noise_rotl(s[0][l] + s[3][l], 23) + s[0][l];
        const uint64_t t = s[1][l] << 17;
        s[2][l] ^= s[0][l];
        s[3][l] ^= s[1][l];
        s[1][l] ^= s[2][l];
        s[0][l] ^= s[3][l];
        s[2][l] ^= t;
        s[3][l] = noise_rotl(s[3][l], 45);
    }
}

/* ------------------------------------------------------------------------------ the ziggurat (256 layers) */
#define ZN_BITS 10                      /* layer bits of a word: 1024 layers, 22 bits of the uniform */
#define ZN_LAYERS (1 << ZN_BITS)
#define ZN_R 4.038849846109505          /* the base strip's edge (V follows from it: zn_init) */
#define ZN_SALT UINT64_C(0xD1B54A32D192ED03)   /* odd: (64 n + c) ZN_SALT is one to one, then one mix64 */

static double zn_x[ZN_LAYERS + 1], zn_f[ZN_LAYERS + 1];   /* layer edges x_i and f(x_i) */
static float zn_xf[ZN_LAYERS], zn_rf[ZN_LAYERS];          /* the fast test's tables: x_i and x_{i+1} / x_i */
static float zn_xr[2 * ZN_LAYERS];                        /* both, interleaved (x_i, r_i): one 64-bit load */

#if defined(__GNUC__)
__attribute__((constructor))           /* tables made when the library is loaded (no first-call race) */
#endif
static void zn_init(void)
{
    double f = exp(-0.5 * ZN_R * ZN_R);
    const double v = ZN_R * f + sqrt(2.0 * atan(1.0)) * erfc(ZN_R / sqrt(2.0));   /* the layers' area */
    zn_x[0] = v / f;
    zn_x[1] = ZN_R;
    zn_f[0] = f, zn_f[1] = f;
    for (int i = 2; i < ZN_LAYERS; ++i) {
        zn_x[i] = sqrt(-2.0 * log(v / zn_x[i - 1] + f));
        f = zn_f[i] = exp(-0.5 * zn_x[i] * zn_x[i]);
    }
    zn_x[ZN_LAYERS] = 0.0, zn_f[ZN_LAYERS] = 1.0;
    for (int i = 0; i < ZN_LAYERS; ++i) {
        zn_xf[i] = (float)zn_x[i];
        zn_rf[i] = (float)(zn_x[i + 1] / zn_x[i]);
        zn_xr[2 * i] = zn_xf[i], zn_xr[2 * i + 1] = zn_rf[i];
    }
}

static inline uint64_t zn_next(uint64_t *h)                /* splitmix64 */
{
    *h += UINT64_C(0x9E3779B97F4A7C15);
    return noise_mix64(*h);
}

static inline double zn_uniform(uint64_t *h) { return ((double)(int64_t)(zn_next(h) >> 11) + 0.5) * 0x1p-53; }

/* The fast test of word w: 1 and z if |U| < r_i. */
static inline int zn_fast(uint32_t w, float *z)
{
    const int i = (int)(w & (ZN_LAYERS - 1));
    const float u = (float)(2 * ((int32_t)w >> ZN_BITS) + 1) * 0x1p-22f;
    *z = u * zn_xf[i];
    return fabsf(u) < zn_rf[i];
}

/* The normal of absolute sample n, channel c whose word w failed the fast test (the header's slow cases). */
static NOINLINE float zn_slow(uint64_t key, int64_t n, int c, uint32_t w)
{
    uint64_t h = noise_mix64(key ^ (((uint64_t)n * 64 + (uint64_t)c) * ZN_SALT));
    for (int first = 1;; first = 0) {
        float z;
        if (!first && zn_fast(w, &z)) return z;
        const int i = (int)(w & (ZN_LAYERS - 1));
        const double u = (double)(2 * ((int32_t)w >> ZN_BITS) + 1) * 0x1p-22;
        if (i == 0) {
            double a, b;
            do {
                a = -log(zn_uniform(&h)) / ZN_R;
                b = -log(zn_uniform(&h));
            } while (b + b < a * a);
            return (float)(u < 0.0 ? -(ZN_R + a) : ZN_R + a);
        }
        const double x = u * zn_x[i];
        if (zn_f[i + 1] + zn_uniform(&h) * (zn_f[i] - zn_f[i + 1]) < exp(-0.5 * x * x)) return (float)x;
        w = (uint32_t)(zn_next(&h) >> 32);
    }
}

/* Normals of samples n0 .. n0 + nb - 1 (absolute indices), C channels, into Z (nb x C, row-major), scalar. */
void noise_fill_scalar(uint64_t key, int64_t n0, int nb, int C, float *Z)
{
    const int S = (C + 7) / 8;
    int j = 0;
    while (j < nb) {
        const int64_t n = n0 + j;
        const int64_t b = n / NOISE_BLOCK;
        const int first = (int)(n - b * NOISE_BLOCK);
        int cnt = NOISE_BLOCK - first;
        if (cnt > nb - j) cnt = nb - j;
        uint64_t s[4][NOISE_LANES], w[NOISE_LANES];
        noise_seed(key, (uint64_t)b, s);
        for (int64_t k = 0; k < (int64_t)first * S; ++k) noise_step(s, w);
        for (int i = 0; i < cnt; ++i) {
            float *row = Z + (int64_t)(j + i) * C;
            for (int st = 0; st < S; ++st) {
                noise_step(s, w);
                for (int k = 0; k < 8 && 8 * st + k < C; ++k) {
                    const uint32_t wk = (uint32_t)(w[k / 2] >> (32 * (k % 2)));
                    float z;
                    if (!zn_fast(wk, &z)) z = zn_slow(key, n + i, 8 * st + k, wk);
                    row[8 * st + k] = z;
                }
            }
        }
        j += cnt;
    }
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#include <immintrin.h>
#define NOISE_TARGET __attribute__((target("avx2,fma")))

static inline __attribute__((always_inline)) NOISE_TARGET __m256i noise_step_avx2(__m256i *s0, __m256i *s1,
                                                                                   __m256i *s2, __m256i *s3)
{
    const __m256i p = _mm256_add_epi64(*s0, *s3);
    const __m256i w = _mm256_add_epi64(_mm256_or_si256(_mm256_slli_epi64(p, 23), _mm256_srli_epi64(p, 41)), *s0);
    const __m256i t = _mm256_slli_epi64(*s1, 17);
    *s2 = _mm256_xor_si256(*s2, *s0);
    *s3 = _mm256_xor_si256(*s3, *s1);
    *s1 = _mm256_xor_si256(*s1, *s2);
    *s0 = _mm256_xor_si256(*s0, *s3);
    *s2 = _mm256_xor_si256(*s2, t);
    *s3 = _mm256_or_si256(_mm256_slli_epi64(*s3, 45), _mm256_srli_epi64(*s3, 19));
    return w;
}

/* The fast test of 8 words (zn_fast lane by lane): the 8 values and a bit mask of the lanes that failed it. */
static inline __attribute__((always_inline)) NOISE_TARGET __m256 zn_fast8(__m256i w, int *bad)
{
    const __m256i i = _mm256_and_si256(w, _mm256_set1_epi32(ZN_LAYERS - 1));
    const __m256i j = _mm256_add_epi32(_mm256_slli_epi32(_mm256_srai_epi32(w, ZN_BITS), 1), _mm256_set1_epi32(1));
    const __m256 u = _mm256_mul_ps(_mm256_cvtepi32_ps(j), _mm256_set1_ps(0x1p-22f));
    /* (x_i, r_i) of the lanes as 64-bit pairs by eight scalar loads (AVX2's gathers are slower on AMD Zen) */
    uint32_t ix[8];
    _mm256_storeu_si256((__m256i *)ix, i);
    const long long *xr = (const long long *)(const void *)zn_xr;
    const __m256 g0 = _mm256_castsi256_ps(_mm256_set_epi64x(xr[ix[3]], xr[ix[2]], xr[ix[1]], xr[ix[0]]));
    const __m256 g1 = _mm256_castsi256_ps(_mm256_set_epi64x(xr[ix[7]], xr[ix[6]], xr[ix[5]], xr[ix[4]]));
    const __m256 x = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, 0x88)), 0xD8));
    const __m256 r = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(g0, g1, 0xDD)), 0xD8));
    const __m256 au = _mm256_andnot_ps(_mm256_set1_ps(-0.0f), u);
    *bad = _mm256_movemask_ps(_mm256_cmp_ps(au, r, _CMP_NLT_UQ));
    return _mm256_mul_ps(u, x);
}

/* The slow lanes of sample n (words w, their fast values already in z) finished one by one. */
static NOINLINE void zn_fix8(uint64_t key, int64_t n, const uint32_t *w, int bad, float *z)
{
    do {
        const int k = __builtin_ctz((unsigned)bad);
        z[k] = zn_slow(key, n, k, w[k]);
        bad &= bad - 1;
    } while (bad);
}

/* The generators of the block of sample n, advanced to n (for C = 8: one step per sample). */
#define NOISE_BLOCK_START(key, n, s0, s1, s2, s3)                                                                   \
    do {                                                                                                            \
        const int64_t b_ = (n) / NOISE_BLOCK;                                                                       \
        uint64_t st_[4][NOISE_LANES];                                                                               \
        noise_seed((key), (uint64_t)b_, st_);                                                                       \
        s0 = _mm256_loadu_si256((const __m256i *)st_[0]), s1 = _mm256_loadu_si256((const __m256i *)st_[1]);         \
        s2 = _mm256_loadu_si256((const __m256i *)st_[2]), s3 = _mm256_loadu_si256((const __m256i *)st_[3]);         \
        for (int64_t k_ = b_ * NOISE_BLOCK; k_ < (n); ++k_) (void)noise_step_avx2(&s0, &s1, &s2, &s3);              \
    } while (0)

/* noise_fill_scalar for C = 8 with AVX2: the same bits. */
NOINLINE NOISE_TARGET void noise_fill8_avx2(uint64_t key, int64_t n0, int nb, float *Z)
{
    int j = 0;
    while (j < nb) {
        const int64_t n = n0 + j;
        int cnt = NOISE_BLOCK - (int)(n % NOISE_BLOCK);
        if (cnt > nb - j) cnt = nb - j;
        __m256i s0, s1, s2, s3;
        NOISE_BLOCK_START(key, n, s0, s1, s2, s3);
        /* the rare samples with a slow lane (3.4 %) are listed and finished after the loop: no call (and no
         * spill of the generators' state) inside it */
        int late[NOISE_BLOCK], n_late = 0;
        uint32_t wl[NOISE_BLOCK][8];
        for (int i = 0; i < cnt; ++i) {
            const __m256i w = noise_step_avx2(&s0, &s1, &s2, &s3);
            int bad;
            _mm256_storeu_ps(Z + 8 * (j + i), zn_fast8(w, &bad));
            if (__builtin_expect(bad != 0, 0)) {
                _mm256_storeu_si256((__m256i *)wl[n_late], w);
                late[n_late++] = i;
            }
        }
        for (int q = 0; q < n_late; ++q) {
            const int i = late[q];
            int bad;
            (void)zn_fast8(_mm256_loadu_si256((const __m256i *)wl[q]), &bad);
            zn_fix8(key, n + i, wl[q], bad, Z + 8 * (j + i));
        }
        j += cnt;
    }
}

/* x[i][c] = (x[i][c] + sigma[c] z[i][c]) (+ extra[i][c]) for 8 float32 channels, nb samples from absolute sample
 * n0 within one noise block: the product, then the sums (noise_add_block's order), without a buffer of normals. */
NOINLINE NOISE_TARGET void noise_add8_avx2(uint64_t key, int64_t n0, int nb, const float *sigma, float *x,
                                                  const float *extra)
{
    __m256i s0, s1, s2, s3;
    NOISE_BLOCK_START(key, n0, s0, s1, s2, s3);
    const __m256 sig = _mm256_loadu_ps(sigma);
    int late[NOISE_BLOCK], n_late = 0;                 /* samples with a slow lane: done after the loop */
    uint32_t wl[NOISE_BLOCK][8];
    for (int i = 0; i < nb; ++i) {
        const __m256i w = noise_step_avx2(&s0, &s1, &s2, &s3);
        int bad;
        const __m256 z = zn_fast8(w, &bad);
        if (__builtin_expect(bad != 0, 0)) {
            _mm256_storeu_si256((__m256i *)wl[n_late], w);
            late[n_late++] = i;
            continue;
        }
        __m256 v = _mm256_add_ps(_mm256_loadu_ps(x + 8 * i), _mm256_mul_ps(sig, z));
        if (extra != NULL) v = _mm256_add_ps(v, _mm256_loadu_ps(extra + 8 * i));
        _mm256_storeu_ps(x + 8 * i, v);
    }
    for (int q = 0; q < n_late; ++q) {
        const int i = late[q];
        int bad;
        float z[8];
        _mm256_storeu_ps(z, zn_fast8(_mm256_loadu_si256((const __m256i *)wl[q]), &bad));
        zn_fix8(key, n0 + i, wl[q], bad, z);
        __m256 v = _mm256_add_ps(_mm256_loadu_ps(x + 8 * i), _mm256_mul_ps(sig, _mm256_loadu_ps(z)));
        if (extra != NULL) v = _mm256_add_ps(v, _mm256_loadu_ps(extra + 8 * i));
        _mm256_storeu_ps(x + 8 * i, v);
    }
}
/* zn_fast8 for the 4 words of a 4-channel sample (the low half of a step): the same operations lane by lane, so the
 * same values, with half the table loads. */
static inline __attribute__((always_inline)) NOISE_TARGET __m128 zn_fast4(__m128i w, int *bad)
{
    const __m128i i = _mm_and_si128(w, _mm_set1_epi32(ZN_LAYERS - 1));
    const __m128i j = _mm_add_epi32(_mm_slli_epi32(_mm_srai_epi32(w, ZN_BITS), 1), _mm_set1_epi32(1));
    const __m128 u = _mm_mul_ps(_mm_cvtepi32_ps(j), _mm_set1_ps(0x1p-22f));
    uint32_t ix[4];
    _mm_storeu_si128((__m128i *)ix, i);
    const long long *xr = (const long long *)(const void *)zn_xr;
    const __m128 g0 = _mm_castsi128_ps(_mm_set_epi64x(xr[ix[1]], xr[ix[0]]));
    const __m128 g1 = _mm_castsi128_ps(_mm_set_epi64x(xr[ix[3]], xr[ix[2]]));
    const __m128 x = _mm_shuffle_ps(g0, g1, 0x88), r = _mm_shuffle_ps(g0, g1, 0xDD);
    const __m128 au = _mm_andnot_ps(_mm_set1_ps(-0.0f), u);
    *bad = _mm_movemask_ps(_mm_cmp_ps(au, r, _CMP_NLT_UQ));
    return _mm_mul_ps(u, x);
}

/* noise_add8_avx2 for 4 channels (the acc4 set): a sample's normals are words 0 .. 3 of its step (as
 * noise_fill_narrow_avx2 keeps them), x + sigma z then + extra in 128-bit lanes: the generic path's values, in one
 * pass without the 8-channel buffer and its per-sample copies. */
NOINLINE NOISE_TARGET void noise_add4_avx2(uint64_t key, int64_t n0, int nb, const float *sigma, float *x,
                                                  const float *extra)
{
    __m256i s0, s1, s2, s3;
    NOISE_BLOCK_START(key, n0, s0, s1, s2, s3);
    const __m128 sig = _mm_loadu_ps(sigma);
    int late[NOISE_BLOCK], n_late = 0;
    uint32_t wl[NOISE_BLOCK][4];
    for (int i = 0; i < nb; ++i) {
        const __m128i w = _mm256_castsi256_si128(noise_step_avx2(&s0, &s1, &s2, &s3));
        int bad;
        const __m128 z = zn_fast4(w, &bad);
        if (__builtin_expect(bad != 0, 0)) {
            _mm_storeu_si128((__m128i *)wl[n_late], w);
            late[n_late++] = i;
            continue;
        }
        __m128 v = _mm_add_ps(_mm_loadu_ps(x + 4 * i), _mm_mul_ps(sig, z));
        if (extra != NULL) v = _mm_add_ps(v, _mm_loadu_ps(extra + 4 * i));
        _mm_storeu_ps(x + 4 * i, v);
    }
    for (int q = 0; q < n_late; ++q) {
        const int i = late[q];
        int bad;
        float z[4];
        _mm_storeu_ps(z, zn_fast4(_mm_loadu_si128((const __m128i *)wl[q]), &bad));
        zn_fix8(key, n0 + i, wl[q], bad, z);
        __m128 v = _mm_add_ps(_mm_loadu_ps(x + 4 * i), _mm_mul_ps(sig, _mm_loadu_ps(z)));
        if (extra != NULL) v = _mm_add_ps(v, _mm_loadu_ps(extra + 4 * i));
        _mm_storeu_ps(x + 4 * i, v);
    }
}

/* Any C <= 8 with AVX2: the 8 normals of each sample's step, the first C kept (the same bits as the scalar code:
 * a slow lane's value depends on its channel only, so computing the unused ones changes nothing). */
void noise_fill_narrow_avx2(uint64_t key, int64_t n0, int nb, int C, float *Z)
{
    float Z8[NOISE_BLOCK * 8];
    for (int j = 0; j < nb; j += NOISE_BLOCK) {
        const int cnt = nb - j < NOISE_BLOCK ? nb - j : NOISE_BLOCK;
        noise_fill8_avx2(key, n0 + j, cnt, Z8);
        for (int i = 0; i < cnt; ++i) memcpy(Z + (int64_t)(j + i) * C, Z8 + 8 * i, sizeof(float) * (size_t)C);
    }
}
#else
void noise_fill8_avx2(uint64_t key, int64_t n0, int nb, float *Z)
{
    noise_fill_scalar(key, n0, nb, 8, Z);
}
void noise_fill_narrow_avx2(uint64_t key, int64_t n0, int nb, int C, float *Z)
{
    noise_fill_scalar(key, n0, nb, C, Z);
}
void noise_add8_avx2(uint64_t key, int64_t n0, int nb, const float *sigma, float *x, const float *extra)
{
    (void)key, (void)n0, (void)nb, (void)sigma, (void)x, (void)extra;
}
void noise_add4_avx2(uint64_t key, int64_t n0, int nb, const float *sigma, float *x, const float *extra)
{
    (void)key, (void)n0, (void)nb, (void)sigma, (void)x, (void)extra;
}
#endif
