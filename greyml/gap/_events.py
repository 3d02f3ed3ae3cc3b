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
  speed changes), not a knock;
- every other event is then tested against the logged inputs (the ambient
  air, the sensors, the drivers): an event is a change the measured inputs
  do not explain. Around its leading edge (``FOLLOW_S`` = 4 min either
  side, at least ``FOLLOW_ROWS`` rows), the gap is fitted with a local
  quadratic and the event's column, then with one input instead, raw or
  through a first-order lag of 30 s to 8 min (as read, or one row late).
  An input that swings near the event (its change over 4 min there is at
  least twice its median over the test), fits about as well as the event's
  column (within one noise variance; any fit when the event explains less
  than z² noise variances over the local quadratic: a ramp, not a step),
  leaves the event's column less than ``z`` standard errors to add, and
  accounts for at least half of the event's size with its sign is the one
  the event **follows** (``follows``, ``follows_lag_s``; the one that fits
  best when several do): a thermal response to a change of the air or of a
  temperature (a door, the air conditioning cycling) that the simulation
  lacks, not a knock (:func:`follows_input`).

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
from greyml.gap._effects import lag_bank
from greyml.gap._event_search import steps_in_test
from greyml.gap._noise import STEP_TIME_S, rows_per_step, variance_inflation

__all__ = [
    "DRIVER_WINDOW_S",
    "EVENT_Z",
    "EVENT_COLUMNS",
    "FOLLOW_S",
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
#: An event is tested against the logged inputs this many seconds either side of it.
FOLLOW_S = 240.0
#: Fewest rows either side of an event in its test against the inputs.
FOLLOW_ROWS = 10
#: Time constants (s) of the lags through which an event may follow an input (0: raw).
FOLLOW_TAUS_S = (0.0, 30.0, 60.0, 120.0, 240.0, 480.0)
#: An input must fit the gap around an event within this many noise standard
#: errors (in sum of squares: FIT_SLACK² noise variances) of the event's column.
FIT_SLACK = 1.0
#: Share of an event's size that an input must account for to be the one it follows.
_FOLLOW_SHARE = 0.5
#: An input swings near an event when its change over FOLLOW_S there is this
#: many times its median change over FOLLOW_S in the test.
SWING = 2.0

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
    "follows",
    "follows_lag_s",
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
    follows : str or None
        The logged input (ambient, sensor or driver) whose change within
        ``FOLLOW_S`` explains the event: a thermal response, not a knock.
    follows_lag_s : float or None
        The time constant (s) of the first-order lag through which the gap
        follows it (0: at once).
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
    follows: str | None = None
    follows_lag_s: float | None = None
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
    follows = record.get("follows")
    if not _missing(follows):
        lag = record.get("follows_lag_s")
        through = "at once" if _missing(lag) or not lag > 0 else f"through a lag of {lag:g} s"
        also = ""
        if not _missing(driver):
            also = (
                f" It came {_change_words(driver)} too ({record['driver_before']:g} -> "
                f"{record['driver_after']:g} at time_s={record['driver_change_s']:g})."
            )
        return (
            f"{head}, following a change of {follows} within {FOLLOW_S / 60:g} min ({through}): "
            f"a thermal response to a logged input that the simulation lacks, not a knock.{also}"
        )
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
    inputs=None,
    input_names=(),
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
    inputs : ndarray of shape (n, p), optional
        Logged inputs (ambient, sensors, drivers) that an event not at a
        driver's switch is tested against (:func:`follows_input`).
    input_names : sequence of str

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
    lagged = None
    if inputs is not None and np.shape(inputs)[1]:
        lagged = _lagged_inputs(np.asarray(inputs, dtype=float), dt, bounds)
        is_driver = np.array([name in driver_names for name in input_names], dtype=bool)
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
            # the leading edge against the logged temperatures (and the drivers
            # when it is at no driver's switch: a speed change moves a probe at
            # once, which is no thermal response); then the switches
            hit = _at_switch(edges[:1], times, start, stop, switches, tolerance)
            found = None
            if lagged is not None:
                inflation = variance_inflation(
                    correlation, rows_per_step(dt[j], settings.step_time_s)
                )
                per_row = floor * np.sqrt(inflation)
                usable = ~is_driver if hit is not None else None
                found = follows_input(
                    x, m, lagged[start:stop], dt[j], per_row, settings.z, usable=usable
                )
            if hit is None and found is None:
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
            if found is not None:
                extra.update(follows=input_names[found[0]], follows_lag_s=found[1])
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


def _lagged_inputs(inputs, dt, bounds):
    """The inputs through every lag of ``FOLLOW_TAUS_S`` (0: raw), as read and one row late.

    Shape (n, p, 2·len(taus)): first the lags of the inputs as read, then
    those of the inputs one row later (the previous row's value, the first
    row kept), since a reading taken as the air changes shows the change
    before the structure has moved.
    """
    late = inputs.copy()
    for start, stop in bounds:
        late[start + 1 : stop] = inputs[start : stop - 1]
    taus = [tau for tau in FOLLOW_TAUS_S if tau > 0]
    k = len(FOLLOW_TAUS_S)
    out = np.empty((len(inputs), inputs.shape[1], 2 * k))
    for offset, x in ((0, inputs), (k, late)):
        out[:, :, offset] = x
        out[:, :, offset + 1 : offset + k] = lag_bank(x, taus, dt, bounds)
    return out


def _swings(inputs, lo, hi, dt):
    """Which inputs swing in rows ``lo`` to ``hi``: a change over ``FOLLOW_S`` that stands out.

    The change of an input over ``FOLLOW_S`` (2 min either side of a row)
    anywhere in the rows must be at least ``SWING`` times its median over the
    test: a door, the air conditioning switching, a spindle started; not the
    slow daily swing of the air, which changes alike everywhere.
    """
    h = max(1, int(round(0.5 * FOLLOW_S / dt)))
    n = len(inputs)
    if n <= 2 * h:
        return np.zeros(inputs.shape[1], dtype=bool)
    change = np.abs(inputs[2 * h :] - inputs[: -2 * h])  # centred at rows h .. n−h−1
    typical = np.median(change, axis=0)
    near = change[max(0, lo - h) : max(0, min(n - 2 * h, hi - h))]
    if not len(near):
        return np.zeros(inputs.shape[1], dtype=bool)
    largest = near.max(axis=0)
    return (largest > 0) & (largest >= SWING * typical)


def follows_input(x, first, lagged, dt, per_row, z, *, usable=None):
    """The input an event of one test follows, and through which lag: (column, tau_s) or None.

    Around the event (``FOLLOW_S`` either side of its first row, at least
    five rows), ``x`` is fitted with a quadratic in time and the event's
    column (a step at row ``first``; a spike is tested by its leading edge,
    since the gap left where the input swung), then with one input of
    ``lagged`` instead. The event follows the input when all of these hold:

    - the input swings near the event: its change over ``FOLLOW_S``
      somewhere within ``FOLLOW_S`` of the event is at least ``SWING``
      times its median over the test (a slow, even change makes no step);
    - the input fits the gap there within ``FIT_SLACK``² noise variances of
      the event's column, or the event is not abrupt there (its column
      explains less than z² noise variances over the local quadratic: a
      ramp that the spline of the whole test took for a step);
    - with the input, the event's column adds less than ``z`` standard
      errors (the sum of squares it explains, given the quadratic and the
      input, is under z² noise variances: an input that steps with the
      event leaves it nothing);
    - the input's fitted part, regressed on the quadratic and the event's
      column, accounts for at least half of the event's size, with its sign.

    Of the inputs that pass, the one that leaves the least is returned.

    Parameters
    ----------
    x : ndarray of shape (n,)
        One test's gap.
    first : int
        The event's first row in the test.
    lagged : ndarray of shape (n, p, k)
        The test's inputs through the lags of ``FOLLOW_TAUS_S``, the first
        column raw (then any number of variants, the lag of column i being
        ``FOLLOW_TAUS_S[i % len(FOLLOW_TAUS_S)]``).
    dt : float
        The test's sampling interval (s).
    per_row : float
        The noise's standard deviation per row, its correlation counted.
    z : float
    usable : ndarray of bool of shape (p,), optional
        The inputs that may be followed (all by default).

    Returns
    -------
    tuple of (int, float) or None

    Examples
    --------
    The gap steps by 1 where the air steps by 2 °C; a sensor that stays
    still does not explain it, the air does:

    >>> import numpy as np
    >>> t = np.arange(60) * 15.0
    >>> air = 20.0 - 2.0 * (t >= 450)
    >>> still = 25.0 + 0.01 * np.sin(t / 100)
    >>> x = 0.5 * (air - 20.0) + np.random.default_rng(0).normal(0, 0.02, 60)
    >>> lagged = np.stack([np.column_stack([still, air])] * 6, axis=2)
    >>> follows_input(x, 30, lagged, 15.0, 0.02, 5.0)
    (1, 0.0)
    """
    n = x.size
    reach = max(FOLLOW_ROWS, int(np.ceil(FOLLOW_S / dt)))
    lo, hi = max(0, first - reach), min(n, first + 1 + reach)
    rows = np.arange(lo, hi)
    event = (rows >= first).astype(float)
    span = max(float(rows[-1] - rows[0]), 1.0)
    u = (rows - rows[0]) / span
    base = np.column_stack([np.ones(rows.size), u, u * u][: 3 if rows.size >= 12 else 2])
    y = x[lo:hi]
    k = base.shape[1]
    design = np.column_stack([base, event])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    size = coef[k]
    if not abs(size) > 0:
        return None
    as_event = float(np.sum((y - design @ coef) ** 2))
    scale = float(np.sum((y - y.mean()) ** 2))
    # not abrupt where it stands: the event's column explains less than z²
    # noise variances over the local quadratic (a ramp the spline of the
    # whole test took for a step); any swinging input that fits it is followed
    gain0, *_ = np.linalg.lstsq(base, y, rcond=None)
    smooth = np.sqrt(max(float(np.sum((y - base @ gain0) ** 2)) - as_event, 0.0)) / per_row < z
    near = max(1, int(np.ceil(FOLLOW_S / dt)))
    swings = _swings(lagged[:, :, 0], max(0, first - near), min(n, first + 1 + near), dt)
    if usable is not None:
        swings = swings & usable
    best = None
    for j in np.flatnonzero(swings):
        for i in range(lagged.shape[2]):
            tau = FOLLOW_TAUS_S[i % len(FOLLOW_TAUS_S)]
            v = lagged[lo:hi, j, i]
            if not np.ptp(v) > 0:
                continue
            # the event's column given the input: what it adds, in noise standard
            # errors (a difference of fits, so an input that steps with the event
            # leaves it nothing to add)
            alone = np.column_stack([base, v])
            gain, *_ = np.linalg.lstsq(alone, y, rcond=None)
            left = float(np.sum((y - alone @ gain) ** 2))
            # the event's column fits clearly better: not the input
            if not smooth and left > as_event + (FIT_SLACK * per_row) ** 2 + 1e-9 * scale:
                continue
            both = np.column_stack([alone, event])
            coef, *_ = np.linalg.lstsq(both, y, rcond=None)
            adds = max(left - float(np.sum((y - both @ coef) ** 2)), 0.0)
            if np.sqrt(adds) / per_row >= z:
                continue
            # how much of the event the input's fitted part accounts for
            explained, *_ = np.linalg.lstsq(
                np.column_stack([base, event]), gain[-1] * v, rcond=None
            )
            if not explained[k] / size >= _FOLLOW_SHARE:
                continue
            if best is None or left < best[0]:
                best = (left, int(j), float(tau))
    return None if best is None else (best[1], best[2])


def events_in(ctx, gap, noise, settings):
    """:func:`locate_events` on the gap ``gap`` of a :class:`GapContext`, with its drivers.

    Events not at a driver's switch are tested against the ambient, the
    sensors and the drivers (:func:`follows_input`).
    """
    names, columns = [], []
    if ctx.ambient is not None:
        names.append(ctx.ambient_name)
        columns.append(ctx.ambient[:, None])
    names += list(ctx.sensor_names) + list(ctx.driver_names)
    columns += [ctx.sensors, ctx.drivers]
    inputs = np.column_stack(columns) if names else None
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
        inputs=inputs,
        input_names=names,
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
