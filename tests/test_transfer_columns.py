"""A fitted ThermalTransferFunction needs only the columns it uses, and remembers the
tests it was fitted on (``fitted_tests_``)."""

import os
import tempfile

import numpy as np
import pandas as pd
import pytest

from greyml import ThermalTransferFunction, make_test_index
from greyml.persist import load_model, save_model

STEP = 60.0


def _recording(n_tests=4, hours=4.0, seed=0):
    """Cycles on one clock like CAIVIAC's: a spindle on then off, six sensors, of which
    only T1 (the spindle's heat) and T2 drive the displacement."""
    rng = np.random.default_rng(seed)
    frames, ys = [], []
    clock = 0.0
    for i, rpm in enumerate([1250.0, 2500.0, 3750.0, 5000.0][:n_tests]):
        t = np.arange(0.0, hours * 3600, STEP)
        n = np.where(t < hours * 1800, rpm, 0.0)
        heat = np.cumsum(n) * 1e-6
        sensors = {
            f"T{k}_C": 20
            + 0.3 * np.sin(t / (700 + 300 * k) + i)
            + 0.02 * rng.standard_normal(t.size)
            for k in range(2, 7)
        }
        sensors = {"T1_C": 20 + heat + 0.01 * rng.standard_normal(t.size), **sensors}
        y = 2.0 * (sensors["T1_C"] - 20) + 1.5 * (sensors["T2_C"] - 20) + 3e-4 * n
        index = make_test_index([str(i + 1)] * t.size, clock + t)
        clock += hours * 3600
        frames.append(pd.DataFrame({"spindle_rpm": n, **sensors}, index=index))
        ys.append(pd.Series(y, index=index, name="dx_um"))
    return pd.concat(frames), pd.concat(ys)


@pytest.fixture(scope="module")
def fitted():
    X, y = _recording()
    model = ThermalTransferFunction(
        drivers=["spindle_rpm"],
        max_sensors=2,
        time_constants=[900.0, 2700.0],
        driver_time_constants=[2700.0],
        driver_powers=(1,),
    )
    weight = np.where(X.index.get_level_values("test") == "4", 0.0, 1.0)
    return model.fit(X, y, sample_weight=weight), X


def test_predict_from_only_the_used_columns_equals_the_full_frame(fitted):
    model, X = fitted
    used = ["spindle_rpm", *model.selected_sensors_]
    assert len(model.selected_sensors_) < 6  # some sensors are left out
    small = X[used].copy()
    before = small.copy()
    np.testing.assert_array_equal(model.predict(small), model.predict(X))
    pd.testing.assert_frame_equal(small, before)  # the user's frame is not modified
    # any order of the used columns
    np.testing.assert_array_equal(model.predict(small[used[::-1]]), model.predict(X))


def test_a_missing_used_column_is_named(fitted):
    model, X = fitted
    sensor = model.selected_sensors_[0]
    with pytest.raises(
        ValueError, match=rf"lacks the column\(s\) '{sensor}', which the model uses"
    ):
        model.predict(X.drop(columns=[sensor]))


def test_fitted_tests_are_the_tests_of_positive_weight(fitted):
    model, _ = fitted
    assert model.fitted_tests_ == ["1", "2", "3"]


def test_fitted_tests_persist_and_a_model_without_them_loads(fitted):
    model, X = fitted
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "m.greyml")
        save_model(model, path)
        assert load_model(path).fitted_tests_ == ["1", "2", "3"]
        del model.fitted_tests_
        try:
            save_model(model, path, overwrite=True)
            back = load_model(path)
        finally:
            model.fitted_tests_ = ["1", "2", "3"]
        assert not hasattr(back, "fitted_tests_")
        np.testing.assert_array_equal(back.predict(X), model.predict(X))
