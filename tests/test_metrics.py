"""Tests of greyml.metrics: hand-computed values, identities, errors, scorers."""

import math
import pickle

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose
from scipy.stats import pearsonr
from sklearn.linear_model import Ridge
from sklearn.metrics import make_scorer, r2_score, root_mean_squared_error
from sklearn.model_selection import GridSearchCV, KFold, cross_validate

from greyml.metrics import (
    correlation,
    get_scorer,
    improvement,
    nash_sutcliffe,
    residual_band,
    rmse,
    scoring,
)
from greyml.metrics._scorers import SCORERS

METRICS = [rmse, correlation, nash_sutcliffe, residual_band, improvement]
GREYML_NAMES = [
    "neg_rmse",
    "correlation",
    "nash_sutcliffe",
    "neg_residual_band",
    "improvement",
]


# ---------------------------------------------------------------------------
# hand-computed values
# ---------------------------------------------------------------------------

# Case A: y = [1, 2, 3, 4], ŷ = [1, 3, 2, 4]
#   residuals y - ŷ = [0, -1, 1, 0]; Σ(y-ŷ)² = 2
#   RMSE = sqrt(2/4) = sqrt(0.5)
#   band = max|y-ŷ| = 1
#   ȳ = 2.5, y - ȳ = [-1.5, -0.5, 0.5, 1.5], Σ(y-ȳ)² = 2.25+0.25+0.25+2.25 = 5
#   E = 1 - 2/5 = 0.6
#   mean(ŷ) = 2.5, ŷ - 2.5 = [-1.5, 0.5, -0.5, 1.5], Σ(ŷ-2.5)² = 5
#   Σ(y-ȳ)(ŷ-2.5) = 2.25 - 0.25 - 0.25 + 2.25 = 4,  R = 4 / sqrt(5·5) = 0.8
#   improvement = 1 - 1/max|y| = 1 - 1/4 = 0.75
CASE_A = ([1, 2, 3, 4], [1, 3, 2, 4])
# Case B, a heating/cooling-like drift in µm: y = [0, 10, 20, 10], ŷ = [1, 8, 21, 10]
#   residuals = [-1, 2, -1, 0]; Σ = 1+4+1 = 6; RMSE = sqrt(6/4) = sqrt(1.5)
#   band = 2; improvement = 1 - 2/20 = 0.9
#   ȳ = 10, y - ȳ = [-10, 0, 10, 0], Σ(y-ȳ)² = 200, E = 1 - 6/200 = 0.97
#   mean(ŷ) = 40/4 = 10, ŷ - 10 = [-9, -2, 11, 0], Σ(ŷ-10)² = 81+4+121 = 206
#   Σ(y-ȳ)(ŷ-10) = 90 + 0 + 110 + 0 = 200, R = 200/sqrt(200·206) = sqrt(200/206)
CASE_B = ([0, 10, 20, 10], [1, 8, 21, 10])


@pytest.mark.parametrize(
    "metric, case, expected",
    [
        (rmse, CASE_A, math.sqrt(0.5)),
        (residual_band, CASE_A, 1.0),
        (nash_sutcliffe, CASE_A, 0.6),
        (correlation, CASE_A, 0.8),
        (improvement, CASE_A, 0.75),
        (rmse, CASE_B, math.sqrt(1.5)),
        (residual_band, CASE_B, 2.0),
        (nash_sutcliffe, CASE_B, 0.97),
        (correlation, CASE_B, math.sqrt(200 / 206)),
        (improvement, CASE_B, 0.9),
    ],
)
def test_hand_computed(metric, case, expected):
    value = metric(*case)
    assert isinstance(value, float)
    assert value == pytest.approx(expected, rel=1e-14)


def test_improvement_uses_absolute_peaks():
    # A drift that goes negative: y = [-5, 0, 2], ŷ = [-4, 0, 2]
    #   max|y| = 5 (the negative peak), max|y-ŷ| = |-1| = 1 → 1 - 1/5 = 0.8
    assert improvement([-5, 0, 2], [-4, 0, 2]) == pytest.approx(0.8)
    # A prediction that doubles the error: y = [0, 4], ŷ = [0, 12] → 1 - 8/4 = -1
    assert improvement([0, 4], [0, 12]) == pytest.approx(-1.0)


