/*
 * Sample loop of the waveform synthesiser (bkabem_core/synth/synthesizer.py), the running moments of the chunk features, the
 * knot table (spline coefficients of a knot from the modal sum's amplitudes) and the sensor noise.
 *
 * Why C: a streaming chunk is 8 channels x 5120 samples every 0.1 s; numpy needs ~25 passes over (m, C)
 * temporaries for it (~2 ms), this loop one pass in blocks that stay in L1. Used from bkabem_core/synth/kernel.py
 * (which also holds the numpy references): segment and knot_table are Python functions of this extension module
 * (the entry points at the bottom, cheap to call), the others are loaded with ctypes.
 *
 * Phase: fixed-point uint64 with wrap-around arithmetic, one ball pass = 2^62 units, one table step = 2^fb units
 * (fb = 62 - log2 N). Integer phases make the per-sample phase two integer adds (it was a chain of ~8 dependent
 * double operations) and make a call's samples independent of where the caller splits it (chunk invariance).
 * For sample j = 0 .. m-1 of a call (all uint64 arithmetic modulo 2^64):
 *   U_0 = phase0, D_0 = dphase0;  U_{j+1} = U_j + D_j,  D_{j+1} = D_j + ddphase
 *   V_j = U_j [+ (uint64) warp[j]];  i = (V_j >> fb) & (N - 1);  q = (V_j >> (fb - 24)) & (2^24 - 1)
 * Interpolation: cubic uniform B-spline of a coefficient table with wrap padding, (N + 3) x C, row n holding
 * coefficient (n - 1) mod N, weights computed from the fraction t = (T) q * 2^-24 (exact in float) of the table step
 * by one fixed sequence of operations in T, every one rounded in T (weight_block; numpy repeats it in
 * synth_kernel._weights_from_fraction):
 *   s = 1 - t;  t2 = t t, s2 = s s;  t3 = t2 t, s3 = s2 s
 *   w0 = s3 (T)(1/6);  w1 = (T)(2/3) - (t2 (2 - t)) 0.5;  w2 = (T)(2/3) - (s2 (2 - s)) 0.5;  w3 = t3 (T)(1/6)
 * (w1 = (3t^3 - 6t^2 + 4)/6 written as 2/3 - t^2 (2 - t)/2, w2 the same of s = 1 - t: the B-spline's symmetry).
 * They were a 4096-entry table indexed by 12 bits of the fraction: 64 KB (float) of random access that fell out of
 * L1, and a phase quantisation that limited the accuracy of an order to ~1e-4. Computed per block of samples into
 * small arrays they cost less than the table's cache misses and are exact to float rounding at any fraction.
 *   va[c] = ((w0 A[i][c] + w1 A[i+1][c]) + w2 A[i+2][c]) + w3 A[i+3][c]     in T, every operation rounded in T
 * Time blend (table b given): vb likewise from B; xi = j + xi0 (double);
 *   s = (T) (clip((int64) (xi * blend_scale), 0, 2^16) / 2^16);  out = va + (vb - va) * s      (in T)
 * else out = va.
 *
 * Bit-for-bit contract with the numpy reference (the generic path, synth_segment_f32_generic / _f64): build with
 * -ffp-contract=off and without -ffast-math, so that no multiply-add is fused and nothing is reassociated (x86-64 /
 * AArch64: float arithmetic is done in float).
 *
 * Fast path (synth_segment_f32 with C = 8 on a CPU with AVX2 and FMA, chosen at run time): one 256-bit vector per
 * table row and fused multiply-adds,
 *   va = fma(w3, A3, fma(w2, A2, fma(w1, A1, w0 A0))),  vb likewise,  out = fma(s, vb - va, va),
 * with the weights and s of the generic path. Its samples differ from the reference by float rounding only (a few
 * units of 2^-24 of the taps' magnitude, tests/test_synth_kernel.py), and are still a function of the sample's
 * phase and position alone, so splitting a call anywhere gives the same samples (chunk invariance). Why: without
 * FMA the loop is 16 multiplies + 15 adds per sample on top of its loads (~2.5x slower).
 *
 * Layout (all C-contiguous): tables ta, tb (N + 3) x C; out m x C (row stride C); warp m int64 (optional);
 * feature accumulators acc C x 6 doubles per channel [sum d, sum d^2, sum d^3, sum d^4, max d, min d] of
 * d = (double) out - off[c], updated in place (the caller starts them at 0, 0, 0, 0, -inf, +inf).
 *
 * Speed: GCC on x86-64 builds an AVX2 clone of the generic path besides the baseline (target_clones, dispatched at
 * load time); the fast path above is a separate function compiled for AVX2 + FMA and called only where the CPU has
 * both (__builtin_cpu_supports). The loops are plain C that the vectoriser maps to the target's vectors. Moments:
 * 8 float32 channels with AVX2 are summed in float per block and shifted into the double accumulators
 * (moments8_f32_avx2); otherwise 4-lane double vectors with AVX2, 2-lane ones without (per block). The float block
 * sums agree with the reference to ~1e-6.
 *
 * The knot table (synth_knot_table_f32 / _f64, at the end of the sample-loop part) builds the (N + 3) x C table of a
 * knot from the modal sum's amplitudes, see its comment.
 */
#include <Python.h>

#include "_synthbase.h"
#include "_synthnoise.h"
#include "_synthblock.h"

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

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
/* The fast path (see the header): 8 float32 channels, one 256-bit vector per table row, fused multiply-adds. Phases,
 * weights and blend weights are those of the generic path (the same inline code, compiled for AVX2; no contraction,
 * so they round as there); the per-sample work is the same at every position of a block. */
/* Sample j of a block from its weights w0 .. w3 and blend weight s (vectors of the value in all lanes). */
#define ROW8_FMA(j, w0, w1, w2, w3, s)                                                                              \
    do {                                                                                                            \
        const int64_t r_ = (int64_t)idx[j] * 8;                                                                     \
        const float *restrict a_ = ta + r_;                                                                         \
        const __m256 w0_ = (w0), w1_ = (w1), w2_ = (w2), w3_ = (w3);                                                \
        __m256 va_ = _mm256_mul_ps(w0_, _mm256_loadu_ps(a_));                                                       \
        va_ = _mm256_fmadd_ps(w1_, _mm256_loadu_ps(a_ + 8), va_);                                                   \
        va_ = _mm256_fmadd_ps(w2_, _mm256_loadu_ps(a_ + 16), va_);                                                  \
        va_ = _mm256_fmadd_ps(w3_, _mm256_loadu_ps(a_ + 24), va_);                                                  \
        if (blend) {                                                                                                \
            const float *restrict b_ = tb + r_;                                                                     \
            __m256 vb_ = _mm256_mul_ps(w0_, _mm256_loadu_ps(b_));                                                   \
            vb_ = _mm256_fmadd_ps(w1_, _mm256_loadu_ps(b_ + 8), vb_);                                               \
            vb_ = _mm256_fmadd_ps(w2_, _mm256_loadu_ps(b_ + 16), vb_);                                              \
            vb_ = _mm256_fmadd_ps(w3_, _mm256_loadu_ps(b_ + 24), vb_);                                              \
            va_ = _mm256_fmadd_ps((s), _mm256_sub_ps(vb_, va_), va_);                                               \
        }                                                                                                           \
        if (noise) {                                                                                                \
            if (sigma) va_ = _mm256_fmadd_ps(sigv, _mm256_loadu_ps(Z + 8 * (int64_t)(j)), va_);                    \
            if (xb != NULL) va_ = _mm256_add_ps(va_, _mm256_loadu_ps(xb + 8 * (int64_t)(j)));                      \
        }                                                                                                           \
        _mm256_storeu_ps(ob + 8 * (int64_t)(j), va_);                                                               \
    } while (0)

