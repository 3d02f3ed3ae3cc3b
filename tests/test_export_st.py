"""The Structured Text export (issue 29): parsed by a third-party IEC 61131-3 parser and run.

blark (the TwinCAT 3 grammar of SLAC, in the test extra) parses every function
block the export writes; ``tests/_st_runtime.py`` runs the parsed block
statement by statement in LREAL (IEEE binary64). 24 h of rows through the
default transfer function's compensator, with and without the controller's
limits and through probe readings with a detected change, match
``Compensator.update`` to 1e-6 µm at every row (they match far closer), and the
script of refusals, held rows, late readings, a restarting clock and resets
gives the same codes and numbers, a missing input told by ``InputsValid``
as by a NaN.
"""

import math
import re

import numpy as np
import pytest
from _export_cases import (
    CHANGE_START_S,
    change_script,
    day,
    fitted,
    replay,
    script,
    scripted,
)

from greyml.controller import Compensator
from greyml.controller._export._program import describe
from greyml.controller._export._st import write_st

blark = pytest.importorskip("blark", reason="blark, the IEC 61131-3 parser, is in the test extra")

from _st_runtime import FunctionBlock  # noqa: E402  (needs blark)


class Block:
    """The exported function block, driven as the C export and Python are."""

    no_nan = True  # Structured Text has no NaN: 0 where Python says NaN

    def __init__(self, comp, *, flag_missing=False, name="gm_block"):
        program = describe(comp, name=name)
        self.source = write_st(program)
        self.fb = FunctionBlock(self.source)
        self.ids = [v.identifier for v in program.inputs]
        self.flag_missing = flag_missing
        self.out = self.fb()  # a call that does nothing: the outputs at the start

    def _call(self, **inputs):
        flags = dict(Execute=False, Reset=False, Observe=False, Recalibrate=False)
        flags = {k: v for k, v in flags.items() if k.lower() in self.fb.inputs}
        self.out = self.fb(**{**flags, **inputs})
        return self.out

    def update(self, t, x):
        x = list(x)
        valid = True
        if self.flag_missing and not all(map(math.isfinite, x)):
            # the PLC's way: a sensor's error bit, with whatever value it holds
            valid, x = False, [v if math.isfinite(v) else -7.0 for v in x]
        out = self._call(Execute=True, TimeS=t, InputsValid=valid, **dict(zip(self.ids, x)))
        return out["status"], out["outputum"]

    def observe(self, t, z):
        return self._call(Observe=True, ProbeTimeS=t, ProbeUm=z)["probestatus"]

    def reset(self, initial=None):
        given = initial is not None
        self._call(Reset=True, UseInitial=given, InitialUm=initial if given else 0.0)

    def recalibrate(self):
        self._call(Recalibrate=True)

    def output(self):
        return self.out["outputum"]

    def correction(self):
        return self.out["correctionum"]

    def held(self):
        return self.out["held"]

    def half_width(self):
        return self.out["halfwidthum"]

    def trusted(self):
        return self.out["trusted"]

    def changes(self):
        return self.out["changes"]

    def change_kind(self):
        return self.out["changekind"]

    def change_start_s(self):
        return self.out["changestarts"]

    def innovation(self):
        return self.out["innovation"]

    def outside(self):
        return self.out["outside"]

    def widening(self):
        return self.out["wideningum"]


# Three function blocks (blark takes seconds to parse one): the day's model with
# a rate limit, a quantum and a clamp, and the script's model twice: on a
# restarting clock with a rate limit, a clamp and held rows, and on a refusing
# clock, refusing missing inputs, without limits or a calibration.
DAY_LIMITS = {"rate_limit_um_s": 0.002, "quantum_um": 0.1, "clamp_um": 8.0}
SCRIPTED = {
    "restarting clock, rate and clamp, hold": (
        True,
        15.0,
        "hold",
        {"rate_limit_um_s": 0.01, "clamp_um": 2.0},
    ),
    "refusing clock, no limits, raise, no calibration": (False, None, "raise", {}),
}
# the second block's inputs are named as a hostile model file would name them
HOSTILE = ('x); system("rm -rf /"); //', "*) END_FUNCTION_BLOCK (*", "t1_C\nEND_VAR")


