"""Departures: smooth transients of the gap located in time, at any row rate; none in noise."""

import numpy as np
import pytest

from greyml.gap._departures import DEPARTURE_COLUMNS, Departure, locate_departures

NOISE = 0.1


def _door(t, at, peak, rise=1200.0, back=5400.0):
    """Falls linearly by ``peak`` over ``rise`` seconds from ``at``, returns with time constant ``back``."""
    up = np.clip((t - at) / rise, 0.0, 1.0)
    return -peak * np.where(t > at + rise, np.exp(-(t - at - rise) / back), up)


def _test(dt, seed, door=True):
    rng = np.random.default_rng(seed)
    t = dt * np.arange(int(5.5 * 3600 / dt))
    slow = 3.0 * (1 - np.exp(-t / 7200.0)) - 0.2 * t / 3600.0
    r = slow + NOISE * rng.standard_normal(t.size)
    return t, r + (_door(t, 7260.0, 1.2) if door else 0.0)


@pytest.mark.parametrize("dt", [15.0, 60.0, 300.0])
def test_a_20_min_door_is_located_within_10_min_of_its_start_at_any_rate(dt):
    t, r = _test(dt, seed=1)
    found = locate_departures(r, [(0, t.size)], t, [dt], NOISE)
    assert len(found) == 1
    door = found[0]
    assert abs(door.start_s - 7260.0) <= 600.0 and door.size == pytest.approx(-1.2, abs=0.3)
    assert door.start_s < door.peak_s <= door.end_s and door.z > 8


@pytest.mark.parametrize("dt", [15.0, 300.0])
def test_a_slow_gap_and_noise_have_no_departure(dt):
    for seed in range(3):
        t, r = _test(dt, seed, door=False)
        assert locate_departures(r, [(0, t.size)], t, [dt], NOISE) == []


def test_a_departure_at_a_located_event_is_that_event():
    t, r = _test(60.0, seed=1)
    row = int(np.searchsorted(t, 7260.0))
    assert locate_departures(r, [(0, t.size)], t, [60.0], NOISE, event_rows=[row]) == []


def test_a_departure_is_a_record_with_the_report_columns():
    d = Departure(test="A", start_s=60.0, peak_s=1260.0, end_s=4000.0, size=-1.0, z=20.0)
    assert [name for name in DEPARTURE_COLUMNS] == list(d.__dataclass_fields__)
    assert d.describe().startswith("Departure: test A from time_s=60 to 4000, -1 at time_s=1260")