static inline __attribute__((always_inline)) FMA_TARGET void rows8_fma(
    const int has_warp, const int blend, const int feats, const int noise, int64_t m, uint64_t mask, int fb,
    uint64_t u, uint64_t d, uint64_t dd, const int64_t *restrict warp, const float *restrict ta,
    const float *restrict tb, double xi0, double blend_scale, float *restrict out, double *restrict acc,
    const double *restrict off, const NoiseArgs *na)
{
    int32_t idx[BLOCK];
    float W0[BLOCK], W1[BLOCK], W2[BLOCK], W3[BLOCK], sw[BLOCK];
    float Z[noise ? BLOCK * 8 : 1];
    const int sigma = noise && na->sigma_f != NULL;
    const float *extra = noise ? (const float *)na->extra : NULL;
    const __m256 sigv = sigma ? _mm256_loadu_ps(na->sigma_f) : _mm256_setzero_ps();
    for (int64_t k0 = 0, nb; k0 < m; k0 += nb) {
        nb = block_length(noise, m - k0, noise ? na->n0 + k0 : 0);
        if (sigma) noise_fill8_avx2(na->key, na->n0 + k0, (int)nb, Z);
        const float *restrict xb = extra != NULL ? extra + k0 * 8 : NULL;
        prologue8_fma(has_warp, blend, (int)nb, k0, &u, &d, dd, has_warp ? warp + k0 : NULL, fb, mask, xi0, blend_scale,
                      idx, W0, W1, W2, W3, sw);
        float *restrict ob = out + k0 * 8;
        int j = 0;
        /* Four samples at a time: each weight array's four values in both halves of a vector (one 128-bit broadcast
         * load), then value l to all lanes with an in-lane permute (port 5, idle here) instead of a broadcast load
         * per weight and sample: the loop is bound by its loads (8 table rows per sample with the blend). The
         * samples' values are the same as one at a time (the tail below). */
        for (; j + 4 <= nb; j += 4) {
            const __m256 V0 = _mm256_broadcast_ps((const __m128 *)(W0 + j));
            const __m256 V1 = _mm256_broadcast_ps((const __m128 *)(W1 + j));
            const __m256 V2 = _mm256_broadcast_ps((const __m128 *)(W2 + j));
            const __m256 V3 = _mm256_broadcast_ps((const __m128 *)(W3 + j));
            const __m256 VS = blend ? _mm256_broadcast_ps((const __m128 *)(sw + j)) : V0;
            ROW8_FMA(j, _mm256_permute_ps(V0, 0x00), _mm256_permute_ps(V1, 0x00), _mm256_permute_ps(V2, 0x00),
                     _mm256_permute_ps(V3, 0x00), _mm256_permute_ps(VS, 0x00));
            ROW8_FMA(j + 1, _mm256_permute_ps(V0, 0x55), _mm256_permute_ps(V1, 0x55), _mm256_permute_ps(V2, 0x55),
                     _mm256_permute_ps(V3, 0x55), _mm256_permute_ps(VS, 0x55));
            ROW8_FMA(j + 2, _mm256_permute_ps(V0, 0xAA), _mm256_permute_ps(V1, 0xAA), _mm256_permute_ps(V2, 0xAA),
                     _mm256_permute_ps(V3, 0xAA), _mm256_permute_ps(VS, 0xAA));
            ROW8_FMA(j + 3, _mm256_permute_ps(V0, 0xFF), _mm256_permute_ps(V1, 0xFF), _mm256_permute_ps(V2, 0xFF),
                     _mm256_permute_ps(V3, 0xFF), _mm256_permute_ps(VS, 0xFF));
        }
        for (; j < nb; ++j)
            ROW8_FMA(j, _mm256_broadcast_ss(W0 + j), _mm256_broadcast_ss(W1 + j), _mm256_broadcast_ss(W2 + j),
                     _mm256_broadcast_ss(W3 + j), blend ? _mm256_broadcast_ss(sw + j) : _mm256_setzero_ps());
        if (feats) moments8_f32_avx2((int)nb, ob, off, acc);
    }
}

#define ROWS8(W, B, F, N) rows8_fma(W, B, F, N, m, mask, fb, u, d, dd, warp, ta, tb, xi0, blend_scale, out, acc, \
                                     off, na)
#define ROWS8_N(W, B, F) do { if (na != NULL) ROWS8(W, B, F, 1); else ROWS8(W, B, F, 0); } while (0)
static NOINLINE FMA_TARGET void segment8_f32_fma(int64_t m, uint64_t mask, int fb, uint64_t u, uint64_t d,
                                                 uint64_t dd, const int64_t *warp, const float *ta, const float *tb,
                                                 double xi0, double blend_scale, float *out, double *acc,
                                                 const double *off, const NoiseArgs *na)
{
    const int w = warp != NULL, b = tb != NULL, f = acc != NULL;
    if (w && b && f) ROWS8_N(1, 1, 1);
    else if (w && b) ROWS8_N(1, 1, 0);
    else if (w && f) ROWS8_N(1, 0, 1);
    else if (w) ROWS8_N(1, 0, 0);
    else if (b && f) ROWS8_N(0, 1, 1);
    else if (b) ROWS8_N(0, 1, 0);
    else if (f) ROWS8_N(0, 0, 1);
    else ROWS8_N(0, 0, 0);
}
#else
static void segment8_f32_fma(int64_t m, uint64_t mask, int fb, uint64_t u, uint64_t d, uint64_t dd,
                             const int64_t *warp, const float *ta, const float *tb, double xi0, double blend_scale,
                             float *out, double *acc, const double *off, const NoiseArgs *na)
{
    (void)m, (void)mask, (void)fb, (void)u, (void)d, (void)dd, (void)warp, (void)ta, (void)tb, (void)xi0;
    (void)blend_scale, (void)out, (void)acc, (void)off, (void)na;
}
#endif

/* Sets the instruction-set cap (isa_cap, _synthbase.h); returns the old one. */
int synth_set_isa_cap(int cap)
{
    const int old = isa_cap;
    isa_cap = cap;
    return old;
}

/* Sets reference_paths (_synthbase.h); returns the old value. */
int synth_set_reference_paths(int on)
{
    const int old = reference_paths;
    reference_paths = on;
    return old;
}

/* 1 if synth_segment_f32 takes the fast path for C = 8 on this CPU (tests and benchmarks ask). */
int synth_fast_path(void) { return isa_cap >= 1 && HAVE_FMA_PATH ? 1 : 0; }

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
/* m samples x C channels of one call into out by the generic path (bit for bit the numpy reference; see the        \
 * header). warp (m values), tb (table of knot b; NULL: no blend) and acc/off (fused feature accumulation) are      \
 * optional. Returns 0, or -1 if the arguments are unusable (segment_args_ok). */                                   \
CLONES int synth_segment_generic_##SUF(int64_t m, int64_t C, int64_t N, int fb, uint64_t phase0, uint64_t dphase0,  \
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
/* The same with the fast path where it applies (float32, C = 8, AVX2 + FMA: see the header), else the generic     \
 * path. */                                                                                                         \
int synth_segment_##SUF(int64_t m, int64_t C, int64_t N, int fb, uint64_t phase0, uint64_t dphase0,                 \
                        uint64_t ddphase, const int64_t *warp, const T *ta, const T *tb, double xi0,                \
                        double blend_scale, T *out, double *acc, const double *off, const NoiseArgs *na)            \
{                                                                                                                   \
    if (sizeof(T) == 4 && C == 8 && isa_cap >= 1 && HAVE_FMA_PATH) {                                               \
        if (!segment_args_ok(m, C, N, fb, ta, out, acc, off)) return -1;                                            \
        segment8_f32_fma(m, (uint64_t)N - 1, fb, phase0, dphase0, ddphase, warp, (const float *)(const void *)ta,   \
                         (const float *)(const void *)tb, xi0, blend_scale, (float *)(void *)out, acc, off, na);    \
        return 0;                                                                                                   \
    }                                                                                                               \
    return synth_segment_generic_##SUF(m, C, N, fb, phase0, dphase0, ddphase, warp, ta, tb, xi0, blend_scale, out,  \
                                       acc, off, na);                                                               \
}                                                                                                                   \
                                                                                                                    \
