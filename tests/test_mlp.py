"""MLPBaseline and its kernels: Jacobian, LM steps, recovery, validation stop, sklearn use."""

import pickle
import re

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

from greyml import groups_of, make_test_index
from greyml.exceptions import UnderdeterminedWarning
from greyml.neural import MLPBaseline
from greyml.neural._kernels import (
    hidden,
    init_nguyen_widrow,
    levenberg_marquardt,
    mlp_forward,
    mlp_jacobian,
    mlp_residuals,
    n_params,
    pack,
    unpack,
)

SENSORS = ["T1_C", "T2_C", "T3_C", "T4_C"]

# a 4-3-1 teacher network acting on (T − 20 °C) / 3 K
TEACHER_W = np.array([[1.5, -2.0, 0.5], [0.8, 1.0, -1.7], [-1.2, 0.4, 1.1], [0.3, -0.9, -0.6]])
TEACHER_B = np.array([0.5, -0.3, 0.2])
TEACHER_V = np.array([2.0, -1.5, 1.0])
TEACHER_C = 0.3


def teacher(X, activation="logistic"):
    """Displacement in µm from the teacher network."""
    p = pack(TEACHER_W, TEACHER_B, TEACHER_V, TEACHER_C)
    return 10.0 * mlp_forward((np.asarray(X) - 20.0) / 3.0, p, 3, activation)


def sigmoid(z):
    return 1.0 / (1.0 + np.exp(-z))


def teacher_tests(seed=0, sizes=(("I", 60), ("II", 80), ("III", 70), ("IV", 90), ("V", 50))):
    """Several tests (rows independent, uniform temperatures) with the teacher's target."""
    rng = np.random.default_rng(seed)
    frames = []
    for label, n in sizes:
        X = rng.uniform(15.0, 25.0, size=(n, 4))
        index = make_test_index([label] * n, 10.0 * np.arange(n))
        frame = pd.DataFrame(X, index=index, columns=SENSORS)
        frame["dz_um"] = teacher(X)
        frames.append(frame)
    data = pd.concat(frames)
    return data[SENSORS], data["dz_um"]


# ---- kernels ---------------------------------------------------------------------------
def test_pack_unpack_round_trip():
    rng = np.random.default_rng(0)
    W, b, v = rng.normal(size=(4, 3)), rng.normal(size=3), rng.normal(size=3)
    p = pack(W, b, v, 0.7)
    assert p.shape == (n_params(4, 3),) == (19,)
    W2, b2, v2, c2 = unpack(p, 4, 3)
    np.testing.assert_array_equal(W2, W)
    np.testing.assert_array_equal(b2, b)
    np.testing.assert_array_equal(v2, v)
    assert c2 == 0.7


def test_hidden_logistic_is_the_log_sigmoid():
    z = np.linspace(-30, 30, 61)[:, None]
    np.testing.assert_allclose(
        hidden(z, np.ones((1, 1)), np.zeros(1))[:, 0], sigmoid(z[:, 0]), rtol=1e-14, atol=1e-15
    )
    np.testing.assert_allclose(
        hidden(z, np.ones((1, 1)), np.zeros(1), "tanh")[:, 0], np.tanh(z[:, 0]), rtol=1e-15
    )
    with pytest.raises(ValueError, match="Unknown activation 'relu'"):
        hidden(z, np.ones((1, 1)), np.zeros(1), "relu")


def test_jacobian_of_a_1_1_1_network_by_hand():
    """ŷ = v σ(w x + b) + c with w = 2, b = −1, v = 3, c = 0.5 at x = 0.25 and 1."""
    p = np.array([2.0, -1.0, 3.0, 0.5])
    X = np.array([[0.25], [1.0]])
    J, y_hat = mlp_jacobian(X, p, 1)
    for row, x in enumerate([0.25, 1.0]):
        s = sigmoid(2.0 * x - 1.0)
        ds = s * (1 - s)
        np.testing.assert_allclose(J[row], [x * 3.0 * ds, 3.0 * ds, s, 1.0], rtol=1e-14)
        assert y_hat[row] == pytest.approx(3.0 * s + 0.5, rel=1e-15)
    # x = 0.5: σ(0) = 1/2, σ' = 1/4 exactly
    J, y_hat = mlp_jacobian(np.array([[0.5]]), p, 1)
    np.testing.assert_allclose(J[0], [0.375, 0.75, 0.5, 1.0], rtol=1e-15)
    assert y_hat[0] == pytest.approx(2.0)


