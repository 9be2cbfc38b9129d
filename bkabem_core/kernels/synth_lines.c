/*
 * Any line set in one pass (synth_lines.h): the samples of a segment summed over all families, with the static
 * part, the sensor noise, the broadband floor and the chunk features fused.
 *
 * Per block of samples, every family's table row index and spline weights from its own fixed-point phase (+ its
 * slip offsets), the two knots' tables blended in time, and for a carrier family cos and sin of its carrier phase
 * (+ slip) from 24 bits of the turn: octant, then Cephes' sinf / cosf polynomials on [0, pi/4] (error ~1e-7), so
 * x += cos(2 pi phi_q) Re G - sin(2 pi phi_q) Im G; then the static part, the noise and the features of the block.
 * Float32, any C (the channel loops are unrolled for C = 8). With 8 (or 4: 128-bit lanes, the same operations per
 * lane) channels and AVX2 + FMA, families of one phase share the rows and weights and the carriers' cos / sin are
 * 8 samples at a time (synth_rows.c); a carrier that is the sum of two others of its group (csrc) takes its cos /
 * sin from theirs by the angle addition (carrier_sum).
 */
#include "synth_lines.h"

#include <math.h>
#include <string.h>

#include "synth_block.h"
#include "synth_common.h"
#include "synth_floor.h"
#include "synth_rows.h"
#include "synth_slip.h"
#include "synth_strike.h"

