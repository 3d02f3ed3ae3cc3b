"""
Where a spindle-driven transfer function misses a real machine: the gap of probe ch3
====================================================================================

A real recording: CAIVIAC/FL_THERMAL ("Learning Thermal Displacement
Compensation from Structured Sequence Data", MIT licence): five heating and
cooling cycles of one machine tool, each 4 h with the spindle on and 4 h off,
at 1250, 2500, 3750, 5000 and 3500 rpm; sixteen temperature sensors and five
displacement probes sampled every 15 s. The data is not part of greyml:
:doc:`/installation` says how to get it; this example reads it from the
folder ``$GREYML_CAIVIAC`` names, else from ``../shared/realdata/caiviac``
beside this checkout. Without it, this example says so and stops. To keep
the example quick, it keeps **one row a minute** (every fourth row).

**The simulation.** The target is probe ch3, measured from each cycle's first
reading. The "simulation" is a :class:`greyml.ThermalTransferFunction` given
only the spindle speed (no temperature sensor): a static gain and first-order
lags of 5, 15, 45, 135 and 405 min of the speed, the structure that Mareš,
Horejš et al. (2020) identify per heat source and run in a CNC. Its lags run
through the whole recording (``state="carry"``), as a controller's would, and
its gains are fitted to **cycle 1 only** (weight 0 on the other cycles). The
speed enters linearly only (``driver_powers=(1,)``): one cycle at one speed
cannot tell ``n`` from ``n²``.

**The diagnosis.** ``greyml.gap.diagnose_gap`` says where the gap lies (by
cycle, phase and frequency band), locates abrupt events, and tries candidate
effects, each fitted on four cycles and scored on the fifth; an effect is
named only if its 95 % interval over the held-out cycles lies above 0 and it
beats random-walk placebos given the same freedom. The
measured temperatures enter as candidates in two ways. First with no air
column (none is documented): all sixteen sensors (``sensor_lag``,
``nonlinear_expansion``), and T4, which the data's description likens to air
under a cycling HVAC, as a custom effect ``hvac_air`` (T4 through two thermal
lags). Then with T4 as the ``ambient`` column, which adds the built-in
``ambient`` and ``initial_state`` effects. Finally the first diagnosis is
repeated with the simulation calibrated on each other cycle.

**What we found** (the output below gives the numbers):

* *Where*: calibrated on cycle 1, the transfer function follows that cycle to
  0.95 µm RMS and misses the others by 15.95 µm RMS held out. 58 % of the
  squared gap lies in cycle 3 and 28 % in cycle 5, 75 % in the cooling halves,
  and 93 % at periods longer than 4 h; the bands under 1 h, where T4's HVAC
  ripple would show, hold 1 %. When the spindle stops, ch3 has fallen
  58.6 µm at 3750 rpm (cycle 3) but 16.6 µm at 3500 rpm (cycle 5); the
  simulation gives 37.8 and 42.4 µm. No function of the speed alone does that,
  so the gap's sign flips between cycles (bias −24.55 µm in cycle 3, +16.74 µm
  in cycle 5).
* *What is named*: nothing, in either diagnosis. Every candidate's 95 %
  interval over the held-out cycles reaches below 0 (it helps some cycles
  and harms others), so none is even compared with placebos. The best,
  ``sensor_lag`` (the structure ahead of T7 by about an hour), shrinks the
  held-out gap by 9 %; T4 as a custom ``hvac_air`` makes it worse (−40 %).
  With T4 as the ``ambient`` column, ``ambient`` makes it worse too (−30 %),
  and so does ``initial_state`` (−43 %). Without an air column, the first
  report lists ``ambient`` and ``initial_state`` as not tried, with the
  column they need. The recalibration of the simulation's own gain and
  timing (−2.1 % and −9.7 %, within ±10 %) leaves more held out (16.28 µm)
  and is not kept.
* *What remains*: verdict ``"unexplained"``: ``unexplained_rms`` 15.95 µm,
  104 times the noise floor of 0.153 µm (the floor at one row a minute),
  with 13 located events of 1.0 to 1.6 µm. Two, in cycle 1, are reported at
  a spindle speed change (1250 -> 0 rpm): a spike that ends as the spindle
  stops and a jump 2 min after it. The other eleven lie 12 to 221 min after
  the spindle's last switch.
* *Whether we believe it*: the verdict, yes; the events, with care. At the
  faster speeds the simulation overshoots in the first quarter hour after
  the start and dips after the stop (the first figure), the work of its
  fast lags, whose gains alternate in sign (printed above) because cycle 1
  alone, at one speed, cannot pin them down. Where that transient ends the
  gap bends; an event is a change completed within two minutes on top of a
  smooth part that may bend, so those bends are not events (a detector that
  counted its windows in rows took six of them, 13 to 21 min after a
  switch, for steps of 1.6 to 5.9 µm). The events left are changes of about
  1 µm within two minutes, most of them long after any switch: whether the
  probe's or the machine's, this run cannot tell. That no candidate is
  named is the honest answer: calibrated on each other cycle, the first
  diagnosis (with 19 placebos instead of 39, to keep it quick) names
  nothing either, leaving 13.11 to 14.16 µm, 88 to 95 times the floor. T4
  is no clean air sensor either: it rises by 4.7 and 5.4 °C while the
  spindle runs in cycles 3 and 4. What the data show is that ch3
  falls about as far in cycle 3 (3750 rpm, 58.6 µm) as in cycle 4
  (5000 rpm, 60.7 µm) and much less in cycle 5 (3500 rpm, 16.6 µm); T1 rises
  by 3.6 and 2.8 °C in cycles 3 and 4 and falls a little in the others. The
  data's description reads ch3's large negative excursions, which recur about
  a day apart, as environmental. This run cannot confirm that (40 h hold too
  few days), but it is consistent with it: the gap is a slow load that comes
  in cycles 3 and 4 (bias −24.55 and −11.30 µm) and not with the speed,
  which a simulation driven by the speed alone cannot know and which none of
  greyml's candidate effects, built from these undocumented sensors, carries
  from four cycles to the fifth. A logged air temperature and the sensor
  positions would be needed to name it.
"""

