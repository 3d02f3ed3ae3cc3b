"""Kernels of the GMC(1,N) time response: pure functions, arrays in, arrays out.

The one response (:func:`gmc_response`) and what is built on it: the
prediction of one parameter set, of a population, the basis of the variable
projection and the layers of GNNMCI(1,N). Like :mod:`greyml.grey._kernels`,
every function that walks along time takes ``test_bounds``, one ``(start,
stop)`` row range per test, and never lets a recursion cross from one test to
the next.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from greyml.grey._kernels import _as_test_bounds, _scaled_lstsq, iago
from greyml.optimize._base import PENALTY

__all__ = [
    "gmc_forcing",
    "gmc_initial",
    "gmc_response",
    "gmc_predict",
    "gmc_predict_population",
    "gmc_sse_population",
    "gmc_basis",
    "gmc_separable",
    "gnnmci_layers",
]

# Largest exponent we let a growing response reach before calling it exploded
# (e^600 ~ 1e260 leaves room for the data's own magnitude below float max).
_MAX_EXPONENT = 600.0


def gmc_forcing(X1, coef, control):
    """f(k) = Σⱼ bⱼ xⱼ⁽¹⁾(k) + u.

    ``coef`` of shape ``(N-1,)`` gives ``(n,)``; of shape ``(P, N-1)`` with
    ``control`` of shape ``(P,)`` gives ``(n, P)``, one column per candidate.
    """
    return X1 @ np.asarray(coef, dtype=float).T + control


def gmc_initial(f1, b1, initial):
    """The response's starting value x̂₁⁽¹⁾(1) = x̂₁⁽⁰⁾(1).

    ``"model"``: the grey equation at k = 1, where z₁⁽¹⁾(1) = x₁⁽¹⁾(1), gives
    x₁⁽⁰⁾(1)(1 + b₁) = f(1); ``"zero"``: the displacement is referenced to the
    start of the test (a probe datum), so x₁⁽⁰⁾(1) = 0.
    """
    f1 = np.asarray(f1, dtype=float)
    if initial == "zero":
        return np.zeros_like(f1)
    denom = 1.0 + np.asarray(b1, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return np.where(np.abs(denom) > 1e-12, f1 / np.where(denom == 0, 1.0, denom), np.inf)


def gmc_response(f, b1, x0, form="trapezoid", test_bounds=None):
    """GMC(1,N) time response x̂₁⁽¹⁾(k) of every test, in O(n).

    The one implementation of the response: :func:`gmc_predict`,
    :func:`gmc_predict_population`, :func:`gmc_basis`, :func:`gnnmci_layers`
    and ``simulate_gmc`` all run it. The recursion restarts at
    every test's first row.

    Parameters
    ----------
    f : ndarray of shape (n,) or (n, P)
        Forcing f(k) = Σⱼ bⱼ xⱼ⁽¹⁾(k) + u; 2-D: one column per series (a
        candidate of a population, or a column of a basis).
    b1 : float or ndarray of shape (P,)
        Development coefficient, shared by the columns or one per column.
    x0 : float or array-like
        Starting value x̂₁⁽¹⁾(1) of each test: a scalar, one per test (shape
        ``(n_tests,)`` for 1-D ``f``), or broadcast to ``(n_tests, P)``.
    form : {"trapezoid", "midpoint"}
        ``"trapezoid"`` (Tien 2012, Abdulshahed et al. (2017))::

            x̂(k) = x0·e^{−b₁(k−1)} + ½e^{−b₁(k−1)}f(1) + Σ_{τ=2}^{k−1} e^{−b₁(k−τ)}f(τ) + ½f(k)

        ``"midpoint"`` (Abdulshahed et al. (2016))::

            x̂(k) = x0·e^{−b₁(k−1)} + Σ_{τ=2}^{k} ½e^{−b₁(k−τ+½)}[f(τ) + f(τ−1)]
    test_bounds : sequence of (start, stop) or None, default=None
        Row ranges of the tests; ``None``: one test.

    Returns
    -------
    x1_hat : ndarray of the shape of ``f``
        May contain ``inf`` if the response explodes (b₁ ≪ 0); callers decide.

    Notes
    -----
    With a = e^{−b₁}, the trapezoid sum obeys P(k) = a·P(k−1) + f(k),
    P(1) = x0 + ½f(1), and x̂(k) = P(k) − ½f(k); the midpoint sum obeys
    M(k) = a·M(k−1) + ½√a·(f(k) + f(k−1)), M(1) = x0. Both are first-order linear
    filters, run by :func:`scipy.signal.lfilter` in compiled code.

    Examples
    --------
    With b₁ = ln 2 (a = ½), a constant forcing f = 1 and x0 = 1, the
    trapezoid form gives x̂(2) = ½·1 + ½·½·1 + ½·1 = 1.25, and so on:

    >>> import numpy as np
    >>> from greyml.grey._response import gmc_response
    >>> np.round(gmc_response([1.0, 1.0, 1.0], np.log(2), 1.0), 6).tolist()
    [1.0, 1.25, 1.375]

    Without development (b₁ = 0) the forcing simply accumulates:

    >>> np.round(gmc_response([1.0, 1.0, 1.0], 0.0, 1.0), 6).tolist()
    [1.0, 2.0, 3.0]
    """
    if form not in ("trapezoid", "midpoint"):
        raise ValueError(f"Unknown response form {form!r}; use 'trapezoid' or 'midpoint'.")
    f = np.asarray(f, dtype=float)
    F = f.reshape(f.shape[0], -1)
    ranges = _as_test_bounds(test_bounds, F.shape[0])
    x0 = np.asarray(x0, dtype=float)
    X0 = np.broadcast_to(
        x0[:, None] if f.ndim == 1 and x0.ndim == 1 else x0, (len(ranges), F.shape[1])
    )
    out = np.empty_like(F)
    with np.errstate(over="ignore", invalid="ignore"):
        decay = np.exp(-np.asarray(b1, dtype=float))
        for i, (a, b) in enumerate(ranges):
            if b == a:
                continue
            if decay.ndim == 0:
                out[a:b] = _recursion(F[a:b], decay, X0[i], form)
                continue
            for j in range(F.shape[1]):
                out[a:b, j : j + 1] = _recursion(
                    F[a:b, j : j + 1], decay[j], X0[i, j : j + 1], form
                )
    return out.reshape(f.shape)


def _recursion(F, decay, x0, form):
    """One test's response for the columns of ``F`` (m, P) sharing ``decay`` = e^{−b₁}."""
    if form == "trapezoid":
        p, _ = lfilter([1.0], [1.0, -decay], F, axis=0, zi=(x0 - 0.5 * F[0])[None, :])
        return p - 0.5 * F
    G = np.zeros_like(F)
    G[1:] = (0.5 * np.sqrt(decay)) * (F[1:] + F[:-1])
    m, _ = lfilter([1.0], [1.0, -decay], G, axis=0, zi=np.array(x0)[None, :])
    return m


