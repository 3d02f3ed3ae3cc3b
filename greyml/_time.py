"""Durations in words: the one formatter of every time greyml prints.

Feature names (``"T4_C|lag 15 min"``), gain tables, step responses, gap
reports and messages all write a number of seconds through
:func:`format_duration`, so 7200 s reads "2 h" everywhere and 30 s never
becomes "0 min".
"""

from __future__ import annotations

import math

__all__ = ["TIME_UNITS", "common_unit", "format_duration"]

#: The units of time greyml reads and writes, with their length in seconds.
TIME_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}

_UNITS = tuple(reversed(TIME_UNITS.items()))  # largest first


def common_unit(seconds):
    """``(unit, scale)``: the largest of h, min, s in which every finite value of
    ``seconds`` is a whole number (``("s", 1.0)`` when none is).

    Examples
    --------
    >>> from greyml._time import common_unit
    >>> common_unit([3600, 7200]), common_unit([900, 3600]), common_unit([90, 0.5])
    (('h', 3600.0), ('min', 60.0), ('s', 1.0))
    """
    values = [float(v) for v in seconds if math.isfinite(v)]
    for unit, scale in _UNITS[:-1]:
        if all(v % scale == 0 for v in values):
            return unit, scale
    return _UNITS[-1]


def format_duration(seconds, digits=3):
    """A number of seconds in the largest unit that writes it well.

    A whole number of hours, minutes or seconds is written exactly in the
    largest such unit (7200 → ``"2 h"``, 8100 → ``"135 min"``, 90 →
    ``"90 s"``). Anything else is written in hours from two hours up, in
    minutes from two minutes up, else in seconds, with ``digits``
    significant digits.

    Parameters
    ----------
    seconds : float
    digits : int, default=3
        Significant digits of a duration that is not a whole number of
        hours, minutes or seconds (feature names use 12, so that distinct
        time constants keep distinct names).

    Returns
    -------
    str

    Examples
    --------
    >>> from greyml._time import format_duration
    >>> [format_duration(s) for s in (30, 900, 8100, 7200, 90, 86.56, 427.5, 9000.5)]
    ['30 s', '15 min', '135 min', '2 h', '90 s', '86.6 s', '7.12 min', '2.5 h']
    >>> format_duration(float("inf"))
    'inf s'
    """
    seconds = float(seconds)
    if not math.isfinite(seconds):
        return f"{seconds} s"
    unit, scale = common_unit([seconds])
    if seconds != 0 and seconds % scale == 0:
        return f"{seconds / scale:.12g} {unit}"
    size = abs(seconds)
    for unit, scale in _UNITS:
        if size >= 2 * scale or unit == "s":
            return f"{seconds / scale:.{digits}g} {unit}"
    raise AssertionError("unreachable")  # pragma: no cover
