/*
 * The line-set kernels and the broadband floor as functions of the extension module _synth (py_synth.c makes the
 * module). A line set's constant arrays go into a plan once (a capsule that holds their buffers: lines_knot_plan,
 * lines_segment_plan), so that a knot (lines_knot) and a segment (lines_render) take the few arrays that change.
 */
#include <Python.h>

#include "py_buffers.h"
#include "py_synth_lines.h"
#include "synth_floor.h"
#include "synth_knot.h"
#include "synth_lines.h"

#define KNOT_PLAN_ARRAYS 15
#define SEG_PLAN_ARRAYS 11

typedef struct {
    Buf b[KNOT_PLAN_ARRAYS];
    KnotPlan p;
} KnotCapsule;

typedef struct {
    Buf b[SEG_PLAN_ARRAYS];
    LinesPlan p;
} SegmentCapsule;

static void knot_capsule_free(PyObject *cap)
{
    KnotCapsule *k = PyCapsule_GetPointer(cap, "bkabem.KnotPlan");
    if (k == NULL) return;
    for (int i = 0; i < KNOT_PLAN_ARRAYS; ++i) buf_drop(&k->b[i]);
    free(k);
}

static void segment_capsule_free(PyObject *cap)
{
    SegmentCapsule *s = PyCapsule_GetPointer(cap, "bkabem.SegPlan");
    if (s == NULL) return;
    for (int i = 0; i < SEG_PLAN_ARRAYS; ++i) buf_drop(&s->b[i]);
    free(s);
}

#define LEN(c, i) ((int64_t)(c)->b[i].v.shape[0])
#define QP(c, i) ((const int64_t *)(c)->b[i].v.buf)
#define DP(c, i) ((const double *)(c)->b[i].v.buf)

PyDoc_STRVAR(lines_knot_plan_doc, "lines_knot_plan(n_lines, line, slot, factor, N, tw, tw_off, carrier, offset, nu, "
                                  "mu, cindex, power, scale, iso, U, two_pi): see render.FusedLines");

static PyObject *py_lines_knot_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("lines_knot_plan", nargs, KNOT_PLAN_ARRAYS + 2)) return NULL;
    static const char *names[KNOT_PLAN_ARRAYS] = {"n_lines", "line", "slot", "factor", "N", "tw", "tw_off",
                                                  "carrier", "offset", "nu", "mu", "cindex", "power", "scale",
                                                  "iso"};
    static const char kinds[KNOT_PLAN_ARRAYS] = {'q', 'q', 'q', 'd', 'q', 'd', 'q', 'q', 'q', 'd', 'd', 'q', 'q', 'd',
                                                 'q'};
    const int64_t U = PyLong_AsLongLong(args[KNOT_PLAN_ARRAYS]);
    const double two_pi = PyFloat_AsDouble(args[KNOT_PLAN_ARRAYS + 1]);
    if (PyErr_Occurred()) return NULL;
    KnotCapsule *c = calloc(1, sizeof(KnotCapsule));
    if (c == NULL) return PyErr_NoMemory();
    for (int i = 0; i < KNOT_PLAN_ARRAYS; ++i) {
        const char k[2] = {kinds[i], 0};
        if (!buf_take(args[i], &c->b[i], names[i], k, 1, 0)) goto fail;
    }
    KnotPlan *p = &c->p;
    p->n_lines = QP(c, 0), p->line = QP(c, 1), p->slot = QP(c, 2), p->factor = DP(c, 3), p->N = QP(c, 4);
    p->tw = DP(c, 5), p->tw_off = QP(c, 6), p->carrier = QP(c, 7), p->offset = QP(c, 8), p->nu = DP(c, 9);
    p->mu = DP(c, 10), p->cindex = QP(c, 11), p->power = QP(c, 12), p->scale = DP(c, 13), p->iso = QP(c, 14);
    p->F = LEN(c, 0), p->L = LEN(c, 9), p->C = LEN(c, 11), p->two_pi = two_pi;
    const char *why = NULL;
    if (LEN(c, 4) != p->F || LEN(c, 6) != p->F || LEN(c, 7) != p->F || LEN(c, 8) != p->F || LEN(c, 10) != p->L
        || LEN(c, 12) != p->C || LEN(c, 13) != p->C || LEN(c, 14) != 4 || LEN(c, 2) != LEN(c, 1)
        || LEN(c, 3) != LEN(c, 1))
        why = "lengths: F families, L lines, C channels, 4 ISO rows";
    else
        why = knot_plan_check(p, LEN(c, 1), LEN(c, 5), U);
    if (why != NULL) {
        PyErr_Format(PyExc_ValueError, "plan: %s", why);
        goto fail;
    }
    knot_plan_sizes(p);
    PyObject *cap = PyCapsule_New(c, "bkabem.KnotPlan", knot_capsule_free);
    if (cap == NULL) goto fail;
    return cap;