def _explodes(b1, n):
    """True where e^{−b₁(n−1)} would overflow: the trajectory is unusable."""
    return (-np.asarray(b1, dtype=float)) * max(n - 1, 0) > _MAX_EXPONENT


def _first_rows(F, ranges):
    """Each test's first row of ``F`` (zeros for an empty test)."""
    rows = [F[a] if b > a else np.zeros(F.shape[1:]) for a, b in ranges]
    return np.array(rows, dtype=float).reshape((len(ranges),) + F.shape[1:])


def _gmc_tests(F, b1, x0, ranges, form):
    """x̂₁⁽⁰⁾, the IAGO of :func:`gmc_response`, for every test and column of ``F``.

    ``inf`` for a whole test and column whose response explodes
    (:func:`_explodes`) or whose start is not finite, and wherever a value is
    not finite. A column skipped in every test is not run at all.
    """
    x0 = np.broadcast_to(x0, (len(ranges), F.shape[1]))
    skip = np.array(
        [~np.isfinite(x0[i]) | _explodes(b1, b - a) for i, (a, b) in enumerate(ranges)]
    ).reshape(x0.shape)
    run = ~skip.all(axis=0)
    if not run.all():  # only the columns that run in some test
        out = np.full(F.shape, np.inf)
        if run.any():
            b1 = np.asarray(b1)[run] if np.ndim(b1) == 1 else b1
            out[:, run] = _gmc_tests(F[:, run], b1, x0[:, run], ranges, form)
        return out
    with np.errstate(over="ignore", invalid="ignore"):
        out = iago(gmc_response(F, b1, x0, form, ranges), ranges)
    for i, (a, b) in enumerate(ranges):
        out[a:b, skip[i]] = np.inf
    out[~np.isfinite(out)] = np.inf
    return out


