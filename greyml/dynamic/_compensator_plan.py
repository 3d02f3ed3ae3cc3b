"""The plan of a Compensator's update: its parameters checked, as arrays over terms.

Built from ``inputs`` and ``terms`` (never taken from a file): which row
position each term reads, its power, its time constant, its weight, which
lags start idle, and the order of an array row.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping

import numpy as np

from greyml._sequences import TIME_LEVEL
from greyml.dynamic._lags import _power_name, _tau_label
from greyml.dynamic._time import MAX_TERMS

__all__ = ["build_plan", "real"]


def real(value):
    """A finite real number (not a bool)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


_real = real


def build_plan(self):
    """Check the terms and inputs one by one (after the constraints); return the plan
    of an update: arrays over terms, in the order the update runs them."""
    name = type(self).__name__
    inputs = [str(v) for v in self.inputs]
    if len(set(inputs)) != len(inputs) or TIME_LEVEL in inputs:
        bad = TIME_LEVEL if TIME_LEVEL in inputs else next(v for v in inputs if inputs.count(v) > 1)
        raise ValueError(
            f"The 'inputs' parameter of {name} names {bad!r} "
            + ("more than once." if bad != TIME_LEVEL else "; time_s is read apart.")
        )
    if isinstance(self.terms, (str, Mapping)) or not hasattr(self.terms, "__iter__"):
        raise ValueError(
            f"The 'terms' parameter of {name} must be a list of "
            f"(input_name, power, tau_s, weight). Got {self.terms!r} instead."
        )
    too_many = f"{name} holds more than the {MAX_TERMS:,} terms or inputs a compensator may hold."
    if len(inputs) > MAX_TERMS:
        raise ValueError(too_many)
    position = {v: j for j, v in enumerate(inputs)}
    raw, lagged = {}, {}
    for k, term in enumerate(self.terms):
        if k >= MAX_TERMS:
            raise ValueError(too_many)
        try:
            column, power, tau, weight = term
        except (TypeError, ValueError):
            raise ValueError(
                f"Term {k} of {name} must be (input_name, power, tau_s, weight); got {term!r}."
            ) from None
        if str(column) not in position:
            raise ValueError(
                f"Term {k} of {name} names the input {column!r}, which is not in "
                f"inputs ({', '.join(inputs)})."
            )
        if not (_real(power) and power > 0):
            raise ValueError(
                f"Term {k} of {name} ({column!r}) has power {power!r}; it must be a "
                "finite number > 0."
            )
        if tau is not None and not (_real(tau) and tau > 0):
            raise ValueError(
                f"Term {k} of {name} ({column!r}) has the time constant {tau!r}; it "
                "must be a finite number of seconds > 0, or None for no lag."
            )
        if not _real(weight):
            raise ValueError(
                f"Term {k} of {name} ({column!r}) has weight {weight!r}; it must be a "
                "finite number."
            )
        key = (position[str(column)], float(power))
        if tau is None:
            raw[key] = raw.get(key, 0.0) + float(weight)
        else:
            key = (*key, float(tau))
            lagged[key] = lagged.get(key, 0.0) + float(weight)
    used = {k[0] for k in raw} | {k[0] for k in lagged}
    # one vector for every term: the lags first, then the inputs without lag,
    # taken as lags with a = 0 (s = 1·x + 0·s is x, exactly); the terms with
    # a power other than 1 in the middle, so one slice holds them all
    lag_keys = sorted(lagged, key=lambda k: k[1] != 1.0)
    raw_keys = sorted(raw, key=lambda k: k[1] == 1.0)
    keys = lag_keys + raw_keys
    powered = [i for i, k in enumerate(keys) if k[1] != 1.0]
    start, stop = (powered[0], powered[-1] + 1) if powered else (0, 0)
    idle = _names_in(self, self.idle_inputs, "idle_inputs", inputs)
    taus = [k[2] for k in lag_keys]
    max_step = self.max_step_s
    if max_step is None:
        max_step = max(taus) if taus else math.inf
    return {
        # positions in a row ("time_s", *inputs)
        "index": np.array([k[0] + 1 for k in keys], dtype=np.intp),
        # only lags start idle: an input without lag is the input itself
        "idle": np.array([inputs[k[0]] in idle for k in lag_keys], dtype=bool),
        "max_step": float(max_step),
        "row": _row_positions(self, inputs),
        "span": (start, stop),
        # terms whose power is not a whole number: a negative input has no real power
        "fractional": np.array(
            [i for i in range(start, stop) if keys[i][1] != round(keys[i][1])], dtype=np.intp
        ),
        "power": np.array([k[1] for k in keys[start:stop]], dtype=float),
        "tau": np.array([k[2] for k in lag_keys], dtype=float),
        "weight": np.array([lagged[k] for k in lag_keys] + [raw[k] for k in raw_keys]),
        "labels": [f"{_power_name(inputs[k[0]], k[1])}|lag {_tau_label(k[2])}" for k in lag_keys],
        "names": inputs,
        "shape": (len(inputs) + 1,),
        "check_all": len(used) < len(inputs),
    }


def _names_in(self, names, what, inputs):
    if isinstance(names, str):
        names = [names]
    names = [str(v) for v in names]
    for v in names:
        if v not in inputs:
            raise ValueError(
                f"The {what!r} parameter of {type(self).__name__} names {v!r}, which is "
                f"not in inputs ({', '.join(inputs)})."
            )
    return set(names)


def _row_positions(self, inputs):
    """Positions of ``time_s`` and each input in an array row, or None (no order declared)."""
    if self.row_columns is None:
        return None
    columns = [str(v) for v in self.row_columns]
    if len(set(columns)) != len(columns):
        twice = next(v for v in columns if columns.count(v) > 1)
        raise ValueError(
            f"The 'row_columns' parameter of {type(self).__name__} names {twice!r} more than once."
        )
    missing = [v for v in (TIME_LEVEL, *inputs) if v not in columns]
    if missing:
        raise ValueError(
            f"The 'row_columns' parameter of {type(self).__name__} lacks "
            f"{', '.join(map(repr, missing))}; an array row must hold time_s and every input."
        )
    return {
        "take": np.array([columns.index(v) for v in (TIME_LEVEL, *inputs)], dtype=np.intp),
        "size": len(columns),
    }
