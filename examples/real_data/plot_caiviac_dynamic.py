"""
Thermal transfer functions on a real machine tool, leave one cycle out
======================================================================

A real recording: CAIVIAC/FL_THERMAL ("Learning Thermal Displacement
Compensation from Structured Sequence Data", MIT licence): five heating and
cooling cycles of one machine tool, each 4 h with the spindle on and 4 h off,
at 1250, 2500, 3750, 5000 and 3500 rpm; sixteen temperature sensors and five
displacement probes sampled every 15 s, on one clock. greyml reads the file
where it lies, as the logger wrote it (``read_tests_csv(path,
test_column="cycle")``); it is not part of greyml. Without it, this example
prints a message and stops.

A machine's displacement lags its heat sources and its surface temperatures
by minutes to hours. :class:`greyml.ThermalTransferFunction` models that
directly, as Mareš, Horejš et al. (2020, Precision Engineering 66) do in a
CNC: each input (the spindle speed, which the controller knows, and at most
five temperature sensors) reaches the displacement through a static gain
plus first-order lags. The model is used as constructed, with only the
driver and the sensor budget: because the cycles run on one clock, it
carries its lags from one cycle into the next and takes the displacement
from the recording's zero. The sensors, the penalty and the length of the
bank of time constants are chosen inside ``fit`` on the training cycles
only (leave one training cycle out), so each held-out cycle below is a
validation result.

Each held-out cycle is given to ``fit`` with sample weight 0: its
temperatures and speed drive the lags, as a controller's would, its
displacement is never seen. It is scored as its change since its first row,
beside the same model given the cycle alone, without its history.
``benchmarks/bench_dynamic_peers.py`` compares it with ARDL, NARX and ridge
on both probes.
"""

# %%
import os
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from threadpoolctl import threadpool_limits

from greyml import ThermalTransferFunction, groups_of
from greyml.controller import Compensator
from greyml.exceptions import WarmStartWarning
from greyml.io import read_tests_csv
from greyml.metrics import rmse

TARGET = "ch1_um"
DRIVER = "spindle_rpm"
SPEEDS = {"1": 1250, "2": 2500, "3": 3750, "4": 5000, "5": 3500}


#: The recording: in the folder $GREYML_CAIVIAC names (docs/conf.py sets it for
#: the gallery), else in ../shared/realdata/caiviac beside this checkout.
CAIVIAC = Path(
    os.environ.get("GREYML_CAIVIAC")
    or Path(__file__).resolve().parents[3] / "shared" / "realdata" / "caiviac"
)


def load():
    """(X, y) as logged: speed and temperatures, ch1 from the recording's zero; or None."""
    path = CAIVIAC / "cycles.csv"
    if not path.is_file():
        return None
    frame = read_tests_csv(path, test_column="cycle")
    inputs = [DRIVER] + [c for c in frame.columns if c.endswith("_C")]
    return frame[inputs], frame[TARGET]


def transfer_function():
    return ThermalTransferFunction(drivers=[DRIVER], max_sensors=5)


def ridge_16():
    return make_pipeline(StandardScaler(), RidgeCV(alphas=np.logspace(-3, 3, 13)))


def change(values):
    """A cycle's values as their change since its first row."""
    values = np.asarray(values, dtype=float)
    return values - values[0]


# %%
# Leave one cycle out
# -------------------
# The transfer function sees the whole recording with weight 0 on the held-out
# cycle, and again the four training cycles only, predicting the held-out one
# alone; ridge-16 (all sixteen temperatures as rises from each cycle's first
# row, no dynamics) sees the four training cycles.
def leave_one_cycle_out(X, y):
    groups = np.asarray(groups_of(X))
    sensors = [c for c in X.columns if c != DRIVER]
    rises = X[sensors] - X[sensors].groupby(level="test", sort=False).transform("first")
    y_rise = y - y.groupby(level="test", sort=False).transform("first")
    results = []
    for cycle in dict.fromkeys(groups):
        train, held = groups != cycle, groups == cycle
        model = transfer_function().fit(X, y, sample_weight=train.astype(float))
        y_ttf = change(model.predict(X)[held])
        alone = transfer_function().fit(X[train], y[train])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", WarmStartWarning)  # alone on purpose
            y_alone = change(alone.predict(X[held]))
        y_ridge = ridge_16().fit(rises[train], y_rise[train]).predict(rises[held])
        y_true = change(y[held])
        results.append(
            {
                "cycle": cycle,
                "model": model,
                "hours": (X[held].index.get_level_values("time_s") - X[held].index[0][1]) / 3600,
                "measured": y_true,
                "ttf": y_ttf,
                "ridge": y_ridge,
                "rmse": rmse(y_true, y_ttf),
                "alone_rmse": rmse(y_true, y_alone),
                "ridge_rmse": rmse(y_true, y_ridge),
            }
        )
    return results


