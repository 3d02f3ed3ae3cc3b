"""What the export tests replay (tests only): a day of rows, a fitted model, a script of
refusals, and the C export compiled and driven through ctypes.

The day is 24 h of the real CAIVIAC recording (``cycles.csv`` read with
``read_tests_csv(path, test_column="cycle")``) where the file is found, else of
a simulated recording of the same layout (five 8 h spindle cycles at 15 s, the
spindle speed and six temperatures, the displacement through thermal lags);
the model is ``ThermalTransferFunction(drivers=["spindle_rpm"],
max_sensors=5)`` fitted on the whole recording (5 sensors and the speed with
the default bank, calibrated: its compensator takes probe readings).
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
from conftest import caiviac_csv

from greyml import Compensator, ThermalTransferFunction, make_test_index
from greyml.controller import Uncertainty
from greyml.controller._export._write import export_text
from greyml.dynamic import InputEnvelope
from greyml.io import read_tests_csv

DAY_S = 24 * 3600.0
TARGET = "ch1_um"


@functools.lru_cache(maxsize=1)
def recording():
    """(X, y, source): the recording's inputs and target, and where they come from."""
    path = caiviac_csv()
    if path is not None:
        frame = read_tests_csv(path, test_column="cycle")
        sensors = [c for c in frame.columns if c.startswith("t") and c.endswith("_C")]
        return frame[["spindle_rpm", *sensors]], frame[TARGET], "CAIVIAC"
    return (*_simulated(), "simulated")


def _simulated(seed=0):
    """Five 8 h cycles at 15 s on one clock: 4 h of spindle, 4 h still, lags and noise."""
    rng = np.random.default_rng(seed)
    step, n = 15.0, 1920
    t = step * np.arange(5 * n)
    rpm = np.zeros(t.size)
    for c, speed in enumerate((1250.0, 2500.0, 3750.0, 5000.0, 3500.0)):
        rpm[c * n : c * n + n // 2] = speed
    ambient = 22.0 + 0.8 * np.sin(2 * np.pi * t / 86400.0)

    def lag(x, tau):
        a = math.exp(-step / tau)
        out = np.empty_like(x)
        s = x[0]
        for k, v in enumerate(x):
            s = a * s + (1 - a) * v
            out[k] = s
        return out

    heat = rpm / 1000.0
    temps = {}
    for j, (gain, tau) in enumerate(
        ((1.2, 900), (0.8, 2700), (0.5, 5400), (0.3, 8100), (0.2, 600), (0.1, 300))
    ):
        temps[f"t{j + 1}_C"] = ambient + gain * lag(heat**1.5, tau) + rng.normal(0, 0.02, t.size)
    y = 4.0 * lag(heat, 1800) + 2.5 * lag(heat**2, 7200) - 3.0 * (temps["t2_C"] - 22.0)
    y = y + rng.normal(0, 0.2, t.size)
    index = make_test_index([f"{1 + k // n}" for k in range(t.size)], t)
    X = pd.DataFrame({"spindle_rpm": rpm, **temps}, index=index)
    return X, pd.Series(y, index=index, name=TARGET)


@functools.lru_cache(maxsize=1)
def fitted():
    """The default transfer function fitted on the whole recording."""
    X, y, _ = recording()
    return ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=5).fit(X, y)


@functools.lru_cache(maxsize=1)
def five_sensors():
    """The default transfer function on the speed and five sensors, all kept."""
    X, y, _ = recording()
    sensors = [c for c in X.columns if c != "spindle_rpm"][:5]
    return ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X[["spindle_rpm", *sensors]], y)


def day(inputs):
    """(time_s, inputs as an array, target) of the recording's first 24 h."""
    X, y, _ = recording()
    t = X.index.get_level_values("time_s").to_numpy(dtype=float)
    keep = t - t[0] < DAY_S
    return t[keep], X[list(inputs)].to_numpy(dtype=float)[keep], y.to_numpy(dtype=float)[keep]


