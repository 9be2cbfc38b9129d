/*
 * The ground every unit of the synthesiser's kernels stands on: fixed-point and block constants, function
 * attributes, vector types, the instruction-set cap of the run-time dispatch, and the per-block helpers of every
 * sample loop (phase_block, WEIGHT_BLOCK, blend_weight; with AVX2 + FMA the 8-sample phases Phase8 and
 * prologue8_fma; the carrier's cos / sin carrier_cos_sin). Inline definitions only: every unit that includes this
 * compiles its own copy, so the loops keep their constants (channel counts, options) folded in. The arithmetic
 * they implement, and why it is shaped so, is docs/performance.md.
 */
#ifndef BKABEM_SYNTH_COMMON_H
#define BKABEM_SYNTH_COMMON_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define FRAC_BITS 24                        /* bits of the fraction of a table step the weights are computed from */
#define FRAC_MASK ((UINT64_C(1) << FRAC_BITS) - 1)
#define BLEND_LEVELS 65536                  /* time-blend weight quantised to 2^-16 */
#define BLOCK 256                           /* samples per block (phases, rows, moments); = NOISE_BLOCK */

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#define NOINLINE __attribute__((noinline))
#else
#define INLINE static inline
#define NOINLINE
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CLONES
#endif

typedef double v4d __attribute__((vector_size(32)));
typedef int64_t v4l __attribute__((vector_size(32)));
typedef float v4f __attribute__((vector_size(16)));
typedef uint64_t v4u __attribute__((vector_size(32)));
typedef int32_t v4i __attribute__((vector_size(16)));
typedef double v2d __attribute__((vector_size(16)));
typedef int64_t v2l __attribute__((vector_size(16)));
typedef float v2f32 __attribute__((vector_size(8)));
typedef float v4f32 __attribute__((vector_size(16)));
typedef float v8f32 __attribute__((vector_size(32)));
typedef double v2f64 __attribute__((vector_size(16)));
typedef double v4f64 __attribute__((vector_size(32)));

/* Highest instruction set the run-time dispatch of the kernels may choose (tests lower it to cover the others):
 * 2 AVX-512 (the knot FFT), 1 AVX2 + FMA, 0 baseline. Process-wide (synth_common.c); not meant to change while
 * kernels run. */
extern int synth_isa_cap;

/* Phases of samples j = 0 .. nb-1 of a block, from the phase u and increment d of sample 0 (advanced to sample nb on
 * return): the row idx[j] = (V_j >> fb) & mask and the fraction frac[j] = (V_j >> (fb - 24)) & (2^24 - 1), as
 * int32 (cheap to load, and to convert to float for the weights). Four samples per step in 64-bit lanes:
 * U_{j+4} = U_j + 4 D_j + 6 dd, D_{j+4} = D_j + 4 dd, which is the scalar recurrence exactly (modulo 2^64). */
INLINE void phase_block(const int has_warp, int nb, uint64_t *pu, uint64_t *pd, uint64_t dd,
                        const int64_t *restrict warp, int fb, uint64_t mask, int32_t *restrict idx,
                        int32_t *restrict frac)
{
    const int sh = fb - FRAC_BITS;
    uint64_t u = *pu, d = *pd;
    int j = 0;
    if (nb >= 4) {
        v4u U = {u, u + d, u + 2 * d + dd, u + 3 * d + 3 * dd}, D = {d, d + dd, d + 2 * dd, d + 3 * dd};
        const v4u dd4 = (v4u){dd, dd, dd, dd} * 4, dd6 = (v4u){dd, dd, dd, dd} * 6;
        for (; j + 4 <= nb; j += 4) {
            v4u v = U;
            if (has_warp) {
                v4u w;
                memcpy(&w, warp + j, sizeof w);
                v += w;
            }
            const v4u t = v >> sh;
            const v4i ti = __builtin_convertvector((t >> FRAC_BITS) & mask, v4i);
            const v4i tf = __builtin_convertvector(t & FRAC_MASK, v4i);
            memcpy(idx + j, &ti, sizeof ti);
            memcpy(frac + j, &tf, sizeof tf);
            U += (D << 2) + dd6;
            D += dd4;
        }
        u = U[0], d = D[0];
    }
    for (; j < nb; ++j) {
        uint64_t v = u;
        if (has_warp) v += (uint64_t)warp[j];
        const uint64_t t = v >> sh;
        idx[j] = (int32_t)((t >> FRAC_BITS) & mask);
        frac[j] = (int32_t)(t & FRAC_MASK);
        u += d;
        d += dd;
    }
    *pu = u;
    *pd = d;
}

