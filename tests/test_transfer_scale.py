"""The fit's cost against rows and tests: the design computed in pieces equals the
whole, and the nested choices cost the same however finely the rows are cut into
tests (folds of consecutive tests beyond :data:`MAX_FOLDS`)."""

import numpy as np
import pytest
from _recordings import tiled as _tiled

from greyml import ThermalTransferFunction
from greyml.dynamic import _gram
from greyml.dynamic._gram import (
    MAX_FOLDS,
    DesignRows,
    design,
    fold_groups,
    grams_by_test,
    grams_of_rows,
)
from greyml.io import TestFiles


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
    got = np.empty_like(whole)
    got[:, rows.order] = np.hstack(parts).T
    np.testing.assert_array_equal(got, whole)


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


def _same_model(a, b):
    """Two fits equal: gains, sensors, interval record, envelope and starts, bit for bit."""
    assert a.selected_sensors_ == b.selected_sensors_
    np.testing.assert_array_equal(a.feature_coef_, b.feature_coef_)
    assert a.intercept_ == b.intercept_
    ca, cb = a.interval_calibration_, b.interval_calibration_
    for field in ca.__dataclass_fields__:
        np.testing.assert_array_equal(getattr(ca, field), getattr(cb, field))
    for field in ("low", "high", "max_rate_per_h"):
        np.testing.assert_array_equal(
            getattr(a.input_envelope_, field), getattr(b.input_envelope_, field)
        )
    assert a.test_starts_ == b.test_starts_
    assert a.sensor_resolution_ == b.sensor_resolution_
    assert a.step_sizes_ == b.step_sizes_


@pytest.fixture(scope="module")
def recording():
    X, y = _tiled(6, hours=48.0)
    return X, y, ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)


@pytest.mark.parametrize("cut", [997, 1440, 2880])
def test_a_fit_from_pieces_equals_the_fit_of_all_rows(recording, monkeypatch, cut):
    """Pieces cut through tests, at test boundaries, and smaller than the design's
    own pieces: the same model, bit for bit."""
    monkeypatch.setattr(_gram, "CHUNK_ROWS", 1000)  # the rows' own pieces cut, too
    X, y, _ = recording
    whole = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    edges = [*range(0, len(y), cut), len(y)]
    pieces = [(X.iloc[a:b], y[a:b]) for a, b in zip(edges[:-1], edges[1:])]
    _same_model(whole, ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(pieces))


def test_files_read_piece_by_piece_give_the_fit_of_all_rows(recording, tmp_path):
    """Parquet files of a recording (tests running on from file to file) and CSV
    files of one test each: the model ``fit`` gives on the rows read whole."""
    pytest.importorskip("pyarrow")
    X, y, whole = recording
    frame = X.reset_index().assign(dx_um=y)
    for k, (a, b) in enumerate([(0, 1000), (1000, 2500), (2500, len(y))]):
        frame.iloc[a:b].to_parquet(tmp_path / f"part{k}.parquet")
    files = TestFiles(tmp_path, "dx_um", each="recording", rows=700)
    _same_model(whole, ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(files))
    one = tmp_path / "one"
    one.mkdir()
    for label, part in frame.groupby("test", sort=False):
        part.drop(columns="test").to_csv(one / f"{label}.csv", index=False)
    files = TestFiles(sorted(one.glob("*.csv")), "dx_um", rows=500)
    _same_model(whole, ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(files))


def test_pieces_that_cannot_be_one_recording_are_refused(recording):
    X, y, _ = recording
    model = ThermalTransferFunction(drivers=["spindle_rpm"])
    pieces = [(X.iloc[:100], y[:100]), (X.iloc[100:200], y[100:200])]
    with pytest.raises(ValueError, match="not a generator"):
        model.fit_chunks(iter(pieces))
    back = [(X.iloc[:1000], y[:1000]), (X.iloc[1000:1100], y[1000:1100]), (X.iloc[:10], y[:10])]
    with pytest.raises(ValueError, match="appears again in piece 2"):
        model.fit_chunks(back)
    with pytest.raises(ValueError, match=r"strictly increase.*piece 1"):
        model.fit_chunks([(X.iloc[:100], y[:100]), (X.iloc[50:150], y[50:150])])
    with pytest.raises(ValueError, match="T2_C"):
        model.fit_chunks([(X.iloc[:100], y[:100]), (X.iloc[100:200].drop(columns="T2_C"), y[:100])])


class _Changing:
    """Pieces that are not the same the second time they are read."""

    def __init__(self, X, y):
        self.X, self.y, self.reads = X, y, 0

    def __iter__(self):
        self.reads += 1
        n = 2000 if self.reads == 1 else 1900
        yield self.X.iloc[:n], self.y[:n]
        yield self.X.iloc[2000:4000], self.y[2000:4000]


def test_data_that_change_between_reads_are_refused(recording):
    X, y, _ = recording
    with pytest.raises(ValueError, match="changed during the fit"):
        ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(_Changing(X, y))


def test_a_long_frame_is_read_in_pieces_with_the_same_model(monkeypatch):
    """Above WHOLE_ROWS rows a frame is read piece by piece (no float copy of it): the
    same model, and an error in a later piece counts its rows from that piece."""
    from greyml.dynamic import _transfer

    X, y = _tiled(5, hours=40.0)
    whole = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    monkeypatch.setattr(_transfer, "WHOLE_ROWS", 700)
    _same_model(whole, ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y))
    bad = X.copy()
    bad.iloc[1500, 1] = np.nan
    with pytest.raises(
        ValueError, match=r"T1_C.*rows counted from row 1,400, the first of piece 2"
    ):
        ThermalTransferFunction(drivers=["spindle_rpm"]).fit(bad, y)


def test_rows_without_labels_or_clock_in_pieces_are_one_test_evenly_spaced():
    """No test level and no time level (sample_interval): the pieces are one test whose
    rows run on; the model of the rows stacked."""
    X, y = _tiled(1, hours=20.0)
    plain = X.reset_index(drop=True)
    model = ThermalTransferFunction(drivers=["spindle_rpm"], sample_interval=60.0)
    whole = model.fit(plain, y)
    pieces = [(plain.iloc[a : a + 500], y[a : a + 500]) for a in range(0, len(y), 500)]
    again = ThermalTransferFunction(drivers=["spindle_rpm"], sample_interval=60.0)
    np.testing.assert_array_equal(again.fit_chunks(pieces).feature_coef_, whole.feature_coef_)


def test_a_bad_cell_in_a_file_read_in_pieces_names_the_file(tmp_path):
    X, y = _tiled(3, hours=12.0)
    flat = X.reset_index().assign(dx_um=y)
    flat.loc[600, "T2_C"] = np.nan
    flat.iloc[:500].to_csv(tmp_path / "a.csv", index=False)
    flat.iloc[500:].to_csv(tmp_path / "b.csv", index=False)
    files = TestFiles(tmp_path, "dx_um", rows=300)
    with pytest.raises(ValueError, match=r"T2_C.*b\.csv, data rows 0-219\)"):
        ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(files)
