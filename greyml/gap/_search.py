"""diagnose_gap, stage 2: where the search starts, and the search for effects.

:func:`starting_point` refits the simulation's own parameters (when asked)
and locates abrupt events, which are held fixed while effects are fitted;
:func:`search_effects` names effects greedily against placebos, prunes what
the others make redundant, with and without the recalibration, and keeps the
search that leaves less of the gap held out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from greyml._sequences import test_segments
from greyml.gap._effects import Bank, lag_bank, lag_picks, recalibration_candidate
from greyml.gap._events import EventSettings, event_columns, events_in
from greyml.gap._fit import evaluate, fit_recalibration, fold_design, placebo_walks
from greyml.gap._noise import NoiseFloor, measure_noise, noise_floor
from greyml.gap._prepare import _sensitivity_design

__all__ = ["Found", "Start", "noise_floor", "search_effects", "starting_point"]

#: What counts as an event when diagnose_gap is not told otherwise.
DEFAULT_EVENTS = EventSettings()


@dataclass
class Start:
    """Where the search starts.

    ``base``: each fold's fixed columns (the located events); ``initial``: the
    held-out gap with them alone; ``recal``: the refitted parameters (None
    without recalibration), ``recalibrated``: the held-out gap with them and
    ``recal_detail`` what they are in words; ``floor``: the gap's noise floor,
    ``noise`` how it was measured (:class:`~greyml.gap._noise.NoiseFloor`),
    ``events`` what counts as an event (:class:`~greyml.gap._events.EventSettings`).
    """

    base: list
    initial: object
    recal: object
    recalibrated: object
    recal_detail: str
    floor: float
    noise: NoiseFloor | None = None
    events: EventSettings = DEFAULT_EVENTS


@dataclass
class Found:
    """What the search named: ``named`` (candidate, evaluation, step) in order,
    every ``steps``' record, the ``final`` held-out evaluation, the candidates
    ``dropped`` by pruning, whether the recalibration was ``kept`` and how many
    placebos were drawn (``n_placebo``)."""

    named: list
    steps: list
    final: object
    dropped: list
    kept: bool
    n_placebo: int


def _recalibration(ctx, real, base, sensitivities, tolerance):
    """The simulation's parameters (or gain and timing) refitted within ``tolerance``."""
    if sensitivities is not None:
        S, names = _sensitivity_design(sensitivities, real, ctx.index, test_segments(real))
        recal = fit_recalibration(ctx.r, lambda s: S, [()], ctx.bounds, tolerance)
        mean = np.mean(recal.theta, axis=0)
        detail = "parameters refitted within ±{:.0%}: {}".format(
            tolerance, ", ".join(f"{c} {m:+.1%}" for c, m in zip(names, mean))
        )
    else:
        cand = recalibration_candidate(ctx)
        recal = fit_recalibration(
            ctx.r, lambda s: cand.make(s)[:, 0, :], cand.settings, ctx.bounds, tolerance
        )
        gain, lead = np.mean(recal.theta, axis=0)
        detail = (
            f"gain {gain:+.1%} and timing {lead:+.1%} of the simulation refitted "
            f"within ±{tolerance:.0%}"
        )
    return recal, detail, evaluate(ctx.r, base, None, [()], ctx.bounds, recal=recal)


def starting_point(
    ctx, real, *, recalibrate, sensitivities, tolerance, quantum=None, events=DEFAULT_EVENTS
):
    """Recalibrate (if asked) and hold the located events fixed: a :class:`Start`.

    ``quantum`` is the step of the readings (None: detected), ``events`` what
    counts as an event.
    """
    n = len(ctx.r)
    base = [np.zeros((n, 0)) for _ in ctx.bounds]
    recalibrated = recal = None
    recal_detail = ""
    if recalibrate:
        recal, recal_detail, recalibrated = _recalibration(
            ctx, real, base, sensitivities, tolerance
        )
    noise = measure_noise(
        ctx.r, ctx.measured, ctx.bounds, ctx.dt, quantum=quantum, step_time_s=events.step_time_s
    )
    # Abrupt events, located on the gap the parameters leave, are held fixed
    # (one column each, in every fold's base) while effects are fitted; those
    # still in the remainder at the end are reported.
    located = events_in(
        ctx, recalibrated.held_out if recalibrated is not None else ctx.r, noise, events
    )
    if located:
        columns = event_columns(located, n)
        base = [columns for _ in ctx.bounds]
        if recal is not None:
            recalibrated = evaluate(ctx.r, base, None, [()], ctx.bounds, recal=recal)
    initial = evaluate(ctx.r, base, None, [()], ctx.bounds)
    return Start(base, initial, recal, recalibrated, recal_detail, noise.floor, noise, events)


def search_effects(ctx, candidates, start, rng, **search):
    """Search for effects as the simulation is and, if recalibrated, with its parameters refitted.

    ``search`` holds ``n_placebo``, ``min_shrinkage``, ``max_effects`` and
    ``tie_tolerance``. Returns a :class:`Found`.
    """
    counter = [0]
    alt_rng = np.random.default_rng(rng.integers(2**63))
    named, steps, final, dropped = _search(
        ctx, candidates, start.base, start.initial, None, rng, counter=counter, **search
    )
    kept = False
    if start.recal is not None:
        # Effects are searched for twice: against the simulation as it is, and
        # with its parameters refitted (jointly with every effect). The
        # recalibration is kept when its search leaves less of the gap held
        # out. Neither order is safe alone: refitted parameters can take up
        # part of an effect, and an effect can hide a parameter error of the
        # opposite sign, which the recalibration alone then seems to worsen.
        alt = _search(
            ctx,
            candidates,
            start.base,
            start.recalibrated,
            start.recal,
            alt_rng,
            counter=counter,
            **search,
        )
        if alt[2].rmse < final.rmse:
            named, steps, final, dropped = alt
            kept = True
    return Found(named, steps, final, dropped, kept, counter[0])


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