/* Cubic B-spline weights of a block from the fractions (the sequence of the header; numpy:
 * bkabem_core/synth/kernel.py, _weights_from_fraction). A plain loop of T operations that the vectoriser maps to the target's
 * vectors; its vector body and scalar tail round alike (no contraction: -ffp-contract=off), so a sample's weights
 * do not depend on its position in the block. */
#define WEIGHT_BLOCK(T)                                                                                             \
    for (int j = 0; j < nb; ++j) {                                                                                  \
        const T t = (T)frac[j] * (T)0x1p-24, s = (T)1 - t;                                                          \
        const T t2 = t * t, s2 = s * s;                                                                             \
        const T t3 = t2 * t, s3 = s2 * s;                                                                           \
        T e = (T)2 - t, f = (T)2 - s;                                                                               \
        e = t2 * e, f = s2 * f;                                                                                     \
        e = e * (T)0.5, f = f * (T)0.5;                                                                             \
        W0[j] = s3 * (T)(1.0 / 6.0);                                                                                \
        W1[j] = (T)(2.0 / 3.0) - e;                                                                                 \
        W2[j] = (T)(2.0 / 3.0) - f;                                                                                 \
        W3[j] = t3 * (T)(1.0 / 6.0);                                                                                \
    }

/* Blend weights of samples k0 .. k0+nb-1: (double) clip((int64) v, 0, 2^16) / 2^16 for v = (k0 + j + xi0) *
 * blend_scale, i.e. numpy's truncating astype(int64) followed by a clip (NaN gives 0). Clipping before the
 * truncation gives the same value and lets the conversion be a 32-bit one; four samples per step (the offsets
 * k0 + j + l are exact in double, so the lanes' xi are the scalar ones). */
