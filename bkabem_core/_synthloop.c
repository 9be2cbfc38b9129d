/*
 * Sample loop of the waveform synthesiser (bkabem_core/synth.py) and the running moments of the chunk features.
 *
 * Why C: a streaming chunk is 8 channels x 5120 samples every 0.1 s; numpy needs ~25 passes over (m, C)
 * temporaries for it (~2 ms), this loop one pass in blocks that stay in L1. Loaded with ctypes
 * (bkabem_core/synth_kernel.py, which also holds the numpy reference); the module init at the bottom only exists
 * so that setuptools builds and installs it as an ordinary extension module.
 *
 * Phase: fixed-point uint64 with wrap-around arithmetic, one ball pass = 2^62 units, one table step = 2^fb units
 * (fb = 62 - log2 N). Integer phases make the per-sample phase two integer adds (it was a chain of ~8 dependent
 * double operations) and make a call's samples independent of where the caller splits it (chunk invariance).
 * For sample j = 0 .. m-1 of a call (all uint64 arithmetic modulo 2^64):
 *   U_0 = phase0, D_0 = dphase0;  U_{j+1} = U_j + D_j,  D_{j+1} = D_j + ddphase
 *   V_j = U_j [+ (uint64) warp[j]];  i = (V_j >> fb) & (N - 1);  q = (V_j >> (fb - 12)) & 4095
 * Interpolation: cubic uniform B-spline of a coefficient table with wrap padding, (N + 3) x C, row n holding
 * coefficient (n - 1) mod N, weights w[q][0..3] from the caller's (4096, 4) table (in T):
 *   va[c] = ((w0 A[i][c] + w1 A[i+1][c]) + w2 A[i+2][c]) + w3 A[i+3][c]     in T, every operation rounded in T
 * Time blend (table b given): vb likewise from B; xi = j + xi0 (double);
 *   s = (T) (clip((int64) (xi * blend_scale), 0, 2^16) / 2^16);  out = va + (vb - va) * s      (in T)
 * else out = va.
 *
 * Bit-for-bit contract with the numpy reference: build with -ffp-contract=off and without -ffast-math, so that no
 * multiply-add is fused and nothing is reassociated (x86-64 / AArch64: float arithmetic is done in float).
 *
 * Layout (all C-contiguous): tables ta, tb (N + 3) x C; out m x C (row stride C); warp m int64 (optional);
 * feature accumulators acc C x 6 doubles per channel [sum d, sum d^2, sum d^3, sum d^4, max d, min d] of
 * d = (double) out - off[c], updated in place (the caller starts them at 0, 0, 0, 0, -inf, +inf).
 *
 * Speed: GCC on x86-64 builds an AVX2 clone besides the baseline (target_clones, dispatched at load time); the
 * 8-channel float32 rows are then one 256-bit vector. The loops are plain C that the vectoriser maps to the
 * target's vectors. Moments: 8 float32 channels with AVX2 are summed in float per block and shifted into the double
 * accumulators (moments8_f32_avx2); otherwise 4-lane double vectors with AVX2, 2-lane ones without (per block).
 * Samples are bit for bit those of the numpy reference; the float block sums agree with it to ~1e-6.
 */
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define WBITS 12                            /* spline weight index: 12 bits of the fraction of a table step */
#define WMASK ((UINT64_C(1) << WBITS) - 1)
#define BLEND_LEVELS 65536                  /* time-blend weight quantised to 2^-16 */
#define BLOCK 256                           /* samples per block (phases, rows, moments) */