/* Noise added to an existing n x C block x (samples from absolute index n0) and, with acc, the features of the     \
 * result accumulated, in one pass per block (a line set's families are summed first: synth_lines.py). */          \
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

#include "_synthlines.h"

/* Random-slip warp of one segment (synth_random._SlipWalk.warp_fixed): for sample i < m at xi = j0 + i, the ball
 * passes u = (c2 xi + c1) xi + u_frac since the knot (speed >= 0 in a segment, so u does not decrease), the walk W
 * at u by the C1 cubic Hermite spline of its values w[k] at passes jw0 + k (Catmull-Rom slopes
 * m_k = (w[k+1] - w[k-1]) / 2), written per pass interval [j, j + 1) as the cubic in t = u - j
 *     W = ((a3 t + a2) t + a1) t + a0,  a0 = w_j, a1 = m_j, a2 = 3 (w_{j+1} - w_j) - 2 m_j - m_{j+1},
 *     a3 = 2 (w_j - w_{j+1}) + m_j + m_{j+1},
 * and for each of the K factors kappa the phase offset in the loop's fixed point, out[k m + i] =
 * rint(y 2^52) 2^10 with y = kappa W - rint(kappa W) (a fraction of a pass in [-1/2, 1/2], to 2^-52). Why this form:
 * the coefficients change once per pass (~100-400 samples), so the samples of an interval are a Horner step of 4
 * doubles at a time with AVX2 (the previous per-sample Hermite with two libm-free rints cost ~70 us a chunk, now
 * ~5 us); rint(y 2^52) is exact by adding and subtracting 1.5 2^52 (|y 2^52| < 2^51), and the integer is the bits
 * of that sum less those of 1.5 2^52, so AVX2 needs no 64-bit conversion. Scalar and AVX2 code do the same double
 * operations (no contraction), so they agree bit for bit, and with synth_kernel.slip_warp_reference. Returns -1 if
 * a sample falls outside w or K is out of 1..8. */
#define WARP_MAGIC 6755399441055744.0              /* 1.5 2^52 */
static inline int64_t warp_fixed1(double wp)
{
    const double r = (wp + WARP_MAGIC) - WARP_MAGIC;                /* rint(wp), |wp| < 2^51 */
    const double y = (wp - r) * 0x1.0p52;
    const double v = y + WARP_MAGIC;
    int64_t bits, base;
    const double mg = WARP_MAGIC;
    memcpy(&bits, &v, 8);
    memcpy(&base, &mg, 8);
    return (int64_t)((uint64_t)(bits - base) << 10);
}

/* Coefficients of the interval starting at walk index k (w[k - 1] .. w[k + 2] must exist). */
static inline void warp_coefficients(const double *w, int64_t k, double a[4])
{
    const double w0 = w[k], w1 = w[k + 1];
    const double m0 = 0.5 * (w[k + 1] - w[k - 1]), m1 = 0.5 * (w[k + 2] - w[k]);
    const double d = w1 - w0;
    a[0] = w0;
    a[1] = m0;
    a[2] = ((3.0 * d) - (2.0 * m0)) - m1;
    a[3] = ((-2.0 * d) + m0) + m1;
}

static inline int64_t warp_interval(double u, int64_t jw0, int64_t nw)
{
    const int64_t k = (int64_t)u - jw0;                            /* floor for u >= 0 */
    return (k < 1 || k + 2 >= nw) ? -1 : k;
}

static int warp_scalar_range(int64_t i0, int64_t i1, double j0, double c1, double c2, double u_frac,
                             const double *w, int64_t nw, int64_t jw0, const double *kappa, int K, int64_t m,
                             int64_t *out, int64_t *pk, double a[4])
{
    for (int64_t i = i0; i < i1; ++i) {
        const double xi = j0 + (double)i;
        const double u = (c2 * xi + c1) * xi + u_frac;
        if (!(u >= 0.0 && u < 9.0e15)) return -1;
        const int64_t k = warp_interval(u, jw0, nw);
        if (k < 0) return -1;
        if (k != *pk) warp_coefficients(w, k, a), *pk = k;
        const double t = u - (double)(k + jw0);
        const double ww = ((a[3] * t + a[2]) * t + a[1]) * t + a[0];
        for (int q = 0; q < K; ++q) out[q * m + i] = warp_fixed1(kappa[q] * ww);
    }
    return 0;
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
static NOINLINE __attribute__((target("avx2"))) int warp_avx2(int64_t m, double j0, double c1, double c2,
                                                              double u_frac, const double *w, int64_t nw,
                                                              int64_t jw0, const double *kappa, int K, int64_t *out)
{
    int64_t k = -1;
    double a[4] = {0, 0, 0, 0};
    const __m256d lanes = _mm256_set_pd(3.0, 2.0, 1.0, 0.0), vc1 = _mm256_set1_pd(c1), vc2 = _mm256_set1_pd(c2);
    const __m256d vuf = _mm256_set1_pd(u_frac), magic = _mm256_set1_pd(WARP_MAGIC), two52 = _mm256_set1_pd(0x1.0p52);
    const __m256i mbase = _mm256_castpd_si256(magic);
    int64_t i = 0;
    for (; i + 4 <= m; i += 4) {
        const __m256d xi = _mm256_add_pd(_mm256_set1_pd(j0 + (double)i), lanes);
        const __m256d u = _mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(vc2, xi), vc1), xi), vuf);
        /* all four in the current interval [k + jw0, k + jw0 + 1)? (u >= 0: truncation is the floor) */
        const double lo = (double)(k + jw0), hi = lo + 1.0;
        const __m256d inside = _mm256_and_pd(_mm256_cmp_pd(u, _mm256_set1_pd(lo), _CMP_GE_OQ),
                                             _mm256_cmp_pd(u, _mm256_set1_pd(hi), _CMP_LT_OQ));
        if (k < 0 || _mm256_movemask_pd(inside) != 15) {
            if (warp_scalar_range(i, i + 4, j0, c1, c2, u_frac, w, nw, jw0, kappa, K, m, out, &k, a)) return -1;
            continue;
        }
        const __m256d t = _mm256_sub_pd(u, _mm256_set1_pd(lo));
        __m256d ww = _mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(a[3]), t), _mm256_set1_pd(a[2]));
        ww = _mm256_add_pd(_mm256_mul_pd(ww, t), _mm256_set1_pd(a[1]));
        ww = _mm256_add_pd(_mm256_mul_pd(ww, t), _mm256_set1_pd(a[0]));
        for (int q = 0; q < K; ++q) {
            const __m256d wp = _mm256_mul_pd(_mm256_set1_pd(kappa[q]), ww);
            const __m256d r = _mm256_sub_pd(_mm256_add_pd(wp, magic), magic);
            const __m256d v = _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(wp, r), two52), magic);
            const __m256i iv = _mm256_slli_epi64(_mm256_sub_epi64(_mm256_castpd_si256(v), mbase), 10);
            _mm256_storeu_si256((__m256i *)(out + q * m + i), iv);
        }
    }
    return warp_scalar_range(i, m, j0, c1, c2, u_frac, w, nw, jw0, kappa, K, m, out, &k, a);
}
#define HAVE_WARP_AVX2 (__builtin_cpu_supports("avx2"))
#else
#define HAVE_WARP_AVX2 0
static int warp_avx2(int64_t m, double j0, double c1, double c2, double u_frac, const double *w, int64_t nw,
                     int64_t jw0, const double *kappa, int K, int64_t *out)
{
    (void)m, (void)j0, (void)c1, (void)c2, (void)u_frac, (void)w, (void)nw, (void)jw0, (void)kappa, (void)K;
    (void)out;
    return -1;
}
#endif

