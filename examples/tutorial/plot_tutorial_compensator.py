"""
From a log file to a running compensator
========================================

A machine's logger writes one CSV: a clock, a cycle number, the spindle
speed, the temperatures and a displacement probe. This tutorial takes such a
file to a compensator that runs in the controller, step by step:

1. read the file with its own cycle column;
2. choose the inputs and fit a :class:`greyml.ThermalTransferFunction`, which
   chooses the sensors;
3. read what it learnt (``selection_``, ``gains_``, ``describe()``);
4. predict a cycle it has not seen, with a 90 % interval;
5. run it row by row as the controller would, with a probe reading every
   hour (:class:`greyml.Compensator`);
6. export it as C, IEC 61131-3 Structured Text and JSON;
7. compare it with a plain ridge regression on the same held-out cycle.

The data is the CAIVIAC recording (CAIVIAC/FL_THERMAL, MIT licence): five
heating and cooling cycles of one machine tool on one clock, sixteen
temperatures and five displacement probes every 15 s. Where it is not found,
the tutorial writes a log of the same shape from greyml's simulated vertical
milling centre and runs on that instead; the first line of its output says
which. To run it on the real recording after ``pip install greyml``,
:func:`greyml.datasets.fetch_caiviac` downloads it once into a cache, and
``GREYML_CAIVIAC`` set to that folder (``<data home>/greyml/caiviac``) points
the tutorial at it.

Every number the code prints below, and every figure, was computed when this
page was built; the numbers in the text are settings.
"""

# %%
# Where the log comes from
# ------------------------
# The recording is looked for in the folder ``$GREYML_CAIVIAC`` names, else
# in ``../shared/realdata/caiviac`` beside this checkout. Without it, greyml's
# simulated small vertical milling centre with a spindle probe (the machine
# of :ref:`Abdulshahed et al. (2017) <ref-abdulshahed2017>`,
# :doc:`/simulator`) runs the programme of the CAIVIAC cycles (4 h of spindle
# at 1250, 2500, 3750, 5000 and 3500 rpm, each followed by 4 h still) in a
# room whose air swings by ±1 °C over a day, and the log is written as a
# logger would write it: one clock, and a cycle number that goes up at each
# spindle start.
import contextlib
import io
import os
import tempfile
import textwrap
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from sklearn.linear_model import RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import ThermalTransferFunction, groups_of
from greyml.cli import main as greyml_command
from greyml.controller import Compensator
from greyml.datasets import make_tests
from greyml.io import read_tests_csv
from greyml.metrics import rmse
from greyml.persist import save_model
from greyml.simulation import Programme, diurnal

#: The recording: in the folder $GREYML_CAIVIAC names (docs/conf.py sets it for
#: the gallery), else in ../shared/realdata/caiviac beside this checkout.
CAIVIAC = Path(
    os.environ.get("GREYML_CAIVIAC")
    or Path(__file__).resolve().parents[3] / "shared" / "realdata" / "caiviac"
)


SPEEDS_RPM = (1250, 2500, 3750, 5000, 3500)


def write_simulated_log(path):
    """The simulated VMC's log in the CAIVIAC file's layout; its target."""
    programme = Programme()
    for speed in SPEEDS_RPM:
        programme = programme.run(240, spindle_rpm=speed).dwell(240)
    data = make_tests(
        "vmc-probe",
        {"log": programme},
        ambient=diurnal(20.0, 1.0),
        random_state=0,
        sample_s=15.0,
    )
    frame = data.frame.reset_index()
    log = pd.DataFrame({"time_s": frame["time_s"]})
    on = frame["spindle_rpm"].to_numpy() > 0
    starts = np.r_[False, on[1:] & ~on[:-1]]
    log["cycle"] = 1 + np.cumsum(starts)
    log["spindle_rpm"] = frame["spindle_rpm"]
    for sensor in data.sensors:
        log[sensor] = frame[sensor].round(3)
    log["dz_um"] = frame["dz_um"].round(2)
    log.to_csv(path, index=False)
    return "dz_um"