# %%
import os
import warnings
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from greyml import ThermalTransferFunction, make_test_index
from greyml.datasets import load_caiviac
from greyml.exceptions import GapWarning
from greyml.gap import diagnose_gap

TARGET = "ch3_um"
DRIVER = "spindle_rpm"
CALIBRATION_CYCLE = "1"
#: one row in ROW_STEP (the recording's 15 s step): one row a minute
ROW_STEP = 4
#: the data's description: "t4 swings ... like air under a cycling HVAC"
AIR_STAND_IN = "t4_C"
#: sensors whose rise is shown next to ch3
SHOWN = ("t1_C", "t4_C", "t5_C")


#: The recording: in the folder $GREYML_CAIVIAC names (docs/conf.py sets it for
#: the gallery), else in ../shared/realdata/caiviac beside this checkout.
CAIVIAC = Path(
    os.environ.get("GREYML_CAIVIAC")
    or Path(__file__).resolve().parents[3] / "shared" / "realdata" / "caiviac"
)


def load():
    """The five cycles, one row a minute (ch3 from each cycle's first reading), or None."""
    path = CAIVIAC / "cycles.csv"
    if not path.is_file():
        return None
    data = load_caiviac(path, reference="cycle", target=TARGET)
    frame = data.frame.groupby(level="test", sort=False, group_keys=False).nth(
        slice(None, None, ROW_STEP)
    )
    # time_s from each cycle's start, as the events and plots read it (the
    # recording's clock runs on; the model carries its lags with state="carry")
    labels = frame.index.get_level_values("test")
    time = pd.Series(frame.index.get_level_values("time_s"), index=frame.index)
    since = time - time.groupby(level="test", sort=False).transform("first")
    frame.index = make_test_index(labels, since.to_numpy())
    return frame, list(data.sensors)


