"""Compensator: what reaches the axis is finite and within max_correction_um (issue 41).

Each case is one of the round-4 findings, built by hand: a saved filter whose
covariance is symmetric with a non-negative diagonal but not positive
semi-definite; ``recalibrate(1e10)`` followed by readings of ±5 µm (which gave
inf and NaN); filter states so large that a row's correction or a reading's
update overflows (which gave inf, or a bare "cannot convert float NaN to
integer" with a quantum, after ``time_s`` had moved); a missing idle input on
the first row (taken as 0 even with ``on_missing="raise"``). Each is refused
in one line, or held, and leaves the state exactly as it was.
"""

import io
import json
import math
import zipfile

import numpy as np
import pytest

from greyml.controller import Compensator, Uncertainty
from greyml.controller._compensator import ordered_sum
from greyml.controller._output import OutputLimits, limit_output
from greyml.persist import load_model, save_model

U = Uncertainty(4.0, 0.5, 0.2, 2.0, 1.5, 0.3, 0.05, 1.25)


def _comp(**kw):
    return Compensator(["T1_C"], [("T1_C", 1, 600.0, 2.0)], uncertainty=U, **kw)


def _row(t, temp=1.0):
    return {"time_s": t, "T1_C": temp}


def _same(a, b):
    """Two states equal, a NaN equal to a NaN."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a):
        return math.isnan(b)
    return a == b


def _one_line(call, words):
    with pytest.raises(ValueError, match=words) as info:
        call()
    assert "\n" not in str(info.value)


NOT_PSD = [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]  # eigenvalues 3, 1, -1


def test_a_covariance_that_is_not_positive_semidefinite_is_refused_by_set_state():
    comp = _comp()
    comp.update(_row(0.0))
    comp.observe(0.0, 1.0)
    state = comp.get_state()
    bad = {**state, "filter": {**state["filter"], "P": NOT_PSD}}
    _one_line(lambda: comp.set_state(bad), "probe filter is not valid")
    assert _same(comp.get_state(), state)


def test_a_covariance_that_is_not_positive_semidefinite_is_refused_at_load(tmp_path):
    comp = _comp()
    comp.update(_row(0.0))
    comp.observe(0.0, 1.0)
    path = save_model(comp, tmp_path / "comp.greyml")
    with zipfile.ZipFile(path) as z:
        members = {n: z.read(n) for n in z.namelist()}
    member = json.loads(members["model.json"])["tree"]["state"]["_fP"]["file"]
    buffer = io.BytesIO()
    np.save(buffer, np.array(NOT_PSD))  # symmetric, its diagonal >= 0: not a covariance
    members[member] = buffer.getvalue()
    bad = tmp_path / "bad.greyml"
    with zipfile.ZipFile(bad, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    with pytest.raises(ValueError, match="probe filter is not valid") as info:
        load_model(bad)
    assert "\n" not in str(info.value)


def test_recalibrate_refuses_a_size_beyond_max_correction_and_readings_stay_finite():
    comp = _comp(quantum_um=0.1)
    comp.update(_row(0.0))
    state = comp.get_state()
    for size in (1e10, -2000.0, math.nan, math.inf):
        _one_line(lambda s=size: comp.recalibrate(s), "size_um is .* finite number within")
        assert _same(comp.get_state(), state)
    comp.recalibrate(1000.0)  # the bound itself is taken
    # the readings of the report (±5 µm): every correction and output finite and bounded
    for k, z in enumerate((5.0, -5.0, 5.0, -5.0)):
        t = 60.0 * (k + 1)
        out = comp.update(_row(t))
        status = comp.observe(t, z)
        assert math.isfinite(out) and abs(out) <= 1000.0
        assert math.isfinite(status.correction) and abs(status.correction) <= 1000.0


@pytest.mark.parametrize(
    "limits", [{}, {"quantum_um": 0.1}, {"quantum_um": 0.1, "rate_limit_um_s": 1.0}]
)
def test_a_row_whose_correction_overflows_is_refused_and_changes_nothing(limits):
    comp = _comp(**limits)
    comp.update(_row(0.0))
    comp.observe(0.0, 1.0)
    state = comp.get_state()
    # an offset and a bias of 1e308 um: their sum is beyond any double
    huge = {**state, "filter": {**state["filter"], "x": [1e308, 1e308, 0.0]}}
    comp.set_state(huge)
    before = comp.get_state()
    _one_line(lambda: comp.update(_row(600.0)), r"correction overflows at time_s = 600 s")
    assert _same(comp.get_state(), before) and comp.status.time_s == 0.0
    # finite but beyond max_correction_um: refused as well
    comp.set_state({**state, "filter": {**state["filter"], "x": [0.0, 0.0, 1e6]}})
    _one_line(lambda: comp.update(_row(600.0)), r"beyond \+-1000 um \(max_correction_um\)")


def test_a_reading_that_overflows_the_filter_is_refused_and_changes_nothing():
    comp = _comp()
    comp.update(_row(0.0))
    comp.update(_row(60.0))
    state = comp.get_state()
    huge = {**state, "filter": {**state["filter"], "x": [1e308, 1e308, 0.0], "adjusted": True}}
    comp.set_state(huge)
    before = comp.get_state()
    _one_line(lambda: comp.observe(60.0, 1.0), "overflows the probe filter")
    assert _same(comp.get_state(), before)


def test_the_output_stage_never_converts_a_nan_to_a_count():
    limits = OutputLimits(quantum_um=0.1)
    for value in (math.nan, math.inf, -math.inf):
        _one_line(lambda v=value: limit_output(v, 1.0, 0.0, 0.0, limits), "not a finite number")


def _idle():
    return dict(
        inputs=["T1_C", "rpm"],
        terms=[("T1_C", 1, 600.0, 2.0), ("rpm", 1, 900.0, 0.01)],
        idle_inputs=["rpm"],
    )


def test_a_missing_idle_input_on_the_first_row_is_refused_with_raise():
    comp = Compensator(**_idle(), on_missing="raise")
    _one_line(
        lambda: comp.update({"time_s": 0.0, "T1_C": 20.0, "rpm": math.nan}),
        r"input 'rpm' is nan at time_s = 0 s",
    )
    assert comp.get_state()["time_s"] is None


def test_a_missing_idle_input_on_the_first_row_is_held_and_the_next_row_is_the_first():
    comp = Compensator(**_idle())
    assert comp.update({"time_s": 0.0, "T1_C": 20.0, "rpm": math.nan}) == 0.0  # the axis's 0
    assert comp.status.held and comp.get_state()["time_s"] is None
    # the next row starts the lags: T1 at rest (2 * 20), the speed's lag at 0
    assert comp.update({"time_s": 15.0, "T1_C": 20.0, "rpm": 3000.0}) == 40.0
    # and then the speed's lag moves: 0.01 * 3000 * (1 - exp(-15 / 900))
    expected = 40.0 + 0.01 * 3000.0 * (1.0 - math.exp(-15.0 / 900.0))
    assert comp.update({"time_s": 30.0, "T1_C": 20.0, "rpm": 3000.0}) == pytest.approx(expected)


def test_sums_are_taken_left_to_right():
    # 1e17 - 1e17 + 1 is 1 in this order; numpy's pairwise sum and BLAS may say 0 or 2
    assert ordered_sum([1e17, -1e17, 1.0, 0.0]) == 1.0
    assert ordered_sum([1.0, 1e17, -1e17]) == 0.0
    assert ordered_sum(np.array([[1e17, -1e17, 1.0], [1.0, 1e17, -1e17]])).tolist() == [1.0, 0.0]
    assert ordered_sum([]) == 0.0


def test_an_overflow_is_a_valueerror_never_an_overflowerror():
    # Python's float power raised OverflowError: products and powers that overflow
    # are inf, and what is refused is refused with the package's ValueError
    comp = _comp(max_correction_um=math.inf)
    comp.update(_row(0.0))
    comp.observe(0.0, 1.0)
    state = comp.get_state()
    _one_line(lambda: comp.recalibrate(1e200), "overflows the probe filter's covariance")
    assert _same(comp.get_state(), state)
    # a row 1e300 s on (no lag: nothing bounds the step): the half-width is infinite
    raw = Compensator(["T1_C"], [("T1_C", 1, None, 2.0)], uncertainty=U)
    raw.update(_row(0.0))
    raw.observe(0.0, 1.0)
    raw.update(_row(1e300))
    assert raw.status.half_width == math.inf
