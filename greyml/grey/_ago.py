"""AGO, the accumulated generating operation, as a scikit-learn transformer."""

from __future__ import annotations

import pandas as pd
from sklearn.base import BaseEstimator, OneToOneFeatureMixin, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from greyml._sequences import has_test_index
from greyml._validation import validate_sequences
from greyml.grey._kernels import ago, iago

__all__ = ["AGO"]


def keep_test_index(estimator, X, out, method="transform"):
    """Return ``out`` as a DataFrame with ``X``'s index when ``X`` carries tests.

    Test boundaries are part of the data: a sequence-aware transformer that got a
    ``test``-indexed DataFrame hands one on (under the default output setting),
    so that the next step of a Pipeline still knows where each test starts.
    ``set_output(transform="pandas")`` does the same for any input; other output
    settings are left to scikit-learn.
    """
    config = getattr(estimator, "_sklearn_output_config", {}).get(method, "default")
    if config == "default" and has_test_index(X):
        columns = estimator.get_feature_names_out()
        return pd.DataFrame(out, index=X.index, columns=columns)
    return out


class AGO(OneToOneFeatureMixin, TransformerMixin, BaseEstimator):
    """First-order accumulated generating operation, restarted at every test.

    ``transform`` returns x⁽¹⁾(k) = Σ_{j ≤ k} x⁽⁰⁾(j) for every column, summing
    within each test only; ``inverse_transform`` is the inverse operation (IAGO),
    x⁽⁰⁾(1) = x⁽¹⁾(1), x⁽⁰⁾(k) = x⁽¹⁾(k) − x⁽¹⁾(k−1).

    Tests are read from the ``test`` level of the row index (see
    :func:`greyml.test_ids`); a plain array is one test. With a ``test``-indexed
    DataFrame in, a DataFrame with the same index comes out, so the boundaries
    survive a Pipeline.

    Attributes
    ----------
    n_features_in_ : int
        Number of columns seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Column names seen in ``fit`` (DataFrame input only).

    See Also
    --------
    greyml.GMC : grey model that works on accumulated series.

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
        validate_sequences(self, X, reset=True)
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
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        out = ago(Xa, [(s.start, s.stop) for s in segments])
        return keep_test_index(self, X, out)

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
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        out = iago(Xa, [(s.start, s.stop) for s in segments])
        return keep_test_index(self, X, out)
