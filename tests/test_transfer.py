"""ThermalTransferFunction: known gains and time constants recovered, sensors chosen,
held-out scores exact, terms that stream, clear messages for bad input."""

import io
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from greyml import LagFeatures, ThermalTransferFunction, make_test_index
from greyml.controller import Compensator
from greyml.exceptions import UnderdeterminedWarning

STEP = 60.0


def _lag(x, tau, dt=STEP, s0=None):
    """A plain first-order lag from rest at the first value (the reference recursion)."""
    a = np.exp(-dt / tau)
    out = np.empty_like(x)
    s = x[0] if s0 is None else s0
    for k, v in enumerate(x):
        if k or s0 is not None:
            s = a * s + (1 - a) * v
        out[k] = s
    return out


def _idle_lag(x, tau, dt=STEP):
    """A lag at 0 at the first row (a heat source that was off before the test)."""
    a = np.exp(-dt / tau)
    out = np.zeros_like(x)
    for k in range(1, x.size):
        out[k] = a * out[k - 1] + (1 - a) * x[k]
    return out


def _tests(n_tests=4, hours=6.0, seed=0):
    """Tests with a spindle (on then off) and five sensors; y from known transfer functions."""
    rng = np.random.default_rng(seed)
    frames, ys = [], []
    speeds = [1000.0, 3000.0, 2000.0, 4000.0, 2500.0][:n_tests]
    for i, rpm in enumerate(speeds):
        t = np.arange(0.0, hours * 3600, STEP)
        n = np.where(t < hours * 1800, rpm, 0.0)
        heat = _lag(n, 1800.0)
        T = {
            "T1_C": 20 + 0.002 * heat + 0.02 * rng.standard_normal(t.size),
            "T2_C": 20 + 0.6 * np.sin(t / 1500 + i),
            "T3_C": 20 + np.cumsum(rng.standard_normal(t.size)) * 0.02,
            "T4_C": 20 + 0.3 * np.cos(t / 900 + 2 * i),
            "T5_C": 20 + np.cumsum(rng.standard_normal(t.size)) * 0.02,
        }
        y = (
            0.8 * (T["T1_C"] - T["T1_C"][0])
            + 3.0 * (_lag(T["T2_C"], 900.0) - T["T2_C"][0])
            + 1e-3 * _idle_lag(n, 2700.0)
            + 2e-4 * n
        )
        index = make_test_index([f"t{i}"] * t.size, t)
        frames.append(pd.DataFrame({"spindle_rpm": n, **T}, index=index))
        ys.append(pd.Series(y, index=index, name="dx_um"))
    return pd.concat(frames), pd.concat(ys)


@pytest.fixture(scope="module")
def data():
    return _tests()


def _model(**kw):
    base = dict(
        drivers=["spindle_rpm"],
        time_constants=[900.0, 2700.0],
        driver_time_constants=[2700.0],
        driver_powers=(1,),
        alphas=[1e-9],
    )
    base.update(kw)
    return ThermalTransferFunction(**base)


def test_known_gains_recovered(data):
    X, y = data
    model = _model(max_sensors=2).fit(X, y)
    assert sorted(model.selected_sensors_) == ["T1_C", "T2_C"]
    g = model.gains_
    assert g.loc[("spindle_rpm", 1), "static"] == pytest.approx(2e-4, abs=1e-7)
    assert g.loc[("spindle_rpm", 1), "lag 45 min"] == pytest.approx(1e-3, abs=1e-6)
    assert g.loc[("T1_C", 1), "static"] == pytest.approx(0.8, abs=1e-4)
    assert g.loc[("T2_C", 1), "lag 15 min"] == pytest.approx(3.0, abs=1e-4)
    assert g.loc[("T2_C", 1), "lag 45 min"] == pytest.approx(0.0, abs=1e-4)
    # relative_to_start: the change since each test's first row
    y0 = y.groupby(level="test", sort=False).transform("first")
    np.testing.assert_allclose(model.predict(X), (y - y0).to_numpy(), atol=1e-4)


