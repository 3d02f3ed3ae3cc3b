"""Numerical kernels of first-order Takagi–Sugeno ANFIS (pure NumPy/SciPy).

A model with ``R`` rules over ``p`` inputs is held as

- ``mf_centres``, ``mf_widths``: 1-D arrays, the centre and the standard
  deviation of every Gaussian membership function (MF);
- ``mf_of_rule``: an int array of shape ``(R, p)``, which MF rule ``r`` uses for
  input ``j``. A grid partition shares each MF between many rules; a clustered
  partition gives every rule its own MFs. The kernels below do not care which;
- ``consequents``: shape ``(R, p + 1)``, the intercept and the slopes of each
  rule's linear consequent.

Layer by layer: Gaussian membership, product T-norm (a sum of logs), normalised
firing strengths (a softmax of the log firing strengths, so that no sample far
from every rule underflows to 0/0), linear consequents, weighted sum. Every
function is vectorised over samples and rules; there is no Python loop over
either.
"""

from __future__ import annotations

import numpy as np
import skfuzzy
from scipy.linalg import LinAlgError, cho_factor, cho_solve, lstsq

__all__ = [
    "log_firing",
    "normalised_firing",
    "anfis_forward",
    "solve_consequents",
    "premise_gradient",
    "JangStepSize",
    "hybrid_learning",
    "CHUNK_ROWS",
    "fuzzy_cmeans",
    "fcm_memberships",
    "NO_FIRE_LOG",
]

#: Log firing strength below which a rule does not fire: e^{−708.4} is the
#: smallest normal double, so a sample whose every log firing strength lies
#: below it has w = 0 in every rule in plain arithmetic (0/0 when normalised;
#: MATLAB's ``evalfis`` then reports that no rule fired and outputs the middle
#: of the output range). Passed as ``floor`` to :func:`normalised_firing`, it is
#: the constant log strength of a default rule whose output is 0.
NO_FIRE_LOG = float(np.log(np.finfo(float).tiny))

#: Rows per block when the least-squares system is accumulated, which bounds
#: memory at ``CHUNK_ROWS × R(p + 1)`` floats whatever the number of samples.
CHUNK_ROWS = 4096


def log_firing(X, centres, widths):
    """Log firing strength of every rule at every sample.

    Product T-norm of Gaussian MFs: log w_r(x) = −½ Σⱼ ((xⱼ − c_rj) / σ_rj)².

    Parameters
    ----------
    X : ndarray of shape (n, p)
    centres, widths : ndarray of shape (R, p)

    Returns
    -------
    ndarray of shape (n, R)

    Examples
    --------
    Two rules on one input, centred at 0 and 2 with σ = 1. Their firing
    strengths e^{−½((x − c)/σ)²} at x = 0 and x = 1:

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import log_firing
    >>> X = np.array([[0.0], [1.0]])
    >>> logw = log_firing(X, centres=np.array([[0.0], [2.0]]), widths=np.ones((2, 1)))
    >>> np.round(np.exp(logw), 6).tolist()
    [[1.0, 0.135335], [0.606531, 0.606531]]
    """
    with np.errstate(over="ignore", invalid="ignore"):
        inv2 = 1.0 / widths**2
        # expanded square: three matrix products instead of an (n, R, p) tensor
        quad = (X**2) @ inv2.T - 2.0 * X @ (centres * inv2).T + np.sum(centres**2 * inv2, axis=1)
    if not np.isfinite(quad).all():
        # |x| beyond ~1e154 overflows x² (inf − inf = NaN): such a sample is
        # infinitely far from the rule, log w = −inf
        quad = np.where(np.isnan(quad), np.inf, quad)
    return -0.5 * np.maximum(quad, 0.0)


def normalised_firing(logw, floor=None):
    """Normalised firing strengths w̄ = w / Σ w, computed as a softmax.

    With ``floor`` (a log firing strength, e.g. :data:`NO_FIRE_LOG`) a default
    rule that fires everywhere at strength e^floor joins the sum:
    w̄_r = w_r / (Σ w + e^floor). Its own weight, 1 − Σ w̄, is left out. Where
    some rule fires well above the floor (log w > floor + 37) the default
    rule's share is below the rounding of the sum and w̄ is bit for bit the
    plain softmax; far from every rule w̄ → 0, so the output of
    :func:`anfis_forward` goes to the default rule's output, 0.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import normalised_firing
    >>> np.round(normalised_firing(np.log([[1.0, 3.0]])), 6).tolist()
    [[0.25, 0.75]]

    A sample far from every rule (w underflows to 0) still gets weights:

    >>> normalised_firing(np.array([[-1000.0, -1000.0]])).tolist()
    [[0.5, 0.5]]

    unless a default rule is asked for, which then takes over:

    >>> from greyml.fuzzy._kernels import NO_FIRE_LOG
    >>> logw = np.array([[-1000.0, -1000.0], [-1.0, -2.0]])
    >>> normalised_firing(logw, floor=NO_FIRE_LOG).round(6).tolist()
    [[0.0, 0.0], [0.731059, 0.268941]]
    """
    top = logw.max(axis=1, keepdims=True)
    if floor is not None:
        top = np.maximum(top, floor)
    shifted = logw - top
    w = np.exp(shifted)
    total = w.sum(axis=1, keepdims=True)
    if floor is not None:
        total += np.exp(floor - top)
    w /= total
    return w


