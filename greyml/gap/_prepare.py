"""diagnose_gap, stage 1: read and check the inputs, gather the roles as arrays.

Everything the search needs is checked here, before any fit: the parameters,
the measured data and the simulation on the same rows, every role's column
(finite, in evenly sampled tests of at least 10 rows) and the user's custom
effects. The search (:mod:`greyml.gap._search`) and the report
(:mod:`greyml.gap._diagnose`) take the :class:`GapContext` built here.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import pandas as pd

from greyml._sequences import segment_label, segments_by_test
from greyml._validation import (
    MAX_INPUT,
    _upper_first,
    check_sampling_interval,
    first_non_finite,
    segment_of,
)
from greyml.gap._effects import EFFECTS, columns_effect, library_effects, signature_effect
from greyml.io import check_test_frame, read_tests_csv

__all__ = ["GapContext", "build_context", "check_parameters", "custom_specs", "prepare"]


def check_parameters(effects, custom_effects, max_effects, n_placebo, min_shrinkage, tie_tolerance):
    """Check what diagnose_gap's declared constraints cannot: the effects named.

    Returns the library's effects to try (:class:`~greyml.gap._effects.Effect`
    records, in order, once) and the settings of
    the search (``n_placebo``, ``min_shrinkage``, ``max_effects``,
    ``tie_tolerance``) as keyword arguments of
    :class:`~greyml.gap._naming.EffectSearch`.
    """
    if effects is None:
        effects = EFFECTS
    effects = list(dict.fromkeys(_as_names(effects, "effects")))
    if not effects and not custom_effects:
        raise ValueError("effects= names no effect; leave it out (None) to try them all.")
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise ValueError(f"Unknown effect(s) {unknown}; the effects are {list(EFFECTS)}.")
    search = {"n_placebo": n_placebo, "min_shrinkage": min_shrinkage}
    search.update(max_effects=max_effects, tie_tolerance=tie_tolerance)
    return library_effects(effects), search


def prepare(real, sim, custom_effects, *, target, ambient, drivers, sensors, fbgs):
    """Read the measured data and check the roles, the simulation and the custom effects.

    (The sensitivities are read when the recalibration needs them, see
    :func:`greyml.gap._search.starting_point`.)

    Returns
    -------
    real : DataFrame
        The measured data, checked.
    ctx : GapContext
        The roles as arrays.
    custom : list of Effect
        The custom effects, see :func:`custom_specs`.
    """
    real = _read(real, "The measured data")
    ctx = build_context(
        real, sim, target=target, ambient=ambient, drivers=drivers, sensors=sensors, fbgs=fbgs
    )
    return real, ctx, custom_specs(custom_effects, real, ctx)


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
    with np.errstate(invalid="ignore"):
        rows = np.flatnonzero(np.abs(values) > MAX_INPUT)
    if rows.size:
        row = int(rows[0])
        raise ValueError(
            f"{name} holds {values[row]:g} in {segment_label(segment_of(segments, row))} at "
            f"time_s={index.get_level_values('time_s')[row]:g}, beyond {MAX_INPUT:g}, which "
            "no measurement reaches; check its unit."
        )


#: A gap whose largest magnitude is below this is nothing to diagnose: far
#: under any instrument's resolution in any unit, and its squares (the noise
#: floor's, the fits') underflow in float64.
MIN_GAP = 1e-100


def _check_gap_size(r, target):
    largest = float(np.max(np.abs(r))) if r.size else 0.0
    if largest == 0.0:
        raise ValueError(
            f"The measured and simulated {target!r} agree exactly in every row: there is "
            "no gap to diagnose (was the simulation given as the measurement?)."
        )
    if largest < MIN_GAP:
        raise ValueError(
            f"The gap between the measured and simulated {target!r} is at most "
            f"{largest:.3g} in every row, below {MIN_GAP:g}: too small to diagnose; "
            "check the unit of both."
        )


def build_context(real, sim, *, target, ambient, drivers, sensors, fbgs):
    """Check the roles and the simulation; gather them into a :class:`GapContext`.

    ``real`` is the measured data as :func:`prepare` has read and checked it.
    """
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
    segments = segments_by_test(real)
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
    _check_gap_size(measured - sim_values, target)
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


def custom_specs(custom_effects, real, ctx):
    """Check ``custom_effects``: one :class:`~greyml.gap._effects.Effect` per entry."""
    if custom_effects is None:
        return []
    out = []
    segments = segments_by_test(real)
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
            out.append(signature_effect(name, names, values))
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
        out.append(columns_effect(name, columns, values))
    return out
