/*
 * The extension module bkabem_core.kernels._synth: the synthesiser's kernels as Python functions
 * (bkabem_core/synth/kernel.py is their Python face and holds the numpy references). This unit binds the sample loop
 * and its companions; py_synth_lines.c the line-set kernels and the broadband floor. The arrays come in through the
 * buffer protocol (py_buffers.h); the GIL is released while a kernel runs.
 */
#include <Python.h>

#include "py_buffers.h"
#include "py_synth_lines.h"
#include "synth_common.h"
#include "synth_segment.h"
#include "synth_slip.h"

static int log2_table(Py_ssize_t n)
{
    if (n < 64 || n > 65536 || (n & (n - 1)) != 0) return -1;
    int l = 0;
    while (((Py_ssize_t)1 << l) < n) ++l;
    return l;
}

PyDoc_STRVAR(segment_doc, "segment(phase0, dphase0, ddphase, warp, table_a, table_b, xi0, blend_scale, out, acc, off"
                          "[, key, n0, sigma, extra]): see kernel.segment");

static PyObject *py_segment(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 11 && nargs != 15) {
        PyErr_SetString(PyExc_TypeError, "segment takes 11 arguments (15 with noise: key, n0, sigma, extra)");
        return NULL;
    }
    uint64_t ph[3];
    for (int i = 0; i < 3; ++i) {
        ph[i] = (uint64_t)PyLong_AsUnsignedLongLongMask(args[i]);          /* modulo 2^64, any sign and size */
        if (ph[i] == (uint64_t)-1 && PyErr_Occurred()) return NULL;
    }
    const double xi0 = PyFloat_AsDouble(args[6]), blend_scale = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred()) return NULL;
    Buf bo = {0}, ba = {0}, bb = {0}, bw = {0}, bacc = {0}, boff = {0}, bsig = {0}, bx = {0};
    PyObject *res = NULL;
    NoiseArgs noise = {0, 0, NULL, NULL, NULL, NULL, NULL, NULL, 0, 0, 0, NULL};
    const int noisy = nargs == 15 && (args[13] != Py_None || args[14] != Py_None);
    if (noisy) {
        noise.key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[11]);
        if (noise.key == (uint64_t)-1 && PyErr_Occurred()) return NULL;
        noise.n0 = (int64_t)PyLong_AsLongLong(args[12]);
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
    if (noisy && args[13] != Py_None) {
        if (!buf_take(args[13], &bsig, "sigma", "fd", 1, 0)) goto done;
        if (buf_kind(&bsig.v) != kind || bsig.v.shape[0] != C || C > NOISE_MAX_C || noise.n0 < 0) {
            PyErr_Format(PyExc_ValueError, "sigma must be (%zd,) of out's dtype, C <= %d, n0 >= 0", C, NOISE_MAX_C);
            goto done;
        }
        noise.sigma_f = (const float *)bsig.v.buf;
        noise.sigma_d = (const double *)bsig.v.buf;
    }
    if (noisy && args[14] != Py_None) {
        if (!buf_take(args[14], &bx, "extra", "fd", 2, 0)) goto done;
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
            rc = synth_segment_f32(m, C, N, fb, ph[0], ph[1], ph[2], w, (const float *)ba.v.buf,
                                   bb.held ? (const float *)bb.v.buf : NULL, xi0, blend_scale, (float *)bo.v.buf, acc,
                                   off, na);
        else
            rc = synth_segment_f64(m, C, N, fb, ph[0], ph[1], ph[2], w, (const double *)ba.v.buf,
                                   bb.held ? (const double *)bb.v.buf : NULL, xi0, blend_scale, (double *)bo.v.buf,
                                   acc, off, na);
        Py_END_ALLOW_THREADS
        if (rc) {
            PyErr_Format(PyExc_ValueError, "segment rejected m=%zd, C=%zd, N=%zd", m, C, N);
            goto done;
        }
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bo), buf_drop(&ba), buf_drop(&bb), buf_drop(&bw), buf_drop(&bacc), buf_drop(&boff), buf_drop(&bsig);
    buf_drop(&bx);
    return res;
}

/* acc (C, 6) and off (C,) float64 for a block of C channels, into bacc / boff; 0 and ValueError if not. */
static int take_acc(PyObject *acc, PyObject *off, Py_ssize_t C, Buf *bacc, Buf *boff)
{
    if (acc == Py_None) return 1;
    if (off == Py_None) {
        PyErr_SetString(PyExc_ValueError, "off must be given with acc");
        return 0;
    }
    if (!buf_take(acc, bacc, "acc", "d", 2, 1) || !buf_take(off, boff, "off", "d", 1, 0)) return 0;
    if (bacc->v.shape[0] != C || bacc->v.shape[1] != 6 || boff->v.shape[0] != C) {
        PyErr_Format(PyExc_ValueError, "acc must be (%zd, 6) and off (%zd,) float64", C, C);
        return 0;
    }
    return 1;
}

