"""Compensator: how far to trust it, probe readings, change detection (issue 28).

Hand-computed Kalman steps on a one-term compensator, the batch interval
reproduced while streaming, one-line refusals that leave the state as it
was, a gain change recovered after the detector fires, and a compensator
saved mid-stream that resumes to the bit.
"""

import math

import numpy as np
import pytest

from greyml.controller import Compensator, Uncertainty
from greyml.persist import load_model, save_model

Q90 = 1.6448536269514722


def _comp(**kw):
    """y = 2 µm/K of T1 (no lag), an offset uncertain by 2 µm that it keeps (a memory
    of 1e6 h), white noise 1 µm."""
    base = dict(uncertainty=Uncertainty(4.0, 0.0, 1.0, 4.0, 1e6), row_columns=["time_s", "T1_C"])
    base.update(kw)
    return Compensator(["T1_C"], [("T1_C", 1, None, 2.0)], **base)


def _row(t, temp):
    return np.array([t, temp])


def test_status_before_any_reading_is_the_calibrated_interval():
    comp = _comp(uncertainty=Uncertainty(3.0, 2.0, 1.0, 3.0, 1e6))
    assert comp.update(_row(0.0, 1.0)) == 2.0
    s = comp.status
    assert s.correction == 2.0 and s.half_width == pytest.approx(Q90 * 2.0)  # sqrt(3 + 1)
    comp.update(_row(7200.0, 1.5))
    # 2 h later: sqrt(3 + 2·2 + 1)
    assert comp.status.half_width == pytest.approx(Q90 * math.sqrt(8.0))
    assert comp.status.trusted and comp.status.plausible


def test_one_reading_by_hand():
    comp = _comp()
    comp.update(_row(0.0, 1.0))  # model 2
    comp.update(_row(60.0, 2.0))  # model 4
    status = comp.observe(60.0, 9.0)  # innovation 5, gain 4 / (4 + 1) = 0.8
    assert status.correction == pytest.approx(4.0 + 0.8 * 5.0)
    assert status.half_width == pytest.approx(Q90 * math.sqrt(4.0 * 1.0 / 5.0 + 1.0))
    # the offset carries on
    assert comp.update(_row(120.0, 3.0)) == pytest.approx(6.0 + 4.0)


def test_the_slow_part_forgets_itself_with_its_memory():
    # memory 1 h, variance 4: one hour after a reading the offset is down by e
    comp = _comp(uncertainty=Uncertainty(4.0, 0.0, 0.0, 4.0, 1.0))
    comp.update(_row(0.0, 1.0))
    comp.observe(0.0, 7.0)  # an exact reading: the offset is 5
    assert comp.update(_row(3600.0, 1.0)) == pytest.approx(2.0 + 5.0 / math.e)
    # its variance returns towards 4: 0 at the reading, 4 (1 - e^-2) an hour on
    assert comp.status.half_width == pytest.approx(Q90 * math.sqrt(4.0 * (1 - math.exp(-2))))


def test_a_recalibration_before_the_first_reading_counts():
    # recalibrate(2 µm) opens the bias and the rate (variance 4 each) before any
    # reading; the first reading then splits between the offset (4) and the bias (4):
    # S = 4 + 4 + 1, gains 4/9 each
    comp = _comp()
    comp.update(_row(0.0, 2.0))  # model 4
    comp.recalibrate(2.0)
    status = comp.observe(0.0, 9.0)  # innovation 5
    np.testing.assert_allclose(comp._fx, [20 / 9, 20 / 9, 0.0])
    assert status.correction == pytest.approx(4.0 + 40 / 9)


def test_a_late_reading_is_placed_between_rows():
    comp = _comp(
        uncertainty=Uncertainty(1.0, 0.0, 0.0, 1.0, 1e6)
    )  # an exact probe: the offset is the innovation
    for t, temp in [(0.0, 1.0), (60.0, 2.0), (120.0, 3.0)]:
        comp.update(_row(t, temp))
    comp.observe(90.0, 10.0)  # the model at 90 s: 5 (between 4 and 6)
    assert comp.status.correction == pytest.approx(6.0 + 5.0)


def _state(comp):
    state = comp.get_state()
    return repr(state)


@pytest.mark.parametrize(
    "time_s, value, match",
    [
        (60.0, math.nan, r"measured_um is nan \(reading at time_s = 60.0\)"),
        (math.inf, 1.0, r"time_s is inf"),
        (60.0, True, r"measured_um is True"),
        (180.0, 1.0, r"reading 1 at time_s = 180 s is after the last update \(120 s\)"),
        (60.0, 5000.0, r"reading 5000 at time_s = 60 s is beyond ±1000"),
        (30.0, 1.0, r"not after the previous reading \(60 s\)"),
    ],
)
def test_bad_readings_are_one_line_and_change_nothing(time_s, value, match):
    comp = _comp()
    for t, temp in [(0.0, 1.0), (60.0, 2.0), (120.0, 3.0)]:
        comp.update(_row(t, temp))
    comp.observe(60.0, 4.5)
    before = _state(comp)
    with pytest.raises(ValueError, match=match) as info:
        comp.observe(time_s, value)
    assert "\n" not in str(info.value)
    assert _state(comp) == before


