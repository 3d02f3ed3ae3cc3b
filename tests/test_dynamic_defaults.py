"""The dynamic models right by default: a recording read as it is logged carries its
lags across its pieces, the reference is named, a test without history warns, the
compensator agrees with predict, and the command line reaches the same model."""

import io
import math
import os
import re
import warnings
from contextlib import redirect_stderr, redirect_stdout

import numpy as np
import pandas as pd
import pytest

from greyml import LagFeatures, ThermalTransferFunction, make_test_index
from greyml.cli import main
from greyml.controller import Compensator
from greyml.dynamic._kernels import lag_filter
from greyml.exceptions import WarmStartWarning
from greyml.io import read_tests_csv, write_tests_csv

STEP = 60.0


def _recording(n_cycles=4, hours=6.0, seed=3, clock="one"):
    """A recording of spindle cycles (2 h on, the rest off) cut into cycles.

    The displacement follows the speed through a 45-min and a 405-min lag of the
    whole recording, plus 0.8 µm/K of a sensor that is itself a 20-min lag of
    the speed, from the recording's zero. ``clock="one"``: time_s runs on;
    ``"each"``: every cycle's clock starts at 0 (the same rows).
    """
    rng = np.random.default_rng(seed)
    per = int(hours * 3600 / STEP)
    t = STEP * np.arange(n_cycles * per)
    speeds = 1000.0 * (1 + np.arange(n_cycles) % 3)
    rpm = np.concatenate([np.where(np.arange(per) < per // 3, v, 0.0) for v in speeds])
    lags, _ = lag_filter(
        rpm[:, None],
        np.full(t.size, STEP),
        np.array([1200.0, 2700.0, 24300.0]),
        [(0, t.size)],
        initial=np.zeros((1, 3)),
    )
    T1 = 20.0 + 2e-3 * lags[:, 0, 0]
    T2 = 20.0 + np.cumsum(rng.normal(0, 0.01, t.size))
    y = 1e-3 * lags[:, 0, 1] + 2e-3 * lags[:, 0, 2] + 0.8 * (T1 - 20.0)
    labels = np.repeat([f"c{i + 1}" for i in range(n_cycles)], per)
    times = t if clock == "one" else np.tile(STEP * np.arange(per), n_cycles)
    X = pd.DataFrame(
        {"spindle_rpm": rpm, "T1_C": T1, "T2_C": T2}, index=make_test_index(labels, times)
    )
    return X, pd.Series(y, index=X.index, name="dz_um")


def _model(**kw):
    return ThermalTransferFunction(drivers=["spindle_rpm"], alphas=[1e-9], **kw)


def test_one_clock_carries_and_takes_the_recordings_reference():
    X, y = _recording()
    model = _model().fit(X, y)
    assert model.state_ == "carry" and model.reference_ == "recording"
    carried = _model(state="carry", reference="recording").fit(X, y)
    np.testing.assert_allclose(model.predict(X), carried.predict(X), rtol=0, atol=1e-12)
    # the same rows with every cycle's clock starting at 0: separate tests, restarted
    Xs, ys = _recording(clock="each")
    separate = _model().fit(Xs, ys)
    assert separate.state_ == "restart" and separate.reference_ == "start"
    # displacements zeroed at every test's start: the tests' own reference
    y0 = y.groupby(level="test", sort=False).transform("first")
    assert _model().fit(X, y - y0).reference_ == "start"


def test_carried_default_beats_the_restarted_one_on_a_held_out_cycle():
    X, y = _recording()
    held = X.index.get_level_values("test") == "c3"
    w = (~held).astype(float)
    carried = _model().fit(X, y, sample_weight=w)
    restarted = _model(state="restart", reference="start").fit(X, y, sample_weight=w)

    def change_rmse(pred):
        p, t = pred[held], y[held].to_numpy()
        return math.sqrt(np.mean(((p - p[0]) - (t - t[0])) ** 2))

    # the true model is in the carried model's span: recovered to the rounding
    assert change_rmse(carried.predict(X)) < 1e-3
    assert change_rmse(restarted.predict(X)) > 0.05


def test_a_gap_longer_than_the_lags_restarts_the_next_piece():
    X, y = _recording()
    keep = X.index.get_level_values("test") != "c2"  # a 6-h hole between c1 and c3
    model = _model(time_constants=[900.0], driver_time_constants=[2700.0])
    model.fit(X[keep], y[keep])
    # c3's lags restart, but it is still a piece of the one recording (its
    # clock runs on), so its displacement is still from the recording's zero
    assert model.state_ == "restart" and model.reference_ == "recording"
    # and within a test, the same gap is refused, naming the test and the time
    cut = X.drop(X.index[30:330])
    with pytest.raises(ValueError, match=r"test 'c1' has a sampling gap of 301 min before time_s"):
        _model(time_constants=[900.0]).fit(cut, y.loc[cut.index])


def test_drivers_start_idle_without_history():
    # one test, spindle on from the first row: the driver's lag starts at 0
    t = STEP * np.arange(120)
    X = pd.DataFrame(
        {"spindle_rpm": np.full(t.size, 3000.0)}, index=make_test_index(["a"] * t.size, t)
    )
    a = math.exp(-STEP / 900.0)
    expected = 3000.0 * (1 - a ** np.arange(t.size))  # 0 at the first row
    model = ThermalTransferFunction(
        drivers=["spindle_rpm"],
        driver_time_constants=[900.0],
        driver_powers=(1,),
        reference="recording",
        alphas=[1e-12],
    ).fit(X, 1e-3 * expected + 0.5)
    np.testing.assert_allclose(model.predict(X), 1e-3 * expected + 0.5, atol=1e-6)


def test_a_test_alone_mid_clock_warns_and_takes_an_initial_displacement():
    X, y = _recording()
    model = _model().fit(X, y)
    alone = X.loc[["c3"]]
    with pytest.warns(WarmStartWarning, match=r"test 'c3' starts at time_s = 43200 s of its clock"):
        cold = model.predict(alone)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warm = model.predict(alone, initial_displacement={"c3": float(y.loc["c3"].iloc[0])})
        whole = model.predict(X)  # from the recording's start: no warning
    np.testing.assert_allclose(warm - warm[0], cold - cold[0], atol=1e-12)
    assert warm[0] == pytest.approx(y.loc["c3"].iloc[0])
    with pytest.raises(ValueError, match=r"names the test 'c9', which is not in X"):
        model.predict(alone, initial_displacement={"c9": 1.0})
    with pytest.raises(ValueError, match=r"initial displacement of 'c3' must be a finite"):
        model.predict(alone, initial_displacement={"c3": np.nan})
    assert np.isfinite(whole).all()


@pytest.mark.parametrize("clock", ["one", "each"])
def test_compensator_streams_as_predict_from_any_test_start(clock):
    X, y = _recording(clock=clock, n_cycles=3)
    model = _model(max_sensors=1).fit(X, y)
    times = X.index.get_level_values("time_s").to_numpy()
    rows = np.column_stack([times, X.to_numpy()])
    order = ["time_s", *X.columns]
    if clock == "one":
        # the whole recording in one stream equals predict on all of it
        comp = Compensator.from_model(model, row_columns=order)
        streamed = np.array([comp.update(r) for r in rows])
        np.testing.assert_allclose(streamed, model.predict(X), rtol=0, atol=1e-9)
    # from any test's start, after reset: predict on that test alone
    comp = Compensator.from_model(model, row_columns=order)
    tests = X.index.get_level_values("test")
    for label in ("c1", "c2", "c3"):
        comp.reset()
        part = tests == label
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", WarmStartWarning)
            batch = model.predict(X[part])
        streamed = np.array([comp.update(r) for r in rows[part]])
        np.testing.assert_allclose(streamed, batch, rtol=0, atol=1e-9)


def test_compensator_refuses_a_gap_as_predict_does_and_steps_restarting_clocks():
    X, y = _recording(n_cycles=2)
    model = _model(max_sensors=1).fit(X, y)
    comp = Compensator.from_model(model)
    first = X.iloc[0]
    comp.update({"time_s": 0.0, **first})
    with pytest.raises(ValueError) as streamed:
        comp.update({"time_s": 40000.0, **first})
    cut = X.iloc[[0, 1]].copy()
    cut.index = make_test_index(["c1", "c1"], [0.0, 40000.0])
    with pytest.raises(ValueError) as batch:
        model.predict(cut)
    core = r"sampling gap of 40000 s before time_s = 40000 s.*longer than the largest time constant"
    assert re.search(core, str(streamed.value)) and re.search(core, str(batch.value))
    # a recording whose clock restarts in each piece: stream it with the nominal step
    Xs, ys = _recording(n_cycles=2, clock="each")
    carried = _model(max_sensors=1, state="carry").fit(Xs, ys)
    comp = Compensator.from_model(carried)
    assert comp.nominal_step_s == STEP
    streamed = [
        comp.update({"time_s": t, **r}) for (_, t), r in zip(Xs.index, Xs.to_dict("records"))
    ]
    np.testing.assert_allclose(streamed, carried.predict(Xs), rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match="time_s goes back"):
        plain = Compensator.from_model(_model(max_sensors=1).fit(Xs, ys))
        for (_, t), r in zip(Xs.index, Xs.to_dict("records")):
            plain.update({"time_s": t, **r})


def test_lag_features_carry_along_one_clock_by_default():
    X, _ = _recording(n_cycles=2)
    lags = LagFeatures([600.0]).fit(X)
    assert lags.terms_[-1] == ("T2_C", 1.0, 600.0)
    whole = lags.transform(X)
    carried = LagFeatures([600.0], state="carry").fit_transform(X)
    np.testing.assert_array_equal(whole.to_numpy(), carried.to_numpy())
    Xs, _ = _recording(n_cycles=2, clock="each")
    restarted = LagFeatures([600.0], state="restart").fit_transform(Xs)
    np.testing.assert_array_equal(
        LagFeatures([600.0]).fit_transform(Xs).to_numpy(), restarted.to_numpy()
    )


# ------------------------------------------------------------------------------
# Reading a recording as it is logged, and the command line
# ------------------------------------------------------------------------------


def _logged_csv(path, X, y):
    """The recording as a logger writes it: a 'cycle' column, the clock running on."""
    frame = pd.concat([X, y], axis=1).reset_index()
    frame = frame.rename(columns={"test": "cycle"})[["time_s", "cycle", *X.columns, y.name]]
    frame["cycle"] = frame["cycle"].str[1:].astype(int)
    frame.to_csv(path, index=False)
    return path


def test_read_tests_csv_takes_the_test_column(tmp_path):
    X, y = _recording(n_cycles=2)
    path = _logged_csv(tmp_path / "log.csv", X, y)
    frame = read_tests_csv(path, test_column="cycle")
    assert list(dict.fromkeys(frame.index.get_level_values("test"))) == ["1", "2"]
    assert frame.index.get_level_values("time_s")[X.shape[0] // 2] == X.index[X.shape[0] // 2][1]
    with pytest.raises(ValueError, match=r"has no 'test' column.*pass test_column='cycle'"):
        read_tests_csv(path)
    with pytest.raises(ValueError, match=r"has no 'run' column"):
        read_tests_csv(path, test_column="run")
    both = pd.read_csv(path)
    both["test"] = "x"
    both.to_csv(tmp_path / "both.csv", index=False)
    with pytest.raises(ValueError, match=r"has a 'test' column as well as the test column 'cycle'"):
        read_tests_csv(tmp_path / "both.csv", test_column="cycle")
    with pytest.raises(ValueError, match=r"test_column must name the column of test labels"):
        read_tests_csv(path, test_column="time_s")


def _run(argv):
    out = io.StringIO()
    with redirect_stdout(out):
        code = main([str(a) for a in argv])
    return code, out.getvalue()


def _cli_equals_api(path, target, train, held, tmp_path):
    model_file, pred_file = tmp_path / "m.greyml", tmp_path / "pred.csv"
    code, fitted = _run(
        [
            "fit",
            path,
            "--test-column",
            "cycle",
            "--target",
            target,
            "--model",
            "transfer-function",
            "--drivers",
            "spindle_rpm",
            "--max-sensors",
            "5" if "ch" in target else "1",
            "--train-tests",
            ",".join(train),
            "--out",
            model_file,
        ]
    )
    assert code == 0, fitted
    assert "displacement from the recording's zero" in fitted
    code, predicted = _run(
        ["predict", model_file, path, "--test-column", "cycle", "--out", pred_file]
    )
    assert code == 0
    assert "displacement from the recording's zero" in predicted
    X = read_tests_csv(path, test_column="cycle")
    inputs = [c for c in X.columns if not c.endswith("_um") and c != "dz_um"]
    tests = X.index.get_level_values("test")
    budget = 5 if "ch" in target else 1
    api = ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=budget)
    api.fit(X.loc[np.isin(tests, train), inputs], X.loc[np.isin(tests, train), target])
    expected = api.predict(X[inputs])
    written = read_tests_csv(pred_file)
    np.testing.assert_allclose(
        written[f"predicted_{target}"].to_numpy(), expected, rtol=0, atol=1e-6
    )
    part = tests == held
    assert np.abs(written[f"predicted_{target}"].to_numpy()[part] - expected[part]).max() < 1e-6
    # the held-out test's printed RMSE is the written file's, in the reference named
    error = written[f"predicted_{target}"].to_numpy()[part] - X[target].to_numpy()[part]
    rmse = math.sqrt(np.mean(error**2))
    row = re.search(rf"^\s*{held}\s+\d+\s+([0-9.e+-]+)", predicted, flags=re.MULTILINE)
    assert float(row.group(1)) == pytest.approx(rmse, rel=5e-3)


def test_cli_fits_and_predicts_a_logged_recording_as_the_api(tmp_path):
    X, y = _recording()
    path = _logged_csv(tmp_path / "log.csv", X, y)
    _cli_equals_api(path, "dz_um", ["1", "2", "3"], "4", tmp_path)


def test_cli_on_caiviac_equals_the_api(tmp_path):
    from conftest import caiviac_csv_or_skip

    _cli_equals_api(os.fspath(caiviac_csv_or_skip()), "ch1_um", ["1", "2", "3", "4"], "5", tmp_path)


def _fit_argv(path, out, *extra):
    """``greyml fit`` of a transfer function of the speed on ``path``'s dz_um."""
    return [
        "fit",
        path,
        "--target",
        "dz_um",
        "--model",
        "transfer-function",
        "--drivers",
        "spindle_rpm",
        *extra,
        "--out",
        out,
    ]


def test_cli_reaches_every_setting(tmp_path):
    X, y = _recording(n_cycles=3)
    path = write_tests_csv(pd.concat([X, y], axis=1), tmp_path / "rec.csv")
    model_file = tmp_path / "m.greyml"
    code, out = _run(
        _fit_argv(
            path,
            model_file,
            "--state",
            "restart",
            "--reference",
            "start",
            "--selection",
            "stable",
            "--time-constants",
            "600,3600",
            "--driver-time-constants",
            "2700",
        )
    )
    assert code == 0, out
    from greyml.persist import load_model

    model = load_model(model_file)
    assert (model.state, model.reference, model.selection) == ("restart", "start", "stable")
    np.testing.assert_array_equal(model.time_constants_, [600.0, 3600.0])
    np.testing.assert_array_equal(model.driver_time_constants_, [2700.0])
    assert "as its change since each test's first row" in out


def test_cli_says_when_nothing_is_held_out_and_when_time_looks_like_minutes(tmp_path):
    X, y = _recording(n_cycles=2)
    frame = pd.concat([X, y], axis=1)
    path = write_tests_csv(frame, tmp_path / "two.csv")
    argv = _fit_argv(path, tmp_path / "m.greyml", "--max-sensors", "1")
    err = io.StringIO()
    with redirect_stderr(err):
        code, out = _run(argv)
    assert code == 0
    assert "fewer than 3 tests, so none is held out" in out
    assert err.getvalue() == ""
    # the same file with time_s in hours, read as seconds
    minutes = frame.copy()
    minutes.index = make_test_index(
        minutes.index.get_level_values("test"), minutes.index.get_level_values("time_s") / 3600.0
    )
    path = write_tests_csv(minutes, tmp_path / "minutes.csv")
    argv[1], argv[-1] = path, tmp_path / "m2.greyml"
    err = io.StringIO()
    with redirect_stderr(err):
        code, out = _run(argv)
    assert code == 0
    assert "steps by 0.0166667 s and its tests last 11.9667 s in all" in err.getvalue()
    assert "--time-unit min" in err.getvalue()
