"""The spectrum at a knot: the displacement combinations of every line of a model at one shaft speed.

Two methods, both within the stated bound of each other (docs/synthesis.md):

``"modal"``
    The model's order-wise pole-residue form in 0.5-Hz cells of shaft speed
    (:class:`~bkabem_core.fe.modal.SpeedCells`: a Chebyshev interpolant of the far poles, the near poles exactly,
    the interpolation error bounded per pole to 2e-6 of the output's reference). The
    speed-locked lines come from the cells, the fixed-frequency lines (the electrical line) from their dense solve.
    Checked once against the exact response at 25 Hz (every line within 1e-5 of the combination's largest); a
    check that fails falls back to ``"exact"``. Kept on the model: synthesisers of one model share the cells.
``"exact"``
    :meth:`BkaBem.response <bkabem_core.solve.harmonic.BkaBem.response>` at every knot,
    cached per speed and shared by every synthesiser of the model in the process.

:func:`choose_method` is ``spectrum="auto"``'s rule. Units: speeds in Hz, amplitudes in m, costs in s.
"""

from __future__ import annotations

import weakref
from collections import OrderedDict

import numpy as np

from bkabem_core.fe.modal import SpeedCells

#: largest error of the speed cells at the check, relative to the combination's largest line (docs/synthesis.md)
MODAL_BOUND = 1e-5
#: speed of the check [Hz]
CHECK_SPEED_HZ = 25.0


class ExactSpectrum:
    """Displacement combinations from :meth:`BkaBem.response` at each requested speed (LRU cache).

    The cache is shared by every ExactSpectrum of the same model object and combination in the process: the
    machines of a fleet that run one case share its model, and when they follow the same speed (one speed topic,
    a line of identical drives) a speed step costs its amplitude knots once per process instead of once per
    machine. The entries are the model's exact response, so sharing changes no sample. Returned arrays are
    shared: read only.
    """

    #: id(model) -> {combination: LRU}; an entry goes with its model (weakref.finalize), so an id is never reused
    _shared: dict[int, dict] = {}

    def __init__(self, model, combination: np.ndarray, cache: int = 256):
        self.model = model
        self._comb = combination
        comb = np.ascontiguousarray(combination)
        key = (comb.shape, comb.dtype.str, comb.tobytes())
        caches = self._shared.get(id(model))
        if caches is None:
            caches = self._shared[id(model)] = {}
            weakref.finalize(model, self._shared.pop, id(model), None)
        # one LRU per (model, combination) that holds as many entries as the sharers' caches did together
        self._lru = caches.setdefault(key, [OrderedDict(), 0])
        self._lru[1] += cache
        self._cache: OrderedDict[float, np.ndarray] = self._lru[0]

    def __call__(self, speed_hz: float) -> np.ndarray:
        """(L, U) complex [m] of every line of the model at ``speed_hz`` [Hz]."""
        key = float(speed_hz)
        x = self._cache.get(key)
        if x is None:
            k = self.model.orders.size
            x = self.model.response([key])[0].reshape(k, -1) @ self._comb.T
            self._cache[key] = x
            if len(self._cache) > self._lru[1]:
                self._cache.popitem(last=False)
        else:
            try:
                self._cache.move_to_end(key)
            except KeyError:                  # dropped meanwhile by a sharer in another thread (a model's warm-up)
                pass
        return x


