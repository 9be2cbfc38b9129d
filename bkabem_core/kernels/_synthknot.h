/*
 * A line set's knot and segment as single calls of the extension module (included by _synthloop.c after the Python
 * entry helpers; synth_lines.py and synth_kernel.py drive them).
 *
 * Why: the line-set path (synth_lines.LineSetPath) spent more Python per chunk than its C kernels took: per knot ~15
 * numpy temporaries for the channel amplitudes and a ctypes call with 15 pointers for the family tables, per
 * segment a Python loop over the families' phases and a ctypes call with 29 arguments, per chunk the ISO velocity
 * in numpy (~100-250 us per chunk in all, against ~50 us of the order path). Here the constant arrays go into a plan
 * (a capsule made once per line set, holding the arrays' buffers) and a knot or a segment is one call:
 *
 * lines_knot (per knot): the speed cells' displacement combinations x (L x U) scaled by the lines' speed powers,
 * the channel amplitudes y = x[:, cindex] (i w)^p scale fade taper, the housing velocity of the ISO 10816 rows and
 * every family's spline tables. Each value is the same IEEE operation sequence as the numpy code it replaces
 * (synth_lines.LineSetPath._line_amplitudes: complex products written out as numpy does them, (a_r b_r - a_i b_i,
 * a_r b_i + a_i b_r); one factor of every product here has a zero part, so numpy's fused multiply-adds round alike),
 * and the tables are synth_family_tables' FFT (_synthlines.h) with the same butterflies in the same order, only laid
 * out for speed: real and imaginary parts in separate planes (8 channels are one or two vectors), the input scattered
 * straight to its bit-reversed row, each butterfly's rows in locals (vector registers), and with AVX-512 two radix-2
 * stages per pass over the table (a group of 4 rows takes its 4 butterflies of both stages in registers), and
 * butterflies whose rows are all still +0 skipped (a family fills 2-17 % of its table's slots: 20-30 % of the
 * butterflies of an inner race's or a ball's tables; exact, signs of zeros included: +0 +- (+-0) is +0, and every
 * row that is not known to be +0 goes through every butterfly as before): the same tables, ~2x faster than
 * synth_family_tables.
 *
 * lines_render (per segment): the fixed-point phase of every family and its carrier at the segment's first sample
 * (synth_lines.LineSetPath._phase_args: the same double operations, Python's round() is rint here), the slip
 * offsets of every distinct slip factor (synth_slip_warp over the walk's values given), then
 * synth_lines_segment_f32 (_synthlines.h) with the noise and the floor.
 *
 * band_rms_lines (per chunk): the ISO 10816 velocity RMS of the lines in the band at the chunk's mid speed.
 */
#ifndef BKABEM_SYNTHKNOT_H
#define BKABEM_SYNTHKNOT_H

/* ------------------------------------------------------------------------------------------------ planar IFFT */
/* One radix-2 butterfly of synth_family_tables' ifft_channels over C channels, planar (re and im rows apart). */
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

/* The stages of ifft_channels (input already in bit-reversed rows): re, im N x C planes, tw as there. Stage len = L
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

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(SYNTHLOOP_NO_CLONES)
#define HAVE_KNOT_AVX512 (isa_cap >= 2 && HAVE_AVX512)
/* knot_stages for C = 8 with AVX-512 (32 vector registers): two stages per pass, each group's four rows loaded into
 * locals (16 registers), its four butterflies, stored back. (With AVX2's 16 registers this spills: 3x slower.) */
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

/* ------------------------------------------------------------------------------------------------ plans */
/* The constant arrays of a line set's knots (lines_knot_plan) or segments (lines_segment_plan), their buffers held
 * by the capsule until it goes. */
#define KNOT_PLAN_ARRAYS 15
typedef struct {
    Buf b[KNOT_PLAN_ARRAYS];
    int64_t F, C, L, max_n, table_floats;
    double two_pi;
    const int64_t *n_lines, *line, *slot, *N, *tw_off, *carrier, *out_off, *cindex, *power, *iso;
    const double *factor, *tw, *nu, *mu, *scale;
} KnotPlan;

