"""diagnose_gap on synthetic gaps with a known cause (fast cases; the simulator suite is #6)."""

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
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
