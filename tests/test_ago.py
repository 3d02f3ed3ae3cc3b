import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from greyml import AGO, make_test_index
from greyml.grey._kernels import ago, iago


def two_tests():
    idx = make_test_index(["I", "I", "I", "II", "II"], [0, 10, 20, 0, 10])
    return pd.DataFrame(
        {"T1_C": [1.0, 2.0, 3.0, 10.0, 20.0], "T2_C": [0.5, 0.5, 1.0, -1.0, 1.0]},
        index=idx,
    )


def test_hand_computed_per_test():
    X = two_tests()
    out = AGO().fit_transform(X)
    # test I: 1, 1+2, 1+2+3; test II restarts: 10, 10+20
    assert out["T1_C"].tolist() == [1.0, 3.0, 6.0, 10.0, 30.0]
    assert out["T2_C"].tolist() == [0.5, 1.0, 2.0, -1.0, 0.0]
    assert out.index.equals(X.index)


def test_inverse_is_iago():
    X = two_tests()
    ago_ = AGO().fit(X)
    back = ago_.inverse_transform(ago_.transform(X))
    np.testing.assert_array_equal(back.to_numpy(), X.to_numpy())


def test_plain_array_single_test_returns_array():
    out = AGO().fit_transform(np.array([[1.0], [2.0], [4.0]]))
    assert isinstance(out, np.ndarray)
    assert out.ravel().tolist() == [1.0, 3.0, 7.0]


def test_set_output_pandas_keeps_index_and_names():
    X = two_tests()
    out = AGO().set_output(transform="pandas").fit_transform(X)
    assert out.index.equals(X.index)
    assert list(out.columns) == ["T1_C", "T2_C"]
    assert AGO().fit(X).get_feature_names_out().tolist() == ["T1_C", "T2_C"]


def test_does_not_modify_input():
    X = two_tests()
    before = X.copy()
    AGO().fit(X).transform(X)
    pd.testing.assert_frame_equal(X, before)


def test_nan_names_column_and_test():
    X = two_tests()
    X.iloc[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"column 'T2_C' has NaN in test 'II' at row 4"):
        AGO().fit(X)


def test_mismatched_columns_between_fit_and_transform():
    X = two_tests()
    ago_ = AGO().fit(X)
    with pytest.raises(ValueError, match="feature names"):
        ago_.transform(X[["T2_C", "T1_C"]])


@settings(max_examples=200, deadline=None)
@given(
    data=arrays(
        np.float64,
        st.tuples(st.integers(1, 30), st.integers(1, 3)),
        elements=st.floats(-1e6, 1e6, allow_nan=False),
    ),
    cuts=st.lists(st.integers(1, 29), max_size=4),
)
def test_iago_inverts_ago_per_test(data, cuts):
    n = data.shape[0]
    edges = sorted({0, n, *[c for c in cuts if c < n]})
    bounds = list(zip(edges[:-1], edges[1:]))
    np.testing.assert_allclose(iago(ago(data, bounds), bounds), data, rtol=1e-9, atol=1e-6)
    # accumulation restarts at every boundary
    acc = ago(data, bounds)
    for a, _ in bounds:
        np.testing.assert_array_equal(acc[a], data[a])


# -- AccumulatedTargetRegressor ------------------------------------------------
def _two_tests():
    rng = np.random.default_rng(5)
    index = make_test_index(["I"] * 30 + ["II"] * 20, 10.0 * np.r_[np.arange(30), np.arange(20)])
    X = pd.DataFrame(rng.normal(size=(50, 2)), index=index, columns=["T1_C", "T2_C"])
    y = pd.Series(rng.normal(size=50), index=index, name="dz_um")
    return X, y


def test_accumulated_target_regressor_accumulates_within_each_test():
    from sklearn.linear_model import LinearRegression

    from greyml import AccumulatedTargetRegressor

    X, y = _two_tests()
    X0, y0 = X.copy(), y.copy()
    model = AccumulatedTargetRegressor(LinearRegression()).fit(X, y)
    # the inner regressor saw the running sum of y restarted at test II (row 30)
    y1 = np.r_[np.cumsum(y.to_numpy()[:30]), np.cumsum(y.to_numpy()[30:])]
    direct = LinearRegression().fit(X, y1)
    np.testing.assert_allclose(model.regressor_.coef_, direct.coef_, rtol=1e-12)
    # and predict differences the inner prediction within each test; a test's
    # first row against the prediction at zero inputs, where the intercept is
    p1 = direct.predict(X) - direct.intercept_
    expected = np.r_[p1[0], np.diff(p1[:30]), p1[30], np.diff(p1[30:])]
    np.testing.assert_allclose(model.predict(X), expected, rtol=1e-12, atol=1e-12)
    pd.testing.assert_frame_equal(X, X0)
    pd.testing.assert_series_equal(y, y0)