# %%
# The simulation: a transfer function of the spindle speed alone
# ----------------------------------------------------------------
# The model sees one column, the speed. It is fitted on the whole recording
# with weight 1 on the calibration cycle and 0 elsewhere, so its lags run on
# through the recording (``state="carry"``) while only that cycle's
# displacement is used.
def simulation(frame, calibration=CALIBRATION_CYCLE):
    X = frame[[DRIVER]]
    weight = (frame.index.get_level_values("test") == calibration).astype(float)
    model = ThermalTransferFunction(drivers=[DRIVER], driver_powers=(1,), state="carry")
    model.fit(X, frame[TARGET], sample_weight=weight)
    return model, pd.Series(model.predict(X), index=frame.index, name=TARGET)


# %%
# What the simulation gets wrong, cycle by cycle
# ----------------------------------------------
# At the moment the spindle stops: the measured and simulated ch3, the gap's
# RMS over the whole cycle, and how much a few sensors have risen since the
# cycle's start.
def at_spindle_stop(frame, sim):
    rows = []
    for label, cycle in frame.groupby(level="test", sort=False):
        stop = np.flatnonzero(cycle[DRIVER].to_numpy() > 0)[-1]
        simulated = sim.loc[cycle.index]
        row = {
            "rpm": int(cycle[DRIVER].max()),
            "ch3 measured": cycle[TARGET].iloc[stop],
            "simulated": simulated.iloc[stop],
            "gap RMS": float(np.sqrt(np.mean((cycle[TARGET] - simulated) ** 2))),
        }
        for name in SHOWN:
            row[f"{name.removesuffix('_C')} rise °C"] = cycle[name].iloc[stop] - cycle[name].iloc[0]
        rows.append(pd.Series(row, name=label))
    return pd.DataFrame(rows).astype({"rpm": int})


# %%
# Printing a diagnosis
# --------------------
# Of the RMSEs, ``rmse_before`` is the simulation as it was run;
# ``rmse_recalibrated`` after refitting its own gain and timing on the other
# cycles (``recalibration`` says whether it was kept); ``rmse_after``
# (``unexplained_rms``) with the named effects added. All are held out: each
# cycle's value comes from fits to the other four. Located events are listed
# with the time since the spindle last switched on or off, and the speed
# change an event is reported at (within a minute and a row of a switch).
def print_where(report):
    where = report.where[report.where["by"].isin(["test", "phase", "band"])]
    print("where the gap lies (µm; share of the squared gap):")
    columns = ["by", "segment", "rms", "bias", "share"]
    print(where[columns].to_string(index=False, float_format="%.2f"))


def since_switch(frame, test, time_s):
    """Minutes from the spindle's last switch (on or off) to ``time_s`` in ``test``."""
    cycle = frame.xs(test, level="test")
    t = cycle.index.get_level_values("time_s").to_numpy()
    on = cycle[DRIVER].to_numpy() > 0
    switches = t[1:][on[1:] != on[:-1]]
    switches = np.append(t[0], switches)
    return (time_s - switches[switches <= time_s].max()) / 60.0


