/*
 * Arrays into the kernels' Python functions (every extension module of bkabem_core/kernels): the buffer protocol
 * does the checks that keep a kernel inside the memory it is given (C-contiguous, writeable where written, element
 * type by format and size, number of dimensions); the functions check the shapes. One failed check raises
 * ValueError naming the argument. Why the kernels are bound this way: docs/performance.md.
 */
#ifndef BKABEM_PY_BUFFERS_H
#define BKABEM_PY_BUFFERS_H

#include <Python.h>
#include <string.h>

typedef struct {
    Py_buffer v;
    int held;
} Buf;

/* Element type of a buffer: 'f' float32, 'd' float64, 'q' int64, 'i' int32, 'h' int16, 'Z' complex128,
 * 'C' complex64, 0 anything else (native byte order only). */
static inline char buf_kind(const Py_buffer *v)
{
    const char *f = v->format ? v->format : "B";
    if (*f == '@' || *f == '=') ++f;
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    else if (*f == '<') ++f;
#endif
    if (f[0] == 'f' && f[1] == 0 && v->itemsize == 4) return 'f';
    if (f[0] == 'd' && f[1] == 0 && v->itemsize == 8) return 'd';
    if ((f[0] == 'q' || f[0] == 'l') && f[1] == 0 && v->itemsize == 8) return 'q';
    if ((f[0] == 'i' || f[0] == 'l') && f[1] == 0 && v->itemsize == 4) return 'i';
    if (f[0] == 'h' && f[1] == 0 && v->itemsize == 2) return 'h';
    if (f[0] == 'Z' && f[1] == 'd' && f[2] == 0 && v->itemsize == 16) return 'Z';
    if (f[0] == 'Z' && f[1] == 'f' && f[2] == 0 && v->itemsize == 8) return 'C';
    return 0;
}

static inline const char *buf_kind_name(char k)
{
    switch (k) {
    case 'f': return "float32";
    case 'd': return "float64";
    case 'q': return "int64";
    case 'i': return "int32";
    case 'h': return "int16";
    case 'Z': return "complex128";
    case 'C': return "complex64";
    default: return "?";
    }
}

/* Takes the buffer of o (C-contiguous, writeable if asked) of ndim dimensions and an element type among kinds; on
 * failure raises ValueError naming the argument and returns 0. */
static inline int buf_take(PyObject *o, Buf *b, const char *name, const char *kinds, int ndim, int writable)
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
        PyErr_Format(PyExc_ValueError, "%s must be a %d-d array of dtype %s%s (got %d-d, format %s)", name, ndim,
                     buf_kind_name(kinds[0]), kinds[1] ? " or float64" : "", b->v.ndim,
                     b->v.format ? b->v.format : "B");
        return 0;
    }
    return 1;
}

/* buf_take for an optional argument: None leaves b empty. */
static inline int buf_take_opt(PyObject *o, Buf *b, const char *name, const char *kinds, int ndim, int writable)
{
    return o == Py_None ? 1 : buf_take(o, b, name, kinds, ndim, writable);
}

static inline void buf_drop(Buf *b)
{
    if (b->held) PyBuffer_Release(&b->v), b->held = 0;
}

/* The number of elements of a held buffer. */
static inline Py_ssize_t buf_len(const Buf *b)
{
    Py_ssize_t n = 1;
    for (int i = 0; i < b->v.ndim; ++i) n *= b->v.shape[i];
    return n;
}

/* The call must take n arguments: TypeError naming the function otherwise. */
static inline int nargs_ok(const char *fn, Py_ssize_t nargs, Py_ssize_t n)
{
    if (nargs == n) return 1;
    PyErr_Format(PyExc_TypeError, "%s takes %zd arguments (got %zd)", fn, n, nargs);
    return 0;
}

#define METHOD(name, doc) {#name, (PyCFunction)(void (*)(void))py_##name, METH_FASTCALL, doc}

#endif
