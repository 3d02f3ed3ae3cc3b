"""Scores test by test, and their table, as ``greyml validate`` and ``greyml predict`` print them.

One row per test: its rows, the RMSE, the worst absolute error and, when the
model gives an interval, the share of rows inside it; then the median and the
worst over the tests summarised. The reference the numbers are in is named on
the line above the table (:data:`REFERENCE_NAMES`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from greyml._cli._printing import printable

__all__ = ["TestScore", "Summary", "score_tests", "summarise", "print_table", "REFERENCE_NAMES"]

#: How each reference of a displacement is named above a table (and in JSON).
REFERENCE_NAMES = {
    "start": "start (the change since each test's first row)",
    "recording": "recording (from the recording's zero, as the target in the file)",
    "target": "the target as in the file",
}


@dataclass(frozen=True)
class TestScore:
    """The scores of one test.

    Attributes
    ----------
    test : str
        Its label.
    rows : int
        Its number of rows.
    rmse : float
        Root-mean-square error over its rows.
    worst : float
        The largest absolute error over its rows.
    coverage : float or None
        The share of its rows inside the interval; None without an interval.
    """

    __test__ = False  # a record, not a pytest test class

    test: str
    rows: int
    rmse: float
    worst: float
    coverage: float | None = None

    def as_dict(self):
        return asdict(self)


@dataclass(frozen=True)
class Summary:
    """The median and the worst of per-test scores (the worst coverage is the lowest).

    ``None`` fields: no test to summarise, or no interval.
    """

    tests: int
    median_rmse: float | None
    worst_rmse: float | None
    median_worst: float | None
    worst_worst: float | None
    median_coverage: float | None
    worst_coverage: float | None

    def as_dict(self):
        return asdict(self)


def score_tests(labels, measured, predicted, half_width=None):
    """One :class:`TestScore` per test, in the order the tests first appear.

    Parameters
    ----------
    labels : array-like of shape (n_rows,)
        The test of every row.
    measured, predicted : array-like of shape (n_rows,)
        In one reference.
    half_width : array-like of shape (n_rows,), optional
        The interval's half-width at every row (a row is inside when its
        absolute error is at most this).
    """
    import numpy as np

    labels = np.asarray(labels, dtype=object)
    error = np.asarray(measured, dtype=float) - np.asarray(predicted, dtype=float)
    half = None if half_width is None else np.asarray(half_width, dtype=float)
    out = []
    for test in dict.fromkeys(labels):
        rows = labels == test
        e = error[rows]
        coverage = None if half is None else float(np.mean(np.abs(e) <= half[rows]))
        out.append(
            TestScore(
                str(test),
                int(rows.sum()),
                float(np.sqrt(np.mean(e**2))),
                float(np.max(np.abs(e))),
                coverage,
            )
        )
    return out


def summarise(scores):
    """The :class:`Summary` of ``scores`` (a list of :class:`TestScore`)."""
    import numpy as np

    if not scores:
        return Summary(0, None, None, None, None, None, None)
    rmse = [s.rmse for s in scores]
    worst = [s.worst for s in scores]
    coverage = [s.coverage for s in scores if s.coverage is not None]
    return Summary(
        len(scores),
        float(np.median(rmse)),
        float(max(rmse)),
        float(np.median(worst)),
        float(max(worst)),
        float(np.median(coverage)) if coverage else None,
        float(min(coverage)) if coverage else None,
    )


def _number(value, percent=False):
    if value is None:
        return "-"
    return f"{100 * value:.1f} %" if percent else f"{value:.3g}"


def print_table(scores, *, coverage=None, marked=()):
    """Print the table of ``scores`` and return the :class:`Summary` it ends with.

    Parameters
    ----------
    scores : list of TestScore
    coverage : float, optional
        The interval's coverage, named in the column's title ("90 % interval").
    marked : collection of str
        Tests to mark with ``*`` (the tests a model was fitted on); the
        summary is over the others only, and a legend line says so.
    """
    title = "interval" if coverage is None else f"{100 * coverage:g} % interval"
    width = max([4, *(len(printable(s.test)) for s in scores)]) + 2
    print(f"  {'test':<{width}} {'rows':>6} {'RMSE':>9} {'worst |error|':>14} {title:>14}")
    for s in scores:
        name = printable(s.test) + (" *" if s.test in marked else "")
        print(
            f"  {name:<{width}} {s.rows:>6d} {_number(s.rmse):>9} {_number(s.worst):>14} "
            f"{_number(s.coverage, True):>14}"
        )
    held = [s for s in scores if s.test not in marked]
    summary = summarise(held)
    over = "" if not marked else " over the tests not fitted on"
    if held:
        print(
            f"  {'median':<{width}} {'':>6} {_number(summary.median_rmse):>9} "
            f"{_number(summary.median_worst):>14} {_number(summary.median_coverage, True):>14}"
        )
        print(
            f"  {'worst':<{width}} {'':>6} {_number(summary.worst_rmse):>9} "
            f"{_number(summary.worst_worst):>14} {_number(summary.worst_coverage, True):>14}"
        )
    if marked:
        print(
            f"  * fitted on this test (its error is a training error); median and worst{over}"
            + ("" if held else ": none, every test was fitted on")
        )
    print("  RMSE and worst |error| in the target's unit; interval: the share of rows inside it")
    return summary
