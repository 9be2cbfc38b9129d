/*
 * Sample loop of the waveform synthesiser (bkabem_core/synth.py, Synthesizer._segment) and the running moments
 * of the chunk features (waveform_features).
 *
 * Why C: a streaming chunk is 8 channels x 5120 samples every 0.1 s. numpy renders it in ~25 passes over
 * (m, C) temporaries (phase, table index, two gathers per table, blend), ~2 ms per chunk on the project machine,
 * almost all of it memory traffic; the same arithmetic done block by block with everything in L1 takes ~0.1 ms
 * (the chunk features, fused into the same pass, add ~0.1 ms; numpy's waveform_features takes ~0.25 ms).
 * Loaded with ctypes (bkabem_core/synth_kernel.py); the module init below only exists so that setuptools can
 * build and install it as an ordinary extension module.
 *
 * Bit-for-bit contract: every value is the result of the same IEEE operations, in the same order and precision,
 * as the numpy code of Synthesizer._segment (build with -ffp-contract=off and without -ffast-math, so that no
 * multiply-add is fused and nothing is reassociated; x86-64 / AArch64, where float arithmetic is done in float).
 * For output sample k of the segment (all in double unless said otherwise):
 *   xi = k + xi0                                      samples since knot a
 *   u  = ((xi * c2 + c1) * xi + u_frac [+ warp[k]] + 2^20) * (N * 2^12) + 0.5
 *   p  = (int64) u;  i = (p >> 12) & (N - 1);  f = (T) ((p & 4095) / 4096)
 *   va = ta[i] + (T) (ta[i+1] - ta[i]) * f            in T (float or double), i+1 wrapping to 0
 *   without table b: out = va
 *   with table b:    vb = tb[i] + (tb[i+1] - tb[i]) * f;  s = (T) (clip((int64) (xi * blend_scale), 0, 2^16) / 2^16)
 *                    out = va + (vb - va) * s
 * The slope ta[i+1] - ta[i] is recomputed here in T; numpy reads it from a precomputed table of the same values.
 *
 * Layout (all C-contiguous): tables ta, tb: N x C (N a power of 2), row i = phase i / N of one ball pass;
 * out: m x C (sample-major, row stride C); warp: m doubles (the slip warp, optional); feature accumulators
 * acc: C x 6 doubles, per channel [sum d, sum d^2, sum d^3, sum d^4, max d, min d] of d = (double) x - off[c],
 * updated in place (the caller starts them at 0, 0, 0, 0, -inf, +inf).
 */
#include <Python.h>
#include <stdint.h>

#define FRAC_BITS 12                        /* _FRAC_BITS: angle fraction inside a table step */
#define FRAC_MASK ((INT64_C(1) << FRAC_BITS) - 1)
#define FRAC_ONE 4096.0
#define BLEND_LEVELS 65536                  /* _BLEND_LEVELS: time-blend weight quantised to 2^-16 */
#define PHASE_OFFSET 1048576.0              /* _PHASE_OFFSET = 2^20 keeps table positions positive */
#define BLOCK 256                           /* samples per block (phases, rows, moments) */

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
#endif

/* 2-lane double vectors (GCC / Clang vector extensions; SSE2 on x86-64, NEON on AArch64) for the moments. */
typedef double v2d __attribute__((vector_size(16)));
typedef int64_t v2l __attribute__((vector_size(16)));
#if defined(__SSE2__)
#include <emmintrin.h>
INLINE v2d vmax(v2d a, v2d b) { return (v2d)_mm_max_pd((__m128d)a, (__m128d)b); }   /* a > b ? a : b */
INLINE v2d vmin(v2d a, v2d b) { return (v2d)_mm_min_pd((__m128d)a, (__m128d)b); }   /* a < b ? a : b */
#else
INLINE v2d vmax(v2d a, v2d b) { v2l m = a > b; return (v2d)((m & (v2l)a) | (~m & (v2l)b)); }
INLINE v2d vmin(v2d a, v2d b) { v2l m = a < b; return (v2d)((m & (v2l)a) | (~m & (v2l)b)); }
#endif

