"""Cases built like real measurements: quantised probes, and one case at three row rates.

The withheld-effect cases (:mod:`gap_harness._cases`) read the probe with
white noise at the simulator's row rate. Real recordings differ in two ways
that the diagnosis must survive:

- **quantised readings** (``quantised_null_case``): a probe that reads in
  steps of 0.25 µm or 1 µm. Nothing is withheld: the measured target is the
  exact simulation plus the probe noise, rounded to the quantum. The
  verdict should be ``"within_noise"``, with no event. With ``quantum=0``
  the same builder gives the Gaussian null (no rounding); ``noise_s`` > 0
  makes the noise slow (a sensor that averages: a first-order autoregression
  with that correlation time, of the same standard deviation);
- **row rate** (``drop_case``, ``smooth_case``): the same tests, the same
  effect and the same noise level sampled every 15 s, 60 s or 5 min (the
  tests and every random choice are drawn before the rate is applied, so
  only the rows differ).

  - ``drop_case``: in one test (drawn) the air drops by 2 °C for 20 min (a
    door opened, at a time drawn in the middle of the test). The simulation
    has the drop in its air, like the measured ambient column, but not the
    probe's bracket, which follows the air within a minute (a first-order
    lag of 30 s): the reading drops by ``size`` times the probe noise at
    once and comes back when the door closes. The diagnosis should locate
    the drop in that test within 10 min, at every rate. ``drop_unlogged``:
    the same drop as a draught that the ambient sensor does not see (neither
    the measured ambient column nor the simulation has it).
  - ``smooth_case``: a heater on the fixture, switched on and off in blocks
    of 20-90 min logged as ``fixture_kW`` (not handed to the diagnosis),
    reaches the probe through one first-order lag of 60-120 min (drawn), its
    part of the target peaking at ``size`` times the probe noise. Nothing
    in it is abrupt: any event located is false.

:func:`run_measured_case` diagnoses one case and returns its outcome;
:func:`validate_measured` runs the families over seeds and rates (joblib,
module-level workers).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, fields, replace

import numpy as np
import pandas as pd

from gap_harness._cases import WithheldCase, _case, _simulated, random_tests
from greyml.datasets import make_tests
from greyml.datasets._simulated import _machine, main_target
from greyml.exceptions import GapWarning
from greyml.simulation import door_openings

__all__ = [
    "FAMILIES",
    "MeasuredCase",
    "QUANTA",
    "RATES_S",
    "door_case",
    "drop_case",
    "quantised_null_case",
    "run_measured_case",
    "smooth_case",
    "summarise_measured",
    "validate_measured",
]

#: Row rates (s) of the row-rate families and of the quantised nulls.
RATES_S = (15.0, 60.0, 300.0)
#: Quanta (µm) of the quantised nulls.
QUANTA = (0.25, 1.0)
#: The families :func:`validate_measured` runs.
FAMILIES = (
    "gaussian_null",
    "quantised_null",
    "slow_noise_null",
    "drop",
    "drop_unlogged",
    "smooth",
    "door",
)
#: The smooth door: the structure's response peaks at this many µm (drawn).
DOOR_UM = (1.0, 2.0)
#: The drop: how much colder, for how long, and how fast the probe follows.
DROP_C, DROP_S, BRACKET_TAU_S = 2.0, 1200.0, 30.0
#: How close (s) a located event must be to the drop's start.
LOCATED_WITHIN_S = 600.0
#: The fixture heater's lag (s), drawn in this range.
SMOOTH_TAU_S = (3600.0, 7200.0)
#: Correlation time (s) of the slow sensor noise of ``slow_noise_null``.
SLOW_NOISE_S = 60.0


@dataclass
class MeasuredCase(WithheldCase):
    """A :class:`~gap_harness.WithheldCase` built like a real measurement.

    Besides the withheld case's data and truth: the ``family``, the row rate
    ``sample_s``, the ``quantum`` of the readings (0: continuous), the
    correlation time ``noise_s`` of the noise (0: white), the ``seed`` and,
    for a drop, ``drop`` = (test, start time_s, size).
    """

    family: str = ""
    sample_s: float = 60.0
    quantum: float = 0.0
    noise_s: float = 0.0
    seed: int = 0
    drop: tuple | None = None


def _check_rate(sample_s):
    if not (np.isfinite(sample_s) and sample_s > 0 and (sample_s / 15.0).is_integer()):
        raise ValueError(f"sample_s must be a positive multiple of 15 s; got {sample_s!r}.")


def _tests(m, seed, sample_s, n_tests, hours):
    """Random tests at ``sample_s``, and the generator after drawing them.

    The generator's state does not depend on ``sample_s``: whatever a case
    draws next is the same at every rate.
    """
    _check_rate(sample_s)
    rng = np.random.default_rng(seed)
    tests = [replace(t, sample_s=float(sample_s)) for t in random_tests(m, rng, n_tests, hours)]
    return tests, rng


def _nominal_noise(m, target):
    """The probe's noise level (the same at every rate)."""
    return float(m.probe_noise_um.get(target, 0.0)) or 0.1


