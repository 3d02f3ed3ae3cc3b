"""diagnose_gap: where a simulation misses the measurement, and which effect it lacks.

A pipeline of three stages: :mod:`greyml.gap._prepare` reads and checks the
inputs, :mod:`greyml.gap._search` finds where the search starts and names the
effects, and the report stage here turns what was found into a
:class:`~greyml.gap.GapReport`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from greyml._caller import warn_user
from greyml._param_validation import Integral, Interval, Real, validate_params
from greyml._rng import RANDOM_STATE_CONSTRAINT, make_generator
from greyml._time import format_duration
from greyml.gap._consistency import inconsistent_sensors
from greyml.gap._departures import DEPARTURE_COLUMNS, departure_table, locate_departures
from greyml.gap._effects import LIBRARY, build_candidates, tau_grid
from greyml.gap._events import EVENT_COLUMNS, EventSettings, event_table, events_in
from greyml.gap._naming import EffectSearch, showing_tests, shrinkage
from greyml.gap._prepare import GapContext, check_parameters, prepare
from greyml.gap._report import GapReport, GapWarning
from greyml.gap._search import starting_point
from greyml.gap._where import gap_breakdown, residual_diagnostics

__all__ = ["diagnose_gap", "GapContext"]


@validate_params(
    {
        "real": "no_validation",  # a DataFrame or a path, checked when read
        "sim": "no_validation",  # a DataFrame, Series, path or callable
        "target": "no_validation",  # column names: checked with the roles, which
        "ambient": "no_validation",  # say "one column name" (ambient may be a 1-list)
        "drivers": "no_validation",
        "sensors": "no_validation",
        "effects": "no_validation",  # names, checked against EFFECTS
        "random_state": RANDOM_STATE_CONSTRAINT,
        "fbgs": "no_validation",
        "max_effects": [Interval(Integral, 1, None, closed="left")],
        "n_placebo": [Interval(Integral, 1, None, closed="left")],
        "min_shrinkage": [Interval(Real, 0, 1, closed="left")],
        "tie_tolerance": [Interval(Real, 0, 1, closed="left")],
        "recalibrate": ["boolean"],
        "sensitivities": "no_validation",  # a DataFrame or a path
        "tolerance": [Interval(Real, 0, None, closed="left")],
        "custom_effects": [dict, None],
        "quantum": [Interval(Real, 0, None, closed="left"), None],
        "step_time_s": [Interval(Real, 0, None, closed="neither")],
        "driver_window_s": [Interval(Real, 0, None, closed="left")],
    },
    prefer_skip_nested_validation=True,
)
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
    quantum=None,
    step_time_s=120.0,
    driver_window_s=60.0,
):
    """Locate the gap between a simulation and measured tests and name its cause.

    The gap r = measured − simulated target is broken down by test, phase,
    time since the start and frequency band (``where``). Then every candidate
    effect of the library (``greyml.gap.EFFECTS``) is fitted to the gap on
    calibration tests and scored on the held-out test, leave one test out.
    An effect is *significant* (named) when its held-out shrinkage
    1 − RMSE_after/RMSE_before beats both ``min_shrinkage`` and every one of
    ``n_placebo`` random-walk placebos given the same freedom (as many
    variants and time constants), and its 95 % interval over tests (whole
    tests resampled) lies above 0. The best significant effect is added and
    the rest re-diagnosed on what is left, until nothing significant remains.
    Before the search, sensors whose relation to the others changes between
    tests (swapped, moved, mislabelled) are reported and left out of the
    effects; effects that only one test shows are reported as untestable.

    Abrupt events (a step or a spike in one test: a probe knocked, a
    re-clamp, a change completed within ``step_time_s``) are located first,
    in time, so that any row rate gives the same ones, and reported in
    ``events``; they are held fixed while effects are fitted, so that an
    event is never taken for ``drift`` or another effect. An event at a
    switch of a driver (within ``driver_window_s``) is reported as such. The
    noise floor holds the readings' own step (``quantum``). The report ends
    in a ``verdict``.

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

    quantum : float, optional
        The step in which the target is read (a probe that reads in whole
        micrometres: 1.0). None detects it in the readings (when nearly all
        their nonzero changes are whole multiples of one step); 0 states that
        they are continuous. The noise floor adds quantum²/12, and a change
        of one quantum is never an event (see :mod:`greyml.gap._noise`).
    step_time_s : float, default=120
        A change of the gap completed within this many seconds is a step (an
        event); slower changes are thermal. Also the time resolution of the
        noise floor.
    driver_window_s : float, default=60
        An event within this many seconds (plus one row) of a switch of a
        ``drivers`` column is reported at that switch (e.g. "at a spindle
        speed change"), not as a knock.

    Returns
    -------
    GapReport

    Warns
    -----
    GapWarning
        When a named effect's fitted time constant ends at the bound of its
        search (often a ``time_s`` that is not in seconds), and when sensors
        relate to the others differently in one test. One line, attributed to
        the line that called ``diagnose_gap``.

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
    effects, search = check_parameters(
        effects, custom_effects, max_effects, n_placebo, min_shrinkage, tie_tolerance
    )
    roles = dict(target=target, ambient=ambient, drivers=drivers, sensors=sensors, fbgs=fbgs)
    real, ctx, custom = prepare(real, sim, custom_effects, **roles)
    asked = [e.name for e in effects]
    flags = inconsistent_sensors(ctx.sensors, ctx.bounds)
    effect_ctx = _without_sensors(ctx, flags)
    candidates, skipped = build_candidates(effect_ctx, [*effects, *custom])
    candidates, untestable = _testable(ctx, candidates)
    start = starting_point(
        ctx,
        real,
        recalibrate=recalibrate,
        sensitivities=sensitivities,
        tolerance=tolerance,
        quantum=quantum,
        events=EventSettings(step_time_s=step_time_s, driver_window_s=driver_window_s),
    )
    found = EffectSearch(ctx, start, make_generator(random_state), **search).run(candidates)
    not_tried = _not_tried(asked, skipped)
    descriptions = {e.name: e.description for e in (*effects, *custom)}
    report = _report(target, ctx, start, found, not_tried, untestable, descriptions, flags)
    report.min_shrinkage = search["min_shrinkage"]
    return report


# --------------------------------------------------------------------------
# before the search: consistent sensors, testable effects
# --------------------------------------------------------------------------


def _without_sensors(ctx, flags):
    """``ctx`` without the sensors flagged as inconsistent (said in one warning)."""
    if not flags:
        return ctx
    bad = sorted({f.sensor for f in flags})
    names = [ctx.sensor_names[j] for j in bad]
    where = "; ".join(_flag_words(ctx, f) for f in flags)
    warn_user(
        f"diagnose_gap: sensor{'s' if len(names) > 1 else ''} {', '.join(names)} relate to the "
        f"other sensors differently in one test (swapped, moved or mislabelled?): {where}; "
        "left out of the effects built from the sensors.",
        GapWarning,
    )
    keep = [j for j in range(len(ctx.sensor_names)) if j not in bad]
    return replace(
        ctx, sensors=ctx.sensors[:, keep], sensor_names=[ctx.sensor_names[j] for j in keep]
    )


def _flag_words(ctx, flag):
    """One flagged sensor in words."""
    words = (
        f"{ctx.sensor_names[flag.sensor]} in test {ctx.labels[flag.test]!r} (held-out error "
        f"{flag.ratio:.0f}× that in the other tests"
    )
    if flag.partner is not None:
        words += f"; it reads as swapped with {ctx.sensor_names[flag.partner]}"
    return words + ")"


def _testable(ctx, candidates):
    """The candidates that leave one test out can score, and why the others cannot.

    An effect whose signatures are zero in every test but one (a coolant
    run in one test only, an air that changed in one test) cannot be
    scored on a held-out test: held out, that test's calibration tests do
    not show it; held in, no other test does.
    """
    keep, untestable = [], {}
    for cand in candidates:
        shown = showing_tests(cand, ctx.bounds)
        if max(len(tests) for tests in shown) >= 2:
            keep.append(cand)
            continue
        seen = sorted(set().union(*shown))
        if seen:
            which = f"only test {ctx.labels[seen[0]]!r} shows it"
        else:
            which = "no test shows it (its signatures are zero)"
        untestable[cand.effect] = (
            f"untestable leave one test out: {which}; another test with this effect would test it"
        )
    return keep, untestable


def _not_tried(asked, skipped):
    """Library effects not tried, and why: the columns they need, or not asked for."""
    out = {}
    for effect in LIBRARY:
        if effect.name not in asked:
            needs = effect.needs()
            out[effect.name] = "not asked for (effects=)" + (f"; needs {needs}" if needs else "")
        elif effect.name in skipped:
            out[effect.name] = skipped[effect.name]
    return out


# --------------------------------------------------------------------------
# report stage
# --------------------------------------------------------------------------


def _report(target, ctx, start, found, not_tried, untestable, descriptions, flags):
    """The :class:`GapReport` of what the search found."""
    final = found.final
    r_series = pd.Series(ctx.r, index=ctx.index, name="gap")
    signals = {}
    for name, values in (
        *zip(ctx.driver_names, ctx.drivers.T),
        *([(ctx.ambient_name, ctx.ambient)] if ctx.ambient is not None else []),
        *zip(ctx.sensor_names, ctx.sensors.T),
    ):
        signals[name] = values
    drivers_frame = pd.DataFrame(dict(zip(ctx.driver_names, ctx.drivers.T)), index=ctx.index)
    drivers_frame = drivers_frame if ctx.driver_names else None
    signal_frame = pd.DataFrame(signals, index=ctx.index)
    # the causes table lists the effects asked for; not_tried lists the whole library
    asked_skipped = {e: why for e, why in not_tried.items() if not why.startswith("not asked")}
    causes = _causes(ctx, found, {**untestable, **asked_skipped})
    where = gap_breakdown(r_series, drivers=drivers_frame)
    whiteness, xcorr = residual_diagnostics(r_series, signal_frame)
    corrected = pd.Series(final.held_out, index=ctx.index, name="gap_after")
    remainder_where = gap_breakdown(corrected, drivers=drivers_frame)
    remainder_white, remainder_xcorr = residual_diagnostics(corrected, signal_frame)
    named = found.named
    # the events still in what the named effects leave (one found in the gap
    # before the search may have been a thermal bend)
    located = events_in(ctx, final.held_out, start.noise, start.events)
    inconsistent = pd.DataFrame(
        {
            "test": [ctx.labels[f.test] for f in flags],
            "sensor": [ctx.sensor_names[f.sensor] for f in flags],
            "error_ratio": [f.ratio for f in flags],
            "swapped_with": [
                ctx.sensor_names[f.partner] if f.partner is not None else None for f in flags
            ],
        },
        columns=_SENSOR_COLUMNS,
    )
    return GapReport(
        target=target,
        where=where,
        causes=causes,
        cause=named[0].candidate.effect if named else None,
        named=[n.candidate.effect for n in named],
        rmse_before=start.initial.rmse,
        rmse_recalibrated=start.recalibrated.rmse if start.recalibrated is not None else np.nan,
        rmse_after=final.rmse,
        peak_before=start.initial.peak,
        peak_after=final.peak,
        noise_floor=start.floor,
        quantum=start.noise.quantum,
        whiteness=whiteness,
        cross_correlation=xcorr,
        gap=r_series,
        corrected=corrected,
        descriptions=descriptions,
        recalibration=start.recal_detail,
        recalibration_kept=found.kept,
        events=pd.DataFrame(event_table(located), columns=EVENT_COLUMNS),
        departures=_departures(ctx, final, start, located),
        n_placebo=found.n_placebo,
        remainder_where=remainder_where,
        remainder_whiteness=remainder_white,
        remainder_cross_correlation=remainder_xcorr,
        not_tried=not_tried,
        untestable=untestable,
        inconsistent_sensors=inconsistent,
    )


def _departures(ctx, final, start, located):
    """Where, in time, what the named effects leave departs from each test's slow pattern."""
    noise = start.noise
    found = locate_departures(
        final.held_out,
        ctx.bounds,
        ctx.index.get_level_values("time_s").to_numpy(dtype=float),
        ctx.dt,
        noise.floor,
        labels=[str(label) for label in ctx.labels],
        correlation=noise.correlation,
        step_time_s=start.events.step_time_s,
        event_rows=[e.row for e in located],
    )
    return pd.DataFrame(departure_table(found), columns=DEPARTURE_COLUMNS)


def _causes(ctx, found, skipped):
    """The ``causes`` table: named effects, the last step's losers, the dropped, the skipped."""
    rows = []
    grid = tau_grid(ctx.dt, ctx.durations)
    for named in found.named:
        best, ev, step = named.candidate, named.evaluation, named.step
        detail = best.describe(best.variants[ev.variant], ev.tau)
        bound = _at_bound(best, ev.tau)
        if bound:
            detail += f"; {bound}"
            warn_user(
                f"diagnose_gap: the time constant of {best.effect!r} ended at {bound}; the "
                f"true one may lie beyond it. {_bound_cause(ctx, grid, best.effect, ev.tau)}",
                GapWarning,
            )
        if step.ties:
            detail += f"; indistinguishable from {', '.join(step.ties)}"
        if step.pair:
            detail += (
                f"; named as a pair with {step.pair} (together they beat the placebos; its "
                f"shrinkage is its own part, what it adds to {step.pair} alone)"
            )
        rows.append(
            _row(best.effect, detail, step, step.after, True, step.number, True, step.interval)
        )
    last = found.steps[-1] if found.steps else None
    if last is not None and not last.significant:
        for k, scored in enumerate(last.scored):
            cand, ev = scored.candidate, scored.evaluation
            why = last.why if k == 0 or last.why_all else _why_not(scored, last)
            detail = f"{cand.describe(cand.variants[ev.variant], ev.tau)}; not supported: {why}"
            rows.append(_row(cand.effect, detail, last, ev, own=k == 0, interval=scored.interval))
    for cand in found.dropped:
        detail = "named, then dropped: the other named effects explain the gap as well without it"
        rows.append(_row(cand.effect, detail))
    for effect, why in skipped.items():
        prefix = "" if why.startswith("untestable") else "not tried: "
        rows.append(_row(effect, prefix + why))
    return pd.DataFrame(rows, columns=_CAUSE_COLUMNS)


def _why_not(scored, step):
    """Why a candidate other than a step's best was not named."""
    lo = scored.interval[0]
    if not (np.isfinite(lo) and lo > 0):
        return "its 95% interval over tests reaches below 0"
    if not scored.shrinkage > step.min_shrinkage:
        return f"it shrinks the gap by no more than min_shrinkage={step.min_shrinkage:g}"
    best = step.scored[0].candidate.effect
    return f"{best} shrinks the gap more and is not supported either"


def _row(effect, detail, step=None, ev=None, significant=False, number=0, own=False, interval=None):
    """One row of ``causes``: ``ev`` scored against ``step``'s starting gap (NaN if unscored).

    ``own``: the row is the one the step's placebos were drawn for (its
    p-value and best placebo are shown).
    """
    scored = step is not None and ev is not None
    before = step.before if scored else None
    return {
        "effect": effect,
        "detail": detail,
        "rmse_before": before.rmse if scored else np.nan,
        "rmse_after": ev.rmse if scored else np.nan,
        "shrinkage": shrinkage(ev.rmse, before.rmse) if scored else np.nan,
        "significant": significant,
        "step": number,
        "placebo_shrinkage": step.placebo_max if scored and own else np.nan,
        "peak_before": before.peak if scored else np.nan,
        "peak_after": ev.peak if scored else np.nan,
        "p_value": step.p_value if scored and own else np.nan,
        "n_placebo": step.n_placebo if scored and own else 0,
        "shrinkage_ci": interval if scored else (np.nan, np.nan),
    }


def _time_unit_hint(ctx):
    """What a time constant at its bound may say about the unit of time_s."""
    lo = tau_grid(ctx.dt, ctx.durations)[0]
    return (
        f"Time constants are searched in seconds of time_s, from {lo:g} s "
        f"({format_duration(lo)}) to twice the longest test ({2 * max(ctx.durations):g} s = "
        f"{format_duration(2 * max(ctx.durations))}); if time_s holds minutes or hours, that is "
        "the likely cause: convert it to seconds."
    )


def _bound_cause(ctx, grid, effect, setting, rtol=1e-9):
    """Why a time constant may have ended at a bound: the time unit, or the effect's own limit.

    Only the ends of the shared grid (two samples, twice the longest test)
    say something about the unit of ``time_s``; an effect that searches less
    than the grid (``sensor_lag`` up to ``max_sensor_lag_s``) ends at a limit
    of its own, which a time unit would not explain.
    """
    ends = (grid[0], grid[-1])
    if any(abs(tau - end) <= rtol * end for tau in setting for end in ends):
        return _time_unit_hint(ctx)
    return (
        f"That is the longest time constant {effect!r} searches, shorter than the other "
        "effects' (for sensor_lag: max_sensor_lag_s); it says nothing about the unit of "
        "time_s."
    )


def _at_bound(cand, setting, rtol=1e-9):
    """Which search bound a setting's time constant sits on, in words; "" if none."""
    if not setting or not cand.taus:
        return ""
    lo, hi = min(cand.taus), max(cand.taus)
    for tau in setting:
        if abs(tau - lo) <= rtol * lo:
            return f"the shortest time constant searched ({lo:g} s = {format_duration(lo)})"
        if abs(tau - hi) <= rtol * hi:
            return f"the longest time constant searched ({hi:g} s = {format_duration(hi)})"
    return ""


_SENSOR_COLUMNS = ["test", "sensor", "error_ratio", "swapped_with"]

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
