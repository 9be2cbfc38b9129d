"""Drive the real Rerun viewer headless: open a ``.rrd``, set the time, list the views and their
errors, take screenshots of the whole window and of each view (rerun-sdk 0.41).

    python -m bkabem_ros.rerun_viewer recordings/demo.rrd --out docs/img [--at 25 --at 29.5]

The viewer is the ``rerun`` binary of the wheel started as ``rerun --headless --bind 127.0.0.1``
(no window, no GPU: it renders with Mesa's software Vulkan driver, lavapipe, which
``tools/setup_viewer.sh`` installs); :class:`rerun.experimental.ViewerClient` talks to it over
gRPC on 127.0.0.1. Nothing listens beyond the loopback address.

:func:`view_statistics` reads a view's screenshot as pixels: the fraction of pixels that differ
from the view's background and how many colours they use. An empty plot (axes, grid and a
title only) stays near 3 %; a plotted waveform or spectrum is well above (see the tests).
"""

from __future__ import annotations

import argparse
import io
import os
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .rerun_io import TIMELINE, rerun_binary

__all__ = ["HeadlessViewer", "ViewStats", "view_statistics", "main"]

#: Window size of the headless viewer (logical points) for the screenshots.
WINDOW_SIZE = (1920, 1080)


def slug(name: str) -> str:
    """File-name form of a view name: ``DE envelope spectrum [m/s²] ...`` -> ``de_envelope_spectrum``."""
    base = name.split(" [")[0].split(":")[0].lower()
    return "".join(ch if ch.isalnum() else "_" for ch in base).strip("_").replace("__", "_")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def lavapipe_available() -> bool:
    """Whether a Vulkan driver is installed (the viewer's GL fallback cannot render headless)."""
    dirs = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d")
    return any(Path(d).is_dir() and any(Path(d).glob("*.json")) for d in dirs)


@dataclass
class ViewStats:
    """Pixel statistics of one view's screenshot: ``ink`` = fraction of pixels differing from the
    background (the most common colour) by more than 24 grey levels; ``colours`` = distinct
    colours among them (quantised to 4 bits per channel)."""

    name: str
    ink: float
    colours: int
    width: int
    height: int


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image  # noqa: PLC0415  (pillow comes with rerun-sdk)

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def view_statistics(png: bytes, name: str = "") -> ViewStats:
    """:class:`ViewStats` of a PNG screenshot."""
    img = _pixels(png).astype(np.int16)
    h, w, _ = img.shape
    flat = img.reshape(-1, 3)
    q = (flat >> 4).astype(np.int32)
    codes = (q[:, 0] << 8) | (q[:, 1] << 4) | q[:, 2]
    bg_code = np.bincount(codes).argmax()
    bg = np.array([(bg_code >> 8) & 15, (bg_code >> 4) & 15, bg_code & 15]) * 16 + 8
    ink = np.abs(flat - bg).max(axis=1) > 24
    return ViewStats(name, float(ink.mean()), int(np.unique(codes[ink]).size), w, h)


