"""The controller's limits of a Compensator (issue 29): clamp, quantum, rate limit, hold.

Hand-computed ramps and roundings, property tests over random corrections and
steps (the output never moves faster than the limit, is always a whole number
of quanta, and with no limit is the correction itself), the hold-last-value
policy on a missing input, and the stage's state through get_state, set_state
and a saved file, checked at load.
"""

import math

import numpy as np
import pytest
from conftest import rewrite_model_file
from hypothesis import given, settings
from hypothesis import strategies as st

from greyml import Compensator
from greyml.controller._output import QUANTA_MAX, OutputLimits, limit_output
from greyml.persist import load_model, save_model


def _echo(**limits):
    """A compensator whose correction is its input ``c`` (one raw term of weight 1)."""
    return Compensator(["c"], [("c", 1, None, 1.0)], row_columns=["time_s", "c"], **limits)


def _run(comp, times, values):
    return np.array([comp.update(np.array([t, v])) for t, v in zip(times, values)])


def _one_line(call, match):
    with pytest.raises(ValueError, match=match) as info:
        call()
    assert "\n" not in str(info.value)


def test_a_clamp_a_quantum_and_their_rounding_by_hand():
    comp = _echo(clamp_um=5.0)
    assert list(_run(comp, [0, 1, 2, 3], [3.0, 7.5, -9.0, -4.9])) == [3.0, 5.0, -5.0, -4.9]
    # halves away from zero, on both sides; 1.25 / 0.1 is 12.5 here
    comp = _echo(quantum_um=0.5)
    out = _run(comp, [0, 1, 2, 3, 4], [0.25, -0.25, 0.74, -0.76, 1.0])
    assert list(out) == [0.5, -0.5, 0.5, -1.0, 1.0]
    comp = _echo(quantum_um=0.1, clamp_um=2.0)
    out = _run(comp, [0, 1, 2], [1.234, 9.0, -1.25])
    np.testing.assert_allclose(out, [1.2, 2.0, -1.3], rtol=0, atol=1e-15)
    assert comp.get_state()["output"] == {"output_um": out[-1], "credit_um": 0.0, "held": False}


def test_the_rate_limit_ramps_from_zero_and_holds_the_first_row():
    comp = _echo(rate_limit_um_s=0.5)
    # the first row holds 0 (nothing written to the axis yet), then 0.5 µm/s
    out = _run(comp, [0, 2, 4, 6, 8, 10], [3.0, 3.0, 3.0, 3.0, -1.0, -1.0])
    assert list(out) == [0.0, 1.0, 2.0, 3.0, 2.0, 1.0]
    assert comp.status.correction == -1.0 and comp.status.output == 1.0
    # a reset keeps the output (the axis has it) and holds it at the next row
    comp.reset()
    assert list(_run(comp, [0, 1, 2], [5.0, 5.0, 5.0])) == [1.0, 1.5, 2.0]


def test_a_quantum_slower_than_one_row_moves_one_quantum_per_quantum_of_time():
    # 0.1 µm quanta, 0.01 µm/s, 1 s rows: one quantum every 10 s, exactly
    comp = _echo(rate_limit_um_s=0.01, quantum_um=0.1)
    times = np.arange(0.0, 61.0)
    out = _run(comp, times, np.full(times.size, 0.32))
    moves = np.flatnonzero(np.diff(out)) + 1
    assert list(times[moves]) == [10.0, 20.0, 30.0]  # then at the target, 0.3
    np.testing.assert_allclose(out[-1], 0.3, rtol=0, atol=1e-15)


def test_a_quantum_and_a_fast_rate_move_whole_quanta_within_the_row():
    # 0.25 µm/s over 1 s rows allows 0.25 µm: two 0.1 µm quanta a row
    comp = _echo(rate_limit_um_s=0.25, quantum_um=0.1)
    out = _run(comp, [0, 1, 2, 3, 4], [1.0] * 5)
    np.testing.assert_allclose(out, [0.0, 0.2, 0.4, 0.6, 0.8], rtol=0, atol=1e-15)


