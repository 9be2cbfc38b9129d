/*
 * The rows of a line set's families for 8 (and 4) float32 channels with AVX2 + FMA (synth_rows.h): families that
 * share one phase are evaluated together, and the carriers' cos / sin are computed 8 samples at a time.
 *
 * A group of families with the same phase (phase0, dphase0, ddphase), table size and slip row takes one prologue
 * (rows, spline and blend weights into small arrays, prologue8_fma), then each family's taps over the block with
 * fused multiply-adds, two families a pass. A group moves its families' contributions together, so the sum over
 * families is in another order than the generic path's (float rounding, as the fused multiply-adds already are).
 *
 * Carrier cos / sin (carrier8_avx2): carrier_cos_sin of synth_common.h on 8 lanes, the same operations (separate
 * multiplies and adds, octant from 24 bits of the turn, quadrant by swap and sign), so the same bits.
 */
#include "synth_rows.h"

#include <string.h>

#include "synth_common.h"

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
/* cos and sin of the carrier phases u_j (+ wc[j]) of a block, u, d advanced to sample nb (carrier_cos_sin's bits). */
NOINLINE __attribute__((target("avx2"))) void carrier8_avx2(int nb, uint64_t *pu, uint64_t *pd, uint64_t dd,
                                                                   const int64_t *restrict wc, float *restrict co,
                                                                   float *restrict si)
{
    uint32_t q[BLOCK];
    uint64_t u = *pu, d = *pd;
    int j = 0;
    if (nb >= 8) {                           /* 24 bits of the turns' fractions, 8 phases at a time (prologue8_fma) */
        const __m256i m24 = _mm256_set1_epi64x(0xFFFFFF);
        Phase8 ph = phase8_start(u, d, dd);
        for (; j + 8 <= nb; j += 8) {
            __m256i va = ph.ua, vb = ph.ub;
            if (wc) {
                va = _mm256_add_epi64(va, _mm256_loadu_si256((const __m256i *)(wc + j)));
                vb = _mm256_add_epi64(vb, _mm256_loadu_si256((const __m256i *)(wc + j + 4)));
            }
            va = _mm256_and_si256(_mm256_srli_epi64(va, 38), m24);
            vb = _mm256_and_si256(_mm256_srli_epi64(vb, 38), m24);
            __m256i t = _mm256_castps_si256(_mm256_shuffle_ps(_mm256_castsi256_ps(va), _mm256_castsi256_ps(vb),
                                                              _MM_SHUFFLE(2, 0, 2, 0)));
            _mm256_storeu_si256((__m256i *)(q + j), _mm256_permute4x64_epi64(t, _MM_SHUFFLE(3, 1, 2, 0)));
            phase8_next(&ph);
        }
        u = (uint64_t)_mm256_extract_epi64(ph.ua, 0);
        d = (uint64_t)_mm256_extract_epi64(ph.da, 0);
    }
    for (; j < nb; ++j) {
        q[j] = (uint32_t)(((u + (wc ? (uint64_t)wc[j] : 0)) >> 38) & 0xFFFFFF);
        u += d, d += dd;
    }
    *pu = u, *pd = d;
    j = 0;
    const __m256i m21 = _mm256_set1_epi32(0x1FFFFF), one = _mm256_set1_epi32(1), full = _mm256_set1_epi32(0x200000);
    const __m256i sign = _mm256_set1_epi32(INT32_MIN);
    for (; j + 8 <= nb; j += 8) {
        const __m256i qv = _mm256_loadu_si256((const __m256i *)(q + j));
        const __m256i o = _mm256_srli_epi32(qv, 21), r = _mm256_and_si256(qv, m21);
        const __m256i odd = _mm256_cmpeq_epi32(_mm256_and_si256(o, one), one);
        const __m256i a = _mm256_blendv_epi8(r, _mm256_sub_epi32(full, r), odd);
        const __m256 x = _mm256_mul_ps(_mm256_cvtepi32_ps(a), _mm256_set1_ps(3.74507028e-7f));
        const __m256 z = _mm256_mul_ps(x, x);
        __m256 sn = _mm256_set1_ps(-1.9515295891e-4f);
        sn = _mm256_add_ps(_mm256_mul_ps(sn, z), _mm256_set1_ps(8.3321608736e-3f));
        sn = _mm256_add_ps(_mm256_mul_ps(sn, z), _mm256_set1_ps(-1.6666654611e-1f));
        sn = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(sn, z), x), x);
        __m256 cs = _mm256_set1_ps(2.443315711809948e-5f);
        cs = _mm256_add_ps(_mm256_mul_ps(cs, z), _mm256_set1_ps(-1.388731625493765e-3f));
        cs = _mm256_add_ps(_mm256_mul_ps(cs, z), _mm256_set1_ps(4.166664568298827e-2f));
        cs = _mm256_add_ps(_mm256_sub_ps(_mm256_mul_ps(_mm256_mul_ps(cs, z), z), _mm256_mul_ps(_mm256_set1_ps(0.5f), z)),
                           _mm256_set1_ps(1.0f));
        /* within the quadrant: (c, s) = odd octant ? (sn, cs) : (cs, sn); quadrant k = o >> 1 turns it by k pi/2:
         * 0 (c, s), 1 (-s, c), 2 (-c, -s), 3 (s, -c): swap for odd k, cos negative for k = 1, 2, sin for k = 2, 3 */
        const __m256 oddf = _mm256_castsi256_ps(odd);
        const __m256 c = _mm256_blendv_ps(cs, sn, oddf), s = _mm256_blendv_ps(sn, cs, oddf);
        const __m256i k = _mm256_srli_epi32(o, 1);
        const __m256 kodd = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(k, one), one));
        __m256 cv = _mm256_blendv_ps(c, s, kodd), sv = _mm256_blendv_ps(s, c, kodd);
        const __m256i neg_c = _mm256_slli_epi32(_mm256_xor_si256(k, _mm256_srli_epi32(k, 1)), 31);
        const __m256i neg_s = _mm256_slli_epi32(_mm256_srli_epi32(k, 1), 31);
        cv = _mm256_xor_ps(cv, _mm256_castsi256_ps(_mm256_and_si256(neg_c, sign)));
        sv = _mm256_xor_ps(sv, _mm256_castsi256_ps(_mm256_and_si256(neg_s, sign)));
        _mm256_storeu_ps(co + j, cv);
        _mm256_storeu_ps(si + j, sv);
    }
    for (; j < nb; ++j) carrier_cos_sin((uint64_t)q[j] << 38, co + j, si + j);
}