def _slow_noise(white, bounds, sample_s, noise_s):
    """White noise made a first-order autoregression of correlation time ``noise_s``, same σ."""
    a = np.exp(-sample_s / noise_s)
    out = np.empty_like(white)
    for start, stop in bounds:
        x = white[start:stop]
        y = np.empty_like(x)
        y[0] = x[0]
        for i in range(1, x.size):
            y[i] = a * y[i - 1] + np.sqrt(1.0 - a * a) * x[i]
        out[start:stop] = y
    return out


def _bounds(frame):
    labels = frame.index.get_level_values("test")
    edges = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    starts = np.r_[0, edges]
    return list(zip(starts, np.r_[edges, len(frame)]))


def _finish(m, tests, target, quiet, n_sensors, real, sim_true, effect, **extra):
    """The case the diagnosis gets: the exact simulation, the roles, the truth."""
    noise = real[target].to_numpy() - sim_true - effect
    case = _case(
        m,
        m,
        tests,
        target,
        quiet,
        0.0,
        extra["seed"],
        n_sensors,
        real,
        sim_true,
        noise,
        withheld=(),
        effect=effect,
    )
    return MeasuredCase(**{f.name: getattr(case, f.name) for f in fields(WithheldCase)}, **extra)


def quantised_null_case(
    quantum,
    sample_s,
    seed,
    *,
    noise_s=0.0,
    machine="vmc",
    n_tests=6,
    hours=5.5,
    n_sensors=10,
):
    """Nothing withheld; the probe reads the simulation plus noise, in steps of ``quantum``.

    Parameters
    ----------
    quantum : float
        The probe's step (µm); 0 for continuous readings (the Gaussian null).
    sample_s : float
        Row rate (s), a multiple of 15 s.
    seed : int
    noise_s : float, default=0.0
        Correlation time (s) of the probe noise; 0: white.
    machine : str, default="vmc"
    n_tests, hours, n_sensors
        Tests per case, their length and the sensors handed to the diagnosis.

    Returns
    -------
    MeasuredCase

    Examples
    --------
    >>> case = quantised_null_case(1.0, 300.0, 0, n_tests=3, hours=3)
    >>> target = case.roles["target"]
    >>> bool((case.real[target] == case.real[target].round()).all()), case.family
    (True, 'quantised_null')
    """
    if not (np.isfinite(quantum) and quantum >= 0):
        raise ValueError(f"quantum must be a finite number >= 0; got {quantum!r}.")
    if not (np.isfinite(noise_s) and noise_s >= 0):
        raise ValueError(f"noise_s must be a finite number >= 0 (s); got {noise_s!r}.")
    m = _machine(machine)
    target = main_target(m)
    tests, _ = _tests(m, seed, sample_s, n_tests, hours)
    quiet, full, real, noise, _ = _simulated(m, tests, target, seed)
    if noise_s > 0:
        noise = _slow_noise(noise, _bounds(real), sample_s, noise_s)
    sim_true = full[target].to_numpy()
    measured = sim_true + noise
    real = real.copy()
    real[target] = quantum * np.round(measured / quantum) if quantum > 0 else measured
    family = "quantised_null" if quantum > 0 else "gaussian_null"
    if noise_s > 0:
        family = "slow_noise_null"
    return _finish(
        m,
        tests,
        target,
        quiet,
        n_sensors,
        real,
        sim_true,
        np.zeros(len(real)),
        family=family,
        sample_s=float(sample_s),
        quantum=float(quantum),
        noise_s=float(noise_s),
        seed=int(seed),
    )