def _rule_arrays(mf_centres, mf_widths, mf_of_rule):
    return mf_centres[mf_of_rule], mf_widths[mf_of_rule]


def anfis_forward(X, mf_centres, mf_widths, mf_of_rule, consequents, floor=None):
    """Output of the network and its normalised firing strengths.

    ``floor``: see :func:`normalised_firing`. With it the output is finite for
    every finite or infinite input: a rule whose weight is 0 contributes 0
    even where its consequent overflows.

    Returns
    -------
    y : ndarray of shape (n,)
    wbar : ndarray of shape (n, R)
    rule_out : ndarray of shape (n, R)
        Each rule's consequent f_r(x) = θ_r0 + Σⱼ θ_rj xⱼ.

    Examples
    --------
    Two rules on one input, with MFs centred at 0 and 2 and consequents
    f₁ = x and f₂ = 2. Halfway between the centres both fire equally, so
    ŷ(1) = ½·1 + ½·2:

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import anfis_forward
    >>> y, wbar, rule_out = anfis_forward(
    ...     np.array([[1.0]]),
    ...     mf_centres=np.array([0.0, 2.0]),
    ...     mf_widths=np.array([1.0, 1.0]),
    ...     mf_of_rule=np.array([[0], [1]]),
    ...     consequents=np.array([[0.0, 1.0], [2.0, 0.0]]),
    ... )
    >>> np.round(y, 6).tolist(), np.round(wbar, 6).tolist(), rule_out.tolist()
    ([1.5], [[0.5, 0.5]], [[1.0, 2.0]])
    """
    C, S = _rule_arrays(mf_centres, mf_widths, mf_of_rule)
    wbar = normalised_firing(log_firing(X, C, S), floor)
    with np.errstate(over="ignore", invalid="ignore"):
        rule_out = consequents[:, 0] + X @ consequents[:, 1:].T
        y = np.einsum("nr,nr->n", wbar, rule_out)
    bad = ~np.isfinite(y)
    if bad.any():
        # 0·inf: a rule that does not fire at a far sample whose consequent overflows
        with np.errstate(over="ignore", invalid="ignore"):
            y[bad] = np.where(wbar[bad] > 0, wbar[bad] * rule_out[bad], 0.0).sum(axis=1)
    return y, wbar, rule_out


def _design_block(wbar, X):
    """Rows of the consequent design matrix: w̄_r · [1, x] for every rule."""
    n, R = wbar.shape
    Xe = np.empty((n, X.shape[1] + 1))
    Xe[:, 0] = 1.0
    Xe[:, 1:] = X
    return (wbar[:, :, None] * Xe[:, None, :]).reshape(n, -1)


