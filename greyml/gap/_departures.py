"""Where, in time, the gap departs from its test's own pattern: smooth transients located.

A located event (:mod:`greyml.gap._events`) is a change completed within the
step time, 2 minutes by default. A door left open for 20 minutes, a draught,
a coolant that warms for half an hour move the gap smoothly, over tens of
minutes, and come back slowly: never an event, and spread too thin over a
test for the breakdown by hour (:func:`~greyml.gap.gap_breakdown`) to say
when. A *departure* is such a transient, located in time:

- **the test's pattern** is the slow part of its gap: cubic B-splines with
  knots every ``PATTERN_KNOT_S`` (2 h; at least six rows apart), which a
  thermal gap of a few hours follows and a 20-minute transient does not;
- **a departure** leaves that pattern at a row, moves linearly for a rise
  time (10, 20 or 40 min: ``RISE_S``) and comes back exponentially, with a
  time constant of one or four rise times, or stays (the structure cools in
  minutes and warms back over hours). Every start row and shape is scanned
  in closed form against the pattern (the column's correlation with the
  residual and with an orthonormal basis of the pattern, by FFT);
- the best one is kept while its size exceeds ``DEPARTURE_Z`` standard
  errors, the noise counted with its row-to-row correlation as for events
  (:func:`~greyml.gap._noise.variance_inflation`); it then joins the
  pattern and the scan goes on, at most ``MAX_PER_TEST`` per test, starts
  at least a rise time apart;
- one whose rise holds a located event (within the step time) is that
  event, already reported, and is left out.

Each departure is reported by its test, its start (``start_s``, the first
row that leaves the pattern), the end of its rise (``peak_s``), when it is
back within a third of its size (``end_s``, or the test's last row) and its
size at the peak, in the target's unit. Rows every 15 s, 60 s or 5 min give
the same departures, to a row: the shapes are defined in seconds.

This is a matched filter (a scan statistic over start and shape, Naus
(1982); Siegmund and Venkatraman (1995)) on the residual of a regression
spline, as in change-point methods for a smooth signal (Truong, Oudre and
Vayatis (2020)).

Pure array functions (no pandas, no validation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import fftconvolve

from greyml.gap._event_search import _smooth_basis
from greyml.gap._noise import STEP_TIME_S, rows_per_step, variance_inflation

__all__ = [
    "DEPARTURE_COLUMNS",
    "DEPARTURE_Z",
    "Departure",
    "departure_table",
    "describe_departure",
    "locate_departures",
]

#: Knot spacing (s) of a test's slow pattern.
PATTERN_KNOT_S = 7200.0
#: Rise times (s) of the departures scanned.
RISE_S = (600.0, 1200.0, 2400.0)
#: Return time constants, in rise times (inf: the departure stays).
RETURN_RISES = (1.0, 4.0, np.inf)
#: Standard errors by which a departure's size must exceed zero.
DEPARTURE_Z = 8.0
#: Most departures located in one test.
MAX_PER_TEST = 3

#: The columns of the departures table of a report, in order.
DEPARTURE_COLUMNS = ["test", "start_s", "peak_s", "end_s", "size", "z"]


@dataclass(frozen=True)
class Departure:
    """A smooth transient of the gap in one test, located in time.

    Attributes
    ----------
    test : str
    start_s : float
        ``time_s`` of the first row that leaves the test's pattern.
    peak_s : float
        ``time_s`` at the end of its rise.
    end_s : float
        ``time_s`` at which it is back within a third of its size (the
        test's last row if it does not come back within the test).
    size : float
        Its height at the peak, in the target's unit (signed).
    z : float
        The size in standard errors.
    """

    test: str
    start_s: float
    peak_s: float
    end_s: float
    size: float
    z: float

    def describe(self):
        """The departure in one sentence (:func:`describe_departure`)."""
        return describe_departure({name: getattr(self, name) for name in DEPARTURE_COLUMNS})


def describe_departure(record):
    """One sentence for a departure given as a mapping of ``DEPARTURE_COLUMNS``.

    Examples
    --------
    >>> text = describe_departure({"test": "B", "start_s": 3600.0, "peak_s": 4800.0,
    ...                            "end_s": 9000.0, "size": -1.2, "z": 30.0})
    >>> text[:64]
    'Departure: test B from time_s=3600 to 9000, -1.2 at time_s=4800 '
    """
    return (
        f"Departure: test {record['test']} from time_s={record['start_s']:g} to "
        f"{record['end_s']:g}, {record['size']:+.3g} at time_s={record['peak_s']:g} (from the "
        "test's slow pattern)."
    )


def _shape(n, rise, back):
    """The shape from its start: up over ``rise`` rows, back with time constant ``back`` rows."""
    j = np.arange(n, dtype=float)
    up = np.minimum(j / rise, 1.0)
    if np.isfinite(back):
        up = np.where(j <= rise, up, np.exp(-(j - rise) / back))
    return up


def _scan(q, e, shape):
    """Size and residual norm² of the shape started at every row (closed form, by FFT).

    Column k is ``shape`` from row k on (0 before). With Q orthonormal and e
    the residual off it: num_k = e'c_k, den_k = c_k'c_k − |Q'c_k|².
    """
    n = e.size
    flipped = shape[::-1]
    # correlation: out[k] = Σ_i x[i]·shape[i−k] = conv(x, shape reversed)[k + n − 1]
    num = fftconvolve(e, flipped)[n - 1 : 2 * n - 1]
    qc = np.column_stack(
        [fftconvolve(q[:, j], flipped)[n - 1 : 2 * n - 1] for j in range(q.shape[1])]
    )
    own = np.cumsum(shape**2)[::-1]  # Σ_{j < n−k} shape[j]²
    den = own - np.einsum("ij,ij->i", qc, qc)
    return num, den, own


def _departures_in_test(x, t, dt, per_row, settings_rows, events):
    """The departures of one test: (start row, peak row, end row, size, z), in order found."""
    n = x.size
    basis = _smooth_basis(t, PATTERN_KNOT_S, dt)
    if basis.shape[1] >= n // 3:
        return []
    shapes = []
    for rise_s in RISE_S:
        rise = max(1, int(round(rise_s / dt)))
        if rise >= n // 3:
            continue
        for back in RETURN_RISES:
            shapes.append((rise, back * rise, _shape(n, rise, back * rise)))
    out, columns = [], []
    while len(out) < MAX_PER_TEST:
        design = np.column_stack([basis, *columns]) if columns else basis
        q, _ = np.linalg.qr(design)
        e = x - q @ (q.T @ x)
        best = None
        for rise, back, shape in shapes:
            num, den, own = _scan(q, e, shape)
            z = np.zeros(n)
            # a departure needs room for its rise, and must start after the first rows
            valid = np.arange(n) <= n - rise - 1
            valid[: max(2, settings_rows)] = False
            ok = valid & (den > 1e-6 * own)
            z[ok] = np.abs(num[ok]) / np.sqrt(den[ok]) / per_row
            for start, *_ in out:
                z[np.abs(np.arange(n) - start) < rise] = 0.0
            k = int(np.argmax(z))
            if z[k] > DEPARTURE_Z and (best is None or z[k] > best[0]):
                best = (z[k], k, rise, back, num[k] / den[k])
        if best is None:
            break
        z, k, rise, back, size = best
        column = np.zeros(n)
        column[k:] = _shape(n - k, rise, back)
        columns.append(column)
        tail = np.flatnonzero(column[k + rise :] < 1.0 / 3.0)
        end = k + rise + int(tail[0]) if tail.size else n - 1
        out.append((k, min(k + rise, n - 1), end, float(size), float(z)))
    near = max(1, settings_rows)
    return [d for d in out if not any(d[0] - near <= m <= d[1] + near for m in events)]


def locate_departures(
    r,
    bounds,
    times,
    dt,
    floor,
    *,
    labels=None,
    correlation=0.0,
    step_time_s=STEP_TIME_S,
    event_rows=(),
):
    """Smooth transients of ``r`` within each test, in time.

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
    correlation : float, default=0.0
        The noise's correlation from row to row.
    step_time_s : float, default=120
        The step time of the events: the noise's correlation is counted up to
        it, and a departure whose rise holds a located event (within it) is
        that event.
    event_rows : sequence of int
        Rows (in the stacked gap) of the located events.

    Returns
    -------
    list of Departure
        In test order, then time.

    Examples
    --------
    A 4-hour test read every minute; 0.05 µm of noise on a slow bend, and
    from 90 min a departure that falls by 1 µm over 20 min and comes back
    over an hour:

    >>> import numpy as np
    >>> t = np.arange(240) * 60.0
    >>> door = np.where(t < 5400, 0.0, np.minimum((t - 5400) / 1200, 1.0))
    >>> door = np.where(t > 6600, np.exp(-(t - 6600) / 3600), door)
    >>> r = 2 * (1 - np.exp(-t / 7200)) - door + np.random.default_rng(0).normal(0, 0.05, 240)
    >>> [(d.start_s, d.peak_s, round(d.size, 1))
    ...  for d in locate_departures(r, [(0, 240)], t, [60.0], 0.05)]
    [(5340.0, 6540.0, -1.0)]
    """
    out = []
    if not floor > 0:
        return out
    labels = list(labels) if labels is not None else [str(i) for i in range(len(bounds))]
    events = np.asarray(event_rows, dtype=int)
    for j, (start, stop) in enumerate(bounds):
        x, t = r[start:stop], times[start:stop]
        if x.size < 20:
            continue
        g = rows_per_step(dt[j], step_time_s)
        per_row = floor * np.sqrt(variance_inflation(correlation, g))
        own = events[(events >= start) & (events < stop)] - start
        for k, peak, end, size, z in sorted(_departures_in_test(x, t, dt[j], per_row, g, own)):
            out.append(
                Departure(
                    test=labels[j],
                    start_s=float(t[k]),
                    peak_s=float(t[peak]),
                    end_s=float(t[end]),
                    size=size,
                    z=z,
                )
            )
    return out


def departure_table(departures):
    """The departures as a table's columns (``DEPARTURE_COLUMNS``)."""
    return {name: [getattr(d, name) for d in departures] for name in DEPARTURE_COLUMNS}