def _bracket(t, t0, t1, tau):
    """The probe bracket's response (0 to 1) to the air leaving at t0 and coming back at t1."""
    on = 1.0 - np.exp(-np.clip(t - t0, 0.0, None) / tau)
    at_end = 1.0 - np.exp(-(t1 - t0) / tau)
    off = at_end * np.exp(-np.clip(t - t1, 0.0, None) / tau)
    return np.where(t < t0, 0.0, np.where(t < t1, on, off))


def drop_case(
    sample_s,
    seed,
    *,
    size=10.0,
    logged=True,
    machine="vmc",
    n_tests=6,
    hours=5.5,
    n_sensors=10,
):
    """A 20-min air drop in one test, which the probe's bracket feels at once.

    See the module's docstring. With ``logged=False`` the drop is a draught
    that the ambient sensor does not see: the measured ``ambient_C`` and the
    simulation's air lack it, so the gap also holds the structure's own slow
    response to it, under the bracket's step.

    Parameters
    ----------
    sample_s : float
        Row rate (s), a multiple of 15 s.
    seed : int
        Draws the tests, the test with the drop, its time and its sign.
    size : float, default=10
        The bracket's part of the target, in probe noise standard deviations.
    logged : bool, default=True
        Whether the measured ambient column, and so the simulation, has the
        drop.
    machine : str, default="vmc"
    n_tests, hours, n_sensors
        Tests per case, their length and the sensors handed to the diagnosis.

    Returns
    -------
    MeasuredCase
        ``drop`` holds (test, start time_s, height); family ``"drop"`` or
        ``"drop_unlogged"``.

    Examples
    --------
    >>> a = drop_case(60.0, 1, n_tests=3, hours=3)
    >>> b = drop_case(300.0, 1, n_tests=3, hours=3)
    >>> a.drop == b.drop, len(a.real) > len(b.real)
    (True, True)
    """
    m = _machine(machine)
    target = main_target(m)
    tests, rng = _tests(m, seed, sample_s, n_tests, hours)
    k = int(rng.integers(n_tests))
    length = tests[k].programme.duration_s
    t0 = 60.0 * np.floor(rng.uniform(0.15, 0.75) * length / 60.0)
    sign = float(rng.choice([-1.0, 1.0]))
    air = door_openings(tests[k].ambient, [t0], drop_C=DROP_C, duration_s=DROP_S)
    drafty = list(tests)
    drafty[k] = replace(tests[k], ambient=air)
    quiet, full, real, noise, _ = _simulated(m, drafty, target, seed)
    sim_true = full[target].to_numpy()
    labels = real.index.get_level_values("test")
    times = real.index.get_level_values("time_s").to_numpy(dtype=float)
    height = sign * size * _nominal_noise(m, target)
    effect = np.where(
        labels == tests[k].label, height * _bracket(times, t0, t0 + DROP_S, BRACKET_TAU_S), 0.0
    )
    real = real.copy()
    real[target] = sim_true + effect + noise
    if logged:
        tests = drafty
    else:
        real["ambient_C"] = make_tests(m, tests, effects=quiet).frame["ambient_C"].to_numpy()
    return _finish(
        m,
        tests,
        target,
        quiet,
        n_sensors,
        real,
        sim_true,
        effect,
        family="drop" if logged else "drop_unlogged",
        sample_s=float(sample_s),
        seed=int(seed),
        drop=(tests[k].label, float(t0), height),
    )


