"""Whole sensors chosen by a group lasso on per-test Gram matrices.

The structured-sparsity candidate of :class:`greyml.ThermalTransferFunction`:
each temperature sensor's static term and lags form one group, penalised by
the Euclidean norm of their standardised gains (Yuan and Lin, 2006), so a
sensor enters or leaves whole and the gains it keeps are shrunk together;
the drivers' terms are never dropped (only a small ridge penalty holds them).
The path runs from the penalty at which no sensor enters down to a thousandth
of it, fitted by the alternating direction method of multipliers (Boyd et
al., 2011) on every training set at once: the Grams of all training sets are
stacked and each iteration is one batched product. The penalty is chosen on
whole held-out tests, like everything else in a fit.

Pure array functions; no validation, no pandas.
"""

from __future__ import annotations

import numpy as np

from greyml.dynamic._gram import _standardised, held_out_rmse

__all__ = [
    "LAMBDA_RATIOS",
    "RIDGE",
    "group_lasso_at",
    "group_lasso_select",
]

#: The path: penalties from the one at which no sensor enters down to 1e-3 of it.
LAMBDA_RATIOS = tuple(np.geomspace(1.0, 1e-3, 13))
#: The ridge penalty (per row, standardised) that keeps the drivers' terms defined.
RIDGE = 1e-3
#: Iterations per penalty at most, and the relative change that stops them.
_MAX_ITER, _TOL = 2000, 1e-3


def _normal_forms(G, b, sw, pen):
    """Standardised, intercept-eliminated normal equations of each training set.

    ``G`` (F, p, p), ``b`` (F, p), ``sw`` (F,): summed raw Grams of F training
    sets. Returns ``(Q, c, back)``: Q (F, m, m) and c (F, m) per unit weight
    over the penalised columns, and ``back``, a function from their
    coefficients (F, L, m) to raw coefficients (F, L, p), the intercept
    (``pen`` 0, last column) restored.
    """
    F, p = b.shape
    has_intercept = bool(pen[-1] == 0)
    Q, c, scales, g_all, s0_all, bl_all = [], [], [], [], [], []
    for f in range(F):
        Gn, bn, scale = _standardised(G[f], b[f], sw[f], pen)
        if has_intercept:
            g, s0 = Gn[:-1, -1], max(float(Gn[-1, -1]), np.finfo(float).tiny)
            Gn = Gn[:-1, :-1] - np.outer(g, g) / s0
            g_all.append(g)
            s0_all.append(s0)
            bl_all.append(bn[-1])
            bn = bn[:-1] - g * (bn[-1] / s0)
        Q.append(Gn / sw[f])
        c.append(bn / sw[f])
        scales.append(scale)
    scale = np.array(scales)

    def back(beta):
        if has_intercept:
            g, s0, bl = np.array(g_all), np.array(s0_all), np.array(bl_all)
            icpt = (bl[:, None] - np.einsum("fm,flm->fl", g, beta)) / s0[:, None]
            beta = np.concatenate([beta, icpt[..., None]], axis=-1)
        return beta / scale[:, None, :]

    return np.array(Q), np.array(c), back


def _memberships(col_group, m):
    groups = np.asarray(col_group)[:m]
    labels = np.unique(groups[groups >= 0])
    M = (groups[:, None] == labels[None, :]).astype(float)  # (m, n_groups)
    return labels, M, groups < 0


def _largest_penalty(Q, c, M, free, ridge):
    """Per training set, the penalty at which no group enters (the drivers alone fitted)."""
    F, m = c.shape
    beta = np.zeros((F, m))
    if free.any():
        k = int(free.sum())
        Qd = Q[:, free][:, :, free] + ridge * np.eye(k)
        beta[:, free] = np.linalg.solve(Qd, c[:, free][..., None])[..., 0]
    if not M.shape[1]:
        return np.zeros(F), beta
    grad = np.einsum("fij,fj->fi", Q, beta) - c + ridge * beta
    size = np.sqrt(M.sum(axis=0))
    return np.max(np.sqrt((grad**2) @ M) / size, axis=1), beta


