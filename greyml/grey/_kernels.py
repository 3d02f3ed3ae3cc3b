"""Numerical kernels of the grey models: pure functions, arrays in, arrays out.

This module holds the grey equation (1-AGO, IAGO, background values and the
GM(1,N) and GMC(1,N) least-squares systems); :mod:`greyml.grey._response`
holds the GMC(1,N) time response built on it.

No validation and no estimator state here; the estimators validate and then call
these. Every function that walks along time takes ``test_bounds``, a sequence of
``(start, stop)`` row ranges, one per test, and never lets a sum, a difference or
a recursion cross from one range to the next.

Notation (DOMAIN.md): x⁽⁰⁾ raw series, x⁽¹⁾ its 1-AGO, z⁽¹⁾(k) = ½(x⁽¹⁾(k) +
x⁽¹⁾(k−1)) the background value, k = 2..n within each test.
"""

from __future__ import annotations

import warnings

import numpy as np

from greyml.exceptions import GreyConditioningWarning

__all__ = [
    "ago",
    "iago",
    "background",
    "gm1n_design",
    "gm1n_lstsq",
    "gm1n_conditioning",
    "CONDITION_LIMIT",
    "gmc_design",
    "gmc_lstsq",
    "gmc_lstsq_fixed_b1",
]

#: Condition number (of the column-scaled design) above which a least-squares
#: system is called ill-conditioned: 1/√eps ≈ 6.7e7, where the solution has
#: lost half of its significant digits to rounding.
CONDITION_LIMIT = 1.0 / np.sqrt(np.finfo(float).eps)


def _as_test_bounds(test_bounds, n):
    if test_bounds is None:
        return [(0, n)]
    return [(int(a), int(b)) for a, b in test_bounds]


def ago(x, test_bounds=None):
    """1-AGO: cumulative sum along axis 0, restarted at every test start.

    Examples
    --------
    >>> from greyml.grey._kernels import ago
    >>> ago([1, 2, 3]).tolist()
    [1.0, 3.0, 6.0]

    Two tests of two rows each: the sum starts again at row 2.

    >>> ago([1, 2, 3, 4], test_bounds=[(0, 2), (2, 4)]).tolist()
    [1.0, 3.0, 3.0, 7.0]
    """
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    for a, b in _as_test_bounds(test_bounds, x.shape[0]):
        np.cumsum(x[a:b], axis=0, out=out[a:b])
    return out


def iago(x1, test_bounds=None):
    """Inverse AGO: first difference within each test, x⁽⁰⁾(1) = x⁽¹⁾(1).

    Examples
    --------
    >>> from greyml.grey._kernels import ago, iago
    >>> iago([1, 3, 6]).tolist()
    [1.0, 2.0, 3.0]

    It undoes :func:`ago` test by test:

    >>> test_bounds = [(0, 2), (2, 4)]
    >>> iago(ago([1, 2, 3, 4], test_bounds), test_bounds).tolist()
    [1.0, 2.0, 3.0, 4.0]
    """
    x1 = np.asarray(x1, dtype=float)
    out = np.empty_like(x1)
    for a, b in _as_test_bounds(test_bounds, x1.shape[0]):
        if b > a:
            out[a] = x1[a]
            np.subtract(x1[a + 1 : b], x1[a : b - 1], out=out[a + 1 : b])
    return out


def background(x1, test_bounds=None):
    """Background values z⁽¹⁾(k) = ½(x⁽¹⁾(k) + x⁽¹⁾(k−1)) for k = 2..n of each test.

    Returns the rows k = 2..n of every test stacked (``n − n_tests`` rows).

    Examples
    --------
    >>> from greyml.grey._kernels import background
    >>> background([1, 3, 6]).tolist()  # ½(1 + 3), ½(3 + 6)
    [2.0, 4.5]

    A test of n rows gives n − 1 values:

    >>> background([1, 3, 6, 10], test_bounds=[(0, 2), (2, 4)]).tolist()
    [2.0, 8.0]
    """
    x1 = np.asarray(x1, dtype=float)
    parts = [
        0.5 * (x1[a + 1 : b] + x1[a : b - 1]) for a, b in _as_test_bounds(test_bounds, len(x1))
    ]
    return np.concatenate(parts, axis=0)


