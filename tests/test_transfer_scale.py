"""The fit's cost against rows and tests: the design computed in pieces equals the
whole, and the nested choices cost the same however finely the rows are cut into
tests (folds of consecutive tests beyond :data:`MAX_FOLDS`)."""

import numpy as np
import pandas as pd
import pytest

from greyml import ThermalTransferFunction, make_test_index
from greyml.dynamic import _gram
from greyml.dynamic._gram import (
    MAX_FOLDS,
    DesignRows,
    design,
    fold_groups,
    grams_by_test,
    grams_of_rows,
)


def _cut(n, sizes):
    """Row ranges of lengths ``sizes`` covering 0..n in order."""
    edges = np.concatenate(([0], np.cumsum(sizes)))
    assert edges[-1] == n
    return list(zip(edges[:-1].tolist(), edges[1:].tolist()))


SPEC = [(0, 1, (120.0, 900.0)), (0, 2, (120.0, 900.0)), (1, 1, (300.0,)), (2, 1, ())]


@pytest.mark.parametrize("start_rows", [False, True])
@pytest.mark.parametrize("pieces", [[40, 1, 59, 100], [200], [1] * 200, [73, 127]])
def test_the_design_in_pieces_equals_the_whole(start_rows, pieces):
    """Tests that carry on, restart and start idle; rows cut anywhere (through a
    test, at a test's first row, one row at a time): the same design to rounding."""
    rng = np.random.default_rng(0)
    n = 200
    x = rng.normal(20.0, 1.0, (n, 3))
    dt = np.full(n, 15.0)
    dt[100] = 60.0  # a longer step into a carried test
    bounds = _cut(n, [40, 60, 50, 50])  # tests start at 0, 40, 100, 150
    carry = [False, True, True, False]
    idle = [0]
    whole = design(x, dt, bounds, SPEC, carry, idle)
    if start_rows:
        for a, b in bounds:
            whole[a:b] -= whole[a].copy()
    rows = DesignRows(dt, bounds, SPEC, carry, idle, start_rows=start_rows)
    parts = [rows.rows(a, x[a:b]) for a, b in _cut(n, pieces)]
    np.testing.assert_allclose(np.vstack(parts), whole, rtol=1e-13, atol=1e-12)


def test_rows_asked_out_of_order_are_refused():
    rows = DesignRows(np.full(10, 1.0), [(0, 10)], SPEC, False)
    with pytest.raises(ValueError, match="from row 5, not 0"):
        rows.rows(5, np.ones((5, 3)))


def test_the_grams_in_pieces_equal_the_grams_of_the_whole_design():
    rng = np.random.default_rng(1)
    n = 300
    x = rng.normal(0.0, 1.0, (n, 3))
    dt = np.full(n, 30.0)
    bounds = _cut(n, [120, 30, 150])
    y, w = rng.normal(size=n), rng.uniform(0.0, 2.0, n)
    A = np.column_stack([design(x, dt, bounds, SPEC, True), np.ones(n)])
    expected = grams_by_test(A, y, w, bounds)
    rows = DesignRows(dt, bounds, SPEC, True)
    got = grams_of_rows(rows, ((a, x[a:b]) for a, b in _cut(n, [7, 200, 93])), y, w, True)
    for name in ("G", "b", "yy", "sw"):
        np.testing.assert_allclose(getattr(got, name), getattr(expected, name), rtol=1e-12)


def test_folds_are_consecutive_tests_one_each_up_to_ten():
    assert fold_groups([0, 2, 5]) == [[0], [2], [5]]
    assert fold_groups(list(range(10))) == [[k] for k in range(10)]
    twelve = fold_groups(list(range(12)))
    assert twelve == [[0], [1], [2], [3], [4, 5], [6], [7], [8], [9], [10, 11]]
    groups = fold_groups(list(range(25)))
    assert len(groups) == MAX_FOLDS
    assert sum(groups, []) == list(range(25))
    assert sorted(len(g) for g in groups) == [2] * 5 + [3] * 5


def _tiled(n_tests, hours=64.0, step=60.0, seed=0):
    """One recording on one clock cut into ``n_tests`` tests of equal length: a spindle
    switched on and off, two sensors, y from known lags."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600.0, step)
    on = ((t // 14400.0) % 2 == 0) * 3000.0
    a = np.exp(-step / 3600.0)
    heat = np.zeros_like(t)
    for k in range(1, t.size):
        heat[k] = a * heat[k - 1] + (1 - a) * on[k]
    T1 = 20.0 + 0.002 * heat + 0.01 * rng.standard_normal(t.size)
    T2 = 20.0 + 0.5 * np.sin(t / 7000.0)
    y = 0.8 * (T1 - 20.0) + 1e-4 * on + 0.02 * rng.standard_normal(t.size)
    label = np.minimum((np.arange(t.size) * n_tests) // t.size, n_tests - 1)
    X = pd.DataFrame(
        {"spindle_rpm": on, "T1_C": T1, "T2_C": T2},
        index=make_test_index([f"r{k:03d}" for k in label], t),
    )
    return X, y


def _solves(monkeypatch, n_tests):
    calls = []
    original = _gram.solve_all

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(_gram, "solve_all", counted)
    X, y = _tiled(n_tests)
    model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    monkeypatch.setattr(_gram, "solve_all", original)
    return len(calls), model


def test_the_nested_choices_cost_the_same_for_ten_or_forty_tests(monkeypatch):
    """The same rows cut into 10 and into 40 tests: as many ridge solves (ten folds of
    whole tests either way), every test still held out once for the intervals."""
    solves_10, m10 = _solves(monkeypatch, 10)
    solves_40, m40 = _solves(monkeypatch, 40)
    assert solves_40 == solves_10
    assert m10.interval_calibration_.n_tests == 10
    assert m40.interval_calibration_.n_tests == 40
    assert len(m40.fitted_tests_) == 40
