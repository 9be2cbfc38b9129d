/* The random-slip warp of a segment (synth_slip.h). */
#include "synth_slip.h"

#include <string.h>

#include "synth_common.h"

/* Random-slip warp of one segment (bkabem_core/synth/randomness.py, SlipWalk.warp_fixed): for sample i < m at xi = j0 + i, the ball
 * passes u = (c2 xi + c1) xi + u_frac since the knot (speed >= 0 in a segment, so u does not decrease), the walk W
 * at u by the C1 cubic Hermite spline of its values w[k] at passes jw0 + k (Catmull-Rom slopes
 * m_k = (w[k+1] - w[k-1]) / 2), written per pass interval [j, j + 1) as the cubic in t = u - j
 *     W = ((a3 t + a2) t + a1) t + a0,  a0 = w_j, a1 = m_j, a2 = 3 (w_{j+1} - w_j) - 2 m_j - m_{j+1},
 *     a3 = 2 (w_j - w_{j+1}) + m_j + m_{j+1},
 * and for each of the K factors kappa the phase offset in the loop's fixed point, out[k m + i] =
 * rint(y 2^52) 2^10 with y = kappa W - rint(kappa W) (a fraction of a pass in [-1/2, 1/2], to 2^-52). The
 * coefficients change once per pass (~100-400 samples), so the samples of an interval are a Horner step of 4
 * doubles at a time with AVX2; rint(y 2^52) is exact by adding and subtracting 1.5 2^52 (|y 2^52| < 2^51), and the
 * integer is the bits of that sum less those of 1.5 2^52, so AVX2 needs no 64-bit conversion. Scalar and AVX2 code
 * do the same double operations (no contraction), so they agree bit for bit, and with kernel.slip_warp_reference.
 * Returns -1 if a sample falls outside w or K is out of 1..8. */
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

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
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
    if (synth_isa_cap >= 1 && HAVE_WARP_AVX2) return warp_avx2(m, j0, c1, c2, u_frac, w, nw, jw0, kappa, (int)K, out);
    int64_t k = -1;
    double a[4] = {0, 0, 0, 0};
    return warp_scalar_range(0, m, j0, c1, c2, u_frac, w, nw, jw0, kappa, (int)K, m, out, &k, a);
}

int synth_slip_value(double xi, double c1, double c2, double u_frac, const double *w, int64_t nw, int64_t jw0,
                     double *out)
{
    const double u = (c2 * xi + c1) * xi + u_frac;
    if (nw < 4 || !(u >= 0.0 && u < 9.0e15)) return -1;
    const int64_t k = warp_interval(u, jw0, nw);
    if (k < 0) return -1;
    double a[4];
    warp_coefficients(w, k, a);
    const double t = u - (double)(k + jw0);
    *out = ((a[3] * t + a[2]) * t + a[1]) * t + a[0];
    return 0;
}
