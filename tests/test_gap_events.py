"""Located events in time: the same at any row rate, slow changes and quanta excluded, drivers named."""

import dataclasses
import re

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
from greyml.gap import diagnose_gap
from greyml.gap._events import EVENT_COLUMNS, Event, locate_events

NOISE = 0.1


def _lag(edges, levels, tau, t):
    """On/off blocks through a first-order lag from rest, exactly, at times ``t``."""
    y, state = np.zeros_like(t), 0.0
    for a, b, level in zip(edges[:-1], edges[1:], levels):
        inside = (t >= a) & ((t < b) | (b == edges[-1]))
        y[inside] = level + (state - level) * np.exp(-(t[inside] - a) / tau)
        state = level + (state - level) * np.exp(-(b - a) / tau)
    return y


def _smooth(t, seed, peak):
    """A heat source switched in blocks of 20-90 min through a 60-120 min lag, peaking at ``peak``."""
    rng = np.random.default_rng(seed)
    edges, levels = [0.0], []
    while edges[-1] < t[-1]:
        edges.append(min(edges[-1] + 60.0 * int(rng.integers(20, 90)), t[-1]))
        levels.append(float(rng.choice([0.0, 1.0])))
    y = _lag(np.array(edges), np.array(levels), float(rng.uniform(3600, 7200)), t)
    return peak * y / max(np.abs(y).max(), 1e-12)


def _locate(r, dt, n_tests, **kwargs):
    n = r.size // n_tests
    bounds = [(k * n, (k + 1) * n) for k in range(n_tests)]
    times = np.tile(dt * np.arange(n), n_tests)
    return locate_events(r, bounds, times, [dt] * n_tests, NOISE, **kwargs)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_same_step_at_15_s_60_s_and_5_min_rows(seed):
    found = {}
    for dt in (15.0, 60.0, 300.0):
        t = dt * np.arange(int(6 * 3600 / dt))
        rng = np.random.default_rng([seed, int(dt)])
        parts = []
        for k in range(2):
            part = _smooth(t, 10 * seed + k, 20 * NOISE) + NOISE * rng.standard_normal(t.size)
            if k == 1:
                part += 1.0 * (t >= 3 * 3600.0)  # 10× the noise, at 3 h in the second test
            parts.append(part)
        events = _locate(np.concatenate(parts), dt, 2)
        assert len(events) == 1, (dt, events)
        found[dt] = events[0]
    for dt, event in found.items():
        assert event.test == "1" and event.kind == "step"
        assert event.time_s == 3 * 3600.0, dt  # its first row at the new level
        # 1 µm within the noise at 15 s and 60 s rows, within 3× it on 5-min rows
        assert event.size == pytest.approx(1.0, abs=0.15 if dt < 300 else 0.3), dt


@pytest.mark.parametrize("dt", [15.0, 60.0, 300.0])
def test_smooth_lags_give_at_most_one_false_event_in_ten_tests(dt):
    # 60-120 min lags of a switched heat source, 30× the noise: bends, no
    # step; issue 27 asks for at most 0.1 false events per test at any rate
    t = dt * np.arange(int(6 * 3600 / dt))
    rng = np.random.default_rng(int(dt))
    r = np.concatenate(
        [_smooth(t, k, 30 * NOISE) + NOISE * rng.standard_normal(t.size) for k in range(10)]
    )
    assert len(_locate(r, dt, 10)) <= 1


def test_a_change_slower_than_the_step_time_is_not_a_step():
    dt = 15.0
    t = dt * np.arange(1200)
    rng = np.random.default_rng(7)

    def ramp(minutes):
        return 1.0 * np.clip((t - 9000.0) / (60.0 * minutes), 0.0, 1.0)

    noise = 0.5 * NOISE * rng.standard_normal(t.size)
    assert _locate(ramp(12) + noise, dt, 1) == []  # 12 min: thermal, not a step
    fast = _locate(ramp(1) + noise, dt, 1)
    assert [(e.kind, abs(e.time_s - 9030.0) <= 60.0) for e in fast] == [("step", True)]
    # told that a change within 20 min is abrupt, the 12-min ramp is a step
    from greyml.gap._events import EventSettings

    slow = _locate(ramp(12) + noise, dt, 1, settings=EventSettings(step_time_s=1200.0))
    assert len(slow) == 1 and slow[0].size == pytest.approx(1.0, abs=0.15)


