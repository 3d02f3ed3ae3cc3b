"""
Thermal transfer functions on a real machine tool, leave one cycle out
======================================================================

A real recording: CAIVIAC/FL_THERMAL ("Learning Thermal Displacement
Compensation from Structured Sequence Data", MIT licence): five heating and
cooling cycles of one machine tool, each 4 h with the spindle on and 4 h off,
at 1250, 2500, 3750, 5000 and 3500 rpm; sixteen temperature sensors and five
displacement probes sampled every 15 s. greyml reads it where it lies
(``greyml.datasets.load_caiviac``); it is not part of greyml. Without it, this
example prints a message and stops.

A machine's displacement lags its heat sources and its surface temperatures
by minutes to hours. :class:`greyml.ThermalTransferFunction` models that
directly, as Mareš, Horejš et al. (2020, Precision Engineering 66) do in a
CNC: each input (the spindle speed, which the controller knows, and at most
five temperature sensors) reaches the displacement through a static gain
plus first-order lags of 5, 15, 45 and 135 min (the speed also through a
405-min lag, as ``n`` and ``n²``). The sensors, the penalty and the gains are
chosen inside ``fit`` on the four training cycles only (leave one training
cycle out), so each held-out cycle below is a validation result.

The target is probe ch1 from each cycle's first reading. The lags run on
through the whole recording, as a controller's would: the held-out cycle's
temperatures and speed drive them, its displacement is never seen (sample
weight 0). The same model fitted from the recording's start follows, scored
the same way. ``benchmarks/bench_caiviac.py`` gives the numbers for ch1 and
ch3 in both references.
"""

# %%
import os

import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from threadpoolctl import threadpool_limits

from greyml import RelativeToStart, ThermalTransferFunction, test_ids
from greyml.datasets import load_caiviac
from greyml.metrics import rmse

TARGET = "ch1_um"
DRIVER = "spindle_rpm"
SPEEDS = {"cycle1": 1250, "cycle2": 2500, "cycle3": 3750, "cycle4": 5000, "cycle5": 3500}


def load():
    """(X, y): speed and temperature rises, ch1 from each cycle's first reading; or None."""
    try:
        data = load_caiviac(reference="cycle", target=TARGET)
    except FileNotFoundError:
        return None
    X = data.frame[data.sensors]
    X = RelativeToStart().fit_transform(X)
    X.insert(0, DRIVER, data.frame[DRIVER].to_numpy())
    return X, data.frame[TARGET]


def transfer_function():
    return ThermalTransferFunction(drivers=[DRIVER], max_sensors=5, state="carry")


def ridge_16():
    return make_pipeline(StandardScaler(), RidgeCV(alphas=np.logspace(-3, 3, 13)))


# %%
# Leave one cycle out
# -------------------
# The transfer function sees the whole recording with weight 0 on the
# held-out cycle; ridge-16 (all sixteen temperatures, no dynamics) sees the
# four training cycles.
def leave_one_cycle_out(X, y):
    groups = np.asarray(test_ids(X))
    sensors = [c for c in X.columns if c != DRIVER]
    results = []
    for cycle in dict.fromkeys(groups):
        train, held = groups != cycle, groups == cycle
        model = transfer_function().fit(X, y, sample_weight=train.astype(float))
        y_ttf = model.predict(X)[held]
        y_ridge = ridge_16().fit(X.loc[train, sensors], y[train]).predict(X.loc[held, sensors])
        y_true = y[held].to_numpy()
        results.append(
            {
                "cycle": cycle,
                "model": model,
                "hours": X[held].index.get_level_values("time_s") / 3600,
                "measured": y_true,
                "ttf": y_ttf,
                "ridge": y_ridge,
                "rmse": rmse(y_true, y_ttf),
                "ridge_rmse": rmse(y_true, y_ridge),
            }
        )
    return results


def report(results):
    print(f"CAIVIAC {TARGET}, leave one cycle out, RMSE in µm")
    print(
        f"{'held out':9s} {'rpm':>5s}  {'sensors chosen in fit':28s} {'TTF':>6s} {'ridge-16':>9s}"
    )
    for r in results:
        sensors = " ".join(s.removesuffix("_C") for s in r["model"].selected_sensors_)
        print(
            f"{r['cycle']:9s} {SPEEDS[r['cycle']]:5d}  {sensors:28s} {r['rmse']:6.2f} "
            f"{r['ridge_rmse']:9.2f}"
        )
    ours = np.median([r["rmse"] for r in results])
    base = np.median([r["ridge_rmse"] for r in results])
    print(
        f"{'median':9s} {'':5s}  {'':28s} {ours:6.2f} {base:9.2f}   "
        f"({100 * (1 - ours / base):.0f} % below ridge-16)"
    )