def _later_rows(x, test_bounds):
    """Rows k = 2..n of every test stacked."""
    return np.concatenate([x[a + 1 : b] for a, b in _as_test_bounds(test_bounds, len(x))], axis=0)


def gm1n_design(y, X, test_bounds=None):
    """GM(1,N) least-squares system ``B θ ≈ Y`` for θ = (a, b₂…b_N).

    B = [−z₁⁽¹⁾(k), x₂⁽¹⁾(k), …, x_N⁽¹⁾(k)], Y = x₁⁽⁰⁾(k), k = 2..n per test.

    Examples
    --------
    x₁ = (1, 2, 4) and one driver held at 1: x₁⁽¹⁾ = (1, 3, 7), so
    z₁⁽¹⁾ = (2, 5), and x₂⁽¹⁾ = (1, 2, 3).

    >>> from greyml.grey._kernels import gm1n_design
    >>> B, Y = gm1n_design([1.0, 2.0, 4.0], [[1.0], [1.0], [1.0]])
    >>> B.tolist(), Y.tolist()
    ([[-2.0, 2.0], [-5.0, 3.0]], [2.0, 4.0])
    """
    y = np.asarray(y, dtype=float)
    X = np.asarray(X, dtype=float)
    y1 = ago(y, test_bounds)
    X1 = ago(X, test_bounds)
    B = np.column_stack([-background(y1, test_bounds), _later_rows(X1, test_bounds)])
    return B, _later_rows(y, test_bounds)


def _scaled_lstsq(B, Y):
    """Least squares on the design scaled to unit column norms.

    A column's units must not decide the rank: sensors of 1e12 beside the
    control column of ones would otherwise look rank deficient. Returns the
    solution in the original units, the rank and the singular values of the
    scaled design.
    """
    norms = np.sqrt(np.einsum("ij,ij->j", B, B))
    norms = np.where((norms > 0) & np.isfinite(norms), norms, 1.0)
    theta, _, rank, sv = np.linalg.lstsq(B / norms, Y, rcond=None)
    return theta / norms, rank, sv


def gm1n_lstsq(y, X, test_bounds=None):
    """Least-squares GM(1,N) coefficients.

    Returns ``(a, b, rank, singular_values)`` with ``a`` the development
    coefficient and ``b`` (shape ``(N-1,)``) the driving (influence) coefficients.

    Examples
    --------
    The system of :func:`gm1n_design`'s example, −2a + 2b = 2 and
    −5a + 3b = 4, has the exact solution a = −0.5, b = 0.5:

    >>> import numpy as np
    >>> from greyml.grey._kernels import gm1n_lstsq
    >>> a, b, rank, _ = gm1n_lstsq([1.0, 2.0, 4.0], [[1.0], [1.0], [1.0]])
    >>> round(float(a), 6), np.round(b, 6).tolist(), int(rank)
    (-0.5, [0.5], 2)
    """
    B, Y = gm1n_design(y, X, test_bounds)
    theta, rank, sv = _scaled_lstsq(B, Y)
    return theta[0], theta[1:], rank, sv