def test_a_reading_before_the_first_update():
    with pytest.raises(ValueError, match=r"comes before the first update"):
        _comp().observe(0.0, 1.0)


def test_a_reading_older_than_the_rows_remembered():
    comp = _comp()
    for k in range(600):
        comp.update(_row(60.0 * k, 1.0))
    with pytest.raises(ValueError, match=r"older than the 512 rows remembered"):
        comp.observe(60.0, 1.0)


def _exact(**kw):
    """The model's error known well: an offset of 0.2 µm SD, white noise of 0.1 µm SD,
    a bias and a rate that barely walk."""
    u = Uncertainty(0.04, 0.0, 0.01, 0.04, 1e6, 1e-6, 1e-8, 1.0)
    return _comp(uncertainty=u, **kw)


def test_a_step_is_found_as_a_step_and_removed():
    """Readings every 10 rows; from row 100 the machine is 5 µm further than the model."""
    comp = _exact()
    errors, found_at = [], None
    for k in range(300):
        truth = 2.0 * 10.0 + (5.0 if k >= 100 else 0.0)
        errors.append(comp.update(_row(60.0 * k, 10.0)) - truth)
        if k % 10 == 9:
            status = comp.observe(60.0 * k, truth)
            if status.changes and found_at is None:
                found_at = k
    assert found_at == 109  # the first reading after the step
    status = comp.status
    assert status.change_kind == "step"
    assert status.change_start_s == pytest.approx(60.0 * 99)  # after the reading before
    assert max(abs(e) for e in errors[110:]) < 0.05


def test_a_ramp_is_found_as_a_ramp_and_followed():
    """From 2 h on the machine drifts 0.5 µm/h away from the model; readings every 15 min."""
    comp = _exact()
    errors, found = [], []
    for k in range(12 * 60):
        t = 60.0 * k
        truth = 20.0 + 0.5 * max(0.0, t / 3600.0 - 2.0)
        errors.append(comp.update(_row(t, 10.0)) - truth)
        if k % 15 == 14:
            before = comp.status.changes
            status = comp.observe(t, truth)
            if status.changes > before:
                found.append((status.change_kind, status.change_start_s / 3600.0))
    kind, start_h = found[0]
    assert kind == "ramp" and 1.5 <= start_h <= 2.5
    assert max(abs(e) for e in errors[-120:]) < 0.1


def test_false_alarms_stay_within_the_rate():
    """Readings the model predicts up to white noise: at 1 % per reading, the Bonferroni
    bound allows at most 1 % of 2,000 readings to fire (Gaussian innovations)."""
    rng = np.random.default_rng(3)
    comp = _comp(uncertainty=Uncertainty(1.0, 0.0, 1.0, 1.0, 1e6), false_alarm_rate=0.01)
    for k in range(2000):
        comp.update(_row(60.0 * k, 10.0))
        comp.observe(60.0 * k, 20.0 + rng.normal(0.0, 1.0))
    assert comp.status.changes <= 20


def test_no_change_detected_on_readings_the_model_predicts():
    rng = np.random.default_rng(0)
    comp = _comp(uncertainty=Uncertainty(1.0, 0.0, 1.0, 1.0, 1e6))
    for k in range(400):  # 40 readings: at one false alarm in 1,000 readings, none
        comp.update(_row(60.0 * k, 10.0))
        if k % 10 == 9:
            comp.observe(60.0 * k, 20.0 + rng.normal(0.0, 1.0))
    assert comp.status.changes == 0


def test_tolerance_sets_the_trust_flag():
    comp = _comp(tolerance_um=3.0)
    comp.update(_row(0.0, 1.0))
    assert comp.status.half_width > 3.0 and not comp.status.trusted
    comp.observe(0.0, 2.0)
    assert comp.status.half_width < 3.0 and comp.status.trusted


def test_an_implausible_correction_is_refused_and_changes_nothing():
    # issue 41: what reaches the axis is within max_correction_um, or the row is refused
    comp = _comp(max_correction_um=10.0)
    assert comp.update(_row(0.0, 4.0)) == 8.0
    state = comp.get_state()
    with pytest.raises(ValueError, match=r"the correction 200 um at time_s = 60 s is beyond "):
        comp.update(_row(60.0, 100.0))
    assert comp.get_state() == state and comp.status.time_s == 0.0  # time_s did not move
    assert comp.update(_row(60.0, 4.5)) == 9.0  # the next plausible row is taken


