"""Prediction intervals calibrated on whole held-out tests (split-conformal kernels).

A thermal model's error is not the same at every row. Where the displacement
was last known (a test's first row in the "start" reference, or a probe
reading) it is small, and it grows with the time since, as the unmodelled
part of the displacement drifts away. The interval's half-width at a time
``t`` (hours) since the displacement was last known is

    h(t) = q · s(t),    s(t)² = a + b·t,

where ``a`` and ``b`` (≥ 0) are fitted to the squared held-out residuals by
non-negative least squares, every training test weighing the same (a long
test does not outvote a short one), and ``q`` comes from the scaled held-out
scores ``|e| / s(t)`` (the "normalised" conformity score of Papadopoulos et
al., 2011). The residuals come from leave-one-test-out refits on the other
training tests, every test's at once.

The rows of one test are not exchangeable with each other (its error is one
slow curve), but whole tests are: the promise is made by test. With ``n``
held-out tests, each test's empirical distribution of scores weighing
``1/n``, the pooled distribution's quantile at ``p·(n + 1)/n`` covers, in
expectation over a new test exchangeable with them, at least a share ``p``
of its rows (the split-conformal argument of Vovk, Gammerman and Shafer,
2005, applied to tests rather than rows; Dunn, Wasserman and Ramdas, 2023,
pool groups' distributions the same way). That level is at most 1 only from ``n ≥ p/(1 − p)`` tests
(9 for 90 %). With fewer, there is no distribution-free promise, and the
quantile is the parametric one: the scores Gaussian with the tests' mean
square, ``q = z_{(1+p)/2}·√(mean over tests of mean(score²))``. Either way a
test unlike every training test (a new speed, a new season) is not covered;
inputs outside what training saw widen the interval separately
(:mod:`greyml.dynamic._envelope`).

Pure array functions (no validation, no estimator), and the record a fit
keeps: :class:`IntervalCalibration`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls
from scipy.special import ndtri

__all__ = [
    "IntervalCalibration",
    "MAX_KEPT_SCORES",
    "compress_scores",
    "conformal_quantile",
    "held_out_predictions",
    "scale_fit",
    "scale_of",
    "quantile_by_test",
    "weights_by_test",
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


def weights_by_test(sizes):
    """Each row's weight when every one of the tests (of ``sizes`` rows) weighs the same:
    ``1 / (n_tests · size)``, summing to 1."""
    sizes = np.asarray(sizes, dtype=int)
    return np.repeat(1.0 / (sizes.size * sizes.astype(float)), sizes)


def scale_fit(hours, residuals, weights=None):
    """``(a, b)`` of ``s(t)² = a + b·t`` fitted to the squared residuals (both ≥ 0),
    each row weighing ``weights`` (equal by default).

    ``hours``, ``residuals`` and ``weights`` may also be sequences of arrays (one
    per test; a test's weights may be one number): the fit is then the same,
    from the sums of each, without joining them (a year of rows costs no copy).
    Non-negative least squares on two unknowns: the unconstrained solution of
    the normal equations if it is non-negative, else the better of the two
    with one unknown at 0.
    """
    parts = (
        list(zip(hours, residuals, weights if weights is not None else [None] * len(hours)))
        if isinstance(hours, (list, tuple))
        else [(hours, residuals, weights)]
    )
    S0 = S1 = S2 = T0 = T1 = total = 0.0
    n = 0
    for h, r, w in parts:
        e2 = np.asarray(r, dtype=float) ** 2
        h = np.asarray(h, dtype=float)
        w = np.ones_like(e2) if w is None else np.asarray(w, dtype=float)
        w = np.broadcast_to(w, e2.shape)  # a number: every row of the test weighs it
        we2 = w * e2
        S0 += float(w.sum())
        S1 += float(w @ h)
        S2 += float(w @ (h * h))
        T0 += float(we2.sum())
        T1 += float(we2 @ h)
        total += float(e2.sum())
        n += e2.size

    def loss(a, b):  # the weighted squared error, less its constant
        return a * a * S0 + 2.0 * a * b * S1 + b * b * S2 - 2.0 * (a * T0 + b * T1)

    candidates = [(0.0, 0.0)]
    if S0 > 0:
        candidates.append((T0 / S0, 0.0))
    if S2 > 0:
        candidates.append((0.0, max(T1 / S2, 0.0)))
    det = S0 * S2 - S1 * S1
    if det > 1e-12 * max(S0 * S2, np.finfo(float).tiny):
        a, b = (S2 * T0 - S1 * T1) / det, (S0 * T1 - S1 * T0) / det
        if a >= 0 and b >= 0:
            candidates = [(a, b)]
    a, b = min(candidates, key=lambda ab: loss(*ab))
    floor = _FLOOR * total / n if n else 0.0
    return max(float(a), floor, np.finfo(float).tiny), float(b)


def scale_of(hours, a, b):
    """``s(t)`` at ``hours`` since the displacement was last known."""
    return np.sqrt(a + b * np.maximum(hours, 0.0))


def variogram_fit(series, step_s, max_hours=8.0, n_lags=24, min_hours=0.0):
    """``(c, s2, memory_h)`` of ``γ(Δ) = c + s2·(1 − exp(−Δ/memory_h))`` fitted to the
    variogram of the residual ``series`` (one array per test, rows ``step_s`` apart).

    ``c`` is the white part (what a reading cannot remove), ``s2`` the
    variance of a slow part that forgets itself with the memory ``memory_h``
    hours (an Ornstein-Uhlenbeck process). Lags are log-spaced from
    ``min_hours`` (at least one row) to ``max_hours``: what decorrelates
    faster than the shortest lag counts as white; for each memory on a log
    grid, ``c`` and ``s2`` come from non-negative least squares, and the best
    fit is kept.
    """
    longest = max((len(e) for e in series), default=0)
    if longest < 3 or not np.isfinite(step_s) or step_s <= 0:
        return 0.0, 0.0, 1.0
    top = max(2, min(longest - 1, int(max_hours * 3600.0 / step_s)))
    low = min(top, max(1, int(round(min_hours * 3600.0 / step_s))))
    lags = np.unique(np.geomspace(low, top, n_lags).astype(int))
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


def quantile_by_test(scores, weights, n_tests, coverage):
    """The quantile of the scaled scores at ``coverage``, the promise made by test.

    ``scores`` (any order) come from ``n_tests`` held-out tests, ``weights``
    their row weights (:func:`weights_by_test`: each test weighs ``1/n``). From
    ``n ≥ coverage/(1 − coverage)`` tests: the weighted quantile at level
    ``coverage·(n + 1)/n`` (split-conformal by test). With fewer: the
    Gaussian quantile times the weighted root mean square of the scores.
    Returns ``(q, method)``, method ``"conformal"`` or ``"gaussian"``.
    """
    scores = np.asarray(scores, dtype=float)
    weights = np.asarray(weights, dtype=float)
    level = coverage * (n_tests + 1) / n_tests if n_tests > 0 else math.inf
    if level <= 1.0 + 1e-12:
        order = np.argsort(scores, kind="stable")
        cum = np.cumsum(weights[order])
        i = int(np.searchsorted(cum, min(level, 1.0) * cum[-1] - 1e-12 * cum[-1]))
        return float(scores[order][min(i, scores.size - 1)]), "conformal"
    rms = math.sqrt(float(weights @ scores**2) / float(weights.sum()))
    return float(ndtri(0.5 + coverage / 2.0)) * rms, "gaussian"


#: The most scaled scores a calibration keeps: beyond, the weighted distribution of
#: the scores is kept at this many levels (:func:`compress_scores`), so that a model
#: fitted on a year of rows is as small as one fitted on a week.
MAX_KEPT_SCORES = 100_000


def compress_scores(scores, weights, k=MAX_KEPT_SCORES):
    """``(scores, weights)`` (``scores`` sorted) kept at ``k`` levels of their weight.

    Each of the ``k`` representatives is the exact weighted quantile at level
    ``j/k`` (j = 1 … k), weighing ``1/k`` of the total: any quantile of the
    kept scores is at least the exact one and at most the exact one ``1/k``
    higher in level, so an interval built on them covers at least what the
    exact scores promise. Unchanged when there are no more than ``k``.
    """
    if scores.size <= k:
        return scores, weights
    cum = np.cumsum(weights)
    levels = np.arange(1, k + 1) / k * cum[-1]
    at = np.minimum(np.searchsorted(cum, levels - 1e-12 * cum[-1]), scores.size - 1)
    return scores[at], np.full(k, cum[-1] / k)


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
        The held-out residuals divided by ``s(t)``, sorted: the conformity
        scores of the quantile.
    score_weights : ndarray of shape (n_residuals,) or None
        Each score's weight, in the order of ``scores``: ``1/(n·size)`` for a
        score of a test of ``size`` rows among ``n`` tests (every test weighs
        the same). None (a calibration saved before the weights): the rows
        are exchangeable, the plain split-conformal rank.
    n_tests : int
        How many held-out tests the scores come from (0 with no weights).
    filter_scale : float
        What the probe filter's variances are multiplied by (> 0): the mean
        square of the filter's standardised innovations on the training
        tests' held-out residuals, read every 15 min, 1 h and 4 h, before
        this scale (so that after it their mean square is 1).
    bias_var_per_h : float
        The variance per hour of the error's persistent bias, a random walk
        (≥ 0; µm²/h).
    rate_var_per_h3 : float
        The variance per hour of the bias's rate, a random walk (≥ 0;
        µm²/h³): the filter follows a drifting machine with it.
    glr_scale : float
        What the change detector's threshold is multiplied by (≥ 1): how much
        more sums of the filter's innovations on the training tests varied
        than independent innovations would
        (:func:`~greyml.dynamic._observer.innovation_memory`).

    Examples
    --------
    Nine held-out scores of one test each: the 90 % quantile of nine tests is
    the conformal one, the pooled scores' quantile at 0.9·10/9 = 1 (the
    largest); the width grows with the square root of the variance since the
    anchor:

    >>> import numpy as np
    >>> from greyml.dynamic import IntervalCalibration
    >>> cal = IntervalCalibration(
    ...     anchor_var=1.0, growth_var_per_h=3.0, noise_var=0.5, memory_var=0.5,
    ...     memory_h=2.0, scores=np.linspace(0.2, 1.8, 9),
    ...     score_weights=np.full(9, 1 / 9), n_tests=9,
    ... )
    >>> cal.quantile(0.9)
    1.8
    >>> cal.promise(0.9)
    'conformal'
    >>> float(cal.scale(1.0))  # s(1 h) = sqrt(1 + 3·1)
    2.0

    With four tests there is no distribution-free 90 % promise: the quantile
    is 1.645 times the scores' root mean square.

    >>> cal4 = IntervalCalibration(
    ...     anchor_var=1.0, growth_var_per_h=0.0, noise_var=0.5, memory_var=0.5,
    ...     memory_h=2.0, scores=np.ones(4), score_weights=np.full(4, 0.25), n_tests=4,
    ... )
    >>> round(cal4.quantile(0.9), 4), cal4.promise(0.9)
    (1.6449, 'gaussian')
    """

    anchor_var: float
    growth_var_per_h: float
    noise_var: float
    memory_var: float
    memory_h: float
    scores: np.ndarray
    score_weights: np.ndarray | None = None
    n_tests: int = 0
    filter_scale: float = 1.0
    bias_var_per_h: float = 0.0
    rate_var_per_h3: float = 0.0
    glr_scale: float = 1.0

    def scale(self, hours):
        """``s(t)`` at ``hours`` since the displacement was last known."""
        return scale_of(hours, self.anchor_var, self.growth_var_per_h)

    def _checked(self, coverage, owner):
        if not isinstance(coverage, (int, float, np.floating)) or not 0 < coverage < 1:
            raise ValueError(
                f"{owner}.predict_interval: coverage must be a number in (0, 1); got {coverage!r}."
            )

    def promise(self, coverage):
        """What the ``coverage`` interval rests on: ``"conformal"`` (a distribution-free
        promise by test: enough tests), ``"gaussian"`` (the parametric model: too few
        tests for one) or ``"rows"`` (a calibration saved before tests were weighed)."""
        self._checked(coverage, "IntervalCalibration")
        if self.score_weights is None:
            return "rows"
        return quantile_by_test(self.scores, self.score_weights, self.n_tests, coverage)[1]

    def quantile(self, coverage, owner="ThermalTransferFunction"):
        """The quantile of the scores at ``coverage`` (``owner`` names the model in the
        messages): by test (:func:`quantile_by_test`), or, for a calibration saved
        without weights, the rows' split-conformal rank."""
        self._checked(coverage, owner)
        if self.score_weights is not None:
            return quantile_by_test(self.scores, self.score_weights, self.n_tests, coverage)[0]
        q = conformal_quantile(self.scores, coverage)
        if not np.isfinite(q):
            n = self.scores.size
            raise ValueError(
                f"{owner}.predict_interval: {n} held-out residuals cannot calibrate a "
                f"{coverage:g} interval (it needs at least {int(np.ceil(1 / (1 - coverage)))})."
            )
        return q
