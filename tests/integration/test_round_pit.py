"""Round pits (EDM pits as CWRU seeds them): the contact ellipse bridges a pit narrower than it.

Oracles written here, independent of the code under test: Hertz's exact elliptical contact (complete elliptic
integrals; Johnson, *Contact Mechanics*, 1985, section 4.2), the geometric drop of a rigid ball onto the rim of a
round hole in its groove, the elliptic pressure's share over a disc (integrated numerically here), and a textbook
envelope analysis (band-pass at the strongest band, Hilbert envelope, spectrum).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, optimize, signal, special

from bkabem_core.bearing.deep_groove import Bearing, BearingGeometry, Dent
from bkabem_core.bearing.defects.round_pit import PitContact
from bkabem_core.bearing.halfspace import HalfSpaceGrid
from bkabem_core.model.case import Case, CaseError
from bkabem_ros.cli.main import main

pytestmark = pytest.mark.slow                  # contact solves on fine grids and renders of pitted machines

INCH = 25.4e-3
MIL = 1e-3 * INCH
CWRU_DEPTH = 0.011 * INCH
E, NU, F = 206e9, 0.3, 0.52                                  # the bearing model's default steel and conformity
D_BALL, D_PITCH = 0.3126 * INCH, 1.537 * INCH                 # CWRU drive-end 6205


def radii_6205(contact: str) -> tuple[float, float]:
    """Rolling-direction and transverse effective radii (R_x, R_y) [m] of a 6205 contact, no clearance."""
    race = (D_PITCH + D_BALL) / 2 if contact == "outer" else (D_PITCH - D_BALL) / 2
    rx = 1.0 / (2.0 / D_BALL + (-1.0 if contact == "outer" else 1.0) / race)
    ry = 1.0 / (2.0 / D_BALL - 1.0 / (F * D_BALL))
    return rx, ry


def exact_hertz(rx: float, ry: float, load_n: float) -> tuple[float, float, float]:
    """Hertz's elliptical contact ``(a across, b along, approach)`` [m] of the gap ``x^2/2R_x + y^2/2R_y`` under a
    load, two steel bodies (Johnson eqs. 3.60-3.62: the major axis across the rolling direction)."""
    e_star = E / (2.0 * (1.0 - NU ** 2))
    big, small = 1.0 / (2.0 * ry), 1.0 / (2.0 * rx)           # curvature coefficients along the major, minor axis

    def ratio(e2):
        k, ee = special.ellipk(e2), special.ellipe(e2)
        return (ee / (1.0 - e2) - k) / (k - ee) - small / big

    e2 = optimize.brentq(ratio, 1e-9, 1.0 - 1e-12, xtol=1e-15)
    k, ee = special.ellipk(e2), special.ellipe(e2)
    c = big * e2 / (k - ee)                                   # p0 b / (E* a^2)
    a = (3.0 * load_n / (2.0 * math.pi * c * e_star)) ** (1.0 / 3.0)
    b = a * math.sqrt(1.0 - e2)
    p0 = c * e_star * a * a / b
    return a, b, p0 * b * k / e_star


def pit(contact: str, mils: float, load_n: float, depth_m: float = CWRU_DEPTH) -> PitContact:
    rx, ry = radii_6205(contact)
    return PitContact(mils * MIL, depth_m, rx, ry, D_BALL / 2, E / (1.0 - NU ** 2), load_n)


def rigid_rim_drop(rx: float, ry: float, radius_m: float) -> float:
    """A rigid ball centred over a round hole rests on its rim: the smallest gap on the rim, the ball's circle
    across against the groove's (radius f d), second order along."""
    rb, rg = D_BALL / 2, F * D_BALL
    res = optimize.minimize_scalar(
        lambda t: (radius_m * math.cos(t)) ** 2 / (2 * rx)
        + (rb - math.sqrt(rb * rb - (radius_m * math.sin(t)) ** 2))
        - (rg - math.sqrt(rg * rg - (radius_m * math.sin(t)) ** 2)), bounds=(0.0, math.pi / 2), method="bounded",
        options={"xatol": 1e-12})
    return float(res.fun)


