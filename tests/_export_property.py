"""Random sequences run in Python and in the compiled C export (tests and benchmarks).

Issue 41's property: for any sequence of ``update`` / ``observe`` /
``recalibrate`` / ``reset`` / a saved state restored (``set_state`` in Python,
the struct copied back in C) on the script's compensator (lags, raw inputs, a
fractional power, an idle driver, a gap limit, its input envelope and
calibration) with one of three sets of limits, every output is finite and
within ``max_correction_um`` (plus half a quantum where it is rounded) or the
call is refused with a status, Python and C refuse or hold the same calls, and
they give the same output, correction and half-width to :data:`TOLERANCE` at
every step. ``tests/test_export_property.py`` runs a few dozen sequences;
``benchmarks/bench_export_property.py`` runs 10,000.
"""

from __future__ import annotations

import copy
import ctypes
import functools
import math
import os
import tempfile

from _export_cases import CompiledC, scripted
from hypothesis import strategies as st

#: The bound the property sets (µm): small, so that rows beyond it are common.
MAX_CORRECTION = 200.0

#: Python = C to this, relative to max(1, |value|): the documented tolerance.
TOLERANCE = 1e-9

#: The compiled variants: the limits of each (C takes them as constants).
VARIANTS = {
    "none": {},
    "rate, quantum and clamp": {"rate_limit_um_s": 0.5, "quantum_um": 0.1, "clamp_um": 150.0},
    "rate, restarting clock": {"rate_limit_um_s": 2.0, "nominal_step_s": 15.0},
}

_FOLDER = tempfile.TemporaryDirectory(prefix="greyml-property-")


def compensator(variant):
    return scripted(True, envelope=True, max_correction_um=MAX_CORRECTION, **VARIANTS[variant])


@functools.cache
def compiled(variant):
    """The variant's C export compiled once per process, driven through ctypes."""
    folder = os.path.join(_FOLDER.name, variant.replace(" ", "_").replace(",", ""))
    os.makedirs(folder, exist_ok=True)
    return CompiledC(compensator(variant), folder)


def _mostly(values, special):
    """``values`` nine times in ten, else one of ``special``."""
    return st.tuples(st.integers(0, 9), values, st.sampled_from(special)).map(
        lambda drawn: drawn[2] if drawn[0] == 9 else drawn[1]
    )


# an input is a sensor's value nine times in ten, else NaN, infinite, huge or negative
_input = _mostly(st.floats(15.0, 30.0), [math.nan, math.inf, 1e300, -5.0])
_rpm = _mostly(st.floats(0.0, 600.0), [math.nan, -5.0, 1e6])
_update = st.tuples(
    st.just("update"),
    st.sampled_from([15.0, 15.0, 15.0, 60.0, 600.0, 0.0, -15.0, 5000.0, math.nan]),
    st.tuples(_input, _input, _rpm),
)
_observe = st.tuples(
    st.just("observe"),
    st.sampled_from([0.0, 0.0, 0.0, 7.0, 7.0, 15.0, 600.0, 1e5]),
    _mostly(st.floats(-250.0, 250.0), [math.nan, 1e4]),
)
_recalibrate = st.tuples(
    st.just("recalibrate"),
    st.one_of(st.none(), st.floats(-300.0, 300.0), st.sampled_from([1e10, math.nan])),
)
_reset = st.tuples(st.just("reset"), st.one_of(st.none(), st.floats(-50.0, 50.0)))
_other = st.tuples(st.sampled_from(["save", "restore"]))

#: A variant and a sequence of 10 to 80 calls, mostly rows.
sequences = st.tuples(
    st.sampled_from(list(VARIANTS)),
    st.lists(
        st.one_of(_update, _update, _update, _observe, _recalibrate, _reset, _other),
        min_size=10,
        max_size=80,
    ),
)


def _close(a, b):
    return abs(a - b) <= TOLERANCE * max(1.0, abs(a))


def run(variant, calls, tally=None):
    """Run ``calls`` in Python and C; assert the property; return the largest
    difference seen, relative to max(1, |value|). ``tally`` (a dict), if given,
    counts the calls refused and the rows held."""
    tally = {} if tally is None else tally
    comp, c = compensator(variant), compiled(variant)
    c.init()
    quantum = VARIANTS[variant].get("quantum_um") or 0.0
    bound = MAX_CORRECTION + quantum / 2
    t, saved, worst = 0.0, None, 0.0
    for call in calls:
        kind = call[0]
        if kind == "update":
            t_next = t + call[1]
            try:
                comp.update(dict(zip(["time_s", *comp.inputs], [t_next, *call[2]])))
                python = 1 if comp.status.held else 0
            except ValueError:
                python = -1
            code, out = c.update(t_next, call[2])
            assert (python < 0) == (code < 0) and (python == 1) == (code == 1), (call, code)
            key = "refused" if code < 0 else "held" if code == 1 else "taken"
            tally[key] = tally.get(key, 0) + 1
            if python == 0:  # a refused or held row leaves the clock where it was
                t = t_next
        elif kind == "observe":
            if comp.status.time_s is None:
                continue
            when = comp.status.time_s - call[1]
            try:
                comp.observe(when, call[2])
                python = 0
            except ValueError:
                python = -4
            assert python == c.observe(when, call[2]), call
            key = "readings refused" if python else "readings taken"
            tally[key] = tally.get(key, 0) + 1
        elif kind == "recalibrate":
            try:
                comp.recalibrate(call[1])
                python = 0
            except ValueError:
                python = -4
            has = call[1] is not None
            code = c._recalibrate(c.state, int(has), call[1] if has else 0.0)
            assert python == code, call
        elif kind == "reset":
            comp.reset(initial_displacement=call[1])
            c.reset(call[1])
        elif kind == "save":
            if comp.status.time_s is not None:
                saved = (copy.deepcopy(comp.get_state()), bytes(c.state.raw))
        elif saved is not None:  # restore
            comp.set_state(copy.deepcopy(saved[0]))
            ctypes.memmove(c.state, saved[1], len(saved[1]))
            t = comp.status.time_s
        status = comp.status
        output = c.output()
        assert math.isfinite(status.output) and abs(status.output) <= bound, (call, status)
        assert math.isfinite(output) and abs(output) <= bound, (call, output)
        pairs = [(status.output, output)]
        if status.correction is not None:
            assert math.isfinite(status.correction) and math.isfinite(c.correction())
            pairs += [(status.correction, c.correction()), (status.half_width, c.half_width())]
            assert status.trusted == c.trusted() and status.changes == c.changes(), call
        assert status.held == c.held(), call
        for a, b in pairs:
            assert _close(a, b), (call, a, b)
            worst = max(worst, abs(a - b) / max(1.0, abs(a)))
    return worst
