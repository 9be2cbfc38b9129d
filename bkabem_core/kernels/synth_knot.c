/*
 * A line set's knot (synth_knot.h): from the displacement combinations at a knot's speed to the channel amplitudes,
 * the housing velocity of the ISO rows and every family's spline tables, in one call.
 *
 * Each amplitude is the same IEEE operation sequence as the numpy formulas of bkabem_core/synth/render.py
 * (LoopLines.knot: complex products written out as numpy does them, (a_r b_r - a_i b_i, a_r b_i + a_i b_r); one
 * factor of every product here has a zero part, so numpy's fused multiply-adds round alike). The tables are an
 * iterative radix-2 decimation-in-time inverse FFT (no 1/N) in double per family, real and imaginary parts in
 * separate planes (8 channels are one or two vectors), the input scattered straight to its bit-reversed row, each
 * butterfly's rows in locals (vector registers), and with AVX-512 two radix-2 stages per pass over the table; the
 * butterflies whose rows are all still +0 are skipped (a family fills a few percent of its table's slots; exact,
 * signs of zeros included: +0 +- (+-0) is +0, and every row that is not known to be +0 goes through every
 * butterfly). Every instruction-set path does the same butterflies in the same order: the same bits.
 */
#include "synth_knot.h"

#include <string.h>

#include "synth_common.h"

/* ------------------------------------------------------------------------------------------------ planar IFFT */
/* One radix-2 butterfly over C channels, planar (re and im rows apart). */
#define KNOT_BFLY(CC, ar, ai, br, bi, wr, wi)                                                                      \
    do {                                                                                                            \
        for (int64_t c = 0; c < (CC); ++c) {                                                                        \
            const double r_ = (br)[c], i_ = (bi)[c];                                                                \
            const double tr = r_ * (wr) - i_ * (wi), ti = r_ * (wi) + i_ * (wr);                                    \
            const double a_ = (ar)[c], e_ = (ai)[c];                                                                \
            (ar)[c] = a_ + tr, (ai)[c] = e_ + ti;                                                                   \
            (br)[c] = a_ - tr, (bi)[c] = e_ - ti;                                                                   \
        }                                                                                                           \
    } while (0)

/* The stages of an inverse FFT (input already in bit-reversed rows): re, im N x C planes, tw[2 j] = cos(2 pi j / N),
 * tw[2 j + 1] = sin(2 pi j / N). Stage len = L
 * pairs rows (s + k, s + k + L/2) with tw[k N / L]; stages L and 2 L are done together per group of four rows
 * {s + k, + L/2, + L, + 3 L/2} (k < L/2): both butterflies of stage L, then both of stage 2 L (twiddles k and
 * k + L/2 of it): every row sees the same operations in the same order as stage by stage. */
static CLONES void knot_stages(int64_t N, int64_t C, double *re, double *im, const double *tw)
{
    int64_t len = 2;
    int lg = 0;
    while (((int64_t)1 << lg) < N) ++lg;
    if (lg & 1) {
        for (int64_t s = 0; s < N; s += 2)
            KNOT_BFLY(C, re + s * C, im + s * C, re + (s + 1) * C, im + (s + 1) * C, tw[0], tw[1]);
        len = 4;
    }
    for (; len <= N; len <<= 2) {
        const int64_t h = len >> 1, st1 = N / len, st2 = st1 >> 1;
        for (int64_t s = 0; s < N; s += 2 * len)
            for (int64_t k = 0; k < h; ++k) {
                double *r0 = re + (s + k) * C, *i0 = im + (s + k) * C;
                double *r1 = r0 + h * C, *i1 = i0 + h * C;
                double *r2 = r0 + len * C, *i2 = i0 + len * C;
                double *r3 = r2 + h * C, *i3 = i2 + h * C;
                const double w1r = tw[2 * k * st1], w1i = tw[2 * k * st1 + 1];
                KNOT_BFLY(C, r0, i0, r1, i1, w1r, w1i);
                KNOT_BFLY(C, r2, i2, r3, i3, w1r, w1i);
                KNOT_BFLY(C, r0, i0, r2, i2, tw[2 * k * st2], tw[2 * k * st2 + 1]);
                KNOT_BFLY(C, r1, i1, r3, i3, tw[2 * (k + h) * st2], tw[2 * (k + h) * st2 + 1]);
            }
    }
}

