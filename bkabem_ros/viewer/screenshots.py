"""Drive the real Rerun viewer headless: open a ``.rrd``, set the time, list the views and their
errors, take screenshots of the whole window and of each view (rerun-sdk 0.41).

    python -m bkabem_ros.viewer.screenshots recordings/demo.rrd [--out out/viewer] [--at 12 --at 29.5]
    python -m bkabem_ros.viewer.screenshots --docs docs/img     # = make screenshots: demo and a scenario run,
                                                          #   then docs/img/rerun_*.png

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
import random
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bkabem_ros.viewer.rerun_io import TIMELINE
from bkabem_ros.viewer.rrd import rerun_binary

__all__ = ["HeadlessViewer", "ViewStats", "expected_legends", "legend_dots", "listening_addresses", "locate", "main",
           "tab_strip", "view_statistics"]

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


def listening_addresses(port: int) -> list[str]:
    """Local addresses listening on TCP ``port``, as /proc/net/tcp{,6} writes them (127.0.0.1 is
    ``0100007F``): the tests check that a viewer listens on the loopback address only."""
    out = []
    for name in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(name).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            parts = line.split()
            addr, p = parts[1].split(":")
            if int(p, 16) == port and parts[3] == "0A":       # 0A = LISTEN
                out.append(addr)
    return out


def lavapipe_available() -> bool:
    """Whether a Vulkan driver is installed (the viewer's GL fallback cannot render headless)."""
    dirs = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d")
    return any(Path(d).is_dir() and any(Path(d).glob("*.json")) for d in dirs)


@dataclass
class ViewStats:
    """Pixel statistics of one view's screenshot: ``ink`` = fraction of pixels differing from the
    background (the most common colour) by more than 24 grey levels; ``colour_ink`` = fraction of
    pixels in colour (max - min of R, G, B > 60: data series, bars and markers; the grid, axes
    and text are grey); ``colours`` = distinct colours among the inked pixels (4 bits per
    channel)."""

    name: str
    ink: float
    colour_ink: float
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
    chroma = (flat.max(axis=1) - flat.min(axis=1)) > 60
    return ViewStats(name, float(ink.mean()), float(chroma.mean()), int(np.unique(codes[ink]).size), w, h)


def locate(full: np.ndarray, view: np.ndarray) -> tuple[int, int] | None:
    """Top-left (x, y) [px] of a view's screenshot ``view`` inside the window's screenshot ``full`` (both RGB
    arrays of the same frame state: the viewer draws a view the same in both), or None."""
    h, w, _ = view.shape
    rows = [np.ascontiguousarray(full[y]).tobytes() for y in range(full.shape[0])]
    for r in sorted({h // 2, h // 3, 2 * h // 3, h - 1}):
        needle = np.ascontiguousarray(view[r]).tobytes()
        for y, hay in enumerate(rows):
            i = hay.find(needle)
            while i >= 0:
                x, y0 = i // 3, y - r
                if i % 3 == 0 and 0 <= y0 <= full.shape[0] - h and np.mean(full[y0:y0 + h, x:x + w] != view) < 1e-3:
                    return x, y0
                i = hay.find(needle, i + 1)
    return None


#: A view's tab strip lies in the rows [y - 24, y - 4) above the view's top y (1 pixel per point).
_STRIP_ROWS = (24, 4)
_INK, _ACTIVE = 60, 160          # grey levels: inactive titles are drawn at ~127, the active one at ~255


def _runs(mask: np.ndarray, min_gap: int) -> list[tuple[int, int]]:
    """(first, last) columns of the runs of ``mask``, runs closer than ``min_gap`` merged."""
    xs = np.flatnonzero(mask)
    out: list[list[int]] = []
    for x in xs:
        if out and x - out[-1][1] < min_gap:
            out[-1][1] = int(x)
        else:
            out.append([int(x), int(x)])
    return [(a, b) for a, b in out]


def tab_strip(full: np.ndarray, x: int, y: int, w: int) -> dict:
    """What the tab strip above a view at (x, y), ``w`` wide, shows: ``tabs``, the (first, last) columns of each
    tab (icon and title; tabs are 18 px apart, words 5-7 px); ``active``, the indices of the tabs drawn white
    (the tab whose view is shown); ``overflow``, ink where the tab row's overflow arrow is drawn (the tabs do
    not fit: some titles are cut or hidden). The last :data:`~bkabem_ros.viewer.blueprint.TAB_BAR_END_PX` hold
    the arrow and the help, visibility and maximise icons."""
    from bkabem_ros.viewer.blueprint import TAB_BAR_END_PX  # noqa: PLC0415

    strip = full[max(y - _STRIP_ROWS[0], 0):y - _STRIP_ROWS[1], x:x + w].max(axis=2)
    end = w - TAB_BAR_END_PX
    ink = (strip > _INK).any(axis=0)
    bright = (strip > _ACTIVE).any(axis=0)
    tabs = _runs(ink[:end], 12)
    active = [i for i, (a, b) in enumerate(tabs) if bright[a:b + 1].sum() > 20]
    return {"tabs": tabs, "active": active, "overflow": bool(ink[end:w - 70].any())}


#: A legend entry's colour dot in the viewer (rerun 0.41, egui_plot, 1 pixel per point): a filled circle about 8 px
#: across, in the series' own colour. Accepted: 6-12 px each way, nearly round, at least 65 % filled (a line of the
#: plot in that colour, 1-2.5 px wide, or a letter, never is); a dot cut by the plot's edge is lower than wide, a
#: dimmed one (egui fades the entries it cuts) is not in the colour.
_DOT_PX, _DOT_FILL, _DOT_TOLERANCE = (6, 12), 0.65, 40


def legend_dots(img: np.ndarray, color) -> int:
    """Number of whole legend dots of colour ``color`` (RGB) in a view's screenshot ``img`` (RGB array)."""
    from scipy import ndimage  # noqa: PLC0415

    mask = np.abs(img.astype(np.int16) - np.asarray(color, dtype=np.int16)[:3]).max(axis=2) < _DOT_TOLERANCE
    labels, _n = ndimage.label(mask)
    count = 0
    for sl in ndimage.find_objects(labels):
        h, w = sl[0].stop - sl[0].start, sl[1].stop - sl[1].start
        if (_DOT_PX[0] <= h <= _DOT_PX[1] and _DOT_PX[0] <= w <= _DOT_PX[1] and abs(h - w) <= 2
                and mask[sl].mean() >= _DOT_FILL):
            count += 1
    return count


def expected_legends(rrd, legends: dict[str, str] | None = None) -> dict[str, list[tuple[str, tuple]]]:
    """{view name: [(series name, RGB), ...]} of the legends the viewer draws for recording ``rrd``: every named
    series (``SeriesLines`` names and colours) of the entities under each legend view's origin
    (:func:`bkabem_ros.viewer.blueprint.legend_views` by default), one entry per name (the viewer merges series of
    one name into one entry)."""
    from rerun.chunk import RrdReader  # noqa: PLC0415

    from bkabem_ros.viewer.blueprint import legend_views  # noqa: PLC0415

    legends = legend_views() if legends is None else legends
    series: dict[str, list[tuple[str, tuple]]] = {}
    for ch in RrdReader(str(rrd)).stream().collect().stream():
        rb = ch.to_record_batch()
        if "SeriesLines:names" not in rb.schema.names or "SeriesLines:colors" not in rb.schema.names:
            continue
        for names, colors in zip(rb.column("SeriesLines:names").to_pylist(),
                                 rb.column("SeriesLines:colors").to_pylist()):
            if names is None or colors is None:
                continue
            series[ch.entity_path] = [(n, ((c >> 24) & 255, (c >> 16) & 255, (c >> 8) & 255))
                                      for n, c in zip(names, colors)]
    out = {}
    for view, origin in legends.items():
        entries: dict[str, tuple] = {}
        for path, items in sorted(series.items()):
            if path == origin or path.startswith(origin.rstrip("/") + "/"):
                for n, c in items:
                    entries.setdefault(n, c)
        out[view] = list(entries.items())
    return out


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
    started: float = field(default=0.0, init=False)

    def __enter__(self) -> HeadlessViewer:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def start(self) -> None:
        from rerun.experimental import ViewerClient  # noqa: PLC0415

        self.started = time.monotonic()
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

    def screenshot(self, view_id=None, settle: int = 2, max_shots: int = 8, ready=None,
                   timeout_s: float = 20.0) -> bytes:
        """PNG of the window (or of one view). After a load or a time change the viewer needs a
        few frames to ingest chunks and fit its axes: shots are repeated until ``settle``
        consecutive ones agree (at most ``max_shots``), and the last is returned.

        ``ready(png) -> bool``, if given, is what the shot should show once loaded (a plot in
        colour, say): shots also go on until it holds, for at most ``timeout_s`` seconds (a
        software-rendered viewer on a loaded machine can agree on two blank frames). The last
        shot is returned either way, so a view that never shows it still fails its test."""
        last, same, png = None, 0, b""
        t_end = time.monotonic() + timeout_s
        shots = 0
        while True:
            png = self.client.take_screenshot(view_id)
            shots += 1
            pix = _pixels(png)
            same = same + 1 if last is not None and pix.shape == last.shape and np.mean(pix != last) < 1e-3 else 0
            last = pix
            settled = same + 1 >= settle or shots >= max(max_shots, 1)
            if ready is None:
                if settled:
                    return png
            elif ready(png) and settled or time.monotonic() > t_end:
                return png
            elif settled:
                time.sleep(0.2)

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

    def maximize(self, view_id=None) -> None:
        """Show one view over the whole window (None: the layout again)."""
        bp = self.client.get_blueprint().blueprint
        vp = bp.setdefault("/viewport", {}).setdefault("ViewportBlueprint", {})
        if view_id is None:
            vp.pop("maximized", None)
        else:
            vp["maximized"] = str(view_id)
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

    def shoot_every_view(self, settle: int = 2, ready=None):
        """{view name: (View, PNG)} of every view of the blueprint, tab by tab (after a tab
        switch every view is shot until two shots agree: the views of a newly shown tab load one
        by one, and one shot of a later one could still be blank; in the first tabs until ``settle``
        agree, the first view at least two); the first tabs are active again afterwards.
        ``ready(view name, png) -> bool``: what each view should show once loaded (see
        :meth:`screenshot`)."""
        out = {}
        n = self.tab_count()
        for i in range(n):
            if n > 1:
                self.show_tab(i)
                self.client.take_screenshot()               # one frame: the viewer applies the new blueprint
            hidden = self.hidden_views()
            todo = [v for v in self.views() if v.name not in out and str(v.view_id) not in hidden]
            for k, view in enumerate(todo):
                # after a tab switch each newly shown view waits until it has loaded (two shots agree)
                wait = k == 0 or (n > 1 and i > 0)
                check = None if ready is None else (lambda png, name=view.name: ready(name, png))
                out[view.name] = (view, self.screenshot(view.view_id, settle=max(settle, 2) if wait else settle,
                                                        ready=check))
        if n > 1:
            self.show_tab(0)
        return out

    def rows(self) -> list[dict]:
        """The layout's rows: every tab container and every view outside one, each with ``path``, ``names``
        (its views' titles, in tab order) and ``ids`` (view ids)."""
        bp = self.client.get_blueprint().blueprint
        names = {p.rsplit("/", 1)[-1]: v["ViewBlueprint"]["display_name"] for p, v in bp.items()
                 if "ViewBlueprint" in v}
        out, in_tabs = [], set()
        for path, value in bp.items():
            c = value.get("ContainerBlueprint")
            if c and c.get("container_kind") == "Tabs":
                ids = [q.rsplit("/", 1)[-1] for q in c.get("contents", [])]
                in_tabs |= set(ids)
                out.append({"path": path, "ids": ids, "names": [names[i] for i in ids]})
        out += [{"path": f"/view/{i}", "ids": [i], "names": [n]} for i, n in names.items() if i not in in_tabs]
        return out

    def title_problems(self, tabs=None) -> list[str]:
        """Checks, tab by tab (:meth:`show_tab` 0, 1, ..., or the indices ``tabs``), that every row of the
        layout shows all its tab titles without the overflow arrow, and the one title drawn white at the index
        of the view shown: a title the user reads is the plot under it. Returns what is wrong ([] when
        nothing); the first tabs are active again afterwards. Views are found by their own screenshots in the
        window's (:func:`locate`), their titles in the strip above them (:func:`tab_strip`)."""
        rows = self.rows()
        n_tabs = max(len(r["ids"]) for r in rows)
        where = {}                                     # row path -> (x, y, w) of its (shared) view area
        problems = []
        for k in (range(n_tabs) if tabs is None else tabs):
            self.show_tab(k)
            self.client.take_screenshot()
            full = _pixels(self.screenshot(settle=2))
            for r in rows:
                shown = min(k, len(r["ids"]) - 1)
                if r["path"] not in where:
                    vp = _pixels(self.client.take_screenshot(r["ids"][shown]))
                    at = locate(full, vp)
                    if at is None:
                        problems.append(f"{r['names'][shown]}: not found in the window")
                        continue
                    where[r["path"]] = (*at, vp.shape[1])
                s = tab_strip(full, *where[r["path"]])
                what = f"{' | '.join(r['names'])} (tab {shown} shown)"
                if s["overflow"]:
                    problems.append(f"{what}: the tab row overflows (arrow shown)")
                if len(s["tabs"]) != len(r["ids"]):
                    problems.append(f"{what}: {len(s['tabs'])} titles visible, not {len(r['ids'])}")
                if s["active"] != [shown]:
                    problems.append(f"{what}: white title at {s['active']}, not at {shown}")
        self.show_tab(0)
        return problems

    def legend_problems(self, legends: dict[str, list[tuple[str, tuple]]], tabs=None) -> list[str]:
        """Checks, tab by tab (as :meth:`title_problems`), that every entry of the legend of each view in
        ``legends`` ({view name: [(series name, RGB)]}, :func:`expected_legends`) is drawn whole: one colour dot
        per entry (:func:`legend_dots`). Returns what is hidden or cut ([] when every entry shows); the first tabs
        are active again afterwards."""
        problems, done = [], set()
        for k in (range(self.tab_count()) if tabs is None else tabs):
            self.show_tab(k)
            self.client.take_screenshot()
            hidden = self.hidden_views()
            for view in self.views():
                entries = legends.get(view.name)
                if not entries or view.name in done or str(view.view_id) in hidden:
                    continue
                done.add(view.name)
                img = _pixels(self.screenshot(view.view_id, settle=2))
                need: dict[tuple, list[str]] = {}
                for name, color in entries:
                    need.setdefault(tuple(color), []).append(name)
                missing = []
                for color, names in need.items():
                    missing += names[legend_dots(img, color):]
                if missing:
                    problems.append(f"{view.name}: legend shows {len(entries) - len(missing)} of {len(entries)} "
                                    f"entries whole ({img.shape[1]} x {img.shape[0]} px view); hidden or cut: "
                                    f"{', '.join(missing)}")
        self.show_tab(0)
        return problems

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


#: The screenshots of docs/recording.md and the README: (file, time cursor [s] or None for the
#: blueprint's default (the latest data), tab index, what it shows).
DOC_SHOTS = (
    ("rerun_default.png", None, 0, "as the demo recording opens: the end of the run (50 Hz hold)"),
    ("rerun_runup.png", 12.0, 1, "t = 12 s of the run-up (30 Hz), second tabs: displacement, line spectrum of the "
                                 "acceleration, kurtosis and crest factor, acceleration per block"),
    ("rerun_trends.png", None, 2, "third tabs: line spectrum of the displacement, peak-to-peak trends"),
)
#: The screenshot of docs/scenarios.md: a node running the embedded run to failure at x3600 from 1.9 h for
#: ~13 s (12 h of scenario time), as it opens (first tabs: the ground truth's depth trend in view).
SCENARIO_SHOT = ("rerun_scenario.png", "de_outer_run_to_failure", 3600.0, 6840.0, 13.0)


def scenario_recording(rrd, scenario: str = SCENARIO_SHOT[1], time_scale: float = SCENARIO_SHOT[2],
                       start_s: float = SCENARIO_SHOT[3], seconds: float = SCENARIO_SHOT[4]) -> Path:
    """Run ``bkabem node --scenario`` for ``seconds`` of wall time (after its first chunk) and save its
    ``.rrd`` (on this host only, a random ROS domain; the node's own defaults otherwise as in
    tests/integration/test_rerun_viewer.py)."""
    rrd = Path(rrd)
    rrd.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, ROS_DOMAIN_ID=str(random.SystemRandom().randrange(1, 100)),
               ROS_LOG_DIR=tempfile.mkdtemp(prefix="bkabem_ros_log_"), PYTHONUNBUFFERED="1")
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    cmd = [sys.executable, "-m", "bkabem_ros", "node", "--namespace", f"/shot{os.getpid()}", "--sample-rate",
           "12800", "--scenario", scenario, "--time-scale", f"{time_scale:g}", "--rerun-save", str(rrd),
           "--ros-args", "-p", f"scenario_start:={start_s:g}", "-p", "spectrum_rate:=4.0",
           "-p", "noise_acc:=6.25e-4", "-p", "slip:=0.01"]     # 0.05 m/s^2 RMS at 12.8 kHz
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    started, lines = threading.Event(), []

    def read():
        for line in proc.stdout:
            lines.append(line)
            if "streaming from t0" in line:
                started.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        if not started.wait(120):
            raise RuntimeError("scenario node did not stream within 120 s: " + "".join(lines[-20:]))
        time.sleep(seconds)
        proc.send_signal(signal.SIGINT)
        if proc.wait(timeout=60) != 0:
            raise RuntimeError(f"scenario node exited with {proc.returncode}: " + "".join(lines[-20:]))
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, 9)
            proc.wait()
    return rrd


def _save_png(png: bytes, path: Path) -> None:
    """Write a screenshot as an optimised RGB PNG (no palette: a 256-colour one merged the rare
    marker colours, e.g. FTF violet into grey)."""
    from PIL import Image  # noqa: PLC0415

    Image.open(io.BytesIO(png)).convert("RGB").save(path, optimize=True)


def _shoot(rrd, shots, out: Path) -> list[Path]:
    written = []
    with HeadlessViewer() as v:
        v.open(rrd)
        time.sleep(max(0.0, 8.0 - (time.monotonic() - v.started)))   # the start-up toasts fade
        problems = v.title_problems()
        if problems:
            raise RuntimeError("tab titles: " + "; ".join(problems))
        problems = v.legend_problems(expected_legends(rrd))
        if problems:
            raise RuntimeError("legends: " + "; ".join(problems))
        for name, at, tab, _what in shots:
            v.show_tab(tab)
            if at is not None:
                v.set_time(at)
            else:
                v.client.set_time(TIMELINE, play_state="following")
            png = v.screenshot(settle=2)
            _save_png(png, out / name)
            written.append(out / name)
            print(f"wrote {out / name}")
        bad = v.errors()
        if bad:
            raise RuntimeError("viewer reported: " + "; ".join(bad))
    return written


def make_doc_screenshots(out_dir, rrd=None, scenario_rrd=None) -> list[Path]:
    """Screenshots for the docs: of the demo recording (:data:`DOC_SHOTS`; without ``rrd`` the demo's ROS
    part runs first, ``out/screenshots/demo.rrd``, the same run as ``make demo``) and of a scenario
    (:data:`SCENARIO_SHOT`; without ``scenario_rrd`` a node runs it, ``out/screenshots/scenario.rrd``). Each
    recording is first checked with :meth:`HeadlessViewer.title_problems` (every tab title visible) and
    :meth:`HeadlessViewer.legend_problems` (every legend entry whole)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if rrd is None:
        from bkabem_ros.cli.demo import run_demo  # noqa: PLC0415

        r = run_demo("out/screenshots", record=False)
        if r.errors:
            raise RuntimeError(f"demo failed: {r.errors}")
        rrd = r.rrd
    written = _shoot(rrd, DOC_SHOTS, out)
    if scenario_rrd is None:
        scenario_rrd = scenario_recording("out/screenshots/scenario.rrd")
    return written + _shoot(scenario_rrd, [(SCENARIO_SHOT[0], None, 0, "")], out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m bkabem_ros.viewer.screenshots", description=__doc__.split("\n\n")[0])
    p.add_argument("rrd", nargs="?", default=None, help="recording (with --docs: default, run the demo first)")
    p.add_argument("--out", default="out/viewer", help="folder for the screenshots (default out/viewer)")
    p.add_argument("--at", type=float, action="append", default=None, help="time cursor [s] (repeatable)")
    p.add_argument("--docs", metavar="DIR", default=None,
                   help="make the documentation screenshots in DIR (docs/img) from the demo")
    args = p.parse_args(argv)
    if args.docs:
        make_doc_screenshots(args.docs, args.rrd)
        return 0
    if args.rrd is None:
        p.error("RRD: a recording is needed (or --docs)")
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
                print(f"  {name:60s} ink {s.ink * 100:5.1f} %  in colour {s.colour_ink * 100:5.2f} %  "
                      f"reports {[r.summary for r in view.reports]}")
        for e in v.errors():
            print("viewer:", e)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