#: The script's envelope: its rows leave it by T1's range (from row 31), T2's range (from
#: row 26) and the speed's (3250 and 3300 rpm), and after the last reset by T2's rate.
ENVELOPE = (
    np.array([20.0, 20.5, 0.0]),
    np.array([21.5, 21.0, 3200.0]),
    np.array([15.0, 5.0, 1e6]),
)


def scripted(calibrated=True, names=("T1_C", "T2_C", "rpm"), envelope=False, **limits):
    """A small compensator with every feature: lags, raw inputs, a fractional power, an
    idle driver, a gap limit and (``calibrated``) a calibration that fires easily; its
    inputs (two temperatures and a speed) are called ``names``; with ``envelope``, the
    script's :data:`ENVELOPE`."""
    t1, t2, rpm = names
    if envelope:
        limits["envelope"] = InputEnvelope(tuple(names), *ENVELOPE)
    return Compensator(
        list(names),
        [
            (t1, 1, 600.0, 2.0),
            (t2, 1, 1800.0, -1.0),
            (t2, 1, None, 0.5),
            (rpm, 1.5, None, 0.01),
            (rpm, 1, 900.0, 0.002),
            (rpm, 2, 300.0, 1e-6),
        ],
        intercept=1.5,
        relative_to_start=True,
        idle_inputs=[rpm],
        max_step_s=3600.0,
        uncertainty=Uncertainty(4.0, 0.5, 0.2, 2.0, 1.5, 0.3, 0.05, 1.25) if calibrated else None,
        tolerance_um=3.0,
        probe_noise_um=0.5,
        false_alarm_rate=0.01,
        **{"max_correction_um": 4000.0, **limits},
    )


ERR_TIME, ERR_GAP, ERR_VALUE, ERR_READING, HELD = -1, -2, -3, -4, 1


def script(nominal):
    """Actions and what each must give: ("update", t, x, code), ("observe", t, z, code),
    ("reset", initial), ("recalibrate",). Code 0 taken, 1 held, < 0 refused."""
    nan, inf = math.nan, math.inf
    out = []
    t = 0.0
    for k in range(40):
        out.append(("update", t, [20 + 0.05 * k, 21 - 0.02 * k, 3000.0 + 50 * (k % 7)], 0))
        t += 15.0
    out += [
        ("update", t, [nan, 21.0, 3000.0], HELD),
        ("update", t, [20.0, 21.0, inf], HELD),
        ("update", nan, [20.0, 21.0, 3000.0], ERR_TIME),
        ("update", inf, [20.0, 21.0, 3000.0], ERR_TIME),
        ("update", t + 4000.0, [20.0, 21.0, 3000.0], ERR_GAP),
        ("update", t, [20.0, 21.0, -5.0], ERR_VALUE),  # negative to the power 1.5
        ("update", t, [nan, 21.0, -5.0], HELD),  # the missing input decides
        ("update", t, [20.0, 21.0, 1e5], ERR_VALUE),  # beyond max_correction_um (issue 41)
        ("update", t, [20.0, 21.0, 1e300], ERR_VALUE),  # its power overflows
        ("observe", t, 3.0, ERR_READING),  # after the last row
        ("observe", t - 20.0, nan, ERR_READING),
        ("observe", t - 20.0, 5000.0, ERR_READING),  # beyond max_correction_um
        ("observe", t - 20.0, 6.0, 0),  # late: interpolated between rows
        ("observe", t - 20.0, 6.0, ERR_READING),  # not after the previous reading
        ("update", t, [20.5, 20.9, 3100.0], 0),
        ("observe", t, 9.0, 0),
        ("update", t + 15.0, [20.6, 20.9, 3100.0], 0),
        ("observe", t + 15.0, 14.0, 0),  # far off: the detector fires
        ("recalibrate",),
    ]
    t += 30.0
    if nominal:
        # a clock that restarts: the next piece, stepping by nominal_step_s
        out.append(("update", 0.0, [20.7, 20.8, 0.0], 0))
        t = 15.0
    else:
        out.append(("update", t - 30.0, [20.7, 20.8, 0.0], ERR_TIME))  # time repeats
    first = t
    for k in range(600):  # past the 512 rows remembered
        out.append(("update", t, [20.7 + 0.01 * math.sin(k / 9), 20.8, 2000.0 + k], 0))
        t += 15.0
    out += [
        ("observe", first + 150.0, 2.0, ERR_READING),  # older than the rows remembered
        ("observe", t - 15.0 - 400 * 15.0 + 3.0, 4.0, 0),
        ("reset", 5.0),
        ("update", 0.0, [21.0, 21.0, 1000.0], 0),
        ("update", 15.0, [nan, nan, nan], HELD),
        ("update", 30.0, [21.1, 21.0, 1000.0], 0),
        ("reset", None),
        ("update", 100.0, [21.0, 21.0, 1000.0], 0),
        ("recalibrate",),  # before the test's first reading: it counts at that reading
        ("update", 115.0, [21.0, 21.2, 1500.0], 0),
        ("observe", 115.0, 1.0, 0),
    ]
    return out


