"""LagFeatures: hand-computed lags, names, state across tests, pipelines, bad input."""

import math

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import LinearRegression, RidgeCV
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut, cross_val_predict
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import AGO, LagFeatures, groups_of, make_test_index
from greyml.persist import load_model, save_model

HALF = 60.0 / math.log(2.0)  # a = 1/2 for a 60 s step


def _lag_loop(x, t, tau, starts, carry_step=None):
    """The lag of one column written out sample by sample (independent of the kernel)."""
    out = np.empty(len(x))
    for k in range(len(x)):
        if k == 0 or (k in starts and carry_step is None):
            s = x[k]
        else:
            dt = carry_step if k in starts else t[k] - t[k - 1]
            a = math.exp(-dt / tau)
            s = a * s + (1.0 - a) * x[k]
        out[k] = s
    return out


def _two_tests():
    X = pd.DataFrame(
        {"T1_C": [20.0, 21.0, 21.0, 21.0, 5.0, 6.0], "rpm": [0.0, 1.0, 1.0, 2.0, 0.0, 0.0]},
        index=make_test_index(["I"] * 4 + ["II"] * 2, [0, 60, 120, 180, 0, 60]),
    )
    return X


def test_hand_computed_lag_names_and_index():
    X = _two_tests()
    lags = LagFeatures([HALF], columns=["T1_C"]).fit(X)
    Z = lags.transform(X)
    name = "T1_C|lag 86.5617024533 s"
    assert list(Z.columns) == ["T1_C", "rpm", name]
    assert Z.index.equals(X.index)
    # restart: test II starts at rest at 5
    np.testing.assert_allclose(Z[name], [20.0, 20.5, 20.75, 20.875, 5.0, 5.5], atol=1e-12)
    np.testing.assert_array_equal(Z["rpm"], X["rpm"])  # not chosen: passed through


def test_feature_names_minutes_hours_and_powers():
    X = _two_tests()
    lags = LagFeatures([900, 7200, 30], powers={"rpm": (1, 2)}, include_input=False).fit(X)
    assert list(lags.get_feature_names_out()) == [
        "T1_C|lag 15 min",
        "T1_C|lag 2 h",
        "T1_C|lag 30 s",
        "rpm|lag 15 min",
        "rpm|lag 2 h",
        "rpm|lag 30 s",
        "rpm^2|lag 15 min",
        "rpm^2|lag 2 h",
        "rpm^2|lag 30 s",
    ]
    Z = lags.transform(X)
    t = X.index.get_level_values("time_s").to_numpy()
    rpm = X["rpm"].to_numpy()
    for tau, label in [(900, "15 min"), (30, "30 s")]:
        expected = _lag_loop(rpm**2, t, tau, {0, 4})
        np.testing.assert_allclose(Z[f"rpm^2|lag {label}"], expected, rtol=1e-14)
    with_input = LagFeatures([900], powers=(1, 1.5)).fit(X)
    assert list(with_input.get_feature_names_out())[:4] == ["T1_C", "T1_C^1.5", "rpm", "rpm^1.5"]


def test_carry_runs_on_with_the_nominal_step():
    X = _two_tests()
    lags = LagFeatures([HALF], state="carry", include_input=False).fit(X)
    assert lags.nominal_step_s_ == 60.0
    Z = lags.transform(X)
    # 20.875 -> 0.5·20.875 + 0.5·5 = 12.9375 -> 0.5·12.9375 + 0.5·6 = 9.46875
    np.testing.assert_allclose(
        Z["T1_C|lag 86.5617024533 s"], [20, 20.5, 20.75, 20.875, 12.9375, 9.46875], atol=1e-12
    )