/* One group of nf families with one phase (u, d, dd, slip row w, table step fb / mask) for a block: rows and
 * weights once (prologue8_fma), then per sample every family's taps (A[k], B[k] the knots' tables, NT[k] floats
 * of one table, car[k] with its carrier's CQ[k], SQ[k]) added to the block accumulator blk in order k = 0 .. nf-1. */
#define GROUP_TAP(T, r, w0, w1, w2, w3)                                                                             \
    _mm256_fmadd_ps(w3, _mm256_loadu_ps((T) + (r) + 24),                                                            \
                    _mm256_fmadd_ps(w2, _mm256_loadu_ps((T) + (r) + 16),                                            \
                                    _mm256_fmadd_ps(w1, _mm256_loadu_ps((T) + (r) + 8),                             \
                                                    _mm256_mul_ps(w0, _mm256_loadu_ps((T) + (r))))))
static inline __attribute__((always_inline)) FMA_TARGET void group8_rows(
    const int blend, const int car, int nb, const int32_t *restrict idx, const float *restrict W0,
    const float *restrict W1, const float *restrict W2, const float *restrict W3, const float *restrict sw,
    const float *restrict A, const float *restrict B, int64_t NT, const float *restrict CQ,
    const float *restrict SQ, float *restrict blk)
{
    /* one family over the block (samples independent: the loop keeps many in flight, where a loop over the
     * families inside the sample loop would chain every family's multiply-adds on one accumulator) */
    for (int j = 0; j < nb; ++j) {
        const int64_t r = (int64_t)idx[j] * 8;
        const __m256 w0 = _mm256_broadcast_ss(W0 + j), w1 = _mm256_broadcast_ss(W1 + j);
        const __m256 w2 = _mm256_broadcast_ss(W2 + j), w3 = _mm256_broadcast_ss(W3 + j);
        __m256 v = GROUP_TAP(A, r, w0, w1, w2, w3);
        if (blend) v = _mm256_fmadd_ps(_mm256_broadcast_ss(sw + j), _mm256_sub_ps(GROUP_TAP(B, r, w0, w1, w2, w3), v), v);
        __m256 o = _mm256_loadu_ps(blk + 8 * j);
        if (!car) {
            _mm256_storeu_ps(blk + 8 * j, _mm256_add_ps(o, v));
            continue;
        }
        __m256 g = GROUP_TAP(A + NT, r, w0, w1, w2, w3);
        if (blend)
            g = _mm256_fmadd_ps(_mm256_broadcast_ss(sw + j), _mm256_sub_ps(GROUP_TAP(B + NT, r, w0, w1, w2, w3), g), g);
        o = _mm256_fmadd_ps(_mm256_broadcast_ss(CQ + j), v, o);
        o = _mm256_fnmadd_ps(_mm256_broadcast_ss(SQ + j), g, o);
        _mm256_storeu_ps(blk + 8 * j, o);
    }
}
#undef GROUP_TAP

