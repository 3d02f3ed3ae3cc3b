"""Compensator: hand-computed cases, streaming equals batch, save and resume, bad rows."""

import math

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import ElasticNet, LinearRegression, RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import MinMaxScaler, StandardScaler

from greyml import Compensator, LagFeatures, make_test_index
from greyml.persist import load_model, save_model


def _machine(seed=0, n_tests=4, n=240, step=30.0, jitter=False):
    """Spindle-speed steps (thousands of rpm) and two wandering temperatures."""
    rng = np.random.default_rng(seed)
    frames, targets = [], []
    for i in range(n_tests):
        t = step * np.arange(n)
        if jitter:
            t = t + rng.uniform(-5, 5, n)
            t[0] = 0.0
        rpm = np.repeat(rng.uniform(0, 8, n // 40), 40)
        T1 = 20 + 0.2 * rng.normal(size=n).cumsum()
        T2 = 22 + 0.1 * rng.normal(size=n).cumsum()
        y = 1.5 * T1 - 0.7 * T2 + 0.3 * rpm**2 + rng.normal(size=n)
        index = make_test_index([f"test{i}"] * n, t)
        frames.append(pd.DataFrame({"T1_C": T1, "T2_C": T2, "rpm": rpm}, index=index))
        targets.append(pd.Series(y, index=index, name="dz_um"))
    return pd.concat(frames), pd.concat(targets)


def _stream(comp, X, kind="array"):
    time = X.index.get_level_values("time_s").to_numpy()
    if kind == "array":
        comp.set_params(row_columns=["time_s", *X.columns])  # (resets the state)
        rows = np.column_stack([time, X.to_numpy()])
        return np.array([comp.update(r) for r in rows])
    if kind == "dict":
        return np.array(
            [comp.update({"time_s": t, **r}) for t, r in zip(time, X.to_dict("records"))]
        )
    frame = X.reset_index(level="time_s")
    return np.array([comp.update(r) for _, r in frame.iterrows()])


def test_hand_computed_terms():
    # 15 min lag, one time constant's step: 1 − e^−1 of the rise
    comp = Compensator(
        ["T1_C", "rpm"],
        [("T1_C", 1, 900.0, 10.0), ("rpm", 2, None, 0.5), ("rpm", 1, 60.0 / math.log(2), 2.0)],
        intercept=1.0,
        row_columns=["time_s", "T1_C", "rpm"],
    )
    assert comp.update({"time_s": 0.0, "T1_C": 20.0, "rpm": 2.0}) == pytest.approx(
        1.0 + 200.0 + 0.5 * 4 + 2.0 * 2.0, abs=1e-12
    )
    second = comp.update(np.array([900.0, 21.0, 4.0]))
    # the rpm lag: 900 s = 15 halvings of its distance to 4
    rpm_lag = 4.0 - 2.0 * 0.5**15
    expected = 1.0 + 10.0 * (21.0 - math.exp(-1.0)) + 0.5 * 16 + 2.0 * rpm_lag
    assert second == pytest.approx(expected, abs=1e-12)
    state = comp.get_state()
    assert state["time_s"] == 900.0 and state["start"] is None
    assert state["lags"] == pytest.approx(
        {"T1_C|lag 15 min": 21.0 - math.exp(-1.0), "rpm|lag 86.5617024533 s": rpm_lag}
    )


def test_relative_to_start_and_shared_lags():
    # two terms on the same lag share one state; the sum is taken from the start
    comp = Compensator(
        ["T1_C"],
        [("T1_C", 1, 600.0, 1.0), ("T1_C", 1, 600.0, 2.0)],
        5.0,
        relative_to_start=True,
        row_columns=["time_s", "T1_C"],
    )
    assert comp.update([0.0, 30.0]) == 5.0
    assert comp.update([600.0, 31.0]) == pytest.approx(5.0 + 3.0 * (1 - math.exp(-1)), abs=1e-12)
    assert list(comp.state_["lags"]) == ["T1_C|lag 10 min"]
    assert comp.state_["start"] == 90.0
    comp.reset()
    assert comp.update([7.0, 40.0]) == 5.0  # at rest again, new start


@pytest.mark.parametrize("scaler", [StandardScaler(), None])
@pytest.mark.parametrize("jitter", [False, True])
def test_streaming_equals_batch_on_held_out_tests(scaler, jitter):
    X, y = _machine(jitter=jitter)
    train, held_out = (
        X.index.get_level_values("test") != "test3",
        X.index.get_level_values("test") == "test3",
    )
    steps = [LagFeatures([300.0, 900.0, 2700.0], powers={"rpm": (1, 2)})]
    steps += [scaler] if scaler is not None else []
    model = make_pipeline(*steps, RidgeCV(alphas=[0.1, 1.0, 10.0])).fit(X[train], y[train])
    comp = Compensator.from_pipeline(model)
    batch = model.predict(X[held_out])
    for kind in ("array", "dict", "series"):
        comp.reset()
        np.testing.assert_allclose(_stream(comp, X[held_out], kind), batch, rtol=0, atol=1e-9)
    # a linear model, no scaler, columns not lagged: passed through as raw terms
    plain = make_pipeline(LagFeatures([600.0], columns=["rpm"]), LinearRegression())
    plain.fit(X[train], y[train])
    comp = Compensator.from_pipeline(plain)
    assert ("T1_C", 1.0, None) in [t[:3] for t in comp.terms]
    np.testing.assert_allclose(
        _stream(comp, X[held_out]), plain.predict(X[held_out]), rtol=0, atol=1e-9
    )


def test_carried_state_streams_through_a_restarting_clock():
    X, y = _machine(n_tests=3)
    model = make_pipeline(
        LagFeatures([300.0, 1800.0], state="carry", powers={"rpm": (1, 2)}),
        StandardScaler(),
        ElasticNet(alpha=0.01, max_iter=10000),
    ).fit(X, y)
    comp = Compensator.from_pipeline(model)
    assert comp.nominal_step_s == 30.0
    np.testing.assert_allclose(_stream(comp, X), model.predict(X), rtol=0, atol=1e-9)
    # without the nominal step, the clock's restart is refused
    comp = Compensator.from_pipeline(model).set_params(nominal_step_s=None)
    with pytest.raises(ValueError, match="time_s goes back from 7170 to 0 s"):
        _stream(comp, X)


def test_saved_mid_stream_and_resumed_equals_uninterrupted(tmp_path):
    X, y = _machine()
    model = make_pipeline(
        LagFeatures([300.0, 900.0], powers={"rpm": (1, 2)}), StandardScaler(), RidgeCV()
    ).fit(X, y)
    rows = np.column_stack([X.index.get_level_values("time_s"), X.to_numpy()])[:240]
    order = ["time_s", *X.columns]
    whole = Compensator.from_pipeline(model, row_columns=order)
    uninterrupted = np.array([whole.update(r) for r in rows])

    first = Compensator.from_pipeline(model, row_columns=order)
    head = [first.update(r) for r in rows[:100]]
    again = load_model(save_model(first, tmp_path / "comp.greyml"))
    tail = [again.update(r) for r in rows[100:]]
    np.testing.assert_array_equal(np.array(head + tail), uninterrupted)

    # the same through get_state / set_state on a new compensator
    other = Compensator.from_pipeline(model, row_columns=order)
    state = Compensator.from_pipeline(model, row_columns=order)
    for r in rows[:150]:
        state.update(r)
    other.set_state(state.get_state())
    np.testing.assert_array_equal([other.update(r) for r in rows[150:]], uninterrupted[150:])


def test_caiviac_cycle_streams_as_predict():
    from conftest import caiviac_csv_or_skip

    from greyml.datasets import load_caiviac

    data = load_caiviac(caiviac_csv_or_skip())
    frame = data.frame
    columns = ["spindle_rpm"] + [f"t{k}_C" for k in range(1, 17)]
    X, y = frame[columns].copy(), frame["ch1_um"]
    X["spindle_rpm"] /= 1000.0
    cycle = X.index.get_level_values("test")
    model = make_pipeline(
        LagFeatures([300.0, 900.0, 2700.0, 8100.0], powers={"spindle_rpm": (1, 2)}),
        StandardScaler(),
        RidgeCV(alphas=np.logspace(-3, 3, 7)),
    ).fit(X[cycle != "5"], y[cycle != "5"])
    comp = Compensator.from_pipeline(model)
    held = X[cycle == "5"]
    np.testing.assert_allclose(_stream(comp, held), model.predict(held), rtol=0, atol=1e-9)


def _one_line(call, match):
    with pytest.raises(ValueError, match=match) as info:
        call()
    assert "\n" not in str(info.value)


def test_bad_rows():
    comp = Compensator(
        ["T1_C", "rpm"],
        [("T1_C", 1, 900.0, 1.0), ("rpm", 1, None, 1.0)],
        row_columns=["time_s", "T1_C", "rpm"],
        on_missing="raise",  # a NaN input refused (the default holds the last output)
    )
    comp.update({"time_s": 0.0, "T1_C": 20.0, "rpm": 1.0})
    before = comp.get_state()
    _one_line(lambda: comp.update({"time_s": 10.0, "T1_C": 20.0}), "the row has no 'rpm'")
    _one_line(lambda: comp.update({"T1_C": 20.0, "rpm": 1.0}), "the row has no 'time_s'")
    _one_line(
        lambda: comp.update({"time_s": 10.0, "T1_C": np.nan, "rpm": 1.0}),
        r"input 'T1_C' is nan at time_s = 10 s",
    )
    _one_line(lambda: comp.update([10.0, 20.0, np.inf]), r"input 'rpm' is inf at time_s = 10 s")
    _one_line(lambda: comp.update([np.nan, 20.0, 1.0]), "time_s is nan")
    _one_line(lambda: comp.update([0.0, 20.0, 1.0]), "time_s repeats from 0 to 0 s")
    _one_line(lambda: comp.update([-5.0, 20.0, 1.0]), "time_s goes back from 0 to -5 s")
    _one_line(lambda: comp.update([5.0, 20.0]), r"must hold the 3 values of row_columns")
    _one_line(lambda: comp.update([5000.0, 20.0, 1.0]), r"sampling gap of 5000 s .* \(15 min\)")
    _one_line(lambda: comp.update({"time_s": 5.0, "T1_C": "hot", "rpm": 1}), "not a real number")
    _one_line(lambda: comp.update(pd.Series({"time_s": 5.0, "T1_C": 20.0})), "the row has no 'rpm'")
    assert comp.get_state() == before  # a refused row changes nothing


@pytest.mark.parametrize(
    "inputs, terms, match",
    [
        (["T1_C"], [("T2_C", 1, 60.0, 1.0)], "names the input 'T2_C', which is not in inputs"),
        (["T1_C"], [("T1_C", 1, 0.0, 1.0)], "time constant 0.0"),
        (["T1_C"], [("T1_C", 1, -1.0, 1.0)], "time constant -1.0"),
        (["T1_C"], [("T1_C", 1, np.inf, 1.0)], "time constant inf"),
        (["T1_C"], [("T1_C", 0, 60.0, 1.0)], "has power 0"),
        (["T1_C"], [("T1_C", 1, 60.0, np.nan)], "has weight nan"),
        (["T1_C"], [("T1_C", 1, 60.0)], r"must be \(input_name, power, tau_s, weight\)"),
        (["T1_C", "T1_C"], [], "names 'T1_C' more than once"),
        ("T1_C", [], r"'inputs' parameter of Compensator must be an instance of 'list'"),
    ],
)
def test_bad_parameters(inputs, terms, match):
    _one_line(lambda: Compensator(inputs, terms).update({"time_s": 0.0, "T1_C": 1.0}), match)


def test_from_pipeline_needs_lags_and_a_linear_model():
    X, y = _machine(n_tests=2, n=80)
    _one_line(
        lambda: Compensator.from_pipeline(
            make_pipeline(LagFeatures([300.0]), MinMaxScaler(), LinearRegression()).fit(X, y)
        ),
        "needs the steps LagFeatures, an optional StandardScaler and a linear model; got "
        "LagFeatures → MinMaxScaler → LinearRegression",
    )
    with pytest.raises(TypeError, match="takes a fitted scikit-learn Pipeline"):
        Compensator.from_pipeline(LagFeatures([300.0]))


def test_array_rows_need_a_declared_order():
    terms = [("T1_C", 1, 900.0, 10.0), ("rpm", 1, None, 1.0)]
    bare = Compensator(["T1_C", "rpm"], terms)
    _one_line(lambda: bare.update(np.array([0.0, 20.0, 3.0])), "an array row has no names")
    assert bare.get_state()["time_s"] is None  # refused before anything changed
    # declared in another order (and with a column the model does not read): read by name
    comp = Compensator(["T1_C", "rpm"], terms, row_columns=["rpm", "time_s", "spare", "T1_C"])
    by_name = Compensator(["T1_C", "rpm"], terms)
    for t, temp, rpm in [(0.0, 20.0, 3.0), (60.0, 20.5, 4.0), (120.0, 21.0, 4.0)]:
        assert comp.update(np.array([rpm, t, -1.0, temp])) == by_name.update(
            {"time_s": t, "T1_C": temp, "rpm": rpm}
        )
    with pytest.raises(ValueError, match="lacks 'T1_C'"):
        Compensator(["T1_C"], terms[:1], row_columns=["time_s", "rpm"]).update([0.0, 1.0])


def test_idle_inputs_start_at_zero_and_reset_takes_a_displacement():
    # a driver idle before the first row: its lag starts at 0, not at its value
    comp = Compensator(["rpm"], [("rpm", 1, 600.0, 1.0)], idle_inputs=["rpm"])
    assert comp.update({"time_s": 0.0, "rpm": 3.0}) == 0.0
    assert comp.update({"time_s": 600.0, "rpm": 3.0}) == pytest.approx(3.0 * (1 - math.exp(-1)))
    # a measured displacement at the first row moves every correction after it
    comp.reset(initial_displacement=7.0)
    assert comp.update({"time_s": 0.0, "rpm": 3.0}) == 7.0
    assert comp.update({"time_s": 600.0, "rpm": 3.0}) == pytest.approx(
        7.0 + 3.0 * (1 - math.exp(-1))
    )
    _one_line(lambda: comp.reset(initial_displacement=float("nan")), "must be a finite number")