#: The change detector's kinds as the exports code them.
CHANGE_CODES = {None: 0, "step": 1, "ramp": 2}


def found_difference(status, engine):
    """The largest difference between what Python's change detector found (its kind,
    start and last innovation) and what ``engine`` says; the kinds must be equal, and
    where Python says NaN (nothing yet) the engine must say NaN (C) or 0 (Structured
    Text, which has no NaN)."""
    assert engine.change_kind() == CHANGE_CODES[status.change_kind], status
    worst = 0.0
    for python, exported in (
        (status.change_start_s, engine.change_start_s()),
        (status.innovation, engine.innovation()),
    ):
        if math.isnan(python):
            assert math.isnan(exported) or (engine.no_nan and exported == 0.0), status
        else:
            worst = max(worst, abs(exported - python))
    return worst


#: When the change in :func:`change_script` begins: at its fifth reading (75 min).
CHANGE_START_S = 4500.0


def change_script(kind, size, restart_row=None):
    """Actions as :func:`script`'s for :func:`scripted`'s compensator: 4 h of rows a
    minute, and a reading every 15 min, exact (the correction without readings) up to
    :data:`CHANGE_START_S`, then off by a step of ``size`` µm (``kind`` "step") or by a
    ramp of ``size`` µm/h from there (``kind`` "ramp"). With ``restart_row``, the
    rows' clock restarts at 0 there (for a compensator with ``nominal_step_s=60``)."""
    twin = scripted(True, nominal_step_s=60.0)  # what it corrects without readings
    out = []
    for k in range(4 * 60 + 1):
        t = 60.0 * (k if restart_row is None or k < restart_row else k - restart_row)
        x = [20.0 + 0.5 * math.sin(k / 40), 21.0 - 0.3 * math.cos(k / 55), 3000.0 + 10 * (k % 13)]
        exact = twin.update(dict(zip(["time_s", *twin.inputs], [t, *x])))
        out.append(("update", t, x, 0))
        if k and k % 15 == 0:
            late = max(60.0 * k - CHANGE_START_S, 0.0)
            off = (size if late else 0.0) if kind == "step" else size * late / 3600.0
            out.append(("observe", t, exact + off, 0))
    return out