#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#define NOINLINE __attribute__((noinline))
#else
#define INLINE static inline
#define NOINLINE
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
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
typedef double v2f64 __attribute__((vector_size(16)));
typedef double v4f64 __attribute__((vector_size(32)));

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

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
#define HAVE_AVX2 __builtin_cpu_supports("avx2")
#define MOMENTS_AVX2(T, SUF)                                                                                        \
    MOMENTS_GROUP(T, SUF, quad, 4, v4d, v4l, v4##SUF, static inline __attribute__((always_inline, target("avx2")))) \
    static NOINLINE __attribute__((target("avx2"))) void moments_avx2_##SUF(                                        \
        const int C, int nb, const T *restrict x, const double *restrict off, double *restrict acc)                \
    {                                                                                                               \
        int c = 0;                                                                                                  \
        for (; c + 4 <= C; c += 4) moments_quad_##SUF(C, c, nb, x, off, acc);                                       \
        for (; c + 2 <= C; c += 2) moments_pair_##SUF(C, c, nb, x, off, acc);                                       \
        for (; c < C; ++c) moments_one_##SUF(C, c, nb, x, off, acc);                                                \
    }
#else
#define HAVE_AVX2 0
#define MOMENTS_AVX2(T, SUF) static void moments_avx2_##SUF(const int C, int nb, const T *restrict x,                 \
                                                            const double *restrict off, double *restrict acc)        \
    { moments_base_##SUF(C, nb, x, off, acc); }
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
/* The common case, 8 float32 channels with AVX2, in one 8-lane float vector per moment: a block's sums (<= BLOCK
 * samples of d = x - (float) off) are taken in float and added to the double accumulators once per block, shifted
 * by e = (float) off - off exactly (binomial expansion in double): relative round-off ~1e-6 of a sum; the double
 * 4-lane path above costs ~2x the whole sample loop. Extremes are those of x itself, so max/min of d are exact:
 * (double) max x - off. */
typedef float v8f __attribute__((vector_size(32)));
typedef int32_t v8i __attribute__((vector_size(32)));
static NOINLINE __attribute__((target("avx2"))) void moments8_f32_avx2(int nb, const float *restrict x,
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
        hi = VSEL_MAX(v8i, v, hi);
        lo = VSEL_MIN(v8i, v, lo);
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
#define HAVE_MOMENTS8_F32 __builtin_cpu_supports("avx2")
#else
#define HAVE_MOMENTS8_F32 0
static void moments8_f32_avx2(int nb, const float *x, const double *off, double *acc) { (void)nb, (void)x, (void)off, (void)acc; }
#endif

/* Phases of samples j = 0 .. nb-1 of a block, from the phase u and increment d of sample 0 (advanced to sample nb on
 * return): tq[j] = V_j >> (fb - 12), from which the row loop takes i = (t >> 12) & mask and q = t & 4095 (one load
 * per sample instead of two: the row loop is bound by its loads). Four samples per step in 64-bit lanes: U_{j+4} = U_j + 4 D_j + 6 dd, D_{j+4} = D_j + 4 dd,
 * which is the scalar recurrence exactly (modulo 2^64). */
INLINE void phase_block(const int has_warp, int nb, uint64_t *pu, uint64_t *pd, uint64_t dd,
                        const int64_t *restrict warp, int fb, uint64_t *restrict tq)
{
    const int sh = fb - WBITS;
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
            v4u t = v >> sh;
            memcpy(tq + j, &t, sizeof t);
            U += (D << 2) + dd6;
            D += dd4;
        }
        u = U[0], d = D[0];
    }
    for (; j < nb; ++j) {
        uint64_t v = u;
        if (has_warp) v += (uint64_t)warp[j];
        tq[j] = v >> sh;
        u += d;
        d += dd;
    }
    *pu = u;
    *pd = d;
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
            v4d w = __builtin_convertvector(__builtin_convertvector(v, v4i), v4d) * (1.0 / BLEND_LEVELS);           \
            STORE4(sw + j, w);                                                                                      \
        }                                                                                                           \
        for (; j < nb; ++j) sw[j] = (T)blend_weight(((double)(k0 + j) + xi0) * blend_scale);                        \
    } while (0)