@dataclass
class HeadlessViewer:
    """A headless ``rerun`` viewer process on 127.0.0.1 and its :class:`ViewerClient`.

    Use as a context manager; :meth:`close` stops the process (it is started in its own process
    group, which is killed if it does not quit)."""

    window_size: tuple[int, int] = WINDOW_SIZE
    port: int = 0
    startup_timeout_s: float = 30.0
    proc: subprocess.Popen | None = field(default=None, init=False)
    client: object = field(default=None, init=False)
    log_path: Path | None = field(default=None, init=False)

    def __enter__(self) -> HeadlessViewer:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        from rerun.experimental import ViewerClient  # noqa: PLC0415

        if not lavapipe_available():
            raise RuntimeError("no Vulkan driver for the headless viewer: install Mesa's lavapipe "
                               "(Debian: apt-get install mesa-vulkan-drivers; tools/setup_viewer.sh)")
        self.port = self.port or _free_port()
        fd, log = tempfile.mkstemp(prefix="bkabem_rerun_viewer_", suffix=".log")
        self.log_path = Path(log)
        env = dict(os.environ, RUST_LOG=os.environ.get("RUST_LOG", "warn"))
        self.proc = subprocess.Popen(
            [rerun_binary(), "--headless", "--bind", "127.0.0.1", "--port", str(self.port),
             "--window-size", f"{self.window_size[0]}x{self.window_size[1]}", "--hide-welcome-screen",
             "--threads", "1"],
            stdout=fd, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True, env=env)
        os.close(fd)
        t_end = time.monotonic() + self.startup_timeout_s
        url = f"rerun+http://127.0.0.1:{self.port}/proxy"
        while True:
            if self.proc.poll() is not None:
                raise RuntimeError(f"headless viewer exited with {self.proc.returncode}: {self.log_tail()}")
            try:
                client = ViewerClient(url)
                client.get_state()
                self.client = client
                return
            except Exception:  # noqa: BLE001 - not listening yet
                if time.monotonic() > t_end:
                    self.close()
                    raise RuntimeError(f"headless viewer not answering on {url}: {self.log_tail()}") from None
                time.sleep(0.1)

    def log_tail(self, n: int = 2000) -> str:
        try:
            return self.log_path.read_text(errors="replace")[-n:] if self.log_path else ""
        except OSError:
            return ""

    def open(self, rrd, timeout_s: float = 30.0):
        """Open a recording and wait until it is loaded; returns the viewer state."""
        self.client.open(str(Path(rrd).resolve()))
        t_end = time.monotonic() + timeout_s
        while True:
            st = self.client.get_state()
            if not st.loading and st.recordings and st.recordings[0].timelines:
                return st
            if time.monotonic() > t_end:
                raise TimeoutError(f"{rrd}: still loading after {timeout_s} s")
            time.sleep(0.1)

    def set_time(self, seconds: float | None = None, play_state: str = "paused") -> None:
        """Time cursor on ``sample_time`` at ``seconds``, paused (None: leave what the blueprint set)."""
        if seconds is not None:
            self.client.set_time(TIMELINE, duration=float(seconds), play_state=play_state)

    def screenshot(self, view_id=None, settle: int = 2, max_shots: int = 8) -> bytes:
        """PNG of the window (or of one view). After a load or a time change the viewer needs a
        few frames to ingest chunks and fit its axes: shots are repeated until ``settle``
        consecutive ones agree (at most ``max_shots``), and the last is returned."""
        last, same, png = None, 0, b""
        for _ in range(max(max_shots, 1)):
            png = self.client.take_screenshot(view_id)
            pix = _pixels(png)
            same = same + 1 if last is not None and pix.shape == last.shape and np.mean(pix != last) < 1e-3 else 0
            if same + 1 >= settle:
                break
            last = pix
        return png

    def views(self):
        return self.client.get_state().views

    def show_tab(self, index: int) -> None:
        """Make tab ``index`` (or the last one, for shorter groups) active in every tab group of
        the current recording's blueprint (views in hidden tabs cannot be screenshot)."""
        bp = self.client.get_blueprint().blueprint
        for value in bp.values():
            c = value.get("ContainerBlueprint")
            if c and c.get("container_kind") == "Tabs" and c.get("contents"):
                c["active_tab"] = c["contents"][min(index, len(c["contents"]) - 1)]
        self.client.set_blueprint(bp, of="recording")

    def hidden_views(self) -> set[str]:
        """Ids of the views in tabs that are not the active one."""
        hidden = set()
        for value in self.client.get_blueprint().blueprint.values():
            c = value.get("ContainerBlueprint")
            if c and c.get("container_kind") == "Tabs":
                active = c.get("active_tab") or (c.get("contents") or [None])[0]
                hidden |= {p.rsplit("/", 1)[-1] for p in c.get("contents", []) if p != active}
        return hidden

    def tab_count(self) -> int:
        """Largest number of tabs in one tab group of the current blueprint (1 without tabs)."""
        bp = self.client.get_blueprint().blueprint
        return max([len(v["ContainerBlueprint"].get("contents", [])) for v in bp.values()
                    if v.get("ContainerBlueprint", {}).get("container_kind") == "Tabs"] or [1])

    def shoot_every_view(self, settle: int = 2):
        """{view name: (View, PNG)} of every view of the blueprint, tab by tab; the first tabs are
        active again afterwards."""
        out = {}
        n = self.tab_count()
        for i in range(n):
            if n > 1:
                self.show_tab(i)
            self.screenshot(settle=settle)
            hidden = self.hidden_views()
            for view in self.views():
                if view.name not in out and str(view.view_id) not in hidden:
                    out[view.name] = (view, self.screenshot(view.view_id, settle=settle))
        if n > 1:
            self.show_tab(0)
        return out

    def errors(self) -> list[str]:
        """WARN/ERROR lines of the viewer's log other than the software-rasteriser notice."""
        return [f"{e.level} {e.target}: {e.message}" for e in self.client.get_logs()
                if e.level in ("WARN", "ERROR") and "oftware rasterizer" not in e.message
                and "Failed to load examples" not in e.message]

    def close(self) -> None:
        if self.proc is None:
            return
        try:
            try:
                self.proc.terminate()
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, 9)
                self.proc.wait()
        finally:
            self.proc = None
            self.client = None
            if self.log_path is not None:
                try:
                    self.log_path.unlink()
                except OSError:
                    pass


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m bkabem_ros.rerun_viewer", description=__doc__.split("\n\n")[0])
    p.add_argument("rrd")
    p.add_argument("--out", default="out/viewer")
    p.add_argument("--at", type=float, action="append", default=None, help="time cursor [s] (repeatable)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with HeadlessViewer() as v:
        v.open(args.rrd)
        for t in args.at or [None]:
            v.set_time(t)
            png = v.screenshot()
            name = out / f"viewer_{'default' if t is None else f'{t:g}s'}.png"
            name.write_bytes(png)
            print(f"wrote {name}")
            for name, (view, vpng) in v.shoot_every_view().items():
                s = view_statistics(vpng, name)
                (out / f"view_{slug(name)}.png").write_bytes(vpng)
                print(f"  {name:60s} ink {s.ink * 100:5.1f} %  colours {s.colours:4d}  "
                      f"reports {[r.summary for r in view.reports]}")
        for e in v.errors():
            print("viewer:", e)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