int synth_slip_warp(int64_t m, double j0, double c1, double c2, double u_frac, const double *w, int64_t nw,
                    int64_t jw0, const double *kappa, int64_t K, int64_t *out)
{
    if (m < 0 || nw < 4 || K < 1 || K > 8) return -1;
    if (isa_cap >= 1 && HAVE_WARP_AVX2) return warp_avx2(m, j0, c1, c2, u_frac, w, nw, jw0, kappa, (int)K, out);
    int64_t k = -1;
    double a[4] = {0, 0, 0, 0};
    return warp_scalar_range(0, m, j0, c1, c2, u_frac, w, nw, jw0, kappa, (int)K, m, out, &k, a);
}

/* Carrier mix of a line family with a carrier (synth_lines.py): out[i][c] += cs[i][0] re[i][c] - cs[i][1] im[i][c],
 * i < m, c < C, row-major blocks; cs holds (cos, sin) of the carrier phase per sample. Two multiplies and two
 * adds per element, in this order (the numpy reference synth_kernel.carrier_mix_reference does the same). */
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

/* Normals of absolute samples n0 .. n0 + n - 1, C channels, into Z (n x C float32): the noise of a segment call
 * (_synthnoise.h), for tests and the numpy fallback's comparisons. avx2: use the AVX2 code where C = 8. */
int synth_noise_fill(uint64_t key, int64_t n0, int64_t n, int64_t C, int avx2, float *Z)
{
    if (n < 0 || n0 < 0 || C < 1 || C > NOISE_MAX_C) return -1;
    for (int64_t k0 = 0, nb; k0 < n; k0 += nb) {
        nb = block_length(1, n - k0, n0 + k0);
        if (avx2 && C == 8 && HAVE_NOISE_AVX2) noise_fill8_avx2(key, n0 + k0, (int)nb, Z + k0 * C);
        else if (avx2 && C < 8 && HAVE_NOISE_AVX2) noise_fill_narrow_avx2(key, n0 + k0, (int)nb, (int)C, Z + k0 * C);
        else noise_fill_scalar(key, n0 + k0, (int)nb, (int)C, Z + k0 * C);
    }
    return 0;
}

/* The broadband floor of samples n0 .. n0 + m - 1 (synth_floor.py): overlapping grains g of 2 S samples from g S,
 * each a circular window into one of the precomputed shaped-noise frames (L x C int16 each, in frames, times
 * scale[c]),
 * weighted by the sine window w(t) = sin(pi t / 2 S) (win: 2 S values), so that the two grains over any sample have
 * w^2 + w^2 = 1. G grains given as (g, frame index, offset) in grains[3 G]. out: m x C float32, written. */
CLONES int synth_floor_render(int64_t m, int64_t C, int64_t n0, int64_t S, int64_t L, const int16_t *frames,
                              const float *win, int64_t G, const int64_t *grains, float *out, const float *scale)
{
    if (m < 0 || C < 1 || S < 1 || L < 2 * S / 2 || G < 0 || scale == NULL) return -1;
    floor_block_f32(m, C, n0, S, L, frames, scale, win, G, grains, out);
    return 0;
}

#include "_synthfloor.h"          /* synth_floor_spectrum, synth_floor_quantise: a seed's frames */

/* ------------------------------------------------------------------------------------------ sensor noise (ziggurat)
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

/* ------------------------------------------------------------------------------------------ knot table
 * The (N + 3) x C spline table of a knot (synth.py, _amplitudes) from the modal sum's amplitudes x (K x U complex):
 *   y[k][c] = x[k][cindex[c]] * ((factor[k][c] * scale[c]) * taper[k])            (complex double; taper optional)
 *   T[n][c] = dc[c] + sum_k Re(y[k][c] exp(i o_k 2 pi n / N)),  n = 0 .. N-1;  table row r = T[(r - 1) mod N]
 * Why C: numpy did it as a float32 GEMM (N + 3) x (2K + 1) x C plus glue, ~50-70 us per new speed; here in double,
 * with a quarter of the cosines and sines. With x_k = o_k 2 pi j / N, j = 0 .. N/4, and the sums over the even (e)
 * and odd (o) orders Ce = sum Re(y) cos x_k, Se = sum Im(y) sin x_k (Co, So likewise), the symmetries
 * cos(o pi +- x) = (-1)^o cos x, sin(o pi +- x) = +-(-1)^o sin x and cos(2 o pi - x) = cos x, sin(2 o pi - x) = -sin x
 * (integer orders) give the four points of a quarter wave:
 *   T[j] = dc + (Ce + Co) - (Se + So)          T[N - j]   = dc + (Ce + Co) + (Se + So)
 *   T[N/2 - j] = dc + (Ce - Co) + (Se - So)    T[N/2 + j] = dc + (Ce - Co) - (Se - So)
 * j = 0 and j = N/4 give each point twice (there sin x = 0, resp. Co = Se = 0: the caller's basis holds exact zeros),
 * and are written once. The basis (synth_kernel.QuarterBasis) holds cos x and sin x for j = 0 .. N/4 and padding rows
 * up to a multiple of KNOT_JB, the orders sorted even first (perm[s] = original index of sorted order s, the first
 * n_even even), interleaved: basis[(j K + s) 2 + {0, 1}]. The sums run over blocks of KNOT_JB values of j with the 8
 * channels of a row in 4-lane double vectors (fused multiply-adds with AVX2 + FMA, dispatched at run time): about
 * (N/4) K C / 2 fused multiply-adds in all. */
typedef double kv4 __attribute__((vector_size(32)));

#define KNOT_JB 6                          /* j per pass over the orders (the basis has rows up to a multiple) */

/* One sum over the orders of one parity (sorted s0 .. s1-1) for j0 .. j0 + KNOT_JB - 1 and G groups of 4 channels
 * from g0: res[jb][g] = sum_s basis[j0 + jb][s][e] Y[s][4 (g0 + g) ..], e = 0 (cos, Y = Re y) or 1 (sin, Y = Im y).
 * A register-blocked product (KNOT_JB x 4G accumulators, the row of Y in registers, one broadcast per j): with
 * G = 2 twelve fused multiply-adds per 8 loads. MADD(a, b, c) = a b + c. */
#define KNOT_PASS(G, MADD, Y, e, res)                                                                               \
    do {                                                                                                            \
        kv4 acc_[KNOT_JB][G];                                                                                       \
        for (int jb = 0; jb < KNOT_JB; ++jb)                                                                        \
            for (int g = 0; g < G; ++g) acc_[jb][g] = (kv4){0, 0, 0, 0};                                            \
        for (int64_t s = s0; s < s1; ++s) {                                                                         \
            kv4 yv[G];                                                                                              \
            for (int g = 0; g < G; ++g) memcpy(&yv[g], (Y) + s * Cp + 4 * (g0 + g), sizeof(kv4));                   \
            const double *bs = basis + (j0 * K + s) * 2 + (e);                                                      \
            for (int jb = 0; jb < KNOT_JB; ++jb) {                                                                  \
                const double bv = bs[jb * 2 * K];                                                                   \
                const kv4 b4 = {bv, bv, bv, bv};                                                                    \
                for (int g = 0; g < G; ++g) acc_[jb][g] = MADD(b4, yv[g], acc_[jb][g]);                             \
            }                                                                                                       \
        }                                                                                                           \
        memcpy(res, acc_, sizeof acc_);                                                                             \
    } while (0)