def test_selection_picks_the_true_sensors_in_order(data):
    X, y = data
    model = _model(max_sensors=4).fit(X, y)
    # T2 (through a lag, 3 µm/K) and T1 (0.8 µm/K) explain y; the others add nothing
    # but rounding (held-out RMSE 1.3e-7 -> 4.5e-8 µm), which selects no sensor
    assert model.selected_sensors_ == ["T2_C", "T1_C"]
    path = model.selection_
    assert path["sensor"].tolist()[1:3] == ["T2_C", "T1_C"]
    assert path["held_out_rmse"].iloc[2] < 1e-3 < path["held_out_rmse"].iloc[1]


def test_time_constants_fitted_by_variable_projection(data):
    X, y = data
    # sensors start from the default bank (5, 15, 45, 135 min) and the driver's
    # one lag from 4000 s; the true ones are 900 s (T2) and 2700 s (speed)
    model = ThermalTransferFunction(
        drivers=["spindle_rpm"],
        max_sensors=2,
        time_constants="fit",
        driver_time_constants=[4000.0],
        driver_powers=(1,),
        alphas=[1e-9],
    ).fit(X, y)
    assert sorted(model.selected_sensors_) == ["T1_C", "T2_C"]
    assert model.driver_time_constants_[0] == pytest.approx(2700.0, rel=0.02)
    # the lag that carries T2's 3 µm/K sits at 900 s
    g = model.gains_.loc[("T2_C", 1)].drop("static").dropna()
    j = int(np.argmax(np.abs(g.to_numpy())))
    assert abs(g.iloc[j]) > 1.0
    assert model.time_constants_[j] == pytest.approx(900.0, rel=0.02)
    assert model.cv_score_ < 1e-3


def _refit_rmses(X, y):
    """Held-out RMSE of each test, the model refitted without it (every sensor, alpha 1e-2)."""
    rmses = []
    for held in dict.fromkeys(X.index.get_level_values("test")):
        train = X.index.get_level_values("test") != held
        part = _model(max_sensors=None, alphas=[1e-2], selection="forward").fit(X[train], y[train])
        pred = part.predict(X[~train])
        y_held = y[~train].to_numpy()
        rmses.append(np.sqrt(np.mean((pred - (y_held - y_held[0])) ** 2)))
    return rmses


def test_held_out_score_equals_refits_on_whole_tests(data):
    X, y = data
    model = _model(max_sensors=None, alphas=[1e-2], selection="forward").fit(X, y)
    rmses = _refit_rmses(X, y)
    assert rmses[0] > 0.01  # the penalty matters here
    assert model.cv_score_ == pytest.approx(np.mean(rmses), rel=1e-6)


def test_penalty_chosen_on_held_out_tests(data):
    X, y = data
    noisy = y + np.random.default_rng(1).standard_normal(len(y)) * 0.5
    alphas = [1e-8, 1e-4, 1e-1, 10.0]
    model = _model(alphas=alphas, selection="forward").fit(X, noisy)
    scores = []
    for a in alphas:
        scores.append(_model(alphas=[a], selection="forward").fit(X, noisy).cv_score_)
    assert model.alpha_ == alphas[int(np.argmin(scores))]
    assert model.cv_score_ == pytest.approx(min(scores))


def test_zero_weight_test_is_left_out(data):
    X, y = data
    keep = X.index.get_level_values("test") != "t3"
    full = _model(max_sensors=3).fit(X[keep], y[keep])
    weighted = _model(max_sensors=3).fit(X, y, sample_weight=keep.astype(float))
    assert weighted.selected_sensors_ == full.selected_sensors_
    np.testing.assert_allclose(weighted.feature_coef_, full.feature_coef_, rtol=1e-8, atol=1e-12)


