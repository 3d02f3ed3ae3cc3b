"""Reading a Compensator's row (a mapping, a pandas Series or an array), and refusing one.

A row becomes the float array ``(time_s, *inputs)``; a value that is not a real
number (a bool, bytes, text, a date) is refused in one line, since it would
otherwise become a number and move the axis by it.
"""

from __future__ import annotations

import math
import numbers
import weakref
from collections.abc import Mapping

import numpy as np
import pandas as pd

from greyml._sequences import TIME_LEVEL

__all__ = ["bad_time", "bad_value", "forget_positions", "read_row"]

_PREFIX = "Compensator.update:"

# per compensator, the last pandas index seen and the positions of time_s and
# the inputs in it (kept outside the object: an Index is not part of its state)
_SERIES_POSITIONS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def forget_positions(comp):
    """Drop the positions remembered for ``comp`` (its inputs may have changed)."""
    _SERIES_POSITIONS.pop(comp, None)


def _numbers_only(values, names):
    """Refuse, in one line, a value of a row that is not a real number.

    A bool, bytes, text, a date or a duration would otherwise become a
    number (``True`` is 1, ``b"21"`` is 21, a datetime64 is its count of
    seconds since 1970) and move the axis by it. ``names`` (or the keys) say
    which entries to check.
    """
    for key in names if names is not None else values:
        value = values[key]
        if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (numbers.Real, np.integer, np.floating)
        ):
            kind = type(value).__name__
            where = f"position {key}" if names is None else repr(key)
            raise ValueError(
                f"{_PREFIX} the row's {where} is {value!r} (a {kind}), not a real number."
            )


def read_row(comp, row, plan):
    """The row as an array ``(time_s, *inputs)`` from a mapping, a Series or an array."""
    names = plan["names"]
    if isinstance(row, pd.Series):
        index = row.index
        seen, positions = _SERIES_POSITIONS.get(comp, (None, None))
        if row.dtype.kind not in "fiu":
            if index.has_duplicates:
                twice = index[index.duplicated()][0]
                raise ValueError(f"{_PREFIX} the row names {twice!r} more than once.")
            _numbers_only(row.to_dict(), [v for v in (TIME_LEVEL, *names) if v in index])
        if index is not seen:
            if index.has_duplicates:
                twice = index[index.duplicated()][0]
                raise ValueError(f"{_PREFIX} the row names {twice!r} more than once.")
            positions = index.get_indexer([TIME_LEVEL, *names])
            if (positions < 0).any():
                missing = [TIME_LEVEL, *names][int(np.flatnonzero(positions < 0)[0])]
                raise ValueError(f"{_PREFIX} the row has no {missing!r}.")
            _SERIES_POSITIONS[comp] = (index, positions)
        try:
            return row.to_numpy(dtype=float)[positions]
        except (TypeError, ValueError):
            raise ValueError(f"{_PREFIX} the row holds a value that is not a number.") from None
    if isinstance(row, Mapping):
        try:
            values = [row[TIME_LEVEL], *(row[v] for v in names)]
        except KeyError as exc:
            raise ValueError(f"{_PREFIX} the row has no {exc.args[0]!r}.") from None
        _numbers_only(dict(zip([TIME_LEVEL, *names], values)), [TIME_LEVEL, *names])
        try:
            return np.asarray(values, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{_PREFIX} the row holds a value that is not a number.") from None
    order = plan["row"]
    if order is None:
        raise ValueError(
            f"{_PREFIX} an array row has no names, so a wrong order cannot be told; pass "
            "a mapping or a Series by name, or declare the order of array rows with "
            f"row_columns= (e.g. {[TIME_LEVEL, *names][:4]})."
        )
    given = np.asarray(row)
    if given.dtype.kind not in "fiu":
        _numbers_only(dict(enumerate(given.reshape(-1).tolist())), None)
    try:
        values = np.asarray(row, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{_PREFIX} the row holds a value that is not a number.") from None
    if values.shape != (order["size"],):
        raise ValueError(
            f"{_PREFIX} an array row must hold the {order['size']} values of row_columns; "
            f"got shape {values.shape}."
        )
    return values[order["take"]]


def bad_time(time, previous):
    """Refuse a time that is not finite or not later than the previous row's, in one line."""
    if not math.isfinite(time):
        raise ValueError(f"{_PREFIX} time_s is {time!r}; it must be a finite number.")
    what = "repeats" if time == previous else "goes back"
    raise ValueError(
        f"{_PREFIX} time_s {what} from {previous:g} to {time:g} s; rows must come in "
        "increasing time (or give nominal_step_s= to read a restarting clock as the "
        "next test of the same recording)."
    )


def bad_value(comp, time, row, plan):
    """Refuse the row in one line, or hold the last output for a missing input."""
    if not math.isfinite(time):
        bad_time(time, comp._time)
    bad = np.flatnonzero(~np.isfinite(row[1:]))
    if bad.size:
        if comp.on_missing == "hold":
            return comp._hold()
        j = int(bad[0])
        raise ValueError(
            f"{_PREFIX} input {plan['names'][j]!r} is {float(row[j + 1])!r} at time_s = {time:g} s."
        )
    start, stop = plan["span"]
    for k, power in zip(range(start, stop), plan["power"]):
        j = int(plan["index"][k]) - 1
        if power != round(power) and row[j + 1] < 0:
            raise ValueError(
                f"{_PREFIX} input {plan['names'][j]!r} is negative ({float(row[j + 1])!r}) "
                f"at time_s = {time:g} s, and a term takes it to the power {power:g}, which "
                "is not a real number."
            )
    raise ValueError(
        f"{_PREFIX} the correction overflows at time_s = {time:g} s (a power of an "
        "input too large); scale the inputs."
    )