def test_a_change_of_one_quantum_is_not_an_event():
    # a slow rise read in whole micrometres: the gap is a sawtooth that flips
    # by one quantum each time the rise crosses a step
    t = 30.0 * np.arange(720)
    true = 5.0 * (1.0 - np.exp(-t / 7200.0))
    gap = np.round(true) - true
    bounds = [(0, 720)]
    assert len(locate_events(gap, bounds, t, [30.0], 0.3)) > 0  # flips, as steps
    assert locate_events(gap, bounds, t, [30.0], 0.3, quantum=1.0) == []


def test_opposite_steps_close_together_are_one_spike():
    dt = 60.0
    t = dt * np.arange(360)
    rng = np.random.default_rng(3)
    dip = np.where((t >= 7200.0) & (t < 8400.0), -1.0, 0.0)  # a door open for 20 min
    events = _locate(dip + NOISE * rng.standard_normal(t.size), dt, 1)
    assert len(events) == 1
    spike = events[0]
    assert spike.kind == "spike" and spike.time_s == 7200.0 and spike.end_s == 8340.0
    assert spike.size == pytest.approx(-1.0, abs=0.1)
    assert re.search(r"a spike of -(1|0\.9\d*) until time_s=8340 ", spike.describe())


def test_a_20_min_dip_at_5_min_rows_is_one_spike_from_its_first_row():
    # four rows low on a smooth lag (a door open for 20 min, read every 5 min):
    # each edge alone is one row, which a bend of the smooth part mimics, so
    # the dip is sought as one; found edge by edge, the drop of test 7 was
    # missed and its return taken for a step 24 min late
    dt = 300.0
    t = dt * np.arange(int(6 * 3600 / dt))
    rng = np.random.default_rng(5)
    parts, starts = [], []
    for k in range(10):
        start = 60.0 * int(rng.integers(60, 300))  # a whole minute, 1-5 h in
        starts.append(start)
        dip = np.where((t >= start) & (t < start + 1200.0), 1.0, 0.0) * rng.choice([-1.0, 1.0])
        parts.append(_smooth(t, 100 + k, 20 * NOISE) + dip + NOISE * rng.standard_normal(t.size))
    events = _locate(np.concatenate(parts), dt, 10)
    assert [e.test for e in events] == [str(k) for k in range(10)]
    for event, start in zip(events, starts):
        first = dt * np.ceil(start / dt)  # the first row of the dip
        assert (event.kind, event.time_s, event.end_s) == ("spike", first, first + 900.0)
        assert abs(event.size) == pytest.approx(1.0, abs=0.25)


