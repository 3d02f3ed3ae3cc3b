"""diagnose_gap: where a simulation misses the measurement, and which effect it lacks."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from greyml._rng import make_generator
from greyml._sequences import segment_label, test_segments
from greyml._validation import (
    _upper_first,
    check_sampling_interval,
    first_non_finite,
    segment_of,
)
from greyml.gap._effects import (
    DESCRIPTIONS,
    EFFECTS,
    Bank,
    build_candidates,
    fmt_tau,
    lag_bank,
    lag_picks,
    recalibration_candidate,
    tau_grid,
)
from greyml.gap._events import event_columns, locate_events
from greyml.gap._fit import evaluate, fit_recalibration, fold_design, placebo_walks
from greyml.gap._report import GapReport, GapWarning
from greyml.gap._where import gap_breakdown, residual_diagnostics
from greyml.io import check_test_frame, read_tests_csv

__all__ = ["diagnose_gap", "GapContext"]


@dataclass
class GapContext:
    """The measured roles as arrays, rows in the measured order."""

    index: pd.MultiIndex
    bounds: list
    labels: list
    dt: list
    durations: list
    t_s: np.ndarray
    measured: np.ndarray
    sim: np.ndarray
    r: np.ndarray
    ambient: np.ndarray | None
    ambient_name: str | None
    drivers: np.ndarray
    driver_names: list
    sensors: np.ndarray
    sensor_names: list
    target_is_fbg: bool


def _as_names(value, role):
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    names = list(value)
    for name in names:
        if not isinstance(name, str):
            raise ValueError(f"{role}= takes column names; got {name!r}.")
    return names


def _read(data, what):
    if isinstance(data, (str, os.PathLike)):
        return read_tests_csv(data)
    if isinstance(data, pd.Series):
        data = data.to_frame()
    return check_test_frame(data, what=what)


def _sim_series(sim, real, target):
    """The simulation's prediction of the target on the measured rows."""
    if callable(sim) and not isinstance(sim, (pd.DataFrame, pd.Series)):
        sim = sim(real.copy())
        if not isinstance(sim, (pd.DataFrame, pd.Series)):
            raise ValueError(
                "A callable sim must return a DataFrame or Series indexed by (test, time_s); "
                f"it returned {type(sim).__name__}."
            )
    frame = _read(sim, "The simulation")
    if target in frame.columns:
        column = frame[[target]]
    elif frame.shape[1] == 1:
        column = frame.iloc[:, :1]
    else:
        raise ValueError(
            f"The simulation has no column {target!r} (its columns: {list(frame.columns)}); "
            "name the simulated target like the measured one."
        )
    return _on_measured_rows(column, real, "The simulation")[:, 0]


def _on_measured_rows(frame, real, what):
    """The rows of ``frame`` at the measured (test, time_s) rows, as an array."""
    if frame.index.has_duplicates:
        dup = frame.index[frame.index.duplicated()][0]
        raise ValueError(f"{what} has the row (test, time_s) = {dup} more than once.")
    keys = real.index.droplevel([n for n in real.index.names if n not in ("test", "time_s")])
    own = frame.index.droplevel([n for n in frame.index.names if n not in ("test", "time_s")])
    frame = pd.DataFrame(frame.to_numpy(dtype=float), index=own, columns=frame.columns)
    missing = ~keys.isin(own)
    if missing.any():
        first = keys[np.flatnonzero(missing)[0]]
        raise ValueError(
            f"{what} does not cover {int(missing.sum())} of the {len(keys)} measured "
            f"rows (its (test, time_s) rows differ from the measured ones); the first is "
            f"test {first[0]!r} at time_s={first[1]:g}. Simulate every measured "
            "(test, time_s) row."
        )
    return frame.reindex(keys).to_numpy()


def _sensitivity_design(sensitivities, real, index, segments):
    """The sensitivities on the measured rows (n, p), checked."""
    frame = _read(sensitivities, "The sensitivities")
    values = _on_measured_rows(frame, real, "The sensitivities")
    for j, name in enumerate(frame.columns):
        _finite(values[:, j], f"Sensitivity {name!r}", index, segments)
    return values, [str(c) for c in frame.columns]


def _finite(values, name, index, segments):
    row, _ = first_non_finite(values)
    if row is not None:
        seg = segment_of(segments, row)
        kind = "NaN" if np.isnan(values[row]) else "infinity"
        raise ValueError(
            f"{name} has {kind} in {segment_label(seg)} at time_s="
            f"{index.get_level_values('time_s')[row]:g}."
        )


