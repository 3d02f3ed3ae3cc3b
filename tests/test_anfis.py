"""ANFIS kernels and the ANFISGrid / ANFISFCM estimators."""

import itertools
import pickle

import numpy as np
import pandas as pd
import pytest
from sklearn.datasets import make_friedman1
from sklearn.model_selection import (
    GridSearchCV,
    LeaveOneGroupOut,
    cross_val_score,
    train_test_split,
)
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import ANFISFCM, ANFISGrid, groups_of, make_test_index
from greyml.fuzzy._kernels import (
    JangStepSize,
    anfis_forward,
    log_firing,
    normalised_firing,
    premise_gradient,
    solve_consequents,
)


def _sinc(t):
    out = np.ones_like(t)
    nz = t != 0
    out[nz] = np.sin(t[nz]) / t[nz]
    return out


def _grid_model(rng, n_inputs=2, m=3):
    centres = np.concatenate([np.linspace(-1, 1, m) for _ in range(n_inputs)])
    widths = 0.4 + 0.2 * rng.random(m * n_inputs)
    mf_of_rule = np.array(
        list(itertools.product(*[range(j * m, (j + 1) * m) for j in range(n_inputs)]))
    )
    consequents = rng.normal(size=(m**n_inputs, n_inputs + 1))
    return centres, widths, mf_of_rule, consequents


# -- kernels -------------------------------------------------------------------
def test_log_firing_equals_product_of_gaussians():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(7, 3))
    C = rng.normal(size=(4, 3))
    S = 0.5 + rng.random((4, 3))
    direct = np.log(np.prod(np.exp(-0.5 * ((X[:, None, :] - C) / S) ** 2), axis=2))
    np.testing.assert_allclose(log_firing(X, C, S), direct, atol=1e-12)


def test_normalised_firing_is_finite_far_from_every_rule():
    # exp(-0.5 * 1e4) underflows to 0 in every rule: 0/0 without the softmax
    logw = np.array([[-5000.0, -5001.0, -5010.0]])
    wbar = normalised_firing(logw)
    assert np.isfinite(wbar).all()
    np.testing.assert_allclose(wbar.sum(), 1.0)
    np.testing.assert_allclose(wbar[0, 0] / wbar[0, 1], np.e)


def test_forward_is_the_weighted_average_of_rule_outputs_by_hand():
    # one input, two rules at 0 and 2 with σ = 1, f1 = 1 + x, f2 = 3 - x; at x = 1
    # both fire equally: y = ½(2) + ½(2) = 2; at x = 0: w = (1, e^-2)
    c = np.array([0.0, 2.0])
    s = np.array([1.0, 1.0])
    mor = np.array([[0], [1]])
    theta = np.array([[1.0, 1.0], [3.0, -1.0]])
    y, wbar, _ = anfis_forward(np.array([[1.0], [0.0]]), c, s, mor, theta)
    w = np.exp(-2.0)
    np.testing.assert_allclose(y, [2.0, (1 * 1 + w * 3) / (1 + w)], rtol=1e-13)
    np.testing.assert_allclose(wbar[0], [0.5, 0.5])


def test_consequents_recovered_exactly_from_a_known_system():
    rng = np.random.default_rng(1)
    c, s, mor, theta = _grid_model(rng)
    X = rng.uniform(-1.2, 1.2, size=(300, 2))
    y, wbar, _ = anfis_forward(X, c, s, mor, theta)
    np.testing.assert_allclose(solve_consequents(wbar, X, y, alpha=0.0), theta, atol=1e-7)


def test_primal_and_dual_ridge_solutions_agree():
    rng = np.random.default_rng(2)
    c, s, mor, theta = _grid_model(rng, n_inputs=2, m=3)
    X = rng.uniform(-1, 1, size=(40, 2))  # 27 unknowns < 40 rows: primal
    y = rng.normal(size=40)
    wbar = normalised_firing(log_firing(X, c[mor], s[mor]))
    primal = solve_consequents(wbar, X, y, alpha=1e-3)
    # the dual route on the same problem (fewer rows than unknowns is forced by
    # solving the transposed system by hand)
    A = (wbar[:, :, None] * np.column_stack([np.ones(40), X])[:, None, :]).reshape(40, -1)
    lam = 1e-3 * np.trace(A.T @ A) / A.shape[1]
    dual = A.T @ np.linalg.solve(A @ A.T + lam * np.eye(40), y)
    np.testing.assert_allclose(primal.ravel(), dual, rtol=1e-8, atol=1e-10)
    # more unknowns than rows: the dual branch runs and interpolates almost exactly
    few = solve_consequents(wbar[:10], X[:10], y[:10], alpha=1e-10)
    y_fit = np.einsum("nr,nr->n", wbar[:10], few[:, 0] + X[:10] @ few[:, 1:].T)
    np.testing.assert_allclose(y_fit, y[:10], atol=1e-6)