#define SEG_PLAN_ARRAYS 8
typedef struct {
    Buf b[SEG_PLAN_ARRAYS];
    int64_t F, K, table_floats;
    const int64_t *lg, *carrier, *off_t, *wp, *wq;
    const double *consts, *kappas;     /* per family (rate / BPFO, fixed, rate, rate / 2) of its phase and carrier */
    const int64_t *csrc;               /* per family -1, -1 or the two families whose carriers add up to its own */
} SegPlan;

static void knot_plan_free(PyObject *cap)
{
    KnotPlan *p = PyCapsule_GetPointer(cap, "bkabem.KnotPlan");
    if (p == NULL) return;
    for (int i = 0; i < KNOT_PLAN_ARRAYS; ++i) buf_drop(&p->b[i]);
    free(p);
}

static void seg_plan_free(PyObject *cap)
{
    SegPlan *p = PyCapsule_GetPointer(cap, "bkabem.SegPlan");
    if (p == NULL) return;
    for (int i = 0; i < SEG_PLAN_ARRAYS; ++i) buf_drop(&p->b[i]);
    free(p);
}

static PyObject *plan_error(const char *what)
{
    PyErr_Format(PyExc_ValueError, "plan: %s", what);
    return NULL;
}

PyDoc_STRVAR(py_lines_knot_plan_doc, "lines_knot_plan(n_lines, line, slot, factor, N, tw, tw_off, carrier, out_off, "
                                     "nu, mu, cindex, power, scale, iso, U, two_pi): see synth_kernel.LineKnots");

static PyObject *py_lines_knot_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != KNOT_PLAN_ARRAYS + 2) {
        PyErr_SetString(PyExc_TypeError, "lines_knot_plan takes 17 arguments");
        return NULL;
    }
    static const char *names[KNOT_PLAN_ARRAYS] = {"n_lines", "line", "slot", "factor", "N", "tw", "tw_off",
                                                  "carrier", "out_off", "nu", "mu", "cindex", "power", "scale",
                                                  "iso"};
    static const char kinds[KNOT_PLAN_ARRAYS] = {'q', 'q', 'q', 'd', 'q', 'd', 'q', 'q', 'q', 'd', 'd', 'q', 'q', 'd',
                                                 'q'};
    const int64_t U = PyLong_AsLongLong(args[KNOT_PLAN_ARRAYS]);
    const double two_pi = PyFloat_AsDouble(args[KNOT_PLAN_ARRAYS + 1]);
    if (PyErr_Occurred()) return NULL;
    KnotPlan *p = calloc(1, sizeof(KnotPlan));
    if (p == NULL) return PyErr_NoMemory();
    for (int i = 0; i < KNOT_PLAN_ARRAYS; ++i) {
        const char k[2] = {kinds[i], 0};
        if (!buf_take(args[i], &p->b[i], names[i], k, 1, 0)) goto fail;
    }