def test_a_clamp_must_be_a_whole_number_of_quanta():
    _one_line(lambda: _echo(quantum_um=0.3, clamp_um=1.0).update([0.0, 1.0]), "whole number")
    _one_line(lambda: _echo(rate_limit_um_s=0.0).update([0.0, 1.0]), "rate_limit_um_s")
    _one_line(lambda: _echo(on_missing="zero").update([0.0, 1.0]), "on_missing")
    _echo(quantum_um=0.1, clamp_um=2.0).update([0.0, 1.0])  # 2 / 0.1 is 20.000000000000004


# -- properties ---------------------------------------------------------------

_steps = st.lists(st.floats(0.01, 50.0), min_size=1, max_size=60)
_values = st.lists(st.floats(-200.0, 200.0), min_size=60, max_size=60)


def _stream(steps, values, **limits):
    times = np.concatenate([[0.0], np.cumsum(steps)])
    comp = _echo(**limits)
    out = np.array([comp.update(np.array([t, v])) for t, v in zip(times, values)])
    return times, np.asarray(values[: times.size]), out


@settings(max_examples=150, deadline=None)
@given(_steps, _values, st.floats(0.001, 20.0))
def test_the_output_never_moves_faster_than_the_rate_limit(steps, values, rate):
    times, _, out = _stream(steps, values, rate_limit_um_s=rate)
    assert out[0] == 0.0
    dt = np.diff(times)
    assert (np.abs(np.diff(out)) <= rate * dt * (1 + 1e-12) + 1e-12).all()


@settings(max_examples=150, deadline=None)
@given(_steps, _values, st.sampled_from([0.001, 0.1, 0.25, 1.0, 7.0]), st.floats(0.001, 20.0))
def test_with_a_quantum_and_a_rate_limit_the_output_is_whole_quanta_and_no_faster(
    steps, values, q, rate
):
    times, target, out = _stream(steps, values, rate_limit_um_s=rate, quantum_um=q)
    counts = out / q
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-6)
    dt = np.diff(times)
    moved = np.abs(np.diff(out))
    # a row moves at most its allowance, or one quantum when that is less
    assert (moved <= np.maximum(rate * dt, q) * (1 + 1e-9) + 1e-12).all()
    # and over any stretch, the rate limit plus what one row may hold back
    slack = max(q, rate * dt.max())
    span = np.abs(out[:, None] - out[None, :])
    apart_s = np.abs(times[:, None] - times[None, :])  # the rows' own time_s, not a clock
    assert (span <= rate * apart_s + slack * (1 + 1e-9) + 1e-12).all()


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.1, 5.0), min_size=5, max_size=80), st.floats(-50.0, 50.0))
def test_slower_than_a_quantum_a_row_every_move_is_one_quantum_after_its_time(steps, value):
    q, rate = 0.1, 0.01  # 0.1 µm per 10 s; rows of at most 5 s
    times, _, out = _stream(steps, [value] * (len(steps) + 1), rate_limit_um_s=rate, quantum_um=q)
    moves = np.flatnonzero(np.abs(np.diff(out)) > 0) + 1
    np.testing.assert_allclose(np.abs(np.diff(out))[moves - 1], q, rtol=1e-9)
    corners = np.concatenate([[0.0], times[moves]])
    assert (np.diff(corners) >= q / rate * (1 - 1e-9)).all()


@settings(max_examples=150, deadline=None)
@given(_steps, _values, st.sampled_from([0.001, 0.1, 0.5, 3.0]))
def test_a_quantum_alone_rounds_to_the_nearest_whole_quantum(steps, values, q):
    _, target, out = _stream(steps, values, quantum_um=q)
    counts = out / q
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-6)
    assert (np.abs(out - target) <= q / 2 * (1 + 1e-9)).all()