/* Blend weight index of numpy's `qs[...] = xi * blend_scale` (truncation toward zero) followed by
 * take(mode="clip") into [0, 2^16]; identical for every |v| < 2^63 (NaN gives 0, as numpy's INT64_MIN clipped). */
INLINE int64_t blend_index(double v)
{
    if (!(v > 0.0)) return 0;
    if (v >= (double)BLEND_LEVELS) return BLEND_LEVELS;
    return (int64_t)v;
}

/* The kernels are written once, as a macro, for T = float and T = double. The row function takes the channel
 * count and the three options (warp, blend, features) as arguments that are compile-time constants at every
 * call site of the dispatcher (ROWS: one instance with the options W, B, F fixed), so the compiler emits one
 * branch-free loop per combination and unrolls the channel loop for C = 8 and C = 4, the usual channel counts. */
#define ROWS(SUF, W, B, F) segment_rows_##SUF(C, W, B, F, m, N, xi0, c1, c2, u_frac, warp, ta, tb, blend_scale, \
                                              out, acc, off)

#define SYNTH_KERNELS(T, SUF)                                                                                       \
                                                                                                                    \
/* Table rows (offsets i C, (i + 1) C), interpolation fraction f and blend weight w of samples k0 .. k0 + nb - 1.   \
 * Kept apart from the row loop: its long chain of dependent double operations per sample then overlaps across      \
 * samples instead of holding up the table reads. */                                                                \
INLINE void phase_block_##SUF(const int C, const int has_warp, const int blend, int64_t k0, int nb, int64_t N,      \
                              double xi0, double c1, double c2, double u_frac, const double *restrict warp,         \
                              double blend_scale, int64_t *restrict r0, int64_t *restrict r1, T *restrict f,        \
                              T *restrict w)                                                                        \
{                                                                                                                   \
    const double nq = (double)(N << FRAC_BITS);                                                                     \
    const int64_t mask = N - 1;                                                                                     \
    for (int j = 0; j < nb; ++j) {                                                                                  \
        double xi = (double)(k0 + j) + xi0;                                                                         \
        double u = xi * c2;                                                                                         \
        u += c1;                                                                                                    \
        u *= xi;                                                                                                    \
        u += u_frac;                                                                                                \
        if (has_warp) u += warp[k0 + j];                                                                            \
        u += PHASE_OFFSET;                                                                                          \
        u *= nq;                                                                                                    \
        u += 0.5;                                                                                                   \
        int64_t p = (int64_t)u;            /* truncation = floor: u > 0 */                                          \
        int64_t i = (p >> FRAC_BITS) & mask;                                                                        \
        r0[j] = i * C;                                                                                              \
        r1[j] = ((i + 1) & mask) * C;                                                                               \
        f[j] = (T)((double)(p & FRAC_MASK) / FRAC_ONE);                                                             \
        if (blend) w[j] = (T)((double)blend_index(xi * blend_scale) / (double)BLEND_LEVELS);                        \
    }                                                                                                               \
}                                                                                                                   \
                                                                                                                    \
/* Running moments of rows x[0 .. nb - 1] (row stride C) of channels c0 .. c0 + 2 P - 1 into acc (C x 6), P pairs   \
 * of channels at a time in 2-lane vectors (the compiler does not vectorise loop-carried sums by itself: that would \
 * reorder them), so that the 6 P accumulators stay in registers over the rows. */                                  \
