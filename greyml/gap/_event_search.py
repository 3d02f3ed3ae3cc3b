"""The search for steps in one test: the smooth part, the scans, and the tests of abruptness.

The kernels of :mod:`greyml.gap._events` (which states the method): the
smooth part of a test is a cubic spline plus bends; steps (ramps completed
within the step time) and bends are scanned at every row in closed form
from running sums of an orthonormal basis of the design and of the
residual, added one at a time (where a step time holds one row, a spike's
two edges also as one), and each step is tested against the slower changes
that could stand for it. Pure array functions; ``settings`` is an
:class:`~greyml.gap._events.EventSettings`.
"""

from __future__ import annotations

import numpy as np

from greyml.gap._noise import rows_per_step, variance_inflation

__all__ = ["MAX_EVENTS_PER_TEST", "knot_spacing", "steps_in_test"]

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
#: Fewest rows between two knots of the smooth gap.
MIN_ROWS_PER_KNOT = 6


def knot_spacing(settings, dt):
    """Knot spacing (s) of the smooth part at rows ``dt`` apart: at least six rows."""
    return max(settings.knot_s, MIN_ROWS_PER_KNOT * dt)


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


def _fit_gain(size, den):
    """Least-squares gain size² × residual norm², 0 where a column has no residual."""
    finite = np.isfinite(den)
    return np.where(finite, size**2 * np.where(finite, den, 0.0), 0.0)


