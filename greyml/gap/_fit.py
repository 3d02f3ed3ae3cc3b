"""Held-out scoring of effect signatures: leave-one-test-out least squares.

Pure array kernels. A model of the gap is the sum of *base* terms (effects
already added, one design per fold) and one *candidate* effect whose time
constant and variant are chosen on the calibration tests of each fold; its
gains are least squares on those tests; its score is the gap left on the
held-out test, pooled over folds. Nothing of a held-out test is used to fit,
to pick a time constant or to pick a variant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear

__all__ = [
    "FoldChoice",
    "Evaluation",
    "Recalibration",
    "box_solve",
    "evaluate",
    "fit_recalibration",
    "fold_design",
    "placebo_walks",
]

_JITTER = 1e-10


@dataclass
class FoldChoice:
    """What the calibration tests of one fold chose for a candidate."""

    tau: tuple  # the setting of the time constants (seconds)
    variant: int
    coef: np.ndarray
    setting: int = 0  # its index among the settings tried


@dataclass
class Evaluation:
    """Held-out result of one candidate (or of the base alone)."""

    held_out: np.ndarray  # gap left on every row, each from the fold holding its test out
    rmse: float
    peak: float
    choices: list  # FoldChoice per fold
    tau: tuple  # the (setting, variant) most folds chose
    variant: int
    bank: object = None  # the candidate's Bank, to rebuild each fold's design


def _solve(G, g):
    """Batched ridge-stabilised solve of G β = g; G (..., K, K), g (..., K)."""
    K = G.shape[-1]
    scale = np.trace(G, axis1=-2, axis2=-1)[..., None, None] / max(K, 1)
    eye = np.eye(K)
    A = G + _JITTER * np.where(scale > 0, scale, 1.0) * eye
    return np.linalg.solve(A, g[..., None])[..., 0]


@dataclass
class Recalibration:
    """The simulation's own parameters, refitted within a tolerance.

    ``designs[f]`` (n, p) is fold f's design of relative parameter changes
    (its columns: the change of the simulated target per unit relative change
    of each parameter); ``theta[f]`` their fit on fold f's calibration tests
    alone; every coefficient is kept within ±``tolerance``.
    """

    designs: list
    theta: list
    tolerance: float
    settings: list  # the setting each fold chose (for reporting)


def box_solve(G, g, n_bounded, tolerance):
    """Minimise xᵀGx − 2gᵀx with |x[:n_bounded]| ≤ tolerance (the rest free).

    Exact least squares when the free solution keeps the bounds; otherwise a
    bounded least-squares problem on the Cholesky factor of ``G`` (K × K, so
    it costs nothing next to forming ``G``).
    """
    K = G.shape[0]
    x = _solve(G, g)
    if n_bounded == 0 or np.all(np.abs(x[:n_bounded]) <= tolerance):
        return x
    scale = np.trace(G) / max(K, 1)
    A = G + _JITTER * (scale if scale > 0 else 1.0) * np.eye(K)
    L = np.linalg.cholesky(A)
    c = np.linalg.solve(L, g)
    lo = np.full(K, -np.inf)
    hi = np.full(K, np.inf)
    lo[:n_bounded], hi[:n_bounded] = -tolerance, tolerance
    return lsq_linear(L.T, c, bounds=(lo, hi), method="bvls").x


def fit_recalibration(r, make, settings, bounds, tolerance):
    """Fit the bounded recalibration alone on each fold's calibration tests.

    ``make(setting)`` gives the (n, p) design for one setting (``settings``
    lists them); each fold keeps the setting that fits its calibration tests
    best.

    Returns
    -------
    Recalibration
    """
    n = r.shape[0]
    designs = {i: make(s) for i, s in enumerate(settings)}
    out_d, out_t, out_s = [], [], []
    for start, stop in bounds:
        cal = np.ones(n, dtype=bool)
        cal[start:stop] = False
        rc = r[cal]
        best = (np.inf, None, None)
        for i, D in designs.items():
            Dc = D[cal]
            G, g = Dc.T @ Dc, Dc.T @ rc
            theta = box_solve(G, g, D.shape[1], tolerance)
            sse = rc @ rc - 2 * theta @ g + theta @ G @ theta
            if sse < best[0]:
                best = (sse, i, theta)
        _, i, theta = best
        out_d.append(designs[i])
        out_t.append(theta)
        out_s.append(settings[i])
    return Recalibration(out_d, out_t, tolerance, out_s)


def _as_bank(make, settings):
    from greyml.gap._effects import Bank

    if make is None or isinstance(make, Bank):
        return make
    return Bank.of_make(make, settings)


def _per_test(bank, key, other, bounds):
    """Per-test cross products of the bank's columns with ``other`` (n, q), kept in the bank.

    Returns an array (T, V, m, q). ``other`` is held in the cache with the
    result, so its ``id`` cannot be reused while the entry lives.
    """
    hit = bank.cache.get(key)
    if hit is not None and hit[0] is other:
        return hit[1]
    X = bank.values
    n, V, m = X.shape
    W = X.reshape(n, V * m)
    out = np.stack([(W[a:b].T @ other[a:b]).reshape(V, m, -1) for a, b in bounds])
    bank.cache[key] = (other, out)
    return out


def _grams(bank, bounds):
    """Per-test cross products of each variant's columns (T, V, m, m), kept in the bank."""
    key = ("grams", tuple(bounds))
    if key not in bank.cache:
        A = bank.values.transpose(1, 2, 0)  # (V, m, n)
        bank.cache[key] = np.stack(
            [A[:, :, a:b] @ A[:, :, a:b].transpose(0, 2, 1) for a, b in bounds]
        )
    return bank.cache[key]