#define LEN(i) ((int64_t)p->b[i].v.shape[0])
#define QP(i) ((const int64_t *)p->b[i].v.buf)
#define DP(i) ((const double *)p->b[i].v.buf)
    p->n_lines = QP(0), p->line = QP(1), p->slot = QP(2), p->factor = DP(3), p->N = QP(4), p->tw = DP(5);
    p->tw_off = QP(6), p->carrier = QP(7), p->out_off = QP(8), p->nu = DP(9), p->mu = DP(10), p->cindex = QP(11);
    p->power = QP(12), p->scale = DP(13), p->iso = QP(14);
    p->F = LEN(0), p->L = LEN(9), p->C = LEN(11), p->two_pi = two_pi;
    if (p->F < 1 || LEN(4) != p->F || LEN(6) != p->F || LEN(7) != p->F || LEN(8) != p->F || LEN(10) != p->L
        || LEN(12) != p->C || LEN(13) != p->C || LEN(14) != 4 || p->C < 1 || p->C > LINES_MAX_C || U < 1) {
        plan_error("lengths: F families, L lines, C channels, 4 ISO rows");
        goto fail;
    }
    for (int64_t c = 0; c < p->C; ++c)
        if (p->cindex[c] < 0 || p->cindex[c] >= U || p->power[c] < 0 || p->power[c] > 2) {
            plan_error("cindex in 0 .. U-1, power in 0 .. 2");
            goto fail;
        }
    for (int i = 0; i < 4; ++i)
        if (p->iso[i] < 0 || p->iso[i] >= U) {
            plan_error("iso rows in 0 .. U-1");
            goto fail;
        }
    int64_t total = 0;
    for (int64_t f = 0; f < p->F; ++f) {
        const int64_t n = p->N[f];
        if (n < 4 || n > 65536 || (n & (n - 1)) != 0 || p->n_lines[f] < 0 || p->tw_off[f] < 0
            || p->tw_off[f] + n > LEN(5) || p->out_off[f] < 0) {
            plan_error("table sizes (powers of 2), twiddle offsets");
            goto fail;
        }
        const int64_t end = p->out_off[f] + (n + 3) * p->C * (p->carrier[f] ? 2 : 1);
        if (end > p->table_floats) p->table_floats = end;
        if (n > p->max_n) p->max_n = n;
        for (int64_t i = total; i < total + p->n_lines[f]; ++i)
            if (i >= LEN(1) || p->line[i] < 0 || p->line[i] >= p->L || p->slot[i] < 0 || p->slot[i] >= n) {
                plan_error("lines in 0 .. L-1 and slots in 0 .. N-1 of their family");
                goto fail;
            }
        total += p->n_lines[f];
    }
    if (total != LEN(1) || total != LEN(2) || total != LEN(3)) {
        plan_error("line, slot and factor: one entry per line of a family");
        goto fail;
    }
    PyObject *cap = PyCapsule_New(p, "bkabem.KnotPlan", knot_plan_free);
    if (cap == NULL) goto fail;
    return cap;
fail:
    for (int i = 0; i < KNOT_PLAN_ARRAYS; ++i) buf_drop(&p->b[i]);
    free(p);
    return NULL;
}

PyDoc_STRVAR(py_lines_segment_plan_doc, "lines_segment_plan(lg, carrier, off_t, wp, wq, consts, kappas, csrc): see "
                                        "synth_kernel.LineKnots");