def print_report(report, frame, title):
    print(f"\n{title}\n{'-' * len(title)}")
    recalibration = report.recalibration or ""
    print(
        f"held-out gap RMSE: simulation {report.rmse_before:.2f} µm, recalibrated "
        f"{report.rmse_recalibrated:.2f} µm ({recalibration}; "
        f"{'kept' if report.recalibration_kept else 'not kept'})"
    )
    causes = report.causes[["effect", "detail", "rmse_after", "shrinkage"]].copy()
    causes["placebo"] = report.causes["placebo_shrinkage"]
    causes["significant"] = report.causes["significant"]
    causes = causes.dropna(subset=["shrinkage"])
    print("candidate effects (placebo: the best random walk with the same freedom):")
    with pd.option_context("display.max_colwidth", 60, "display.width", 200):
        print(causes.to_string(index=False, float_format="%.2f"))
    print(f"named: {', '.join(report.named) if report.named else 'nothing'}")
    if report.not_tried:  # e.g. ambient: this recording has no air column
        print("not tried: " + "; ".join(f"{e} ({why})" for e, why in report.not_tried.items()))
    for effect, why in report.untestable.items():
        print(f"untestable: {effect}, {why}")
    print(
        f"verdict {report.verdict!r}: unexplained_rms {report.unexplained_rms:.2f} µm, "
        f"noise floor {report.noise_floor:.3f} µm, remainder ratio {report.remainder_ratio:.0f}"
    )
    events = report.events.copy()
    if len(events):
        events["min since switch"] = [
            since_switch(frame, e.test, e.time_s) for e in events.itertuples()
        ]
        events["h"] = events["time_s"] / 3600
        events["at a speed change"] = [
            f"{e.driver_before:g} -> {e.driver_after:g} rpm" if e.at_driver_change == DRIVER else ""
            for e in events.itertuples()
        ]
        print(f"{len(events)} located events (time_s from the cycle's start; size in µm):")
        shown = events[["test", "h", "kind", "size", "min since switch", "at a speed change"]]
        print(shown.to_string(index=False, float_format="%.2f"))
    remains = report.remainder_where
    remains = remains[remains["by"] == "test"][["segment", "share"]]
    print(
        "share of the squared remainder by cycle: "
        + ", ".join(f"{s} {v:.0%}" for s, v in zip(remains["segment"], remains["share"]))
    )


def diagnose(frame, sim, sensors, n_placebo=39):
    """The first diagnosis: no air column, all sensors, T4 also as a custom effect."""
    return diagnose_gap(
        frame,
        sim,
        target=TARGET,
        ambient=None,
        drivers=[DRIVER],
        sensors=sensors,
        custom_effects={"hvac_air": [AIR_STAND_IN]},
        n_placebo=n_placebo,
        random_state=0,
    )


# %%
# Does the answer hold with another calibration cycle?
# ----------------------------------------------------
# The same simulation and first diagnosis, calibrated on each other cycle in
# turn; to keep this quick, an effect must beat 19 placebos (a one-sided 5 %
# level) instead of 39.
def other_calibrations(frame, sensors):
    rows = {}
    for cycle in dict.fromkeys(frame.index.get_level_values("test")):
        if cycle == CALIBRATION_CYCLE:
            continue
        with warnings.catch_warnings():
            # a time constant at its search bound (time_s is in seconds here)
            warnings.simplefilter("ignore", GapWarning)
            r = diagnose(frame, simulation(frame, cycle)[1], sensors, n_placebo=19)
        rows[cycle] = {
            "named": ", ".join(r.named) or "nothing",
            "verdict": r.verdict,
            "rmse_before": r.rmse_before,
            "unexplained_rms": r.unexplained_rms,
            "remainder_ratio": r.remainder_ratio,
            "events": len(r.events),
        }
    return pd.DataFrame(rows).T.rename_axis("calibrated on").infer_objects()


# %%
# Figures
# -------
# Measured and simulated ch3 per cycle (spindle on shaded), and the located
# events of the first diagnosis.
def plot_cycles(frame, sim, report):
    cycles = list(dict.fromkeys(frame.index.get_level_values("test")))
    fig, grid = plt.subplots(3, 2, figsize=(12, 9.5), layout="constrained")
    axes = grid.ravel()
    for ax in axes[len(cycles) :]:
        ax.set_axis_off()
    for ax, label in zip(axes, cycles):
        cycle = frame.xs(label, level="test", drop_level=False)
        hours = cycle.index.get_level_values("time_s") / 3600
        on = cycle[DRIVER].to_numpy() > 0
        ax.fill_between(hours, 0, 1, where=on, color="0.92", transform=ax.get_xaxis_transform())
        ax.plot(hours, cycle[TARGET], color="k", label="measured")
        label_sim = f"spindle-only transfer function (cycle {CALIBRATION_CYCLE})"
        ax.plot(hours, sim.loc[cycle.index], label=label_sim)
        for e in report.events[report.events["test"] == label].itertuples():
            ax.axvline(e.time_s / 3600, color="C3", lw=0.8, ls=":")
        twin = ax.twinx()
        twin.plot(hours, cycle["t1_C"] - cycle["t1_C"].iloc[0], color="C2", lw=0.8, ls=":")
        twin.set_ylabel("T1 rise (°C)", color="C2", fontsize=8)
        rpm = int(cycle[DRIVER].max())
        title = f"cycle {label}, {rpm} rpm (shaded: spindle on; red dotted: located events)"
        ax.set_title(title, fontsize=9)
        ax.set_ylabel("ch3 from the cycle's start (µm)", fontsize=8)
    axes[0].legend(fontsize=7, loc="lower left")
    for ax in axes[: len(cycles)]:
        ax.set_xlabel("time from the cycle's start (h)", fontsize=8)
    fig.suptitle("CAIVIAC/FL_THERMAL (MIT licence): probe ch3 and a spindle-only transfer function")
    return fig


