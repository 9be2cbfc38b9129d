"""Build hook for the C kernels (bkabem_core/kernels/_blocktri.c, _modalsum.c, _synthloop.c); all metadata lives in
pyproject.toml. All are optional: without a compiler the numpy fallbacks are used."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension("bkabem_core.kernels._blocktri", sources=["bkabem_core/kernels/_blocktri.c"],
                  extra_compile_args=["-O3", "-std=c99", "-fcx-limited-range"], optional=True),
        Extension("bkabem_core.kernels._modalsum", sources=["bkabem_core/kernels/_modalsum.c"],
                  extra_compile_args=["-O3", "-std=c99"], optional=True),
        # -ffp-contract=off: the sample loop must round exactly like numpy (no fused multiply-add)
        Extension("bkabem_core.kernels._synthloop", sources=["bkabem_core/kernels/_synthloop.c"],
                  depends=["bkabem_core/kernels/_synthbase.h", "bkabem_core/kernels/_synthblock.h", "bkabem_core/kernels/_synthnoise.h",
                           "bkabem_core/kernels/_synthlines.h", "bkabem_core/kernels/_synthrows.h", "bkabem_core/kernels/_synthknot.h",
                           "bkabem_core/kernels/_synthfloor.h"],
                  libraries=["m"],
                  extra_compile_args=["-O3", "-std=c99", "-ffp-contract=off"], optional=True),
    ],
)
