"""Textbook features of a vibration signal and two transparent classifiers written in numpy.

Features (:func:`features`; every level in dB over the SES floor of its band, at the signal's own bearing's fault
frequencies and shaft speed, so that machines with other bearings and speeds share one feature space):

* the fundamentals of BPFO, BPFI and 2 x BSF, FTF and 1x in the SES of the fixed 2-4 kHz band and of the band the
  kurtogram picks (10 features);
* the power mean of the first three harmonics of BPFO, BPFI and 2 x BSF in the fixed band (3);
* log10 kurtosis, crest factor, log10 RMS [g], the kurtosis of the kurtogram's band (log10 of 1 + K) (4);
* the energy of each broad band up to 5 kHz relative to their sum [dB] (6).

Models, fitted on standardized features (the training set's mean and standard deviation):

* **multinomial logistic regression** with an L2 penalty and class-balanced weights (each class weighs as much as
  the others whatever its run count), fitted by L-BFGS on the exact gradient (scipy.optimize): linear, its
  weights say which feature votes for which class;
* **nearest centroid**: the class whose mean feature vector is nearest (Euclidean).

Why not scikit-learn: both models are a few lines of numpy, and a bench-only dependency would buy nothing these
lines do not show.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from realdata.diagnostics import BROAD_BANDS

CLASSES = ("healthy", "inner", "ball", "outer")
_LINES = ("BPFO", "BPFI", "2BSF", "FTF", "1x")
_FAMILIES = ("BPFO", "BPFI", "2BSF")
_SHAPE = [i for i, (lo, hi) in enumerate(BROAD_BANDS) if hi <= 5000.0]
FEATURE_NAMES = tuple(
    [f"{n} fixed" for n in _LINES] + [f"{n} kurtogram" for n in _LINES] + [f"{n} h1-3 fixed" for n in _FAMILIES]
    + ["log kurtosis", "crest", "log RMS", "log(1 + band K)"]
    + [f"{BROAD_BANDS[i][0] / 1e3:g}-{BROAD_BANDS[i][1] / 1e3:g} kHz share" for i in _SHAPE])

#: Feature sets compared: every textbook feature, and the issue's own set (the envelope line levels, kurtosis and
#: crest factor: no absolute level, no spectral shape, which carry the machine's structure rather than the fault).
FEATURE_SETS = {
    "all features": tuple(range(len(FEATURE_NAMES))),
    "envelope, kurtosis, crest": tuple(i for i, n in enumerate(FEATURE_NAMES)
                                       if n.endswith(("fixed", "kurtogram")) or n in ("log kurtosis", "crest")),
}


#: The features by what they read, for the ablation of ``bench/sim2real.py`` (each left out in turn): a family whose
#: absence raises the score on the measured records is one the twin teaches differently from the rig.
FEATURE_FAMILIES = {
    "FTF lines": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.startswith("FTF ")),
    "1x lines": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.startswith("1x ")),
    # both read the shaft's modulation of the envelope: on the rig's race records the line in the FTF window is the
    # shaft sideband |BPFO - 4x| = |BPFI - 5x| (docs/rigs.md)
    "FTF and 1x lines": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.startswith(("FTF ", "1x "))),
    "BPFO lines": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.startswith("BPFO ")),
    "BPFI lines": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.startswith("BPFI ")),
    "2BSF lines": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.startswith("2BSF ")),
    "kurtosis, crest, band K": tuple(FEATURE_NAMES.index(n) for n in ("log kurtosis", "crest", "log(1 + band K)")),
    "RMS": (FEATURE_NAMES.index("log RMS"),),
    "band shares": tuple(i for i, n in enumerate(FEATURE_NAMES) if n.endswith(" share")),
}


def features(d: dict) -> np.ndarray:
    """The feature vector (:data:`FEATURE_NAMES`) of a :func:`realdata.diagnostics.diagnose` result."""
    fx, ku = d["ses"]["fixed"]["levels"], d["ses"]["kurtogram"]["levels"]
    v = [fx[n] for n in _LINES] + [ku[n] for n in _LINES]
    for n in _FAMILIES:
        p = [10 ** (fx[k] / 10) for k in (n, f"{n}_h2", f"{n}_h3")]
        v.append(10 * np.log10(np.mean(p)))
    v += [np.log10(d["kurtosis"]), d["crest"], np.log10(d["rms"]), np.log10(1 + max(d["kurtogram"]["kurtosis"], 0))]
    e = np.array([d["bands_db"][i] for i in _SHAPE])
    v += list(e - 10 * np.log10(np.sum(10 ** (e / 10))))
    return np.array(v, dtype=float)


class Standardizer:
    """z = (x - mean) / std with the training set's statistics (a constant feature gets std 1)."""

    def __init__(self, X: np.ndarray):
        self.mean = X.mean(axis=0)
        s = X.std(axis=0)
        self.std = np.where(s > 1e-12, s, 1.0)

    def __call__(self, X: np.ndarray) -> np.ndarray:
        return (X - self.mean) / self.std


