/*
 * Any line set in one pass (included by _synthloop.c; uses _synthbase.h, _synthblock.h, _synthrows.h): the spline
 * tables of a line set's families made by an FFT that keeps the channels in vector lanes, and the samples of a
 * segment summed over all families in one call, with the sensor noise and the chunk features fused (synth_lines.py).
 *
 * Why: a non-order line set (inner race: 9 families, ball: 10) was one numpy inverse FFT per family and knot
 * (~90 us for 1024 points x 8 channels in numpy: the ball's tables alone were 1.1 ms per knot) and per family two
 * or three calls of the sample loop, a carrier table and a mix pass over the chunk (~20 us each). Here:
 *
 * Tables (synth_family_tables): family f's G(phi) = sum_k Y_k exp(i k 2 pi phi) at phi = n / N, n = 0 .. N-1, for
 * its lines' channel amplitudes Y (pre-emphasised, conjugated where the family holds the conjugate line), as an
 * iterative radix-2 decimation-in-time inverse FFT (no 1/N) in double over N x C complex values, the C channels
 * contiguous so the butterflies are vector operations over the channels (the twiddles are cos / sin of 2 pi j / N,
 * exact to rounding, from the caller). A real family writes Re G to its (N + 3) x C table, a carrier family Re G
 * and Im G to two; rows padded as the order tables (row r = coefficient (r - 1) mod N).
 *
 * Samples (synth_lines_segment_f32): per block of samples, every family's table row index and spline weights from
 * its own fixed-point phase (+ its slip offsets), the two knots' tables blended in time as the order path, and for a
 * carrier family cos and sin of its carrier phase (+ slip) from 24 bits of the turn: octant, then Cephes' sinf /
 * cosf polynomials on [0, pi/4] (error ~1e-7), so x += cos(2 pi phi_q) Re G - sin(2 pi phi_q) Im G; then the
 * static part, the noise and the features of the block. Float32, any C (the channel loops are unrolled for C = 8).
 * With 8 (or 4: 128-bit lanes, the same operations per lane) channels and AVX2 + FMA, families of one phase share
 * the rows and weights and the carriers' cos / sin are 8 samples at a time (_synthrows.h); a carrier that is the sum
 * of two others of its group (csrc) takes its cos / sin from theirs by the angle addition (carrier_sum).
 */
#ifndef BKABEM_SYNTHLINES_H
#define BKABEM_SYNTHLINES_H

#include "_synthbase.h"
#include "_synthblock.h"   /* NoiseArgs, block_length, noise_add_block_f32, moments_f32 */
#include "_synthrows.h"    /* the grouped AVX2 rows */

/* The broadband floor (synth_floor.py) of m samples from absolute sample n0 into out (m x C, written): grains q of G
 * (grain g, frame, offset: samples [g S, g S + 2 S) read frame `frame` from `offset` under the sine window win),
 * frames F x L x C int16 times scale[c] per channel. Each sample is (0 + w_1 f_1 + w_2 f_2) scale in the grains'
 * order, f the int16 taps as float (synth_floor_render, the per-block render of the line-set kernel and the numpy
 * fallback round alike). Why int16: 4 frames of 2^13 x 8 are 512 KB and stay in L2 (the float32 frames of 2^15
 * were 4 MB and made this the largest kernel of a noisy chunk, bound by memory). */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
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
#define FLOOR8_AVX2 (isa_cap >= 1 && __builtin_cpu_supports("avx2"))
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