INLINE void moments_pairs_##SUF(const int C, const int P, int c0, int64_t nb, const T *restrict x,                  \
                                const double *restrict off, double *restrict acc)                                   \
{                                                                                                                   \
    v2d s1[2], s2[2], s3[2], s4[2], hi[2], lo[2], o[2];                                                             \
    for (int p = 0; p < P; ++p) {                                                                                   \
        const double *a = acc + 6 * (c0 + 2 * p), *b = a + 6;                                                       \
        s1[p] = (v2d){a[0], b[0]}, s2[p] = (v2d){a[1], b[1]}, s3[p] = (v2d){a[2], b[2]};                            \
        s4[p] = (v2d){a[3], b[3]}, hi[p] = (v2d){a[4], b[4]}, lo[p] = (v2d){a[5], b[5]};                            \
        o[p] = (v2d){off[c0 + 2 * p], off[c0 + 2 * p + 1]};                                                         \
    }                                                                                                               \
    for (int64_t k = 0; k < nb; ++k) {                                                                              \
        const T *xr = x + k * C + c0;                                                                               \
        for (int p = 0; p < P; ++p) {                                                                               \
            v2d d = (v2d){(double)xr[2 * p], (double)xr[2 * p + 1]} - o[p];                                         \
            v2d d2 = d * d;                                                                                         \
            s1[p] += d;                                                                                             \
            s2[p] += d2;                                                                                            \
            s3[p] += d2 * d;                                                                                        \
            s4[p] += d2 * d2;                                                                                       \
            hi[p] = vmax(d, hi[p]);                                                                                 \
            lo[p] = vmin(d, lo[p]);                                                                                 \
        }                                                                                                           \
    }                                                                                                               \
    for (int p = 0; p < P; ++p) {                                                                                   \
        double *a = acc + 6 * (c0 + 2 * p), *b = a + 6;                                                             \
        a[0] = s1[p][0], a[1] = s2[p][0], a[2] = s3[p][0], a[3] = s4[p][0], a[4] = hi[p][0], a[5] = lo[p][0];       \
        b[0] = s1[p][1], b[1] = s2[p][1], b[2] = s3[p][1], b[3] = s4[p][1], b[4] = hi[p][1], b[5] = lo[p][1];       \
    }                                                                                                               \
}                                                                                                                   \
                                                                                                                    \
/* The same for the single channel c (odd channel counts). */                                                       \
INLINE void moments_one_##SUF(const int C, int c, int64_t nb, const T *restrict x, const double *restrict off,      \
                              double *restrict acc)                                                                 \
{                                                                                                                   \
    double *a = acc + 6 * c;                                                                                        \
    double s1 = a[0], s2 = a[1], s3 = a[2], s4 = a[3], hi = a[4], lo = a[5];                                        \
    for (int64_t k = 0; k < nb; ++k) {                                                                              \
        double d = (double)x[k * C + c] - off[c];                                                                   \
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
INLINE void moments_##SUF(const int C, int64_t nb, const T *restrict x, const double *restrict off,                 \
                          double *restrict acc)                                                                     \
{                                                                                                                   \
    int c = 0;                                                                                                      \
    for (; c + 4 <= C; c += 4) moments_pairs_##SUF(C, 2, c, nb, x, off, acc);                                       \
    for (; c + 2 <= C; c += 2) moments_pairs_##SUF(C, 1, c, nb, x, off, acc);                                       \
    for (; c < C; ++c) moments_one_##SUF(C, c, nb, x, off, acc);                                                    \
}                                                                                                                   \
                                                                                                                    \
/* Segment loop, in blocks of BLOCK samples: phases, then the table rows, then (option) the moments of the block    \
 * while it is in L1. */                                                                                            \
INLINE void segment_rows_##SUF(const int C, const int has_warp, const int blend, const int feats,                   \
                               int64_t m, int64_t N, double xi0, double c1, double c2, double u_frac,               \
                               const double *restrict warp, const T *restrict ta, const T *restrict tb,             \
                               double blend_scale, T *restrict out, double *restrict acc,                           \
                               const double *restrict off)                                                          \
{                                                                                                                   \
    int64_t r0[BLOCK], r1[BLOCK];                                                                                   \
    T f[BLOCK], w[BLOCK];                                                                                           \
    for (int64_t k0 = 0; k0 < m; k0 += BLOCK) {                                                                     \
        const int nb = m - k0 < BLOCK ? (int)(m - k0) : BLOCK;                                                      \
        phase_block_##SUF(C, has_warp, blend, k0, nb, N, xi0, c1, c2, u_frac, warp, blend_scale, r0, r1, f, w);     \
        T *ob = out + k0 * C;                                                                                       \
        for (int j = 0; j < nb; ++j) {                                                                              \
            const T *a0 = ta + r0[j], *a1 = ta + r1[j];                                                             \
            const T fj = f[j];                                                                                      \
            T *o = ob + (int64_t)j * C;                                                                             \
            if (!blend) {                                                                                           \
                for (int c = 0; c < C; ++c) {                                                                       \
                    T sl = a1[c] - a0[c];                                                                           \
                    T bf = sl * fj;                                                                                 \
                    o[c] = a0[c] + bf;             /* numpy: B *= F; out = A + B */                                 \
                }                                                                                                   \
            } else {                                                                                                \
                const T *b0 = tb + r0[j], *b1 = tb + r1[j];                                                         \
                const T wj = w[j];                                                                                  \
                for (int c = 0; c < C; ++c) {                                                                       \
                    T sa = a1[c] - a0[c];                                                                           \
                    T sb = b1[c] - b0[c];                                                                           \
                    T fa = sa * fj;                                                                                 \
                    T va = a0[c] + fa;             /* numpy: B *= F; A += B */                                      \
                    T fb = sb * fj;                                                                                 \
                    T vb = b0[c] + fb;             /* D *= F; C += D */                                             \
                    T d = vb - va;                 /* C -= A */                                                     \
                    T dw = d * wj;                 /* C *= S */                                                     \
                    o[c] = va + dw;                /* out = A + C */                                                \
                }                                                                                                   \
            }                                                                                                       \
        }                                                                                                           \
        if (feats) moments_##SUF(C, nb, ob, off, acc);                                                              \
    }                                                                                                               \
}                                                                                                                   \
                                                                                                                    \
