"""GNNMCI(1,N): the layers of Abdulshahed et al.'s (2016) network, training and integration."""

import pickle

import numpy as np
import pandas as pd
import pytest
from conftest import TRUE_B, TRUE_B1, TRUE_U, exciting_drivers
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import GMC, GNNMCI, groups_of, make_test_index
from greyml.exceptions import GreyStabilityWarning
from greyml.grey._functions import simulate_gmc
from greyml.grey._kernels import ago
from greyml.grey._response import gmc_forcing, gmc_initial, gmc_response, gnnmci_layers


def _midpoint_tests(noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    frames = []
    for label, n in [("Z", 80), ("C", 90), ("helical", 100)]:
        X = exciting_drivers(rng, n)
        y = simulate_gmc(X, TRUE_B1, TRUE_B, TRUE_U, form="midpoint")
        y = y + noise * np.abs(y).max() * rng.normal(size=n)
        index = make_test_index([label] * n, 10.0 * np.arange(n))
        frame = pd.DataFrame(X, index=index, columns=[f"T{j + 1}_C" for j in range(4)])
        frame["dz_um"] = y
        frames.append(frame)
    data = pd.concat(frames)
    return data.drop(columns="dz_um"), data["dz_um"]


def test_layers_multiply_out_to_the_midpoint_response():
    rng = np.random.default_rng(1)
    X1 = ago(exciting_drivers(rng, 40, 3))
    b1, b, u = 0.25, np.array([0.4, -0.3, 0.1]), 1.5
    f = gmc_forcing(X1, b, u)
    x0 = float(gmc_initial(f[0], b1, "model"))
    layers = gnnmci_layers(X1, b1, b, u, x0)
    response = gmc_response(f, b1, x0, "midpoint")
    np.testing.assert_allclose(layers["D"], response[1:], rtol=1e-12)
    # layer A and B by hand at k = 3; the first unit of layer C is b·(−x0)
    assert layers["A"][2] == pytest.approx(0.75)
    assert layers["B"][2] == pytest.approx(1 / (1 + np.exp(-0.75)))
    assert layers["C"][2, 0] == pytest.approx(-x0 * layers["B"][2])
    assert layers["C"].shape == (39, 5)


def test_layer_outputs_of_a_fitted_model_reproduce_predict():
    X, y = _midpoint_tests()
    model = GNNMCI(n_population=20, max_iter=20, random_state=0).fit(X, y)
    pred = model.predict(X)
    start = 0
    for layers, label in zip(model.layer_outputs(X), ["Z", "C", "helical"]):
        n = layers["D"].size + 1
        x_hat = np.cumsum(pred[start : start + n])  # the accumulated prediction
        np.testing.assert_allclose(layers["D"], x_hat[1:], rtol=1e-9)
        assert layers["test"] == label
        start += n


def test_recovers_known_weights_with_seed_000_swarm():
    X, y = _midpoint_tests()
    model = GNNMCI(random_state=0).fit(X, y)  # 90 particles, 100 epochs
    assert model.optimizer_result_.history.shape[0] == 100
    assert model.development_coef_ == pytest.approx(TRUE_B1, abs=1e-6)
    np.testing.assert_allclose(model.driving_coef_, TRUE_B, atol=1e-5)
    assert model.control_ == pytest.approx(TRUE_U, abs=1e-3)


def test_full_search_as_in_seed_000_trains_every_weight():
    X, y = _midpoint_tests()
    full = GNNMCI(search="full", max_iter=60, random_state=0).fit(X, y)
    sep = GNNMCI(max_iter=60, random_state=0).fit(X, y)
    assert full.optimizer_result_.x.shape == (6,)  # b1, four b_j, u
    assert sep.optimizer_result_.x.shape == (1,)  # b1 only
    # the warm start from least squares means the full search never ends worse
    gmc_ls = GMC(solver="ls", response="midpoint").fit(X, y)
    assert full.loss_ <= gmc_ls.loss_ * (1 + 1e-12)
    assert sep.loss_ <= full.loss_


def test_noisy_tests_generalise_to_the_held_out_test():
    X, y = _midpoint_tests(noise=0.01, seed=3)
    train = groups_of(X) != "helical"
    model = GNNMCI(max_iter=40, random_state=0).fit(X[train], y[train])
    truth = simulate_gmc(X[~train], TRUE_B1, TRUE_B, TRUE_U, form="midpoint")
    err = model.predict(X[~train]) - y[~train].to_numpy()
    ref = truth - y[~train].to_numpy()
    assert np.sqrt(np.mean(err**2)) <= 1.02 * np.sqrt(np.mean(ref**2))


def test_pipeline_gridsearch_logo_pickle_and_determinism():
    X, y = _midpoint_tests(noise=0.005)
    X_before = X.copy()
    state = np.random.get_state()
    pipe = make_pipeline(StandardScaler(with_mean=False), GNNMCI(max_iter=15, random_state=0))
    scores = cross_val_score(
        pipe,
        X,
        y,
        groups=groups_of(X),
        cv=LeaveOneGroupOut(),
        scoring="neg_root_mean_squared_error",
    )
    assert scores.shape == (3,) and np.all(np.isfinite(scores))
    search = GridSearchCV(pipe, {"gnnmci__n_population": [10, 20]}, cv=LeaveOneGroupOut())
    search.fit(X, y, groups=groups_of(X))
    assert search.best_params_["gnnmci__n_population"] in (10, 20)
    a = GNNMCI(max_iter=15, random_state=4).fit(X, y)
    b = GNNMCI(max_iter=15, random_state=4).fit(X, y)
    assert a.predict(X).tobytes() == b.predict(X).tobytes()
    assert pickle.loads(pickle.dumps(a)).predict(X).tobytes() == a.predict(X).tobytes()
    pd.testing.assert_frame_equal(X, X_before)
    assert np.random.get_state()[1].tobytes() == state[1].tobytes()


@pytest.mark.parametrize(
    "params, match",
    [
        ({"n_population": 1}, "'n_population' parameter of GNNMCI"),
        ({"max_iter": 0}, "'max_iter' parameter of GNNMCI"),
        ({"c1": -1.0}, "'c1' parameter of GNNMCI"),
        ({"search": "grid"}, "'search' parameter of GNNMCI"),
        ({"initial": "first"}, "'initial' parameter of GNNMCI"),
        ({"bounds": (5, -5)}, "lower 5 is not below upper -5"),
    ],
)
def test_bad_parameters(params, match):
    X, y = _midpoint_tests()
    with pytest.raises(ValueError, match=match):
        GNNMCI(**params).fit(X, y)


def test_bad_input_names_column_and_test():
    X, y = _midpoint_tests()
    bad = X.copy()
    bad.iloc[100, 2] = np.nan
    with pytest.raises(ValueError, match="column 'T3_C' has NaN in test 'C'"):
        GNNMCI().fit(bad, y)
    with pytest.raises(ValueError, match="Column 'T1_C' is constant"):
        GNNMCI().fit(X.assign(T1_C=3.0), y)
    with pytest.raises(ValueError, match="too few samples"):
        GNNMCI().fit(X.iloc[:4], y.iloc[:4])


def test_stable_default_keeps_b1_non_negative_where_unconstrained_diverges():
    from greyml.datasets import load_gantry_tests

    frame = load_gantry_tests().frame
    cols = ["FBG1_ue", "FBG2_ue", "FBG3_ue", "FBG4_ue", "T2_C"]
    X = frame[cols] - frame[cols].groupby(level="test").transform("first")
    y = frame["dz_um"]
    train = groups_of(X) != "helical"
    with pytest.warns(GreyStabilityWarning, match=r"b1 = -.*factor"):
        free = GNNMCI(bounds=(-100, 100), max_iter=30, random_state=0).fit(X[train], y[train])
    assert free.development_coef_ < 0  # fits Z and C, then grows without bound
    assert np.abs(free.predict(X[~train])).max() > 1e6
    stable = GNNMCI(max_iter=30, random_state=0).fit(X[train], y[train])
    assert stable.development_coef_ >= 0
    err = stable.predict(X[~train]) - y[~train].to_numpy()
    assert np.sqrt(np.mean(err**2)) < 0.25 * np.abs(y[~train]).max()
    with pytest.raises(ValueError, match="'bounds' parameter of GNNMCI"):
        GNNMCI(bounds="loose").fit(X[train], y[train])