/* group8_rows for 4 float32 channels (C = 4, the acc4 set): the same operations per lane in 128-bit registers (FMA
 * of the same operands in the same order), so each channel's value has the bits of the 8-lane rows' for it. */
#define GROUP_TAP4(T, r, w0, w1, w2, w3)                                                                            \
    _mm_fmadd_ps(w3, _mm_loadu_ps((T) + (r) + 12),                                                                  \
                 _mm_fmadd_ps(w2, _mm_loadu_ps((T) + (r) + 8),                                                      \
                              _mm_fmadd_ps(w1, _mm_loadu_ps((T) + (r) + 4), _mm_mul_ps(w0, _mm_loadu_ps((T) + (r))))))
static inline __attribute__((always_inline)) FMA_TARGET void group4_rows(
    const int blend, const int car, int nb, const int32_t *restrict idx, const float *restrict W0,
    const float *restrict W1, const float *restrict W2, const float *restrict W3, const float *restrict sw,
    const float *restrict A, const float *restrict B, int64_t NT, const float *restrict CQ,
    const float *restrict SQ, float *restrict blk)
{
    for (int j = 0; j < nb; ++j) {
        const int64_t r = (int64_t)idx[j] * 4;
        const __m128 w0 = _mm_broadcast_ss(W0 + j), w1 = _mm_broadcast_ss(W1 + j);
        const __m128 w2 = _mm_broadcast_ss(W2 + j), w3 = _mm_broadcast_ss(W3 + j);
        __m128 v = GROUP_TAP4(A, r, w0, w1, w2, w3);
        if (blend) v = _mm_fmadd_ps(_mm_broadcast_ss(sw + j), _mm_sub_ps(GROUP_TAP4(B, r, w0, w1, w2, w3), v), v);
        __m128 o = _mm_loadu_ps(blk + 4 * j);
        if (!car) {
            _mm_storeu_ps(blk + 4 * j, _mm_add_ps(o, v));
            continue;
        }
        __m128 g = GROUP_TAP4(A + NT, r, w0, w1, w2, w3);
        if (blend) g = _mm_fmadd_ps(_mm_broadcast_ss(sw + j), _mm_sub_ps(GROUP_TAP4(B + NT, r, w0, w1, w2, w3), g), g);
        o = _mm_fmadd_ps(_mm_broadcast_ss(CQ + j), v, o);
        o = _mm_fnmadd_ps(_mm_broadcast_ss(SQ + j), g, o);
        _mm_storeu_ps(blk + 4 * j, o);
    }
}
#undef GROUP_TAP4

/* Two families k, k + 1 of a group in one pass over the block (group8_rows / group4_rows for both): the weights'
 * broadcasts and the accumulator's load and store once per sample for the pair, each family's value as there and
 * added in the same order (k, then k + 1), so the same bits. V the vector type, L its lanes (one row of L floats). */
