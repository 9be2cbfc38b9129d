"""The fault library carries its lines up to the acquisition's band: an envelope analysis in the usual
high-resonance band (8-11 kHz at 25.6 kHz sampling, below the anti-alias edge fs / 2.56 = 10 kHz and the taper's
0.85 x Nyquist) finds every defect at its strike frequency, with the library's default settings.

The envelope spectrum is the textbook one, written here: band-pass by FFT mask, analytic signal, magnitude, its
amplitude spectrum; the floor is the median of the envelope spectrum below 1 kHz.
"""

from __future__ import annotations

import numpy as np
import pytest

FS, SPEED_HZ, SECONDS = 25600.0, 25.0, 2.0
BAND_HZ = (8000.0, 11000.0)
#: Strike frequency of each kind's defect (a ball defect strikes both races once per spin: 2 x BSF).
STRIKE = {"outer": lambda ff: ff.bpfo, "inner": lambda ff: ff.bpfi, "ball": lambda ff: 2.0 * ff.bsf}


def _envelope_peak_over_floor(x: np.ndarray, fs: float, f_strike: float) -> float:
    n = x.size
    spec = np.fft.fft(x - x.mean())
    f = np.fft.fftfreq(n, 1.0 / fs)
    spec[(np.abs(f) < BAND_HZ[0]) | (np.abs(f) > BAND_HZ[1])] = 0.0
    env = np.abs(np.fft.ifft(np.where(f > 0, 2.0 * spec, 0.0)))
    e = np.abs(np.fft.rfft(env - env.mean())) * 2.0 / n
    fe = np.fft.rfftfreq(n, 1.0 / fs)
    i = int(np.argmin(np.abs(fe - f_strike)))
    return float(e[i - 1:i + 2].max() / np.median(e[(fe > 5.0) & (fe < 1000.0)]))


def test_every_kind_carries_lines_to_the_anti_alias_edge(fault_library):
    edge = FS / 2.56                                        # the usable band of a 25.6 kHz acquisition
    for kind in ("outer", "inner", "ball"):
        top = float(fault_library[kind].lines.multipliers.max()) * SPEED_HZ
        assert top >= edge, (kind, top)


@pytest.mark.parametrize("kind", ["outer", "inner", "ball"])
def test_envelope_in_the_high_resonance_band_finds_the_defect(fault_library, classic_ball, cached_model, kind):
    """The lines carried to the band make the defect's strikes in it: with the faulty bearing as rough as a sound
    one (``roughness_db = 0``) the textbook envelope finds each kind far over its floor. The library's faulty
    bearings roll 15 dB rougher, which buries part of that (the ball's most: a ball fault is the hard one). The
    ball's pit kept on the track (its lines as the model makes them; a wandering pit may stay off the track for a
    whole short run)."""
    from bkabem_core.synth.synthesizer import Synthesizer

    library = classic_ball if kind == "ball" else fault_library[kind]
    sound = cached_model(library.case.with_overrides({"defects.0.roughness_db": 0.0}), like=library)
    ratios = []
    for model in (sound, library):
        s = Synthesizer(model, sample_rate_hz=FS, chunk_s=0.5, quantities=("acceleration",), features=False)
        x = np.concatenate([c.channel("de_vertical_acceleration") for c in s.render(f"constant:{SPEED_HZ}", SECONDS)])
        ratios.append(_envelope_peak_over_floor(x.astype(float), FS,
                                                STRIKE[kind](model.fault_multipliers.at_speed(SPEED_HZ))))
    assert ratios[0] > 15.0, (kind, ratios)     # 85x, 46x, 33x measured; 1.2-2.5x with the lines cut at 50 x BPFO
    assert ratios[1] < ratios[0], (kind, ratios)  # 14x, 7x, 2.8x measured with the library's 15 dB
