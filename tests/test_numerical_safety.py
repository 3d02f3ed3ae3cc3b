"""Numerical safety (#8 item 2): non-finite objectives, degenerate ANFIS inputs,
near-collinear GM(1,N) sensors. Warnings are errors here (pyproject), so every
test also proves that no RuntimeWarning escapes from greyml."""

import numpy as np
import pandas as pd
import pytest

from greyml import ANFISFCM, ANFISGrid, make_test_index
from greyml.exceptions import GreyConditioningWarning
from greyml.fuzzy._kernels import (
    NO_FIRE_LOG,
    JangStepSize,
    anfis_forward,
    hybrid_learning,
    normalised_firing,
)
from greyml.grey._functions import fit_gm1n
from greyml.grey._kernels import CONDITION_LIMIT, gm1n_conditioning, gm1n_design
from greyml.optimize import CuckooSearch, ParticleSwarm
from greyml.optimize._base import PENALTY

OPTIMIZERS = [
    lambda: ParticleSwarm(max_iter=150),
    lambda: CuckooSearch(max_iter=300),
]
IDS = ["pso", "cs"]


def sphere(P):
    return ((P - 1.5) ** 2).sum(axis=1)


# -- (a) optimisers --------------------------------------------------------------
@pytest.mark.parametrize("make", OPTIMIZERS, ids=IDS)
def test_quadratic_minimum_found_with_30_percent_nan(make):
    noise = np.random.default_rng(123)

    def flaky(P):
        out = sphere(P)
        out[noise.random(len(P)) < 0.3] = np.nan
        return out

    res = make().minimize(flaky, (-5, 5), np.random.default_rng(0), n_dim=2)
    np.testing.assert_allclose(res.x, 1.5, atol=1e-2)
    assert 0.0 <= res.fun < 1e-4 and np.isfinite(res.history).all()
    share = res.nfev_nonfinite / res.nfev
    assert 0.27 < share < 0.33, share  # the objective's 30 %, counted


@pytest.mark.parametrize("make", OPTIMIZERS, ids=IDS)
def test_minus_inf_is_not_a_best(make):
    # -inf on a third of the box, where the finite loss would be larger anyway
    def sink(P):
        out = sphere(P)
        out[P[:, 0] > 2.5] = -np.inf
        return out

    res = make().minimize(sink, (-5, 5), np.random.default_rng(1), n_dim=2)
    np.testing.assert_allclose(res.x, 1.5, atol=1e-2)
    assert res.fun >= 0.0 and res.nfev_nonfinite > 0


@pytest.mark.parametrize("make", OPTIMIZERS, ids=IDS)
def test_every_loss_non_finite_on_the_first_iterations(make):
    calls = []

    def late(P):
        calls.append(len(P))
        values = [np.nan, np.inf, -np.inf][len(calls) % 3]
        return np.full(len(P), values) if len(calls) <= 6 else sphere(P)

    res = make().minimize(late, (-5, 5), np.random.default_rng(2), n_dim=2)
    np.testing.assert_allclose(res.x, 1.5, atol=1e-2)
    assert res.nfev_nonfinite == sum(calls[:6])
    assert res.history[0] == PENALTY and np.isfinite(res.history).all()


@pytest.mark.parametrize("make", OPTIMIZERS, ids=IDS)
def test_overflow_in_the_objective_neither_warns_nor_stops(make):
    # exp overflows (a RuntimeWarning, an error under this suite's filters) for x0 > 2.71
    def steep(P):
        return np.exp(1000.0 * (P[:, 0] - 2.0)) + sphere(P)

    res = make().minimize(steep, (-5, 5), np.random.default_rng(3), n_dim=2)
    np.testing.assert_allclose(res.x, 1.5, atol=1e-2)
    assert res.nfev_nonfinite > 0


@pytest.mark.parametrize("make", OPTIMIZERS, ids=IDS)
def test_floating_point_error_penalises_only_the_rows_that_raise(make):
    def strict(P):
        with np.errstate(over="raise"):
            return np.exp(800.0 * (P[:, 0] - 2.0)) + sphere(P)  # raises for x0 > 2.89

    res = make().minimize(strict, (-5, 5), np.random.default_rng(4), n_dim=2)
    np.testing.assert_allclose(res.x, 1.5, atol=1e-2)
    # the rows with x0 > 2.89 (about 21 % of a uniform start) and no others
    assert 0 < res.nfev_nonfinite < res.nfev


@pytest.mark.parametrize("make", OPTIMIZERS, ids=IDS)
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_no_finite_value_at_all_is_an_error(make, value):
    opt = make().set_params(max_iter=3)
    name = type(opt).__name__
    with pytest.raises(ValueError, match=rf"^{name} .*objective returned no finite value in"):
        opt.minimize(lambda P: np.full(len(P), value), (-1, 1), np.random.default_rng(0), n_dim=2)