def test_perfect_prediction():
    y = np.array([0.0, 3.0, 11.5, 20.0, 14.0, 6.0])
    assert rmse(y, y) == 0.0
    assert residual_band(y, y) == 0.0
    assert correlation(y, y) == pytest.approx(1.0)
    assert nash_sutcliffe(y, y) == 1.0
    assert improvement(y, y) == 1.0


def test_single_sample_where_defined():
    # One sample: y = [3], ŷ = [1] → residual 2, RMSE = band = 2, 1 - 2/3
    assert rmse([3.0], [1.0]) == 2.0
    assert residual_band([3.0], [1.0]) == 2.0
    assert improvement([3.0], [1.0]) == pytest.approx(1 / 3)


# ---------------------------------------------------------------------------
# relationships
# ---------------------------------------------------------------------------


@pytest.fixture
def pair():
    rng = np.random.default_rng(0)
    t = np.linspace(0.0, 4.0, 60)
    y = 30.0 * (1.0 - np.exp(-t)) + rng.normal(scale=0.5, size=t.size)
    y_hat = 29.0 * (1.0 - np.exp(-1.1 * t)) + 0.3
    return y, y_hat


def test_nash_sutcliffe_is_one_minus_mse_over_variance(pair):
    y, y_hat = pair
    mse = np.mean((y - y_hat) ** 2)
    assert_allclose(nash_sutcliffe(y, y_hat), 1.0 - mse / np.var(y), rtol=1e-12)
    # ... and the same formula as scikit-learn's coefficient of determination.
    assert_allclose(nash_sutcliffe(y, y_hat), r2_score(y, y_hat), rtol=1e-12)


def test_nash_sutcliffe_of_the_mean_is_zero(pair):
    y, _ = pair
    assert nash_sutcliffe(y, np.full_like(y, y.mean())) == pytest.approx(0, abs=1e-12)


def test_rmse_matches_definition_and_sklearn(pair):
    y, y_hat = pair
    assert_allclose(rmse(y, y_hat), np.sqrt(np.mean((y - y_hat) ** 2)), rtol=1e-14)
    assert_allclose(rmse(y, y_hat), root_mean_squared_error(y, y_hat), rtol=1e-14)


def test_correlation_matches_scipy(pair):
    y, y_hat = pair
    assert_allclose(correlation(y, y_hat), pearsonr(y, y_hat).statistic, rtol=1e-12)


def test_correlation_of_affine_maps(pair):
    y, _ = pair
    assert correlation(y, 2.5 * y + 7.0) == pytest.approx(1.0, abs=1e-14)
    assert correlation(y, -0.1 * y + 3.0) == pytest.approx(-1.0, abs=1e-14)


def test_symmetry(pair):
    y, y_hat = pair
    for metric in (rmse, residual_band, correlation):
        assert metric(y, y_hat) == pytest.approx(metric(y_hat, y), rel=1e-14)


def test_units(pair):
    # µm → mm: errors scale by 1e-3, dimensionless measures do not change.
    y, y_hat = pair
    assert rmse(y / 1e3, y_hat / 1e3) == pytest.approx(rmse(y, y_hat) / 1e3)
    assert residual_band(y / 1e3, y_hat / 1e3) == pytest.approx(residual_band(y, y_hat) / 1e3)
    for metric in (correlation, nash_sutcliffe, improvement):
        assert metric(y / 1e3, y_hat / 1e3) == pytest.approx(metric(y, y_hat))


def test_band_and_rmse_order(pair):
    y, y_hat = pair
    assert 0 < rmse(y, y_hat) <= residual_band(y, y_hat)