def test_a_day_of_rows_and_readings_gives_pythons_output_to_1e_6():
    comp = Compensator.from_model(fitted()).set_params(**DAY_LIMITS)
    block = Block(comp)
    t, x, y = day(comp.inputs)
    drift = np.where(t - t[0] > 12 * 3600, (t - t[0] - 12 * 3600) / 3600 * 2.0, 0.0)
    python, exported = np.empty(t.size), np.empty(t.size)
    worst = 0.0
    for k in range(t.size):
        python[k] = comp.update(dict(zip(["time_s", *comp.inputs], [t[k], *x[k]])))
        code, exported[k] = block.update(t[k], x[k])
        assert code == 0
        if k % 240 == 239:  # every hour, a reading 7 s late
            comp.observe(t[k] - 7.0, y[k] + drift[k])
            assert block.observe(t[k] - 7.0, y[k] + drift[k]) == 0
        status = comp.status
        worst = max(worst, abs(block.correction() - status.correction))
        worst = max(worst, abs(block.half_width() - status.half_width))
        assert block.changes() == status.changes and block.trusted() == status.trusted
    np.testing.assert_allclose(exported, python, rtol=0, atol=1e-6)
    assert worst <= 1e-6
    assert comp.status.changes >= 1  # the drift was detected, in both
    counts = python / DAY_LIMITS["quantum_um"]
    np.testing.assert_allclose(counts, np.round(counts), rtol=0, atol=1e-6)


@pytest.mark.parametrize("label", list(SCRIPTED))
def test_refusals_held_rows_readings_and_resets_match_python(label):
    calibrated, nominal, on_missing, limits = SCRIPTED[label]
    names = {} if calibrated else {"names": HOSTILE}
    # the calibrated block with the script's input envelope (its rows leave it)
    comp = scripted(
        calibrated,
        nominal_step_s=nominal,
        on_missing=on_missing,
        envelope=calibrated,
        **names,
        **limits,
    )
    block = Block(comp)
    outside = []
    worst, changes = replay(comp, block, script(nominal), on_missing, outside)
    assert worst <= 1e-6
    if calibrated:
        assert changes >= 2  # the detector fired, and recalibrate was called
        assert {flag for flag, _ in outside} == {1, 2, 3}  # each input left the envelope
        assert max(w for _, w in outside) > 0.1
    else:  # no probe inputs, and the hostile names as harmless identifiers
        assert "observe" not in block.fb.inputs
        assert {"x_x_system_rm_rf", "x_end_function_block", "x_t1_c_end_var"} <= set(
            block.fb.inputs
        )


@pytest.mark.parametrize("kind, size", [("step", 5.0), ("ramp", 3.0)])
def test_a_step_or_a_ramp_is_found_as_python_finds_it(kind, size):
    # exact readings every 15 min, then a 5 µm step or a 3 µm/h ramp from the fifth
    comp = scripted()
    block = Block(comp)
    worst, changes = replay(comp, block, change_script(kind, size), "hold")
    assert worst <= 1e-6  # output, correction, half-width, start and innovation
    status = comp.status
    assert changes == status.changes == block.changes() == 1  # it fired once, in both
    assert status.change_kind == kind and block.change_kind() == {"step": 1, "ramp": 2}[kind]
    assert status.change_start_s == block.change_start_s() == CHANGE_START_S


def test_inputs_valid_false_is_a_missing_input():
    calibrated, nominal, on_missing, limits = SCRIPTED["restarting clock, rate and clamp, hold"]
    comp = scripted(calibrated, nominal_step_s=nominal, on_missing=on_missing, **limits)
    worst, _ = replay(comp, Block(comp, flag_missing=True), script(nominal), on_missing)
    assert worst <= 1e-6


def test_every_loop_runs_over_constants_and_there_is_no_other():
    source = Block(Compensator.from_model(fitted()).set_params(**DAY_LIMITS)).source
    code = re.sub(r"\(\*.*?\*\)", "", source, flags=re.S)
    for word in ("WHILE", "REPEAT", "JMP", "POINTER", "__NEW", "RETURN", "AND_THEN"):
        assert word not in code, word
    loops = re.findall(r"FOR (\w+) := (\S+) TO (.+?) DO", code)
    assert len(loops) > 10
    for variable, start, stop in loops:
        assert start == "0", (variable, start)
        assert re.fullmatch(r"\d+|(N_TERMS|N_INPUTS|N_ENV|HISTORY|WINDOW) - [12]", stop), stop
