"""Input checks of :mod:`greyml.gap._where`: the gap, its companions and the edges.

The generic checks (finite values, the test of a row, real numbers, an even
sampling interval, the parameter message) are greyml's shared ones in
:mod:`greyml._validation`; here they are applied to the gap's layout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from greyml._sequences import TEST_LEVEL, TIME_LEVEL, Segment, segment_label, segments_by_test
from greyml._validation import (
    MAX_INPUT,
    check_sampling_interval,
    check_unique_columns,
    first_non_finite,
    param_error,
    real_values,
    segment_of,
)
from greyml.io._csv import describe_input

#: Largest relative deviation of a time step of a test from its first step.
_STEP_RTOL = 1e-3


@dataclass(frozen=True)
class _Layout:
    """Where the rows of the gap sit: tests, times and sampling intervals."""

    segments: list[Segment]
    time: np.ndarray  # time_s of every row
    labels: np.ndarray  # test label of every row (None for a single unlabelled test)
    dt: np.ndarray  # sampling interval of every segment, NaN for a one-row test


def _check_finite(values: np.ndarray, layout: _Layout, what: str) -> None:
    row, count = first_non_finite(values)
    if row is None:
        with np.errstate(invalid="ignore"):
            big = np.flatnonzero(np.abs(values) > MAX_INPUT)
        if big.size:
            row = int(big[0])
            where = segment_label(segment_of(layout.segments, row))
            raise ValueError(
                f"{what} holds {values[row]:g} in {where} at {TIME_LEVEL}="
                f"{layout.time[row]:g}, beyond "
                f"{MAX_INPUT:g}, which no measurement reaches; check its unit."
            )
        return
    seg = segment_of(layout.segments, row)
    kind = "NaN" if np.isnan(values[row]) else "inf"
    more = "" if count == 1 else f" (and {count - 1} more non-finite values)"
    raise ValueError(
        f"{what} has {kind} in {segment_label(seg)} at {TIME_LEVEL}={layout.time[row]:g} "
        f"(row {row}){more}; the gap can only be analysed where it is finite. Drop "
        "those rows or fill them first."
    )


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
    segments = segments_by_test(r)  # also checks that time increases within each test
    time = np.asarray(r.index.get_level_values(TIME_LEVEL), dtype=np.float64)
    labels = np.empty(len(r), dtype=object)
    dt = np.empty(len(segments))
    for i, seg in enumerate(segments):
        labels[seg.slice] = seg.label
        dt[i] = check_sampling_interval(time[seg.slice], seg, _STEP_RTOL)
    layout = _Layout(segments, time, labels, dt)
    values = real_values(r, "The gap r")
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
        values[:, j] = real_values(column, f"Column {name!r} of {what}")
        _check_finite(values[:, j], layout, f"{what} column {name!r}")
    return values, names


def _check_time_edges(time_edges_s) -> np.ndarray:
    what = (
        "a strictly increasing sequence of at least 2 times in seconds (-inf and inf "
        "are allowed at the ends)"
    )
    try:
        edges = np.asarray(time_edges_s, dtype=np.float64)
    except (TypeError, ValueError):
        raise param_error("gap_breakdown", "time_edges_s", what, time_edges_s) from None
    if edges.ndim != 1 or edges.size < 2 or np.isnan(edges).any() or np.any(np.diff(edges) <= 0):
        raise param_error("gap_breakdown", "time_edges_s", what, time_edges_s)
    return edges


def _check_band_edges(bands_s) -> np.ndarray:
    what = "a sequence of distinct positive finite periods in seconds"
    try:
        edges = np.asarray(bands_s, dtype=np.float64)
    except (TypeError, ValueError):
        raise param_error("gap_breakdown", "bands_s", what, bands_s) from None
    if edges.ndim != 1 or not np.all(np.isfinite(edges)) or np.any(edges <= 0):
        raise param_error("gap_breakdown", "bands_s", what, bands_s)
    edges = np.sort(edges)[::-1]
    if np.any(np.diff(edges) == 0):
        raise param_error("gap_breakdown", "bands_s", what, bands_s)
    return edges
