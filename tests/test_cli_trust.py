"""``greyml predict --interval`` and ``--probe`` (issue 28, item 5).

The bounds are the model's ``predict_interval``; replayed through the
compensator without a reading, every configuration of tests (separate tests,
one recording carried from the recording's zero or from each piece's start, a
clock that restarts in every piece, a test started at a given displacement)
gives batch ``predict`` to 1e-9; a reading corrects the rows from its time on
and not before; bad readings are one line naming the probe file's line, test
and time.
"""

import re

import numpy as np
import pandas as pd
import pytest

from greyml import GMC, ThermalTransferFunction, make_test_index
from greyml.cli import main
from greyml.controller import Compensator
from greyml.io import read_tests_csv, write_tests_csv
from greyml.persist import save_model
from greyml.preprocessing import RelativeToStart

STEP = 60.0
TARGET = "dx_um"


def _series(n_tests, seed, hours=6.0):
    """Heating and cooling tests in one stretch of time: the speed heats a sensor
    through a 30-min lag, the displacement is 2 µm/K of it plus a random-walk drift
    (an unmodelled slow effect: the error grows with the time since it was known)."""
    rng = np.random.default_rng(seed)
    per = int(hours * 3600 / STEP)
    rpm = np.concatenate(
        [np.where(np.arange(per) < per // 2, rng.uniform(1000, 4000), 0.0) for _ in range(n_tests)]
    )
    heat = np.zeros(rpm.size)
    for k in range(1, rpm.size):
        heat[k] = heat[k - 1] + (STEP / 1800.0) * (2e-3 * rpm[k] - heat[k - 1])
    T1 = 20.0 + heat + 0.01 * rng.standard_normal(rpm.size)
    T2 = 20.0 + 0.5 * np.sin(np.arange(rpm.size) / 40.0) + 0.01 * rng.standard_normal(rpm.size)
    drift = np.cumsum(0.08 * rng.standard_normal(rpm.size))
    y = 2.0 * (T1 - 20.0) + drift + 3.0
    return per, pd.DataFrame({"spindle_rpm": rpm, "T1_C": T1, "T2_C": T2, TARGET: y})


def _tests(prefix, n_tests, seed, clock):
    """``n_tests`` tests labelled ``prefix0`` …; ``clock="own"``: separate tests, each
    from 0 and measured from its own start; ``"one"``: one recording whose time runs
    on; ``"each"``: the same recording, its clock restarting in every piece."""
    per, frame = _series(n_tests, seed)
    labels = np.repeat([f"{prefix}{k}" for k in range(n_tests)], per)
    local = np.tile(STEP * np.arange(per), n_tests)
    times = STEP * np.arange(labels.size) if clock == "one" else local
    frame.index = make_test_index(labels, times)
    if clock == "own":  # each test its own heating from a machine at rest
        frame[TARGET] -= frame[TARGET].groupby(level="test").transform("first")
    return frame


def _model(**kw):
    params = dict(drivers=["spindle_rpm"], max_sensors=1, time_constants=[900.0, 2700.0])
    return ThermalTransferFunction(**{**params, **kw})


def _fit(frame, **kw):
    model = _model(**kw).fit(frame.drop(columns=TARGET), frame[TARGET])
    model.target_name_ = TARGET  # as greyml fit records it
    return model


CASES = {
    "separate tests": ("own", {}),
    "one recording": ("one", {}),
    "one recording, from each start": ("one", {"reference": "start"}),
    "restarting clocks": ("each", {"state": "carry"}),
}


@pytest.fixture(scope="module", params=list(CASES))
def case(request, tmp_path_factory):
    """A model file fitted on five tests and a data file of three new ones."""
    clock, kw = CASES[request.param]
    folder = tmp_path_factory.mktemp("trust")
    model = _fit(_tests("a", 5, seed=1, clock=clock), **kw)
    new = _tests("n", 3, seed=2, clock=clock)
    return {
        "name": request.param,
        "model": model,
        "model_file": save_model(model, folder / "m.greyml"),
        "new": new,
        "data": write_tests_csv(new, folder / "new.csv"),
        "folder": folder,
    }


@pytest.fixture(scope="module")
def separate(tmp_path_factory):
    folder = tmp_path_factory.mktemp("separate")
    model = _fit(_tests("a", 5, seed=1, clock="own"))
    new = _tests("n", 2, seed=3, clock="own")
    return {
        "model": model,
        "model_file": save_model(model, folder / "m.greyml"),
        "new": new,
        "data": write_tests_csv(new, folder / "new.csv"),
        "folder": folder,
    }


def _run(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


def _error(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert err.startswith("greyml predict: error: ") and err.count("\n") == 1, err
    return err


def _probes(path, frame):
    """A probe file of the rows of ``frame`` (test, time_s and the target)."""
    return write_tests_csv(frame[[TARGET]], path, overwrite=True)


def _inputs(frame):
    return frame.drop(columns=TARGET)


# -- --interval -----------------------------------------------------------------


def test_interval_writes_the_models_bounds_next_to_the_prediction(capsys, separate):
    out_csv = separate["folder"] / "iv.csv"
    argv = ["predict", separate["model_file"], separate["data"], "--out", out_csv]
    out = _run(capsys, [*argv, "--interval", "0.8"])
    written = read_tests_csv(out_csv)
    name = f"{TARGET}_since_start"  # separate tests: the change since each test's start
    assert list(written.columns) == [
        f"predicted_{name}",
        f"lower_{name}",
        f"upper_{name}",
        f"compensation_{name}",
    ]
    expected = separate["model"].predict_interval(_inputs(separate["new"]), coverage=0.8)
    np.testing.assert_allclose(written.to_numpy()[:, :3], expected, rtol=0, atol=1e-12)
    assert f"lower_{name} and upper_{name} (its 0.8 interval)" in out
    # the data file holds the measured target: each test's coverage is printed
    assert "80 % interval" in out
    new = separate["new"]
    for test, rows in new.groupby(level="test", sort=False):
        at = np.asarray(new.index.get_level_values("test") == test)
        pred, low = expected[at, 0], expected[at, 1]
        measured = rows[TARGET].to_numpy() - rows[TARGET].iloc[0]  # since each test's start
        inside = np.mean(np.abs(measured - pred) <= pred - low)
        line = next(s for s in out.splitlines() if s.split()[:1] == [test])
        assert line.split()[-2:] == [f"{100 * inside:.1f}", "%"]
    # a measured start for every test: the file's own reference, no suffix
    _run(capsys, [*argv, "--interval", "0.8", "--initial-displacement", "2.5", "--force"])
    written = read_tests_csv(out_csv)
    assert list(written.columns)[:3] == [
        f"predicted_{TARGET}",
        f"lower_{TARGET}",
        f"upper_{TARGET}",
    ]
    expected = separate["model"].predict_interval(
        _inputs(separate["new"]), coverage=0.8, initial_displacement=2.5
    )
    np.testing.assert_allclose(written.to_numpy()[:, :3], expected, rtol=0, atol=1e-12)


def test_tolerance_writes_the_trust_flag(capsys, separate):
    out_csv = separate["folder"] / "tol.csv"
    half = separate["model"].predict_interval(_inputs(separate["new"]), coverage=0.9)
    half = half[:, 2] - half[:, 0]
    tolerance = float(np.median(half))  # some rows within it, some not
    argv = ["predict", separate["model_file"], separate["data"], "--out", out_csv]
    out = _run(capsys, [*argv, "--interval", "0.9", "--tolerance", tolerance])
    trusted = read_tests_csv(out_csv)["trusted"].to_numpy()
    np.testing.assert_array_equal(trusted, (half <= tolerance).astype(int))
    assert 0 < trusted.sum() < trusted.size
    assert f"trusted (half-width at most {tolerance:g})" in out


def test_a_pipeline_ending_in_a_transfer_function_gives_its_interval(capsys, tmp_path):
    from sklearn.pipeline import Pipeline

    train, new = _tests("a", 4, seed=1, clock="own"), _tests("n", 2, seed=3, clock="own")
    model = Pipeline(
        [
            ("rises", RelativeToStart(columns=["T1_C", "T2_C"])),
            ("model", _model()),
        ]
    ).fit(_inputs(train), train[TARGET])
    model[-1].target_name_ = TARGET
    path, data = save_model(model, tmp_path / "p.greyml"), write_tests_csv(new, tmp_path / "n.csv")
    _run(capsys, ["predict", path, data, "--out", tmp_path / "o.csv", "--interval", "0.9"])
    written = read_tests_csv(tmp_path / "o.csv")
    rises = model[:-1].transform(_inputs(new))
    expected = model[-1].predict_interval(rises, coverage=0.9)
    np.testing.assert_allclose(written.to_numpy()[:, :3], expected, rtol=0, atol=1e-12)
    # the same rows replayed through the compensator, without a reading but the last
    probes = _probes(tmp_path / "probes.csv", new.iloc[[-1]])
    _run(capsys, ["predict", path, data, "--out", tmp_path / "r.csv", "--probe", probes])
    streamed = read_tests_csv(tmp_path / "r.csv").iloc[:-1, 0].to_numpy()
    np.testing.assert_allclose(streamed, expected[:-1, 0], rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    "flag, words", [("--interval", "gives no interval"), ("--probe", "takes no probe readings")]
)
def test_a_model_that_is_not_a_transfer_function(capsys, tmp_path, separate, flag, words):
    train = _tests("a", 2, seed=1, clock="own")
    gmc = GMC().fit(train[["T1_C"]], train[TARGET])
    path = save_model(gmc, tmp_path / "gmc.greyml")
    probes = _probes(tmp_path / "probes.csv", separate["new"].iloc[:2])
    value = "0.9" if flag == "--interval" else probes
    err = _error(
        capsys, ["predict", path, separate["data"], "--out", tmp_path / "o.csv", flag, value]
    )
    assert f"{flag}: the model" in err and f"(GMC) {words}; fit a transfer function" in err
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("coverage", ["1", "0", "-0.5", "1.5", "abc", "nan"])
def test_coverage_must_be_between_0_and_1(capsys, separate, tmp_path, coverage):
    code = main(
        [
            "predict",
            str(separate["model_file"]),
            str(separate["data"]),
            "--out",
            str(tmp_path / "o.csv"),
            "--interval",
            coverage,
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1
    assert f"--interval: expected a coverage between 0 and 1 (e.g. 0.9); got {coverage!r}" in err


def test_tolerance_needs_an_interval(capsys, separate, tmp_path):
    argv = ["predict", separate["model_file"], separate["data"], "--out", tmp_path / "o.csv"]
    err = _error(capsys, [*argv, "--tolerance", "2"])
    assert "--tolerance compares the interval's half-width" in err and "--interval" in err


def test_a_model_fitted_on_two_tests_has_no_calibration(capsys, tmp_path, separate):
    model = _fit(_tests("a", 2, seed=1, clock="own"))
    path = save_model(model, tmp_path / "two.greyml")
    argv = ["predict", path, separate["data"], "--out", tmp_path / "o.csv"]
    err = _error(capsys, [*argv, "--interval", "0.9"])
    assert "fewer than 3 tests" in err
    probes = _probes(tmp_path / "probes.csv", separate["new"].iloc[:2])
    err = _error(capsys, [*argv, "--probe", probes])
    assert "--probe: the model" in err and "fewer than 3 tests" in err


# -- --probe ---------------------------------------------------------------------


def test_replayed_without_readings_equals_predict(capsys, case):
    """Every row before the one reading (at the data's last row) is batch predict."""
    folder, new = case["folder"], case["new"]
    probes = _probes(folder / "last.csv", new.iloc[[-1]])
    base = ["predict", case["model_file"], case["data"], "--interval", "0.9"]
    _run(capsys, [*base, "--out", folder / "batch.csv", "--force"])
    out = _run(capsys, [*base, "--out", folder / "stream.csv", "--probe", probes, "--force"])
    batch = read_tests_csv(folder / "batch.csv")
    stream = read_tests_csv(folder / "stream.csv")
    assert list(stream.columns) == list(batch.columns)
    np.testing.assert_allclose(
        stream.iloc[:-1, 0], case["model"].predict(_inputs(new))[:-1], rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(stream.iloc[:-1, 0], batch.iloc[:-1, 0], rtol=0, atol=1e-9)
    assert abs(stream.iloc[-1, 0] - batch.iloc[-1, 0]) > 1e-6  # the reading moved it
    assert "corrected by 1 probe reading from" in out
    if case["name"] in ("separate tests", "one recording, from each start"):
        # each test's displacement known at its start: the compensator's interval is
        # the batch one until the reading
        np.testing.assert_allclose(stream.iloc[:-1, 1:3], batch.iloc[:-1, 1:3], rtol=0, atol=1e-9)


def test_replayed_from_a_given_displacement_equals_predict(capsys, case):
    """The first test after a reset, the last one carried in a recording."""
    folder, new = case["folder"], case["new"]
    labels = new.index.get_level_values("test")
    given = {labels[0]: 4.25, labels[-1]: -1.5}
    probes = _probes(folder / "last.csv", new.iloc[[-1]])
    start = ["--initial-displacement", ",".join(f"{t}={v}" for t, v in given.items())]
    argv = ["predict", case["model_file"], case["data"], "--out", folder / "s.csv", "--force"]
    _run(capsys, [*argv, *start, "--probe", probes])
    stream = read_tests_csv(folder / "s.csv").iloc[:-1, 0].to_numpy()
    batch = case["model"].predict(_inputs(new), initial_displacement=given)
    np.testing.assert_allclose(stream, batch[:-1], rtol=0, atol=1e-9)
    for label, value in given.items():
        assert stream[int(np.flatnonzero(labels == label)[0])] == pytest.approx(value, abs=1e-9)


def test_a_reading_corrects_the_rows_from_its_time_on(capsys, separate, tmp_path):
    new = separate["new"]
    model = separate["model"]
    batch = model.predict(_inputs(new))
    measured = new[TARGET].to_numpy()
    # one reading between rows 100 and 101 of the first test, off the model (not so far
    # off that the change detector fires)
    t100 = new.index[100][1]
    reading = measured[100] + 1.0
    probes = tmp_path / "probes.csv"
    probes.write_text(f"test,time_s,{TARGET}\nn0,{t100 + 20.0},{reading}\n", encoding="utf-8")
    argv = ["predict", separate["model_file"], separate["data"], "--out", tmp_path / "o.csv"]
    _run(capsys, [*argv, "--probe", probes, "--interval", "0.9"])
    written = read_tests_csv(tmp_path / "o.csv")
    pred, lower, upper = (written.iloc[:, k].to_numpy() for k in range(3))
    np.testing.assert_allclose(pred[:101], batch[:101], rtol=0, atol=1e-9)
    # from the row after the reading on, the compensator's observe at the reading's
    # own time (the model interpolated between the rows around it)
    comp = Compensator.from_model(model, row_columns=["time_s", *_inputs(new).columns])
    rows = np.column_stack([new.index.get_level_values("time_s"), _inputs(new).to_numpy()])
    first = new.index.get_level_values("test") == "n0"
    expected = []
    for k, row in enumerate(rows[first]):
        comp.update(row)
        if k == 101:
            comp.observe(t100 + 20.0, reading)
        expected.append(comp.status.correction)
    np.testing.assert_allclose(pred[first], expected, rtol=0, atol=1e-9)
    assert pred[101] - batch[101] > 0.3  # pulled towards the reading
    # the interval narrows at the reading, and the next test starts anew
    assert (upper - lower)[101] < (upper - lower)[100]
    np.testing.assert_allclose(pred[~first], batch[~first], rtol=0, atol=1e-9)


def test_hourly_readings_lower_the_error(capsys, separate, tmp_path):
    new = separate["new"]
    probes = _probes(tmp_path / "hourly.csv", new.iloc[::60])
    argv = ["predict", separate["model_file"], separate["data"], "--out", tmp_path / "o.csv"]
    out = _run(capsys, [*argv, "--probe", probes])
    pred = read_tests_csv(tmp_path / "o.csv").iloc[:, 0].to_numpy()
    measured = new[TARGET].to_numpy()
    batch = separate["model"].predict(_inputs(new))
    with_readings = np.sqrt(np.mean((pred - measured) ** 2))
    without = np.sqrt(np.mean((batch - measured) ** 2))
    assert with_readings < 0.9 * without, (with_readings, without)
    assert "corrected by 12 probe readings" in out
    assert "the change detector did not fire" in out


def test_a_drift_the_model_never_saw_fires_the_change_detector(capsys, separate, tmp_path):
    new = separate["new"]
    hourly = new.iloc[::60][[TARGET]].copy()
    hours = hourly.index.get_level_values("time_s").to_numpy() / 3600.0
    hourly[TARGET] += 8.0 * hours  # 8 µm/h more than the model says, from each start
    probes = write_tests_csv(hourly, tmp_path / "drift.csv")
    argv = ["predict", separate["model_file"], separate["data"], "--out", tmp_path / "o.csv"]
    out = _run(capsys, [*argv, "--probe", probes])
    assert (
        "the change detector fired" in out
        and "and recalibrated (after the readings at test 'n0'" in out
    )


@pytest.mark.parametrize(
    "text, match",
    [
        ("x9,60,1.0\n", r"line 2 of '.*probes\.csv' \(test 'x9', time_s 60\): test 'x9' is not in"),
        (
            "n0,99999,1.0\n",
            r"line 2 .*\(test 'n0', time_s 99999\): test 'n0' of '.*new\.csv' runs from time_s 0 "
            r"to 21540 s; a reading at 99999 s is not within it",
        ),
        (
            "n1,60,1.0\nn0,120,1.0\n",
            r"line 3 .*\(test 'n0', time_s 120\): the reading of test 'n0' comes after readings "
            r"of test 'n1'",
        ),
        (
            "n0,60,5000\n",
            r"line 2 .*\(test 'n0', time_s 60\): Compensator.observe: the reading 5000 at "
            r"time_s = 60 s is beyond ±1000",
        ),
        ("n0,60,\n", r"probe reading column 'dx_um' has no value \(NaN\) at line 2"),
    ],
)
def test_bad_readings_are_one_line(capsys, separate, tmp_path, text, match):
    probes = tmp_path / "probes.csv"
    probes.write_text(f"test,time_s,{TARGET}\n{text}", encoding="utf-8")
    argv = ["predict", separate["model_file"], separate["data"], "--out", tmp_path / "o.csv"]
    err = _error(capsys, [*argv, "--probe", probes])
    assert re.search(match, err), err
    assert not (tmp_path / "o.csv").exists()


def test_a_probe_file_without_the_target(capsys, separate, tmp_path):
    probes = tmp_path / "probes.csv"
    probes.write_text("test,time_s,dz_um\nn0,60,1.0\n", encoding="utf-8")
    argv = ["predict", separate["model_file"], separate["data"], "--out", tmp_path / "o.csv"]
    err = _error(capsys, [*argv, "--probe", probes])
    assert "has no column 'dx_um' (the model's target)" in err and "its columns: dz_um" in err


def test_the_probe_file_is_read_with_the_data_files_options(capsys, separate, tmp_path):
    """--test-column and --time-unit apply to both files."""
    new = separate["new"]
    data = new.reset_index().rename(columns={"test": "cycle"})
    data["time_s"] /= 60.0
    data.to_csv(tmp_path / "cycles.csv", index=False)
    probes = tmp_path / "probes.csv"
    probes.write_text(
        f"cycle,time_s,{TARGET}\nn0,100.5,{new[TARGET].iloc[100]}\n", encoding="utf-8"
    )
    argv = ["predict", separate["model_file"], tmp_path / "cycles.csv", "--out", tmp_path / "o.csv"]
    _run(capsys, [*argv, "--probe", probes, "--test-column", "cycle", "--time-unit", "min"])
    _run(
        capsys, [*argv[:-1], tmp_path / "plain.csv", "--test-column", "cycle", "--time-unit", "min"]
    )
    read = read_tests_csv(tmp_path / "o.csv").iloc[:, 0].to_numpy()
    plain = read_tests_csv(tmp_path / "plain.csv").iloc[:, 0].to_numpy()
    np.testing.assert_allclose(read[:101], plain[:101], rtol=0, atol=1e-9)
    assert not np.allclose(read[101:120], plain[101:120])  # the reading at 100.5 min
