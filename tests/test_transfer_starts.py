"""How a test's lags start: carried on, at rest (a cold start), or assumed at rest,
told apart from the temperatures at its first row and the sensors' resolution."""

import io
import warnings

import numpy as np
import pandas as pd
import pytest

from greyml import ThermalTransferFunction, make_test_index
from greyml.dynamic._transfer import sensor_resolution, start_states
from greyml.exceptions import WarmStartWarning


def test_resolution_is_the_quantum_of_quantised_readings():
    x = np.round(20.0 + np.linspace(0.0, 2.0, 500), 1)  # a 0.1 K logger
    assert sensor_resolution(x, [(0, 250), (250, 500)]) == pytest.approx(0.1)


def test_resolution_is_the_noise_of_noisy_readings():
    rng = np.random.default_rng(0)
    x = 20.0 + 0.05 * rng.standard_normal(20000)
    # successive differences of white noise have spread 0.05·√2
    assert sensor_resolution(x, [(0, 20000)]) == pytest.approx(0.05, rel=0.05)


def test_start_states_by_hand():
    x = np.array(
        [
            [20.00, 20.02, 19.98],  # test 0: within 6 x 0.01 K of each other
            [21.0, 22.0, 23.0],
            [24.0, 25.0, 26.0],  # test 1: spread 2 K
            [26.0, 26.0, 26.0],  # test 2: carried from test 1
        ]
    )
    bounds = [(0, 2), (2, 3), (3, 4)]
    carried = np.array([False, False, True])
    assert start_states(x, bounds, carried, [0, 1, 2], 0.01) == [
        "at rest",
        "assumed at rest",
        "carried",
    ]
    # one sensor cannot tell agreement: assumed
    assert start_states(x, bounds, carried, [0], 0.01)[0] == "assumed at rest"


def _tests():
    """Three tests on clocks of their own: two from cold, one cut from a warm machine."""
    rng = np.random.default_rng(1)
    frames, ys = [], []
    for i, (warm, t0) in enumerate(((0.0, 0.0), (0.0, 600.0), (3.0, 600.0), (0.0, 0.0))):
        t = t0 + np.arange(0.0, 6 * 3600.0, 60.0)
        rpm = np.where(t < t0 + 3 * 3600, 2000.0 + 500 * i, 0.0)
        rise = warm + 4.0 * (1 - np.exp(-(t - t0) / 2400.0)) * (rpm > 0)
        T = {
            f"T{k}_C": 20 + (k + 1) / 3 * rise + 0.01 * rng.standard_normal(t.size)
            for k in range(3)
        }
        index = make_test_index([f"r{i}"] * t.size, t)
        frames.append(pd.DataFrame({"spindle_rpm": rpm, **T}, index=index))
        ys.append(pd.Series(2.0 * rise, index=index))
    return pd.concat(frames), pd.concat(ys)


def test_fit_says_which_tests_started_at_rest_and_predict_warns_only_for_the_others():
    X, y = _tests()
    model = ThermalTransferFunction(drivers=["spindle_rpm"], state="auto").fit(X, y)
    assert model.sensor_resolution_ == pytest.approx(0.01, rel=0.3)
    assert model.test_starts_ == {
        "r0": "at rest",
        "r1": "at rest",
        "r2": "assumed at rest",
        "r3": "at rest",
    }
    text = model.describe(file=io.StringIO())
    assert "at rest at their first row (cold starts): r0, r1, r3" in text
    assert "their lags assumed at rest: r2" in text
    tests = X.index.get_level_values("test")
    # r1 starts at 600 s of its clock but from cold: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", WarmStartWarning)
        model.predict(X[tests == "r1"])
    # r2 starts at 600 s of its clock, 3 K warm and spread: the state is assumed
    with pytest.warns(WarmStartWarning, match="r2"):
        model.predict(X[tests == "r2"])