class LineSpectrum:
    """Displacement combinations (L, U) [m] of every line of ``model`` by ``method`` (module docstring).

    Parameters
    ----------
    model : BkaBem
    combination : ndarray (U, 8)
        The output combinations (:class:`~bkabem_core.synth.channels.ChannelMap`).
    method : {"modal", "exact"}
    """

    def __init__(self, model, combination: np.ndarray, method: str):
        self.model = model
        self.combination = combination
        self.requested = method
        self.exact = ExactSpectrum(model, combination)
        self._cells = None
        #: why the speed cells were refused (their check's error), or None
        self.failed: str | None = None
        self._speed_scaled = bool(np.any(model._speed_power != 0.0))
        li, fi = model._locked_idx, model._fixed_idx
        #: the cells hold every line, in order (then their array is the spectrum itself)
        self._cells_are_all = not fi.size and li.size == len(model.lines) and (li.size == 0 or li[-1] == li.size - 1)

    @property
    def method(self) -> str:
        """``"modal"`` or ``"exact"`` (and why, where the speed cells failed their check)."""
        if self.failed is not None:
            return f"exact (speed cells failed their check: {self.failed})"
        return self.requested

    @property
    def cells(self):
        """The checked speed cells of the speed-locked lines, or None (``"exact"``, or the check failed); made and
        checked on first use."""
        if self.requested != "modal" or self.failed is not None:
            return None
        if self._cells is None:
            cells = self.model.order_modal_form(self.combination).speed_cells()
            err = self._check(cells, CHECK_SPEED_HZ)
            if err >= MODAL_BOUND:
                self.failed = f"error {err:.1e}"
                return None
            self._cells = cells
        return self._cells

    def _check(self, cells, f: float) -> float:
        """Largest error of the cells relative to the largest amplitude per combination, against the exact one."""
        m = self.model
        exact = self.exact(f)
        mine = np.array(exact, copy=True)
        mine[m._locked_idx] = cells(f) * (f ** m._speed_power[m._locked_idx])[:, None]
        return float(np.max(np.abs(mine - exact).max(axis=0) / np.maximum(np.abs(exact).max(axis=0), 1e-300)))

    def raw(self, speed_hz: float):
        """(x, spow): the combinations (L, U) of every line of the model at ``speed_hz`` [Hz] before the lines'
        speed powers, and those (``f ** p`` (L,), None where x has them or they are all 0). x is the speed cells'
        own array where they hold every line in order: read only."""
        f = float(speed_hz)
        cells = self.cells
        if cells is None:
            return np.ascontiguousarray(self.exact(f)), None
        m = self.model
        if self._cells_are_all:
            x = cells(f)
        else:
            x = np.empty((len(m.lines), self.combination.shape[0]), complex)
            x[m._locked_idx] = cells(f)
            if m._fixed_idx.size:
                x[m._fixed_idx] = m._fixed_lines(f) @ self.combination.T
        return x, (f ** m._speed_power if self._speed_scaled else None)

    def __call__(self, speed_hz: float) -> np.ndarray:
        """(L, U) combinations [m] of every line of the model at ``speed_hz`` [Hz], speed powers applied."""
        x, spow = self.raw(speed_hz)
        if spow is not None:
            x = x * spow[:, None]
        return x

    def build(self, f_lo_hz: float, f_hi_hz: float) -> None:
        """Make the speed cells of ``[f_lo_hz, f_hi_hz]`` [Hz] now (nothing with ``"exact"``)."""
        cells = self.cells
        if cells is not None:
            cells.build(f_lo_hz, f_hi_hz)


#: cost model of ``spectrum="auto"`` for a rendered profile [s]: one exact solve per knot of a new speed; one modal
#: evaluation per knot; the modal form's set-up per line, scaled with the cube of the model's DOFs; one speed cell
#: per line (measured on the embedded 60-DOF case of 50 BPFO orders)
COST_EXACT_S, COST_MODAL_S, COST_MODAL_SETUP_PER_LINE_S, COST_CELL_PER_LINE_S = 0.6e-3, 0.01e-3, 0.036, 0.08e-3


def choose_method(model, combination: np.ndarray, profile, seconds: float, knot_s: float,
                  max_speed_step_hz: float) -> str:
    """``spectrum="auto"``'s method for rendering ``profile`` over ``seconds``: the cheaper of the two by the cost
    model above for a model of BPFO orders (the set-up of the speed cells pays off after a few thousand knots,
    and a constant speed has one); the speed cells for any other line set (their exact solve grows with its
    ~50-700 lines and its dense fixed-frequency lines, the cells do not per knot)."""
    if not model.is_order_set:
        return "modal"
    t = profile.times_s
    t_end = np.concatenate([t[t < seconds], [seconds]])
    f_end = profile.speed_hz(t_end)
    knots = 1.0
    for i in range(len(t_end) - 1):
        df = abs(f_end[i + 1] - f_end[i])
        if df > 0:
            knots += max((t_end[i + 1] - t_end[i]) / knot_s, df / max_speed_step_hz) + 1
    made = model.has_order_modal_form(combination)
    n_k, scale = model.orders.size, model.basis.size / 60.0          # cost per pole, relative to 60 DOF
    setup = 0.0 if made or model.has_line_modes() else COST_MODAL_SETUP_PER_LINE_S * n_k * scale ** 3
    if made:
        cells = model.order_modal_form(combination).speed_cells().missing(f_end.min(), f_end.max())
    else:
        cells = len(SpeedCells.cell_range(SpeedCells.DEFAULT_CELL_HZ, f_end.min(), f_end.max()))
    setup += cells * COST_CELL_PER_LINE_S * n_k * scale
    return "modal" if setup + COST_MODAL_S * knots < COST_EXACT_S * knots else "exact"
