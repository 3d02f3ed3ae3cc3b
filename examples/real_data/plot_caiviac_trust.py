"""
How far to trust a compensation, probe readings, and a machine that changes
===========================================================================

The CAIVIAC recording (CAIVIAC/FL_THERMAL, MIT licence): five heating and
cooling cycles of one machine tool on one clock, sixteen temperatures and
five displacement probes every 15 s. greyml reads the file where it lies, as
the logger wrote it (``read_tests_csv(path, test_column="cycle")``); it is
not part of greyml. Without it, this example prints a message and stops.

A :class:`greyml.ThermalTransferFunction` with the spindle speed as driver
and at most five sensors is fitted on cycles 1 to 4, and cycle 5 is
predicted after them (the lags carry along the clock; the displacement is
from the recording's zero). Three views of cycle 5:

1. its 90 % interval without any reading
   (:meth:`~greyml.ThermalTransferFunction.predict_interval`, calibrated in
   ``fit`` on the training cycles held out one at a time);
2. the compensator (:meth:`~greyml.Compensator.from_model`)
   given a probe reading every hour (:meth:`~greyml.Compensator.observe`);
3. a simulated change: 1.5 µm/h added to cycle 5's measured displacement, as
   a machine whose error has drifted since the model was fitted, with the same
   hourly readings: the filter's bias and rate follow it, and the change
   detector (a likelihood-ratio test for a step or a ramp) says when it
   found it.

:doc:`/trust` explains what the interval promises and what it does not.
"""

# %%

import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from threadpoolctl import threadpool_limits

from greyml import ThermalTransferFunction, groups_of
from greyml.controller import Compensator
from greyml.io import read_tests_csv
from greyml.metrics import rmse

TARGET = "ch1_um"
INPUTS = ["spindle_rpm"] + [f"t{k}_C" for k in range(1, 17)]
HELD_OUT = "5"
EVERY_ROWS = 240  # one reading an hour at 15 s a row
DRIFT_UM_PER_H = 1.5


#: The recording: in the folder $GREYML_CAIVIAC names (docs/conf.py sets it for
#: the gallery), else in ../shared/realdata/caiviac beside this checkout.
CAIVIAC = Path(
    os.environ.get("GREYML_CAIVIAC")
    or Path(__file__).resolve().parents[3] / "shared" / "realdata" / "caiviac"
)


def load():
    """The recording as logged (inputs, ch1 from the recording's zero), or None."""
    path = CAIVIAC / "cycles.csv"
    if not path.is_file():
        return None
    frame = read_tests_csv(path, test_column="cycle")
    return frame[INPUTS], frame[TARGET]


# %%
# The interval without readings
# -----------------------------
# Fitted on cycles 1-4 only; predicting the whole recording carries the lags
# through them into cycle 5. The interval's half-width grows with the time
# since each cycle's start (``interval_calibration_``: ``s(t)² = a + b·t``; from the
# recording's zero no row is known, so ``b = 0`` and the width is constant).
def interval_without_readings(model, X, held):
    intervals = model.predict_interval(X, coverage=0.9)[held]
    return intervals[:, 0], intervals[:, 2] - intervals[:, 0]


# %%
# Probe readings through the compensator
# --------------------------------------
# The compensator runs the recording row by row, as a controller would; in
# cycle 5 a reading of the displacement every hour (from the cycle's first
# row) corrects it. ``status`` gives the correction after the readings, the
# interval's half-width and how many times the change detector fired.
def stream(model, X, held, readings):
    """Corrections and half-widths of the held-out rows; when the detector fired (h)."""
    compensator = Compensator.from_model(model, row_columns=["time_s", *INPUTS])
    times = X.index.get_level_values("time_s").to_numpy()
    rows = np.column_stack([times, X.to_numpy()])
    first = int(np.flatnonzero(held)[0])
    correction, half, fired = np.empty(len(rows)), np.empty(len(rows)), []
    for k, row in enumerate(rows):
        compensator.update(row)
        if k - first in readings:
            before = compensator.status.changes
            status = compensator.observe(row[0], readings[k - first])
            if status.changes > before:
                fired.append((row[0] - times[first]) / 3600.0)
        status = compensator.status
        correction[k], half[k] = status.correction, status.half_width
    return correction[held], half[held], fired


def hourly(values):
    """Readings of ``values`` (a held-out cycle's rows) every hour from its first row."""
    return {j: float(values[j]) for j in range(0, len(values), EVERY_ROWS)}


def coverage(measured, prediction, half):
    return float(np.mean(np.abs(measured - prediction) <= half))