def door_case(sample_s, seed, *, machine="vmc", n_tests=6, hours=5.5, n_sensors=10):
    """A door open for 20 min in one test, which only the structure feels: a smooth transient.

    See the module's docstring. ``drop`` holds (test, opening time_s, peak
    of the response in µm); family ``"door"``.

    Examples
    --------
    >>> case = door_case(300.0, 0, n_tests=3, hours=3)
    >>> test, at, peak = case.drop
    >>> bool(1.0 <= abs(peak) <= 2.0), bool(abs(case.effect).max() == abs(peak))
    (True, True)
    """
    m = _machine(machine)
    target = main_target(m)
    tests, rng = _tests(m, seed, sample_s, n_tests, hours)
    k = int(rng.integers(n_tests))
    length = tests[k].programme.duration_s
    t0 = 60.0 * np.floor(rng.uniform(0.15, 0.75) * length / 60.0)
    peak = float(rng.uniform(*DOOR_UM))
    air = door_openings(tests[k].ambient, [t0], drop_C=DROP_C, duration_s=DROP_S)
    drafty = list(tests)
    drafty[k] = replace(tests[k], ambient=air)
    quiet, full, real, noise, _ = _simulated(m, drafty, target, seed)
    plain = make_tests(m, tests, effects=quiet).frame
    part = full[target].to_numpy() - plain[target].to_numpy()
    effect = peak / float(np.max(np.abs(part))) * part
    sim_true = plain[target].to_numpy()
    real = real.copy()
    real[target] = sim_true + effect + noise
    real["ambient_C"] = plain["ambient_C"].to_numpy()
    return _finish(
        m,
        tests,
        target,
        quiet,
        n_sensors,
        real,
        sim_true,
        effect,
        family="door",
        sample_s=float(sample_s),
        seed=int(seed),
        drop=(tests[k].label, float(t0), float(effect[np.argmax(np.abs(effect))])),
    )


def _heater(rng, length_s):
    """On/off blocks of 20-90 min (whole minutes) over ``length_s``: (edges, levels)."""
    edges, levels, total = [0.0], [], 0.0
    while total < length_s:
        total += 60.0 * int(rng.integers(20, 90))
        edges.append(min(total, length_s))
        levels.append(float(rng.choice([0.0, 1.0])))
    return np.array(edges), np.array(levels)


def _lagged(edges, levels, tau, t):
    """A piecewise-constant input through a first-order lag from rest, exactly, at times ``t``."""
    y = np.zeros_like(t)
    state = 0.0
    for a, b, level in zip(edges[:-1], edges[1:], levels):
        inside = (t >= a) & (t < b) if b < edges[-1] else (t >= a)
        y[inside] = level + (state - level) * np.exp(-(t[inside] - a) / tau)
        state = level + (state - level) * np.exp(-(b - a) / tau)
    return y


def smooth_case(sample_s, seed, *, size=10.0, machine="vmc", n_tests=6, hours=5.5, n_sensors=10):
    """A fixture heater through a 60-120 min lag: a smooth gap with nothing abrupt in it.

    See the module's docstring.

    Parameters
    ----------
    sample_s : float
        Row rate (s), a multiple of 15 s.
    seed : int
        Draws the tests, the heater's blocks and its lag.
    size : float, default=10
        The heater's part of the target at its peak, in probe noise
        standard deviations.
    machine : str, default="vmc"
    n_tests, hours, n_sensors
        Tests per case, their length and the sensors handed to the diagnosis.

    Returns
    -------
    MeasuredCase
        The measured frame holds the heater's column ``fixture_kW``, which
        the roles do not name.

    Examples
    --------
    >>> case = smooth_case(300.0, 0, n_tests=3, hours=3)
    >>> peak = float(abs(case.effect).max() / 0.1)
    >>> round(peak, 6), "fixture_kW" in case.real, "fixture_kW" in case.roles["drivers"]
    (10.0, True, False)
    """
    m = _machine(machine)
    target = main_target(m)
    tests, rng = _tests(m, seed, sample_s, n_tests, hours)
    tau = float(rng.uniform(*SMOOTH_TAU_S))
    schedules = [_heater(rng, t.programme.duration_s) for t in tests]
    quiet, full, real, noise, _ = _simulated(m, tests, target, seed)
    sim_true = full[target].to_numpy()
    labels = real.index.get_level_values("test")
    times = real.index.get_level_values("time_s").to_numpy(dtype=float)
    part = np.zeros(len(real))
    heater = np.zeros(len(real))
    for test, (edges, levels) in zip(tests, schedules):
        rows = np.flatnonzero(labels == test.label)
        part[rows] = _lagged(edges, levels, tau, times[rows])
        block = np.searchsorted(edges, times[rows], side="right") - 1
        heater[rows] = levels[np.minimum(block, levels.size - 1)]
    peak = float(np.max(np.abs(part)))
    effect = size * _nominal_noise(m, target) / peak * part if peak > 0 else part
    real = real.copy()
    real[target] = sim_true + effect + noise
    real["fixture_kW"] = heater
    return _finish(
        m,
        tests,
        target,
        quiet,
        n_sensors,
        real,
        sim_true,
        effect,
        family="smooth",
        sample_s=float(sample_s),
        seed=int(seed),
    )


