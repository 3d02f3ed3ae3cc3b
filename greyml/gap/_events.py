"""Located events in the gap: a step or a spike in one test, defined in time.

Thermal effects change the gap smoothly, over tens of minutes; an event
changes it at once: a probe knocked, a part re-clamped, a door opened on
the probe, or the spindle's own growth when its speed changes. An event is
defined in seconds, so that the same test sampled every 15 s, every minute
or every 5 min gives the same events:

- **a step** is a change of the gap completed within the step time
  (``step_time_s``, 2 min by default);
- **the smooth gap** around it is a cubic spline with knots every
  ``10 × step_time_s`` (20 min by default; at least six rows apart) plus
  *bends*, changes of slope where the data ask for one (a heat source
  switching on or off starts a thermal response with a bend), at least
  four step times apart;
- steps and bends are added one at a time, whichever explains more first,
  every row scanned in closed form. A step (a ramp that rises within the
  step time; where a step time holds two rows, also a jump between two
  rows) is kept while its size, less one quantum of the readings,
  exceeds ``z`` standard errors; while no two bends near it explain as
  much; and while no slower change (a ramp twice or four times as long, or
  a bend, placed over it) fits clearly better and leaves no abrupt part on
  top of it. At rows further apart than the step time, a change between two
  rows is a step as far as the rows can tell;
- where a step time holds a single row (rows more than about 80 s apart
  at the default 2 min), each edge of a spike is one row, which a bend of
  the smooth part mimics as well; there a spike (the gap leaves at one row
  and is back at a later row within the spike time) is also sought as one,
  every row and width in closed form, and taken when it explains more than
  any bend and clearly more than one step (by nine noise variances), its
  two rows then fitted as one column, of one height;
- the standard errors count the noise's own row-to-row correlation
  (:func:`~greyml.gap._noise.row_correlation`), up to one independent
  reading per step time: noise that a sensor averages is not averaged
  away by reading it faster;
- a quantised reading flips by one quantum whenever the displacement crosses
  a step of the instrument, so a change of one quantum is never an event;
- two opposite steps closer than ``15 × step_time_s`` are one **spike** (the
  gap leaves and comes back: a door opened and closed);
- an event within ``driver_window_s`` (1 min by default, plus one row of
  sampling) of a switch of a driver column (a change of more than 5 % of
  its range between two rows, e.g. the spindle speed) is reported **at that
  driver change**: a real response to the driver that is not thermal (the
  spindle's centrifugal and preload growth moves a probe at once when the
  speed changes), not a knock.

This is the one-sided fit idea of jump detection in regression (Müller
(1992); Qiu and Yandell (1998)), with a spline and bends for the smooth part
and least-squares steps added greedily, as in the segmentation methods
reviewed by Truong, Oudre and Vayatis (2020).

Pure array functions (no pandas, no validation); :func:`events_in` applies
them to a :class:`~greyml.gap._prepare.GapContext`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from greyml._threads import blas_threads_for
from greyml.gap._event_search import steps_in_test
from greyml.gap._noise import STEP_TIME_S

__all__ = [
    "DRIVER_WINDOW_S",
    "EVENT_Z",
    "EVENT_COLUMNS",
    "Event",
    "EventSettings",
    "describe_event",
    "event_columns",
    "event_table",
    "events_in",
    "locate_events",
]

#: Standard errors by which a step's size, less one quantum, must exceed zero.
EVENT_Z = 5.0
#: Knot spacing of the smooth gap, in step times.
KNOTS_PER_STEP_TIME = 10
#: Two opposite steps closer than this many step times are one spike.
SPIKE_STEP_TIMES = 15
#: Default window (s) within which an event coincides with a driver's switch.
DRIVER_WINDOW_S = 60.0
#: A driver switches when it changes by more than this share of its range.
_SWITCH_SHARE = 0.05

#: The columns of the events table of a report, in order.
EVENT_COLUMNS = [
    "test",
    "time_s",
    "kind",
    "size",
    "end_s",
    "z",
    "at_driver_change",
    "driver_change_s",
    "driver_before",
    "driver_after",
]


@dataclass(frozen=True)
class EventSettings:
    """What counts as an event: the step time, the driver window and the threshold.

    Attributes
    ----------
    step_time_s : float, default=120
        A change of the gap completed within this many seconds is a step.
    driver_window_s : float, default=60
        An event this close (s) to a switch of a driver is at that switch.
    z : float, default=5
        Standard errors by which a step must exceed one quantum.
    """

    step_time_s: float = STEP_TIME_S
    driver_window_s: float = DRIVER_WINDOW_S
    z: float = EVENT_Z

    @property
    def knot_s(self):
        """Knot spacing of the smooth gap (s), before the rows' minimum."""
        return KNOTS_PER_STEP_TIME * self.step_time_s

    @property
    def spike_s(self):
        """Two opposite steps closer than this (s) are one spike."""
        return SPIKE_STEP_TIMES * self.step_time_s


