"""RelativeToStart: each column as its change since the first row of its test."""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, OneToOneFeatureMixin, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from greyml._validation import column_names, shown_names, validate_sequences

__all__ = ["RelativeToStart"]


class RelativeToStart(OneToOneFeatureMixin, TransformerMixin, BaseEstimator):
    """Each column minus its value at the first row of its test.

    Temperatures logged during heating/cooling tests are usually modelled as
    rises from each test's start (the papers of Abdulshahed et al. and
    greyml's simulated tests start every displacement at 0): a static model
    fitted on absolute temperatures learns the ambient level of the training
    days as well. The transformation learns nothing, so in a ``Pipeline`` it
    can never leak a held-out test's values into training, and
    :mod:`greyml.persist` saves it with the model it feeds.

    Read more in the :ref:`User Guide <ug-relative-to-start>`.

    Parameters
    ----------
    columns : sequence of str or int, or None, default=None
        Columns to take relative to each test's start (names for a DataFrame,
        positions otherwise); the others pass through unchanged (e.g. a
        spindle speed, which is a level, not a rise). ``None``: every column.

    Attributes
    ----------
    columns_ : list of str
        The names of the columns made relative (``x0``, ``x1`` ... without
        column names).
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)
        Defined only when ``X`` has string column names.

    See Also
    --------
    greyml.AGO : accumulation per test, also without crossing a test boundary.
    greyml.LagFeatures : thermal lags, whose ``state`` says where a test starts.

    Notes
    -----
    Tests are read from the ``test`` level of the row index (see
    :func:`greyml.make_test_index`); without it all rows are one test.

    Examples
    --------
    >>> import pandas as pd
    >>> from greyml import RelativeToStart, make_test_index
    >>> X = pd.DataFrame({"T1_C": [20.0, 21.5, 23.0, 25.0, 25.5],
    ...                   "spindle_rpm": [0.0, 4000.0, 4000.0, 0.0, 8000.0]},
    ...                  index=make_test_index(["I", "I", "I", "II", "II"],
    ...                                        [0, 60, 120, 0, 60]))
    >>> RelativeToStart(columns=["T1_C"]).fit_transform(X)["T1_C"].tolist()
    [0.0, 1.5, 3.0, 0.0, 0.5]
    """

    _parameter_constraints: dict = {"columns": ["array-like", None]}

    def __init__(self, columns=None):
        self.columns = columns

    def fit(self, X, y=None):
        """Check ``X`` and the columns to make relative.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_features)
            Rows of one or more tests.
        y : ignored

        Returns
        -------
        self : RelativeToStart
        """
        # before the constraints, which would only say "an array-like"
        if isinstance(self.columns, str):
            raise ValueError(
                "The 'columns' parameter of RelativeToStart must be a sequence of column "
                f"names or positions, e.g. [{self.columns!r}]. Got the string "
                f"{self.columns!r} instead."
            )
        self._validate_params()
        Xa, _, _ = validate_sequences(self, X, reset=True, bounded=False)
        names = column_names(self, Xa.shape[1])
        self.columns_ = [names[j] for j in self._positions(names)]
        return self

    def _positions(self, names):
        if self.columns is None:
            return list(range(len(names)))
        positions = []
        for c in self.columns:
            if isinstance(c, (int, np.integer)) and not isinstance(c, bool):
                if not 0 <= c < len(names):
                    raise ValueError(
                        f"RelativeToStart: column position {c} is outside the "
                        f"{len(names)} columns of X."
                    )
                positions.append(int(c))
            elif str(c) in names:
                positions.append(names.index(str(c)))
            else:
                raise ValueError(
                    f"RelativeToStart: {c!r} is not a column of X (columns: {shown_names(names)})."
                )
        if len(set(positions)) != len(positions):
            raise ValueError(f"RelativeToStart: a column is named twice in {self.columns!r}.")
        return positions

    def transform(self, X):
        """Each chosen column minus its value at its test's first row.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_features)
            The columns seen in ``fit``.

        Returns
        -------
        Z : DataFrame or ndarray of shape (n_samples, n_features)
            A DataFrame with ``X``'s index and columns when ``X`` is one
            (and the output is not set to "default" arrays), else an array.
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        names = column_names(self, Xa.shape[1])
        cols = [names.index(c) for c in self.columns_]
        out = np.array(Xa, dtype=float, copy=True)
        for seg in segments:
            out[seg.start : seg.stop, cols] -= Xa[seg.start, cols]
        config = getattr(self, "_sklearn_output_config", {}).get("transform", "default")
        if isinstance(X, pd.DataFrame) and config in ("default", "pandas"):
            return pd.DataFrame(out, index=X.index, columns=X.columns)
        return out
