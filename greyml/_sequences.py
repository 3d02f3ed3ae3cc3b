"""Which rows belong to which heating/cooling test.

greyml represents several tests in one table by the row index: a pandas
``MultiIndex`` whose level named ``"test"`` holds the test label of each row and,
optionally, a level named ``"time_s"`` holds seconds from the start of that test.
Rows of one test are contiguous and in time order. Anything without a ``test``
level (a NumPy array, a DataFrame with a plain index) is a single test.

Why the index: scikit-learn's ``Pipeline``, ``cross_val_score``, ``GridSearchCV``
and every splitter index rows with ``iloc``, so the row index travels with the
data through all of them, and ``set_output(transform="pandas")`` keeps it across
transformers. Nothing has to be routed as extra metadata.

Every sequence-aware piece of greyml (AGO, the grey models, the learning models,
the simulator's I/O) calls :func:`segments_by_test` and nothing else to find the
boundaries, so accumulation, differencing and convolution never cross them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

#: Name of the row-index level that holds the test labels.
TEST_LEVEL = "test"
#: Name of the row-index level that holds the seconds from each test's start.
TIME_LEVEL = "time_s"

__all__ = [
    "TEST_LEVEL",
    "TIME_LEVEL",
    "Segment",
    "groups_of",
    "has_test_index",
    "keep_test_index",
    "make_test_index",
    "segment_label",
    "segments_by_test",
]


@dataclass(frozen=True)
class Segment:
    """Rows ``start:stop`` (in the order given) of the test labelled ``label``.

    ``label`` is ``None`` when the data carries no test labels (a single test).
    """

    label: object
    start: int
    stop: int

    @property
    def n(self) -> int:
        return self.stop - self.start

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)


def segment_label(segment: Segment) -> str:
    """How a segment is named in messages: ``"test 'IV'"`` or ``"the single test"``."""
    if segment.label is None:
        return "the single test"
    return f"test {segment.label!r}"


def _index_of(X):
    if isinstance(X, (pd.DataFrame, pd.Series)):
        return X.index
    if isinstance(X, pd.Index):
        return X
    return None


def has_test_index(X) -> bool:
    """True when ``X`` is a pandas object whose index has a level named ``test``."""
    index = _index_of(X)
    return index is not None and TEST_LEVEL in (index.names or [])


def _label_codes(index):
    """An integer code per row for its test label (−1: missing), and the labels of rows.

    Integer codes let the runs of a long recording be found without comparing
    Python objects row by row (a MultiIndex holds them already).
    """
    if isinstance(index, pd.MultiIndex):
        level = index.names.index(TEST_LEVEL)
        codes = np.asarray(index.codes[level])
        values = index.levels[level]
    else:
        codes, values = pd.factorize(index.get_level_values(TEST_LEVEL), use_na_sentinel=True)

    def label_of(rows):
        return np.asarray(values.take(codes[rows]), dtype=object)

    return codes, label_of


def _first_runs(codes: np.ndarray):
    """Start positions of runs of equal consecutive label codes."""
    n = len(codes)
    if n == 0:
        return np.array([], dtype=int)
    change = np.ones(n, dtype=bool)
    change[1:] = codes[1:] != codes[:-1]
    return np.flatnonzero(change)


def segments_by_test(X, n_samples: int | None = None) -> list[Segment]:
    """Split the rows of ``X`` into tests.

    Parameters
    ----------
    X : DataFrame, Series, Index or array-like
        Data whose row index may carry a ``test`` level (and a ``time_s`` level).
    n_samples : int, optional
        Number of rows, needed only when ``X`` is not a pandas object and has no
        ``len``.

    Returns
    -------
    segments : list of Segment
        One per test, in the order the tests first appear.

    Raises
    ------
    ValueError
        If a test label is missing, if a test appears in two separate runs of
        rows, or if ``time_s`` does not strictly increase within a test.
    """
    index = _index_of(X)
    if n_samples is None:
        n_samples = len(index) if index is not None else len(X)
    if index is None or TEST_LEVEL not in (index.names or []):
        return [Segment(None, 0, int(n_samples))]

    codes, label_of = _label_codes(index)
    missing = codes < 0
    if missing.any():
        row = int(np.flatnonzero(missing)[0])
        raise ValueError(
            f"The '{TEST_LEVEL}' index level has a missing test label at row {row}; "
            "every row must name the test it belongs to."
        )
    starts = _first_runs(codes)
    stops = np.append(starts[1:], len(codes))
    segments = []
    seen = {}
    for start, stop, label in zip(starts, stops, label_of(starts)):
        if label in seen:
            first = seen[label]
            raise ValueError(
                f"Test {label!r} appears in two separate runs of rows "
                f"(rows {first.start}-{first.stop - 1} and {start}-{stop - 1}); "
                "the rows of one test must be contiguous. Sort the data by test "
                "and time, e.g. X.sort_index(level=['test', 'time_s'])."
            )
        seg = Segment(label, int(start), int(stop))
        seen[label] = seg
        segments.append(seg)

    if TIME_LEVEL in index.names:
        time = np.asarray(index.get_level_values(TIME_LEVEL), dtype=float)
        for seg in segments:
            t = time[seg.slice]
            if np.isnan(t).any():
                row = seg.start + int(np.flatnonzero(np.isnan(t))[0])
                raise ValueError(
                    f"The '{TIME_LEVEL}' index level of {segment_label(seg)} is "
                    f"missing at row {row}."
                )
            steps = np.diff(t)
            bad = np.flatnonzero(steps <= 0)
            if bad.size:
                k = int(bad[0])
                what = "repeats" if steps[k] == 0 else "goes back"
                raise ValueError(
                    f"Time does not increase within {segment_label(seg)}: "
                    f"'{TIME_LEVEL}' {what} from {t[k]:g} to {t[k + 1]:g} at row "
                    f"{seg.start + k + 1}. Rows of a test must be in strictly "
                    "increasing time order."
                )
    return segments


def groups_of(X) -> np.ndarray:
    """The test label of every row, for ``groups=`` of scikit-learn splitters.

    Not called ``test_ids``: pytest would collect that name from a test
    module that imports it.

    Examples
    --------
    >>> import pandas as pd
    >>> idx = pd.MultiIndex.from_tuples(
    ...     [("I", 0), ("I", 10), ("II", 0)], names=["test", "time_s"])
    >>> groups_of(pd.DataFrame({"T1_C": [20.0, 20.5, 21.0]}, index=idx)).tolist()
    ['I', 'I', 'II']
    """
    segments = segments_by_test(X)
    n = segments[-1].stop if segments else 0
    out = np.empty(n, dtype=object)
    for seg in segments:
        out[seg.slice] = 0 if seg.label is None else seg.label
    return out


def make_test_index(tests, times) -> pd.MultiIndex:
    """Build greyml's ``(test, time_s)`` row index from per-row labels and times.

    Examples
    --------
    Two tests, the second starting its clock again at 0 s:

    >>> import pandas as pd
    >>> from greyml import make_test_index, groups_of
    >>> index = make_test_index(["I", "I", "II"], [0, 60, 0])
    >>> list(index.names)
    ['test', 'time_s']
    >>> index.tolist()
    [('I', 0.0), ('I', 60.0), ('II', 0.0)]
    >>> groups_of(pd.DataFrame({"T1_C": [20.0, 20.5, 21.0]}, index=index)).tolist()
    ['I', 'I', 'II']
    """
    return pd.MultiIndex.from_arrays(
        [np.asarray(tests), np.asarray(times, dtype=float)],
        names=[TEST_LEVEL, TIME_LEVEL],
    )


def keep_test_index(estimator, X, out, method="transform"):
    """Return ``out`` as a DataFrame with ``X``'s index when ``X`` carries tests.

    Test boundaries are part of the data: a sequence-aware transformer that got a
    ``test``-indexed DataFrame hands one on (under the default output setting),
    so that the next step of a Pipeline still knows where each test starts.
    ``set_output(transform="pandas")`` does the same for any input; other output
    settings are left to scikit-learn.
    """
    config = getattr(estimator, "_sklearn_output_config", {}).get(method, "default")
    if config == "default" and has_test_index(X):
        columns = estimator.get_feature_names_out()
        return pd.DataFrame(out, index=X.index, columns=columns)
    return out
