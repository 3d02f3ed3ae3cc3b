"""Tests of greyml.gap._where: the gap by segment and the residual diagnostics."""

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose
from scipy.signal import lfilter
from scipy.stats import chi2

from greyml import make_test_index
from greyml.gap._where import BREAKDOWN_COLUMNS, gap_breakdown, residual_diagnostics

HOUR = 3600.0


def family(table, by):
    return table[table["by"] == by].set_index("segment")


def smooth_noise(rng, n, pole=0.9):
    """A seeded AR(1) series: smooth, not periodic, so a correlation peak is unique."""
    return lfilter([1.0], [1.0, -pole], rng.normal(size=n))


# ---------------------------------------------------------------------------
# gap_breakdown: hand-computed small case
# ---------------------------------------------------------------------------

# Two tests, 60 s steps, the spindle on in the first half of each:
#   test I : r = [1, -2, 3, 0]   Σr² = 1+4+9+0 = 14, mean = 2/4 = 0.5, peak 3 at 120 s
#   test II: r = [2, 2, -1, -1]  Σr² = 4+4+1+1 = 10, mean = 2/4 = 0.5, peak 2 at 0 s
#   all    : Σr² = 24, n = 8, rms = sqrt(3), mean = 0.5, peak 3 (I, 120 s)
#   heating (rows 0, 1 of each): [1, -2, 2, 2]  Σ = 13, mean 0.75, peak 2 first at (I, 60 s)
#   cooling (rows 2, 3 of each): [3, 0, -1, -1] Σ = 11, mean 0.25, peak 3 at (I, 120 s)
SMALL_R = [1.0, -2.0, 3.0, 0.0, 2.0, 2.0, -1.0, -1.0]
SMALL_INDEX = make_test_index(["I"] * 4 + ["II"] * 4, [0.0, 60.0, 120.0, 180.0] * 2)
SMALL_ON = [1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0]


@pytest.fixture
def small():
    r = pd.Series(SMALL_R, index=SMALL_INDEX)
    drivers = pd.DataFrame({"spindle_rpm": np.multiply(SMALL_ON, 8000.0)}, index=SMALL_INDEX)
    return r, drivers


def test_hand_computed_all_test_phase(small):
    r, drivers = small
    table = gap_breakdown(r, drivers=drivers)
    assert list(table.columns) == list(BREAKDOWN_COLUMNS)
    assert list(table["by"].unique()) == ["all", "test", "phase", "time", "band"]

    expected = {
        # by, segment: n, rms, peak, peak_test, peak_time_s, bias, share
        ("all", "all"): (8, math.sqrt(24 / 8), 3.0, "I", 120.0, 0.5, 1.0),
        ("test", "I"): (4, math.sqrt(14 / 4), 3.0, "I", 120.0, 0.5, 14 / 24),
        ("test", "II"): (4, math.sqrt(10 / 4), 2.0, "II", 0.0, 0.5, 10 / 24),
        ("phase", "heating"): (4, math.sqrt(13 / 4), 2.0, "I", 60.0, 0.75, 13 / 24),
        ("phase", "cooling"): (4, math.sqrt(11 / 4), 3.0, "I", 120.0, 0.25, 11 / 24),
        # all rows lie within the first quarter of an hour
        ("time", "0-15 min"): (8, math.sqrt(3), 3.0, "I", 120.0, 0.5, 1.0),
    }
    got = table.set_index(["by", "segment"])
    for key, (n, rms, peak, test, time, bias, share) in expected.items():
        row = got.loc[key]
        assert row["n"] == n, key
        assert row["rms"] == pytest.approx(rms, rel=1e-14), key
        assert row["peak"] == peak, key
        assert row["peak_test"] == test, key
        assert row["peak_time_s"] == time, key
        assert row["bias"] == pytest.approx(bias, rel=1e-14), key
        assert row["share"] == pytest.approx(share, rel=1e-14), key
    assert table["n"].dtype == np.int64


