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
  step time) is kept while its size, less one quantum of the readings,
  exceeds ``z`` standard errors; while no two bends near it explain as
  much; and while no slower change (a ramp twice or four times as long, or
  a bend, placed over it) fits clearly better and leaves no abrupt part on
  top of it. At rows further apart than the step time, a change between two
  rows is a step as far as the rows can tell;
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
from greyml.gap._noise import STEP_TIME_S, rows_per_step, variance_inflation

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
#: Standard errors by which the part of a step completed within the step
#: time must exceed the best slower ramp placed over it.
ABRUPT_Z = 3.0
#: Standard errors beyond which a bend is added to the smooth part of a test.
BEND_Z = 3.0
#: At most this many bends per test (the switches of heat sources).
MAX_BENDS_PER_TEST = 12
#: Fewest step times between two bends.
BEND_APART = 4
#: At most this many events per test, the most significant kept: events are
#: rare (a probe knocked, a re-clamp); a recording whose noise floor is far
#: below its gap would otherwise turn every bend into an event, and every
#: event is a column of every fit that follows.
MAX_EVENTS_PER_TEST = 5
#: Knot spacing of the smooth gap, in step times.
KNOTS_PER_STEP_TIME = 10
#: Fewest rows between two knots of the smooth gap.
MIN_ROWS_PER_KNOT = 6
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


