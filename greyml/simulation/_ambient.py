"""Ambient air temperature profiles around the machine.

A profile is a callable of the time in s from the test start returning °C,
with the times at which it jumps (:meth:`AmbientProfile.breakpoints`) so that
the simulator can place step boundaries there and stay exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from greyml._time import format_duration
from greyml.simulation._numbers import as_float

__all__ = [
    "AmbientProfile",
    "constant",
    "linear_drift",
    "diurnal",
    "door_openings",
    "as_profile",
]


class AmbientProfile:
    """Base class: ``profile(t)`` gives the air temperature at times ``t`` (s).

    Profiles add up, with each other and with numbers, and the sum keeps the
    jumps of both.

    Examples
    --------
    A profile of one's own: the air warms by 2 °C at 10 min. It declares the
    jump, so the simulator ends a step there.

    >>> import numpy as np
    >>> from greyml.simulation import AmbientProfile, linear_drift
    >>> class Step(AmbientProfile):
    ...     def __call__(self, t):
    ...         return np.where(np.asarray(t, dtype=float) < 600.0, 20.0, 22.0)
    ...
    ...     def breakpoints(self):
    ...         return np.array([600.0])
    >>> air = Step() + 0.5
    >>> air([0.0, 600.0]).tolist(), air.breakpoints().tolist()
    ([20.5, 22.5], [600.0])
    >>> (Step() + linear_drift(0.0, 1.0))([3600.0]).tolist()  # plus 1 °C/h
    [23.0]
    """

    def __call__(self, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def breakpoints(self) -> np.ndarray:
        """Times (s) at which the profile jumps."""
        return np.empty(0)

    def __add__(self, other):
        return _Sum(self, as_profile(other))

    __radd__ = __add__


class _Shown(AmbientProfile):
    """A profile of greyml's, shown as its ``_text`` with its fields filled in."""

    _text = ""

    def _fields(self):
        return vars(self)

    def __repr__(self):
        return self._text.format(**self._fields())


@dataclass(frozen=True, repr=False)
class _Constant(_Shown):
    _text = "constant({temperature_C:g} °C)"
    temperature_C: float

    def __call__(self, t):
        return np.full(np.shape(t), float(self.temperature_C))


@dataclass(frozen=True, repr=False)
class _Linear(_Shown):
    _text = "linear drift from {start_C:g} °C at {rate_C_per_h:+g} °C/h"
    start_C: float
    rate_C_per_h: float

    def __call__(self, t):
        return self.start_C + self.rate_C_per_h * np.asarray(t, dtype=float) / 3600.0


@dataclass(frozen=True, repr=False)
class _Diurnal(_Shown):
    _text = (
        "diurnal {mean_C:g} ± {amplitude_C:g} °C, peak at {peak_hour:g} h, "
        "test starting at {start_hour:g} h"
    )
    mean_C: float
    amplitude_C: float
    peak_hour: float
    start_hour: float
    period_h: float

    def __call__(self, t):
        hour = self.start_hour + np.asarray(t, dtype=float) / 3600.0
        phase = 2.0 * np.pi * (hour - self.peak_hour) / self.period_h
        return self.mean_C + self.amplitude_C * np.cos(phase)


@dataclass(frozen=True, repr=False)
class _Doors(_Shown):
    _text = "{base!r} with {n} door opening(s) of -{drop_C:g} °C for {duration}"
    base: AmbientProfile
    at_s: tuple
    drop_C: float
    duration_s: float

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        out = np.asarray(self.base(t), dtype=float).copy()
        for t0 in self.at_s:
            out = out - self.drop_C * ((t >= t0) & (t < t0 + self.duration_s))
        return out

    def breakpoints(self):
        own = [t for t0 in self.at_s for t in (t0, t0 + self.duration_s)]
        return np.unique(np.concatenate([self.base.breakpoints(), own]))

    def _fields(self):
        return {**vars(self), "n": len(self.at_s), "duration": format_duration(self.duration_s)}


@dataclass(frozen=True, repr=False)
class _Sum(_Shown):
    _text = "{a!r} + {b!r}"
    a: AmbientProfile
    b: AmbientProfile

    def __call__(self, t):
        return self.a(t) + self.b(t)

    def breakpoints(self):
        return np.unique(np.concatenate([self.a.breakpoints(), self.b.breakpoints()]))


