"""Numerical kernels of the one-hidden-layer perceptron: pure functions.

Arrays in, arrays out; no validation, no estimator state and no global random
state. The network with ``n_in`` inputs, ``n_hidden`` hidden units of activation
σ and one linear output is

    ŷ = σ(X W + b) v + c,

with ``W`` of shape (n_in, n_hidden), ``b`` and ``v`` of shape (n_hidden,) and
``c`` a scalar. All of them travel as one flat parameter vector

    p = [W.ravel() (row-major), b, v, c],

of length ``n_params(n_in, n_hidden) = n_hidden (n_in + 2) + 1``, the layout
that :func:`mlp_jacobian` differentiates against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, cho_factor, cho_solve

__all__ = [
    "ACTIVATIONS",
    "n_params",
    "pack",
    "unpack",
    "hidden",
    "mlp_forward",
    "mlp_residuals",
    "mlp_jacobian",
    "init_nguyen_widrow",
    "levenberg_marquardt",
    "LMResult",
]

#: Hidden-layer activations: "logistic" is MATLAB's logsig, "tanh" its tansig.
ACTIVATIONS = ("logistic", "tanh")


def n_params(n_in: int, n_hidden: int) -> int:
    """Number of weights and biases of an ``n_in``-``n_hidden``-1 network.

    Examples
    --------
    A 2-3-1 network: 2 × 3 input weights, 3 hidden biases, 3 output weights
    and the output bias.

    >>> from greyml.neural._kernels import n_params
    >>> n_params(2, 3)
    13
    """
    return n_hidden * (n_in + 2) + 1


def pack(W, b, v, c) -> np.ndarray:
    """Flat parameter vector ``[W.ravel(), b, v, c]``.

    Examples
    --------
    >>> from greyml.neural._kernels import pack
    >>> pack(W=[[1.0, 2.0]], b=[3.0, 4.0], v=[5.0, 6.0], c=7.0).tolist()
    [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
    """
    return np.concatenate(
        [np.ravel(W), np.ravel(b), np.ravel(v), np.atleast_1d(np.asarray(c, dtype=float))]
    ).astype(float, copy=False)


def unpack(p, n_in: int, n_hidden: int):
    """``(W, b, v, c)`` from a flat parameter vector (views, not copies).

    Examples
    --------
    The inverse of :func:`pack`, for one input and two hidden units:

    >>> from greyml.neural._kernels import unpack
    >>> W, b, v, c = unpack([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0], n_in=1, n_hidden=2)
    >>> W.tolist(), b.tolist(), v.tolist(), c
    ([[1.0, 2.0]], [3.0, 4.0], [5.0, 6.0], 7.0)
    """
    p = np.asarray(p, dtype=float)
    k = n_in * n_hidden
    W = p[:k].reshape(n_in, n_hidden)
    b = p[k : k + n_hidden]
    v = p[k + n_hidden : k + 2 * n_hidden]
    c = p[k + 2 * n_hidden]
    return W, b, v, float(c)


def hidden(X, W, b, activation: str = "logistic") -> np.ndarray:
    """Hidden-layer outputs σ(X W + b), shape (n_samples, n_hidden).

    Examples
    --------
    At z = 0 and z = ln 3 the logistic function is ½ and ¾, tanh 0 and 0.8:

    >>> import numpy as np
    >>> from greyml.neural._kernels import hidden
    >>> X, W, b = np.zeros((1, 1)), np.ones((1, 2)), np.array([0.0, np.log(3.0)])
    >>> np.round(hidden(X, W, b), 6).tolist()
    [[0.5, 0.75]]
    >>> np.round(hidden(X, W, b, "tanh"), 6).tolist()
    [[0.0, 0.8]]
    """
    Z = X @ W
    Z += b
    if activation == "logistic":
        # σ(z) = (1 + tanh(z/2))/2: the same function, several times faster than
        # scipy.special.expit in NumPy's vectorised tanh
        Z *= 0.5
        np.tanh(Z, out=Z)
        Z *= 0.5
        Z += 0.5
        return Z
    if activation == "tanh":
        return np.tanh(Z, out=Z)
    raise ValueError(f"Unknown activation {activation!r}; expected one of {ACTIVATIONS}.")


def mlp_forward(X, p, n_hidden: int, activation: str = "logistic") -> np.ndarray:
    """Network output ŷ of shape (n_samples,) for inputs ``X`` (n_samples, n_in).

    Examples
    --------
    One hidden unit: ŷ = 2σ(x) + 1, so ŷ(0) = 2 and ŷ(ln 3) = 2.5.

    >>> import numpy as np
    >>> from greyml.neural._kernels import mlp_forward, pack
    >>> p = pack(W=[[1.0]], b=[0.0], v=[2.0], c=1.0)
    >>> np.round(mlp_forward(np.array([[0.0], [np.log(3.0)]]), p, n_hidden=1), 6).tolist()
    [2.0, 2.5]
    """
    X = np.asarray(X, dtype=float)
    W, b, v, c = unpack(p, X.shape[1], n_hidden)
    return hidden(X, W, b, activation) @ v + c


def mlp_residuals(X, y, p, n_hidden: int, activation: str = "logistic") -> np.ndarray:
    """Residuals ŷ − y, shape (n_samples,).

    Examples
    --------
    The network of :func:`mlp_forward`'s example against targets of 2:

    >>> import numpy as np
    >>> from greyml.neural._kernels import mlp_residuals, pack
    >>> p = pack(W=[[1.0]], b=[0.0], v=[2.0], c=1.0)
    >>> X, y = np.array([[0.0], [np.log(3.0)]]), np.array([2.0, 2.0])
    >>> np.round(mlp_residuals(X, y, p, n_hidden=1), 6).tolist()
    [0.0, 0.5]
    """
    return mlp_forward(X, p, n_hidden, activation) - y


def mlp_jacobian(X, p, n_hidden: int, activation: str = "logistic", out=None):
    """Jacobian ∂ŷ/∂p (equal to ∂(ŷ − y)/∂p), shape (n_samples, n_params).

    With A = σ(X W + b) and D = σ'(X W + b) · v (row-wise):
    ∂ŷ/∂W[i, j] = X[:, i] D[:, j], ∂ŷ/∂b = D, ∂ŷ/∂v = A, ∂ŷ/∂c = 1.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_in)
    p : ndarray of shape (n_params,)
    n_hidden : int
    activation : {"logistic", "tanh"}
    out : ndarray of shape (n_samples, n_params), optional
        Written in place when given (saves an allocation per iteration).

    Returns
    -------
    J : ndarray of shape (n_samples, n_params)
    y_hat : ndarray of shape (n_samples,)
        The network output at ``p``, computed on the way.

    Examples
    --------
    For ŷ = 2σ(x) + 1 at x = 0: A = ½ and D = σ'(0)·v = ¼·2, so the
    derivatives with respect to (W, b, v, c) are (0·½, ½, ½, 1).

    >>> import numpy as np
    >>> from greyml.neural._kernels import mlp_jacobian, pack
    >>> p = pack(W=[[1.0]], b=[0.0], v=[2.0], c=1.0)
    >>> J, y_hat = mlp_jacobian(np.array([[0.0]]), p, n_hidden=1)
    >>> J.tolist(), y_hat.tolist()
    ([[0.0, 0.5, 0.5, 1.0]], [2.0])
    """
    X = np.asarray(X, dtype=float)
    n, n_in = X.shape
    W, b, v, c = unpack(p, n_in, n_hidden)
    A = hidden(X, W, b, activation)
    if activation == "logistic":
        D = A * (1.0 - A)
    else:
        D = 1.0 - A * A
    D *= v
    if out is None:
        out = np.empty((n, n_params(n_in, n_hidden)))
    m = (n_in + 1) * n_hidden
    # [X, 1] ⊗ D fills the W block (row-major) and the b block in one product;
    # splitting the contiguous column range of `out` into (n_in + 1, n_hidden) is a view
    block = out[:, :m].reshape(n, n_in + 1, n_hidden)
    np.multiply(X[:, :, None], D[:, None, :], out=block[:, :n_in, :])
    block[:, n_in, :] = D
    out[:, m : m + n_hidden] = A
    out[:, -1] = 1.0
    return out, A @ v + c


def init_nguyen_widrow(
    n_in: int, n_hidden: int, rng: np.random.Generator, activation: str = "logistic"
) -> np.ndarray:
    """Nguyen–Widrow initial parameters for standardised inputs.

    Each hidden unit gets a random direction of length β = 0.7 n_hidden^(1/n_in)
    and a bias uniform in [−β, β], so that the units' active regions tile the
    region of the (standardised) inputs; the widths are doubled for the logistic
    function, whose active region is twice that of tanh (σ(z) = (1 + tanh(z/2))/2).
    Output weights are uniform in [−1, 1]/√n_hidden, the output bias 0.

    Parameters
    ----------
    n_in, n_hidden : int
    rng : numpy.random.Generator
    activation : {"logistic", "tanh"}

    Returns
    -------
    p : ndarray of shape (n_params(n_in, n_hidden),)

    References
    ----------
    Nguyen, D. and Widrow, B. (1990). Improving the learning speed of 2-layer
    neural networks by choosing initial values of the adaptive weights. IJCNN
    1990, vol. 3, 21-26.

    Examples
    --------
    Whatever the draw, every hidden unit's input weights have the length
    2β = 2 · 0.7 · 3^(1/2) = 2.424871 for 2 inputs and 3 logistic units:

    >>> import numpy as np
    >>> from greyml.neural._kernels import init_nguyen_widrow, unpack
    >>> p = init_nguyen_widrow(2, 3, np.random.default_rng(0))
    >>> p.shape
    (13,)
    >>> W, b, v, c = unpack(p, 2, 3)
    >>> np.round(np.linalg.norm(W, axis=0), 6).tolist(), c
    ([2.424871, 2.424871, 2.424871], 0.0)
    """
    beta = 0.7 * n_hidden ** (1.0 / n_in)
    W = rng.uniform(-1.0, 1.0, size=(n_in, n_hidden))
    norms = np.sqrt(np.sum(W * W, axis=0))
    norms[norms == 0.0] = 1.0
    W *= beta / norms
    b = rng.uniform(-beta, beta, size=n_hidden)
    if activation == "logistic":
        W *= 2.0
        b *= 2.0
    v = rng.uniform(-1.0, 1.0, size=n_hidden) / np.sqrt(n_hidden)
    return pack(W, b, v, 0.0)


@dataclass
class LMResult:
    """What :func:`levenberg_marquardt` returns.

    Attributes
    ----------
    p : ndarray of shape (n_params,)
        The parameters kept: those of the lowest checking error when checking
        data were given, else the last accepted ones.
    loss : float
        Training MSE at ``p``.
    val_loss : float or None
        Checking MSE at ``p`` (``None`` without checking data).
    n_iter : int
        Epochs (accepted or final Levenberg–Marquardt iterations) run.
    best_iter : int
        Epoch whose parameters were kept (0: the initial ones).
    stop : str
        Why training stopped: "goal", "max_iter", "max_fail", "min_grad" or "mu_max".

    Examples
    --------
    With no epoch to run, the result holds the initial parameters and their
    loss: ŷ = 2σ(0) + 1 = 2 against a target of 1.

    >>> import numpy as np
    >>> from greyml.neural._kernels import levenberg_marquardt, pack
    >>> p = pack(W=[[1.0]], b=[0.0], v=[2.0], c=1.0)
    >>> result = levenberg_marquardt(np.array([[0.0]]), np.array([1.0]), p, 1, max_iter=0)
    >>> result.loss, result.val_loss, result.n_iter, result.best_iter, result.stop
    (1.0, None, 0, 0, 'max_iter')
    """

    p: np.ndarray
    loss: float
    val_loss: float | None
    n_iter: int
    best_iter: int
    stop: str


def _mse(r):
    return float(r @ r) / r.size


def levenberg_marquardt(
    X,
    y,
    p0,
    n_hidden: int,
    activation: str = "logistic",
    *,
    X_val=None,
    y_val=None,
    max_iter: int = 5000,
    goal: float = 0.0,
    max_fail: int = 6,
    mu: float = 1e-3,
    mu_dec: float = 0.1,
    mu_inc: float = 10.0,
    mu_max: float = 1e10,
    min_grad: float = 1e-7,
) -> LMResult:
    """Train the network by Levenberg–Marquardt, as MATLAB's ``trainlm`` does.

    Each epoch solves (JᵀJ + μI) δ = Jᵀr by Cholesky with the analytic Jacobian
    and accepts p − δ if it lowers the training MSE, then μ ← μ·``mu_dec``;
    otherwise μ ← μ·``mu_inc`` and the step is solved again. Training stops when
    the training MSE reaches ``goal``, after ``max_iter`` epochs, when the
    gradient norm of the MSE falls below ``min_grad``, when μ exceeds
    ``mu_max``, or, with checking data, after ``max_fail`` consecutive epochs
    without a new lowest checking MSE; the parameters with the lowest checking
    MSE are then returned.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_in)
    y : ndarray of shape (n_samples,)
    p0 : ndarray of shape (n_params,)
        Initial parameters (not modified).
    n_hidden : int
    activation : {"logistic", "tanh"}
    X_val, y_val : ndarray, optional
        Checking data for the validation stop; ``None`` or empty disables it.
    max_iter, goal, max_fail, mu, mu_dec, mu_inc, mu_max, min_grad
        ``trainlm``'s ``epochs``, ``goal``, ``max_fail``, ``mu``, ``mu_dec``,
        ``mu_inc``, ``mu_max`` and ``min_grad``; μ never drops below 1e-20.

    Returns
    -------
    LMResult

    Examples
    --------
    Three logistic units fitted to a sine on 21 points:

    >>> import numpy as np
    >>> from greyml.neural._kernels import init_nguyen_widrow, levenberg_marquardt
    >>> X = np.linspace(-2.0, 2.0, 21)[:, None]
    >>> y = np.sin(X[:, 0])
    >>> p0 = init_nguyen_widrow(1, 3, np.random.default_rng(0))
    >>> start = levenberg_marquardt(X, y, p0, 3, max_iter=0)
    >>> result = levenberg_marquardt(X, y, p0, 3, max_iter=200)
    >>> round(start.loss, 2), bool(result.loss < 1e-3), result.p.shape
    (0.79, True, (10,))
    """
    X = np.asarray(X, dtype=float)
    y = np.asarray(y, dtype=float)
    n = y.size
    p = np.array(p0, dtype=float)
    n_par = p.size
    diag = np.diag_indices(n_par)
    use_val = X_val is not None and y_val is not None and len(y_val) > 0

    J = np.empty((n, n_par))
    J, y_hat = mlp_jacobian(X, p, n_hidden, activation, out=J)
    r = y_hat - y
    perf = _mse(r)
    if use_val:
        best_val = _mse(mlp_residuals(X_val, y_val, p, n_hidden, activation))
        best_p, best_perf, best_iter, n_fail = p.copy(), perf, 0, 0

    stop = "max_iter"
    epoch = 0
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        while True:
            if perf <= goal:
                stop = "goal"
                break
            if epoch >= max_iter:
                break
            JtJ = J.T @ J
            g = J.T @ r
            if 2.0 * np.sqrt(g @ g) / n < min_grad:
                stop = "min_grad"
                break
            accepted = False
            while mu <= mu_max:
                H = JtJ.copy()
                H[diag] += mu
                try:
                    step = cho_solve(cho_factor(H, check_finite=False), g, check_finite=False)
                except LinAlgError:
                    step = None
                if step is not None and np.isfinite(step).all():
                    p_new = p - step
                    r_new = mlp_residuals(X, y, p_new, n_hidden, activation)
                    perf_new = _mse(r_new)
                    if perf_new < perf:
                        p, perf = p_new, perf_new
                        mu = max(mu * mu_dec, 1e-20)
                        accepted = True
                        break
                mu *= mu_inc
            if not accepted:
                stop = "mu_max"
                break
            epoch += 1
            J, y_hat = mlp_jacobian(X, p, n_hidden, activation, out=J)
            r = y_hat - y
            if use_val:
                val = _mse(mlp_residuals(X_val, y_val, p, n_hidden, activation))
                if val < best_val:
                    best_val, best_p, best_perf, best_iter, n_fail = val, p.copy(), perf, epoch, 0
                else:
                    n_fail += 1
                    if n_fail >= max_fail:
                        stop = "max_fail"
                        break
    if use_val:
        return LMResult(best_p, best_perf, best_val, epoch, best_iter, stop)
    return LMResult(p, perf, None, epoch, epoch, stop)
