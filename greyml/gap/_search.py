"""diagnose_gap, stage 2: where the search for effects starts.

:func:`starting_point` refits the simulation's own parameters (when asked)
and locates abrupt events, which are held fixed while effects are fitted;
the search itself (:class:`greyml.gap._naming.EffectSearch`) names effects
greedily against placebos, prunes what the others make redundant, with and
without the recalibration, and keeps the search that leaves less of the gap
held out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from greyml._sequences import segments_by_test
from greyml.gap._effects import recalibration_candidate
from greyml.gap._events import EventSettings, event_columns, events_in
from greyml.gap._fit import evaluate, fit_recalibration
from greyml.gap._noise import NoiseFloor, measure_noise, noise_floor
from greyml.gap._prepare import _sensitivity_design

__all__ = ["Start", "noise_floor", "starting_point"]

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


def _recalibration(ctx, real, base, sensitivities, tolerance):
    """The simulation's parameters (or gain and timing) refitted within ``tolerance``."""
    if sensitivities is not None:
        S, names = _sensitivity_design(sensitivities, real, ctx.index, segments_by_test(real))
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
