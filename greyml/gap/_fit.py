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

__all__ = ["FoldChoice", "Evaluation", "evaluate", "fold_design", "placebo_walks"]

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


def evaluate(r, base, make, settings, bounds):
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

    Returns
    -------
    Evaluation
    """
    n = r.shape[0]
    held = np.empty(n)
    choices = []
    tensors = [make(s) for s in settings] if make is not None else [None]
    settings = list(settings) if make is not None else [()]
    for f, (start, stop) in enumerate(bounds):
        cal = np.ones(n, dtype=bool)
        cal[start:stop] = False
        B = base[f]
        Bc, rc = B[cal], r[cal]
        BB, Br = Bc.T @ Bc, Bc.T @ rc
        kb = B.shape[1]
        best = (np.inf, 0, 0, None)
        for i, X in enumerate(tensors):
            if X is None:
                coef = _solve(BB, Br) if kb else np.zeros(0)
                best = (rc @ rc - coef @ Br, i, 0, coef)
                continue
            Xc = X[cal]
            V, k = X.shape[1], X.shape[2]
            G = np.empty((V, kb + k, kb + k))
            G[:, :kb, :kb] = BB
            BX = np.einsum("nb,nvk->vbk", Bc, Xc)
            G[:, :kb, kb:] = BX
            G[:, kb:, :kb] = np.swapaxes(BX, 1, 2)
            G[:, kb:, kb:] = np.einsum("nvk,nvl->vkl", Xc, Xc)
            g = np.empty((V, kb + k))
            g[:, :kb] = Br
            g[:, kb:] = np.einsum("nvk,n->vk", Xc, rc)
            coef = _solve(G, g)
            sse = rc @ rc - np.einsum("vk,vk->v", coef, g)
            v = int(np.argmin(sse))
            if sse[v] < best[0]:
                best = (sse[v], i, v, coef[v])
        _, i, v, coef = best
        X = tensors[i]
        design = B[start:stop]
        if X is not None:
            design = np.hstack([design, X[start:stop, v, :]])
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