def run_measured_case(case, **diagnose_kwargs):
    """Diagnose one :class:`MeasuredCase`; its outcome as a dict (one row of a table).

    Parameters
    ----------
    case : MeasuredCase
    **diagnose_kwargs
        Passed to :func:`~greyml.gap.diagnose_gap` (the case's roles, its
        sensitivities and its seed are passed already).

    Returns
    -------
    dict
        The case's family, rate, quantum and seed; the ``verdict``, the
        effects ``named``, the ``noise_floor`` and the ``true_noise`` (root
        mean square of the measurement error), the ``detected_quantum``;
        ``n_events``; ``located`` (a drop found as an event in its test
        within 10 min of its start; a door, as a departure), ``located_s`` and ``follows`` (the
        logged input the located event follows, "mechanical" when none); ``false_events``
        (events that are not the drop: in a null or smooth case, every
        event); ``n_departures`` and ``departure_times``; ``seconds`` of the diagnosis.
    """
    from greyml.gap import diagnose_gap

    start = time.perf_counter()
    with warnings.catch_warnings(record=True):
        # a time constant at its search bound is not what these cases measure
        warnings.simplefilter("always", GapWarning)
        report = diagnose_gap(
            case.real,
            case.sim,
            **case.roles,
            sensitivities=case.sensitivities,
            random_state=case.seed,
            **diagnose_kwargs,
        )
    seconds = time.perf_counter() - start
    events = report.events
    located = False
    n_true = 0
    at = np.nan
    follows = ""
    departures = report.departures
    if case.family == "door":
        # a smooth transient: located as a departure from its test's pattern
        test, at, _ = case.drop
        found = (departures["test"].astype(str) == test) & (
            (departures["start_s"] - at).abs() <= LOCATED_WITHIN_S
        )
        located = bool(found.any())
        at = float(departures.loc[found, "start_s"].iloc[0]) if located else np.nan
    elif case.drop is not None:
        test, at, _ = case.drop
        hit = (events["test"].astype(str) == test) & (
            (events["time_s"] - at).abs() <= LOCATED_WITHIN_S
        )
        located = bool(hit.any())
        n_true = int(hit.sum())
        at = float(events.loc[hit, "time_s"].iloc[0]) if located else np.nan
        if located:
            first = events.loc[hit].iloc[0]
            follows = first["follows"] if isinstance(first["follows"], str) else "mechanical"
    n_tests = len(pd.unique(case.real.index.get_level_values("test")))
    return {
        "family": case.family,
        "sample_s": case.sample_s,
        "quantum": case.quantum,
        "noise_s": case.noise_s,
        "seed": case.seed,
        "rows": len(case.real),
        "n_tests": n_tests,
        "verdict": report.verdict,
        "named": "+".join(report.named) if report.named else "none",
        "noise_floor": report.noise_floor,
        "detected_quantum": report.quantum,
        "true_noise": float(np.sqrt(np.mean(np.square(case.noise)))),
        "rmse_after": report.rmse_after,
        "n_events": len(events),
        "located": located,
        "located_s": at,
        "follows": follows,
        "false_events": len(events) - min(n_true, 1),
        "n_departures": len(departures),
        "departure_times": ";".join(
            f"{t}@{a:g}" for t, a in zip(departures["test"], departures["start_s"])
        ),
        "event_times": ";".join(f"{t}@{s:g}" for t, s in zip(events["test"], events["time_s"])),
        "seconds": seconds,
    }