INLINE double blend_weight(double v)
{
    v = v > 0.0 ? v : 0.0;
    v = v < (double)BLEND_LEVELS ? v : (double)BLEND_LEVELS;
    return (double)(int32_t)v * (1.0 / BLEND_LEVELS);
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#include <immintrin.h>
#define FMA_TARGET __attribute__((target("avx2,fma")))

/* The phases of 8 consecutive samples j .. j+7 in two 4-lane uint64 vectors (ua: j .. j+3, ub: j+4 .. j+7) from the
 * phase u and increment d of sample j, and their advance by 8 samples (U + 8 D + 28 dd, D + 8 dd): lane by lane
 * the integers of u += d, d += dd (prologue8_fma, and the carriers of synth_rows.c). */
typedef struct { __m256i ua, ub, da, db, dd8, dd28; } Phase8;
static inline __attribute__((always_inline, target("avx2"))) Phase8 phase8_start(uint64_t u, uint64_t d, uint64_t dd)
{
    Phase8 p;
    const __m256i ddv = _mm256_set1_epi64x((int64_t)dd);
    p.ua = _mm256_set_epi64x((int64_t)(u + 3 * d + 3 * dd), (int64_t)(u + 2 * d + dd), (int64_t)(u + d), (int64_t)u);
    p.da = _mm256_set_epi64x((int64_t)(d + 3 * dd), (int64_t)(d + 2 * dd), (int64_t)(d + dd), (int64_t)d);
    /* samples 4..7: U + 4 D + 6 dd, D + 4 dd (lane by lane) */
    p.ub = _mm256_add_epi64(_mm256_add_epi64(p.ua, _mm256_slli_epi64(p.da, 2)),
                            _mm256_add_epi64(_mm256_slli_epi64(ddv, 2), _mm256_slli_epi64(ddv, 1)));
    p.db = _mm256_add_epi64(p.da, _mm256_slli_epi64(ddv, 2));
    p.dd8 = _mm256_slli_epi64(ddv, 3);
    p.dd28 = _mm256_sub_epi64(_mm256_slli_epi64(ddv, 5), _mm256_slli_epi64(ddv, 2));
    return p;
}
static inline __attribute__((always_inline, target("avx2"))) void phase8_next(Phase8 *p)
{
    p->ua = _mm256_add_epi64(p->ua, _mm256_add_epi64(_mm256_slli_epi64(p->da, 3), p->dd28));
    p->ub = _mm256_add_epi64(p->ub, _mm256_add_epi64(_mm256_slli_epi64(p->db, 3), p->dd28));
    p->da = _mm256_add_epi64(p->da, p->dd8);
    p->db = _mm256_add_epi64(p->db, p->dd8);
}

/* Rows, spline weights and blend weights of a block for the fast path: phase_block, WEIGHT_BLOCK and BLEND_BLOCK
 * fused into one pass over 8 samples at a time in AVX2 registers (the three separate passes through memory cost as
 * much as the row loop). The same integer and float operations as there (no fused ones: the values are the generic
 * path's bit for bit), the 64-bit phases' low halves packed to 8 x 32 bits for the row index and the fraction;
 * the last nb mod 8 samples by the scalar code. u, d advance to sample nb. */
static inline __attribute__((always_inline)) FMA_TARGET void prologue8_fma(
    const int has_warp, const int blend, int nb, int64_t k0, uint64_t *pu, uint64_t *pd, uint64_t dd,
    const int64_t *restrict warp, int fb, uint64_t mask, double xi0, double blend_scale, int32_t *restrict idx,
    float *restrict W0, float *restrict W1, float *restrict W2, float *restrict W3, float *restrict sw)
{
    uint64_t u = *pu, d = *pd;
    int j = 0;
    if (nb >= 8) {
        const __m128i sh = _mm_cvtsi32_si128(fb - FRAC_BITS), sh24 = _mm_cvtsi32_si128(FRAC_BITS);
        Phase8 ph = phase8_start(u, d, dd);
        const __m256i idx_mask = _mm256_set1_epi32((int32_t)mask), frac_mask = _mm256_set1_epi32((int32_t)FRAC_MASK);
        const __m256 scale24 = _mm256_set1_ps(0x1p-24f), one = _mm256_set1_ps(1.0f), two = _mm256_set1_ps(2.0f);
        const __m256 half = _mm256_set1_ps(0.5f), sixth = _mm256_set1_ps((float)(1.0 / 6.0));
        const __m256 two_thirds = _mm256_set1_ps((float)(2.0 / 3.0));
        const __m256d lanes = _mm256_set_pd(3.0, 2.0, 1.0, 0.0), zero = _mm256_setzero_pd();
        const __m256d top = _mm256_set1_pd((double)BLEND_LEVELS), bsc = _mm256_set1_pd(blend_scale);
        const __m256d x0 = _mm256_set1_pd(xi0);
        const __m256 level = _mm256_set1_ps((float)(1.0 / BLEND_LEVELS));
        for (; j + 8 <= nb; j += 8) {
            __m256i va = ph.ua, vb = ph.ub;
            if (has_warp) {
                va = _mm256_add_epi64(va, _mm256_loadu_si256((const __m256i *)(warp + j)));
                vb = _mm256_add_epi64(vb, _mm256_loadu_si256((const __m256i *)(warp + j + 4)));
            }
            const __m256i ta_ = _mm256_srl_epi64(va, sh), tb_ = _mm256_srl_epi64(vb, sh);
            const __m256i ia = _mm256_srl_epi64(ta_, sh24), ib = _mm256_srl_epi64(tb_, sh24);
            /* low 32 bits of the 8 lanes, in order: [a0 a1 b0 b1 | a2 a3 b2 b3] then the middle quarters swapped */
            __m256i ti = _mm256_castps_si256(_mm256_shuffle_ps(_mm256_castsi256_ps(ia), _mm256_castsi256_ps(ib),
                                                               _MM_SHUFFLE(2, 0, 2, 0)));
            __m256i tf = _mm256_castps_si256(_mm256_shuffle_ps(_mm256_castsi256_ps(ta_), _mm256_castsi256_ps(tb_),
                                                               _MM_SHUFFLE(2, 0, 2, 0)));
            ti = _mm256_permute4x64_epi64(ti, _MM_SHUFFLE(3, 1, 2, 0));
            tf = _mm256_permute4x64_epi64(tf, _MM_SHUFFLE(3, 1, 2, 0));
            _mm256_storeu_si256((__m256i *)(idx + j), _mm256_and_si256(ti, idx_mask));
            /* weights: WEIGHT_BLOCK's sequence */
            const __m256 t = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_and_si256(tf, frac_mask)), scale24);
            const __m256 sv = _mm256_sub_ps(one, t);
            const __m256 t2 = _mm256_mul_ps(t, t), s2 = _mm256_mul_ps(sv, sv);
            const __m256 t3 = _mm256_mul_ps(t2, t), s3 = _mm256_mul_ps(s2, sv);
            __m256 e = _mm256_sub_ps(two, t), f = _mm256_sub_ps(two, sv);
            e = _mm256_mul_ps(t2, e), f = _mm256_mul_ps(s2, f);
            e = _mm256_mul_ps(e, half), f = _mm256_mul_ps(f, half);
            _mm256_storeu_ps(W0 + j, _mm256_mul_ps(s3, sixth));
            _mm256_storeu_ps(W1 + j, _mm256_sub_ps(two_thirds, e));
            _mm256_storeu_ps(W2 + j, _mm256_sub_ps(two_thirds, f));
            _mm256_storeu_ps(W3 + j, _mm256_mul_ps(t3, sixth));
            if (blend) {
                /* BLEND_BLOCK's values: max(v, 0) gives 0 for NaN (the second operand), as (v > 0 ? v : 0) */
                __m256d xa = _mm256_add_pd(_mm256_add_pd(lanes, _mm256_set1_pd((double)(k0 + j))), x0);
                __m256d xb = _mm256_add_pd(_mm256_add_pd(lanes, _mm256_set1_pd((double)(k0 + j + 4))), x0);
                xa = _mm256_min_pd(_mm256_max_pd(_mm256_mul_pd(xa, bsc), zero), top);
                xb = _mm256_min_pd(_mm256_max_pd(_mm256_mul_pd(xb, bsc), zero), top);
                const __m256i lv = _mm256_set_m128i(_mm256_cvttpd_epi32(xb), _mm256_cvttpd_epi32(xa));
                _mm256_storeu_ps(sw + j, _mm256_mul_ps(_mm256_cvtepi32_ps(lv), level));
            }
            phase8_next(&ph);
        }
        u = (uint64_t)_mm256_extract_epi64(ph.ua, 0);
        d = (uint64_t)_mm256_extract_epi64(ph.da, 0);
    }
    for (; j < nb; ++j) {
        uint64_t v = u;
        if (has_warp) v += (uint64_t)warp[j];
        const uint64_t tt = v >> (fb - FRAC_BITS);
        idx[j] = (int32_t)((tt >> FRAC_BITS) & mask);
        const float t = (float)(int32_t)(tt & FRAC_MASK) * 0x1p-24f, sv = 1.0f - t;
        const float t2 = t * t, s2 = sv * sv;
        const float t3 = t2 * t, s3 = s2 * sv;
        float e = 2.0f - t, f = 2.0f - sv;
        e = t2 * e, f = s2 * f;
        e = e * 0.5f, f = f * 0.5f;
        W0[j] = s3 * (float)(1.0 / 6.0);
        W1[j] = (float)(2.0 / 3.0) - e;
        W2[j] = (float)(2.0 / 3.0) - f;
        W3[j] = t3 * (float)(1.0 / 6.0);
        if (blend) sw[j] = (float)blend_weight(((double)(k0 + j) + xi0) * blend_scale);
        u += d;
        d += dd;
    }
    *pu = u;
    *pd = d;
}
#define HAVE_FMA_PATH (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
#else
#define HAVE_FMA_PATH 0
#endif

