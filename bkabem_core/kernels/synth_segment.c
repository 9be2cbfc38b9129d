/*
 * The per-family sample loop (synth_segment.h): m samples of C channels from the periodic spline table of one
 * family at an integer phase that advances with a constant second difference (a linear speed ramp), optionally
 * blended in time towards a second table (the next knot), with the sensor noise, an extra block and the running
 * moments of the chunk features fused. Written once, as a macro, for T = float and T = double. The row function
 * takes the channel count and the options (warp, blend, features) as arguments that are compile-time constants at
 * every call site of the dispatcher, so the compiler emits one branch-free loop per combination with the channel
 * loop unrolled for C = 8 and C = 4. Built with -ffp-contract=off: bit for bit the numpy reference.
 */
#include "synth_segment.h"

#include <math.h>
#include <string.h>

#include "synth_block.h"
#include "synth_common.h"

#define BLEND_BLOCK(T, STORE4)                                                                                      \
    do {                                                                                                            \
        int j = 0;                                                                                                  \
        const v4d lanes = {0.0, 1.0, 2.0, 3.0}, top = {BLEND_LEVELS, BLEND_LEVELS, BLEND_LEVELS, BLEND_LEVELS};     \
        for (; j + 4 <= nb; j += 4) {                                                                               \
            v4d xi = (lanes + (double)(k0 + j)) + xi0;                                                              \
            v4d v = xi * blend_scale;                                                                               \
            v = (v4d)((v > 0.0) & (v4l)v);                     /* NaN and v <= 0: +0 */                             \
            v4l lt = v < top;                                                                                       \
            v = (v4d)((lt & (v4l)v) | (~lt & (v4l)top));                                                            \
            const v4i lv = __builtin_convertvector(v, v4i);                                                         \
            STORE4(sw + j, lv);                                                                                     \
        }                                                                                                           \
        for (; j < nb; ++j) sw[j] = (T)blend_weight(((double)(k0 + j) + xi0) * blend_scale);                        \
    } while (0)


/* Four blend levels (v4i, 0 .. 2^16) as weights level / 2^16 in T: exact either way, so converting the integers to
 * float directly gives the values of the double weights rounded to float (numpy's order) in half the operations. */
#define STORE4_f32(p, l) do { v4f t_ = __builtin_convertvector((l), v4f) * (float)(1.0 / BLEND_LEVELS); memcpy((p), &t_, sizeof t_); } while (0)
#define STORE4_f64(p, l) do { v4d t_ = __builtin_convertvector((l), v4d) * (1.0 / BLEND_LEVELS); memcpy((p), &t_, sizeof t_); } while (0)

/* Arguments a segment call can run with: m >= 0, C >= 1, N a power of 2 in 64 .. 2^16, fb = 62 - log2 N, the
 * table, out (if m > 0) and off (with acc) given. */
static int segment_args_ok(int64_t m, int64_t C, int64_t N, int fb, const void *ta, const void *out,
                           const double *acc, const double *off)
{
    if (m < 0 || C < 1 || C > INT32_MAX / 4 || N < 64 || N > 65536 || (N & (N - 1)) != 0
        || (acc != NULL && off == NULL) || ta == NULL || (m > 0 && out == NULL) || fb < 46 || fb > 56)
        return 0;
    return (INT64_C(1) << (62 - fb)) == N;
}


/* The kernels are written once, as a macro, for T = float and T = double. The row function takes the channel
 * count and the options (warp, blend, features) as arguments that are compile-time constants at every call site of
 * the dispatcher, so the compiler emits one branch-free loop per combination with the channel loop unrolled for
 * C = 8 and C = 4. */
#define SYNTH_KERNELS(T, SUF)                                                                                       \
/* Segment loop (generic path), in blocks of BLOCK samples: phases, spline weights (and blend weights), then the  \
 * rows, then (option) the moments of the block while it is in L1. */                                              \