static PyObject *py_lines_segment_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != SEG_PLAN_ARRAYS) {
        PyErr_SetString(PyExc_TypeError, "lines_segment_plan takes 8 arguments");
        return NULL;
    }
    static const char *names[SEG_PLAN_ARRAYS] = {"lg", "carrier", "off_t", "wp", "wq", "consts", "kappas", "csrc"};
    static const char kinds[SEG_PLAN_ARRAYS] = {'q', 'q', 'q', 'q', 'q', 'd', 'd', 'q'};
    SegPlan *p = calloc(1, sizeof(SegPlan));
    if (p == NULL) return PyErr_NoMemory();
    for (int i = 0; i < SEG_PLAN_ARRAYS; ++i) {
        const char k[2] = {kinds[i], 0};
        if (!buf_take(args[i], &p->b[i], names[i], k, 1, 0)) goto fail;
    }
    p->lg = QP(0), p->carrier = QP(1), p->off_t = QP(2), p->wp = QP(3), p->wq = QP(4), p->consts = DP(5);
    p->kappas = DP(6), p->csrc = QP(7);
    p->F = LEN(0), p->K = LEN(6);
    if (p->F < 1 || p->F > 64 || p->K > 128 || LEN(1) != p->F || LEN(2) != p->F || LEN(3) != p->F || LEN(4) != p->F
        || LEN(5) != 8 * p->F || LEN(7) != 2 * p->F) {
        plan_error("lengths: F <= 64 families, K <= 128 slip factors, 8 F constants, 2 F carrier sources");
        goto fail;
    }
    for (int64_t f = 0; f < p->F; ++f)
        if (p->lg[f] < 6 || p->lg[f] > 16 || p->off_t[f] < 0 || p->wp[f] < -1 || p->wp[f] >= p->K
            || p->wq[f] < -1 || p->wq[f] >= p->K) {
            plan_error("log2 table sizes in 6 .. 16, slip rows in -1 .. K-1");
            goto fail;
        }
    for (int64_t f = 0; f < p->F; ++f) {
        const int64_t a = p->csrc[2 * f], b = p->csrc[2 * f + 1];
        if ((a < 0) != (b < 0) || a < -1 || b < -1 || a >= p->F || b >= p->F || a == f || b == f
            || (a >= 0 && (!p->carrier[f] || !p->carrier[a] || !p->carrier[b]))) {
            plan_error("carrier sources: -1, -1 or two other families with carriers, for a family with one");
            goto fail;
        }
    }
    {                                   /* no cycle: every summed carrier resolves to carriers of their own phase */
        char done[64];
        int left = 0;
        for (int64_t f = 0; f < p->F; ++f) done[f] = p->csrc[2 * f] < 0, left += !done[f];
        for (int pass = 0; left > 0 && pass < p->F; ++pass)
            for (int64_t f = 0; f < p->F; ++f)
                if (!done[f] && done[p->csrc[2 * f]] && done[p->csrc[2 * f + 1]]) done[f] = 1, --left;
        if (left > 0) {
            plan_error("carrier sources: a cycle");
            goto fail;
        }
    }
#undef LEN
#undef QP
#undef DP
    PyObject *cap = PyCapsule_New(p, "bkabem.SegPlan", seg_plan_free);
    if (cap == NULL) goto fail;
    return cap;
fail:
    for (int i = 0; i < SEG_PLAN_ARRAYS; ++i) buf_drop(&p->b[i]);
    free(p);
    return NULL;
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

static NOINLINE CLONES void lines_knot(const KnotPlan *p, int64_t U, double *x, double f, double fade,
                                       const double *taper, const double *spow, double *y, double *viso,
                                       float *table, double *work, uint8_t *nz)
{
    const int64_t L = p->L, C = p->C;
    double sc[LINES_MAX_C];
    int64_t pw[LINES_MAX_C], ci[LINES_MAX_C];
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
    /* the families' tables: synth_family_tables' operations, planar */
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
        float *tr = table + p->out_off[fam];
        knot_store(n, C, re, tr);
        if (p->carrier[fam]) knot_store(n, C, im, tr + (n + 3) * C);
    }
}

PyDoc_STRVAR(py_lines_knot_doc, "lines_knot(plan, x, f, fade, taper, spow, y, viso, table, work): see "
                                "synth_kernel.LineKnots.knot");