def _fold_constants(r, B, D, f, bounds, cache):
    """Cross products of the base B and the parameters' design D with B, D and r on fold f.

    They do not depend on the candidate: kept in ``cache`` (a dict owned by
    the caller, dropped with it) while the same base is scored against every
    candidate and placebo of a step. The entry holds the arrays themselves,
    so that their ids stay theirs while it lives.
    """
    key = (id(r), id(B), id(D), f, tuple(bounds))
    hit = cache.get(key)
    if hit is not None and hit[0] is r and hit[1] is B and hit[2] is D:
        return hit[3]
    start, stop = bounds[f]

    def cal(a, b):
        return a.T @ b - a[start:stop].T @ b[start:stop]

    rc = r[:, None]
    out = (
        (cal(B, B), cal(B, rc)[:, 0], cal(B, D)),
        (cal(D, D), cal(D, rc)[:, 0], float(cal(rc, rc)[0, 0])),
    )
    cache[key] = (r, B, D, out)
    return out


class _Fold:
    """Everything of one fold's least squares that does not change while it is fitted.

    The gap r, the base B (n, k_b), the parameters' design D (n, p; p may be
    0) and the bank X, all over the fold's calibration rows: their cross
    products. Sums over calibration tests are totals minus the held-out
    test's.
    """

    def __init__(self, r, B, D, bank, f, bounds, cache):
        start, stop = bounds[f]
        n = r.shape[0]
        (self.BB, self.Br, self.BD), (self.DD, self.Dr, self.rr) = _fold_constants(
            r, B, D, f, bounds, cache
        )
        self.bank = bank
        if bank is not None:
            grams = _grams(bank, bounds)
            self.WW = grams.sum(axis=0) - grams[f]
            wr = _per_test(bank, ("r", id(r)), r[:, None], bounds)
            self.Wr = (wr.sum(axis=0) - wr[f])[..., 0]
            if D.shape[1]:
                wd = _per_test(bank, ("D", id(D)), D, bounds)
                self.WD = wd.sum(axis=0) - wd[f]
            else:
                self.WD = np.zeros(self.Wr.shape + (0,))
            V, m = self.Wr.shape
            kb = B.shape[1]
            if kb:
                W = bank.values.reshape(n, V * m)
                BW = B.T @ W - B[start:stop].T @ W[start:stop]
                self.BW = BW.reshape(kb, V, m)
            else:
                self.BW = np.zeros((0, V, m))

    def select(self, theta, keep=1):
        """The ``keep`` best (sse, setting, variant, coef) fitting r − Dθ with B and one setting."""
        kb = self.BB.shape[0]
        Br = self.Br - self.BD @ theta
        rr = self.rr - 2.0 * theta @ self.Dr + theta @ self.DD @ theta
        if self.bank is None:
            coef = _solve(self.BB, Br) if kb else np.zeros(0)
            return [(float(rr - coef @ Br), 0, 0, coef)]
        picks = self.bank.picks
        S, k = picks.shape
        V = self.Wr.shape[0]
        gx = self.Wr - self.WD @ theta  # (V, m)
        G = np.empty((S, V, kb + k, kb + k))
        G[:, :, :kb, :kb] = self.BB
        BX = self.BW[:, :, picks].transpose(2, 1, 0, 3)  # (S, V, kb, k)
        G[:, :, :kb, kb:] = BX
        G[:, :, kb:, :kb] = np.swapaxes(BX, 2, 3)
        G[:, :, kb:, kb:] = self.WW[:, picks[:, :, None], picks[:, None, :]].transpose(1, 0, 2, 3)
        g = np.empty((S, V, kb + k))
        g[:, :, :kb] = Br
        g[:, :, kb:] = gx[:, picks].transpose(1, 0, 2)
        coef = _solve(G, g)
        sse = (rr - np.einsum("svk,svk->sv", coef, g)).ravel()
        order = np.argsort(sse, kind="stable")[:keep]
        coef = coef.reshape(S * V, kb + k)
        return [(float(sse[j]), int(j // V), int(j % V), coef[j]) for j in order]

    def joint(self, i, v, tolerance):
        """Bounded joint fit of the parameters, B and setting ``i`` of variant ``v``."""
        p, kb = self.DD.shape[0], self.BB.shape[0]
        if self.bank is None:
            k = 0
        else:
            cols = self.bank.picks[i]
            k = cols.size
        K = p + kb + k
        G = np.empty((K, K))
        G[:p, :p] = self.DD
        G[:p, p : p + kb] = self.BD.T
        G[p : p + kb, :p] = self.BD
        G[p : p + kb, p : p + kb] = self.BB
        g = np.empty(K)
        g[:p], g[p : p + kb] = self.Dr, self.Br
        if k:
            DX = self.WD[v][cols].T  # (p, k)
            BX = self.BW[:, v, cols]  # (kb, k)
            G[:p, p + kb :] = DX
            G[p + kb :, :p] = DX.T
            G[p : p + kb, p + kb :] = BX
            G[p + kb :, p : p + kb] = BX.T
            G[p + kb :, p + kb :] = self.WW[v][np.ix_(cols, cols)]
            g[p + kb :] = self.Wr[v, cols]
        coef = box_solve(G, g, p, tolerance)
        return self.rr - 2.0 * coef @ g + coef @ G @ coef, coef


def _joint_choice(fold, recal, f, max_rounds, shortlist):
    """The (setting, variant) and coefficients that fit best with the parameters.

    Candidates are short-listed by how well they fit the gap that the
    parameters leave (starting from the recalibration alone) and the bare gap
    (parameters at their simulated values); each short-listed one is fitted
    jointly with the bounded parameters, and the best joint fit gives the
    parameters for the next round, until the choice settles.
    """
    p = fold.DD.shape[0]
    starts = [recal.theta[f], np.zeros(p)]
    picked, best = None, None
    for _ in range(max_rounds):
        pool = {}
        for theta in starts:
            for _, i, v, _ in fold.select(theta, keep=shortlist):
                pool[(i, v)] = None
        for i, v in pool:
            sse, coef = fold.joint(i, v, recal.tolerance)
            if best is None or sse < best[0]:
                best = (sse, (i, v), coef)
        if best[1] == picked:
            break
        picked = best[1]
        starts = [best[2][:p]]
    return best[1], best[2]


def evaluate(r, base, make, settings, bounds, recal=None, max_rounds=3, shortlist=4, cache=None):
    """Leave-one-test-out score of ``base`` + one candidate.

    Parameters
    ----------
    r : ndarray of shape (n,)
        The gap.
    base : list of ndarray
        One design (n, k_b) per fold (k_b may be 0): terms already in the model.
    make : Bank, callable or None
        The candidate's signatures: a :class:`~greyml.gap._effects.Bank`, or
        ``setting -> ndarray (n, V, k)`` for one setting of its time
        constants; ``None`` scores the base alone.
    settings : sequence
        The settings to try (tuples of time constants; ``()`` when the
        candidate has none).
    bounds : list of (start, stop)
        The tests; fold f holds test f out.
    recal : Recalibration, optional
        The simulation's own parameters, kept within their tolerance. They,
        the base and the candidate are fitted together (bounded least
        squares); the candidate's setting and variant are short-listed on the
        gap the parameters leave (and on the bare gap), fitted jointly, and
        the best joint fit kept, alternating until the choice settles (at
        most ``max_rounds`` times).
    max_rounds : int, default=3
    shortlist : int, default=4
        (setting, variant) pairs fitted jointly per start and round.
    cache : dict, optional
        Where the cross products that do not depend on the candidate are
        kept between calls (the caller's, e.g. one search's); by default
        they are kept for this call only.

    Returns
    -------
    Evaluation
    """
    n = r.shape[0]
    held = np.empty(n)
    choices = []
    bank = _as_bank(make, settings)
    settings = list(settings) if bank is not None else [()]
    empty = np.zeros((n, 0))
    cache = {} if cache is None else cache
    for f, (start, stop) in enumerate(bounds):
        B = base[f]
        D = recal.designs[f] if recal is not None else empty
        fold = _Fold(r, B, D, bank, f, bounds, cache)
        if recal is None:
            _, i, v, coef = fold.select(np.zeros(0))[0]
        else:
            (i, v), coef = _joint_choice(fold, recal, f, max_rounds, shortlist)
        design = [D[start:stop], B[start:stop]]
        if bank is not None:
            design.append(bank.values[start:stop, v][:, bank.picks[i]])
        design = np.hstack(design)
        pred = design @ coef if design.shape[1] else np.zeros(stop - start)
        held[start:stop] = r[start:stop] - pred
        choices.append(FoldChoice(settings[i], int(v), coef, i))
    picked = [(c.tau, c.variant) for c in choices]
    common = max(set(picked), key=picked.count)
    return Evaluation(
        held_out=held,
        rmse=float(np.sqrt(np.mean(held**2))),
        peak=float(np.max(np.abs(held))),
        choices=choices,
        tau=common[0],
        variant=common[1],
        bank=bank,
    )


def fold_design(make, choices):
    """The design (n, k) each fold's choice of a candidate gives, one per fold."""
    from greyml.gap._effects import Bank

    if isinstance(make, Bank):
        return [make.values[:, c.variant][:, make.picks[c.setting]] for c in choices]
    out = []
    cache = {}
    for choice in choices:
        if choice.tau not in cache:
            cache[choice.tau] = make(choice.tau)
        out.append(cache[choice.tau][:, choice.variant, :])
    return out


def placebo_walks(rng, bounds, n_walks):
    """Random walks from 0 in every test, one column per walk, unit step variance."""
    n = bounds[-1][1]
    out = np.empty((n, n_walks))
    for start, stop in bounds:
        steps = rng.standard_normal((stop - start, n_walks))
        steps[0] = 0.0
        out[start:stop] = np.cumsum(steps, axis=0)
    return out
