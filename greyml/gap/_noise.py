"""The noise floor of the gap: what the instrument alone puts into it.

The floor is the level below which a held-out gap is noise (the verdict
compares the remainder with it) and the scale of the tests for located
events. It must hold for the instruments a user meets:

- **white noise**, the textbook case;
- **quantised readings**: a probe or an encoder that reads in steps of q
  (1 µm, 0.255 µm). While the displacement moves slowly the reading sits on
  one step and then flips to the next, so the sample-to-sample differences
  are mostly zero and say nothing of the rounding error, which can reach
  q/2 and has a root mean square of q/√12 over a test in which the
  displacement crosses many steps (Sheppard (1898); Widrow and Kollár (2008));
- **slow sensor noise**: a sensor that averages or filters its reading over
  tens of seconds, read every 15 s, has noise correlated from one row to the
  next, which first differences see only in part.

The floor is therefore built from two parts. The *white* part is a robust
spread of the gap about a local straight line at the resolution of the step
time (by default 2 min, the longest change still called abrupt): the
pseudo-residual ``r[i] − (r[i−h] + r[i+h]) / 2`` with ``h`` the number of rows
in one step time (at least one row), as Gasser, Sroka and Jennen-Steinmetz
(1986) use it with h = 1. A local line removes the thermal gap, which bends
little within a few minutes; a lag of a step time reaches past noise that is
correlated within it. The spread is the root mean square of the 90 % smallest
pseudo-residuals, scaled so that it estimates σ for Gaussian noise: a step,
a spike or a bend of the gap touches a few per cent of them and drops out,
and, unlike the median absolute deviation, the trimmed root mean square does
not collapse to zero when most of the pseudo-residuals of quantised readings
are exactly zero.

The *quantisation* part is what the white part cannot see. Where the
reading changes step within a step time (the displacement moves, or the
noise dithers it over steps), the rounding error varies from row to row and
the white part already holds it. Where the reading stands on one step at
``i − h``, ``i`` and ``i + h``, its rounding error (up to q/2) follows the
slow displacement and the local line takes it up. So, with ``s`` the share
of rows where the reading stands still over a step time either side::

    floor = √(white² + s·q²/12)

with q the step of the readings (given, or detected: :func:`detect_quantum`).
For a probe whose reading stands still, s = 1 and the floor is
√(σ² + q²/12); for readings that dither, s ≈ 0 and it is the white part.
With quantised readings the white part is taken two ways and the smaller
floor kept (:func:`noise_floor`): trimmed by 10 % and scaled as for Gaussian
noise, it overstates the bounded rounding errors of readings that flip from
row to row (20-27 % high on 1-µm steps over 0.1 µm of noise); trimmed by
1 %, it keeps the flips of readings that mostly stand still, whose rounding
s·q²/12 then adds again. On the null cases of
``benchmarks/bench_gap_measured.py`` (VMC probe noise 0.1 µm, steps of 0.25
and 1 µm, rows every 15 s to 5 min) the floor is 7-14 % above the root
mean square of the true measurement error on 1-µm steps (it was 11-25 %),
0-3 % on 0.25-µm steps. Where the displacement stands still on one step for a
whole test, its rounding error is a constant offset anywhere from 0 to q/2,
which no estimate from the readings can know; q/√12 is its average.

Noise slower than the step time is not noise by this definition: it is
signal, which the diagnosis must explain (a drift) or leave unexplained.

Pure array functions: no pandas, no validation.
"""

from __future__ import annotations

from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

__all__ = [
    "STEP_TIME_S",
    "NoiseFloor",
    "detect_quantum",
    "measure_noise",
    "noise_floor",
    "row_correlation",
    "rows_per_step",
    "still_share",
    "variance_inflation",
    "white_noise",
]

#: Default step time (s): a change of the gap completed within it is abrupt.
STEP_TIME_S = 120.0
#: Share of the smallest pseudo-residuals kept in the trimmed root mean square.
_KEEP = 0.9
#: The same for quantised readings, whose pseudo-residuals are lighter-tailed
#: than a Gaussian's (rounding errors are bounded): trimming 10 % and scaling
#: by the Gaussian consistency put the floor 20-25 % above the truth on 1-µm
#: steps over 0.1 µm of noise; trimming 1 % leaves a step's few rows out still.
_KEEP_QUANTISED = 0.99
#: Share of the nonzero differences that must be multiples of a quantum.
_QUANTUM_SHARE = 0.9
#: How far from a whole multiple of the quantum a difference may lie (in quanta).
_QUANTUM_TOLERANCE = 0.1
#: Fewest nonzero differences from which a quantum is detected.
_QUANTUM_MIN_STEPS = 20
#: A detected quantum below this share of the white noise is ignored (q²/12
#: would add less than 0.1 % to the floor's square): a file's printed digits.
_NEGLIGIBLE = 0.1


