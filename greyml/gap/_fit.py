"""Held-out scoring of effect signatures: leave-one-test-out least squares.

Pure array kernels. A model of the gap is the sum of *base* terms (effects
already added, one design per fold) and one *candidate* effect whose time
constant and variant are chosen on the calibration tests of each fold; its
gains are least squares on those tests; its score is the gap left on the
held-out test, pooled over folds. Nothing of a held-out test is used to fit,
to pick a time constant or to pick a variant.
"""

from __future__ import annotations

import weakref
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


@dataclass
class Evaluation:
    """Held-out result of one candidate (or of the base alone)."""

    held_out: np.ndarray  # gap left on every row, each from the fold holding its test out
    rmse: float
    peak: float
    choices: list  # FoldChoice per fold
    tau: tuple  # the (setting, variant) most folds chose
    variant: int


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


def _select(tensors, grams, B, rz, cal, f, bounds, keep=1):
    """The (setting, variant) that best fits ``rz`` on the calibration rows.

    ``tensors[i]`` is (n, V, k); ``grams[i]`` holds its (V·k)² cross products
    over all rows and per test, so the calibration tests' products are the
    total minus the held-out test's. ``B`` is the fold's base design, ``rz``
    the gap with the held-out rows zeroed. Returns the best ``(sse, setting,
    variant, coef)``, or with ``keep`` > 1 a list of the ``keep`` best.
    """
    start, stop = bounds[f]
    Bz = B * cal[:, None]
    BB, Br = Bz.T @ B, Bz.T @ rz
    kb = B.shape[1]
    rr = rz @ rz
    found = []
    for i, X in enumerate(tensors):
        if X is None:
            coef = _solve(BB, Br) if kb else np.zeros(0)
            best = (rr - coef @ Br, i, 0, coef)
            return best if keep == 1 else [best]
        n, V, k = X.shape
        W = X.reshape(n, V * k)
        total, per_test = grams[i]
        WW = (total - per_test[f]).reshape(V, k, V, k)
        G = np.empty((V, kb + k, kb + k))
        G[:, :kb, :kb] = BB
        BX = (Bz.T @ W).reshape(kb, V, k).transpose(1, 0, 2)
        G[:, :kb, kb:] = BX
        G[:, kb:, :kb] = np.swapaxes(BX, 1, 2)
        idx = np.arange(V)
        G[:, kb:, kb:] = WW[idx, :, idx, :]
        g = np.empty((V, kb + k))
        g[:, :kb] = Br
        g[:, kb:] = (W.T @ rz).reshape(V, k)
        coef = _solve(G, g)
        sse = rr - np.einsum("vk,vk->v", coef, g)
        for v in np.argsort(sse)[:keep]:
            found.append((float(sse[v]), i, int(v), coef[v]))
    found.sort(key=lambda x: x[0])
    return found[0] if keep == 1 else found[:keep]


_GRAMS = weakref.WeakKeyDictionary()


def _cached_grams(make, setting, X, bounds):
    """:func:`_grams` of ``make(setting)``, remembered for as long as ``make`` lives.

    A candidate is scored at every step of the search with the same
    signatures; only the base and the gap change.
    """
    try:
        store = _GRAMS.setdefault(make, {})
    except TypeError:  # not weak-referenceable: no cache
        return _grams(X, bounds)
    key = (setting, tuple(bounds))
    if key not in store:
        store[key] = _grams(X, bounds)
    return store[key]


def _grams(X, bounds):
    """Cross products of the (n, V·k) signatures: over all rows and per test."""
    if X is None:
        return None
    n, V, k = X.shape
    W = X.reshape(n, V * k)
    per_test = [W[a:b].T @ W[a:b] for a, b in bounds]
    return W.T @ W, per_test


