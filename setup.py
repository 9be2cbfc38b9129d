"""Build hook for the one C kernel (bkabem_core/_blocktri.c); all metadata lives in pyproject.toml."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension("bkabem_core._blocktri", sources=["bkabem_core/_blocktri.c"],
                  extra_compile_args=["-O3", "-std=c99", "-fcx-limited-range"], optional=True),
    ],
)