def build_context(real, sim, *, target, ambient, drivers, sensors, fbgs):
    """Check the inputs and gather the roles into a :class:`GapContext`."""
    real = _read(real, "The measured data")
    roles = {"target": [target], "ambient": _as_names(ambient, "ambient")}
    roles["drivers"] = _as_names(drivers, "drivers")
    roles["sensors"] = _as_names(sensors, "sensors")
    roles["fbgs"] = _as_names(fbgs, "fbgs")
    if not isinstance(target, str):
        raise ValueError(f"target= takes one column name; got {target!r}.")
    if len(roles["ambient"]) > 1:
        raise ValueError(f"ambient= takes one column name; got {roles['ambient']}.")
    for role, names in roles.items():
        for name in names:
            if name not in real.columns:
                raise ValueError(
                    f"The {role} column {name!r} is not in the measured data; its columns "
                    f"are {list(real.columns)}."
                )
    segments = test_segments(real)
    small = [s for s in segments if s.n < 10]
    if small:
        n = small[0].n
        raise ValueError(
            f"{_upper_first(segment_label(small[0]))} has {n} rows; diagnose_gap "
            f"needs at least 10 per test (too few samples: {n} sample{'' if n == 1 else 's'})."
        )
    if len(segments) < 2:
        raise ValueError(
            "diagnose_gap scores every effect on held-out whole tests, so it needs at least "
            f"2 tests; the measured data has 1 ({segments[0].label!r})."
        )
    index = real.index
    time = index.get_level_values("time_s").to_numpy(dtype=float)
    bounds = [(s.start, s.stop) for s in segments]
    dt, durations = [], []
    t_s = np.empty(len(real))
    for seg in segments:
        tt = time[seg.slice]
        # lags and frequency bands need even sampling: checked before any search
        dt.append(check_sampling_interval(tt, seg))
        t_s[seg.slice] = tt - tt[0]
        durations.append(float(tt[-1] - tt[0]))
    columns = {}
    for role, names in roles.items():
        for name in names:
            values = real[name].to_numpy(dtype=float)
            _finite(values, f"Column {name!r} ({role}=)", index, segments)
            columns[name] = values
    sim_values = _sim_series(sim, real, target)
    _finite(sim_values, f"The simulated target {target!r}", index, segments)
    measured = columns[target]
    amb_name = roles["ambient"][0] if roles["ambient"] else None
    n = len(real)

    def stack(names):
        return np.column_stack([columns[c] for c in names]) if names else np.zeros((n, 0))

    return GapContext(
        index=index,
        bounds=bounds,
        labels=[s.label for s in segments],
        dt=dt,
        durations=durations,
        t_s=t_s,
        measured=measured,
        sim=sim_values,
        r=measured - sim_values,
        ambient=columns[amb_name] if amb_name else None,
        ambient_name=amb_name,
        drivers=stack(roles["drivers"]),
        driver_names=roles["drivers"],
        sensors=stack(roles["sensors"]),
        sensor_names=roles["sensors"],
        target_is_fbg=target in roles["fbgs"],
    )


def noise_floor(r, bounds):
    """Robust white-noise level of the gap: MAD of first differences / (0.6745·√2)."""
    diffs = np.concatenate([np.diff(r[a:b]) for a, b in bounds])
    mad = np.median(np.abs(diffs - np.median(diffs)))
    return float(mad / 0.6745 / np.sqrt(2.0))


def _shrinkage(after, before):
    """Held-out shrinkage 1 - after/before; 0 when there is no gap left to shrink."""
    return 1.0 - after / before if before > 0 else 0.0


def _placebo_make(ctx, cand, rng):
    """Random-walk signatures as free as ``cand``: a :class:`Bank` like its own.

    As many variants, features and time-constant settings: the variants are
    random walks from 0 in every test, lagged like the candidate's signatures
    (or used as they are when it has no time constant).
    """
    n, V, k = len(ctx.r), len(cand.variants), cand.n_features
    if cand.settings[0]:
        taus = cand.taus or tuple(sorted({float(t) for s in cand.settings for t in s}))
        walks = placebo_walks(rng, ctx.bounds, V)
        return Bank(lag_bank(walks, taus, ctx.dt, ctx.bounds), lag_picks(cand.settings, taus))
    walks = placebo_walks(rng, ctx.bounds, V * k).reshape(n, V, k)
    return Bank(walks, [list(range(k))])


def _placebo_improvements(ctx, base, before, cand, rng, n_placebo, recal=None, beat=np.inf):
    """Held-out shrinkage of up to ``n_placebo`` random-walk placebos as free as ``cand``.

    Stops at the first placebo whose shrinkage reaches ``beat`` (the effect's
    own): the effect is then not significant, whatever the others do.
    """
    out = []
    for _ in range(n_placebo):
        make = _placebo_make(ctx, cand, rng)
        ev = evaluate(ctx.r, base, make, cand.settings, ctx.bounds, recal=recal)
        out.append(_shrinkage(ev.rmse, before.rmse))
        if out[-1] >= beat:
            break
    return np.array(out)