def as_profile(ambient, what="ambient") -> AmbientProfile:
    """A profile from a profile or a number (a constant temperature).

    ``what`` names the argument in messages (``"ambient"``, ``"history_ambient"``).
    """
    if isinstance(ambient, AmbientProfile):
        return ambient
    value = as_float(
        ambient,
        f"{what} must be an AmbientProfile (linear_drift, diurnal, door_openings) "
        "or a temperature in °C",
        f"The {what} temperature must be finite",
    )
    return _Constant(value)


def _finite(value, name, function):
    """A finite float, or a ValueError naming the parameter and the function."""
    what = f"{name!r} of {function}"
    return as_float(value, f"{what} must be a number", f"{what} must be finite")


def constant(temperature_C=20.0) -> AmbientProfile:
    """Constant ambient temperature.

    Examples
    --------
    >>> constant(21.0)([0, 3600]).tolist()
    [21.0, 21.0]
    """
    return as_profile(temperature_C)


def linear_drift(start_C=20.0, rate_C_per_h=0.3) -> AmbientProfile:
    """Ambient temperature changing at a constant rate.

    Parameters
    ----------
    start_C : float
        Temperature at the start of the test.
    rate_C_per_h : float
        Change per hour (a workshop warming up in the morning: a few tenths
        of a kelvin per hour).

    Examples
    --------
    >>> linear_drift(20.0, 0.5)([0, 7200]).tolist()
    [20.0, 21.0]
    """
    return _Linear(
        _finite(start_C, "start_C", "linear_drift"),
        _finite(rate_C_per_h, "rate_C_per_h", "linear_drift"),
    )


def diurnal(mean_C=20.0, amplitude_C=2.0, *, peak_hour=15.0, start_hour=8.0, period_h=24.0):
    """Daily cycle of a workshop without air conditioning.

    Parameters
    ----------
    mean_C, amplitude_C : float
        Mean and half the peak-to-peak swing.
    peak_hour : float, default=15.0
        Hour of the day with the warmest air.
    start_hour : float, default=8.0
        Hour of the day at which the test starts.
    period_h : float, default=24.0

    Examples
    --------
    >>> round(float(diurnal(20.0, 2.0, peak_hour=15.0, start_hour=15.0)(0)), 6)
    22.0
    """
    values = {
        name: _finite(value, name, "diurnal")
        for name, value in (
            ("mean_C", mean_C),
            ("amplitude_C", amplitude_C),
            ("peak_hour", peak_hour),
            ("start_hour", start_hour),
            ("period_h", period_h),
        )
    }
    if values["period_h"] <= 0:
        raise ValueError(f"'period_h' of diurnal must be positive; got {period_h!r}.")
    return _Diurnal(*values.values())


def door_openings(base=20.0, at_s=(3600.0,), *, drop_C=1.0, duration_s=600.0):
    """Steps of colder air while a workshop door stands open.

    Parameters
    ----------
    base : AmbientProfile or float
        Profile without the openings.
    at_s : sequence of float
        Times (s from the test start) at which the door opens.
    drop_C : float, default=1.0
        How much colder the air is while the door is open.
    duration_s : float, default=600.0
        How long the door stays open.

    Examples
    --------
    >>> door_openings(20.0, [60.0], drop_C=2.0, duration_s=60.0)([0, 60, 119, 120]).tolist()
    [20.0, 18.0, 18.0, 20.0]
    """
    try:
        at = tuple(float(t) for t in np.atleast_1d(at_s))
    except (TypeError, ValueError):
        raise ValueError(f"at_s of door_openings must be times in s; got {at_s!r}.") from None
    if not all(np.isfinite(at)):
        raise ValueError(f"at_s of door_openings must hold finite times; got {list(at)}.")
    duration = _finite(duration_s, "duration_s", "door_openings")
    if duration <= 0:
        raise ValueError(f"duration_s must be positive; got {duration_s!r}.")
    drop = _finite(drop_C, "drop_C", "door_openings")
    return _Doors(as_profile(base, "base"), at, drop, duration)