def test_hand_computed_against_numpy(small):
    """The same figures straight from numpy on boolean masks."""
    r, drivers = small
    table = gap_breakdown(r, drivers=drivers)
    x = np.asarray(SMALL_R)
    on = np.asarray(SMALL_ON) > 0
    tests = np.asarray(["I"] * 4 + ["II"] * 4)
    masks = {
        ("test", "I"): tests == "I",
        ("test", "II"): tests == "II",
        ("phase", "heating"): on,
        ("phase", "cooling"): ~on,
    }
    got = table.set_index(["by", "segment"])
    for key, mask in masks.items():
        assert got.loc[key, "rms"] == pytest.approx(np.sqrt(np.mean(x[mask] ** 2)))
        assert got.loc[key, "bias"] == pytest.approx(np.mean(x[mask]))
        assert got.loc[key, "peak"] == np.max(np.abs(x[mask]))
        assert got.loc[key, "share"] == pytest.approx(np.sum(x[mask] ** 2) / np.sum(x**2))
    for by in ("test", "phase"):
        assert family(table, by)["share"].sum() == pytest.approx(1.0, abs=1e-15)


def test_phase_needs_any_driver_relative_to_its_own_scale():
    index = make_test_index(["A"] * 4, [0.0, 10.0, 20.0, 30.0])
    r = pd.Series([1.0, 2.0, 3.0, 4.0], index=index)
    # feed is on (tiny but on its own scale) in row 1, spindle in row 2;
    # row 3 carries rounding noise of the spindle (1e-12 of its range): off
    drivers = pd.DataFrame(
        {"spindle": [0.0, 0.0, 5000.0, 5e-9], "feed": [0.0, 1e-6, 0.0, 0.0]}, index=index
    )
    phase = family(gap_breakdown(r, drivers=drivers), "phase")
    assert phase.loc["heating", "n"] == 2
    assert phase.loc["heating", "bias"] == pytest.approx(2.5)
    assert phase.loc["cooling", "n"] == 2
    assert phase.loc["cooling", "bias"] == pytest.approx(2.5)
    assert phase.loc["cooling", "share"] == pytest.approx((1 + 16) / 30)


def test_empty_phase_is_left_out(small):
    r, drivers = small
    always_on = drivers.assign(spindle_rpm=8000.0)
    phase = family(gap_breakdown(r, drivers=always_on), "phase")
    assert list(phase.index) == ["heating"]
    assert phase.loc["heating", "share"] == 1.0
    all_off = drivers.assign(spindle_rpm=0.0)
    assert list(family(gap_breakdown(r, drivers=all_off), "phase").index) == ["cooling"]


def test_no_drivers_no_phase_family(small):
    r, _ = small
    for drivers in (None, pd.DataFrame(index=SMALL_INDEX)):
        table = gap_breakdown(r, drivers=drivers)
        assert "phase" not in set(table["by"])


def test_zero_gap_has_nan_shares(small):
    r, drivers = small
    table = gap_breakdown(r * 0.0, drivers=drivers)
    assert table["rms"].eq(0).all()
    assert table["share"].isna().all()


def test_single_test_without_test_level():
    index = pd.Index([0.0, 60.0, 120.0], name="time_s")
    table = gap_breakdown(pd.Series([1.0, -1.0, 2.0], index=index))
    assert list(family(table, "test").index) == ["the single test"]
    assert table.loc[0, "peak_test"] is None
    assert table.loc[0, "peak_time_s"] == 120.0


# ---------------------------------------------------------------------------
# gap_breakdown: time bins
# ---------------------------------------------------------------------------


def test_ramp_bias_per_hour_is_the_mid_time():
    # r = t at the centres of 1-min steps over 3 h: each hourly bin holds a
    # symmetric set of times around its middle, so its mean is the mid time
    t = 30.0 + 60.0 * np.arange(180)
    r = pd.Series(t, index=make_test_index(["ramp"] * t.size, t))
    time = family(gap_breakdown(r), "time")
    assert list(time.index) == ["0-1 h", "1-2 h", "2-3 h"]
    assert_allclose(time["bias"], [1800.0, 5400.0, 9000.0], rtol=1e-14)
    assert list(time["n"]) == [60, 60, 60]
    assert_allclose(time["peak"], [3570.0, 7170.0, 10770.0])
    assert_allclose(
        time["share"], [np.sum(t[k * 60 : (k + 1) * 60] ** 2) / np.sum(t**2) for k in range(3)]
    )
    assert time["share"].sum() == pytest.approx(1.0, abs=1e-15)