@dataclass(frozen=True)
class Event:
    """A located step or spike in one test.

    Attributes
    ----------
    test : str
        The test's label.
    time_s : float
        ``time_s`` of the first row at the new level (a spike: its first row).
    kind : {"step", "spike"}
    size : float
        The step's height, or the spike's mean height, in the target's unit.
    z : float
        The size, less one quantum, in standard errors.
    end_s : float or None
        A spike's last row's ``time_s``; None for a step.
    at_driver_change : str or None
        The driver whose switch the event coincides with, or None.
    driver_change_s : float or None
        ``time_s`` of the first row after that switch.
    driver_before, driver_after : float or None
        The driver's value on the rows either side of its switch.
    row, last_row, stop : int
        Rows in the stacked gap: the first row, a spike's last row (None for
        a step) and the end (exclusive) of the test.
    """

    test: str
    time_s: float
    kind: str
    size: float
    z: float
    end_s: float | None = None
    at_driver_change: str | None = None
    driver_change_s: float | None = None
    driver_before: float | None = None
    driver_after: float | None = None
    row: int = field(default=0, repr=False, compare=False)
    last_row: int | None = field(default=None, repr=False, compare=False)
    stop: int = field(default=0, repr=False, compare=False)

    def describe(self):
        """The event in one sentence of the report (:func:`describe_event`)."""
        return describe_event({name: getattr(self, name) for name in EVENT_COLUMNS})


def _missing(value):
    return value is None or (isinstance(value, float) and np.isnan(value))


def describe_event(record):
    """One sentence for an event given as a mapping of ``EVENT_COLUMNS`` (a table's row).

    Examples
    --------
    >>> text = describe_event({"test": "B", "time_s": 3600.0, "kind": "step", "size": 0.42,
    ...                        "at_driver_change": "spindle_rpm", "driver_change_s": 3585.0,
    ...                        "driver_before": 0.0, "driver_after": 2500.0})
    >>> text[:54]
    'Located event: test B at time_s=3600, a jump of +0.42,'
    >>> text[55:108]
    'at a spindle speed change (0 -> 2500 at time_s=3585):'
    """
    size = record["size"]
    if record.get("kind", "step") == "spike":
        what = f"a spike of {size:+.3g} until time_s={record['end_s']:g}"
    else:
        what = f"a jump of {size:+.3g}"
    head = f"Located event: test {record['test']} at time_s={record['time_s']:g}, {what}"
    driver = record.get("at_driver_change")
    if _missing(driver):
        return f"{head} (not a physical effect: a probe knocked, a re-clamp, a door opened?)."
    return (
        f"{head}, {_change_words(driver)} ({record['driver_before']:g} -> "
        f"{record['driver_after']:g} at time_s={record['driver_change_s']:g}): a response to "
        "the driver that is not thermal, not a knock."
    )


def _change_words(driver):
    name = driver.lower()
    if "spindle" in name or name.endswith("rpm"):
        return "at a spindle speed change"
    return f"at a change of {driver}"


def _switches(drivers, driver_names):
    """Per driver: the rows at which it switches (changes by > 5 % of its range)."""
    out = []
    for j, name in enumerate(driver_names):
        x = drivers[:, j]
        span = float(np.ptp(x)) if x.size else 0.0
        if span > 0:
            rows = np.flatnonzero(np.abs(np.diff(x)) > _SWITCH_SHARE * span) + 1
            out.append((name, x, rows))
    return out


def _at_switch(rows, times, start, stop, switches, tolerance):
    """The driver switch nearest to any of ``rows`` within ``tolerance`` s, or None."""
    best = None
    for name, x, switch_rows in switches:
        inside = switch_rows[(switch_rows > start) & (switch_rows < stop)]
        for row in rows:
            if not inside.size:
                continue
            gaps = np.abs(times[inside] - times[row])
            i = int(np.argmin(gaps))
            if gaps[i] <= tolerance and (best is None or gaps[i] < best[0]):
                s = int(inside[i])
                best = (gaps[i], name, float(times[s]), float(x[s - 1]), float(x[s]))
    return best