static PyObject *py_lines_knot(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 10) {
        PyErr_SetString(PyExc_TypeError, "lines_knot takes 10 arguments");
        return NULL;
    }
    const KnotPlan *p = PyCapsule_GetPointer(args[0], "bkabem.KnotPlan");
    if (p == NULL) return NULL;
    const double f = PyFloat_AsDouble(args[2]), fade = PyFloat_AsDouble(args[3]);
    if (PyErr_Occurred()) return NULL;
    Buf bx = {0}, bt = {0}, bs = {0}, by = {0}, bv = {0}, btab = {0}, bw = {0};
    PyObject *res = NULL;
    if (!buf_take(args[1], &bx, "x", "Z", 2, args[5] != Py_None) || !buf_take(args[6], &by, "y", "Z", 2, 1)
        || !buf_take(args[7], &bv, "viso", "d", 2, 1) || !buf_take(args[8], &btab, "table", "f", 1, 1)
        || !buf_take(args[9], &bw, "work", "d", 1, 1))
        goto done;
    if (args[4] != Py_None && !buf_take(args[4], &bt, "taper", "d", 1, 0)) goto done;
    if (args[5] != Py_None && !buf_take(args[5], &bs, "spow", "d", 1, 0)) goto done;
    const int64_t L = p->L, C = p->C, U = bx.v.shape[1];
    if (bx.v.shape[0] != L || by.v.shape[0] != L || by.v.shape[1] != C || bv.v.shape[0] != L || bv.v.shape[1] != 8
        || btab.v.shape[0] < p->table_floats || bw.v.shape[0] < 2 * p->max_n * C || (bt.held && bt.v.shape[0] != L)
        || (bs.held && bs.v.shape[0] != L)) {
        PyErr_Format(PyExc_ValueError, "lines_knot: x must be (%lld, U), y (%lld, %lld), viso (%lld, 8), table >= %lld "
                     "floats, work >= %lld doubles, taper and spow (%lld,)", (long long)L, (long long)L, (long long)C,
                     (long long)L, (long long)p->table_floats, (long long)(2 * p->max_n * C), (long long)L);
        goto done;
    }
    for (int64_t c = 0; c < C; ++c)
        if (p->cindex[c] >= U) {
            PyErr_SetString(PyExc_ValueError, "lines_knot: x has fewer columns than the plan's channels read");
            goto done;
        }
    for (int i = 0; i < 4; ++i)
        if (p->iso[i] >= U) {
            PyErr_SetString(PyExc_ValueError, "lines_knot: x has fewer columns than the plan's ISO rows");
            goto done;
        }
    uint8_t *nz = malloc((size_t)p->max_n);                     /* rows known to be +0 (0) in the FFT */
    if (nz == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    lines_knot(p, U, bx.v.buf, f, fade, bt.held ? bt.v.buf : NULL, bs.held ? bs.v.buf : NULL, by.v.buf, bv.v.buf,
               btab.v.buf, bw.v.buf, nz);
    Py_END_ALLOW_THREADS
    free(nz);
    res = Py_None;
    Py_INCREF(res);
done:
    buf_drop(&bx), buf_drop(&bt), buf_drop(&bs), buf_drop(&by), buf_drop(&bv), buf_drop(&btab), buf_drop(&bw);
    return res;
}

/* ------------------------------------------------------------------------------------------------ a segment */
/* Python's round(v) of a double as int64 (half to even, = rint in the default rounding mode); 0 and -1 if |v| is
 * beyond int64. */
static inline int round_i64(double v, int64_t *out)
{
    if (!(fabs(v) < 9.2e18)) return -1;
    *out = (int64_t)nearbyint(v);
    return 0;
}

PyDoc_STRVAR(py_lines_render_doc, "lines_render(plan, m, j, fa, fb, xa, length, ua, fs, ta, tb, w, jw0, c1u, c2u, "
                                  "u_frac, warp, out, acc, off, dc, key, n0, sigma, extra): see "
                                  "synth_kernel.LineKnots.segment");

