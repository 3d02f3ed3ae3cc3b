"""Ridge regression on per-test Gram matrices, and whole-sensor selection with it.

The pure array functions behind :class:`greyml.ThermalTransferFunction`: the
design of lag features, per-test Gram matrices, ridge solutions for every
penalty at once, held-out scores of whole tests computed from the Grams (a
candidate costs a few small linear solves, not a refit), and the forward and
stable selection of whole sensors under a budget. No validation, no pandas.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

from greyml.dynamic._kernels import lag_filter

__all__ = [
    "CHUNK_ROWS",
    "DesignRows",
    "GramBlocks",
    "MAX_FOLDS",
    "design",
    "fold_groups",
    "grams_of_rows",
    "row_pieces",
    "held_out_errors",
    "held_out_rmse",
    "held_out_scores",
    "held_out_spread",
    "select_sensors",
    "solve_all",
    "grams_by_test",
    "train_scores",
]

#: Relative improvement of the held-out score below which forward selection adds no sensor.
_RESOLUTION = 1e-6


#: Rows of lag features computed at a time: the design's memory is this many rows
#: times its columns (8 bytes each), however many rows the tests have.
CHUNK_ROWS = 1 << 15
#: Held-out scores come from at most this many folds of whole tests: one test
#: each up to this many tests, consecutive tests together beyond (ten folds, the
#: compromise of bias and variance Hastie, Tibshirani and Friedman, 2009,
#: §7.10.1, recommend), so that the nested choices cost the same however finely
#: a recording is cut into tests.
MAX_FOLDS = 10


def _layout(spec):
    """``(groups, order, starts)``: the blocks of each set of taus; the design's
    columns in the order they are computed (``order[i]``, the column of ``spec``'s
    layout that computed row ``i`` is): every block's static column, then each set
    of taus' lags, block by block, so that the lag filter writes them in place;
    and where each set's lags begin."""
    widths = [1 + len(taus) for _, _, taus in spec]
    offsets = np.concatenate(([0], np.cumsum(widths))).astype(int)
    groups = {}
    for b, (_col, _power, taus) in enumerate(spec):
        groups.setdefault(tuple(taus), []).append(b)
    order = [offsets[b] for b in range(len(spec))]
    starts = {}
    for taus, blocks in groups.items():
        starts[taus] = len(order)
        order += [offsets[b] + 1 + j for b in blocks for j in range(len(taus))]
    return groups, np.asarray(order, dtype=int), starts


def _design_part(x, dt, bounds, spec, carry, idle, initial, layout=None):
    """``(FT, final)``: the design of rows ``x``, transposed, its rows in
    :func:`_layout`'s order, and the lag state after them (a dict keyed by the
    blocks' taus), continuing from ``initial`` (such a dict)."""
    groups, order, starts = _layout(spec) if layout is None else layout
    n = x.shape[0]
    FT = np.empty((order.size, n))
    for b, (col, power, _taus) in enumerate(spec):
        FT[b] = x[:, col] ** power
    final = {}
    for taus, blocks in groups.items():
        if not taus:
            continue
        m = len(taus)
        store = FT[starts[taus] : starts[taus] + len(blocks) * m].reshape(len(blocks), m, n)
        _, final[taus] = lag_filter(
            FT[blocks].T,
            dt,
            np.asarray(taus),
            bounds,
            carry=carry,
            idle=np.isin(blocks, idle),
            initial=None if initial is None else initial[taus],
            out=store,
        )
    return FT, final


def design(x, dt, bounds, spec, carry, idle=()):
    """Design columns for inputs ``x`` (n, q) given ``spec``.

    ``spec`` is a list of (column, power, taus) blocks; each block contributes a
    static column ``x[:, column] ** power`` followed by its lags at ``taus``.
    Blocks with the same taus are filtered together (one kernel call).
    ``carry`` is :func:`~greyml.dynamic._kernels.lag_filter`'s (one flag per
    test), ``idle`` the blocks whose lags start at 0 in a test without history.
    Returns ``F`` of shape (n, n_columns).
    """
    FT, _ = _design_part(x, dt, bounds, spec, carry, idle, None)
    F = np.empty((x.shape[0], FT.shape[0]))
    F[:, _layout(spec)[1]] = FT.T
    return F


def row_pieces(starts, bounds, r0, r1):
    """``(test, start, stop)`` of every test's rows within ``r0 : r1`` (``starts``
    the tests' first rows, ``bounds`` their ranges, in order)."""
    first = max(int(np.searchsorted(starts, r0, side="right")) - 1, 0)
    out = []
    for i in range(first, len(bounds)):
        a, b = bounds[i]
        if a >= r1:
            break
        if b > r0:
            out.append((i, max(a, r0), min(b, r1)))
    return out


