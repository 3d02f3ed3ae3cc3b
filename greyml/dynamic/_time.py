"""Time in the dynamic models: steps between rows, gaps, and which tests carry state.

One place decides, for :class:`greyml.LagFeatures`, :class:`greyml.ThermalTransferFunction`
and the :class:`greyml.Compensator` alike:

* the step in seconds into every row, from the ``time_s`` index level;
* which steps are too long: a gap longer than the largest time constant inside
  a test is refused with one message, whoever finds it;
* which tests continue the state of the test before them (``state``):

  - ``"restart"``: none; every test starts without history;
  - ``"carry"``: every test after the first (the tests are consecutive pieces of
    one recording); the step into a test is the time since the previous test's
    last row when its clock runs on, else the recording's nominal step (a clock
    that restarts in every piece);
  - ``"auto"``: a test continues the previous one when its clock runs on from the
    previous test's last row by a step that the lags can bridge (more than 0, at
    most the largest time constant): a recording cut into consecutive pieces
    carries, tests on separate clocks (each starting at 0) restart.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from greyml._sequences import TEST_LEVEL, TIME_LEVEL, segment_label
from greyml._time import format_duration
from greyml._validation import float_vector

__all__ = [
    "MAX_TERMS",
    "MAX_TIME_CONSTANTS",
    "STATES",
    "Timeline",
    "check_time_constants",
    "gap_message",
    "timeline",
    "timeline_of",
]

#: The values of the ``state`` parameter of the dynamic models.
STATES = ("auto", "carry", "restart")

#: The most time constants a dynamic model takes (a bank, or each input's
#: lags): no honest model needs more than a few dozen, and each one costs
#: every predicted row a column. A model file that holds more is refused.
MAX_TIME_CONSTANTS = 1000

#: The most terms (lag features) a dynamic model or compensator holds: the
#: work and memory of one ``predict`` row or one ``update`` grow with them.
MAX_TERMS = 100_000


@dataclass(frozen=True)
class Timeline:
    """Steps and links of the rows of some tests.

    Attributes
    ----------
    dt : ndarray of shape (n_samples,)
        Step in seconds into each row. At the first row of a test that carries
        the previous test's state, the step from that test's last row; at the
        first row of a test that restarts, unused.
    carried : ndarray of shape (n_tests,) of bool
        Whether each test continues the state of the test before it.
    starts : ndarray of shape (n_tests,)
        ``time_s`` of each test's first row (NaN without a ``time_s`` level).
    nominal_step_s : float
        The median step between rows inside the tests (NaN when no test has
        two rows).
    """

    dt: np.ndarray
    carried: np.ndarray
    starts: np.ndarray
    nominal_step_s: float


def check_time_constants(values, what):
    """``values`` as a 1-D float array of time constants in seconds, checked.

    Each must be finite and > 0 (a lag with a negative time constant grows
    without bound), and there may be at most :data:`MAX_TIME_CONSTANTS`.
    ``what`` names them in the one-line ValueError, e.g. ``"The
    'time_constants' parameter of LagFeatures"``.
    """
    taus = float_vector(
        values, f"{what} must be a sequence of time constants in seconds. Got {values!r} instead."
    )
    if taus.size == 0:
        raise ValueError(f"{what} needs at least one time constant.")
    if taus.size > MAX_TIME_CONSTANTS:
        raise ValueError(
            f"{what} holds {taus.size:,} time constants, more than the {MAX_TIME_CONSTANTS:,} "
            "a dynamic model takes."
        )
    bad = np.flatnonzero(~(np.isfinite(taus) & (taus > 0)))
    if bad.size:
        k = int(bad[0])
        raise ValueError(
            f"{what}: time constant {float(taus[k])!r} s (entry {k}) is not a finite number > 0."
        )
    return taus


def gap_message(owner, where, gap, time, tau_max, row=None):
    """The one message of a step too long for the lags, in batch and streaming alike."""
    at = "" if row is None else f" (row {row})"
    return (
        f"{owner}: {where} has a sampling gap of {format_duration(gap)} before "
        f"time_s = {time:g} s{at}, longer than the largest time constant "
        f"({format_duration(tau_max)}); the lags cannot bridge it: split the test there "
        "(a new test restarts), or give a longer time constant."
    )


def _times(X, segments, owner, default_step):
    index = X.index if isinstance(X, (pd.DataFrame, pd.Series)) else None
    if index is not None and TIME_LEVEL in (index.names or []):
        return np.asarray(index.get_level_values(TIME_LEVEL), dtype=float), True
    if default_step is None:
        raise ValueError(
            f"{owner} needs the time of every row: X has no '{TIME_LEVEL}' index level. "
            "Give X greyml's (test, time_s) index (greyml.make_test_index), or set "
            "sample_interval= (seconds per row) for rows evenly spaced in time."
        )
    n = segments[-1].stop if segments else 0
    t = np.empty(n)
    for seg in segments:
        t[seg.slice] = default_step * np.arange(seg.n)
    return t, False


def timeline(X, segments, *, owner, tau_max, state, nominal=None, default_step=None):
    """Steps into every row and the tests that carry state, checked.

    Parameters
    ----------
    X : DataFrame or array-like
        Rows of the tests; the time comes from its ``time_s`` index level.
    segments : list of Segment
    owner : str
        Who is asking, for messages (``"LagFeatures"``).
    tau_max : float
        The largest time constant: a longer step inside a test is refused.
    state : {"auto", "carry", "restart"}
    nominal : float, optional
        The recording's step (from ``fit``); by default the median step.
    default_step : float, optional
        Seconds between rows when ``X`` has no ``time_s`` level; None refuses
        such ``X``.

    Returns
    -------
    Timeline
    """
    t, clocked = _times(X, segments, owner, default_step)
    index = X.index if isinstance(X, (pd.DataFrame, pd.Series)) else None
    labelled = index is not None and TEST_LEVEL in (index.names or [])
    return timeline_of(
        t, clocked, labelled, segments, owner=owner, tau_max=tau_max, state=state, nominal=nominal
    )


def timeline_of(t, clocked, labelled, segments, *, owner, tau_max, state, nominal=None):
    """:func:`timeline` of the times ``t`` of every row (``clocked``: from a
    ``time_s`` level; ``labelled``: whose tests' times were checked with their
    labels), however the rows were read."""
    n = t.size
    dt = np.empty(n)
    if n:
        dt[0] = np.nan
        dt[1:] = np.diff(t)
    starts = np.array([s.start for s in segments], dtype=int)
    inner = np.ones(n, dtype=bool)
    inner[starts] = False
    if clocked and not labelled:
        # with a test level, segments_by_test has checked the time already
        bad = np.flatnonzero(~np.isfinite(t) | (inner & ~(dt > 0)))
        if bad.size:
            k = int(bad[0])
            after = f" after {t[k - 1]:g}." if k and np.isfinite(t[k]) else "."
            raise ValueError(
                f"{owner}: '{TIME_LEVEL}' must be finite and strictly increase within a test; "
                f"in {segment_label(segments[0])} it is {t[k]:g} at row {k}{after}"
            )
    gap = np.flatnonzero(inner & (dt > tau_max))
    if gap.size:
        k = int(gap[0])
        seg = segments[int(np.searchsorted(starts, k, side="right")) - 1]
        raise ValueError(gap_message(owner, segment_label(seg), dt[k], t[k], tau_max, row=k))
    if nominal is None:
        nominal = float(np.median(dt[inner])) if inner.any() else float("nan")
    carried = np.zeros(len(segments), dtype=bool)
    for i in range(1, len(segments)):
        step = t[starts[i]] - t[starts[i] - 1]
        runs_on = clocked and step > 0
        if state == "auto":
            carried[i] = runs_on and step <= tau_max
        elif state == "carry":
            carried[i] = True
            if not runs_on:
                if not np.isfinite(nominal):
                    raise ValueError(
                        f"{owner}(state='carry') cannot step from one test into the next: no "
                        "test seen in fit has two rows, so the recording's step is unknown."
                    )
                step = nominal
            elif step > tau_max:
                raise ValueError(
                    gap_message(
                        owner,
                        f"the recording between {segment_label(segments[i - 1])} and "
                        f"{segment_label(segments[i])}",
                        step,
                        t[starts[i]],
                        tau_max,
                    )
                    + " With state='auto' a test after such a gap restarts."
                )
        if carried[i]:
            dt[starts[i]] = step
    test_starts = t[starts] if clocked else np.full(len(segments), np.nan)
    return Timeline(dt, carried, test_starts, float(nominal))