fail:
    for (int i = 0; i < KNOT_PLAN_ARRAYS; ++i) buf_drop(&c->b[i]);
    free(c);
    return NULL;
}

PyDoc_STRVAR(lines_segment_plan_doc, "lines_segment_plan(lg, carrier, offset, wp, wq, consts, kappas, csrc, walks, "
                                     "strike, strike_params): see render.FusedLines.segment_plan");

static PyObject *py_lines_segment_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("lines_segment_plan", nargs, SEG_PLAN_ARRAYS)) return NULL;
    static const char *names[SEG_PLAN_ARRAYS] = {"lg", "carrier", "offset", "wp", "wq", "consts", "kappas", "csrc",
                                                 "walks", "strike", "strike_params"};
    static const char kinds[SEG_PLAN_ARRAYS] = {'q', 'q', 'q', 'q', 'q', 'd', 'd', 'q', 'q', 'q', 'd'};
    SegmentCapsule *c = calloc(1, sizeof(SegmentCapsule));
    if (c == NULL) return PyErr_NoMemory();
    for (int i = 0; i < SEG_PLAN_ARRAYS; ++i) {
        const char k[2] = {kinds[i], 0};
        if (!buf_take(args[i], &c->b[i], names[i], k, 1, 0)) goto fail;
    }
    LinesPlan *p = &c->p;
    p->lg = QP(c, 0), p->carrier = QP(c, 1), p->offset = QP(c, 2), p->wp = QP(c, 3), p->wq = QP(c, 4);
    p->consts = DP(c, 5), p->kappas = DP(c, 6), p->csrc = QP(c, 7), p->walks = QP(c, 8), p->strike = QP(c, 9);
    p->F = LEN(c, 0), p->K = LEN(c, 6), p->n_walks = 1;
    for (int64_t k = 0; k < LEN(c, 8) && k < p->K; ++k)
        if (p->walks[k] + 1 > p->n_walks) p->n_walks = p->walks[k] + 1;
    const char *why = NULL;
    if (LEN(c, 1) != p->F || LEN(c, 2) != p->F || LEN(c, 3) != p->F || LEN(c, 4) != p->F || LEN(c, 5) != 8 * p->F
        || LEN(c, 7) != 2 * p->F || LEN(c, 8) != p->K || LEN(c, 9) != p->F || LEN(c, 10) != 2)
        why = "lengths: F families, 8 F constants, 2 F carrier sources, one walk per slip factor, F strike flags, "
              "2 strike parameters";
    else {
        p->strike_sigma = DP(c, 10)[0], p->strike_offset = DP(c, 10)[1];
        why = lines_plan_check(p);
    }
    if (why != NULL) {
        PyErr_Format(PyExc_ValueError, "plan: %s", why);
        goto fail;
    }
    PyObject *cap = PyCapsule_New(c, "bkabem.SegPlan", segment_capsule_free);
    if (cap == NULL) goto fail;
    return cap;
fail:
    for (int i = 0; i < SEG_PLAN_ARRAYS; ++i) buf_drop(&c->b[i]);
    free(c);
    return NULL;
}