found = CAIVIAC / "cycles.csv"
scratch = tempfile.TemporaryDirectory()  # the simulated log's, if any
if found.is_file():
    path, target = found, "ch1_um"
    print("Data: the real CAIVIAC recording (CAIVIAC/FL_THERMAL,")
    print(f"      MIT licence), {path.name}, probe channel {target}")
else:
    path = os.path.join(scratch.name, "simulated_log.csv")
    target = write_simulated_log(path)
    print("Data: greyml's simulated VMC with a spindle probe (the CAIVIAC")
    print(f"      recording was not found), probe {target}")

# %%
# Read the log with its own cycle column
# --------------------------------------
# :func:`greyml.io.read_tests_csv` takes the logger's ``cycle`` column as
# the tests' labels (``test_column="cycle"``). The clock runs on from one
# cycle into the next, so the dynamic model carries its thermal state
# across them: each cycle starts as warm as the previous one left it.
frame = read_tests_csv(path, test_column="cycle")
scratch.cleanup()

cycles = np.asarray(groups_of(frame))
frame = frame[
    np.isin(cycles, ["1", "2", "3", "4", "5"])
]  # a longer log: its first five
cycles = np.asarray(groups_of(frame))
clock_h = frame.index.get_level_values("time_s").to_numpy() / 3600.0
sensors = [c for c in frame.columns if c.endswith("_C")]
print(f"{len(frame):,} rows, {len(sensors)} temperatures, every 15 s")
print("cycle  starts at (h)  rows  top speed (rpm)")
for cycle in dict.fromkeys(cycles):
    rows = cycles == cycle
    top = frame["spindle_rpm"][rows].max()
    start = clock_h[rows][0]
    print(f"  {cycle:>3}  {start:13.1f}  {rows.sum():4d}  {top:15,.0f}")


# %%
# The whole log: the speed drives the heat, the temperatures follow it, and
# the probe reads the displacement from the recording's zero (its datum is
# wherever the logger started, whatever the machine's state then).
def plot_log():
    fig, axes = plt.subplots(
        3, 1, figsize=(9, 7), sharex=True, layout="constrained"
    )
    axes[0].plot(clock_h, frame["spindle_rpm"], color="C0")
    axes[0].set_ylabel("spindle speed (rpm)")
    axes[0].set_ylim(0, 1.2 * frame["spindle_rpm"].max())
    axes[1].plot(clock_h, frame[sensors], color="grey", lw=0.6)
    axes[1].set_ylabel("temperatures (°C)")
    axes[2].plot(clock_h, frame[target], color="k", lw=0.8)
    axes[2].set_ylabel(f"{target} from the\nrecording's zero (µm)")
    axes[2].set_xlabel("time on the log's clock (h)")
    for ax in axes:
        for cycle in dict.fromkeys(cycles):
            ax.axvline(clock_h[cycles == cycle][0], color="C3", lw=0.6, ls=":")
    for cycle in dict.fromkeys(cycles):
        axes[0].annotate(
            f"cycle {cycle}",
            (clock_h[cycles == cycle][0], 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(3, -12),
            textcoords="offset points",
            fontsize=9,
        )
    return fig


plot_log()
plt.show()

# %%
# Choose the inputs and hold out a cycle
# --------------------------------------
# The spindle speed is a *driver*: the controller knows it, it is always in
# the model, and it enters as ``n`` and ``n²``. Every temperature is a
# *candidate sensor*. The other probe channels are measurements, not inputs.
# Cycle 5 is held out whole: the model is fitted on the rows of cycles 1 to 4
# and never sees cycle 5's displacement.
X = frame[["spindle_rpm", *sensors]]
y = frame[target]
held = cycles == "5"
print(f"training rows (cycles 1-4): {(~held).sum():,}")
print(f"held-out rows (cycle 5): {held.sum():,}")

# %%
# Fit: the model chooses the sensors
# ----------------------------------
# ``max_sensors=5`` lets forward selection add sensors one at a time, each
# scored on whole cycles held out in turn (leave one cycle out), and keeps
# the shortest list whose held-out RMSE is within one standard error of the
# lowest. The time constants of the lags, the ridge penalty and the interval
# are all chosen inside ``fit`` in the same way (:doc:`/dynamic_transfer`).
model = ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=5)
model.fit(X[~held], y[~held])
print(f"sensors kept: {', '.join(model.selected_sensors_)}")
print(f"lag state: {model.state_!r}")
print(f"displacement reference: {model.reference_!r}")

