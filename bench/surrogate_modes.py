"""Surrogate electric-motor rotor: geometry check, mass budget, static bearing loads, mode tables, drawing.

Regenerates the numbers and the figure of docs/surrogate_motor.md from the case file:

    .venv/bin/python bench/surrogate_modes.py                         # tables + docs/img/surrogate_motor.png
    python3 bench/surrogate_modes.py --case FILE --png OUT.png --speed-hz 50 --fmax-hz 2500
    python3 bench/surrogate_modes.py --no-plot

The design parameters below (core annulus, impeller radius of gyration, ...) are the assumptions from
which the [[rotor.disks]] numbers of the case file were derived; the script recomputes the lumps from
them and flags any disagreement with the case file.
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bkabem_core.fe.rotor import STANDARD_GRAVITY_M_S2, Rotor, rotor_from_case  # noqa: E402

DEFAULT_CASE = ROOT / "bkabem_core" / "embedded" / "cases" / "electric_motor_6010.toml"
DEFAULT_PNG = ROOT / "docs" / "img" / "surrogate_motor.png"

# Design assumptions behind [[rotor.disks]] (see docs/surrogate_motor.md).
IMPELLER = {"outer_diameter_m": 0.280, "radius_of_gyration_m": 0.084, "width_m": 0.060}
CORE = {"outer_diameter_m": 0.200, "bore_m": 0.065, "slice_length_m": 0.040}
BEARING_OD_M = 0.080  # 6010


# --------------------------------------------------------------------------------------------
# model summaries
# --------------------------------------------------------------------------------------------
def design_check(case: dict) -> list[str]:
    """Recompute the disk lumps from the design assumptions and compare with the case file."""
    lines = []
    for d in case["rotor"]["disks"]:
        m = d["mass_kg"]
        if d["name"] == "impeller":
            ip = m * IMPELLER["radius_of_gyration_m"] ** 2
            i_d = ip / 2 + m * IMPELLER["width_m"] ** 2 / 12
            rho = None
        else:
            do, di, s = CORE["outer_diameter_m"], CORE["bore_m"], CORE["slice_length_m"]
            ip = m * (do**2 + di**2) / 8
            i_d = ip / 2 + m * s**2 / 12
            rho = m / (np.pi / 4 * (do**2 - di**2) * s)
        dev = max(abs(ip / d["polar_inertia_kg_m2"] - 1), abs(i_d / d["diametral_inertia_kg_m2"] - 1))
        flag = "ok" if dev < 1e-3 else f"MISMATCH {dev:.1e}"
        extra = f", rho_eff {rho:7.1f} kg/m^3" if rho is not None else ""
        lines.append(
            f"  {d['name']:9s} node {d['node']:2d}: m {m:7.3f} kg, Ip {ip:.5f} (case {d['polar_inertia_kg_m2']:.5f}), "
            f"Id {i_d:.5f} (case {d['diametral_inertia_kg_m2']:.5f}) kg m^2{extra}  [{flag}]"
        )
    return lines


def geometry_table(case: dict, rotor: Rotor) -> list[str]:
    r = case["rotor"]
    z = np.asarray(r["node_positions_m"])
    lines = ["  el  nodes   z_left..z_right [mm]   L [mm]  OD [mm]  ID [mm]  mass [kg]   L/OD"]
    for i, e in enumerate(rotor.shaft_elements):
        lines.append(
            f"  {i + 1:2d}  {e.node_left:2d}-{e.node_right:<2d}   {1e3 * z[i]:7.1f} .. {1e3 * z[i + 1]:7.1f}   "
            f"{1e3 * e.length_m:6.1f}   {1e3 * e.outer_diameter_m:6.1f}   {1e3 * e.inner_diameter_m:6.1f}   "
            f"{e.mass_kg:8.3f}  {e.length_m / e.outer_diameter_m:5.2f}"
        )
    return lines


def mass_budget(rotor: Rotor, case: dict) -> list[str]:
    z = rotor.shaft_node_positions_m
    shaft = rotor.shaft_mass_kg
    imp = sum(d.mass_kg for d in rotor.disks if d.name == "impeller")
    core = sum(d.mass_kg for d in rotor.disks if d.name != "impeller")
    hous = sum(p.mass_kg for p in rotor.point_masses)
    # centre of gravity of shaft + disks
    zm = sum(e.mass_kg * (z[e.node_left] + z[e.node_right]) / 2 for e in rotor.shaft_elements)
    zm += sum(d.mass_kg * z[d.node] for d in rotor.disks)
    z_cg = zm / rotor.rotor_mass_kg
    rows = [
        (f"shaft ({len(rotor.shaft_elements)} elements, rho {case['rotor']['density_kg_m3']:.0f})", shaft, ""),
        ("impeller (node 2)", imp, ""),
        ("rotor core (7 lumps, nodes 6..12)", core, ""),
        ("rotor = shaft + disks", rotor.rotor_mass_kg, "   (target 82.000)"),
        ("housings (nodes 15, 16)", hous, ""),
        ("total", rotor.total_mass_kg, ""),
    ]
    lines = [f"  {label:35s}{m:9.4f} kg{note}" for label, m, note in rows] + [
        f"  {'rotor centre of gravity':35s}z = {1e3 * z_cg:.1f} mm "
        f"({1e3 * (z_cg - z[5]):.1f} mm from the DE bearing, span {1e3 * (z[13] - z[5]):.0f} mm)",
    ]
    return lines


def load_table(rotor: Rotor, g: float) -> list[str]:
    loads = rotor.static_bearing_loads_n(g)
    q = rotor.static_displacement(rotor.gravity_force(g))
    lines = ["  element       Fy on its node [N]   share"]
    w_rot, w_tot = rotor.rotor_mass_kg * g, rotor.total_mass_kg * g
    for name, (fx, fy) in loads.items():
        share = fy / (w_tot if name.startswith("support") else w_rot)
        lines.append(f"  {name:12s}  {fy:12.2f}          {100 * share:5.1f} %")
    lines.append(f"  rotor weight {w_rot:.2f} N, total weight {w_tot:.2f} N")
    lines.append("  static sag y [um]: " + ", ".join(
        f"node {n} {1e6 * q[rotor.dof_index(n, 'y')]:.1f}" for n in (2, 5, 9, 13, 15, 16)))
    return lines


def _energy_parts(rotor: Rotor):
    """Index sets and element matrices for energy bookkeeping."""
    kb, ks = np.zeros_like(rotor.K), np.zeros_like(rotor.K)
    for b in rotor.bearings:
        idx = np.array([rotor.dof_index(n, d) for n in b.nodes for d in ("x", "y")])
        target = ks if b.other_node is None else kb
        target[np.ix_(idx, idx)] += b.stiffness_matrix()
    kshaft = rotor.K - kb - ks
    house = [n for n in rotor.node_labels if n not in rotor.shaft_node_labels]
    hidx = np.array([rotor.dof_index(n, d) for n in house for d in ("x", "y")])
    xidx = np.array([rotor.dof_index(n, "x") for n in rotor.node_labels])
    return kshaft, kb, ks, hidx, xidx


def describe_mode(rotor: Rotor, v: np.ndarray, parts) -> tuple[str, float, float, float, float, str]:
    """Plane, energy split and a short description of a real mode shape ``v``."""
    kshaft, kb, ks, hidx, xidx = parts
    pe = np.array([v @ kshaft @ v, v @ kb @ v, v @ ks @ v])
    pe = pe / pe.sum()
    ke = v @ rotor.M @ v
    mh = np.zeros_like(v)
    mh[hidx] = v[hidx]
    ke_h = (mh @ rotor.M @ mh) / ke
    vx = np.zeros_like(v)
    vx[xidx] = v[xidx]
    plane = "x" if (vx @ rotor.M @ vx) / ke > 0.5 else "y"
    d = plane
    u5, u13 = v[rotor.dof_index(5, d)], v[rotor.dof_index(13, d)]
    h15, h16 = v[rotor.dof_index(15, d)], v[rotor.dof_index(16, d)]
    if pe[2] > 0.5:
        kind = "rigid rotor on supports, " + ("bounce (in phase)" if u5 * u13 > 0 else "rocking (conical)")
    elif ke_h > 0.5:
        kind = "housings on bearings, " + ("in phase" if h15 * h16 > 0 else "anti-phase")
        if abs(h15) > 3 * abs(h16):
            kind = "DE housing on its bearing"
        elif abs(h16) > 3 * abs(h15):
            kind = "NDE housing on its bearing"
    else:
        # nodal points of the lateral deflection along the shaft (sign changes between nodes)
        defl = np.array([v[rotor.dof_index(n, d)] for n in rotor.shaft_node_labels])
        big = defl[np.abs(defl) > 0.05 * np.abs(defl).max()]
        crossings = int(np.sum(np.diff(np.sign(big)) != 0))
        # where the kinetic energy sits (lumped, node-diagonal blocks of M); regions by axial position, so that
        # nodes added by mesh refinement count where they are
        pos = rotor.shaft_node_positions_m
        z5, z13 = pos[5], pos[13]
        groups = {"impeller": [n for n, z in pos.items() if z < z5 - 1e-9],
                  "core": [n for n, z in pos.items() if z5 - 1e-9 <= z <= z13 + 1e-9],
                  "NDE end": [n for n, z in pos.items() if z > z13 + 1e-9]}
        ke_g = {}
        for g, nodes in groups.items():
            idx = np.concatenate([rotor.node_dofs(n) for n in nodes if n in rotor.shaft_node_labels])
            ke_g[g] = v[idx] @ rotor.M[np.ix_(idx, idx)] @ v[idx]
        tot = sum(ke_g.values())
        where = ", ".join(f"{g} {100 * e / tot:.0f}%" for g, e in ke_g.items() if e / tot > 0.15)
        kind = f"shaft bending, {crossings} nodal pt(s); KE {where}"
    return plane, pe[0], pe[1], pe[2], ke_h, kind


def undamped_table(rotor: Rotor, fmax_hz: float, parts) -> tuple[list[str], np.ndarray, np.ndarray]:
    f, phi = rotor.undamped_modes()
    lines = ["   #   f [Hz]  plane  PE shaft  PE brg  PE supp  KE hous  description"]
    for k in np.flatnonzero(f <= fmax_hz):
        plane, ps, pb, pk, kh, kind = describe_mode(rotor, phi[:, k], parts)
        lines.append(f"  {k + 1:2d}  {f[k]:7.1f}    {plane}     {100 * ps:5.1f}%  {100 * pb:5.1f}%  "
                     f"{100 * pk:5.1f}%  {100 * kh:5.1f}%   {kind}")
    return lines, f, phi


def damped_table(rotor: Rotor, speed_hz: float, fmax_hz: float, f_und, phi_und) -> list[str]:
    speed = 2 * np.pi * speed_hz
    lam, vec = rotor.damped_modes(speed, return_vectors=True)
    n = rotor.ndof
    overdamped = int(np.sum(np.abs(lam.imag) < 1e-9 * np.abs(lam).max()))
    sel = np.flatnonzero(lam.imag > 1e-9 * np.abs(lam).max())
    lines = [f"  shaft speed {speed_hz:g} Hz ({60 * speed_hz:.0f} rpm, {speed:.1f} rad/s); "
             f"{overdamped} real (overdamped) eigenvalues",
             "   #  f_d [Hz]  f_n [Hz]  zeta     whirl     two closest undamped modes: mass-weighted share"]
    mnorm = phi_und.T @ rotor.M
    k_out = 0
    for k in sel:
        fd = lam[k].imag / (2 * np.pi)
        fn = abs(lam[k]) / (2 * np.pi)
        if fd > fmax_hz:
            break
        if fn > 2 * fmax_hz:                 # far-overdamped high modes (stiffness-proportional damping): not listed
            continue
        k_out += 1
        zeta = -lam[k].real / abs(lam[k])
        u = vec[:n, k]
        # whirl direction at the shaft node with the largest orbit
        amps = [abs(u[rotor.dof_index(m, "x")]) ** 2 + abs(u[rotor.dof_index(m, "y")]) ** 2
                for m in rotor.shaft_node_labels]
        m = rotor.shaft_node_labels[int(np.argmax(amps))]
        h = np.imag(np.conj(u[rotor.dof_index(m, "x")]) * u[rotor.dof_index(m, "y")])
        whirl = "forward" if h < 0 else "backward"
        # modal assurance criterion with the undamped modes (mass-weighted)
        proj = np.abs(mnorm @ u) ** 2 / np.real(np.conj(u) @ rotor.M @ u)
        j1, j2 = np.argsort(proj)[::-1][:2]
        lines.append(f"  {k_out:2d}  {fd:7.1f}  {fn:7.1f}   {zeta:6.3f}  {whirl:8s}  "
                     f"#{j1 + 1} + #{j2 + 1} ({f_und[j1]:.0f}/{f_und[j2]:.0f} Hz): {proj[j1] + proj[j2]:.2f}")
    return lines


# --------------------------------------------------------------------------------------------
# drawing
# --------------------------------------------------------------------------------------------
def draw(case: dict, rotor: Rotor, f_und: np.ndarray, phi: np.ndarray, parts, png: Path,
         modal_rotor: Rotor | None = None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    z = {n: 1e3 * p for n, p in rotor.shaft_node_positions_m.items()}
    fig, (ax, axm) = plt.subplots(2, 1, figsize=(12, 10.5), gridspec_kw={"height_ratios": [1.3, 1]})

    # shaft
    for e in rotor.shaft_elements:
        r = 1e3 * e.outer_diameter_m / 2
        ax.add_patch(Rectangle((z[e.node_left], -r), z[e.node_right] - z[e.node_left], 2 * r,
                               fc="#9aa5b1", ec="k", lw=0.8, zorder=3))
        ax.text((z[e.node_left] + z[e.node_right]) / 2, 0, f"Ø{1e3 * e.outer_diameter_m:.0f}",
                ha="center", va="center", fontsize=7, zorder=4, rotation=90)
    # disks
    for d in rotor.disks:
        if d.name == "impeller":
            w, r, c = 1e3 * IMPELLER["width_m"], 1e3 * IMPELLER["outer_diameter_m"] / 2, "#d98c5f"
            label = f"impeller (node {d.node})\n{d.mass_kg:.2f} kg, Ip {d.polar_inertia_kg_m2:.4f}"
            ax.text(z[d.node], -r - 6, label, ha="center", va="top", fontsize=8)
        else:
            w, r, c = 1e3 * CORE["slice_length_m"], 1e3 * CORE["outer_diameter_m"] / 2, "#e8d38a"
        for s in (1, -1):
            ax.add_patch(Rectangle((z[d.node] - w / 2, 0 if s > 0 else -r), w, r, fc=c, ec="#7a6a30",
                                   lw=0.6, alpha=0.85, zorder=1))
        ax.plot([z[d.node]], [0], "k.", ms=3, zorder=5)
    core = [d for d in rotor.disks if d.name != "impeller"]
    if core:
        zc = np.mean([z[d.node] for d in core])
        ax.text(zc, 1e3 * CORE["outer_diameter_m"] / 2 + 8,
                f"rotor core: {len(core)} lumps x {core[0].mass_kg:.3f} kg "
                f"(OD {1e3 * CORE['outer_diameter_m']:.0f} mm, stack {len(core) * 1e3 * CORE['slice_length_m']:.0f} mm)",
                ha="center", va="bottom", fontsize=8)
    # bearings, housings, supports
    loads = rotor.static_bearing_loads_n()
    hous = {p.node: p for p in rotor.point_masses}
    for name, b in case["bearings"].items():
        zb = z[b["rotor_node"]]
        ri, ro = 25.0, 1e3 * BEARING_OD_M / 2
        for s in (1, -1):
            ax.add_patch(Rectangle((zb - 8, s * ri if s > 0 else -ro), 16, ro - ri, fc="#4c72b0", ec="k",
                                   lw=0.6, zorder=4))
            ax.add_patch(Rectangle((zb - 22, s * ro if s > 0 else -ro - 30), 44, 30, fc="#8fb3de", ec="k",
                                   lw=0.6, zorder=4))
        h = hous[b["housing_node"]]
        ax.text(zb, -ro - 34, f"{name.upper()} bearing 6010, node {b['rotor_node']}\n"
                f"housing node {b['housing_node']} ({h.mass_kg:.2f} kg)\n"
                f"static load {loads[name][1]:.1f} N", ha="center", va="top", fontsize=8)
        # support spring to ground (zig-zag)
        y0, y1 = -ro - 80, -ro - 125
        ys = np.linspace(y0, y1, 12)
        xs = zb + np.r_[0, 6 * (-1) ** np.arange(10), 0]
        ax.plot(xs, ys, "k-", lw=0.8)
        ax.plot([zb - 20, zb + 20], [y1, y1], "k-", lw=1.5)
        for xh in np.linspace(zb - 18, zb + 14, 5):
            ax.plot([xh, xh + 5], [y1, y1 - 6], "k-", lw=0.6)
    mr = modal_rotor if modal_rotor is not None else rotor
    kb = {b.name: b for b in mr.bearings}
    ax.text(z[rotor.shaft_node_labels[-1]] + 12, -205, "supports: 1e6 N/m, 1e4 N s/m\nbearings (model, 390 N preload):\n"
            f"DE kyy {kb['de'].kyy_n_m:.3g}, kxx {kb['de'].kxx_n_m:.3g}\nNDE kyy {kb['nde'].kyy_n_m:.3g}, "
            f"kxx {kb['nde'].kxx_n_m:.3g} N/m", fontsize=8, va="bottom")
    # node labels
    for n, zn in z.items():
        ax.plot([zn, zn], [-160, 160], color="0.75", lw=0.5, zorder=0)
        ax.text(zn, 168, f"{n}\n{zn:.0f}", ha="center", va="bottom", fontsize=7, color="0.3")
    ax.text(z[1] - 10, 168, "node\nz [mm]", ha="right", va="bottom", fontsize=7, color="0.3")
    ax.set_xlim(-60, max(z.values()) + 160)
    ax.set_ylim(-250, 205)
    ax.set_aspect("equal")
    ax.set_xlabel("z [mm] (DE/impeller end at 0)")
    ax.set_ylabel("radius [mm]")
    ax.set_title(f"Surrogate motor rotor: shaft + disks {rotor.rotor_mass_kg:.3f} kg, "
                 f"DE/NDE static load {loads['de'][1]:.1f} / {loads['nde'][1]:.1f} N")

    # vertical mode shapes (of the model: refined mesh, its bearings)
    zm = {n: 1e3 * p for n, p in mr.shaft_node_positions_m.items()}
    zs = np.array([zm[n] for n in mr.shaft_node_labels])
    shown = 0
    for k in range(len(f_und)):
        v = phi[:, k]
        plane, *_, kind = describe_mode(mr, v, parts)
        if plane != "y":
            continue
        ys = np.array([v[mr.dof_index(n, "y")] for n in mr.shaft_node_labels])
        hy = {n: v[mr.dof_index(n, "y")] for n in hous}
        scale = max(np.abs(ys).max(), max(abs(x) for x in hy.values()))
        (line,) = axm.plot(zs, ys / scale, "-", lw=1.2, label=f"{f_und[k]:.0f} Hz: {kind}")
        for n, val in hy.items():
            zb = z[next(b["rotor_node"] for b in case["bearings"].values() if b["housing_node"] == n)]
            axm.plot([zb], [val / scale], "s", mfc="none", color=line.get_color(), ms=7)
        shown += 1
        if shown == 6:
            break
    axm.axhline(0, color="k", lw=0.5)
    axm.set_xlim(ax.get_xlim())
    axm.set_xlabel("z [mm]")
    axm.set_ylabel("vertical mode shape y (normalised)")
    axm.set_title("Undamped vertical modes at standstill (squares: housing nodes 15, 16 at their bearings)")
    axm.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, frameon=False)
    fig.tight_layout()
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)
    plt.close(fig)


# --------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", type=Path, default=DEFAULT_CASE)
    ap.add_argument("--png", type=Path, default=DEFAULT_PNG)
    ap.add_argument("--no-plot", action="store_true")
    ap.add_argument("--speed-hz", type=float, default=50.0, help="shaft speed for the damped modes")
    ap.add_argument("--fmax-hz", type=float, default=2500.0, help="highest frequency listed")
    args = ap.parse_args(argv)

    from bkabem_core.fe.machine import Machine
    from bkabem_core.model.case import Case

    with open(args.case, "rb") as fh:
        case = tomllib.load(fh)
    machine = Machine(Case.load(str(args.case)))
    geometry = rotor_from_case(machine.case.raw, damping={})         # the case's own elements: geometry, masses
    rotor = machine.rotor                                            # the model: refined, damped, its bearings
    g = float(case.get("excitation", {}).get("gravity_m_s2", STANDARD_GRAVITY_M_S2))
    parts = _energy_parts(rotor)

    print(f"case: {args.case}")
    print(f"geometry: {len(geometry.shaft_elements)} case elements, {len(rotor.disks)} disks, "
          f"{len(rotor.point_masses)} point masses")
    print(f"model: {len(rotor.shaft_elements)} Timoshenko elements (mesh for {machine.mesh.max_frequency_hz:g} Hz), "
          f"{rotor.ndof} DOF, shaft damping beta {rotor.stiffness_damping_s:.3e} s")
    for name, site in machine.sites.items():
        print(f"  bearing {name}: {-site.radial_load_n[1]:.1f} N radial + {site.axial_load_n:.0f} N axial -> "
              f"k_h {site.stiffness_n_m[0]:.4g}, k_v {site.stiffness_n_m[1]:.4g} N/m, c {site.damping_n_s_m[1]:g} N s/m "
              f"({site.source}); {site.state.loaded_balls} balls loaded, contact angle "
              f"{site.state.mean_contact_angle_deg:.1f} deg")
    print()
    print("Shaft elements:")
    print("\n".join(geometry_table(case, geometry)))
    print("\nDisk lumps recomputed from the design assumptions:")
    print("\n".join(design_check(case)))
    print("\nMass budget:")
    print("\n".join(mass_budget(geometry, case)))
    print(f"\nStatic loads under gravity (g = {g} m/s^2; force each element exerts on its first node):")
    print("\n".join(load_table(rotor, g)))
    und, f_und, phi = undamped_table(rotor, args.fmax_hz, parts)
    print(f"\nUndamped modes at standstill up to {args.fmax_hz:g} Hz "
          "(PE = share of strain energy in shaft / rotor-housing bearings / supports; KE hous = housing share):")
    print("\n".join(und))
    print(f"\nDamped modes (state-space eigenvalues, C + Omega G) up to {args.fmax_hz:g} Hz:")
    print("\n".join(damped_table(rotor, args.speed_hz, args.fmax_hz, f_und, phi)))
    if not args.no_plot:
        draw(case, geometry, f_und, phi, parts, args.png, modal_rotor=rotor)
        print(f"\nwrote {args.png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