# --------------------------------------------------------------------------- the half-space solver
def test_half_space_contact_is_hertz():
    """A smooth paraboloid gap on the grid: the approach and the ellipse of Hertz's exact solution (6205 outer
    contact, 20 N), to the grid's resolution."""
    rx, ry = radii_6205("outer")
    a, b, delta = exact_hertz(rx, ry, 20.0)
    dx, dy = b / 12, a / 12
    nx, ny = 2 * math.ceil(1.5 * b / dx), 2 * math.ceil(1.5 * a / dy)
    grid = HalfSpaceGrid(nx, ny, dx, dy, E / (2 * (1 - NU ** 2)))
    x = (np.arange(nx) - nx / 2 + 0.5) * dx
    y = (np.arange(ny) - ny / 2 + 0.5) * dy
    sol = grid.solve(x[:, None] ** 2 / (2 * rx) + y[None, :] ** 2 / (2 * ry), 20.0)
    assert sol.approach_m == pytest.approx(delta, rel=0.02)
    loaded = sol.pressure_pa > 0
    assert np.abs(x[loaded.any(axis=1)]).max() == pytest.approx(b, abs=1.5 * dx)
    assert np.abs(y[loaded.any(axis=0)]).max() == pytest.approx(a, abs=1.5 * dy)
    assert sol.pressure_pa.sum() * dx * dy == pytest.approx(20.0, rel=1e-9)


# --------------------------------------------------------------------------- the bridging
def test_a_pit_much_wider_than_the_ellipse_gives_the_depth_limited_geometric_drop():
    """Wider than the contact: a shallow pit takes the whole contact down by its depth; a deep one lets the ball
    down onto its rim (the rigid geometric drop, here 2.8 um for a 1.5 mm pit in the 6205's groove), plus no more
    than the contact's own elastic approach at a light load; a rigid (unloaded) ball exactly onto the rim."""
    rx, ry = radii_6205("outer")
    shallow = pit("outer", 2.0 / MIL * 1e-3, 20.0, depth_m=0.2e-6)                # 2 mm, 0.2 um deep
    assert shallow.profile().max_drop_m == pytest.approx(0.2e-6, rel=1e-4)
    geometric = rigid_rim_drop(rx, ry, 0.75e-3)
    assert pit("outer", 1.5 / MIL * 1e-3, 0.0).profile().max_drop_m == pytest.approx(geometric, rel=1e-6)
    light = pit("outer", 1.5 / MIL * 1e-3, 0.5)
    _, _, delta = exact_hertz(rx, ry, 0.5)
    h = light.profile().max_drop_m
    assert geometric < h < geometric + 2 * delta and h == pytest.approx(geometric, rel=0.05)
    assert pit("outer", 1.5 / MIL * 1e-3, 0.0, depth_m=1e-6).profile().max_drop_m == pytest.approx(1e-6)


@pytest.mark.parametrize("contact", ["outer", "inner"])
def test_a_pit_narrower_than_the_ellipse_drops_the_ball_a_little_more_the_wider_it_is(contact):
    """CWRU's sizes at 20 N per ball: the drop grows with the diameter, stays a fraction of the contact's
    approach for the narrow pits (the ball rests on the pit's sides), and stays below the loss of the pit's Hertz
    share without letting the contact spread around the pit (the same load on the rest of the ellipse:
    ``delta ((1 - share)^(-2/3) - 1)``; the real contact carries part of it around the pit's rim)."""
    rx, ry = radii_6205(contact)
    a, b, delta = exact_hertz(rx, ry, 20.0)
    mils = (7, 10, 14, 21, 28)
    drops = [pit(contact, m, 20.0).profile().max_drop_m for m in mils]
    assert np.all(np.diff(drops) > 0), drops
    assert drops[0] < 0.15 * delta
    for m, h in zip(mils[:3], drops[:3]):                    # narrower than the ellipse (D < a)
        rho = m * MIL / 2
        t = np.linspace(0.0, 2 * math.pi, 4097)[:-1]
        share = np.mean(1 - (1 - np.minimum(rho / np.hypot(b * np.cos(t), a * np.sin(t)), 1) ** 2) ** 1.5)
        assert h < delta * ((1 - share) ** (-2 / 3) - 1), (m, h, share)


