/* The extension module bkabem_core.kernels._modalsum: the pole-residue sums (modalsum.h) as Python functions
 * (bkabem_core/fe/modal.py: OrderModalForm, SpeedCells). A speed cell's arrays go into a capsule once
 * (cell_plan), so that an evaluation (cell_sum) takes one array besides the cell. */
#include <Python.h>

#include "modalsum.h"
#include "py_buffers.h"

PyDoc_STRVAR(modal_sum_doc, "modal_sum(w, lam_re, lam_im, e_re, e_im, x0_re, x0_im, x_re, x_im): see "
                            "fe.modal.OrderModalForm");

static PyObject *py_modal_sum(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("modal_sum", nargs, 9)) return NULL;
    static const char *names[9] = {"w", "lam_re", "lam_im", "e_re", "e_im", "x0_re", "x0_im", "x_re", "x_im"};
    static const int ndims[9] = {1, 2, 2, 3, 3, 2, 2, 2, 2};
    Buf b[9];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    for (int i = 0; i < 9; ++i)
        if (!buf_take(args[i], &b[i], names[i], "d", ndims[i], i >= 7)) goto done;
    const Py_ssize_t K = b[0].v.shape[0], R = b[1].v.shape[1];
    int bad = R > MODAL_MAXR;
    for (int i = 1; i < 9; ++i) bad |= b[i].v.shape[0] != K;
    bad |= b[2].v.shape[1] != R || b[3].v.shape[1] != R || b[4].v.shape[1] != R;
    bad |= b[3].v.shape[2] != 8 || b[4].v.shape[2] != 8;
    for (int i = 5; i < 9; ++i) bad |= b[i].v.shape[1] != 8;
    if (bad) {
        PyErr_Format(PyExc_ValueError, "modal_sum: w (K,), lam (K, R), e (K, R, 8), x0 and x (K, 8), R <= %d",
                     MODAL_MAXR);
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    modal_sum8((int)K, (int)R, b[0].v.buf, b[1].v.buf, b[2].v.buf, b[3].v.buf, b[4].v.buf, b[5].v.buf, b[6].v.buf,
               b[7].v.buf, b[8].v.buf);
    Py_END_ALLOW_THREADS
    res = Py_NewRef(Py_None);
done:
    for (int i = 0; i < 9; ++i) buf_drop(&b[i]);
    return res;
}

#define CELL_ARRAYS 8

typedef struct {
    Buf b[CELL_ARRAYS];
    ModalCell c;
} CellCapsule;

static void cell_capsule_free(PyObject *cap)
{
    CellCapsule *c = PyCapsule_GetPointer(cap, "bkabem.ModalCell");
    if (c == NULL) return;
    for (int i = 0; i < CELL_ARRAYS; ++i) buf_drop(&c->b[i]);
    free(c);
}

PyDoc_STRVAR(cell_plan_doc, "cell_plan(nu, w_per_hz, coef_re, coef_im, near_start, near_lr, near_li, near_er, "
                            "near_ei) -> a speed cell for cell_sum: see fe.modal.SpeedCells");

static PyObject *py_cell_plan(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("cell_plan", nargs, CELL_ARRAYS + 1)) return NULL;
    static const char *names[CELL_ARRAYS] = {"w_per_hz", "coef_re", "coef_im", "near_start", "near_lr", "near_li",
                                             "near_er", "near_ei"};
    static const char *kinds[CELL_ARRAYS] = {"d", "d", "d", "i", "d", "d", "d", "d"};
    static const int ndims[CELL_ARRAYS] = {1, 3, 3, 1, 1, 1, 2, 2};
    const long nu = PyLong_AsLong(args[0]);
    if (nu == -1 && PyErr_Occurred()) return NULL;
    CellCapsule *c = calloc(1, sizeof(CellCapsule));
    if (c == NULL) return PyErr_NoMemory();
    for (int i = 0; i < CELL_ARRAYS; ++i)
        if (!buf_take(args[i + 1], &c->b[i], names[i], kinds[i], ndims[i], 0)) goto fail;
    const Py_ssize_t K = c->b[0].v.shape[0], nd = c->b[1].v.shape[1], n_near = c->b[4].v.shape[0];
    const int *start = c->b[3].v.buf;
    int bad = nu < 1 || nu > 8 || nd < 1 || nd > MODAL_MAXD || c->b[1].v.shape[0] != K || c->b[1].v.shape[2] != 8;
    bad |= c->b[2].v.shape[0] != K || c->b[2].v.shape[1] != nd || c->b[2].v.shape[2] != 8;
    bad |= c->b[3].v.shape[0] != K + 1 || c->b[5].v.shape[0] != n_near || c->b[6].v.shape[0] != n_near;
    bad |= c->b[6].v.shape[1] != 8 || c->b[7].v.shape[0] != n_near || c->b[7].v.shape[1] != 8;
    for (Py_ssize_t k = 0; k < K && !bad; ++k) bad = start[k] < 0 || start[k] > start[k + 1];
    if (!bad) bad = start[0] != 0 || start[K] != n_near;
    if (bad) {
        PyErr_SetString(PyExc_ValueError, "cell_plan: w_per_hz (K,), coef (K, nd, 8), near_start (K + 1,) int32 "
                                          "rising from 0 to the near poles' count, near_l* (n,), near_e* (n, 8), "
                                          "1 <= nu <= 8");
        goto fail;
    }
    c->c = (ModalCell){(int)K, (int)nd, (int)nu, c->b[0].v.buf, c->b[1].v.buf, c->b[2].v.buf, start, c->b[4].v.buf,
                       c->b[5].v.buf, c->b[6].v.buf, c->b[7].v.buf};
    PyObject *cap = PyCapsule_New(c, "bkabem.ModalCell", cell_capsule_free);
    if (cap == NULL) goto fail;
    return cap;
fail:
    for (int i = 0; i < CELL_ARRAYS; ++i) buf_drop(&c->b[i]);
    free(c);
    return NULL;
}

PyDoc_STRVAR(cell_sum_doc, "cell_sum(cell, f, t, x): the cell's evaluation at shaft speed f [Hz], t in [-1, 1], into x "
                           "(K, nu) complex128");

static PyObject *py_cell_sum(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("cell_sum", nargs, 4)) return NULL;
    const CellCapsule *c = PyCapsule_GetPointer(args[0], "bkabem.ModalCell");
    if (c == NULL) return NULL;
    const double f = PyFloat_AsDouble(args[1]), t = PyFloat_AsDouble(args[2]);
    if (PyErr_Occurred()) return NULL;
    Buf bx = {0};
    if (!buf_take(args[3], &bx, "x", "Z", 2, 1)) return NULL;
    PyObject *res = NULL;
    if (bx.v.shape[0] != c->c.nk || bx.v.shape[1] != c->c.nu) {
        PyErr_Format(PyExc_ValueError, "cell_sum: x must be (%d, %d) complex128", c->c.nk, c->c.nu);
        goto done;
    }
    cell_sum8(&c->c, f, t, bx.v.buf);
    res = Py_NewRef(Py_None);
done:
    buf_drop(&bx);
    return res;
}

static PyMethodDef methods[] = {METHOD(modal_sum, modal_sum_doc), METHOD(cell_plan, cell_plan_doc),
                                METHOD(cell_sum, cell_sum_doc), {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_modalsum",
                                       "Pole-residue sums of the order-wise modal form (bkabem_core/fe/modal.py)", -1,
                                       methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__modalsum(void) { return PyModule_Create(&moduledef); }