def _trim_consistency(keep):
    """√E[X² | |X| below its ``keep`` quantile] for a standard normal X."""
    a = NormalDist().inv_cdf(0.5 + keep / 2.0)
    return float(np.sqrt(1.0 - 2.0 * a * NormalDist().pdf(a) / keep))


_CONSISTENCY = _trim_consistency(_KEEP)


@dataclass(frozen=True)
class NoiseFloor:
    """The noise of the gap, as :func:`measure_noise` estimates it.

    Attributes
    ----------
    floor : float
        √(white² + still·quantum²/12): the root mean square of what the
        instrument alone puts into the gap, in the target's unit.
    white : float
        The robust spread of the gap about a local line at the step time's
        resolution.
    quantum : float
        The step of the readings (0.0: continuous readings).
    quantum_source : {"given", "detected", "none"}
        Whether the quantum was stated by the user, found in the readings,
        or neither.
    still : float
        Share of the rows at which the reading stands on one step over a
        step time either side (1.0 when the readings are not given).
    correlation : float
        The noise's correlation from one row to the next
        (:func:`row_correlation`).
    """

    floor: float
    white: float
    quantum: float = 0.0
    quantum_source: str = "none"
    still: float = 0.0
    correlation: float = 0.0

    def describe(self):
        """The floor in words, with the quantum when there is one."""
        text = f"noise floor {self.floor:.3g}"
        if self.quantum > 0:
            how = "detected in" if self.quantum_source == "detected" else "stated for"
            text += (
                f" (white {self.white:.3g}, and readings in steps of {self.quantum:.4g} "
                f"{how} the target, standing still at {self.still:.0%} of the rows)"
            )
        return text


def rows_per_step(dt, step_time_s=STEP_TIME_S):
    """Rows in one step time at the sampling interval ``dt`` (at least one)."""
    return max(1, int(round(step_time_s / dt)))


def _trimmed_rms(e, keep=_KEEP):
    """Root mean square of the ``keep`` share of smallest ``|e|``, consistent for Gaussian σ."""
    if e.size == 0:
        return 0.0
    a = np.sort(np.abs(e))
    kept = a[: max(1, int(np.ceil(keep * a.size)))]
    consistency = _CONSISTENCY if keep == _KEEP else _trim_consistency(keep)
    return float(np.sqrt(np.mean(kept**2)) / consistency)