@pytest.mark.parametrize("activation", ["logistic", "tanh"])
def test_jacobian_equals_finite_differences(activation):
    rng = np.random.default_rng(1)
    n_in, n_hidden = 3, 4
    X = rng.normal(size=(25, n_in))
    y = rng.normal(size=25)
    p = rng.normal(size=n_params(n_in, n_hidden))
    J, y_hat = mlp_jacobian(X, p, n_hidden, activation)
    np.testing.assert_allclose(y_hat, mlp_forward(X, p, n_hidden, activation), rtol=1e-14)
    h = 1e-6
    fd = np.empty_like(J)
    for k in range(p.size):
        e = np.zeros_like(p)
        e[k] = h
        fd[:, k] = (
            mlp_residuals(X, y, p + e, n_hidden, activation)
            - mlp_residuals(X, y, p - e, n_hidden, activation)
        ) / (2 * h)
    np.testing.assert_allclose(J, fd, rtol=1e-7, atol=1e-9)
    # writing into a given buffer gives the same numbers
    out = np.full_like(J, np.nan)
    J2, _ = mlp_jacobian(X, p, n_hidden, activation, out=out)
    assert J2 is out
    np.testing.assert_array_equal(J2, J)


@pytest.mark.parametrize("activation, scale", [("logistic", 2.0), ("tanh", 1.0)])
def test_nguyen_widrow_initialisation(activation, scale):
    n_in, n_hidden = 5, 10
    p = init_nguyen_widrow(n_in, n_hidden, np.random.default_rng(0), activation)
    W, b, v, c = unpack(p, n_in, n_hidden)
    beta = 0.7 * n_hidden ** (1 / n_in)
    np.testing.assert_allclose(np.linalg.norm(W, axis=0), scale * beta, rtol=1e-12)
    assert np.all(np.abs(b) <= scale * beta)
    assert np.all(np.abs(v) <= 1 / np.sqrt(n_hidden)) and c == 0.0
    again = init_nguyen_widrow(n_in, n_hidden, np.random.default_rng(0), activation)
    np.testing.assert_array_equal(p, again)


def test_first_lm_epoch_is_the_damped_gauss_newton_step():
    """One epoch by hand: p₁ = p₀ − (JᵀJ + μI)⁻¹Jᵀr for the first μ of 1e-3, 1e-2, …
    (trainlm's start and increase) whose step lowers the MSE."""
    rng = np.random.default_rng(2)
    X = rng.normal(size=(40, 2))
    y = np.sin(X[:, 0]) - 0.5 * X[:, 1] ** 2
    p0 = init_nguyen_widrow(2, 3, rng)
    p0_copy = p0.copy()
    J, y_hat = mlp_jacobian(X, p0, 3)
    r = y_hat - y
    mse0 = np.mean(r**2)
    for k in range(10):
        mu = 1e-3 * 10.0**k
        p1 = p0 - np.linalg.solve(J.T @ J + mu * np.eye(p0.size), J.T @ r)
        mse1 = np.mean(mlp_residuals(X, y, p1, 3) ** 2)
        if mse1 < mse0:
            break
    assert k == 1  # this start needs one increase of μ: both paths are exercised
    result = levenberg_marquardt(X, y, p0, 3, max_iter=1)
    np.testing.assert_array_equal(p0, p0_copy)  # the start is not modified
    np.testing.assert_allclose(result.p, p1, rtol=1e-9, atol=1e-12)
    assert result.loss == pytest.approx(mse1, rel=1e-12)
    assert (result.n_iter, result.best_iter, result.stop, result.val_loss) == (
        1,
        1,
        "max_iter",
        None,
    )


def test_lm_recovers_a_network_from_its_own_data():
    """Exact data from a 4-3-1 network: LM drives the MSE to ~0 and the function
    is recovered on unseen inputs."""
    rng = np.random.default_rng(3)
    X = (rng.uniform(15, 25, size=(300, 4)) - 20) / 3
    y = teacher(20 + 3 * X) / 10
    result = levenberg_marquardt(X, y, init_nguyen_widrow(4, 3, rng), 3, goal=1e-24, max_iter=500)
    assert result.stop in ("goal", "min_grad") and result.loss < 1e-18
    Xn = rng.normal(size=(500, 4))
    np.testing.assert_allclose(mlp_forward(Xn, result.p, 3), teacher(20 + 3 * Xn) / 10, atol=1e-7)