def test_carry_runs_the_lags_across_tests():
    # one recording cut in two: with carried state the second piece continues the lag
    t = np.arange(0.0, 4 * 3600, STEP)
    n = np.where((t > 1800) & (t < 9000), 3000.0, 0.0)
    y = 1e-3 * _lag(n, 2700.0)
    half = t.size // 2
    labels = ["a"] * half + ["b"] * (t.size - half)
    times = np.concatenate([t[:half], t[half:] - t[half]])
    X = pd.DataFrame({"spindle_rpm": n}, index=make_test_index(labels, times))
    model = ThermalTransferFunction(
        drivers=["spindle_rpm"],
        driver_time_constants=[2700.0],
        driver_powers=(1,),
        state="carry",
        reference="recording",
        alphas=[1e-9],
    ).fit(X, y)
    assert model.gains_.loc[("spindle_rpm", 1), "lag 45 min"] == pytest.approx(1e-3, rel=1e-4)
    np.testing.assert_allclose(model.predict(X), y, atol=1e-4)
    # restarted at b's first row, the lag would jump: the fit is visibly worse
    restart = model.set_params(state="restart").fit(X, y)
    assert np.abs(restart.predict(X) - y).max() > 0.1


def _stream(terms, intercept, relative, frame, idle=("spindle_rpm",)):
    """The agreed Compensator recursion, row by row (written out, independent of greyml.dynamic.Compensator)."""
    state, prev_t, first = {}, None, None
    out = []
    for (_, t), row in zip(frame.index, frame.to_dict("records")):
        total = intercept
        for name, power, tau, weight in terms:
            x = row[name] ** power
            if tau is None:
                value = x
            else:
                key = (name, power, tau)
                if key not in state:
                    state[key] = 0.0 if name in idle else x
                else:
                    a = np.exp(-(t - prev_t) / tau)
                    state[key] = a * state[key] + (1 - a) * x
                value = state[key]
            total += weight * value
        if first is None:
            first = total
        out.append(total - first if relative else total)
        prev_t = t
    return np.array(out)


@pytest.mark.parametrize("relative", [True, False])
def test_terms_stream_equal_to_predict(data, relative):
    X, y = data
    model = ThermalTransferFunction(
        drivers=["spindle_rpm"], max_sensors=3, reference="start" if relative else "recording"
    ).fit(X, y)
    one = X.xs("t2", level="test", drop_level=False)
    streamed = _stream(model.terms_, model.intercept_, relative, one)
    np.testing.assert_allclose(streamed, model.predict(one), rtol=0, atol=1e-9)


def test_compensator_equals_predict(data):
    X, y = data
    model = ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=2).fit(X, y)
    one = X.xs("t1", level="test", drop_level=False)
    comp = Compensator.from_model(model)
    out = [
        comp.update({**row, "time_s": t}) for (_, t), row in zip(one.index, one.to_dict("records"))
    ]
    np.testing.assert_allclose(out, model.predict(one), rtol=0, atol=1e-9)


def test_step_response_and_describe(data, capsys):
    X, y = data
    model = _model(max_sensors=2).fit(X, y)
    r = model.step_response("spindle_rpm", times=[0.0, 2700.0, 1e6])
    # 1000 rpm: 0.2 µm at once, + 1 µm through the 45-min lag
    assert model.step_sizes_["spindle_rpm"] == 1000.0
    np.testing.assert_allclose(r.to_numpy(), [0.2, 0.2 + 1.0 * (1 - np.exp(-1)), 1.2], atol=2e-4)
    r2 = model.step_response("T2_C", times=[900.0])
    assert r2.iloc[0] == pytest.approx(3.0 * (1 - np.exp(-1)), abs=1e-3)
    text = model.describe()
    # one line per input, the driver first, then the sensors in the order selected
    assert capsys.readouterr().out == text + "\n"
    lines = text.splitlines()
    assert [line.split(":")[0] for line in lines[:-2]] == ["spindle_rpm", *model.selected_sensors_]
    # how far to trust it: four tests, so the Gaussian quantile
    assert (
        lines[-2].startswith("90 % interval: ±")
        and "(from 4 held-out tests; gaussian)" in lines[-2]
    )
    # and how the training tests started: each on a clock of its own, not at rest
    assert lines[-1] == "training tests without history, their lags assumed at rest: t0, t1, t2, t3"
    assert model.selected_sensors_ == ["T2_C", "T1_C"]
    # the gains _tests() made y with: 2e-4 µm/rpm at once and 1e-3 µm/rpm through a
    # 45-min lag, 3 µm/K through a 15-min lag for T2, 0.8 µm/K at once for T1
    spindle = (1000 * 2e-4, 1000 * (2e-4 + 1e-3), 1000 * (2e-4 + 1e-3 * (1 - np.exp(-1))))
    t2_45 = 3.0 * (1 - np.exp(-2700.0 / 900.0))
    assert lines[0] == (
        f"spindle_rpm: {spindle[1]:.3g} µm per 1000 rpm at steady state, {spindle[0]:.3g} µm "
        f"at once, {spindle[2]:.3g} µm after 45 min; 63 % of the lagged part within 45 min"
    )
    assert lines[1].startswith("T2_C: 3 µm per 1 K at steady state, ")
    assert lines[1].endswith(f" {t2_45:.3g} µm after 45 min; 63 % of the lagged part within 15 min")
    assert lines[2].startswith("T1_C: 0.8 µm per 1 K at steady state, 0.8 µm at once, 0.8 µm after")
    # file= takes the lines instead of standard output
    buffer = io.StringIO()
    assert model.describe(unit="mm", file=buffer) == buffer.getvalue().rstrip("\n")
    assert capsys.readouterr().out == ""
    assert buffer.getvalue().startswith("spindle_rpm: 1.2 mm per 1000 rpm")
    with pytest.raises(ValueError, match="'T9_C' is not an input"):
        model.step_response("T9_C")


