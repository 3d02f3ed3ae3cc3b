"""Data consistency before any effect is searched: sensors whose relation to the others changes.

Two sensors swapped in one test, a sensor moved or a column mislabelled do
not change the gap, but they change every effect built from the sensors
(``initial_state`` reads the start offset of a sensor, ``sensor_lag`` its
rise), and such an effect can then be named for the wrong reason. Before the
search, each sensor is predicted from the others, leave one test out: least
squares with an intercept common to all tests (the levels must relate too),
fitted on the other tests and scored on the test held out. A sensor whose
held-out error in one test is many times its error in the other tests no
longer relates to the others there as it does elsewhere. Sensors that lean
on a changed one break with it, so a test's flags are found by explaining
the excess away: first a swapped pair (swapping two sensors back makes the
test consistent), else one sensor at a time, the one whose removal leaves
the least excess in the others.

Pure array functions: no pandas, no validation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SensorFlag", "inconsistent_sensors"]


def _centred(x, bounds):
    """Each test's columns minus their mean in that test."""
    out = np.empty_like(x)
    for a, b in bounds:
        out[a:b] = x[a:b] - x[a:b].mean(axis=0)
    return out


#: A sensor is flagged in a test when its held-out error there is this many
#: times its median held-out error in the other tests.
RATIO = 5.0
#: An error below this fraction of the sensor's within-test standard
#: deviation counts as this fraction (exact data have errors of 0).
_FLOOR = 1e-3


@dataclass(frozen=True)
class SensorFlag:
    """A sensor whose relation to the other sensors changes in one test."""

    test: int  # index of the test
    sensor: int  # index of the sensor
    ratio: float  # its held-out error there over its median in the other tests
    partner: int | None = None  # the sensor it reads as swapped with, when swapping back fits


def _ratios(grams, j_set, floor):
    """Held-out error ratios (T, p) of the sensors in ``j_set``, each from the others in it.

    ``grams`` (T, p+1, p+1) holds each test's cross products of [1, x]. Each
    sensor j is fitted on the other sensors of ``j_set`` and an intercept
    common to all tests, on every test but t (sums of the other tests'
    cross products), and scored on test t; entry [t, j] is that error over
    its median in the other tests (NaN for sensors not in ``j_set``).
    """
    T, q, _ = grams.shape
    total = grams.sum(axis=0)
    n = grams[:, 0, 0]
    err = np.full((T, q - 1), np.nan)
    for j in j_set:
        rows = [0] + [k + 1 for k in j_set if k != j]
        for t in range(T):
            G = total - grams[t]
            A = G[np.ix_(rows, rows)]
            ridge = 1e-10 * np.trace(A) / len(rows)
            beta = np.linalg.solve(A + ridge * np.eye(len(rows)), G[rows, j + 1])
            own = grams[t]
            sse = (
                own[j + 1, j + 1]
                - 2 * beta @ own[rows, j + 1]
                + beta @ own[np.ix_(rows, rows)] @ beta
            )
            err[t, j] = max(np.sqrt(max(sse, 0.0) / n[t]), floor[j])
    out = np.full_like(err, np.nan)
    for t in range(T):
        out[t] = err[t] / np.median(np.delete(err, t, axis=0), axis=0)
    return out


def inconsistent_sensors(sensors, bounds, *, ratio=RATIO):
    """Sensors whose relation to the other sensors changes in one test.

    Each sensor is predicted from the others (least squares with an
    intercept common to all tests, so that the sensors' levels must relate
    too: a swapped pair often differs most in level), fitted on all tests
    but one and scored on that one. In a test where a sensor's error is more
    than ``ratio`` times its median error in the other tests, something
    changed. The sensors that merely lean on a changed one break with it, so
    the flags are found one at a time: the sensor whose removal (as a
    target and a predictor) leaves the least excess in the others is
    flagged and removed, until no sensor of the test exceeds ``ratio``.

    Parameters
    ----------
    sensors : ndarray of shape (n, p)
        Temperature sensors, tests stacked in ``bounds`` order.
    bounds : sequence of (start, stop)
    ratio : float, default=5
        How many times its median held-out error in the other tests a
        sensor's error in a test must be to flag it.

    Returns
    -------
    list of SensorFlag
        Empty with fewer than 3 sensors or 3 tests (with two sensors, which
        of the two changed cannot be told).

    Examples
    --------
    Four sensors driven by two heat inputs, in four tests; two sensors are
    swapped in the third:

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> w = np.array([[1.0, 0.2], [0.5, 1.0], [0.1, 0.8], [0.7, 0.7]])
    >>> tests = []
    >>> for k in range(4):
    ...     drive = np.cumsum(rng.standard_normal((60, 2)), axis=0)
    ...     tests.append(20 + drive @ w.T + 0.05 * rng.standard_normal((60, 4)))
    >>> tests[2][:, [1, 2]] = tests[2][:, [2, 1]]
    >>> bounds = [(0, 60), (60, 120), (120, 180), (180, 240)]
    >>> [(f.test, f.sensor, f.partner) for f in inconsistent_sensors(np.concatenate(tests), bounds)]
    [(2, 1, 2), (2, 2, 1)]
    """
    x = np.asarray(sensors, dtype=float)
    T, p = len(bounds), x.shape[1]
    if p < 3 or T < 3:
        return []
    spread = np.sqrt(np.mean(_centred(x, bounds) ** 2, axis=0))
    floor = _FLOOR * np.where(spread > 0, spread, 1.0)
    z = np.column_stack([np.ones(len(x)), x])
    grams = np.stack([z[a:b].T @ z[a:b] for a, b in bounds])
    active = [j for j in range(p) if spread[j] > 0]
    first = _ratios(grams, active, floor)
    flags = []
    for t in range(T):
        ratios = first[t]
        if not np.nanmax(ratios[active]) > ratio:
            continue
        swap = _swapped(x, bounds, grams, t, active, floor, ratio, ratios)
        if swap is not None:
            flags.extend(swap)
            continue
        left = list(active)
        while len(left) > 2 and np.nanmax(ratios[left]) > ratio:
            best = None
            for j in [k for k in left if ratios[k] > ratio]:
                rest = [k for k in left if k != j]
                after = _ratios(grams, rest, floor)[t]
                excess = float(np.sum(np.log(np.maximum(after[rest] / ratio, 1.0))))
                if best is None or excess < best[0]:
                    best = (excess, j, after)
            _, j, after = best
            flags.append(SensorFlag(t, j, float(ratios[j])))
            left.remove(j)
            ratios = after
    return flags


def _swapped(x, bounds, grams, t, active, floor, ratio, ratios):
    """The pair whose swap back makes test ``t`` consistent, as two flags (or None).

    Every pair of the sensors that exceed ``ratio`` in the test is swapped
    back in turn; the pair after whose swap no sensor of the test exceeds
    ``ratio`` (the one that leaves the least, if several) was swapped.
    """
    high = [k for k in active if ratios[k] > ratio]
    a, b = bounds[t]
    best = None
    for i, j in enumerate(high):
        for k in high[i + 1 :]:
            z = np.column_stack([np.ones(b - a), x[a:b]])
            z[:, [j + 1, k + 1]] = z[:, [k + 1, j + 1]]
            trial = grams.copy()
            trial[t] = z.T @ z
            worst = float(np.nanmax(_ratios(trial, active, floor)[t][active]))
            if worst <= ratio and (best is None or worst < best[0]):
                best = (worst, j, k)
    if best is None:
        return None
    _, j, k = best
    return [SensorFlag(t, j, float(ratios[j]), k), SensorFlag(t, k, float(ratios[k]), j)]