def _noisy_problem(seed=4, n=160):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1.5, 1.5, size=(n, 2))
    y = np.sin(2 * X[:, 0]) * X[:, 1] + 0.3 * rng.normal(size=n)
    return X, y


def test_validation_stop_keeps_the_best_checking_weights():
    """The epochs of one run are reproduced by runs with max_iter = k (the same
    deterministic path); the kept weights are those of the lowest checking MSE,
    and training stops max_fail epochs after it."""
    X, y = _noisy_problem()
    Xt, yt, Xv, yv = X[:120], y[:120], X[120:], y[120:]
    p0 = init_nguyen_widrow(2, 12, np.random.default_rng(0))
    result = levenberg_marquardt(Xt, yt, p0, 12, X_val=Xv, y_val=yv, max_fail=6)
    assert result.stop == "max_fail"
    assert result.n_iter == result.best_iter + 6
    path = [levenberg_marquardt(Xt, yt, p0, 12, max_iter=k).p for k in range(result.n_iter + 1)]
    val = [np.mean(mlp_residuals(Xv, yv, p, 12) ** 2) for p in path]
    assert int(np.argmin(val)) == result.best_iter
    np.testing.assert_array_equal(result.p, path[result.best_iter])
    assert result.val_loss == pytest.approx(min(val), rel=1e-12)
    assert all(v >= min(val) for v in val[result.best_iter + 1 :])
    # training went on lowering the training MSE after the kept epoch
    train = [np.mean(mlp_residuals(Xt, yt, p, 12) ** 2) for p in path]
    assert train[-1] < train[result.best_iter] == pytest.approx(result.loss, rel=1e-12)


def test_lm_stops_when_no_step_helps():
    """Converged to machine precision with min_grad = 0: every step fails, μ grows
    past mu_max, and the last accepted weights are kept."""
    X, y = _noisy_problem()
    p0 = init_nguyen_widrow(2, 2, np.random.default_rng(0))
    result = levenberg_marquardt(X, y, p0, 2, min_grad=0.0, max_iter=2000)
    assert result.stop == "mu_max" and result.n_iter < 2000
    J, y_hat = mlp_jacobian(X, result.p, 2)
    assert np.linalg.norm(J.T @ (y_hat - y)) / len(y) < 1e-8  # a stationary point
    exact = levenberg_marquardt(X, np.zeros_like(y), np.zeros(n_params(2, 2)), 2, goal=0.0)
    assert (exact.stop, exact.n_iter, exact.loss) == ("goal", 0, 0.0)


# ---- the estimator ---------------------------------------------------------------------
def test_friedman1_benchmark():
    """make_friedman1 (noise σ = 1) with a 75/25 split: the noise alone gives a test
    RMSE of 0.987. The defaults (5-10-1, validation stop) measure 1.00-1.04 over
    seeds: the 71 weights fitted to 1500 noisy rows add an estimation error of
    about √(71/1500)·σ ≈ 0.22 in quadrature. Asserted: test RMSE ≤ 1.05 and the
    error against the noise-free function ≤ 0.4 (the target's spread is 5.1)."""
    X, y = make_friedman1(n_samples=2000, n_features=5, noise=1.0, random_state=0)
    f = (
        10 * np.sin(np.pi * X[:, 0] * X[:, 1])
        + 20 * (X[:, 2] - 0.5) ** 2
        + 10 * X[:, 3]
        + 5 * X[:, 4]
    )
    Xtr, Xte, ytr, yte, _, fte = train_test_split(X, y, f, test_size=0.25, random_state=0)
    oracle = np.sqrt(np.mean((yte - fte) ** 2))
    assert oracle == pytest.approx(0.9867, abs=1e-4)
    model = MLPBaseline(random_state=0).fit(Xtr, ytr)
    pred = model.predict(Xte)
    rmse = np.sqrt(np.mean((pred - yte) ** 2))
    assert rmse <= 1.05
    assert np.sqrt(np.mean((pred - fte) ** 2)) <= 0.4
    assert model.stop_reason_ == "max_fail" and model.checking_ == "last 225 of 1500 rows"
    assert model.coefs_[0].shape == (5, 10) and model.coefs_[1].shape == (10, 1)
    assert model.intercepts_[0].shape == (10,) and model.intercepts_[1].shape == (1,)


