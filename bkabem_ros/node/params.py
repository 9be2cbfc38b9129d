"""The bkabem node's parameters: one table, declared in this order (docs/ros_node.md has the same table).

Each :class:`ParamSpec` gives name, default (None: derived from the case), unit, description, whether it may change
while the node runs ("live"), and its range or choices. :mod:`bkabem_ros.node.vibration_node` declares them and checks changes;
``bkabem node``'s shorthand options are checked against the ranges before rclpy starts (:mod:`bkabem_ros.cli.ros`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ParamSpec:
    """One node parameter: name, default (None: from the case), unit, description, live, range/choices."""

    name: str
    default: Any
    unit: str
    description: str
    live: bool = False
    range: tuple | None = None
    choices: tuple | None = None


#: Every parameter of the node, declared in this order (docs/ros_node.md has the same table).
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("case", "electric_motor_6010", "",
              "embedded case name or path of a case TOML file (not used while a scenario runs: it names its case)"),
    ParamSpec("scenario", "", "",
              "embedded scenario name or path of a scenario TOML file (docs/scenarios.md): the machine over time, "
              "defects appearing and growing, speed and load; '' = the case alone. A change loads the new scenario "
              "(a bad one is refused with the reason) and switches to it when its first model is ready", live=True),
    ParamSpec("scenario_time_scale", 1.0, "",
              "scenario seconds per second of stream (3600: an hour per second)", live=True, range=(1.0e-3, 1.0e7)),
    ParamSpec("scenario_start", 0.0, "s",
              "scenario time at the first sample of the stream (and when a scenario is switched on)",
              range=(0.0, 1.0e9)),
    ParamSpec("labels", "", "",
              "labels of the machine, key=value,key=value: copied into every message's ground truth"),
    ParamSpec("machine_id", "", "",
              "machine (fleet) id written into every message; empty: the node's namespace without the "
              "leading '/', or 'bkabem' in the root namespace"),
    ParamSpec("sample_rate", 25600.0, "Hz",
              "samples per second and channel; default the case's measurement section's sample_rate_hz, else 25600; "
              "lines near Nyquist fade out and are dropped, with a warning (a scenario whose [speed] puts a line "
              "above Nyquist is refused at start: docs/ros_node.md, Band limit)",
              range=(1000.0, 204800.0)),
    ParamSpec("chunk_duration", 0.1, "s",
              "length of one waveform message; samples per chunk = round(sample_rate * chunk_duration)",
              range=(0.005, 2.0)),
    ParamSpec("seed", 0, "", "seed of the random parts (noise, slip); the same seed gives the same samples",
              range=(0, 2**31 - 1)),
    ParamSpec("noise_acc", 0.0, "m/s^2/sqrt(Hz)",
              "accelerometer noise density: white Gaussian, one-sided, RMS = density x sqrt(sample_rate / 2) (the "
              "unit of bkabem synth --noise-acc and of a data set's noise_acc; 0: the case's measurement section's, "
              "else none)", live=True, range=(0.0, 1.0e3)),
    ParamSpec("noise_disp", 0.0, "m/sqrt(Hz)",
              "proximity-probe noise density on the displacement channels (bkabem synth --noise-disp)", live=True,
              range=(0.0, 1.0e-2)),
    ParamSpec("noise.snr_db", 0.0, "dB",
              "instead of the densities: noise RMS = each channel's dynamic signal RMS / 10^(snr_db/20); "
              "0 = off (use the densities)", live=True, range=(0.0, 200.0)),
    ParamSpec("noise.acceleration", 0.0, "m/s^2",
              "deprecated (use noise_acc): noise RMS on the acceleration channels, still read as the density "
              "RMS / sqrt(sample_rate / 2) with a warning; ignored when noise_acc is set", live=True,
              range=(0.0, 1.0e4)),
    ParamSpec("noise.displacement", 0.0, "m",
              "deprecated (use noise_disp): noise RMS on the displacement channels, read as noise_disp = RMS / "
              "sqrt(sample_rate / 2) with a warning; ignored when noise_disp is set", live=True, range=(0.0, 1.0e-2)),
    ParamSpec("slip", 0.0, "",
              "random ball slip: standard deviation of the ball-pass interval as a fraction of it (real bearings "
              "0.01-0.02; smears the high orders); default the case's measurement section's, else 0",
              range=(0.0, 0.1)),
    ParamSpec("defect_depth", None, "m",
              "depth of the case's first defect; default the case's. A change makes the model in a helper process "
              "(0.1-2 s; the stream goes on) and switches to it at a chunk boundary; refused while a scenario runs",
              live=True, range=(0.0, 1.0e-3)),
    ParamSpec("speed_unit", "rad/s", "",
              "unit of the speed topic: rad/s (REP 103), hz or rpm", live=True, choices=("rad/s", "hz", "rpm")),
    ParamSpec("max_speed", None, "rad/s",
              "speeds above it are rejected; default the case's operating.max_speed_hz (as rad/s)",
              live=True, range=(0.0, 1.0e5)),
    ParamSpec("wait_for_speed", False, "",
              "true: publish nothing until the first valid speed arrives; false: start at once at speed 0 "
              "(the static part of the response)"),
    ParamSpec("spectrum_rate", 1.0, "Hz",
              "spectra and fault frequencies per second besides the ones sent on a speed change; 0: only on "
              "speed change", live=True, range=(0.0, 50.0)),
    ParamSpec("qos", "sensor_data", "",
              "QoS of the outputs: sensor_data (best effort, volatile) or reliable", choices=("sensor_data", "reliable")),
    ParamSpec("qos_depth", 10, "messages", "history depth (keep last) of the outputs", range=(1, 1000)),
    ParamSpec("frame_id.de", "de_bearing", "", "frame_id of the drive-end sensor messages"),
    ParamSpec("frame_id.nde", "nde_bearing", "", "frame_id of the non-drive-end sensor messages"),
)
PARAMETER_SPECS = {p.name: p for p in PARAMETERS}
#: Noise parameters of earlier versions (RMS over 0 .. sample_rate/2) -> the density parameter that replaces each.
DEPRECATED_NOISE = {"noise.acceleration": "noise_acc", "noise.displacement": "noise_disp"}
LIVE_PARAMETERS = frozenset(p.name for p in PARAMETERS if p.live)