/* W consecutive values of x (T) as a W-lane double vector d; VT the W-lane vector of T. */
#define LOADV_f32(d, VT, p) do { VT t_; memcpy(&t_, (p), sizeof t_); (d) = __builtin_convertvector(t_, __typeof__(d)); } while (0)
#define LOADV_f64(d, VT, p) memcpy(&(d), (p), sizeof(d))
#define STORE4_f32(p, w) do { v4f t_ = __builtin_convertvector((w), v4f); memcpy((p), &t_, sizeof t_); } while (0)
#define STORE4_f64(p, w) memcpy((p), &(w), sizeof(w))

/* The kernels are written once, as a macro, for T = float and T = double. The row function takes the channel
 * count and the options (warp, blend, features) as arguments that are compile-time constants at every call site of
 * the dispatcher, so the compiler emits one branch-free loop per combination with the channel loop unrolled for
 * C = 8 and C = 4. */
#define SYNTH_KERNELS(T, SUF)                                                                                       \
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
/* Moments of a block: channel groups of 4 in 256-bit vectors where AVX2 is there, else of 2 (4-lane vectors in the \
 * SSE2 build spill: ~4x slower), then single channels. Not inlined: called once per block, dispatched on the CPU.  \
 * Written for C = 8 and any C. */                                                                                  \
MOMENTS_GROUP(T, SUF, pair, 2, v2d, v2l, v2##SUF, INLINE)                                                           \
static NOINLINE void moments_base_##SUF(const int C, int nb, const T *restrict x, const double *restrict off,       \
                                        double *restrict acc)                                                       \
{                                                                                                                   \
    int c = 0;                                                                                                      \
    for (; c + 2 <= C; c += 2) moments_pair_##SUF(C, c, nb, x, off, acc);                                           \
    for (; c < C; ++c) moments_one_##SUF(C, c, nb, x, off, acc);                                                    \
}                                                                                                                   \
MOMENTS_AVX2(T, SUF)                                                                                                \
INLINE void moments_##SUF(const int C, int nb, const T *restrict x, const double *restrict off,                     \
                          double *restrict acc)                                                                     \
{                                                                                                                   \
    if (sizeof(T) == 4 && C == 8 && nb > 0 && HAVE_MOMENTS8_F32)                                                   \
        moments8_f32_avx2(nb, (const float *)(const void *)x, off, acc);                                            \
    else if (HAVE_AVX2) moments_avx2_##SUF(C, nb, x, off, acc);                                                     \
    else moments_base_##SUF(C, nb, x, off, acc);                                                                    \
}                                                                                                                   \
                                                                                                                    \
/* Segment loop, in blocks of BLOCK samples: phases (and blend weights), then the rows, then (option) the moments   \
 * of the block while it is in L1. */                                                                               \