def report(results):
    print(f"CAIVIAC {TARGET}, leave one cycle out, RMSE in µm of each cycle's change since its")
    print("first row (the model itself predicts from the recording's zero)")
    print(
        f"{'held out':9s} {'rpm':>5s}  {'sensors chosen in fit':24s} {'TTF':>6s} "
        f"{'alone':>6s} {'ridge-16':>9s}"
    )
    for r in results:
        sensors = " ".join(s.removesuffix("_C") for s in r["model"].selected_sensors_)
        print(
            f"cycle {r['cycle']:3s} {SPEEDS[r['cycle']]:5d}  {sensors:24s} {r['rmse']:6.2f} "
            f"{r['alone_rmse']:6.2f} {r['ridge_rmse']:9.2f}"
        )
    ours = np.median([r["rmse"] for r in results])
    alone = np.median([r["alone_rmse"] for r in results])
    base = np.median([r["ridge_rmse"] for r in results])
    print(
        f"{'median':9s} {'':5s}  {'':24s} {ours:6.2f} {alone:6.2f} {base:9.2f}   "
        f"({100 * (1 - ours / base):.0f} % below ridge-16)"
    )


# %%
# Measured against predicted
# --------------------------
# The vertical line is where the spindle stops.
def plot_cycles(results):
    fig, grid = plt.subplots(3, 2, figsize=(12, 9.5), layout="constrained")
    axes = grid.ravel()
    for ax in axes[len(results) :]:
        ax.set_axis_off()
    for ax, r in zip(axes, results):
        ax.plot(r["hours"], r["measured"], color="k", label="measured")
        ax.plot(r["hours"], r["ttf"], label=f"transfer function ({r['rmse']:.1f} µm)")
        ax.plot(
            r["hours"], r["ridge"], lw=0.7, label=f"ridge, 16 sensors ({r['ridge_rmse']:.1f} µm)"
        )
        ax.axvline(4, color="grey", lw=0.5)
        ax.set_title(f"cycle {r['cycle']} held out, {SPEEDS[r['cycle']]} rpm", fontsize=9)
        ax.set_ylabel("ch1 from the cycle's start (µm)", fontsize=8)
        ax.legend(fontsize=7, loc="upper right")
        ax.set_xlabel("time from the cycle's start (h)", fontsize=8)
    fig.suptitle("CAIVIAC/FL_THERMAL (MIT licence): each cycle predicted from the other four")
    return fig


# %%
# Each input's step response
# --------------------------
# Fitted on all five cycles: what 1000 rpm more, or 1 K more at a sensor, does
# to ch1 over the following hours, other inputs held. ``describe`` says the
# same in words.
def plot_steps(model):
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    minutes = np.linspace(0.0, 600.0, 301)
    for name in model.drivers_ + model.selected_sensors_:
        r = model.step_response(name, times=minutes * 60.0)
        step = "1000 rpm" if name == DRIVER else "1 K"
        ax.plot(minutes, r.to_numpy(), label=f"{name} (+{step})")
    ax.axhline(0, color="grey", lw=0.5)
    ax.set_xlabel("time after the step (min)")
    ax.set_ylabel("ch1 change (µm)")
    ax.set_title("Step response of each input, fitted on all five cycles")
    ax.legend(fontsize=8)
    return fig


# %%
# Compensation sample by sample
# -----------------------------
# A controller runs ``Compensator.from_model(model)``: ``update(row)`` takes one row of
# inputs by name and returns the correction, carrying the lags from row to
# row along the recording's clock, from the recording's zero. Streamed from the
# recording's first row it equals the batch ``predict``.
def stream(model, X):
    compensator = Compensator.from_model(model)
    times = X.index.get_level_values("time_s")
    out = np.array(
        [compensator.update({**row, "time_s": t}) for t, row in zip(times, X.to_dict("records"))]
    )
    print(
        f"compensator streamed {len(X)} rows; largest difference from predict "
        f"{np.abs(out - model.predict(X)).max():.1e} µm"
    )
    return out


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
    # one BLAS thread: the products are small, and on busy cores more threads only wait
    with threadpool_limits(limits=1):
        results = leave_one_cycle_out(X, y)
        report(results)
        full = transfer_function().fit(X, y)
        print(f"\nFitted on all five cycles (state {full.state_}, reference {full.reference_}):")
        full.describe()
        stream(full, X)
    figures = {
        "caiviac_dynamic_cycles.png": plot_cycles(results),
        "caiviac_dynamic_steps.png": plot_steps(full),
    }
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
