"""Inputs outside what training saw: each input's envelope, and the part of a row beyond it.

A model fitted on some tests has seen each input only within a range and
only changing so fast. Beyond that, a linear model of lags extrapolates, and
the interval calibrated on the training tests says nothing about it. The
*envelope* of an input is the record of what training saw: its lowest and
highest value and the largest rate of change (per hour) between two
consecutive rows of one test (or of a test and the one it carries on from),
over the rows with a positive weight.

For a sequence of rows, the *follower* x̃ of an input is the nearest signal to
it that never leaves the envelope:

    x̃_k = clip(x̃_{k−1} + clip(x_k − x̃_{k−1}, ±r·Δt_k), low, high),

starting at ``clip(x_0, low, high)`` at a test's first row (or carrying the
follower of the test before, for a test that carries its state), with ``r``
the largest rate per hour (and a part in 10⁹ more, so that the training
rows' own fastest change stays inside after rounding) and ``Δt_k`` the step
into row ``k`` in hours; it is computed as ``x_k`` clipped to
``[max(x̃_{k−1} − r·Δt_k, low), min(x̃_{k−1} + r·Δt_k, high)]``, so a row
inside the envelope has an excess of exactly 0. The
*excess* ``x − x̃`` is the part of the input that training never validated:
0 at every row inside the envelope, the distance beyond it outside (in the
input's own unit, signed).

Pure array functions (no validation, no estimator), and the record a fit
keeps: :class:`InputEnvelope`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "RATE_SLACK",
    "InputEnvelope",
    "envelope_of",
    "follow",
    "follow_step",
    "reach_of",
    "union",
]

#: The follower may move this share faster than the largest rate: the rate a
#: training pair defines, times the same step, may round below that pair's change.
RATE_SLACK = 1e-9


@dataclass(frozen=True)
class InputEnvelope:
    """What training saw of each input: its range and its fastest change.

    Attributes
    ----------
    names : tuple of str
        The inputs, in order.
    low, high : ndarray of shape (n_inputs,)
        The lowest and highest value of each input over the training rows
        with a positive weight (``low <= high``; equal for a constant input).
    max_rate_per_h : ndarray of shape (n_inputs,)
        The largest ``|x_k − x_{k−1}| / Δt_k`` (per hour) between two
        consecutive rows of one training test (or across into a test that
        carries the state of the one before), both with a positive weight
        (``>= 0``; 0 for a constant input, or a test of one row).

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.dynamic import InputEnvelope
    >>> env = InputEnvelope(("T1_C",), np.array([20.0]), np.array([25.0]), np.array([2.0]))
    >>> float(env.high[0] - env.low[0])
    5.0
    """

    names: tuple
    low: np.ndarray
    high: np.ndarray
    max_rate_per_h: np.ndarray

    def check(self, owner):
        """This envelope with its numbers checked, or one ValueError naming what is wrong.

        ``owner`` names the object that holds it, for the message.
        """
        try:
            names = tuple(str(v) for v in self.names)
            low, high, rate = (
                np.asarray(v, dtype=float).reshape(-1)
                for v in (self.low, self.high, self.max_rate_per_h)
            )
        except (AttributeError, TypeError, ValueError):
            raise ValueError(
                f"{owner}: the input envelope must hold names, low, high and max_rate_per_h."
            ) from None
        n = len(names)
        if len(set(names)) != n or not (low.shape == high.shape == rate.shape == (n,)):
            raise ValueError(
                f"{owner}: the input envelope must hold one low, high and max_rate_per_h "
                f"per input, each input named once; it names {n} inputs."
            )
        for j, name in enumerate(names):
            lo, hi, r = low[j], high[j], rate[j]
            if not (np.isfinite(lo) and np.isfinite(hi) and np.isfinite(r)):
                raise ValueError(
                    f"{owner}: the input envelope of {name!r} holds a number that is not "
                    f"finite (low {lo!r}, high {hi!r}, max_rate_per_h {r!r})."
                )
            if lo > hi:
                raise ValueError(
                    f"{owner}: the input envelope of {name!r} has low {lo:g} above high {hi:g}."
                )
            if r < 0:
                raise ValueError(
                    f"{owner}: the input envelope of {name!r} has a negative "
                    f"max_rate_per_h ({r:g})."
                )
        return InputEnvelope(names, low.copy(), high.copy(), rate.copy())


def envelope_of(x, dt, bounds, weight, names, carry=False):
    """The :class:`InputEnvelope` of the columns of ``x`` over the rows of positive ``weight``.

    Parameters
    ----------
    x : ndarray of shape (n, p)
        The inputs, tests stacked in the order of ``bounds``.
    dt : ndarray of shape (n,)
        Step in seconds into each row (unused at a test's first row).
    bounds : sequence of (start, stop)
        Row ranges of the tests.
    weight : ndarray of shape (n,)
        A row's weight; only rows > 0 count (a rate, only between two of them).
    names : sequence of str
    carry : bool or sequence of bool, default=False
        Whether each test continues the one before it (as for :func:`follow`):
        the step from that test's last row into its first is then a change
        the training saw too (the first test's flag is ignored).

    Returns
    -------
    InputEnvelope
    """
    x = np.asarray(x, dtype=float)
    used = np.asarray(weight) > 0
    p = x.shape[1]
    low = np.full(p, np.inf)
    high = np.full(p, -np.inf)
    rate = np.zeros(p)
    links = np.broadcast_to(np.asarray(carry, dtype=bool), (len(bounds),))
    for i, (start, stop) in enumerate(bounds):
        if i > 0 and links[i] and stop > start and used[start] and used[start - 1]:
            change = np.abs(x[start] - x[start - 1]) / (dt[start] / 3600.0)
            rate = np.maximum(rate, change)
        rows = used[start:stop]
        if rows.any():
            low = np.minimum(low, x[start:stop][rows].min(axis=0))
            high = np.maximum(high, x[start:stop][rows].max(axis=0))
        pairs = rows[1:] & rows[:-1]
        if pairs.any():
            step_h = dt[start + 1 : stop][pairs] / 3600.0
            change = np.abs(np.diff(x[start:stop], axis=0))[pairs]
            rate = np.maximum(rate, (change / step_h[:, None]).max(axis=0))
    return InputEnvelope(tuple(str(v) for v in names), low, high, rate)


def union(first, second):
    """The envelope of what ``first`` and ``second`` (over the same inputs) saw together."""
    return InputEnvelope(
        first.names,
        np.minimum(first.low, second.low),
        np.maximum(first.high, second.high),
        np.maximum(first.max_rate_per_h, second.max_rate_per_h),
    )


def reach_of(max_rate_per_h, step_s):
    """How far the follower may move in a step of ``step_s`` seconds: the largest rate
    times the step, and :data:`RATE_SLACK` more."""
    return max_rate_per_h * (step_s / 3600.0) * (1.0 + RATE_SLACK)


def follow_step(previous, x, reach, low, high):
    """One row of the follower: ``x`` within ``reach`` of ``previous`` and within
    ``[low, high]``, the nearest such value (``previous`` None: a test without
    history, ``x`` within ``[low, high]``).

    Since ``previous`` lies in ``[low, high]``, this is ``previous`` moved towards
    ``x`` by at most ``reach``, then clipped to the range; a value inside both
    bounds is ``x`` itself, bit for bit. Arrays of shape (p,) in and out; the one
    update every caller uses (:func:`follow`, :class:`greyml.Compensator`).
    """
    if previous is None:
        return np.minimum(np.maximum(x, low), high)
    lower = np.maximum(previous - reach, low)
    upper = np.minimum(previous + reach, high)
    return np.minimum(np.maximum(x, lower), upper)


def follow(x, dt, bounds, envelope, carry=False):
    """The follower x̃ of every column of ``x`` (see the module), test by test.

    Parameters
    ----------
    x : ndarray of shape (n, p)
        The inputs, in the order of the envelope's names.
    dt : ndarray of shape (n,)
        Step in seconds into each row.
    bounds : sequence of (start, stop)
    envelope : InputEnvelope
    carry : bool or sequence of bool, default=False
        Whether each test continues the follower the test before left
        (stepping by ``dt`` at its first row); the first test's flag is ignored.

    Returns
    -------
    followed : ndarray of shape (n, p)
        The follower; ``x - followed`` is the excess.
    """
    x = np.asarray(x, dtype=float)
    n, p = x.shape
    links = np.broadcast_to(np.asarray(carry, dtype=bool), (len(bounds),))
    fresh = np.zeros(n, dtype=bool)  # a row where the follower starts without history
    for i, (start, stop) in enumerate(bounds):
        if stop > start and (i == 0 or not links[i]):
            fresh[start] = True
    reach = reach_of(envelope.max_rate_per_h[None, :], np.asarray(dt, dtype=float)[:, None])
    out = x.copy()
    for j in range(p):
        out[:, j] = _follow_column(x[:, j], reach[:, j], envelope.low[j], envelope.high[j], fresh)
    return out


def _follow_column(x, reach, low, high, fresh):
    """:func:`follow_step` down one column: vectorised while the follower equals the
    input, row by row from a row that leaves the envelope until it equals it again."""
    out = x.copy()
    previous = np.empty_like(x)
    previous[0], previous[1:] = np.nan, x[:-1]
    # the rows follow_step gives back as they are, if the row before was the input
    lower = np.maximum(previous - reach, low)
    upper = np.minimum(previous + reach, high)
    inside = np.where(fresh, (x >= low) & (x <= high), (x >= lower) & (x <= upper))
    leaving = np.flatnonzero(~inside)
    k, n = 0, x.size
    while k < leaving.size:
        i = int(leaving[k])
        state = None if fresh[i] else out[i - 1]
        while i < n:
            state = follow_step(None if fresh[i] else state, x[i], reach[i], low, high)
            out[i] = state
            i += 1
            if state == x[i - 1]:  # the follower is the input again
                break
        k = int(np.searchsorted(leaving, i))
    return out
