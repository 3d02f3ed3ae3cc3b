"""``greyml predict --interval`` and ``--probe``: bounds, and probe readings replayed.

``--interval`` asks the model for its calibrated interval
(:meth:`greyml.ThermalTransferFunction.predict_interval`). ``--probe`` runs
the data file through the model's :class:`greyml.dynamic.Compensator`, test
by test as ``predict`` treats them, and hands it each probe reading
(:meth:`~greyml.dynamic.Compensator.observe`) once the row at or after the
reading's time has been updated; the correction written for a row is the one
after the readings up to its time. Without readings it equals ``predict``.
"""

from __future__ import annotations

import copy
import os
import warnings
from dataclasses import dataclass, field

from greyml._cli._files import _read, _require_values, _where
from greyml._cli._fitting import _final_step

__all__ = ["Replayed", "batch_half_width", "read_probes", "replay", "trust_model"]

#: What each flag needs of the model's final step, and how its refusal ends.
_NEEDS = {
    "--interval": ("predict_interval", "gives no interval"),
    "--probe": ("predict_interval", "takes no probe readings"),  # a transfer function
}


def trust_model(estimator, path, flag):
    """The model's final step, if it can serve ``flag``; else one line.

    A fitted :class:`greyml.ThermalTransferFunction`, alone or as the last
    step of a Pipeline, gives an interval and takes probe readings; any other
    model is a ValueError.
    """
    method, refusal = _NEEDS[flag]
    final = _final_step(estimator)
    if not callable(getattr(final, method, None)):
        raise ValueError(
            f"{flag}: the model {os.fspath(path)!r} ({type(final).__name__}) {refusal}; fit a "
            "transfer function (greyml fit --model transfer-function)."
        )
    if flag == "--probe" and getattr(final, "interval_calibration_", None) is None:
        raise ValueError(
            f"--probe: the model {os.fspath(path)!r} was fitted on fewer than 3 tests, so its "
            "error was never calibrated on held-out tests and a probe reading cannot be "
            "weighed against it; fit it on at least 3 tests."
        )
    return final


def model_rows(estimator, X):
    """``X`` as the final step sees it (through the Pipeline's other steps, if any)."""
    steps = getattr(estimator, "steps", None)
    return estimator[:-1].transform(X) if steps and len(steps) > 1 else X


def batch_half_width(estimator, X, coverage, params):
    """Half-width of the model's ``coverage`` interval at every row of ``X``.

    ``params`` are the keyword arguments of ``predict`` (``initial_displacement``);
    its warnings were reported by the prediction already.
    """
    final = _final_step(estimator)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        intervals = final.predict_interval(model_rows(estimator, X), coverage, **params)
    return intervals[:, 2] - intervals[:, 0]


@dataclass(frozen=True)
class Reading:
    """One probe reading: at ``time_s`` of test ``test``, placed after data row ``row``."""

    row: int
    time_s: float
    value: float
    where: str


def read_probes(path, csv_options, target, frame, data):
    """The readings of the probe file ``path``, checked against the data ``frame``.

    Each reading must name a test of ``data`` and a time within that test's
    rows, and the readings must come in the data's order (its tests in the
    order they appear, each in time order). Returns a list of
    :class:`Reading`, each placed at the first data row at or after its time.
    """
    import numpy as np

    from greyml._sequences import segments_by_test

    probes = _read(path, csv_options)
    if target not in probes.columns:
        from greyml._validation import shown_names

        have = shown_names(probes.columns, 12) or "none"
        raise ValueError(
            f"--probe {os.fspath(path)!r} has no column {target!r} (the model's target) to "
            f"read the readings from (its columns: {have})."
        )
    _require_values(probes, [target], path, "probe reading")
    times = frame.index.get_level_values("time_s").to_numpy(dtype=float)
    spans = {str(seg.label): (seg.start, seg.stop) for seg in segments_by_test(frame)}
    order = {label: k for k, label in enumerate(spans)}
    values = probes[target].to_numpy(dtype=float)
    readings, last = [], None
    for k, (test, time_s) in enumerate(probes.index):
        where = _where(probes, k, path)
        if test not in order:
            shown = ", ".join(map(repr, list(order)[:10]))
            raise ValueError(
                f"{where}: test {test!r} is not in {os.fspath(data)!r} (its tests: {shown})."
            )
        start, stop = spans[test]
        if not times[start] <= time_s <= times[stop - 1]:
            raise ValueError(
                f"{where}: test {test!r} of {os.fspath(data)!r} runs from time_s "
                f"{times[start]:g} to {times[stop - 1]:g} s; a reading at {time_s:g} s is not "
                "within it."
            )
        if last is not None and order[test] < order[last]:
            raise ValueError(
                f"{where}: the reading of test {test!r} comes after readings of test {last!r}, "
                f"which follows it in {os.fspath(data)!r}; readings must come in the data's "
                "order."
            )
        last = test
        row = start + int(np.searchsorted(times[start:stop], time_s, side="left"))
        readings.append(Reading(row, float(time_s), float(values[k]), where))
    return readings