/* knot_stages for C = 8 stage by stage, each butterfly on 4-lane vectors (4 channels of a row's plane; AVX2: 8
 * registers; locals copied through memory would stall store forwarding). */
static CLONES void knot_stages8_r2(int64_t N, double *restrict re, double *restrict im, const double *restrict tw,
                                  uint8_t *restrict nz)
{
    for (int64_t len = 2; len <= N; len <<= 1) {
        const int64_t h = len >> 1, st = N / len;
        for (int64_t s = 0; s < N; s += len)
            for (int64_t k = 0; k < h; ++k) {
                if (!(nz[s + k] | nz[s + k + h])) continue;        /* both rows +0: they stay +0 */
                nz[s + k] = nz[s + k + h] = 1;
                const double wr = tw[2 * k * st], wi = tw[2 * k * st + 1];
                for (int64_t half = 0; half < 8; half += 4) {
                    const int64_t o0 = 8 * (s + k) + half, o1 = o0 + 8 * h;
                    v4d ar, ai, br, bi;
                    memcpy(&ar, re + o0, 32), memcpy(&ai, im + o0, 32), memcpy(&br, re + o1, 32);
                    memcpy(&bi, im + o1, 32);
                    const v4d tr = br * wr - bi * wi, ti = br * wi + bi * wr;
                    const v4d a0 = ar + tr, a1 = ai + ti, b0 = ar - tr, b1 = ai - ti;
                    memcpy(re + o0, &a0, 32), memcpy(im + o0, &a1, 32), memcpy(re + o1, &b0, 32);
                    memcpy(im + o1, &b1, 32);
                }
            }
    }
}

/* knot_stages8_r2 for C = 4 (acc4): one 4-lane vector per row's plane, the same operations per lane (the same bits
 * as the 8-channel stages give their first 4 lanes), the rows that are still +0 skipped likewise. */