#define GROUP_PAIR(NAME, V, L, LD, ST, BC, FMADD, FNMADD, MUL, SUB, ADD)                                            \
    static inline __attribute__((always_inline)) FMA_TARGET void NAME(                                              \
        const int blend, const int car0, const int car1, int nb, const int32_t *restrict idx,                       \
        const float *restrict W0, const float *restrict W1, const float *restrict W2, const float *restrict W3,     \
        const float *restrict sw, const float *restrict A0, const float *restrict B0, int64_t NT0,                  \
        const float *restrict CQ0, const float *restrict SQ0, const float *restrict A1, const float *restrict B1,   \
        int64_t NT1, const float *restrict CQ1, const float *restrict SQ1, float *restrict blk)                     \
    {                                                                                                               \
        for (int j = 0; j < nb; ++j) {                                                                              \
            const int64_t r = (int64_t)idx[j] * (L);                                                                \
            const V w0 = BC(W0 + j), w1 = BC(W1 + j), w2 = BC(W2 + j), w3 = BC(W3 + j);                             \
            const V s = blend ? BC(sw + j) : w0;                                                                    \
            V v0 = PT(A0, r, L, LD, FMADD, MUL), v1 = PT(A1, r, L, LD, FMADD, MUL), g0 = v0, g1 = v1;               \
            if (blend) v0 = FMADD(s, SUB(PT(B0, r, L, LD, FMADD, MUL), v0), v0);                                    \
            if (car0) {                                                                                             \
                g0 = PT(A0 + NT0, r, L, LD, FMADD, MUL);                                                            \
                if (blend) g0 = FMADD(s, SUB(PT(B0 + NT0, r, L, LD, FMADD, MUL), g0), g0);                          \
            }                                                                                                       \
            if (blend) v1 = FMADD(s, SUB(PT(B1, r, L, LD, FMADD, MUL), v1), v1);                                    \
            if (car1) {                                                                                             \
                g1 = PT(A1 + NT1, r, L, LD, FMADD, MUL);                                                            \
                if (blend) g1 = FMADD(s, SUB(PT(B1 + NT1, r, L, LD, FMADD, MUL), g1), g1);                          \
            }                                                                                                       \
            V o = LD(blk + (L) * j);                                                                                \
            if (car0) o = FNMADD(BC(SQ0 + j), g0, FMADD(BC(CQ0 + j), v0, o));                                       \
            else o = ADD(o, v0);                                                                                    \
            if (car1) o = FNMADD(BC(SQ1 + j), g1, FMADD(BC(CQ1 + j), v1, o));                                       \
            else o = ADD(o, v1);                                                                                    \
            ST(blk + (L) * j, o);                                                                                   \
        }                                                                                                           \
    }
#define PT(T, r, L, LD, FMADD, MUL)                                                                                 \
    FMADD(w3, LD((T) + (r) + 3 * (L)),                                                                              \
          FMADD(w2, LD((T) + (r) + 2 * (L)), FMADD(w1, LD((T) + (r) + (L)), MUL(w0, LD((T) + (r))))))
GROUP_PAIR(group8_rows2, __m256, 8, _mm256_loadu_ps, _mm256_storeu_ps, _mm256_broadcast_ss, _mm256_fmadd_ps,
           _mm256_fnmadd_ps, _mm256_mul_ps, _mm256_sub_ps, _mm256_add_ps)
GROUP_PAIR(group4_rows2, __m128, 4, _mm_loadu_ps, _mm_storeu_ps, _mm_broadcast_ss, _mm_fmadd_ps, _mm_fnmadd_ps,
           _mm_mul_ps, _mm_sub_ps, _mm_add_ps)
#undef PT
#undef GROUP_PAIR

/* 4 channels, two samples j, j + 1 per 256-bit register (lanes 0-3 sample j, 4-7 sample j + 1): family k (and k + 1
 * if two) as group4_rows / group4_rows2 with the same operations lane by lane in the same order (so the same bits),
 * half the multiply-adds and accumulator loads and stores. A sample's four taps are 64 contiguous bytes, two 256-bit
 * loads; the taps of both samples are paired by 128-bit lane permutes. The last sample of an odd block by the 128-bit
 * code. */