@settings(max_examples=100, deadline=None)
@given(_steps, _values)
def test_with_no_limit_the_output_is_the_correction(steps, values):
    times, target, out = _stream(steps, values)
    np.testing.assert_array_equal(out, target)
    # and a model with lags: the same outputs as before the limits existed
    lagged = Compensator(["c"], [("c", 1, 60.0, 2.0), ("c", 2, None, 0.01)], intercept=1.0)
    limited = Compensator(
        ["c"], [("c", 1, 60.0, 2.0), ("c", 2, None, 0.01)], intercept=1.0, on_missing="raise"
    )
    for t, v in zip(times, target):
        a = lagged.update({"time_s": t, "c": v})
        assert a == limited.update({"time_s": t, "c": v}) == lagged.status.correction


@settings(max_examples=50, deadline=None)
@given(_values, st.floats(0.5, 10.0), st.floats(0.01, 2.0))
def test_the_output_settles_on_a_steady_correction(values, rate, q):
    comp = _echo(rate_limit_um_s=rate, quantum_um=q, clamp_um=q * 1000)
    target = values[0]
    t = 0.0
    for _ in range(3):
        comp.update(np.array([t, target]))
        t += 1.0
    # whole quanta per row: at least half the limit's pace (a row allows floor(r dt / q) quanta)
    need = 2 * abs(target) / rate + 2 * q / rate + 3
    steps = int(min(need, 1e5))
    out = None
    for k in range(steps):
        out = comp.update(np.array([t + k, target]))
    expected, _, _ = limit_output(target, None, 0.0, 0.0, OutputLimits(q * 1000, q, None))
    assert out == pytest.approx(expected, abs=1e-9)


def test_the_kernel_bounds_a_count_to_a_plcs_integer():
    out, count, _ = limit_output(1e300, 1.0, 0.0, 0.0, OutputLimits(None, 0.1, None))
    assert count == QUANTA_MAX and out == pytest.approx(1e8)


# -- a missing input ----------------------------------------------------------


def test_a_missing_input_holds_the_last_output_and_changes_no_state():
    comp = Compensator(
        ["T1_C", "rpm"],
        [("T1_C", 1, 900.0, 2.0), ("rpm", 1.5, None, 0.01)],
        row_columns=["time_s", "T1_C", "rpm"],
        rate_limit_um_s=0.02,
        quantum_um=0.1,
    )
    rows = [[0.0, 20.0, 4.0], [60.0, 20.5, 4.0], [120.0, 21.0, 9.0]]
    for r in rows:
        comp.update(np.array(r))
    before = comp.get_state()
    last = comp.status.output
    for bad in ([180.0, np.nan, 4.0], [180.0, 21.0, np.inf], [180.0, -np.inf, np.nan]):
        assert comp.update(np.array(bad)) == last
        status = comp.status
        assert status.held and status.output == last and status.time_s == 120.0
        state = comp.get_state()
        assert state["output"]["held"] and {**state["output"], "held": False} == before["output"]
        assert {k: v for k, v in state.items() if k != "output"} == {
            k: v for k, v in before.items() if k != "output"
        }
    # the next row steps from the last row taken (240 s of allowance: 4.8 µm)
    twin = Compensator(**comp.get_params())
    twin.set_state(before)
    assert comp.update(np.array([240.0, 21.5, 9.0])) == twin.update(np.array([240.0, 21.5, 9.0]))
    assert not comp.status.held
    # a time that is not finite is not a sensor: still refused
    _one_line(lambda: comp.update(np.array([np.nan, 21.0, 4.0])), "time_s is nan")
    # a negative input to a fractional power is not missing: refused
    _one_line(lambda: comp.update(np.array([300.0, 21.0, -1.0])), "is negative")


def test_a_missing_input_before_any_row_gives_zero_and_then_starts():
    comp = _echo()
    assert comp.update(np.array([0.0, np.nan])) == 0.0
    assert comp.status.held and comp.status.time_s is None
    assert comp.update(np.array([1.0, 4.0])) == 4.0  # the first row taken


def test_on_missing_raise_keeps_the_refusal():
    comp = _echo(on_missing="raise")
    comp.update(np.array([0.0, 1.0]))
    _one_line(lambda: comp.update(np.array([1.0, np.nan])), r"input 'c' is nan at time_s = 1 s")


