"""The synthesiser's randomness, indexed by absolute position so that chunking never changes it.

:class:`SlipWalk` is the random walk of a bearing's ball-pass phase (random slip, Antoni & Randall), :class:`SlipWalks`
those of a machine's bearings (each its own, seeded by the run's seed and the bearing's name), :class:`SensorNoise`
the sensor noise of a set of channels (made in the C sample loops from :func:`noise_key`; :class:`NoiseBlocks`,
numpy's generator in seeded blocks, where the kernels are not built). Units: ball passes, standard normal
numbers, noise in the channels' units.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from bkabem_core.synth import kernel as synth_kernel
from bkabem_core.synth.features import _FOLD
from bkabem_core.synth.splitmix import stream_key


class _Walk:
    """A Gaussian random walk at integer passes j, ``X_0 = 0``, ``X_{j+1} - X_j ~ N(0, sigma^2)``, made in blocks of
    :data:`SlipWalk.BLOCK` increments, each block from ``SeedSequence([*key, block])`` (``key``: the seed, a tag and
    any further words; values depend on (key, j) alone; a block goes on from the last one's end)."""

    def __init__(self, sigma: float, key: tuple, block: int):
        self.sigma, self.key, self.size = float(sigma), tuple(int(v) for v in key), int(block)
        self.reset()

    def reset(self):
        self._blocks: OrderedDict[int, np.ndarray] = OrderedDict()
        self._next_block = 0
        self._next_start = 0.0

    def block(self, b: int) -> np.ndarray:
        if b in self._blocks:
            return self._blocks[b]
        if b < self._next_block:                         # went back beyond the kept blocks: replay
            self.reset()
        while self._next_block <= b:
            rng = np.random.default_rng(np.random.SeedSequence([*self.key, self._next_block]))
            eps = self.sigma * rng.standard_normal(self.size)
            w = np.empty(self.size)
            w[0] = 0.0
            np.cumsum(eps[:-1], out=w[1:])
            w += self._next_start
            self._next_start = float(w[-1] + eps[-1])
            self._blocks[self._next_block] = w
            self._next_block += 1
            while len(self._blocks) > 3:
                self._blocks.popitem(last=False)
        return self._blocks[b]

    def values(self, j0: int, j1: int) -> np.ndarray:
        """X_j for j in [j0, j1] (inclusive; 0 for j <= 0)."""
        out = np.zeros(j1 - j0 + 1)
        if self.sigma == 0.0:
            return out
        lo = max(j0, 0)
        j = lo
        while j <= j1:
            b = j // self.size
            blk = self.block(b)
            s = j - b * self.size
            e = min(self.size, j1 - b * self.size + 1)
            out[j - j0:j - j0 + e - s] = blk[s:e]
            j += e - s
        return out


def bearing_word(bearing: str) -> int:
    """The word of a bearing's name in its walks' seeds (the name's ASCII bytes as one integer: ``"nde"`` is
    0x6E6465)."""
    return int.from_bytes(str(bearing).encode("ascii"), "big")


class SlipWalk:
    """Random walk W_j of a bearing's ball-pass phase [passes] at integer nominal passes j (W_j = 0 for j <= 0).

    ``W_{j+1} - W_j ~ N(0, sigma^2)`` i.i.d.: the j-th inter-arrival lasts ``1 - (W_{j+1} - W_j)`` nominal passes,
    i.e. a relative jitter of standard deviation ``sigma`` (Antoni & Randall's random slip). Increments come in
    blocks of 2^14 passes, each from its own seeded generator, so values depend only on (seed, bearing, j): the DE's
    blocks from ``SeedSequence([seed, tag, block])`` (the walk of a machine with one bearing type), another
    bearing's from ``SeedSequence([seed, tag, bearing_word(bearing), block])``.

    The balls' spin slip (:mod:`bkabem_core.synth.balltrack`) is a second, independent walk ``s V_j`` of the same
    form, ``V`` of unit steps and ``s`` the spin slip [fraction of the spin's advance per pass]: the spin phase of
    the defective ball reads ``W + s V`` (``spin=s`` in :meth:`values`, :meth:`window`, :meth:`warp_fixed`).
    """

    BLOCK = 1 << 14
    _TAG, _SPIN_TAG = 0x51117, 0x5B1A

    def __init__(self, sigma: float, seed: int, bearing: str = "de"):
        self.sigma = float(sigma)
        self.seed = int(seed)
        self.bearing = str(bearing)
        own = () if self.bearing == "de" else (bearing_word(self.bearing),)
        self._cage = _Walk(self.sigma, (self.seed, self._TAG, *own), self.BLOCK)
        self._spin = _Walk(1.0, (self.seed, self._SPIN_TAG, *own), self.BLOCK)

    def reset(self):
        self._cage.reset()
        self._spin.reset()

    def values(self, j0: int, j1: int, spin: float | None = None) -> np.ndarray:
        """W_j for j in [j0, j1] (inclusive); with ``spin`` s, ``W_j + s V_j``."""
        w = self._cage.values(j0, j1)
        if spin is not None:
            w = w + float(spin) * self._spin.values(j0, j1)
        return w

    def warp(self, u_int: int, u: np.ndarray) -> np.ndarray:
        """W at absolute passes ``u_int + u`` (C1 cubic Hermite, Catmull-Rom slopes)."""
        fl = np.floor(u)
        j_lo, j_hi = int(fl[0]) if u.size else 0, int(fl[-1]) if u.size else 0
        j_lo, j_hi = min(j_lo, int(fl.min())), max(j_hi, int(fl.max()))
        w = self.values(u_int + j_lo - 1, u_int + j_hi + 2)
        m = np.empty_like(w)
        m[1:-1] = 0.5 * (w[2:] - w[:-2])
        m[0], m[-1] = m[1], m[-2]
        idx = fl.astype(np.intp) - (j_lo - 1)
        t = u - fl
        t2 = t * t
        t3 = t2 * t
        w0, w1 = w[idx], w[idx + 1]
        m0, m1 = m[idx], m[idx + 1]
        return (2 * t3 - 3 * t2 + 1) * w0 + (t3 - 2 * t2 + t) * m0 + (3 * t2 - 2 * t3) * w1 + (t3 - t2) * m1

    def warp_fixed(self, u_int: int, j0: int, m: int, c1: float, c2: float, u_frac: float,
                   kappas=(1.0,), spin: float | None = None) -> list:
        """Per ``kappa`` the (m,) int64 phase offsets of a segment's samples j0..j0+m-1 (ball passes since the knot
        ``u = (c2 xi + c1) xi + u_frac``, speed >= 0 so u is monotonic), ``rint(frac(kappa W(u)) 2^52) 2^10``: the
        Hermite warp of :meth:`warp` (Horner form per pass interval) and the fixed-point conversion in one C pass
        for all factors (:func:`~bkabem_core.synth.kernel.slip_warp`); of ``W + spin V`` with ``spin``."""
        w, jw0 = self._window(u_int, j0, m, c1, c2, u_frac, spin)
        kap = list(kappas)
        rows = []
        for i in range(0, len(kap), 8):                  # the C kernel takes up to 8 factors per pass
            rows.extend(synth_kernel.slip_warp(m, j0, c1, c2, u_frac, w, jw0, kap[i:i + 8]))
        return rows

    def _window(self, u_int: int, j0: int, m: int, c1: float, c2: float, u_frac: float, spin: float | None):
        u_lo = u_frac + (c2 * j0 + c1) * j0
        xe = float(j0 + m - 1)
        u_hi = (c2 * xe + c1) * xe + u_frac
        j_lo, j_hi = int(math.floor(min(u_lo, u_hi))), int(math.floor(max(u_lo, u_hi)))
        return self.values(u_int + j_lo - 1, u_int + j_hi + 2, spin), j_lo - 1

    def window(self, u_int: int, j0: int, m: int, c1: float, c2: float, u_frac: float, spin: float | None = None):
        """(W values, pass of the first) that :meth:`warp_fixed`'s samples need (the walk from one pass before
        the first sample's to two after the last's); with ``spin`` s, the values of W and then those of
        ``W + s V`` in one array (the line-set kernel's two walks)."""
        w, jw0 = self._window(u_int, j0, m, c1, c2, u_frac, None)
        if spin is not None:
            w = np.concatenate([w, w + float(spin) * self._spin.values(u_int + jw0, u_int + jw0 + w.size - 1)])
        return w, jw0


class SlipWalks:
    """The slip walks of a machine's bearings for one run: each bearing's cage slips on its own (a :class:`SlipWalk`
    per bearing, made when first read), all of relative standard deviation ``sigma`` per ball pass and all read at
    the DE's ball passes (the stream's clock; :mod:`bkabem_core.synth.lines` scales the NDE's step to its own
    passes). A machine whose two bearings share their kinematics has its lines on the DE's phases and reads the DE's
    walk alone: the run's one walk.

    Parameters
    ----------
    sigma : float
        Relative standard deviation of a ball pass's inter-arrival [-].
    seed : int
    """

    def __init__(self, sigma: float, seed: int):
        self.sigma = float(sigma)
        self.seed = int(seed)
        self._walks: dict[str, SlipWalk] = {}

    def bearing(self, bearing: str) -> SlipWalk:
        """The walk of ``bearing`` (``"de"``, ``"nde"``)."""
        walk = self._walks.get(bearing)
        if walk is None:
            walk = self._walks[bearing] = SlipWalk(self.sigma, self.seed, bearing)
        return walk

    def reset(self) -> None:
        for walk in self._walks.values():
            walk.reset()

    def warp_fixed(self, u_int: int, j0: int, m: int, c1: float, c2: float, u_frac: float, kappas=(1.0,),
                   spin: float | None = None, bearing: str = "de") -> list:
        """:meth:`SlipWalk.warp_fixed` of the walk of ``bearing``."""
        return self.bearing(bearing).warp_fixed(u_int, j0, m, c1, c2, u_frac, kappas, spin)

    def window(self, u_int: int, j0: int, m: int, c1: float, c2: float, u_frac: float, sources) -> tuple:
        """(values, pass of the first) of the walks ``sources`` (each (bearing, spin slip or None): a bearing's
        cage walk W, or ``W + s V`` with its spin walk) that a segment's samples need (:meth:`SlipWalk.window`),
        one walk's values after the other in one array (the line-set kernel's walks)."""
        if len(sources) == 1 and sources[0][1] is None:
            return self.bearing(sources[0][0]).window(u_int, j0, m, c1, c2, u_frac)
        cage: dict = {}
        parts, jw0 = [], 0
        for bearing, spin in sources:
            walk = self.bearing(bearing)
            if bearing not in cage:
                cage[bearing] = walk.window(u_int, j0, m, c1, c2, u_frac)
            w, jw0 = cage[bearing]
            if spin is not None:
                w = w + float(spin) * walk._spin.values(u_int + jw0, u_int + jw0 + w.size - 1)
            parts.append(w)
        return np.concatenate(parts), jw0


def noise_key(seed: int) -> int:
    """The 64-bit key of the sensor-noise stream of ``seed`` (``kernels/synth_noise.c``: the sample loops make the normals
    of absolute sample n from it, in blocks of 256 samples)."""
    return stream_key(seed, NoiseBlocks._TAG)


class NoiseBlocks:
    """Standard normal noise (n, C) indexed by absolute sample, in seeded blocks: the fallback when the C kernel is
    not built (numpy's generator; block b from ``SeedSequence([seed, tag, b])``), another, equally valid,
    realisation for the same seed. With the kernel the noise is made inside the sample loop (:func:`noise_key`)."""

    BLOCK = 1 << 13
    _TAG = 0x4015E

    def __init__(self, seed: int, n_channels: int, dtype):
        self.seed, self.c, self.dtype = int(seed), int(n_channels), dtype
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()

    def _block(self, b: int) -> np.ndarray:
        z = self._cache.get(b)
        if z is None:
            seq = np.random.SeedSequence([self.seed, self._TAG, b])
            dt = np.float32 if self.dtype == np.float32 else np.float64
            z = np.random.default_rng(seq).standard_normal((self.BLOCK, self.c), dtype=dt)
            self._cache[b] = z
            while len(self._cache) > 4:
                self._cache.popitem(last=False)
        return z

    def get(self, n0: int, n: int) -> np.ndarray:
        out = np.empty((n, self.c), dtype=self.dtype)
        i = n0
        while i < n0 + n:
            b = i // self.BLOCK
            s = i - b * self.BLOCK
            e = min(self.BLOCK, n0 + n - b * self.BLOCK)
            out[i - n0:i - n0 + e - s] = self._block(b)[s:e]
            i += e - s
        return out


class SensorNoise:
    """White sensor noise of a set of channels (one realisation per seed, a function of the absolute sample).

    Parameters
    ----------
    density : dict or None
        One-sided density per quantity (``{"acceleration": m/s^2/sqrt(Hz), ...}``): noise RMS = density *
        sqrt(sample_rate / 2).
    snr_db : float or None
        Alternative: noise RMS = the dynamic RMS of the channel (from the line amplitudes at the segment's knots) /
        10^(snr_db / 20).
    channels : sequence of Channel
    sample_rate_hz : float
    seed : int
    dtype : numpy dtype of the samples

    With the C kernels the normals are made inside the sample loops (:meth:`segment`: the key, the first sample and
    sigma per channel); without them numpy's generator in seeded blocks is added after the samples (:meth:`add`),
    another, equally valid, realisation for the same seed.
    """

    def __init__(self, density: dict | None, snr_db: float | None, channels, sample_rate_hz: float, seed: int,
                 dtype):
        dens = dict(density or {})
        self.snr_db = snr_db
        self.sigma = np.array([dens.get(c.quantity, 0.0) * math.sqrt(sample_rate_hz / 2) for c in channels])
        #: whether any channel has noise
        self.on = bool(np.any(self.sigma > 0)) or snr_db is not None
        self.key = noise_key(seed)
        self.dtype = dtype
        self._sigma_t = np.ascontiguousarray(self.sigma, dtype=dtype)
        self._blocks = NoiseBlocks(seed, len(self.sigma), dtype) if self.on else None

    def _snr_sigma(self, a, b) -> np.ndarray:
        """sigma per channel of the segment between knots a and b (``snr_db``): the knots' mean dynamic power."""
        g = 10 ** (-self.snr_db / 20)
        return g * np.sqrt(0.5 * (a.amp.rms ** 2 + b.amp.rms ** 2))

    def segment(self, a, b, lo: int) -> tuple:
        """(key, first sample, sigma per channel in the samples' dtype) of the noise of a segment from sample
        ``lo`` between knots a and b, for the C sample loops."""
        if self.snr_db is None:
            return self.key, lo, self._sigma_t
        return self.key, lo, np.ascontiguousarray(self._snr_sigma(a, b), dtype=self.dtype)

    @staticmethod
    def _add_scaled(out: np.ndarray, z: np.ndarray, sigma: np.ndarray) -> None:
        """out += z * sigma (per channel), rows folded (see _FOLD)."""
        m, c = out.shape
        q = m // _FOLD * _FOLD
        sig = sigma.astype(out.dtype)
        if q:
            zz = z[:q].reshape(-1, _FOLD * c)
            zz *= np.tile(sig, _FOLD)
            out[:q].reshape(-1, _FOLD * c)[...] += zz
        if q < m:
            out[q:] += z[q:] * sig

    def add(self, out: np.ndarray, n0: int, segments) -> None:
        """Add numpy's noise to the samples ``out`` of [n0, n0 + len(out)) (``segments``: the (knot a, knot b,
        first, end) that cover them)."""
        z = self._blocks.get(n0, out.shape[0])
        if self.snr_db is None:
            self._add_scaled(out, z, self.sigma)
            return
        for a, b, lo, hi in segments:
            self._add_scaled(out[lo - n0:hi - n0], z[lo - n0:hi - n0], self._snr_sigma(a, b))