# ------------------------------------------------------------------------------
# Bad input
# ------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [0.0, -5.0, np.nan, np.inf])
def test_bad_time_constant(data, bad):
    X, y = data
    with pytest.raises(ValueError, match=r"'time_constants'.*time constant .* not a finite"):
        ThermalTransferFunction(time_constants=[300.0, bad]).fit(X, y)


def test_gap_longer_than_largest_time_constant(data):
    X, y = data
    cut = X.drop(X.index[400:460])
    with pytest.raises(
        ValueError,
        match=r"test 't1' has a sampling gap of 61 min before time_s = 6000 s \(row 400\), "
        r"longer than the largest time constant \(15 min\)",
    ):
        ThermalTransferFunction(time_constants=[300.0, 900.0]).fit(cut, y.loc[cut.index])
    # drivers get a slower lag (3 x 900 s) by default: the gap is measured against it
    with pytest.raises(ValueError, match=r"longer than the largest time constant \(45 min\)"):
        ThermalTransferFunction(drivers=["spindle_rpm"], time_constants=[300.0, 900.0]).fit(
            cut, y.loc[cut.index]
        )
    # and at predict, against the fitted model's
    model = ThermalTransferFunction(time_constants=[300.0, 900.0]).fit(X, y)
    with pytest.raises(ValueError, match=r"test 't1' has a sampling gap of 61 min"):
        model.predict(cut)


def test_fewer_rows_than_gains_fits_with_the_penalty_and_warns():
    X, y = _tests(n_tests=1, hours=0.25)
    # one test whose displacement does not start at 0: the recording's reference, an
    # intercept; 2 x 6 driver gains + 5 x 5 sensor gains + 1 = 38 for 15 rows
    with pytest.warns(
        UnderdeterminedWarning,
        match=r"^ThermalTransferFunction is under-determined: 15 samples in 1 test\(s\) give "
        r"15 equations for 38 coefficients\. The ridge penalty keeps",
    ):
        model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    # one test: the penalty is chosen on training error, the smallest, which interpolates
    assert model.reference_ == "recording" and model.alpha_ == 1e-6
    assert np.abs(model.predict(X) - y).max() < 1e-4 * np.ptp(y)
    # a penalty of 1 per row shrinks the gains: the fit no longer interpolates
    with pytest.warns(UnderdeterminedWarning):
        shrunk = ThermalTransferFunction(drivers=["spindle_rpm"], alphas=[1.0]).fit(X, y)
    assert shrunk.alpha_ == 1.0
    assert np.abs(shrunk.predict(X) - y).max() > 1e-2 * np.ptp(y)


def test_fewer_than_two_equations_are_refused():
    X, y = _tests(n_tests=1, hours=0.25)
    # the change since the first row: two rows give one equation
    with pytest.raises(
        ValueError,
        match=r"too few rows to fit: 2 samples in 1 test\(s\) give 1 equation, and a fit "
        r"needs at least 2\.",
    ):
        ThermalTransferFunction(reference="start").fit(X.iloc[:2], y.iloc[:2])