def test_time_bins_span_tests_and_close_the_last_bin():
    # test A: 0..7200 s (the sample at exactly 2 h belongs to the last bin),
    # test B: 0..3000 s; bins pool both tests by time since their start
    ta = 600.0 * np.arange(13)
    tb = 600.0 * np.arange(6)
    index = make_test_index(["A"] * 13 + ["B"] * 6, np.concatenate([ta, tb]))
    r = pd.Series(1.0, index=index)
    time = family(gap_breakdown(r), "time")
    assert list(time.index) == ["0-1 h", "1-2 h"]
    assert list(time["n"]) == [6 + 6, 7]


def test_short_tests_get_quarter_hour_bins_and_empty_bins_are_left_out():
    t = np.concatenate([60.0 * np.arange(10), 60.0 * np.arange(40, 50)])  # 0-9 and 40-49 min
    r = pd.Series(np.arange(20.0), index=make_test_index(["A"] * 20, t))
    with pytest.raises(ValueError, match="sampling interval of test 'A' is not constant"):
        gap_breakdown(r)
    index = make_test_index(["A"] * 10 + ["B"] * 10, t)
    time = family(gap_breakdown(pd.Series(np.arange(20.0), index=index)), "time")
    # 15-30 min holds no sample and is not listed
    assert list(time.index) == ["0-15 min", "30-45 min", "45-60 min"]
    assert list(time["n"]) == [10, 5, 5]


def test_custom_time_edges_with_infinity(small):
    r, _ = small
    time = family(gap_breakdown(r, time_edges_s=[0, 90, np.inf]), "time")
    assert list(time.index) == ["0-90 s", ">= 90 s"]
    assert list(time["n"]) == [4, 4]
    with pytest.raises(ValueError, match="Widen 'time_edges_s'"):
        gap_breakdown(r, time_edges_s=[0, 90])
    with pytest.raises(ValueError, match="'time_edges_s' parameter of gap_breakdown"):
        gap_breakdown(r, time_edges_s=[0, 0, 200])


# ---------------------------------------------------------------------------
# gap_breakdown: frequency bands
# ---------------------------------------------------------------------------


def two_sines(a=5.0, b=2.0, c=3.0, hours=12, dt=60.0, label="I", start=0.0):
    t = start + dt * np.arange(int(hours * HOUR / dt))
    r = a * np.sin(2 * np.pi * t / (6 * HOUR)) + b * np.sin(2 * np.pi * t / 1800.0) + c
    return pd.Series(r, index=make_test_index([label] * t.size, t))


def test_bands_default_edges():
    # 12 h at 1 min: the 6 h sine is bin 2, the 30 min sine bin 24, c is DC.
    # Default bands: DC and 6 h in "period > 4 h", 30 min in "15 min-1 h".
    a, b, c = 5.0, 2.0, 3.0
    r = two_sines(a, b, c)
    band = family(gap_breakdown(r), "band")
    assert list(band.index) == ["period > 4 h", "1-4 h", "15 min-1 h", "< 15 min"]
    total = c**2 + a**2 / 2 + b**2 / 2
    assert_allclose(
        band["share"], [(c**2 + a**2 / 2) / total, 0.0, (b**2 / 2) / total, 0.0], atol=1e-14
    )
    assert band["share"].sum() == pytest.approx(1.0, abs=1e-12)
    assert band.loc["15 min-1 h", "rms"] == pytest.approx(b / math.sqrt(2), rel=1e-12)
    # the samples (every minute) miss the crest of the 30 min sine at 7.5 min
    t = r.index.get_level_values("time_s").to_numpy()
    crest = np.max(np.abs(b * np.sin(2 * np.pi * t / 1800.0)))
    assert crest < b
    assert band.loc["15 min-1 h", "peak"] == pytest.approx(crest, rel=1e-12)
    assert band.loc["period > 4 h", "bias"] == pytest.approx(c, rel=1e-12)
    assert band.loc["15 min-1 h", "bias"] == pytest.approx(0.0, abs=1e-12)
    assert (band["n"] == 720).all()


