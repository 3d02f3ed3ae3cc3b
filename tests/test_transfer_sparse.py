"""The group lasso over whole sensors: the closed form on an orthonormal design,
optimality on a general one, the true sensors found, the candidates compared on
tests their choices did not see, and partial_fit at the chosen penalty."""

import numpy as np
import pytest
from test_transfer import _tests

from greyml import ThermalTransferFunction
from greyml.dynamic._sparse import RIDGE, _largest_penalty, _memberships, _path


def _solve(Q, c, col_group, lam):
    labels, M, free = _memberships(np.asarray(col_group), c.shape[0])
    _, beta0 = _largest_penalty(Q[None], c[None], M, free, RIDGE)
    return _path(Q[None], c[None], M, free, np.array([[lam]]), beta0, RIDGE)[0, 0]


def test_orthonormal_design_is_the_group_soft_threshold():
    # Q = I: each group's solution is max(0, 1 - lam*sqrt(size)/|c_g|) c_g / (1 + ridge)
    c = np.array([3.0, 4.0, 0.3, -0.4, 1.0, 1.0, 1.0])
    groups = [0, 0, 1, 1, 2, 2, 2]
    lam = 1.0
    beta = _solve(np.eye(7), c, groups, lam)
    expected = np.zeros(7)
    for idx in ([0, 1], [2, 3], [4, 5, 6]):
        norm = np.linalg.norm(c[idx])
        expected[idx] = max(0.0, 1.0 - lam * np.sqrt(len(idx)) / norm) * c[idx] / (1.0 + RIDGE)
    # group 0: |c| = 5 > sqrt(2); group 1: 0.5 < sqrt(2), dropped; group 2: sqrt(3) = sqrt(3)
    np.testing.assert_allclose(beta, expected, atol=1e-6)
    assert beta[2] == beta[3] == 0.0


def test_general_design_meets_the_optimality_conditions():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((200, 9))
    A[:, 4] += 0.9 * A[:, 3]  # correlated groups
    Q = A.T @ A / 200
    c = Q @ np.array([1.5, -1.0, 0.5, 0.0, 0.0, 0.0, 0.8, 0.0, 0.0]) + 0.05 * rng.standard_normal(9)
    groups = np.array([-1, 0, 0, 1, 1, 1, 2, 2, 2])
    lam = 0.05
    beta = _solve(Q, c, groups, lam)
    grad = Q @ beta - c + RIDGE * beta
    assert abs(grad[0]) < 1e-3  # the driver is unpenalised
    for g in range(3):
        idx = groups == g
        size = np.sqrt(idx.sum())
        norm = np.linalg.norm(beta[idx])
        if norm > 0:
            # the subgradient of the penalty balances the gradient
            np.testing.assert_allclose(-grad[idx], lam * size * beta[idx] / norm, atol=2e-3)
        else:
            assert np.linalg.norm(grad[idx]) <= lam * size * (1 + 1e-3)
    assert np.linalg.norm(beta[groups == 1]) == 0.0  # the group without signal is out


@pytest.fixture(scope="module")
def data():
    return _tests(n_tests=5)


def _model(**kw):
    return ThermalTransferFunction(
        drivers=["spindle_rpm"],
        time_constants=[900.0, 2700.0],
        driver_time_constants=[2700.0],
        driver_powers=(1,),
        **kw,
    )


def test_group_lasso_keeps_the_sensors_that_drive_the_displacement(data):
    X, y = data
    noisy = y + 0.02 * np.random.default_rng(0).standard_normal(len(y))
    model = _model(selection="group").fit(X, noisy)
    assert model.selection_method_ == "group"
    assert {"T1_C", "T2_C"} <= set(model.selected_sensors_)
    # a sensor left out has no term at all
    for name, _power, _tau, weight in model.terms_:
        if name not in model.selected_sensors_ and name != "spindle_rpm":
            assert weight == 0.0
    path = model.selection_
    assert list(path.columns) == ["penalty", "n_sensors", "held_out_rmse"]
    assert path["n_sensors"].iloc[0] == 0 and path["n_sensors"].iloc[-1] >= 2
    assert model.group_penalty_ in path["penalty"].tolist()
    assert model.cv_score_ < 0.2  # the noise is 0.02, the displacement several µm


def test_auto_keeps_the_candidate_with_the_lower_held_out_error(data):
    X, y = data
    auto = _model(max_sensors=2).fit(X, y)
    group = _model(max_sensors=2, selection="group").fit(X, y)
    forward = _model(max_sensors=2, selection="forward").fit(X, y)
    assert auto.selection_method_ in ("group", "forward")
    kept = group if auto.selection_method_ == "group" else forward
    np.testing.assert_allclose(auto.feature_coef_, kept.feature_coef_, rtol=1e-9, atol=1e-12)
    assert len(group.selected_sensors_) <= 2


def test_partial_fit_solves_the_group_lasso_again_at_its_penalty(data):
    X, y = data
    model = _model(selection="group").fit(X, y)
    before = model.predict(X)
    # the same tests again, the past forgotten: the same Gram, the same solution
    model.partial_fit(X, y, forgetting=0.0)
    after = model.predict(X)
    assert np.abs(after - before).max() < 1e-2 * np.abs(before).max()
    assert model.group_penalty_ is not None


def test_a_saved_penalty_out_of_its_domain_is_refused(data):
    X, y = data
    model = _model(selection="group").fit(X, y)
    model.group_penalty_ = -1.0
    with pytest.raises(ValueError, match="group_penalty_ must be None or a finite number"):
        model._check_fitted_state()
    model.group_penalty_ = 0.1
    model.selection_method_ = "lasso"
    with pytest.raises(ValueError, match="selection_method_ is 'lasso'"):
        model._check_fitted_state()


def test_group_with_fewer_than_three_tests_is_forward_selection():
    X, y = _tests(n_tests=2)
    model = _model(selection="group", max_sensors=2).fit(X, y)
    assert model.selection_method_ == "forward"
    assert model.group_penalty_ is None
    forward = _model(selection="forward", max_sensors=2).fit(X, y)
    np.testing.assert_array_equal(model.feature_coef_, forward.feature_coef_)