def test_a_non_finite_value_is_reported_before_the_rows_and_columns():
    X, y = _tests(n_tests=1, hours=0.25)
    bad = X.iloc[:1].copy()
    bad.iloc[0, 2] = np.nan
    # one row (too few) and max_sensors beyond the sensors: the NaN is named first
    with pytest.raises(ValueError, match=r"^Input X contains NaN: column 'T2_C' has NaN in test "):
        ThermalTransferFunction(max_sensors=9).fit(bad, y.iloc[:1])
    with pytest.raises(ValueError, match=r"^Input y contains infinity .* row 1 "):
        ThermalTransferFunction(max_sensors=9).fit(X.iloc[:2], [0.0, np.inf])
    w = np.ones(len(X))
    w[3] = np.nan
    with pytest.raises(ValueError, match=r"sample_weight of row 3 \(test 't0'\) is NaN;"):
        ThermalTransferFunction(max_sensors=9).fit(X, y, sample_weight=w)
    with pytest.raises(ValueError, match=r"^Input X contains infinity .*'T1_C'"):
        LagFeatures([60.0], columns=["nope"]).fit(X.assign(T1_C=np.inf))


def test_driver_not_a_column(data):
    X, y = data
    with pytest.raises(ValueError, match=r"the driver 'rpm' is not a column of X \(columns: "):
        ThermalTransferFunction(drivers=["rpm"]).fit(X, y)
    with pytest.raises(ValueError, match=r"sequence of column names, e\.g\. \['spindle_rpm'\]"):
        ThermalTransferFunction(drivers="spindle_rpm").fit(X, y)


def test_max_sensors_larger_than_sensors(data):
    X, y = data
    with pytest.raises(
        ValueError, match=r"'max_sensors' parameter .* is 6, more than the 5 temperature"
    ):
        ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=6).fit(X, y)


@pytest.mark.parametrize(
    "params, match",
    [
        (
            {"state": "keep"},
            r"'state' parameter .* must be a str among \{.*'auto'.*\}",
        ),
        ({"max_sensors": 0}, r"'max_sensors' parameter .* range \[1, inf\) or None"),
        ({"driver_powers": (1, -2)}, r"'driver_powers' parameter .* finite numbers > 0"),
        ({"alphas": [0.0]}, r"'alphas' parameter .* finite floats > 0"),
        ({"reference": "zero"}, r"'reference' parameter .* must be a str among"),
        (
            {"time_constants": "auto"},
            r"'time_constants' parameter .* among \{'fit'\}, an array-like or None",
        ),
    ],
)
def test_bad_parameters(data, params, match):
    X, y = data
    with pytest.raises(ValueError, match=match):
        ThermalTransferFunction(drivers=["spindle_rpm"], **params).fit(X, y)


def test_stable_selection_keeps_the_sensors_most_runs_chose(data):
    X, y = data
    model = _model(max_sensors=3, selection="stable").fit(X, y)
    # every run without one of the four tests finds T2 and T1; nothing else is
    # chosen by half of them
    assert model.selected_sensors_ == ["T2_C", "T1_C"]
    shares = dict(zip(model.selection_["sensor"], model.selection_["share_of_runs"]))
    assert shares["T2_C"] == 1.0 and shares["T1_C"] == 1.0
    assert all(v < 0.5 for k, v in shares.items() if k not in ("T1_C", "T2_C"))
    # with three tests there is no run without one that still holds out three: forward
    three = X.index.get_level_values("test") != "t3"
    forward = _model(max_sensors=3, selection="stable").fit(X[three], y[three])
    assert list(forward.selection_.columns) == ["sensor", "held_out_rmse", "alpha"]