# %%
# Fitted from the recording's start
# ---------------------------------
# The cycles are pieces of one recording, and each starts in the cooling tail
# of the one before. Fitted to each cycle's change, as above, the model learns
# every cycle's zero anew; fitted to ch1 from the recording's start
# (``relative_to_start=False``: one intercept for all cycles) it keeps what
# the cycles share. Its prediction of the held-out cycle, minus its value at
# the cycle's first row, is scored against the same target as above.
def from_the_recording(y_cycle):
    data = load_caiviac(reference="recording", target=TARGET)
    X = data.frame[data.sensors]
    X = X - X.iloc[0]  # rises from the recording's first reading
    X.insert(0, DRIVER, data.frame[DRIVER].to_numpy())
    groups = np.asarray(test_ids(X))
    out = {}
    for cycle in dict.fromkeys(groups):
        held = groups == cycle
        model = ThermalTransferFunction(
            drivers=[DRIVER], max_sensors=5, state="carry", relative_to_start=False
        ).fit(X, data.frame[TARGET], sample_weight=(~held).astype(float))
        pred = model.predict(X)[held]
        out[cycle] = rmse(y_cycle[held].to_numpy(), pred - pred[0])
    print("\nFitted from the recording's start, scored on each cycle's change (µm):")
    print("  " + "  ".join(f"{c} {v:.2f}" for c, v in out.items()))
    print(f"  median {np.median(list(out.values())):.2f}")
    return out


# %%
# Measured against predicted
# --------------------------
# The vertical line is where the spindle stops.
def plot_cycles(results):
    fig, axes = plt.subplots(len(results), 1, figsize=(9, 11), sharex=True, layout="constrained")
    for ax, r in zip(axes, results):
        ax.plot(r["hours"], r["measured"], color="k", label="measured")
        ax.plot(r["hours"], r["ttf"], label=f"transfer function ({r['rmse']:.1f} µm)")
        ax.plot(
            r["hours"], r["ridge"], lw=0.7, label=f"ridge, 16 sensors ({r['ridge_rmse']:.1f} µm)"
        )
        ax.axvline(4, color="grey", lw=0.5)
        ax.set_title(f"{r['cycle']} held out, {SPEEDS[r['cycle']]} rpm", fontsize=9)
        ax.set_ylabel("ch1 (µm)")
        ax.legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("time from the cycle's start (h)")
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
# A controller runs ``model.compensator()``: ``update(row)`` takes one row of
# inputs and returns the correction, carrying the lags from row to row. It
# streams the recording from its first row; the held-out cycle's correction,
# measured from that cycle's first row, equals the batch ``predict``.
def stream(model, X, cycle):
    compensator = model.compensator()
    groups = np.asarray(test_ids(X))
    local = X.index.get_level_values("time_s").to_numpy()
    # one clock for the recording: each cycle starts one step after the last ended
    clock = local.copy()
    for k in range(1, len(local)):
        step = local[k] - local[k - 1] if groups[k] == groups[k - 1] else local[k + 1] - local[k]
        clock[k] = clock[k - 1] + step
    out = np.empty(len(X))
    for k, row in enumerate(X.to_dict("records")):
        out[k] = compensator.update({**row, "time_s": clock[k]})
    held = groups == cycle
    streamed = out[held] - out[held][0]
    batch = model.predict(X)[held]
    print(
        f"compensator streamed {len(X)} rows; {cycle}: largest difference from predict "
        f"{np.abs(streamed - batch).max():.1e} µm"
    )
    return streamed


# %%
# Run
# ---
loaded = load()
if loaded is None:
    print("CAIVIAC data not found (see greyml.datasets.load_caiviac); skipping this example.")
else:
    X, y = loaded
    # one BLAS thread: the products are small, and on busy cores more threads only wait
    with threadpool_limits(limits=1):
        results = leave_one_cycle_out(X, y)
        report(results)
        from_the_recording(y)
        full = transfer_function().fit(X, y)
        print("\nFitted on all five cycles:")
        full.describe()
        stream(results[2]["model"], X, results[2]["cycle"])
    figures = {
        "caiviac_dynamic_cycles.png": plot_cycles(results),
        "caiviac_dynamic_steps.png": plot_steps(full),
    }
    out = os.environ.get("GREYML_EXAMPLE_OUT")
    if out:
        for name, fig in figures.items():
            fig.savefig(os.path.join(out, name), dpi=100)
        print(f"plots written: {', '.join(figures)}")
    plt.show()