def test_premise_gradient_matches_finite_differences_with_shared_mfs():
    rng = np.random.default_rng(3)
    c, s, mor, theta = _grid_model(rng)
    X = rng.uniform(-1.5, 1.5, size=(25, 2))
    y = rng.normal(size=25)

    def loss(cc, ss):
        return 0.5 * np.sum((anfis_forward(X, cc, ss, mor, theta)[0] - y) ** 2)

    y_hat, wbar, rule_out = anfis_forward(X, c, s, mor, theta)
    gc, gs = premise_gradient(X, y_hat - y, wbar, rule_out, y_hat, c, s, mor)
    h = 1e-6
    for i in range(c.size):
        e = np.zeros_like(c)
        e[i] = h
        np.testing.assert_allclose(
            gc[i], (loss(c + e, s) - loss(c - e, s)) / (2 * h), rtol=1e-5, atol=1e-7
        )
        np.testing.assert_allclose(
            gs[i], (loss(c, s + e) - loss(c, s - e)) / (2 * h), rtol=1e-5, atol=1e-7
        )


def test_jang_step_size_rule_by_hand():
    step = JangStepSize(1.0, 1.1, 0.9)
    for e in [5, 4, 3, 2]:
        assert step.update(e) == 1.0  # fewer than five errors: no change yet
    assert step.update(1) == pytest.approx(1.1)  # four consecutive reductions
    assert step.update(0.5) == pytest.approx(1.21)  # the window slides
    step = JangStepSize(1.0, 1.1, 0.9)
    for e in [1, 2, 1, 2]:
        step.update(e)
    assert step.update(1) == pytest.approx(0.9)  # up, down, up, down
    step = JangStepSize(1.0, 1.1, 0.9)
    for e in [1, 2, 3, 2]:
        step.update(e)
    assert step.update(1) == 1.0  # neither rule


# -- estimators: accuracy ------------------------------------------------------
def test_sinc_benchmark_16_rules_250_epochs():
    grid = np.linspace(-10, 10, 11)
    X = np.array(list(itertools.product(grid, grid)))
    y = _sinc(X[:, 0]) * _sinc(X[:, 1])
    Xt = np.random.default_rng(0).uniform(-10, 10, size=(1000, 2))
    yt = _sinc(Xt[:, 0]) * _sinc(Xt[:, 1])
    model = ANFISGrid(n_mfs=4, max_iter=250).fit(X, y)
    assert model.n_rules_ == 16
    rmse = np.sqrt(np.mean((model.predict(Xt) - yt) ** 2))
    assert rmse <= 0.035, rmse


def test_friedman1_three_rules():
    X, y = make_friedman1(n_samples=2000, n_features=5, noise=1.0, random_state=0)
    Xtr, Xte, ytr, yte = train_test_split(X, y, test_size=0.25, random_state=0)
    model = ANFISFCM(n_clusters=3, m=1.7, max_iter=300, random_state=0).fit(Xtr, ytr)
    rmse = np.sqrt(np.mean((model.predict(Xte) - yte) ** 2))
    assert rmse <= 1.03, rmse
    # a linear model cannot get there: the rules matter
    A = np.column_stack([np.ones(len(Xtr)), Xtr])
    coef = np.linalg.lstsq(A, ytr, rcond=None)[0]
    linear = np.sqrt(np.mean((np.column_stack([np.ones(len(Xte)), Xte]) @ coef - yte) ** 2))
    assert linear > 2.0


def test_rules_reproduce_predictions_in_user_units():
    rng = np.random.default_rng(4)
    X = pd.DataFrame({"T18": 25 + 8 * rng.random(120), "T55": 22 + 5 * rng.random(120)})
    y = pd.Series(3 * (X["T18"] - 25) + np.sin(X["T55"]), name="dz")
    for model in (ANFISGrid(n_mfs=2, max_iter=20), ANFISFCM(n_clusters=3, random_state=0)):
        model.fit(X, y)
        x = X.to_numpy()
        logw = np.zeros((len(x), model.n_rules_))
        out = np.zeros((len(x), model.n_rules_))
        for r, rule in enumerate(model.rules_):
            for j, (name, c, s) in enumerate(rule["if"]):
                assert name == X.columns[j]
                logw[:, r] += -0.5 * ((x[:, j] - c) / s) ** 2
            then = rule["then"]
            out[:, r] = then["intercept"] + x @ np.array([then["coef"][n] for n in X.columns])
        w = np.exp(logw - logw.max(axis=1, keepdims=True))
        y_rules = np.sum(w * out, axis=1) / w.sum(axis=1)
        np.testing.assert_allclose(y_rules, model.predict(X), rtol=1e-9, atol=1e-9)
        text = model.describe_rules(unit="°C", digits=3)
        first = text.splitlines()[0]
        assert first.startswith("Rule 1: IF T18 is about ")
        assert "°C (σ " in first and " AND T55 is about " in first and " THEN dz = " in first
        assert len(text.splitlines()) == model.n_rules_


