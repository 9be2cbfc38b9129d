/*
 * Sensor noise of the synthesiser, generated inside the sample loop (included by _synthloop.c).
 *
 * Why: a noisy 0.1-s chunk of 8 channels at 51.2 kHz needs 40 960 normal numbers. The ziggurat of the previous
 * design (scalar, branchy, ~4 ns a number) took ~160-200 us per chunk, twice the rest of the synthesiser, and the
 * noise was added and its features taken in two more passes over the chunk. Here the normals come from a
 * branch-free generator that vectorises, are made per block of samples while the block is in L1, and are added
 * before the features of the block are accumulated.
 *
 * Stream. Sample n (absolute sample index of the run) belongs to noise block b = n / NOISE_BLOCK (256 samples).
 * Block b has its own xoshiro256+ generators (Blackman & Vigna 2018), NOISE_LANES = 4 of them, seeded from
 * x = mix64(key ^ mix64(b + golden)) by 16 consecutive splitmix64 outputs (lane l word i = output 4 l + i), so a
 * value depends on (key, n, channel) only: any chunking, any segment split gives the same noise. One step of the
 * four generators makes four 64-bit words; a sample with C channels takes S = ceil(C / 8) steps (8 normals a step),
 * its channel c the normal 8 s + c' of step s = c / 8 ... in the order below.
 *
 * Normals (Box & Muller 1958, polar form of the Gaussian in two dimensions): from a word w,
 *     u = ((w >> 40) + 1) 2^-24 in (0, 1],   r = sqrt(-2 ln u)
 *     a = (w >> 16) & (2^24 - 1): bit 23 swap, bit 22 sign of the first, bit 21 sign of the second,
 *     x = (a & (2^21 - 1)) (pi/4) 2^-21 in [0, pi/4),   (c, s) = (cos x, sin x), swapped if the swap bit is set,
 *     z1 = +-r c, z2 = +-r s
 * i.e. an angle uniform on the circle from its octant (three random reflections of a uniform angle in [0, pi/4),
 * which the Gaussian's symmetry allows) and a radius with the Rayleigh law: two independent standard normals. The
 * 24-bit radius truncates the law at r = sqrt(2 ln 2^24) = 5.77 (a probability of 3.3e-8 beyond it for a pair), far
 * below what a float32 record of a few hours can show. Word w of lane l of step s gives channels 8 s + l (z1) and
 * 8 s + 4 + l (z2). ln, cos and sin are Cephes' single-precision polynomials (logf, sinf, cosf: relative error
 * ~1e-7 on these ranges), their Horner steps as fused multiply-adds (fmaf; 20 % of the generator's time), the
 * other operations separate, in the same order in the scalar and the AVX2 code, so both give the same bits (tested;
 * and against a numpy transcription, synth_kernel.noise_reference, to float rounding: numpy has no fused
 * multiply-add).
 *
 * Cost: ~1 ns a normal with AVX2 + FMA (8 lanes of Box-Muller; the xoshiro steps ~0.3 ns of it).
 */
#ifndef BKABEM_SYNTHNOISE_H
#define BKABEM_SYNTHNOISE_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#define NOISE_BLOCK 256                 /* samples per seeded noise block (absolute sample index / 256) */
#define NOISE_LANES 4                   /* xoshiro256+ generators per block, one 64-bit word each per step */
#define NOISE_MAX_C 64                  /* channels a noisy call may have (the block buffer is on the stack) */

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

/* One step of the four xoshiro256+ generators: w[l] = s0 + s3 of lane l, then the state update. */
static inline void noise_step(uint64_t s[4][NOISE_LANES], uint64_t w[NOISE_LANES])
{
    for (int l = 0; l < NOISE_LANES; ++l) {
        w[l] = s[0][l] + s[3][l];
        const uint64_t t = s[1][l] << 17;
        s[2][l] ^= s[0][l];
        s[3][l] ^= s[1][l];
        s[1][l] ^= s[2][l];
        s[0][l] ^= s[3][l];
        s[2][l] ^= t;
        s[3][l] = noise_rotl(s[3][l], 45);
    }
}

