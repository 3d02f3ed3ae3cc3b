"""AGO, the accumulated generating operation, as a scikit-learn transformer."""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import (
    BaseEstimator,
    OneToOneFeatureMixin,
    RegressorMixin,
    TransformerMixin,
    clone,
)
from sklearn.linear_model import LinearRegression
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import HasMethods
from greyml._sequences import keep_test_index
from greyml._validation import require_y, validate_sequences
from greyml.grey._kernels import ago, iago

__all__ = ["AGO", "AccumulatedTargetRegressor"]


class AGO(OneToOneFeatureMixin, TransformerMixin, BaseEstimator):
    """First-order accumulated generating operation, restarted at every test.

    ``transform`` returns x⁽¹⁾(k) = Σ_{j ≤ k} x⁽⁰⁾(j) for every column, summing
    within each test only; ``inverse_transform`` is the inverse operation (IAGO),
    x⁽⁰⁾(1) = x⁽¹⁾(1), x⁽⁰⁾(k) = x⁽¹⁾(k) − x⁽¹⁾(k−1).

    Tests are read from the ``test`` level of the row index (see
    :func:`greyml.groups_of`); a plain array is one test. With a ``test``-indexed
    DataFrame in, a DataFrame with the same index comes out, so the boundaries
    survive a Pipeline.

    Read more in the :ref:`User Guide <ug-ago>`.

    Attributes
    ----------
    n_features_in_ : int
        Number of columns seen in ``fit``.
    feature_names_in_ : ndarray of shape (``n_features_in_``,)
        Column names seen in ``fit`` (DataFrame input only).

    See Also
    --------
    greyml.GMC : grey model that works on accumulated series.
    greyml.AccumulatedTargetRegressor : accumulates the target for any regressor.

    References
    ----------
    Deng, J. (1989). Introduction to grey system theory. J. Grey System 1, 1-24.

    Examples
    --------
    >>> import pandas as pd
    >>> from greyml import AGO
    >>> idx = pd.MultiIndex.from_tuples(
    ...     [("I", 0), ("I", 10), ("I", 20), ("II", 0), ("II", 10)],
    ...     names=["test", "time_s"])
    >>> X = pd.DataFrame({"T1_C": [1.0, 2.0, 3.0, 10.0, 20.0]}, index=idx)
    >>> AGO().fit_transform(X)["T1_C"].tolist()
    [1.0, 3.0, 6.0, 10.0, 30.0]
    """

    _parameter_constraints: dict = {}

    def fit(self, X, y=None):
        """Record the number and names of the columns.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        y : ignored

        Returns
        -------
        self : AGO
        """
        self._validate_params()
        validate_sequences(self, X, reset=True, bounded=False)
        return self

    def transform(self, X):
        """Accumulate every column within each test.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)

        Returns
        -------
        X1 : ndarray or DataFrame of shape (n_samples, n_features)
        """
        return self._per_test(ago, X)

    def inverse_transform(self, X):
        """IAGO: first difference within each test.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Accumulated series.

        Returns
        -------
        X0 : ndarray or DataFrame of shape (n_samples, n_features)
        """
        return self._per_test(iago, X)

    def _per_test(self, kernel, X):
        """``kernel`` (ago or iago) applied within each test of checked ``X``."""
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        out = kernel(Xa, [(s.start, s.stop) for s in segments])
        return keep_test_index(self, X, out)