INLINE void segment_rows_##SUF(const int C, const int has_warp, const int blend, const int feats, int64_t m,        \
                               int64_t N, int fb, uint64_t u, uint64_t d, uint64_t dd,                             \
                               const int64_t *restrict warp, const T *restrict ta, const T *restrict tb,           \
                               double xi0, double blend_scale, T *restrict out, double *restrict acc,              \
                               const double *restrict off, const NoiseArgs *na)                                    \
{                                                                                                                   \
    int32_t idx[BLOCK], frac[BLOCK];                                                                                \
    T W0[BLOCK], W1[BLOCK], W2[BLOCK], W3[BLOCK], sw[BLOCK];                                                        \
    const uint64_t mask = (uint64_t)N - 1;                                                                          \
    const int64_t C2 = 2 * (int64_t)C, C3 = 3 * (int64_t)C;                                                         \
    const int noise = na != NULL;                                                                                   \
    for (int64_t k0 = 0, nbl; k0 < m; k0 += nbl) {                                                                  \
        nbl = block_length(noise, m - k0, noise ? na->n0 + k0 : 0);                                                 \
        const int nb = (int)nbl;                                                                                    \
        phase_block(has_warp, nb, &u, &d, dd, has_warp ? warp + k0 : NULL, fb, mask, idx, frac);                    \
        WEIGHT_BLOCK(T)                                                                                             \
        if (blend) BLEND_BLOCK(T, STORE4_##SUF);                                                                    \
        T *restrict ob = out + k0 * C;                                                                              \
        for (int j = 0; j < nb; ++j) {                                                                              \
            const T *restrict a = ta + (int64_t)idx[j] * C;                                                         \
            const T w0 = W0[j], w1 = W1[j], w2 = W2[j], w3 = W3[j];                                                 \
            T *restrict o = ob + (int64_t)j * C;                                                                    \
            if (!blend) {                                                                                           \
                for (int c = 0; c < C; ++c) {                                                                       \
                    T v = w0 * a[c], p;                                                                             \
                    p = w1 * a[C + c], v = v + p;                                                                   \
                    p = w2 * a[C2 + c], v = v + p;                                                                  \
                    p = w3 * a[C3 + c], v = v + p;                                                                  \
                    o[c] = v;                                                                                       \
                }                                                                                                   \
            } else {                                                                                                \
                const T *restrict b = tb + (int64_t)idx[j] * C;                                                     \
                const T s = sw[j];                                                                                  \
                for (int c = 0; c < C; ++c) {                                                                       \
                    T va = w0 * a[c], vb = w0 * b[c], p;                                                            \
                    p = w1 * a[C + c], va = va + p;                                                                 \
                    p = w2 * a[C2 + c], va = va + p;                                                                \
                    p = w3 * a[C3 + c], va = va + p;                                                                \
                    p = w1 * b[C + c], vb = vb + p;                                                                 \
                    p = w2 * b[C2 + c], vb = vb + p;                                                                \
                    p = w3 * b[C3 + c], vb = vb + p;                                                                \
                    T dv = vb - va;                                                                                 \
                    dv = dv * s;                                                                                    \
                    o[c] = va + dv;                                                                                 \
                }                                                                                                   \
            }                                                                                                       \
        }                                                                                                           \
        if (noise) noise_add_block_##SUF(C, nb, na, na->n0 + k0, ob,                                               \
                                         na->extra != NULL ? (const T *)na->extra + k0 * C : NULL);                \
        if (feats) moments_##SUF(C, nb, ob, off, acc);                                                              \
    }                                                                                                               \
}                                                                                                                   \
                                                                                                                    \