def locate_events(
    r,
    bounds,
    times,
    dt,
    floor,
    *,
    labels=None,
    quantum=0.0,
    correlation=0.0,
    settings=None,
    drivers=None,
    driver_names=(),
):
    """Abrupt steps and spikes of ``r`` within each test, in time.

    Parameters
    ----------
    r : ndarray of shape (n,)
        The gap (or what is left of it), tests stacked in ``bounds`` order.
    bounds : sequence of (start, stop)
    times : ndarray of shape (n,)
        ``time_s`` of every row (seconds).
    dt : sequence of float
        Each test's sampling interval (seconds).
    floor : float
        The noise floor of ``r`` (:mod:`greyml.gap._noise`).
    labels : sequence of str, optional
        The tests' labels (default: their positions).
    quantum : float, default=0.0
        The step of the readings: a change of one quantum is not an event.
    correlation : float, default=0.0
        The noise's correlation from row to row
        (:func:`~greyml.gap._noise.row_correlation`).
    settings : EventSettings, optional
    drivers : ndarray of shape (n, d), optional
        Driver columns; an event close to a switch of one is at that switch.
    driver_names : sequence of str

    Returns
    -------
    list of Event
        In test order, then time.

    Examples
    --------
    A 0.5 µm step at 90 min of a 4-hour test read every minute, on a slow
    thermal bend, with 0.05 µm of noise:

    >>> import numpy as np
    >>> t = np.arange(240) * 60.0
    >>> r = 2 * (1 - np.exp(-t / 5400)) + 0.5 * (t >= 5400)
    >>> r += np.random.default_rng(0).normal(0, 0.05, t.size)
    >>> [(e.kind, e.time_s, round(e.size, 1)) for e in locate_events(
    ...     r, [(0, 240)], t, [60.0], 0.05)]
    [('step', 5400.0, 0.5)]
    """
    settings = settings or EventSettings()
    out = []
    if not floor > 0:
        return out
    labels = list(labels) if labels is not None else [str(i) for i in range(len(bounds))]
    switches = _switches(drivers, driver_names) if drivers is not None else []
    for j, (start, stop) in enumerate(bounds):
        x, t = r[start:stop], times[start:stop]
        if x.size < 20:
            continue
        # many small least-squares fits: one BLAS thread (greyml._threads)
        with blas_threads_for(2.0 * x.size * 40**2):
            steps = steps_in_test(x, t, dt[j], floor, quantum, correlation, settings)
        merged = []
        i = 0
        while i < len(steps):
            m, size, z = steps[i]
            if i + 1 < len(steps):
                m2, size2, z2 = steps[i + 1]
                if np.sign(size2) == -np.sign(size) and t[m2] - t[m] < settings.spike_s:
                    merged.append((m, m2 - 1, 0.5 * (size - size2), min(z, z2)))
                    i += 2
                    continue
            merged.append((m, None, size, z))
            i += 1
        tolerance = settings.driver_window_s + dt[j]
        for m, last, size, z in merged:
            edges = [start + m] + ([start + last + 1] if last is not None else [])
            edges = [e for e in edges if e < stop]
            hit = _at_switch(edges, times, start, stop, switches, tolerance)
            extra = {}
            if hit is not None:
                _, name, when, before, after = hit
                extra = dict(
                    at_driver_change=name,
                    driver_change_s=when,
                    driver_before=before,
                    driver_after=after,
                )
            out.append(
                Event(
                    test=labels[j],
                    time_s=float(t[m]),
                    kind="step" if last is None else "spike",
                    size=float(size),
                    z=float(z),
                    end_s=None if last is None else float(t[last]),
                    row=start + m,
                    last_row=None if last is None else start + last,
                    stop=stop,
                    **extra,
                )
            )
    return out


def events_in(ctx, gap, noise, settings):
    """:func:`locate_events` on the gap ``gap`` of a :class:`GapContext`, with its drivers."""
    return locate_events(
        gap,
        ctx.bounds,
        ctx.index.get_level_values("time_s").to_numpy(dtype=float),
        ctx.dt,
        noise.floor,
        labels=[str(label) for label in ctx.labels],
        quantum=noise.quantum,
        correlation=noise.correlation,
        settings=settings,
        drivers=ctx.drivers,
        driver_names=ctx.driver_names,
    )


def event_columns(events, n):
    """One column per event: 1 from a step's first row to its test's end, or over a spike.

    Parameters
    ----------
    events : list of Event
    n : int

    Returns
    -------
    ndarray of shape (n, len(events))
    """
    out = np.zeros((n, len(events)))
    for j, event in enumerate(events):
        end = event.stop if event.last_row is None else event.last_row + 1
        out[event.row : end, j] = 1.0
    return out


def event_table(events):
    """The events as a table's columns (``EVENT_COLUMNS``), one entry per event."""
    return {name: [getattr(e, name) for e in events] for name in EVENT_COLUMNS}