INLINE void segment_opts_##SUF(const int C, int64_t m, int64_t N, double xi0, double c1, double c2,                 \
                               double u_frac, const double *warp, const T *ta, const T *tb, double blend_scale,     \
                               T *out, double *acc, const double *off)                                              \
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
/* Samples [lo, hi) of one segment (m = hi - lo rows of C channels) into out; xi0 = lo - a.x. warp (m values),      \
 * tb (table of knot b; NULL: no blend) and acc/off (fused feature accumulation) are optional. Returns 0, or -1     \
 * if the arguments are unusable (C < 1, N not a power of 2, m < 0, acc without off). */                            \
int synth_segment_##SUF(int64_t m, int64_t C, int64_t N, double xi0, double c1, double c2, double u_frac,           \
                        const double *warp, const T *ta, const T *tb, double blend_scale, T *out, double *acc,      \
                        const double *off)                                                                          \
{                                                                                                                   \
    if (m < 0 || C < 1 || C > INT32_MAX || N < 1 || (N & (N - 1)) != 0 || (acc != NULL && off == NULL))             \
        return -1;                                                                                                  \
    if (C == 8)                                                                                                     \
        segment_opts_##SUF(8, m, N, xi0, c1, c2, u_frac, warp, ta, tb, blend_scale, out, acc, off);                 \
    else if (C == 4)                                                                                                \
        segment_opts_##SUF(4, m, N, xi0, c1, c2, u_frac, warp, ta, tb, blend_scale, out, acc, off);                 \
    else                                                                                                            \
        segment_opts_##SUF((int)C, m, N, xi0, c1, c2, u_frac, warp, ta, tb, blend_scale, out, acc, off);            \
    return 0;                                                                                                       \
}                                                                                                                   \
                                                                                                                    \
/* Feature accumulation (as the fused one of synth_segment) over an existing n x C block x. */                      \
int synth_accumulate_##SUF(int64_t n, int64_t C, const T *x, const double *off, double *acc)                        \
{                                                                                                                   \
    if (n < 0 || C < 1 || C > INT32_MAX) return -1;                                                                 \
    for (int64_t k0 = 0; k0 < n; k0 += BLOCK) {                                                                     \
        const int64_t nb = n - k0 < BLOCK ? n - k0 : BLOCK;                                                         \
        if (C == 8) moments_##SUF(8, nb, x + k0 * C, off, acc);                                                     \
        else moments_##SUF((int)C, nb, x + k0 * C, off, acc);                                                       \
    }                                                                                                               \
    return 0;                                                                                                       \
}

SYNTH_KERNELS(float, f32)
SYNTH_KERNELS(double, f64)

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_synthloop",
                                       "C kernel loaded with ctypes (see bkabem_core/synth_kernel.py)", -1, NULL};

PyMODINIT_FUNC PyInit__synthloop(void) { return PyModule_Create(&moduledef); }