def _p_value(placebo, shrink):
    """Sequential placebo p-value (Besag and Clifford, 1991): stop at the first placebo as good.

    ``placebo`` holds the shrinkage of the placebos drawn (NaN: none drawn).
    Stopped after l placebos at the first one at least as good as the effect,
    p = 1/l; all drawn and none as good, p = 1/(l + 1). NaN when none was drawn.
    """
    drawn = placebo[np.isfinite(placebo)]
    if not drawn.size:
        return np.nan
    beaten = int(np.sum(drawn >= shrink))
    return beaten / drawn.size if beaten else 1.0 / (drawn.size + 1)


def _shrinkage_ci(before, after, bounds, level=0.95, n_boot=2000):
    """Percentile interval of the held-out shrinkage over tests resampled with replacement."""
    b = np.array([np.sum(before[s:e] ** 2) for s, e in bounds])
    a = np.array([np.sum(after[s:e] ** 2) for s, e in bounds])
    # a fixed seed: the interval is a property of the data, not of random_state
    pick = np.random.default_rng(0).integers(0, len(bounds), size=(n_boot, len(bounds)))
    den = b[pick].sum(axis=1)
    ok = den > 0
    if not ok.any():
        return (np.nan, np.nan)
    shrink = 1.0 - np.sqrt(a[pick].sum(axis=1)[ok] / den[ok])
    lo, hi = np.quantile(shrink, [(1 - level) / 2, (1 + level) / 2])
    return (float(lo), float(hi))


def _row(
    effect, detail, step=None, ev=None, significant=False, number=0, placebo=np.nan, bounds=None
):
    """One row of ``causes``: ``ev`` scored against ``step``'s starting gap (NaN if unscored)."""
    scored = step is not None and ev is not None
    ci = (np.nan, np.nan)
    if scored and bounds is not None and step.get("held_before") is not None:
        ci = _shrinkage_ci(step["held_before"], ev.held_out, bounds)
    own = scored and placebo is not None and np.isfinite(placebo)
    return {
        "effect": effect,
        "detail": detail,
        "rmse_before": step["rmse_before"] if scored else np.nan,
        "rmse_after": ev.rmse if scored else np.nan,
        "shrinkage": _shrinkage(ev.rmse, step["rmse_before"]) if scored else np.nan,
        "significant": significant,
        "step": number,
        "placebo_shrinkage": placebo,
        "peak_before": step["peak_before"] if scored else np.nan,
        "peak_after": ev.peak if scored else np.nan,
        "p_value": step["p_value"] if own else np.nan,
        "n_placebo": int(step["n_placebo"]) if own else 0,
        "shrinkage_ci": ci,
    }


def _best(placebo):
    """The best placebo's shrinkage, or NaN when none was tried."""
    finite = placebo[np.isfinite(placebo)]
    return float(finite.max()) if finite.size else np.nan


def _with(base, make, ev):
    """Each fold's base with one more effect, as that fold chose it."""
    return [np.hstack([b, d]) for b, d in zip(base, fold_design(make, ev.choices))]


def _pair_step(ctx, base, before, scored, recal, rng, n_placebo, min_shrinkage, top=3):
    """The best pair of effects, and placebo pairs as free as it.

    Two effects withheld at once can each explain too little of the gap to
    beat placebos alone, while together they explain it. The best ``top``
    single effects are each completed by every other effect (fitted given
    the first); the best pair is compared with ``n_placebo`` pairs of random
    walks given the same freedom (the first fitted alone, the second given
    it).
    """
    best = None
    for _, first, ev_first in scored[:top]:
        with_first = _with(base, ev_first.bank, ev_first)
        for _, second, _ in scored:
            if second is first:
                continue
            ev = evaluate(
                ctx.r, with_first, second.get_bank(), second.settings, ctx.bounds, recal=recal
            )
            if best is None or ev.rmse < best[3].rmse:
                best = (first, ev_first, second, ev)
    first, ev_first, second, ev = best
    shrink = _shrinkage(ev.rmse, before.rmse)
    placebo = []
    for _ in range(n_placebo if shrink > min_shrinkage else 0):
        make_a = _placebo_make(ctx, first, rng)
        ev_a = evaluate(ctx.r, base, make_a, first.settings, ctx.bounds, recal=recal)
        make_b = _placebo_make(ctx, second, rng)
        ev_b = evaluate(
            ctx.r, _with(base, ev_a.bank, ev_a), make_b, second.settings, ctx.bounds, recal=recal
        )
        placebo.append(_shrinkage(ev_b.rmse, before.rmse))
        if placebo[-1] >= shrink:  # not significant, whatever the others do
            break
    return (shrink, first, ev_first, second, ev), np.array(placebo or [np.nan]), len(placebo)