def gmc_predict(
    X1, b1, coef, control, test_bounds=None, form="trapezoid", initial="model", start=None
):
    """Predicted x̂₁⁽⁰⁾ of every test (IAGO of the time response), shape ``(n,)``.

    ``X1`` holds the 1-AGO of the drivers (per test). Values of an exploding
    trajectory come back as ``inf`` (never NaN); callers decide what to do.
    ``start`` (one value per test, or ``None``) gives a test's measured value
    at its first row, x₁⁽⁰⁾(1), for a test that starts mid-run. It is the
    response's starting value x̂₁⁽¹⁾(1), and the inputs accumulated before
    the test, which its own 1-AGO does not see, add a constant c to its
    forcing: the one for which the grey equation holds at k = 1,
    x₁⁽⁰⁾(1)(1 + b₁) = f(1) + c. The prediction then relaxes from the
    measured value at the model's own rate b₁; with b₁ = 0 it is the measured
    value plus the change the model predicts since the first row. (The
    starting value alone would only add a transient that decays like
    e^{−b₁k}: with a small b₁ the prediction would fall back to the cold
    start's level from the second row on.) Where ``start`` is ``None`` or
    NaN, the response starts as ``initial`` says (:func:`gmc_initial`).

    Examples
    --------
    One driver, b₁ = 0.4, b₂ = 0.5, u = 0.1. The first value is the grey
    equation at k = 1: f(1)/(1 + b₁) = (0.5·1 + 0.1)/1.4 = 0.428571.

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago
    >>> from greyml.grey._response import gmc_predict
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]))
    >>> np.round(gmc_predict(X1, 0.4, [0.5], 0.1), 6).tolist()
    [0.428571, 0.859805, 1.161504, 1.69616]

    Split into two tests, each starts afresh from its own first value:

    >>> test_bounds = [(0, 2), (2, 4)]
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]), test_bounds)
    >>> np.round(gmc_predict(X1, 0.4, [0.5], 0.1, test_bounds), 6).tolist()
    [0.428571, 0.859805, 0.428571, 1.109805]

    The second test starting mid-run, from a measured 5.0; it relaxes at the
    rate b₁ = 0.4. With b₁ = 0 it keeps 5.0 plus the change the model
    predicts from its first row (1.35 − 0.6):

    >>> np.round(gmc_predict(X1, 0.4, [0.5], 0.1, test_bounds, start=[np.nan, 5.0]), 6).tolist()
    [0.428571, 0.859805, 5.0, 4.94772]
    >>> np.round(gmc_predict(X1, 0.0, [0.5], 0.1, test_bounds), 6).tolist()
    [0.6, 1.1, 0.6, 1.35]
    >>> np.round(gmc_predict(X1, 0.0, [0.5], 0.1, test_bounds, start=[np.nan, 5.0]), 6).tolist()
    [0.6, 1.1, 5.0, 5.75]
    """
    X1 = np.asarray(X1, dtype=float)
    ranges = _as_test_bounds(test_bounds, X1.shape[0])
    with np.errstate(over="ignore", invalid="ignore"):
        f = gmc_forcing(X1, coef, control)
        x0 = gmc_initial(_first_rows(f, ranges), b1, initial)
        for i, (a, b) in enumerate(ranges):
            given = np.nan if start is None else float(start[i])
            if b > a and np.isfinite(given):
                # started mid-run: the inputs accumulated before the test add a
                # constant to its forcing, the one that makes the grey equation
                # hold at k = 1 with the measured value, x(1)(1 + b1) = f(1) + c
                f[a:b] += given * (1.0 + b1) - f[a]
                x0[i] = given
    return _gmc_tests(f[:, None], b1, x0[:, None], ranges, form)[:, 0]


def gmc_predict_population(X1, params, test_bounds=None, form="trapezoid", initial="model"):
    """Predictions for a population of parameter vectors ``(b₁, b₂…b_N, u)``.

    ``params`` has shape ``(P, N+1)``; returns ``(n, P)``. The forcing of all
    candidates is one matrix product; each candidate's recursion is one compiled
    :func:`~scipy.signal.lfilter` call per test.

    Examples
    --------
    Three candidates: the coefficients of :func:`gmc_predict`'s example, the
    same without the driver, and one whose response explodes (b₁ ≪ 0):

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago
    >>> from greyml.grey._response import gmc_predict, gmc_predict_population
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]))
    >>> params = [[0.4, 0.5, 0.1], [0.4, 0.0, 0.1], [-400.0, 0.5, 0.1]]
    >>> P = gmc_predict_population(X1, params)
    >>> P.shape
    (4, 3)
    >>> bool(np.allclose(P[:, 0], gmc_predict(X1, 0.4, [0.5], 0.1)))
    True
    >>> np.isinf(P[:, 2]).tolist()
    [True, True, True, True]
    """
    X1 = np.asarray(X1, dtype=float)
    params = np.atleast_2d(np.asarray(params, dtype=float))
    ranges = _as_test_bounds(test_bounds, X1.shape[0])
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        F = gmc_forcing(X1, params[:, 1:-1], params[:, -1])
        x0 = gmc_initial(_first_rows(F, ranges), params[:, 0], initial)
    return _gmc_tests(F, params[:, 0], x0, ranges, form)


