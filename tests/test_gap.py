"""diagnose_gap on synthetic gaps with a known cause (fast cases; the simulator suite is #6)."""

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
from greyml.exceptions import GapWarning
from greyml.gap import EFFECTS, diagnose_gap
from greyml.gap._effects import first_order_lag

NOISE = 0.1


def _tests(seed=0, n_tests=5, n=400, dt=30.0):
    """Measured columns of a few tests: spindle blocks, drifting air, two sensors."""
    rng = np.random.default_rng(seed)
    frames = []
    for k in range(n_tests):
        t = dt * np.arange(n)
        on = ((t // 3600) % 2 == 0).astype(float) * rng.choice([2000.0, 4000.0, 6000.0])
        air = 20 + rng.normal(0, 1) + rng.uniform(-1, 1) * np.sin(2 * np.pi * t / 86400 * 4 + k)
        spindle = air[0] + 3 * first_order_lag(on / 6000, 1800.0, [dt], [(0, n)])
        frames.append(
            pd.DataFrame(
                {
                    "spindle_rpm": on,
                    "ambient_C": air,
                    "T1_C": spindle + 0.5 * (air - air[0]),
                    "T2_C": air[0] + 0.8 * first_order_lag(air - air[0], 3600.0, [dt], [(0, n)]),
                },
                index=make_test_index([f"test{k + 1}"] * n, t),
            )
        )
    return pd.concat(frames)


def _with_gap(frame, gap, seed=1):
    rng = np.random.default_rng(seed)
    sim = pd.Series(
        5 * (frame["T1_C"] - frame.groupby(level="test")["T1_C"].transform("first")),
        name="dz_um",
    )
    real = frame.copy()
    real["dz_um"] = sim + gap + NOISE * rng.normal(size=len(frame))
    return real, sim.to_frame()


def _diagnose(real, sim, **kwargs):
    return diagnose_gap(
        real,
        sim,
        target="dz_um",
        ambient="ambient_C",
        drivers=["spindle_rpm"],
        sensors=["T1_C", "T2_C"],
        random_state=0,
        **kwargs,
    )


def test_a_right_simulation_has_no_significant_effect():
    real, sim = _with_gap(_tests(), 0.0)
    report = _diagnose(real, sim)
    assert report.cause is None
    assert report.named == []
    assert not report.causes["significant"].any()
    assert report.noise_floor == pytest.approx(NOISE, rel=0.15)


def test_probe_drift_is_named_and_removed():
    frame = _tests()
    t_h = frame.index.get_level_values("time_s").to_numpy() / 3600
    real, sim = _with_gap(frame, 0.4 * t_h)  # 0.4 µm/h: 1.3 µm after 3.3 h, 13× the noise
    report = _diagnose(real, sim)
    assert report.cause == "drift"
    top = report.causes.iloc[0]
    assert top["effect"] == "drift" and top["significant"]
    assert report.shrinkage > 0.8  # against the simulation as given
    # what is left is the probe noise
    assert report.rmse_after == pytest.approx(NOISE, rel=0.15)


def test_ambient_through_a_lag_is_named():
    frame = _tests()
    bounds = [(i * 400, (i + 1) * 400) for i in range(5)]
    air = frame["ambient_C"].to_numpy()
    rise = air - np.repeat(air[[b[0] for b in bounds]], 400)
    gap = -2.0 * first_order_lag(rise, 2400.0, [30.0] * 5, bounds)
    real, sim = _with_gap(frame, gap)
    report = _diagnose(real, sim)
    assert report.cause == "ambient", report.causes
    assert report.shrinkage > 0.6


def test_report_to_dict_has_the_stable_keys():
    frame = _tests()
    t_h = frame.index.get_level_values("time_s").to_numpy() / 3600
    real, sim = _with_gap(frame, 0.4 * t_h)
    out = _diagnose(real, sim).to_dict()
    assert {"cause", "causes", "where"} <= out.keys()
    assert set(out["causes"][0]) >= {
        "effect",
        "detail",
        "rmse_before",
        "rmse_after",
        "shrinkage",
        "significant",
    }
    assert {row["effect"] for row in out["causes"]} == set(EFFECTS)


def test_bad_inputs_say_what_is_wrong():
    real, sim = _with_gap(_tests(n_tests=3), 0.0)
    with pytest.raises(ValueError, match="The drivers column 'feed' is not in the measured data"):
        diagnose_gap(real, sim, target="dz_um", drivers=["feed"])
    with pytest.raises(ValueError, match="does not cover 10 of the 1200 measured rows"):
        diagnose_gap(real, sim.iloc[:-10], target="dz_um")
    bad = real.copy()
    bad.iloc[450, bad.columns.get_loc("ambient_C")] = np.nan
    with pytest.raises(ValueError, match=r"'ambient_C' \(ambient=\) has NaN in test 'test2'"):
        diagnose_gap(bad, sim, target="dz_um", ambient="ambient_C")
    with pytest.raises(ValueError, match="at least 2 tests"):
        diagnose_gap(real.loc[["test1"]], sim.loc[["test1"]], target="dz_um")
    with pytest.raises(ValueError, match="Test 'test2' has 5 rows; diagnose_gap needs at least 10"):
        diagnose_gap(real.iloc[:405], sim, target="dz_um")
    with pytest.raises(ValueError, match="Unknown effect"):
        diagnose_gap(real, sim, target="dz_um", effects=["gravity"])
    before = real.copy()
    diagnose_gap(real, sim, target="dz_um", ambient="ambient_C", random_state=0)
    pd.testing.assert_frame_equal(real, before)


def test_verdicts_of_a_right_simulation_and_an_explained_drift():
    real, sim = _with_gap(_tests(), 0.0)
    report = _diagnose(real, sim)
    assert report.verdict == "within_noise" and report.events.empty
    assert report.remainder_ratio < 1.5
    assert str(report).startswith("Verdict: within noise.")
    frame = _tests()
    t_h = frame.index.get_level_values("time_s").to_numpy() / 3600
    report = _diagnose(*_with_gap(frame, 0.4 * t_h))
    assert report.verdict == "explained"
    assert report.unexplained_rms == report.rmse_after == pytest.approx(NOISE, rel=0.15)
    row = report.causes.iloc[0]
    # the effect beat all 39 placebos: p = 1/40 (sequential p-value)
    assert row["p_value"] == pytest.approx(1 / 40) and row["n_placebo"] == 39
    assert report.n_placebo >= 39
    low, high = row["shrinkage_ci"]
    assert low <= row["shrinkage"] <= high


def test_a_step_in_one_test_is_a_located_event_not_an_effect():
    frame = _tests()
    t = frame.index.get_level_values("time_s").to_numpy()
    in_test3 = np.asarray(frame.index.get_level_values("test") == "test3")
    step = np.where(in_test3 & (t >= 6000.0), 0.5, 0.0)  # 5× the probe noise
    report = _diagnose(*_with_gap(frame, step))
    assert report.named == [] and report.verdict == "unexplained"
    assert list(report.events.columns)[:4] == ["test", "time_s", "kind", "size"]
    assert len(report.events) == 1
    event = report.events.iloc[0]
    assert event["test"] == "test3" and abs(event["time_s"] - 6000.0) <= 600
    assert event["size"] == pytest.approx(0.5, abs=0.1)
    text = str(report)
    assert text.startswith("Verdict: unexplained.")
    assert "Located event: test test3 at time_s=" in text


def _coolant(frame):
    t = frame.index.get_level_values("time_s").to_numpy()
    return ((t // 2700) % 2 == 1).astype(float)


def test_custom_effects_by_columns_and_by_callable():
    frame = _tests()
    frame = frame.assign(coolant_on=_coolant(frame))
    n = 400
    bounds = [(i * n, (i + 1) * n) for i in range(5)]
    gap = -0.8 * first_order_lag(frame["coolant_on"].to_numpy(), 1200.0, [30.0] * 5, bounds)
    real, sim = _with_gap(frame, gap)
    report = _diagnose(real, sim, custom_effects={"coolant": ["coolant_on"]})
    assert report.named == ["coolant"] and report.verdict == "explained"
    assert report.causes.iloc[0]["detail"].startswith("user-defined: coolant_on")
    assert report.rmse_after == pytest.approx(NOISE, rel=0.15)  # what is left is the noise

    def signature(measured):  # the user's own model of the effect, on the same rows
        return pd.Series(gap / -0.8, index=measured.index, name="cool")

    report = _diagnose(real, sim, custom_effects={"door": signature})
    assert report.named == ["door"] and report.rmse_after == pytest.approx(NOISE, rel=0.15)
    with pytest.raises(ValueError, match="custom effect 'drift' has the name of a built-in"):
        _diagnose(real, sim, custom_effects={"drift": ["coolant_on"]})
    with pytest.raises(ValueError, match="The column 'pump' of custom effect 'p' is not in"):
        _diagnose(real, sim, custom_effects={"p": ["pump"]})
    with pytest.raises(ValueError, match="the callable must return signature columns on the 2000"):
        _diagnose(real, sim, custom_effects={"p": lambda f: np.zeros(5)})
    with pytest.raises(TypeError, match=r"'custom_effects' parameter of diagnose_gap .* 'dict'"):
        _diagnose(real, sim, custom_effects=["coolant_on"])


def test_minutes_labelled_as_seconds_warn_at_the_search_bound():
    # the air's lag of 40 min, with time_s holding minutes: 40 "s", below the
    # shortest time constant searched (60 s)
    frame = _tests()
    bounds = [(i * 400, (i + 1) * 400) for i in range(5)]
    air = frame["ambient_C"].to_numpy()
    rise = air - np.repeat(air[[b[0] for b in bounds]], 400)
    gap = -2.0 * first_order_lag(rise, 2400.0, [30.0] * 5, bounds)
    real, sim = _with_gap(frame, gap)
    minutes = frame.index.set_levels(frame.index.levels[1] / 60.0, level="time_s")
    real.index, sim.index = minutes, minutes
    with pytest.warns(GapWarning, match=r"shortest time constant searched \(60 s = 1 min\)"):
        report = _diagnose(real, sim, effects=["ambient"])
    assert "the shortest time constant searched" in report.causes.iloc[0]["detail"]


def test_lag_signatures_run_on_the_shared_kernel_as_before():
    # greyml.gap's lags come from greyml.dynamic's lag_filter now; from rest
    # at 0 in each test they equal the previous per-test lfilter to the bit
    from scipy.signal import lfilter

    from greyml.gap._effects import lag_bank

    rng = np.random.default_rng(3)
    x = rng.standard_normal((250, 3))
    bounds, dt = [(0, 100), (100, 250)], [30.0, 60.0]
    taus = [120.0, 1800.0]
    lags = lag_bank(x, taus, dt, bounds)
    for j, tau in enumerate(taus):
        for (start, stop), step in zip(bounds, dt):
            a = np.exp(-step / tau)
            expected = lfilter([1.0 - a], [1.0, -a], x[start:stop], axis=0)
            np.testing.assert_array_equal(lags[start:stop, :, j], expected)
        np.testing.assert_array_equal(first_order_lag(x, tau, dt, bounds), lags[:, :, j])
    # by hand: the first sample of a test is (1 - a)·x, the lag starts from rest
    a = np.exp(-30.0 / 120.0)
    assert lags[0, 0, 0] == pytest.approx((1 - a) * x[0, 0], rel=1e-15)


def test_a_limit_of_the_effect_itself_does_not_blame_the_time_unit():
    from types import SimpleNamespace

    from greyml.gap._diagnose import _bound_cause
    from greyml.gap._effects import tau_grid

    # 1-min rows, 6-h tests: the shared grid runs from 120 s to 12 h
    ctx = SimpleNamespace(dt=np.full(360, 60.0), durations=[6 * 3600.0])
    grid = tau_grid(ctx.dt, ctx.durations)
    assert grid[0] == 120.0 and grid[-1] == 12 * 3600.0
    for setting in [(grid[0], 900.0), (600.0, grid[-1])]:
        assert "convert it to seconds" in _bound_cause(ctx, grid, "heat_source", setting)
    # sensor_lag stops at max_sensor_lag_s (1 h), inside the grid
    own = _bound_cause(ctx, grid, "sensor_lag", (3600.0,))
    assert "max_sensor_lag_s" in own and "convert" not in own
