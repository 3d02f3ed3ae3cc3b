"""Duty cycles: what the machine is commanded to do during a test."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from greyml._time import format_duration
from greyml.simulation import _check
from greyml.simulation._machine import OPERATING_INPUTS
from greyml.simulation._numbers import as_float

__all__ = ["Segment", "Programme"]


@dataclass(frozen=True)
class Segment:
    """A stretch of time with constant commanded spindle speed, feed and C-axis speed.

    Parameters
    ----------
    duration_s : float
        Length in s, positive.
    spindle_rpm : float, default=0.0
    feed_mm_min : float, default=0.0
        Mean axis feed while the axes move.
    c_rpm : float, default=0.0
        C-axis (rotary table or head) speed.

    Examples
    --------
    >>> from greyml.simulation import Programme, Segment
    >>> seg = Segment(600.0, spindle_rpm=4000.0)
    >>> seg.value("spindle_rpm"), seg.value("feed_mm_min")
    (4000.0, 0.0)
    >>> Programme().then(seg).dwell(10).describe()
    '10 min spindle_rpm 4000; 10 min stopped'
    """

    duration_s: float
    spindle_rpm: float = 0.0
    feed_mm_min: float = 0.0
    c_rpm: float = 0.0

    def __post_init__(self):
        _check.real(self.duration_s, "Segment: 'duration_s'", low=0.0, strict=True)
        for column in OPERATING_INPUTS:
            _check.real(getattr(self, column), f"Segment: {column!r}", low=0.0)

    def value(self, column: str) -> float:
        return getattr(self, column)


def _duration(minutes, seconds, hours, what):
    given = [v for v in (minutes, seconds, hours) if v is not None]
    if len(given) != 1:
        raise ValueError(f"Give exactly one of minutes, seconds or hours for {what}.")
    total = (minutes or 0.0) * 60.0 + (seconds or 0.0) + (hours or 0.0) * 3600.0
    if not np.isfinite(total) or total <= 0:
        raise ValueError(f"The duration of {what} must be positive; got {total:g} s.")
    return float(total)


def _level(name, value, what):
    message = f"'{name}' of {what} must be a finite non-negative number"
    return as_float(value, message, message, low=0.0)


@dataclass(frozen=True)
class Programme:
    """An operating programme: a sequence of :class:`Segment`.

    Immutable; every builder method returns a new programme, so that
    programmes can be shared between tests.

    Parameters
    ----------
    segments : tuple of Segment, default=()
    name : str, default=""
        What the programme is, for descriptions.

    Examples
    --------
    Abdulshahed et al.'s (2015) Test IV: 4000 rpm for 120 min, 60 min pause,
    120 min, 180 min stopped.

    >>> p = (Programme(name="Test IV").run(120, spindle_rpm=4000).dwell(60)
    ...      .run(120, spindle_rpm=4000).dwell(180))
    >>> p.duration_s / 3600
    8.0
    >>> len(p.segments)
    4

    Abdulshahed et al.'s (2016) Z-axis test: 10 s of reciprocation, 10 s dwell, for 2 h, then
    2 h cooling.

    >>> z = Programme().cycle(on_s=10, off_s=10, minutes=120, feed_mm_min=70000)
    >>> z = z.dwell(120)
    >>> len(z.segments), z.duration_s
    (721, 14400.0)
    """

    segments: tuple = ()
    name: str = ""

    def __post_init__(self):
        if isinstance(self.segments, (str, bytes)) or not hasattr(self.segments, "__iter__"):
            raise ValueError(
                f"Programme: segments must be a tuple of Segment; got {self.segments!r}."
            )
        segments = tuple(self.segments)
        for k, seg in enumerate(segments):
            if not isinstance(seg, Segment):
                raise ValueError(
                    f"Programme: segment {k} is a {type(seg).__name__} ({seg!r}); expected a "
                    "Segment (or build the programme with run(), dwell() and cycle())."
                )
        object.__setattr__(self, "segments", segments)

    # ---------------------------------------------------------------- builder
    def then(self, segment: Segment) -> Programme:
        """Append one segment."""
        return Programme(self.segments + (segment,), self.name)

    def run(
        self,
        minutes=None,
        *,
        seconds=None,
        hours=None,
        spindle_rpm=0.0,
        feed_mm_min=0.0,
        c_rpm=0.0,
    ) -> Programme:
        """Append a stretch at constant speeds."""
        what = f"segment {len(self.segments)}"
        seg = Segment(
            _duration(minutes, seconds, hours, what),
            _level("spindle_rpm", spindle_rpm, what),
            _level("feed_mm_min", feed_mm_min, what),
            _level("c_rpm", c_rpm, what),
        )
        return self.then(seg)

    def dwell(self, minutes=None, *, seconds=None, hours=None) -> Programme:
        """Append a stretch with everything stopped (cooling)."""
        return self.run(minutes, seconds=seconds, hours=hours)

    def cycle(
        self,
        on_s,
        off_s,
        minutes=None,
        *,
        seconds=None,
        hours=None,
        spindle_rpm=0.0,
        feed_mm_min=0.0,
        c_rpm=0.0,
    ) -> Programme:
        """Append ``on_s`` of motion and ``off_s`` of dwell, repeated for a duration.

        The last repetition is cut at the end of the duration.
        """
        what = f"the cycle starting at segment {len(self.segments)}"
        total = _duration(minutes, seconds, hours, what)
        on_s = _level("on_s", on_s, what)
        off_s = _level("off_s", off_s, what)
        if on_s <= 0:
            raise ValueError(f"'on_s' of {what} must be positive; got {on_s:g}.")
        out = self
        t = 0.0
        levels = {"spindle_rpm": spindle_rpm, "feed_mm_min": feed_mm_min, "c_rpm": c_rpm}
        while t < total - 1e-9:
            d = min(on_s, total - t)
            out = out.run(seconds=d, **levels)
            t += d
            if off_s > 0 and t < total - 1e-9:
                d = min(off_s, total - t)
                out = out.dwell(seconds=d)
                t += d
        return out

    def __add__(self, other: Programme) -> Programme:
        if not isinstance(other, Programme):
            return NotImplemented
        return Programme(self.segments + other.segments, self.name or other.name)

    # ---------------------------------------------------------------- queries
    @property
    def duration_s(self) -> float:
        return float(sum(s.duration_s for s in self.segments))

    def boundaries(self) -> np.ndarray:
        """Start of every segment and the end of the last, in s."""
        return np.concatenate([[0.0], np.cumsum([s.duration_s for s in self.segments])])

    def levels(self, column: str) -> np.ndarray:
        """The commanded value of ``column`` in every segment."""
        if column not in OPERATING_INPUTS:
            raise ValueError(
                f"Unknown operating input {column!r}; expected one of {list(OPERATING_INPUTS)}."
            )
        return np.array([s.value(column) for s in self.segments], dtype=float)

    def at(self, column: str, t) -> np.ndarray:
        """Commanded value of ``column`` at times ``t`` (s); 0 after the end."""
        t = np.asarray(t, dtype=float)
        edges = self.boundaries()
        idx = np.searchsorted(edges, t, side="right") - 1
        vals = np.append(self.levels(column), 0.0)
        idx = np.where((idx < 0) | (idx >= len(self.segments)), len(self.segments), idx)
        return vals[idx]

    def mean_over(self, column: str, starts, width: float) -> np.ndarray:
        """Mean commanded value of ``column`` over ``[t, t + width)`` for each start."""
        edges = self.boundaries()
        vals = self.levels(column)
        cum = np.concatenate([[0.0], np.cumsum(vals * np.diff(edges))])

        def integral(t):
            t = np.clip(np.asarray(t, dtype=float), 0.0, edges[-1])
            k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(vals) - 1)
            return cum[k] + vals[k] * (t - edges[k])

        starts = np.asarray(starts, dtype=float)
        return (integral(starts + width) - integral(starts)) / width

    def describe(self) -> str:
        """One line per run of equal segments."""
        if not self.segments:
            return "empty programme"
        parts = []
        for seg in self.segments:
            level = ", ".join(f"{c} {seg.value(c):g}" for c in OPERATING_INPUTS if seg.value(c))
            parts.append(f"{format_duration(seg.duration_s)} " + (level or "stopped"))
        if len(parts) > 8:
            return f"{len(parts)} segments, {format_duration(self.duration_s)} in all"
        return "; ".join(parts)