static inline __attribute__((always_inline)) FMA_TARGET __m256 x2_tap(const float *restrict T, int64_t ra,
                                                                       int64_t rb, __m256 w0, __m256 w1, __m256 w2,
                                                                       __m256 w3)
{
    const __m256 xa = _mm256_loadu_ps(T + ra), xb = _mm256_loadu_ps(T + ra + 8);
    const __m256 ya = _mm256_loadu_ps(T + rb), yb = _mm256_loadu_ps(T + rb + 8);
    return _mm256_fmadd_ps(w3, _mm256_permute2f128_ps(xb, yb, 0x31),
                           _mm256_fmadd_ps(w2, _mm256_permute2f128_ps(xb, yb, 0x20),
                                           _mm256_fmadd_ps(w1, _mm256_permute2f128_ps(xa, ya, 0x31),
                                                           _mm256_mul_ps(w0, _mm256_permute2f128_ps(xa, ya, 0x20)))));
}
/* (p[0] in lanes 0-3, p[1] in lanes 4-7) */
#define X2_BC(p)                                                                                                    \
    _mm256_permutevar8x32_ps(_mm256_castps128_ps256(_mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)(p)))), lo_hi)
static inline __attribute__((always_inline)) FMA_TARGET void group4x2_core(
    const int blend, const int two, const int car0, const int car1, int nb, const int32_t *restrict idx,
    const float *restrict W0, const float *restrict W1, const float *restrict W2, const float *restrict W3,
    const float *restrict sw, const float *restrict A0, const float *restrict B0, int64_t NT0,
    const float *restrict CQ0, const float *restrict SQ0, const float *restrict A1, const float *restrict B1,
    int64_t NT1, const float *restrict CQ1, const float *restrict SQ1, float *restrict blk)
{
    const __m256i lo_hi = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
    int j = 0;
    for (; j + 2 <= nb; j += 2) {
        const int64_t ra = (int64_t)idx[j] * 4, rb = (int64_t)idx[j + 1] * 4;
        const __m256 w0 = X2_BC(W0 + j), w1 = X2_BC(W1 + j), w2 = X2_BC(W2 + j), w3 = X2_BC(W3 + j);
        const __m256 s = blend ? X2_BC(sw + j) : w0;
        __m256 v0 = x2_tap(A0, ra, rb, w0, w1, w2, w3), g0 = v0, v1 = v0, g1 = v0;
        if (blend) v0 = _mm256_fmadd_ps(s, _mm256_sub_ps(x2_tap(B0, ra, rb, w0, w1, w2, w3), v0), v0);
        if (car0) {
            g0 = x2_tap(A0 + NT0, ra, rb, w0, w1, w2, w3);
            if (blend) g0 = _mm256_fmadd_ps(s, _mm256_sub_ps(x2_tap(B0 + NT0, ra, rb, w0, w1, w2, w3), g0), g0);
        }
        if (two) {
            v1 = x2_tap(A1, ra, rb, w0, w1, w2, w3);
            if (blend) v1 = _mm256_fmadd_ps(s, _mm256_sub_ps(x2_tap(B1, ra, rb, w0, w1, w2, w3), v1), v1);
            if (car1) {
                g1 = x2_tap(A1 + NT1, ra, rb, w0, w1, w2, w3);
                if (blend) g1 = _mm256_fmadd_ps(s, _mm256_sub_ps(x2_tap(B1 + NT1, ra, rb, w0, w1, w2, w3), g1), g1);
            }
        }
        __m256 o = _mm256_loadu_ps(blk + 4 * j);
        if (car0) o = _mm256_fnmadd_ps(X2_BC(SQ0 + j), g0, _mm256_fmadd_ps(X2_BC(CQ0 + j), v0, o));
        else o = _mm256_add_ps(o, v0);
        if (two) {
            if (car1) o = _mm256_fnmadd_ps(X2_BC(SQ1 + j), g1, _mm256_fmadd_ps(X2_BC(CQ1 + j), v1, o));
            else o = _mm256_add_ps(o, v1);
        }
        _mm256_storeu_ps(blk + 4 * j, o);
    }
    if (j == nb) return;
    if (two)
        group4_rows2(blend, car0, car1, 1, idx + j, W0 + j, W1 + j, W2 + j, W3 + j, blend ? sw + j : sw, A0, B0, NT0,
                     car0 ? CQ0 + j : NULL, car0 ? SQ0 + j : NULL, A1, B1, NT1, car1 ? CQ1 + j : NULL,
                     car1 ? SQ1 + j : NULL, blk + 4 * j);
    else
        group4_rows(blend, car0, 1, idx + j, W0 + j, W1 + j, W2 + j, W3 + j, blend ? sw + j : sw, A0, B0, NT0,
                    car0 ? CQ0 + j : NULL, car0 ? SQ0 + j : NULL, blk + 4 * j);
}
#undef X2_BC
static inline __attribute__((always_inline)) FMA_TARGET void group4x2_rows(
    const int blend, const int car, int nb, const int32_t *restrict idx, const float *restrict W0,
    const float *restrict W1, const float *restrict W2, const float *restrict W3, const float *restrict sw,
    const float *restrict A, const float *restrict B, int64_t NT, const float *restrict CQ,
    const float *restrict SQ, float *restrict blk)
{
    group4x2_core(blend, 0, car, 0, nb, idx, W0, W1, W2, W3, sw, A, B, NT, CQ, SQ, NULL, NULL, 0, NULL, NULL, blk);
}
static inline __attribute__((always_inline)) FMA_TARGET void group4x2_rows2(
    const int blend, const int car0, const int car1, int nb, const int32_t *restrict idx, const float *restrict W0,
    const float *restrict W1, const float *restrict W2, const float *restrict W3, const float *restrict sw,
    const float *restrict A0, const float *restrict B0, int64_t NT0, const float *restrict CQ0,
    const float *restrict SQ0, const float *restrict A1, const float *restrict B1, int64_t NT1,
    const float *restrict CQ1, const float *restrict SQ1, float *restrict blk)
{
    group4x2_core(blend, 1, car0, car1, nb, idx, W0, W1, W2, W3, sw, A0, B0, NT0, CQ0, SQ0, A1, B1, NT1, CQ1, SQ1,
                  blk);
}