# %%
# ``selection_`` lists each step of the forward selection: the sensor added
# and the mean held-out RMSE of ``target`` with it (µm, in the model's
# reference: here the recording's zero when ``reference_`` is
# ``'recording'``, each cycle's first row when it is ``'start'``). The first
# row is the speed alone, with no sensor.
selection = model.selection_.fillna({"sensor": "(speed only)"})
selection.round({"held_out_rmse": 2, "alpha": 6})

# %%
# Read the gains
# --------------
# ``gains_`` has one row per input and power and one column per term: the
# static gain (what moves at once) and the gain of each lag (what arrives
# with that time constant). Units: µm per K for a sensor, µm per rpm and per
# rpm² for the spindle. Neighbouring lags of one input often carry large
# gains of opposite signs; the step responses below say more than any single
# gain.
model.gains_.map(lambda v: "" if np.isnan(v) else f"{v:.3g}")

# %%
# ``describe()`` says the same in words, input by input: the response to a
# step of that input with every other input held.
for line in model.describe(file=io.StringIO()).splitlines():
    print(textwrap.fill(line, 76, subsequent_indent="    "))


# %%
def plot_steps():
    hours = np.linspace(0.0, 24.0, 289)
    inputs = [*model.drivers_, *model.selected_sensors_]
    fig, axes = plt.subplots(
        1, len(inputs), figsize=(9, 3), layout="constrained", squeeze=False
    )
    for ax, name in zip(axes[0], inputs):
        step = model.step_sizes_[name]
        response = model.step_response(name, times=hours * 3600.0)
        ax.plot(hours, response.to_numpy(), color="C0")
        ax.axhline(0.0, color="grey", lw=0.5)
        per = (
            f"{step:g} rpm from rest"
            if name in model.drivers_
            else f"{step:g} K"
        )
        ax.set_title(f"{name}: a step of {per}", fontsize=9)
        ax.set_xlabel("time after the step (h)")
    axes[0, 0].set_ylabel(f"{target} change\nsince the step (µm)")
    return fig


plot_steps()
plt.show()

# %%
# Predict cycle 5 with a 90 % interval
# ------------------------------------
# The model predicts the whole log, so that its lags run through cycles 1 to
# 4 into cycle 5 as they would in the machine; cycle 5's rows are then read
# off. :meth:`~greyml.ThermalTransferFunction.predict_interval` gives the
# prediction and the bounds of an interval meant to hold 90 % of the rows of
# a cycle like the training cycles (calibrated in ``fit`` on cycles held out
# one at a time; :doc:`/trust` says what it promises).
intervals = model.predict_interval(X, coverage=0.9)[held]
measured = y.to_numpy()[held]
predicted, lower, upper = intervals.T
inside = (lower <= measured) & (measured <= upper)
hours = clock_h[held] - clock_h[held][0]  # since cycle 5's first row
print(f"cycle 5, {target} from the recording's zero:")
print(f"  RMSE {rmse(measured, predicted):.2f} µm without any reading")
print(f"  the 90 % interval holds {100 * inside.mean():.0f} % of the rows")
print(f"  its half-width: {np.mean(upper - predicted):.2f} µm on average")

# %%
# Stream: the compensator, with a probe reading every hour
# --------------------------------------------------------
# :meth:`~greyml.Compensator.from_model` gives the same model as
# a :class:`~greyml.Compensator`: it takes one row at a time (``update``) and
# keeps the lags' state between rows, as the controller's loop does. Here it
# runs the whole log from its first row. In cycle 5 the machine's probe
# measures the displacement every hour (from the cycle's first row) and
# :meth:`~greyml.dynamic.Compensator.observe` takes the reading: a Kalman
# filter moves the correction towards it, and a change detector fires when
# the readings say the machine no longer behaves as the model says.
# ``status`` holds the correction, the interval's half-width at that row and
# whether to trust it.
EVERY_ROWS = 240  # an hour of 15 s rows
compensator = Compensator.from_model(model, row_columns=["time_s", *X.columns])
rows = np.column_stack([frame.index.get_level_values("time_s"), X.to_numpy()])
first = int(np.flatnonzero(held)[0])
output = np.empty(len(rows))
half = np.empty(len(rows))
readings = []
for k, row in enumerate(rows):
    output[k] = compensator.update(row)
    if k >= first and (k - first) % EVERY_ROWS == 0:
        readings.append(
            (clock_h[k] - clock_h[first], y.iloc[k], compensator.status)
        )
        compensator.observe(row[0], y.iloc[k])
        output[k] = compensator.status.correction
    half[k] = compensator.status.half_width