PyDoc_STRVAR(accumulate_doc, "accumulate(x, off, acc): see kernel.accumulate");

static PyObject *py_accumulate(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("accumulate", nargs, 3)) return NULL;
    Buf bx = {0}, bacc = {0}, boff = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &bx, "x", "fd", 2, 0)) goto done;
    const Py_ssize_t n = bx.v.shape[0], C = bx.v.shape[1];
    if (!take_acc(args[2], args[1], C, &bacc, &boff)) goto done;
    if (!bacc.held) {
        PyErr_SetString(PyExc_ValueError, "acc must be given");
        goto done;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = buf_kind(&bx.v) == 'f' ? synth_accumulate_f32(n, C, bx.v.buf, boff.v.buf, bacc.v.buf)
                                : synth_accumulate_f64(n, C, bx.v.buf, boff.v.buf, bacc.v.buf);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_Format(PyExc_ValueError, "accumulate rejected n=%zd, C=%zd", n, C);
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bx), buf_drop(&bacc), buf_drop(&boff);
    return res;
}

PyDoc_STRVAR(noise_add_doc, "noise_add(x, key, n0, sigma, extra, off, acc): see kernel.noise_add");

static PyObject *py_noise_add(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("noise_add", nargs, 7)) return NULL;
    const uint64_t key = (uint64_t)PyLong_AsUnsignedLongLongMask(args[1]);
    const int64_t n0 = PyLong_AsLongLong(args[2]);
    if (PyErr_Occurred()) return NULL;
    Buf bx = {0}, bsig = {0}, bex = {0}, bacc = {0}, boff = {0};
    PyObject *res = NULL;
    if (!buf_take(args[0], &bx, "x", "fd", 2, 1)) goto done;
    const char kind = buf_kind(&bx.v);
    const char kinds[2] = {kind, 0};
    const Py_ssize_t n = bx.v.shape[0], C = bx.v.shape[1];
    if (!buf_take_opt(args[3], &bsig, "sigma", kinds, 1, 0) || !buf_take_opt(args[4], &bex, "extra", kinds, 2, 0)
        || !take_acc(args[6], args[5], C, &bacc, &boff))
        goto done;
    if ((bsig.held && bsig.v.shape[0] != C) || (bex.held && (bex.v.shape[0] != n || bex.v.shape[1] != C))
        || C > NOISE_MAX_C || n0 < 0) {
        PyErr_Format(PyExc_ValueError, "noise_add: sigma (%zd,) and extra (%zd, %zd) of x's dtype, C <= %d, n0 >= 0",
                     C, n, C, NOISE_MAX_C);
        goto done;
    }
    const void *sig = bsig.held ? bsig.v.buf : NULL, *ex = bex.held ? bex.v.buf : NULL;
    const double *off = boff.held ? boff.v.buf : NULL;
    double *acc = bacc.held ? bacc.v.buf : NULL;
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = kind == 'f' ? synth_noise_add_f32(n, C, bx.v.buf, key, n0, sig, ex, off, acc)
                     : synth_noise_add_f64(n, C, bx.v.buf, key, n0, sig, ex, off, acc);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_Format(PyExc_ValueError, "noise_add rejected n=%zd, C=%zd", n, C);
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bx), buf_drop(&bsig), buf_drop(&bex), buf_drop(&bacc), buf_drop(&boff);
    return res;
}

PyDoc_STRVAR(features_doc, "features(acc, n, off, out): see kernel.features_from_acc");

static PyObject *py_features(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("features", nargs, 4)) return NULL;
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
    res = Py_NewRef(Py_None);
done:
    buf_drop(&ba), buf_drop(&bo), buf_drop(&bout);
    return res;
}

PyDoc_STRVAR(carrier_mix_doc, "carrier_mix(cs, re, im, out): see kernel.carrier_mix");