def test_an_event_is_a_frozen_record():
    event = Event(test="A", time_s=60.0, kind="step", size=1.0, z=9.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        event.size = 2.0
    assert event.at_driver_change is None and event.end_s is None
    assert "probe knocked" in event.describe()


def _spindle_tests(dt=30.0, n=480, seed=0):
    """Three tests; the spindle starts at 2 h in each. Returns (real, sim, switch time)."""
    rng = np.random.default_rng(seed)
    frames, sims = [], []
    t = dt * np.arange(n)
    rpm = np.where(t >= 7200.0, 3000.0, 0.0)
    for k in range(3):
        index = make_test_index([f"T{k + 1}"] * n, t)
        sim = 3.0 * (1 - np.exp(-np.clip(t - 7200.0, 0, None) / 3600.0))
        gap = NOISE * rng.standard_normal(n)
        if k == 0:
            gap += 0.8 * (t >= 7230.0)  # the probe moves at once with the speed
        if k == 1:
            gap += 0.8 * (t >= 3000.0)  # a knock, far from any switch
        frames.append(pd.DataFrame({"spindle_rpm": rpm, "dz_um": sim + gap}, index=index))
        sims.append(pd.DataFrame({"dz_um": sim}, index=index))
    return pd.concat(frames), pd.concat(sims)


def test_a_step_at_a_spindle_switch_is_labelled_with_its_size():
    real, sim = _spindle_tests()
    report = diagnose_gap(real, sim, target="dz_um", drivers=["spindle_rpm"], random_state=0)
    assert list(report.events.columns) == EVENT_COLUMNS
    events = report.events.set_index("test")
    assert sorted(events.index) == ["T1", "T2"]
    at_switch, knock = events.loc["T1"], events.loc["T2"]
    assert at_switch["at_driver_change"] == "spindle_rpm"
    assert at_switch["driver_change_s"] == 7200.0
    assert (at_switch["driver_before"], at_switch["driver_after"]) == (0.0, 3000.0)
    assert at_switch["time_s"] == 7230.0 and at_switch["size"] == pytest.approx(0.8, abs=0.15)
    assert pd.isna(knock["at_driver_change"]) and knock["time_s"] == 3000.0
    text = str(report)
    assert "test T1 at time_s=7230, a jump of +0." in text
    assert "at a spindle speed change (0 -> 3000 at time_s=7200)" in text
    assert "test T2 at time_s=3000, a jump of +0." in text and "probe knocked" in text
    records = report.to_dict()["events"]
    assert records[0]["at_driver_change"] == "spindle_rpm" and records[1]["end_s"] is None


def test_the_driver_window_is_a_stated_time():
    real, sim = _spindle_tests()
    late = real.copy()
    t = late.index.get_level_values("time_s").to_numpy()
    first = np.asarray(late.index.get_level_values("test") == "T1")
    # the probe moves 3 min after the switch: outside 60 s (plus one 30-s row)
    late.loc[first, "dz_um"] += np.where(t[first] >= 7410.0, 0.8, 0.0) - np.where(
        t[first] >= 7230.0, 0.8, 0.0
    )
    kwargs = dict(target="dz_um", drivers=["spindle_rpm"], random_state=0)
    event = diagnose_gap(late, sim, **kwargs).events.set_index("test").loc["T1"]
    assert event["time_s"] == 7410.0 and pd.isna(event["at_driver_change"])
    wide = diagnose_gap(late, sim, driver_window_s=300.0, **kwargs).events.set_index("test")
    assert wide.loc["T1", "at_driver_change"] == "spindle_rpm"


def _air_case(dt, seed=0):
    """One 4-hour test: the air drops by 2 °C at 1 h and the probe's bracket follows it
    (30 s lag, 0.8 µm); a knock of 0.8 µm at 3 h that no input explains."""
    rng = np.random.default_rng(seed)
    t = dt * np.arange(int(4 * 3600 / dt))
    air = 20.0 + 0.5 * np.sin(2 * np.pi * t / 86400) - 2.0 * (t >= 3600.0)
    bracket = -0.4 * (air - air[0]) * (1 - np.exp(-np.clip(t - 3600.0 + dt, 0, None) / 30.0))
    sensor = 25.0 + 3.0 * (1 - np.exp(-t / 5400.0)) + 0.02 * rng.standard_normal(t.size)
    r = bracket * (t >= 3600.0) + 0.8 * (t >= 10800.0) + NOISE * rng.standard_normal(t.size)
    return t, r, np.column_stack([sensor, air])


@pytest.mark.parametrize("dt", [15.0, 60.0, 300.0])
def test_an_event_that_follows_the_air_is_thermal_and_names_it(dt):
    t, r, inputs = _air_case(dt)
    events = locate_events(
        r, [(0, t.size)], t, [dt], NOISE, inputs=inputs, input_names=["T1_C", "ambient_C"]
    )
    assert [(e.kind, e.follows) for e in events] == [("step", "ambient_C"), ("step", None)]
    assert events[0].time_s == pytest.approx(3600.0, abs=dt) and events[1].time_s == 10800.0
    assert "following a change of ambient_C within 4 min" in events[0].describe()
    assert "probe knocked" in events[1].describe()
    # without the inputs both are knocks
    plain = locate_events(r, [(0, t.size)], t, [dt], NOISE)
    assert [e.follows for e in plain] == [None, None]


def test_the_report_says_what_it_compared_held_out_and_drew_and_what_to_do_next():
    real, sim = _spindle_tests()
    kwargs = dict(target="dz_um", drivers=["spindle_rpm"], random_state=0, recalibrate=False)
    report = diagnose_gap(real, sim, **kwargs)
    assert report.verdict == "unexplained" and report.named == [] and report.n_placebo == 0
    assert report.departures.empty  # the knock is an event, not a departure
    assert not report.remainder_held_out and report.reference == "recording"
    text = str(report)
    assert "A gap over all rows (nothing fitted to it) of RMSE" in text
    assert 'reference "recording"' in text and "Held out: leave one test out" in text
    assert "Placebos drawn: none. They are drawn only for an effect" in text
    assert "min_shrinkage=0.05" in text
    tried = report.causes.loc[report.causes["shrinkage"].notna(), "effect"]
    line = next(x for x in text.splitlines() if x.startswith("Tried, not supported: "))
    assert line.count("(held-out shrinkage ") == len(tried) == 3  # every effect tried
    assert all(f"{effect} (held-out shrinkage" in line for effect in tried)
    assert "What to do next:" in text and "(custom_effects=)" in text
    assert report.to_dict()["next_steps"] == report.next_steps()