def test_saved_mid_stream_resumes_to_the_bit(tmp_path):
    rows = [_row(60.0 * k, 10.0 + math.sin(k / 9.0)) for k in range(300)]
    readings = {k: 25.0 + 0.01 * k for k in range(19, 300, 20)}

    def run(comp, ks):
        out = []
        for k in ks:
            out.append(comp.update(rows[k]))
            if k in readings:
                comp.observe(60.0 * k, readings[k])
        return out

    whole = run(_comp(), range(300))
    first = _comp()
    run(first, range(150))
    path = save_model(first, tmp_path / "c.greyml")
    resumed = run(load_model(path), range(150, 300))
    np.testing.assert_allclose(resumed, whole[150:], rtol=0, atol=1e-12)


def test_a_tampered_filter_is_refused_at_load(tmp_path):
    comp = _comp()
    comp.update(_row(0.0, 1.0))
    comp.observe(0.0, 3.0)
    comp._fP = np.array([[-1.0, 0, 0], [0, 0, 0], [0, 0, 0]])
    path = save_model(comp, tmp_path / "bad.greyml")
    with pytest.raises(ValueError, match=r"probe filter is not valid"):
        load_model(path)


@pytest.mark.parametrize(
    "bad",
    [
        (1.0, 2.0),
        (4.0, 0.0, 1.0, 4.0, 1e6),  # five numbers by position: a record is asked for
        Uncertainty(1.0, -1.0, 0.0, 1.0, 1.0),
        Uncertainty(math.nan, 0.0, 0.0, 1.0, 1.0),
        Uncertainty(1, 0, 0, 1, 0),
        Uncertainty("1", 0, 0, 1, 1),
        "abc",
    ],
)
def test_bad_uncertainty(bad):
    with pytest.raises(ValueError, match=r"'uncertainty' parameter of Compensator"):
        _comp(uncertainty=bad).update(_row(0.0, 1.0))


def test_reset_with_an_initial_displacement_before_any_update():
    comp = _comp()
    comp.reset(initial_displacement=7.0)
    assert comp.update(_row(0.0, 100.0)) == 7.0  # not 200: the reset is kept
    assert comp.update(_row(60.0, 101.0)) == pytest.approx(9.0)


def test_start_test_carries_the_lags_and_restarts_the_reference():
    comp = Compensator(
        ["T1_C"], [("T1_C", 1, 900.0, 2.0)], relative_to_start=True, row_columns=["time_s", "T1_C"]
    )
    for k in range(30):
        comp.update(_row(60.0 * k, 20.0 + k))
    lag = comp.state_["lags"]["T1_C|lag 15 min"]
    assert comp.start_test(_row(1800.0, 50.0)) == 0.0
    carried = comp.state_["lags"]["T1_C|lag 15 min"]
    a = math.exp(-60.0 / 900.0)
    assert carried == pytest.approx(a * lag + (1 - a) * 50.0)  # not restarted at 50
    assert comp.update(_row(1860.0, 50.0)) == pytest.approx(2.0 * (1 - a) * (50.0 - carried))
    assert comp.start_test(_row(1920.0, 50.0), initial_displacement=3.0) == 3.0
    assert isinstance(comp.update(_row(1980.0, 50.0)), float)


def test_start_test_restarts_the_interval_at_the_known_displacement():
    comp = _comp(uncertainty=Uncertainty(3.0, 2.0, 1.0, 3.0, 1e6))
    comp.update(_row(0.0, 1.0))
    comp.update(_row(7200.0, 1.0))
    comp.start_test(_row(7260.0, 1.0))  # recording reference, nothing given: nothing known
    assert comp.status.half_width == pytest.approx(Q90 * math.sqrt(3.0 + 2.0 * 7260 / 3600 + 1.0))
    comp.start_test(_row(7320.0, 1.0), initial_displacement=2.0)  # known here
    assert comp.status.half_width == pytest.approx(Q90 * 2.0)


def test_a_reading_without_uncertainty_is_refused():
    comp = _comp(uncertainty=None)
    comp.update(_row(0.0, 1.0))
    with pytest.raises(ValueError, match=r"cannot be weighed: this compensator has no uncertainty"):
        comp.observe(0.0, 2.0)


def test_a_reading_after_set_state_without_rows():
    comp = _comp()
    comp.update(_row(0.0, 1.0))
    state = comp.get_state()
    del state["filter"]
    other = _comp().set_state(state)
    with pytest.raises(ValueError, match=r"no row is remembered since the state was set"):
        other.observe(0.0, 2.0)


def test_no_bound_on_the_correction():
    comp = _comp(max_correction_um=math.inf)
    comp.update(_row(0.0, 1e6))
    assert comp.status.plausible


def test_start_test_passes_through_the_rate_limit():
    comp = Compensator(
        ["T1_C"],
        [("T1_C", 1, 900.0, 2.0)],
        relative_to_start=True,
        rate_limit_um_s=0.01,
        row_columns=["time_s", "T1_C"],
    )
    outputs = [comp.update(_row(60.0 * k, 20.0 + k)) for k in range(60)]
    before = outputs[-1]
    after = comp.start_test(_row(3600.0, 80.0))  # the correction itself drops to 0
    assert abs(after - before) <= 0.01 * 60.0 + 1e-12 and after != 0.0