def _spread(r, bounds, lags, keep=_KEEP):
    """Trimmed spread of the pseudo-residuals at ``lags[j]`` rows in test j (σ for white noise)."""
    parts = []
    for (a, b), h in zip(bounds, lags):
        x = r[a:b]
        h = min(h, (x.size - 1) // 2)
        if h < 1:
            continue
        parts.append(x[h:-h] - 0.5 * (x[: -2 * h] + x[2 * h :]))
    if not parts:
        return 0.0
    # var(r[i] − (r[i−h] + r[i+h]) / 2) = 1.5·σ² for white noise
    return float(_trimmed_rms(np.concatenate(parts), keep) / np.sqrt(1.5))


def _lags(bounds, dt, step_time_s):
    if dt is None:
        return [1] * len(bounds)
    return [rows_per_step(d, step_time_s) for d in dt]


def variance_inflation(correlation, rows):
    """How much the noise's correlation inflates the variance of a fit over many rows.

    (1 + ρ)/(1 − ρ) for noise correlated by ρ from one row to the next, at
    most ``rows`` (the rows in one step time: noise is taken as uncorrelated
    beyond a step time) and at least 1.

    Examples
    --------
    >>> variance_inflation(0.0, 8), variance_inflation(0.5, 8), variance_inflation(0.9, 8)
    (1.0, 3.0, 8.0)
    """
    rho = min(max(float(correlation), 0.0), 1.0)
    cap = float(max(rows, 1))
    if rho >= 1.0:
        return cap
    return float(min(cap, max(1.0, (1.0 + rho) / (1.0 - rho))))


def white_noise(r, bounds, dt=None, *, step_time_s=STEP_TIME_S, quantised=False):
    """Robust spread of ``r`` about a local line, at the step time's resolution.

    Parameters
    ----------
    r : ndarray of shape (n,)
        The gap, tests stacked in ``bounds`` order.
    bounds : sequence of (start, stop)
    dt : sequence of float, optional
        Each test's sampling interval in seconds; None: one row per step time.
    step_time_s : float, default=120
    quantised : bool, default=False
        Trim 1 % of the pseudo-residuals, not 10 %: quantised readings'
        rounding errors are bounded, lighter-tailed than a Gaussian's, and
        the Gaussian consistency of a 10 % trim overstates them (see
        :func:`noise_floor`).

    Returns
    -------
    float
        σ for Gaussian white noise.

    Examples
    --------
    >>> import numpy as np
    >>> r = np.random.default_rng(0).normal(0.0, 0.5, 4000)
    >>> round(white_noise(r, [(0, 2000), (2000, 4000)], [15.0, 15.0]), 2)
    0.5
    """
    keep = _KEEP_QUANTISED if quantised else _KEEP
    return _spread(r, bounds, _lags(bounds, dt, step_time_s), keep)


def row_correlation(r, bounds, dt=None, *, step_time_s=STEP_TIME_S):
    """The noise's correlation from row to row, from its spread at one row and at one step time.

    For noise whose correlation decays by ρ per row (a first-order
    autoregression) and is gone within a step time, the pseudo-residual at
    one row has the variance (1 + ρ²/3 − 4ρ/3)·σ², and at one step time
    σ²; so ρ = 2 − √(1 + 3u) with u the ratio of the two variances. White
    noise gives ρ ≈ 0; a sensor that averages over a minute, read every
    15 s, about 0.8. A bend of the gap within a step time counts as
    correlation too, which only makes the event tests more cautious.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> white = np.random.default_rng(0).normal(0.0, 1.0, 20000)
    >>> round(row_correlation(white, [(0, 20000)], [15.0]), 1)
    0.0
    >>> slow = lfilter([np.sqrt(1 - 0.8**2)], [1.0, -0.8], white)
    >>> round(row_correlation(slow, [(0, 20000)], [15.0]), 1)
    0.8
    """
    wide = _spread(r, bounds, _lags(bounds, dt, step_time_s))
    if not wide > 0:
        return 0.0
    u = min(1.0, (_spread(r, bounds, [1] * len(bounds)) / wide) ** 2)
    return float(2.0 - np.sqrt(1.0 + 3.0 * u))


def detect_quantum(readings, bounds):
    """The step in which the readings move, or 0.0 if they are continuous.

    The readings are quantised in steps of q when nearly all (90 %) of their
    nonzero sample-to-sample differences lie within 0.1·q of a whole
    multiple of q. The candidates are the smallest nonzero difference and the
    1 % quantile of the differences (which skips a stray small one), each
    divided by 1 to 4; the largest candidate that passes is q. Continuous
    readings pass none: their differences, counted in any small unit, have
    fractional parts spread evenly, and only about a fifth lie that close to
    a whole number.

    Parameters
    ----------
    readings : ndarray of shape (n,)
        The measured target, tests stacked in ``bounds`` order.
    bounds : sequence of (start, stop)

    Returns
    -------
    float

    Examples
    --------
    >>> import numpy as np
    >>> x = np.round(np.cumsum(np.random.default_rng(0).normal(0, 0.3, 500)) / 0.25) * 0.25
    >>> detect_quantum(x, [(0, 500)])
    0.25
    >>> detect_quantum(np.cumsum(np.random.default_rng(0).normal(0, 0.3, 500)), [(0, 500)])
    0.0
    """
    diffs = [np.abs(np.diff(readings[a:b])) for a, b in bounds]
    d = np.concatenate(diffs) if diffs else np.zeros(0)
    scale = float(np.max(np.abs(readings))) if readings.size else 0.0
    d = d[d > 1e-9 * max(scale, np.finfo(float).tiny)]
    if d.size < _QUANTUM_MIN_STEPS:
        return 0.0
    seeds = sorted({float(d.min()), float(np.quantile(d, 0.01))}, reverse=True)
    candidates = sorted({s / k for s in seeds for k in (1, 2, 3, 4)}, reverse=True)
    for q in candidates:
        units = d / q
        if np.mean(np.abs(units - np.round(units)) <= _QUANTUM_TOLERANCE) >= _QUANTUM_SHARE:
            return float(_tidy(q, d))
    return 0.0


def _tidy(q, d):
    """The quantum refined as the mean step per quantum over the single steps."""
    single = d[np.round(d / q) == 1]
    return float(np.mean(single)) if single.size else q


def still_share(readings, bounds, dt=None, *, step_time_s=STEP_TIME_S):
    """Share of rows at which the reading is the same one step time before and after.

    Examples
    --------
    >>> import numpy as np
    >>> still_share(np.array([0.0, 0, 0, 0, 1, 1, 1, 1]), [(0, 8)])  # rows 1, 2, 5, 6 of 1-6
    0.6666666666666666
    """
    hits, total = 0, 0
    for j, (a, b) in enumerate(bounds):
        x = readings[a:b]
        h = 1 if dt is None else rows_per_step(dt[j], step_time_s)
        h = min(h, (x.size - 1) // 2)
        if h < 1:
            continue
        mid = x[h:-h]
        hits += int(np.sum((mid == x[: -2 * h]) & (mid == x[2 * h :])))
        total += mid.size
    return hits / total if total else 1.0


def noise_floor(r, bounds, dt=None, *, quantum=0.0, readings=None, step_time_s=STEP_TIME_S):
    """The noise floor of the gap: √(white² + still·quantum²/12).

    Parameters
    ----------
    r : ndarray of shape (n,)
        The gap, tests stacked in ``bounds`` order.
    bounds : sequence of (start, stop)
    dt : sequence of float, optional
        Each test's sampling interval in seconds; None: one row per step time.
    quantum : float, default=0.0
        The step of the readings (0: continuous).
    readings : ndarray of shape (n,), optional
        The readings themselves, for the share of rows at which they stand
        still (:func:`still_share`); without them the whole q²/12 is added.
    step_time_s : float, default=120

    Returns
    -------
    float

    Examples
    --------
    A displacement that rises by 3 µm in 4 hours, read in whole micrometres
    with 0.1 µm of noise: the reading stands still most of the time, and the
    rounding (q/√12 = 0.29 µm), not the noise, is what the floor must hold.
    Sample-to-sample differences see 0.14 µm of it.

    >>> import numpy as np
    >>> t = np.arange(1000) * 15.0
    >>> true = 3.0 * t / t[-1]
    >>> reading = np.round(true + np.random.default_rng(0).normal(0, 0.1, t.size))
    >>> gap = reading - true
    >>> round(float(np.sqrt(np.mean(gap**2))), 2)
    0.3
    >>> round(white_noise(gap, [(0, 1000)], [15.0]), 2)
    0.14
    >>> round(noise_floor(gap, [(0, 1000)], [15.0], quantum=1.0, readings=reading), 2)
    0.3
    """
    white = white_noise(r, bounds, dt, step_time_s=step_time_s)
    if not quantum > 0:
        return float(white)
    still = 1.0 if readings is None else still_share(readings, bounds, dt, step_time_s=step_time_s)
    return _quantised_floor(r, bounds, dt, white, quantum, still, step_time_s)[0]


def _quantised_floor(r, bounds, dt, white, quantum, still, step_time_s):
    """(floor, white) of quantised readings: the smaller of the two ways of counting the rounding.

    √(white² + still·q²/12), with the white part trimmed by 10 % (Gaussian
    consistency) or by 1 %. Each counts the rounding at least once and twice
    in one regime: the 10 % trim, scaled as for a Gaussian, overstates the
    bounded rounding errors of readings that flip from row to row (20-25 %
    high on 1-µm steps over 0.1 µm of noise, rows moving a step in minutes);
    the 1 % trim keeps the flips of readings that mostly stand still, whose
    rounding ``still`` adds again (about 12 % high). The smaller is kept.
    """
    rounding = still * quantum**2 / 12.0
    light = white_noise(r, bounds, dt, step_time_s=step_time_s, quantised=True)
    return min((float(np.sqrt(w**2 + rounding)), float(w)) for w in (float(white), float(light)))


def measure_noise(r, readings, bounds, dt, *, quantum=None, step_time_s=STEP_TIME_S):
    """The :class:`NoiseFloor` of the gap ``r`` of the ``readings``.

    ``quantum``: None detects it in the readings (:func:`detect_quantum`;
    a step under a tenth of the white noise, such as the last digit a file
    prints, is ignored), 0 states that they are continuous, a positive
    number states their step.
    """
    white = white_noise(r, bounds, dt, step_time_s=step_time_s)
    if quantum is None:
        q = detect_quantum(readings, bounds)
        if q < _NEGLIGIBLE * white:  # a file's last printed digit: nothing to add
            q = 0.0
        source = "detected" if q > 0 else "none"
    else:
        q = float(quantum)
        source = "given" if q > 0 else "none"
    still, floor = 0.0, float(white)
    if q > 0:
        still = still_share(readings, bounds, dt, step_time_s=step_time_s)
        floor, white = _quantised_floor(r, bounds, dt, white, q, still, step_time_s)
    rho = row_correlation(r, bounds, dt, step_time_s=step_time_s)
    return NoiseFloor(floor, float(white), q, source, float(still), rho)
