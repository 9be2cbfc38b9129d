/* The line-set and broadband-floor functions of the extension module _synth (py_synth_lines.c). */
#ifndef BKABEM_PY_SYNTH_LINES_H
#define BKABEM_PY_SYNTH_LINES_H

#include <Python.h>

extern PyMethodDef synth_lines_methods[];

#endif
