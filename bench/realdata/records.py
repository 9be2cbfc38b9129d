"""A folder of CWRU bearing records read as :class:`Record` s: what each file name says, the samples in g, provenance.

The Case Western Reserve University Bearing Data Center (https://engineering.case.edu/bearingdatacenter) recorded a
2 hp induction motor on SKF 6205-2RS JEM (drive end) and 6203-2RS JEM (fan end) bearings with EDM pits (0.007 to
0.028 in diameter, 0.011 in deep) in one race or a ball, at 0-3 hp of dynamometer load, with accelerometers on
the motor housing at 12 o'clock at the drive end (``DE``) and the fan end (``FE``). The folder this module reads
holds NumPy ``.npz`` conversions of CWRU's ``.mat`` files (keys ``DE``, ``FE``: acceleration in g, CWRU's
convention) and, optionally, a ``files.tsv`` that maps each file to its source file (provenance).

File names (CWRU's, with ``@`` written ``at``): ``RPM_KIND[_SIZE][_SENSORRATE]``, e.g. ``1797_IR_7_DE12``
(inner race, 0.007 in, drive-end bearing, 12 kHz), ``1772_ORat6_21_DE12`` (outer race at 6 o'clock),
``1797_Normal`` (the healthy baseline, recorded at 48 kHz).
"""

from __future__ import annotations

import csv
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: One inch [m]; CWRU gives pit sizes in mils (0.001 in).
INCH_M = 0.0254
#: EDM pit depth of CWRU's 0.007-0.021 in faults (0.011 in, CWRU's fault specifications) [m].
PIT_DEPTH_M = 0.011 * INCH_M
#: Nominal motor speed [rpm] -> dynamometer load [hp] (CWRU's table of the 12 kHz drive-end data).
LOAD_HP_OF_RPM = {1797: 0, 1772: 1, 1750: 2, 1730: 3}
#: Fault kind in a file name -> the kind's name here.
KIND_OF_CODE = {"Normal": "healthy", "IR": "inner", "B": "ball", "OR": "outer"}
KINDS = ("healthy", "inner", "ball", "outer")
#: Outer-race fault position, o'clock (seen from the drive end) -> the angle in the bearing plane [deg] measured
#: from +x (horizontal) towards +y (up), bkabem's convention: 6 o'clock is the bottom, centred in the load zone.
POSITION_ANGLE_DEG = {6: -90.0, 3: 0.0, 12: 90.0}


def seeded_bearing_make(size_mils: int) -> str:
    """The make of CWRU's seeded bearing for a pit of ``size_mils``: its 0.028 in pits were cut in NTN bearings
    (CWRU's fault specifications), the others in the rig's SKF ones."""
    return "NTN" if size_mils == 28 else "SKF"

#: Fault multipliers [per shaft Hz] of the drive-end 6205, as CWRU publishes them (0 deg contact angle):
#: BPFI, BPFO, FTF, BSF (CWRU's "rolling element" 4.7135 is 2 x BSF).
CWRU_6205 = {"bpfo": 3.5848, "bpfi": 5.4152, "ftf": 0.39828, "bsf": 2.3567}
#: The same as measured in the records (the race lines of every record's raw spectrum; BPFO + BPFI = 9 to 3e-4):
#: 0.37 % above and 0.25 % below the published values, an effective d cos(alpha) / D 1.5 % smaller (a contact
#: angle of ~9.75 deg under the axial play). FTF = BPFO / z; BSF kept at CWRU's value (the ball lines are too
#: smeared to measure it better).
EFFECTIVE_6205 = {"bpfo": 3.598, "bpfi": 5.402, "ftf": 3.598 / 9.0, "bsf": 2.3567}
#: Fan-end 6203 as CWRU publishes it (used to keep its lines out of the FE channel's envelope floor).
CWRU_6203 = {"bpfo": 3.0530, "bpfi": 4.9469, "ftf": 0.3817, "bsf": 1.9944}

_NAME = re.compile(r"^(?P<rpm>\d{4})_(?P<kind>Normal|IR|B|OR(?:at|@)(?P<pos>\d+))(?:_(?P<size>\d+))?"
                   r"(?:_(?P<bearing>DE|FE)(?P<khz>12|48))?$")