def test_uneven_sampling_equals_the_loop():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(5.0, 25.0, 300))
    t -= t[0]
    x = 20 + np.cumsum(rng.normal(size=300)) * 0.1
    X = pd.DataFrame({"T1_C": x}, index=make_test_index(["A"] * 300, t))
    Z = LagFeatures([40.0, 400.0], include_input=False).fit_transform(X)
    for j, tau in enumerate([40.0, 400.0]):
        np.testing.assert_allclose(Z.iloc[:, j], _lag_loop(x, t, tau, {0}), rtol=1e-13)


def test_array_needs_sample_interval_and_set_output_keeps_names():
    x = np.array([[0.0], [1.0], [1.0]])
    with pytest.raises(ValueError, match="no 'time_s' index level.*sample_interval="):
        LagFeatures([HALF]).fit(x)
    lags = LagFeatures([10.0 / math.log(2.0)], sample_interval=10.0).set_output(transform="pandas")
    Z = lags.fit_transform(x)
    assert list(Z.columns) == ["x0", "x0|lag 14.4269504089 s"]
    # a half-life of one 10-s row: half the way, then three quarters
    np.testing.assert_allclose(Z.iloc[:, 1], [0.0, 0.5, 0.75], atol=1e-15)
    assert lags.nominal_step_s_ == 10.0
    # plain array out by default, Fortran-ordered (one block for pandas)
    out = LagFeatures([5.0], sample_interval=1.0).fit_transform(x)
    assert isinstance(out, np.ndarray) and out.flags.f_contiguous
    # a time_s level wins over sample_interval: a half-life of one 20-s row
    timed = pd.DataFrame({"T1_C": x[:, 0]}, index=make_test_index(["A"] * 3, [0.0, 20.0, 40.0]))
    Z = LagFeatures([20.0 / math.log(2.0)], sample_interval=10.0).fit_transform(timed)
    np.testing.assert_allclose(Z.iloc[:, 1], [0.0, 0.5, 0.75], atol=1e-15)


def test_rows_sample_interval_apart_halve_a_lag_of_that_half_life():
    # the old name sample_step_s went with the deprecation layer (nothing was released)
    x = np.array([[0.0], [1.0], [1.0]])
    with pytest.raises(TypeError, match="sample_step_s"):
        LagFeatures([10.0 / math.log(2.0)], sample_step_s=10.0)
    out = LagFeatures([10.0 / math.log(2.0)], sample_interval=10.0).fit_transform(x)
    np.testing.assert_allclose(out[:, 1], [0.0, 0.5, 0.75], atol=1e-15)


@pytest.mark.parametrize("bad", [0.0, -15.0, np.inf, np.nan, "15 s"])
def test_a_sample_interval_that_is_not_a_finite_positive_number_is_refused(bad):
    x = np.array([[0.0], [1.0], [1.0]])
    with pytest.raises(ValueError, match=r"^The 'sample_interval' parameter of LagFeatures must"):
        LagFeatures([60.0], sample_interval=bad).fit(x)


