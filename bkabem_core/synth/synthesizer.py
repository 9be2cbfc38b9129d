"""Waveform synthesis: speed-driven, phase-continuous sensor signals for the DE and NDE bearings.

A monitoring pipeline consumes samples. :class:`Synthesizer` turns the BKA-BEM spectra of a case into the signals
real sensors give, chunk by chunk, under a shaft speed that may change at any time (a profile, or a stream of
updates arriving between chunks). The method, its error bounds and the realism options are described in
``docs/synthesis.md``; in short:

* **Angle domain.** Speed is integrated exactly (it is piecewise linear in time, so every line's phase is a
  quadratic per segment) and a line of coefficients ``c`` contributes ``Re(Y exp(i c . Phi))`` where ``Phi`` are
  the shaft phase, each bearing's cage and ball-spin phases and the supply phase since t = 0 (cage angles 0 at
  t = 0, the convention of :mod:`bkabem_core.solve.harmonic`); BPFO order ``k`` is ``Re(Y_k exp(i k u 2 pi))``
  with ``u`` the ball passes. Each bearing slips by a walk of its own (docs/synthesis.md).
  Signals are continuous in value and slope across chunks and speed changes.
* **Knots.** The complex amplitudes ``Y`` (per channel) are evaluated at *knots*: every chunk border in streaming,
  every ``knot_s`` of run time and every profile breakpoint when rendering a profile, plus subdivisions so that the
  speed moves by at most ``max_speed_step_hz`` between knots. Between knots amplitudes are linear in time.
* **Spectrum at a knot** (:mod:`bkabem_core.synth.plan`): ``"modal"``, the model's order-wise pole-residue form
  in 0.5-Hz speed cells (every line within 1e-5 of the channel's largest, against :meth:`BkaBem.response`, at
  shaft speeds >= ``min_speed_hz``, tested); ``"exact"``, :meth:`BkaBem.response` at every knot; ``"auto"``
  (default), modal when streaming and the cheaper of the two for a rendered profile.
* **Wavetables** (:mod:`bkabem_core.synth.lines`, :mod:`bkabem_core.synth.render`, :mod:`bkabem_core.synth.stream`). The lines are grouped into
  families of harmonics of one phase (BPFO orders are one family of the ball-pass phase); at each knot every family
  is tabulated over one turn of its phase as the coefficients of a periodic cubic B-spline (the spline's droop
  pre-emphasised, so every line comes out exact), by an FFT. Samples evaluate the spline at the family's
  fixed-point phase (an exact function of knot and sample) and blend the two knots' tables linearly in time;
  interpolation images of harmonic k stay below ``(k / (N - k))^4`` of it (N >= 8 k: -77 dB).
* **Channels** (:mod:`bkabem_core.synth.channels`): per bearing and direction ``acceleration`` of the housing
  [m/s^2], ``displacement`` of the shaft relative to the housing [m], optionally ``velocity`` of the housing [mm/s];
  through the sensor chain (:mod:`bkabem_core.synth.sensors`).

Structure: the settings (:mod:`~bkabem_core.synth.settings`) and the model make an immutable plan
(:mod:`~bkabem_core.synth.plan`); a run is a small mutable stream of knots (:mod:`~bkabem_core.synth.stream`);
a model switch swaps the plan at a chunk border (:mod:`~bkabem_core.synth.switch`). Everything random (slip,
noise, floor) is seeded and indexed by absolute ball pass / sample number, so the samples do not depend on how a
run is cut into chunks. Bad input raises :class:`SynthError` naming the argument and the reason.
"""

from __future__ import annotations

import time
from typing import Iterator

import numpy as np

