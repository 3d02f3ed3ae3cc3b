"""GreyInfluenceSelector and the TrainOnOneTest splitter."""

import numpy as np
import pandas as pd
import pytest
from sklearn.linear_model import Ridge
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut, cross_validate
from sklearn.pipeline import make_pipeline

from greyml import GreyInfluenceSelector, TrainOnOneTest, groups_of, make_test_index
from greyml.datasets import load_vmc_tests
from greyml.grey._kernels import gm1n_lstsq


def _three_groups(seed=0):
    """Two spindle sensors, two ambient sensors, one motor sensor, three tests."""
    rng = np.random.default_rng(seed)
    frames, ys = [], []
    for label, n, power in [("I", 80, 1.0), ("II", 60, 0.6), ("III", 70, 0.8)]:
        t = np.arange(n, dtype=float)
        heat = power * (1 - np.exp(-t / 25))
        amb = 0.4 * np.sin(t / 12 + power)
        motor = power * (1 - np.exp(-t / 8))
        noise = 0.01 * rng.normal(size=(n, 5))
        frames.append(
            pd.DataFrame(
                {
                    "spindle_1": 20 + 6 * heat + noise[:, 0],
                    "spindle_2": 20 + 5.5 * heat + noise[:, 1],
                    "ambient_1": 20 + amb + noise[:, 2],
                    "ambient_2": 20 + 0.9 * amb + noise[:, 3],
                    "motor": 20 + 3 * motor + noise[:, 4],
                },
                index=make_test_index([label] * n, 60.0 * t),
            )
        )
        ys.append(12 * heat - 5 * amb + 2 * motor)
    X = pd.concat(frames)
    return X, pd.Series(np.concatenate(ys), index=X.index, name="dz_um")


def test_influence_is_gm1n_on_range_normalised_sensors():
    X, y = _three_groups()
    sel = GreyInfluenceSelector(n_clusters=3, random_state=0).fit(X, y)
    Xa = X.to_numpy()
    Xn = (Xa - Xa.min(axis=0)) / np.ptp(Xa, axis=0)
    bounds = [(0, 80), (80, 140), (140, 210)]
    a, b, _, _ = gm1n_lstsq(y.to_numpy() / np.mean(np.abs(y)), Xn, bounds)
    np.testing.assert_allclose(sel.influence_, b, rtol=1e-10)
    assert sel.development_coef_ == pytest.approx(a)
    np.testing.assert_allclose(sel.membership_.sum(axis=0), 1.0)


def test_series_clustering_keeps_one_sensor_per_physical_group():
    X, y = _three_groups()
    sel = GreyInfluenceSelector(n_clusters=3, cluster_on="series", random_state=0).fit(X, y)
    kept = set(sel.get_feature_names_out())
    assert len(kept) == 3
    assert len(kept & {"spindle_1", "spindle_2"}) == 1
    assert len(kept & {"ambient_1", "ambient_2"}) == 1
    assert "motor" in kept
    # the kept sensor of each cluster is the one with the largest |influence|
    for k in range(3):
        members = np.flatnonzero(sel.clusters_ == k)
        best = members[np.argmax(np.abs(sel.influence_[members]))]
        assert sel.support_[best]


def test_pandas_in_and_out_keeps_the_test_index():
    X, y = _three_groups()
    sel = GreyInfluenceSelector(n_clusters=2, cluster_on="series", random_state=0)
    out = sel.set_output(transform="pandas").fit_transform(X, y)
    assert list(out.columns) == list(sel.get_feature_names_out())
    pd.testing.assert_index_equal(out.index, X.index)


# the three-group data are not a heating test: GMC fits them with b1 < 0, which
# is not what this test is about (the test index reaching the model is)
@pytest.mark.filterwarnings("ignore::greyml.exceptions.GreyStabilityWarning")
def test_transform_hands_the_tests_on_in_a_pipeline():
    # without the test index the next step would accumulate across tests
    from greyml import GMC

    X, y = _three_groups()
    sel = GreyInfluenceSelector(n_clusters=2, cluster_on="series", random_state=0).fit(X, y)
    out = sel.transform(X)
    pd.testing.assert_index_equal(out.index, X.index)
    plain = GreyInfluenceSelector(n_clusters=2, cluster_on="series", random_state=0)
    assert isinstance(plain.fit(X.to_numpy(), y.to_numpy()).transform(X.to_numpy()), np.ndarray)
    kept = list(sel.get_feature_names_out())
    pipe = make_pipeline(sel, GMC(solver="ls")).fit(X, y)
    direct = GMC(solver="ls").fit(X[kept], y)
    np.testing.assert_array_equal(pipe.predict(X), direct.predict(X[kept]))
    one_long_test = GMC(solver="ls").fit(X[kept].to_numpy(), y.to_numpy())
    assert not np.allclose(pipe.predict(X), one_long_test.predict(X[kept].to_numpy()))


def test_on_the_simulated_vmc_one_sensor_from_five_groups():
    vmc = load_vmc_tests()
    X, y = vmc.frame[vmc.sensors], vmc.frame["dy_um"]
    train = groups_of(X) == "IV"
    for seed in range(5):
        sel = GreyInfluenceSelector(5, cluster_on="series", random_state=seed)
        sel.fit(X[train], y[train])
        # motors, carrier strip 1, carrier strip 2, ambient near the base, column
        assert sel.selected_ == ["T65_C", "T25_C", "T53_C", "T71_C", "T8_C"]
        groups = [vmc.sensor_groups[name] for name in sel.selected_]
        assert len(set(groups)) == 5, groups
    # a single c-means run from seed 0 settles in a partition (higher objective)
    # that splits the column in two and keeps T8 and T7; n_init=10 avoids it
    one_run = GreyInfluenceSelector(5, cluster_on="series", n_init=1, random_state=0)
    one_run.fit(X[train], y[train])
    assert one_run.selected_ == ["T65_C", "T25_C", "T53_C", "T8_C", "T7_C"]


