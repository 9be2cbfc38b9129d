"""Build hook for the C kernels (bkabem_core/_blocktri.c, _modalsum.c, _synthloop.c); all metadata lives in
pyproject.toml. All are optional: without a compiler the numpy fallbacks are used."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension("bkabem_core._blocktri", sources=["bkabem_core/_blocktri.c"],
                  extra_compile_args=["-O3", "-std=c99", "-fcx-limited-range"], optional=True),
        Extension("bkabem_core._modalsum", sources=["bkabem_core/_modalsum.c"],
                  extra_compile_args=["-O3", "-std=c99"], optional=True),
        # -ffp-contract=off: the sample loop must round exactly like numpy (no fused multiply-add)
        Extension("bkabem_core._synthloop", sources=["bkabem_core/_synthloop.c"],
                  depends=["bkabem_core/_synthbase.h", "bkabem_core/_synthblock.h", "bkabem_core/_synthnoise.h",
                           "bkabem_core/_synthlines.h", "bkabem_core/_synthrows.h", "bkabem_core/_synthknot.h",
                           "bkabem_core/_synthfloor.h"],
                  libraries=["m"],
                  extra_compile_args=["-O3", "-std=c99", "-ffp-contract=off"], optional=True),
    ],
)
