"""Build hook for the C kernels (bkabem_core/kernels: three extension modules, each of its translation units); all
metadata lives in pyproject.toml. All are optional: without a compiler the numpy fallbacks are used."""

from pathlib import Path

from setuptools import Extension, setup

KERNELS = Path("bkabem_core/kernels")
# -ffp-contract=off: the loops must round exactly like their numpy references (no fused multiply-add where the
# code does not ask for one); -fvisibility=hidden: the units share functions, the modules export only their init
FLAGS = ["-O3", "-std=c99", "-ffp-contract=off", "-fvisibility=hidden"]
HEADERS = sorted(str(p) for p in KERNELS.glob("*.h"))


def kernel(name: str, sources: list[str], flags=FLAGS, libraries=()) -> Extension:
    return Extension(f"bkabem_core.kernels.{name}", sources=[str(KERNELS / s) for s in sources], depends=HEADERS,
                     extra_compile_args=list(flags), libraries=list(libraries), optional=True)


setup(
    ext_modules=[
        kernel("_blocktri", ["py_blocktri.c", "blocktri.c"],
               ["-O3", "-std=c99", "-fcx-limited-range", "-fvisibility=hidden"]),
        kernel("_modalsum", ["py_modalsum.c", "modalsum.c"], ["-O3", "-std=c99", "-fvisibility=hidden"]),
        kernel("_synth", ["py_synth.c", "py_synth_lines.c", "synth_common.c", "synth_noise.c", "synth_block.c",
                          "synth_segment.c", "synth_slip.c", "synth_floor.c", "synth_rows.c", "synth_lines.c",
                          "synth_strike.c", "synth_knot.c"], libraries=["m"]),
    ],
)