#undef LEN
#undef QP
#undef DP

PyDoc_STRVAR(lines_knot_doc, "lines_knot(plan, x, f, fade, taper, spow, y, viso, table, work): see "
                             "render.FusedLines.knot");

static PyObject *py_lines_knot(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("lines_knot", nargs, 10)) return NULL;
    const KnotCapsule *c = PyCapsule_GetPointer(args[0], "bkabem.KnotPlan");
    if (c == NULL) return NULL;
    const KnotPlan *p = &c->p;
    const double f = PyFloat_AsDouble(args[2]), fade = PyFloat_AsDouble(args[3]);
    if (PyErr_Occurred()) return NULL;
    Buf bx = {0}, bt = {0}, bs = {0}, by = {0}, bv = {0}, btab = {0}, bw = {0};
    PyObject *res = NULL;
    if (!buf_take(args[1], &bx, "x", "Z", 2, args[5] != Py_None) || !buf_take(args[6], &by, "y", "Z", 2, 1)
        || !buf_take(args[7], &bv, "viso", "d", 2, 1) || !buf_take(args[8], &btab, "table", "f", 1, 1)
        || !buf_take(args[9], &bw, "work", "d", 1, 1) || !buf_take_opt(args[4], &bt, "taper", "d", 1, 0)
        || !buf_take_opt(args[5], &bs, "spow", "d", 1, 0))
        goto done;
    const int64_t L = p->L, C = p->C, U = bx.v.shape[1];
    if (bx.v.shape[0] != L || by.v.shape[0] != L || by.v.shape[1] != C || bv.v.shape[0] != L || bv.v.shape[1] != 8
        || btab.v.shape[0] < p->table_floats || bw.v.shape[0] < 2 * p->max_n * C || (bt.held && bt.v.shape[0] != L)
        || (bs.held && bs.v.shape[0] != L)) {
        PyErr_Format(PyExc_ValueError, "lines_knot: x must be (%lld, U), y (%lld, %lld), viso (%lld, 8), table >= %lld "
                     "floats, work >= %lld doubles, taper and spow (%lld,)", (long long)L, (long long)L, (long long)C,
                     (long long)L, (long long)p->table_floats, (long long)(2 * p->max_n * C), (long long)L);
        goto done;
    }
    for (int64_t ch = 0; ch < C; ++ch)
        if (p->cindex[ch] >= U) {
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
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bx), buf_drop(&bt), buf_drop(&bs), buf_drop(&by), buf_drop(&bv), buf_drop(&btab), buf_drop(&bw);
    return res;
}

PyDoc_STRVAR(lines_render_doc, "lines_render(plan, m, j, fa, fb, xa, length, ua, fs, ta, tb, w, jw0, c1u, c2u, "
                               "u_frac, warp, out, acc, off, dc, key, n0, sigma, extra, strike_key): see "
                               "render.FusedLines.segment");