/* The rows of families k (and k + 1 if pair) of a group, with their options as constants. */
#define GROUP_ARGS1(b0, c0) nb, idx, W0, W1, W2, W3, sw, A[k], b0, NT[k], c0 ? CQ[k] : NULL, c0 ? SQ[k] : NULL
#define GROUP_ARGS2(b1, c1) A[k + 1], b1, NT[k + 1], c1 ? CQ[k + 1] : NULL, c1 ? SQ[k + 1] : NULL, blk
#define GROUP_CALL(R1, R2)                                                                                          \
    do {                                                                                                            \
        const float *b0 = blend ? B[k] : NULL;                                                                      \
        if (pair) {                                                                                                 \
            const int c0 = car[k], c1 = car[k + 1];                                                                 \
            const float *b1 = blend ? B[k + 1] : NULL;                                                              \
            if (blend) {                                                                                            \
                if (c0 && c1) R2(1, 1, 1, GROUP_ARGS1(b0, 1), GROUP_ARGS2(b1, 1));                                  \
                else if (c0) R2(1, 1, 0, GROUP_ARGS1(b0, 1), GROUP_ARGS2(b1, 0));                                   \
                else if (c1) R2(1, 0, 1, GROUP_ARGS1(b0, 0), GROUP_ARGS2(b1, 1));                                   \
                else R2(1, 0, 0, GROUP_ARGS1(b0, 0), GROUP_ARGS2(b1, 0));                                           \
            } else {                                                                                                \
                if (c0 && c1) R2(0, 1, 1, GROUP_ARGS1(NULL, 1), GROUP_ARGS2(NULL, 1));                              \
                else if (c0) R2(0, 1, 0, GROUP_ARGS1(NULL, 1), GROUP_ARGS2(NULL, 0));                               \
                else if (c1) R2(0, 0, 1, GROUP_ARGS1(NULL, 0), GROUP_ARGS2(NULL, 1));                               \
                else R2(0, 0, 0, GROUP_ARGS1(NULL, 0), GROUP_ARGS2(NULL, 0));                                       \
            }                                                                                                       \
        } else if (blend && car[k]) R1(1, 1, GROUP_ARGS1(b0, 1), blk);                                              \
        else if (blend) R1(1, 0, GROUP_ARGS1(b0, 0), blk);                                                          \
        else if (car[k]) R1(0, 1, GROUP_ARGS1(NULL, 1), blk);                                                       \
        else R1(0, 0, GROUP_ARGS1(NULL, 0), blk);                                                                   \
    } while (0)