def test_bands_separate_dc_and_each_sine():
    a, b, c = 5.0, 2.0, 3.0
    r = two_sines(a, b, c)
    band = family(gap_breakdown(r, bands_s=[8 * HOUR, 4 * HOUR, HOUR, 900.0]), "band")
    assert list(band.index) == ["period > 8 h", "4-8 h", "1-4 h", "15 min-1 h", "< 15 min"]
    total = c**2 + a**2 / 2 + b**2 / 2
    assert_allclose(
        band["share"], [c**2 / total, a**2 / 2 / total, 0, b**2 / 2 / total, 0], atol=1e-14
    )
    assert band["share"].sum() == pytest.approx(1.0, abs=1e-12)
    assert_allclose(band["bias"], [c, 0, 0, 0, 0], atol=1e-12)
    assert_allclose(band["rms"], [c, a / math.sqrt(2), 0, b / math.sqrt(2), 0], atol=1e-12)
    assert band.loc["4-8 h", "peak"] == pytest.approx(a, rel=1e-12)
    assert band.loc["4-8 h", "peak_time_s"] == pytest.approx(1.5 * HOUR)  # sin peaks at T/4


def test_bands_pool_tests_with_different_intervals_and_respect_nyquist():
    # test I at 1 min, test II at 10 min: II cannot resolve periods < 20 min, so
    # the band "< 15 min" only gets energy from test I
    rng = np.random.default_rng(3)
    r1 = two_sines(hours=12, dt=60.0, label="I")
    r2 = two_sines(hours=8, dt=600.0, label="II")
    r = pd.concat([r1, r2 + rng.normal(size=r2.size)])
    r.iloc[:720] += rng.normal(size=720)  # white noise in I reaches "< 15 min"
    band = family(gap_breakdown(r), "band")
    assert band["share"].sum() == pytest.approx(1.0, abs=1e-12)
    assert (band["n"] == r.size).all()
    # II's band components are zero in "< 15 min": its peak must lie in test I
    assert band.loc["< 15 min", "peak_test"] == "I"
    table_ii = family(gap_breakdown(r.loc[["II"]]), "band")
    assert "< 15 min" not in table_ii.index  # no bin of II falls in it: left out
    assert table_ii["share"].sum() == pytest.approx(1.0, abs=1e-12)


def test_band_components_add_up_to_the_gap_energy_for_random_gaps():
    rng = np.random.default_rng(11)
    parts = []
    for label, n, dt in [("I", 301, 30.0), ("II", 1000, 10.0), ("III", 2, 60.0), ("IV", 1, 60.0)]:
        t = 17.0 + dt * np.arange(n)
        parts.append(pd.Series(rng.normal(3.0, 2.0, size=n), index=make_test_index([label] * n, t)))
    r = pd.concat(parts)
    table = gap_breakdown(r, bands_s=[3600, 600, 120, 45])
    for by in ("test", "time", "band"):
        assert family(table, by)["share"].sum() == pytest.approx(1.0, abs=1e-12), by
    assert family(table, "band")["bias"].iloc[0] == pytest.approx(r.mean(), rel=1e-12)


def test_band_edge_period_goes_to_the_shorter_band():
    # a 1 h test at 1 min: bin 1 has a period of exactly 1 h, on the edge
    t = 60.0 * np.arange(60)
    r = pd.Series(np.sin(2 * np.pi * t / HOUR), index=make_test_index(["I"] * 60, t))
    band = family(gap_breakdown(r), "band")
    assert band.loc["15 min-1 h", "share"] == pytest.approx(1.0, rel=1e-12)