/* Rows n of T (table row n + 1) from the sums, channels 4 g .. 4 g + 3 below C. */
#define KNOT_STORE(T, n, v)                                                                                         \
    do {                                                                                                            \
        T *restrict o_ = table + ((int64_t)(n) + 1) * C + 4 * (g0 + g);                                             \
        if (4 * (g0 + g) + 4 <= C)                                                                                  \
            for (int l = 0; l < 4; ++l) o_[l] = (T)(v)[l];                                                          \
        else                                                                                                        \
            for (int l = 0; 4 * (g0 + g) + l < C; ++l) o_[l] = (T)(v)[l];                                           \
    } while (0)

#define KNOT_GROUPS(T, G, MADD)                                                                                     \
    for (int64_t j0 = 0; j0 <= Q; j0 += KNOT_JB) {                                                                  \
        kv4 ce[KNOT_JB][G], co[KNOT_JB][G], se[KNOT_JB][G], so[KNOT_JB][G];                                         \
        int64_t s0 = 0, s1 = n_even;                                                                                \
        KNOT_PASS(G, MADD, YR, 0, ce);                                                                              \
        KNOT_PASS(G, MADD, YI, 1, se);                                                                              \
        s0 = n_even, s1 = K;                                                                                        \
        KNOT_PASS(G, MADD, YR, 0, co);                                                                              \
        KNOT_PASS(G, MADD, YI, 1, so);                                                                              \
        for (int jb = 0; jb < KNOT_JB && j0 + jb <= Q; ++jb) {                                                      \
            const int64_t j = j0 + jb;                                                                              \
            for (int g = 0; g < G; ++g) {                                                                           \
                kv4 dcv;                                                                                            \
                memcpy(&dcv, DC + 4 * (g0 + g), sizeof dcv);                                                        \
                const kv4 p = ce[jb][g] + co[jb][g], q = se[jb][g] + so[jb][g];                                     \
                const kv4 r = ce[jb][g] - co[jb][g], t = se[jb][g] - so[jb][g];                                     \
                const kv4 v0 = (dcv + p) - q, v3 = (dcv + r) - t;                                                   \
                KNOT_STORE(T, j, v0);                                                                               \
                KNOT_STORE(T, 2 * Q + j, v3);                                                                       \
                if (j > 0 && j < Q) {                                                                               \
                    const kv4 v1 = (dcv + p) + q, v2 = (dcv + r) + t;                                               \
                    KNOT_STORE(T, 4 * Q - j, v1);                                                                   \
                    KNOT_STORE(T, 2 * Q - j, v2);                                                                   \
                }                                                                                                   \
            }                                                                                                       \
        }                                                                                                           \
    }

/* WIDE: both groups of 8 channels at once (16 vector registers of AVX2 hold the 12 sums; the baseline's 4-lane     \
 * vectors are pairs of SSE2 registers, which would spill) */                                                       \
#define KNOT_SUMS(T, SUF, NAME, ATTR, MADD, WIDE)                                                                   \
ATTR void knot_sums_##NAME##_##SUF(int64_t C, int64_t Cp, int64_t K, int64_t n_even, int64_t Q,                     \
                                   const double *restrict basis, const double *restrict YR,                        \
                                   const double *restrict YI, const double *restrict DC, T *restrict table)         \
{                                                                                                                   \
    if (WIDE && Cp == 8) {                                                                                          \
        const int64_t g0 = 0;                                                                                       \
        KNOT_GROUPS(T, 2, MADD)                                                                                     \
    } else {                                                                                                        \
        for (int64_t g0 = 0; 4 * g0 < Cp; ++g0) {                                                                   \
            KNOT_GROUPS(T, 1, MADD)                                                                                 \
        }                                                                                                           \
    }                                                                                                               \
}

#define MADD_PLAIN(a, b, c) ((a) * (b) + (c))
KNOT_SUMS(float, f32, base, static NOINLINE, MADD_PLAIN, 0)
KNOT_SUMS(double, f64, base, static NOINLINE, MADD_PLAIN, 0)
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
#define MADD_FMA(a, b, c) ((kv4)_mm256_fmadd_pd((__m256d)(a), (__m256d)(b), (__m256d)(c)))
KNOT_SUMS(float, f32, fma, static NOINLINE FMA_TARGET, MADD_FMA, 1)
KNOT_SUMS(double, f64, fma, static NOINLINE FMA_TARGET, MADD_FMA, 1)
#else
#define knot_sums_fma_f32 knot_sums_base_f32
#define knot_sums_fma_f64 knot_sums_base_f64
#endif

/* 8 channels with AVX-512 (Cascade Lake and later): a row of 8 doubles is one 512-bit vector, the broadcasts fold
 * into the fused multiply-adds (embedded broadcast), and 32 registers hold the cosine and sine sums of KNOT_JB values
 * of j at once: half the instructions of the 4-lane path. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
typedef double kv8 __attribute__((vector_size(64)));
#define KNOT8_SUMS(T, SUF)                                                                                          \
static NOINLINE __attribute__((target("avx512f"))) void knot8_sums_avx512_##SUF(                                    \
    int64_t K, int64_t n_even, int64_t Q, const double *restrict basis, const double *restrict YR,                  \
    const double *restrict YI, const double *restrict DC, T *restrict table)                                        \
{                                                                                                                   \
    const int64_t C = 8;                                                                                            \
    kv8 dcv;                                                                                                        \
    memcpy(&dcv, DC, sizeof dcv);                                                                                   \
    for (int64_t j0 = 0; j0 <= Q; j0 += KNOT_JB) {                                                                  \
        kv8 cs[2][KNOT_JB], sn[2][KNOT_JB];                  /* [even, odd] */                                      \
        for (int par = 0; par < 2; ++par) {                                                                         \
            kv8 ca[KNOT_JB], sa[KNOT_JB];                                                                           \
            for (int jb = 0; jb < KNOT_JB; ++jb) ca[jb] = (kv8){0}, sa[jb] = (kv8){0};                              \
            for (int64_t s = par ? n_even : 0; s < (par ? K : n_even); ++s) {                                       \
                kv8 yr, yi;                                                                                         \
                memcpy(&yr, YR + s * 8, sizeof yr);                                                                 \
                memcpy(&yi, YI + s * 8, sizeof yi);                                                                 \
                const double *bs = basis + (j0 * K + s) * 2;                                                        \
                for (int jb = 0; jb < KNOT_JB; ++jb) {                                                              \
                    ca[jb] = (kv8)_mm512_fmadd_pd(_mm512_set1_pd(bs[jb * 2 * K]), (__m512d)yr, (__m512d)ca[jb]);    \
                    sa[jb] = (kv8)_mm512_fmadd_pd(_mm512_set1_pd(bs[jb * 2 * K + 1]), (__m512d)yi, (__m512d)sa[jb]); \
                }                                                                                                   \
            }                                                                                                       \
            memcpy(cs[par], ca, sizeof ca);                                                                         \
            memcpy(sn[par], sa, sizeof sa);                                                                         \
        }                                                                                                           \
        for (int jb = 0; jb < KNOT_JB && j0 + jb <= Q; ++jb) {                                                      \
            const int64_t j = j0 + jb;                                                                              \
            const kv8 p = cs[0][jb] + cs[1][jb], q = sn[0][jb] + sn[1][jb];                                         \
            const kv8 r = cs[0][jb] - cs[1][jb], t = sn[0][jb] - sn[1][jb];                                         \
            const kv8 v0 = (dcv + p) - q, v3 = (dcv + r) - t;                                                       \
            KNOT8_STORE(T, j, v0);                                                                                  \
            KNOT8_STORE(T, 2 * Q + j, v3);                                                                          \
            if (j > 0 && j < Q) {                                                                                   \
                const kv8 v1 = (dcv + p) + q, v2 = (dcv + r) + t;                                                   \
                KNOT8_STORE(T, 4 * Q - j, v1);                                                                      \
                KNOT8_STORE(T, 2 * Q - j, v2);                                                                      \
            }                                                                                                       \
        }                                                                                                           \
    }                                                                                                               \
}
typedef float kv8f __attribute__((vector_size(32)));
#define KNOT8_STORE(T, n, v)                                                                                        \
    do {                                                                                                            \
        if (sizeof(T) == 4) {                                                                                       \
            const kv8f f_ = __builtin_convertvector((v), kv8f);                                                     \
            memcpy(table + ((int64_t)(n) + 1) * C, &f_, sizeof f_);                                                 \
        } else {                                                                                                    \
            memcpy(table + ((int64_t)(n) + 1) * C, &(v), sizeof(v));                                                \
        }                                                                                                           \
    } while (0)