static PyObject *py_lines_render(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 25) {
        PyErr_SetString(PyExc_TypeError, "lines_render takes 25 arguments");
        return NULL;
    }
    const SegPlan *p = PyCapsule_GetPointer(args[0], "bkabem.SegPlan");
    if (p == NULL) return NULL;
    const int64_t m = PyLong_AsLongLong(args[1]), j = PyLong_AsLongLong(args[2]);
    const double fa = PyFloat_AsDouble(args[3]), fb = PyFloat_AsDouble(args[4]);
    const int64_t xa = PyLong_AsLongLong(args[5]), length = PyLong_AsLongLong(args[6]);
    const double ua = PyFloat_AsDouble(args[7]), fs = PyFloat_AsDouble(args[8]);
    const int64_t jw0 = args[12] == Py_None ? 0 : PyLong_AsLongLong(args[12]);
    const double c1u = PyFloat_AsDouble(args[13]), c2u = PyFloat_AsDouble(args[14]);
    const double u_frac = PyFloat_AsDouble(args[15]);
    const uint64_t key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[21]);
    const int64_t n0 = PyLong_AsLongLong(args[22]);
    if (PyErr_Occurred()) return NULL;
    Buf bta = {0}, btb = {0}, bw = {0}, bwarp = {0}, bo = {0}, bacc = {0}, boff = {0}, bdc = {0}, bsig = {0};
    Buf bx = {0}, bfr = {0}, bwin = {0}, bgr = {0}, bsc = {0};
    PyObject *res = NULL;
    const float *win = NULL, *extra = NULL, *floor_scale = NULL;
    const int16_t *frames = NULL;
    const int64_t *grains = NULL;
    int64_t n_grains = 0, half = 1, frame_length = 2;
    if (!buf_take(args[9], &bta, "ta", "f", 1, 0) || !buf_take(args[17], &bo, "out", "f", 2, 1)
        || !buf_take(args[20], &bdc, "dc", "f", 1, 0))
        goto done;
    const int64_t C = bo.v.shape[1];
    if (m < 0 || length < 1 || bo.v.shape[0] != m || bdc.v.shape[0] != C || bta.v.shape[0] < p->table_floats) {
        PyErr_SetString(PyExc_ValueError, "lines_render: out (m, C), dc (C,), ta the plan's tables, length >= 1");
        goto done;
    }
    for (int64_t f = 0; f < p->F; ++f) {                    /* the tables' extent at this C */
        const int64_t nt = (((int64_t)1 << p->lg[f]) + 3) * C * (p->carrier[f] ? 2 : 1);
        if (p->off_t[f] + nt > (int64_t)bta.v.shape[0]) {
            PyErr_SetString(PyExc_ValueError, "lines_render: ta smaller than the plan's tables");
            goto done;
        }
    }
    if (args[10] != Py_None) {
        if (!buf_take(args[10], &btb, "tb", "f", 1, 0)) goto done;
        if (btb.v.shape[0] != bta.v.shape[0]) {
            PyErr_SetString(PyExc_ValueError, "lines_render: tb must be ta's size");
            goto done;
        }
    }
    if (args[18] != Py_None) {
        if (!buf_take(args[18], &bacc, "acc", "d", 2, 1) || !buf_take(args[19], &boff, "off", "d", 1, 0)) goto done;
        if (bacc.v.shape[0] != C || bacc.v.shape[1] != 6 || boff.v.shape[0] != C) {
            PyErr_SetString(PyExc_ValueError, "lines_render: acc (C, 6), off (C,)");
            goto done;
        }
    }
    if (args[23] != Py_None) {
        if (!buf_take(args[23], &bsig, "sigma", "f", 1, 0)) goto done;
        if (bsig.v.shape[0] != C || n0 < 0) {
            PyErr_SetString(PyExc_ValueError, "lines_render: sigma (C,), n0 >= 0");
            goto done;
        }
    }
    PyObject *ex = args[24];
    if (PyTuple_Check(ex)) {                   /* the floor's source: (frames int16, window, grains, half, scale) */
        if (PyTuple_GET_SIZE(ex) != 5 || !buf_take(PyTuple_GET_ITEM(ex, 0), &bfr, "frames", "h", 3, 0)
            || !buf_take(PyTuple_GET_ITEM(ex, 1), &bwin, "window", "f", 1, 0)
            || !buf_take(PyTuple_GET_ITEM(ex, 2), &bgr, "grains", "q", 2, 0)
            || !buf_take(PyTuple_GET_ITEM(ex, 4), &bsc, "scale", "f", 1, 0))
            goto done;
        half = PyLong_AsLongLong(PyTuple_GET_ITEM(ex, 3));
        if (PyErr_Occurred()) goto done;
        frame_length = bfr.v.shape[1], n_grains = bgr.v.shape[0];
        if (bfr.v.shape[2] != C || bgr.v.shape[1] != 3 || bwin.v.shape[0] < 2 * half || bsc.v.shape[0] != C
            || n0 < 0) {
            PyErr_SetString(PyExc_ValueError, "lines_render: floor frames (F, L, C) int16, window (2 half,), grains "
                                              "(G, 3), scale (C,)");
            goto done;
        }
        for (int64_t g = 0; g < n_grains; ++g) {
            const int64_t *q = (const int64_t *)bgr.v.buf + 3 * g;
            if (q[1] < 0 || q[1] >= bfr.v.shape[0] || q[2] < 0 || q[2] >= frame_length) {
                PyErr_SetString(PyExc_ValueError, "lines_render: a grain's frame or offset out of range");
                goto done;
            }
        }
        frames = bfr.v.buf, win = bwin.v.buf, grains = bgr.v.buf, floor_scale = bsc.v.buf;
    } else if (ex != Py_None) {
        if (!buf_take(ex, &bx, "extra", "f", 2, 0)) goto done;
        if (bx.v.shape[0] != m || bx.v.shape[1] != C) {
            PyErr_SetString(PyExc_ValueError, "lines_render: extra (m, C)");
            goto done;
        }
        extra = bx.v.buf;
    }
    const int slip = args[11] != Py_None;
    if (slip) {
        if (!buf_take(args[11], &bw, "w", "d", 1, 0) || !buf_take(args[16], &bwarp, "warp", "q", 1, 1)) goto done;
        if (bwarp.v.shape[0] < p->K * m) {
            PyErr_SetString(PyExc_ValueError, "lines_render: warp must hold K x m offsets");
            goto done;
        }
    } else
        for (int64_t f = 0; f < p->F; ++f)
            if (p->wp[f] >= 0 || p->wq[f] >= 0) {
                PyErr_SetString(PyExc_ValueError, "lines_render: the plan's slip rows need the walk's values");
                goto done;
            }
    /* the phases of _phase_args, as LineSetPath._segment_lines_fused computes them */
    uint64_t ph[6 * 64];
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
                || round_i64(t0 * 4611686018427387904.0, &u0)) {
                PyErr_SetString(PyExc_ValueError, "lines_render: a phase increment beyond 2^63 units");
                goto done;
            }
            o[0] = (uint64_t)u0 + (uint64_t)j * (uint64_t)d0 + (uint64_t)dd * (uint64_t)jj;
            o[1] = (uint64_t)d0 + (uint64_t)j * (uint64_t)dd;
            o[2] = (uint64_t)dd;
        }
    int64_t *warp = slip ? (int64_t *)bwarp.v.buf : NULL;
    int rc = 0;
    char need[128];
    if (slip) lines_rows_needed(p->F, C, ph, p->lg, p->carrier, p->csrc, p->wp, p->wq, p->K, need);
    Py_BEGIN_ALLOW_THREADS
    for (int64_t i = 0, e; slip && i < p->K && rc == 0; i = e) {   /* the rows read, in runs of at most 8 */
        if (!need[i]) {
            e = i + 1;
            continue;
        }
        for (e = i + 1; e < p->K && e < i + 8 && need[e]; ++e) {}
        rc = synth_slip_warp(m, (double)j, c1u, c2u, u_frac, bw.v.buf, bw.v.shape[0], jw0, p->kappas + i, e - i,
                             warp + i * m);
    }
    if (rc == 0)
        rc = synth_lines_segment_f32(m, C, p->F, ph, p->lg, p->carrier, p->csrc, p->off_t, bta.v.buf,
                                     btb.held ? btb.v.buf : NULL, warp, p->wp, p->wq, bdc.v.buf, (double)j,
                                     65536.0 / (double)length, bo.v.buf, bacc.held ? bacc.v.buf : NULL,
                                     boff.held ? boff.v.buf : NULL, key, n0, bsig.held ? bsig.v.buf : NULL, extra,
                                     frames, win, n_grains, grains, half, frame_length, floor_scale);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_SetString(PyExc_ValueError, "lines_render: the slip walk's values do not cover the segment, or the "
                                          "segment kernel rejected its arguments");
        goto done;
    }
    res = Py_None;
    Py_INCREF(res);