/* Cephes logf for x in (0, 1] (normal floats), the operation order of the AVX2 code below. */
static inline float noise_logf(float x)
{
    int32_t bits;
    memcpy(&bits, &x, 4);
    float e = (float)((bits >> 23) - 126);                              /* x = m 2^e, m in [0.5, 1) */
    bits = (bits & 0x007FFFFF) | 0x3F000000;
    float m;
    memcpy(&m, &bits, 4);
    if (m < 0.707106781186547524f) {                                    /* m in [sqrt(1/2), sqrt(2)) */
        e = e - 1.0f;
        m = m + m;
    }
    m = m - 1.0f;
    const float z = m * m;
    float y = 7.0376836292e-2f;
    y = fmaf(y, m, -1.1514610310e-1f);
    y = fmaf(y, m, 1.1676998740e-1f);
    y = fmaf(y, m, -1.2420140846e-1f);
    y = fmaf(y, m, 1.4249322787e-1f);
    y = fmaf(y, m, -1.6668057665e-1f);
    y = fmaf(y, m, 2.0000714765e-1f);
    y = fmaf(y, m, -2.4999993993e-1f);
    y = fmaf(y, m, 3.3333331174e-1f);
    y = y * m;
    y = y * z;
    y = y + e * -2.12194440e-4f;
    y = y - z * 0.5f;
    return (m + y) + e * 0.693359375f;
}

/* z1, z2 of one word (the header's formula), scalar. */
static inline void noise_pair(uint64_t w, float *z1, float *z2)
{
    const float u = (float)(int32_t)((w >> 40) + 1) * 0x1p-24f;
    const int32_t a = (int32_t)((w >> 16) & 0xFFFFFF);
    const float x = (float)(a & 0x1FFFFF) * 3.74507028e-7f;           /* (pi/4) 2^-21 */
    const float r = sqrtf(-2.0f * noise_logf(u));
    const float q = x * x;
    float sn = -1.9515295891e-4f;
    sn = fmaf(sn, q, 8.3321608736e-3f);
    sn = fmaf(sn, q, -1.6666654611e-1f);
    sn = sn * q; sn = sn * x; sn = sn + x;
    float cs = 2.443315711809948e-5f;
    cs = fmaf(cs, q, -1.388731625493765e-3f);
    cs = fmaf(cs, q, 4.166664568298827e-2f);
    cs = cs * q; cs = cs * q; cs = cs - q * 0.5f; cs = cs + 1.0f;
    const int swap = (a >> 23) & 1;                                     /* selects and sign flips without branches */
    float c = swap ? sn : cs, s = swap ? cs : sn;
    uint32_t cb, sb;
    memcpy(&cb, &c, 4);
    memcpy(&sb, &s, 4);
    cb ^= ((uint32_t)a << 9) & UINT32_C(0x80000000);
    sb ^= ((uint32_t)a << 10) & UINT32_C(0x80000000);
    memcpy(&c, &cb, 4);
    memcpy(&s, &sb, 4);
    *z1 = r * c;
    *z2 = r * s;
}

/* Normals of one step's four words into z[0 .. 7] (z[l] = z1 of lane l, z[4 + l] = z2). */
static inline void noise_step_normals(const uint64_t w[NOISE_LANES], float z[8])
{
    for (int l = 0; l < NOISE_LANES; ++l) noise_pair(w[l], z + l, z + 4 + l);
}

/* Normals of samples n0 .. n0 + nb - 1 (absolute indices), C channels, into Z (nb x C, row-major), scalar. */
static void noise_fill_scalar(uint64_t key, int64_t n0, int nb, int C, float *Z)
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
                float z[8];
                noise_step(s, w);
                noise_step_normals(w, z);
                const int c0 = 8 * st, cn = C - c0 < 8 ? C - c0 : 8;
                memcpy(row + c0, z, sizeof(float) * (size_t)cn);
            }
        }
        j += cnt;
    }
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
#include <immintrin.h>
#define NOISE_AVX2 1
#define NOISE_TARGET __attribute__((target("avx2,fma")))

/* 8 x int32 from the low halves of two vectors of 4 x 64 bits, in order (a0 a1 a2 a3 b0 b1 b2 b3). */
static inline __attribute__((always_inline)) NOISE_TARGET __m256i noise_pack(__m256i a, __m256i b)
{
    const __m256i t = _mm256_castps_si256(_mm256_shuffle_ps(_mm256_castsi256_ps(a), _mm256_castsi256_ps(b),
                                                            _MM_SHUFFLE(2, 0, 2, 0)));
    return _mm256_permute4x64_epi64(t, _MM_SHUFFLE(3, 1, 2, 0));
}

