"""Prediction intervals of ThermalTransferFunction (issue 28): hand-computed kernels,
coverage on new tests of a known process, widths that grow with the time since the
displacement was known, and one-line errors."""

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from greyml import ThermalTransferFunction, make_test_index
from greyml.dynamic import IntervalCalibration
from greyml.dynamic._intervals import (
    compress_scores,
    conformal_quantile,
    quantile_by_test,
    scale_fit,
    scale_of,
    weights_by_test,
)
from greyml.persist import load_model, save_model

STEP = 60.0


def test_conformal_quantile_by_hand():
    scores = np.arange(9.0, 0.0, -1.0)  # 1 … 9, unsorted
    assert conformal_quantile(scores, 0.9) == 9.0  # rank ceil(10 · 0.9) = 9
    assert conformal_quantile(scores, 0.5) == 5.0  # rank ceil(5) = 5
    assert conformal_quantile(scores, 0.95) == math.inf  # rank 10 > 9 scores


def test_scale_fit_recovers_a_variance_that_grows_linearly():
    hours = np.linspace(0.0, 8.0, 200)
    residuals = np.sqrt(0.25 + 0.5 * hours) * np.where(np.arange(200) % 2, 1.0, -1.0)
    a, b = scale_fit(hours, residuals)
    assert a == pytest.approx(0.25, rel=1e-9) and b == pytest.approx(0.5, rel=1e-9)
    np.testing.assert_allclose(scale_of(hours, a, b), np.abs(residuals), rtol=1e-9)


def _tests(labels, seed):
    """Heating tests; y follows one sensor with a gain, plus a drift that is a random walk
    from each test's start (an unmodelled slow effect: the error grows with time)."""
    rng = np.random.default_rng(seed)
    frames, ys = [], []
    for label in labels:
        t = np.arange(0.0, 6 * 3600.0, STEP)
        rpm = np.where(t < 3 * 3600, rng.uniform(1000, 4000), 0.0)
        heat = np.zeros(t.size)
        for k in range(1, t.size):
            heat[k] = heat[k - 1] + (STEP / 1800.0) * (2e-3 * rpm[k] - heat[k - 1])
        T1 = 20.0 + heat + 0.01 * rng.standard_normal(t.size)
        T2 = (
            20.0 + 0.5 * np.sin(t / 2000.0 + rng.uniform(0, 6)) + 0.01 * rng.standard_normal(t.size)
        )
        drift = np.cumsum(0.08 * rng.standard_normal(t.size))
        y = 2.0 * (T1 - T1[0]) + drift - drift[0]
        index = make_test_index([label] * t.size, t)
        frames.append(pd.DataFrame({"spindle_rpm": rpm, "T1_C": T1, "T2_C": T2}, index=index))
        ys.append(pd.Series(y, index=index, name="dx_um"))
    return pd.concat(frames), pd.concat(ys)


@pytest.fixture(scope="module")
def fitted():
    X, y = _tests([f"a{k}" for k in range(8)], seed=1)
    model = ThermalTransferFunction(
        drivers=["spindle_rpm"], max_sensors=1, time_constants=[900.0, 2700.0], reference="start"
    ).fit(X, y)
    return model


def test_intervals_cover_new_tests_of_the_same_process(fitted):
    X, y = _tests([f"new{k}" for k in range(12)], seed=2)
    iv = fitted.predict_interval(X, coverage=0.9)
    np.testing.assert_array_equal(iv[:, 0], fitted.predict(X))
    inside = (y.to_numpy() >= iv[:, 1]) & (y.to_numpy() <= iv[:, 2])
    # refits on one test fewer than the model are a little worse than it, so
    # the calibration errs wide (conservative), not narrow; never all rows
    assert 0.85 <= inside.mean() <= 0.99, inside.mean()
    # the drift is a random walk from each start: the width grows with the time since
    cal = fitted.interval_calibration_
    a, b, c = cal.anchor_var, cal.growth_var_per_h, cal.noise_var
    s2, memory_h = cal.memory_var, cal.memory_h
    assert 0 <= c <= a and s2 >= 0 and memory_h > 0
    assert b > 0
    assert fitted.interval_half_width(0.0) < fitted.interval_half_width(6.0)
    assert (iv[0, 2] - iv[0, 1]) / 2 == pytest.approx(fitted.interval_half_width(0.0))


def test_a_wider_coverage_gives_a_wider_interval(fitted):
    X, _ = _tests(["n"], seed=3)
    narrow, wide = fitted.predict_interval(X, 0.5), fitted.predict_interval(X, 0.95)
    assert ((wide[:, 2] - wide[:, 1]) > (narrow[:, 2] - narrow[:, 1])).all()


@pytest.mark.parametrize("coverage", [0.0, 1.0, -0.1, "0.9", np.nan])
def test_bad_coverage_is_one_line(fitted, coverage):
    X, _ = _tests(["n"], seed=3)
    with pytest.raises(ValueError, match=r"coverage must be a number in \(0, 1\)"):
        fitted.predict_interval(X, coverage)


def test_too_few_tests_to_calibrate():
    X, y = _tests(["a", "b"], seed=4)
    model = ThermalTransferFunction(drivers=["spindle_rpm"], time_constants=[900.0]).fit(X, y)
    assert model.interval_calibration_ is None
    with pytest.raises(ValueError, match=r"fewer than 3 tests .* fit it on at least 3 tests"):
        model.predict_interval(X)