# -- estimators: checking data -------------------------------------------------
def _three_tests():
    rng = np.random.default_rng(5)
    frames = []
    for label, n in [("I", 60), ("II", 50), ("III", 70)]:
        t = np.arange(n) * 60.0
        T = 20 + 10 * (1 - np.exp(-t / 1500)) + 0.1 * rng.normal(size=n)
        frames.append(
            pd.DataFrame(
                {"T1": T, "T2": 20 + 0.5 * (T - 20) + 0.1 * rng.normal(size=n)},
                index=make_test_index([label] * n, t),
            )
        )
    X = pd.concat(frames)
    y = 4 * (X["T1"] - 20) - 2 * (X["T2"] - 20) + 0.2 * rng.normal(size=len(X))
    return X, y


def test_checking_data_are_whole_tests_and_the_best_epoch_is_kept():
    X, y = _three_tests()
    model = ANFISFCM(n_clusters=2, max_iter=40, validation_fraction=0.34, random_state=0)
    model.fit(X, y)
    assert model.checking_.startswith("whole tests held out: test ")
    assert model.check_error_.size == model.n_iter_
    best = int(np.argmin(model.check_error_))
    assert model.best_epoch_ == best + 1
    # kept parameters give the best checking error again
    held = model.checking_.split("test ")[-1].strip("'")
    Xc, yc = X.xs(held, level="test", drop_level=False), y.xs(held, level="test")
    rmse = np.sqrt(np.mean((model.predict(Xc) - yc.to_numpy()) ** 2))
    np.testing.assert_allclose(rmse, model.check_error_[best], rtol=1e-9)


def test_single_test_checks_on_its_last_rows_and_explicit_checking_data():
    X, y = _three_tests()
    Xi, yi = X.xs("I", level="test", drop_level=False), y.xs("I", level="test", drop_level=False)
    model = ANFISGrid(n_mfs=2, max_iter=10, validation_fraction=0.25).fit(Xi, yi)
    assert model.checking_ == "last 15 of 60 rows"
    Xv, yv = X.xs("II", level="test", drop_level=False), y.xs("II", level="test")
    model = ANFISGrid(n_mfs=2, max_iter=10).fit(Xi, yi, X_val=Xv, y_val=yv)
    assert model.checking_ == "explicit checking data (50 rows)"
    with pytest.raises(ValueError, match="give one of them"):
        ANFISGrid(validation_fraction=0.2).fit(Xi, yi, X_val=Xv, y_val=yv)
    with pytest.raises(ValueError, match="X_val and y_val together"):
        ANFISGrid().fit(Xi, yi, X_val=Xv)


# -- estimators: sklearn integration, determinism, persistence -----------------
@pytest.mark.parametrize(
    "model",
    [ANFISGrid(n_mfs=2, max_iter=15), ANFISFCM(n_clusters=2, max_iter=15, random_state=0)],
    ids=["grid", "fcm"],
)
def test_pipeline_gridsearch_and_leave_one_test_out(model):
    X, y = _three_tests()
    pipe = make_pipeline(StandardScaler(), model)
    scores = cross_val_score(
        pipe,
        X,
        y,
        groups=groups_of(X),
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    )
    assert scores.shape == (3,)
    assert np.all(-scores < 3.0)  # signal spans ~40 units
    key = "anfisgrid__n_mfs" if isinstance(model, ANFISGrid) else "anfisfcm__n_clusters"
    search = GridSearchCV(pipe, {key: [1, 2]}, cv=LeaveOneGroupOut())
    search.fit(X, y, groups=groups_of(X))
    assert search.best_params_[key] in (1, 2)


@pytest.mark.parametrize(
    "make",
    [
        lambda s: ANFISGrid(n_mfs=2, max_iter=20, validation_fraction=0.3, random_state=s),
        lambda s: ANFISFCM(n_clusters=3, max_iter=20, validation_fraction=0.3, random_state=s),
    ],
    ids=["grid", "fcm"],
)
def test_bit_identical_pickles_and_leaves_inputs_and_global_state_alone(make):
    X, y = _three_tests()
    X_before, y_before = X.copy(), y.copy()
    state = np.random.get_state()
    a = make(7).fit(X, y)
    b = make(7).fit(X, y)
    assert np.random.get_state()[1].tobytes() == state[1].tobytes()
    pd.testing.assert_frame_equal(X, X_before)
    pd.testing.assert_series_equal(y, y_before)
    assert a.predict(X).tobytes() == b.predict(X).tobytes()
    c = pickle.loads(pickle.dumps(a))
    assert c.predict(X).tobytes() == a.predict(X).tobytes()