KNOT8_SUMS(float, f32)
KNOT8_SUMS(double, f64)
#define HAVE_AVX512 __builtin_cpu_supports("avx512f")
#else
#define HAVE_AVX512 0
#define knot8_sums_avx512_f32(...) ((void)0)
#define knot8_sums_avx512_f64(...) ((void)0)
#endif


/* The knot table into table ((N + 3) x C, float or double) and y (K x C complex double), see above. x: K x U complex
 * (row stride U), cindex: C channel columns of x, factor: K x C complex, scale: C, taper: K or NULL, dc: C, perm and
 * basis: the caller's QuarterBasis. Returns 0, -1 for unusable sizes, -2 for an index out of range, -3 if out of
 * memory. */
#define KNOT_TABLE(T, SUF)                                                                                          \
int synth_knot_table_##SUF(int64_t K, int64_t C, int64_t U, int64_t N, int64_t n_even, const double *x,             \
                           const int64_t *cindex, const double *factor, const double *scale, const double *taper,   \
                           const double *dc, const int64_t *perm, const double *basis, T *table, double *y)         \
{                                                                                                                   \
    if (K < 0 || C < 1 || U < 1 || N < 64 || N > 65536 || (N & (N - 1)) != 0 || n_even < 0 || n_even > K)          \
        return -1;                                                                                                  \
    for (int64_t c = 0; c < C; ++c)                                                                                 \
        if (cindex[c] < 0 || cindex[c] >= U) return -2;                                                             \
    for (int64_t s = 0; s < K; ++s)                                                                                 \
        if (perm[s] < 0 || perm[s] >= K) return -2;                                                                 \
    const int64_t Cp = (C + 3) / 4 * 4, Q = N / 4;                                                                  \
    double *work = malloc(sizeof(double) * (size_t)((2 * K + 1) * Cp));                                             \
    if (work == NULL) return -3;                                                                                    \
    double *YR = work, *YI = work + K * Cp, *DC = work + 2 * K * Cp;                                                \
    memset(work, 0, sizeof(double) * (size_t)((2 * K + 1) * Cp));                                                  \
    for (int64_t c = 0; c < C; ++c) DC[c] = dc[c];                                                                  \
    /* y as numpy's fac = factor * scale; fac *= taper; y = x[:, cindex] * fac (complex (a + bi)(c + di) =        \
     * (ac - bd) + (ad + bc) i), and its real and imaginary parts in the sorted order for the sums */               \
    for (int64_t s = 0; s < K; ++s) {                                                                               \
        const int64_t k = perm[s];                                                                                  \
        for (int64_t c = 0; c < C; ++c) {                                                                           \
            double fr = factor[2 * (k * C + c)] * scale[c], fi = factor[2 * (k * C + c) + 1] * scale[c];            \
            if (taper != NULL) fr = fr * taper[k], fi = fi * taper[k];                                              \
            const double xr = x[2 * (k * U + cindex[c])], xi = x[2 * (k * U + cindex[c]) + 1];                      \
            const double yr = xr * fr - xi * fi, yi = xr * fi + xi * fr;                                            \
            y[2 * (k * C + c)] = yr, y[2 * (k * C + c) + 1] = yi;                                                   \
            YR[s * Cp + c] = yr, YI[s * Cp + c] = yi;                                                               \
        }                                                                                                           \
    }                                                                                                               \
    if (C == 8 && isa_cap >= 2 && HAVE_AVX512) knot8_sums_avx512_##SUF(K, n_even, Q, basis, YR, YI, DC, table);     \
    else if (isa_cap >= 1 && HAVE_FMA_PATH) knot_sums_fma_##SUF(C, Cp, K, n_even, Q, basis, YR, YI, DC, table);      \
    else knot_sums_base_##SUF(C, Cp, K, n_even, Q, basis, YR, YI, DC, table);                                        \
    free(work);                                                                                                     \
    memcpy(table, table + N * C, sizeof(T) * (size_t)C);                   /* row 0 = T[N - 1] */                   \
    memcpy(table + (N + 1) * C, table + C, sizeof(T) * (size_t)(2 * C));   /* rows N + 1, N + 2 = T[0], T[1] */     \
    return 0;                                                                                                       \
}
KNOT_TABLE(float, f32)
KNOT_TABLE(double, f64)

/* ------------------------------------------------------------------------------------------ Python entry points
 * segment and knot_table are also Python functions of this module (synth_kernel.py calls them): a ctypes call costs
 * ~150 ns per argument plus ~400 ns per array address (ctypes.c_char.from_buffer), ~5 us for a segment call, more
 * than a tenth of the sample loop itself. Here the arrays come in through the buffer protocol, which also does the
 * checks that keep the kernels inside the memory they are given: C-contiguous, writeable where written, element
 * type by format and size, shapes. The GIL is released while a kernel runs (as ctypes did). */
typedef struct {
    Py_buffer v;
    int held;
} Buf;

/* Element type of a buffer: 'f' float32, 'd' float64, 'q' int64, 'Z' complex128, 0 anything else (native order). */
static char buf_kind(const Py_buffer *v)
{
    const char *f = v->format ? v->format : "B";
    if (*f == '@' || *f == '=') ++f;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    else if (*f == '<') ++f;
#endif
    if (f[0] == 'f' && f[1] == 0 && v->itemsize == 4) return 'f';
    if (f[0] == 'd' && f[1] == 0 && v->itemsize == 8) return 'd';
    if ((f[0] == 'q' || f[0] == 'l') && f[1] == 0 && v->itemsize == 8) return 'q';
    if (f[0] == 'Z' && f[1] == 'd' && f[2] == 0 && v->itemsize == 16) return 'Z';
    if (f[0] == 'h' && f[1] == 0 && v->itemsize == 2) return 'h';
    return 0;
}

/* Takes the buffer of o (C-contiguous, writeable if asked) of ndim dimensions and an element type among kinds; on
 * failure raises ValueError naming the argument and returns 0. */
static int buf_take(PyObject *o, Buf *b, const char *name, const char *kinds, int ndim, int writable)
{
    if (PyObject_GetBuffer(o, &b->v, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0)) < 0) {
        PyErr_Clear();
        PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous%s array (got %.80s)", name,
                     writable ? ", writeable" : "", Py_TYPE(o)->tp_name);
        return 0;
    }
    b->held = 1;
    const char k = buf_kind(&b->v);
    if (b->v.ndim != ndim || k == 0 || strchr(kinds, k) == NULL) {
        PyErr_Format(PyExc_ValueError, "%s must be a %d-d array of dtype %s (got %d-d, format %s)", name, ndim,
                     kinds[0] == 'f' ? "float32 or float64" : kinds[0] == 'd' ? "float64"
                     : kinds[0] == 'q' ? "int64" : kinds[0] == 'h' ? "int16" : "complex128", b->v.ndim, b->v.format ? b->v.format : "B");
        return 0;
    }
    return 1;
}

static void buf_drop(Buf *b)
{
    if (b->held) PyBuffer_Release(&b->v), b->held = 0;
}

static int log2_table(Py_ssize_t n)
{
    if (n < 64 || n > 65536 || (n & (n - 1)) != 0) return -1;
    int l = 0;
    while (((Py_ssize_t)1 << l) < n) ++l;
    return l;
}

