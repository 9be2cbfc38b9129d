"""What the sensors of one machine measure, chunk by chunk: its model, the synthesiser, its scenario, the messages.

The bkabem node (:mod:`bkabem_ros.node.vibration_node`) is ROS plumbing: parameters, publishers, timers, the speed input. For each
chunk it asks a :class:`MachineSource` for the chunk (:meth:`MachineSource.next_chunk`) and the chunk's messages
(:meth:`MachineSource.waveform_messages`, :meth:`MachineSource.spectrum_messages`), every one of them carrying the
ground truth of the model in the signal (``bkabem_msgs/GroundTruth``).

The machine is always run by a :class:`~bkabem_core.scenario.run.ScenarioDriver`: a scenario (``scenario``
parameter), or the case alone (:meth:`Scenario.of_case`: one state). A change of the machine while the stream runs
(a new scenario, ``defect_depth``, the scenario's next state) is a model made in the background
(:class:`bkabem_core.scenario.models.ModelHelper`, a helper process at low CPU priority: the stream never waits for
it), unpickled and warmed for this source's synthesiser in a low-priority thread (:meth:`Synthesizer.warm`: the
floor's transfer, the line set's plans, the first knot's spectrum; ~0.2 s that the chunk after the switch would
otherwise pay inside the timer) and switched to at the first chunk border after that, phase-continuously
(:meth:`Synthesizer.set_model`). Until the model is there, the stream goes on with the one it has and the ground
truth describes that one.

No rclpy here: messages are built with :mod:`bkabem_ros.messages.convert`. Units: SI (Hz, rad/s, m, m/s^2, s).
"""

from __future__ import annotations

import math
import threading
import time
from typing import Any

import numpy as np

from bkabem_core.model.vocabulary import BEARINGS
from bkabem_core.scenario.run import BackgroundModels, ScenarioClock, ScenarioDriver
from bkabem_core.scenario.timeline import Scenario
from bkabem_ros.messages.convert import (
    fault_frequencies_message,
    ground_truth_message,
    spectrum_message,
    waveform_message,
)

TWO_PI = 2.0 * math.pi
QUANTITIES = ("acceleration", "displacement")
CHANNELS = ("vertical", "horizontal")
WAVEFORM_TYPE = "bkabem_msgs/msg/VibrationWaveform"
SPECTRUM_TYPE = "bkabem_msgs/msg/VibrationSpectrum"
FAULT_TYPE = "bkabem_msgs/msg/BearingFaultFrequencies"


# --------------------------------------------------------------------------- model cache
_MODEL_CACHE: dict[str, Any] = {}
_MODEL_LOCK = threading.Lock()


def prepare_model(case, logger=None):
    """BKA-BEM model of ``case``, shared by all nodes of this process that use the same case (by hash)."""
    from bkabem_core.solve.harmonic import BkaBem

    with _MODEL_LOCK:
        model = _MODEL_CACHE.get(case.case_hash)
        if model is None:
            from bkabem_core.fe.budget import check_mesh

            check_mesh(case)                # a model too big to make: refused before anything is said or made
            if logger is not None:
                logger.info(f"preparing the BKA-BEM model of case {case.name} ({case.source}, hash "
                            f"{case.case_hash}): 4-DOF excitation + FE rotor ...")
            t0 = time.perf_counter()
            model = BkaBem(case)
            if logger is not None:
                pt = model.preparation_time_s
                logger.info(f"model prepared in {time.perf_counter() - t0:.2f} s (excitation "
                            f"{pt.get('excitation', 0.0):.2f} s, {len(model.lines)} lines, solver "
                            f"{model.solver})")
            _MODEL_CACHE[case.case_hash] = model
        elif logger is not None:
            logger.info(f"reusing the BKA-BEM model of case {case.name} (hash {case.case_hash})")
        return model