def _prune(ctx, named, base, recal, tie_tolerance):
    """Named effects that the others make redundant (backward elimination).

    Greedy forward naming can add, early on, an effect that stands in for
    two later ones (a slow heat source for the air plus a drift). Each named
    effect is left out in turn, the others refitted; while leaving one out
    costs less than ``tie_tolerance`` of the held-out RMSE, the cheapest is
    dropped.
    """
    designs = {id(c): fold_design(ev.bank, ev.choices) for c, ev, _ in named}
    keep = [c for c, _, _ in named]

    def score(effects):
        fold = [np.hstack([b] + [designs[id(c)][f] for c in effects]) for f, b in enumerate(base)]
        return evaluate(ctx.r, fold, None, [()], ctx.bounds, recal=recal).rmse

    dropped = []
    full = score(keep)
    while len(keep) > 1:
        trials = [(score([c for c in keep if c is not e]), e) for e in keep]
        rmse, worst = min(trials, key=lambda t: t[0])
        if rmse > (1.0 + tie_tolerance) * full:
            break
        keep.remove(worst)
        dropped.append(worst)
        full = rmse
    return dropped


def _search(ctx, candidates, base, before, recal, rng, **search):
    """Forward naming, backward pruning, and forward again without what was pruned."""
    named, steps, final = _forward(ctx, candidates, base, before, recal, rng, **search)
    dropped = _prune(ctx, named, base, recal, search["tie_tolerance"]) if len(named) > 1 else []
    if dropped:
        rest = [c for c in candidates if all(c is not d for d in dropped)]
        named, steps, final = _forward(ctx, rest, base, before, recal, rng, **search)
    return named, steps, final, dropped


def _forward(
    ctx,
    candidates,
    base,
    before,
    recal,
    rng,
    *,
    n_placebo,
    min_shrinkage,
    max_effects,
    tie_tolerance,
    counter,
):
    """Greedy forward naming: add the best significant effect until none is left."""
    steps, named = [], []
    remaining = list(candidates)
    while remaining:
        scored = []
        for cand in remaining:
            ev = evaluate(ctx.r, base, cand.get_bank(), cand.settings, ctx.bounds, recal=recal)
            shrink = _shrinkage(ev.rmse, before.rmse)
            scored.append((shrink, cand, ev))
        scored.sort(key=lambda s: -s[0])
        best_shrink, best, best_ev = scored[0]
        placebo = np.array([np.nan])
        if best_shrink > min_shrinkage:
            placebo = _placebo_improvements(
                ctx, base, before, best, rng, n_placebo, recal, beat=best_shrink
            )
            counter[0] += placebo.size
        threshold = max(min_shrinkage, np.nan_to_num(_best(placebo), nan=-np.inf))
        significant = best_shrink > threshold and len(named) < max_effects
        ties = [c.effect for s, c, _ in scored[1:] if best_shrink - s <= tie_tolerance]
        step = {
            "step": len(steps) + 1,
            "rmse_before": before.rmse,
            "peak_before": before.peak,
            "scored": scored,
            "threshold": threshold,
            "placebo_max": _best(placebo),
            "p_value": _p_value(placebo, best_shrink),
            "n_placebo": int(np.isfinite(placebo).sum()),
            "held_before": before.held_out,
            "significant": significant,
            "ties": ties if significant else [],
        }
        if not significant and len(remaining) >= 2 and len(named) + 2 <= max_effects:
            pair, placebo, drawn = _pair_step(
                ctx, base, before, scored, recal, rng, n_placebo, min_shrinkage
            )
            counter[0] += drawn
            shrink, first, ev_first, second, ev_second = pair
            threshold = max(min_shrinkage, np.nan_to_num(_best(placebo), nan=-np.inf))
            if shrink > threshold:
                for cand, ev, start, partner in (
                    (first, ev_first, before, second),
                    (second, ev_second, ev_first, first),
                ):
                    step = {
                        "step": len(steps) + 1,
                        "rmse_before": start.rmse,
                        "peak_before": start.peak,
                        "scored": [],
                        "threshold": threshold,
                        "placebo_max": _best(placebo),
                        "p_value": _p_value(placebo, shrink),
                        "n_placebo": int(np.isfinite(placebo).sum()),
                        "held_before": start.held_out,
                        "significant": True,
                        "ties": [],
                        "pair": partner.effect,
                    }
                    steps.append(step)
                    named.append((cand, ev, step))
                base = _with(_with(base, ev_first.bank, ev_first), ev_second.bank, ev_second)
                before = ev_second
                remaining = [c for c in remaining if c is not first and c is not second]
                continue
        steps.append(step)
        if not significant:
            break
        named.append((best, best_ev, step))
        base = _with(base, best_ev.bank, best_ev)
        before = best_ev
        remaining = [c for c in remaining if c is not best]

    return named, steps, before