# -- state and files ----------------------------------------------------------


def _limited():
    return Compensator(
        ["T1_C"],
        [("T1_C", 1, 600.0, 3.0), ("T1_C", 1, None, -1.0)],
        relative_to_start=True,
        rate_limit_um_s=0.004,
        quantum_um=0.1,
        clamp_um=20.0,
    )


def _rows(n=80):
    return [{"time_s": 15.0 * k, "T1_C": 20.0 + 0.04 * k + 0.3 * math.sin(k / 5)} for k in range(n)]


def test_state_and_a_saved_file_resume_the_output_stage_exactly(tmp_path):
    rows = _rows()
    whole = _limited()
    expected = [whole.update(r) for r in rows]
    assert len(set(expected)) > 3  # the ramp moved
    part = _limited()
    for r in rows[:37]:
        part.update(r)
    state = part.get_state()
    assert state["output"]["credit_um"] > 0  # mid-quantum: the credit is part of the state
    resumed = _limited().set_state(state)
    path = save_model(part, tmp_path / "limited.greyml")
    loaded = load_model(path)
    for r, e in zip(rows[37:], expected[37:]):
        assert resumed.update(r) == e
        assert loaded.update(r) == e


@pytest.mark.parametrize(
    "attribute, value, words",
    [
        ("_output", 0.15, "not a whole number of quanta"),
        ("_output", 40.0, "beyond the clamp"),
        ("_output", {"kind": "float", "value": "nan"}, "output is not valid"),
        ("_credit", -1.0, "output is not valid"),
        ("_held", 1, "output is not valid"),
    ],
)
def test_a_tampered_output_stage_is_refused_at_load(tmp_path, attribute, value, words):
    comp = _limited()
    for r in _rows(20):
        comp.update(r)
    path = save_model(comp, tmp_path / "comp.greyml")

    def edit(state):
        state[attribute] = value

    bad = rewrite_model_file(path, tmp_path / "bad.greyml", edit)
    with pytest.raises(ValueError, match=words) as info:
        load_model(bad)
    assert "\n" not in str(info.value) and "Cannot load" in str(info.value)


def test_set_state_refuses_a_bad_output_and_keeps_the_state():
    comp = _limited()
    for r in _rows(10):
        comp.update(r)
    state = comp.get_state()
    for output in ({"output_um": 0.05, "credit_um": 0.0, "held": False}, {"output_um": 1.0}):
        _one_line(lambda o=output: comp.set_state({**state, "output": o}), "output")
        assert comp.get_state() == state


def test_a_transfer_functions_compensator_takes_the_limits_at_construction():
    """``Compensator.from_model`` passes the output stage on: the
    same stream through it and through one given the limits by ``set_params``."""
    from greyml import ThermalTransferFunction, make_test_index

    rng = np.random.default_rng(3)
    n = 120
    index = make_test_index(np.repeat(["a", "b", "c"], n), np.tile(np.arange(n) * 60.0, 3))
    t1 = 20.0 + np.cumsum(rng.normal(0, 0.05, 3 * n))
    import pandas as pd

    X = pd.DataFrame({"T1_C": t1}, index=index)
    model = ThermalTransferFunction(time_constants=(600.0,)).fit(X, 4.0 * (t1 - 20.0))
    limits = dict(clamp_um=3.0, quantum_um=0.5, rate_limit_um_s=0.01, max_correction_um=50.0)
    given = Compensator.from_model(model, row_columns=["time_s", "T1_C"], **limits)
    later = Compensator.from_model(model, row_columns=["time_s", "T1_C"]).set_params(**limits)
    rows = np.column_stack([np.arange(n) * 60.0, t1[:n]])
    out = np.array([given.update(r) for r in rows])
    assert np.array_equal(out, [later.update(r) for r in rows])
    assert np.abs(out).max() <= 3.0 and np.all(np.abs(np.diff(out)) <= 0.01 * 60.0 + 1e-12)
    assert np.all(np.abs(out / 0.5 - np.round(out / 0.5)) < 1e-9)
    assert given.max_correction_um == 50.0