from bkabem_core.solve.harmonic import BkaBem
from bkabem_core.synth.balltrack import TrackGate
from bkabem_core.synth.channels import DEFAULT_QUANTITIES
from bkabem_core.synth.features import Chunk, waveform_features  # noqa: F401  (re-exported)
from bkabem_core.synth.measurement import DEFAULT_SAMPLE_RATE_HZ, FROM_CASE, Measurement  # noqa: F401
from bkabem_core.synth.plan import Plan, choose_method
from bkabem_core.synth.profile import SpeedProfile, SynthError, _finite, parse_profile  # noqa: F401  (re-exported)
from bkabem_core.synth.randomness import SlipWalks
from bkabem_core.synth.sensors import Accelerometer, AntiAliasFilter
from bkabem_core.synth.settings import Settings
from bkabem_core.synth.stream import Stream
from bkabem_core.synth.switch import WarmModel


class Synthesizer:
    """Speed-driven, phase-continuous sensor signals of one case, chunk by chunk.

    Parameters
    ----------
    model : BkaBem
        The prepared model of the case (its spectrum is evaluated at every knot).
    sample_rate_hz : float or None
        Samples per second (up to 1 MHz; None, the default: the case's ``measurement.sample_rate_hz``, else 25 600).
    chunk_s : float
        Chunk length [s] (default 0.1); ``round(chunk_s * sample_rate_hz)`` samples.
    quantities : sequence of str
        Any of ``"acceleration"`` (housing, m/s^2), ``"displacement"`` (shaft relative to housing, m),
        ``"velocity"`` (housing, mm/s). Default acceleration and displacement (8 channels).
    noise_density : dict, None or "case"
        White sensor noise, one-sided density per quantity: ``{"acceleration": m/s^2/sqrt(Hz), "displacement":
        m/sqrt(Hz), "velocity": mm/s/sqrt(Hz)}``; noise RMS = density * sqrt(sample_rate / 2). ``"case"`` (the
        default): the case's ``measurement.noise_density_m_s2_per_sqrt_hz`` (none without it, or with ``snr_db``).
    snr_db : float or None
        Alternative to ``noise_density``: noise RMS = dynamic signal RMS of the channel (from the line amplitudes
        at the segment's knots) / 10^(snr_db / 20).
    slip : float or "case"
        Standard deviation of the ball-pass inter-arrival as a fraction of its nominal value (0 = off; real
        bearings 0.01-0.02). Must be in [0, 0.1]. Default: the case's ``[measurement] slip``, else 0.
    seed : int or None
        Seed of slip, noise, floor and strikes (None: a random seed, reported in the ground truth).
    max_order : int or None
        Synthesise model orders up to this one (None: every order the model keeps).
    band_limit : {"auto", "taper", "error"}
        ``"taper"``: the lines are carried up to the acquisition's band and fade out (raised cosine) between 0.85
        and 0.95 of Nyquist, dropped above, evaluated at the knots, with knots close enough that nothing aliases.
        ``"error"``: every kept line must stay below Nyquist at every speed (else :class:`SynthError`). ``"auto"``
        (default): ``"taper"`` for a case that carries its lines to the band (``excitation.max_order = 0``, the
        fault library), ``"error"`` for a case that caps them (it asked for every one of its orders).
    spectrum : {"auto", "modal", "exact"}
        How the BKA-BEM spectrum is evaluated at a knot (module docstring).
    knot_s : float
        Largest time between amplitude knots when rendering a profile [s] (default 0.1). In streaming, knots are
        the chunk borders.
    max_speed_step_hz : float
        Largest speed change between knots [Hz]; longer segments are subdivided (default 0.5).
    min_speed_hz : float
        Below this speed only the static part is output; the lines fade in (smoothstep) up to twice it.
    initial_speed_hz : float or None
        Speed at t = 0 for streaming; None: the first update (the first chunk is then at constant speed).
    dtype : numpy dtype
        ``np.float32`` (default) or ``np.float64`` samples.
    features : bool
        Compute per-chunk features (default True).
    table_size : int or None
        Spline coefficients per turn of every family's phase (power of 2; default each family its own,
        max(64, 8 x its highest harmonic): 512 for 50 BPFO orders).
    accelerometer : Accelerometer, None or "case"
        The mounted sensor's resonance on the housing channels (:mod:`bkabem_core.synth.sensors`; None: ideal).
    anti_alias : AntiAliasFilter, None or "case"
        The acquisition's low-pass on every channel (None: none; ``AntiAliasFilter.for_rate(fs)`` the usual one).
    high_pass : HighPassFilter, None or "case"
        The acquisition's AC coupling on the housing channels (None: none).
    tones : InterferenceTones, None or "case"
        Fixed-frequency interference added to the acceleration channels as recorded (None: none).
    quantisation : Quantiser, None or "case"
        The converter's step on the acceleration channels (None: none).
    measurement : bool
        Take what the arguments above leave at ``"case"`` (their default) from the case's ``[measurement]``
        section (:mod:`bkabem_core.synth.measurement`; default True); False: none of it, an ideal acquisition.
    sensors : sequence
        Further sensors of the chain (:mod:`bkabem_core.synth.sensors`), after the anti-alias filter and sensor.
    broadband_floor : bool
        Add the case's broadband floor (``baseline.broadband_force_n_per_sqrt_hz``: random force pairs across the
        bearings through the machine's receptance, :mod:`bkabem_core.synth.floor`) when the case sets one (default
        True); made with the plan (the transfer is shared by the models of one machine).
    kernel : {"auto", "loop", "reference"}
        Which sample kernels (:class:`~bkabem_core.synth.settings.Settings`); the samples agree to float32 rounding.
    strikes : bool
        A race pit's strikes of random strength (:mod:`bkabem_core.synth.strikes`; default True); False: all alike.
    """

    def __init__(self, model: BkaBem, sample_rate_hz: float | None = None, chunk_s: float = 0.1, *,
                 quantities=DEFAULT_QUANTITIES, noise_density: dict | None | str = FROM_CASE,
                 snr_db: float | None = None, slip: float | str = FROM_CASE, seed: int | None = 0,
                 max_order: int | None = None, band_limit: str = "auto", spectrum: str = "auto", knot_s: float = 0.1,
                 max_speed_step_hz: float = 0.5, min_speed_hz: float = 0.05, initial_speed_hz: float | None = None,
                 dtype=np.float32, features: bool = True, table_size: int | None = None, accelerometer=FROM_CASE,
                 anti_alias=FROM_CASE, sensors=(), broadband_floor: bool = True, kernel: str = "auto",
                 high_pass=FROM_CASE, tones=FROM_CASE, quantisation=FROM_CASE, measurement: bool = True,
                 strikes: bool = True):
        if not isinstance(model, BkaBem):
            raise SynthError("model", f"must be a BkaBem (got {type(model).__name__})")
        #: the case's measurement chain (empty with ``measurement=False``)
        self.measurement = Measurement.of_case(model.case) if measurement else Measurement()
        m = self.measurement

        def case_default(value, name):
            return getattr(m, name) if isinstance(value, str) and value == FROM_CASE else value

        if sample_rate_hz is None:
            sample_rate_hz = m.sample_rate_hz if m.sample_rate_hz is not None else DEFAULT_SAMPLE_RATE_HZ
        if isinstance(noise_density, str) and noise_density == FROM_CASE:
            noise_density = None if snr_db is not None else m.noise_density
        accelerometer, anti_alias, high_pass, tones, quantisation, case_slip = (
            case_default(v, k) for v, k in ((accelerometer, "accelerometer"), (anti_alias, "anti_alias"),
                                            (high_pass, "high_pass"), (tones, "tones"),
                                            (quantisation, "quantisation"), (slip, "slip")))
        if band_limit == "auto":            # lines carried to the band: taper; a case that caps its lines: error
            band_limit = "taper" if int(model.case.raw["excitation"].get("max_order", 0)) == 0 else "error"
        self.settings = Settings.make(
            sample_rate_hz, chunk_s, quantities=quantities, noise_density=noise_density, snr_db=snr_db,
            slip=0.0 if case_slip is None and slip == FROM_CASE else case_slip, seed=seed, max_order=max_order,
            band_limit=band_limit, spectrum=spectrum, max_speed_step_hz=max_speed_step_hz, min_speed_hz=min_speed_hz,
            dtype=dtype, table_size=table_size, accelerometer=accelerometer, anti_alias=anti_alias, sensors=sensors,
            broadband_floor=broadband_floor, kernel=kernel, high_pass=high_pass, tones=tones,
            quantisation=quantisation, strikes=strikes, input_noise=m.input_noise)
        self.knot_s = _finite("knot_s", knot_s, 0.0, strict=True)
        #: Most knots one speed step (one streamed chunk) may add; a real-time caller (the ROS node) lowers it so a
        #: jump of any size costs a bounded time (coarser amplitude interpolation through the jump, exact phase).
        self.max_knots_per_step = 100000
        self.compute_features = bool(features)
        self.initial_speed_hz = None if initial_speed_hz is None else _finite("initial_speed_hz", initial_speed_hz, 0.0)
        self._plan = Plan(model, self.settings, "exact" if spectrum == "exact" else "modal")
        self.reset()

    # ------------------------------------------------------------------ settings and plan
    def _set_settings(self, settings: Settings) -> None:
        self.settings = settings
        self._plan = self._plan.with_settings(settings)

    @property
    def seed(self) -> int:
        return self.settings.seed

    @seed.setter
    def seed(self, seed: int) -> None:
        """A new seed (slip, noise, floor): the floor's and the noise's from now on, the slip walk's from
        :meth:`reset`."""
        self._set_settings(self.settings.with_seed(seed))

    def set_noise(self, noise_density: dict | None = None, snr_db: float | None = None) -> None:
        """Sensor noise from the next chunk on (see the class parameters); both None switches it off."""
        self._set_settings(self.settings.with_noise(noise_density, snr_db))

    # the settings' facts
    sample_rate_hz = property(lambda self: self.settings.sample_rate_hz)
    chunk_samples = property(lambda self: self.settings.chunk_samples)
    band_limit = property(lambda self: self.settings.band_limit)
    max_speed_step_hz = property(lambda self: self.settings.max_speed_step_hz)
    min_speed_hz = property(lambda self: self.settings.min_speed_hz)
    slip = property(lambda self: self.settings.slip)
    snr_db = property(lambda self: self.settings.snr_db)
    dtype = property(lambda self: self.settings.dtype)

    @property
    def noise_density(self) -> dict | None:
        return self.settings.noise

    @property
    def accelerometer(self) -> Accelerometer | None:
        return self.settings.sensors.get("accelerometer")

    @property
    def anti_alias(self) -> AntiAliasFilter | None:
        return self.settings.sensors.get("anti_alias")

    @property
    def model(self) -> BkaBem:
        return self._plan.model

    @model.setter
    def model(self, model: BkaBem) -> None:
        self.set_model(model)

    # the plan's facts
    case = property(lambda self: self._plan.case)
    channels = property(lambda self: self._plan.channels.channels)
    channel_names = property(lambda self: self._plan.channels.names)
    units = property(lambda self: self._plan.channels.units)
    orders = property(lambda self: self._plan.lines.orders, doc="BPFO order of each kept line (0: not an order).")
    coefficients = property(lambda self: self._plan.lines.coefficients, doc="(L, 6) on the machine's phases.")
    bpfo_per_hz = property(lambda self: self._plan.lines.bpfo_per_hz, doc="The DE bearing's BPFO per shaft Hz.")
    n_balls = property(lambda self: self._plan.lines.n_balls, doc="The DE bearing's ball count.")
    fault_multipliers = property(lambda self: self._plan.lines.multipliers["de"], doc="The DE bearing's.")
    bearing_multipliers = property(lambda self: dict(self._plan.lines.multipliers), doc="Each bearing's.")
    highest_order = property(lambda self: self._plan.lines.highest_order)
    table_size = property(lambda self: self._plan.lines.families.table_size)
    floor_density = property(lambda self: self._plan.floor_density)
    floor = property(lambda self: self._plan.floor, doc="The broadband floor (made with the plan; None: none).")
    spectrum_method = property(lambda self: self._plan.spectrum.method)

    def ground_truth(self) -> dict:
        """The run's ground truth (case, defects, multipliers, seed, realism settings, lines), JSON-ready."""
        return dict(self._plan.ground_truth)

    # ------------------------------------------------------------------ the lines
    @property
    def multipliers(self) -> np.ndarray:
        """Speed-proportional part of each synthesised line's frequency [Hz per shaft Hz]."""
        return self._plan.lines.nu.copy()

    def frequency_hz(self, speed_hz: float) -> np.ndarray:
        """Frequencies of the synthesised lines [Hz] at a shaft speed [Hz]."""
        return self._plan.lines.frequency_hz(speed_hz)

    def line_orders(self) -> np.ndarray:
        """Each synthesised line's frequency in the DE bearing's BPFO orders [-] (the integer orders of BPFO orders,
        as floats)."""
        return self._plan.lines.nu / self._plan.lines.bpfo_per_hz

    def line_phases_rad(self, chunk: Chunk) -> np.ndarray:
        """Phase of every line at the first sample of ``chunk`` [rad], before slip: ``c . Phi`` (BPFO order k:
        ``k z theta_cage``, each line on its own bearing's cage and spin), so that ``line_spectrum`` amplitudes
        times ``exp(i phase)`` are the lines at t0."""
        cages = chunk.cage_angles_rad or {"de": chunk.cage_angle_rad, "nde": chunk.cage_angle_rad}
        return self._plan.line_phases_rad(float(chunk.shaft_angle_rad), cages, float(chunk.t0_s))

    def line_spectrum(self, speed_hz: float) -> dict:
        """The lines the waveform holds at ``speed_hz`` [Hz] (what an FFT of a steady run shows).

        Returns ``orders`` (L,), ``frequency_hz`` (L,), ``amplitude`` (L, C) complex in the channel units (quantity,
        sensors, Nyquist taper and low-speed fade applied; phase origin t = 0, before slip) and ``dc`` (C,), the
        static part."""
        f = _finite("speed_hz", speed_hz, 0.0)
        plan = self._plan
        return {"orders": plan.lines.orders.copy(), "frequency_hz": plan.lines.frequency_hz(f),
                "amplitude": plan.amplitudes(f).y.copy(), "dc": plan.dc.copy(), "channel_names": self.channel_names,
                "units": self.units}

    def band_taper(self, speed_hz: float):
        """The Nyquist taper per line at a shaft speed [Hz] (``band_limit="taper"``), or None when every line is
        carried in full: weight of each kept line in [0, 1], 1 below 0.85 of Nyquist, a raised cosine to 0 at
        0.95, 0 above [-]."""
        return self._plan.weights(float(speed_hz))[1]

    def max_speed_for_rate_hz(self) -> float:
        """Highest shaft speed at which every kept line is below Nyquist [Hz]."""
        return self._plan.lines.max_speed_for_rate_hz(self.settings.sample_rate_hz)

    # ------------------------------------------------------------------ models
    def _switch_key(self) -> tuple:
        """What a warm model must have been made under to be installed: the settings and the spectrum method."""
        return self.settings, self._plan.spectrum.requested

    def speed_now_hz(self) -> float | None:
        """The stream's speed now [Hz]: the last knot's (None before the first chunk without ``initial_speed_hz``);
        safe to call from another thread than the streaming one."""
        f = self._stream.speed_hz
        return self.initial_speed_hz if f is None else f

    def set_model(self, model: "BkaBem | WarmModel") -> None:
        """Switch to another model (e.g. a new defect depth) from the next knot on (``synth.model = m`` does the
        same). Phase stays continuous; the amplitudes move from the old to the new spectrum over one segment.

        A bare model's plan is made now (its line kernels, its floor), the first knot's spectrum by the next chunk
        (with the modal spectrum its speed cells). Where the next chunk must not wait, pass
        ``self.warm(model)`` made earlier (off the streaming thread: :mod:`bkabem_core.synth.switch`): then this
        only swaps the plan in, and the samples are the same. A warm model that no longer fits (other settings,
        spent) is made afresh."""
        if isinstance(model, WarmModel):
            plan = model.take(self)
            if plan is not None:
                self._plan = plan
                return
            model = model.model
        if not isinstance(model, BkaBem):
            raise SynthError("model", f"must be a BkaBem (got {type(model).__name__})")
        self._plan = Plan(model, self.settings, self._plan.spectrum.requested)

    def warm(self, model: BkaBem, speed_hz: float | None = None, margin_hz: float | None = None) -> WarmModel:
        """The plan of ``model`` under this synthesiser's settings, made now for a later ``set_model`` that costs
        the stream nothing (:mod:`bkabem_core.synth.switch`); callable from any thread while this synthesiser
        streams.

        Parameters
        ----------
        model : BkaBem
            The model to switch to.
        speed_hz : float or None
            Shaft speed [Hz] at which the first knot after the switch is expected (its spectrum is made now and
            the speed cells within ``margin_hz`` of it); None: the stream's current speed.
        margin_hz : float or None
            Speed range [Hz] either side of ``speed_hz`` whose speed cells are made too (modal spectrum); None:
            ``max_speed_step_hz`` (a stream whose next speed is not known yet); 0: the knot's own cell only.
        """
        if not isinstance(model, BkaBem):
            raise SynthError("model", f"must be a BkaBem (got {type(model).__name__})")
        f = self.speed_now_hz() if speed_hz is None else _finite("speed_hz", speed_hz, 0.0)
        margin = self.settings.max_speed_step_hz if margin_hz is None else _finite("margin_hz", margin_hz, 0.0)
        t0 = time.perf_counter()
        key = self._switch_key()
        plan = Plan(model, key[0], key[1])
        if f is None:
            plan.prepare(0.0, -1.0)
        else:
            plan.prepare(max(f - margin, 0.0), f + margin, f)
        return WarmModel(self, plan, key, f, time.perf_counter() - t0)

    def prepare(self) -> None:
        """Make the spectrum method ready now, so that the first chunk carries no set-up: with ``"modal"`` or
        ``"auto"`` (modal when streaming) the speed cells of the lines up to the case's ``operating.max_speed_hz``
        (or the rate's limit if lower). Once per model: synthesisers of one model share them; cells above are made
        when first used."""
        if self.settings.spectrum == "auto":
            self._plan = self._plan.with_method("modal")
        self._plan.prepare(0.0, min(self.case.max_speed_hz, self.max_speed_for_rate_hz()))

    # ------------------------------------------------------------------ streaming
    def reset(self) -> None:
        """Start a new stream at sample 0, cage angle 0."""
        s = self.settings
        self._stream = Stream(SlipWalks(s.slip, s.seed), TrackGate(s.seed))

    @property
    def next_sample_index(self) -> int:
        return self._stream.next_index

    def next_chunk(self, speed_hz: float | None = None, n_samples: int | None = None) -> Chunk:
        """The next chunk of the stream.

        ``speed_hz`` is the shaft speed [Hz] at the *end* of this chunk; within the chunk the speed goes linearly
        from the previous chunk's end speed to it (so angle and its derivative stay continuous). None keeps the
        previous speed. On the very first call, without ``initial_speed_hz``, the chunk is at constant speed.
        """
        stream = self._stream
        if speed_hz is None:
            f = self.speed_now_hz()
            if f is None:
                raise SynthError("speed_hz", "the first chunk needs a speed (or initial_speed_hz)")
        else:
            f = _finite("speed_hz", speed_hz, 0.0)
        n = self.settings.chunk_samples if n_samples is None else int(n_samples)
        if n < 1:
            raise SynthError("n_samples", f"must be >= 1 (got {n_samples!r})")
        self._plan.check_band(f, "speed_hz")
        n0 = stream.next_index
        if not stream.knots:
            if self.settings.spectrum == "auto":
                self._plan = self._plan.with_method("modal")      # streaming: an unknown number of speeds
            f0 = f if self.initial_speed_hz is None else self.initial_speed_hz
            self._plan.check_band(f0, "initial_speed_hz")
            stream.append(n0, f0, self._plan, self.max_knots_per_step)
        stream.append(n0 + n, f, self._plan, self.max_knots_per_step)
        chunk = stream.chunk(self._plan, n0, n, self.compute_features)
        stream.next_index = n0 + n
        return chunk

    # ------------------------------------------------------------------ profiles
    def render(self, profile, seconds: float, progress=None) -> Iterator[Chunk]:
        """Chunks of a whole run under ``profile`` (SpeedProfile or a spec for :func:`parse_profile`).

        Starts a new stream (:meth:`reset`). Knots every ``knot_s`` of run time and at every profile breakpoint,
        independent of the chunk length, so that any chunk length gives the same samples. ``progress``: an
        optional callable receiving the number of samples done after each chunk.
        """
        profile = parse_profile(profile)
        secs = _finite("seconds", seconds, 0.0, strict=True)
        fs = self.settings.sample_rate_hz
        n_total = int(round(secs * fs))
        if n_total < 1:
            raise SynthError("seconds", f"{secs:g} s is less than one sample at {fs:g} Hz")
        self._plan.check_band(profile.max_speed_hz(secs), "sample_rate_hz")
        if self.settings.spectrum == "auto":
            self._plan = self._plan.with_method(choose_method(
                self.model, self._plan.channels.combination, profile, secs, self.knot_s,
                self.settings.max_speed_step_hz))
        return self._render_profile(profile, n_total, progress)

    def _render_profile(self, profile: SpeedProfile, n_total: int, progress) -> Iterator[Chunk]:
        self.reset()
        stream, plan = self._stream, self._plan
        fs = self.settings.sample_rate_hz
        knot_n = max(1, int(round(self.knot_s * fs)))
        breaks = sorted({int(round(t * fs)) for t in profile.times_s if round(t * fs) > 0})   # on samples
        bi = 0
        stream.append(0, float(profile.speed_hz(0.0)), plan, self.max_knots_per_step)
        n0 = 0
        while n0 < n_total:
            n = min(self.settings.chunk_samples, n_total - n0)
            while stream.knots[-1].x < n0 + n:
                last = stream.knots[-1].x
                nxt = (last // knot_n + 1) * knot_n
                while bi < len(breaks) and breaks[bi] <= last:
                    bi += 1
                if bi < len(breaks) and breaks[bi] < nxt:
                    nxt = breaks[bi]
                stream.append(nxt, float(profile.speed_hz(nxt / fs)), plan, self.max_knots_per_step)
            yield stream.chunk(plan, n0, n, self.compute_features)
            n0 += n
            stream.next_index = n0
            if progress is not None:
                progress(n)

    def info(self) -> dict:
        """Settings and method, JSON-ready (goes into output metadata)."""
        s, lines = self.settings, self._plan.lines
        return {"sample_rate_hz": s.sample_rate_hz, "chunk_samples": s.chunk_samples,
                "channel_names": list(self.channel_names), "units": list(self.units),
                "orders": [int(k) for k in lines.orders], "bpfo_per_hz": lines.bpfo_per_hz,
                "n_balls": lines.n_balls, "band_limit": s.band_limit, "spectrum": self.spectrum_method,
                "knot_s": self.knot_s, "max_speed_step_hz": s.max_speed_step_hz,
                "min_speed_hz": s.min_speed_hz, "table_size": self.table_size,
                "slip_std_fraction": s.slip, "noise_density": s.noise, "snr_db": s.snr_db,
                "seed": s.seed, "dtype": np.dtype(s.dtype).name, "case_hash": self.case.case_hash}

