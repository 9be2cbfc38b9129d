"""BKA-BEM with the bearings' time-varying stiffness: one harmonic-balance Newton step from the quasi-static path.

The plain method (:class:`bkabem_core.solve.harmonic.BkaBem`) drives the LTI FE with the quasi-static relative
displacement of each bearing through its mean stiffness ``K_b``. What it leaves out is that the bearing stiffness
itself varies with the cage angle: the dent unloads a ball once per ball pass, and the ball set's own stiffness
varies as it turns. Those variations couple the orders and make the plain method 1-3 dB off at high speed
(docs/validation.md). The exact periodic steady state is the harmonic balance of the nonlinear model
(:func:`bkabem_core.reference.periodic.harmonic_balance`, ~0.1-0.5 s per speed); this module gets its accuracy at the cost
of a plain spectrum, because almost everything it needs does not depend on the speed:

* speed-independent, made once: the quasi-static path ``u_qs(theta)`` of every bearing (the excitation itself),
  truncated to the model's orders, ``U_0``; the ball forces and tangent stiffnesses along it, whose spectra give the
  residual force ``Phi_0 = F[f(u_0) - f_s + K_b U_0]`` and the stiffness modulation ``dK = F[K_t(u_0)] - K_b``;
* per speed: the FE receptances at the bearings ``G_k`` from the line modes (a pole sum), one Newton step of the
  harmonic balance from ``U_0``::

      (I + G_k dK_{k-j}) dU_j = -(U_0 - G_k Phi_0)_k        (Hill's system, 4 (2K + 1) unknowns)

  solved by GMRES (the Toeplitz operator of ``dK`` is made once; a block-diagonal preconditioner; a few
  iterations), then the ball forces at ``U_1 = U_0 + dU`` once more in the time domain and the response
  ``X_k = H_k Phi(U_1)_k``.

Starting from the quasi-static path is what makes one step enough: that path is exact at low frequency, and the
dynamic deviation from it is small. The result agrees with the full harmonic balance (and so with the TDSM) to
about 0.1 dB (tests/integration/test_validation.py, docs/validation.md).

Any line set
------------
Inner-race and ball defects move with the shaft and with their ball's spin: their lines (``m BPFI +- n f_r``,
``m 2 BSF +- n FTF``) are not harmonics of one period, and the same step runs on the lattice of the line set
instead (``method="lattice"``, the default for such sets): every line ``c`` (coefficients on the machine's base
phases: shaft, each bearing's cage and spin, line) is written ``c = y B`` on a basis ``B`` (r, 6) of the lattice the
lines and the defects' phases span (:func:`lattice_basis`: r = 1 for BPFO orders, 2 for one moving kind, 3 for
inner-race and ball defects together, one more for the ball passage of a second, different bearing), and ``k``
becomes ``y``:

* the stiffness modulation ``dK(y - y')`` comes from the tangent stiffness along the quasi-static path split as the
  excitation splits it: each bearing without its moving defects over one of its ball pitches (its BPFO harmonics,
  on its own cage phase) plus, for each moving kind, the difference it makes on its own 2-torus
  (:func:`~bkabem_core.excitation.quasi_static.torus_path`);
* the ball forces of a series ``U`` are evaluated on a rank-1 lattice of the r-torus, ``n`` points
  ``phi_j = 2 pi j w / n`` (:func:`rank1_lattice`), where harmonic ``y`` is DFT bin ``y . w mod n``: one force
  evaluation and one FFT per speed, whatever the number of phases. ``w`` is chosen so that no two lines share a bin.

For an order set (r = 1, ``w = 1``, ``n = n_time``) every step is the orders method's, point for point: both give
the same spectrum to round-off (tests/integration/test_hill.py).

Units: SI (m, s, N, rad).
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse

from bkabem_core.bearing.contacts import HertzPair
from bkabem_core.bearing.deep_groove import Bearing
from bkabem_core.excitation.path import quasi_static_path_m
from bkabem_core.excitation.quasi_static import torus_path
from bkabem_core.fe.modal import LineModes
from bkabem_core.model.vocabulary import BEARINGS
from bkabem_core.solve.harmonic import BkaBem, Spectrum

TWO_PI = 2.0 * math.pi
#: Largest rank-1 lattice of the improved method for a non-order line set (points per ball-force evaluation).
MAX_LATTICE_POINTS = 1 << 20
# HertzPair order [de x, de y, nde x, nde y] -> BkaBem's input patterns [(de, v), (de, h), (nde, v), (nde, h)]
_PATTERN_OF = np.array([1, 0, 3, 2])
# bearing relative displacements (HertzPair order) from BkaBem's 8 outputs (LOCATIONS x DIRECTIONS)
_REL = np.zeros((4, 8))
for _i, (_r, _h) in enumerate(((1, 3), (0, 2), (5, 7), (4, 6))):
    _REL[_i, _r], _REL[_i, _h] = 1.0, -1.0


class HillCorrection:
    """The improved BKA-BEM of a model: its spectra with the bearings' time-varying stiffness (module docstring).

    Parameters
    ----------
    model : BkaBem
        The plain model (its machine, orders and line modes are used).
    n_time : int
        Instants per ball pass of the ball-force evaluation at the solution (512 resolve the dent ramps: 43
        instants per ramp; 1024 change the result by < 0.001 dB); for a non-order set the least number of
        points of its rank-1 lattice.
    n_precompute : int
        Instants per ball pass of the quasi-static path and its spectra (made once); for a non-order set those
        of the ball-passage stiffness (the moving defects' tori have the excitation's grid).
    tol : float
        Relative residual of the GMRES solve (1e-4 changes the result by < 0.002 dB against 1e-8).
    method : str
        ``"orders"`` (harmonics of the BPFO period: outer-race and healthy bearing sets), ``"lattice"`` (any line
        set, module docstring "Any line set") or ``"auto"`` (orders where the lines are all BPFO orders).
    n_lattice : int, optional
        Points of the rank-1 lattice of a non-order set (default: the power of two >= 16 |S|, |S| = 2 x lines + 1,
        doubled until the lines separate; doubling it changes the largest lines by < 0.01 dB).

    Attributes
    ----------
    preparation_time_s : float
    last_iterations : int
        GMRES iterations of the last :meth:`spectrum`.
    method : str
        The method used (``"orders"`` or ``"lattice"``).
    """

    def __init__(self, model: BkaBem, n_time: int = 512, n_precompute: int = 4096, tol: float = 1e-4,
                 method: str = "auto", n_lattice: int | None = None):
        t0 = time.perf_counter()
        if method not in ("auto", "orders", "lattice"):
            raise ValueError(f"method: one of auto, orders, lattice (got {method!r})")
        self.model = model
        self.tol = float(tol)
        self.last_iterations = 0
        self.method = "orders" if method == "auto" and model.is_order_set else method
        if self.method == "auto":
            self.method = "lattice"
        if self.method == "orders" and not model.is_order_set:
            raise ValueError("HillCorrection: method 'orders' needs a model whose lines are all BPFO orders of one "
                             "bearing type (BkaBem(..., baseline=False) of an outer-race or healthy bearing set)")
        if self.method == "lattice":
            self._lattice = _LatticeHill(model, n_time, n_precompute, tol, n_lattice)
            self.preparation_time_s = time.perf_counter() - t0
            return
        machine = model.machine
        sites = [machine.sites[b] for b in BEARINGS]
        kk = int(model.orders.max())
        self.n_harmonics = kk
        self._ks = np.arange(-kk, kk + 1)
        orders = np.arange(1, kk + 1)
        if np.array_equal(model.orders, orders):
            self.modes = model.line_modes
            self._rows = np.arange(kk)
        else:                                   # the coupling needs every harmonic up to the highest order
            self.modes = LineModes(model.basis, orders * model.bpfo_per_hz)
            self._rows = model.orders - 1
        z = sites[0].bearing.geometry.n_balls
        bearings = tuple(s.bearing for s in sites)
        axial = tuple(float(s.state.displacement_m[2]) for s in sites)
        self._u_s = np.concatenate([s.state.displacement_m[:2] for s in sites])         # [de x, y, nde x, y]
        self._f_s = np.concatenate([-s.radial_load_n for s in sites])                   # ball force = the load
        self._kb = np.concatenate([s.stiffness_n_m for s in sites])                      # (x, y) per bearing
        # the quasi-static paths of both bearings over one ball pitch (the excitation), truncated to K harmonics
        n0 = int(n_precompute)
        theta = TWO_PI / z * np.arange(n0) / n0
        path = np.hstack([quasi_static_path_m(s.bearing, s.radial_load_n, s.axial_load_n, theta)[0]
                          for s in sites])                                                # (n0, 4)
        ks = self._ks
        self._u0 = (np.fft.fft(path - self._u_s, axis=0) / n0)[ks % n0]                # (2K+1, 4)
        u_tr = self._synth(self._u0, n0) + self._u_s
        f_t, kt_t = HertzPair(bearings, theta, axial_m=axial).forces_many(u_tr)
        self._phi0 = (np.fft.fft(f_t - self._f_s, axis=0) / n0)[ks % n0] + self._u0 * self._kb
        dk = np.fft.fft(kt_t, axis=0) / n0
        dk[0] -= np.diag(self._kb)
        # the Toeplitz operator of the stiffness modulation on harmonics -K..K, one per bearing (dK is block
        # diagonal: a bearing's stiffness couples only its own coordinates): T_b[(k, i), (j, l)] = dK_{k-j}[b i, b l]
        diff = (ks[:, None] - ks[None, :]) % n0
        self._t = [np.ascontiguousarray(dk[diff][:, :, 2 * b:2 * b + 2, 2 * b:2 * b + 2].transpose(0, 2, 1, 3)
                                        .reshape(2 * ks.size, 2 * ks.size)) for b in range(2)]
        self.n_time = int(n_time)
        self._pair = HertzPair(bearings, TWO_PI / z * np.arange(self.n_time) / self.n_time, axial_m=axial)
        self.last_iterations = 0
        self.preparation_time_s = time.perf_counter() - t0

    @staticmethod
    def _to_grid(spec, ks, n):
        full = np.zeros((n,) + spec.shape[1:], complex)
        full[ks % n] = spec
        return full

    def _synth(self, spec, n):
        return (np.fft.ifft(self._to_grid(spec, self._ks, n), axis=0) * n).real

    def receptances(self, speed_hz: float):
        """``(H, G)``: outputs (2K+1, 8, 4) and bearing relative displacements (2K+1, 4, 4) per unit force pair,
        harmonics -K..K, inputs in HertzPair order [m/N]."""
        h_pos = self.modes.receptance(speed_hz)[:, :, _PATTERN_OF]                        # (K, 8, 4)
        h0 = self.modes.static[:, _PATTERN_OF].astype(complex)
        h = np.concatenate([np.conj(h_pos[::-1]), h0[None], h_pos])
        return h, np.einsum("ij,kjl->kil", _REL, h)

    def spectrum(self, speed_hz: float) -> Spectrum:
        """The improved BKA-BEM spectrum at one shaft speed [Hz] (same fields as :meth:`BkaBem.spectrum`)."""
        f = float(speed_hz)
        if not (math.isfinite(f) and f > 0.0):
            raise ValueError(f"speed_hz: must be finite and > 0 (got {speed_hz})")
        if self.method == "lattice":
            sp = self._lattice.spectrum(f)
            self.last_iterations = self._lattice.last_iterations
            return sp
        h, g = self.receptances(f)
        u0, phi0 = self._u0, self._phi0
        r = u0 - np.einsum("kij,kj->ki", g, phi0)
        # Hill's system (I + G T) dU = -r by GMRES: T is the Toeplitz operator of dK (made once), G per harmonic
        (t_de, t_nde), n_k = self._t, self._ks.size
        tv = np.empty((n_k, 4), complex)

        def apply(v):                                   # (I + G T) v
            x = v.reshape(n_k, 4)
            tv[:, :2] = (t_de @ x[:, :2].ravel()).reshape(n_k, 2)
            tv[:, 2:] = (t_nde @ x[:, 2:].ravel()).reshape(n_k, 2)
            return v + (g @ tv[:, :, None]).ravel()

        du, self.last_iterations = _gmres(apply, -r.ravel(), self.tol, 60)
        du = du.reshape(n_k, 4)
        u1 = u0 + du
        n = self.n_time
        f1 = self._pair.forces_only(self._synth(u1, n) + self._u_s)
        phi1 = (np.fft.fft(f1 - self._f_s, axis=0) / n)[self._ks % n] + u1 * self._kb
        x = np.einsum("kij,kj->ki", h, phi1)                                               # (2K+1, 8)
        kk = self.n_harmonics
        disp = 2.0 * x[kk + 1:][self._rows].reshape(-1, 4, 2)
        dc = (h[kk] @ (phi1[kk] + self._kb * self._u_s)).real.reshape(4, 2)
        m = self.model
        return Spectrum(speed_hz=f, orders=m.orders.copy(), frequency_hz=m.orders * m.bpfo_per_hz * f,
                        displacement=disp, dc_m=dc, **m.spectrum_fields(f))


class _LatticeHill:
    """The improved method on the lattice of any line set (module docstring, "Any line set").

    Harmonics ``S``: every speed-locked line the bearings excite, its conjugate and the mean, written in integer
    coordinates ``y`` on a basis of the lattice they span (:func:`lattice_basis`). The steps are those of the
    orders method with the harmonic index ``k`` replaced by ``y``:

    * ``U_0``: the model's own excitation lines (the quasi-static path decomposed on its grids);
    * ``dK``: per bearing, the tangent stiffness along the path of the bearing without its moving defects over one
      ball pitch (ball passage and outer-race dents: BPFO harmonics, at the truncated path as in the orders method)
      plus, for each moving defect kind, the difference it makes on its own torus
      (:func:`~bkabem_core.excitation.quasi_static.torus_path`, exact path, zero where no ball meets it); the Toeplitz operator
      ``T[s, s'] = dK(y_s - y_s')``: sparse for a bearing without moving defects, dense (BLAS) for one with them;
    * ``Phi_0`` and ``Phi(U_1)``: the ball forces of the truncated series, evaluated on a rank-1 lattice of the
      torus (``N`` points ``phi_j = 2 pi j w / N``, :func:`rank1_lattice`): ``y . w mod N`` is the DFT bin of
      harmonic ``y``. One ball-force evaluation of ``N`` points and one FFT per speed. For an order set
      (``r = 1``, ``w = 1``, ``N = n_time``) this is the orders method's own grid, point for point.
    """

    def __init__(self, model: BkaBem, n_time: int, n_precompute: int, tol: float, n_lattice: int | None):
        self.model = model
        self.tol = float(tol)
        self.last_iterations = 0
        machine, case = model.machine, model.case
        lines = model.lines
        phases = model.phases
        sites = [machine.sites[b] for b in BEARINGS]
        zs = [int(s.bearing.geometry.n_balls) for s in sites]
        z = zs[0]
        n_fast = int(case.raw["excitation"]["samples_per_ball_pass"])
        amp = lines.amplitude[:, :4][:, _PATTERN_OF]                    # HertzPair order [de x, de y, nde x, nde y]
        rows = np.flatnonzero(lines.speed_locked & (np.abs(amp).max(axis=1) > 0.0))   # the bearing lines
        self._rows = rows                                                # model line indices
        self._base_rows = np.flatnonzero(np.abs(model._force_a[rows, 4:]).max(axis=1, initial=0.0) > 0.0)
        pos = {int(j): i for i, j in enumerate(model.speed_locked_index)}
        self._modes_rows = np.array([pos[int(j)] for j in rows], dtype=int)
        c = lines.coefficients[rows]
        n_k = rows.size
        self.n_lines = n_k
        cs = np.concatenate([c, -c, np.zeros((1, c.shape[1]), np.int64)])   # S: lines, conjugates, mean
        self._n_s = cs.shape[0]
        # the lattice of S and of every phase the ball forces depend on (so that the samples below are exact): each
        # bearing's ball passage on its own cage phase, each moving kind's torus on its bearing's phases
        gens = [cs]
        for b, zb in zip(BEARINGS, zs):
            gens.append(phases.place_coefficients([[0, zb, 0, 0]], b))
        for b, s, zb in zip(BEARINGS, sites, zs):
            for kind in s.bearing.defect_set.moving:
                gens.append(phases.place_coefficients(kind.phase_map(zb), b))
        self.basis = lattice_basis(np.concatenate(gens))                 # (r, 6)
        y = lattice_coordinates(cs, self.basis)                          # (|S|, r)
        self.rank = self.basis.shape[0]
        bearings = tuple(s.bearing for s in sites)
        axial = tuple(float(s.state.displacement_m[2]) for s in sites)
        if self.rank == 1:                   # the orders method's grids: one ball pitch, n_precompute and n_time
            self._grid0 = _Rank1Grid(self.basis, y, int(n_precompute), np.ones(1, np.int64), bearings, axial, phases)
            self._grid = _Rank1Grid(self.basis, y, int(n_time), np.ones(1, np.int64), bearings, axial, phases)
        else:
            n = int(n_lattice) if n_lattice else max(int(n_time), 1 << math.ceil(math.log2(16 * self._n_s)))
            while True:                  # more points until one generating vector separates S (rank 3: mixed kinds)
                try:
                    w = rank1_lattice(y, n)
                    break
                except ValueError:
                    if n_lattice or n >= MAX_LATTICE_POINTS:
                        raise
                    n *= 2
            self._grid = self._grid0 = _Rank1Grid(self.basis, y, n, w, bearings, axial, phases)
        self.n_time, self.w = self._grid.n, self._grid.w
        self._u_s = np.concatenate([s.state.displacement_m[:2] for s in sites])
        self._f_s = np.concatenate([-s.radial_load_n for s in sites])
        self._kb = np.concatenate([s.stiffness_n_m for s in sites])
        self._turning = _turning_terms(sites, n_fast)
        dc = lines.dc[:4][_PATTERN_OF]
        u0 = np.zeros((self._n_s, 4), complex)
        u0[:n_k] = 0.5 * amp[rows]
        u0[n_k:2 * n_k] = 0.5 * np.conj(amp[rows])
        u0[2 * n_k] = dc - self._u_s
        self._u0 = u0
        self._phi0 = self._forces(u0, self._grid0)
        # stiffness modulation of each bearing (1-D ball passage at the truncated path + moving defects' tori): each
        # bearing's path over one of its own ball pitches, from the lines that are its BPFO orders
        n0 = int(n_precompute)
        grid = np.zeros((n0, 4), complex)
        for bi, (name, zb) in enumerate(zip(BEARINGS, zs)):
            cage = phases.columns(name)[0]
            on_pitch = _on_cage_orders(cs, cage, zb)
            k_pitch = cs[:, cage] // zb
            u_pitch = np.where(on_pitch[:, None], u0[:, 2 * bi:2 * bi + 2], 0.0)
            np.add.at(grid[:, 2 * bi:2 * bi + 2], k_pitch[on_pitch] % n0, u_pitch[on_pitch])
        u_tr = (np.fft.ifft(grid, axis=0) * n0).real + self._u_s
        steps = np.arange(n0) / n0
        theta0 = TWO_PI / z * steps if zs[0] == zs[1] else np.stack([TWO_PI / zb * steps for zb in zs], axis=1)
        outer = tuple(Bearing(b.geometry, defects=b.periodic_defects) for b in bearings)
        _, kt_pitch = HertzPair(outer, theta0, axial_m=axial).forces_many(u_tr)
        spec_pitch = np.fft.fft(kt_pitch, axis=0) / n0
        self._t = []
        self.stiffness_sources = {}
        for bi, (name, site, zb) in enumerate(zip(BEARINGS, sites, zs)):
            base = spec_pitch[:, 2 * bi:2 * bi + 2, 2 * bi:2 * bi + 2]
            n_slow = max(32, 1 << math.ceil(math.log2(4 * zb)))
            tori = [(k, phases.place_coefficients(pm, name), spec) for k, pm, spec in
                    _stiffness_tori(site, machine.excitation_load_n(name), n_fast, n_slow, model.excitations.get(name))]
            self.stiffness_sources[name] = ["ball passage"] + [t[0] for t in tori]
            self._t.append(_toeplitz(cs, phases.columns(name)[0], zb, base, tori,
                                     np.diag(self._kb[2 * bi:2 * bi + 2])))

    def _forces(self, u: np.ndarray, grid: "_Rank1Grid") -> np.ndarray:
        """``Phi(U) = F[f(u) - f_s] + K_b U`` on S (|S|, 4) [N]: the ball forces of the series ``U`` (|S|, 4) [m]
        at the points of ``grid``, their DFT read at the bins of S."""
        n = grid.n
        spec = np.zeros((n, 4), complex)
        np.add.at(spec, grid.bins, u)
        u_t = (np.fft.ifft(spec, axis=0) * n).real + self._u_s
        f_ref = self._f_s
        if self._turning is not None:                    # the load turning with the shaft (_turning_terms)
            shift, load = self._turning
            turns = np.exp(1j * np.outer(grid.shaft, np.arange(1, shift.shape[0] + 1)))          # (n, K)
            u_t = u_t + 2.0 * (turns @ shift).real
            f_ref = f_ref - (np.exp(1j * grid.shaft)[:, None] * load).real
        f = grid.pair.forces_only(u_t)
        return (np.fft.fft(f - f_ref, axis=0) / n)[grid.bins] + u * self._kb

    def spectrum(self, f: float) -> Spectrum:
        """The improved spectrum at shaft speed ``f`` [Hz]: the bearing lines from Hill's step, every other line
        (baseline forces) and the baseline's share of a bearing line as the plain model has them."""
        m = self.model
        n_k, n_s = self.n_lines, self._n_s
        h_pos = m.line_modes.receptance(f, self._modes_rows)[:, :, _PATTERN_OF]             # (K, 8, 4)
        h0 = m.line_modes.static[:, _PATTERN_OF].astype(complex)
        h = np.concatenate([h_pos, np.conj(h_pos), h0[None]])                               # S order
        g = np.einsum("ij,kjl->kil", _REL, h)
        u0 = self._u0
        r = u0 - np.einsum("kij,kj->ki", g, self._phi0)

        def apply(v):                                    # (I + G T) v
            x = v.reshape(n_s, 4)
            t_de, t_nde = self._t
            tv = np.empty((n_s, 4), complex)
            tv[:, :2] = (t_de @ x[:, :2].ravel()).reshape(n_s, 2)
            tv[:, 2:] = (t_nde @ x[:, 2:].ravel()).reshape(n_s, 2)
            return v + (g @ tv[:, :, None]).ravel()

        du, self.last_iterations = _gmres(apply, -r.ravel(), self.tol, 80)
        u1 = u0 + du.reshape(n_s, 4)
        phi1 = self._forces(u1, self._grid)
        x = np.einsum("kij,kj->ki", h, phi1)                                               # (S, 8)
        disp = m.response([f])[0].reshape(len(m.lines), 8)  # lines the bearings do not excite: plain
        disp[self._rows] = 2.0 * x[:n_k]
        if self._base_rows.size:                         # a baseline force on a bearing line (e.g. 2x misalignment)
            j = self._base_rows
            h_all = m.line_modes.receptance(f, self._modes_rows[j])                           # (J, 8, P)
            fb = m._force_a[self._rows[j], 4:] * f ** m.lines.speed_power[self._rows[j], None]
            disp[self._rows[j]] += np.einsum("kup,kp->ku", h_all[:, :, 4:], fb)
        dc = (h[2 * n_k] @ (phi1[2 * n_k] + self._kb * self._u_s)).real.reshape(4, 2)
        return Spectrum(speed_hz=f, orders=m.orders.copy(), frequency_hz=m.frequency_hz(f),
                        displacement=disp.reshape(-1, 4, 2), dc_m=dc, **m.spectrum_fields(f),
                        labels=m.line_labels, band_hz=m.band_hz)