done:
    buf_drop(&bta), buf_drop(&btb), buf_drop(&bw), buf_drop(&bwarp), buf_drop(&bo), buf_drop(&bacc);
    buf_drop(&boff), buf_drop(&bdc), buf_drop(&bsig), buf_drop(&bx), buf_drop(&bfr), buf_drop(&bwin), buf_drop(&bgr);
    buf_drop(&bsc);
    return res;
}

/* ------------------------------------------------------------------------------------------------ ISO velocity */
PyDoc_STRVAR(py_band_rms_lines_doc, "band_rms_lines(va, vb, nu, mu, f, lo_hz, hi_hz, s) -> 4 floats: see "
                                    "synth_kernel.band_rms_lines");

/* sqrt(0.5 sum_k |va_k + s (vb_k - va_k)|^2) over the lines k with lo_hz <= nu_k f + mu_k <= hi_hz, per ISO row
 * (va, vb L x 8: Re of 4 rows | Im). */
static PyObject *py_band_rms_lines(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "band_rms_lines takes 8 arguments");
        return NULL;
    }
    const double f = PyFloat_AsDouble(args[4]), lo = PyFloat_AsDouble(args[5]), hi = PyFloat_AsDouble(args[6]);
    const double s = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred()) return NULL;
    Buf ba = {0}, bb = {0}, bn = {0}, bm = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &ba, "va", "d", 2, 0) || !buf_take(args[1], &bb, "vb", "d", 2, 0)
        || !buf_take(args[2], &bn, "nu", "d", 1, 0) || !buf_take(args[3], &bm, "mu", "d", 1, 0))
        goto done;
    const Py_ssize_t L = ba.v.shape[0];
    if (ba.v.shape[1] != 8 || bb.v.shape[0] != L || bb.v.shape[1] != 8 || bn.v.shape[0] != L || bm.v.shape[0] != L) {
        PyErr_SetString(PyExc_ValueError, "band_rms_lines: va, vb (L, 8), nu, mu (L,)");
        goto done;
    }
    const double *a = ba.v.buf, *b = bb.v.buf, *nu = bn.v.buf, *mu = bm.v.buf;
    double q[8] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (Py_ssize_t k = 0; k < L; ++k) {
        const double fr = nu[k] * f + mu[k];
        if (!(fr >= lo && fr <= hi)) continue;
        for (int c = 0; c < 8; ++c) {
            const double v = a[8 * k + c] + s * (b[8 * k + c] - a[8 * k + c]);
            q[c] += v * v;
        }
    }
    res = Py_BuildValue("(dddd)", sqrt(0.5 * (q[0] + q[4])), sqrt(0.5 * (q[1] + q[5])), sqrt(0.5 * (q[2] + q[6])),
                        sqrt(0.5 * (q[3] + q[7])));
done:
    buf_drop(&ba), buf_drop(&bb), buf_drop(&bn), buf_drop(&bm);
    return res;
}

#define SYNTHKNOT_METHODS                                                                                           \
    {"lines_knot_plan", (PyCFunction)(void (*)(void))py_lines_knot_plan, METH_FASTCALL, py_lines_knot_plan_doc},    \
    {"lines_segment_plan", (PyCFunction)(void (*)(void))py_lines_segment_plan, METH_FASTCALL,                       \
     py_lines_segment_plan_doc},                                                                                    \
    {"lines_knot", (PyCFunction)(void (*)(void))py_lines_knot, METH_FASTCALL, py_lines_knot_doc},                   \
    {"lines_render", (PyCFunction)(void (*)(void))py_lines_render, METH_FASTCALL, py_lines_render_doc},             \
    {"band_rms_lines", (PyCFunction)(void (*)(void))py_band_rms_lines, METH_FASTCALL, py_band_rms_lines_doc},

#endif