INLINE void segment_opts_##SUF(const int C, int64_t m, int64_t N, int fb, uint64_t u, uint64_t d, uint64_t dd,      \
                               const int64_t *warp, const T *ta, const T *tb, double xi0, double blend_scale,       \
                               T *out, double *acc, const double *off, const NoiseArgs *na)                         \
{                                                                                                                   \
    const int w = warp != NULL, b = tb != NULL, f = acc != NULL;                                                    \
    if (w && b && f) ROWS(SUF, 1, 1, 1);                                                                            \
    else if (w && b) ROWS(SUF, 1, 1, 0);                                                                            \
    else if (w && f) ROWS(SUF, 1, 0, 1);                                                                            \
    else if (w) ROWS(SUF, 1, 0, 0);                                                                                 \
    else if (b && f) ROWS(SUF, 0, 1, 1);                                                                            \
    else if (b) ROWS(SUF, 0, 1, 0);                                                                                 \
    else if (f) ROWS(SUF, 0, 0, 1);                                                                                 \
    else ROWS(SUF, 0, 0, 0);                                                                                        \
}                                                                                                                   \
                                                                                                                    \
/* m samples x C channels of one call into out (bit for bit the numpy reference,                                    \
 * bkabem_core/synth/kernel.py segment_reference). warp (m values), tb (table of knot b; NULL: no blend) and acc/off (fused feature accumulation) are      \
 * optional. Returns 0, or -1 if the arguments are unusable (segment_args_ok). */                                   \
CLONES int synth_segment_##SUF(int64_t m, int64_t C, int64_t N, int fb, uint64_t phase0, uint64_t dphase0,  \
                                       uint64_t ddphase, const int64_t *warp, const T *ta, const T *tb, double xi0, \
                                       double blend_scale, T *out, double *acc, const double *off,                  \
                                       const NoiseArgs *na)                                                         \
{                                                                                                                   \
    if (!segment_args_ok(m, C, N, fb, ta, out, acc, off) || (na != NULL && C > NOISE_MAX_C)) return -1;            \
    if (C == 8)                                                                                                     \
        segment_opts_##SUF(8, m, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, out, acc, off,    \
                           na);                                                                                     \
    else if (C == 4)                                                                                                \
        segment_opts_##SUF(4, m, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, out, acc, off,    \
                           na);                                                                                     \
    else                                                                                                            \
        segment_opts_##SUF((int)C, m, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, out, acc,    \
                           off, na);                                                                                \
    return 0;                                                                                                       \
}                                                                                                                   \
                                                                                                                    \
/* Noise added to an existing n x C block x (samples from absolute index n0) and, with acc, the features of the     \
 * result accumulated, in one pass per block (the per-family loop's families are summed first). */          \
CLONES int synth_noise_add_##SUF(int64_t n, int64_t C, T *x, uint64_t key, int64_t n0, const T *sigma,            \
                                 const T *extra, const double *off, double *acc)                                    \
{                                                                                                                   \
    if (n < 0 || C < 1 || C > NOISE_MAX_C || (acc != NULL && off == NULL)) return -1;                              \
    NoiseArgs na = {key, n0, (const float *)(const void *)sigma, (const double *)(const void *)sigma, extra,\
                   NULL, NULL, NULL, 0, 0, 0, NULL};                                                        \
    for (int64_t k0 = 0, nb; k0 < n; k0 += nb) {                                                                    \
        nb = block_length(1, n - k0, n0 + k0);                                                                      \
        noise_add_block_##SUF((int)C, (int)nb, &na, n0 + k0, x + k0 * C, extra != NULL ? extra + k0 * C : NULL);   \
        if (acc != NULL) {                                                                                          \
            if (C == 8) moments_##SUF(8, (int)nb, x + k0 * C, off, acc);                                            \
            else moments_##SUF((int)C, (int)nb, x + k0 * C, off, acc);                                              \
        }                                                                                                           \
    }                                                                                                               \
    return 0;                                                                                                       \
}                                                                                                                   \
                                                                                                                    \