def solve_consequents(wbar, X, y, alpha):
    """Ridge least squares for the linear consequents (the forward half of Jang's
    hybrid learning).

    Minimises ‖Aθ − y‖² + λ‖θ‖² with A the design matrix of w̄_r·[1, x] and
    λ = ``alpha`` × (mean diagonal of AᵀA), so ``alpha`` is free of the data's
    scale. The system is solved by Cholesky on whichever is smaller, the
    normal equations (AᵀA + λI, accumulated in row blocks so A is never held
    whole) or the dual system (AAᵀ + λI, when there are more consequent
    parameters than samples: hundreds of rules on a short test; AAᵀ is then
    formed as (w̄w̄ᵀ)∘(x̃x̃ᵀ) without A). If the
    factorisation fails (``alpha`` = 0 and A rank deficient) the minimum-norm
    least-squares solution (SVD) is used.

    Returns
    -------
    consequents : ndarray of shape (R, p + 1)

    Examples
    --------
    One rule that always fires is ordinary linear regression: y = 1 + 2x.

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import solve_consequents
    >>> X = np.array([[0.0], [1.0], [2.0]])
    >>> theta = solve_consequents(np.ones((3, 1)), X, np.array([1.0, 3.0, 5.0]), alpha=0.0)
    >>> np.round(theta, 6).tolist()
    [[1.0, 2.0]]
    """
    n, R = wbar.shape
    q = X.shape[1] + 1
    P = R * q
    if P <= n:
        G = np.zeros((P, P))
        b = np.zeros(P)
        for start in range(0, n, CHUNK_ROWS):
            A = _design_block(wbar[start : start + CHUNK_ROWS], X[start : start + CHUNK_ROWS])
            G += A.T @ A
            b += A.T @ y[start : start + CHUNK_ROWS]
        lam = alpha * np.trace(G) / P
        try:
            theta = cho_solve(cho_factor(G + lam * np.eye(P)), b)
        except LinAlgError:
            theta = _min_norm(_design_block(wbar, X), y)
    else:
        # A[n, (r, a)] = w̄[n, r]·x̃[n, a] (x̃ = [1, x]), so AAᵀ is the elementwise
        # product (w̄w̄ᵀ)∘(x̃x̃ᵀ) and Aᵀv = w̄ᵀ(x̃∘v): O(n²(R + p)), A never formed
        Xe = np.column_stack([np.ones(n), X])
        K = (wbar @ wbar.T) * (Xe @ Xe.T)
        lam = alpha * np.trace(K) / n
        try:
            dual = cho_solve(cho_factor(K + lam * np.eye(n)), y)
        except LinAlgError:
            return _min_norm(_design_block(wbar, X), y).reshape(R, q)
        return wbar.T @ (Xe * dual[:, None])
    return theta.reshape(R, q)


def _min_norm(A, y):
    return lstsq(A, y, lapack_driver="gelsd")[0]


def premise_gradient(X, err, wbar, rule_out, y_hat, mf_centres, mf_widths, mf_of_rule):
    """Gradient of ½Σe² with respect to every MF centre and width.

    With g_r = log w_r and ŷ = Σ_r w̄_r f_r: ∂ŷ/∂g_r = w̄_r (f_r − ŷ),
    ∂g_r/∂c_rj = (xⱼ − c_rj)/σ_rj², ∂g_r/∂σ_rj = (xⱼ − c_rj)²/σ_rj³. The
    per-rule gradients are summed into the MFs the rules share.

    Returns
    -------
    grad_centres, grad_widths : ndarray, shaped like ``mf_centres``

    Examples
    --------
    Rules centred at 0 and 2 (σ = 1) with constant consequents 0 and 2, one
    sample x = 1 whose target is 0: ŷ = 1, e = 1, and ∂E/∂g = e·w̄·(f − ŷ) =
    (−½, ½). Moving either centre to the right (towards x for the first
    rule, away from it for the second) lowers the error:

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import anfis_forward, premise_gradient
    >>> X = np.array([[1.0]])
    >>> c, s, rules = np.array([0.0, 2.0]), np.array([1.0, 1.0]), np.array([[0], [1]])
    >>> y_hat, wbar, rule_out = anfis_forward(X, c, s, rules, np.array([[0.0, 0.0], [2.0, 0.0]]))
    >>> grad_c, grad_s = premise_gradient(X, y_hat - 0.0, wbar, rule_out, y_hat, c, s, rules)
    >>> np.round(grad_c, 6).tolist(), np.round(grad_s, 6).tolist()
    ([-0.5, -0.5], [-0.5, 0.5])
    """
    C, S = _rule_arrays(mf_centres, mf_widths, mf_of_rule)
    G = err[:, None] * wbar * (rule_out - y_hat[:, None])  # (n, R): ∂E/∂g_r
    g_sum = G.sum(axis=0)[:, None]  # (R, 1)
    GX = G.T @ X  # (R, p)
    GX2 = G.T @ (X**2)
    d_c = (GX - g_sum * C) / S**2
    d_s = (GX2 - 2.0 * C * GX + g_sum * C**2) / S**3
    n_mf = mf_centres.size
    idx = mf_of_rule.ravel()
    grad_c = np.bincount(idx, weights=d_c.ravel(), minlength=n_mf)
    grad_s = np.bincount(idx, weights=d_s.ravel(), minlength=n_mf)
    return grad_c, grad_s


