r"""Where the sim-to-real gap lies, as plain functions.

The gap is ``r = measured - simulated`` for one target (e.g. the tool-point
displacement in µm), one value per row of greyml's ``(test, time_s)`` layout
(see :mod:`greyml._sequences`). Two questions are answered here:

- :func:`gap_breakdown`: how large the gap is, and how its energy
  :math:`\sum r^2` divides up, by test, by phase (heating or cooling), by time
  since the start of the test and by frequency band;
- :func:`residual_diagnostics`: the residual checks of system identification,
  i.e. whether the gap is white and which input it still correlates with, at
  which lag.

Implementation notes
--------------------
Every computation runs test by test: the band decomposition takes one real FFT
per test, and the auto- and cross-correlations add up products of samples of
the same test only, so nothing is ever paired across a test boundary. The
correlation sums come from zero-padded FFTs, :math:`O(n \log n)` per test for
all lags and all signals at once.

Both functions need a constant sampling interval within each test (it may
differ between tests): frequency bins and lags in samples are only converted
to periods and lags in seconds that way. They check it, to a relative
tolerance of ``_STEP_RTOL``, and say where it fails.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import fft as sp_fft
from scipy.stats import chi2

from greyml._sequences import TEST_LEVEL, TIME_LEVEL, Segment, segment_label
from greyml._sequences import test_segments as _test_segments  # not collected by pytest
from greyml._validation import check_unique_columns
from greyml.io._csv import describe_input

__all__ = ["gap_breakdown", "residual_diagnostics"]

BREAKDOWN_COLUMNS = (
    "by",
    "segment",
    "n",
    "rms",
    "peak",
    "peak_test",
    "peak_time_s",
    "bias",
    "share",
)
XCORR_COLUMNS = ("signal", "peak_corr", "peak_lag_s", "corr_at_zero", "note")

_HOUR = 3600.0
_MINUTE = 60.0
#: Band edges (periods, in seconds) of :func:`gap_breakdown` by default.
DEFAULT_BAND_EDGES_S = (4 * _HOUR, _HOUR, 15 * _MINUTE)
#: A driver counts as "on" where ``|value| > _ON_RTOL * max|value|`` of that driver.
_ON_RTOL = 1e-9
#: Largest relative deviation of a time step of a test from its first step.
_STEP_RTOL = 1e-3
#: Periods within this relative distance of a band edge belong to the shorter band.
_EDGE_RTOL = 1e-9
_WHITENESS_MAX_LAGS = 20
_WHITENESS_ALPHA = 0.05


# --------------------------------------------------------------------------
# input checking
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class _Layout:
    """Where the rows of the gap sit: tests, times and sampling intervals."""

    segments: list[Segment]
    time: np.ndarray  # time_s of every row
    labels: np.ndarray  # test label of every row (None for a single unlabelled test)
    dt: np.ndarray  # sampling interval of every segment, NaN for a one-row test


def _real_values(series: pd.Series, what: str) -> np.ndarray:
    dtype = series.dtype
    numeric = pd.api.types.is_numeric_dtype(dtype) or pd.api.types.is_bool_dtype(dtype)
    if not numeric or pd.api.types.is_complex_dtype(dtype):
        raise ValueError(f"{what} must hold real numbers; it has non-numeric dtype {dtype}.")
    return series.to_numpy(dtype=np.float64, na_value=np.nan)


def _check_finite(values: np.ndarray, layout: _Layout, what: str) -> None:
    bad = np.flatnonzero(~np.isfinite(values))
    if not bad.size:
        return
    row = int(bad[0])
    seg = next(s for s in layout.segments if s.start <= row < s.stop)
    kind = "NaN" if np.isnan(values[row]) else "inf"
    more = "" if bad.size == 1 else f" (and {bad.size - 1} more non-finite values)"
    raise ValueError(
        f"{what} has {kind} in {segment_label(seg)} at {TIME_LEVEL}={layout.time[row]:g} "
        f"(row {row}){more}; the gap can only be analysed where it is finite. Drop "
        "those rows or fill them first."
    )


def _sampling_interval(t: np.ndarray, seg: Segment) -> float:
    """The constant time step of one test; raise if the steps are not constant."""
    if t.size < 2:
        return math.nan
    dt = (t[-1] - t[0]) / (t.size - 1)
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        k = int(back[0])
        raise ValueError(
            f"Time does not increase within {segment_label(seg)}: {TIME_LEVEL} goes "
            f"from {t[k]:g} to {t[k + 1]:g} at row {seg.start + k + 1}."
        )
    off = np.flatnonzero(np.abs(steps - steps[0]) > _STEP_RTOL * steps[0])
    if off.size:
        k = int(off[0])
        raise ValueError(
            f"The sampling interval of {segment_label(seg)} is not constant: "
            f"{steps[0]:g} s from {TIME_LEVEL}={t[0]:g} to {t[1]:g}, but {steps[k]:g} s "
            f"from {TIME_LEVEL}={t[k]:g} to {t[k + 1]:g}. Frequency bands and lags need "
            "evenly spaced samples; resample the test onto a uniform time grid first."
        )
    return float(dt)


def _check_gap(r) -> tuple[np.ndarray, _Layout]:
    """Validate the gap; return its values and its layout."""
    if not isinstance(r, pd.Series):
        raise ValueError(
            f"The gap r must be a pandas Series indexed by (test, time_s); got {type(r).__name__}."
        )
    if len(r) == 0:
        raise ValueError("The gap r is empty (0 samples): at least one row is needed.")
    names = list(r.index.names or [])
    if TIME_LEVEL not in names:
        raise ValueError(
            f"The index of the gap r needs a {TIME_LEVEL!r} level (seconds from the "
            f"start of each test) and, for several tests, a {TEST_LEVEL!r} level; its "
            f"levels are {names}."
        )
    segments = _test_segments(r)  # also checks that time increases within each test
    time = np.asarray(r.index.get_level_values(TIME_LEVEL), dtype=np.float64)
    labels = np.empty(len(r), dtype=object)
    dt = np.empty(len(segments))
    for i, seg in enumerate(segments):
        labels[seg.slice] = seg.label
        dt[i] = _sampling_interval(time[seg.slice], seg)
    layout = _Layout(segments, time, labels, dt)
    values = _real_values(r, "The gap r")
    _check_finite(values, layout, "The gap")
    return values, layout


def _check_aligned(index: pd.Index, other: pd.Index, what: str) -> None:
    if index.equals(other):
        return
    hint = f"Give {what} the same (test, time_s) index as r, e.g. {what}.loc[r.index]."
    if len(other) != len(index):
        raise ValueError(
            f"The index of {what} does not match the index of the gap r: r has "
            f"{len(index)} rows, {what} has {len(other)}. {hint}"
        )
    for row, (a, b) in enumerate(zip(index, other)):
        if a != b:
            raise ValueError(
                f"The index of {what} does not match the index of the gap r: row "
                f"{row} is {a!r} in r but {b!r} in {what}. {hint}"
            )


def _check_frame(frame, what: str, r: pd.Series, layout: _Layout):
    """Validate drivers or signals; return a float array and the column names."""
    if isinstance(frame, pd.Series):
        frame = frame.to_frame()
    if not isinstance(frame, pd.DataFrame):
        raise ValueError(
            f"{what} must be a 2-D pandas DataFrame with the index of the gap r; got "
            f"{describe_input(frame)}."
        )
    _check_aligned(r.index, frame.index, what)
    check_unique_columns(frame.columns, what)
    names = [str(c) for c in frame.columns]
    values = np.empty((len(frame), len(names)))
    for j, name in enumerate(names):
        column = frame.iloc[:, j]
        values[:, j] = _real_values(column, f"Column {name!r} of {what}")
        _check_finite(values[:, j], layout, f"{what} column {name!r}")
    return values, names


def _param_error(function: str, name: str, what: str, value) -> ValueError:
    return ValueError(
        f"The {name!r} parameter of {function} must be {what}. Got {value!r} instead."
    )


def _check_time_edges(time_edges_s) -> np.ndarray:
    what = (
        "a strictly increasing sequence of at least 2 times in seconds (-inf and inf "
        "are allowed at the ends)"
    )
    try:
        edges = np.asarray(time_edges_s, dtype=np.float64)
    except (TypeError, ValueError):
        raise _param_error("gap_breakdown", "time_edges_s", what, time_edges_s) from None
    if edges.ndim != 1 or edges.size < 2 or np.isnan(edges).any() or np.any(np.diff(edges) <= 0):
        raise _param_error("gap_breakdown", "time_edges_s", what, time_edges_s)
    return edges


def _check_band_edges(bands_s) -> np.ndarray:
    what = "a sequence of distinct positive finite periods in seconds"
    try:
        edges = np.asarray(bands_s, dtype=np.float64)
    except (TypeError, ValueError):
        raise _param_error("gap_breakdown", "bands_s", what, bands_s) from None
    if edges.ndim != 1 or not np.all(np.isfinite(edges)) or np.any(edges <= 0):
        raise _param_error("gap_breakdown", "bands_s", what, bands_s)
    edges = np.sort(edges)[::-1]
    if np.any(np.diff(edges) == 0):
        raise _param_error("gap_breakdown", "bands_s", what, bands_s)
    return edges


# --------------------------------------------------------------------------
# labels
# --------------------------------------------------------------------------


def _unit_for(values) -> tuple[str, float]:
    """The largest of h, min, s in which every value is a whole number."""
    values = [v for v in values if np.isfinite(v)]
    for unit, scale in (("h", _HOUR), ("min", _MINUTE)):
        if all(v % scale == 0 for v in values):
            return unit, scale
    return "s", 1.0


def _duration(value: float) -> str:
    unit, scale = _unit_for([value])
    return f"{value / scale:g} {unit}"


def _time_bin_labels(edges: np.ndarray) -> list[str]:
    unit, scale = _unit_for(edges)
    labels = []
    for a, b in zip(edges[:-1], edges[1:]):
        if np.isneginf(a):
            labels.append(f"< {b / scale:g} {unit}")
        elif np.isposinf(b):
            labels.append(f">= {a / scale:g} {unit}")
        else:
            sep = " to " if a < 0 else "-"
            labels.append(f"{a / scale:g}{sep}{b / scale:g} {unit}")
    return labels


def _band_labels(edges: np.ndarray) -> list[str]:
    """Labels of the bands cut at the periods ``edges`` (in decreasing order)."""
    if edges.size == 0:
        return ["all periods"]
    labels = [f"period > {_duration(edges[0])}"]
    for long, short in zip(edges[:-1], edges[1:]):
        unit_long, scale_long = _unit_for([long])
        unit_short, scale_short = _unit_for([short])
        if unit_long == unit_short:
            labels.append(f"{short / scale_short:g}-{long / scale_long:g} {unit_long}")
        else:
            labels.append(f"{_duration(short)}-{_duration(long)}")
    labels.append(f"< {_duration(edges[-1])}")
    return labels


# --------------------------------------------------------------------------
# kernels: arrays in, arrays out
# --------------------------------------------------------------------------


def _sum_sq(x: np.ndarray) -> float:
    # not ``x @ x``: a BLAS dot product may start threads that spin on a busy
    # machine (see greyml._threads); numpy's pairwise sum is also more accurate
    return float(np.sum(np.square(x)))


def _summary(x: np.ndarray, rows: np.ndarray, layout: _Layout, total: float) -> dict:
    """RMS, peak (and where), bias and share of the gap values ``x`` at ``rows``."""
    energy = _sum_sq(x)
    i = int(np.argmax(np.abs(x)))
    return {
        "n": int(x.size),
        "rms": math.sqrt(energy / x.size),
        "peak": float(abs(x[i])),
        "peak_test": layout.labels[rows[i]],
        "peak_time_s": float(layout.time[rows[i]]),
        "bias": float(np.mean(x)),
        "share": energy / total if total > 0 else math.nan,
    }


def _drivers_on(D: np.ndarray) -> np.ndarray:
    """Rows where at least one driver is non-zero, relative to its own range."""
    size = np.abs(D)
    return np.any(size > _ON_RTOL * size.max(axis=0), axis=1)


def _default_time_edges(time: np.ndarray) -> np.ndarray:
    t_max = float(time.max())
    step = _HOUR if t_max >= 2 * _HOUR else 15 * _MINUTE
    first = min(0.0, math.floor(float(time.min()) / step))
    last = max(math.ceil(t_max / step), first + 1)
    return step * np.arange(first, last + 1)


def _time_bins(time: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Bin of every time: ``[a, b)``, the last bin closed ``[a, b]``."""
    outside = (time < edges[0]) | (time > edges[-1])
    if outside.any():
        row = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"The time bins of gap_breakdown span {TIME_LEVEL} {edges[0]:g} to "
            f"{edges[-1]:g} s but the gap has rows from {time.min():g} to "
            f"{time.max():g} s (first outside: row {row}). Widen 'time_edges_s'; "
            "-inf and inf are allowed as its first and last edges."
        )
    bins = np.searchsorted(edges, time, side="right") - 1
    return np.minimum(bins, edges.size - 2)