same = np.abs(output[:first] - model.predict(X)[:first]).max()
print(f"cycles 1-4: update gives what predict gives, to {same:.1e} µm")
print(f"cycle 5, {target} from the recording's zero (µm); at each reading,")
print("what the compensator gave just before it:")
print("   h  reading  correction  half-width  trusted  changes")
for h, reading, status in readings:
    print(
        f"  {h:2.0f}  {reading:7.2f}  {status.correction:10.2f}"
        f"  {status.half_width:10.2f}  {status.trusted!s:>7}"
        f"  {status.changes:7d}"
    )
with_readings, half_with_readings = output[held], half[held]
score = rmse(measured, with_readings)
print(f"RMSE over cycle 5 with the readings: {score:.2f} µm")
covered = np.mean(np.abs(measured - with_readings) <= half_with_readings)
print(f"its 90 % interval holds {100 * covered:.0f} % of the rows,")
print(f"  with a half-width of {half_with_readings.mean():.2f} µm on average")

# %%
# Export it to the controller
# ---------------------------
# A compensator runs in the controller or beside it, not in Python.
# :meth:`~greyml.dynamic.Compensator.export` writes the same computation as
# C99, as an IEC 61131-3 Structured Text function block (TwinCAT 3, CODESYS)
# and as JSON, with the controller's limits: here an output that moves by at
# most 0.5 µm/s, in steps of 0.1 µm, within ±100 µm (:doc:`/export`). On the
# command line, ``greyml export`` does the same from a saved model; both
# write the same file.
limits = {"rate_limit_um_s": 0.5, "quantum_um": 0.1, "clamp_um": 100.0}
for_machine = Compensator.from_model(model).set_params(**limits)
with tempfile.TemporaryDirectory() as folder:
    for language, suffix in (("c", "c"), ("st", "st"), ("json", "json")):
        written = for_machine.export(
            language, os.path.join(folder, f"comp.{suffix}"), name="comp"
        )
        print(f"{written.name:10s} {written.stat().st_size / 1024:5.1f} KB")
    saved = save_model(model, os.path.join(folder, "model.greyml"))
    cli = os.path.join(folder, "cli.st")
    with contextlib.redirect_stdout(io.StringIO()) as said:
        code = greyml_command(
            ["export", str(saved), "--language", "st", "--out", cli,
             "--name", "comp", "--rate-limit", "0.5", "--quantum", "0.1",
             "--clamp", "100"]
        )  # fmt: skip
    with open(os.path.join(folder, "comp.st"), encoding="utf-8") as fh:
        header, code_st = fh.read().split("*)", 1)
    with open(cli, encoding="utf-8") as fh:
        same = fh.read().split("*)", 1)[1] == code_st
print(f"greyml export: exit code {code}; it said:")
for line in said.getvalue().replace(folder + os.sep, "").splitlines():
    print(
        textwrap.fill(
            line.strip(), 76, initial_indent="  ", subsequent_indent="    "
        )
    )
print("the same code as export() below the header, which names")
print(f"the source: {same}")
header = header.splitlines()
start = next(
    k for k, line in enumerate(header) if "Inputs, in this order" in line
)
end = next(
    k for k, line in enumerate(header) if line.lstrip().startswith("Output:")
)
print("The function block's header, its inputs:")
print("\n".join(line.rstrip() for line in header[start:end]))