def replay(comp, engine, actions, on_missing, outside=None):
    """Run ``actions`` on the Python compensator and on ``engine`` (C or Structured Text);
    return the largest difference of output, correction, half-width and what the change
    detector found after each, and the most changes the detector counted; each exported
    ``outside`` flag that is not 0 is appended to the list ``outside``, if given."""
    worst, changes = 0.0, 0
    for action in actions:
        kind = action[0]
        if kind in ("observe", "recalibrate") and comp.uncertainty is None:
            continue  # without a calibration the exports take no readings
        if kind == "update":
            _, t, x, code = action
            if code == HELD and on_missing == "raise":
                code = ERR_VALUE
            try:
                value = comp.update(dict(zip(["time_s", *comp.inputs], [t, *x])))
                got = HELD if comp.status.held else 0
            except ValueError:
                got = None
            assert (got is None) == (code < 0) and (got is None or got == code), (action, got)
            c_code, c_out = engine.update(t, x)
            assert c_code == code, (action, c_code)
            if code >= 0:
                worst = max(worst, abs(c_out - value))
        elif kind == "observe":
            _, t, z, code = action
            try:
                comp.observe(t, z)
                got = 0
            except ValueError:
                got = ERR_READING
            assert got == code, action
            assert engine.observe(t, z) == code, action
        elif kind == "reset":
            comp.reset(initial_displacement=action[1])
            engine.reset(action[1])
        else:
            comp.recalibrate()
            engine.recalibrate()
        status = comp.status
        assert engine.held() == status.held, action
        if comp.envelope is not None and status.correction is not None:
            first = status.outside[0][0] if status.outside else None
            assert engine.outside() == (0 if first is None else comp.inputs.index(first) + 1)
            if outside is not None and engine.outside():
                outside.append((engine.outside(), engine.widening()))
            worst = max(worst, abs(engine.widening() - comp._widening))
        worst = max(worst, abs(engine.output() - status.output))
        if status.correction is not None:
            worst = max(worst, abs(engine.correction() - status.correction))
        if status.correction is not None and comp.uncertainty is not None:
            worst = max(worst, abs(engine.half_width() - status.half_width))
            assert engine.trusted() == status.trusted and engine.changes() == status.changes
        if comp.uncertainty is not None:
            worst = max(worst, found_difference(status, engine))
        changes = max(changes, status.changes)
    return worst, changes


# -- the C export, compiled ----------------------------------------------------