def test_the_share_of_the_contact_over_a_cwru_pit():
    """The share of the intact contact's load over a centred pit, the 6205 at 20 N per ball (outer contact): the
    elliptic pressure of Hertz's exact ellipse integrated over the disc here agrees with the code's (which uses the
    Brewe-Hamrock ellipse), and lies where the 7/14/21 mil pits of CWRU put it: over a third, about two thirds, nearly
    all of it."""
    rx, ry = radii_6205("outer")
    a, b, _ = exact_hertz(rx, ry, 20.0)
    expected = {7: (0.25, 0.50), 14: (0.55, 0.85), 21: (0.85, 1.0)}
    for m, (lo, hi) in expected.items():
        rho = m * MIL / 2

        def density(y, x):
            return 1.5 / (math.pi * a * b) * math.sqrt(max(1.0 - (x / b) ** 2 - (y / a) ** 2, 0.0))

        xm = min(rho, b)
        share, _ = integrate.dblquad(density, -xm, xm, lambda x: -min(math.sqrt(rho * rho - x * x), a),
                                     lambda x: min(math.sqrt(rho * rho - x * x), a), epsabs=1e-10)
        assert lo < share < hi, (m, share)
        assert pit("outer", m, 20.0).hertz_load_fraction() == pytest.approx(share, abs=0.02)


def test_entry_and_exit_the_drop_over_the_ball_position():
    """The profile of a 14 mil pit on the outer race of a 6205: largest at the centre, falling monotonically to zero
    once the pit's rim is a contact half-length away from the contact point (the ellipse has left it), and the
    bearing places it symmetrically about the pit's angle."""
    rx, ry = radii_6205("outer")
    _, b, _ = exact_hertz(rx, ry, 20.0)
    g = BearingGeometry("6205", D_BALL, D_PITCH, 9)
    br = Bearing(g, defects=[Dent(14 * MIL, CWRU_DEPTH, -math.pi / 2, shape="round_pit", bridging_load_n=20.0)])
    ro = br.outer_race_radius_m
    arc = np.linspace(-400e-6, 400e-6, 801)
    h = br.dent_depth_m(-math.pi / 2 + arc / ro)
    assert np.allclose(h, h[::-1], atol=1e-12 * h.max())
    right = h[400:]
    assert np.all(np.diff(right) <= 1e-15) and right[0] == h.max()
    gone = arc[400:][right == 0.0][0]
    assert 7 * MIL + 0.8 * b < gone < 7 * MIL + 1.3 * b
    assert br.dent_half_angle_rad * ro == pytest.approx(gone, abs=10e-6)


# --------------------------------------------------------------------------- the case file
def _case_text(defect: str) -> str:
    text = (Path(__file__).parents[2] / "bkabem_core/embedded/cases/motor_6010_outer.toml").read_text()
    start = text.index("[[defects]]")
    end = text.index("[baseline]")
    return text[:start] + "[[defects]]\n" + defect + "\n\n" + text[end:]


ROUND = 'bearing = "de"\nrace = "outer"\nshape = "round_pit"\nlength_m = {d}\ndepth_m = 0.000279\n{place}\n' \
        'edge = "ball"\nedge_fraction = 0.1'


def test_clock_positions_place_an_outer_race_pit():
    """``clock`` stands for ``angle_deg`` (12 at the top, 6 in the load zone at the bottom, 3 at +x), and the
    same pit gives the same bearing either way."""
    for hours, angle in ((12, 90.0), (3, 0.0), (6, -90.0), (9, 180.0), (1, 60.0)):
        c = Case.from_toml(_case_text(ROUND.format(d=0.000356, place=f"clock = {hours}")), "clock.toml")
        assert math.remainder(math.degrees(c.defects()[0].angle_rad) - angle, 360.0) == pytest.approx(0.0, abs=1e-9)
    six = Case.from_toml(_case_text(ROUND.format(d=0.000356, place="clock = 6")), "c.toml").defects()
    ninety = Case.from_toml(_case_text(ROUND.format(d=0.000356, place="angle_deg = -90.0")), "a.toml").defects()
    assert six == ninety and six[0].shape == "round_pit"
    with pytest.raises(CaseError, match=r"defects\[0\]\.clock: give angle_deg or clock"):
        Case.from_toml(_case_text(ROUND.format(d=0.000356, place="clock = 6\nangle_deg = -90.0")), "b.toml")
    inner = ROUND.replace('"outer"', '"inner"').format(d=0.000356, place="clock = 6")
    with pytest.raises(CaseError, match=r"defects\[0\]\.clock: only for a pit fixed in the bearing plane"):
        Case.from_toml(_case_text(inner), "i.toml")
    with pytest.raises(CaseError, match=r"defects\[0\]\.clock: must be in \[1, 12\]"):
        Case.from_toml(_case_text(ROUND.format(d=0.000356, place="clock = 13")), "x.toml")