def test_band_labels_with_mixed_units():
    r = two_sines(hours=2, dt=10.0)
    band = family(gap_breakdown(r, bands_s=[5400, 90, 45]), "band")
    assert list(band.index) == ["period > 90 min", "90 s-90 min", "45-90 s", "< 45 s"]
    assert list(family(gap_breakdown(r, bands_s=[]), "band").index) == ["all periods"]


# ---------------------------------------------------------------------------
# residual_diagnostics: cross-correlation
# ---------------------------------------------------------------------------


def delayed_case(rng, delay_samples=10, dts=(60.0, 60.0, 60.0), n=500, noise=0.05):
    """Tests where the gap is a signal delayed by ``delay_samples`` plus noise."""
    r_parts, s_parts = [], []
    for k, dt in enumerate(dts):
        ext = smooth_noise(rng, n + delay_samples)
        index = make_test_index([f"T{k}"] * n, dt * np.arange(n))
        s_parts.append(pd.Series(ext[delay_samples:], index=index))
        r_parts.append(pd.Series(ext[:n] + noise * rng.normal(size=n), index=index))
    return pd.concat(r_parts), pd.concat(s_parts)


def test_delay_of_ten_minutes_is_found():
    rng = np.random.default_rng(1)
    r, s = delayed_case(rng)
    signals = pd.DataFrame({"spindle": s, "flipped": -s, "other": smooth_noise(rng, s.size)})
    signals.index = r.index
    _, xc = residual_diagnostics(r, signals)
    xc = xc.set_index("signal")
    assert xc.loc["spindle", "peak_lag_s"] == 600.0
    assert xc.loc["spindle", "peak_corr"] > 0.95
    assert xc.loc["flipped", "peak_lag_s"] == 600.0
    assert xc.loc["flipped", "peak_corr"] < -0.95
    assert xc.loc["flipped", "peak_corr"] == pytest.approx(-xc.loc["spindle", "peak_corr"])
    assert abs(xc.loc["other", "peak_corr"]) < 0.3
    assert (xc["note"] == "").all()
    assert abs(xc.loc["spindle", "corr_at_zero"]) < xc.loc["spindle", "peak_corr"]


def test_cross_correlation_against_direct_sums():
    """The pooled coefficient at every lag, from a plain double loop."""
    rng = np.random.default_rng(5)
    r, s = delayed_case(rng, delay_samples=3, n=40, noise=0.5)
    signals = pd.DataFrame({"s": s.to_numpy()}, index=r.index)
    _, xc = residual_diagnostics(r, signals, max_lag_s=8 * 60.0)
    tests = r.index.get_level_values("test")
    num = dict.fromkeys(range(-8, 9), 0.0)
    er = es = 0.0
    for label in pd.unique(tests):
        x = r[tests == label].to_numpy()
        y = s[tests == label].to_numpy()
        x, y = x - x.mean(), y - y.mean()
        er, es = er + x @ x, es + y @ y
        for lag in num:
            num[lag] += sum(x[t] * y[t - lag] for t in range(len(x)) if 0 <= t - lag < len(y))
    corr = {lag: v / math.sqrt(er * es) for lag, v in num.items()}
    best = max(corr, key=lambda lag: (abs(corr[lag]), -abs(lag)))
    assert xc.loc[0, "peak_lag_s"] == 60.0 * best
    assert xc.loc[0, "peak_corr"] == pytest.approx(corr[best], rel=1e-12)
    assert xc.loc[0, "corr_at_zero"] == pytest.approx(corr[0], rel=1e-12)


def test_lags_never_cross_a_test_boundary():
    # Both series are small noise, except a burst in the signal over the last 10
    # rows of test A that the gap repeats over the first 10 rows of test B. On
    # the concatenated series that pairing gives a near-perfect peak at 10
    # samples; within the tests the burst meets only noise.
    rng = np.random.default_rng(7)
    n, lag = 200, 10
    s = 0.1 * rng.normal(size=2 * n)
    s[n - lag : n] = 10.0 * rng.normal(size=lag)
    r = 0.1 * rng.normal(size=2 * n)
    r[n : n + lag] = s[n - lag : n]
    index = make_test_index(["A"] * n + ["B"] * n, np.tile(60.0 * np.arange(n), 2))

    rc, sc = r - r.mean(), s - s.mean()
    naive = np.dot(rc[lag:], sc[:-lag]) / math.sqrt(np.dot(rc, rc) * np.dot(sc, sc))
    assert naive > 0.9  # what a computation across the boundary would find

    signals = pd.DataFrame({"s": s}, index=index)
    _, xc = residual_diagnostics(pd.Series(r, index=index), signals)
    assert abs(xc.loc[0, "peak_corr"]) < 0.1
    assert xc.loc[0, "peak_lag_s"] != 600.0


