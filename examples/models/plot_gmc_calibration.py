"""
GMC calibration by least squares, particle swarm and cuckoo search
==================================================================

The protocol of seeds 002/004: a small VMC runs its spindle at 9000 rpm with
5000 mm/min feed for 200 min while nine temperatures and the Z displacement of a
spindle probe are logged every 10 s. GMC(1,N) is calibrated on the first part of
the test and predicts the rest from the temperatures alone.

The data is greyml's simulation of that test (``greyml.datasets.load_probe_test``).
The drivers are temperature rises from the test start: GMC has no intercept of its
own (u only shapes a transient), so absolute temperatures would turn the ambient
drift into a spurious offset. b₁ is kept ≥ 0 for the swarm and cuckoo solvers, so
that the response cannot grow without bound. The least-squares solver has no such
constraint: here it settles on b₁ < 0, and GMC warns as it calibrates
(:class:`greyml.GreyStabilityWarning`), which the script prints.

The script prints the seeds' metrics (R, RMSE, E, ±residual, improvement) next to
the numbers seed 004 reports. It also prints an ordinary least-squares regression
as a reference, and saves a plot of measured against predicted with the residual band.
"""

# %%
import os
import warnings

import matplotlib

if not os.environ.get("MPLBACKEND"):
    matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import LinearRegression

from greyml import GMC, GreyStabilityWarning
from greyml.datasets import load_probe_test
from greyml.metrics import correlation, improvement, nash_sutcliffe, residual_band, rmse

CALIBRATION_FRACTION = float(os.environ.get("GREYML_CALIBRATION_FRACTION", 0.5))

data = load_probe_test()
frame = data.frame
X = frame[data.sensors] - frame[data.sensors].iloc[0]  # temperature rises, °C
y = frame["dz_um"] - frame["dz_um"].iloc[0]  # displacement from the start, µm
n = len(y)
k = int(CALIBRATION_FRACTION * n)
print(
    f"Probe test: {n} samples every 10 s, {len(data.sensors)} sensors; "
    f"calibration on the first {k} samples ({100 * k / n:.0f} %), validation on the rest"
)

# %%
# Calibrate the three solvers (and a linear reference) on the first part
models = {
    "GMC-LS": GMC(solver="ls"),
    "PSO-GMC": GMC(solver="pso", bounds=(0.0, 100.0), random_state=0),
    "CS-GMC": GMC(solver="cs", bounds=(0.0, 100.0), random_state=0),
    "linear regression": LinearRegression(),
}
seed_004 = {"PSO-GMC": "RMSE 1.91, ±4, E 0.95", "CS-GMC": "RMSE 1.09, ±2, E 0.99"}

y_val = y.to_numpy()[k:]
rows = []
predictions = {}
for name, model in models.items():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", GreyStabilityWarning)
        model.fit(X.iloc[:k], y.iloc[:k])
    for w in caught:
        print(f"{name} warned: {w.message}")
    pred = model.predict(X)
    predictions[name] = pred
    p = pred[k:]
    if not np.isfinite(p).all() or np.abs(p).max() > 1e6:
        rows.append((name, "diverges (b1 < 0: unstable response)", seed_004.get(name, "")))
        continue
    rows.append(
        (
            name,
            f"R {correlation(y_val, p):5.3f}  RMSE {rmse(y_val, p):6.2f} µm  "
            f"E {nash_sutcliffe(y_val, p):6.3f}  ±{residual_band(y_val, p):5.1f} µm  "
            f"improvement {100 * improvement(y_val, p):5.1f} %",
            seed_004.get(name, ""),
        )
    )

print(f"\n{'model':<18} {'validation (this run)':<82} seed 004")
for name, result, paper in rows:
    print(f"{name:<18} {result:<82} {paper}")

# %%
# Measured against predicted, with the residual band of CS-GMC
t_min = frame.index.get_level_values("time_s").to_numpy() / 60.0
fig, (ax, ax_r) = plt.subplots(2, 1, figsize=(8, 6), sharex=True, height_ratios=[3, 1])
ax.plot(t_min, y, color="black", lw=2, label="measured (simulated)")
for name, pred in predictions.items():
    if np.isfinite(pred).all() and np.abs(pred).max() < 1e6:
        ax.plot(t_min, pred, lw=1, label=name)
ax.axvspan(0, t_min[k], color="0.9", label="calibration")
ax.set_ylabel("Z displacement (µm)")
ax.legend(loc="lower left", fontsize=8)
resid = y.to_numpy() - predictions["CS-GMC"]
ax_r.plot(t_min, resid, color="C2")
band = np.abs(resid[k:]).max()
ax_r.axhspan(-band, band, color="C2", alpha=0.15)
ax_r.set_ylabel("residual (µm)")
ax_r.set_xlabel("time (min)")
fig.tight_layout()
out = os.environ.get("GREYML_EXAMPLE_OUT", ".")
path = os.path.join(out, "gmc_calibration.png")
fig.savefig(path, dpi=100)
print(f"\nplot written to {path}")
