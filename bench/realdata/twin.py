"""The twin adapter: a measured record's operating condition -> the twin's run, rendered by the product.

One function, :func:`twin_run`, says what "the twin of this record" is: the base case, the case keys it
overrides, and the parameters of a ``bkabem dataset`` run (defect, speed, load, acquisition). Both bench scripts
go through it, so the side-by-side comparison (``validate_real.py``, one run per record and seed, rendered in
this process by the product's data-set renderer) and the training set (``sim2real.py``, the ``bkabem dataset``
command) make the same machine.

Twins known here:

* ``motor_6010``: today's fault library (``motor_6010_{healthy,outer,inner,ball}``, docs/faults.md), the 6010
  motor as it is, with its own defects (2 mm x 50 um dents, 1.5 mm on the ball), at the record's speed and, for
  an outer race, at the record's clock position; the CWRU pit size and load do not map onto another machine's
  defect and are not applied. Acquisition as a monitoring developer sets it up for this rig: 1 % slip, a
  100 mV/g-class sensor noise floor (the fault library's data-set example), a magnet-mounted accelerometer
  (CWRU's sensors sit on magnetic bases) and the product's anti-alias filter.
* any other name or TOML path (``cwru_rig`` once it is embedded): the case with the record's pit (diameter along
  the race, CWRU's depth), clock position and load. This mapping is a first version for the lead to adjust to the
  keys the rig case has (see the comments in :func:`twin_run`).
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from realdata.diagnostics import G
from realdata.records import PIT_DEPTH_M, POSITION_ANGLE_DEG, Record, seeded_bearing_make

LIBRARY = "motor_6010"
#: The twin's channels standing for CWRU's drive-end and fan-end accelerometers (housing, 12 o'clock = vertical).
CHANNELS = {"DE": "de_vertical_acceleration", "FE": "nde_vertical_acceleration"}
#: The acquisition the fault-library twin gets (module docstring).
LIBRARY_ACQUISITION = {"slip": 0.01, "noise_acc": 5.0e-4, "accelerometer": "magnet", "anti_alias": True}
#: A rig twin's random slip of the ball passes (std of the interval / its mean) is its case's ``[measurement] slip``
#: (cwru_rig: 0.1 %, docs/rigs.md). Textbooks give 1-2 % (Randall & Antoni 2011, MSSP 25(2), section 2.1), but the
#: CWRU rig's race-fault lines are sharper than that: in the 7-mil outer- and inner-race records (10 s, 0 and 1 hp)
#: 99-100 % of the power of each of the first four harmonics of the fault line lies within +-0.3 Hz, which a random
#: walk of the ball passes keeps only for a std of ~0.1 % per pass (1 % gives 0.93, 0.61, 0.39, 0.44; 0.3 % gives
#: 0.99, 0.97, 0.95, 0.91). Measured once, for the rig. A rig case without one: the textbook's lower end.
TEXTBOOK_SLIP = 0.01
#: A rig twin's seeded bearing rolls rougher than the healthy one (a defect's ``roughness_db``, docs/faults.md): the
#: CWRU records whose signal is Gaussian carry this much more energy in the housing's band than the healthy record,
#: the median per bearing make (``bench/rig_floor.py``; SKF: the B 7 mil and OR@6 14 mil records, 12.9-17.1 dB; NTN:
#: the 28 mil records, 30.7-40.9 dB). Eight of the 22 fault records set it: their levels are not independent checks.
SEEDED_ROUGHNESS_DB = {"SKF": 15.0, "NTN": 36.0}


def rig_slips(twin: str) -> tuple[float, float]:
    """The slips of a rig twin's training set (bench/sim2real.py): the rig case's and three times it."""
    from bkabem_core.model.case import Case
    from bkabem_core.synth.measurement import Measurement

    slip = Measurement.of_case(Case.load(twin)).slip
    slip = TEXTBOOK_SLIP if slip is None else slip
    return (slip, 3.0 * slip)


@dataclass(frozen=True)
class Condition:
    """What the twin is asked to reproduce of a record: fault kind, pit size, load, position.

    Attributes
    ----------
    kind : str
        ``healthy``, ``inner``, ``ball`` or ``outer``.
    size_mils : int
        Pit diameter [0.001 in] (0 for healthy).
    load_hp : int
        Dynamometer load [hp].
    position_oclock : int or None
        Outer-race pit position [o'clock].
    fault_bearing : str
        ``de`` or ``fe`` (CWRU's names; the twin's ``de`` and ``nde``).
    """

    kind: str
    size_mils: int = 0
    load_hp: int = 0
    position_oclock: int | None = None
    fault_bearing: str = "de"

    @classmethod
    def of(cls, record: Record) -> "Condition":
        return cls(record.kind, record.size_mils, record.load_hp, record.position_oclock,
                   record.fault_bearing or "de")

    @property
    def pit_diameter_m(self) -> float:
        return self.size_mils * 2.54e-5

    @property
    def angle_deg(self) -> float:
        """bkabem's defect angle: the outer-race clock position (6 o'clock = -90 deg, the bottom); the inner race
        and the ball at 0 (their pit turns with the shaft or the ball)."""
        if self.kind == "outer":
            return POSITION_ANGLE_DEG[self.position_oclock or 6]
        return 0.0


def _library_defect(kind: str) -> dict:
    from bkabem_core.model.case import Case

    return dict(Case.load(f"{LIBRARY}_{kind}").raw["defects"][0])


def twin_run(cond: Condition, twin: str, speed_hz: float) -> tuple[str, dict, dict]:
    """THE mapping from a record's condition to its twin: ``(base case, case overrides, run parameters)``.

    Parameters
    ----------
    cond : Condition
        The record's fault kind, size, load and position.
    twin : str
        ``motor_6010`` (the fault library) or a case name / TOML path (``cwru_rig``).
    speed_hz : float
        Shaft speed [Hz] (the record's, estimated from its spectrum).

    Returns
    -------
    base : str
        The data set's ``dataset.case`` (embedded name or path).
    overrides : dict
        ``{"section.key": value}`` on the base case for what a data-set run cannot set (empty: none); the adapter
        writes the overridden case to a TOML file and renders from it.
    params : dict
        Run parameters of a ``bkabem dataset`` spec (docs/datasets.md): defect, ``speed_hz``, ``load_factor``
        and the acquisition. The caller adds ``seed``, ``duration_s``, ``sample_rate_hz``, ``quantities``.
    """
    bearing = "nde" if cond.fault_bearing == "fe" else "de"
    if twin == LIBRARY:
        params = {"speed_hz": float(speed_hz), **LIBRARY_ACQUISITION}
        if cond.kind != "healthy":
            d = _library_defect(cond.kind)
            params.update(fault=cond.kind, bearing=bearing, length_m=float(d["length_m"]),
                          depth_m=float(d["depth_m"]), angle_deg=float(d["angle_deg"]), edge=d["edge"],
                          roughness_db=float(d.get("roughness_db", 0.0)))
            if cond.kind == "outer":
                params["angle_deg"] = cond.angle_deg
            if cond.kind == "ball":
                params["ball"] = int(d.get("ball", 1))
        else:
            params["fault"] = "healthy"
        return f"{LIBRARY}_healthy", {}, params
    # A rig twin (cwru_rig): CWRU's EDM pit as a round pit of the record's diameter and CWRU's depth, whose entry
    # and exit follow from the contact (edge "ball"), the outer-race angle from the clock position. The load: CWRU's
    # dynamometer load is a torque; it enters through the record's speed (the motor's slip), the radial load on the
    # bearings is the rotor's weight and the coupling's turning force (the rig case's [baseline]). The seeded bearing
    # rolls rougher than the healthy one by its make's SEEDED_ROUGHNESS_DB. The acquisition (mounting, noise floor,
    # anti-alias, tones) is the rig case's [measurement].
    params = {"speed_hz": float(speed_hz)}        # slip: the rig case's [measurement] slip
    if cond.kind == "healthy":
        params["fault"] = "healthy"
    else:
        params.update(fault=cond.kind, bearing=bearing, length_m=cond.pit_diameter_m, depth_m=PIT_DEPTH_M,
                      angle_deg=cond.angle_deg, shape="round_pit", edge="ball",
                      roughness_db=SEEDED_ROUGHNESS_DB[seeded_bearing_make(cond.size_mils)])
        if cond.kind == "ball":
            params["ball"] = 1
    params["load_hp"] = cond.load_hp              # the record's load, its label; the speed is the record's measured one
    return twin, {}, params


def default_twin() -> str:
    """``cwru_rig`` when the product embeds it, else the fault library."""
    from bkabem_core.model.case import embedded_cases

    return "cwru_rig" if "cwru_rig" in embedded_cases() else LIBRARY


def check_twin(twin: str) -> str | None:
    """``None`` if ``twin`` can be used, else the reason (one line)."""
    if twin == LIBRARY:
        return None
    from bkabem_core.model.case import Case, CaseError

    try:
        Case.load(twin)
    except CaseError as exc:
        return f"{exc.key}: {exc.reason}"
    except OSError as exc:
        return str(exc)
    return None


# --------------------------------------------------------------------------- cases as TOML
def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            raise ValueError(f"not finite: {v!r}")
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def case_toml(raw: dict) -> str:
    """A case's parameters (``Case.raw``: tables of scalars, lists, tables and arrays of tables) as TOML text."""
    lines: list[str] = []

    def is_tables(v):
        return isinstance(v, list) and v and all(isinstance(x, dict) for x in v)

    def body(table: dict, path: list[str]):
        for k, v in table.items():
            if not isinstance(v, dict) and not is_tables(v):
                lines.append(f"{json.dumps(k) if not k.replace('_', '').isalnum() else k} = {_toml_value(v)}")
        for k, v in table.items():
            if isinstance(v, dict):
                lines.append("")
                lines.append(f"[{'.'.join(path + [k])}]")
                body(v, path + [k])
            elif is_tables(v):
                for item in v:
                    lines.append("")
                    lines.append(f"[[{'.'.join(path + [k])}]]")
                    body(item, path + [k])

    body(raw, [])
    return "\n".join(lines).lstrip("\n") + "\n"


def base_case_ref(base: str, overrides: dict, folder: Path) -> str:
    """``base`` itself, or the path of a TOML file in ``folder`` holding ``base`` with ``overrides``."""
    if not overrides:
        return base
    from bkabem_core.model.case import Case

    case = Case.load(base).with_overrides(overrides)
    path = Path(folder) / f"{case.name}_{case.case_hash}.toml"
    path.write_text(case_toml(case.raw))
    return str(path.resolve())


# --------------------------------------------------------------------------- rendering one run
def label_multipliers(row: dict) -> dict:
    """The fault multipliers [per shaft Hz] of a labels row (``bpfo``, ``bpfi``, ``ftf``, ``bsf``)."""
    return {k: float(row[f"{k}_per_hz"]) for k in ("bpfo", "bpfi", "ftf", "bsf")}


def label_mains_hz(row: dict) -> float:
    """The twin's supply frequency [Hz] from a labels row (its electrical lines sit at its multiples)."""
    return float(row.get("baseline_line_frequency_hz") or 50.0)


def synthesize(cond: Condition, twin: str, seed: int, speed_hz: float, sample_rate_hz: float,
               duration_s: float) -> dict:
    """The twin's DE and FE acceleration [g] for ``cond`` at ``speed_hz`` [Hz], ``sample_rate_hz`` [Hz] and
    ``duration_s`` [s], with ``seed`` (slip, noise, the broadband floor): ``{"DE": array, "FE": array,
    "mult": the twin bearing's fault multipliers, "mains_hz": its supply frequency, "label": the labels row}``.

    Rendered by the product's data-set renderer (``bkabem_core.dataset``: the spec validates the run, the run's
    case is built as ``bkabem dataset`` builds it, models are pooled in this process), into a temporary folder
    that is removed afterwards.
    """
    import pyarrow.parquet as pq

    from bkabem_core.dataset.render import render_run
    from bkabem_core.dataset.spec import DatasetSpec

    base, overrides, params = twin_run(cond, twin, speed_hz)
    with tempfile.TemporaryDirectory(prefix="bkabem_twin_") as tmp:
        raw = {"dataset": {"name": "twin", "schema_version": 1, "case": base_case_ref(base, overrides, Path(tmp)),
                           "sampling": "grid"},
               "run": {**params, "seed": int(seed), "duration_s": float(duration_s),
                       "sample_rate_hz": float(sample_rate_hz), "quantities": ["acceleration"]}}
        spec = DatasetSpec(raw, source="twin adapter")
        out = render_run(spec.runs[0], tmp)
        row = out["labels"][0]
        table = pq.read_table(Path(tmp) / row["file"], columns=list(CHANNELS.values()))
        for col in CHANNELS.values():
            unit = (table.schema.field(col).metadata or {}).get(b"unit", b"").decode()
            if unit != "m/s^2":
                raise ValueError(f"twin channel {col}: unit {unit!r}, expected 'm/s^2'")
        sig = {ch: table.column(col).to_numpy().astype(np.float64) / G for ch, col in CHANNELS.items()}
    return {**sig, "mult": label_multipliers(row), "mains_hz": label_mains_hz(row), "label": row}