def _smooth_basis(t, knot_s, dt):
    """Cubic B-splines on ``t`` with knots about ``knot_s`` apart (at least six rows)."""
    from scipy.interpolate import BSpline

    span = float(t[-1] - t[0])
    spacing = max(knot_s, MIN_ROWS_PER_KNOT * dt)
    intervals = max(1, int(round(span / spacing)))
    intervals = min(intervals, max(1, t.size // 4 - 3))
    edges = np.linspace(t[0], t[-1], intervals + 1)
    knots = np.r_[[edges[0]] * 3, edges, [edges[-1]] * 3]
    return BSpline.design_matrix(t, knots, 3).toarray()


def _ramp(n, k, g):
    """The step column that rises linearly from row k−g (0) to row k (1) and stays."""
    return np.clip((np.arange(n) - (k - g)) / g, 0.0, 1.0)


def _project(x, design):
    """An orthonormal basis Q of ``design`` and the residual of ``x`` off it."""
    q, _ = np.linalg.qr(design)
    return q, x - q @ (q.T @ x)


def _scan(q, e, g, lo, hi):
    """Size and residual norm² of a ramp ending at every row k in [lo, hi).

    Closed form: with Q an orthonormal basis of the design and e the
    residual, the ramp h_k (the mean of the Heaviside columns H_k … H_{k−g+1})
    has Q'h_k and e'h_k from running sums of Q and e.
    """
    n = e.size
    tail_q = np.cumsum(q[::-1], axis=0)[::-1]  # tail_q[m] = Σ_{i≥m} Q[i] = Q'H_m
    tail_e = np.cumsum(e[::-1])[::-1]
    run_q = np.vstack([np.zeros((1, q.shape[1])), np.cumsum(tail_q, axis=0)])
    run_e = np.r_[0.0, np.cumsum(tail_e)]
    k = np.arange(lo, hi)
    qh = (run_q[k + 1] - run_q[k - g + 1]) / g
    num = (run_e[k + 1] - run_e[k - g + 1]) / g
    hh = (n - k) + (g - 1) * (2 * g - 1) / (6.0 * g)
    den = hh - np.einsum("ij,ij->i", qh, qh)
    ok = den > 1e-9 * hh
    size = np.where(ok, num / np.where(ok, den, 1.0), 0.0)
    return k, size, np.where(ok, den, np.inf)


def _gains(q, e, width, lo, hi):
    """Rows k, and the gain (size² × residual norm²) of a ramp of ``width`` ending at each."""
    if hi <= lo:
        return np.zeros(0, dtype=int), np.zeros(0)
    k, size, den = _scan(q, e, width, lo, hi)
    finite = np.isfinite(den)
    return k, np.where(finite, size**2 * np.where(finite, den, 0.0), 0.0)


def _most(k, gain, first, last):
    """The largest ``gain`` of the ramps ending at rows ``first`` to ``last``."""
    inside = (k >= first) & (k <= last)
    return float(gain[inside].max()) if inside.any() else 0.0


def _refine(x, design, k, g):
    """The Heaviside row in (k−g, k] that fits best given ``design``: where the step is."""
    if g == 1:
        return k
    m, gain = _gains(*_project(x, design), 1, k - g + 1, k + 1)
    return int(m[np.argmax(gain)])


def _scan_bends(q, e, lo, hi):
    """Gain of a bend at every row j in [lo, hi) given the design (closed form, like _scan)."""
    n = e.size
    tail_q = np.cumsum(q[::-1], axis=0)[::-1]
    tail_e = np.cumsum(e[::-1])[::-1]
    # the bend at j is the sum of the Heaviside columns H_{j+1} … H_{n−1}
    bend_q = np.cumsum(tail_q[::-1], axis=0)[::-1]
    bend_e = np.cumsum(tail_e[::-1])[::-1]
    j = np.arange(lo, hi)
    qh, num = bend_q[j + 1], bend_e[j + 1]
    length = n - 1 - j
    hh = length * (length + 1) * (2 * length + 1) / 6.0
    den = hh - np.einsum("ij,ij->i", qh, qh)
    ok = den > 1e-9 * hh
    return j, np.where(ok, num**2 / np.where(ok, den, 1.0), 0.0)


def _smoother(q, e, j, gain, kb, g, reach, lo, hi):
    """The first of the two bends within ``reach`` rows of row ``kb`` that explain most.

    Returns (row of the first bend, gain of both), or None. The second is
    sought given the first, at least ``BEND_APART`` step times away from it.
    """
    near = np.abs(j - kb) <= reach
    if not near.any():
        return None
    first = int(j[np.argmax(np.where(near, gain, -np.inf))])
    total = float(gain[j == first][0])
    column = _hinge(e.size, first)
    column = column - q @ (q.T @ column)
    norm = np.sqrt(column @ column)
    if norm > 0:
        q2 = np.column_stack([q, column / norm])
        e2 = e - q2[:, -1] * (q2[:, -1] @ e)
        j2, gain2 = _scan_bends(q2, e2, lo, hi)
        ok = (np.abs(j2 - kb) <= reach) & (np.abs(j2 - first) >= BEND_APART * g)
        if ok.any():
            total += float(np.max(gain2[ok]))
    return first, total


def _greedy(x, basis, g, dt, lo, hi, per_row, quantum, settings, masked):
    """Steps (ramp ends) and bends of the smooth part, the most significant first.

    Each round adds the best step or the best bend, whichever explains more:
    a bend (the start of a thermal response, where a heat source switched)
    belongs to the smooth gap and is never an event; a step is one when it
    passes ``settings.z`` and no two bends within half a knot spacing of it
    explain nearly as much (within ``ABRUPT_Z``² noise variances): the
    smooth explanation (two heat-source switches, an on and an off) is
    preferred. Bends are at least ``BEND_APART`` step times apart, so that
    two of them cannot pass for a step. Steps are not sought at ``masked``
    rows.
    """
    n = x.size
    reach = max(1, int(round(0.5 * _knot(settings, dt) / dt)))
    ramps, bends = [], []
    while len(ramps) < MAX_EVENTS_PER_TEST:
        columns = [_step_column(n, s, g) for s in ramps] + [_hinge(n, j) for j in bends]
        q, e = _project(x, np.column_stack([basis, *columns]))
        k, size, den = _scan(q, e, g, lo, hi)
        finite = np.isfinite(den) & ~masked[k]
        score = np.full(size.shape, -np.inf)
        score[finite] = (np.abs(size[finite]) - quantum) * np.sqrt(den[finite]) / per_row
        for chosen, _ in ramps:
            score[np.abs(k - chosen) <= g] = -np.inf
        best = int(np.argmax(score))
        step_gain = size[best] ** 2 * den[best] if np.isfinite(score[best]) else 0.0
        if len(bends) < MAX_BENDS_PER_TEST:
            j, gain = _scan_bends(q, e, lo, hi)
            for chosen in bends:
                gain[np.abs(j - chosen) < BEND_APART * g] = 0.0
            bend = int(np.argmax(gain))
            if gain[bend] > max(step_gain, (BEND_Z * per_row) ** 2):
                bends.append(int(j[bend]))
                continue
            if score[best] > settings.z:
                local = _smoother(q, e, j, gain, int(k[best]), g, reach, lo, hi)
                if local is not None and local[1] >= step_gain:
                    bends.append(local[0])
                    continue
        if not score[best] > settings.z:
            break
        kb = int(k[best])
        # a jump between two rows, if it fits better than the ramp: a step
        # completed within one row is not left half explained
        rows, jumps = _gains(q, e, 1, kb - g + 1, kb + 1)
        jump = int(rows[np.argmax(jumps)]) if rows.size else kb
        ramps.append((kb, jump if rows.size and jumps.max() >= step_gain else None))
    return ramps, bends


def _step_column(n, step, g):
    """The column of a located step: its jump between two rows, or its ramp."""
    end, jump = step
    if jump is not None:
        return (np.arange(n) >= jump).astype(float)
    return _ramp(n, end, g)


def _hinge(n, j):
    """The column of a bend at row j: 0 before it, rising by one per row after it."""
    return np.clip(np.arange(n, dtype=float) - j, 0.0, None)


def _column_gains(q, e, columns):
    """Least-squares gain of each column of ``columns`` added alone to the design."""
    proj = q.T @ columns
    den = np.einsum("ij,ij->j", columns, columns) - np.einsum("ij,ij->j", proj, proj)
    ok = den > 1e-9 * np.einsum("ij,ij->j", columns, columns)
    num = e @ columns
    return np.where(ok, num**2 / np.where(ok, den, 1.0), 0.0)


def _gradual(x, basis, ramps, g, widths, edge, hi, per_row, quantum):
    """The ramps of ``ramps`` that a smooth change explains better, given the rest.

    For each step, the best of its slow alternatives placed over it (a ramp
    twice or four times as long; a bend, the start of a thermal response,
    within four step times) competes with the best jump between two rows or
    ramp of the step time. The step is taken for a smooth change when the
    alternative fits better by more than ``ABRUPT_Z``² noise variances
    (evidence of smoothness) and, added to the rest, leaves less than
    ``ABRUPT_Z`` standard errors (less one quantum) for a jump on top of it
    (no abrupt part). A clean step stays a step however few rows it has to
    show it; a slow drop or a bend is not one; a jump followed by a slower
    drift (a spindle stopping) keeps its jump.
    """
    n = x.size
    out = []
    for i, (kb, _) in enumerate(ramps):
        others = [_step_column(n, r, g) for j, r in enumerate(ramps) if j != i]
        base = np.column_stack([basis, *others])
        q, e = _project(x, base)
        narrow = max(
            _most(*_gains(q, e, v, v + edge - 1, hi), kb - g, kb + g) for v in sorted({1, g})
        )
        alternatives = []
        for w in widths:
            kw, gw = _gains(q, e, w, w + edge - 1, hi)
            inside = (kw >= kb - g) & (kw <= kb + w)
            if inside.any():
                best = int(np.argmax(np.where(inside, gw, -np.inf)))
                alternatives.append((gw[best], _ramp(n, int(kw[best]), w)))
        bends = np.arange(max(1, kb - 4 * g), min(n - edge, kb + 4 * g) + 1)
        if bends.size:
            columns = np.column_stack([_hinge(n, j) for j in bends])
            gains = _column_gains(q, e, columns)
            best = int(np.argmax(gains))
            alternatives.append((gains[best], columns[:, best]))
        for gain, column in sorted(alternatives, key=lambda a: -a[0]):
            if gain - narrow <= (ABRUPT_Z * per_row) ** 2:
                break
            q2, e2 = _project(x, np.column_stack([base, column]))
            z = max(
                _abrupt_z(q2, e2, v, kb - g, kb + g, edge, hi, per_row, quantum)
                for v in sorted({1, g})
            )
            if not z > ABRUPT_Z:
                out.append(kb)
                break
    return out


def _abrupt_z(q, e, width, first, last, edge, hi, per_row, quantum):
    """The largest z of a ramp of ``width`` ending at rows ``first`` to ``last``."""
    lo = max(first, width + edge - 1)
    if min(last + 1, hi) <= lo:
        return -np.inf
    _, size, den = _scan(q, e, width, lo, min(last + 1, hi))
    finite = np.isfinite(den)
    if not finite.any():
        return -np.inf
    return float(np.max((np.abs(size[finite]) - quantum) * np.sqrt(den[finite]) / per_row))


def _steps_in_test(x, t, dt, floor, quantum, correlation, settings):
    """Rows, sizes and z of the steps of one test (most significant first, then refitted)."""
    n = x.size
    g = rows_per_step(dt, settings.step_time_s)
    # the noise's own correlation, within a step time, widens every fit's error
    per_row = floor * np.sqrt(variance_inflation(correlation, g))
    basis = _smooth_basis(t, settings.knot_s, dt)
    edge = max(3, g)
    lo, hi = g + edge - 1, n - edge + 1
    if hi <= lo or basis.shape[1] >= n - 2 * edge:
        return []
    widths = [w for w in (2 * g, 4 * g) if w + edge - 1 < hi]
    masked = np.zeros(n + 1, dtype=bool)
    smooth = basis
    for _ in range(MAX_EVENTS_PER_TEST):
        ramps, bends = _greedy(x, basis, g, dt, lo, hi, per_row, quantum, settings, masked)
        smooth = np.column_stack([basis] + [_hinge(n, j) for j in bends])
        # a change that takes longer than the step time is not a step: leave
        # it (and its neighbours) out, and look again without it
        slow = _gradual(x, smooth, ramps, g, widths, edge, hi, per_row, quantum)
        if not slow:
            break
        for kb in slow:
            masked[max(0, kb - 4 * g) : kb + 4 * g + 1] = True
    else:
        ramps = [r for r in ramps if r[0] not in slow]
    basis = smooth
    rows = []
    for i, (k, jump) in enumerate(ramps):
        if jump is not None:
            rows.append(jump)
            continue
        others = [_step_column(n, r, g) for j, r in enumerate(ramps) if j != i]
        rows.append(_refine(x, np.column_stack([basis, *others]), k, g))
    # the joint fit: drop the weakest step until every one holds
    while rows:
        steps = np.column_stack([(np.arange(n) >= m).astype(float) for m in rows])
        design = np.column_stack([basis, steps])
        coef, *_ = np.linalg.lstsq(design, x, rcond=None)
        cov = np.linalg.pinv(design.T @ design)
        sizes = coef[basis.shape[1] :]
        se = per_row * np.sqrt(np.diag(cov)[basis.shape[1] :])
        z = (np.abs(sizes) - quantum) / se
        weakest = int(np.argmin(z))
        if z[weakest] > settings.z:
            return sorted(zip(rows, sizes.tolist(), z.tolist()))
        rows.pop(weakest)
    return []


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
            steps = _steps_in_test(x, t, dt[j], floor, quantum, correlation, settings)
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


def _knot(settings, dt):
    return max(settings.knot_s, MIN_ROWS_PER_KNOT * dt)


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