static PyObject *py_carrier_mix(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("carrier_mix", nargs, 4)) return NULL;
    Buf bo = {0}, bc = {0}, br = {0}, bi = {0};
    PyObject *res = NULL;
    if (!buf_take(args[3], &bo, "out", "fd", 2, 1)) goto done;
    const char kinds[2] = {buf_kind(&bo.v), 0};
    if (!buf_take(args[0], &bc, "cs", kinds, 2, 0) || !buf_take(args[1], &br, "re", kinds, 2, 0)
        || !buf_take(args[2], &bi, "im", kinds, 2, 0))
        goto done;
    const Py_ssize_t m = bo.v.shape[0], C = bo.v.shape[1];
    if (bc.v.shape[0] != m || bc.v.shape[1] != 2 || br.v.shape[0] != m || br.v.shape[1] != C
        || bi.v.shape[0] != m || bi.v.shape[1] != C) {
        PyErr_SetString(PyExc_ValueError, "carrier_mix: shapes (m, 2), (m, C), (m, C), (m, C)");
        goto done;
    }
    if (kinds[0] == 'f') synth_carrier_mix_f32(m, C, bc.v.buf, br.v.buf, bi.v.buf, bo.v.buf);
    else synth_carrier_mix_f64(m, C, bc.v.buf, br.v.buf, bi.v.buf, bo.v.buf);
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bo), buf_drop(&bc), buf_drop(&br), buf_drop(&bi);
    return res;
}

PyDoc_STRVAR(slip_warp_doc, "slip_warp(j0, c1, c2, u_frac, w, jw0, kappas, out): see kernel.slip_warp");

static PyObject *py_slip_warp(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("slip_warp", nargs, 8)) return NULL;
    const double j0 = PyFloat_AsDouble(args[0]), c1 = PyFloat_AsDouble(args[1]), c2 = PyFloat_AsDouble(args[2]);
    const double u_frac = PyFloat_AsDouble(args[3]);
    const int64_t jw0 = PyLong_AsLongLong(args[5]);
    if (PyErr_Occurred()) return NULL;
    Buf bw = {0}, bk = {0}, bo = {0};
    PyObject *res = NULL;
    if (!buf_take(args[4], &bw, "w", "d", 1, 0) || !buf_take(args[6], &bk, "kappas", "d", 1, 0)
        || !buf_take(args[7], &bo, "out", "q", 2, 1))
        goto done;
    const Py_ssize_t K = bk.v.shape[0], m = bo.v.shape[1];
    if (bo.v.shape[0] != K || K < 1 || K > 8) {
        PyErr_SetString(PyExc_ValueError, "slip_warp: out (K, m) int64 for K = 1 .. 8 factors");
        goto done;
    }
    int rc;
    Py_BEGIN_ALLOW_THREADS
    rc = synth_slip_warp(m, j0, c1, c2, u_frac, bw.v.buf, bw.v.shape[0], jw0, bk.v.buf, K, bo.v.buf);
    Py_END_ALLOW_THREADS
    if (rc) {
        PyErr_SetString(PyExc_ValueError, "slip_warp: a sample falls outside the walk's values");
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bw), buf_drop(&bk), buf_drop(&bo);
    return res;
}

PyDoc_STRVAR(set_isa_cap_doc, "set_isa_cap(cap) -> previous: the highest instruction set the kernels may use (2 "
                              "AVX-512, 1 AVX2 + FMA, 0 baseline), for the tests of the other paths");

static PyObject *py_set_isa_cap(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("set_isa_cap", nargs, 1)) return NULL;
    const long cap = PyLong_AsLong(args[0]);
    if (cap == -1 && PyErr_Occurred()) return NULL;
    const int old = synth_isa_cap;
    synth_isa_cap = (int)cap;
    return PyLong_FromLong(old);
}

PyDoc_STRVAR(fast_path_doc, "fast_path() -> bool: whether the AVX2 + FMA paths run (CPU and instruction-set cap)");

static PyObject *py_fast_path(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self, (void)args;
    if (!nargs_ok("fast_path", nargs, 0)) return NULL;
    return PyBool_FromLong(synth_isa_cap >= 1 && HAVE_FMA_PATH);
}

static PyMethodDef methods[] = {
    METHOD(segment, segment_doc),
    METHOD(accumulate, accumulate_doc),
    METHOD(noise_add, noise_add_doc),
    METHOD(features, features_doc),
    METHOD(carrier_mix, carrier_mix_doc),
    METHOD(slip_warp, slip_warp_doc),
    METHOD(set_isa_cap, set_isa_cap_doc),
    METHOD(fast_path, fast_path_doc),
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_synth",
                                       "The synthesiser's C kernels (bkabem_core/synth/kernel.py is their Python face)",
                                       -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__synth(void)
{
    PyObject *m = PyModule_Create(&moduledef);
    if (m != NULL && PyModule_AddFunctions(m, synth_lines_methods) < 0) Py_CLEAR(m);
    return m;
}