class AccumulatedTargetRegressor(RegressorMixin, BaseEstimator):
    """Fit any regressor to the accumulated target and difference its predictions.

    The grey-modelling recipe for an ordinary regressor: the target is
    accumulated (AGO) within each test before ``regressor`` is fitted, and
    the regressor's predictions are differenced (IAGO) within each test, so
    ``predict`` is in the target's own units. Put :class:`AGO` in front of it
    to accumulate the inputs too::

        make_pipeline(GreyInfluenceSelector(), AGO(), AccumulatedTargetRegressor(Ridge()))

    scikit-learn's :class:`~sklearn.compose.TransformedTargetRegressor` with
    ``transformer=AGO()`` would not do: it hands the target to the
    transformer as a bare array, so the sums would run from one test into the
    next. Here the tests are read from ``X`` (its ``test`` index level, which
    greyml's transformers hand on through a Pipeline); a plain array is one
    test.

    Read more in the :ref:`User Guide <ug-selection-flows>`.

    Parameters
    ----------
    regressor : estimator or None, default=None
        Any scikit-learn regressor; it is cloned. ``None`` means
        :class:`~sklearn.linear_model.LinearRegression`.

    Attributes
    ----------
    regressor_ : estimator
        The fitted clone of ``regressor``, fitted to the accumulated target.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)
        Column names seen in ``fit`` (DataFrame input only).

    See Also
    --------
    greyml.AGO : the same accumulation for the inputs, the step in front of it.
    greyml.GMC : a grey model that accumulates and differences by itself.

    Notes
    -----
    A row's prediction is the difference of the regressor's predictions at
    that row and the row before it in the same test, so it depends on the
    previous row: predict whole tests, as for every grey model.

    Each test's first row is differenced against the regressor's prediction
    at a row of zeros, the accumulated inputs before the test's first sample
    (``X`` is meant to come from :class:`AGO`). So the regressor's constant,
    e.g. an intercept, cancels on every row, the first included; were it kept
    there, the first prediction of a new test would be off by that constant
    (a thousand µm on a real spindle recording). So behind :class:`AGO`, a
    constant offset in the target (which accumulates to a ramp c·k) is
    fitted only as far as the accumulated inputs can mimic a ramp, as in
    GM(1,N), which has no constant term either. Measure the target from each
    test's start, or add a column of ones before ``AGO`` if the target
    carries an offset.

    Examples
    --------
    >>> import pandas as pd
    >>> from sklearn.linear_model import LinearRegression
    >>> from sklearn.pipeline import make_pipeline
    >>> from greyml import AGO, AccumulatedTargetRegressor, make_test_index
    >>> X = pd.DataFrame({"T1_C": [1.0, 2.0, 4.0, 1.0, 3.0]},
    ...                  index=make_test_index(["I"] * 3 + ["II"] * 2, [0, 10, 20, 0, 10]))
    >>> y = 2 * X["T1_C"]
    >>> model = make_pipeline(AGO(), AccumulatedTargetRegressor(LinearRegression()))
    >>> model.fit(X, y).predict(X).round(9).tolist()
    [2.0, 4.0, 8.0, 2.0, 6.0]
    """

    _parameter_constraints: dict = {"regressor": [HasMethods(["fit", "predict"]), None]}

    def __init__(self, regressor=None):
        self.regressor = regressor

    def fit(self, X, y, **fit_params):
        """Fit ``regressor`` to the target accumulated within each test.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Passed to the regressor unchanged.
        y : array-like of shape (n_samples,)
        **fit_params : dict
            Passed to the regressor's ``fit``.

        Returns
        -------
        self : AccumulatedTargetRegressor
        """
        self._validate_params()
        require_y(self, y)
        _, ya, segments = validate_sequences(
            self, X, y, reset=True, min_rows=1, n_params_msg="an accumulated target"
        )
        if ya.ndim != 1:
            raise ValueError(
                f"AccumulatedTargetRegressor takes one target column; y has shape {ya.shape}."
            )
        y1 = ago(ya[:, None], [(s.start, s.stop) for s in segments])[:, 0]
        regressor = LinearRegression() if self.regressor is None else self.regressor
        self.regressor_ = clone(regressor).fit(X, y1, **fit_params)
        return self

    def predict(self, X):
        """Predict the target: the regressor's output differenced within each test.

        A test's first row is the regressor's output there minus its output at
        a row of zeros (the accumulated inputs before the test starts).

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        y1 = np.asarray(self.regressor_.predict(X), dtype=np.float64).reshape(Xa.shape[0], -1)
        if y1.shape[1] != 1:
            raise ValueError(
                f"{type(self.regressor_).__name__} predicted {y1.shape[1]} columns; "
                "AccumulatedTargetRegressor needs one."
            )
        pred = iago(y1, [(s.start, s.stop) for s in segments])[:, 0]
        # each test's first row is differenced against the regressor at the row
        # before the test, where the accumulated inputs are zero: a constant of the
        # regressor (an intercept) then cancels there as on every other row
        if isinstance(X, pd.DataFrame):
            zero = pd.DataFrame(np.zeros((1, Xa.shape[1])), columns=X.columns)
        else:
            zero = np.zeros((1, Xa.shape[1]))
        before = float(np.asarray(self.regressor_.predict(zero), dtype=np.float64).reshape(-1)[0])
        pred[[s.start for s in segments]] -= before
        return pred

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # fitted to the running sum of the target: on scikit-learn's i.i.d. check
        # data, where the target is not a dynamic response, the fit is poor.
        tags.regressor_tags.poor_score = True
        return tags
