"""Prediction intervals of a ThermalTransferFunction, calibrated on held-out tests.

A mixin: ``_calibrate`` runs at the end of ``fit`` (the residuals of the
leave-one-test-out refits of the chosen model), ``predict_interval`` uses
them. The kernels are in :mod:`greyml.dynamic._intervals`.
"""

from __future__ import annotations

import numpy as np
from sklearn.utils.validation import check_is_fitted

from greyml._validation import validate_sequences
from greyml.dynamic._gram import _cols_all, select_sensors
from greyml.dynamic._intervals import (
    conformal_quantile,
    held_out_predictions,
    scale_fit,
    scale_of,
    variogram_fit,
)

__all__ = ["elapsed_hours"]


def elapsed_hours(dt, bounds):
    """Hours since each test's first row, from the steps ``dt`` into the rows."""
    hours = np.zeros(dt.size)
    for start, stop in bounds:
        if stop - start > 1:
            hours[start + 1 : stop] = np.cumsum(dt[start + 1 : stop]) / 3600.0
    return hours


class _TransferIntervals:
    """Calibration and use of a transfer function's prediction intervals."""

    def _calibrate(self, data, bank, reference, y, folds, alphas):
        """``interval_scale_`` and ``conformity_scores_`` from the held-out tests.

        ``None`` for both when fewer than 3 tests were scored (nothing was
        held out, so there is nothing honest to calibrate on).
        """
        self.interval_scale_ = None
        self.conformity_scores_ = None
        if folds is None:
            return
        F = self._design(data.X, data.steps, data.bounds, bank.spec, bank.groups, reference)
        A = F if reference == "start" else np.column_stack([F, np.ones(len(F))])
        n_total = bank.grams[0].shape[1]

        # the sensors and the penalty are chosen again without each test, the
        # penalty on every other value of the grid (half the cost; the residuals
        # of a choice that saw the test would be too small)
        grid = np.asarray(alphas, dtype=float)[::2]

        def choose(grams, other_folds):
            chosen, alpha, _, _ = select_sensors(
                grams,
                bank.pen,
                bank.col_group,
                data.sensors,
                grid,
                other_folds if len(other_folds) >= 2 else None,
                self.max_sensors,
                self.selection,
            )
            return _cols_all(bank.col_group, chosen, n_total), alpha, bank.pen

        preds = held_out_predictions(A, bank.grams, folds, data.bounds, choose)
        hours_all = elapsed_hours(data.steps.dt, data.bounds)
        hours, residuals = [], []
        for k, pred in preds.items():
            start, stop = data.bounds[k]
            used = data.w[start:stop] > 0
            hours.append(hours_all[start:stop][used])
            residuals.append((y[start:stop] - pred)[used])
        c, s2, memory_h = variogram_fit(residuals, data.steps.nominal_step_s)
        hours, residuals = np.concatenate(hours), np.concatenate(residuals)
        if reference == "start":
            a, b = scale_fit(hours, residuals)
        else:
            # from the recording's zero the displacement is never known at a row,
            # so nothing anchors a width that grows: one width for every row
            a, b = scale_fit(np.zeros_like(hours), residuals)[0], 0.0
        self.interval_scale_ = np.array([a, b, min(c, a), s2, memory_h])
        self.conformity_scores_ = np.sort(np.abs(residuals) / scale_of(hours, a, b))

    def interval_half_width(self, hours, coverage=0.9):
        """Half-width of the ``coverage`` interval ``hours`` after the displacement was known.

        Parameters
        ----------
        hours : float or array-like
            Time since the displacement was last known: since the test's first
            row (the "start" reference, or a test given with
            ``initial_displacement``), or since a probe reading.
        coverage : float, default=0.9
            In (0, 1).

        Returns
        -------
        half_width : float or ndarray, in the unit of the target
        """
        check_is_fitted(self)
        q = self._quantile(coverage)
        a, b = self.interval_scale_[:2]
        width = q * scale_of(np.asarray(hours, dtype=float), a, b)
        return float(width) if np.ndim(width) == 0 else width

    def _quantile(self, coverage):
        name = type(self).__name__
        if not isinstance(coverage, (int, float, np.floating)) or not 0 < coverage < 1:
            raise ValueError(
                f"{name}.predict_interval: coverage must be a number in (0, 1); got {coverage!r}."
            )
        if self.conformity_scores_ is None:
            raise ValueError(
                f"{name} was fitted on fewer than 3 tests with a weight, so no test was held "
                "out and its intervals could not be calibrated; fit it on at least 3 tests."
            )
        q = conformal_quantile(self.conformity_scores_, coverage)
        if not np.isfinite(q):
            n = self.conformity_scores_.size
            raise ValueError(
                f"{name}.predict_interval: {n} held-out residuals cannot calibrate a "
                f"{coverage:g} interval (it needs at least {int(np.ceil(1 / (1 - coverage)))})."
            )
        return q

    def _trust_parameters(self, coverage, tolerance_um, probe_noise_um):
        """The Compensator's interval parameters at ``coverage`` (none uncalibrated)."""
        params = {"tolerance_um": tolerance_um, "probe_noise_um": probe_noise_um}
        if getattr(self, "conformity_scores_", None) is None:
            return params
        a, b, c, s2, memory_h = (float(v) for v in self.interval_scale_)
        params["uncertainty"] = (a - c, b, c, s2, memory_h)
        params["interval_quantile"] = self._quantile(coverage)
        return params

    def predict_interval(self, X, coverage=0.9, initial_displacement=None):
        """Prediction and its ``coverage`` interval for every row, in ``reference_``.

        The interval is calibrated in ``fit`` on whole held-out tests
        (split-conformal on the leave-one-test-out residuals, scaled by a
        width that grows with the time since the displacement was last known;
        see :mod:`greyml.dynamic._intervals`). Its coverage is a promise over
        tests like the training tests, held out whole; it says nothing about
        a test unlike all of them.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            As for :meth:`predict`.
        coverage : float, default=0.9
            The share of rows the interval should hold, in (0, 1).
        initial_displacement : float or dict, optional
            As for :meth:`predict`.

        Returns
        -------
        intervals : ndarray of shape (n_samples, 3)
            Columns: prediction, lower bound, upper bound.
        """
        check_is_fitted(self)
        q = self._quantile(coverage)
        pred = self.predict(X, initial_displacement=initial_displacement)
        _, _, segments = validate_sequences(self, X, reset=False)
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        a, b = self.interval_scale_[:2]
        half = q * scale_of(elapsed_hours(steps.dt, bounds), a, b)
        return np.column_stack([pred, pred - half, pred + half])