static CLONES void floor_block_f32(int64_t m, int64_t C, int64_t n0, int64_t S, int64_t L, const int16_t *frames,
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

/* In-place inverse FFT (sign +, unscaled) of x (N x C complex as re/im pairs, row-major: x[2 (n C + c)] = Re),
 * N a power of 2, tw[2 j] = cos(2 pi j / N), tw[2 j + 1] = sin(2 pi j / N), j < N / 2. */
static CLONES void ifft_channels(int64_t N, int64_t C, double *restrict x, const double *restrict tw)
{
    for (int64_t i = 1, j = 0; i < N; ++i) {                     /* bit reversal of the rows */
        int64_t bit = N >> 1;
        for (; j & bit; bit >>= 1) j ^= bit;
        j ^= bit;
        if (i < j)
            for (int64_t c = 0; c < 2 * C; ++c) {
                const double t = x[2 * i * C + c];
                x[2 * i * C + c] = x[2 * j * C + c];
                x[2 * j * C + c] = t;
            }
    }
    for (int64_t len = 2; len <= N; len <<= 1) {
        const int64_t half = len >> 1, step = N / len;
        for (int64_t s = 0; s < N; s += len)
            for (int64_t k = 0; k < half; ++k) {
                const double wr = tw[2 * k * step], wi = tw[2 * k * step + 1];
                double *restrict a = x + 2 * (s + k) * C, *restrict b = x + 2 * (s + k + half) * C;
                for (int64_t c = 0; c < C; ++c) {
                    const double br = b[2 * c], bi = b[2 * c + 1];
                    const double tr = br * wr - bi * wi, ti = br * wi + bi * wr;
                    const double ar = a[2 * c], ai = a[2 * c + 1];
                    a[2 * c] = ar + tr, a[2 * c + 1] = ai + ti;
                    b[2 * c] = ar - tr, b[2 * c + 1] = ai - ti;
                }
            }
    }
}

/* Tables of F families. y: L x C complex (re/im pairs) channel amplitudes of the lines. Per family f: n_lines[f]
 * lines line[...] (concatenated over the families), their FFT slot (k mod N) and factor (emphasis, sign: a negative
 * factor conjugates), size N[f] with twiddles tw + tw_off[f], and its output tables at table + out_off[f] (one or,
 * for carrier[f], two consecutive (N + 3) x C float tables). work: at least max N x C x 2 doubles. Returns 0 or -1. */
int synth_family_tables(int64_t F, int64_t C, int64_t L, const double *y, const int64_t *n_lines,
                        const int64_t *line, const int64_t *slot, const double *factor, const int64_t *N,
                        const double *tw, const int64_t *tw_off, const int64_t *carrier, float *table,
                        const int64_t *out_off, double *work)
{
    int64_t p = 0;
    for (int64_t f = 0; f < F; ++f) {
        const int64_t n = N[f];
        if (n < 4 || (n & (n - 1)) != 0) return -1;
        memset(work, 0, sizeof(double) * (size_t)(2 * n * C));
        for (int64_t i = 0; i < n_lines[f]; ++i, ++p) {
            const int64_t l = line[p], s = slot[p];
            if (l < 0 || l >= L || s < 0 || s >= n) return -1;
            const double g = factor[p] < 0 ? -factor[p] : factor[p], conj = factor[p] < 0 ? -1.0 : 1.0;
            for (int64_t c = 0; c < C; ++c) {
                work[2 * (s * C + c)] += g * y[2 * (l * C + c)];
                work[2 * (s * C + c) + 1] += conj * g * y[2 * (l * C + c) + 1];
            }
        }
        ifft_channels(n, C, work, tw + tw_off[f]);
        float *re = table + out_off[f], *im = re + (n + 3) * C;
        for (int64_t r = 0; r < n + 3; ++r) {
            const int64_t src = (r - 1 + n) % n;
            for (int64_t c = 0; c < C; ++c) {
                re[r * C + c] = (float)work[2 * (src * C + c)];
                if (carrier[f]) im[r * C + c] = (float)work[2 * (src * C + c) + 1];
            }
        }
    }
    return 0;
}

/* One segment of a line set: m samples x C channels into out (written). Per family f (F of them): phases[f] =
 * {phase0, dphase0, ddphase} of the family phase and {...} of its carrier (uint64, the order path's fixed point),
 * log2 of its table size lg[f], carrier[f], its tables at offset off_t[f] in ta (knot a) and tb (knot b; NULL: no
 * blend), its slip offsets rows wp[f], wq[f] of warp (m int64 each; -1: none). dc: static part per channel.
 * xi0, blend_scale as in segment. acc/off: features (optional); na: noise (optional). Returns 0 or -1. */
#define LINES_ROWS(CC)                                                                                              \
    do {                                                                                                            \
        for (int j = 0; j < nb; ++j) {                                                                              \
            const float *a0 = A + (int64_t)idx[j] * (CC);                                                           \
            const float w0 = W0[j], w1 = W1[j], w2 = W2[j], w3 = W3[j];                                             \
            float v[LINES_MAX_C], g[LINES_MAX_C];                                                                  \
            for (int c = 0; c < (CC); ++c)                                                                          \
                v[c] = w0 * a0[c] + w1 * a0[(CC) + c] + w2 * a0[2 * (CC) + c] + w3 * a0[3 * (CC) + c];             \
            if (B) {                                                                                                \
                const float *b0 = B + (int64_t)idx[j] * (CC);                                                       \
                for (int c = 0; c < (CC); ++c) {                                                                    \
                    const float vb = w0 * b0[c] + w1 * b0[(CC) + c] + w2 * b0[2 * (CC) + c] + w3 * b0[3 * (CC) + c]; \
                    v[c] = v[c] + sw[j] * (vb - v[c]);                                                              \
                }                                                                                                   \
            }                                                                                                       \
            float *o = blk + (int64_t)j * (CC);                                                                     \
            if (!car) {                                                                                             \
                for (int c = 0; c < (CC); ++c) o[c] += v[c];                                                        \
                continue;                                                                                           \
            }                                                                                                       \
            const float *a1 = A + NT + (int64_t)idx[j] * (CC);                                                      \
            for (int c = 0; c < (CC); ++c)                                                                          \
                g[c] = w0 * a1[c] + w1 * a1[(CC) + c] + w2 * a1[2 * (CC) + c] + w3 * a1[3 * (CC) + c];             \
            if (B) {                                                                                                \
                const float *b1 = B + NT + (int64_t)idx[j] * (CC);                                                  \
                for (int c = 0; c < (CC); ++c) {                                                                    \
                    const float vb = w0 * b1[c] + w1 * b1[(CC) + c] + w2 * b1[2 * (CC) + c] + w3 * b1[3 * (CC) + c]; \
                    g[c] = g[c] + sw[j] * (vb - g[c]);                                                              \
                }                                                                                                   \
            }                                                                                                       \
            const float cq = CQ[j], sq = SQ[j];                                                                     \
            for (int c = 0; c < (CC); ++c) o[c] += cq * v[c] - sq * g[c];                                           \
        }                                                                                                           \
    } while (0)

/* cos and sin of the sum of two carrier phases by the angle addition (cos a cos b - sin a sin b, sin a cos b +
 * cos a sin b), for a family whose carrier is the sum of two others of its group (csrc; synth_lines._carrier_sums):
 * 6 operations a sample instead of a phase and two polynomials (carrier8_avx2: ~7 % of a 10-s data-set run of the
 * inner race or the ball). Not the bits of the direct cos / sin: within a few float32 roundings of them. */
static inline void carrier_sum(int nb, const float *restrict ca, const float *restrict sa, const float *restrict cb,
                               const float *restrict sb, float *restrict co, float *restrict si)
{
    for (int j = 0; j < nb; ++j) {
        co[j] = ca[j] * cb[j] - sa[j] * sb[j];
        si[j] = sa[j] * cb[j] + ca[j] * sb[j];
    }
}

/* For the fast path's groups (lines_groups): spos[f] = the places in f's group of the two families whose carriers
 * add up to f's (csrc), or -1, -1 where f's carrier comes from its own phase (no sources, or one of them in another
 * group). The slip rows a render computes follow it (py_lines_render: a summed carrier's own row is not needed). */
static void carrier_sum_places(int64_t F, const int64_t *carrier, const int64_t *csrc, int n_groups,
                               const int *gstart, const int *gmember, int (*spos)[2])
{
    for (int64_t f = 0; f < F; ++f) spos[f][0] = spos[f][1] = -1;
    if (csrc == NULL) return;
    for (int q = 0; q < n_groups; ++q) {
        const int nf = gstart[q + 1] - gstart[q], *mem = gmember + gstart[q];
        for (int k = 0; k < nf; ++k) {
            const int64_t f = mem[k];
            int a = -1, b = -1;
            if (!carrier[f] || csrc[2 * f] < 0) continue;
            for (int i = 0; i < nf; ++i) {
                if (mem[i] == csrc[2 * f]) a = i;
                if (mem[i] == csrc[2 * f + 1]) b = i;
            }
            if (a >= 0 && b >= 0) spos[f][0] = a, spos[f][1] = b;
        }
    }
}

#define LINES_MAX_C 64

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
#define HAVE_LINES8 HAVE_FMA_PATH
#else
#define HAVE_LINES8 0
#endif

/* 1 if lines_segment_f32 takes the fast path (groups, carrier sums) for C channels on this CPU now. */
static int lines_fast_path(int64_t C)
{
    return (C == 8 || C == 4) && isa_cap >= 1 && HAVE_LINES8 && HAVE_GROUP8;
}

/* need[i] = 1 for the slip rows 0 .. K-1 that lines_segment_f32 reads for these families: every family's phase row,
 * and the carrier rows of the carriers it computes from their own phase (on the fast path not those of the carrier
 * sums), so that a render computes no row for nothing (synth_slip_warp: ~1 of a 10-s ball run's ~5 % per row set). */
static void lines_rows_needed(int64_t F, int64_t C, const uint64_t *phases, const int64_t *lg, const int64_t *carrier,
                              const int64_t *csrc, const int64_t *wp, const int64_t *wq, int64_t K, char *need)
{
    int gstart[65], gmember[64], spos[64][2];
    const int fast = lines_fast_path(C);
    const int n_groups = fast ? lines_groups(F, phases, lg, wp, gstart, gmember) : 0;
    carrier_sum_places(F, carrier, csrc, n_groups, gstart, gmember, spos);
    for (int64_t i = 0; i < K; ++i) need[i] = 0;
    for (int64_t f = 0; f < F; ++f) {
        if (wp[f] >= 0) need[wp[f]] = 1;
        if (carrier[f] && wq[f] >= 0 && spos[f][0] < 0) need[wq[f]] = 1;
    }
}

static CLONES int lines_segment_f32(int64_t m, int64_t C, int64_t F, const uint64_t *phases, const int64_t *lg,
                                    const int64_t *carrier, const int64_t *csrc, const int64_t *off_t, const float *ta,
                                    const float *tb, const int64_t *warp, const int64_t *wp, const int64_t *wq,
                                    const float *dc, double xi0, double blend_scale, float *out, double *acc,
                                    const double *off, const NoiseArgs *na)
{
    int32_t idx[BLOCK], frac[BLOCK];
    float W0[BLOCK], W1[BLOCK], W2[BLOCK], W3[BLOCK], sw[BLOCK], CQ[BLOCK], SQ[BLOCK];
    float blk[BLOCK * LINES_MAX_C], flr[BLOCK * LINES_MAX_C];
    uint64_t st[64][4];                                  /* per family: phase, increment of family and carrier */
    if (F > 64 || C > LINES_MAX_C || C < 1) return -1;
    for (int64_t f = 0; f < F; ++f) {
        st[f][0] = phases[6 * f], st[f][1] = phases[6 * f + 1];
        st[f][2] = phases[6 * f + 3], st[f][3] = phases[6 * f + 4];
        if (lg[f] < 6 || lg[f] > 16) return -1;
    }
    const int noise = na != NULL;
    const int fast = lines_fast_path(C);
    int gstart[65], gmember[64];
    const int n_groups = fast ? lines_groups(F, phases, lg, wp, gstart, gmember) : 0;
    int spos[64][2];                        /* a summed carrier's sources: their places in its group, else -1 */
    carrier_sum_places(F, carrier, csrc, n_groups, gstart, gmember, spos);
    for (int64_t k0 = 0, nbl; k0 < m; k0 += nbl) {
        nbl = block_length(noise, m - k0, noise ? na->n0 + k0 : 0);
        const int nb = (int)nbl;
        /* a constant row length vectorises; a variable one was compiled as a `rep movsq` of C floats per sample,
         * ~85 % of this function's time at C = 4 (perf annotate: ~3 of ~23 ms a 10-s data-set run) */
        if (C == 8)
            for (int j = 0; j < nb; ++j)
                for (int c = 0; c < 8; ++c) blk[8 * j + c] = dc[c];
        else if (C == 4)
            for (int j = 0; j < nb; ++j)
                for (int c = 0; c < 4; ++c) blk[4 * j + c] = dc[c];
        else
            for (int j = 0; j < nb; ++j)
                for (int c = 0; c < C; ++c) blk[(int64_t)j * C + c] = dc[c];
        const int blend = tb != NULL;
        for (int q = 0; q < n_groups; ++q) {                       /* the fast path: groups of one phase */
            const int nf = gstart[q + 1] - gstart[q], *mem = gmember + gstart[q];
            const int64_t f0 = mem[0];
            float CQg[GROUP_MAX][BLOCK], SQg[GROUP_MAX][BLOCK];
            const float *A[GROUP_MAX], *Bt[GROUP_MAX];
            int64_t NTg[GROUP_MAX];
            int carg[GROUP_MAX], ready[GROUP_MAX], n_sum = 0;
            for (int k = 0; k < nf; ++k) {
                const int64_t f = mem[k];
                A[k] = ta + off_t[f], Bt[k] = blend ? tb + off_t[f] : NULL;
                NTg[k] = ((int64_t)1 << lg[f]) * C + 3 * C;
                carg[k] = (int)carrier[f];
                ready[k] = !carg[k];
                if (carg[k] && spos[f][0] >= 0) {
                    ++n_sum;
                    continue;
                }
                if (carg[k]) {
                    carrier8_avx2(nb, &st[f][2], &st[f][3], phases[6 * f + 5], wq[f] >= 0 ? warp + wq[f] * m + k0 : NULL,
                                  CQg[k], SQg[k]);
                    ready[k] = 1;
                }
            }
            for (int pass = 0; n_sum > 0; ++pass) {             /* carriers that are sums of two: in order */
                if (pass == nf) return -1;                      /* a cycle: the plan's check rules it out */
                for (int k = 0; k < nf; ++k) {
                    const int a = spos[mem[k]][0], b = spos[mem[k]][1];
                    if (ready[k] || !ready[a] || !ready[b]) continue;
                    carrier_sum(nb, CQg[a], SQg[a], CQg[b], SQg[b], CQg[k], SQg[k]);
                    ready[k] = 1, --n_sum;
                }
            }
            lines_group8_fma((int)C, nb, k0, &st[f0][0], &st[f0][1], phases[6 * f0 + 2],
                             wp[f0] >= 0 ? warp + wp[f0] * m + k0 : NULL, 62 - (int)lg[f0],
                             ((uint64_t)1 << lg[f0]) - 1, xi0, blend_scale, nf, A, blend ? Bt : NULL, NTg, carg, CQg,
                             SQg, blk);
            for (int k = 1; k < nf; ++k) st[mem[k]][0] = st[f0][0], st[mem[k]][1] = st[f0][1];
        }
        if (blend && !fast) {
            float *restrict swp = sw;
            for (int j = 0; j < nb; ++j) swp[j] = (float)blend_weight(((double)(k0 + j) + xi0) * blend_scale);
        }
        for (int64_t f = 0; f < (fast ? 0 : F); ++f) {          /* the generic path: one family at a time */
            const int fb = 62 - (int)lg[f];
            const uint64_t mask = ((uint64_t)1 << lg[f]) - 1;
            const int64_t *w = wp[f] >= 0 ? warp + wp[f] * m + k0 : NULL;
            const int car = (int)carrier[f];
            {
                if (w) phase_block(1, nb, &st[f][0], &st[f][1], phases[6 * f + 2], w, fb, mask, idx, frac);
                else phase_block(0, nb, &st[f][0], &st[f][1], phases[6 * f + 2], NULL, fb, mask, idx, frac);
                WEIGHT_BLOCK(float)
            }
            if (car) {
                uint64_t u = st[f][2], d = st[f][3];
                const uint64_t dd = phases[6 * f + 5];
                const int64_t *wc = wq[f] >= 0 ? warp + wq[f] * m + k0 : NULL;
                for (int j = 0; j < nb; ++j) {
                    carrier_cos_sin(u + (wc ? (uint64_t)wc[j] : 0), CQ + j, SQ + j);
                    u += d, d += dd;
                }
                st[f][2] = u, st[f][3] = d;
            }
            const int64_t NT = ((int64_t)1 << lg[f]) * C + 3 * C;        /* floats of one table */
            const float *A = ta + off_t[f], *B = blend ? tb + off_t[f] : NULL;
            if (C == 8) LINES_ROWS(8);
            else LINES_ROWS(C);
        }
        if (noise) {
            const float *extra = na->extra != NULL ? (const float *)na->extra + k0 * C : NULL;
            if (na->frames != NULL) {                     /* the floor of this block, rendered while in L1 */
                floor_block_f32(nbl, C, na->n0 + k0, na->half, na->frame_length, na->frames, na->floor_scale, na->win,
                                na->n_grains, na->grains, flr);
                extra = flr;
            }
            noise_add_block_f32((int)C, nb, na, na->n0 + k0, blk, extra);
        }
        memcpy(out + k0 * C, blk, sizeof(float) * (size_t)(nb * C));
        if (acc != NULL) moments_f32((int)C, nb, out + k0 * C, off, acc);
    }
    return 0;
}

/* The segment kernel's entry point (py_lines_render, and ctypes: synth_kernel.lines_segment); csrc (F x 2) the
 * carrier sums of synth_lines._carrier_sums, or NULL: every carrier from its own phase. */
int synth_lines_segment_f32(int64_t m, int64_t C, int64_t F, const uint64_t *phases, const int64_t *lg,
                            const int64_t *carrier, const int64_t *csrc, const int64_t *off_t, const float *ta,
                            const float *tb, const int64_t *warp, const int64_t *wp, const int64_t *wq,
                            const float *dc, double xi0, double blend_scale, float *out, double *acc,
                            const double *off, uint64_t noise_key, int64_t noise_n0, const float *sigma,
                            const float *extra, const int16_t *frames, const float *win, int64_t n_grains,
                            const int64_t *grains, int64_t half, int64_t frame_length, const float *floor_scale)
{
    if (m < 0 || (acc != NULL && off == NULL) || F < 0 || F > 64) return -1;
    for (int64_t f = 0; f < F; ++f)                      /* a slip row needs the offsets (else: out of bounds) */
        if (warp == NULL && (wp[f] >= 0 || wq[f] >= 0)) return -1;
    if (frames != NULL && (extra != NULL || win == NULL || grains == NULL || floor_scale == NULL || n_grains < 0
                           || half < 1 || frame_length < 2 * half)) return -1;
    NoiseArgs na = {noise_key, noise_n0, sigma, NULL, extra, frames, win, grains, n_grains, half, frame_length,
                    floor_scale};
    return lines_segment_f32(m, C, F, phases, lg, carrier, csrc, off_t, ta, tb, warp, wp, wq, dc, xi0, blend_scale,
                             out, acc, off, sigma != NULL || extra != NULL || frames != NULL ? &na : NULL);
}

#endif