class DesignRows:
    """The design of consecutive row ranges, each continuing the lags of the one before.

    ``DesignRows(dt, bounds, spec, carry, idle, start_rows)`` then
    ``rows(r0, x)`` for the rows ``r0 : r0 + len(x)`` (``x`` their inputs,
    ``dt`` and ``bounds`` in the whole data's row numbers), called in order
    from row 0: the same rows of :func:`design` (each test's rows less its
    first row's with ``start_rows``), transposed, the columns in the order
    ``order`` (row ``i`` is :func:`design`'s column ``order[i]``), in memory
    proportional to the rows asked for. How the rows are cut does not matter:
    a test may begin, end or run through a range.
    """

    def __init__(self, dt, bounds, spec, carry, idle=(), start_rows=False):
        self.dt, self.bounds, self.spec, self.idle = dt, list(bounds), spec, idle
        self.carry = np.broadcast_to(np.asarray(carry, dtype=bool), (len(self.bounds),))
        self.start_rows = start_rows
        self.starts = np.array([a for a, _ in self.bounds], dtype=int)
        self.state, self.next_row, self.firsts = None, 0, {}
        self.layout = _layout(spec)
        self.order = self.layout[1]

    def pieces(self, r0, r1):
        """``(test, start, stop)`` of every test's rows within ``r0 : r1``."""
        return row_pieces(self.starts, self.bounds, r0, r1)

    def rows(self, r0, x):
        if r0 != self.next_row:
            raise ValueError(f"the design's rows are asked from row {r0}, not {self.next_row}.")
        r1 = r0 + x.shape[0]
        parts = self.pieces(r0, r1)
        local = [(a - r0, b - r0) for _, a, b in parts]
        i0, a0, _ = parts[0]
        # the first piece continues the state unless it is a test's first row at rest
        at_rest = a0 == self.bounds[i0][0] and (i0 == 0 or not self.carry[i0])
        initial = None if (at_rest or self.state is None) else self.state
        link = [True] + [bool(self.carry[i]) for i, _, _ in parts[1:]]
        FT, self.state = _design_part(
            x, self.dt[r0:r1], local, self.spec, link, self.idle, initial, self.layout
        )
        if self.start_rows:
            for i, a, b in parts:
                if a == self.bounds[i][0]:
                    self.firsts[i] = FT[:, a - r0].copy()
                FT[:, a - r0 : b - r0] -= self.firsts[i][:, None]
            # a test's rows only need its first row's while they last
            done = [i for i in self.firsts if self.bounds[i][1] <= r1]
            for i in done:
                del self.firsts[i]
        self.next_row = r1
        return FT


@dataclass(frozen=True)
class GramBlocks:
    """The weighted normal equations of a design, one block per test.

    Whatever is scored on held-out tests is computed from these: leaving a
    test out subtracts its block, never refits.

    Attributes
    ----------
    G : ndarray of shape (n_tests, p, p)
        ``A'WA`` of each test's rows.
    b : ndarray of shape (n_tests, p)
        ``A'Wy``.
    yy : ndarray of shape (n_tests,)
        ``y'Wy``.
    sw : ndarray of shape (n_tests,)
        The sum of the test's row weights.
    """

    G: np.ndarray
    b: np.ndarray
    yy: np.ndarray
    sw: np.ndarray

    @property
    def n_columns(self):
        """``p``, the columns of the design."""
        return self.G.shape[1]

    def grouped(self, groups):
        """One block per group of tests (lists of test indices): the sum of theirs."""
        return GramBlocks(
            np.stack([self.G[g].sum(axis=0) for g in groups]),
            np.stack([self.b[g].sum(axis=0) for g in groups]),
            np.array([self.yy[g].sum() for g in groups]),
            np.array([self.sw[g].sum() for g in groups]),
        )

    def columns(self, cols):
        """The blocks of the design's columns ``cols`` only."""
        return replace(self, G=self.G[:, cols][:, :, cols], b=self.b[:, cols])

    def without(self, k):
        """The same blocks with test ``k``'s set to 0 (a copy)."""
        blocks = {}
        for name in ("G", "b", "yy", "sw"):
            a = getattr(self, name).copy()
            a[k] = 0.0
            blocks[name] = a
        return replace(self, **blocks)