def diagnose_gap(
    real,
    sim,
    *,
    target,
    ambient=None,
    drivers=(),
    sensors=(),
    effects=None,
    random_state=None,
    fbgs=(),
    max_effects=3,
    n_placebo=39,
    min_shrinkage=0.05,
    tie_tolerance=0.02,
    recalibrate=True,
    sensitivities=None,
    tolerance=0.1,
    custom_effects=None,
):
    """Locate the gap between a simulation and measured tests and name its cause.

    The gap r = measured − simulated target is broken down by test, phase,
    time since the start and frequency band (``where``). Then every candidate
    effect of the library (``greyml.gap.EFFECTS``) is fitted to the gap on
    calibration tests and scored on the held-out test, leave one test out.
    An effect is *significant* when its held-out shrinkage
    1 − RMSE_after/RMSE_before beats both ``min_shrinkage`` and every one of
    ``n_placebo`` random-walk placebos given the same freedom (as many
    variants and time constants). The best significant effect is added and the
    rest re-diagnosed on what is left, until nothing significant remains.

    Abrupt events (a step or a spike in one test: a probe knocked, a
    re-clamp) are located first (``ruptures``) and reported in ``events``;
    they are held fixed while effects are fitted, so that an event is never
    taken for ``drift`` or another effect. The report ends in a ``verdict``.

    Parameters
    ----------
    real : DataFrame or path
        Measured tests, indexed by ``(test, time_s)`` (at least 2 tests).
    sim : DataFrame, Series, path or callable
        The simulation's prediction of ``target`` on the same rows (a column
        named like the target, or a single column), or a function
        ``sim(real) -> DataFrame/Series`` that simulates the measured tests.
    target : str
        The measured target column (e.g. ``"dz_um"``).
    ambient : str, optional
        The ambient air temperature column.
    drivers : sequence of str
        Operating drivers (e.g. ``"spindle_rpm"``, ``"feed_mm_min"``), zero
        when off.
    sensors : sequence of str
        Temperature sensor columns.
    effects : sequence of str, optional
        Effects to try; all of ``greyml.gap.EFFECTS`` by default.
    random_state : int, Generator or None
        Seeds the placebos.
    fbgs : sequence of str
        FBG columns; ``fbg_temperature`` is tried when the target is one.
    max_effects : int, default=3
        Most effects added.
    n_placebo : int, default=39
        Placebo fits per effect and step (39: an effect must beat all of them,
        a one-sided 2.5 % level).
    min_shrinkage : float, default=0.05
        Smallest held-out shrinkage that can count as an effect.
    tie_tolerance : float, default=0.02
        Effects whose held-out shrinkage is within this of the best are
        reported as indistinguishable from it.
    recalibrate : bool, default=True
        Refit the simulation's own parameters within ``tolerance``, so that
        parameters a few percent off are not taken for an unmodelled effect.
        With ``sensitivities``, those parameters; without, the simulation's
        gain and timing (``r ≈ a·s + b·(s − L_τ[s])``, ``|a|, |b| ≤ tolerance``).
        They are fitted together with every effect (bounded least squares).
        The search for effects is run with and without the recalibration,
        and the one that leaves less of the gap held out is kept
        (``recalibration_kept``); ``rmse_recalibrated`` is the held-out gap
        after the recalibration alone.
    sensitivities : DataFrame or path, optional
        The simulation's sensitivities to its uncertain parameters on the
        same (test, time_s) rows: one column per parameter, the change of the
        simulated target for a relative change of 1 in it (∂s/∂ln θ; a finite
        difference at +1 % divided by 0.01 will do).
    tolerance : float, default=0.1
        How far the simulation's parameters may be off (relative): the
        recalibration keeps every relative change within ±tolerance. What
        needs more is left for an unmodelled effect to explain.
    custom_effects : dict, optional
        Effects the library lacks, tried like the built-in ones and reported
        under their names: ``{"coolant": ["coolant_on"]}`` puts the measured
        columns (one variant each) through the two thermal lags of
        ``heat_source``; ``{"door": f}`` calls ``f(real)`` (a copy of the
        measured frame) for signature columns on the same rows (a DataFrame
        indexed like ``real``, a Series or an array of shape (n,) or (n, k)),
        whose gains are fitted. Each is compared with placebos given the same
        freedom.

    Returns
    -------
    GapReport

    Warns
    -----
    GapWarning
        When a named effect's fitted time constant ends at the bound of its
        search (often a ``time_s`` that is not in seconds).

    Examples
    --------
    Three tests whose probe drifts by 0.5 µm/h, which the simulation lacks:

    >>> import numpy as np, pandas as pd
    >>> from greyml import make_test_index
    >>> t = np.arange(120) * 60.0
    >>> index = make_test_index(tests=np.repeat(["A", "B", "C"], 120), times=np.tile(t, 3))
    >>> sim = pd.DataFrame({"dz_um": np.tile(5 * (1 - np.exp(-t / 3600)), 3)}, index=index)
    >>> noise = 0.01 * np.random.default_rng(0).standard_normal(360)
    >>> real = sim.assign(dz_um=sim["dz_um"] + 0.5 * np.tile(t, 3) / 3600 + noise)
    >>> report = diagnose_gap(real, sim, target="dz_um", random_state=0)
    >>> report.cause, round(report.shrinkage, 2)
    ('drift', 0.98)
    """
    if effects is None:
        effects = EFFECTS
    effects = list(dict.fromkeys(_as_names(effects, "effects")))
    if not effects and not custom_effects:
        raise ValueError("effects= names no effect; leave it out (None) to try them all.")
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise ValueError(f"Unknown effect(s) {unknown}; the effects are {list(EFFECTS)}.")
    if not (isinstance(max_effects, (int, np.integer)) and max_effects >= 1):
        raise ValueError(f"max_effects must be an integer >= 1; got {max_effects!r}.")
    if not (isinstance(tolerance, (int, float)) and 0 <= tolerance < np.inf):
        raise ValueError(f"tolerance must be a finite number >= 0; got {tolerance!r}.")
    if not (
        isinstance(n_placebo, (int, np.integer))
        and not isinstance(n_placebo, bool)
        and n_placebo >= 1
    ):
        raise ValueError(f"n_placebo must be an integer >= 1; got {n_placebo!r}.")
    for name, value in (("min_shrinkage", min_shrinkage), ("tie_tolerance", tie_tolerance)):
        if not (isinstance(value, (int, float)) and 0 <= value < 1):
            raise ValueError(f"{name} must be a number in [0, 1); got {value!r}.")
    if isinstance(max_effects, bool):
        raise ValueError(f"max_effects must be an integer >= 1; got {max_effects!r}.")
    real = _read(real, "The measured data")
    ctx = build_context(
        real, sim, target=target, ambient=ambient, drivers=drivers, sensors=sensors, fbgs=fbgs
    )
    custom = _custom_effects(custom_effects, real, ctx)
    rng = make_generator(random_state)
    candidates, skipped = build_candidates(ctx, effects, custom=custom)
    n = len(ctx.r)
    base = [np.zeros((n, 0)) for _ in ctx.bounds]
    recalibrated = recal = None
    recal_detail, kept = "", False
    if recalibrate:
        if sensitivities is not None:
            S, names = _sensitivity_design(sensitivities, real, ctx.index, test_segments(real))
            recal = fit_recalibration(ctx.r, lambda s: S, [()], ctx.bounds, tolerance)
            mean = np.mean(recal.theta, axis=0)
            recal_detail = "parameters refitted within ±{:.0%}: {}".format(
                tolerance, ", ".join(f"{c} {m:+.1%}" for c, m in zip(names, mean))
            )
        else:
            cand = recalibration_candidate(ctx)
            recal = fit_recalibration(
                ctx.r, lambda s: cand.make(s)[:, 0, :], cand.settings, ctx.bounds, tolerance
            )
            gain, lead = np.mean(recal.theta, axis=0)
            recal_detail = (
                f"gain {gain:+.1%} and timing {lead:+.1%} of the simulation refitted "
                f"within ±{tolerance:.0%}"
            )
        recalibrated = evaluate(ctx.r, base, None, [()], ctx.bounds, recal=recal)
    floor = noise_floor(ctx.r, ctx.bounds)
    # Abrupt events, located on the gap the parameters leave, are held fixed
    # (one column each, in every fold's base) while effects are fitted; those
    # still in the remainder at the end are reported.
    located = locate_events(
        recalibrated.held_out if recalibrated is not None else ctx.r, ctx.bounds, floor
    )
    if located:
        stops = [ctx.bounds[t][1] for t, *_ in located]
        columns = event_columns([(*e, stop) for e, stop in zip(located, stops)], n)
        base = [columns for _ in ctx.bounds]
        if recal is not None:
            recalibrated = evaluate(ctx.r, base, None, [()], ctx.bounds, recal=recal)
    before = evaluate(ctx.r, base, None, [()], ctx.bounds)
    initial = before

    rows = []
    counter = [0]
    search = dict(
        n_placebo=n_placebo,
        min_shrinkage=min_shrinkage,
        max_effects=max_effects,
        tie_tolerance=tie_tolerance,
        counter=counter,
    )
    alt_rng = np.random.default_rng(rng.integers(2**63))
    named, steps, before, dropped = _search(ctx, candidates, base, initial, None, rng, **search)
    if recal is not None:
        # Effects are searched for twice: against the simulation as it is, and
        # with its parameters refitted (jointly with every effect). The
        # recalibration is kept when its search leaves less of the gap held
        # out. Neither order is safe alone: refitted parameters can take up
        # part of an effect, and an effect can hide a parameter error of the
        # opposite sign, which the recalibration alone then seems to worsen.
        alt = _search(ctx, candidates, base, recalibrated, recal, alt_rng, **search)
        if alt[2].rmse < before.rmse:
            named, steps, before, dropped = alt
            kept = True

    unit = _time_unit_hint(ctx)
    for best, ev, step in named:
        detail = best.describe(best.variants[ev.variant], ev.tau)
        bound = _at_bound(best, ev.tau)
        if bound:
            detail += f"; {bound}"
            warnings.warn(
                f"diagnose_gap: the time constant of {best.effect!r} ended at {bound}; the "
                f"true one may lie beyond it. {unit}",
                GapWarning,
                stacklevel=2,
            )
        if step["ties"]:
            detail += f"; indistinguishable from {', '.join(step['ties'])}"
        if step.get("pair"):
            detail += f"; named as a pair with {step['pair']} (together they beat the placebos)"
        rows.append(
            _row(
                best.effect,
                detail,
                step,
                ev,
                True,
                step["step"],
                step["placebo_max"],
                bounds=ctx.bounds,
            )
        )
    last = steps[-1] if steps else None
    if last is not None and not last["significant"]:
        for _, cand, ev in last["scored"]:
            first = cand is last["scored"][0][1]
            detail = cand.describe(cand.variants[ev.variant], ev.tau)
            rows.append(
                _row(
                    cand.effect,
                    detail,
                    last,
                    ev,
                    placebo=last["placebo_max"] if first else np.nan,
                    bounds=ctx.bounds,
                )
            )
    for cand in dropped:
        detail = "named, then dropped: the other named effects explain the gap as well without it"
        rows.append(_row(cand.effect, detail))
    for effect, why in skipped.items():
        rows.append(_row(effect, f"not tried: {why}"))
    causes = pd.DataFrame(rows, columns=_CAUSE_COLUMNS)
    final = before
    r_series = pd.Series(ctx.r, index=ctx.index, name="gap")
    signals = {}
    for name, values in (
        *zip(ctx.driver_names, ctx.drivers.T),
        *([(ctx.ambient_name, ctx.ambient)] if ctx.ambient is not None else []),
        *zip(ctx.sensor_names, ctx.sensors.T),
    ):
        signals[name] = values
    drivers_frame = pd.DataFrame(dict(zip(ctx.driver_names, ctx.drivers.T)), index=ctx.index)
    where = gap_breakdown(r_series, drivers=drivers_frame if ctx.driver_names else None)
    signal_frame = pd.DataFrame(signals, index=ctx.index)
    whiteness, xcorr = residual_diagnostics(r_series, signal_frame)
    corrected = pd.Series(final.held_out, index=ctx.index, name="gap_after")
    remainder_where = gap_breakdown(corrected, drivers=drivers_frame if ctx.driver_names else None)
    remainder_white, remainder_xcorr = residual_diagnostics(corrected, signal_frame)
    times = ctx.index.get_level_values("time_s").to_numpy(dtype=float)
    # the events reported are those still in what the named effects leave:
    # one found in the gap before the search may have been a thermal bend
    located = locate_events(final.held_out, ctx.bounds, floor)
    events = pd.DataFrame(
        {
            "test": [ctx.labels[t] for t, *_ in located],
            "time_s": [times[first] for _, first, *_ in located],
            "size": [float(size) for _, _, size, _ in located],
        },
        columns=["test", "time_s", "size"],
    )
    descriptions = {e: DESCRIPTIONS[e] for e in EFFECTS}
    for name, (kind, columns, _) in custom.items():
        descriptions[name] = (
            f"user-defined: {', '.join(columns)} through a thermal lag"
            if kind == "columns"
            else "user-defined signature"
        )
    return GapReport(
        target=target,
        where=where,
        causes=causes,
        cause=named[0][0].effect if named else None,
        named=[b.effect for b, _, _ in named],
        rmse_before=initial.rmse,
        rmse_recalibrated=recalibrated.rmse if recalibrated is not None else np.nan,
        rmse_after=final.rmse,
        peak_before=initial.peak,
        peak_after=final.peak,
        noise_floor=floor,
        whiteness=whiteness,
        cross_correlation=xcorr,
        gap=r_series,
        corrected=corrected,
        descriptions=descriptions,
        recalibration=recal_detail,
        recalibration_kept=kept,
        events=events,
        n_placebo=counter[0],
        remainder_where=remainder_where,
        remainder_whiteness=remainder_white,
        remainder_cross_correlation=remainder_xcorr,
    )