INLINE void segment_rows_##SUF(const int C, const int has_warp, const int blend, const int feats, int64_t m,        \
                               int64_t N, int fb, uint64_t u, uint64_t d, uint64_t dd,                             \
                               const int64_t *restrict warp, const T *restrict ta, const T *restrict tb,           \
                               double xi0, double blend_scale, const T *restrict wtab, T *restrict out,            \
                               double *restrict acc, const double *restrict off)                                   \
{                                                                                                                   \
    uint64_t tq[BLOCK];                                                                                             \
    T sw[BLOCK];                                                                                                    \
    const uint64_t mask = (uint64_t)N - 1;                                                                          \
    const int64_t C2 = 2 * (int64_t)C, C3 = 3 * (int64_t)C;                                                         \
    for (int64_t k0 = 0; k0 < m; k0 += BLOCK) {                                                                     \
        const int nb = m - k0 < BLOCK ? (int)(m - k0) : BLOCK;                                                      \
        phase_block(has_warp, nb, &u, &d, dd, has_warp ? warp + k0 : NULL, fb, tq);                                 \
        if (blend) BLEND_BLOCK(T, STORE4_##SUF);                                                                    \
        T *restrict ob = out + k0 * C;                                                                              \
        for (int j = 0; j < nb; ++j) {                                                                              \
            const uint64_t t = tq[j];                                                                               \
            const int64_t r = (int64_t)((t >> WBITS) & mask) * C;                                                   \
            const T *restrict a = ta + r;                                                                           \
            const T *restrict wt = wtab + ((t & WMASK) << 2);                                                       \
            const T w0 = wt[0], w1 = wt[1], w2 = wt[2], w3 = wt[3];                                                 \
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
                const T *restrict b = tb + r;                                                                        \
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
        if (feats) moments_##SUF(C, nb, ob, off, acc);                                                              \
    }                                                                                                               \
}                                                                                                                   \
                                                                                                                    \
INLINE void segment_opts_##SUF(const int C, int64_t m, int64_t N, int fb, uint64_t u, uint64_t d, uint64_t dd,      \
                               const int64_t *warp, const T *ta, const T *tb, double xi0, double blend_scale,       \
                               const T *wtab, T *out, double *acc, const double *off)                               \
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
/* m samples x C channels of one call into out (see the header). warp (m values), tb (table of knot b; NULL: no     \
 * blend) and acc/off (fused feature accumulation) are optional. Returns 0, or -1 if the arguments are unusable     \
 * (m < 0, C < 1, N not a power of 2 in 64 .. 2^16, fb != 62 - log2 N, acc without off). */                          \
CLONES int synth_segment_##SUF(int64_t m, int64_t C, int64_t N, int fb, uint64_t phase0, uint64_t dphase0,          \
                               uint64_t ddphase, const int64_t *warp, const T *ta, const T *tb, double xi0,         \
                               double blend_scale, const T *wtab, T *out, double *acc, const double *off)           \
{                                                                                                                   \
    if (m < 0 || C < 1 || C > INT32_MAX / 4 || N < 64 || N > 65536 || (N & (N - 1)) != 0                            \
        || (acc != NULL && off == NULL) || ta == NULL || wtab == NULL || (m > 0 && out == NULL))                    \
        return -1;                                                                                                  \
    if ((INT64_C(1) << (62 - fb)) != N) return -1;                                                                  \
    if (C == 8)                                                                                                     \
        segment_opts_##SUF(8, m, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, wtab, out, acc,   \
                           off);                                                                                    \
    else if (C == 4)                                                                                                \
        segment_opts_##SUF(4, m, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, wtab, out, acc,   \
                           off);                                                                                    \
    else                                                                                                            \
        segment_opts_##SUF((int)C, m, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, wtab, out,   \
                           acc, off);                                                                               \
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

#define ROWS(SUF, W, B, F) segment_rows_##SUF(C, W, B, F, m, N, fb, u, d, dd, warp, ta, tb, xi0, blend_scale, wtab, \
                                              out, acc, off)


SYNTH_KERNELS(float, f32)
SYNTH_KERNELS(double, f64)

/* Chunk features from the accumulators of n samples per channel (acc C x 6 as above, about off[c]): out 6 x C
 * rows mean, rms, peak, peak_to_peak, crest_factor, kurtosis (synth._moment_features in numpy, the reference):
 * raw moments s_p = sum / n; m2 = max(s2 - s1^2, 0); m4 = max(s4 - 4 s1 s3 + 6 s1^2 s2 - 3 s1^4, 0);
 * peak = max(hi - s1, s1 - lo); crest factor and kurtosis 0 where m2 = 0. In C: one call instead of ~30 numpy
 * operations on 8-element arrays (~40 us of Python per chunk). */
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

/* ------------------------------------------------------------------------------------------ sensor noise
 * Standard normal numbers for the sensor noise, ~4x faster than numpy's generator here (which made noise the
 * largest cost of a noisy run). Stream: xoshiro256+ (Blackman & Vigna) seeded by splitmix64 from a 64-bit key (the
 * caller derives one key per block of samples from seed and block number, so values depend on the absolute sample
 * only). Normals: the ziggurat of Marsaglia & Tsang (2000) with 128 layers, in Doornik's (2005) form that takes the
 * layer index and the uniform from different bits of one 64-bit word (bits 0-6 and 11-63), avoiding the
 * correlation of the original; the tail beyond R = 3.442619855899 by Marsaglia's exponential method. */
