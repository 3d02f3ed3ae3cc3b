"""The lag features of a ThermalTransferFunction: time, inputs, blocks, design and Grams.

A mixin of the estimator's design side, shared by ``fit`` and ``predict``:
which tests carry state (:func:`greyml.dynamic._time.timeline`), the drivers
and sensors, the blocks of lags of each, the design matrix (through the one
lag kernel), and its per-test Gram matrices.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from greyml.dynamic._gram import design, grams_by_test, held_out_scores
from greyml.dynamic._time import timeline

__all__ = ["fit_time_constants"]


class _TransferDesign:
    """The design of a transfer function's lag features (see the module)."""

    def _timeline(self, X, segments, tau_max, nominal=None):
        # without a time_s level: sample_interval seconds per row; without
        # either, refused in one line that names both (as LagFeatures does)
        return timeline(
            X,
            segments,
            owner=type(self).__name__,
            tau_max=tau_max,
            state=self.state,
            nominal=nominal,
            default_step=self.sample_interval,
        )

    def _inputs(self, names):
        drivers = list(self.drivers)
        for d in drivers:
            if d not in names:
                raise ValueError(
                    f"{type(self).__name__}: the driver {d!r} is not a column of X "
                    f"(columns: {', '.join(map(str, names))})."
                )
        if len(set(drivers)) != len(drivers):
            raise ValueError(f"{type(self).__name__}: a driver is named twice in {drivers!r}.")
        sensors = [c for c in names if c not in drivers]
        return drivers, sensors

    def _spec(self, drivers, sensors, names, powers, taus, driver_taus):
        """Blocks (column, power, taus) and the group of each: -1 drivers, k sensor k."""
        spec, groups, labels = [], [], []
        for d in drivers:
            for p in powers:
                spec.append((names.index(d), p, tuple(driver_taus)))
                groups.append(-1)
                labels.append((d, p))
        for k, s in enumerate(sensors):
            spec.append((names.index(s), 1, tuple(taus)))
            groups.append(k)
            labels.append((s, 1))
        return spec, groups, labels

    def _design(self, x, steps, bounds, spec, groups, reference):
        """Lag features of the blocks ``spec``; drivers (group -1) start idle without history."""
        idle = [b for b, g in enumerate(groups) if g == -1]
        F = design(x, steps.dt, bounds, spec, steps.carried, idle)
        if reference == "start":
            for start, stop in bounds:
                F[start:stop] -= F[start].copy()
        return F

    @staticmethod
    def _grams(F, y, w, bounds, reference):
        """Per-test raw Grams of the design (a ones column last in the recording reference)."""
        relative = reference == "start"
        A = F if relative else np.column_stack([F, np.ones(len(F))])
        pen = np.ones(A.shape[1])
        if not relative:
            pen[-1] = 0.0
        return grams_by_test(A, y, w, bounds), pen


def fit_time_constants(model, data, chosen_names, settings, y, folds, reference):
    """Variable projection: Nelder–Mead over the log time constants, gains solved inside.

    Only the drivers and the chosen sensors are filtered; the score is the
    mean held-out RMSE (best penalty) of whole tests.
    """
    m = len(settings.taus)

    def unpack(z):
        return np.sort(np.exp(z[:m])), np.sort(np.exp(z[m:]))

    def objective(z):
        ts, td = unpack(z)
        if ts.max() > 1e7 or td.max() > 1e7 or ts.min() < 1.0 or td.min() < 1.0:
            return np.inf
        spec, groups, _ = model._spec(
            data.drivers, chosen_names, data.names, settings.powers, ts, td
        )
        F = model._design(data.X, data.steps, data.bounds, spec, groups, reference)
        grams, pen = model._grams(F, y, data.w, data.bounds, reference)
        cols = np.arange(grams[0].shape[1])
        return float(held_out_scores(grams, cols, settings.alphas, pen, folds).min())

    z0 = np.log(np.concatenate([settings.taus, settings.driver_taus]))
    f0 = objective(z0)
    result = minimize(
        objective,
        z0,
        method="Nelder-Mead",
        options={"maxfev": 40 * len(z0), "xatol": 0.02, "fatol": 1e-6 * max(f0, 1e-12)},
    )
    best = result.x if result.fun < f0 else z0
    return unpack(best)