def _time_unit_hint(ctx):
    """What a time constant at its bound may say about the unit of time_s."""
    lo = tau_grid(ctx.dt, ctx.durations)[0]
    return (
        f"Time constants are searched in seconds of time_s, from {lo:g} s "
        f"({fmt_tau(lo)}) to twice the longest test ({2 * max(ctx.durations):g} s = "
        f"{fmt_tau(2 * max(ctx.durations))}); if time_s holds minutes or hours, that is "
        "the likely cause: convert it to seconds."
    )


def _at_bound(cand, setting, rtol=1e-9):
    """Which search bound a setting's time constant sits on, in words; "" if none."""
    if not setting or not cand.taus:
        return ""
    lo, hi = min(cand.taus), max(cand.taus)
    for tau in setting:
        if abs(tau - lo) <= rtol * lo:
            return f"the shortest time constant searched ({lo:g} s = {fmt_tau(lo)})"
        if abs(tau - hi) <= rtol * hi:
            return f"the longest time constant searched ({hi:g} s = {fmt_tau(hi)})"
    return ""


def _custom_effects(custom_effects, real, ctx):
    """Check ``custom_effects``: name -> (kind, column names, (n, k) array)."""
    if custom_effects is None:
        return {}
    if not isinstance(custom_effects, dict):
        raise TypeError(
            "custom_effects= takes a dict {name: [columns] or callable}; got "
            f"{type(custom_effects).__name__}."
        )
    out = {}
    segments = test_segments(real)
    for name, spec in custom_effects.items():
        if not isinstance(name, str) or not name:
            raise TypeError(f"custom_effects= needs effect names as strings; got {name!r}.")
        if name in EFFECTS:
            raise ValueError(
                f"custom effect {name!r} has the name of a built-in effect; give it another "
                f"name (the built-in effects are {list(EFFECTS)})."
            )
        if callable(spec):
            values = spec(real.copy())
            if isinstance(values, pd.Series):
                values = values.to_frame()
            if isinstance(values, pd.DataFrame):
                if isinstance(values.index, pd.MultiIndex) and "time_s" in values.index.names:
                    values = pd.DataFrame(
                        _on_measured_rows(values, real, f"custom effect {name!r}"),
                        columns=values.columns,
                    )
                names = [f"{name}: {c}" for c in values.columns]
                values = values.to_numpy()
            else:
                values = np.asarray(values)
                names = [name]
            if values.dtype.kind not in "biuf":
                raise TypeError(
                    f"custom effect {name!r}: the callable must return numbers; got dtype "
                    f"{values.dtype}."
                )
            values = values.astype(float)
            if values.ndim == 1:
                values = values[:, None]
            if values.ndim != 2 or values.shape[0] != len(ctx.r) or values.shape[1] == 0:
                raise ValueError(
                    f"custom effect {name!r}: the callable must return signature columns on "
                    f"the {len(ctx.r)} measured rows; got shape {values.shape}."
                )
            if len(names) != values.shape[1]:
                names = [f"{name}[{j}]" for j in range(values.shape[1])]
            for j in range(values.shape[1]):
                _finite(values[:, j], f"Custom effect {name!r}", ctx.index, segments)
            out[name] = ("signatures", names, values)
            continue
        columns = _as_names(spec, f"custom_effects[{name!r}]")
        if not columns:
            raise ValueError(f"custom effect {name!r} names no column.")
        for column in columns:
            if column not in real.columns:
                raise ValueError(
                    f"The column {column!r} of custom effect {name!r} is not in the measured "
                    f"data; its columns are {list(real.columns)}."
                )
        values = np.empty((len(ctx.r), len(columns)))
        for j, column in enumerate(columns):
            series = real[column]
            if not pd.api.types.is_numeric_dtype(series.dtype):
                raise TypeError(
                    f"Column {column!r} of custom effect {name!r} must hold numbers; it has "
                    f"dtype {series.dtype}."
                )
            values[:, j] = series.to_numpy(dtype=float)
            _finite(
                values[:, j], f"Column {column!r} (custom effect {name!r})", ctx.index, segments
            )
        out[name] = ("columns", columns, values)
    return out


_CAUSE_COLUMNS = [
    "effect",
    "detail",
    "rmse_before",
    "rmse_after",
    "shrinkage",
    "significant",
    "step",
    "placebo_shrinkage",
    "peak_before",
    "peak_after",
    "p_value",
    "n_placebo",
    "shrinkage_ci",
]