def _path(Q, c, M, free, lambdas, beta, ridge):
    """Group-lasso solutions of F problems along their penalties ``lambdas`` (F, L).

    ADMM (Boyd et al., 2011) on ``β = z``: the quadratic step is exact (one
    eigendecomposition of each problem serves every iteration and penalty),
    the other a group soft threshold, so the lag features' strong collinearity
    does not slow it as it slows a gradient method. Warm-started along the path.
    """
    F, m = c.shape
    size = np.sqrt(M.sum(axis=0))
    lam_eig, V = np.linalg.eigh(Q)
    lam_eig = np.maximum(lam_eig, 0.0) + ridge
    rho = np.sqrt(ridge * lam_eig[:, -1])[:, None]  # the geometric middle of the spectrum
    Vc = np.einsum("fji,fj->fi", V, c)
    z, u = beta.copy(), np.zeros((F, m))
    out = np.empty((F, lambdas.shape[1], m))
    for i in range(lambdas.shape[1]):
        thresh = lambdas[:, i : i + 1] * size / rho  # (F, n_groups)
        for _ in range(_MAX_ITER):
            rhs = Vc + rho * np.einsum("fji,fj->fi", V, z - u)
            x = np.einsum("fij,fj->fi", V, rhs / (lam_eig + rho))
            v = x + u
            norms = np.sqrt((v**2) @ M)
            shrink = np.maximum(0.0, 1.0 - thresh / np.maximum(norms, 1e-300))
            z_new = v * np.where(free, 1.0, shrink @ M.T)
            u = v - z_new
            dual = np.abs(z_new - z).max(axis=1, keepdims=True)
            primal = np.abs(x - z_new).max(axis=1, keepdims=True)
            z = z_new
            scale = _TOL * max(1.0, float(np.abs(z).max()))
            if primal.max() <= scale and dual.max() <= scale:
                break
            # residual balancing (Boyd et al., 2011, section 3.4.1), per problem
            up, down = primal > 10.0 * rho * dual, rho * dual > 10.0 * primal
            factor = np.where(up, 2.0, np.where(down, 0.5, 1.0))
            rho, u = rho * factor, u / factor
            thresh = lambdas[:, i : i + 1] * size / rho
        out[:, i] = _polish(Q, c, M, free, z, lambdas[:, i : i + 1] * size[None, :], ridge)
    return out


def _polish(Q, c, M, free, z, weights, ridge, steps=4):
    """Newton steps on the groups ADMM left active (the objective is smooth there).

    ADMM finds which groups are in after a few iterations but approaches the
    solution slowly; on the active groups, with the others held at 0, the
    optimality conditions ``Hβ − c + λ w_g β_g/‖β_g‖ = 0`` are smooth and
    Newton's method meets them to rounding in a few steps. ``weights`` (F,
    n_groups) are ``λ·w_g``.
    """
    F, m = z.shape
    same = M @ M.T > 0  # (m, m): columns of one group
    eye = np.eye(m)
    for _ in range(steps):
        norms = np.sqrt((z**2) @ M)  # (F, n_groups)
        active = norms > 0
        inv = np.where(active, 1.0 / np.where(active, norms, 1.0), 0.0)
        per_col = (weights * inv) @ M.T  # λ w_g / ‖β_g‖ on each column
        cubed = (weights * inv**3) @ M.T
        keep = free[None, :] | ((active.astype(float) @ M.T) > 0)
        grad = np.einsum("fij,fj->fi", Q, z) - c + ridge * z + per_col * z
        hess = Q + ridge * eye + per_col[:, :, None] * eye
        hess -= (
            np.sqrt(cubed)[:, :, None]
            * np.sqrt(cubed)[:, None, :]
            * (z[:, :, None] * z[:, None, :] * same)
        )
        both = keep[:, :, None] & keep[:, None, :]
        hess = np.where(both, hess, eye)
        grad = np.where(keep, grad, 0.0)
        try:
            step = np.linalg.solve(hess, grad[..., None])[..., 0]
        except np.linalg.LinAlgError:
            break
        new = z - step
        # a group Newton would shrink through 0 stays where ADMM left it
        if (((new**2) @ M == 0) & active).any() or not np.isfinite(new).all():
            break
        z = new
        if np.abs(step).max() <= 1e-12 * max(1.0, float(np.abs(z).max())):
            break
    return z