#define ZIG_C 128
#define ZIG_R 3.442619855899
#define ZIG_V 9.91256303526217e-3

static double zig_x[ZIG_C + 1], zig_ratio[ZIG_C];
static int zig_ready = 0;

#if defined(__GNUC__)
__attribute__((constructor))           /* tables made when the library is loaded (no first-call race) */
#endif
static void zig_init(void)
{
    double f = exp(-0.5 * ZIG_R * ZIG_R);
    zig_x[0] = ZIG_V / f;              /* the base layer: a rectangle of area V plus the tail */
    zig_x[1] = ZIG_R;
    zig_x[ZIG_C] = 0.0;
    for (int i = 2; i < ZIG_C; ++i) {
        zig_x[i] = sqrt(-2.0 * log(ZIG_V / zig_x[i - 1] + f));
        f = exp(-0.5 * zig_x[i] * zig_x[i]);
    }
    for (int i = 0; i < ZIG_C; ++i) zig_ratio[i] = zig_x[i + 1] / zig_x[i];
    zig_ready = 1;
}

static inline uint64_t rotl64(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

static inline uint64_t xoshiro_next(uint64_t s[4])
{
    const uint64_t result = s[0] + s[3];
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl64(s[3], 45);
    return result;
}

static inline uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* (int64_t): a signed conversion is one instruction, an unsigned one a sequence (the value fits either way) */
static inline double uniform01(uint64_t s[4]) { return (double)(int64_t)(xoshiro_next(s) >> 11) * 0x1.0p-53; }

static inline double zig_normal(uint64_t s[4])
{
    for (;;) {
        const uint64_t b = xoshiro_next(s);
        const int i = (int)(b & (ZIG_C - 1));
        const double u = 2.0 * ((double)(int64_t)(b >> 11) * 0x1.0p-53) - 1.0;
        if (fabs(u) < zig_ratio[i]) return u * zig_x[i];                 /* inside the layer's rectangle */
        if (i == 0) {                                                      /* the tail beyond R */
            double x, y;
            do {
                x = log(1.0 - uniform01(s)) / ZIG_R;
                y = log(1.0 - uniform01(s));
            } while (-2.0 * y < x * x);
            return u < 0.0 ? x - ZIG_R : ZIG_R - x;
        }
        const double x = u * zig_x[i];                                     /* the wedge: accept under the curve */
        const double f0 = exp(-0.5 * (zig_x[i] * zig_x[i] - x * x));
        const double f1 = exp(-0.5 * (zig_x[i + 1] * zig_x[i + 1] - x * x));
        if (f1 + uniform01(s) * (f0 - f1) < 1.0) return x;
    }
}

/* n standard normal numbers of the stream ``key`` into out (float32 or float64). (Four interleaved streams were
 * tried for instruction-level parallelism: slower, the ziggurat's branches dominate.) */
#define NORMALS(T, SUF)                                                                                             \
int synth_normals_##SUF(uint64_t key, int64_t n, T *out)                                                            \
{                                                                                                                   \
    if (n < 0) return -1;                                                                                           \
    if (!zig_ready) zig_init();                                                                                     \
    uint64_t s[4], k = key;                                                                                         \
    for (int i = 0; i < 4; ++i) s[i] = splitmix64(&k);                                                              \
    for (int64_t j = 0; j < n; ++j) out[j] = (T)zig_normal(s);                                                      \
    return 0;                                                                                                       \
}
NORMALS(float, f32)
NORMALS(double, f64)

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_synthloop",
                                       "C kernel loaded with ctypes (see bkabem_core/synth_kernel.py)", -1, NULL};

PyMODINIT_FUNC PyInit__synthloop(void) { return PyModule_Create(&moduledef); }