/* cos and sin of 2 pi (v / 2^64 of a turn modulo 4: v in units of 2^62 per turn) from the top 24 bits of the turn's
 * fraction: octant o = 3 bits, x = (21 bits) (pi/4) 2^-21 (or pi/4 - x for odd octants, exact in the integers). */
static inline void carrier_cos_sin(uint64_t v, float *co, float *si)
{
    const uint32_t q = (uint32_t)((v >> 38) & 0xFFFFFF);
    const uint32_t o = q >> 21, r = q & 0x1FFFFF;
    const float x = (float)(int32_t)((o & 1) ? 0x200000 - r : r) * 3.74507028e-7f;
    const float z = x * x;
    float sn = -1.9515295891e-4f;
    sn = sn * z + 8.3321608736e-3f;
    sn = sn * z + -1.6666654611e-1f;
    sn = sn * z * x + x;
    float cs = 2.443315711809948e-5f;
    cs = cs * z + -1.388731625493765e-3f;
    cs = cs * z + 4.166664568298827e-2f;
    cs = cs * z * z - 0.5f * z + 1.0f;
    float c = (o & 1) ? sn : cs, s = (o & 1) ? cs : sn;          /* the angle within its quadrant */
    switch (o >> 1) {
    case 0: *co = c, *si = s; break;
    case 1: *co = -s, *si = c; break;
    case 2: *co = -c, *si = -s; break;
    default: *co = s, *si = -c; break;
    }
}

#endif