@pytest.mark.parametrize("defect, key", [
    (ROUND.format(d=0.0050, place="clock = 6"), "defects[0].length_m"),          # wider than the ball track
    (ROUND.format(d=0.0003, place="clock = 6").replace('"ball"', '"cubic"'), "defects[0].edge"),
    (ROUND.format(d=0.0003, place="clock = 6").replace("round_pit", "round"), "defects[0].shape"),
])
def test_a_pit_that_does_not_fit_is_one_line_and_exit_2(capsys, tmp_path, defect, key):
    p = tmp_path / "pit.toml"
    p.write_text(_case_text(defect))
    rc = main(["excitation", "--case", str(p)])
    out, err = capsys.readouterr()
    assert rc == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], err
    if key.endswith("length_m"):
        assert "ball track" in lines[0] and "5 mm" in lines[0]


# --------------------------------------------------------------------------- the signal
def test_the_envelope_line_of_a_7_mil_pit_is_weaker_than_a_21_mil_pits(cached_model):
    """The fault-library motor (6010 bearings) with a CWRU pit in the DE outer race at 6 o'clock, 25 Hz, 1 % slip,
    sensor noise: the BPFO line of the envelope spectrum (textbook analysis here) stands far higher above its
    floor for the 21 mil pit than for the 7 mil one."""
    from bkabem_core.synth.synthesizer import Synthesizer

    fs, speed = 51200.0, 25.0
    base = Case.load("motor_6010_outer")
    ratio, model = {}, None
    for mils in (7, 21):
        case = base.with_overrides({"defects.0.shape": "round_pit", "defects.0.length_m": mils * MIL,
                                    "defects.0.depth_m": CWRU_DEPTH})
        model = cached_model(case, like=model)
        s = Synthesizer(model, sample_rate_hz=fs, chunk_s=0.25, quantities=("acceleration",), slip=0.01, seed=3,
                        noise_density={"acceleration": 2e-4}, band_limit="taper", features=False)
        x = np.concatenate([s.next_chunk(speed).channel("de_vertical_acceleration") for _ in range(4)]).astype(float)
        f, pxx = signal.welch(x, fs, nperseg=4096)
        edges = np.arange(1000.0, 0.4 * fs, 500.0)
        lo = edges[int(np.argmax([pxx[(f >= e) & (f < e + 1000.0)].sum() for e in edges]))]
        sos = signal.butter(4, [lo, lo + 1000.0], btype="bandpass", fs=fs, output="sos")
        env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x))) ** 2
        spec = np.abs(np.fft.rfft((env - env.mean()) * np.hanning(env.size)))
        fr = np.fft.rfftfreq(env.size, 1.0 / fs)
        bpfo = model.fault_multipliers.bpfo * speed
        line = np.abs(fr - bpfo) <= 0.01 * bpfo
        around = (np.abs(fr - bpfo) < 0.4 * speed) & ~line
        ratio[mils] = spec[line].max() / np.median(spec[around])
    assert ratio[21] > 4.0 and ratio[21] > 3.0 * ratio[7], ratio


@pytest.mark.parametrize("race", ["outer", "inner", "ball"])
def test_every_kind_takes_a_round_pit(race):
    """The shape is the same for every kind: its drop is deepest at the pit's centre on the kind's own surface and
    zero beyond the profile's half-angle; a pit in a ball has a profile at each of its two contacts (the outer
    contact's longer ellipse lets the ball down less)."""
    from bkabem_core.bearing.defects.base import DefectProfile

    g = BearingGeometry("6205", D_BALL, D_PITCH, 9)
    b = Bearing(g, defects=[Dent(14 * MIL, CWRU_DEPTH, 0.0, race=race, shape="round_pit", bridging_load_n=25.0)])
    p = DefectProfile(b.defects[0], b.contact_geometry)
    for contact in p.kind.contacts:
        rel = np.linspace(0.0, 1.2 * p.half_angle_rad, 241)
        h = p.drop_m(rel, contact)
        assert h[0] == h.max() > 0.0 and np.all(h[rel >= p.half_angle_rad] == 0.0)
    if race == "ball":
        assert p.drop_m(0.0, "outer") < p.drop_m(0.0, "inner") == p.depth_eff_m
    slot = DefectProfile(Dent(14 * MIL, CWRU_DEPTH, 0.0, race=race), b.contact_geometry)
    assert p.depth_eff_m < 0.1 * slot.depth_eff_m