/* Feature accumulation (as the fused one of synth_segment) over an existing n x C block x. */                      \
CLONES int synth_accumulate_##SUF(int64_t n, int64_t C, const T *x, const double *off, double *acc)                 \
{                                                                                                                   \
    if (n < 0 || C < 1 || C > INT32_MAX / 4) return -1;                                                             \
    for (int64_t k0 = 0; k0 < n; k0 += BLOCK) {                                                                     \
        const int nb = n - k0 < BLOCK ? (int)(n - k0) : BLOCK;                                                      \
        if (C == 8) moments_##SUF(8, nb, x + k0 * C, off, acc);                                                     \
        else moments_##SUF((int)C, nb, x + k0 * C, off, acc);                                                       \
    }                                                                                                               \
    return 0;                                                                                                       \
}

#define ROWS(SUF, W, B, F) segment_rows_##SUF(C, W, B, F, m, N, fb, u, d, dd, warp, ta, tb, xi0, blend_scale, out, \
                                              acc, off, na)


SYNTH_KERNELS(float, f32)
SYNTH_KERNELS(double, f64)


/* Carrier mix of a line family with a carrier (the per-family loop, bkabem_core/synth/render.py): out[i][c] += cs[i][0] re[i][c] - cs[i][1] im[i][c],
 * i < m, c < C, row-major blocks; cs holds (cos, sin) of the carrier phase per sample. Two multiplies and two
 * adds per element, in this order (the numpy reference kernel.carrier_mix_reference does the same). */
#define CARRIER_MIX(T, SUF)                                                                                         \
int synth_carrier_mix_##SUF(int64_t m, int64_t C, const T *cs, const T *re, const T *im, T *out)                    \
{                                                                                                                   \
    if (m < 0 || C < 1) return -1;                                                                                  \
    for (int64_t i = 0; i < m; ++i) {                                                                               \
        const T c = cs[2 * i], s = cs[2 * i + 1];                                                                   \
        const T *a = re + i * C, *b = im + i * C;                                                                   \
        T *o = out + i * C;                                                                                         \
        for (int64_t k = 0; k < C; ++k) {                                                                           \
            const T x = c * a[k];                                                                                   \
            const T y = s * b[k];                                                                                   \
            o[k] = o[k] + (x - y);                                                                                  \
        }                                                                                                           \
    }                                                                                                               \
    return 0;                                                                                                       \
}
CARRIER_MIX(float, f32)
CARRIER_MIX(double, f64)

/* Chunk features from the accumulators of n samples per channel (acc C x 6 as above, about off[c]): out 6 x C

 * rows mean, rms, peak, peak_to_peak, crest_factor, kurtosis (features._moment_features in numpy, the reference):
 * raw moments s_p = sum / n; m2 = max(s2 - s1^2, 0); m4 = max(s4 - 4 s1 s3 + 6 s1^2 s2 - 3 s1^4, 0);
 * peak = max(hi - s1, s1 - lo); crest factor and kurtosis 0 where m2 = 0. */
int synth_features(int64_t C, int64_t n, const double *acc, const double *off, double *out)
{
    if (C < 1 || n < 1) return -1;
    for (int64_t c = 0; c < C; ++c) {
        const double *a = acc + 6 * c;
        double s1 = a[0] / (double)n, s2 = a[1] / (double)n, s3 = a[2] / (double)n, s4 = a[3] / (double)n;
        double m2 = s2 - s1 * s1;
        double m4 = s4 - 4 * s1 * s3 + 6 * s1 * s1 * s2 - 3 * (s1 * s1) * (s1 * s1);
        m2 = m2 > 0.0 ? m2 : 0.0;
        m4 = m4 > 0.0 ? m4 : 0.0;
        double rms = sqrt(m2), up = a[4] - s1, down = s1 - a[5];
        double peak = up > down ? up : down;
        out[0 * C + c] = s1 + off[c];
        out[1 * C + c] = rms;
        out[2 * C + c] = peak;
        out[3 * C + c] = a[4] - a[5];
        out[4 * C + c] = m2 > 0.0 ? peak / rms : 0.0;
        out[5 * C + c] = m2 > 0.0 ? m4 / (m2 * m2) : 0.0;
    }
    return 0;
}
