"""The Rerun command-line tool of the wheel: where its real executable is, and compacting a written ``.rrd``."""

from __future__ import annotations

__all__ = ["rerun_binary", "optimize_rrd"]


def rerun_binary() -> str:
    """Path of the real ``rerun`` executable shipped in ``rerun_cli`` (not the Python wrapper,
    whose PID is not the viewer's)."""
    import os  # noqa: PLC0415

    import rerun_cli  # noqa: PLC0415

    return os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")


def optimize_rrd(path) -> str | None:
    """Compact the chunks of an ``.rrd`` in place with ``rerun rrd optimize`` (the SDK writes one
    chunk per send; the viewer loads fewer, larger chunks faster). Returns None, or why the
    file was left as written."""
    import os  # noqa: PLC0415
    import subprocess  # noqa: PLC0415

    path = str(path)
    tmp = path + ".optimizing.rrd"
    try:
        size = os.path.getsize(path)
        r = subprocess.run([rerun_binary(), "rrd", "optimize", path, "-o", tmp], capture_output=True, text=True,
                           timeout=60 + size / 5e6, stdin=subprocess.DEVNULL)
        if r.returncode != 0 or not os.path.exists(tmp):
            return f"rerun rrd optimize failed ({r.returncode}): {r.stderr.strip()[-300:]}"
        os.replace(tmp, path)
        return None
    except (OSError, subprocess.SubprocessError) as exc:
        return f"rerun rrd optimize: {type(exc).__name__}: {exc}"
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