static inline __attribute__((always_inline)) NOISE_TARGET __m256i noise_step_avx2(__m256i *s0, __m256i *s1,
                                                                                   __m256i *s2, __m256i *s3)
{
    const __m256i w = _mm256_add_epi64(*s0, *s3);
    const __m256i t = _mm256_slli_epi64(*s1, 17);
    *s2 = _mm256_xor_si256(*s2, *s0);
    *s3 = _mm256_xor_si256(*s3, *s1);
    *s1 = _mm256_xor_si256(*s1, *s2);
    *s0 = _mm256_xor_si256(*s0, *s3);
    *s2 = _mm256_xor_si256(*s2, t);
    *s3 = _mm256_or_si256(_mm256_slli_epi64(*s3, 45), _mm256_srli_epi64(*s3, 19));
    return w;
}

/* Box-Muller of two steps' words (wa: sample i, wb: sample i + 1), 8 lanes, the scalar operation order: the rows
 * of the two samples (8 channels each) into za, zb. */
static inline __attribute__((always_inline)) NOISE_TARGET void noise_bm8(__m256i wa, __m256i wb, float *za,
                                                                          float *zb)
{
    const __m256i one = _mm256_set1_epi64x(1);
    const __m256i ui = noise_pack(_mm256_add_epi64(_mm256_srli_epi64(wa, 40), one),
                                  _mm256_add_epi64(_mm256_srli_epi64(wb, 40), one));
    const __m256i m24 = _mm256_set1_epi64x(0xFFFFFF);
    const __m256i a = noise_pack(_mm256_and_si256(_mm256_srli_epi64(wa, 16), m24),
                                 _mm256_and_si256(_mm256_srli_epi64(wb, 16), m24));
    const __m256 u = _mm256_mul_ps(_mm256_cvtepi32_ps(ui), _mm256_set1_ps(0x1p-24f));
    /* ln u (noise_logf) */
    __m256i bits = _mm256_castps_si256(u);
    __m256 e = _mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_srai_epi32(bits, 23), _mm256_set1_epi32(126)));
    bits = _mm256_or_si256(_mm256_and_si256(bits, _mm256_set1_epi32(0x007FFFFF)), _mm256_set1_epi32(0x3F000000));
    __m256 m = _mm256_castsi256_ps(bits);
    const __m256 lt = _mm256_cmp_ps(m, _mm256_set1_ps(0.707106781186547524f), _CMP_LT_OQ);
    e = _mm256_blendv_ps(e, _mm256_sub_ps(e, _mm256_set1_ps(1.0f)), lt);
    m = _mm256_blendv_ps(m, _mm256_add_ps(m, m), lt);
    m = _mm256_sub_ps(m, _mm256_set1_ps(1.0f));
    const __m256 z = _mm256_mul_ps(m, m);
#define NOISE_HORNER(y, x, c) y = _mm256_fmadd_ps(y, x, _mm256_set1_ps(c))
    __m256 y = _mm256_set1_ps(7.0376836292e-2f);
    NOISE_HORNER(y, m, -1.1514610310e-1f);
    NOISE_HORNER(y, m, 1.1676998740e-1f);
    NOISE_HORNER(y, m, -1.2420140846e-1f);
    NOISE_HORNER(y, m, 1.4249322787e-1f);
    NOISE_HORNER(y, m, -1.6668057665e-1f);
    NOISE_HORNER(y, m, 2.0000714765e-1f);
    NOISE_HORNER(y, m, -2.4999993993e-1f);
    NOISE_HORNER(y, m, 3.3333331174e-1f);
    y = _mm256_mul_ps(y, m);
    y = _mm256_mul_ps(y, z);
    y = _mm256_add_ps(y, _mm256_mul_ps(e, _mm256_set1_ps(-2.12194440e-4f)));
    y = _mm256_sub_ps(y, _mm256_mul_ps(z, _mm256_set1_ps(0.5f)));
    const __m256 ln = _mm256_add_ps(_mm256_add_ps(m, y), _mm256_mul_ps(e, _mm256_set1_ps(0.693359375f)));
    const __m256 r = _mm256_sqrt_ps(_mm256_mul_ps(_mm256_set1_ps(-2.0f), ln));
    /* cos, sin of the octant angle */
    const __m256 x = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_and_si256(a, _mm256_set1_epi32(0x1FFFFF))),
                                   _mm256_set1_ps(3.74507028e-7f));
    const __m256 q = _mm256_mul_ps(x, x);
    __m256 sn = _mm256_set1_ps(-1.9515295891e-4f);
    NOISE_HORNER(sn, q, 8.3321608736e-3f);
    NOISE_HORNER(sn, q, -1.6666654611e-1f);
    sn = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(sn, q), x), x);
    __m256 cs = _mm256_set1_ps(2.443315711809948e-5f);
    NOISE_HORNER(cs, q, -1.388731625493765e-3f);
    NOISE_HORNER(cs, q, 4.166664568298827e-2f);
    cs = _mm256_mul_ps(_mm256_mul_ps(cs, q), q);
    cs = _mm256_add_ps(_mm256_sub_ps(cs, _mm256_mul_ps(q, _mm256_set1_ps(0.5f))), _mm256_set1_ps(1.0f));