@pytest.mark.parametrize("activation", ["logistic", "tanh"])
def test_estimator_recovers_the_teacher(activation):
    """Exact data in °C and µm: the goal stop is reached and the network is
    recovered on unseen temperatures to 1e-8 of the target's spread."""
    rng = np.random.default_rng(5)
    X, Xn = rng.uniform(15, 25, size=(400, 4)), rng.uniform(15, 25, size=(500, 4))
    y = teacher(X, activation)
    model = MLPBaseline(
        3, activation=activation, validation_fraction=0, goal=1e-20, max_iter=500, random_state=0
    ).fit(X, y)
    assert model.best_validation_loss_ is None and model.checking_ == "no checking data"
    assert model.loss_ < 1e-18
    np.testing.assert_allclose(model.predict(Xn), teacher(Xn, activation), atol=1e-8 * y.std())
    # the standardisation statistics are those of the data
    np.testing.assert_allclose(model.x_mean_, X.mean(axis=0))
    np.testing.assert_allclose(model.x_scale_, X.std(axis=0))
    assert model.y_mean_ == pytest.approx(y.mean()) and model.y_scale_ == pytest.approx(y.std())


def test_goal_and_max_iter_stop():
    X, y = _noisy_problem()
    coarse = MLPBaseline(4, goal=0.5, validation_fraction=0, random_state=0).fit(X, y)
    assert coarse.stop_reason_ == "goal" and coarse.loss_ <= 0.5
    short = MLPBaseline(4, max_iter=3, validation_fraction=0, random_state=0).fit(X, y)
    assert short.stop_reason_ == "max_iter" and short.n_iter_ == short.best_iter_ == 3


def test_restarts_keep_the_lowest_error():
    """Each initialisation is the next Nguyen–Widrow draw of the same generator;
    the estimator keeps the one with the lowest training MSE (no checking data)."""
    X, y = _noisy_problem()
    Xs = (X - X.mean(axis=0)) / X.std(axis=0)
    ys = (y - y.mean()) / y.std()
    rng = np.random.default_rng(7)
    runs = [
        levenberg_marquardt(Xs, ys, init_nguyen_widrow(2, 6, rng), 6, max_iter=40, goal=1e-4)
        for _ in range(4)
    ]
    model = MLPBaseline(6, n_restarts=4, max_iter=40, validation_fraction=0, random_state=7).fit(
        X, y
    )
    best = min(runs, key=lambda r: r.loss)
    assert len({r.loss for r in runs}) == 4  # the restarts differ
    assert model.loss_ == best.loss
    np.testing.assert_array_equal(model.coefs_[0], unpack(best.p, 2, 6)[0])


def test_single_test_checks_on_its_last_rows():
    X, y = _noisy_problem()
    model = MLPBaseline(6, validation_fraction=0.25, random_state=0).fit(X, y)
    assert model.checking_ == "last 40 of 160 rows"
    z = (model.predict(X) - y) / model.y_scale_  # standardised residuals
    assert model.best_validation_loss_ == pytest.approx(np.mean(z[120:] ** 2), rel=1e-10)
    assert model.loss_ == pytest.approx(np.mean(z[:120] ** 2), rel=1e-10)


def test_whole_tests_are_held_out():
    X, y = teacher_tests()
    y = y + np.random.default_rng(0).normal(scale=0.5, size=len(y))
    model = MLPBaseline(4, validation_fraction=0.2, random_state=1).fit(X, y)
    held = re.fullmatch(r"whole tests held out: test '(\w+)'", model.checking_).group(1)
    mask = groups_of(X) == held
    z = (model.predict(X) - y.to_numpy()) / model.y_scale_
    assert model.best_validation_loss_ == pytest.approx(np.mean(z[mask] ** 2), rel=1e-10)
    assert model.loss_ == pytest.approx(np.mean(z[~mask] ** 2), rel=1e-10)
    # another seed may hold out another test; with 0.4, two of the five tests
    two = MLPBaseline(4, validation_fraction=0.4, random_state=1).fit(X, y)
    assert len(re.findall(r"test '\w+'", two.checking_)) == 2