class JangStepSize:
    """Jang's heuristic step-size rule (Jang 1993; MATLAB ``anfis``).

    The step size k is the Euclidean length of each gradient step on the premise
    parameters. After each epoch, over the last five training errors: four
    consecutive reductions grow k by ``increase``; two consecutive
    increase-then-reduction pairs (the error alternating) shrink it by
    ``decrease``. The window slides, as in MATLAB's implementation, so a long
    run of reductions grows k on every epoch.

    Examples
    --------
    Four reductions in a row grow the step by 10 %:

    >>> from greyml.fuzzy._kernels import JangStepSize
    >>> step = JangStepSize(initial=0.01)
    >>> [round(step.update(e), 6) for e in [5, 4, 3, 2, 1]]
    [0.01, 0.01, 0.01, 0.01, 0.011]

    An alternating error shrinks it by 10 %:

    >>> step = JangStepSize(initial=0.01)
    >>> [round(step.update(e), 6) for e in [1, 2, 1, 2, 1]]
    [0.01, 0.01, 0.01, 0.01, 0.009]
    """

    def __init__(self, initial=0.01, increase=1.1, decrease=0.9):
        self.size = float(initial)
        self.increase = float(increase)
        self.decrease = float(decrease)
        self._errors: list[float] = []

    def update(self, error: float) -> float:
        self._errors.append(float(error))
        e = self._errors[-5:]
        if len(e) == 5:
            d = np.diff(e)
            if np.all(d < 0):
                self.size *= self.increase
            elif (d[0] > 0 > d[1] and d[2] > 0 > d[3]) or (d[0] < 0 < d[1] and d[2] < 0 < d[3]):
                self.size *= self.decrease
        return self.size


def _rmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))


def hybrid_learning(
    X,
    y,
    mf_centres,
    mf_widths,
    mf_of_rule,
    *,
    n_epochs,
    alpha,
    step,
    min_width,
    X_check=None,
    y_check=None,
    error_goal=0.0,
    floor=None,
):
    """Jang's hybrid learning: per epoch, least squares for the consequents with
    the premise fixed, then one normalised gradient step on the premise with the
    consequents fixed.

    The parameters returned are those of the epoch with the lowest checking
    error when checking data is given, else of the lowest training error (as
    MATLAB's ``anfis``). The gradient step on the widths is taken on log σ, so
    they stay positive; they are also kept at or above ``min_width`` so no MF
    collapses into a spike.

    Parameters
    ----------
    X, y : ndarray
        Training data (already scaled).
    mf_centres, mf_widths : ndarray
        Initial premise parameters; not modified.
    mf_of_rule : ndarray of int, shape (R, p)
    n_epochs : int
    alpha : float
        Ridge strength of :func:`solve_consequents`.
    step : JangStepSize
    min_width : float
    X_check, y_check : ndarray or None
    error_goal : float
        Stop once the training RMSE reaches it.
    floor : float or None
        Log strength of a default rule with output 0 (see
        :func:`normalised_firing`); ``None`` for none.

    Returns
    -------
    dict with ``mf_centres``, ``mf_widths``, ``consequents`` (the kept epoch's),
    ``best_epoch`` (1-based), ``train_error`` and ``check_error`` (RMSE per
    epoch; the latter empty without checking data) and ``step_size`` per epoch.

    Examples
    --------
    Two rules learn the kink of ``y = |x − 0.4|``:

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import JangStepSize, hybrid_learning
    >>> X = np.linspace(0.0, 1.0, 21)[:, None]
    >>> y = np.abs(X[:, 0] - 0.4)
    >>> result = hybrid_learning(
    ...     X, y, np.array([0.0, 1.0]), np.array([0.3, 0.3]), np.array([[0], [1]]),
    ...     n_epochs=20, alpha=0.0, step=JangStepSize(0.05), min_width=0.01)
    >>> result["best_epoch"], result["consequents"].shape
    (20, (2, 2))
    >>> np.round(result["train_error"][[0, -1]], 4).tolist()
    [0.0163, 0.0053]
    """
    c = np.array(mf_centres, dtype=float)
    s = np.maximum(np.array(mf_widths, dtype=float), min_width)
    checking = X_check is not None and len(X_check) > 0
    train_err, check_err, steps = [], [], []
    best = (np.inf, None)
    for epoch in range(n_epochs):
        C, S = _rule_arrays(c, s, mf_of_rule)
        wbar = normalised_firing(log_firing(X, C, S), floor)
        theta = solve_consequents(wbar, X, y, alpha)
        rule_out = theta[:, 0] + X @ theta[:, 1:].T
        y_hat = np.einsum("nr,nr->n", wbar, rule_out)
        err = y_hat - y
        e_train = _rmse(y_hat, y)
        train_err.append(e_train)
        if checking:
            y_chk = anfis_forward(X_check, c, s, mf_of_rule, theta, floor)[0]
            e_check = _rmse(y_chk, y_check)
            check_err.append(e_check)
            score = e_check
        else:
            score = e_train
        if not np.isfinite(score):
            break
        if score < best[0]:
            best = (score, (c.copy(), s.copy(), theta, epoch + 1))
        steps.append(step.size)
        if e_train <= error_goal or epoch == n_epochs - 1:
            break
        gc, gs = premise_gradient(X, err, wbar, rule_out, y_hat, c, s, mf_of_rule)
        # widths are descended on a log scale (∂E/∂log σ = σ ∂E/∂σ): they stay
        # positive by construction and a step changes them relatively
        gs *= s
        norm = np.sqrt(np.sum(gc**2) + np.sum(gs**2))
        step.update(e_train)
        if not norm > 0 or not np.isfinite(norm):
            break
        eta = step.size / norm
        c -= eta * gc
        s = np.maximum(s * np.exp(-eta * gs), min_width)
    if best[1] is None:
        raise FloatingPointError("ANFIS training produced no finite error")
    c_best, s_best, theta_best, epoch_best = best[1]
    return {
        "mf_centres": c_best,
        "mf_widths": s_best,
        "consequents": theta_best,
        "best_epoch": epoch_best,
        "train_error": np.asarray(train_err),
        "check_error": np.asarray(check_err),
        "step_size": np.asarray(steps),
    }