def _band_of_bins(n: int, dt: float, edges: np.ndarray) -> np.ndarray:
    """Band of every rFFT bin of an ``n``-sample test (0 = longest periods, with DC).

    Bin ``k`` has the period ``n * dt / k``; a period at an edge (to
    ``_EDGE_RTOL``) belongs to the shorter band.
    """
    k = np.arange(n // 2 + 1, dtype=np.float64)
    band = np.zeros(k.size, dtype=np.intp)
    if n < 2:
        return band
    span = n * dt
    for j, edge in enumerate(edges):  # decreasing periods: shorter bands override
        band[k * edge * (1 + _EDGE_RTOL) >= span] = j + 1
    return band


def _band_components(x: np.ndarray, dt: float, edges: np.ndarray) -> np.ndarray:
    """The gap of one test split by frequency band, shape ``(n_bands, n)``.

    The rows add up to ``x`` and are orthogonal to each other (their spectra
    do not overlap), so their energies add up to that of ``x``.
    """
    n = x.size
    spectrum = sp_fft.rfft(x)
    band = _band_of_bins(n, dt, edges)
    out = np.zeros((edges.size + 1, n))
    for j in np.unique(band):
        out[j] = sp_fft.irfft(np.where(band == j, spectrum, 0), n)
    return out


def _lagged_sums(a: np.ndarray, B: np.ndarray, max_lag: int) -> np.ndarray:
    """``S[m + max_lag, j] = sum_t a[t] * B[t - m, j]`` for ``m = -max_lag..max_lag``.

    Zero padding to at least ``n + max_lag`` keeps the circular correlation of
    the FFT from wrapping round within the lags returned.
    """
    n = a.size
    size = sp_fft.next_fast_len(n + max_lag, real=True)
    fa = sp_fft.rfft(a, size)
    fb = sp_fft.rfft(B, size, axis=0)
    circular = sp_fft.irfft(fa[:, None] * np.conj(fb), size, axis=0)
    return np.concatenate([circular[size - max_lag :], circular[: max_lag + 1]])


def _ljung_box(values: np.ndarray, segments: list[Segment], n_lags: int | None):
    """Per-test Ljung-Box statistics summed; pooled lag-1 autocorrelation."""
    q, dof, lag1_num, lag1_den = 0.0, 0, 0.0, 0.0
    for seg in segments:
        c = values[seg.slice] - np.mean(values[seg.slice])
        n = c.size
        energy = _sum_sq(c)
        if n >= 2:
            lag1_num += float(np.sum(c[1:] * c[:-1]))
            lag1_den += energy
        h = min(_WHITENESS_MAX_LAGS, n // 5) if n_lags is None else min(n_lags, n - 1)
        if h < 1:
            continue
        if energy > 0:
            rho = _lagged_sums(c, c[:, None], h)[h + 1 :, 0] / energy
            q += n * (n + 2) * float(np.sum(rho**2 / (n - np.arange(1, h + 1))))
        dof += h
    lag1 = lag1_num / lag1_den if lag1_den > 0 else 0.0
    return q, dof, lag1


def _pooled_cross_correlation(values, S, layout: _Layout, max_lag_s: float):
    """Cross-correlation of the gap with every column of ``S``, pooled over tests.

    Returns the lags in seconds, shape ``(n_lags,)``, the correlations, shape
    ``(n_lags, n_signals)``, the pooled energy of the centred gap and that of
    every centred signal. Each test gives the sums of products at its own lags
    ``m * dt``; they are added up on a common grid with the finest sampling
    interval of all tests, by linear interpolation in the lag where a test is
    sampled more coarsely (exact when all tests share one interval).
    """
    usable = [(seg, dt) for seg, dt in zip(layout.segments, layout.dt) if seg.n >= 2]
    if not usable:
        zeros = np.zeros((1, S.shape[1]))
        return np.zeros(1), zeros, 0.0, np.zeros(S.shape[1])
    step = min(dt for _, dt in usable)
    reach = max((seg.n - 1) * dt for seg, dt in usable)
    n_grid = int(math.floor(min(max_lag_s, reach) / step * (1 + 1e-12)))
    grid = step * np.arange(-n_grid, n_grid + 1)

    sums = np.zeros((grid.size, S.shape[1]))
    energy_r, energy_s = 0.0, np.zeros(S.shape[1])
    for seg, dt in usable:
        c = values[seg.slice] - np.mean(values[seg.slice])
        C = S[seg.slice] - np.mean(S[seg.slice], axis=0)
        energy_r += _sum_sq(c)
        energy_s += np.sum(np.square(C), axis=0)
        max_lag = min(int(math.ceil(max_lag_s / dt * (1 - 1e-12))), seg.n - 1)
        local = _lagged_sums(c, C, max_lag)
        if dt == step and max_lag >= n_grid:
            sums += local[max_lag - n_grid : max_lag + n_grid + 1]
        else:
            lags = dt * np.arange(-max_lag, max_lag + 1)
            for j in range(S.shape[1]):
                sums[:, j] += np.interp(grid, lags, local[:, j], left=0.0, right=0.0)

    scale = np.sqrt(energy_r * energy_s)
    corr = np.divide(sums, scale, out=np.zeros_like(sums), where=scale > 0)
    return grid, np.clip(corr, -1.0, 1.0), energy_r, energy_s


# --------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------


def gap_breakdown(
    r: pd.Series,
    *,
    drivers: pd.DataFrame | None = None,
    time_edges_s=None,
    bands_s=None,
) -> pd.DataFrame:
    r"""Size of the gap and its share of the squared gap, segment by segment.

    Parameters
    ----------
    r : pandas.Series
        The gap, measured minus simulated target (e.g. tool-point displacement
        in µm), indexed by greyml's ``(test, time_s)`` MultiIndex: rows of a test
        contiguous and in time order, ``time_s`` in seconds from the start of
        the test (used as given: it need not start at 0). The sampling interval
        must be constant within a test and may differ between tests. An index
        with only a ``time_s`` level is a single test.
    drivers : pandas.DataFrame, optional
        The heat sources that the test switches on and off (spindle speed, feed
        motors, ...), with exactly the index of ``r``. Used only for the
        "phase" family, which is left out when ``drivers`` is None or has no
        columns.
    time_edges_s : sequence of float, optional
        Edges, in seconds of ``time_s``, of the "time" bins. They must cover
        every row (``-inf`` and ``inf`` are allowed at the ends). By default
        hourly bins from 0 to the longest test, or quarter-hour bins if the
        longest test is shorter than 2 h.
    bands_s : sequence of float, optional
        Periods, in seconds, at which the "band" family is cut; by default
        4 h, 1 h and 15 min, giving the bands "period > 4 h", "1-4 h",
        "15 min-1 h" and "< 15 min". An empty sequence gives a single band.

    Returns
    -------
    pandas.DataFrame
        One row per segment, with a default integer index and the columns

        - ``by``: the family, one of "all", "test", "phase", "time", "band";
        - ``segment``: the segment's label, e.g. ``"II"`` (a test),
          ``"heating"``, ``"0-1 h"`` or ``"15 min-1 h"``;
        - ``n``: number of rows;
        - ``rms``: root mean square of the gap in the segment;
        - ``peak``: the largest :math:`|r|`, and ``peak_test`` and
          ``peak_time_s``: where it first occurs;
        - ``bias``: the mean of the gap;
        - ``share``: the segment's :math:`\sum r^2` over that of the whole gap
          (NaN if the gap is zero everywhere).

        The families come in the order above. "all" is the whole gap. "test"
        has one row per test, in order of appearance (a single test without a
        ``test`` level is called "the single test"). "phase" has "heating",
        the rows where at least one driver is on, then "cooling", the rows
        where every driver is off. "time" has one row per bin of ``time_s``.
        "band" has one row per frequency band, longest periods first. Within
        each family the shares add up to 1.

    Raises
    ------
    ValueError
        If ``r`` is not a Series, is empty, has no ``time_s`` level, has a
        non-finite value (the message names the test and ``time_s``), or a
        test whose sampling interval is not constant; if ``drivers`` does not
        have the index of ``r`` (the message names the first differing row)
        or is not finite; if ``time_edges_s`` or ``bands_s`` is malformed or
        the time bins leave rows out.

    See Also
    --------
    residual_diagnostics : Whiteness of the gap and its cross-correlation with
        the inputs.

    Notes
    -----
    *Empty segments are left out*: a family lists only segments that hold data,
    so there is no "cooling" row if a driver is on in every row, no row for a
    time bin without samples and no row for a band that no test can resolve
    (all its periods shorter than two sampling intervals). The shares of a
    family therefore always add up to 1.

    A driver is *on* in a row where its absolute value exceeds
    :math:`10^{-9}` times its own largest absolute value, so that each driver
    is judged on its own scale and rounding noise around zero counts as off.

    *Bands.* The gap of each test is transformed with a real FFT and split
    into one time series per band by keeping only the bins of that band; no
    trend or mean is removed, and the mean (the zero-frequency bin) belongs to
    the band of the longest periods. Bin :math:`k` of an :math:`n`-sample test
    with interval :math:`\Delta t` has the period :math:`n\Delta t / k`; a
    period equal to an edge belongs to the shorter band. The band series of a
    test add up to its gap and have disjoint spectra, so they are orthogonal
    and, by Parseval's theorem, their energies add up to the energy of the
    gap: the band shares add up to 1 to rounding. ``rms``, ``peak`` and
    ``bias`` of a band are taken over its series in all tests, so ``n`` is the
    number of rows of the gap and ``bias`` is zero except in the band that
    holds the mean. A test with :math:`n` samples resolves no period shorter
    than :math:`2\Delta t`, and none longer than :math:`n\Delta t` except the
    mean, so slow drifts of a short test end up in the band of the longest
    periods that the test resolves.

    Examples
    --------
    Two tests of four samples; the first driver is on in the first half of
    each test:

    >>> import pandas as pd
    >>> from greyml import make_test_index
    >>> from greyml.gap._where import gap_breakdown
    >>> index = make_test_index(["I"] * 4 + ["II"] * 4, [0, 60, 120, 180] * 2)
    >>> r = pd.Series([1.0, -2.0, 3.0, 0.0, 2.0, 2.0, -1.0, -1.0], index=index)
    >>> drivers = pd.DataFrame({"spindle": [1, 1, 0, 0, 1, 1, 0, 0]}, index=index)
    >>> table = gap_breakdown(r, drivers=drivers)
    >>> table.loc[table["by"] != "band", ["by", "segment", "n", "peak", "bias", "share"]]
       by    segment  n  peak  bias     share
    0  all       all  8   3.0   0.5  1.000000
    1  test        I  4   3.0   0.5  0.583333
    2  test       II  4   2.0   0.5  0.416667
    3  phase  heating 4   2.0  0.75  0.541667
    4  phase  cooling 4   3.0  0.25  0.458333
    5  time  0-15 min 8   3.0   0.5  1.000000
    """
    values, layout = _check_gap(r)
    on = None
    if drivers is not None:
        D, _ = _check_frame(drivers, "drivers", r, layout)
        if D.shape[1]:
            on = _drivers_on(D)
    edges_t = (
        _default_time_edges(layout.time)
        if time_edges_s is None
        else _check_time_edges(time_edges_s)
    )
    edges_b = _check_band_edges(DEFAULT_BAND_EDGES_S if bands_s is None else bands_s)
    bins = _time_bins(layout.time, edges_t)

    total = _sum_sq(values)
    everything = np.arange(values.size)
    rows = []

    def add(by, segment, where):
        rows.append({"by": by, "segment": segment, **_summary(values[where], where, layout, total)})

    add("all", "all", everything)
    for seg in layout.segments:
        label = "the single test" if seg.label is None else str(seg.label)
        add("test", label, everything[seg.slice])
    if on is not None:
        for phase, mask in (("heating", on), ("cooling", ~on)):
            if mask.any():
                add("phase", phase, np.flatnonzero(mask))
    for j, label in enumerate(_time_bin_labels(edges_t)):
        where = np.flatnonzero(bins == j)
        if where.size:
            add("time", label, where)

    components = np.zeros((edges_b.size + 1, values.size))
    resolved = np.zeros(edges_b.size + 1, dtype=bool)
    for seg, dt in zip(layout.segments, layout.dt):
        components[:, seg.slice] = _band_components(values[seg.slice], dt, edges_b)
        resolved[np.unique(_band_of_bins(seg.n, dt, edges_b))] = True
    for j, label in enumerate(_band_labels(edges_b)):
        if resolved[j]:
            summary = _summary(components[j], everything, layout, total)
            rows.append({"by": "band", "segment": label, **summary})

    table = pd.DataFrame(rows, columns=list(BREAKDOWN_COLUMNS))
    return table.astype({"n": np.int64})


def residual_diagnostics(
    r: pd.Series,
    signals: pd.DataFrame,
    *,
    max_lag_s=None,
    n_lags_whiteness=None,
) -> tuple[dict, pd.DataFrame]:
    r"""Whiteness of the gap and its cross-correlation with the inputs.

    Parameters
    ----------
    r : pandas.Series
        The gap, measured minus simulated target, indexed by greyml's
        ``(test, time_s)`` MultiIndex, with a constant sampling interval within
        each test (see :func:`gap_breakdown`).
    signals : pandas.DataFrame
        The series to correlate the gap with (drivers, ambient temperature,
        sensors), one column each, with exactly the index of ``r``.
    max_lag_s : float, optional
        Largest lag, in seconds, of the cross-correlation; 3600 (1 h) by
        default. Each test turns it into samples with its own sampling
        interval.
    n_lags_whiteness : int, optional
        Number of lags of the Ljung-Box test in every test (at most the test's
        length minus one). By default :math:`\min(20, \lfloor n/5 \rfloor)`
        for a test of :math:`n` samples.

    Returns
    -------
    whiteness : dict
        ``"ljung_box_q"`` (float): the Ljung-Box statistic Q summed over tests;
        ``"dof"`` (int): the number of lags summed over tests;
        ``"p_value"`` (float): the probability of a Q at least this large if
        the gap were white (chi-square with ``dof`` degrees of freedom);
        ``"white"`` (bool): ``p_value > 0.05``;
        ``"lag1_autocorrelation"`` (float): the lag-1 autocorrelation of the
        gap, pooled over tests.
    cross_correlation : pandas.DataFrame
        One row per column of ``signals``, in their order, with the columns
        ``signal`` (the column name as a string); ``peak_corr``: the
        correlation, with its sign, at the lag where its absolute value is
        largest (the smallest such lag in absolute value on a tie);
        ``peak_lag_s``: that lag in seconds, positive when the gap follows
        the signal; ``corr_at_zero``: the correlation at lag 0; ``note``:
        ``"constant"`` for a signal that is constant within every test (it
        gets correlation 0 at every lag), ``"gap constant"`` if the gap itself
        is constant within every test, otherwise empty.

    Raises
    ------
    ValueError
        For a malformed gap (see :func:`gap_breakdown`); if ``signals`` does
        not have the index of ``r`` (the message names the first differing row)
        or has a non-numeric or non-finite value; for a negative or
        non-finite ``max_lag_s`` or an ``n_lags_whiteness`` that is not a
        positive integer; if no test is long enough for a single Ljung-Box
        lag (5 samples by default, 2 with ``n_lags_whiteness``).

    See Also
    --------
    gap_breakdown : How large the gap is, by test, phase, time and band.

    Notes
    -----
    Both diagnostics are those of the residual analysis of system
    identification [1]_: a model that has captured the dynamics leaves a
    residual that is white and uncorrelated with past inputs. A correlation
    peak at a positive lag :math:`\tau` means that the gap at time :math:`t`
    still follows the signal at time :math:`t-\tau`: a thermal path, with
    that delay, that the simulation misses or gets the gain of wrong.

    Every quantity is computed within tests; nothing pairs samples of two
    tests. Each test's gap and signals are centred on their own means. The
    correlation at lag :math:`\tau` is

    .. math:: \rho(\tau) = \frac{\sum_k \sum_t r_k(t)\, s_k(t-\tau)}
              {\sqrt{\sum_k \sum_t r_k(t)^2 \; \sum_k \sum_t s_k(t)^2}}

    with :math:`k` running over the tests: the sums of products are pooled
    before normalising, so :math:`|\rho| \le 1` and long tests weigh more.
    Lags are on the grid of the finest sampling interval among the tests; a
    more coarsely sampled test contributes its sums interpolated linearly in
    the lag.

    The Ljung-Box statistic of a test with :math:`n` samples and :math:`h`
    lags is :math:`Q = n(n+2)\sum_{j=1}^{h} \hat\rho_j^2/(n-j)` [2]_, with
    :math:`\hat\rho_j` the sample autocorrelation; under whiteness it is
    approximately chi-square with :math:`h` degrees of freedom, and the
    statistics of independent tests add up, as do their degrees of freedom.
    A test whose gap is constant has no autocorrelation to speak of: it adds
    its lags to ``dof`` and nothing to Q, and a gap that is constant in every
    test is reported white with ``p_value`` 1. Tests too short for a lag are
    skipped.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, section 16.6 (model validation by residual
       analysis).
    .. [2] G. M. Ljung and G. E. P. Box, "On a measure of lack of fit in time
       series models", *Biometrika* 65(2), pp. 297-303, 1978.

    Examples
    --------
    The gap follows a heat input with a delay of 10 min, plus some noise:

    >>> import numpy as np
    >>> import pandas as pd
    >>> from greyml import make_test_index
    >>> from greyml.gap._where import residual_diagnostics
    >>> rng = np.random.default_rng(0)
    >>> heat = np.cumsum(rng.normal(size=400))
    >>> index = make_test_index(["I"] * 390, 60.0 * np.arange(390))
    >>> r = pd.Series(heat[:390] + 0.1 * rng.normal(size=390), index=index)
    >>> signals = pd.DataFrame({"heat": heat[10:]}, index=index)
    >>> whiteness, xcorr = residual_diagnostics(r, signals)
    >>> whiteness["white"]
    False
    >>> float(xcorr.loc[0, "peak_lag_s"])
    600.0
    """
    values, layout = _check_gap(r)
    S, names = _check_frame(signals, "signals", r, layout)
    if max_lag_s is None:
        max_lag_s = _HOUR
    if (
        not isinstance(max_lag_s, numbers.Real)
        or isinstance(max_lag_s, bool)
        or not np.isfinite(max_lag_s)
        or max_lag_s < 0
    ):
        raise _param_error(
            "residual_diagnostics", "max_lag_s", "a real number in the range [0, inf)", max_lag_s
        )
    if n_lags_whiteness is not None and (
        not isinstance(n_lags_whiteness, numbers.Integral)
        or isinstance(n_lags_whiteness, bool)
        or n_lags_whiteness < 1
    ):
        raise _param_error(
            "residual_diagnostics",
            "n_lags_whiteness",
            "an int in the range [1, inf)",
            n_lags_whiteness,
        )

    q, dof, lag1 = _ljung_box(values, layout.segments, n_lags_whiteness)
    if dof == 0:
        need = 5 if n_lags_whiteness is None else 2
        longest = max(layout.segments, key=lambda seg: seg.n)
        raise ValueError(
            f"The gap is too short for a whiteness test: a Ljung-Box lag needs at least "
            f"{need} samples in a test, and the longest, {segment_label(longest)}, has "
            f"{longest.n} sample{'' if longest.n == 1 else 's'} (too few samples)."
        )
    p_value = float(chi2.sf(q, dof))
    whiteness = {
        "ljung_box_q": float(q),
        "dof": int(dof),
        "p_value": p_value,
        "white": bool(p_value > _WHITENESS_ALPHA),
        "lag1_autocorrelation": float(lag1),
    }

    lags, corr, energy_r, energy_s = _pooled_cross_correlation(values, S, layout, float(max_lag_s))
    zero = int(np.flatnonzero(lags == 0)[0])
    # the peak of |corr|, the smallest |lag| first on a tie
    order = np.argsort(np.abs(lags), kind="stable")
    rows = []
    for j, name in enumerate(names):
        best = order[int(np.argmax(np.abs(corr[order, j])))]
        if energy_r == 0:
            note = "gap constant"
        elif energy_s[j] == 0:
            note = "constant"
        else:
            note = ""
        rows.append(
            {
                "signal": name,
                "peak_corr": float(corr[best, j]),
                "peak_lag_s": float(lags[best]),
                "corr_at_zero": float(corr[zero, j]),
                "note": note,
            }
        )
    return whiteness, pd.DataFrame(rows, columns=list(XCORR_COLUMNS))