def gm1n_conditioning(y, X, test_bounds=None, limit=CONDITION_LIMIT):
    """Condition number of the GM(1,N) system and the columns of ``X`` that are
    near-collinear after accumulation.

    The design of :func:`gm1n_design` is scaled to unit column norms first
    (so sensor units do not count), then κ = σ_max/σ_min from its singular
    values. Each singular value below σ_max/``limit`` is a near-null direction
    B̃v ≈ 0; the columns carrying most of such a v (|vⱼ| ≥ 0.1·max|v|) are the
    near-collinear ones. Cheap: one SVD of an (n − n_tests) × N matrix.

    Returns
    -------
    cond : float
        κ of the column-scaled design; ``inf`` if exactly singular (or a column
        is all zero).
    groups : list of list of int
        One group per near-null direction: indices into the columns of ``X``,
        and ``-1`` for the target's own column −z₁⁽¹⁾. Empty when κ ≤ ``limit``.

    Examples
    --------
    Two drivers, the second twice the first:

    >>> import numpy as np
    >>> from greyml.grey._kernels import gm1n_conditioning
    >>> x = np.array([1.0, 1.2, 1.5, 1.9, 2.2, 2.0])
    >>> y = np.array([0.5, 0.9, 1.4, 1.6, 2.1, 1.8])
    >>> cond, groups = gm1n_conditioning(y, np.column_stack([x, np.sin(x), 2 * x]))
    >>> bool(cond > 1e12), groups
    (True, [[0, 2]])
    """
    B, _ = gm1n_design(y, X, test_bounds)
    cond, groups = _conditioning(B, limit)
    return cond, [[j - 1 for j in group] for group in groups]


def _conditioning(B, limit):
    """κ of ``B`` scaled to unit column norms, and the columns of ``B`` carrying
    each near-null direction (all the zero columns if there are any)."""
    norms = np.sqrt(np.einsum("ij,ij->j", B, B))
    if not np.all(norms > 0):
        return float("inf"), [[int(j) for j in np.flatnonzero(~(norms > 0))]]
    _, sv, vt = np.linalg.svd(B / norms, full_matrices=False)
    with np.errstate(divide="ignore"):
        cond = float(sv[0] / sv[-1])
    groups = []
    for k in np.flatnonzero(sv * limit < sv[0]):
        v = np.abs(vt[k])
        groups.append([int(j) for j in np.flatnonzero(v >= 0.1 * v.max())])
    return cond, groups


def _grey_lstsq(design, y, X, test_bounds, who, names, limit=np.inf, stacklevel=3):
    """The checked least-squares fit of a grey equation, behind :func:`fit_gm1n`,
    :class:`GMC`/:class:`GNNMCI` and :class:`GreyInfluenceSelector`.

    ``design`` is :func:`gm1n_design` or :func:`gmc_design`. Returns θ (in the
    design's column order) and the rank. If the system is rank deficient, or
    its condition number after column scaling exceeds ``limit``, warns
    :class:`GreyConditioningWarning` (starting with ``who``, naming from
    ``names``, the columns of ``X``, those near-collinear); the minimum-norm
    solution is returned.
    """
    B, Y = design(y, X, test_bounds)
    theta, rank, sv = _scaled_lstsq(B, Y)
    with np.errstate(divide="ignore"):
        cond = float(sv[0] / sv[-1]) if sv.size else float("inf")
    n_theta = B.shape[1]
    if rank < n_theta or cond > limit:
        _, groups = _conditioning(B, CONDITION_LIMIT)
        labels = ["the target", *names, "the control u"]
        cols = ", ".join(labels[j] for j in (groups or [[]])[0])
        what = (
            f"rank deficient (rank {rank} < {n_theta})"
            if rank < n_theta
            else f"ill-conditioned (condition number {cond:.1e} after column scaling)"
        )
        warnings.warn(
            f"{who} least-squares system is {what}: "
            f"{cols or 'some columns'} are (nearly) linear combinations of each other "
            "after accumulation, so their coefficients are unreliable; the minimum-norm "
            "solution is used. Drop or merge one of them.",
            GreyConditioningWarning,
            stacklevel=stacklevel,
        )
    return theta, rank


