"""Prediction intervals calibrated on whole held-out tests (split-conformal kernels).

A thermal model's error is not the same at every row. Where the displacement
was last known (a test's first row in the "start" reference, or a probe
reading) it is small, and it grows with the time since, as the unmodelled
part of the displacement drifts away. The interval's half-width at a time
``t`` (hours) since the displacement was last known is

    h(t) = q · s(t),    s(t)² = a + b·t,

where ``a`` and ``b`` (≥ 0) are fitted to the squared held-out residuals by
non-negative least squares, and ``q`` is the conformal quantile of the scaled
held-out scores ``|e| / s(t)`` (Vovk, Gammerman and Shafer, 2005; with a
scale, the "normalised" conformity score of Papadopoulos et al., 2011). The
residuals come from leave-one-test-out refits, so the coverage promise rests
on whole tests being exchangeable: a test unlike every training test (a new
speed, a new season) is not covered by it.

Pure array functions (no validation, no estimator), and the record a fit
keeps: :class:`IntervalCalibration`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

__all__ = [
    "IntervalCalibration",
    "conformal_quantile",
    "held_out_predictions",
    "scale_fit",
    "scale_of",
    "variogram_fit",
]

#: The smallest variance floor, as a share of the residuals' mean square:
#: keeps ``s(0)`` > 0 where the residuals at the anchor are all 0.
_FLOOR = 1e-6


def held_out_predictions(A, grams, folds, bounds, choose):
    """Prediction of each held-out test from a model chosen and solved on the others.

    ``A`` is the design (n, p) in the columns of ``grams`` (per-test raw
    :class:`~greyml.dynamic._gram.GramBlocks`). For each fold ``k``,
    ``choose(k, grams_without_k, other_folds)`` returns the coefficients
    (p,) chosen and solved without test ``k`` (the sensor selection redone,
    so the residuals carry its own error, as a refit on the other tests
    would), which predict its rows. Returns {k: ndarray}.
    """
    out = {}
    for k in folds:
        coef = choose(k, grams.without(k), [f for f in folds if f != k])
        start, stop = bounds[k]
        out[k] = A[start:stop] @ coef
    return out


def scale_fit(hours, residuals):
    """``(a, b)`` of ``s(t)² = a + b·t`` fitted to the squared residuals (both ≥ 0)."""
    M = np.column_stack([np.ones_like(hours), hours])
    e2 = residuals**2
    (a, b), _ = nnls(M, e2)
    floor = _FLOOR * float(e2.mean()) if e2.size else 0.0
    return max(float(a), floor, np.finfo(float).tiny), float(b)


def scale_of(hours, a, b):
    """``s(t)`` at ``hours`` since the displacement was last known."""
    return np.sqrt(a + b * np.maximum(hours, 0.0))


def variogram_fit(series, step_s, max_hours=8.0, n_lags=24):
    """``(c, s2, memory_h)`` of ``γ(Δ) = c + s2·(1 − exp(−Δ/memory_h))`` fitted to the
    variogram of the residual ``series`` (one array per test, rows ``step_s`` apart).

    ``c`` is the white part (what a reading cannot remove), ``s2`` the
    variance of a slow part that forgets itself with the memory ``memory_h``
    hours (an Ornstein-Uhlenbeck process). Lags are log-spaced from one row
    to ``max_hours``; for each memory on a log grid, ``c`` and ``s2`` come
    from non-negative least squares, and the best fit is kept.
    """
    longest = max((len(e) for e in series), default=0)
    if longest < 3 or not np.isfinite(step_s) or step_s <= 0:
        return 0.0, 0.0, 1.0
    top = max(2, min(longest - 1, int(max_hours * 3600.0 / step_s)))
    lags = np.unique(np.geomspace(1, top, n_lags).astype(int))
    gamma, used = [], []
    for lag in lags:
        d = [e[lag:] - e[:-lag] for e in series if len(e) > lag]
        if d:
            d = np.concatenate(d)
            gamma.append(0.5 * float(np.mean(d**2)))
            used.append(lag)
    hours = np.asarray(used, dtype=float) * step_s / 3600.0
    gamma = np.asarray(gamma)
    best = (np.inf, 0.0, 0.0, 1.0)
    for memory in np.geomspace(hours[0] / 2, 100.0 * hours[-1], 60):
        M = np.column_stack([np.ones_like(hours), 1.0 - np.exp(-hours / memory)])
        (c, s2), resid = nnls(M, gamma)
        if resid < best[0]:
            best = (resid, float(c), float(s2), float(memory))
    return best[1], best[2], best[3]


def conformal_quantile(scores, coverage):
    """The split-conformal quantile of ``scores`` at ``coverage``.

    The ``⌈(n+1)·coverage⌉``-th smallest score; ``inf`` when that rank
    exceeds ``n`` (too few scores for the coverage asked).
    """
    scores = np.sort(np.asarray(scores, dtype=float))
    n = scores.size
    rank = math.ceil((n + 1) * coverage)
    if rank > n or n == 0:
        return math.inf
    return float(scores[rank - 1])


@dataclass
class IntervalCalibration:
    """How far to trust a fitted model: its interval's calibration on held-out tests.

    What :meth:`greyml.ThermalTransferFunction.fit` keeps as
    ``interval_calibration_`` (three tests or more), what
    :meth:`~greyml.ThermalTransferFunction.predict_interval` and
    :meth:`greyml.Compensator.from_model` read. The error's variance at a time
    ``t`` (hours) since the displacement was last known is
    ``s(t)² = anchor_var + growth_var_per_h·t``; the half-width at coverage
    ``p`` is ``quantile(p)·s(t)``. Variances in the target's unit squared
    (µm² for a displacement in µm).

    Attributes
    ----------
    anchor_var : float
        ``s(0)²``, > 0: the variance where the displacement was last known
        (a test's first row, or a probe reading).
    growth_var_per_h : float
        How fast the variance grows, per hour since then (≥ 0).
    noise_var : float
        The white part of the error (``0 <= noise_var <= anchor_var``): what
        a probe reading cannot remove.
    memory_var : float
        The variance of the error's slow part (≥ 0), which forgets itself
        with ``memory_h``: an Ornstein-Uhlenbeck process fitted to the
        held-out residuals' variogram.
    memory_h : float
        The slow part's memory, in hours (> 0).
    scores : ndarray of shape (n_residuals,)
        The held-out residuals divided by ``s(t)``, sorted: the split-conformal
        scores of the quantile.

    Examples
    --------
    Nine held-out scores: the 90 % quantile is the ⌈10·0.9⌉ = 9th smallest,
    and the width grows with the square root of the variance since the anchor:

    >>> import numpy as np
    >>> from greyml.dynamic import IntervalCalibration
    >>> cal = IntervalCalibration(
    ...     anchor_var=1.0, growth_var_per_h=3.0, noise_var=0.5, memory_var=0.5,
    ...     memory_h=2.0, scores=np.linspace(0.2, 1.8, 9),
    ... )
    >>> cal.quantile(0.9)
    1.8
    >>> float(cal.scale(1.0))  # s(1 h) = sqrt(1 + 3·1)
    2.0
    """

    anchor_var: float
    growth_var_per_h: float
    noise_var: float
    memory_var: float
    memory_h: float
    scores: np.ndarray

    def scale(self, hours):
        """``s(t)`` at ``hours`` since the displacement was last known."""
        return scale_of(hours, self.anchor_var, self.growth_var_per_h)

    def quantile(self, coverage, owner="ThermalTransferFunction"):
        """The conformal quantile of the scores at ``coverage`` (``owner`` names the model
        in the messages)."""
        if not isinstance(coverage, (int, float, np.floating)) or not 0 < coverage < 1:
            raise ValueError(
                f"{owner}.predict_interval: coverage must be a number in (0, 1); got {coverage!r}."
            )
        q = conformal_quantile(self.scores, coverage)
        if not np.isfinite(q):
            n = self.scores.size
            raise ValueError(
                f"{owner}.predict_interval: {n} held-out residuals cannot calibrate a "
                f"{coverage:g} interval (it needs at least {int(np.ceil(1 / (1 - coverage)))})."
            )
        return q