def test_column_vector_objective_with_non_finite_rows():
    def column(P):
        out = sphere(P)[:, None]
        out[P[:, 1] < 0] = np.inf
        return out

    res = ParticleSwarm().minimize(column, (-5, 5), np.random.default_rng(5), n_dim=3)
    np.testing.assert_allclose(res.x, 1.5, atol=1e-2)
    assert res.nfev_nonfinite > 0


# -- (b) ANFIS -------------------------------------------------------------------
def _plant(n=120, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(20, 30, (n, 2))
    return X, np.sin(X[:, 0]) + 0.1 * X[:, 1]


FAR = np.array([[1e3, 1e3], [-1e4, 25.0], [1e150, 25.0], [1e300, -1e300], [1.7e308, -1.7e308]])


@pytest.mark.parametrize(
    "model",
    [ANFISGrid(n_mfs=3, max_iter=30), ANFISFCM(n_clusters=3, max_iter=30, random_state=0)],
    ids=["grid", "fcm"],
)
def test_far_query_falls_back_to_the_training_mean(model):
    X, y = _plant()
    model.fit(X, y)
    far = model.predict(FAR)
    # no rule fires (every firing strength underflows): the default rule, ȳ
    np.testing.assert_allclose(far, y.mean(), rtol=1e-12)
    assert y.min() <= far.min() and far.max() <= y.max()
    # inside the training range nothing changed: the plain softmax, bit for bit
    Xs = (X - model.x_mean_) / model.x_scale_
    args = (model._mf_centres, model._mf_widths, model._mf_of_rule, model._consequents)
    plain = model.y_mean_ + model.y_scale_ * anfis_forward(Xs, *args)[0]
    assert model.predict(X).tobytes() == plain.tobytes()
    assert np.sqrt(np.mean((model.predict(X) - y) ** 2)) < 0.3


def test_default_rule_is_invisible_near_the_rules_and_takes_over_far_away():
    rng = np.random.default_rng(6)
    logw = -rng.uniform(0, 600, size=(500, 4))
    assert normalised_firing(logw, NO_FIRE_LOG).tobytes() == normalised_firing(logw).tobytes()
    far = normalised_firing(np.array([[-5000.0, -5001.0], [-np.inf, -np.inf]]), NO_FIRE_LOG)
    assert far.tolist() == [[0.0, 0.0], [0.0, 0.0]]
    # consequents that overflow at an infinitely far sample contribute 0, not NaN
    y, _, _ = anfis_forward(
        np.array([[np.inf], [1e308], [0.5]]),
        np.array([0.0, 1.0]),
        np.array([0.5, 0.5]),
        np.array([[0], [1]]),
        np.array([[1.0, 1e10], [2.0, 0.0]]),
        floor=NO_FIRE_LOG,
    )
    assert y[:2].tolist() == [0.0, 0.0] and 1.0 < y[2] < 2.0 + 1e10


def test_fcm_with_duplicate_rows_and_more_clusters_than_points():
    base = np.array([[21.0, 27.0], [28.0, 22.0]])
    X = np.repeat(base, 30, axis=0)
    y = X[:, 0] - X[:, 1]  # -6 and 6
    for alpha in (0.0, 1e-6):
        model = ANFISFCM(n_clusters=5, alpha=alpha, max_iter=20, random_state=0).fit(X, y)
        centres = np.round(model.cluster_centers_, 6)
        assert len(np.unique(centres, axis=0)) < 5  # identical cluster centres
        # exact without a penalty; the ridge penalty (alpha relative to the mean
        # diagonal of the normal equations) shrinks the consequents by O(alpha)
        np.testing.assert_allclose(model.predict(base), [-6.0, 6.0], rtol=10 * alpha, atol=1e-9)
        mid, far = model.predict(np.array([[24.5, 24.5], [1e6, -1e6]]))
        assert abs(mid) <= 6.0 and far == pytest.approx(0.0, abs=1e-12)  # ȳ = 0


def test_widths_collapsing_under_large_steps_stay_at_the_floor():
    X = np.linspace(0.0, 1.0, 41)[:, None]
    y = (X[:, 0] > 0.5).astype(float)  # a step: gradient steps sharpen the MFs
    result = hybrid_learning(
        X,
        y,
        np.array([0.0, 0.45, 0.55, 1.0]),
        np.array([1e-6, 0.2, 0.2, 1e-6]),
        np.array([[0], [1], [2], [3]]),
        n_epochs=60,
        alpha=0.0,
        step=JangStepSize(5.0, increase=2.0),
        min_width=1e-3,
        floor=NO_FIRE_LOG,
    )
    assert result["mf_widths"].min() >= 1e-3
    assert np.isfinite(result["train_error"]).all() and result["train_error"].min() < 0.2
    model = ANFISGrid(n_mfs=5, mf_overlap=1e-300, max_iter=30).fit(X, y)  # σ → floor at start
    pred = model.predict(np.linspace(-1.0, 2.0, 61)[:, None])
    assert np.isfinite(pred).all() and pred.min() >= -1.0 and pred.max() <= 2.0


def _constant_in_training_test():
    n = 40
    rng = np.random.default_rng(7)
    index = make_test_index(["A"] * n + ["B"] * n, list(range(n)) * 2)
    X = pd.DataFrame(
        {"T1": np.r_[np.full(n, 20.0), np.linspace(20, 30, n)], "T2": rng.uniform(20, 30, 2 * n)},
        index=index,
    )
    return X, 0.5 * X["T1"] + X["T2"]


@pytest.mark.parametrize(
    "make",
    [
        lambda: ANFISGrid(n_mfs=2, max_iter=20, validation_fraction=0.5, random_state=0),
        lambda: ANFISFCM(n_clusters=2, max_iter=20, validation_fraction=0.5, random_state=0),
    ],
    ids=["grid", "fcm"],
)
def test_column_constant_on_the_training_rows_is_ignored(make):
    X, y = _constant_in_training_test()
    model = make().fit(X, y)
    assert model.checking_ == "whole tests held out: test 'B'"  # T1 varies only there
    pred = model.predict(X)
    assert np.isfinite(pred).all()
    # the model does not depend on the input it never saw vary
    assert model.predict(X.assign(T1=-300.0)).tobytes() == pred.tobytes()
    rmse = np.sqrt(np.mean((pred[:40] - y.iloc[:40]) ** 2))
    assert rmse < 0.2


def test_column_constant_in_a_fold_is_a_clear_error():
    X, y = _constant_in_training_test()
    with pytest.raises(
        ValueError, match="Column 'T1' is constant \\(20\\) in every row of test 'A'"
    ):
        ANFISFCM(random_state=0).fit(X.loc[["A"]], y.loc[["A"]])


# -- (c) GM(1,N) -----------------------------------------------------------------
def _gm1n_data(n=50, seed=0):
    rng = np.random.default_rng(seed)
    x1 = 1.0 + rng.random(n)
    X1 = np.cumsum(x1)
    y = np.empty(n)
    y[0], acc = 1.0, 1.0
    for k in range(1, n):  # x⁰(k) + 0.3·z(k) = 0.5·x₁¹(k)
        y[k] = (0.5 * X1[k] - 0.3 * acc) / 1.15
        acc += y[k]
    return x1, y


@pytest.mark.parametrize(
    "second, exact",
    [
        (lambda x, r: x + 1e-10 * r.standard_normal(x.size), False),
        (lambda x, r: 2.0 * x, True),
        (lambda x, r: x.copy(), True),
    ],
    ids=["x1+1e-10noise", "2*x1", "copy"],
)
def test_near_collinear_sensors_are_reported_and_still_reproduce_the_data(second, exact):
    x1, y = _gm1n_data()
    X = np.column_stack([x1, second(x1, np.random.default_rng(1))])
    cond, groups = gm1n_conditioning(y, X)
    assert cond > 1e11 and groups == [[0, 1]]
    match = "rank deficient" if exact else "ill-conditioned"
    with pytest.warns(GreyConditioningWarning, match=rf"{match}.*x0, x1"):
        a, b = fit_gm1n(X, y)
    assert np.isfinite(a) and np.isfinite(b).all()
    B, Y = gm1n_design(y, X)
    np.testing.assert_allclose(B @ np.r_[a, b], Y, atol=1e-9)
    assert a == pytest.approx(0.3, abs=1e-6)
    assert b.sum() == pytest.approx(0.5, abs=1e-5) if not exact else True


def test_well_conditioned_sensors_are_not_flagged():
    x1, y = _gm1n_data()
    X = np.column_stack([x1, 1.0 + np.random.default_rng(2).random(x1.size)])
    cond, groups = gm1n_conditioning(y, X)
    assert cond < 1e3 and groups == []
    assert CONDITION_LIMIT == pytest.approx(6.7108864e7)


def test_near_collinear_sensors_warn_with_the_condition_number():
    x1, y = _gm1n_data()
    X = np.column_stack([x1, x1 + 1e-10 * np.random.default_rng(1).standard_normal(x1.size)])
    with pytest.warns(GreyConditioningWarning, match=r"condition number .*e\+11"):
        fit_gm1n(X, y)