def _heating_test(label, n, start, rng):
    """Two sensors rising from ``start`` °C; the target 2·T1 + T2 starts near 50."""
    t = np.arange(n)
    T1 = start + 8 * (1 - np.exp(-t / 30)) + 0.05 * rng.normal(size=n)
    T2 = start / 2 + 3 * (1 - np.exp(-t / 60)) + 0.05 * rng.normal(size=n)
    index = make_test_index([label] * n, 60.0 * t)
    X = pd.DataFrame({"T1_C": T1, "T2_C": T2}, index=index)
    return X, pd.Series(2.0 * T1 + T2 + 0.3 * rng.normal(size=n), index=index, name="dz_um")


@pytest.mark.parametrize("regressor", ["linear", "ridgecv"])
def test_first_row_of_a_new_test_carries_no_accumulated_constant(regressor):
    # issue 15: AGO + AccumulatedTargetRegressor put the intercept fitted in
    # accumulated space (here -3.6) on the first row of a new test
    from sklearn.linear_model import LinearRegression, RidgeCV
    from sklearn.pipeline import make_pipeline

    from greyml import AccumulatedTargetRegressor

    rng = np.random.default_rng(0)
    starts = [("A", 20.0), ("B", 21.0), ("C", 19.5)]
    parts = [_heating_test(label, 120, start, rng) for label, start in starts]
    X, y = pd.concat([p[0] for p in parts]), pd.concat([p[1] for p in parts])
    X_new, y_new = _heating_test("new", 80, 20.0, rng)
    assert abs(y_new.iloc[0] - 50) < 1 and (X_new.iloc[0] > 9).all()  # nothing starts at zero
    inner = LinearRegression() if regressor == "linear" else RidgeCV()
    model = make_pipeline(AGO(), AccumulatedTargetRegressor(inner)).fit(X, y)
    assert abs(model[-1].regressor_.intercept_) > 3  # a constant to cancel
    error = model.predict(X_new) - y_new.to_numpy()
    rest = np.sqrt(np.mean(error[1:] ** 2))
    # measured: first row 0.22, the other rows' RMSE 0.33 (the intercept on the
    # first row made it -3.36)
    assert abs(error[0]) <= 3 * rest, (error[0], rest)
    assert rest < 0.4


def test_transformed_target_regressor_would_sum_across_tests():
    # why greyml has its own wrapper: TransformedTargetRegressor hands AGO a bare
    # array, so its running sum does not restart at test II
    from sklearn.compose import TransformedTargetRegressor
    from sklearn.linear_model import LinearRegression

    from greyml import AccumulatedTargetRegressor

    X, y = _two_tests()
    ttr = TransformedTargetRegressor(LinearRegression(), transformer=AGO(), check_inverse=False)
    ours = AccumulatedTargetRegressor(LinearRegression())
    leaked = np.cumsum(y.to_numpy())
    np.testing.assert_allclose(
        ttr.fit(X, y).regressor_.coef_, LinearRegression().fit(X, leaked).coef_, rtol=1e-12
    )
    assert not np.allclose(ttr.regressor_.coef_, ours.fit(X, y).regressor_.coef_)


def test_accumulated_target_regressor_errors():
    from sklearn.base import BaseEstimator, RegressorMixin

    from greyml import AccumulatedTargetRegressor

    class TwoColumns(RegressorMixin, BaseEstimator):
        def fit(self, X, y):
            return self

        def predict(self, X):
            return np.zeros((len(X), 2))

    X, y = _two_tests()
    with pytest.raises(ValueError, match="TwoColumns predicted 2 columns"):
        AccumulatedTargetRegressor(TwoColumns()).fit(X, y).predict(X)
    with pytest.raises(ValueError, match="y to be passed"):
        AccumulatedTargetRegressor().fit(X, None)
    bad = y.copy()
    bad.iloc[35] = np.nan
    with pytest.raises(ValueError, match="NaN in test 'II'"):
        AccumulatedTargetRegressor().fit(X, bad)
    with pytest.raises(ValueError, match="same order as they were in fit"):
        AccumulatedTargetRegressor().fit(X, y).predict(X[["T2_C", "T1_C"]])
