"""Located events in the gap: a step or a spike in one test (a probe knocked, a re-clamp).

Thermal effects change the gap smoothly; an event changes it abruptly. The
candidate change points of each test come from ``ruptures`` (binary
segmentation of the piecewise-constant mean, Truong et al. (2020)); each is
kept only if the gap jumps there: a straight line fitted to the samples just
before it and one fitted to the samples just after disagree, at the change
point, by more than ``z`` standard errors of the noise. A smooth thermal gap
bends the two lines little over a short window; a step or a spike separates
them by its size.

Pure array functions: no pandas, no validation.
"""

from __future__ import annotations

import numpy as np

__all__ = ["event_columns", "locate_events"]

#: Standard errors by which the two local lines must disagree at a change point.
EVENT_Z = 5.0
#: Samples of the windows on either side of a change point (clipped to the test).
_WINDOW = (10, 60)
#: Penalty of a change point in the segmentation, in noise variances × log(n).
_PEN = 3.0
#: At most this many events per test, the most significant kept: events are
#: rare (a probe knocked, a re-clamp); a recording whose noise floor is far
#: below its gap would otherwise turn every bend into an event, and every
#: event is a column of every fit that follows.
MAX_EVENTS_PER_TEST = 5


def _edge_value(y, at_end):
    """Value at the window's edge (next to the change point) of a line fitted to ``y``."""
    m = y.size
    x = np.arange(m, dtype=float)
    x -= x.mean()
    slope = (x @ (y - y.mean())) / (x @ x)
    edge = x[-1] + 0.5 if at_end else x[0] - 0.5
    return y.mean() + slope * edge, 1.0 / m + edge**2 / (x @ x)


def _jump(x, k, w):
    """Jump of ``x`` at ``k`` (between k−1 and k) from local lines; and its variance factor."""
    left, right = x[max(0, k - w) : k], x[k : k + w]
    if left.size < 3 or right.size < 3:
        return 0.0, np.inf
    a, va = _edge_value(left, True)
    b, vb = _edge_value(right, False)
    return b - a, va + vb


def locate_events(r, bounds, sigma, *, z=EVENT_Z):
    """Abrupt steps and spikes of ``r`` within each test.

    Parameters
    ----------
    r : ndarray of shape (n,)
        The gap (or what is left of it), tests stacked in ``bounds`` order.
    bounds : sequence of (start, stop)
    sigma : float
        The white-noise level of ``r`` (its noise floor).
    z : float, default=5
        Standard errors by which the local lines must disagree.

    Returns
    -------
    events : list of (test index, first row of the event, size, last row or None)
        ``size`` is the step's height (the spike's height for a spike, whose
        last row is then given; None for a step), in the unit of ``r``.
    """
    import ruptures as rpt

    out = []
    if not sigma > 0:
        return out
    for t, (start, stop) in enumerate(bounds):
        x = r[start:stop]
        n = x.size
        if n < 20:
            continue
        w = int(np.clip(n // 5, *_WINDOW))
        jump = 1
        algo = rpt.KernelCPD(kernel="linear", min_size=2).fit(x - x.mean())
        found = algo.predict(pen=_PEN * sigma**2 * np.log(n))[:-1]
        kept = []
        for k in found:
            # refine on the fine grid: the sample where the local lines disagree most
            lo, hi = max(3, k - jump - 2), min(n - 3, k + jump + 2)
            best = max(range(lo, hi + 1), key=lambda j: abs(_jump(x, j, w)[0]), default=k)
            size, var = _jump(x, best, w)
            if np.isfinite(var) and abs(size) > z * sigma * np.sqrt(var):
                kept.append((best, size, abs(size) / np.sqrt(var)))
        kept.sort(key=lambda e: -e[2])
        kept = sorted(dict((k, size) for k, size, _ in kept[:MAX_EVENTS_PER_TEST]).items())
        # two opposite jumps closer than a window: one spike
        i = 0
        while i < len(kept):
            k, size = kept[i]
            if i + 1 < len(kept):
                k2, size2 = kept[i + 1]
                if k2 - k < w and np.sign(size2) == -np.sign(size):
                    out.append((t, start + k, 0.5 * (size - size2), start + k2 - 1))
                    i += 2
                    continue
            # the same jump found twice a few samples apart: keep the first
            if out and out[-1][0] == t and start + k - out[-1][1] < w and out[-1][3] is None:
                i += 1
                continue
            out.append((t, start + k, size, None))
            i += 1
    return out


def event_columns(events, n):
    """One column per event: 1 from a step's first row to its test's end, or over a spike.

    Parameters
    ----------
    events : list from :func:`locate_events`, with each test's stop appended
        as a fifth item.
    n : int

    Returns
    -------
    ndarray of shape (n, len(events))
    """
    out = np.zeros((n, len(events)))
    for j, (_, first, _, last, stop) in enumerate(events):
        out[first : (stop if last is None else last + 1), j] = 1.0
    return out
