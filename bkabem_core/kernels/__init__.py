"""The C kernels: extension modules built at install time (setup.py), bound through the CPython API (the arrays by
the buffer protocol), loaded by the modules that use them. What they do and why: docs/performance.md.

    _blocktri   -- batched block-tridiagonal complex solve (fe.solvers): blocktri.c, py_blocktri.c
    _modalsum   -- pole-residue sums of the modal form and its speed cells (fe.modal): modalsum.c, py_modalsum.c
    _synth      -- the synthesiser's sample loops, line sets, noise, slip, floor, strikes (synth.kernel): synth_*.c,
                   py_synth.c, py_synth_lines.c
"""

__all__: list[str] = []