def test_intervals_survive_a_save_and_a_tampered_file_is_refused(fitted, tmp_path):
    X, _ = _tests(["n"], seed=5)
    path = save_model(fitted, tmp_path / "m.greyml")
    np.testing.assert_array_equal(load_model(path).predict_interval(X), fitted.predict_interval(X))
    fitted_bad = load_model(path)
    fitted_bad.interval_calibration_ = replace(fitted.interval_calibration_, anchor_var=-1.0)
    bad = save_model(fitted_bad, tmp_path / "bad.greyml")
    with pytest.raises(ValueError, match=r"interval_calibration_ must hold five finite numbers"):
        load_model(bad)
    fitted_bad.interval_calibration_ = replace(
        fitted.interval_calibration_, scores=fitted.interval_calibration_.scores[::-1].copy()
    )
    bad = save_model(fitted_bad, tmp_path / "bad2.greyml")
    with pytest.raises(ValueError, match=r"interval_calibration_.scores must be"):
        load_model(bad)


def test_every_test_weighs_the_same():
    w = weights_by_test([1, 3])
    np.testing.assert_allclose(w, [0.5, 1 / 6, 1 / 6, 1 / 6])


def test_quantile_by_test_by_hand():
    # nine tests of one row each, scores 1..9: the 90 % level is 0.9·10/9 = 1, the
    # largest score (the split-conformal rank over tests)
    scores = np.arange(1.0, 10.0)
    q, how = quantile_by_test(scores, weights_by_test([1] * 9), 9, 0.9)
    assert (q, how) == (9.0, "conformal")
    # 80 %: level 0.8·10/9 = 0.889: the 8th smallest
    assert quantile_by_test(scores, weights_by_test([1] * 9), 9, 0.8) == (8.0, "conformal")
    # a long test does not outvote a short one: one test of 1 row (score 10) and one of
    # 99 rows (score 1): at 50 %, level 0.5·3/2 = 0.75 of the pooled weights
    scores = np.array([10.0] + [1.0] * 99)
    q, how = quantile_by_test(scores, weights_by_test([1, 99]), 2, 0.5)
    assert (q, how) == (10.0, "conformal")  # level 0.75: past the 99-row test's half


def test_too_few_tests_give_the_gaussian_quantile():
    # four tests: 90 % needs 9; the scores' weighted root mean square times z(0.95)
    scores = np.array([1.0, 1.0, 3.0, 3.0])
    w = weights_by_test([2, 1, 1])
    q, how = quantile_by_test(scores, w, 3, 0.9)
    assert how == "gaussian"
    rms = math.sqrt(1 / 6 + 1 / 6 + 9 / 3 + 9 / 3)  # each of 3 tests weighs 1/3
    assert q == pytest.approx(1.6448536269514722 * rms)


def test_old_calibrations_keep_the_rows_rank():
    cal = IntervalCalibration(1.0, 0.0, 0.5, 0.5, 2.0, scores=np.linspace(0.2, 1.8, 9))
    assert cal.quantile(0.9) == 1.8 and cal.promise(0.9) == "rows"


def test_the_scores_kept_give_quantiles_no_lower_and_at_most_a_level_higher():
    """A year of rows keeps 100,000 scores, not one per row: every quantile of the kept
    scores lies between the exact one and the exact one 1/k higher in level."""
    rng = np.random.default_rng(5)
    sizes = rng.integers(2_000, 30_000, 40)
    scores = np.sort(np.abs(rng.standard_t(4, sizes.sum())))
    weights = rng.permutation(weights_by_test(sizes))
    kept, kept_weights = compress_scores(scores, weights, k=1000)
    assert kept.size == 1000 and kept_weights.sum() == pytest.approx(weights.sum())
    cum = np.cumsum(weights) / weights.sum()
    for level in (0.5, 0.8, 0.9, 0.95, 0.99, 0.999):
        exact = scores[np.searchsorted(cum, level - 1e-12)]
        higher = scores[min(np.searchsorted(cum, level + 1e-3 - 1e-12), scores.size - 1)]
        q, _ = quantile_by_test(kept, kept_weights, 40, level * 40 / 41)
        assert exact <= q <= higher
    small = np.sort(rng.uniform(size=50))
    assert compress_scores(small, np.ones(50), k=1000)[0] is small


@pytest.mark.parametrize("slope", [0.5, -0.5])
def test_scale_fit_is_non_negative_least_squares_on_the_rows_or_the_tests(slope):
    """From the sums of each test: scipy's NNLS on every row (the weighted rows), also
    where the unconstrained slope is negative (then b = 0)."""
    from scipy.optimize import nnls

    rng = np.random.default_rng(2)
    hours = [np.linspace(0, 8, n) for n in (50, 120, 80)]
    resid = [rng.normal(0, 1, h.size) * np.sqrt(np.maximum(1 + slope * h, 0.05)) for h in hours]
    w = [np.full(h.size, 1 / (3 * h.size)) for h in hours]
    H, R, W = np.concatenate(hours), np.concatenate(resid), np.concatenate(w)
    root = np.sqrt(W)
    (a0, b0), _ = nnls(np.column_stack([np.ones_like(H), H]) * root[:, None], R**2 * root)
    a, b = scale_fit(hours, resid, w)
    assert (a, b) == pytest.approx((a0, b0), rel=1e-9, abs=1e-12)
    assert scale_fit(H, R, W) == pytest.approx((a, b), rel=1e-12)
    assert (b == 0.0) == (slope < 0)