#include "_synthknot.h"

PyDoc_STRVAR(py_segment_doc, "segment(phase0, dphase0, ddphase, warp, table_a, table_b, xi0, blend_scale, out, acc, "
                             "off, exact): see synth_kernel.segment");

static PyObject *py_segment(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 12 && nargs != 16) {
        PyErr_SetString(PyExc_TypeError, "segment takes 12 arguments (16 with noise: key, n0, sigma, extra)");
        return NULL;
    }
    uint64_t ph[3];
    for (int i = 0; i < 3; ++i) {
        ph[i] = (uint64_t)PyLong_AsUnsignedLongLongMask(args[i]);          /* modulo 2^64, any sign and size */
        if (ph[i] == (uint64_t)-1 && PyErr_Occurred()) return NULL;
    }
    const double xi0 = PyFloat_AsDouble(args[6]), blend_scale = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred()) return NULL;
    const int exact = PyObject_IsTrue(args[11]);
    if (exact < 0) return NULL;
    Buf bo = {0}, ba = {0}, bb = {0}, bw = {0}, bacc = {0}, boff = {0}, bsig = {0}, bx = {0};
    PyObject *res = NULL;
    NoiseArgs noise = {0, 0, NULL, NULL, NULL, NULL, NULL, NULL, 0, 0, 0, NULL};
    const int noisy = nargs == 16 && (args[14] != Py_None || args[15] != Py_None);
    if (noisy) {
        noise.key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[12]);
        if (noise.key == (uint64_t)-1 && PyErr_Occurred()) return NULL;
        noise.n0 = (int64_t)PyLong_AsLongLong(args[13]);
        if (noise.n0 == -1 && PyErr_Occurred()) return NULL;
    }
    if (!buf_take(args[8], &bo, "out", "fd", 2, 1) || !buf_take(args[4], &ba, "table_a", "fd", 2, 0)) goto done;
    const char kind = buf_kind(&bo.v);
    const Py_ssize_t m = bo.v.shape[0], C = bo.v.shape[1], N = ba.v.shape[0] - 3;
    if (buf_kind(&ba.v) != kind || ba.v.shape[1] != C) {
        PyErr_Format(PyExc_ValueError, "table_a must be (N + 3, %zd) of out's dtype (got (%zd, %zd), format %s)", C,
                     ba.v.shape[0], ba.v.shape[1], ba.v.format);
        goto done;
    }
    const int l2 = log2_table(N);
    if (l2 < 0) {
        PyErr_Format(PyExc_ValueError, "table size must be a power of 2 in 64..65536 (got %zd)", N);
        goto done;
    }
    if (args[5] != Py_None) {
        if (!buf_take(args[5], &bb, "table_b", "fd", 2, 0)) goto done;
        if (buf_kind(&bb.v) != kind || bb.v.shape[0] != N + 3 || bb.v.shape[1] != C) {
            PyErr_Format(PyExc_ValueError, "table_b must be (%zd, %zd) of out's dtype", N + 3, C);
            goto done;
        }
    }
    if (args[3] != Py_None) {
        if (!buf_take(args[3], &bw, "warp", "q", 1, 0)) goto done;
        if (bw.v.shape[0] != m) {
            PyErr_Format(PyExc_ValueError, "warp must be (%zd,) int64 (got (%zd,))", m, bw.v.shape[0]);
            goto done;
        }
    }
    if (args[9] != Py_None) {
        if (args[10] == Py_None) {
            PyErr_SetString(PyExc_ValueError, "off must be given with acc");
            goto done;
        }
        if (!buf_take(args[9], &bacc, "acc", "d", 2, 1) || !buf_take(args[10], &boff, "off", "d", 1, 0)) goto done;
        if (bacc.v.shape[0] != C || bacc.v.shape[1] != 6 || boff.v.shape[0] != C) {
            PyErr_Format(PyExc_ValueError, "acc must be (%zd, 6) and off (%zd,) float64", C, C);
            goto done;
        }
    }
    if (noisy && args[14] != Py_None) {
        if (!buf_take(args[14], &bsig, "sigma", "fd", 1, 0)) goto done;
        if (buf_kind(&bsig.v) != kind || bsig.v.shape[0] != C || C > NOISE_MAX_C || noise.n0 < 0) {
            PyErr_Format(PyExc_ValueError, "sigma must be (%zd,) of out's dtype, C <= %d, n0 >= 0", C, NOISE_MAX_C);
            goto done;
        }
        noise.sigma_f = (const float *)bsig.v.buf;
        noise.sigma_d = (const double *)bsig.v.buf;
    }
    if (noisy && args[15] != Py_None) {
        if (!buf_take(args[15], &bx, "extra", "fd", 2, 0)) goto done;
        if (buf_kind(&bx.v) != kind || bx.v.shape[0] != m || bx.v.shape[1] != C || C > NOISE_MAX_C) {
            PyErr_Format(PyExc_ValueError, "extra must be (%zd, %zd) of out's dtype", m, C);
            goto done;
        }
        noise.extra = bx.v.buf;
    }
    if (m > 0) {
        int rc;
        const int fb = 62 - l2;
        const NoiseArgs *na = noisy ? &noise : NULL;
        const int64_t *w = bw.held ? (const int64_t *)bw.v.buf : NULL;
        double *acc = bacc.held ? (double *)bacc.v.buf : NULL;
        const double *off = boff.held ? (const double *)boff.v.buf : NULL;
        Py_BEGIN_ALLOW_THREADS
        if (kind == 'f')
            rc = (exact ? synth_segment_generic_f32 : synth_segment_f32)(
                m, C, N, fb, ph[0], ph[1], ph[2], w, (const float *)ba.v.buf,
                bb.held ? (const float *)bb.v.buf : NULL, xi0, blend_scale, (float *)bo.v.buf, acc, off, na);
        else
            rc = synth_segment_generic_f64(m, C, N, fb, ph[0], ph[1], ph[2], w, (const double *)ba.v.buf,
                                           bb.held ? (const double *)bb.v.buf : NULL, xi0, blend_scale,
                                           (double *)bo.v.buf, acc, off, na);
        Py_END_ALLOW_THREADS
        if (rc) {
            PyErr_Format(PyExc_ValueError, "synth_segment rejected m=%zd, C=%zd, N=%zd", m, C, N);
            goto done;
        }
    }
    res = Py_None;
    Py_INCREF(res);
done:
    buf_drop(&bo), buf_drop(&ba), buf_drop(&bb), buf_drop(&bw), buf_drop(&bacc), buf_drop(&boff), buf_drop(&bsig);
    buf_drop(&bx);
    return res;
}

PyDoc_STRVAR(py_knot_table_doc, "knot_table(x, cindex, factor, scale, taper, dc, n_even, perm, basis, table, y): "
                                "see synth_kernel.knot_table");

