"""docs/img/dataset_example.png: what `bkabem dataset dataset_example` gives a data scientist, read back from its files.

    .venv/bin/python bench/plot_dataset.py [--out DIR] [--png docs/img/dataset_example.png]

Renders the embedded example spec (or reuses DIR when it holds it), reads the labels table and each 25 Hz run's DE
vertical acceleration, and plots per class the waveform and its envelope spectrum (band-pass 1 kHz at the strongest
band above 1 kHz, squared Hilbert envelope), with the labelled fault frequency of the run (``d0_strike_frequency_hz``)
and its harmonics marked.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402
from scipy import signal  # noqa: E402

from bkabem_core.dataset.engine import read_labels, render_dataset  # noqa: E402
from bkabem_core.dataset.spec import DatasetSpec  # noqa: E402


def envelope_spectrum(x: np.ndarray, fs: float):
    f, pxx = signal.welch(x, fs, nperseg=4096)
    los = np.arange(1000.0, 0.4 * fs, 500.0)
    lo = los[int(np.argmax([pxx[(f >= a) & (f < a + 1000.0)].sum() for a in los]))]
    sos = signal.butter(4, [lo, lo + 1000.0], btype="bandpass", fs=fs, output="sos")
    env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, x))) ** 2
    env -= env.mean()
    spec = np.abs(np.fft.rfft(env * np.hanning(env.size))) * 2 / np.hanning(env.size).sum()
    return np.fft.rfftfreq(env.size, 1 / fs), spec, lo


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "dataset_example"))
    ap.add_argument("--png", default=str(ROOT / "docs" / "img" / "dataset_example.png"))
    a = ap.parse_args(argv)
    render_dataset(DatasetSpec.load("dataset_example"), a.out, log=lambda line: None)
    rows = [r for r in read_labels(a.out).to_pylist() if r["speed_hz_mean"] == 25.0]
    fig, axes = plt.subplots(len(rows), 2, figsize=(11, 2.3 * len(rows)))
    for (ax1, ax2), row in zip(axes, rows):
        t = pq.read_table(Path(a.out) / row["file"], columns=["de_vertical_acceleration"])
        x = t.column(0).to_numpy().astype(float)
        fs = row["sample_rate_hz"]
        n = int(0.1 * fs)
        ax1.plot(np.arange(n) / fs * 1e3, x[:n], lw=0.6)
        ax1.set_ylabel("m/s^2")
        ax1.set_title(f"{row['run_id']}: {row['fault']}, {row['shaft_hz']:g} Hz, seed {row['seed']}", fontsize=8)
        f, spec, lo = envelope_spectrum(x, fs)
        sel = f <= 600
        ax2.plot(f[sel], spec[sel], lw=0.7, color="C1")
        fc = row.get("d0_strike_frequency_hz")
        if fc:
            for h in (1, 2, 3):
                ax2.axvline(h * fc, color="C3", lw=0.8, alpha=0.5)
            label = f"labelled {row['d0_fault_frequency']} strike {fc:.1f} Hz"
        else:
            label = "healthy: no defect in the labels"
        ax2.set_title(f"envelope spectrum (band {lo / 1e3:g}-{lo / 1e3 + 1:g} kHz); red: {label}", fontsize=8)
    axes[-1][0].set_xlabel("time [ms]")
    axes[-1][1].set_xlabel("frequency [Hz]")
    fig.tight_layout()
    fig.savefig(a.png, dpi=100)
    print(f"wrote {a.png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