def test_tests_with_different_sampling_intervals_pool_on_seconds():
    # 10 min delay: 10 samples at 60 s, 20 samples at 30 s; the lags meet at 600 s
    rng = np.random.default_rng(2)
    r1, s1 = delayed_case(rng, delay_samples=10, dts=(60.0,), n=400)
    r2, s2 = delayed_case(rng, delay_samples=20, dts=(30.0,), n=800)
    r2.index = make_test_index(["U"] * 800, 30.0 * np.arange(800))
    r = pd.concat([r1, r2])
    signals = pd.DataFrame({"s": np.concatenate([s1, s2])}, index=r.index)
    _, xc = residual_diagnostics(r, signals, max_lag_s=1800)
    assert xc.loc[0, "peak_lag_s"] == 600.0
    assert xc.loc[0, "peak_corr"] > 0.95


def test_constant_signals_give_zero_not_nan():
    rng = np.random.default_rng(4)
    r, _ = delayed_case(rng, n=100)
    tests = r.index.get_level_values("test")
    # constant within every test, at a different level in each: no variation left
    level = pd.Series(tests).map({"T0": 20.0, "T1": 21.0, "T2": 19.5}).to_numpy()
    signals = pd.DataFrame({"ambient": level, "off": 0.0}, index=r.index)
    _, xc = residual_diagnostics(r, signals)
    assert list(xc["note"]) == ["constant", "constant"]
    assert (xc[["peak_corr", "peak_lag_s", "corr_at_zero"]] == 0.0).all().all()
    whiteness, xc_gap = residual_diagnostics(r * 0 + 1.5, signals.assign(x=rng.normal(size=300)))
    assert list(xc_gap["note"]) == ["gap constant"] * 3
    assert not xc_gap[["peak_corr", "corr_at_zero"]].isna().any().any()
    assert whiteness["white"] and whiteness["p_value"] == 1.0 and whiteness["ljung_box_q"] == 0.0


def test_no_signals_gives_an_empty_frame(small):
    r, _ = small
    _, xc = residual_diagnostics(r, pd.DataFrame(index=SMALL_INDEX), n_lags_whiteness=1)
    assert list(xc.columns) == ["signal", "peak_corr", "peak_lag_s", "corr_at_zero", "note"]
    assert len(xc) == 0


# ---------------------------------------------------------------------------
# residual_diagnostics: whiteness
# ---------------------------------------------------------------------------


def multi_test_series(values_by_test, dt=60.0):
    parts = []
    for label, x in values_by_test.items():
        parts.append(pd.Series(x, index=make_test_index([label] * len(x), dt * np.arange(len(x)))))
    return pd.concat(parts)


def test_white_noise_is_white_and_random_walk_is_not():
    rng = np.random.default_rng(12345)
    noise = multi_test_series(
        {k: rng.normal(size=n) for k, n in [("I", 500), ("II", 300), ("III", 60)]}
    )
    signals = pd.DataFrame(index=noise.index)
    white, _ = residual_diagnostics(noise, signals)
    assert white["dof"] == 20 + 20 + 12
    assert white["white"] is True
    assert white["p_value"] > 0.01
    assert abs(white["lag1_autocorrelation"]) < 0.1

    walk = multi_test_series({k: np.cumsum(rng.normal(size=400)) for k in ["I", "II"]})
    drift, _ = residual_diagnostics(walk, pd.DataFrame(index=walk.index))
    assert drift["white"] is False
    assert drift["p_value"] < 1e-12
    assert drift["lag1_autocorrelation"] > 0.9