class RecordError(ValueError):
    """A folder or file that cannot be read as CWRU records; the message names it and says why."""


@dataclass
class Record:
    """One measured record: the file and what its name says.

    Attributes
    ----------
    name : str
        File name without ``.npz`` (``1797_IR_7_DE12``).
    path : Path
        The ``.npz`` file.
    rpm_nominal : int
        Nominal speed from the file name [rpm].
    load_hp : int
        Dynamometer load [hp] (0-3).
    kind : str
        ``healthy``, ``inner``, ``ball`` or ``outer``.
    size_mils : int
        Pit diameter [0.001 in] (0 for healthy).
    position_oclock : int or None
        Outer-race pit position [o'clock] (None for other kinds).
    fault_bearing : str or None
        ``de`` or ``fe`` (None for healthy).
    sample_rate_hz : float
        12 kHz, or 48 kHz for the healthy baseline and ``..48`` files.
    source_file, source_sha1_prefix : str
        Provenance from ``files.tsv`` when the folder has one ("" otherwise).
    """

    name: str
    path: Path
    rpm_nominal: int
    load_hp: int
    kind: str
    size_mils: int
    position_oclock: int | None
    fault_bearing: str | None
    sample_rate_hz: float
    source_file: str = ""
    source_sha1_prefix: str = ""
    _channels: tuple | None = field(default=None, repr=False)

    @property
    def speed_hz_nominal(self) -> float:
        """Nominal shaft speed [Hz] (the file name's rpm / 60)."""
        return self.rpm_nominal / 60.0

    @property
    def pit_diameter_m(self) -> float:
        """EDM pit diameter [m] (0 for healthy)."""
        return self.size_mils * 1e-3 * INCH_M

    @property
    def pit_depth_m(self) -> float:
        """EDM pit depth [m]: 0.011 in for every fault (0 for healthy). CWRU states this depth for the 0.007-0.021
        in pits; its 0.028 in pits, made in NTN bearings, are printed 0.050 in (inner race) and 0.150 in (ball,
        half the ball's diameter) deep, beyond a case's plausibility bound for a defect's depth (1 mm). A round
        pit's drop is set by the contact that bridges it (under 1 um for these pits), so any depth above a few um
        gives the twin the same signal: 0.011 in stands for all of them."""
        return 0.0 if self.kind == "healthy" else PIT_DEPTH_M

    @property
    def position_angle_deg(self) -> float | None:
        """Outer-race pit angle in bkabem's convention [deg] (None for other kinds)."""
        return None if self.position_oclock is None else POSITION_ANGLE_DEG.get(self.position_oclock)

    @property
    def label(self) -> str:
        """Short label for tables: ``IR 7 mil, 0 hp``."""
        code = {"healthy": "healthy", "inner": "IR", "ball": "B", "outer": "OR"}[self.kind]
        if self.kind == "healthy":
            return f"healthy, {self.load_hp} hp"
        pos = f"@{self.position_oclock}" if self.position_oclock is not None else ""
        return f"{code}{pos} {self.size_mils} mil, {self.load_hp} hp"

    @property
    def channels(self) -> tuple:
        """Channel keys in the file (``DE``, ``FE``; some records have ``DE`` only)."""
        if self._channels is None:
            with np.load(self.path) as d:
                self._channels = tuple(k for k in ("DE", "FE") if k in d.files)
        return self._channels

    def load(self) -> dict:
        """The channels as float64 arrays in g, ``{"DE": ..., "FE": ...}`` (those present)."""
        with np.load(self.path) as d:
            out = {k: np.asarray(d[k], dtype=np.float64).ravel() for k in ("DE", "FE") if k in d.files}
        if "DE" not in out:
            raise RecordError(f"{self.path}: no DE channel (keys {', '.join(sorted(out)) or 'none'})")
        for k, x in out.items():
            if x.size < 1024 or not np.all(np.isfinite(x)):
                raise RecordError(f"{self.path}: channel {k} is shorter than 1024 samples or not finite")
        return out

    def n_samples(self) -> int:
        with np.load(self.path) as d:
            return int(np.asarray(d["DE"]).size)

    def duration_s(self) -> float:
        return self.n_samples() / self.sample_rate_hz