static PyObject *py_lines_render(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("lines_render", nargs, 26)) return NULL;
    const SegmentCapsule *cap = PyCapsule_GetPointer(args[0], "bkabem.SegPlan");
    if (cap == NULL) return NULL;
    const LinesPlan *p = &cap->p;
    const int64_t m = PyLong_AsLongLong(args[1]), j = PyLong_AsLongLong(args[2]);
    const double fa = PyFloat_AsDouble(args[3]), fb = PyFloat_AsDouble(args[4]);
    const int64_t xa = PyLong_AsLongLong(args[5]), length = PyLong_AsLongLong(args[6]);
    const double ua = PyFloat_AsDouble(args[7]), fs = PyFloat_AsDouble(args[8]);
    const int64_t jw0 = args[12] == Py_None ? 0 : PyLong_AsLongLong(args[12]);
    const double c1u = PyFloat_AsDouble(args[13]), c2u = PyFloat_AsDouble(args[14]);
    const double u_frac = PyFloat_AsDouble(args[15]);
    const uint64_t key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[21]);
    const int64_t n0 = PyLong_AsLongLong(args[22]);
    const uint64_t strike_key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[25]);
    if (PyErr_Occurred()) return NULL;
    Buf bta = {0}, btb = {0}, bw = {0}, bwarp = {0}, bo = {0}, bacc = {0}, boff = {0}, bdc = {0}, bsig = {0};
    Buf bx = {0}, bfr = {0}, bwin = {0}, bgr = {0}, bsc = {0};
    PyObject *res = NULL;
    FloorSource floor = {NULL, NULL, NULL, NULL, 0, 1, 2};
    const int has_floor = PyTuple_Check(args[24]);
    if (!buf_take(args[9], &bta, "ta", "f", 1, 0) || !buf_take(args[17], &bo, "out", "f", 2, 1)
        || !buf_take(args[20], &bdc, "dc", "f", 1, 0))
        goto done;
    const int64_t C = bo.v.shape[1];
    if (m < 0 || length < 1 || bo.v.shape[0] != m || bdc.v.shape[0] != C) {
        PyErr_SetString(PyExc_ValueError, "lines_render: out (m, C), dc (C,), length >= 1");
        goto done;
    }
    for (int64_t f = 0; f < p->F; ++f) {                    /* the tables' extent at this C */
        const int64_t nt = (((int64_t)1 << p->lg[f]) + 3) * C * (p->carrier[f] ? 2 : 1);
        if (p->offset[f] + nt > (int64_t)bta.v.shape[0]) {
            PyErr_SetString(PyExc_ValueError, "lines_render: ta smaller than the plan's tables");
            goto done;
        }
    }
    if (!buf_take_opt(args[10], &btb, "tb", "f", 1, 0)) goto done;
    if (btb.held && btb.v.shape[0] != bta.v.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "lines_render: tb must be ta's size");
        goto done;
    }
    if (args[18] != Py_None) {
        if (!buf_take(args[18], &bacc, "acc", "d", 2, 1) || !buf_take(args[19], &boff, "off", "d", 1, 0)) goto done;
        if (bacc.v.shape[0] != C || bacc.v.shape[1] != 6 || boff.v.shape[0] != C) {
            PyErr_SetString(PyExc_ValueError, "lines_render: acc (C, 6), off (C,)");
            goto done;
        }
    }
    if (!buf_take_opt(args[23], &bsig, "sigma", "f", 1, 0)) goto done;
    if (bsig.held && (bsig.v.shape[0] != C || n0 < 0)) {
        PyErr_SetString(PyExc_ValueError, "lines_render: sigma (C,), n0 >= 0");
        goto done;
    }
    PyObject *ex = args[24];
    if (has_floor) {                           /* the floor's source: (frames int16, window, grains, half, scale) */
        if (PyTuple_GET_SIZE(ex) != 5 || !buf_take(PyTuple_GET_ITEM(ex, 0), &bfr, "frames", "h", 3, 0)
            || !buf_take(PyTuple_GET_ITEM(ex, 1), &bwin, "window", "f", 1, 0)
            || !buf_take(PyTuple_GET_ITEM(ex, 2), &bgr, "grains", "q", 2, 0)
            || !buf_take(PyTuple_GET_ITEM(ex, 4), &bsc, "scale", "f", 1, 0))
            goto done;
        floor.half = PyLong_AsLongLong(PyTuple_GET_ITEM(ex, 3));
        if (PyErr_Occurred()) goto done;
        floor.frame_length = bfr.v.shape[1], floor.n_grains = bgr.v.shape[0];
        if (bfr.v.shape[2] != C || bgr.v.shape[1] != 3 || bwin.v.shape[0] < 2 * floor.half || bsc.v.shape[0] != C
            || n0 < 0) {
            PyErr_SetString(PyExc_ValueError, "lines_render: floor frames (F, L, C) int16, window (2 half,), grains "
                                              "(G, 3), scale (C,)");
            goto done;
        }
        for (int64_t g = 0; g < floor.n_grains; ++g) {
            const int64_t *q = (const int64_t *)bgr.v.buf + 3 * g;
            if (q[1] < 0 || q[1] >= bfr.v.shape[0] || q[2] < 0 || q[2] >= floor.frame_length) {
                PyErr_SetString(PyExc_ValueError, "lines_render: a grain's frame or offset out of range");
                goto done;
            }
        }
        floor.frames = bfr.v.buf, floor.win = bwin.v.buf, floor.grains = bgr.v.buf, floor.scale = bsc.v.buf;
    } else {
        if (!buf_take_opt(ex, &bx, "extra", "f", 2, 0)) goto done;
        if (bx.held && (bx.v.shape[0] != m || bx.v.shape[1] != C)) {
            PyErr_SetString(PyExc_ValueError, "lines_render: extra (m, C)");
            goto done;
        }
    }
    if (args[11] != Py_None) {
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
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = lines_render(p, m, C, j, fa, fb, xa, length, ua, fs, bta.v.buf, btb.held ? btb.v.buf : NULL,
                      bw.held ? bw.v.buf : NULL, bw.held ? bw.v.shape[0] : 0, jw0, c1u, c2u, u_frac,
                      bwarp.held ? bwarp.v.buf : NULL, bdc.v.buf, bo.v.buf, bacc.held ? bacc.v.buf : NULL,
                      boff.held ? boff.v.buf : NULL, key, n0, bsig.held ? bsig.v.buf : NULL,
                      bx.held ? bx.v.buf : NULL, has_floor ? &floor : NULL, strike_key);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_SetString(PyExc_ValueError, rc == -2 ? "lines_render: a phase increment beyond 2^63 units"
                                          : rc == -3 ? "lines_render: the slip walk's values do not cover the segment"
                                                     : "lines_render: the segment kernel rejected its arguments");
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bta), buf_drop(&btb), buf_drop(&bw), buf_drop(&bwarp), buf_drop(&bo), buf_drop(&bacc);
    buf_drop(&boff), buf_drop(&bdc), buf_drop(&bsig), buf_drop(&bx), buf_drop(&bfr), buf_drop(&bwin), buf_drop(&bgr);
    buf_drop(&bsc);
    return res;
}

