"""The accuracy measures that the seed papers report, as plain functions.

Every function takes ``(y_true, y_pred)``: the measured thermal error and the
model's prediction of it, one value per sample, compared by position.

Implementation notes
--------------------
Inputs are checked once, in :func:`_check_pair`, which turns them into two
1-D float64 arrays and raises a ``ValueError`` that names the argument for
anything a metric cannot be computed from.

The arithmetic is done on copies rescaled by a power of two so that the
largest magnitude is below 1. Multiplying by a power of two is exact in binary
floating point (short of the subnormal range), so the rescaling adds no
rounding error, and for extreme data (values near 1e308) no intermediate square
or difference can overflow, so no NumPy ``RuntimeWarning`` is ever raised.
Only a result that is itself beyond the float64 range (an RMSE above about
1.8e308, say) comes back as ``inf``.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from greyml._docstrings import shared_doc

__all__ = [
    "rmse",
    "correlation",
    "nash_sutcliffe",
    "residual_band",
    "improvement",
]


# --------------------------------------------------------------------------
# input checking
# --------------------------------------------------------------------------


def _as_real_1d(y, name):
    """Return ``y`` as a 1-D float64 array, or raise a ``ValueError``."""
    try:
        if isinstance(y, (pd.Series, pd.DataFrame, pd.Index)):
            # Nullable pandas dtypes ("Float64", "Int64") turn <NA> into NaN
            # here, which the finiteness check below then reports by position.
            arr = y.to_numpy(na_value=np.nan)
        else:
            arr = np.asarray(y)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"{name} must be a 1-D array-like of real numbers; it could not be "
            f"converted to an array ({exc})."
        ) from exc

    kind = arr.dtype.kind
    if kind == "c":
        raise ValueError(
            f"{name} must contain real numbers; got complex values (dtype {arr.dtype})."
        )
    if kind == "O":
        try:
            arr = arr.astype(np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"{name} ({_ROLE[name]}) must contain real numbers; some of its elements "
                f"are not numbers, i.e. non-numeric ({exc})."
            ) from exc
    elif kind in "biuf":
        arr = arr.astype(np.float64, copy=False)
    else:
        raise ValueError(f"{name} must contain real numbers; got an array of dtype {arr.dtype}.")

    if arr.ndim == 0:
        raise ValueError(
            f"{name} must be a 1-D array-like with one value per sample; got a scalar."
        )
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr.ravel()
    if arr.ndim != 1:
        raise ValueError(
            f"{name} must be 1-D (or a single column); got an array of shape {arr.shape}."
        )
    return arr


_ROLE = {"y_true": "the measured target", "y_pred": "the prediction"}


def _where(original, i):
    """`` (test 'B', time_s=50)`` for position ``i`` of a test-indexed pandas object."""
    index = getattr(original, "index", None)
    names = list(getattr(index, "names", None) or [])
    if index is None or "test" not in names or len(index) <= i:
        return ""
    test = index.get_level_values("test")[i]
    if "time_s" in names:
        return f" (test {test!r}, time_s={index.get_level_values('time_s')[i]:g})"
    return f" (test {test!r})"


def _check_finite(arr, name, original=None):
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        i = int(bad[0])
        raise ValueError(
            f"{name} contains a non-finite value ({arr[i]}) at position {i}"
            f"{_where(original, i)}"
            f"{'' if bad.size == 1 else f' and {bad.size - 1} more after it'}; "
            f"the metrics are only defined for finite values of {_ROLE[name]}."
        )


def _check_pair(y_true, y_pred):
    """Validate a ``(y_true, y_pred)`` pair; return two 1-D float64 arrays.

    The arrays may share memory with the inputs: nothing downstream writes
    to them.
    """
    true_given, pred_given = y_true, y_pred
    y_true = _as_real_1d(y_true, "y_true")
    y_pred = _as_real_1d(y_pred, "y_pred")
    if y_true.shape[0] != y_pred.shape[0]:
        raise ValueError(
            f"y_true and y_pred have different lengths: y_true has "
            f"{y_true.shape[0]} values, y_pred has {y_pred.shape[0]}."
        )
    if y_true.shape[0] == 0:
        raise ValueError("y_true and y_pred are empty (0 samples): at least one sample is needed.")
    _check_finite(y_true, "y_true", true_given)
    _check_finite(y_pred, "y_pred", pred_given)
    return y_true, y_pred


def _check_not_constant(arr, name, metric, why):
    # Exact equality on purpose: with a tolerance, legitimate data with a tiny
    # spread would be rejected; without the check, the rounding noise of the
    # mean of equal values would give a meaningless number.
    if arr.min() == arr.max():
        raise ValueError(
            f"{name} is constant (all {arr.shape[0]} values equal {float(arr[0])!r}; "
            f"{arr.shape[0]} sample{'' if arr.shape[0] == 1 else 's'}): "
            f"{metric} is undefined because {why}."
        )


# --------------------------------------------------------------------------
# overflow-free arithmetic
# --------------------------------------------------------------------------


def _exponent(*arrays):
    """Smallest ``e`` with every ``|x| < 2**e`` (0 if all values are 0)."""
    peak = max(float(np.max(np.abs(a))) for a in arrays)
    return math.frexp(peak)[1] if peak > 0 else 0


def _times_pow2(x, e):
    """``x * 2**e`` as a Python float, ``±inf`` if it is beyond float64."""
    try:
        return math.ldexp(x, e)
    except OverflowError:
        return math.copysign(math.inf, x)


def _scaled_residuals(y_true, y_pred):
    """Return ``(d, e)`` with ``y_true - y_pred == d * 2**e`` and ``|d| < 1`` (or all 0).

    Scaled first by the inputs' peak (the difference cannot overflow), then by
    the residuals' own: residuals far below the values (4e16 beside 4e177)
    would otherwise square into subnormal numbers and lose their digits.
    """
    e = _exponent(y_true, y_pred)
    d = np.ldexp(y_true, -e) - np.ldexp(y_pred, -e)
    k = _exponent(d)
    return np.ldexp(d, -k), e + k


def _scaled_deviations(y):
    """Return ``(c, e)`` with ``y - mean(y) == c * 2**e`` and ``|c| < 2``."""
    e = _exponent(y)
    s = np.ldexp(y, -e)
    return s - np.mean(s), e


# --------------------------------------------------------------------------
# docstrings
# --------------------------------------------------------------------------

# Text that several of the docstrings below share, written once: each
# ``{key}`` in a docstring decorated with ``_shared_doc`` becomes its text.
_SHARED_DOC = {
    "y_true_not_constant": (
        "y_true : array-like of shape (n_samples,)\n"
        "        Measured values; must not be constant. A single column of shape\n"
        "        ``(n_samples, 1)`` is accepted and flattened; pandas objects are\n"
        "        compared by position."
    ),
    "raises": (
        "Raises\n    ------\n    ValueError\n"
        "        If the inputs differ in length, are empty, are not 1-D real numbers"
    ),
    "anfis_2015": (
        'A. M. Abdulshahed, A. P. Longstaff and S. Fletcher, "The application\n'
        "       of ANFIS prediction models for thermal error compensation on CNC machine\n"
        '       tools", *Applied Soft Computing* 27, pp. 158-168, 2015.'
    ),
    "gnn_2016": (
        "A. M. Abdulshahed, A. P. Longstaff, S. Fletcher and A. Potdar,\n"
        '       "Thermal error modelling of a gantry-type 5-axis machine tool using a\n'
        '       Grey Neural Network Model", *Journal of Manufacturing Systems* 41,\n'
        "       pp. 130-142, 2016."
    ),
}
_shared_doc = shared_doc(**_SHARED_DOC)


# --------------------------------------------------------------------------
# metrics
# --------------------------------------------------------------------------


@_shared_doc
def rmse(y_true, y_pred):
    r"""Root mean squared error between the measured and predicted error.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        Measured values (e.g. the thermal displacement of the tool point, in
        µm). A single column of shape ``(n_samples, 1)`` is accepted and
        flattened; pandas objects are compared by position, not by index.
    y_pred : array-like of shape (n_samples,)
        Predicted values, in the same unit and order.

    Returns
    -------
    float
        :math:`\sqrt{\frac{1}{n}\sum_i (y_i - \hat y_i)^2}`, in the unit of
        ``y``; 0 for a perfect prediction.

    {raises}
        or contain NaN or inf.

    See Also
    --------
    residual_band : The largest absolute residual, never smaller than the RMSE.
    sklearn.metrics.root_mean_squared_error : The same quantity, with sample
        weights and multi-output support.

    Notes
    -----
    The RMSE weights large residuals more than small ones but, unlike
    :func:`residual_band`, it averages them over the whole test; the seeds
    quote both. It is computed on residuals rescaled by a power of two, which
    is exact and cannot overflow.

    References
    ----------
    .. [1] A. M. Abdulshahed, A. P. Longstaff and S. Fletcher, "A cuckoo search
       optimisation-based Grey prediction model for thermal error compensation
       on CNC machine tools", *Grey Systems: Theory and Application* 7(2),
       pp. 146-155, 2017. https://doi.org/10.1108/GS-08-2016-0021

    Examples
    --------
    The residuals are ``[0, -1, 1, 0]``, so the RMSE is :math:`\sqrt{2/4}`:

    >>> from greyml.metrics import rmse
    >>> rmse([1, 2, 3, 4], [1, 3, 2, 4])
    0.7071067811865476
    >>> rmse([5.0, 7.5], [5.0, 7.5])
    0.0
    """
    y_true, y_pred = _check_pair(y_true, y_pred)
    d, e = _scaled_residuals(y_true, y_pred)
    return _times_pow2(math.sqrt(float(np.mean(np.square(d)))), e)


@_shared_doc
def residual_band(y_true, y_pred):
    r"""Half-width of the band that holds every residual: :math:`\max|y-\hat y|`.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        Measured values. A single column of shape ``(n_samples, 1)`` is
        accepted and flattened; pandas objects are compared by position.
    y_pred : array-like of shape (n_samples,)
        Predicted values, in the same unit and order.

    Returns
    -------
    float
        :math:`\max_i |y_i - \hat y_i|`, in the unit of ``y``. A model
        reported as "residual within ±4 µm" has a band of 4.

    {raises}
        or contain NaN or inf.

    See Also
    --------
    rmse : The average counterpart of this worst case.
    improvement : The band relative to the largest measured error.
    sklearn.metrics.max_error : The same quantity.

    Notes
    -----
    The seeds report the residual of a compensation model as a symmetric band
    ±max|y − ŷ|: after compensation the machine's error stays inside it. It is
    the worst case over the test, so a single outlier sets it.

    References
    ----------
    .. [1] {anfis_2015}

    Examples
    --------
    The residuals are ``[0, -1, 1, 0]``; the largest in absolute value is 1:

    >>> from greyml.metrics import residual_band
    >>> residual_band([1, 2, 3, 4], [1, 3, 2, 4])
    1.0
    """
    y_true, y_pred = _check_pair(y_true, y_pred)
    d, e = _scaled_residuals(y_true, y_pred)
    return _times_pow2(float(np.max(np.abs(d))), e)


@_shared_doc
def correlation(y_true, y_pred):
    r"""Pearson correlation coefficient R between measured and predicted values.

    Parameters
    ----------
    {y_true_not_constant}
    y_pred : array-like of shape (n_samples,)
        Predicted values, in the same order; must not be constant.

    Returns
    -------
    float
        .. math:: R = \frac{\sum_i (y_i-\bar y)(\hat y_i-\bar{\hat y})}
                  {\sqrt{\sum_i (y_i-\bar y)^2 \sum_i (\hat y_i-\bar{\hat y})^2}}

        in [-1, 1]; 1 when the prediction is any increasing affine function
        of the measurement. Square it for the R² that some seeds quote.

    {raises},
        contain NaN or inf, or if either of them is constant (the correlation
        of a constant is 0/0: undefined). One sample is a constant.

    See Also
    --------
    nash_sutcliffe : Also penalises offset and gain errors, which R ignores.
    scipy.stats.pearsonr : The same coefficient, with a p-value.

    Notes
    -----
    R measures how well the *shape* of the predicted curve follows the
    measured one: a prediction that is off by a constant offset or a wrong
    gain still has R = 1. Read it together with :func:`rmse` or
    :func:`nash_sutcliffe`. Each input is rescaled by its own power of two
    before centring (R does not depend on scale), so nothing can overflow; the
    result is clipped to [-1, 1] against rounding.

    References
    ----------
    .. [1] {gnn_2016}

    Examples
    --------
    With deviations from the means ``[-1.5, -0.5, 0.5, 1.5]`` and
    ``[-1.5, 0.5, -0.5, 1.5]``: R = 4 / sqrt(5 * 5) = 0.8.

    >>> from greyml.metrics import correlation
    >>> correlation([1, 2, 3, 4], [1, 3, 2, 4])
    0.8
    >>> correlation([1, 2, 3, 4], [12, 14, 16, 18])  # offset and gain: R = 1
    1.0
    """
    y_true, y_pred = _check_pair(y_true, y_pred)
    _check_not_constant(y_true, "y_true", "the correlation", "its standard deviation is 0")
    _check_not_constant(y_pred, "y_pred", "the correlation", "its standard deviation is 0")
    cy, _ = _scaled_deviations(y_true)
    cp, _ = _scaled_deviations(y_pred)
    # Normalise first, then take the dot product: every factor is O(1).
    cy = cy / math.sqrt(float(np.sum(np.square(cy))))
    cp = cp / math.sqrt(float(np.sum(np.square(cp))))
    r = float(np.sum(cy * cp))
    return min(1.0, max(-1.0, r))


@_shared_doc
def nash_sutcliffe(y_true, y_pred):
    r"""Nash–Sutcliffe efficiency E of the prediction.

    Parameters
    ----------
    {y_true_not_constant}
    y_pred : array-like of shape (n_samples,)
        Predicted values, in the same unit and order.

    Returns
    -------
    float
        .. math:: E = 1 - \frac{\sum_i (y_i - \hat y_i)^2}{\sum_i (y_i - \bar y)^2}

        at most 1 (a perfect prediction); 0 when the model does no better than
        the constant mean of the measurement; negative when it does worse.
        Not symmetric in its arguments.

    {raises},
        contain NaN or inf, or if ``y_true`` is constant (the denominator is 0:
        E is undefined). One sample is a constant.

    See Also
    --------
    correlation : Pearson R, blind to offset and gain errors.
    sklearn.metrics.r2_score : The same formula under the name "coefficient of
        determination"; it returns a number for a constant ``y_true`` where
        this function raises.

    Notes
    -----
    Equivalently E = 1 − MSE / Var(y), with the population variance. It comes
    from hydrology [1]_ and is the "efficiency coefficient" of the seeds [2]_.
    The two sums are computed on separately rescaled copies, so neither can
    overflow; if their ratio is beyond the float64 range the result is
    ``-inf``.

    References
    ----------
    .. [1] J. E. Nash and J. V. Sutcliffe, "River flow forecasting through
       conceptual models part I - A discussion of principles", *Journal of
       Hydrology* 10(3), pp. 282-290, 1970.
    .. [2] {gnn_2016}

    Examples
    --------
    The squared residuals sum to 2, the squared deviations of ``y_true`` from
    its mean 2.5 to 5, so E = 1 - 2/5:

    >>> from greyml.metrics import nash_sutcliffe
    >>> nash_sutcliffe([1, 2, 3, 4], [1, 3, 2, 4])
    0.6
    >>> nash_sutcliffe([1, 2, 3, 4], [2.5, 2.5, 2.5, 2.5])  # the mean: E = 0
    0.0
    """
    y_true, y_pred = _check_pair(y_true, y_pred)
    _check_not_constant(
        y_true,
        "y_true",
        "the Nash-Sutcliffe efficiency",
        "the sum of squared deviations from its mean (the denominator of E) is 0",
    )
    d, e_res = _scaled_residuals(y_true, y_pred)
    c, e_dev = _scaled_deviations(y_true)
    ratio = float(np.sum(np.square(d))) / float(np.sum(np.square(c)))
    return 1.0 - _times_pow2(ratio, 2 * (e_res - e_dev))


@_shared_doc
def improvement(y_true, y_pred):
    r"""Fraction of the peak error that compensation removes.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,)
        Measured error without compensation; must not be all zero. A single
        column of shape ``(n_samples, 1)`` is accepted and flattened; pandas
        objects are compared by position.
    y_pred : array-like of shape (n_samples,)
        The model's prediction, which the controller would subtract.

    Returns
    -------
    float
        .. math:: 1 - \frac{\max_i |y_i - \hat y_i|}{\max_i |y_i|}

        as a fraction (0.94 is the "94 % improvement" of the seeds). 1 for a
        perfect model, 0 when the residual peak equals the uncompensated peak,
        negative when compensating would make the machine worse.

    {raises},
        contain NaN or inf, or if ``y_true`` is all zero (there is no error
        to improve on: the ratio is undefined).

    See Also
    --------
    residual_band : The numerator, ``max |y - ŷ|``.

    Notes
    -----
    ``y - ŷ`` is what remains after the prediction is subtracted, so
    :math:`\max|y-\hat y|` is the peak error of the compensated machine and
    :math:`\max|y|` that of the uncompensated one; both are peaks of absolute
    values, so a negative drift counts like a positive one. The peaks need
    not occur at the same time.

    References
    ----------
    .. [1] {anfis_2015}

    Examples
    --------
    A drift that peaks at 20 µm, predicted to within 2 µm, is improved by
    1 - 2/20 = 90 %:

    >>> from greyml.metrics import improvement
    >>> improvement([0, 10, 20, 10], [1, 8, 21, 10])
    0.9
    """
    y_true, y_pred = _check_pair(y_true, y_pred)
    if not np.any(y_true):
        raise ValueError(
            f"y_true is all zero ({y_true.shape[0]} values): there is no error "
            f"to improve on, so the improvement max|y - y_pred| / max|y| is "
            f"undefined."
        )
    d, e_res = _scaled_residuals(y_true, y_pred)
    e_true = _exponent(y_true)
    peak = float(np.max(np.abs(np.ldexp(y_true, -e_true))))
    ratio = float(np.max(np.abs(d))) / peak
    return 1.0 - _times_pow2(ratio, e_res - e_true)