def grams_by_test(A, y, w, bounds):
    """Per-test weighted Gram matrices ``A'WA``, ``A'Wy``, ``y'Wy`` and weight sums."""
    G, b, yy, sw = [], [], [], []
    for start, stop in bounds:
        a, t, v = A[start:stop], y[start:stop], w[start:stop]
        av = a * v[:, None]
        G.append(av.T @ a)
        b.append(av.T @ t)
        yy.append(float(t @ (v * t)))
        sw.append(float(v.sum()))
    return GramBlocks(np.array(G), np.array(b), np.array(yy), np.array(sw))


def grams_of_rows(rows, chunks, y, w, intercept, groups=None):
    """:func:`grams_by_test` of the design :class:`DesignRows` ``rows`` gives for the
    inputs ``chunks`` (``(r0, x)`` in order, covering every row), a ones column
    last with ``intercept``: the design is never held whole. With ``groups``
    (lists of tests), one block per group, summed as it is read (the tests in no
    group are left out): :meth:`GramBlocks.grouped` without a block per test."""
    width = rows.order.size
    T = len(rows.bounds)
    block = {t: j for j, g in enumerate(groups) for t in g} if groups else None
    B = T if groups is None else len(groups)
    G, b = np.zeros((B, width, width)), np.zeros((B, width))
    ones = np.zeros((B, width))
    for r0, x in chunks:
        FT = rows.rows(r0, x)
        for t, start, stop in rows.pieces(r0, r0 + x.shape[0]):
            i = t if block is None else block.get(t)
            if i is None:
                continue
            a = FT[:, start - r0 : stop - r0]
            v = w[start:stop]
            av = a if (v == 1.0).all() else a * v
            G[i] += av @ a.T
            b[i] += av @ y[start:stop]
            ones[i] += av.sum(axis=1)
    # back to design()'s column order, a ones column last with the intercept
    back = np.argsort(rows.order)
    G, b, ones = G[:, back][:, :, back], b[:, back], ones[:, back]
    members = [[t] for t in range(T)] if groups is None else groups
    per = np.array(
        [
            (float(w[a:e].sum()), float(y[a:e] @ (w[a:e] * y[a:e])), float(w[a:e] @ y[a:e]))
            for a, e in rows.bounds
        ]
    ).reshape(T, 3)
    sw, yy, yw = (np.array([per[g, k].sum() for g in members]) for k in range(3))
    if intercept:
        G = np.concatenate(
            [
                np.concatenate([G, ones[:, None, :]], axis=1),
                np.concatenate([ones, sw[:, None]], axis=1)[:, :, None],
            ],
            axis=2,
        )
        b = np.concatenate([b, yw[:, None]], axis=1)
    return GramBlocks(G, b, yy, sw)