class _Rank1Grid:
    """``n`` points ``phi_j = 2 pi j w / n`` of the torus of a lattice ``basis`` (r, 6), the bins ``y . w mod n``
    of harmonics ``y`` (M, r), and the ball-force table of both bearings at the points' base phases (each bearing
    at its own cage and spin phase of ``phases``)."""

    def __init__(self, basis, y, n: int, w, bearings, axial, phases):
        self.n, self.w = int(n), np.asarray(w, dtype=np.int64)
        self.bins = (y @ self.w) % self.n
        theta = lattice_phases(basis, TWO_PI * (np.outer(np.arange(self.n), self.w) % self.n) / self.n)  # [rad]
        self.shaft = theta[:, 0]
        (c0, s0), (c1, s1) = phases.columns("de"), phases.columns("nde")
        if (c0, s0) == (c1, s1):
            self.pair = HertzPair(bearings, theta[:, c0], axial_m=axial).bake_phases(theta[:, 0], theta[:, s0])
        else:
            self.pair = HertzPair(bearings, theta[:, [c0, c1]], axial_m=axial).bake_phases(theta[:, 0],
                                                                                          theta[:, [s0, s1]])


# --------------------------------------------------------------------------- lattices
def lattice_basis(c: np.ndarray) -> np.ndarray:
    """A basis (r, N) of the integer lattice spanned by the rows of ``c`` (M, N), its Hermite normal form: row i
    has its first nonzero (positive) entry, its pivot, in a column right of row i-1's, and the entries above a
    pivot lie in [0, pivot) (integer row reduction, Euclid). E.g. an inner-race line set: ``[[1, 0, 0, 0],
    [0, z, 0, 0]]`` (shaft, z x cage); a ball defect's: ``[[0, 1, 0, 0], [0, 0, 1, 0]]`` (cage, spin)."""
    a = np.unique(np.asarray(c, dtype=np.int64).reshape(-1, c.shape[-1]), axis=0)
    a = a[a.any(axis=1)]
    basis = []
    for col in range(a.shape[1] if a.size else 0):
        while True:
            nz = np.flatnonzero(a[:, col])
            if nz.size <= 1:
                break
            p = nz[np.argmin(np.abs(a[nz, col]))]
            others = nz[nz != p]
            a[others] -= (a[others, col] // a[p, col])[:, None] * a[p]
            a = np.unique(a[a.any(axis=1)], axis=0)
        nz = np.flatnonzero(a[:, col])
        if nz.size:
            row = a[nz[0]] * np.sign(a[nz[0], col])
            basis.append(row)
            a = np.delete(a, nz[0], axis=0)
    basis = np.array(basis, dtype=np.int64).reshape(-1, c.shape[-1])
    for i, p in enumerate(_pivots(basis)):            # Hermite normal form: entries above a pivot in [0, pivot)
        basis[:i] -= (basis[:i, p] // basis[i, p])[:, None] * basis[i]
    return basis


def _pivots(basis: np.ndarray) -> np.ndarray:
    return np.array([int(np.flatnonzero(row)[0]) for row in basis], dtype=int)


def lattice_coordinates(c: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Integer coordinates y (M, r) with ``y @ basis = c`` for lattice vectors ``c`` (M, N) (ValueError if one is
    not on the lattice)."""
    rest = np.array(c, dtype=np.int64)
    y = np.zeros((rest.shape[0], basis.shape[0]), dtype=np.int64)
    for i, p in enumerate(_pivots(basis)):
        q, r = np.divmod(rest[:, p], basis[i, p])
        if np.any(r):
            raise ValueError("lattice_coordinates: a vector is not on the lattice")
        y[:, i] = q
        rest -= q[:, None] * basis[i]
    if np.any(rest):
        raise ValueError("lattice_coordinates: a vector is not on the lattice")
    return y


def lattice_phases(basis: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Base phases theta (n, N) [rad] with ``basis @ theta = phi`` (n, r) [rad]: the non-pivot phases 0, the
    pivots by back substitution. Any solution is as good as another for a function whose Fourier coefficients lie
    on the lattice (it cannot tell them apart)."""
    theta = np.zeros((phi.shape[0], basis.shape[1]))
    piv = _pivots(basis)
    for i in range(basis.shape[0] - 1, -1, -1):
        p = piv[i]
        theta[:, p] = (phi[:, i] - theta @ basis[i] + theta[:, p] * basis[i, p]) / basis[i, p]
    return theta


def rank1_lattice(y: np.ndarray, n: int, max_step: int = 4096, seed: int = 0) -> np.ndarray:
    """A generating vector w (r,) of a rank-1 lattice of n points for harmonics y (M, r): ``y . w mod n`` distinct
    over y, so that no harmonic of S aliases onto another.

    Component by component: ``w_1 = 1``, then each ``w_i`` among ``+-1 .. +-max_step`` (small steps keep the bins of
    a compact set of harmonics compact, as a tensor grid would) the one with the fewest coinciding bins of distinct
    projections on the first i coordinates, ties broken by the fewest second-order sums ``y_a + y_b`` (products in
    the ball forces) landing on a bin of S. ValueError if no w separates y."""
    r = y.shape[1]
    rng = np.random.default_rng(seed)
    uniq = np.unique(y, axis=0)
    pick = rng.choice(uniq.shape[0], size=(min(20000, uniq.shape[0] ** 2), 2))
    sums = np.unique(uniq[pick[:, 0]] + uniq[pick[:, 1]], axis=0)
    in_s = {tuple(v) for v in uniq}
    sums = sums[[tuple(v) not in in_s for v in sums]]
    steps = np.arange(1, min(max_step, n // 2) + 1)
    cands = np.unique(np.concatenate([steps, n - steps, rng.integers(1, n, size=2048)]) % n)
    w = np.ones(1, dtype=np.int64)
    for i in range(1, r):
        proj = np.unique(uniq[:, :i + 1], axis=0)
        base = (proj[:, :i] @ w) % n                                       # (P,)
        bins = (base[:, None] + proj[:, i:i + 1] * cands[None, :]) % n     # (P, C)
        srt = np.sort(bins, axis=0)
        clash = (srt[1:] == srt[:-1]).sum(axis=0)                           # (C,)
        ok = np.flatnonzero(clash == clash.min())
        if i == r - 1 and clash.min() == 0:
            hits = [int(np.isin((sums @ np.append(w, cands[j])) % n, bins[:, j]).sum()) for j in ok[:64]]
            w = np.append(w, cands[ok[int(np.argmin(hits))]])
        else:
            w = np.append(w, cands[ok[0]])
    b = (uniq @ w) % n
    if np.unique(b).size < b.size:
        raise ValueError(f"rank1_lattice: no generating vector of {n} points separates the {uniq.shape[0]} harmonics")
    return w


def _stiffness_tori(site, load_n: float, n_fast: int, n_slow: int, excitation=None):
    """Per moving defect kind of the bearing: ``(kind, phase_map (2, 4) on the bearing's own phases, 2-D spectrum
    (n_fast, n_slow, 2, 2))`` of
    the tangent stiffness difference the kind makes on its torus along the exact quasi-static path [N/m] (zero
    where no ball meets the defect). The torus paths of the bearing's ``excitation`` are used where it has them on
    this grid (the same paths its lines came from), else they are solved here."""
    b = site.bearing
    if not b.defect_set.moving:
        return []
    g = b.geometry
    z = g.n_balls
    load = (0.0, -float(load_n))
    axial = site.axial_load_n
    outer = Bearing(g, defects=b.periodic_defects)
    theta = TWO_PI / z * np.arange(n_fast) / n_fast
    cached = getattr(excitation, "torus_paths", None) or {}
    tori = []
    kt = e_z = None
    for kind in (k.name for k in b.defect_set.moving):
        tp = cached.get(kind)
        if tp is None or tp.path.shape[:2] != (n_fast, n_slow):
            tp = torus_path(b, outer, kind, load, axial, n_fast, n_slow)
        if kt is None:
            e_z = quasi_static_path_m(outer, load, axial, theta[:1])[1].displacement_m[2]
            kt = _tangent(outer, tp.base, theta, e_z)
        dk = np.zeros(tp.path.shape[:2] + (2, 2))
        t = tp.touched
        dk[t] = _tangent(tp.bearing, tp.path[t], tp.cage[t], e_z, tp.shaft[t], tp.spin[t]) - kt[tp.base_index[t]]
        tori.append((kind, tp.phase_map, np.fft.fft2(dk, axes=(0, 1)) / (n_fast * n_slow)))
    return tori


def _turning_terms(sites, n_fast: int, n_shaft: int = 32):
    """The load that turns with the shaft (:meth:`bkabem_core.fe.machine.Machine._turning_loads`) in the ball
    forces, or None if no bearing has one: ``(shift, load)`` in HertzPair order. ``shift`` (K, 4) [m]: shaft
    harmonics 1..K of the quasi-static path of each bearing without its defects, averaged over the ball-set
    position: the pure shaft orders the excitation leaves to the FE's coupling line (a defect's own shaft orders
    are lines of the excitation, :func:`~bkabem_core.excitation.turning.turning_lines`); they are part of every
    ball's displacement, ``u = U + 2 Re sum_k shift_k exp(i k theta_shaft)``. ``load`` (4,) complex [N]: the ball
    forces balance ``-(W + (Re, Im)(R exp(i theta_shaft)))``, so the reference force turns too. With both, the
    quasi-static path gives ``Phi_0 = K_b U_0`` as without a turning load. The stiffness modulation ``dK`` keeps
    the static load's (a first-order approximation of the Newton step)."""
    if all(s.rotating_load_n == 0 for s in sites):
        return None
    shift = np.zeros((n_shaft // 2 - 1, 4), complex)
    load = np.zeros(4, complex)
    for bi, s in enumerate(sites):
        r = complex(s.rotating_load_n)
        if r == 0:
            continue
        b = s.bearing
        z = b.geometry.n_balls
        sound = Bearing(b.geometry)                      # its defects' shaft orders are excitation lines
        cage, shaft = np.meshgrid(TWO_PI / z * np.arange(n_fast) / n_fast, TWO_PI * np.arange(n_shaft) / n_shaft,
                                  indexing="ij")
        path, _, _ = quasi_static_path_m(sound, s.radial_load_n, s.axial_load_n, cage, shaft_angles_rad=shaft,
                                         turning_load_n=r)
        harmonics = np.fft.fft(path.mean(axis=0), axis=0) / n_shaft                     # (n_shaft, 2: x, y)
        shift[:, 2 * bi:2 * bi + 2] = harmonics[1:n_shaft // 2]
        load[2 * bi:2 * bi + 2] = (r, -1j * r)
    return shift, load


def _tangent(bearing, path, cage, e_z, shaft=0.0, spin=0.0) -> np.ndarray:
    """Lateral tangent stiffness ``-dF/de`` (N, 2, 2) [N/m] of ``bearing`` at displacements ``path`` (N, 2)."""
    _, _, (kxx, kxy, kyy) = bearing.forces_n(path[:, 0], path[:, 1], cage, with_stiffness=True, e_z_m=e_z,
                                             shaft_angle_rad=shaft, spin_angle_rad=spin)
    return np.stack([np.stack([kxx, kxy], -1), np.stack([kxy, kyy], -1)], -2)


def _torus_index(d: np.ndarray, phase_map: np.ndarray, n_fast: int, n_slow: int):
    """Grid indices (i, j) of lattice differences d (M, N) on a torus with ``phase_map`` (2, N), and the mask of
    those on it and inside the grid's band (|m| < N / 2)."""
    pm = np.asarray(phase_map, dtype=np.int64)
    width = pm.shape[1]
    for i in range(width):
        for j in range(i + 1, width):
            det = pm[0, i] * pm[1, j] - pm[0, j] * pm[1, i]
            if det != 0:
                break
        else:
            continue
        break
    n1 = d[:, i] * pm[1, j] - d[:, j] * pm[1, i]
    n2 = pm[0, i] * d[:, j] - pm[0, j] * d[:, i]
    ok = (n1 % det == 0) & (n2 % det == 0)
    m1, m2 = n1 // det, n2 // det
    ok &= np.all(m1[:, None] * pm[0] + m2[:, None] * pm[1] == d, axis=1)
    ok &= (np.abs(m1) < n_fast / 2) & (np.abs(m2) < n_slow / 2)
    return m1 % n_fast, m2 % n_slow, ok


def _on_cage_orders(c: np.ndarray, cage: int, z: int) -> np.ndarray:
    """(M,) bool: rows of ``c`` (M, N) that are BPFO orders of the bearing whose cage phase is column ``cage``: a
    multiple of its ``z`` there, 0 on every other phase."""
    others = np.ones(c.shape[1], bool)
    others[cage] = False
    return (c[:, others] == 0).all(axis=1) & (c[:, cage] % z == 0)


def _toeplitz(cs: np.ndarray, cage: int, z: int, base: np.ndarray, tori, kb: np.ndarray, chunk: int = 256):
    """The stiffness modulation of one bearing (cage phase in column ``cage`` of the lines ``cs``, ``z`` balls) as
    an operator on S: ``T[(s, r), (s', l)] = dK(c_s - c_s')[r, l]`` ((2 |S|) x (2 |S|) [N/m]), ``dK = K_t - K_b``
    (the FE's linear spring ``kb`` (2, 2) off the mean). Dense if the bearing has moving defects (their broad
    spectra couple every pair of lines), else sparse (ball passage only: pairs a BPFO multiple of its own apart)."""
    n_s = cs.shape[0]
    n_fast = base.shape[0]
    dense = np.zeros((n_s, 2, n_s, 2), complex) if tori else None
    rows, cols, vals = [], [], []
    for a in range(0, n_s, chunk):
        d = (cs[a:a + chunk, None, :] - cs[None, :, :]).reshape(-1, cs.shape[1])
        blk = np.zeros((d.shape[0], 2, 2), complex)
        on = _on_cage_orders(d, cage, z)
        k = d[:, cage] // z
        on &= np.abs(k) < n_fast / 2
        blk[on] += base[k[on] % n_fast]
        for _, pm, spec in tori:
            i, j, ok = _torus_index(d, pm, spec.shape[0], spec.shape[1])
            blk[ok] += spec[i[ok], j[ok]]
        zero = ~d.any(axis=1)
        blk[zero] -= kb
        if dense is not None:
            dense[a:a + chunk] = blk.reshape(-1, n_s, 2, 2).transpose(0, 2, 1, 3)
            continue
        nz = np.flatnonzero(np.abs(blk).reshape(-1, 4).max(axis=1) > 0.0)
        s_row, s_col = a + nz // n_s, nz % n_s
        for r in range(2):
            for c in range(2):
                rows.append(2 * s_row + r)
                cols.append(2 * s_col + c)
                vals.append(blk[nz, r, c])
    if dense is not None:
        return dense.reshape(2 * n_s, 2 * n_s)
    rows, cols, vals = (np.concatenate(v) for v in (rows, cols, vals))
    return scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(2 * n_s, 2 * n_s))


def _gmres(apply, b, tol: float, max_iter: int):
    """Unrestarted GMRES with Givens rotations for ``A x = b`` (A given by ``apply``): (x, iterations).

    Raises ``RuntimeError`` if the relative residual is not below ``tol`` after ``max_iter`` iterations.
    """
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros_like(b), 0
    q = np.empty((max_iter + 1, b.size), complex)
    qc = np.empty((max_iter + 1, b.size), complex)               # the conjugates, kept (no copy per product)
    hess = np.zeros((max_iter + 1, max_iter), complex)
    cs = np.zeros(max_iter, complex)
    sn = np.zeros(max_iter, complex)
    e = np.zeros(max_iter + 1, complex)
    e[0] = beta
    q[0] = b / beta
    np.conjugate(q[0], out=qc[0])
    for j in range(max_iter):
        w = apply(q[j])
        h = qc[:j + 1] @ w                             # classical Gram-Schmidt, twice (as stable as modified)
        w = w - h @ q[:j + 1]
        h2 = qc[:j + 1] @ w
        w = w - h2 @ q[:j + 1]
        hess[:j + 1, j] = h + h2
        nrm = float(np.linalg.norm(w))
        hess[j + 1, j] = nrm
        for i in range(j):                            # the previous rotations on the new column
            a, c = hess[i, j], hess[i + 1, j]
            hess[i, j] = np.conj(cs[i]) * a + np.conj(sn[i]) * c
            hess[i + 1, j] = -sn[i] * a + cs[i] * c
        a, c = hess[j, j], hess[j + 1, j]
        r = np.hypot(abs(a), abs(c))
        cs[j], sn[j] = (a / r, c / r) if r > 0 else (1.0, 0.0)
        hess[j, j], hess[j + 1, j] = r, 0.0
        e[j + 1] = -sn[j] * e[j]
        e[j] = np.conj(cs[j]) * e[j]
        if abs(e[j + 1]) <= tol * beta or r == 0.0:
            y = np.linalg.solve(np.triu(hess[:j + 1, :j + 1]), e[:j + 1])
            return y @ q[:j + 1], j + 1
        q[j + 1] = w / nrm
        np.conjugate(q[j + 1], out=qc[j + 1])
    raise RuntimeError(f"GMRES did not converge in {max_iter} iterations (residual {abs(e[max_iter]) / beta:.1e})")

