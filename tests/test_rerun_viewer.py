"""The Rerun view tested in the real viewer: the wheel's ``rerun --headless --bind 127.0.0.1``
(software Vulkan, no GPU) driven by ``rerun.experimental.ViewerClient``.

The recording is the committed ``recordings/example_runup.mcap`` (an old recording: made before
this layout existed) converted as ``bkabem replay FILE --rerun-save`` does. Checked: every view
of the blueprint exists and reports no error, the viewer logs no warning, the recording opens at
its latest data, and every view's screenshot shows data (pixels in colour for plots, text for
the health panels), while the envelope spectra at the first instant of the run, before the first
full window, are empty: the statistic can tell.
"""

from __future__ import annotations

import os
import tempfile

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="bkabem_ros_log_"))

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from bkabem_ros import replay, rerun_io  # noqa: E402
from bkabem_ros.rerun_blueprint import view_names  # noqa: E402
from bkabem_ros.rerun_viewer import HeadlessViewer, lavapipe_available, view_statistics  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "recordings" / "example_runup.mcap"

if not lavapipe_available():     # the project installs it (tools/setup_viewer.sh); say so plainly
    pytest.fail("no Vulkan driver for the headless Rerun viewer: run tools/setup_viewer.sh "
                "(Debian: apt-get install mesa-vulkan-drivers)", pytrace=False)


@pytest.fixture(scope="module")
def example_rrd(tmp_path_factory):
    out = tmp_path_factory.mktemp("viewer") / "example.rrd"
    logger = rerun_io.RerunLogger("bkabem", recording_id="example", save_path=out)
    stats = replay.to_rerun(EXAMPLE, logger)
    logger.close()
    assert stats.logged > 1000
    return out


def test_every_view_exists_without_error_and_shows_data(example_rrd):
    with HeadlessViewer(window_size=(1280, 800)) as v:
        st = v.open(example_rrd)
        # opens on the latest data (following), not at t = 0
        rec = st.recordings[0]
        (tl,) = [t for t in rec.timelines if t.name == "sample_time"]
        shots = v.shoot_every_view(settle=1)
        st = v.client.get_state()
        assert st.recordings[0].current_time == tl.end
        assert sorted(shots) == sorted(view_names())
        for name, (view, png) in shots.items():
            assert view.reports == [], (name, view.reports)
            s = view_statistics(png, name)
            if name.endswith("health"):
                assert s.ink > 0.01, s                  # text
            else:
                assert s.colour_ink > 0.002, s          # series / bars / markers in colour
        assert v.errors() == []
        # the first instant: no condition window yet -> the envelope spectra (latest-at) are empty
        v.set_time(tl.start / 1e9)
        v.screenshot(settle=2)
        env = [w for w in v.views() if "envelope" in w.name]
        assert len(env) == 2
        for w in env:
            s = view_statistics(v.screenshot(w.view_id, settle=2), w.name)
            assert s.colour_ink < 0.0005, s