/* One segment of a line set: m samples x C channels into out (written). Per family f (F of them): phases[f] =
 * {phase0, dphase0, ddphase} of the family phase and {...} of its carrier (uint64, the sample loop's fixed point),
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
            float *o = dst + (int64_t)j * (CC);                                                                     \
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
 * cos a sin b), for a family whose carrier is the sum of two others of its group (csrc; lines.carrier_sums):
 * 6 operations a sample instead of a phase and two polynomials. Not the bits of the direct cos / sin: within a few
 * float32 roundings of them. */
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
 * group). The slip rows a render computes follow it (a summed carrier's own row is not needed). */
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


#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(BKABEM_NO_SIMD)
#define HAVE_LINES8 HAVE_FMA_PATH
#else
#define HAVE_LINES8 0
#endif

/* 1 if lines_segment_f32 takes the fast path (groups, carrier sums) for C channels on this CPU now. */
static int lines_fast_path(int64_t C)
{
    return (C == 8 || C == 4) && synth_isa_cap >= 1 && HAVE_LINES8 && HAVE_GROUP8;
}

/* need[i] = 1 for the slip rows 0 .. K-1 that lines_segment_f32 reads for these families: every family's phase row,
 * and the carrier rows of the carriers it computes from their own phase (on the fast path not those of the carrier
 * sums), so that a render computes no row for nothing. */
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
                                    const double *off, const NoiseArgs *na, const int64_t *strike, int64_t sfam,
                                    StrikeState *ss)
{
    int32_t idx[BLOCK], frac[BLOCK];
    float W0[BLOCK], W1[BLOCK], W2[BLOCK], W3[BLOCK], sw[BLOCK], CQ[BLOCK], SQ[BLOCK], gain[BLOCK];
    float blk[BLOCK * LINES_MAX_C], flr[BLOCK * LINES_MAX_C];
    float gblk[BLOCK * LINES_MAX_C];                     /* the struck families' sum, before their strikes' gain */
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
        /* the static part first: a constant row length for 8 and 4 channels, so that the copy vectorises */
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
        if (ss != NULL) {                   /* the strikes' gain from the struck phase, before the families advance it */
            strike_block(nb, st[sfam][0], st[sfam][1], phases[6 * sfam + 2],
                         wp[sfam] >= 0 ? warp + wp[sfam] * m + k0 : NULL, ss, gain);
            memset(gblk, 0, sizeof(float) * (size_t)(nb * C));
        }
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
                             SQg, ss != NULL && strike[f0] ? gblk : blk);
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
            float *dst = ss != NULL && strike[f] ? gblk : blk;
            if (C == 8) LINES_ROWS(8);
            else LINES_ROWS(C);
        }
        if (ss != NULL) {                                        /* the struck families times their strikes' gain */
            if (C == 8)                                 /* a sample's row a vector, its gain broadcast */
                for (int j = 0; j < nb; ++j) {
                    v8f32 o, v;
                    const float g = gain[j];
                    memcpy(&o, blk + 8 * j, sizeof o);
                    memcpy(&v, gblk + 8 * j, sizeof v);
                    o += (v8f32){g, g, g, g, g, g, g, g} * v;
                    memcpy(blk + 8 * j, &o, sizeof o);
                }
            else if (C == 4)
                for (int j = 0; j < nb; ++j) {
                    v4f32 o, v;
                    const float g = gain[j];
                    memcpy(&o, blk + 4 * j, sizeof o);
                    memcpy(&v, gblk + 4 * j, sizeof v);
                    o += (v4f32){g, g, g, g} * v;
                    memcpy(blk + 4 * j, &o, sizeof o);
                }
            else
                for (int j = 0; j < nb; ++j)
                    for (int64_t c = 0; c < C; ++c) blk[j * C + c] += gain[j] * gblk[j * C + c];
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

/* Python's round(v) of a double as int64 (half to even, = rint in the default rounding mode); -1 if |v| is beyond
 * int64. */
static inline int round_i64(double v, int64_t *out)
{
    if (!(fabs(v) < 9.2e18)) return -1;
    *out = (int64_t)nearbyint(v);
    return 0;
}

const char *lines_plan_check(LinesPlan *p)
{
    if (p->F < 1 || p->F > LINES_MAX_F || p->K < 0 || p->K > 128)
        return "lengths: F <= 64 families, K <= 128 slip factors";
    if (!(p->strike_sigma >= 0.0 && p->strike_sigma <= 10.0) || !(p->strike_offset >= 0.0 && p->strike_offset < 1.0))
        return "strikes: sigma in 0 .. 10, offset in [0, 1) turns";
    p->strike_family = -1;
    for (int64_t f = 0; f < p->F; ++f) {
        if (p->strike[f] == 0) continue;
        const int64_t g = p->strike_family;
        if (g < 0) {
            p->strike_family = f;
            continue;
        }
        if (p->wp[f] != p->wp[g] || memcmp(p->consts + 8 * f, p->consts + 8 * g, 4 * sizeof(double)) != 0)
            return "strikes: the struck families must share one phase (its constants and slip row)";
    }
    for (int64_t f = 0; f < p->F; ++f)
        if (p->lg[f] < 6 || p->lg[f] > 16 || p->offset[f] < 0 || p->wp[f] < -1 || p->wp[f] >= p->K
            || p->wq[f] < -1 || p->wq[f] >= p->K)
            return "log2 table sizes in 6 .. 16, slip rows in -1 .. K-1";
    for (int64_t k = 0; k < p->K; ++k)
        if (p->walks[k] < 0 || p->walks[k] >= p->n_walks) return "slip walks in 0 .. n_walks - 1";
    for (int64_t f = 0; f < p->F; ++f) {
        const int64_t a = p->csrc[2 * f], b = p->csrc[2 * f + 1];
        if ((a < 0) != (b < 0) || a < -1 || b < -1 || a >= p->F || b >= p->F || a == f || b == f
            || (a >= 0 && (!p->carrier[f] || !p->carrier[a] || !p->carrier[b])))
            return "carrier sources: -1, -1 or two other families with carriers, for a family with one";
    }
    char done[LINES_MAX_F];             /* no cycle: every summed carrier resolves to carriers of their own phase */
    int left = 0;
    for (int64_t f = 0; f < p->F; ++f) done[f] = p->csrc[2 * f] < 0, left += !done[f];
    for (int pass = 0; left > 0 && pass < p->F; ++pass)
        for (int64_t f = 0; f < p->F; ++f)
            if (!done[f] && done[p->csrc[2 * f]] && done[p->csrc[2 * f + 1]]) done[f] = 1, --left;
    return left > 0 ? "carrier sources: a cycle" : NULL;
}

int lines_render(const LinesPlan *p, int64_t m, int64_t C, int64_t j, double fa, double fb, int64_t xa,
                 int64_t length, double ua, double fs, const float *ta, const float *tb, const double *w, int64_t nw,
                 int64_t jw0, double c1u, double c2u, double u_frac, int64_t *warp, const float *dc, float *out,
                 double *acc, const double *off, uint64_t key, int64_t n0, const float *sigma, const float *extra,
                 const FloorSource *fl, uint64_t strike_key)
{
    if (m < 0 || length < 1 || C < 1 || C > LINES_MAX_C || (acc != NULL && off == NULL)) return -1;
    const int slip = w != NULL;
    for (int64_t f = 0; f < p->F; ++f)                      /* a slip row needs the walk (else: out of bounds) */
        if (!slip && (p->wp[f] >= 0 || p->wq[f] >= 0)) return -1;
    if (fl != NULL && (extra != NULL || fl->win == NULL || fl->grains == NULL || fl->scale == NULL
                       || fl->n_grains < 0 || fl->half < 1 || fl->frame_length < 2 * fl->half))
        return -1;
    /* every family's phase and carrier at sample j of the segment (render.phase_args, the same double operations,
     * Python's round() is rint here) */
    uint64_t ph[6 * LINES_MAX_F];
    const double dfa = fb - fa, fsl = fs * (double)length, xs = (double)xa / fs;
    const int64_t jj = j * (j - 1) / 2;
    for (int64_t f = 0; f < p->F; ++f)
        for (int side = 0; side < 2; ++side) {
            uint64_t *o = ph + 6 * f + 3 * side;
            if (side == 1 && !p->carrier[f]) {
                o[0] = o[1] = o[2] = 0;
                continue;
            }
            const double *k = p->consts + 8 * f + 4 * side;
            const double r_b = k[0], fixed = k[1], rate = k[2], hf = k[3];
            const double t = r_b * ua + fixed * xs;
            const double t0 = t - floor(t);
            const double c1 = (rate * fa + fixed) / fs;
            const double c2 = hf * dfa / fsl;
            int64_t d0, dd, u0;
            if (round_i64((c1 + c2) * 4611686018427387904.0, &d0) || round_i64(2.0 * c2 * 4611686018427387904.0, &dd)
                || round_i64(t0 * 4611686018427387904.0, &u0))
                return -2;
            o[0] = (uint64_t)u0 + (uint64_t)j * (uint64_t)d0 + (uint64_t)dd * (uint64_t)jj;
            o[1] = (uint64_t)d0 + (uint64_t)j * (uint64_t)dd;
            o[2] = (uint64_t)dd;
        }
    int64_t nwk = 0;
    if (slip) {                          /* the slip rows read, in runs of at most 8 of one walk */
        char need[128];
        if (nw % p->n_walks) return -1;
        nwk = nw / p->n_walks;
        lines_rows_needed(p->F, C, ph, p->lg, p->carrier, p->csrc, p->wp, p->wq, p->K, need);
        for (int64_t i = 0, e; i < p->K; i = e) {
            if (!need[i]) {
                e = i + 1;
                continue;
            }
            for (e = i + 1; e < p->K && e < i + 8 && need[e] && p->walks[e] == p->walks[i]; ++e) {}
            if (synth_slip_warp(m, (double)j, c1u, c2u, u_frac, w + p->walks[i] * nwk, nwk, jw0, p->kappas + i, e - i,
                                warp + i * m))
                return -3;
        }
    }
    /* the strike passed at sample j: the struck phase's integer turns less the offset, from its double value (the
     * knot's ball passes, the advance since, the slip walk) made to agree with the loop's fixed point, whose
     * fraction decides where a turn ends */
    StrikeState strikes, *ss = NULL;
    const int64_t g = p->strike_family;
    if (g >= 0 && p->strike_sigma > 0.0 && m > 0) {
        const double *k = p->consts + 8 * g;
        const double c1 = (k[2] * fa + k[1]) / fs, c2 = k[3] * dfa / fsl, jd = (double)j;
        double x = k[0] * ua + k[1] * xs + (c1 + c2 * jd) * jd - p->strike_offset;
        uint64_t psi = ph[6 * g];
        if (p->wp[g] >= 0) {
            double walk;
            if (synth_slip_value(jd, c1u, c2u, u_frac, w + p->walks[p->wp[g]] * nwk, nwk, jw0, &walk)) return -3;
            x += p->kappas[p->wp[g]] * walk;
            psi += (uint64_t)warp[p->wp[g] * m];
        }
        const uint64_t off_fixed = (uint64_t)llround(p->strike_offset * 4611686018427387904.0);
        psi -= off_fixed;
        const double f0 = (double)(psi & ((UINT64_C(1) << 62) - 1)) * 0x1.0p-62;
        if (!(fabs(x) < 4.0e15)) return -2;
        const double sg = p->strike_sigma;
        strikes = (StrikeState){strike_key, off_fixed, sg, 2.0 * (1.0 - exp(-0.25 * sg * sg)), llround(x - f0),
                                (int)(psi >> 62), INT64_MIN, 1.0, 1.0};
        ss = &strikes;
    }
    NoiseArgs na = {key, n0, sigma, NULL, extra, NULL, NULL, NULL, 0, 0, 0, NULL};
    if (fl != NULL) {
        na.frames = fl->frames, na.win = fl->win, na.grains = fl->grains, na.n_grains = fl->n_grains;
        na.half = fl->half, na.frame_length = fl->frame_length, na.floor_scale = fl->scale;
    }
    const int noisy = sigma != NULL || extra != NULL || fl != NULL;
    return lines_segment_f32(m, C, p->F, ph, p->lg, p->carrier, p->csrc, p->offset, ta, tb, slip ? warp : NULL,
                             p->wp, p->wq, dc, (double)j, 65536.0 / (double)length, out, acc, off,
                             noisy ? &na : NULL, p->strike, g, ss);
}