def _balanced_weights(y: np.ndarray, k: int) -> np.ndarray:
    counts = np.bincount(y, minlength=k).astype(float)
    w = np.where(counts > 0, len(y) / (k * np.maximum(counts, 1)), 0.0)
    return w[y]


class LogisticRegression:
    """Multinomial logistic regression with an L2 penalty ``l2`` on the weights (not the intercepts).

    Minimises sum_i w_i (-log p(y_i | x_i)) / sum_i w_i + l2 / 2 ||W||^2 with class-balanced w_i.
    """

    def __init__(self, l2: float = 0.01):
        self.l2 = float(l2)

    def fit(self, X: np.ndarray, y: np.ndarray, n_classes: int = len(CLASSES)) -> "LogisticRegression":
        self.scale = Standardizer(X)
        Z = self.scale(X)
        n, p = Z.shape
        k = n_classes
        w = _balanced_weights(y, k)
        w = w / w.sum()
        Y = np.eye(k)[y]

        def loss(theta):
            W = theta[: p * k].reshape(p, k)
            b = theta[p * k:]
            A = Z @ W + b
            A -= A.max(axis=1, keepdims=True)
            logp = A - np.log(np.exp(A).sum(axis=1, keepdims=True))
            f = -np.sum(w * np.sum(Y * logp, axis=1)) + 0.5 * self.l2 * np.sum(W ** 2)
            G = (np.exp(logp) - Y) * w[:, None]
            return f, np.concatenate([(Z.T @ G + self.l2 * W).ravel(), G.sum(axis=0)])

        res = minimize(loss, np.zeros(p * k + k), jac=True, method="L-BFGS-B", options={"maxiter": 2000})
        self.W = res.x[: p * k].reshape(p, k)
        self.b = res.x[p * k:]
        self.converged = bool(res.success)
        return self

    def proba(self, X: np.ndarray) -> np.ndarray:
        A = self.scale(X) @ self.W + self.b
        A -= A.max(axis=1, keepdims=True)
        E = np.exp(A)
        return E / E.sum(axis=1, keepdims=True)

    def predict(self, X: np.ndarray) -> np.ndarray:
        return np.argmax(self.proba(X), axis=1)


class NearestCentroid:
    """The class of the nearest class mean, in standardized features."""

    def fit(self, X: np.ndarray, y: np.ndarray, n_classes: int = len(CLASSES)) -> "NearestCentroid":
        self.scale = Standardizer(X)
        Z = self.scale(X)
        self.centroids = np.array([Z[y == c].mean(axis=0) if np.any(y == c) else np.full(Z.shape[1], np.inf)
                                   for c in range(n_classes)])
        return self

    def predict(self, X: np.ndarray) -> np.ndarray:
        Z = self.scale(X)
        d = ((Z[:, None, :] - self.centroids[None, :, :]) ** 2).sum(axis=2)
        return np.argmin(d, axis=1)


def confusion(y_true: np.ndarray, y_pred: np.ndarray, n_classes: int = len(CLASSES)) -> np.ndarray:
    """Counts, rows = truth, columns = prediction."""
    m = np.zeros((n_classes, n_classes), dtype=int)
    for t, p in zip(y_true, y_pred):
        m[t, p] += 1
    return m


def per_class_accuracy(m: np.ndarray) -> list:
    """Recall of each class (None where the class has no sample)."""
    return [float(m[i, i] / m[i].sum()) if m[i].sum() else None for i in range(m.shape[0])]


def grouped_folds(groups: list, k: int, seed: int = 0) -> list[np.ndarray]:
    """``k`` folds of sample indices, whole groups at a time (no group in two folds)."""
    uniq = sorted(set(groups), key=str)
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(uniq))
    fold_of = {uniq[j]: i % k for i, j in enumerate(order)}
    g = np.array([fold_of[x] for x in groups])
    return [np.flatnonzero(g == i) for i in range(k)]