def test_extreme_magnitudes_no_overflow():
    # Differences of ±1e300 values would overflow if squared directly.
    y = np.array([1e300, -1e300, 5e299])
    y_hat = np.array([-1e300, 1e300, 5e299])
    # residuals [2e300, -2e300, 0]: RMSE = 2e300·sqrt(2/3), band = 2e300
    assert rmse(y, y_hat) == pytest.approx(2e300 * math.sqrt(2 / 3))
    assert residual_band(y, y_hat) == pytest.approx(2e300)
    assert improvement(y, y_hat) == pytest.approx(-1.0)
    assert correlation(y, y_hat) == pytest.approx(correlation([2, -2, 1], [-2, 2, 1]))
    assert nash_sutcliffe(y, y_hat) == pytest.approx(nash_sutcliffe([2, -2, 1], [-2, 2, 1]))
    # Tiny values are not flushed to zero by a common scale factor.
    tiny = np.array([1e-300, 3e-300, 2e-300])
    assert nash_sutcliffe(tiny, tiny * 2.0) == pytest.approx(nash_sutcliffe([1, 3, 2], [2, 6, 4]))
    assert improvement(tiny, [0.0, 0.0, 1e300]) == pytest.approx(1 - 1e300 / 3e-300)
    # A result beyond the float64 range is infinite, not NaN and not a warning.
    assert rmse([1.7e308], [-1.7e308]) == math.inf
    assert nash_sutcliffe([0, 1e-300], [1e300, 0]) == -math.inf


# ---------------------------------------------------------------------------
# input types
# ---------------------------------------------------------------------------

INPUTS = {
    "list": lambda v: list(v),
    "tuple": lambda v: tuple(v),
    "array": lambda v: np.asarray(v, dtype=float),
    "int array": lambda v: np.asarray(v, dtype=np.int64),
    "float32 array": lambda v: np.asarray(v, dtype=np.float32),
    "column": lambda v: np.asarray(v, dtype=float).reshape(-1, 1),
    "series": lambda v: pd.Series(v, index=[10, 11, 12, 13]),
    "nullable series": lambda v: pd.Series(v, dtype="Float64"),
    "one-column frame": lambda v: pd.DataFrame({"z_um": v}),
}


@pytest.mark.parametrize("kind", list(INPUTS))
@pytest.mark.parametrize("metric", METRICS)
def test_input_types(metric, kind):
    expected = metric(*CASE_A)
    convert = INPUTS[kind]
    assert metric(convert(CASE_A[0]), convert(CASE_A[1])) == pytest.approx(expected)
    assert metric(convert(CASE_A[0]), np.asarray(CASE_A[1])) == pytest.approx(expected)


def test_pandas_compared_by_position_not_index():
    y = pd.Series([1.0, 2.0, 3.0, 4.0], index=[0, 1, 2, 3])
    y_hat = pd.Series([1.0, 3.0, 2.0, 4.0], index=[3, 2, 1, 0])
    assert rmse(y, y_hat) == pytest.approx(math.sqrt(0.5))


@pytest.mark.parametrize("metric", METRICS)
def test_inputs_not_modified(metric):
    y = np.array([[1.0], [2.0], [3.0], [4.0]])
    y_hat = pd.Series([1.0, 3.0, 2.0, 4.0])
    y_copy, y_hat_copy = y.copy(), y_hat.copy()
    metric(y, y_hat)
    np.testing.assert_array_equal(y, y_copy)
    pd.testing.assert_series_equal(y_hat, y_hat_copy)


@pytest.mark.parametrize("metric", METRICS)
def test_read_only_inputs(metric):
    y, y_hat = np.array(CASE_A[0], dtype=float), np.array(CASE_A[1], dtype=float)
    y.flags.writeable = False
    y_hat.flags.writeable = False
    assert metric(y, y_hat) == pytest.approx(metric(*CASE_A))


# ---------------------------------------------------------------------------
# errors
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("metric", METRICS)
def test_different_lengths(metric):
    with pytest.raises(ValueError, match=r"different lengths.*y_true has 4.*y_pred has 3"):
        metric([1, 2, 3, 4], [1, 2, 3])