static PyObject *py_knot_table(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 11) {
        PyErr_SetString(PyExc_TypeError, "knot_table takes 11 arguments");
        return NULL;
    }
    const Py_ssize_t n_even = PyLong_AsSsize_t(args[6]);
    if (n_even == -1 && PyErr_Occurred()) return NULL;
    Buf bx = {0}, bci = {0}, bf = {0}, bs = {0}, bt = {0}, bdc = {0}, bp = {0}, bbas = {0}, btab = {0}, by = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &bx, "x", "Z", 2, 0) || !buf_take(args[1], &bci, "cindex", "q", 1, 0)
        || !buf_take(args[2], &bf, "factor", "Z", 2, 0) || !buf_take(args[3], &bs, "scale", "d", 1, 0)
        || !buf_take(args[5], &bdc, "dc", "d", 1, 0) || !buf_take(args[7], &bp, "perm", "q", 1, 0)
        || !buf_take(args[8], &bbas, "basis", "d", 3, 0) || !buf_take(args[9], &btab, "table_out", "fd", 2, 1)
        || !buf_take(args[10], &by, "y_out", "Z", 2, 1))
        goto done;
    if (args[4] != Py_None && !buf_take(args[4], &bt, "taper", "d", 1, 0)) goto done;
    const Py_ssize_t K = bx.v.shape[0], U = bx.v.shape[1], C = bci.v.shape[0], N = btab.v.shape[0] - 3;
    if (bf.v.shape[0] != K || bf.v.shape[1] != C || bs.v.shape[0] != C || bdc.v.shape[0] != C
        || btab.v.shape[1] != C || by.v.shape[0] != K || by.v.shape[1] != C || bp.v.shape[0] != K
        || (bt.held && bt.v.shape[0] != K) || C < 1 || U < 1) {
        PyErr_Format(PyExc_ValueError, "shapes do not match x (K, U) = (%zd, %zd) and cindex (C,) = (%zd,): factor "
                     "and y_out must be (K, C), scale and dc (C,), taper (K,), table_out (N + 3, C), perm (K,)",
                     K, U, C);
        goto done;
    }
    if (log2_table(N) < 0 || bbas.v.shape[0] != (N / 4 + KNOT_JB) / KNOT_JB * KNOT_JB || bbas.v.shape[1] != K
        || bbas.v.shape[2] != 2) {
        PyErr_Format(PyExc_ValueError, "table_out must have N + 3 rows, N a power of 2 in 64..65536, and the basis "
                     "(N/4 + 1 rounded up to a multiple of %d, K, 2) (got N = %zd, basis rows %zd)", KNOT_JB, N,
                     bbas.v.shape[0]);
        goto done;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS
    if (buf_kind(&btab.v) == 'f')
        rc = synth_knot_table_f32(K, C, U, N, n_even, bx.v.buf, bci.v.buf, bf.v.buf, bs.v.buf,
                                  bt.held ? bt.v.buf : NULL, bdc.v.buf, bp.v.buf, bbas.v.buf, btab.v.buf, by.v.buf);
    else
        rc = synth_knot_table_f64(K, C, U, N, n_even, bx.v.buf, bci.v.buf, bf.v.buf, bs.v.buf,
                                  bt.held ? bt.v.buf : NULL, bdc.v.buf, bp.v.buf, bbas.v.buf, btab.v.buf, by.v.buf);
    Py_END_ALLOW_THREADS
    if (rc == -3) {
        PyErr_NoMemory();
        goto done;
    }
    if (rc) {
        PyErr_Format(PyExc_ValueError, rc == -2 ? "cindex (columns of x) or perm out of range"
                                                : "synth_knot_table rejected K=%zd, C=%zd, N=%zd, n_even=%zd",
                     K, C, N, n_even);
        goto done;
    }
    res = Py_None;
    Py_INCREF(res);
done:
    buf_drop(&bx), buf_drop(&bci), buf_drop(&bf), buf_drop(&bs), buf_drop(&bt), buf_drop(&bdc), buf_drop(&bp);
    buf_drop(&bbas), buf_drop(&btab), buf_drop(&by);
    return res;
}

PyDoc_STRVAR(py_band_rms_doc, "band_rms(va, vb, lo, hi, s) -> tuple of 4 floats: see synth_kernel.band_rms");

/* RMS of four complex channels over the rows lo .. hi-1 of the blend va + s (vb - va): va, vb (K, 8) float64 with the
 * real parts in columns 0-3 and the imaginary parts in 4-7; returns (sqrt(0.5 sum_k |v_k,c|^2) for c = 0..3). The
 * ISO 10816 velocity of a chunk (synth.Synthesizer._iso_velocity) in one call instead of ~8 numpy calls. */
static PyObject *py_band_rms(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "band_rms takes 5 arguments");
        return NULL;
    }
    const Py_ssize_t lo = PyLong_AsSsize_t(args[2]), hi = PyLong_AsSsize_t(args[3]);
    const double s = PyFloat_AsDouble(args[4]);
    if (PyErr_Occurred()) return NULL;
    Buf ba = {0}, bb = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &ba, "va", "d", 2, 0) || !buf_take(args[1], &bb, "vb", "d", 2, 0)) goto done;
    const Py_ssize_t K = ba.v.shape[0];
    if (ba.v.shape[1] != 8 || bb.v.shape[0] != K || bb.v.shape[1] != 8 || lo < 0 || hi > K || lo > hi) {
        PyErr_Format(PyExc_ValueError, "band_rms: va and vb must be (K, 8) alike and 0 <= lo <= hi <= K (got %zd x "
                     "%zd, %zd x %zd, lo %zd, hi %zd)", ba.v.shape[0], ba.v.shape[1], bb.v.shape[0], bb.v.shape[1],
                     lo, hi);
        goto done;
    }
    const double *a = ba.v.buf, *b = bb.v.buf;
    double p[8] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (Py_ssize_t k = lo; k < hi; ++k)
        for (int c = 0; c < 8; ++c) {
            const double v = a[8 * k + c] + s * (b[8 * k + c] - a[8 * k + c]);
            p[c] += v * v;
        }
    res = Py_BuildValue("(dddd)", sqrt(0.5 * (p[0] + p[4])), sqrt(0.5 * (p[1] + p[5])), sqrt(0.5 * (p[2] + p[6])),
                        sqrt(0.5 * (p[3] + p[7])));
done:
    buf_drop(&ba), buf_drop(&bb);
    return res;
}

PyDoc_STRVAR(py_features_doc, "features(acc, n, off, out): see synth_kernel.features_from_acc");

/* synth_features through the module (one call, the buffers checked here) instead of ctypes and Python checks. */
static PyObject *py_features(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "features takes 4 arguments");
        return NULL;
    }
    const Py_ssize_t n = PyLong_AsSsize_t(args[1]);
    if (n == -1 && PyErr_Occurred()) return NULL;
    Buf ba = {0}, bo = {0}, bout = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &ba, "acc", "d", 2, 0) || !buf_take(args[2], &bo, "off", "d", 1, 0)
        || !buf_take(args[3], &bout, "out", "d", 2, 1))
        goto done;
    const Py_ssize_t C = ba.v.shape[0];
    if (ba.v.shape[1] != 6 || bo.v.shape[0] != C || bout.v.shape[0] != 6 || bout.v.shape[1] != C || n < 1) {
        PyErr_Format(PyExc_ValueError, "features: acc must be (C, 6), off (C,), out (6, C) and n >= 1 (got acc %zd x "
                     "%zd, off %zd, out %zd x %zd, n %zd)", ba.v.shape[0], ba.v.shape[1], bo.v.shape[0],
                     bout.v.shape[0], bout.v.shape[1], n);
        goto done;
    }
    synth_features(C, n, ba.v.buf, bo.v.buf, bout.v.buf);
    res = Py_None;
    Py_INCREF(res);
done:
    buf_drop(&ba), buf_drop(&bo), buf_drop(&bout);
    return res;
}

static PyMethodDef methods[] = {
    {"segment", (PyCFunction)(void (*)(void))py_segment, METH_FASTCALL, py_segment_doc},
    SYNTHKNOT_METHODS
    {"knot_table", (PyCFunction)(void (*)(void))py_knot_table, METH_FASTCALL, py_knot_table_doc},
    {"band_rms", (PyCFunction)(void (*)(void))py_band_rms, METH_FASTCALL, py_band_rms_doc},
    {"features", (PyCFunction)(void (*)(void))py_features, METH_FASTCALL, py_features_doc},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_synthloop",
                                       "C kernels of the synthesiser (see bkabem_core/synth/kernel.py): segment, "
                                       "knot_table, band_rms and features here, the others loaded with ctypes", -1, methods,
                                       NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__synthloop(void) { return PyModule_Create(&moduledef); }
