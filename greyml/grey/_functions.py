"""Public, validated entry points to the grey kernels."""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator

from greyml._param_validation import Interval, Real, StrOptions, validate_params
from greyml._sequences import segment_label
from greyml._validation import column_names, float_vector, validate_sequences
from greyml.grey._kernels import CONDITION_LIMIT, _grey_lstsq, ago, gm1n_design, iago
from greyml.grey._response import gmc_forcing, gmc_initial, gmc_response

__all__ = ["fit_gm1n", "simulate_gmc"]


class _Inputs(BaseEstimator):
    """Holds what validation learns about a function's inputs (names, counts)."""


@validate_params({"X": ["array-like"], "y": ["array-like"]}, prefer_skip_nested_validation=True)
def fit_gm1n(X, y):
    """GM(1,N) coefficients by least squares.

    Solves x₁⁽⁰⁾(k) + a·z₁⁽¹⁾(k) = Σⱼ bⱼxⱼ⁽¹⁾(k), k = 2..n of every test, for the
    development coefficient ``a`` and the driving (influence) coefficients
    ``b``, with B = [−z₁⁽¹⁾, x₂⁽¹⁾, …, x_N⁽¹⁾] (DOMAIN.md corrects the sign that
    Abdulshahed et al. (2015) drops).

    Parameters
    ----------
    X : array-like or DataFrame of shape (n_samples, n_features)
        Drivers x₂…x_N (columns); tests from the ``test`` index level.
    y : array-like or Series of shape (n_samples,)
        The series x₁ whose behaviour the drivers explain.

    Returns
    -------
    a : float
        Development coefficient.
    b : ndarray of shape (n_features,)
        Driving coefficients. They are comparable between columns only when the
        columns are on a common scale (normalise first).

    Warns
    -----
    GreyConditioningWarning
        If the system is rank deficient (e.g. two identical sensors) or
        ill-conditioned (condition number above 1/√eps ≈ 6.7e7 once every
        column is scaled to unit norm, e.g. a sensor that is another plus
        1e-10 noise); the warning names the columns involved. The minimum-norm
        solution is returned.

    Examples
    --------
    >>> import numpy as np
    >>> from greyml.grey._functions import fit_gm1n
    >>> X = np.array([[1.0, 2.0], [1.2, 1.9], [1.5, 2.2], [1.9, 2.1], [2.2, 2.5]])
    >>> y = np.array([0.5, 0.9, 1.4, 1.6, 2.1])
    >>> a, b = fit_gm1n(X, y)
    >>> b.shape
    (2,)
    """
    inputs = _Inputs()
    Xa, ya, segments = validate_sequences(
        inputs, X, y, reset=True, min_samples_per_test=2, min_rows=lambda p: p + 1
    )
    names = column_names(inputs, Xa.shape[1])
    test_bounds = [(s.start, s.stop) for s in segments]
    theta, _ = _grey_lstsq(
        gm1n_design, ya, Xa, test_bounds, "GM(1,N)", names, limit=CONDITION_LIMIT
    )
    a, b = theta[0], theta[1:]
    return float(a), np.asarray(b, dtype=float)


@validate_params(
    {
        "X": ["array-like"],
        "development": [Interval(Real, None, None, closed="neither")],
        "driving": ["array-like", Real],  # a number for one column, as before
        "control": [Interval(Real, None, None, closed="neither")],
        "form": [StrOptions({"trapezoid", "midpoint"})],
        "initial": [StrOptions({"model", "zero"})],
    },
    prefer_skip_nested_validation=True,
)
def simulate_gmc(X, development, driving, control=0.0, *, form="trapezoid", initial="model"):
    """The GMC(1,N) prediction x̂₁⁽⁰⁾ for given coefficients, per test.

    Useful to make data with known coefficients, and to see what a calibrated
    model does on new drivers.

    Parameters
    ----------
    X : array-like or DataFrame of shape (n_samples, n_features)
        Drivers; tests from the ``test`` index level.
    development : float
        b₁.
    driving : array-like of shape (n_features,)
        b₂…b_N.
    control : float, default=0.0
        u.
    form : {"trapezoid", "midpoint"}, default="trapezoid"
    initial : {"model", "zero"}, default="model"
        See :class:`greyml.GMC`.

    Returns
    -------
    y : ndarray of shape (n_samples,)

    Examples
    --------
    With b₁ = 0 and one driver of ones (x⁽¹⁾ = 1, 2, 3), the trapezoid response
    is 0, ½·1 + ½·2 = 1.5 and ½·1 + 2 + ½·3 = 4, whose IAGO is 0, 1.5, 2.5:

    >>> import numpy as np
    >>> from greyml.grey._functions import simulate_gmc
    >>> simulate_gmc(np.ones((3, 1)), 0.0, [1.0], initial="zero").tolist()
    [0.0, 1.5, 2.5]
    """
    Xa, _, segments = validate_sequences(_Inputs(), X, reset=True)
    driving = float_vector(
        driving, f"simulate_gmc: driving must be numbers, one per column of X; got {driving!r}."
    )
    if driving.size != Xa.shape[1]:
        raise ValueError(
            f"driving has {driving.size} coefficients but X has {Xa.shape[1]} columns."
        )
    if not np.isfinite(driving).all():
        raise ValueError(f"simulate_gmc: driving must be finite; got {driving.tolist()}.")
    test_bounds = [(s.start, s.stop) for s in segments]
    f = gmc_forcing(ago(Xa, test_bounds), driving, control)
    x0 = gmc_initial(f[[s.start for s in segments]], development, initial)
    with np.errstate(over="ignore", invalid="ignore"):
        out = iago(gmc_response(f, float(development), x0, form, test_bounds), test_bounds)
    for seg in segments:
        if not np.isfinite(out[seg.slice]).all():
            raise ValueError(
                f"simulate_gmc: the response of {segment_label(seg)} overflows: with "
                f"development coefficient b1={float(development):g} over {seg.n} samples "
                "it grows beyond floating point (b1 < 0 makes the response grow like "
                "exp(-b1*k)). Check the coefficients or shorten the test."
            )
    return out