def parse_labels(text: str) -> dict:
    """``"key=value,key=value"`` -> dict (the node's ``labels`` parameter); ValueError naming the bad item."""
    out = {}
    for item in (p.strip() for p in str(text).split(",")):
        if not item:
            continue
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"parameter labels: {item!r} is not key=value (labels are key=value,key=value)")
        out[key.strip()] = value.strip()
    from bkabem_core.scenario.timeline import label_problem

    bad = label_problem(out)
    if bad is not None:
        raise ValueError(f"parameter {bad[0]}: {bad[1]}")
    return out


class MachineSource:
    """One machine's model, synthesiser and scenario; the messages of every chunk (module docstring).

    Parameters
    ----------
    case : Case
        The machine when no scenario is given.
    scenario : Scenario or None
        The machine over scenario time (its own case replaces ``case``).
    time_scale, scenario_start_s : float
        Scenario seconds per stream second; scenario time at the first sample [s].
    sample_rate_hz : float
    samples_per_chunk : int
    seed : int
    slip : float
    machine_id : str
    frames : dict bearing -> frame id
    labels : dict
        Labels of the machine, in every ground truth.
    logger
        Anything with ``info``, ``warning``, ``error`` (the node's rclpy logger).
    """

    #: Seconds of synthesis per amplitude knot assumed when limiting the knots of a fast speed change.
    KNOT_COST_S = 0.0025

    def __init__(self, case, *, scenario: Scenario | None = None, time_scale: float = 1.0,
                 scenario_start_s: float = 0.0, sample_rate_hz: float, samples_per_chunk: int, seed: int,
                 slip: float, machine_id: str, frames: dict, labels: dict | None = None, logger=None):
        self.sample_rate = float(sample_rate_hz)
        self.samples_per_chunk = int(samples_per_chunk)
        self.machine_id = machine_id
        self.frames = dict(frames)
        self.labels = dict(labels or {})
        self.log = logger
        self.base_case = case
        self.scenario = scenario
        sc = scenario if scenario is not None else Scenario.of_case(case)
        clock = ScenarioClock(self.sample_rate, time_scale if scenario is not None else 1.0,
                              scenario_start_s if scenario is not None else 0.0)
        self._driver = ScenarioDriver(sc, clock, self._models(), self.samples_per_chunk)
        self._next: ScenarioDriver | None = None
        self._next_reason = ""
        self._next_t0 = 0.0
        self.model = prepare_model(self._driver.applied.case, logger)
        self.case = self.model.case
        self.changed = True            # the machine changed: the node sends spectra and fault frequencies now
        self.switches = 0
        self._make_synth(seed, slip)

    # ------------------------------------------------------------------ synthesiser
    def _make_synth(self, seed: int, slip: float) -> None:
        from bkabem_core.synth.synthesizer import Synthesizer

        # spectrum="exact": the model's own response at each new speed (a pole sum of the reduced model, ~0.1 ms),
        # no speed cells to build inside the timer when the machine changes
        n = self.samples_per_chunk
        synth = Synthesizer(self.model, sample_rate_hz=self.sample_rate, chunk_s=n / self.sample_rate, seed=seed,
                            slip=slip, band_limit="taper", features=False, spectrum="exact")
        if synth.chunk_samples != n:
            raise RuntimeError(f"synth chunk of {synth.chunk_samples} samples, node expects {n}")
        synth.max_knots_per_step = max(4, int(0.4 * (n / self.sample_rate) / self.KNOT_COST_S))
        self.synth = synth

    def _models(self) -> BackgroundModels:
        """Models from the helper process, warmed for this source's synthesiser before they count as ready."""
        return BackgroundModels(warm=self._warm)

    def _warm(self, model):
        """(In the warm-up thread) ``model`` bound to the synthesiser's settings at its current speed."""
        return self.synth.warm(model)

    def set_noise(self, acceleration_density: float, displacement_density: float, snr_db: float) -> None:
        """Sensor noise from the next chunk on: one-sided densities per quantity [m/s^2/sqrt(Hz), m/sqrt(Hz)], or by
        SNR [dB] (> 0); a density of 0 is the case's (its ``[measurement]`` section's, else none)."""
        if snr_db > 0.0:
            self.synth.set_noise(snr_db=float(snr_db))
            return
        case = self.synth.measurement.noise_density or {}
        dens = {"acceleration": float(acceleration_density) or case.get("acceleration", 0.0),
                "displacement": float(displacement_density) or case.get("displacement", 0.0)}
        self.synth.set_noise(noise_density={q: v for q, v in dens.items() if v > 0.0} or None)

    # ------------------------------------------------------------------ the machine changes
    @property
    def driver(self) -> ScenarioDriver:
        return self._driver

    @property
    def switching(self) -> bool:
        """Whether a switch to another machine (scenario, defect depth) waits for its model."""
        return self._next is not None

    def set_scenario(self, scenario: Scenario | None, at_index: int, time_scale: float = 1.0,
                     start_s: float = 0.0) -> None:
        """Run ``scenario`` (None: the case alone) from the chunk at sample ``at_index`` on; its first model is made
        in the background and switched to when it is ready."""
        self.scenario = scenario
        if scenario is None:
            sc, clock = Scenario.of_case(self.base_case), ScenarioClock(self.sample_rate, 1.0,
                                                                        at_index / self.sample_rate, at_index)
            why = f"case {self.base_case.name} without a scenario"
        else:
            sc, clock = scenario, ScenarioClock(self.sample_rate, time_scale, start_s, at_index)
            why = f"scenario {scenario.name}"
        self._switch_to(sc, clock, why)

    def set_case(self, case, at_index: int, why: str) -> None:
        """Run another case (e.g. the defect at another depth) from the chunk at sample ``at_index`` on."""
        self.base_case = case
        self.scenario = None
        self._switch_to(Scenario.of_case(case), ScenarioClock(self.sample_rate, 1.0, at_index / self.sample_rate,
                                                              at_index), why)

    def _switch_to(self, scenario: Scenario, clock: ScenarioClock, why: str) -> None:
        self._next = ScenarioDriver(scenario, clock, self._models(), self.samples_per_chunk, start_applied=False)
        self._next_reason = why
        self._next_t0 = time.perf_counter()
        if self.log is not None:
            self.log.info(f"{why}: preparing its model in a helper process; the stream goes on meanwhile")

    def set_time_scale(self, time_scale: float, at_index: int) -> None:
        """A new scenario time scale from sample ``at_index`` on (scenario time continuous there)."""
        for d in (self._driver, self._next):
            if d is not None and d.scenario.name:
                d.clock.rescale(time_scale, at_index)

    def _before_chunk(self, index: int) -> None:
        if self._next is not None:
            model = self._next.before_chunk(index)
            self._log_events(self._next)
            if model is not None:
                old = self._driver
                if old.applied is not None:
                    old.models.release(old.applied)
                self._driver, self._next = self._next, None
                self._apply(model)
                if self.log is not None:
                    self.log.info(f"{self._next_reason} in effect from sample {index} (prepared in "
                                  f"{time.perf_counter() - self._next_t0:.2f} s): {self._driver.applied.label}")
            return
        model = self._driver.before_chunk(index)
        self._log_events(self._driver)
        if model is not None:
            self._apply(model)

    def _log_events(self, driver: ScenarioDriver) -> None:
        if self.log is not None:
            for text in driver.events:         # (rclpy loggers want one severity per call site)
                if "not ready" in text or "could not" in text:
                    self.log.warning(text)
                else:
                    self.log.info(text)
        driver.events.clear()

    def _apply(self, model) -> None:
        self.synth.set_model(model)          # from this chunk border on, phase continuous (warm: no set-up here)
        self.model = self.synth.model
        self.case = self.model.case
        self.changed = True
        self.switches += 1

    # ------------------------------------------------------------------ chunks and their messages
    def next_chunk(self, index: int, topic_speed_hz: float):
        """The chunk starting at sample ``index`` and its ground truth (a ``GroundTruth`` message).

        The shaft speed at the chunk's end is the scenario's (when it has a speed profile), else ``topic_speed_hz``
        (the last good speed from the ``speed`` topic)."""
        self._before_chunk(index)
        end = self._driver.end_speed_hz(index, self.samples_per_chunk)
        chunk = self.synth.next_chunk(topic_speed_hz if end is None else end)
        truth = ground_truth_message(self._driver.ground_truth(index, float(chunk.shaft_speed_hz)), self.labels)
        return chunk, truth

    @property
    def speed_from_scenario(self) -> bool:
        return self._driver.scenario.has_speed

    def waveform_messages(self, chunk, stamp: int, truth) -> list:
        """``((bearing, quantity), VibrationWaveform)`` for the chunk, DE first."""
        speed = float(chunk.shaft_speed_hz) * TWO_PI
        index = int(chunk.first_sample_index)
        out = []
        for b in BEARINGS:
            for q in QUANTITIES:
                out.append(((b, q), waveform_message(
                    chunk.samples[chunk.rows(b, q)], sample_rate=self.sample_rate, first_sample_index=index,
                    shaft_speed=speed, machine_id=self.machine_id, location=b, quantity=q, channel_names=CHANNELS,
                    stamp=stamp, frame_id=self.frames[b], ground_truth=truth)))
        return out

    def spectrum_messages(self, chunk, stamp: int, truth) -> list:
        """``(bearing or None, type name, message)``: the spectra per bearing and quantity at the chunk's
        first-sample speed, with the phase origin at its first sample (line j turned by its phase there), then the
        fault frequencies (bearing None)."""
        synth = self.synth
        speed_hz = float(chunk.shaft_speed_hz)
        speed_rad_s = speed_hz * TWO_PI
        ls = synth.line_spectrum(speed_hz)
        y, dc = np.asarray(ls["amplitude"]), np.asarray(ls["dc"])           # (K, C), (C,)
        orders = synth.line_orders()                                          # BPFO orders (any line: nu / BPFO)
        y = y * np.exp(1j * synth.line_phases_rad(chunk))[:, None]
        freq = np.concatenate([[0.0], synth.frequency_hz(speed_hz)])
        k_all = np.concatenate([[0.0], orders])
        out = []
        for b in BEARINGS:
            for q in QUANTITIES:
                rows = chunk.rows(b, q)
                yy = y[:, rows].T                                              # (2, K)
                d = np.asarray(dc[rows], dtype=float)
                amp = np.concatenate([np.abs(d)[:, None], np.abs(yy)], axis=1)
                ph = np.concatenate([np.where(d < 0, np.pi, 0.0)[:, None], np.angle(yy)], axis=1)
                out.append((b, SPECTRUM_TYPE, spectrum_message(
                    freq, k_all, amp, ph, shaft_speed=speed_rad_s, machine_id=self.machine_id, location=b,
                    quantity=q, channel_names=CHANNELS, stamp=stamp, frame_id=self.frames[b], ground_truth=truth)))
        kin = self.case.kinematics(speed_hz)                 # each bearing's own; the single fields: the DE's
        de = kin["de"]
        dent = self.case.dent()
        out.append((None, FAULT_TYPE, fault_frequencies_message(
            shaft_speed=speed_rad_s, ftf=de["ftf"], bpfo=de["bpfo"], bpfi=de["bpfi"], bsf=de["bsf"],
            machine_id=self.machine_id, bearing_designation=de["designation"], defect_bearing=dent.bearing,
            defect_race=dent.race, defect_length=dent.length_m, defect_depth=dent.depth_m,
            defect_angle=dent.angle_rad, stamp=stamp, frame_id=self.frames[dent.bearing], ground_truth=truth,
            bearings=[{"bearing": b, **k} for b, k in kin.items()])))
        self.changed = False
        return out

    def stats(self) -> dict:
        d = self._driver
        return {"machine_switches": self.switches, "scenario": d.scenario.name,
                "scenario_state": None if d.applied is None else d.applied.index,
                "scenario_states_late": len(d.late), "switch_pending": self._next is not None}

    def close(self) -> None:
        """Nothing to stop per source: the model helper is shared by the process (it ends with it)."""