# -- bad input -----------------------------------------------------------------
def test_rule_limit_names_the_count_and_suggests_fcm():
    X = np.random.default_rng(0).random((50, 8))
    with pytest.raises(ValueError, match=r"3 × 3 × 3 × 3 × 3 × 3 × 3 × 3 = 6,561 rules.*ANFISFCM"):
        ANFISGrid(n_mfs=3).fit(X, X[:, 0])
    with pytest.raises(ValueError, match="n_mfs for 3 inputs but X has 8 columns"):
        ANFISGrid(n_mfs=[2, 2, 2]).fit(X, X[:, 0])


@pytest.mark.parametrize("cls", [ANFISGrid, ANFISFCM])
def test_bad_input_names_column_and_test(cls):
    X, y = _three_tests()
    bad = X.copy()
    bad.iloc[70, 1] = np.nan
    with pytest.raises(ValueError, match="column 'T2' has NaN in test 'II'"):
        cls().fit(bad, y)
    bad = X.copy()
    bad.iloc[3, 0] = np.inf
    with pytest.raises(ValueError, match="column 'T1' has infinity"):
        cls().fit(bad, y)
    const = X.assign(T2=1.0)
    with pytest.raises(ValueError, match="Column 'T2' is constant"):
        cls().fit(const, y)
    with pytest.raises(ValueError, match="too few samples"):
        cls().fit(X.iloc[:3], y.iloc[:3])
    with pytest.raises(ValueError, match="y to be passed"):
        cls().fit(X, None)
    y_bad = y.copy()
    y_bad.iloc[5] = np.nan
    with pytest.raises(ValueError, match="Input y contains NaN"):
        cls().fit(X, y_bad)
    fitted = cls(max_iter=2).fit(X, y)
    with pytest.raises(ValueError, match="feature names"):
        fitted.predict(X[["T2", "T1"]])


@pytest.mark.parametrize(
    "params, match",
    [
        ({"max_iter": 0}, "'max_iter' parameter"),
        ({"step_size": -1.0}, "'step_size' parameter"),
        ({"alpha": -1e-3}, "'alpha' parameter"),
        ({"validation_fraction": 1.0}, "'validation_fraction' parameter"),
        ({"step_increase": 0.5}, "step_increase >= 1"),
    ],
)
def test_bad_parameters(params, match):
    X, y = _three_tests()
    with pytest.raises(ValueError, match=match):
        ANFISFCM(**params).fit(X, y)


def test_bad_fcm_and_grid_parameters():
    X, y = _three_tests()
    with pytest.raises(ValueError, match=r"'m' parameter of ANFISFCM .* \(1.0, inf\)"):
        ANFISFCM(m=1.0).fit(X, y)
    with pytest.raises(ValueError, match="'n_mfs' parameter"):
        ANFISGrid(n_mfs=[2, 0]).fit(X, y)
    with pytest.raises(ValueError, match="'mf_overlap' parameter"):
        ANFISGrid(mf_overlap=1.0).fit(X, y)


def test_clustering_a_subset_keeps_memberships_of_every_row():
    from greyml.fuzzy._kernels import fcm_memberships as _memberships

    rng = np.random.default_rng(8)
    data = np.vstack([rng.normal(0, 0.3, (60, 2)), rng.normal(3, 0.3, (60, 2))])
    centres = np.array([[0.0, 0.0], [3.0, 3.0]])
    u = _memberships(data, centres, 2.0)
    np.testing.assert_allclose(u.sum(axis=0), 1.0)
    # by hand for one row: u_1 = 1 / (1 + (d1/d2)^2) with m = 2
    d1, d2 = np.linalg.norm(data[0] - centres[0]), np.linalg.norm(data[0] - centres[1])
    assert u[0, 0] == pytest.approx(1 / (1 + (d1 / d2) ** 2))
    X, y = data[:, :1], data[:, 1]
    full = ANFISFCM(n_clusters=2, max_iter=5, random_state=0).fit(X, y)
    part = ANFISFCM(n_clusters=2, max_iter=5, fcm_max_samples=40, random_state=0).fit(X, y)
    # the two well-separated clusters are found from a third of the rows too
    np.testing.assert_allclose(
        np.sort(part.cluster_centers_[:, 0]), np.sort(full.cluster_centers_[:, 0]), atol=0.15
    )


def test_max_iter_and_cluster_centers_are_the_names():
    X, y = make_friedman1(n_samples=80, n_features=5, random_state=0)
    X = X[:, :3]
    model = ANFISFCM(n_clusters=2, max_iter=4, random_state=0).fit(X, y)
    assert model.n_iter_ == 4
    assert model.cluster_centers_.shape == (2, 3)
