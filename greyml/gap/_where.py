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

The input checks are in :mod:`greyml.gap._where_checks` (built on the shared
ones of :mod:`greyml._validation`), the kernels in
:mod:`greyml.gap._where_kernels`; the labels and the public functions here.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.stats import chi2

from greyml._param_validation import Integral, Interval, Real, validate_params
from greyml._sequences import segment_label
from greyml._time import common_unit, format_duration
from greyml.gap._where_checks import (
    _check_band_edges,
    _check_frame,
    _check_gap,
    _check_time_edges,
)
from greyml.gap._where_kernels import (
    _band_components,
    _band_of_bins,
    _default_time_edges,
    _drivers_on,
    _ljung_box,
    _pooled_cross_correlation,
    _sum_sq,
    _summary,
    _time_bins,
)

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
_WHITENESS_ALPHA = 0.05


# --------------------------------------------------------------------------
# labels
# --------------------------------------------------------------------------


def _time_bin_labels(edges: np.ndarray) -> list[str]:
    unit, scale = common_unit(edges)
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
    labels = [f"period > {format_duration(edges[0])}"]
    for long, short in zip(edges[:-1], edges[1:]):
        unit_long, scale_long = common_unit([long])
        unit_short, scale_short = common_unit([short])
        if unit_long == unit_short:
            labels.append(f"{short / scale_short:g}-{long / scale_long:g} {unit_long}")
        else:
            labels.append(f"{format_duration(short)}-{format_duration(long)}")
    labels.append(f"< {format_duration(edges[-1])}")
    return labels


# --------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------


@validate_params(
    {
        "r": "no_validation",  # a Series indexed by (test, time_s), checked with its index
        "drivers": "no_validation",  # a DataFrame with r's index, or None
        "time_edges_s": ["array-like", None],
        "bands_s": ["array-like", None],
    },
    prefer_skip_nested_validation=True,
)
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


@validate_params(
    {
        "r": "no_validation",
        "signals": "no_validation",
        "max_lag_s": [Interval(Real, 0, None, closed="left"), None],
        "n_lags_whiteness": [Interval(Integral, 1, None, closed="left"), None],
    },
    prefer_skip_nested_validation=True,
)
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
    max_lag_s = _HOUR if max_lag_s is None else max_lag_s

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