def group_lasso_at(G, b, sw, pen, col_group, lam, ridge=RIDGE):
    """The group-lasso coefficients (raw units, shape (p,)) of one training set at ``lam``.

    ``G``, ``b``, ``sw``: its summed raw Grams; the penalty ``lam`` is per unit
    weight on the standardised columns, as :func:`group_lasso_select` chooses it.
    """
    Q, c, back = _normal_forms(G[None], b[None], np.array([sw]), pen)
    labels, M, free = _memberships(col_group, c.shape[1])
    _, beta = _largest_penalty(Q, c, M, free, ridge)
    return back(_path(Q, c, M, free, np.array([[lam]]), beta, ridge))[0, 0]


def _choose(errors, ok):
    """The penalty's index: the lowest mean held-out RMSE among ``ok``.

    Not the sparsest within one standard error of it (the rule forward
    selection uses): a sparser group lasso drops sensors that a test unlike
    the training tests needs, and on the development fleet that rule left a
    held-out test at 14 µm where the lowest mean gave 2.7.
    """
    mean = np.where(ok, errors.mean(axis=0), np.inf)
    if not np.isfinite(mean).any():
        return int(np.flatnonzero(ok)[0]) if ok.any() else 0
    return int(np.argmin(mean))


def group_lasso_select(
    grams, pen, col_group, folds, max_groups, ratios=LAMBDA_RATIOS, lambdas=None
):
    """The group lasso with its penalty chosen on held-out tests.

    ``grams`` are per-test raw :class:`~greyml.dynamic._gram.GramBlocks`,
    ``folds`` the tests that are scored (three or more), ``max_groups`` a
    budget of sensors (None: any number). The whole data and every set
    without one test are the problems of one batched path, on the whole
    data's penalties (as glmnet's cross-validation does: a penalty means the
    same on each set). The penalty kept has the lowest mean held-out RMSE
    among those that keep at most ``max_groups`` sensors on the whole data.
    ``lambdas`` (absolute penalties, largest first) replaces the path, e.g.
    one penalty already chosen on another bank of the same sensors.

    Returns ``(coef, chosen, lam, score, path, without)``: the raw
    coefficients on all tests, the sensors (group labels) they keep, the
    penalty, its mean held-out RMSE, one ``(lambda, n_sensors, held-out
    RMSE)`` per penalty of the path, and ``{k: coefficients at that penalty
    without test k}`` (the intervals' held-out predictions).
    """
    folds = list(folds)
    G0, b0, s0 = grams.G.sum(axis=0), grams.b.sum(axis=0), grams.sw.sum()
    Gs = np.concatenate([G0[None], G0[None] - grams.G[folds]])
    bs = np.concatenate([b0[None], b0[None] - grams.b[folds]])
    sws = np.concatenate([[s0], s0 - grams.sw[folds]])
    Q, c, back = _normal_forms(Gs, bs, sws, pen)
    labels, M, free = _memberships(col_group, c.shape[1])
    lam_max, beta0 = _largest_penalty(Q, c, M, free, RIDGE)
    path_of = lam_max[0] * np.asarray(ratios) if lambdas is None else np.asarray(lambdas)
    lambdas = np.repeat(path_of[None, :], len(Gs), axis=0)
    coefs = back(_path(Q, c, M, free, lambdas, beta0, RIDGE))
    active = np.einsum("flp,pg->flg", coefs[:, :, : M.shape[0]] ** 2, M) > 0
    errors = np.array([held_out_rmse(grams, h, coefs[1 + i]) for i, h in enumerate(folds)])
    budget = np.inf if max_groups is None else max_groups
    n_active = active[0].sum(axis=1)
    j = _choose(errors, n_active <= budget)
    mean = errors.mean(axis=0)
    path = [(float(lam), int(n), float(m)) for lam, n, m in zip(lambdas[0], n_active, mean)]
    chosen = [int(g) for g in labels[active[0, j]]]
    without = {h: coefs[1 + i, j] for i, h in enumerate(folds)}
    return coefs[0, j], chosen, float(lambdas[0, j]), float(mean[j]), path, without