def test_forward_selection_keeps_the_shortest_prefix_within_one_standard_error():
    from greyml.dynamic._gram import _forward

    scores = {(): 1.0, (0,): 0.5, (0, 1): 0.45, (0, 1, 2): 0.44}

    def evaluate(chosen):
        return scores.get(tuple(chosen), 2.0), 1e-3  # other sensors help less

    def forward(se):
        keep, _, score, path = _forward(
            evaluate,
            [0, 1, 2],
            ["a", "b", "c"],
            np.array([-1, 0, 1, 2]),
            4,
            3,
            lambda chosen, alpha: se,
        )
        return keep, score

    # 0.44 is the lowest; within 0.06 of it, one sensor (0.50) is enough
    assert forward(0.06) == ([0], 0.5)
    assert forward(0.01) == ([0, 1], 0.45)
    assert forward(0.0) == ([0, 1, 2], 0.44)


def test_held_out_spread_is_the_standard_error_of_the_refits(data):
    from greyml.dynamic._gram import _cols_all, held_out_spread

    X, y = data
    noisy = y + 0.05 * np.sin(np.arange(len(y)))
    model = _model(max_sensors=None, alphas=[1e-2], selection="forward").fit(X, noisy)
    rmses = _refit_rmses(X, noisy)
    bounds = [(i * 360, (i + 1) * 360) for i in range(4)]
    steps = model._timeline(
        X, __import__("greyml")._sequences.segments_by_test(X), model.gap_limit_s_
    )
    y0 = noisy.groupby(level="test", sort=False).transform("first")
    rows = SimpleNamespace(chunks=lambda: model._chunks(X.to_numpy()))
    data = SimpleNamespace(
        steps=steps, bounds=bounds, w=np.ones(len(y)), fold_tests=None, rows=rows
    )
    grams, pen = model._grams(data, model._spec_, model._groups_, (noisy - y0).to_numpy(), "start")
    cols = _cols_all(model._col_group_, list(range(5)), grams.n_columns)
    spread = held_out_spread(grams, cols, 1e-2, pen, [0, 1, 2, 3])
    assert spread == pytest.approx(np.std(rmses, ddof=1) / 2.0, rel=1e-6)


def test_an_input_beyond_any_measurement_is_one_line(data):
    X, y = data
    huge = X.copy()
    huge.iloc[5, 0] = 1e300  # spindle_rpm: its square overflows
    with pytest.raises(
        ValueError, match=r"column 'spindle_rpm' holds 1e\+300 in test 't0' at row 5"
    ):
        ThermalTransferFunction(drivers=["spindle_rpm"]).fit(huge, y)
    model = _model(max_sensors=2).fit(X, y)
    with pytest.raises(ValueError, match=r"beyond 1e\+100, which no measurement reaches"):
        model.predict(huge)


def test_sample_interval_spaces_the_rows_of_an_array():
    X, y = _tests(n_tests=1, hours=1.0)  # rows 60 s apart on a time_s level
    # an array's columns are x0, x1, ...: the spindle is x0
    kw = dict(drivers=["x0"], time_constants=[900.0, 2700.0], driver_time_constants=[2700.0])
    timed = ThermalTransferFunction(**{**kw, "drivers": ["spindle_rpm"]}).fit(X, y)
    array = ThermalTransferFunction(**kw, sample_interval=STEP).fit(X.to_numpy(), y.to_numpy())
    np.testing.assert_allclose(array.feature_coef_, timed.feature_coef_, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(array.predict(X.to_numpy()), timed.predict(X), atol=1e-9)
    assert array.nominal_step_s_ == STEP
    # without it, rows with no time are refused in one line that says what to give
    # (a guessed spacing would stretch every time constant by the true step)
    untimed = r"^ThermalTransferFunction needs the time of every row: .* set sample_interval="
    with pytest.raises(ValueError, match=untimed):
        ThermalTransferFunction(**kw).fit(X.to_numpy(), y.to_numpy())
    with pytest.raises(ValueError, match=untimed):  # a DataFrame with a plain index
        ThermalTransferFunction(**{**kw, "drivers": ["spindle_rpm"]}).fit(
            X.reset_index(drop=True), y.to_numpy()
        )
    with pytest.raises(ValueError, match=untimed):
        timed.predict(X.reset_index(drop=True))
    with pytest.raises(ValueError, match=r"^The 'sample_interval' parameter of Thermal"):
        ThermalTransferFunction(sample_interval=-60.0).fit(X, y)