def _run(spec, diagnose_kwargs):
    """One case of ``validate_measured`` (a module-level worker for joblib)."""
    family, quantum, sample_s, seed, size = spec
    if family in ("gaussian_null", "quantised_null"):
        case = quantised_null_case(quantum, sample_s, seed)
    elif family == "slow_noise_null":
        case = quantised_null_case(0.0, sample_s, seed, noise_s=SLOW_NOISE_S)
    elif family in ("drop", "drop_unlogged"):
        case = drop_case(sample_s, seed, size=size, logged=family == "drop")
    elif family == "door":
        case = door_case(sample_s, seed)
    else:
        case = smooth_case(sample_s, seed, size=size)
    row = run_measured_case(case, **diagnose_kwargs)
    row["size"] = size
    return row


def validate_measured(
    families=FAMILIES,
    *,
    n_seeds=20,
    rates=RATES_S,
    quanta=QUANTA,
    drop_size=10.0,
    smooth_sizes=(10.0, 30.0),
    random_state=0,
    n_jobs=None,
    verbose=0,
    **diagnose_kwargs,
):
    """Run the measured-like families over seeds and row rates: one row per case.

    Parameters
    ----------
    families : sequence of str, default=FAMILIES
    n_seeds : int, default=20
        Seeds are ``random_state`` to ``random_state + n_seeds - 1`` in every
        family and at every rate, so a seed is the same tests at every rate.
    rates : sequence of float, default=RATES_S
    quanta : sequence of float, default=QUANTA
        The quantised nulls' steps.
    drop_size : float, default=10
    smooth_sizes : sequence of float, default=(10, 30)
    random_state : int, default=0
    n_jobs : int, optional
        Cases in parallel with joblib (module-level workers).
    verbose : int, default=0
    **diagnose_kwargs
        Passed to :func:`~greyml.gap.diagnose_gap`.

    Returns
    -------
    DataFrame
        One row per case (:func:`run_measured_case`) with its ``size``.
    """
    from joblib import Parallel, delayed

    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ValueError(f"Unknown families {unknown}; the families are {list(FAMILIES)}.")
    seeds = range(int(random_state), int(random_state) + int(n_seeds))
    specs = []
    for family in families:
        for rate in rates:
            for seed in seeds:
                if family == "quantised_null":
                    specs += [(family, q, rate, seed, 0.0) for q in quanta]
                elif family == "smooth":
                    specs += [(family, 0.0, rate, seed, s) for s in smooth_sizes]
                elif family in ("drop", "drop_unlogged"):
                    specs.append((family, 0.0, rate, seed, drop_size))
                elif family == "door":
                    specs.append((family, 0.0, rate, seed, 0.0))
                else:
                    specs.append((family, 0.0, rate, seed, 0.0))
    rows = Parallel(n_jobs=n_jobs, verbose=verbose)(
        delayed(_run)(spec, diagnose_kwargs) for spec in specs
    )
    return pd.DataFrame(rows)


def summarise_measured(cases):
    """The acceptance numbers of :func:`validate_measured`'s table, by family, quantum and rate.

    Parameters
    ----------
    cases : DataFrame
        From :func:`validate_measured`.

    Returns
    -------
    DataFrame
        Indexed by family, quantum, size and rate: ``n`` (cases),
        ``within_noise`` and ``no_events`` (shares of the cases),
        ``located`` (share of drops found in their test within 10 min),
        ``false_per_test`` (false events per test), the median ``floor``
        and ``true_noise``.
    """
    keys = ["family", "quantum", "size", "sample_s"]
    grouped = cases.assign(
        within_noise=cases["verdict"] == "within_noise",
        no_events=cases["n_events"] == 0,
        false_per_test=cases["false_events"] / cases["n_tests"],
    ).groupby(keys)
    return grouped.agg(
        n=("seed", "size"),
        within_noise=("within_noise", "mean"),
        no_events=("no_events", "mean"),
        located=("located", "mean"),
        false_per_test=("false_per_test", "mean"),
        floor=("noise_floor", "median"),
        true_noise=("true_noise", "median"),
    )