def compiler():
    """The system's C compiler ($CC, gcc, cc or clang), or None."""
    for name in (os.environ.get("CC"), "gcc", "cc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


C_FLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wconversion", "-pedantic", "-Werror"]


#: The probe filter's arrays in the C state struct, and their lengths.
FILTER_ARRAYS = {"fx": 3, "fp": 9, "glr_d": 72, "glr_a": 24, "glr_b": 24, "glr_t0": 12}


class CompiledC:
    """The C export of ``comp`` compiled into a shared library, driven through ctypes."""

    no_nan = False  # C says NaN where Python does

    def __init__(self, comp, folder, name="gm", cc=None):
        self.source = export_text(comp, "c", name=name)
        self.trust = comp.uncertainty is not None
        folder = Path(folder)
        (folder / f"{name}.c").write_text(self.source)
        shim = [f'#include "{name}.c"', "#include <stddef.h>"]
        shim.append(f"size_t shim_size(void) {{ return sizeof({name}_state); }}")
        for field, kind in (("correction_um", "double"), ("held", "int"), ("output_um", "double")):
            shim.append(f"{kind} shim_{field}(const {name}_state *s) {{ return s->{field}; }}")
        if self.trust:
            shim.append(f"long shim_changes(const {name}_state *s) {{ return s->changes; }}")
            shim.append(f"long shim_glr_n(const {name}_state *s) {{ return s->glr_n; }}")
            for field in FILTER_ARRAYS:
                shim.append(
                    f"const double *shim_{field}(const {name}_state *s) {{ return s->{field}; }}"
                )
        self.envelope = comp.envelope is not None
        if self.envelope:
            shim.append(f"long shim_outside(const {name}_state *s) {{ return s->outside; }}")
            shim.append(f"double shim_widening(const {name}_state *s) {{ return s->widening_um; }}")
        (folder / "shim.c").write_text("\n".join(shim) + "\n")
        library = folder / f"lib{name}.so"
        subprocess.run(
            [cc or compiler(), *C_FLAGS, "-shared", "-fPIC", "-o", str(library), "shim.c", "-lm"],
            cwd=folder,
            check=True,
            capture_output=True,
        )
        lib = ctypes.CDLL(str(library))
        self.lib, self.name = lib, name
        lib.shim_size.restype = ctypes.c_size_t
        self.state = ctypes.create_string_buffer(lib.shim_size())
        self.n = len(comp.inputs)
        vector = ctypes.POINTER(ctypes.c_double)
        self._update = getattr(lib, f"{name}_update")
        self._update.argtypes = [ctypes.c_void_p, ctypes.c_double, vector, vector]
        self._reset = getattr(lib, f"{name}_reset")
        self._reset.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_double]
        for field in ("correction_um", "output_um"):
            getattr(lib, f"shim_{field}").restype = ctypes.c_double
        if self.envelope:
            lib.shim_widening.restype = ctypes.c_double
            lib.shim_outside.restype = ctypes.c_long
        if self.trust:
            self._observe = getattr(lib, f"{name}_observe")
            self._observe.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double]
            self._recalibrate = getattr(lib, f"{name}_recalibrate")
            self._recalibrate.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_double]
            for what in ("half_width", "change_start_s", "innovation"):
                getattr(lib, f"{name}_{what}").restype = ctypes.c_double
            lib.shim_changes.restype = ctypes.c_long
            lib.shim_glr_n.restype = ctypes.c_long
            for field in FILTER_ARRAYS:
                getattr(lib, f"shim_{field}").restype = vector
        self._out = ctypes.c_double()
        self.init()

    def init(self):
        """A fresh state: nothing taken, the output 0."""
        getattr(self.lib, f"{self.name}_init")(self.state)

    def update(self, t, x):
        xs = (ctypes.c_double * self.n)(*x)
        code = self._update(self.state, t, xs, ctypes.byref(self._out))
        return code, self._out.value

    def observe(self, t, z):
        return self._observe(self.state, t, z)

    def reset(self, initial=None):
        self._reset(self.state, initial is not None, 0.0 if initial is None else initial)

    def recalibrate(self):
        self._recalibrate(self.state, 0, 0.0)

    def output(self):
        return self.lib.shim_output_um(self.state)

    def correction(self):
        return self.lib.shim_correction_um(self.state)

    def held(self):
        return bool(self.lib.shim_held(self.state))

    def half_width(self):
        return getattr(self.lib, f"{self.name}_half_width")(self.state)

    def trusted(self):
        return bool(getattr(self.lib, f"{self.name}_trusted")(self.state))

    def changes(self):
        return self.lib.shim_changes(self.state)

    def change_kind(self):
        return getattr(self.lib, f"{self.name}_change_kind")(self.state)

    def change_start_s(self):
        return getattr(self.lib, f"{self.name}_change_start_s")(self.state)

    def innovation(self):
        return getattr(self.lib, f"{self.name}_innovation")(self.state)

    def filter_state(self):
        """The probe filter's state in the layout of ``Compensator.get_state()["filter"]``."""
        got = {
            field: np.ctypeslib.as_array(getattr(self.lib, f"shim_{field}")(self.state), (n,))
            for field, n in FILTER_ARRAYS.items()
        }
        return {
            "x": got["fx"],
            "P": got["fp"].reshape(3, 3),
            "response": got["glr_d"].reshape(2, 12, 3),
            "sum_rho_nu": got["glr_a"].reshape(2, 12),
            "sum_rho2": got["glr_b"].reshape(2, 12),
            "start_h": got["glr_t0"],
            "open": self.lib.shim_glr_n(self.state),
        }

    def outside(self):
        return self.lib.shim_outside(self.state)

    def widening(self):
        return self.lib.shim_widening(self.state)
