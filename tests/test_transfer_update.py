"""ThermalTransferFunction.partial_fit (issue 28 item 4): the normal equations of new
tests added to the fitted ones, with forgetting; exact against a fit on all tests."""

import numpy as np
import pandas as pd
import pytest
from test_transfer import _tests

from greyml import ThermalTransferFunction
from greyml.persist import load_model, save_model


def _model():
    # the ridge on every sensor: its normal equations are what partial_fit adds to
    # (the group lasso's partial_fit is in test_transfer_sparse.py)
    return ThermalTransferFunction(
        drivers=["spindle_rpm"],
        time_constants=[900.0, 2700.0],
        driver_time_constants=[2700.0],
        driver_powers=(1,),
        alphas=[1e-3],
        selection="forward",
    )


def _split(X, y, tests):
    rows = X.index.get_level_values("test").isin(tests)
    return X[rows], y[rows]


def test_forgetting_one_equals_a_fit_on_all_tests():
    X, y = _tests(n_tests=5)
    first = _model().fit(*_split(X, y, ["t0", "t1", "t2"]))
    first.partial_fit(*_split(X, y, ["t3", "t4"]))
    whole = _model().fit(X, y)
    np.testing.assert_allclose(first.feature_coef_, whole.feature_coef_, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(first.predict(X), whole.predict(X), rtol=0, atol=1e-8)


def test_a_changed_machine_is_followed_with_forgetting():
    """The machine now moves 1.5 times as much: the less the old tests weigh, the closer."""
    X, y = _tests(n_tests=5)
    old = _split(X, y, ["t0", "t1", "t2"])
    new_X, new_y = _split(X, y, ["t3"])
    check_X, check_y = _split(X, y, ["t4"])

    def error(model):
        return np.sqrt(np.mean((model.predict(check_X) - 1.5 * check_y) ** 2))

    before = error(_model().fit(*old))
    errors = [
        error(_model().fit(*old).partial_fit(new_X, 1.5 * new_y, forgetting=f))
        for f in (1.0, 0.5, 0.05, 0.0)
    ]
    assert errors == sorted(errors, reverse=True)
    assert errors[-1] < 0.3 * before


def test_the_first_partial_fit_fits():
    X, y = _tests(n_tests=3)
    np.testing.assert_array_equal(
        _model().partial_fit(X, y).feature_coef_, _model().fit(X, y).feature_coef_
    )


@pytest.mark.parametrize("bad", [-0.1, 1.5, "1", np.nan, True])
def test_bad_forgetting(bad):
    X, y = _tests(n_tests=3)
    model = _model().fit(X, y)
    with pytest.raises(ValueError, match=r"forgetting must be a number in \[0, 1\]"):
        model.partial_fit(X, y, forgetting=bad)


def test_normal_equations_are_saved_and_checked(tmp_path):
    X, y = _tests(n_tests=3)
    model = _model().fit(X, y)
    path = save_model(model, tmp_path / "m.greyml")
    again = load_model(path).partial_fit(X, y)
    np.testing.assert_allclose(again.feature_coef_, model.partial_fit(X, y).feature_coef_)
    model.normal_gram_ = model.normal_gram_[:, :-1]
    with pytest.raises(ValueError, match=r"normal equations .* are not valid"):
        load_model(save_model(model, tmp_path / "bad.greyml"))


def test_new_columns_at_partial_fit_are_refused():
    X, y = _tests(n_tests=3)
    model = _model().fit(X, y)
    with pytest.raises(ValueError, match=r"feature names|T5_C"):
        model.partial_fit(X.drop(columns="T5_C"), y)
    assert isinstance(X, pd.DataFrame)