def test_units_do_not_matter():
    """°C and µm or K and mm with offsets: the standardised problem, and so the
    prediction in the given units, is the same."""
    X, y = _noisy_problem()
    a = MLPBaseline(6, max_iter=20, random_state=0).fit(X, y)
    b = MLPBaseline(6, max_iter=20, random_state=0).fit(X * 1e-2 + 273.15, y * 1e-3 - 5)
    np.testing.assert_allclose(b.predict(X * 1e-2 + 273.15), a.predict(X) * 1e-3 - 5, atol=1e-7)


def test_bit_identical_and_global_state_untouched():
    X, y = teacher_tests()
    state = np.random.get_state()
    a = MLPBaseline(random_state=3).fit(X, y)
    b = MLPBaseline(random_state=3).fit(X, y)
    np.testing.assert_array_equal(a.predict(X), b.predict(X))
    np.testing.assert_array_equal(a.coefs_[0], b.coefs_[0])
    assert a.checking_ == b.checking_
    c = MLPBaseline(random_state=4).fit(X, y)
    assert not np.array_equal(a.coefs_[0], c.coefs_[0])
    MLPBaseline(random_state=None).fit(X, y)  # OS entropy, not the global state
    after = np.random.get_state()
    assert np.array_equal(state[1], after[1]) and state[2:] == after[2:]


def test_fit_does_not_modify_inputs():
    X, y = teacher_tests()
    X0, y0 = X.copy(), y.copy()
    MLPBaseline(4, random_state=0).fit(X, y).predict(X)
    pd.testing.assert_frame_equal(X, X0)
    pd.testing.assert_series_equal(y, y0)
    Xa, ya = X.to_numpy(), y.to_numpy()
    Xa0, ya0 = Xa.copy(), ya.copy()
    MLPBaseline(4, random_state=0).fit(Xa, ya).predict(Xa)
    np.testing.assert_array_equal(Xa, Xa0)
    np.testing.assert_array_equal(ya, ya0)


def test_pickle_round_trip():
    X, y = teacher_tests()
    model = MLPBaseline(4, random_state=0).fit(X, y)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict(X), model.predict(X))
    assert list(again.feature_names_in_) == SENSORS


def test_pipeline_grid_search_over_hidden_units():
    """Exact data from a 3-hidden-unit network: one unit cannot represent it, three
    can; leave-one-test-out grid search finds that."""
    X, y = teacher_tests()
    pipe = make_pipeline(
        StandardScaler().set_output(transform="pandas"), MLPBaseline(random_state=0)
    )
    grid = GridSearchCV(
        pipe,
        {"mlpbaseline__hidden_layer_sizes": [1, (3,)]},
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    ).fit(X, y, groups=groups_of(X))
    assert grid.best_params_["mlpbaseline__hidden_layer_sizes"] == (3,)
    rmse = -grid.cv_results_["mean_test_score"]
    assert rmse[1] < 0.1 * rmse[0]
    assert rmse[1] < 0.02 * y.std()


def test_cross_val_score_leave_one_test_out():
    X, y = teacher_tests()
    scores = cross_val_score(
        MLPBaseline(3, random_state=0),
        X,
        y,
        groups=groups_of(X),
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    )
    assert scores.shape == (5,)
    assert np.all(-scores < 0.02 * y.std())


# ---- bad input and parameters ----------------------------------------------------------
def test_y_none_is_a_clear_error():
    X, _ = teacher_tests()
    with pytest.raises(ValueError, match="MLPBaseline requires y to be passed"):
        MLPBaseline().fit(X, None)


def test_more_than_one_hidden_layer_is_refused():
    X, y = teacher_tests()
    with pytest.raises(
        ValueError, match=r"one hidden layer only: hidden_layer_sizes=\(10, 5\) asks for 2"
    ):
        MLPBaseline((10, 5)).fit(X, y)


