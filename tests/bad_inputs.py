"""The bad inputs of the hardening matrix (issue #8), shared by its test files.

A *case* corrupts a valid data set of two heating tests in one way that a user
can meet: a NaN in one sensor, a test whose rows come in two runs, a column
renamed between fit and predict. Each case says what a good message must
contain (the kind of problem, the column, the test), and which part of the
data it corrupts, so that one case runs against every entry point it applies
to: the estimators (``tests/test_bad_input.py``) and the loaders, simulator,
gap diagnosis and command line (``tests/test_bad_input_io.py``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from greyml import make_test_index
from greyml.grey._functions import simulate_gmc

SENSORS = ["T1_C", "T2_C", "T3_C"]
TARGET = "dz_um"


def valid_data(seed=0, lengths=(30, 26)):
    """Two tests 'A' and 'B' of three sensors and a GMC target: (X, y)."""
    rng = np.random.default_rng(seed)
    frames, targets = [], []
    for label, n in zip(["A", "B"], lengths):
        X = 20.0 + 0.3 * np.cumsum(rng.normal(size=(n, len(SENSORS))), axis=0)
        y = simulate_gmc(X - X[0], 0.3, np.array([0.8, -0.5, 0.3]), 0.0)
        index = make_test_index([label] * n, 10.0 * np.arange(n))
        frames.append(pd.DataFrame(X, index=index, columns=SENSORS))
        targets.append(pd.Series(y, index=index, name=TARGET))
    return pd.concat(frames), pd.concat(targets)


@dataclass(frozen=True)
class Case:
    """One way the data can be bad.

    ``corrupt(X, y) -> (X, y)`` works on copies of the training data (stage
    ``"fit"``) or of the data given to ``predict``/``transform`` (stage
    ``"predict"``). ``match`` are regular expressions that must all occur in
    the message. ``needs`` says what the entry point must have for the case to
    apply: ``"y"`` (it takes a target), ``"index"`` (it reads test boundaries),
    ``"names"`` (it keeps column names), ``"fitted"`` (it has a second step
    after fit), ``"model"`` (it learns, so one sample is too few), ``"params"``
    (it knows how many coefficients it fits), ``"constant"`` (it rejects a
    constant sensor).
    With ``finite_ok`` a clear error is not required: the entry point may also
    succeed, but then every output must be finite.
    """

    name: str
    stage: str
    corrupt: Callable
    match: tuple = ()
    needs: frozenset = field(default_factory=frozenset)
    finite_ok: bool = False


def _set(X, row, col, value):
    X = X.copy()
    X.iloc[row, X.columns.get_loc(col)] = value
    return X


def _sety(y, row, value):
    y = y.copy()
    y.iloc[row] = value
    return y


def _reindex(X, y, index):
    X = X.copy()
    X.index = index
    if y is not None:
        y = y.copy()
        y.index = index
    return X, y


def _split_test(X, y):
    """Rows of test 'A' in two runs: the last five rows of 'A' moved after 'B'."""
    a = X.index.get_level_values("test") == "A"
    pos_a = np.flatnonzero(a)
    order = np.r_[pos_a[:-5], np.flatnonzero(~a), pos_a[-5:]]
    return X.iloc[order], None if y is None else y.iloc[order]


def _times(X, y, row, value):
    tests = X.index.get_level_values("test")
    times = np.asarray(X.index.get_level_values("time_s"), dtype=float).copy()
    times[row] = value
    return _reindex(X, y, make_test_index(tests, times))


def _label(X, y, row, value):
    tests = np.asarray(X.index.get_level_values("test"), dtype=object).copy()
    tests[row] = value
    times = X.index.get_level_values("time_s")
    return _reindex(X, y, make_test_index(tests, times))


def _object_column(X, values):
    X = X.copy()
    X["T2_C"] = values(X["T2_C"])
    return X


def _one_test(X, y, n):
    X, y = X.iloc[:n], None if y is None else y.iloc[:n]
    return X, y


def _empty(X, y):
    return X.iloc[:0], None if y is None else y.iloc[:0]


def _y_index_from(X, y):
    """y labelled with other tests than X (the same length)."""
    tests = np.where(X.index.get_level_values("test") == "A", "B", "A")
    index = make_test_index(tests, X.index.get_level_values("time_s"))
    return X, y.set_axis(index)


NAN = r"NaN"
INF = r"inf"
T2 = r"'T2_C'"
TEST_A = r"test 'A'"
TEST_B = r"test 'B'"

CASES = [
    # -- non-finite values --------------------------------------------------
    Case("nan_in_sensor", "fit", lambda X, y: (_set(X, 7, "T2_C", np.nan), y), (NAN, T2, TEST_A)),
    Case("inf_in_sensor", "fit", lambda X, y: (_set(X, 40, "T2_C", np.inf), y), (INF, T2, TEST_B)),
    Case("minus_inf_in_sensor", "fit", lambda X, y: (_set(X, 3, "T2_C", -np.inf), y), (INF, T2)),
    Case(
        "nan_in_target",
        "fit",
        lambda X, y: (X, _sety(y, 35, np.nan)),
        (NAN, r"target|\by\b", TEST_B),
        frozenset({"y"}),
    ),
    Case(
        "inf_in_target",
        "fit",
        lambda X, y: (X, _sety(y, 2, np.inf)),
        (INF, r"target|\by\b", TEST_A),
        frozenset({"y"}),
    ),
    Case(
        "nan_at_predict",
        "predict",
        lambda X, y: (_set(X, 40, "T3_C", np.nan), y),
        (NAN, r"'T3_C'", TEST_B),
        frozenset({"fitted"}),
    ),
    Case(
        "inf_at_predict",
        "predict",
        lambda X, y: (_set(X, 1, "T1_C", np.inf), y),
        (INF, r"'T1_C'", TEST_A),
        frozenset({"fitted"}),
    ),
    # -- values no measurement reaches (issue 26 item 7d) ----------------------
    Case(
        "huge_in_sensor",
        "fit",
        lambda X, y: (_set(X, 40, "T2_C", 1e300), y),
        (r"1e\+300", T2, TEST_B, r"check its unit"),
        frozenset({"model"}),
    ),
    Case(
        "huge_in_target",
        "fit",
        lambda X, y: (X, _sety(y, 2, -1e200)),
        (r"-1e\+200", r"target|'dz_um'", TEST_A, r"check its unit"),
        frozenset({"y", "model"}),
    ),
    # -- too little data ------------------------------------------------------
    Case("empty", "fit", _empty, (r"0 sample",)),
    Case(
        "one_sample",
        "fit",
        lambda X, y: _one_test(X, y, 1),
        (r"1 sample",),
        frozenset({"model"}),
    ),
    Case(
        "fewer_samples_than_parameters",
        "fit",
        lambda X, y: _one_test(X, y, 3),
        (r"too few samples", r"3 samples"),
        frozenset({"params"}),
    ),
    Case(
        "no_columns",
        "fit",
        lambda X, y: (X[[]], y),
        (r"0 feature",),
    ),
    Case(
        "empty_at_predict",
        "predict",
        _empty,
        (r"0 sample",),
        frozenset({"fitted"}),
    ),
    # -- bad columns ---------------------------------------------------------
    Case(
        "constant_sensor",
        "fit",
        lambda X, y: (X.assign(T2_C=21.5), y),
        (T2, r"constant"),
        frozenset({"constant", "names"}),
    ),
    Case(
        "text_column",
        "fit",
        lambda X, y: (_object_column(X, lambda c: np.where(c > c.median(), "hot", "cold")), y),
        (T2, r"non-numeric|string|object"),
        frozenset({"names"}),
    ),
    Case(
        "numbers_as_text",
        "fit",
        lambda X, y: (_object_column(X, lambda c: c.map("{:.3f}".format)), y),
        (T2, r"non-numeric|string|object"),
        frozenset({"names"}),
    ),
    Case(
        "datetime_column",
        "fit",
        lambda X, y: (
            _object_column(X, lambda c: pd.Timestamp("2026-01-01") + pd.to_timedelta(c, "s")),
            y,
        ),
        (T2, r"non-numeric|datetime"),
        frozenset({"names"}),
    ),
    Case(
        "complex_column",
        "fit",
        lambda X, y: (_object_column(X, lambda c: c + 1j), y),
        (r"complex",),
    ),
    Case(
        "text_column_at_predict",
        "predict",
        lambda X, y: (_object_column(X, lambda c: c.astype(str)), y),
        (T2, r"non-numeric|string|object"),
        frozenset({"fitted", "names"}),
    ),
    Case(
        "duplicate_column_names",
        "fit",
        lambda X, y: (X.set_axis(["T1_C", "T2_C", "T2_C"], axis=1), y),
        (T2, r"more than once"),
        frozenset({"names"}),
    ),
    Case(
        "mixed_column_name_types",
        "fit",
        lambda X, y: (X.set_axis(["T1_C", 2, "T3_C"], axis=1), y),
        (r"string names|column name",),
        frozenset({"names"}),
    ),
    Case(
        "categorical_column",
        "fit",
        lambda X, y: (X.assign(T2_C=X["T2_C"].round().astype("category")), y),
        (T2, r"non-numeric|category"),
        frozenset({"names"}),
    ),
    Case(
        "pandas_missing_value",
        "fit",
        lambda X, y: (_set(X.astype("Float64"), 9, "T2_C", pd.NA), y),
        (NAN, T2, TEST_A),
        frozenset({"names"}),
    ),
    Case(
        "nan_in_first_row_of_a_test",
        "fit",
        lambda X, y: (_set(X, 30, "T1_C", np.nan), y),
        (NAN, r"'T1_C'", TEST_B, r"sample 1\b|time_s\W+0\b"),
    ),
    Case(
        "extra_column_at_predict",
        "predict",
        lambda X, y: (X.assign(T4_C=1.0), y),
        (r"T4_C", r"unseen"),
        frozenset({"fitted", "names"}),
    ),
    # -- test boundaries and time -------------------------------------------
    Case(
        "test_in_two_runs",
        "fit",
        _split_test,
        (r"'A'", r"two separate runs"),
        frozenset({"index"}),
    ),
    Case(
        "time_goes_back",
        "fit",
        lambda X, y: _times(X, y, 12, 5.0),
        (TEST_A, r"[Tt]ime", r"goes back|increas"),
        frozenset({"index"}),
    ),
    Case(
        "duplicate_time_stamp",
        "fit",
        lambda X, y: _times(X, y, 41, X.index.get_level_values("time_s")[40]),
        (TEST_B, r"repeats|duplicate"),
        frozenset({"index"}),
    ),
    Case(
        "missing_time",
        "fit",
        lambda X, y: _times(X, y, 5, np.nan),
        (TEST_A, r"time_s", r"missing"),
        frozenset({"index"}),
    ),
    Case(
        "missing_test_label",
        "fit",
        lambda X, y: _label(X, y, 33, None),
        (r"missing test label", r"row 33"),
        frozenset({"index"}),
    ),
    Case(
        "test_in_two_runs_at_predict",
        "predict",
        _split_test,
        (r"'A'", r"two separate runs"),
        frozenset({"index", "fitted"}),
    ),
    Case(
        "time_goes_back_at_predict",
        "predict",
        lambda X, y: _times(X, y, 45, 5.0),
        (TEST_B, r"[Tt]ime", r"goes back"),
        frozenset({"index", "fitted"}),
    ),
    Case(
        "x_and_y_tests_disagree",
        "fit",
        _y_index_from,
        (r"disagree|differ",),
        frozenset({"index", "y"}),
    ),
    # -- fit and predict disagree --------------------------------------------
    Case(
        "renamed_column_at_predict",
        "predict",
        lambda X, y: (X.rename(columns={"T3_C": "T9_C"}), y),
        (r"T9_C", r"T3_C"),
        frozenset({"fitted", "names"}),
    ),
    Case(
        "column_order_at_predict",
        "predict",
        lambda X, y: (X[["T1_C", "T3_C", "T2_C"]], y),
        (r"order", r"T2_C|T3_C"),
        frozenset({"fitted", "names"}),
    ),
    Case(
        "missing_column_at_predict",
        "predict",
        lambda X, y: (X.drop(columns="T2_C"), y),
        (r"T2_C",),
        frozenset({"fitted", "names"}),
    ),
    Case(
        "fewer_columns_at_predict_array",
        "predict",
        lambda X, y: (X.to_numpy()[:, :2], y),
        (r"2 features", r"expecting 3"),
        frozenset({"fitted"}),
    ),
    # -- shapes and types ----------------------------------------------------
    Case(
        "target_length",
        "fit",
        lambda X, y: (X, y.iloc[:-3].reset_index(drop=True)),
        (r"56", r"53"),
        frozenset({"y"}),
    ),
    Case(
        "target_two_columns",
        "fit",
        lambda X, y: (X, pd.concat([y, y.rename("dx_um")], axis=1)),
        (r"1d|1-D|one column|shape",),
        frozenset({"y"}),
    ),
    Case(
        "target_text",
        "fit",
        lambda X, y: (X, y.map("{:.2f} um".format)),
        (r"target|\by\b|numeric",),
        frozenset({"y"}),
    ),
    Case("one_dimensional_X", "fit", lambda X, y: (X["T1_C"].to_numpy(), y), (r"2D|2-D|reshape",)),
    Case(
        "three_dimensional_X",
        "fit",
        lambda X, y: (X.to_numpy()[:, :, None], y),
        (r"dim 3|3-D|2D|2-D",),
    ),
    Case("sparse_X", "fit", lambda X, y: (_sparse(X), y), (r"sparse",)),
    # -- extreme magnitudes --------------------------------------------------
    Case(
        "huge_sensor_values",
        "fit",
        lambda X, y: (X * 1e12, y),
        (r"large|magnitude|overflow|finite|beyond ±",),
        finite_ok=True,
    ),
    Case(
        "huge_target",
        "fit",
        lambda X, y: (X, y * 1e12),
        (r"large|magnitude|overflow|finite|beyond ±",),
        frozenset({"y"}),
        finite_ok=True,
    ),
    Case(
        "huge_values_at_predict",
        "predict",
        lambda X, y: (X * 1e12, y),
        (r"large|magnitude|overflow|finite|range|beyond ±",),
        frozenset({"fitted"}),
        finite_ok=True,
    ),
]


def _sparse(X):
    from scipy import sparse

    return sparse.csr_matrix(X.to_numpy())


CASE_IDS = [c.name for c in CASES]


def assert_clear_message(entry, case, message):
    """The message names what was wrong and where (every pattern of the case),
    and is greyml's sentence, not a traceback or a NumPy ufunc error."""
    for pattern in case.match:
        assert re.search(pattern, message, re.IGNORECASE), (
            f"{entry} on {case.name}: message lacks {pattern!r}:\n{message}"
        )
    assert not re.search(r"^\s*File |numpy\.core|ufunc", message), message