PyDoc_STRVAR(band_rms_lines_doc, "band_rms_lines(va, vb, nu, mu, f, lo_hz, hi_hz, s) -> 4 floats: see "
                                 "kernel.band_rms_lines");

/* sqrt(0.5 sum_k |va_k + s (vb_k - va_k)|^2) over the lines k with lo_hz <= nu_k f + mu_k <= hi_hz, per ISO row
 * (va, vb L x 8: Re of 4 rows | Im). */
static PyObject *py_band_rms_lines(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("band_rms_lines", nargs, 8)) return NULL;
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

PyDoc_STRVAR(floor_render_doc, "floor_render(n0, half, frames, window, grains, out, scale): see kernel.floor_render");

static PyObject *py_floor_render(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("floor_render", nargs, 7)) return NULL;
    const int64_t n0 = PyLong_AsLongLong(args[0]), half = PyLong_AsLongLong(args[1]);
    if (PyErr_Occurred()) return NULL;
    Buf bfr = {0}, bwin = {0}, bgr = {0}, bo = {0}, bsc = {0};
    PyObject *res = NULL;
    if (!buf_take(args[2], &bfr, "frames", "h", 3, 0) || !buf_take(args[3], &bwin, "window", "f", 1, 0)
        || !buf_take(args[4], &bgr, "grains", "q", 2, 0) || !buf_take(args[5], &bo, "out", "f", 2, 1)
        || !buf_take(args[6], &bsc, "scale", "f", 1, 0))
        goto done;
    const int64_t m = bo.v.shape[0], C = bo.v.shape[1], L = bfr.v.shape[1], G = bgr.v.shape[0];
    int bad = bfr.v.shape[2] != C || bsc.v.shape[0] != C || bgr.v.shape[1] != 3 || half < 1
              || bwin.v.shape[0] < 2 * half || L < half;
    for (int64_t g = 0; g < G && !bad; ++g) {
        const int64_t *q = (const int64_t *)bgr.v.buf + 3 * g;
        bad = q[1] < 0 || q[1] >= bfr.v.shape[0] || q[2] < 0 || q[2] >= L;
    }
    if (bad) {
        PyErr_SetString(PyExc_ValueError, "floor_render: frames (F, L, C) int16, window (2 half,), grains (G, 3) in "
                                          "range, out (m, C), scale (C,)");
        goto done;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = synth_floor_render(m, C, n0, half, L, bfr.v.buf, bwin.v.buf, G, bgr.v.buf, bo.v.buf, bsc.v.buf);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_SetString(PyExc_ValueError, "floor_render rejected its arguments");
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bfr), buf_drop(&bwin), buf_drop(&bgr), buf_drop(&bo), buf_drop(&bsc);
    return res;
}

