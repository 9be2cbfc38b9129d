"""The size and cost of a case's FE model, estimated from the case before anything is allocated.

The mesh rule (:func:`bkabem_core.fe.rotor.mesh_for`) refines every shaft element to ``elements_per_wavelength``
sub-elements per shortest wavelength at the model's highest frequency (:attr:`Case.max_frequency_hz`: half of
``operating.max_sample_rate_hz``, or the highest kept order at ``operating.max_speed_hz``). The number of elements
follows from the case alone, so it is counted (as a real number: a unit slip can ask for 1e77 of them) and
compared with ``rotor.fe_elements`` of :data:`bkabem_core.model.plausibility.BOUNDS` before the mesh is made.
That bound also keeps each dense eigen-decomposition of the model under a second, so that SIGINT / SIGTERM stop
the preparation promptly (a LAPACK call holds the interpreter until it returns).

Once the lines and the reduced model are known (before the line-by-line eigen-decompositions), their cost,
``lines x (reduced-model size)^3``, is compared with ``model.line_modes``.

A case beyond either bound is refused with :class:`bkabem_core.model.case.CaseError` naming the case key that sets
the size and the derived quantity; ``[plausibility]`` in the case widens a bound (docs: the plausibility module).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from bkabem_core.fe.elements import Material
from bkabem_core.fe.rotor import shortest_wavelength_m
from bkabem_core.model import plausibility
from bkabem_core.model.case import Case, CaseError

__all__ = ["check_line_modes", "check_mesh", "mesh_elements", "singular_stiffness"]


def mesh_elements(case_dict: Mapping, max_frequency_hz: float, elements_per_wavelength: float) -> float:
    """Number of FE shaft elements :func:`~bkabem_core.fe.rotor.mesh_for` would make, as a float (inf when a
    section's wavelength underflows); one per case element when ``elements_per_wavelength`` is 0."""
    r = case_dict["rotor"]
    n_case = len(r["outer_diameters_m"])
    if not elements_per_wavelength > 0:
        return float(n_case)
    mat = Material(float(r["youngs_modulus_pa"]), float(r["poisson_ratio"]), float(r["density_kg_m3"]))
    z = [float(v) for v in r["node_positions_m"]]
    total = 0.0
    for i, (do, di) in enumerate(zip(r["outer_diameters_m"], r["inner_diameters_m"])):
        with np.errstate(all="ignore"):          # absurd materials: the count says it
            h = shortest_wavelength_m(float(do), float(di), mat, max_frequency_hz) / elements_per_wavelength
        pieces = (z[i + 1] - z[i]) / h if h > 0 and math.isfinite(h) else math.inf
        total += max(1.0, math.ceil(pieces - 1e-9) if math.isfinite(pieces) else math.inf)
    return total


def check_mesh(case: Case) -> None:
    """Refuse a case whose refined FE mesh has more elements than ``rotor.fe_elements`` allows (one line naming
    the key that sets the mesh frequency)."""
    raw = case.raw
    epw = float(raw["rotor"]["elements_per_wavelength"])
    f_max = case.max_frequency_hz
    n = mesh_elements(raw, f_max, epw)
    lo, hi, why = plausibility.bound(raw, "rotor.fe_elements")
    if lo <= n <= hi:
        return
    op, ex, rotor = raw["operating"], raw["excitation"], raw["rotor"]
    by_order = f_max > 0.5 * float(op["max_sample_rate_hz"])
    unusual = [k for k in ("density_kg_m3", "youngs_modulus_pa")          # a material only an override admits
               if not plausibility.BOUNDS[f"rotor.{k}"][0] <= float(rotor[k]) <= plausibility.BOUNDS[f"rotor.{k}"][1]]
    if unusual:
        key, source = f"rotor.{unusual[0]}", (f"rotor.{unusual[0]} {rotor[unusual[0]]:g}: its waves are "
                                              f"that short")
    elif by_order:
        key, source = "excitation.max_order", (f"excitation.max_order {ex['max_order']} x BPFO at "
                                               f"operating.max_speed_hz {op['max_speed_hz']:g} Hz")
    else:
        key, source = "operating.max_sample_rate_hz", (f"half of operating.max_sample_rate_hz "
                                                       f"{op['max_sample_rate_hz']:g} Hz")
    count = f"{n:.3g}" if n >= 1e6 else f"{n:.0f}"
    raise CaseError(key, f"the FE mesh for {f_max:.6g} Hz ({source}) at rotor.elements_per_wavelength {epw:g} needs "
                         f"{count} elements, more than {hi:g}: {why}; lower the frequency the model must serve or "
                         f"the elements per wavelength, or {plausibility.override_hint('rotor.fe_elements')}",
                    case.source)


def check_line_modes(case: Case, n_lines: int, basis_size: int) -> None:
    """Refuse a model whose line-by-line eigen-decompositions (``n_lines`` lines of a reduced model of
    ``basis_size`` vectors) cost more than ``model.line_modes`` allows."""
    cost = float(n_lines) * float(basis_size) ** 3
    lo, hi, why = plausibility.bound(case.raw, "model.line_modes")
    if lo <= cost <= hi:
        return
    raise CaseError("excitation.relative_amplitude_threshold",
                    f"{n_lines} lines on a reduced model of {basis_size} modes: lines x modes^3 = {cost:.3g}, more "
                    f"than {hi:g}: {why}; keep fewer lines (a higher relative_amplitude_threshold, a lower "
                    f"max_order) or a smaller model (operating.max_sample_rate_hz), or "
                    f"{plausibility.override_hint('model.line_modes')}", case.source)



def singular_stiffness(case: Case, detail: str) -> CaseError:
    """The error for an FE stiffness matrix double precision cannot solve (a rigid-body mode, an rcond near 0):
    stiffnesses that span too many decades, named by the stiffest and the softest support or table bearing."""
    values = []
    for i, h in enumerate(case.raw["housings"]):
        for d in ("vertical", "horizontal"):
            values.append((f"housings[{i}].support_stiffness_{d}_n_m", float(h[f"support_stiffness_{d}_n_m"])))
    for name, b in case.raw["bearings"].items():
        if b["linearisation"] == "table":
            for d in ("vertical", "horizontal"):
                values.append((f"bearings.{name}.table_stiffness_{d}_n_m", float(b[f"table_stiffness_{d}_n_m"])))
    hi = max(values, key=lambda kv: kv[1])
    lo = min(values, key=lambda kv: kv[1])
    return CaseError(hi[0], f"the FE stiffness matrix is numerically singular ({detail}): its stiffnesses span more "
                            f"decades than double precision resolves (the stiffest support or table bearing "
                            f"{hi[1]:g} N/m, the softest {lo[0]} = {lo[1]:g} N/m, the shaft ~1e7-1e9 N/m)",
                     case.source)
