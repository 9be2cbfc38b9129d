"""MCAP per run of a data set (``bkabem dataset`` with ``[output] mcap = true``): what the node would have recorded.

:class:`McapRunSink` is a sink of :func:`bkabem_core.dataset.render.render_run`: for every chunk of a run it records
the node's waveform messages (``/<run id>/vibration/<bearing>/<quantity>``, ``bkabem_msgs/msg/VibrationWaveform``,
vertical + horizontal, each with the chunk's ``GroundTruth``) into ``runs/<run id>.mcap`` with the project's
ros2-profile writer (:class:`bkabem_ros.recording.mcap_io.McapRecorder`), stamped with the samples' own time (sample i at
i / sample rate s), not the wall clock: the file depends on the run only. Written under a temporary name,
fsync-ed and renamed into place before the run's Parquet file is, like it.

Quantities the node does not publish (``velocity``) are left out of the MCAP (they are in the Parquet file).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from bkabem_core.dataset.render import TEMP_MARK, commit, fsync_file
from bkabem_core.model.vocabulary import BEARINGS
from bkabem_ros.messages.convert import ground_truth_message, waveform_message
from bkabem_ros.recording.mcap_io import McapRecorder

TWO_PI = 2.0 * math.pi
QUANTITIES = ("acceleration", "displacement")
WAVEFORM_TYPE = "bkabem_msgs/msg/VibrationWaveform"


class McapRunSink:
    """Records one run's chunks as the node's waveform messages (module docstring)."""

    def __init__(self, run, stem: Path, synth):
        self.final = Path(f"{stem}.mcap")
        self.tmp = self.final.with_name(f".{self.final.name}{TEMP_MARK}-{os.getpid()}.mcap")
        self.run = run
        self.fs = synth.sample_rate_hz
        from bkabem_core.scenario.timeline import Scenario

        self.alone = Scenario.of_case(synth.model.case)          # a grid run: the case alone, one state
        self.pairs = [(b, q) for b in BEARINGS for q in QUANTITIES if q in run.params["quantities"]]
        self.ns = f"/run_{run.run_id}"
        self.rec = McapRecorder(self.tmp, chunk_duration_s=1e6, background_flush=False,
                                metadata={"run_id": run.run_id, "run_hash": run.run_hash})

    def write(self, chunk, truth) -> None:
        index = int(chunk.first_sample_index)
        stamp = int(round(index / self.fs * 1e9))
        speed_hz = float(chunk.shaft_speed_hz)
        gt = truth if truth is not None else self.alone.ground_truth(self.alone.states[0], index / self.fs, speed_hz)
        gt_msg = ground_truth_message(gt)
        for b, q in self.pairs:
            msg = waveform_message(chunk.samples[chunk.rows(b, q)], sample_rate=self.fs, first_sample_index=index,
                                   shaft_speed=speed_hz * TWO_PI, machine_id=self.run.run_id, location=b, quantity=q,
                                   channel_names=("vertical", "horizontal"), stamp=stamp, frame_id=f"{b}_bearing",
                                   ground_truth=gt_msg)
            self.rec.add(f"{self.ns}/vibration/{b}/{q}", WAVEFORM_TYPE, msg, log_time_ns=stamp, publish_time_ns=stamp)

    def finish(self) -> None:
        self.rec.close()
        if self.rec.error is not None:
            raise self.rec.error
        fsync_file(self.tmp)
        commit(self.tmp, self.final)

    def abort(self) -> None:
        try:
            self.rec.close()
        except Exception:  # noqa: BLE001 - already failing
            pass
        try:
            self.tmp.unlink()
        except OSError:
            pass


SINK = "bkabem_ros.recording.dataset_sink:McapRunSink"