@pytest.mark.parametrize(
    "params, match",
    [
        (
            {"hidden_layer_sizes": 0},
            r"'hidden_layer_sizes' parameter of MLPBaseline must be an int in the range \[1, inf\), an instance of 'tuple' or an instance of 'list'. Got 0",
        ),
        ({"hidden_layer_sizes": ()}, r"'hidden_layer_sizes' .* Got \(\) instead"),
        ({"hidden_layer_sizes": 2.5}, r"'hidden_layer_sizes' .* Got 2.5 instead"),
        (
            {"activation": "relu"},
            r"'activation' parameter of MLPBaseline must be a str among \{('logistic', 'tanh'|'tanh', 'logistic')\}. Got 'relu'",
        ),
        (
            {"max_iter": 0},
            r"'max_iter' parameter of MLPBaseline must be an int in the range \[1, inf\). Got 0",
        ),
        ({"n_restarts": 0}, r"'n_restarts' parameter .* Got 0"),
        ({"max_fail": 1.5}, r"'max_fail' parameter .* Got 1.5"),
        (
            {"goal": -1e-4},
            r"'goal' parameter of MLPBaseline must be a float in the range \[0.0, inf\). Got -0.0001",
        ),
        ({"goal": np.nan}, r"'goal' parameter .* Got nan"),
        (
            {"validation_fraction": 1.0},
            r"'validation_fraction' parameter of MLPBaseline must be a float in the range \[0.0, 1.0\). Got 1.0",
        ),
        ({"random_state": -1}, r"'random_state' parameter of MLPBaseline must be .* Got -1"),
    ],
)
def test_bad_parameters(params, match):
    X, y = _noisy_problem()
    with pytest.raises(ValueError, match=match):
        MLPBaseline(**params).fit(X, y)


@pytest.mark.parametrize(
    "corrupt, match",
    [
        (
            lambda X, y: X.iloc.__setitem__((75, 2), np.nan),
            r"column 'T3_C' has NaN in test 'II' at row 75",
        ),
        (
            lambda X, y: y.iloc.__setitem__(140, np.inf),
            r"the target y has infinity \(inf\) in test 'III'",
        ),
        (lambda X, y: X.__setitem__("T4_C", 21.5), r"Column 'T4_C' is constant \(21.5\)"),
    ],
)
def test_bad_values_name_column_and_test(corrupt, match):
    X, y = teacher_tests()
    X, y = X.copy(), y.copy()
    corrupt(X, y)
    with pytest.raises(ValueError, match=match):
        MLPBaseline().fit(X, y)


def test_too_few_rows():
    with pytest.raises(ValueError, match="1 samples in 1 test"):
        MLPBaseline().fit(np.array([[1.0, 2.0]]), np.array([3.0]))


def test_fewer_rows_than_weights_trains_and_warns():
    # scikit-learn's check_dont_overwrite_parameters data: 20 rows of 3 columns,
    # 51 weights in a default 3-10-1 network; validation_fraction=0 trains on all
    rng = np.random.default_rng(0)
    X = 3 * rng.uniform(size=(20, 3))
    y = X[:, 0] - 2 * X[:, 1] ** 2 + np.sin(X[:, 2])
    msg = (
        r"MLPBaseline is under-determined: 20 training rows for the 51 weights of a "
        r"3-10-1 network\..*damping.*hidden_layer_sizes=3 or fewer is determined"
    )
    with pytest.warns(UnderdeterminedWarning, match=msg):
        model = MLPBaseline(validation_fraction=0, random_state=0).fit(X, y)
    # the damped fit is well-posed: finite weights, and it reaches the goal on
    # the rows it has (it interpolates them, which is what the warning says)
    assert np.isfinite(np.concatenate([c.ravel() for c in model.coefs_])).all()
    assert model.stop_reason_ == "goal" and model.loss_ <= 1e-4
    np.testing.assert_allclose(model.predict(X), y, atol=0.05 * np.std(y))
    # three hidden units (16 weights) are determined by 20 rows: no warning
    MLPBaseline(3, validation_fraction=0, random_state=0).fit(X, y)


def test_predict_checks_columns():
    X, y = teacher_tests()
    model = MLPBaseline(3, random_state=0).fit(X, y)
    with pytest.raises(ValueError, match="The feature names should match"):
        model.predict(X[SENSORS[::-1]])
    plain = MLPBaseline(3, random_state=0).fit(X.to_numpy(), y.to_numpy())
    with pytest.raises(ValueError, match="X has 3 features, but MLPBaseline is expecting 4"):
        plain.predict(X.to_numpy()[:, :3])