def gmc_sse_population(X1, y, params, test_bounds=None, form="trapezoid", initial="model"):
    """Σ(x̂₁⁽⁰⁾ − x₁⁽⁰⁾)² for each candidate, shape ``(P,)``, always finite.

    A candidate whose trajectory explodes or overflows gets ``PENALTY``.

    Examples
    --------
    Data from the first candidate: its loss is 0, the exploding third one
    gets 1e200.

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago
    >>> from greyml.grey._response import gmc_predict, gmc_sse_population
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]))
    >>> y = gmc_predict(X1, 0.4, [0.5], 0.1)
    >>> params = [[0.4, 0.5, 0.1], [0.4, 0.0, 0.1], [-400.0, 0.5, 0.1]]
    >>> np.round(gmc_sse_population(X1, y, params), 6).tolist()
    [0.0, 4.810897, 1e+200]
    """
    pred = gmc_predict_population(X1, params, test_bounds, form, initial)
    with np.errstate(over="ignore", invalid="ignore"):
        resid = pred - np.asarray(y, dtype=float)[:, None]
        sse = np.einsum("ij,ij->j", resid, resid)
    sse[~np.isfinite(sse)] = PENALTY
    return np.minimum(sse, PENALTY)


def gmc_basis(X1, b1, test_bounds=None, form="trapezoid", initial="model"):
    """Prediction x̂₁⁽⁰⁾ as a linear map of θ = (b₂…b_N, u) for a fixed b₁.

    For a fixed development coefficient the time response is linear in the
    forcing and in its starting value, and both are linear in θ, so
    x̂₁⁽⁰⁾ = Φ(b₁)·θ. Returns Φ of shape ``(n, N)``: column j is the prediction
    with bⱼ = 1 and every other coefficient 0; the last column is u's. All
    columns run through one :func:`~scipy.signal.lfilter` call per test.
    Non-finite entries (an exploding response) come back as ``inf``.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.grey._kernels import ago
    >>> from greyml.grey._response import gmc_basis, gmc_predict
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]))
    >>> phi = gmc_basis(X1, 0.4)
    >>> phi.shape
    (4, 2)
    >>> bool(np.allclose(phi @ [0.5, 0.1], gmc_predict(X1, 0.4, [0.5], 0.1)))
    True
    """
    X1 = np.asarray(X1, dtype=float)
    U = np.column_stack([X1, np.ones(X1.shape[0])])
    ranges = _as_test_bounds(test_bounds, U.shape[0])
    x0 = gmc_initial(_first_rows(U, ranges), b1, initial)
    return _gmc_tests(U, b1, x0, ranges, form)


def gmc_separable(X1, y, b1, test_bounds=None, form="trapezoid", initial="model"):
    """Best (b₂…b_N, u) for each candidate b₁, and the resulting loss.

    Variable projection (Golub & Pereyra 1973): for every b₁ in ``b1`` (shape
    ``(P,)``) the linear coefficients solve min ‖Φ(b₁)θ − y‖² exactly.

    Returns
    -------
    sse : ndarray of shape (P,)
        Finite; ``PENALTY`` for a candidate whose response explodes.
    theta : ndarray of shape (P, N)
        (b₂…b_N, u) per candidate (zeros where the response explodes).

    Examples
    --------
    Data made with b₁ = 0.4, b₂ = 0.5 and u = 0.1: of three candidate b₁,
    the true one fits exactly, with the true linear coefficients.

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago
    >>> from greyml.grey._response import gmc_predict, gmc_separable
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]))
    >>> y = gmc_predict(X1, 0.4, [0.5], 0.1)
    >>> sse, theta = gmc_separable(X1, y, [0.2, 0.4, 0.6])
    >>> np.round(sse, 6).tolist()
    [0.003932, 0.0, 0.004839]
    >>> np.round(theta[1], 6).tolist()
    [0.5, 0.1]
    """
    b1 = np.atleast_1d(np.asarray(b1, dtype=float))
    y = np.asarray(y, dtype=float)
    q = np.asarray(X1).shape[1] + 1
    sse = np.full(b1.shape[0], PENALTY)
    theta = np.zeros((b1.shape[0], q))
    scale = max(float(np.abs(y).max(initial=0.0)), 1.0)
    for i, b in enumerate(b1):
        phi = gmc_basis(X1, b, test_bounds, form, initial)
        if not np.isfinite(phi).all() or np.abs(phi).max(initial=0.0) > 1e150:
            continue
        # column scaling keeps lstsq well conditioned whatever the drivers' units
        coef, _, _ = _scaled_lstsq(phi, y)
        resid = phi @ coef - y
        value = float(resid @ resid)
        if np.isfinite(value) and np.abs(coef).max(initial=0.0) < 1e100 * scale:
            sse[i] = min(value, PENALTY)
            theta[i] = coef
    return sse, theta