def test_deterministic_and_leaves_inputs_and_global_state_alone():
    X, y = _three_groups()
    X0, y0 = X.copy(), y.copy()
    state = np.random.get_state()
    a = GreyInfluenceSelector(3, random_state=3).fit(X, y)
    b = GreyInfluenceSelector(3, random_state=3).fit(X, y)
    assert a.membership_.tobytes() == b.membership_.tobytes()
    assert np.random.get_state()[1].tobytes() == state[1].tobytes()
    pd.testing.assert_frame_equal(X, X0)
    pd.testing.assert_series_equal(y, y0)


@pytest.mark.parametrize(
    "params, match",
    [
        ({"n_clusters": 6}, "more groups than sensors"),
        ({"n_clusters": 0}, "'n_clusters' parameter"),
        ({"m": 1.0}, "'m' parameter"),
        ({"cluster_on": "weights"}, "'cluster_on' parameter"),
        ({"normalisation": "z"}, "'normalisation' parameter"),
    ],
)
def test_bad_parameters(params, match):
    X, y = _three_groups()
    with pytest.raises(ValueError, match=match):
        GreyInfluenceSelector(**params).fit(X, y)


def test_bad_input_names_column_and_test():
    X, y = _three_groups()
    bad = X.copy()
    bad.iloc[100, 2] = np.nan
    with pytest.raises(ValueError, match="column 'ambient_1' has NaN in test 'II'"):
        GreyInfluenceSelector(2).fit(bad, y)
    with pytest.raises(ValueError, match="Column 'motor' is constant"):
        GreyInfluenceSelector(2).fit(X.assign(motor=21.0), y)
    with pytest.raises(ValueError, match="column 'ambient_1' has mean 0"):
        GreyInfluenceSelector(2, normalisation="mean").fit(
            X.assign(ambient_1=X["ambient_1"] - X["ambient_1"].mean()), y
        )
    with pytest.raises(ValueError, match="y to be passed"):
        GreyInfluenceSelector(2).fit(X, None)


# -- TrainOnOneTest ------------------------------------------------------------
def test_train_on_one_test_is_the_mirror_of_leave_one_group_out():
    X, y = _three_groups()
    ours = list(TrainOnOneTest().split(X))  # tests read from the index
    logo = list(LeaveOneGroupOut().split(X, groups=groups_of(X)))
    assert len(ours) == 3
    for (train, test), (l_train, l_test) in zip(ours, logo):
        np.testing.assert_array_equal(train, l_test)
        np.testing.assert_array_equal(test, l_train)
    only = list(TrainOnOneTest(train_tests=["II"]).split(X))
    assert len(only) == 1 and only[0][0].tolist() == list(range(80, 140))
    assert TrainOnOneTest(train_tests=["II"]).get_n_splits() == 1
    assert TrainOnOneTest().get_n_splits(X) == 3


def test_train_on_one_test_in_cross_validate_and_grid_search():
    X, y = _three_groups()
    pipe = make_pipeline(GreyInfluenceSelector(random_state=0, cluster_on="series"), Ridge())
    res = cross_validate(
        pipe.set_params(greyinfluenceselector__n_clusters=3),
        X,
        y,
        cv=TrainOnOneTest(),
        scoring=["neg_root_mean_squared_error", "r2"],
    )
    assert res["test_r2"].shape == (3,) and np.all(res["test_r2"] > 0.9)
    search = GridSearchCV(
        pipe, {"greyinfluenceselector__n_clusters": [1, 3]}, cv=TrainOnOneTest(train_tests=["I"])
    )
    search.fit(X, y)
    assert search.best_params_ == {"greyinfluenceselector__n_clusters": 3}


def test_train_on_one_test_errors():
    with pytest.raises(ValueError, match="needs the test of every row"):
        list(TrainOnOneTest().split(np.zeros((4, 1))))
    with pytest.raises(ValueError, match="at least 2 tests"):
        list(TrainOnOneTest().split(np.zeros((4, 1)), groups=["a"] * 4))
    with pytest.raises(ValueError, match=r"train_tests \['V'\] are not among"):
        list(TrainOnOneTest(train_tests=["V"]).split(np.zeros((4, 1)), groups=list("aabb")))


def test_seed_metrics_as_multi_metric_scoring_with_the_right_signs():
    from greyml.metrics import residual_band, rmse, scoring

    X, y = _three_groups()
    pipe = make_pipeline(GreyInfluenceSelector(3, cluster_on="series", random_state=0), Ridge())
    res = cross_validate(
        pipe,
        X,
        y,
        cv=TrainOnOneTest(),
        scoring=scoring("neg_rmse", "nash_sutcliffe", "neg_residual_band"),
    )
    # recompute the first split by hand: errors come back negated, E as is
    train, test = next(TrainOnOneTest().split(X))
    fitted = pipe.fit(X.iloc[train], y.iloc[train])
    pred = fitted.predict(X.iloc[test])
    assert res["test_neg_rmse"][0] == pytest.approx(-rmse(y.iloc[test], pred))
    assert res["test_neg_residual_band"][0] == pytest.approx(-residual_band(y.iloc[test], pred))
    assert np.all(res["test_nash_sutcliffe"] > 0.9)
    search = GridSearchCV(
        pipe,
        {"greyinfluenceselector__n_clusters": [1, 3]},
        cv=TrainOnOneTest(),
        scoring=scoring("neg_rmse", "nash_sutcliffe"),
        refit="neg_rmse",
    )
    search.fit(X, y)
    assert search.best_params_ == {"greyinfluenceselector__n_clusters": 3}