def test_ljung_box_against_a_direct_computation():
    rng = np.random.default_rng(8)
    parts = {"I": lfilter([1.0], [1.0, -0.3], rng.normal(size=120)), "II": rng.normal(size=47)}
    r = multi_test_series(parts)
    result, _ = residual_diagnostics(r, pd.DataFrame(index=r.index))
    q, dof, num, den = 0.0, 0, 0.0, 0.0
    for x in parts.values():
        n = len(x)
        c = x - x.mean()
        h = min(20, n // 5)
        rho = [np.dot(c[k:], c[:-k]) / np.dot(c, c) for k in range(1, h + 1)]
        q += n * (n + 2) * sum(rho[k - 1] ** 2 / (n - k) for k in range(1, h + 1))
        dof += h
        num += np.dot(c[1:], c[:-1])
        den += np.dot(c, c)
    assert result["dof"] == dof == 20 + 9
    assert result["ljung_box_q"] == pytest.approx(q, rel=1e-12)
    assert result["p_value"] == pytest.approx(chi2.sf(q, dof), rel=1e-10)
    assert result["lag1_autocorrelation"] == pytest.approx(num / den, rel=1e-12)
    # an explicit number of lags, capped by each test's length
    short = multi_test_series({"I": rng.normal(size=6)})
    assert (
        residual_diagnostics(short, pd.DataFrame(index=short.index), n_lags_whiteness=50)[0]["dof"]
        == 5
    )


def test_ar1_lag1_autocorrelation():
    rng = np.random.default_rng(9)
    r = multi_test_series({k: lfilter([1.0], [1.0, -0.8], rng.normal(size=3000)) for k in "AB"})
    result, _ = residual_diagnostics(r, pd.DataFrame(index=r.index))
    assert result["lag1_autocorrelation"] == pytest.approx(0.8, abs=0.03)
    assert result["white"] is False


def test_types_of_the_whiteness_dict(small):
    r, drivers = small
    result, xc = residual_diagnostics(r, drivers, n_lags_whiteness=1)
    assert set(result) == {"ljung_box_q", "dof", "p_value", "white", "lag1_autocorrelation"}
    assert isinstance(result["ljung_box_q"], float)
    assert isinstance(result["dof"], int)
    assert isinstance(result["white"], bool)
    assert list(xc["signal"]) == ["spindle_rpm"]


# ---------------------------------------------------------------------------
# errors
# ---------------------------------------------------------------------------


def test_misaligned_index_is_named(small):
    r, drivers = small
    shifted = drivers.copy()
    shifted.index = make_test_index(
        ["I"] * 4 + ["II"] * 4, [0.0, 60.0, 120.0, 180.0, 0.0, 60.0, 120.0, 240.0]
    )
    with pytest.raises(
        ValueError,
        match=r"index of drivers does not match .* row 7 is \('II', 180.0\) in r but \('II', 240.0\) in drivers",
    ):
        gap_breakdown(r, drivers=shifted)
    with pytest.raises(ValueError, match="r has 8 rows, signals has 7"):
        residual_diagnostics(r, drivers.iloc[:7])
    with pytest.raises(
        ValueError, match=r"row 0 is \('I', 0.0\) in r but \('II', 180.0\) in signals"
    ):
        residual_diagnostics(r, drivers.iloc[::-1])


def test_non_finite_values_are_located(small):
    r, drivers = small
    bad = r.copy()
    bad.iloc[6] = np.nan
    with pytest.raises(ValueError, match=r"gap has NaN in test 'II' at time_s=120 \(row 6\)"):
        gap_breakdown(bad)
    with pytest.raises(ValueError, match=r"gap has NaN in test 'II' at time_s=120"):
        residual_diagnostics(bad, drivers)
    bad.iloc[1] = np.inf
    with pytest.raises(ValueError, match=r"gap has inf in test 'I' at time_s=60 .*1 more"):
        gap_breakdown(bad)
    bad_drivers = drivers.copy()
    bad_drivers.iloc[3, 0] = np.nan
    with pytest.raises(
        ValueError, match=r"drivers column 'spindle_rpm' has NaN in test 'I' at time_s=180"
    ):
        gap_breakdown(r, drivers=bad_drivers)
    with pytest.raises(ValueError, match=r"signals column 'spindle_rpm' has NaN in test 'I'"):
        residual_diagnostics(r, bad_drivers)
    nullable = r.astype("Float64")
    nullable.iloc[2] = pd.NA
    with pytest.raises(ValueError, match=r"gap has NaN in test 'I' at time_s=120"):
        gap_breakdown(nullable)


def test_empty_and_malformed_gaps(small):
    r, drivers = small
    with pytest.raises(ValueError, match="The gap r is empty"):
        gap_breakdown(r.iloc[:0])
    with pytest.raises(ValueError, match="The gap r is empty"):
        residual_diagnostics(r.iloc[:0], drivers.iloc[:0])
    with pytest.raises(ValueError, match="must be a pandas Series"):
        gap_breakdown(r.to_numpy())
    with pytest.raises(ValueError, match="needs a 'time_s' level"):
        gap_breakdown(pd.Series([1.0, 2.0]))
    with pytest.raises(ValueError, match="must hold real numbers"):
        gap_breakdown(r.astype(str))
    with pytest.raises(ValueError, match="must hold real numbers"):
        residual_diagnostics(r, drivers.assign(name="a"))
    with pytest.raises(ValueError, match="appears in two separate runs"):
        gap_breakdown(r.iloc[[0, 1, 4, 5, 2, 3, 6, 7]])
    uneven = pd.Series([1.0, 2.0, 3.0], index=make_test_index(["I"] * 3, [0.0, 60.0, 180.0]))
    with pytest.raises(
        ValueError,
        match=r"sampling interval of test 'I' is not constant: 60 s from time_s=0 to 60, but 120 s from time_s=60 to 180",
    ):
        gap_breakdown(uneven)
    with pytest.raises(ValueError, match="Time does not increase"):
        gap_breakdown(pd.Series([1.0, 2.0], index=pd.Index([60.0, 0.0], name="time_s")))


def test_bad_parameters(small):
    r, drivers = small
    with pytest.raises(
        ValueError,
        match=r"The 'max_lag_s' parameter of residual_diagnostics must be a float in the range \[0.0, inf\) or None. Got -1 instead.",
    ):
        residual_diagnostics(r, drivers, max_lag_s=-1)
    with pytest.raises(ValueError, match="'max_lag_s' parameter"):
        residual_diagnostics(r, drivers, max_lag_s=np.inf)
    with pytest.raises(ValueError, match="'n_lags_whiteness' parameter"):
        residual_diagnostics(r, drivers, n_lags_whiteness=0)
    with pytest.raises(ValueError, match="'n_lags_whiteness' parameter"):
        residual_diagnostics(r, drivers, n_lags_whiteness=2.5)
    with pytest.raises(ValueError, match="'bands_s' parameter of gap_breakdown"):
        gap_breakdown(r, bands_s=[3600, -1])
    with pytest.raises(ValueError, match="'bands_s' parameter of gap_breakdown"):
        gap_breakdown(r, bands_s=[3600, 3600])


def test_too_short_for_whiteness():
    r = multi_test_series({"I": [1.0, 2.0, 0.5, 3.0], "II": [1.0, 0.0]})
    with pytest.raises(ValueError, match=r"too short for a whiteness test: .* test 'I', has 4"):
        residual_diagnostics(r, pd.DataFrame(index=r.index))
    # with an explicit number of lags, 2 samples are enough
    result, _ = residual_diagnostics(r, pd.DataFrame(index=r.index), n_lags_whiteness=1)
    assert result["dof"] == 2


def test_max_lag_zero(small):
    r, drivers = small
    _, xc = residual_diagnostics(r, drivers, max_lag_s=0, n_lags_whiteness=1)
    assert xc.loc[0, "peak_lag_s"] == 0.0
    assert xc.loc[0, "peak_corr"] == xc.loc[0, "corr_at_zero"]