NOINLINE FMA_TARGET void lines_group8_fma(int lanes, int nb, int64_t k0, uint64_t *u, uint64_t *d,
                                                uint64_t dd,
                                                const int64_t *w, int fb, uint64_t mask, double xi0,
                                                double blend_scale, int nf, const float *const *A,
                                                const float *const *B, const int64_t *NT, const int *car,
                                                float (*CQ)[BLOCK], float (*SQ)[BLOCK], float *blk)
{
    int32_t idx[BLOCK];
    float W0[BLOCK], W1[BLOCK], W2[BLOCK], W3[BLOCK], sw[BLOCK];
    const int blend = B != NULL && B[0] != NULL;
    if (w != NULL) {
        if (blend) prologue8_fma(1, 1, nb, k0, u, d, dd, w, fb, mask, xi0, blend_scale, idx, W0, W1, W2, W3, sw);
        else prologue8_fma(1, 0, nb, k0, u, d, dd, w, fb, mask, xi0, blend_scale, idx, W0, W1, W2, W3, sw);
    } else {
        if (blend) prologue8_fma(0, 1, nb, k0, u, d, dd, NULL, fb, mask, xi0, blend_scale, idx, W0, W1, W2, W3, sw);
        else prologue8_fma(0, 0, nb, k0, u, d, dd, NULL, fb, mask, xi0, blend_scale, idx, W0, W1, W2, W3, sw);
    }
    for (int k = 0; k < nf; k += 2) {                         /* the families in pairs (the last one alone) */
        const int pair = k + 1 < nf;
        if (lanes == 4) GROUP_CALL(group4x2_rows, group4x2_rows2);
        else GROUP_CALL(group8_rows, group8_rows2);
        if (!pair) break;
    }
}
#undef GROUP_CALL
#undef GROUP_ARGS1
#undef GROUP_ARGS2
#else
void carrier8_avx2(int nb, uint64_t *pu, uint64_t *pd, uint64_t dd, const int64_t *wc, float *co, float *si)
{
    (void)nb, (void)pu, (void)pd, (void)dd, (void)wc, (void)co, (void)si;
}
void lines_group8_fma(int lanes, int nb, int64_t k0, uint64_t *u, uint64_t *d, uint64_t dd, const int64_t *w,
                             int fb,
                             uint64_t mask, double xi0, double blend_scale, int nf, const float *const *A,
                             const float *const *B, const int64_t *NT, const int *car, float (*CQ)[BLOCK],
                             float (*SQ)[BLOCK], float *blk)
{
    (void)lanes, (void)nb, (void)k0, (void)u, (void)d, (void)dd, (void)w, (void)fb, (void)mask, (void)xi0, (void)blend_scale;
    (void)nf, (void)A, (void)B, (void)NT, (void)car, (void)CQ, (void)SQ, (void)blk;
}
#endif

/* Groups of the families of a line set: families f and g are in one group if their phases (phase0, dphase0,
 * ddphase), table sizes and slip rows are equal, at most GROUP_MAX a group; group q holds first[q] .. (its members
 * in member[], in the families' order). Returns the number of groups. */
int lines_groups(int64_t F, const uint64_t *phases, const int64_t *lg, const int64_t *wp, int *start,
                        int *member)
{
    int taken[64] = {0}, n = 0, p = 0;
    for (int64_t f = 0; f < F; ++f) {
        if (taken[f]) continue;
        start[n++] = p;
        int size = 0;
        for (int64_t g = f; g < F && size < GROUP_MAX; ++g)
            if (!taken[g] && lg[g] == lg[f] && wp[g] == wp[f] && phases[6 * g] == phases[6 * f]
                && phases[6 * g + 1] == phases[6 * f + 1] && phases[6 * g + 2] == phases[6 * f + 2]) {
                taken[g] = 1;
                member[p++] = (int)g;
                ++size;
            }
    }
    start[n] = p;
    return n;
}
