"""The landing page's figure: a transfer function predicting a cycle it has not seen.

On the CAIVIAC recording (a real machine tool) when it is found in
``$GREYML_CAIVIAC`` (which docs/conf.py sets), else on greyml's simulated VMC;
docs/conf.py gives the page the caption that says which. A
ThermalTransferFunction of the spindle speed and at most five temperature
sensors is fitted on every cycle but the last (the last given with weight 0,
so that its lags run on) and predicts the last. Run by matplotlib's plot
directive when the documentation is built (about 5 s).
"""

import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from greyml import ThermalTransferFunction, groups_of
from greyml.datasets import load_caiviac, load_vmc_tests
from greyml.metrics import rmse

CAIVIAC = Path(os.environ.get("GREYML_CAIVIAC", "")) / "cycles.csv"
if os.environ.get("GREYML_CAIVIAC") and CAIVIAC.is_file():
    data = load_caiviac(CAIVIAC)  # ch1 from each cycle's first row
    X, y = data.frame[data.inputs + data.sensors], data.frame["ch1_um"]
    driver, target, source = "spindle_rpm", "probe ch1", "CAIVIAC recording"
else:
    data = load_vmc_tests()  # dy from each test's first row
    X, y = data.frame[["spindle_rpm", *data.sensors]], data.frame["dy_um"]
    driver, target, source = "spindle_rpm", "Y drift of the tool", "simulated VMC"

tests = np.asarray(groups_of(X))
held_out = tests == tests[-1]
model = ThermalTransferFunction(drivers=[driver], max_sensors=5)
model.fit(X, y, sample_weight=(~held_out).astype(float))
predicted = model.predict(X)
error = rmse(y[held_out], predicted[held_out])

# hours on one clock: tests on clocks of their own are laid end to end
seconds = X.index.get_level_values("time_s").to_numpy(dtype=float)
hours, end = seconds.copy(), 0.0
for label in dict.fromkeys(tests):
    rows = tests == label
    if seconds[rows][0] < end:
        hours[rows] = seconds[rows] - seconds[rows][0] + end
    end = hours[rows][-1]
hours /= 3600

fig, (ax, ax_rpm) = plt.subplots(
    2, 1, figsize=(12, 4.2), sharex=True, height_ratios=(3, 1), layout="constrained"
)
ax.axvspan(hours[held_out][0], hours[held_out][-1], color="C1", alpha=0.08, lw=0)
ax.plot(hours, y, color="k", lw=1.4, label="measured")
ax.plot(hours[~held_out], predicted[~held_out], color="C0", lw=1.2, label="fitted (training)")
ax.plot(
    hours[held_out],
    predicted[held_out],
    color="C1",
    lw=1.6,
    ls="--",
    label=f"predicted, not seen in training (RMSE {error:.2f} µm)",
)
ax.set_ylabel(f"{target} (µm)\nfrom each {'cycle' if 'CAIVIAC' in source else 'test'}'s start")
ax.legend(fontsize=8, loc="best")
sensors = ", ".join(model.selected_sensors_)
ax.set_title(
    f"{source}: spindle speed and {len(model.selected_sensors_)} sensors chosen in fit ({sensors})",
    fontsize=10,
)
ax_rpm.plot(hours, X[driver], color="0.4", lw=1)
ax_rpm.set_ylabel("spindle (rpm)")
ax_rpm.set_xlabel("time (h)")