static CLONES void knot_stages4_r2(int64_t N, double *restrict re, double *restrict im, const double *restrict tw,
                                  uint8_t *restrict nz)
{
    for (int64_t len = 2; len <= N; len <<= 1) {
        const int64_t h = len >> 1, st = N / len;
        for (int64_t s = 0; s < N; s += len)
            for (int64_t k = 0; k < h; ++k) {
                if (!(nz[s + k] | nz[s + k + h])) continue;        /* both rows +0: they stay +0 */
                nz[s + k] = nz[s + k + h] = 1;
                const double wr = tw[2 * k * st], wi = tw[2 * k * st + 1];
                const int64_t o0 = 4 * (s + k), o1 = o0 + 4 * h;
                v4d ar, ai, br, bi;
                memcpy(&ar, re + o0, 32), memcpy(&ai, im + o0, 32), memcpy(&br, re + o1, 32);
                memcpy(&bi, im + o1, 32);
                const v4d tr = br * wr - bi * wi, ti = br * wi + bi * wr;
                const v4d a0 = ar + tr, a1 = ai + ti, b0 = ar - tr, b1 = ai - ti;
                memcpy(re + o0, &a0, 32), memcpy(im + o0, &a1, 32), memcpy(re + o1, &b0, 32);
                memcpy(im + o1, &b1, 32);
            }
    }
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define HAVE_KNOT_AVX512 (synth_isa_cap >= 2 && __builtin_cpu_supports("avx512f"))
/* knot_stages for C = 8 with AVX-512 (32 vector registers): two stages per pass, each group's four rows loaded into
 * locals (16 registers), its four butterflies, stored back (AVX2's 16 registers would spill). */
typedef double knot_v8d __attribute__((vector_size(64)));
#define KNOT_V8_BFLY(AR, AI, BR, BI, WR, WI)                                                                        \
    do {                                                                                                            \
        const knot_v8d tr_ = BR * (WR) - BI * (WI), ti_ = BR * (WI) + BI * (WR);                                    \
        const knot_v8d a_ = AR, e_ = AI;                                                                            \
        AR = a_ + tr_, AI = e_ + ti_, BR = a_ - tr_, BI = e_ - ti_;                                                 \
    } while (0)

static NOINLINE __attribute__((target("avx512f"))) void knot_stages8_avx512(int64_t N, double *restrict re,
                                                                            double *restrict im,
                                                                            const double *restrict tw,
                                                                            uint8_t *restrict nz)
{
    int lg = 0;
    while (((int64_t)1 << lg) < N) ++lg;
    int64_t len = 2;
    if (lg & 1) {
        for (int64_t s = 0; s < N; s += 2) {
            if (!(nz[s] | nz[s + 1])) continue;
            nz[s] = nz[s + 1] = 1;
            knot_v8d R0, I0, R1, I1;
            memcpy(&R0, re + 8 * s, 64), memcpy(&I0, im + 8 * s, 64);
            memcpy(&R1, re + 8 * s + 8, 64), memcpy(&I1, im + 8 * s + 8, 64);
            KNOT_V8_BFLY(R0, I0, R1, I1, tw[0], tw[1]);
            memcpy(re + 8 * s, &R0, 64), memcpy(im + 8 * s, &I0, 64);
            memcpy(re + 8 * s + 8, &R1, 64), memcpy(im + 8 * s + 8, &I1, 64);
        }
        len = 4;
    }
    for (; len <= N; len <<= 2) {
        const int64_t h = len >> 1, st1 = N / len, st2 = st1 >> 1;
        for (int64_t s = 0; s < N; s += 2 * len)
            for (int64_t k = 0; k < h; ++k) {
                uint8_t *z0 = nz + s + k, *z1 = z0 + h, *z2 = z0 + len, *z3 = z2 + h;
                if (!(*z0 | *z1 | *z2 | *z3)) continue;
                *z0 = *z1 = *z2 = *z3 = 1;
                const int64_t o0 = 8 * (s + k), o1 = o0 + 8 * h, o2 = o0 + 8 * len, o3 = o2 + 8 * h;
                knot_v8d R0, I0, R1, I1, R2, I2, R3, I3;
                memcpy(&R0, re + o0, 64), memcpy(&I0, im + o0, 64), memcpy(&R1, re + o1, 64);
                memcpy(&I1, im + o1, 64), memcpy(&R2, re + o2, 64), memcpy(&I2, im + o2, 64);
                memcpy(&R3, re + o3, 64), memcpy(&I3, im + o3, 64);
                const double w1r = tw[2 * k * st1], w1i = tw[2 * k * st1 + 1];
                KNOT_V8_BFLY(R0, I0, R1, I1, w1r, w1i);
                KNOT_V8_BFLY(R2, I2, R3, I3, w1r, w1i);
                KNOT_V8_BFLY(R0, I0, R2, I2, tw[2 * k * st2], tw[2 * k * st2 + 1]);
                KNOT_V8_BFLY(R1, I1, R3, I3, tw[2 * (k + h) * st2], tw[2 * (k + h) * st2 + 1]);
                memcpy(re + o0, &R0, 64), memcpy(im + o0, &I0, 64), memcpy(re + o1, &R1, 64);
                memcpy(im + o1, &I1, 64), memcpy(re + o2, &R2, 64), memcpy(im + o2, &I2, 64);
                memcpy(re + o3, &R3, 64), memcpy(im + o3, &I3, 64);
            }
    }
}
#else
#define HAVE_KNOT_AVX512 0
static void knot_stages8_avx512(int64_t N, double *re, double *im, const double *tw, uint8_t *nz)
{
    (void)N, (void)re, (void)im, (void)tw, (void)nz;
}
#endif


/* The padded float table (n + 3) x C of a plane: row r holds row (r - 1) mod n. */
static CLONES void knot_store(int64_t n, int64_t C, const double *restrict src, float *restrict dst)
{
    for (int64_t c = 0; c < C; ++c) dst[c] = (float)src[(n - 1) * C + c];
    for (int64_t i = 0; i < n * C; ++i) dst[C + i] = (float)src[i];
    for (int64_t i = 0; i < 2 * C; ++i) dst[(n + 1) * C + i] = (float)src[i];
}

/* ------------------------------------------------------------------------------------------------ a knot */
/* Complex product as numpy computes it: (a_r b_r - a_i b_i, a_r b_i + a_i b_r). */
#define CMUL(ar, ai, br, bi, outr, outi)                                                                            \
    do {                                                                                                            \
        const double ar_ = (ar), ai_ = (ai), br_ = (br), bi_ = (bi);                                                \
        outr = ar_ * br_ - ai_ * bi_;                                                                               \
        outi = ar_ * bi_ + ai_ * br_;                                                                               \
    } while (0)

/* y, v_iso, tables of one knot (see the top). x L x U complex (scaled in place by spow, L, if given), f [Hz],
 * fade, taper (L, or NULL), y L x C complex, viso L x 8 [Re of the 4 ISO rows | Im], table the families' tables,
 * work >= 2 max_n C doubles. */
#define KNOT_CHANNELS(CC)                                                                                           \
    for (int64_t c = 0; c < (CC); ++c) {                                                                            \
        double fr, fi;                                              /* powers[p].T * (scale * fade) [* taper] */    \
        const int64_t q = pw[c];                                                                                    \
        CMUL(pr[q], pi[q], sc[c], 0.0, fr, fi);                                                                     \
        if (taper != NULL) CMUL(fr, fi, taper[k], 0.0, fr, fi);                                                     \
        const int64_t u = ci[c];                                                                                    \
        CMUL(xk[2 * u], xk[2 * u + 1], fr, fi, yk[2 * c], yk[2 * c + 1]);                                           \
    }

NOINLINE CLONES void lines_knot(const KnotPlan *p, int64_t U, double *x, double f, double fade,
                                       const double *taper, const double *spow, double *y, double *viso,
                                       float *table, double *work, uint8_t *nz)
{
    const int64_t L = p->L, C = p->C;
    double sc[KNOT_MAX_C];
    int64_t pw[KNOT_MAX_C], ci[KNOT_MAX_C];
    for (int64_t c = 0; c < C; ++c) sc[c] = p->scale[c] * fade, pw[c] = p->power[c], ci[c] = p->cindex[c];
    for (int64_t k = 0; k < L; ++k) {
        double *xk = x + 2 * k * U;
        if (spow != NULL)                                           /* x *= (f ** speed_power)[:, None] */
            for (int64_t u = 0; u < U; ++u) {
                double r, i;
                CMUL(xk[2 * u], xk[2 * u + 1], spow[k], 0.0, r, i);
                xk[2 * u] = r, xk[2 * u + 1] = i;
            }
        const double w = p->two_pi * (p->nu[k] * f + p->mu[k]);     /* w = 2 pi (nu f + mu) */
        double pr[3], pi[3];                                        /* (i w)^p: 1, 1j * w, iw * iw */
        pr[0] = 1.0, pi[0] = 0.0;
        CMUL(0.0, 1.0, w, 0.0, pr[1], pi[1]);
        CMUL(pr[1], pi[1], pr[1], pi[1], pr[2], pi[2]);
        double *yk = y + 2 * k * C;
        if (C == 8) KNOT_CHANNELS(8)
        else KNOT_CHANNELS(C)
        /* housing velocity [mm/s]: x[:, iso] * (1j * w * 1e3 * weights) */
        double vr, vi;
        CMUL(0.0, 1.0, w, 0.0, vr, vi);
        CMUL(vr, vi, 1e3, 0.0, vr, vi);
        CMUL(vr, vi, taper != NULL ? fade * taper[k] : fade * 1.0, 0.0, vr, vi);
        for (int i = 0; i < 4; ++i) {
            const int64_t u = p->iso[i];
            CMUL(xk[2 * u], xk[2 * u + 1], vr, vi, viso[8 * k + i], viso[8 * k + 4 + i]);
        }
    }
    /* the families' tables: per family an inverse FFT of its lines placed at their slots, planar */
    int64_t q = 0;
    for (int64_t fam = 0; fam < p->F; ++fam) {
        const int64_t n = p->N[fam];
        int lgn = 0;
        while (((int64_t)1 << lgn) < n) ++lgn;
        double *re = work, *im = work + n * C;
        memset(work, 0, sizeof(double) * (size_t)(2 * n * C));
        memset(nz, 0, (size_t)n);
        for (int64_t i = 0; i < p->n_lines[fam]; ++i, ++q) {
            const int64_t l = p->line[q], s = p->slot[q];
            int64_t r = 0;                                          /* bit-reversed row of slot s */
            for (int b = 0; b < lgn; ++b) r |= ((s >> b) & 1) << (lgn - 1 - b);
            nz[r] = 1;
            const double g = p->factor[q] < 0 ? -p->factor[q] : p->factor[q], conj = p->factor[q] < 0 ? -1.0 : 1.0;
            const double *yl = y + 2 * l * C;
            for (int64_t c = 0; c < C; ++c) {
                re[r * C + c] += g * yl[2 * c];
                im[r * C + c] += conj * g * yl[2 * c + 1];
            }
        }
        if (C == 8 && HAVE_KNOT_AVX512) knot_stages8_avx512(n, re, im, p->tw + p->tw_off[fam], nz);
        else if (C == 8) knot_stages8_r2(n, re, im, p->tw + p->tw_off[fam], nz);
        else if (C == 4) knot_stages4_r2(n, re, im, p->tw + p->tw_off[fam], nz);
        else knot_stages(n, C, re, im, p->tw + p->tw_off[fam]);
        float *tr = table + p->offset[fam];
        knot_store(n, C, re, tr);
        if (p->carrier[fam]) knot_store(n, C, im, tr + (n + 3) * C);
    }
}

const char *knot_plan_check(const KnotPlan *p, int64_t n_line_entries, int64_t n_tw, int64_t U)
{
    if (p->F < 1 || p->C < 1 || p->C > KNOT_MAX_C || U < 1) return "lengths: F families, L lines, C channels";
    for (int64_t c = 0; c < p->C; ++c)
        if (p->cindex[c] < 0 || p->cindex[c] >= U || p->power[c] < 0 || p->power[c] > 2)
            return "cindex in 0 .. U-1, power in 0 .. 2";
    for (int i = 0; i < 4; ++i)
        if (p->iso[i] < 0 || p->iso[i] >= U) return "iso rows in 0 .. U-1";
    int64_t total = 0;
    for (int64_t f = 0; f < p->F; ++f) {
        const int64_t n = p->N[f];
        if (n < 4 || n > 65536 || (n & (n - 1)) != 0 || p->n_lines[f] < 0 || p->tw_off[f] < 0
            || p->tw_off[f] + n > n_tw || p->offset[f] < 0)
            return "table sizes (powers of 2), twiddle offsets";
        for (int64_t i = total; i < total + p->n_lines[f]; ++i)
            if (i >= n_line_entries || p->line[i] < 0 || p->line[i] >= p->L || p->slot[i] < 0 || p->slot[i] >= n)
                return "lines in 0 .. L-1 and slots in 0 .. N-1 of their family";
        total += p->n_lines[f];
    }
    return total == n_line_entries ? NULL : "line, slot and factor: one entry per line of a family";
}

void knot_plan_sizes(KnotPlan *p)
{
    p->table_floats = p->max_n = 0;
    for (int64_t f = 0; f < p->F; ++f) {
        const int64_t end = p->offset[f] + (p->N[f] + 3) * p->C * (p->carrier[f] ? 2 : 1);
        if (end > p->table_floats) p->table_floats = end;
        if (p->N[f] > p->max_n) p->max_n = p->N[f];
    }
}