@pytest.mark.parametrize("metric", METRICS)
def test_empty(metric):
    with pytest.raises(ValueError, match="empty"):
        metric([], [])
    with pytest.raises(ValueError, match="empty"):
        metric(np.empty((0, 1)), np.array([]))


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_y_true(metric, bad):
    y = [1.0, 2.0, bad, 4.0, bad]
    with pytest.raises(ValueError, match=r"y_true contains .*at position 2\b"):
        metric(y, [1.0, 3.0, 2.0, 4.0, 5.0])


@pytest.mark.parametrize("metric", METRICS)
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_y_pred(metric, bad):
    with pytest.raises(ValueError, match=r"y_pred contains .*at position 0\b"):
        metric([1.0, 2.0, 3.0, 4.0], [bad, 3.0, 2.0, 4.0])


def test_non_finite_message_names_the_value():
    with pytest.raises(ValueError, match=r"\(inf\) at position 1 and 1 more"):
        rmse([1.0, 2.0, 3.0], [0.0, np.inf, -np.inf])
    with pytest.raises(ValueError, match=r"y_true contains a non-finite value \(nan\)"):
        rmse(pd.Series([1.0, None, 3.0], dtype="Float64"), [0.0, 1.0, 2.0])


@pytest.mark.parametrize("metric", [correlation, nash_sutcliffe])
def test_constant_y_true(metric):
    with pytest.raises(ValueError, match=r"y_true is constant .* undefined"):
        metric([2.0, 2.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"y_true is constant \(all 1 values"):
        metric([2.0], [1.0])


def test_constant_y_pred_for_correlation():
    with pytest.raises(ValueError, match=r"y_pred is constant .* undefined"):
        correlation([1.0, 2.0, 3.0], [5.0, 5.0, 5.0])
    # A constant prediction is fine for the other measures: E = 0 for the mean.
    assert nash_sutcliffe([1.0, 2.0, 3.0], [2.0, 2.0, 2.0]) == 0.0


def test_all_zero_y_true_for_improvement():
    with pytest.raises(ValueError, match=r"y_true is all zero .* undefined"):
        improvement([0.0, 0.0, -0.0], [1.0, 0.0, 2.0])


@pytest.mark.parametrize(
    "bad, match",
    [
        (3.0, "got a scalar"),
        (np.ones((3, 2)), r"shape \(3, 2\)"),
        (np.ones((1, 3)), r"shape \(1, 3\)"),
        (np.ones((3, 1, 1)), r"shape \(3, 1, 1\)"),
        (["a", "b", "c"], "dtype <U1"),
        (np.array([1 + 1j, 2, 3]), "complex"),
        ([1.0, "x", 3.0], "real numbers"),
        ([[1.0, 2.0], [3.0]], "could not be converted"),
        (pd.Series(pd.to_datetime(["2024-01-01"] * 3)), "dtype datetime64"),
    ],
)
def test_bad_input(bad, match):
    with pytest.raises(ValueError, match=match):
        rmse(bad, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=f"y_pred.*{match}"):
        rmse([1.0, 2.0, 3.0], bad)


# ---------------------------------------------------------------------------
# properties
# ---------------------------------------------------------------------------


@st.composite
def pairs(draw, max_magnitude=1e6):
    n = draw(st.integers(min_value=1, max_value=40))
    elements = st.floats(
        min_value=-max_magnitude,
        max_value=max_magnitude,
        allow_nan=False,
        allow_infinity=False,
    )
    y = draw(arrays(np.float64, n, elements=elements))
    y_hat = draw(arrays(np.float64, n, elements=elements))
    return y, y_hat


@settings(max_examples=200, deadline=None)
@given(pairs())
def test_error_orderings(pair):
    y, y_hat = pair
    e, band = rmse(y, y_hat), residual_band(y, y_hat)
    assert e >= 0.0
    # RMSE ≤ max|y - ŷ| exactly in real arithmetic; allow the rounding of the
    # mean (a few ulp) when all residuals have the same magnitude.
    assert band >= e * (1.0 - 1e-14)
    if np.any(y):
        assert improvement(y, y_hat) <= 1.0
    if y.min() != y.max():
        assert nash_sutcliffe(y, y_hat) <= 1.0
        if y_hat.min() != y_hat.max():
            assert -1.0 <= correlation(y, y_hat) <= 1.0


def test_residuals_far_below_the_values_keep_their_digits():
    # found by the property below: scaled by the values' peak (4e177), the
    # residuals (2.8e16) squared into subnormal numbers, and the RMSE came out
    # 3.12e16, above the largest residual
    y = np.array([4.0522613e177] + [0.0] * 6)
    y_hat = np.array([4.0522613e177] + [2.8483265e16] * 6)
    e = y - y_hat  # [0, -2.8e16, ...]: exact
    assert rmse(y, y_hat) == pytest.approx(math.sqrt(np.mean(e**2)), rel=1e-15)
    assert rmse(y, y_hat) <= residual_band(y, y_hat) == pytest.approx(np.max(np.abs(e)), rel=0)


@settings(max_examples=200, deadline=None)
@given(pairs(max_magnitude=1.7e308))
def test_any_finite_input_gives_a_number(pair):
    # Over the whole float64 range: no warning (they are errors here), no NaN.
    y, y_hat = pair
    values = [rmse(y, y_hat), residual_band(y, y_hat)]
    if np.any(y):
        values.append(improvement(y, y_hat))
    if y.min() != y.max():
        values.append(nash_sutcliffe(y, y_hat))
        if y_hat.min() != y_hat.max():
            values.append(correlation(y, y_hat))
    assert not any(math.isnan(v) for v in values)
    assert values[0] <= values[1] * (1.0 + 1e-14)


# ---------------------------------------------------------------------------
# scorers
# ---------------------------------------------------------------------------


@pytest.fixture
def regression():
    rng = np.random.default_rng(42)
    X = rng.uniform(0.0, 10.0, size=(45, 3))
    y = X @ np.array([3.0, -1.0, 0.5]) + 4.0 + rng.normal(scale=1.0, size=45)
    return X, y


def test_scorer_registry():
    assert list(SCORERS) == GREYML_NAMES
    for name in GREYML_NAMES:
        assert callable(SCORERS[name])


@pytest.mark.parametrize(
    "name, metric, sign",
    [
        ("neg_rmse", rmse, -1),
        ("correlation", correlation, 1),
        ("nash_sutcliffe", nash_sutcliffe, 1),
        ("neg_residual_band", residual_band, -1),
        ("improvement", improvement, 1),
    ],
)
def test_scorer_sign(regression, name, metric, sign):
    X, y = regression
    model = Ridge(alpha=1.0).fit(X[:30], y[:30])
    expected = sign * metric(y[30:], model.predict(X[30:]))
    assert get_scorer(name)(model, X[30:], y[30:]) == pytest.approx(expected)
    assert SCORERS[name](model, X[30:], y[30:]) == pytest.approx(expected)


def test_scorers_pickle(regression):
    X, y = regression
    model = Ridge().fit(X, y)
    for name, scorer in SCORERS.items():
        clone = pickle.loads(pickle.dumps(scorer))
        assert clone(model, X, y) == scorer(model, X, y), name


def test_get_scorer_returns_copies():
    first, second = get_scorer("neg_rmse"), get_scorer("neg_rmse")
    assert first is not second
    assert first is not SCORERS["neg_rmse"]


def test_get_scorer_falls_back_to_sklearn(regression):
    X, y = regression
    model = Ridge().fit(X, y)
    assert get_scorer("r2")(model, X, y) == pytest.approx(r2_score(y, model.predict(X)))
    custom = make_scorer(rmse)
    assert get_scorer(custom) is custom
    assert get_scorer(None) is None


def test_get_scorer_unknown_name():
    with pytest.raises(ValueError, match=r"'bogus'.*'neg_rmse'.*'improvement'"):
        get_scorer("bogus")


@pytest.mark.parametrize("name", ["rmse", "residual_band"])
def test_get_scorer_suggests_neg(name):
    with pytest.raises(ValueError, match=f"use 'neg_{name}'"):
        get_scorer(name)


def test_scoring_helper():
    chosen = scoring("neg_rmse", "nash_sutcliffe", "r2")
    assert list(chosen) == ["neg_rmse", "nash_sutcliffe", "r2"]
    assert list(scoring()) == GREYML_NAMES
    with pytest.raises(ValueError, match="'bogus'"):
        scoring("neg_rmse", "bogus")
    with pytest.raises(TypeError, match="must be strings"):
        scoring(SCORERS["neg_rmse"])


def test_cross_validate_single_metric(regression):
    X, y = regression
    cv = KFold(n_splits=3, shuffle=True, random_state=0)
    result = cross_validate(
        Ridge(alpha=0.5),
        X,
        y,
        cv=cv,
        scoring=get_scorer("neg_rmse"),
        return_estimator=True,
    )
    for score, model, (_, test) in zip(
        result["test_score"], result["estimator"], cv.split(X, y), strict=True
    ):
        by_hand = math.sqrt(np.mean((y[test] - model.predict(X[test])) ** 2))
        assert score == pytest.approx(-by_hand, rel=1e-12)
        assert score < 0


def test_cross_validate_multi_metric(regression):
    X, y = regression
    cv = KFold(n_splits=3, shuffle=True, random_state=0)
    result = cross_validate(Ridge(alpha=0.5), X, y, cv=cv, scoring=scoring(), return_estimator=True)
    for i, (_, test) in enumerate(cv.split(X, y)):
        y_test, y_hat = y[test], result["estimator"][i].predict(X[test])
        assert result["test_neg_rmse"][i] == pytest.approx(-rmse(y_test, y_hat))
        assert result["test_neg_residual_band"][i] == pytest.approx(-np.max(np.abs(y_test - y_hat)))
        assert result["test_nash_sutcliffe"][i] == pytest.approx(r2_score(y_test, y_hat))
        assert result["test_correlation"][i] == pytest.approx(np.corrcoef(y_test, y_hat)[0, 1])
        assert result["test_improvement"][i] == pytest.approx(
            1 - np.max(np.abs(y_test - y_hat)) / np.max(np.abs(y_test))
        )
    # A good linear fit: high R and E, errors reported as negative numbers.
    assert np.all(result["test_correlation"] > 0.9)
    assert np.all(result["test_nash_sutcliffe"] > 0.8)
    assert np.all(result["test_neg_rmse"] < 0)


def _mean_cv_rmse(alpha, X, y, cv):
    errors = []
    for train, test in cv.split(X, y):
        model = Ridge(alpha=alpha).fit(X[train], y[train])
        errors.append(rmse(y[test], model.predict(X[test])))
    return float(np.mean(errors))


def test_grid_search_minimises_rmse(regression):
    # Heavy shrinkage makes a worse model: the search must pick the small
    # alpha, which it only does if neg_rmse is negated correctly.
    X, y = regression
    cv = KFold(n_splits=3, shuffle=True, random_state=0)
    alphas = [0.01, 100.0, 10000.0]
    search = GridSearchCV(Ridge(), {"alpha": alphas}, cv=cv, scoring=get_scorer("neg_rmse")).fit(
        X, y
    )
    by_hand = {a: _mean_cv_rmse(a, X, y, cv) for a in alphas}
    assert search.best_params_["alpha"] == min(by_hand, key=by_hand.get) == 0.01
    assert search.best_score_ == pytest.approx(-by_hand[0.01], rel=1e-12)


def test_grid_search_multi_metric(regression):
    X, y = regression
    cv = KFold(n_splits=3, shuffle=True, random_state=0)
    search = GridSearchCV(
        Ridge(),
        {"alpha": [0.01, 10000.0]},
        cv=cv,
        scoring=scoring("neg_rmse", "nash_sutcliffe", "neg_residual_band"),
        refit="nash_sutcliffe",
    ).fit(X, y)
    results = search.cv_results_
    assert search.best_params_ == {"alpha": 0.01}
    assert results["mean_test_neg_rmse"][0] == pytest.approx(
        -_mean_cv_rmse(0.01, X, y, cv), rel=1e-12
    )
    # Ranks agree: the better model has the higher (less negative) scores.
    for key in ("neg_rmse", "nash_sutcliffe", "neg_residual_band"):
        assert list(results[f"rank_test_{key}"]) == [1, 2]
