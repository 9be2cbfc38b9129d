/* The extension module bkabem_core.kernels._blocktri: the block-tridiagonal solver (blocktri.h) as a Python
 * function (bkabem_core/fe/solvers.py, ShaftSolver). */
#include <Python.h>

#include "blocktri.h"
#include "py_buffers.h"

PyDoc_STRVAR(solve_doc, "solve(coef_d, coef_u, coef_l, o_node, coef_oo, coef_so, coef_os, w, W, f_s, f_o, x_o, D, U, "
                        "L, X, g, bad, min_pivot_ratio) -> systems whose smallest pivot was too small: see "
                        "fe.solvers.ShaftSolver.solve");

static PyObject *py_solve(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (!nargs_ok("solve", nargs, 19)) return NULL;
    static const char *names[18] = {"coef_d", "coef_u", "coef_l", "o_node", "coef_oo", "coef_so", "coef_os", "w", "W",
                                    "f_s", "f_o", "x_o", "D", "U", "L", "X", "g", "bad"};
    static const char kinds[18] = {'d', 'd', 'd', 'i', 'd', 'd', 'd', 'd', 'd', 'Z', 'Z', 'Z', 'Z', 'Z', 'Z', 'Z',
                                   'Z', 'i'};
    static const int ndims[18] = {2, 2, 2, 1, 2, 2, 2, 1, 1, 2, 2, 2, 3, 3, 3, 3, 2, 1};
    static const int writes[18] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 1, 1, 1, 1, 1};
    const double min_pivot = PyFloat_AsDouble(args[18]);
    if (PyErr_Occurred()) return NULL;
    Buf b[18];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    for (int i = 0; i < 18; ++i) {
        const char k[2] = {kinds[i], 0};
        if (!buf_take(args[i], &b[i], names[i], k, ndims[i], writes[i])) goto done;
    }
    const Py_ssize_t B = b[7].v.shape[0], no = b[3].v.shape[0], nb = b[12].v.shape[0];
    const Py_ssize_t nd = nb * 16, nu = (nb > 1 ? nb - 1 : 1) * 16;
    if (nb < 1 || b[0].v.shape[0] != 4 || b[0].v.shape[1] != nd || b[1].v.shape[0] != 4 || b[2].v.shape[0] != 4
        || (nb > 1 && (b[1].v.shape[1] != (nb - 1) * 16 || b[2].v.shape[1] != (nb - 1) * 16))
        || b[4].v.shape[0] != 4 || b[4].v.shape[1] != no || b[5].v.shape[1] != 4 * no || b[6].v.shape[1] != 4 * no
        || b[8].v.shape[0] != B || b[9].v.shape[0] != B || b[9].v.shape[1] != 4 * nb || b[10].v.shape[0] != B
        || b[10].v.shape[1] != no || b[11].v.shape[0] != B || b[11].v.shape[1] != no || buf_len(&b[12]) != nd
        || buf_len(&b[13]) < nu || buf_len(&b[14]) < nu || buf_len(&b[15]) < nu || buf_len(&b[16]) != 4 * nb
        || b[17].v.shape[0] != B) {
        PyErr_SetString(PyExc_ValueError, "solve: the coefficient blocks, forces and work arrays do not fit the shaft "
                                          "of D (nb, 4, 4) and the batch of w (B,)");
        goto done;
    }
    for (Py_ssize_t o = 0; o < no; ++o) {
        const int node = ((const int *)b[3].v.buf)[o];
        if (node < 0 || node >= nb) {
            PyErr_SetString(PyExc_ValueError, "solve: o_node out of range");
            goto done;
        }
    }
    int n_bad;
    Py_BEGIN_ALLOW_THREADS
    n_bad = bt_solve_coef((int)nb, (int)B, b[0].v.buf, b[1].v.buf, b[2].v.buf, (int)no, b[3].v.buf, b[4].v.buf,
                          b[5].v.buf, b[6].v.buf, b[7].v.buf, b[8].v.buf, b[9].v.buf, b[10].v.buf, b[11].v.buf,
                          b[12].v.buf, b[13].v.buf, b[14].v.buf, b[15].v.buf, b[16].v.buf, b[17].v.buf, min_pivot);
    Py_END_ALLOW_THREADS
    res = PyLong_FromLong(n_bad);
done:
    for (int i = 0; i < 18; ++i) buf_drop(&b[i]);
    return res;
}

static PyMethodDef methods[] = {METHOD(solve, solve_doc), {NULL, NULL, 0, NULL}};

static struct PyModuleDef moduledef = {PyModuleDef_HEAD_INIT, "_blocktri",
                                       "Batched block-tridiagonal solve of the FE model (bkabem_core/fe/solvers.py)",
                                       -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__blocktri(void) { return PyModule_Create(&moduledef); }