def gnnmci_layers(X1, b1, coef, control, x0):
    """Layer outputs of Abdulshahed et al.'s (2016) grey neural network GNNMCI(1,N) for one test.

    The network maps the midpoint time response of GMC(1,N) onto four layers,
    evaluated for k = 1..n−1 (the output is x̂₁⁽¹⁾(k+1)):

    - A: a = w₁₁k with w₁₁ = b₁;
    - B: b = 1 / (1 + e^{−a}), the sigmoid;
    - C: c₁ = b·w₂₁ with w₂₁ = −x̂₁⁽¹⁾(1); cⱼ = Gⱼ(k)·b·w₂ⱼ with w₂ⱼ = bⱼ and
      Gⱼ the convolution of the accumulated input j (midpoint form); the last
      unit carries u with G_u the convolution of a constant 1;
    - D: d = Σ w₃ⱼcⱼ − θ with every w₃ⱼ = 1 + e^{−b₁k} and the bias
      θ = −x̂₁⁽¹⁾(1)(1 + e^{−b₁k}).

    Since w₃·b = 1, d = x̂₁⁽¹⁾(1)e^{−b₁k} + Σⱼ bⱼGⱼ(k) + uG_u(k): the GMC
    midpoint response (:func:`gmc_response`), which is how the network is
    evaluated in training and prediction. This function exists to show and
    test that mapping; for large ``|b₁k|`` its products overflow where the
    response does not.

    Parameters
    ----------
    X1 : ndarray of shape (n, N-1)
        Accumulated inputs of one test.
    b1, coef, control, x0 : float, ndarray, float, float
        w₁₁, the driving weights, u and the starting value x̂₁⁽¹⁾(1).

    Returns
    -------
    dict of ndarray
        ``"A"``, ``"B"`` (shape (n−1,)), ``"C"`` (shape (n−1, N+1): c₁, the
        inputs' units, u's unit) and ``"D"`` (shape (n−1,)).

    Examples
    --------
    The output layer reproduces the midpoint time response from k = 2 on:

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago
    >>> from greyml.grey._response import gmc_response, gnnmci_layers
    >>> X1 = ago(np.array([[1.0], [2.0], [1.0], [3.0]]))
    >>> layers = gnnmci_layers(X1, 0.4, [0.5], 0.1, x0=1.0)
    >>> [layers[name].shape for name in "ABCD"]
    [(3,), (3,), (3, 3), (3,)]
    >>> np.round(layers["B"], 6).tolist()  # the sigmoid of 0.4k, k = 1, 2, 3
    [0.598688, 0.689974, 0.768525]
    >>> f = 0.5 * X1[:, 0] + 0.1
    >>> bool(np.allclose(layers["D"], gmc_response(f, 0.4, 1.0, "midpoint")[1:]))
    True
    """
    X1 = np.asarray(X1, dtype=float)
    n = X1.shape[0]
    k = np.arange(1, n, dtype=float)
    G = gmc_response(np.column_stack([X1, np.ones(n)]), b1, 0.0, "midpoint")[1:]
    w2 = np.concatenate([[-x0], np.asarray(coef, dtype=float), [control]])
    with np.errstate(over="ignore", invalid="ignore"):
        A = b1 * k
        B = 1.0 / (1.0 + np.exp(-A))
        C = np.column_stack([B, G * B[:, None]]) * w2
        w3 = 1.0 + np.exp(-b1 * k)
        theta = -x0 * w3
        D = w3 * C.sum(axis=1) - theta
    return {"A": A, "B": B, "C": C, "D": D}
