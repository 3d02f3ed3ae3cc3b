"""A recording built for the tests of scale: one clock, cut into any number of tests."""

import numpy as np
import pandas as pd

from greyml import make_test_index


def tiled(n_tests, hours=64.0, step=60.0, seed=0):
    """One recording on one clock cut into ``n_tests`` tests of equal length: a spindle
    switched on and off, two sensors, y from known lags."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600.0, step)
    on = ((t // 14400.0) % 2 == 0) * 3000.0
    a = np.exp(-step / 3600.0)
    heat = np.zeros_like(t)
    for k in range(1, t.size):
        heat[k] = a * heat[k - 1] + (1 - a) * on[k]
    T1 = 20.0 + 0.002 * heat + 0.01 * rng.standard_normal(t.size)
    T2 = 20.0 + 0.5 * np.sin(t / 7000.0)
    y = 0.8 * (T1 - 20.0) + 1e-4 * on + 0.02 * rng.standard_normal(t.size)
    label = np.minimum((np.arange(t.size) * n_tests) // t.size, n_tests - 1)
    X = pd.DataFrame(
        {"spindle_rpm": on, "T1_C": T1, "T2_C": T2},
        index=make_test_index([f"r{k:03d}" for k in label], t),
    )
    return X, y