PyDoc_STRVAR(floor_spectrum_doc, "floor_spectrum(key, by_input, s, out, avx2): see kernel.floor_spectrum");

static PyObject *py_floor_spectrum(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("floor_spectrum", nargs, 5)) return NULL;
    const uint64_t key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[0]);
    const double s = PyFloat_AsDouble(args[2]);
    const int avx2 = PyObject_IsTrue(args[4]);
    if (PyErr_Occurred() || avx2 < 0) return NULL;
    Buf bt = {0}, bo = {0};
    PyObject *res = NULL;
    if (!buf_take(args[1], &bt, "by_input", "C", 3, 0) || !buf_take(args[3], &bo, "out", "C", 2, 1)) goto done;
    const int64_t F = bt.v.shape[1], C = bt.v.shape[2];
    if (bt.v.shape[0] != 4 || bo.v.shape[0] != F || bo.v.shape[1] != C) {
        PyErr_SetString(PyExc_ValueError, "floor_spectrum: by_input must be (4, F, C) and out (F, C)");
        goto done;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = synth_floor_spectrum(key, F, C, bt.v.buf, s, bo.v.buf, avx2);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_SetString(PyExc_ValueError, "floor_spectrum rejected its arguments");
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bt), buf_drop(&bo);
    return res;
}

PyDoc_STRVAR(floor_quantise_doc, "floor_quantise(x, q, scale): see kernel.floor_quantise");

static PyObject *py_floor_quantise(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("floor_quantise", nargs, 3)) return NULL;
    Buf bx = {0}, bq = {0}, bs = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &bx, "x", "f", 3, 0) || !buf_take(args[1], &bq, "q", "h", 3, 1)
        || !buf_take(args[2], &bs, "scale", "f", 1, 1))
        goto done;
    const int64_t C = bx.v.shape[2], n = bx.v.shape[0] * bx.v.shape[1];
    if (bq.v.shape[0] != bx.v.shape[0] || bq.v.shape[1] != bx.v.shape[1] || bq.v.shape[2] != C
        || bs.v.shape[0] != C) {
        PyErr_SetString(PyExc_ValueError, "floor_quantise: q of x's shape (F, L, C), scale (C,)");
        goto done;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = synth_floor_quantise(n, C, bx.v.buf, bq.v.buf, bs.v.buf);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_SetString(PyExc_ValueError, "floor_quantise rejected its arguments (C <= 64)");
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bx), buf_drop(&bq), buf_drop(&bs);
    return res;
}

PyMethodDef synth_lines_methods[] = {
    METHOD(lines_knot_plan, lines_knot_plan_doc),
    METHOD(lines_segment_plan, lines_segment_plan_doc),
    METHOD(lines_knot, lines_knot_doc),
    METHOD(lines_render, lines_render_doc),
    METHOD(band_rms_lines, band_rms_lines_doc),
    METHOD(floor_render, floor_render_doc),
    METHOD(floor_spectrum, floor_spectrum_doc),
    METHOD(floor_quantise, floor_quantise_doc),
    {NULL, NULL, 0, NULL}};