def fold_groups(scored, max_folds=MAX_FOLDS):
    """The scored tests in at most ``max_folds`` groups of consecutive tests
    (one test each when there are no more)."""
    n = len(scored)
    k = min(n, max_folds)
    return [list(scored[(j * n) // k : ((j + 1) * n) // k]) for j in range(k)]


def _ridge(G, b, alpha, penalised):
    """Solve (G + alpha·diag(penalised)) w = b; falls back to lstsq when singular."""
    M = G + np.diag(alpha * penalised)
    try:
        return cho_solve(cho_factor(M, check_finite=False), b, check_finite=False)
    except (LinAlgError, ValueError):
        return np.linalg.lstsq(M, b, rcond=None)[0]


def _standardised(G, b, sw, pen):
    """Gram of the design with unit weighted standard deviation per column.

    ``G``, ``b`` are the summed raw Grams of some tests and ``sw`` their weight.
    Where a column is unpenalised (the intercept, always last) the others are
    scaled by their centred deviation, which with an unpenalised intercept is
    the same ridge as on centred columns. Returns (G', b', scale).
    """
    m2 = np.diag(G) / sw
    if (pen == 0).any():
        var = m2 - (G[-1] / sw) ** 2
    else:
        var = m2
    scale = np.sqrt(np.maximum(var, 0.0))
    scale = np.where((scale > 0) & (var > 1e-14 * np.maximum(m2, 1e-300)) & (pen > 0), scale, 1.0)
    d = 1.0 / scale
    return G * d[:, None] * d[None, :], b * d, scale


def solve_all(G, b, sw, alphas, pen):
    """Ridge coefficients (raw units) for every alpha: columns of a (p, n_alphas) array.

    The penalty is ``alpha`` per unit of weight (per row with unit weights) on
    the standardised columns, so a fit on fewer tests is penalised in proportion.
    """
    Gn, bn, scale = _standardised(G, b, sw, pen)
    alphas = np.asarray(alphas, dtype=float)
    if (pen > 0).all():
        # one eigendecomposition serves every alpha
        lam, V = np.linalg.eigh(Gn)
        lam = np.maximum(lam, 0.0)
        coefs = V @ ((V.T @ bn)[:, None] / (lam[:, None] + alphas[None, :] * sw))
    elif pen[-1] == 0 and (pen[:-1] > 0).all() and Gn[-1, -1] > 0:
        # an unpenalised intercept, last: eliminated exactly (the ridge on the
        # centred columns), then one eigendecomposition serves every alpha
        g, s0 = Gn[:-1, -1], Gn[-1, -1]
        Gc = Gn[:-1, :-1] - np.outer(g, g) / s0
        bc = bn[:-1] - g * (bn[-1] / s0)
        lam, V = np.linalg.eigh(Gc)
        lam = np.maximum(lam, 0.0)
        beta = V @ ((V.T @ bc)[:, None] / (lam[:, None] + alphas[None, :] * sw))
        coefs = np.vstack([beta, (bn[-1] - g @ beta) / s0])
    else:
        coefs = np.column_stack([_ridge(Gn, bn, a * sw, pen) for a in alphas])
    return coefs / scale[:, None]


def held_out_errors(grams, cols, alphas, pen, folds):
    """Held-out RMSE of each fold for each alpha: an array (n_folds, n_alphas).

    ``grams`` are the per-test raw :class:`GramBlocks`; each fold holds out one test,
    standardises and solves the ridge on the others exactly as a refit on them
    would, and scores the held-out test from its own Gram.
    """
    yy, sw = grams.yy, grams.sw
    ix = np.ix_(cols, cols)
    Gs = grams.G[:, ix[0], ix[1]]
    bs = grams.b[:, cols]
    Gt, bt, st = Gs.sum(axis=0), bs.sum(axis=0), sw.sum()
    pen = pen[cols]
    out = np.zeros((len(folds), len(alphas)))
    for i, h in enumerate(folds):
        coefs = solve_all(Gt - Gs[h], bt - bs[h], st - sw[h], alphas, pen)
        sse = yy[h] - 2.0 * (bs[h] @ coefs) + np.einsum("ia,ij,ja->a", coefs, Gs[h], coefs)
        out[i] = np.sqrt(np.maximum(sse, 0.0) / sw[h])
    return out


def held_out_rmse(grams, k, coef):
    """The RMSE of test ``k`` predicted by ``coef`` (every column), from its own Gram.

    ``coef`` of shape (p,) gives a float; of shape (L, p), one RMSE per row.
    """
    coef = np.asarray(coef, dtype=float)
    rows = np.atleast_2d(coef)
    sse = grams.yy[k] - 2.0 * (rows @ grams.b[k]) + np.einsum("lp,pq,lq->l", rows, grams.G[k], rows)
    rmse = np.sqrt(np.maximum(sse, 0.0) / grams.sw[k])
    return float(rmse[0]) if coef.ndim == 1 else rmse


def held_out_scores(grams, cols, alphas, pen, folds):
    """Mean held-out RMSE over ``folds`` for each alpha, on design columns ``cols``.

    An array (n_alphas,): the mean over the folds of :func:`held_out_errors`.
    """
    return held_out_errors(grams, cols, alphas, pen, folds).mean(axis=0)


def held_out_spread(grams, cols, alpha, pen, folds):
    """The standard error of the mean held-out RMSE for one penalty (0 without folds).

    The one-standard-error rule (Breiman et al., 1984) takes the simplest
    candidate whose mean held-out RMSE is within this of the best one: with
    a handful of tests, differences smaller than that are noise.
    """
    if folds is None or len(folds) < 2:
        return 0.0
    errors = held_out_errors(grams, cols, [alpha], pen, folds)[:, 0]
    return float(errors.std(ddof=1) / np.sqrt(errors.size))


def train_scores(grams, cols, alphas, pen):
    """Training RMSE (all tests pooled) for each alpha, when too few tests to hold one out."""
    yy, sw = grams.yy, grams.sw
    ix = np.ix_(cols, cols)
    Gt, bt = grams.G[:, ix[0], ix[1]].sum(axis=0), grams.b[:, cols].sum(axis=0)
    coefs = solve_all(Gt, bt, sw.sum(), alphas, pen[cols])
    sse = yy.sum() - 2.0 * (bt @ coefs) + np.einsum("ia,ij,ja->a", coefs, Gt, coefs)
    return np.sqrt(np.maximum(sse, 0.0) / sw.sum())


def _cols(col_group, chosen):
    keep = np.isin(col_group, [-1, *chosen])
    return np.flatnonzero(keep)


def _cols_all(col_group, chosen, n_total):
    cols = list(_cols(col_group, chosen))
    if n_total > len(col_group):
        cols.append(len(col_group))
    return np.asarray(cols, dtype=int)


def _score(grams, cols, alphas, pen, folds):
    if folds is None:
        return train_scores(grams, cols, alphas, pen)
    return held_out_scores(grams, cols, alphas, pen, folds)


def select_sensors(grams, pen, col_group, sensors, alphas, folds, max_sensors, selection):
    """Whole sensors chosen under a budget; returns (chosen, alpha, score, path).

    ``max_sensors`` None keeps every sensor (the penalty is still chosen);
    ``selection`` is "forward" or "stable" (stable needs four scored tests).
    """
    n_total = grams.n_columns

    def evaluate(chosen):
        cols = _cols_all(col_group, chosen, n_total)
        sc = _score(grams, cols, alphas, pen, folds)
        i = int(np.argmin(sc))
        return float(sc[i]), float(alphas[i])

    def spread(chosen, alpha):
        cols = _cols_all(col_group, chosen, n_total)
        return held_out_spread(grams, cols, alpha, pen, folds)

    everything = list(range(len(sensors)))
    if max_sensors is None:
        score, alpha = evaluate(everything)
        return everything, alpha, score, []
    if selection == "stable" and folds is not None and len(folds) >= 4:
        return _stable(grams, pen, col_group, sensors, alphas, folds, evaluate, max_sensors)
    return _forward(evaluate, everything, sensors, col_group, n_total, max_sensors, spread)


def _stable(grams, pen, col_group, sensors, alphas, folds, evaluate, max_sensors):
    """Forward selection repeated without each test in turn; keep the sensors most runs chose.

    A sensor enters when at least half of the runs chose it (at most
    ``max_sensors``, most votes first, then earliest on average); the
    penalty is then chosen by leave one test out on all tests.
    """
    votes, rank = {}, {}
    n_total = grams.n_columns
    for t in folds:
        without = grams.without(t)
        rest = [f for f in folds if f != t]

        def evaluate_without(chosen, without=without, rest=rest):
            cols = _cols_all(col_group, chosen, n_total)
            sc = held_out_scores(without, cols, alphas, pen, rest)
            i = int(np.argmin(sc))
            return float(sc[i]), float(alphas[i])

        keep, _, _, _ = _forward(
            evaluate_without, list(range(len(sensors))), sensors, col_group, n_total, max_sensors
        )
        for position, k in enumerate(keep):
            votes[k] = votes.get(k, 0) + 1
            rank[k] = rank.get(k, 0) + position
    order = sorted(votes, key=lambda k: (-votes[k], rank[k] / votes[k], k))
    chosen = [k for k in order if 2 * votes[k] >= len(folds)][:max_sensors]
    if not chosen and order:
        chosen = order[:1]
    score, alpha = evaluate(chosen)
    path = [(sensors[k], float(votes[k]) / len(folds)) for k in order]
    return chosen, alpha, score, path


def _forward(evaluate, everything, sensors, col_group, n_total, max_sensors, spread=None):
    """Greedy forward selection; the shortest good prefix up to ``max_sensors``.

    The prefix kept is the shortest whose mean held-out score is within one
    standard error of the lowest (``spread(chosen, alpha)`` of the lowest;
    the one-standard-error rule), and never within less than
    ``_RESOLUTION`` times the first step's score: a sensor whose gain is at
    the level of rounding (noise-free data fitted to 1e-7) is not chosen by
    the last digits of a floating-point sum.
    """
    chosen, path, prefixes = [], [], []
    if (col_group == -1).any() or n_total > len(col_group):
        score, alpha = evaluate([])
        path.append((None, score, alpha))
        prefixes.append((score, [], alpha))
    for _ in range(max_sensors):
        trial = []
        for k in everything:
            if k in chosen:
                continue
            score, alpha = evaluate([*chosen, k])
            trial.append((score, k, alpha))
        if not trial:
            break
        score, k, alpha = min(trial)
        chosen = [*chosen, k]
        path.append((sensors[k], score, alpha))
        prefixes.append((score, list(chosen), alpha))
    lowest, best, best_alpha = min(prefixes, key=lambda p: p[0])
    margin = 0.0 if spread is None else spread(best, best_alpha)
    within = lowest + max(margin, _RESOLUTION * abs(prefixes[0][0]))
    score, keep, alpha = next(p for p in prefixes if p[0] <= within)
    return keep, alpha, score, path