def _machine(seed=0, n_tests=4, n=240, step=30.0):
    """Spindle-speed steps heating two sensors; the displacement is linear in lags."""
    rng = np.random.default_rng(seed)
    frames, targets = [], []
    for i in range(n_tests):
        t = step * np.arange(n)
        rpm = np.repeat(rng.uniform(0, 8, n // 40), 40)  # thousands of rpm
        # heated by the spindle, plus independent wanderings (no exact collinearity)
        T1 = 20 + 0.8 * _lag_loop(rpm, t, 600.0, {0}) + 0.2 * rng.normal(size=n).cumsum()
        T2 = 20 + 0.1 * rng.normal(size=n).cumsum()
        y = 3.0 * _lag_loop(T1, t, 900.0, {0}) - 2.0 * T2 + 0.05 * _lag_loop(rpm**2, t, 300.0, {0})
        index = make_test_index([f"test{i}"] * n, t)
        frames.append(pd.DataFrame({"T1_C": T1, "T2_C": T2, "rpm": rpm}, index=index))
        targets.append(pd.Series(y + 7.0, index=index, name="dz_um"))
    return pd.concat(frames), pd.concat(targets)


def test_pipeline_recovers_known_coefficients_and_grid_search_picks_the_bank():
    X, y = _machine()
    lags = LagFeatures([300.0, 900.0], powers={"rpm": (1, 2)})
    model = make_pipeline(lags, LinearRegression()).fit(X, y)
    coef = pd.Series(model[-1].coef_, index=model[0].get_feature_names_out())
    assert coef["T1_C|lag 15 min"] == pytest.approx(3.0, abs=1e-8)
    assert coef["T2_C"] == pytest.approx(-2.0, abs=1e-8)
    assert coef["rpm^2|lag 5 min"] == pytest.approx(0.05, abs=1e-9)
    assert model[-1].intercept_ == pytest.approx(7.0, abs=1e-6)
    search = GridSearchCV(
        make_pipeline(LagFeatures([300.0], powers={"rpm": (1, 2)}), LinearRegression()),
        {"lagfeatures__time_constants": [[300.0, 600.0], [300.0, 900.0], [300.0, 2700.0]]},
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    ).fit(X, y, groups=groups_of(X))
    assert search.best_params_["lagfeatures__time_constants"] == [300.0, 900.0]
    assert -search.best_score_ < 1e-6


def test_carried_lags_computed_before_the_split():
    # one recording cut into tests: with carried lags computed once, each held-out
    # test starts from the state the recording was in, and the model is exact
    X, _ = _machine(seed=3, n_tests=4, n=200)
    X.index = make_test_index(groups_of(X), np.arange(len(X)) * 30.0 % (200 * 30.0))
    t = np.arange(len(X)) * 30.0
    y = 4.0 * _lag_loop(X["T1_C"].to_numpy(), t, 900.0, {0}) - 1.0
    Z = LagFeatures([900.0, 3600.0], state="carry").fit_transform(X)
    pred = cross_val_predict(LinearRegression(), Z, y, groups=groups_of(Z), cv=LeaveOneGroupOut())
    np.testing.assert_allclose(pred, y, atol=1e-8)
    # restarting the lags at each test misses the carried heat
    R = LagFeatures([900.0, 3600.0]).fit_transform(X)
    miss = cross_val_predict(LinearRegression(), R, y, groups=groups_of(R), cv=LeaveOneGroupOut())
    assert np.abs(miss - y).max() > 0.1


def test_test_index_handed_on_through_a_pipeline():
    X = _two_tests()
    out = make_pipeline(LagFeatures([HALF], columns=["T1_C"]), AGO()).fit_transform(X)
    # AGO restarts at test II: it saw the test index
    assert out.index.equals(X.index)
    assert out["rpm"].tolist() == [0.0, 1.0, 2.0, 4.0, 0.0, 0.0]


def test_saved_and_loaded(tmp_path):
    X, y = _machine(n_tests=2, n=80)
    model = make_pipeline(
        LagFeatures([300.0, 900.0], powers={"rpm": (1, 2)}), StandardScaler(), RidgeCV()
    ).fit(X, y)
    again = load_model(save_model(model, tmp_path / "lags.greyml"))
    np.testing.assert_array_equal(again.predict(X), model.predict(X))


@pytest.mark.parametrize(
    "params, match",
    [
        ({"time_constants": [600.0, 0.0]}, r"time constant 0\.0 s \(entry 1\) is not a finite"),
        (
            {"time_constants": list(range(1, 1003))},
            r"holds 1,002 time constants, more than the 1,000",
        ),
        ({"time_constants": [-5.0]}, r"time constant -5\.0 s \(entry 0\)"),
        ({"time_constants": [np.inf]}, r"time constant inf s \(entry 0\)"),
        ({"time_constants": [np.nan]}, r"time constant nan s \(entry 0\)"),
        ({"time_constants": []}, "non-empty sequence"),
        ({"time_constants": [60.0, 60.0]}, "1 min more than once"),
        ({"time_constants": [60.0], "state": "keep"}, "'state' parameter.*'keep'"),
        ({"time_constants": [60.0], "powers": (0,)}, "'powers' parameter"),
        ({"time_constants": [60.0], "powers": {"rpm": (1, 1)}}, "repeats a power for column 'rpm'"),
        ({"time_constants": [60.0], "columns": ["T9_C"]}, "'T9_C' named in columns= is not"),
        ({"time_constants": [60.0], "powers": {"T9_C": (2,)}}, "powers= names the column 'T9_C'"),
    ],
)
def test_bad_parameters(params, match):
    with pytest.raises(ValueError, match=match) as info:
        LagFeatures(**params).fit(_two_tests())
    assert "\n" not in str(info.value)


def _one_line(call, match):
    with pytest.raises(ValueError, match=match) as info:
        call()
    assert "\n" not in str(info.value)
    return str(info.value)


def test_bad_data_names_column_test_and_time():
    X = _two_tests()
    gap = X.copy()
    gap.index = make_test_index(groups_of(X), [0, 60, 120, 4000, 0, 60])
    message = _one_line(
        lambda: LagFeatures([600.0, 900.0]).fit(gap),
        r"test 'I' has a sampling gap of 3880 s before time_s = 4000 s \(row 3\), longer "
        r"than the largest time constant \(15 min\)",
    )
    assert "split the test" in message
    fitted = LagFeatures([900.0]).fit(X)
    _one_line(lambda: fitted.transform(gap), "test 'I' has a sampling gap")
    nan = X.copy()
    nan.iloc[5, 1] = np.nan
    _one_line(lambda: fitted.transform(nan), r"column 'rpm' has NaN in test 'II' at row 5")
    negative = X.copy()
    negative.iloc[4, 1] = -1.0
    _one_line(
        lambda: LagFeatures([900.0], powers={"rpm": (1.5,)}).fit(negative),
        r"column 'rpm' is negative \(-1\) in test 'II' at row 4, so its power 1.5",
    )
    huge = X.copy()
    huge.iloc[2, 1] = 1e200
    _one_line(
        lambda: LagFeatures([900.0], powers={"rpm": (2,)}).fit(X).transform(huge),
        r"column 'rpm' to the power 2 overflows to infinity in test 'I' at row 2",
    )
    back = X.copy()
    back.index = make_test_index(groups_of(X), [0, 60, 50, 180, 0, 60])
    _one_line(lambda: fitted.transform(back), r"test 'I'.*goes back from 60 to 50")
    # a plain time_s index (one test) is checked too
    plain = X.iloc[:4].reset_index(level="test", drop=True)
    plain.index = pd.Index([0.0, 60.0, 60.0, 120.0], name="time_s")
    _one_line(lambda: LagFeatures([900.0]).fit(plain), "strictly increase.*60 at row 2 after 60")


def test_mismatched_columns_at_transform():
    X = _two_tests()
    fitted = LagFeatures([900.0]).fit(X)
    # scikit-learn's wording (its estimator checks require it): a line of its own
    # first, then the names
    with pytest.raises(ValueError, match="Feature names unseen at fit time:\n- spindle_rpm"):
        fitted.transform(X.rename(columns={"rpm": "spindle_rpm"}))
    with pytest.raises(ValueError, match="column 1 of X is 'rpm' where LagFeatures"):
        fitted.transform(X[["rpm", "T1_C"]])
    with pytest.warns(UserWarning, match="X does not have valid feature names"):
        _one_line(lambda: fitted.transform(X[["T1_C"]].to_numpy()), "X has 1 features")


def test_input_is_not_modified():
    X = _two_tests()
    X0 = X.copy()
    LagFeatures([900.0], powers=(1, 2), state="carry").fit_transform(X)
    pd.testing.assert_frame_equal(X, X0)