# %%
# Plots
# -----
def plot(hours, views):
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), sharex=True, layout="constrained")
    titles = [
        "cycle 5, 90 % interval without readings",
        "a probe reading every hour",
        f"simulated change (+{DRIFT_UM_PER_H} µm/h) and hourly readings",
    ]
    for ax, title, (truth, prediction, half, fired) in zip(axes, titles, views):
        ax.fill_between(
            hours, prediction - half, prediction + half, alpha=0.3, label="90 % interval"
        )
        ax.plot(hours, truth, color="k", lw=1, label="measured")
        ax.plot(hours, prediction, label="predicted")
        if title != titles[0]:
            at = np.arange(0, hours.size, EVERY_ROWS)
            ax.plot(hours[at], truth[at], "o", color="C3", ms=4, label="probe reading")
        for h in fired:
            ax.axvline(h, color="C3", ls="--", lw=0.8)
        ax.set_title(title, fontsize=10)
        ax.set_ylabel("ch1 from the recording's zero (µm)")
        ax.legend(fontsize=7, loc="upper left")
    axes[-1].plot(hours, views[0][1], lw=0.8, color="grey", label="without readings")
    axes[-1].legend(fontsize=7, loc="upper left")
    axes[-1].set_xlabel("time from cycle 5's start (h)")
    fig.suptitle("CAIVIAC/FL_THERMAL (MIT licence): fitted on cycles 1-4, cycle 5 predicted")
    return fig


# %%
# Run
# ---
loaded = load()
if loaded is None:
    print(
        "CAIVIAC data not found (see the installation page, or set GREYML_CAIVIAC);"
        " skipping this example."
    )
else:
    X, y = loaded
    held = np.asarray(groups_of(X)) == HELD_OUT
    measured = y.to_numpy()[held]
    times = X.index.get_level_values("time_s").to_numpy()[held]
    hours = (times - times[0]) / 3600.0
    changed = measured + DRIFT_UM_PER_H * hours
    # one BLAS thread: the products are small, and on busy cores more threads only wait
    with threadpool_limits(limits=1):
        model = ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=5)
        model.fit(X[~held], y[~held])
        batch, batch_half = interval_without_readings(model, X, held)
        probed, probed_half, probed_fired = stream(model, X, held, hourly(measured))
        fixed, fixed_half, fixed_fired = stream(model, X, held, hourly(changed))
    cal = model.interval_calibration_
    a, b, s2, memory_h = cal.anchor_var, cal.growth_var_per_h, cal.memory_var, cal.memory_h
    print(
        f"fitted on cycles 1-4 ({', '.join(model.selected_sensors_)} and the speed; reference "
        f"{model.reference_!r}); interval scale a = {a:.3g} µm², b = {b:.3g} µm²/h; "
        f"after a reading: slow part {s2:.3g} µm² with a memory of {memory_h:.3g} h"
    )
    print("cycle 5, ch1 from the recording's zero (errors are the same in any reference):")
    print(
        f"  without readings:     RMSE {rmse(measured, batch):5.2f} µm, the 90 % interval "
        f"holds {100 * coverage(measured, batch, batch_half):5.1f} % of rows "
        f"(mean half-width {batch_half.mean():.2f} µm)"
    )
    print(
        f"  a reading every hour: RMSE {rmse(measured, probed):5.2f} µm, the 90 % interval "
        f"holds {100 * coverage(measured, probed, probed_half):5.1f} % of rows "
        f"(mean half-width {probed_half.mean():.2f} µm); change detector fired at "
        f"{', '.join(f'{h:g} h' for h in probed_fired) or 'no reading'}"
    )
    print(f"simulated change: +{DRIFT_UM_PER_H} µm/h from cycle 5's first row")
    print(f"  without readings:     RMSE {rmse(changed, batch):5.2f} µm")
    print(
        f"  a reading every hour: RMSE {rmse(changed, fixed):5.2f} µm; change detector fired "
        f"at {', '.join(f'{h:g} h' for h in fixed_fired) or 'no reading'} from the cycle's start"
    )
    if fixed_fired:
        after = hours > fixed_fired[0]
        print(
            f"  after it fired:       RMSE {rmse(changed[after], fixed[after]):5.2f} µm "
            f"(without readings {rmse(changed[after], batch[after]):.2f} µm)"
        )
    views = [
        (measured, batch, batch_half, []),
        (measured, probed, probed_half, probed_fired),
        (changed, fixed, fixed_half, fixed_fired),
    ]
    figures = {"caiviac_trust.png": plot(hours, views)}
    # sphinx_gallery_start_ignore
    # as a script with $GREYML_EXAMPLE_OUT naming a folder, the figures are saved there too
    import os

    out = os.environ.get("GREYML_EXAMPLE_OUT")
    if out:
        for name, fig in figures.items():
            fig.savefig(os.path.join(out, name), dpi=100)
        print(f"plots written: {', '.join(figures)}")
    # sphinx_gallery_end_ignore
    plt.show()
# sphinx_gallery_multi_image = "single"
