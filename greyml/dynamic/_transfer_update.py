"""New tests update a fitted ThermalTransferFunction's gains: ``partial_fit``.

A mixin. ``fit`` keeps the normal equations of its final solve (the raw
Gram matrix of the chosen columns, its right-hand side and the weight of
the rows); ``partial_fit`` adds those of the new tests to the old ones,
weighted by ``forgetting``, and solves the same ridge again: recursive
least squares with a forgetting factor, in batch form (the old tests are
the prior, weighted as ``forgetting`` times their rows). The sensors, the
time constants and the penalty stay as ``fit`` chose them; the intervals'
calibration is not redone (say so to a user who relies on them).
"""

from __future__ import annotations

import numbers

import numpy as np
from sklearn.utils.validation import check_is_fitted

from greyml._validation import check_magnitudes, column_names, require_y, validate_sequences
from greyml.dynamic._gram import solve_all
from greyml.dynamic._transfer_checks import sample_weights

__all__ = []


class _TransferUpdate:
    """``partial_fit``: the gains updated from new tests, the old ones as the prior."""

    def _keep_normal_equations(self, G, b, sw, cols, pen):
        """What ``partial_fit`` adds to: the chosen columns' raw Gram, its rhs, the weight."""
        self.normal_gram_ = np.asarray(G, dtype=float)
        self.normal_rhs_ = np.asarray(b, dtype=float)
        self.normal_weight_ = float(sw)
        self._normal_cols_ = np.asarray(cols, dtype=int)
        self._normal_pen_ = np.asarray(pen, dtype=float)

    def partial_fit(self, X, y, sample_weight=None, *, forgetting=1.0):
        """Update the gains with new tests; the fitted model is the prior.

        The normal equations of the tests seen so far, weighted by
        ``forgetting``, are added to those of the new tests, and the ridge is
        solved again with the same sensors, time constants and penalty:
        recursive least squares with forgetting, not a refit from scratch.
        With ``forgetting=1`` the result equals a fit on all the tests with
        those choices; with 0 the new tests alone decide (a few rows then fit
        many gains: keep it above 0 unless the new tests are many).

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            New tests, with the columns seen in ``fit``.
        y : array-like of shape (n_samples,)
            Their displacement, as given to ``fit``.
        sample_weight : array-like of shape (n_samples,), optional
            As in ``fit``.
        forgetting : float, default=1.0
            The weight of the tests seen so far, in [0, 1].

        Before any ``fit``, ``partial_fit`` fits (as scikit-learn's
        incremental estimators do).

        Returns
        -------
        self : ThermalTransferFunction
        """
        if not hasattr(self, "feature_coef_"):  # scikit-learn's convention: the first call fits
            return self.fit(X, y, sample_weight=sample_weight)
        check_is_fitted(self)
        name = type(self).__name__
        if "normal_gram_" not in vars(self):
            raise ValueError(
                f"{name} was saved by an earlier greyml, without its normal equations; "
                "fit it again before partial_fit."
            )
        if (
            isinstance(forgetting, bool)
            or not isinstance(forgetting, numbers.Real)
            or not 0 <= forgetting <= 1
        ):
            raise ValueError(
                f"{name}.partial_fit: forgetting must be a number in [0, 1]; got {forgetting!r}."
            )
        require_y(self, y)
        Xa, ya, segments = validate_sequences(self, X, y, reset=False)
        check_magnitudes(self, Xa, column_names(self, Xa.shape[1]), segments)
        check_magnitudes(self, ya, ["the target y"], segments)
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        w = sample_weights(self, sample_weight, Xa.shape[0], segments)
        y_fit = ya.copy()
        if self.reference_ == "start":
            for start, stop in bounds:
                y_fit[start:stop] -= ya[start]
        F = self._design(Xa, steps, bounds, self._spec_, self._groups_, self.reference_)
        (G, b, _, sw), _ = self._grams(F, y_fit, w, bounds, self.reference_)
        cols = self._normal_cols_
        G = forgetting * self.normal_gram_ + G.sum(axis=0)[np.ix_(cols, cols)]
        b = forgetting * self.normal_rhs_ + b.sum(axis=0)[cols]
        weight = forgetting * self.normal_weight_ + float(sw.sum())
        coef = np.zeros(F.shape[1] + (0 if self.reference_ == "start" else 1))
        coef[cols] = solve_all(G, b, weight, [self.alpha_], self._normal_pen_)[:, 0]
        n_cols = F.shape[1]
        self.feature_coef_ = coef[:n_cols]
        self.intercept_ = 0.0 if self.reference_ == "start" else float(coef[n_cols])
        self.terms_ = self._terms()
        self._keep_normal_equations(G, b, weight, cols, self._normal_pen_)
        return self