@dataclass
class Replayed:
    """What replaying the readings gave, row by row, and what the detector did.

    ``changes`` holds ``(test, time_s)`` of each reading after which the
    change detector fired (and recalibrated).
    """

    prediction: object
    half_width: object
    trusted: object
    readings: int = 0
    changes: list = field(default_factory=list)


def _reanchor(comp, row, value):
    """Keep the lags; make the correction at the row just updated ``value``, known there.

    What ``predict`` does at a test that carries the previous test's lags but
    is measured from its own start (``reference_="start"``, or a value given
    with ``initial_displacement``): the lags run on, the displacement at the
    test's first row is ``value``, and the filter starts anew there (as after
    :meth:`~greyml.dynamic.Compensator.reset`), through the public state:
    ``start`` moves the correction to ``value``; the filter is the one a
    copy of it reset to ``value`` has after this row.
    """
    state = comp.get_state()
    model = state["filter"]["model"]  # the correction before the filter's offset
    start = state["start"] or 0.0
    fresh = copy.deepcopy(comp).reset(initial_displacement=value)
    fresh.update(row)
    state["start"] = start + model - value
    state["filter"] = fresh.get_state()["filter"]
    if state.get("envelope") is not None:  # the excess is measured from here too
        state["envelope"]["excess_start"] = state["envelope"]["excess_sum"]
    comp.set_state(state)


def _unshift(comp):
    """Measure the correction from the model's own zero again, as ``predict`` does in a
    carried test after one it started at a given displacement.

    Nothing is learnt or forgotten: the lags and the filter's states stay, and
    the values the filter remembers (the last correction, the model's values
    for late readings) move with the reference.
    """
    state = comp.get_state()
    shift, state["start"] = state["start"], None
    memory = state["filter"]
    memory["model"] += shift
    memory["correction"] += shift
    memory["history_model"] = [m + shift for m in memory["history_model"]]
    if state.get("envelope") is not None:
        state["envelope"]["excess_start"] = None
    comp.set_state(state)


def replay(estimator, X, readings, *, params, coverage, tolerance, bound):
    """Stream ``X`` through the model's compensator and give it the ``readings``.

    Every test that does not continue the one before it (as ``predict``
    decides from the clock and the model's ``state``) starts after a reset,
    at its initial displacement if one is given; a test that continues it
    keeps the lags, and is moved to start at 0 (``reference_="start"``) or at
    its initial displacement, as ``predict`` moves it (and, without one, is
    not moved by the one given to the test before it).

    Returns
    -------
    Replayed
    """
    import numpy as np

    from greyml._sequences import segments_by_test
    from greyml.controller import Compensator
    from greyml.dynamic._time import timeline

    final = _final_step(estimator)
    Xt = model_rows(estimator, X)
    if "time_s" not in list(getattr(getattr(Xt, "index", None), "names", None) or ()):
        raise ValueError(
            "--probe: the steps before the model's transfer function drop the rows' test and "
            "time_s, so its compensator cannot be run along them."
        )
    comp = Compensator.from_model(
        final,
        row_columns=["time_s", *map(str, Xt.columns)],
        coverage=0.9 if coverage is None else coverage,
        tolerance_um=tolerance,
    )
    # the readings' plausibility bound is the predictions' (--max-displacement);
    # set_params also builds it, so that the first reset keeps its displacement
    comp.set_params(max_correction_um=min(bound, np.finfo(float).max))
    times = Xt.index.get_level_values("time_s").to_numpy(dtype=float)
    rows = np.column_stack([times, Xt.to_numpy(dtype=float)])
    segments = segments_by_test(Xt)
    carried = timeline(
        Xt,
        segments,
        owner=type(final).__name__,
        tau_max=final.gap_limit_s_,
        state=final.state,
        nominal=final.nominal_step_s_,
        default_step=1.0,
    ).carried
    given = params.get("initial_displacement")
    if given is not None and not isinstance(given, dict):
        given = {str(s.label): given for s in segments}
    given = {str(k): v for k, v in (given or {}).items()}
    n = len(rows)
    out = Replayed(np.empty(n), np.empty(n), np.zeros(n, dtype=bool), len(readings))
    placed = {}
    for reading in readings:
        placed.setdefault(reading.row, []).append(reading)
    for i, seg in enumerate(segments):
        label = str(seg.label)
        anchor = given.get(label)
        if i == 0 or not carried[i]:
            comp.reset(initial_displacement=anchor)
            anchor = None
        elif anchor is None and final.reference_ == "start":
            anchor = 0.0
        elif anchor is None and comp.get_state()["start"] is not None:
            _unshift(comp)  # the test before was moved to a given displacement
        for k in range(seg.start, seg.stop):
            comp.update(rows[k])
            if k == seg.start and anchor is not None:
                _reanchor(comp, rows[k], anchor)
            for reading in placed.get(k, ()):
                fired = comp.status.changes
                try:
                    status = comp.observe(reading.time_s, reading.value)
                except ValueError as exc:
                    raise ValueError(f"{reading.where}: {exc}") from None
                if status.changes > fired:
                    out.changes.append((seg.label, reading.time_s))
            status = comp.status
            out.prediction[k] = status.correction
            out.half_width[k] = status.half_width
            out.trusted[k] = status.trusted
    return out