def _gains(q, e, width, lo, hi):
    """Rows k, and the gain (size² × residual norm²) of a ramp of ``width`` ending at each."""
    if hi <= lo:
        return np.zeros(0, dtype=int), np.zeros(0)
    k, size, den = _scan(q, e, width, lo, hi)
    return k, _fit_gain(size, den)


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
    rows. Where a step time holds one row (``g == 1``), a spike of whole
    rows (:func:`_best_pulse`) also competes, both its edges added at once.

    Returns the ramps (end row, jump row or None), the bends' rows and the
    spikes taken as one (first row, row back), whose rows are among the
    ramps'.
    """
    n = x.size
    reach = max(1, int(round(0.5 * knot_spacing(settings, dt) / dt)))
    ramps, bends, pulses = [], [], []
    while len(ramps) < MAX_EVENTS_PER_TEST:
        columns = [_step_column(n, s, g) for s in ramps] + [_hinge(n, j) for j in bends]
        q, e = _project(x, np.column_stack([basis, *columns]))
        # a step within the step time: a ramp of the step time, or, when a
        # step time holds two rows only, a jump between two rows (the better
        # of the two at each row); with more rows the ramp finds a jump too,
        # and single-row jumps would only add chances for the noise
        k, size, den = _scan(q, e, g, lo, hi)
        width = np.full(k.shape, g)
        if g == 2:
            _, size1, den1 = _scan(q, e, 1, lo, hi)
            sharper = _fit_gain(size1, den1) > _fit_gain(size, den)
            size, den = np.where(sharper, size1, size), np.where(sharper, den1, den)
            width[sharper] = 1
        finite = np.isfinite(den) & ~masked[k]
        score = np.full(size.shape, -np.inf)
        score[finite] = (np.abs(size[finite]) - quantum) * np.sqrt(den[finite]) / per_row
        for chosen, _ in ramps:
            score[np.abs(k - chosen) <= g] = -np.inf
        best = int(np.argmax(score))
        step_gain = size[best] ** 2 * den[best] if np.isfinite(score[best]) else 0.0
        # where a step time holds one row, each edge of a spike is one row,
        # which a bend of the smooth part mimics: the spike is sought as one,
        # and taken when it explains clearly more than one step (by ABRUPT_Z²
        # noise variances) or no step passes, and more than any bend
        pulse = None
        if g == 1:
            pulse = _best_pulse(q, e, dt, lo, hi, per_row, quantum, settings, ramps, masked)
            clearly = (ABRUPT_Z * per_row) ** 2
            if pulse is not None and score[best] > settings.z and pulse[2] - step_gain <= clearly:
                pulse = None
        if len(bends) < MAX_BENDS_PER_TEST:
            j, gain = _scan_bends(q, e, lo, hi)
            for chosen in bends:
                gain[np.abs(j - chosen) < BEND_APART * g] = 0.0
            bend = int(np.argmax(gain))
            if gain[bend] > max(step_gain, pulse[2] if pulse else 0.0, (BEND_Z * per_row) ** 2):
                bends.append(int(j[bend]))
                continue
            if pulse is None and score[best] > settings.z:
                local = _smoother(q, e, j, gain, int(k[best]), g, reach, lo, hi)
                if local is not None and local[1] >= step_gain:
                    bends.append(local[0])
                    continue
        if pulse is not None:
            ramps.extend([(pulse[0], pulse[0]), (pulse[1], pulse[1])])
            pulses.append(pulse[:2])
            continue
        if not score[best] > settings.z:
            break
        kb = int(k[best])
        if width[best] == 1:
            ramps.append((kb, kb))
            continue
        # a jump between two rows, if it fits better than the ramp: a step
        # completed within one row is not left half explained
        rows, jumps = _gains(q, e, 1, kb - g + 1, kb + 1)
        jump = int(rows[np.argmax(jumps)]) if rows.size else kb
        ramps.append((kb, jump if rows.size and jumps.max() >= step_gain else None))
    return ramps, bends, pulses


def _best_pulse(q, e, dt, lo, hi, per_row, quantum, settings, ramps, masked):
    """The best spike of whole rows given the design: (first row, row back, gain), or None.

    A spike leaves at row k and is back at row k + w, w rows within the
    spike time: the column H_k − H_{k+w}, scanned at every k and w in closed
    form like a step (:func:`_scan`). Only one whose size, less one quantum,
    passes ``settings.z`` standard errors counts; rows within one row of a
    step already found are not tried.
    """
    tail_q = np.cumsum(q[::-1], axis=0)[::-1]  # Q'H_m
    tail_e = np.cumsum(e[::-1])[::-1]
    chosen = np.array([c for c, _ in ramps], dtype=np.intp)
    best = None
    for w in range(1, int(settings.spike_s // dt) + 1):
        k = np.arange(lo, hi - w)
        if not k.size:
            break
        qp = tail_q[k] - tail_q[k + w]
        den = w - np.einsum("ij,ij->i", qp, qp)
        ok = (den > 1e-9 * w) & ~masked[k] & ~masked[k + w]
        for c in chosen:
            ok &= (np.abs(k - c) > 1) & (np.abs(k + w - c) > 1)
        if not ok.any():
            continue
        den = np.where(ok, den, 1.0)
        size = (tail_e[k] - tail_e[k + w]) / den
        z = np.where(ok, (np.abs(size) - quantum) * np.sqrt(den) / per_row, -np.inf)
        i = int(np.argmax(z))
        gain = float(size[i] ** 2 * den[i])
        if z[i] > settings.z and (best is None or gain > best[2]):
            best = (int(k[i]), int(k[i] + w), gain)
    return best


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


def steps_in_test(x, t, dt, floor, quantum, correlation, settings):
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
        ramps, bends, pulses = _greedy(x, basis, g, dt, lo, hi, per_row, quantum, settings, masked)
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
    # the joint fit: drop the weakest event until every one holds; a spike
    # sought as one is one column (the gap leaves and comes back by one height)
    groups = _groups(rows, pulses)
    index = np.arange(n)
    while groups:
        columns = [_event_column(index, m) for m in groups]
        design = np.column_stack([basis, *columns])
        coef, *_ = np.linalg.lstsq(design, x, rcond=None)
        cov = np.linalg.pinv(design.T @ design)
        sizes = coef[basis.shape[1] :]
        se = per_row * np.sqrt(np.diag(cov)[basis.shape[1] :])
        z = (np.abs(sizes) - quantum) / se
        weakest = int(np.argmin(z))
        if z[weakest] > settings.z:
            out = []
            for m, size, zm in zip(groups, sizes.tolist(), z.tolist()):
                out += [(m[0], size, zm)] + ([(m[1], -size, zm)] if len(m) == 2 else [])
            return sorted(out)
        groups.pop(weakest)
    return []


def _event_column(index, rows):
    """A step's column (1 from its row on), or a spike's (1 from its first row to the row back)."""
    column = (index >= rows[0]).astype(float)
    if len(rows) == 2:
        column[rows[1] :] = 0.0
    return column


def _groups(rows, pulses):
    """The joint fit's columns: a spike sought as one is its two rows; any other row, a step."""
    pairs = [tuple(p) for p in pulses if p[0] in rows and p[1] in rows]
    paired = {m for p in pairs for m in p}
    return pairs + [(m,) for m in rows if m not in paired]