def parse_name(stem: str) -> dict | None:
    """What a CWRU file name says (``None`` if it is not one): rpm, load, kind, size, position, bearing, rate."""
    m = _NAME.match(stem)
    if m is None:
        return None
    rpm = int(m["rpm"])
    if rpm not in LOAD_HP_OF_RPM:
        return None
    code = "OR" if m["kind"].startswith("OR") else m["kind"]
    kind = KIND_OF_CODE[code]
    pos = int(m["pos"]) if m["pos"] else None
    if kind == "outer" and pos not in POSITION_ANGLE_DEG:
        return None
    if kind != "healthy" and m["size"] is None:
        return None
    fs = 48000.0 if (m["khz"] == "48" or kind == "healthy") else 12000.0
    return {"rpm_nominal": rpm, "load_hp": LOAD_HP_OF_RPM[rpm], "kind": kind,
            "size_mils": int(m["size"]) if m["size"] else 0, "position_oclock": pos,
            "fault_bearing": None if kind == "healthy" else (m["bearing"] or "DE").lower(), "sample_rate_hz": fs}


def _provenance(folder: Path) -> dict:
    tsv = folder / "files.tsv"
    if not tsv.is_file():
        return {}
    with open(tsv, newline="") as f:
        return {r["file"]: r for r in csv.DictReader(f, delimiter="\t") if "file" in r}


def scan(folder) -> list[Record]:
    """Every CWRU record of ``folder`` (``.npz`` files whose name parses), sorted by kind, load and size.

    Raises
    ------
    RecordError
        If the folder does not exist or holds no record.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise RecordError(f"{folder}: not a folder")
    prov = _provenance(folder)
    out = []
    for p in sorted(folder.glob("*.npz")):
        info = parse_name(p.stem)
        if info is None:
            continue
        src = prov.get(p.name, {})
        out.append(Record(name=p.stem, path=p, source_file=src.get("source_file", ""),
                          source_sha1_prefix=src.get("source_sha1_prefix", ""), **info))
    if not out:
        raise RecordError(f"{folder}: no CWRU record (.npz files named like 1797_IR_7_DE12.npz)")
    order = {k: i for i, k in enumerate(KINDS)}
    out.sort(key=lambda r: (order[r.kind], r.load_hp, r.position_oclock or 0, r.size_mils))
    return out


def race_record_main(name: str, description: str, argv, run, table, write_docs, twin_option: bool = False,
                     reads: str = "race-fault record") -> int:
    """The command line of a bench script over a folder's race-fault records: ``DATA_DIR``, ``--seeds`` (twin
    renders per record), ``--no-docs`` and, with ``twin_option``, ``--twin CASE``. ``run(args)`` gives the rows,
    ``table(rows, args)`` the text printed, ``write_docs(rows, text, args)`` writes the page and the figure (not
    with ``--no-docs``). Bad input (``--seeds`` below 1, a folder without records or without the drive-end
    records the script ``reads``): one line naming the argument on stderr, exit 2."""
    import argparse

    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("data_dir", type=Path, help="folder of the CWRU records (.npz)")
    ap.add_argument("--seeds", type=int, default=2, help="twin renders per record (default 2)")
    if twin_option:
        ap.add_argument("--twin", default="cwru_rig", help="the twin: an embedded case name or a case TOML "
                        "(default cwru_rig); docs/rigs.md takes only cwru_rig's table")
    ap.add_argument("--no-docs", action="store_true", help="print the table; write neither docs/rigs.md nor the figure")
    a = ap.parse_args(argv)
    if a.seeds < 1:
        print(f"{name}: --seeds: must be at least 1 (got {a.seeds})", file=sys.stderr)
        return 2
    try:
        rows = run(a)
    except RecordError as exc:                     # a missing folder, or one without records
        print(f"{name}: data_dir: {exc}", file=sys.stderr)
        return 2
    if not rows:
        print(f"{name}: data_dir: no drive-end {reads} in {a.data_dir}", file=sys.stderr)
        return 2
    text = table(rows, a)
    print(text)
    if not a.no_docs:
        write_docs(rows, text, a)
    return 0