def gmc_design(y, X, test_bounds=None):
    """GMC(1,N) least-squares system for θ = (b₁, b₂…b_N, u).

    x₁⁽⁰⁾(k) + b₁z₁⁽¹⁾(k) = Σⱼ bⱼ zⱼ⁽¹⁾(k) + u, k = 2..n per test, so
    B = [−z₁⁽¹⁾, z₂⁽¹⁾, …, z_N⁽¹⁾, 1] and Y = x₁⁽⁰⁾.

    Examples
    --------
    x₁ = (1, 2, 4) gives z₁⁽¹⁾ = (2, 5); a driver held at 1 gives
    x₂⁽¹⁾ = (1, 2, 3) and z₂⁽¹⁾ = (1.5, 2.5).

    >>> from greyml.grey._kernels import gmc_design
    >>> B, Y = gmc_design([1.0, 2.0, 4.0], [[1.0], [1.0], [1.0]])
    >>> B.tolist(), Y.tolist()
    ([[-2.0, 1.5, 1.0], [-5.0, 2.5, 1.0]], [2.0, 4.0])
    """
    y = np.asarray(y, dtype=float)
    X = np.asarray(X, dtype=float)
    z1 = background(ago(y, test_bounds), test_bounds)
    zX = background(ago(X, test_bounds), test_bounds)
    B = np.column_stack([-z1, zX, np.ones(len(z1))])
    return B, _later_rows(y, test_bounds)


def gmc_lstsq(y, X, test_bounds=None):
    """GMC(1,N) by least squares. Returns ``(b1, b, u, rank, singular_values)``.

    Examples
    --------
    A series that obeys the grey equation exactly with b₁ = 0.4, b₂ = 0.5 and
    u = 0.1: as z₁⁽¹⁾(k) = x₁⁽¹⁾(k−1) + ½x₁⁽⁰⁾(k), each value solves
    (1 + ½b₁)x₁⁽⁰⁾(k) = b₂z₂⁽¹⁾(k) + u − b₁x₁⁽¹⁾(k−1).

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago, background, gmc_lstsq
    >>> X = np.array([[1.0], [2.0], [1.0], [3.0], [2.0]])
    >>> z2 = background(ago(X))[:, 0]
    >>> y = [1.0]
    >>> for k in range(1, 5):
    ...     y.append((0.5 * z2[k - 1] + 0.1 - 0.4 * sum(y)) / (1 + 0.5 * 0.4))
    >>> b1, b, u, rank, _ = gmc_lstsq(y, X)
    >>> np.round([b1, *b, u], 6).tolist(), int(rank)
    ([0.4, 0.5, 0.1], 3)
    """
    B, Y = gmc_design(y, X, test_bounds)
    theta, rank, sv = _scaled_lstsq(B, Y)
    return theta[0], theta[1:-1], theta[-1], rank, sv


def gmc_lstsq_fixed_b1(y, X, b1, test_bounds=None):
    """GMC(1,N) least squares with b₁ held at ``b1``: returns ``(b, u)``.

    The sum of squares is a convex quadratic, so when the free optimum's b₁
    lies outside a range, the optimum within it has b₁ at the nearer end and
    the other coefficients solved with b₁ fixed there.

    Examples
    --------
    Data made with b₁ = 0.4, b₂ = 0.5 and u = 0.1 (as in :func:`gmc_lstsq`):
    with b₁ fixed at its true value the rest is recovered exactly.

    >>> import numpy as np
    >>> from greyml.grey._kernels import ago, background, gmc_lstsq_fixed_b1
    >>> X = np.array([[1.0], [2.0], [1.0], [3.0], [2.0]])
    >>> z2 = background(ago(X))[:, 0]
    >>> y = [1.0]
    >>> for k in range(1, 5):
    ...     y.append((0.5 * z2[k - 1] + 0.1 - 0.4 * sum(y)) / (1 + 0.5 * 0.4))
    >>> b, u = gmc_lstsq_fixed_b1(y, X, 0.4)
    >>> np.round([*b, u], 6).tolist()
    [0.5, 0.1]
    """
    B, Y = gmc_design(y, X, test_bounds)
    theta, _, _ = _scaled_lstsq(B[:, 1:], Y - b1 * B[:, 0])
    return theta[:-1], theta[-1]