#undef NOISE_HORNER
    const __m256 swap = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(a, _mm256_set1_epi32(0x800000)),
                                                               _mm256_set1_epi32(0x800000)));
    __m256 c = _mm256_blendv_ps(cs, sn, swap), s = _mm256_blendv_ps(sn, cs, swap);
    /* the sign bits 22 and 21 moved to bit 31 flip the sign (xor) */
    c = _mm256_xor_ps(c, _mm256_castsi256_ps(_mm256_and_si256(_mm256_slli_epi32(a, 9), _mm256_set1_epi32(INT32_MIN))));
    s = _mm256_xor_ps(s, _mm256_castsi256_ps(_mm256_and_si256(_mm256_slli_epi32(a, 10), _mm256_set1_epi32(INT32_MIN))));
    const __m256 z1 = _mm256_mul_ps(r, c), z2 = _mm256_mul_ps(r, s);
    _mm256_storeu_ps(za, _mm256_permute2f128_ps(z1, z2, 0x20));
    _mm256_storeu_ps(zb, _mm256_permute2f128_ps(z1, z2, 0x31));
}

/* noise_fill_scalar for C = 8 with AVX2: the same bits. */
static NOINLINE NOISE_TARGET void noise_fill8_avx2(uint64_t key, int64_t n0, int nb, float *Z)
{
    int j = 0;
    while (j < nb) {
        const int64_t n = n0 + j;
        const int64_t b = n / NOISE_BLOCK;
        const int first = (int)(n - b * NOISE_BLOCK);
        int cnt = NOISE_BLOCK - first;
        if (cnt > nb - j) cnt = nb - j;
        uint64_t st[4][NOISE_LANES];
        noise_seed(key, (uint64_t)b, st);
        __m256i s0 = _mm256_loadu_si256((const __m256i *)st[0]), s1 = _mm256_loadu_si256((const __m256i *)st[1]);
        __m256i s2 = _mm256_loadu_si256((const __m256i *)st[2]), s3 = _mm256_loadu_si256((const __m256i *)st[3]);
        for (int k = 0; k < first; ++k) (void)noise_step_avx2(&s0, &s1, &s2, &s3);
        float *zr = Z + (int64_t)j * 8;
        int i = 0;
        for (; i + 2 <= cnt; i += 2) {
            const __m256i wa = noise_step_avx2(&s0, &s1, &s2, &s3);
            const __m256i wb = noise_step_avx2(&s0, &s1, &s2, &s3);
            noise_bm8(wa, wb, zr + 8 * i, zr + 8 * i + 8);
        }
        if (i < cnt) {
            uint64_t w[NOISE_LANES];
            _mm256_storeu_si256((__m256i *)w, noise_step_avx2(&s0, &s1, &s2, &s3));
            noise_step_normals(w, zr + 8 * i);
        }
        j += cnt;
    }
}
#define HAVE_NOISE_AVX2 (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))

/* Any C <= 8 with AVX2: the 8 normals of each sample's step, the first C kept (the same bits as the scalar code). */
static void noise_fill_narrow_avx2(uint64_t key, int64_t n0, int nb, int C, float *Z)
{
    float Z8[NOISE_BLOCK * 8];
    for (int j = 0; j < nb; j += NOISE_BLOCK) {
        const int cnt = nb - j < NOISE_BLOCK ? nb - j : NOISE_BLOCK;
        noise_fill8_avx2(key, n0 + j, cnt, Z8);
        for (int i = 0; i < cnt; ++i) memcpy(Z + (int64_t)(j + i) * C, Z8 + 8 * i, sizeof(float) * (size_t)C);
    }
}
#else
#define NOISE_AVX2 0
#define HAVE_NOISE_AVX2 0
static void noise_fill8_avx2(uint64_t key, int64_t n0, int nb, float *Z)
{
    noise_fill_scalar(key, n0, nb, 8, Z);
}
static void noise_fill_narrow_avx2(uint64_t key, int64_t n0, int nb, int C, float *Z)
{
    noise_fill_scalar(key, n0, nb, C, Z);
}
#endif

#endif
