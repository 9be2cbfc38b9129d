"""A synthesiser's settings: everything besides the model that decides its samples, checked once.

Bad input raises :class:`~bkabem_core.synth.profile.SynthError` naming the argument and the reason. The meaning of
each setting is documented on :class:`~bkabem_core.synth.synthesizer.Synthesizer`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bkabem_core.synth.channels import DEFAULT_QUANTITIES, QUANTITIES, make_channels
from bkabem_core.synth.profile import SynthError, _finite
from bkabem_core.synth.sensors import (
    Accelerometer,
    AntiAliasFilter,
    HighPassFilter,
    InterferenceTones,
    OutputStage,
    Quantiser,
    SensorChain,
)

MAX_SAMPLE_RATE_HZ = 1.0e6
MAX_SLIP = 0.1
KERNELS = ("auto", "loop", "reference")
#: The Nyquist taper (``band_limit="taper"``) as fractions of Nyquist: (where knots start to be subdivided, where the
#: taper starts, where it ends, its width): a raised cosine from 0.85 to 0.95 stands in for the acquisition's
#: anti-alias filter ...
TAPER_BAND = (0.8, 0.85, 0.95, 0.1)
#: ... and moves out of the way of a steep anti-alias filter of the chain (down by >= 20 dB at 0.95 Nyquist, the
#: acquisition band-limits itself), a guard that keeps every line below Nyquist (0.975 x 1.02 < 1)
GUARD_TAPER_BAND = (0.9, 0.95, 0.975, 0.025)


@dataclass(frozen=True)
class Settings:
    """The settings of a synthesiser (immutable; :meth:`with_noise` and :meth:`with_seed` make changed copies).

    Attributes
    ----------
    sample_rate_hz : float
    chunk_samples : int
    channels : tuple of Channel
    band_limit : {"error", "taper"}
    spectrum : {"auto", "modal", "exact"}
    max_speed_step_hz, min_speed_hz : float
    slip : float
    seed : int
    dtype : numpy scalar type (np.float32 or np.float64)
    max_order, table_size : int or None
    sensors : SensorChain
    output : OutputStage
        The acquisition's output stage (interference tones, quantisation) on the summed samples.
    taper_band : tuple
        :data:`TAPER_BAND`, or :data:`GUARD_TAPER_BAND` behind a steep anti-alias filter.
    broadband_floor : bool
    strikes : bool
        A race pit's strikes of random strength (:mod:`bkabem_core.synth.strikes`); False: all alike.
    noise_density : tuple of (quantity, density) or None
    snr_db : float or None
    input_noise : float
        The acquisition's broadband floor at the acceleration channels' input [m/s^2/sqrt(Hz)] (0: none;
        :mod:`bkabem_core.synth.floor`).
    kernel : {"auto", "loop", "reference"}
        Which sample kernels: the C line-set kernels where they apply (float32, <= 64 channels and families),
        else the per-family C loop (``"auto"``); always the per-family C loop (``"loop"``); the per-family numpy
        reference of the loop, as without a compiler (``"reference"``).
    """

    sample_rate_hz: float
    chunk_samples: int
    channels: tuple
    band_limit: str
    spectrum: str
    max_speed_step_hz: float
    min_speed_hz: float
    slip: float
    seed: int
    dtype: type
    max_order: int | None
    table_size: int | None
    sensors: SensorChain
    output: OutputStage
    taper_band: tuple
    broadband_floor: bool
    strikes: bool
    noise_density: tuple | None
    snr_db: float | None
    kernel: str
    input_noise: float = 0.0

    @classmethod
    def make(cls, sample_rate_hz: float = 25600.0, chunk_s: float = 0.1, *, quantities=DEFAULT_QUANTITIES,
             noise_density: dict | None = None, snr_db: float | None = None, slip: float = 0.0,
             seed: int | None = 0, max_order: int | None = None, band_limit: str = "error", spectrum: str = "auto",
             max_speed_step_hz: float = 0.5, min_speed_hz: float = 0.05, dtype=np.float32,
             table_size: int | None = None, accelerometer: Accelerometer | None = None,
             anti_alias: AntiAliasFilter | None = None, sensors=(), broadband_floor: bool = True,
             kernel: str = "auto", high_pass: HighPassFilter | None = None,
             tones: InterferenceTones | None = None, quantisation: Quantiser | None = None,
             strikes: bool = True, input_noise: float | None = None) -> "Settings":
        """Checked settings from the synthesiser's keyword arguments (``seed=None``: a random seed)."""
        fs = _finite("sample_rate_hz", sample_rate_hz, 0.0, strict=True)
        if fs > MAX_SAMPLE_RATE_HZ:
            raise SynthError("sample_rate_hz", f"must be <= {MAX_SAMPLE_RATE_HZ:g} (got {fs:g})")
        cs = _finite("chunk_s", chunk_s, 0.0, strict=True)
        n_chunk = int(round(cs * fs))
        if n_chunk < 1:
            raise SynthError("chunk_s", f"{cs:g} s is less than one sample at {fs:g} Hz")
        if n_chunk > 1 << 24:
            raise SynthError("chunk_s", f"{cs:g} s is more than 2^24 samples")
        channels = make_channels(quantities)
        if band_limit not in ("error", "taper"):
            raise SynthError("band_limit", f"must be 'error' or 'taper' (got {band_limit!r})")
        if spectrum not in ("auto", "modal", "exact"):
            raise SynthError("spectrum", f"must be 'auto', 'modal' or 'exact' (got {spectrum!r})")
        step = _finite("max_speed_step_hz", max_speed_step_hz, 0.0, strict=True)
        min_speed = _finite("min_speed_hz", min_speed_hz, 0.0, strict=True)
        slip = _finite("slip", slip, 0.0)
        if slip > MAX_SLIP:
            raise SynthError("slip", f"must be <= {MAX_SLIP:g} (a fraction of the ball-pass period; "
                                     f"real bearings 0.01-0.02), got {slip:g}")
        if dtype not in (np.float32, np.float64, "float32", "float64"):
            raise SynthError("dtype", f"must be float32 or float64 (got {dtype!r})")
        if table_size is not None and (isinstance(table_size, bool) or not isinstance(table_size, (int, np.integer))
                                       or table_size < 64 or table_size & (table_size - 1) or table_size > 1 << 16):
            raise SynthError("table_size", f"must be a power of 2 in 64..65536 (got {table_size!r})")
        chain = []
        for name, v, kind in (("anti_alias", anti_alias, AntiAliasFilter), ("accelerometer", accelerometer,
                                                                            Accelerometer),
                              ("high_pass", high_pass, HighPassFilter)):
            if v is not None and not isinstance(v, kind):
                raise SynthError(name, f"must be a {kind.__name__} or None (got {type(v).__name__})")
            if v is not None:
                chain.append(v)
        stages = []
        for name, v, kind in (("tones", tones, InterferenceTones), ("quantisation", quantisation, Quantiser)):
            if v is not None and not isinstance(v, kind):
                raise SynthError(name, f"must be a {kind.__name__} or None (got {type(v).__name__})")
            if v is not None:
                stages.append(v)
        if tones is not None and tones.check_rate(fs):
            raise SynthError("tones", tones.check_rate(fs))
        taper_band = TAPER_BAND
        if anti_alias is not None and abs(complex(anti_alias.gain(0.95 * fs / 2))) <= 0.1:
            taper_band = GUARD_TAPER_BAND
        for s in sensors:
            if not all(hasattr(s, a) for a in ("name", "measures", "gain", "to_dict")):
                raise SynthError("sensors", f"{s!r} is not a sensor (name, measures, gain, to_dict)")
        try:
            chain = SensorChain(tuple(chain) + tuple(sensors))
        except ValueError as e:
            raise SynthError("sensors", str(e).split(": ", 1)[-1]) from None
        if not isinstance(strikes, (bool, np.bool_)):
            raise SynthError("strikes", f"must be true or false (got {strikes!r})")
        if kernel not in KERNELS:
            raise SynthError("kernel", f"must be one of {', '.join(KERNELS)} (got {kernel!r})")
        base = cls(sample_rate_hz=fs, chunk_samples=n_chunk, channels=channels, band_limit=band_limit,
                   spectrum=spectrum, max_speed_step_hz=step, min_speed_hz=min_speed, slip=slip, seed=0,
                   dtype=np.dtype(dtype).type, max_order=max_order, table_size=table_size, sensors=chain,
                   output=OutputStage(tuple(stages)), taper_band=taper_band, broadband_floor=bool(broadband_floor),
                   strikes=bool(strikes), noise_density=None, snr_db=None, kernel=kernel,
                   input_noise=_finite("input_noise", 0.0 if input_noise is None else input_noise, 0.0))
        return base.with_seed(seed).with_noise(noise_density, snr_db)

    def with_seed(self, seed: int | None) -> "Settings":
        """These settings with another seed (None: a random one)."""
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % (1 << 63))
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise SynthError("seed", f"must be an integer >= 0 (got {seed!r})")
        return replace(self, seed=int(seed))

    def with_noise(self, noise_density: dict | None = None, snr_db: float | None = None) -> "Settings":
        """These settings with another sensor noise (both None: none)."""
        if noise_density is not None and snr_db is not None:
            raise SynthError("noise", "give noise_density or snr_db, not both")
        dens = {}
        if noise_density is not None:
            if not isinstance(noise_density, dict):
                raise SynthError("noise_density", "must be a dict quantity -> density")
            for q, v in noise_density.items():
                if q not in QUANTITIES:
                    raise SynthError("noise_density", f"unknown quantity {q!r}")
                dens[q] = _finite(f"noise_density.{q}", v, 0.0)
        snr = None if snr_db is None else _finite("snr_db", snr_db)
        return replace(self, noise_density=tuple(dens.items()) or None, snr_db=snr)

    @property
    def noise(self) -> dict | None:
        """The noise density per quantity as a dict (None: none)."""
        return None if self.noise_density is None else dict(self.noise_density)