def _joint_fit(r, fixed, B, X, cal, tolerance):
    """Bounded joint fit of the parameters (bounded), base B and one signature X.

    ``fixed`` holds the fold's products of the parameters' design D that do
    not change between fits: (D·cal, DᵀD and Dᵀr over the calibration rows,
    rᵀr); only the products with [B, X] are formed here.
    """
    Dz, DD, Dr, rr = fixed
    E = B if X is None else np.hstack([B, X])
    Ez = E * cal[:, None]
    p, m = DD.shape[0], E.shape[1]
    G = np.empty((p + m, p + m))
    G[:p, :p] = DD
    G[:p, p:] = Dz.T @ E
    G[p:, :p] = G[:p, p:].T
    G[p:, p:] = Ez.T @ E
    g = np.concatenate([Dr, Ez.T @ r])
    coef = box_solve(G, g, p, tolerance)
    return rr - 2.0 * coef @ g + coef @ G @ coef, coef


def _joint_choice(r, tensors, grams, B, recal, f, cal, bounds, max_rounds, shortlist):
    """The (setting, variant) and coefficients that fit best with the parameters.

    Candidates are short-listed by how well they fit the gap that the
    parameters leave (starting from the recalibration alone) and the bare gap
    (parameters at their simulated values); each short-listed one is fitted
    jointly with the bounded parameters, and the best joint fit gives the
    parameters for the next round, until the choice settles.
    """
    D = recal.designs[f]
    p = D.shape[1]
    Dz = D * cal[:, None]
    rz = r * cal
    fixed = (Dz, Dz.T @ D, Dz.T @ r, rz @ r)
    starts = [recal.theta[f], np.zeros(p)]
    picked, best = None, None
    for _ in range(max_rounds):
        pool = {}
        for theta in starts:
            for _, i, v, _ in _select(
                tensors, grams, B, (r - D @ theta) * cal, cal, f, bounds, keep=shortlist
            ):
                pool[(i, v)] = None
        for i, v in pool:
            X = tensors[i]
            sse, coef = _joint_fit(
                r, fixed, B, None if X is None else X[:, v, :], cal, recal.tolerance
            )
            if best is None or sse < best[0]:
                best = (sse, (i, v), coef)
        if best[1] == picked:
            break
        picked = best[1]
        starts = [best[2][:p]]
    return best[1], best[2]


def evaluate(r, base, make, settings, bounds, recal=None, max_rounds=3, shortlist=4):
    """Leave-one-test-out score of ``base`` + one candidate.

    Parameters
    ----------
    r : ndarray of shape (n,)
        The gap.
    base : list of ndarray
        One design (n, k_b) per fold (k_b may be 0): terms already in the model.
    make : callable or None
        ``setting -> ndarray (n, V, k)``: the candidate's signatures for one
        setting of its time constants; ``None`` scores the base alone.
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

    Returns
    -------
    Evaluation
    """
    n = r.shape[0]
    held = np.empty(n)
    choices = []
    tensors = [make(s) for s in settings] if make is not None else [None]
    settings = list(settings) if make is not None else [()]
    grams = [
        None if X is None else _cached_grams(make, s, X, bounds) for X, s in zip(tensors, settings)
    ]
    for f, (start, stop) in enumerate(bounds):
        cal = np.ones(n, dtype=bool)
        cal[start:stop] = False
        B = base[f]
        if recal is None:
            _, i, v, coef = _select(tensors, grams, B, r * cal, cal, f, bounds)
        else:
            (i, v), coef = _joint_choice(
                r, tensors, grams, B, recal, f, cal, bounds, max_rounds, shortlist
            )
        X = tensors[i]
        design = B if X is None else np.hstack([B, X[:, v, :]])
        if recal is not None:
            design = np.hstack([recal.designs[f], design])
        design = design[start:stop]
        pred = design @ coef if design.shape[1] else np.zeros(stop - start)
        held[start:stop] = r[start:stop] - pred
        choices.append(FoldChoice(settings[i], int(v), coef))
    picked = [(c.tau, c.variant) for c in choices]
    common = max(set(picked), key=picked.count)
    return Evaluation(
        held_out=held,
        rmse=float(np.sqrt(np.mean(held**2))),
        peak=float(np.max(np.abs(held))),
        choices=choices,
        tau=common[0],
        variant=common[1],
    )


def fold_design(make, choices):
    """The design (n, k) each fold's choice of a candidate gives, one per fold."""
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