def fuzzy_cmeans(data, n_clusters, m, tol, max_iter, rng, n_init=1):
    """Fuzzy c-means of the rows of ``data`` (scikit-fuzzy), from partitions
    drawn from ``rng``.

    The initial partition is passed to scikit-fuzzy, so its use of NumPy's
    global random state is never reached. scikit-fuzzy stops on the Frobenius
    norm of the change of the whole c × n partition, which grows like √(cn);
    here ``tol`` is the root-mean-square change of one membership, whatever n.
    With ``n_init`` > 1, c-means runs from that many initial partitions (drawn
    one after the other from ``rng``) and the run with the lowest objective
    J_m = Σ u^m d² is kept, as k-means does with its ``n_init``.

    Returns
    -------
    centres : ndarray of shape (n_clusters, n_columns)
    u : ndarray of shape (n_clusters, n_rows)
        Memberships; not finite if c-means broke down (callers check).
    n_iter : int
    fpc : float
        Fuzzy partition coefficient (1 = crisp, 1/c = uniform).

    Examples
    --------
    Two well separated groups of points:

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import fuzzy_cmeans
    >>> data = np.array([[0.0], [0.1], [0.2], [5.0], [5.1], [5.2]])
    >>> centres, u, n_iter, fpc = fuzzy_cmeans(
    ...     data, n_clusters=2, m=2.0, tol=1e-6, max_iter=100, rng=np.random.default_rng(0))
    >>> np.round(np.sort(centres[:, 0]), 3).tolist(), u.shape, round(fpc, 3)
    ([0.1, 5.1], (2, 6), 0.999)
    """
    n = data.shape[0]
    best, best_objective = None, np.inf
    for _ in range(n_init):
        u0 = rng.random((n_clusters, n))
        u0 /= u0.sum(axis=0, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            centres, u, _, _, jm, n_iter, fpc = skfuzzy.cluster.cmeans(
                data.T, n_clusters, float(m), tol * np.sqrt(n_clusters * n), max_iter, init=u0
            )
        objective = jm[-1] if len(jm) and np.isfinite(jm[-1]) else np.inf
        if best is None or objective < best_objective:
            best, best_objective = (centres, u, int(n_iter), float(fpc)), objective
    return best


def fcm_memberships(data, centres, m):
    """Fuzzy c-means memberships of every row for fixed centres, shape (c, n).

    Examples
    --------
    With m = 2 the memberships go as 1/d²: x = 0.5 lies at distances 0.5 and
    1.5 from centres 0 and 2, so its memberships are 4 : 4/9, i.e. 0.9 : 0.1;
    x = 1 lies halfway.

    >>> import numpy as np
    >>> from greyml.fuzzy._kernels import fcm_memberships
    >>> u = fcm_memberships(np.array([[0.5], [1.0]]), np.array([[0.0], [2.0]]), m=2.0)
    >>> np.round(u, 6).tolist()
    [[0.9, 0.5], [0.1, 0.5]]
    """
    d = np.sqrt(((data[None, :, :] - centres[:, None, :]) ** 2).sum(axis=2))
    d = np.fmax(d, np.finfo(float).eps)
    inv = d ** (-2.0 / (m - 1.0))
    return inv / inv.sum(axis=0, keepdims=True)
