"""The C kernels: built at install time (setup.py), loaded by the modules that use them.

    _blocktri   -- batched block-tridiagonal complex solve (fe.solvers)
    _modalsum   -- pole-residue sums of the modal form (fe.modal)
    _synthloop  -- the synthesiser's sample loop, line sets, noise and floor (synth.kernel)
"""

__all__: list[str] = []