# %%
# Compare with a plain ridge regression
# -------------------------------------
# The baseline is what one would try first: ridge regression on every
# temperature at the same instant (standardised, its penalty chosen by
# ``RidgeCV``'s leave-one-row-out), fitted on the same rows of cycles 1 to
# 4. Both models are scored on cycle 5 in two references. *From the
# recording's zero* is what the controller would apply; *since cycle 5's
# first row* removes each model's offset at the start of the cycle, as a
# probe reading at that row would, and scores only how well the model
# follows the drift within the cycle.
ridge = make_pipeline(StandardScaler(), RidgeCV(alphas=np.logspace(-3, 3, 13)))
ridge.fit(X[~held][sensors], y[~held])
by_ridge = ridge.predict(X[held][sensors])
candidates = {
    "transfer function": predicted,
    "transfer function, readings": with_readings,
    f"ridge, {len(sensors)} temperatures": by_ridge,
}
print(f"cycle 5, RMSE of {target} (µm)")
print(f"{'':27s}{'from the':>13s}{'since the':>12s}")
print(f"{'':27s}{'recording':>13s}{'cycle start':>12s}")
scores = {}
for name, values in candidates.items():
    scores[name] = (
        rmse(measured, values),
        rmse(measured - measured[0], values - values[0]),
    )
    print(f"{name:27s}{scores[name][0]:13.2f}{scores[name][1]:12.2f}")
print("without readings, the lower RMSE:")
for k, reference in enumerate(
    ("from the recording's zero", "since cycle 5's start")
):
    names = ["transfer function", f"ridge, {len(sensors)} temperatures"]
    print(f"  {reference}: {min(names, key=lambda name: scores[name][k])}")


# %%
# The figure shows cycle 5 in both references: the interval without
# readings, the compensator with its hourly readings, and ridge.
def plot_cycle5():
    fig, axes = plt.subplots(
        2, 1, figsize=(9, 7), sharex=True, layout="constrained"
    )
    at = np.arange(0, hours.size, EVERY_ROWS)
    axes[0].fill_between(
        hours, lower, upper, alpha=0.2, color="C0", label="90 % interval"
    )
    axes[0].fill_between(
        hours,
        with_readings - half_with_readings,
        with_readings + half_with_readings,
        alpha=0.2,
        color="C2",
        label="90 % interval, readings",
    )
    for ax, since_start in zip(axes, (False, True)):
        lines = {
            "measured": (measured, {"color": "k", "lw": 1}),
            "transfer function": (predicted, {"color": "C0"}),
            "with hourly readings": (with_readings, {"color": "C2"}),
            "ridge": (by_ridge, {"color": "C1", "lw": 0.7, "alpha": 0.8}),
        }
        for label, (values, style) in lines.items():
            shown = values - values[0] if since_start else values
            ax.plot(hours, shown, label=label, **style)
        shown = measured - measured[0] if since_start else measured
        ax.plot(
            hours[at], shown[at], "o", color="C3", ms=4, label="probe reading"
        )
    axes[0].set_ylabel(f"{target} from the\nrecording's zero (µm)")
    axes[1].set_ylabel(f"{target} since\ncycle 5's first row (µm)")
    axes[1].set_xlabel("time since cycle 5's first row (h)")
    fig.legend(
        *axes[0].get_legend_handles_labels(),
        loc="outside lower center",
        ncols=4,
        fontsize=8,
    )
    fig.suptitle("Cycle 5, held out: fitted on cycles 1-4", fontsize=10)
    return fig


plot_cycle5()
plt.show()

# %%
# What to take from it
# --------------------
# * The reference can change the comparison. From the recording's zero, a
#   model must also get the offset right at the start of a cycle; from each
#   cycle's start, only the drift within the cycle counts.
#   A probe reading at the cycle's start, or an hourly one, takes care of the
#   offset in the machine.
# * With five cycles, the choice of sensors and the interval's calibration
#   rest on five units of evidence. The interval promises a share of rows
#   over cycles like the training cycles, not for each cycle; the readings and
#   the change detector are there for what the training cycles did not show.
# * The exported files are not safety functions: check the sign, the unit,
#   the axis and the limits on the machine before the compensation moves
#   anything (:doc:`/export`).