def plot_reports(reports):
    fig = plt.figure(figsize=(12, 7 * len(reports)), layout="constrained")
    for sub, (title, report) in zip(fig.subfigures(len(reports), 1), reports.items()):
        panels = sub.subplot_mosaic([["time"] * 3, ["phase", "band", "rank"]])
        report.plot(axes=[panels[k] for k in ("time", "phase", "band", "rank")])
        sub.suptitle(title)
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
    frame, sensors = loaded
    # one BLAS thread: the products are small, and on busy cores more threads only wait
    with threadpool_limits(limits=1):
        model, sim = simulation(frame)
        cal = frame.index.get_level_values("test") == CALIBRATION_CYCLE
        fit_rmse = float(np.sqrt(np.mean((frame.loc[cal, TARGET] - sim[cal]) ** 2)))
        print(
            f"Spindle-only transfer function of {TARGET} fitted to cycle {CALIBRATION_CYCLE} "
            f"({len(frame)} rows, one a minute; RMSE {fit_rmse:.2f} µm there), penalty "
            f"{model.alpha_:.0e}; gains (µm per rpm):"
        )
        print(model.gains_.to_string(float_format="%+.4f"))
        print("\nAt the moment the spindle stops (µm, °C):")
        print(at_spindle_stop(frame, sim).to_string(float_format="%.1f"))

        report = diagnose(frame, sim, sensors)
        title = f"The gap: measured − simulated {TARGET} (cycle {CALIBRATION_CYCLE} was fitted)"
        print(f"\n{title}\n{'-' * len(title)}")
        print_where(report)
        print_report(
            report, frame, f"Diagnosis, all 16 sensors, {AIR_STAND_IN} also as a custom 'hvac_air'"
        )

        report_air = diagnose_gap(
            frame,
            sim,
            target=TARGET,
            ambient=AIR_STAND_IN,
            drivers=[DRIVER],
            sensors=[s for s in sensors if s != AIR_STAND_IN],
            random_state=0,
        )
        print_report(report_air, frame, f"Diagnosis with {AIR_STAND_IN} standing in for the air")

        print("\nThe first diagnosis with the simulation calibrated on another cycle (µm):")
        with pd.option_context("display.width", 200):
            print(other_calibrations(frame, sensors).to_string(float_format="%.2f"))

    fig = plot_cycles(frame, sim, report)
    fig_reports = plot_reports(
        {"16 sensors, custom hvac_air": report, f"{AIR_STAND_IN} as the air": report_air}
    )
    # sphinx_gallery_start_ignore
    # as a script with $GREYML_EXAMPLE_OUT naming a folder, the figures are saved there too
    import os

    out = os.environ.get("GREYML_EXAMPLE_OUT")
    if out:
        for name, figure in (("caiviac_gap.png", fig), ("caiviac_gap_report.png", fig_reports)):
            figure.savefig(os.path.join(out, name), dpi=100)
        print("plots written: caiviac_gap.png, caiviac_gap_report.png")
    # sphinx_gallery_end_ignore
    plt.show()
# sphinx_gallery_multi_image = "single"
