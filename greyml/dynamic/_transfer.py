"""ThermalTransferFunction: the displacement as a sum of first-order responses.

Each input (a temperature sensor, or a driver the controller knows such as the
spindle speed) reaches the displacement through its own transfer function: a
static gain plus a gain per first-order lag of a small bank of time constants,

    ŷ(t) = c + Σ_inputs Σ_powers [ g₀ · x(t)^p + Σ_j g_j · lag_τj(x^p)(t) ],

the form identified per heat source by Mareš, Horejš et al. (2020). For fixed
time constants the response is linear in the gains, so the gains come from one
ridge regression on the lag features; the time constants are taken from a bank
or fitted around it by variable projection (the gains solved inside every
evaluation of the time constants). The lags are computed by
:func:`greyml.dynamic._kernels.lag_filter`, the same kernel as the streaming
compensator, so batch and stream agree.

Choices made inside ``fit`` are scored on whole held-out tests (leave one test
out, from three tests on): the ridge penalty, which temperature sensors to use
(forward selection under ``max_sensors``) and, with ``time_constants="fit"``,
the time constants. Every held-out score is computed from per-test Gram
matrices, so a candidate costs a few small linear solves, not a refit.
"""

from __future__ import annotations

import numbers

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Integral, Interval, StrOptions
from greyml._sequences import TIME_LEVEL, segment_label
from greyml._validation import column_names, first_flagged, require_y, validate_sequences
from greyml.dynamic._gram import (
    _cols_all,
    design,
    grams_by_test,
    held_out_scores,
    select_sensors,
    solve_all,
)
from greyml.dynamic._transfer_readout import _round_step, _TransferReadout

__all__ = ["ThermalTransferFunction"]

#: Default time constants of the temperature sensors, in seconds (5, 15, 45, 135 min).
DEFAULT_TIME_CONSTANTS = (300.0, 900.0, 2700.0, 8100.0)
#: Ridge penalties tried, per row of the (standardised) design.
DEFAULT_ALPHAS = tuple(np.logspace(-6, 0, 13))


class ThermalTransferFunction(_TransferReadout, RegressorMixin, BaseEstimator):
    """Displacement as a sum of each input's first-order thermal responses.

    Every input reaches the displacement through a transfer function of its
    own: a static gain (what moves at once) plus one gain per first-order lag
    ``s_k = a_k s_{k-1} + (1 - a_k) x_k``, ``a_k = exp(-Δt_k / τ)``, for a bank
    of time constants τ. Drivers (columns the controller knows, such as the
    spindle speed) enter with their powers (``n`` and ``n²`` by default:
    bearing friction heat grows faster than linearly with speed) and a slower
    extra lag; every other column is a temperature sensor. This is the
    structure of the thermal transfer functions that Mareš, Horejš et al.
    (2020) identify per heat source and run in real time in the CNC.

    For fixed time constants the model is linear in its gains: they are one
    ridge regression on the standardised lag features. Everything else is
    chosen inside ``fit`` on whole held-out tests (leave one test out) when
    ``fit`` has three tests or more, never on rows of a test being predicted:

    * the ridge penalty, from ``alphas``;
    * with ``max_sensors``, which temperature sensors: **forward selection**
      of whole sensors (a sensor's static term and all its lags enter
      together), each step adding the sensor that lowers the mean held-out
      RMSE most, then keeping the number of sensors (up to ``max_sensors``)
      whose held-out RMSE is lowest (a longer list must lower it by more
      than one part in a million of the first step's RMSE, so that rounding
      never adds a sensor). Forward selection rather than a group
      lasso because it scores exactly what is asked (held-out error of whole
      tests with a hard budget of sensors), its penalty does not shrink the
      gains that are kept, and with per-test Gram matrices a step costs only
      small linear solves;
    * with ``time_constants="fit"``, the time constants (variable
      projection: a Nelder–Mead search over their logarithms, the gains
      solved for each candidate), after the sensors are chosen on the bank.

    ``selection="stable"`` (four tests or more) repeats the forward selection
    without each test in turn and keeps the sensors that at least half of the
    runs chose (stability selection, Meinshausen and Bühlmann (2010)): fewer
    sensors that fit one test's peculiarities.

    With fewer than three tests the penalty and the sensors are chosen by
    training error (which favours the smallest penalty), and
    ``time_constants="fit"`` keeps the default bank: there is no whole test
    to hold out that leaves two to fit.

    The time constants' search starts from the given driver lags and the
    default sensor bank, and fits the drivers' and the chosen sensors' lags
    (a shared bank for the sensors).

    Read more in the :ref:`User Guide <ug-thermal-transfer-function>`.

    Parameters
    ----------
    drivers : sequence of str, default=()
        Columns the controller knows (spindle speed, feed, power). Always in
        the model, not counted as sensors.
    max_sensors : int or None, default=None
        Budget of temperature sensors (every column that is not a driver).
        ``None`` uses all of them.
    time_constants : sequence of float, "fit" or None, default=None
        Time constants of the lags, in seconds. ``None``: 300, 900, 2700 and
        8100 s (5, 15, 45 and 135 min), spaced by a factor of three to cover
        what heat does in a machine structure, from a cover plate to a column.
        ``"fit"``: start from that bank and fit the time constants by
        variable projection on held-out tests (three tests or more).
    state : {"restart", "carry"}, default="restart"
        Lag state at a test's start. ``"restart"``: at rest at the test's first
        value. ``"carry"``: the tests, in the order given, are consecutive
        pieces of one recording; the lags run on from the previous test
        (stepping by the test's own first sampling step, as ``time_s``
        restarts in each test).
    random_state : int, RandomState instance or None, default=None
        Unused (the fit is deterministic); kept so the model is searchable
        alongside the stochastic greyml models.
    driver_powers : sequence of int, default=(1, 2)
        Powers of each driver that enter as inputs.
    driver_time_constants : sequence of float or None, default=None
        Lags of the drivers, in seconds. ``None``: the sensors' time
        constants and one three times slower than the largest (405 min by
        default), since a heat source's effect outlasts the sensors' lags.
    relative_to_start : bool, default=True
        ``True``: displacement relative to each test's first row (greyml's
        tests start at 0): the model is fitted to and predicts ``y - y₀``
        from features minus their first-row values, without intercept.
        ``False``: absolute, with an intercept (use with ``state="carry"``
        for a recording relative to its own start).
    alphas : sequence of float or None, default=None
        Ridge penalties per row of the standardised design; ``None``: 13
        values from 1e-6 to 1 (log spaced).
    selection : {"forward", "stable"}, default="forward"
        How ``max_sensors`` sensors are chosen: one forward selection on
        held-out tests, or the sensors chosen by at least half of the forward
        selections run without each test in turn (needs four tests; with
        fewer, ``"forward"``).

    Attributes
    ----------
    sensors_ : list of str
        Every candidate temperature sensor (the columns that are not drivers).
    selected_sensors_ : list of str
        The sensors in the model, in the order forward selection added them
        (all sensors when ``max_sensors`` is None).
    time_constants_ : ndarray of shape (n_taus,)
        The sensors' time constants in seconds (fitted with ``"fit"``).
    driver_time_constants_ : ndarray of shape (n_driver_taus,)
        The drivers' time constants in seconds.
    alpha_ : float
        The ridge penalty chosen (per row of the standardised design).
    terms_ : list of tuple
        ``(input, power, tau_s or None, weight)``: the feature ``x**power``
        lagged with ``tau_s`` (None: the raw value), times ``weight``, in the
        inputs' units. The prediction is ``intercept_`` plus their sum (minus
        its first-row value per test when ``relative_to_start``).
    feature_coef_ : ndarray of shape (n_terms,)
        The weights of the lag features in the order of ``terms_`` (named
        ``feature_coef_``, not ``coef_``: there is one per term, not one per
        input column).
    intercept_ : float
        Constant term (0 when ``relative_to_start``).
    gains_ : DataFrame
        One row per input and power, one column per term (``static``,
        ``lag 5 min`` ...): the weights of ``terms_`` (µm per unit of the
        input raised to the power, for a displacement in µm).
    selection_ : DataFrame
        Forward selection, step by step: the sensor added, the mean held-out
        RMSE and the penalty (empty without ``max_sensors``). With
        ``selection="stable"``: each sensor any run chose and the share of
        runs that chose it.
    cv_score_ : float
        Mean held-out RMSE of the chosen model (training RMSE with fewer than
        three tests).
    step_sizes_ : dict
        Default step of each input for :meth:`step_response` and
        :meth:`describe`: 1 for a sensor, the power of ten below a driver's
        largest training value (1000 for a spindle up to 5000 rpm).
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)
        Defined only when ``X`` has string column names.

    See Also
    --------
    greyml.GMC : one first-order grey response driven by all sensors.
    greyml.LagFeatures : the same lags as a transformer, for any linear model.
    greyml.Compensator : runs a fitted model row by row, from ``compensator()``.

    Notes
    -----
    Without a ``time_s`` index level the rows are taken as one second apart.
    A sampling gap longer than the largest time constant is refused: the
    lags would have forgotten everything before it.

    References
    ----------
    Mareš, M., Horejš, O., Havlík, L. (2020). Thermal error compensation of a
    5-axis machine tool using indigenous temperature sensors and CNC
    integrated Python code validated with a machined test piece. Precision
    Engineering 66, 21–30.

    Examples
    --------
    A displacement that follows a heat source through a 15-minute lag, from a
    machine at rest (spindle on from minute 10 to minute 120):

    >>> import numpy as np, pandas as pd
    >>> from greyml import ThermalTransferFunction, make_test_index
    >>> t = np.arange(0.0, 4 * 3600, 60.0)
    >>> rpm = np.where((t >= 600) & (t < 2 * 3600), 3000.0, 0.0)
    >>> lag = np.empty_like(rpm); s = 0.0
    >>> for k, x in enumerate(rpm):
    ...     s = np.exp(-60.0 / 900.0) * s + (1 - np.exp(-60.0 / 900.0)) * x; lag[k] = s
    >>> X = pd.DataFrame({"spindle_rpm": rpm}, index=make_test_index(["I"] * t.size, t))
    >>> y = 0.002 * lag
    >>> model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    >>> float(np.abs(model.predict(X) - y).max()) < 0.05
    True
    >>> model.terms_[0][:3]  # (input, power, time constant): the static term
    ('spindle_rpm', 1, None)
    """

    _parameter_constraints: dict = {
        "drivers": ["array-like"],
        "max_sensors": [Interval(Integral, 1, None, closed="left"), None],
        "time_constants": [StrOptions({"fit"}), "array-like", None],
        "state": [StrOptions({"restart", "carry"})],
        "random_state": ["random_state"],
        "driver_powers": ["array-like"],
        "driver_time_constants": ["array-like", None],
        "relative_to_start": ["boolean"],
        "alphas": ["array-like", None],
        "selection": [StrOptions({"forward", "stable"})],
    }

    def __init__(
        self,
        *,
        drivers=(),
        max_sensors=None,
        time_constants=None,
        state="restart",
        random_state=None,
        driver_powers=(1, 2),
        driver_time_constants=None,
        relative_to_start=True,
        alphas=None,
        selection="forward",
    ):
        self.drivers = drivers
        self.max_sensors = max_sensors
        self.time_constants = time_constants
        self.state = state
        self.random_state = random_state
        self.driver_powers = driver_powers
        self.driver_time_constants = driver_time_constants
        self.relative_to_start = relative_to_start
        self.alphas = alphas
        self.selection = selection

    # -- parameters -----------------------------------------------------------

    def _taus(self, name, value, default):
        if value is None:
            return np.asarray(default, dtype=float)
        try:
            taus = np.asarray(value, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ValueError(
                f"The {name!r} parameter of {type(self).__name__} must be a sequence of "
                f"time constants in seconds. Got {value!r} instead."
            ) from None
        if taus.size == 0:
            raise ValueError(
                f"The {name!r} parameter of {type(self).__name__} needs at least one time constant."
            )
        for tau in taus:
            if not np.isfinite(tau) or tau <= 0:
                raise ValueError(
                    f"The {name!r} parameter of {type(self).__name__}: time constant "
                    f"{tau!r} s is not a finite number > 0."
                )
        return taus

    def _check_params(self):
        """Check what the constraints cannot say: the entries of the sequences."""
        name = type(self).__name__
        fit_taus = isinstance(self.time_constants, str) and self.time_constants == "fit"
        taus = self._taus(
            "time_constants", None if fit_taus else self.time_constants, DEFAULT_TIME_CONSTANTS
        )
        dtaus = self.driver_time_constants
        driver_taus = (
            np.append(taus, 3.0 * taus.max())
            if dtaus is None
            else self._taus("driver_time_constants", dtaus, DEFAULT_TIME_CONSTANTS)
        )
        powers = tuple(self.driver_powers)
        if not powers or any(
            not isinstance(p, numbers.Real) or isinstance(p, bool) or not np.isfinite(p) or p <= 0
            for p in powers
        ):
            raise ValueError(
                f"The 'driver_powers' parameter of {name} must be a non-empty sequence of "
                f"finite numbers > 0. Got {self.driver_powers!r} instead."
            )
        alphas = np.asarray(DEFAULT_ALPHAS if self.alphas is None else self.alphas, dtype=float)
        if alphas.ndim != 1 or alphas.size == 0 or not (np.isfinite(alphas) & (alphas > 0)).all():
            raise ValueError(
                f"The 'alphas' parameter of {name} must be a non-empty sequence of finite "
                f"floats > 0. Got {self.alphas!r} instead."
            )
        return taus, driver_taus, fit_taus, powers, alphas

    # -- data -----------------------------------------------------------------

    def _time_steps(self, X, segments, taus_max):
        """Step in seconds to each row; checks gaps against the largest time constant."""
        n = segments[-1].stop if segments else 0
        index = X.index if isinstance(X, (pd.DataFrame, pd.Series)) else None
        if index is not None and TIME_LEVEL in (index.names or []):
            t = np.asarray(index.get_level_values(TIME_LEVEL), dtype=float)
        else:
            t = None
        dt = np.ones(n)
        for seg in segments:
            if t is None:
                continue
            tt = t[seg.slice]
            if seg.n > 1:
                steps = np.diff(tt)
                dt[seg.start + 1 : seg.stop] = steps
                dt[seg.start] = steps[0]
                k = int(np.argmax(steps))
                if steps[k] > taus_max:
                    raise ValueError(
                        f"{type(self).__name__}: {segment_label(seg)} has a sampling gap of "
                        f"{steps[k]:g} s from time_s={tt[k]:g} to {tt[k + 1]:g} (row "
                        f"{seg.start + k + 1}), longer than the largest time constant "
                        f"({taus_max:g} s); the lags cannot bridge it. Split the test there "
                        "or give longer time constants."
                    )
        return dt

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

    def _design(self, x, dt, bounds, spec):
        F = design(x, dt, bounds, spec, self.state == "carry")
        if self.relative_to_start:
            for start, stop in bounds:
                F[start:stop] -= F[start].copy()
        return F

    # -- fit ------------------------------------------------------------------

    def fit(self, X, y, sample_weight=None):
        """Fit the gains (and choose sensors, penalty and time constants) on tests.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            Drivers and temperature sensors, tests marked by the ``test`` index
            level (and ``time_s`` in seconds within each test).
        y : array-like of shape (n_samples,)
            Displacement.
        sample_weight : array-like of shape (n_samples,), optional
            Weight of each row in the fit. Rows of weight 0 still drive the
            lags (with ``state="carry"``, give the whole recording and weight
            0 on the rows of a held-out test), and a test whose weights are all
            0 is never held out for scoring.

        Returns
        -------
        self : ThermalTransferFunction
        """
        if isinstance(self.drivers, str):
            # before the constraints, which would only say "an array-like"
            raise ValueError(
                f"The 'drivers' parameter of {type(self).__name__} must be a sequence of "
                f"column names, e.g. [{self.drivers!r}]. Got the string {self.drivers!r} "
                "instead."
            )
        self._validate_params()
        require_y(self, y)
        taus, driver_taus, fit_taus, powers, alphas = self._check_params()
        Xa, ya, segments = validate_sequences(self, X, y, reset=True)
        names = column_names(self, Xa.shape[1])
        drivers, sensors = self._inputs(names)
        if self.max_sensors is not None and self.max_sensors > len(sensors):
            raise ValueError(
                f"The 'max_sensors' parameter of {type(self).__name__} is {self.max_sensors}, "
                f"more than the {len(sensors)} temperature sensor(s) given "
                f"({', '.join(sensors) or 'none'})."
            )
        w = self._weights(sample_weight, Xa.shape[0], segments)
        taus_max = max(taus.max(), driver_taus.max()) if drivers else taus.max()
        dt = self._time_steps(X, segments, taus_max)
        bounds = [(s.start, s.stop) for s in segments]
        if self.relative_to_start:
            y_fit = ya.copy()
            for start, stop in bounds:
                y_fit[start:stop] -= ya[start]
        else:
            y_fit = ya

        scored = [i for i, s in enumerate(segments) if w[s.slice].sum() > 0]
        folds = scored if len(scored) >= 3 else None

        def build(taus_s, taus_d):
            spec, groups, labels = self._spec(drivers, sensors, names, powers, taus_s, taus_d)
            F = self._design(Xa, dt, bounds, spec)
            return spec, groups, labels, F

        spec, groups, labels, F = build(taus, driver_taus)
        col_group = np.repeat(groups, [1 + len(b[2]) for b in spec])
        n_used = len(sensors) if self.max_sensors is None else self.max_sensors
        n_coef = int((col_group == -1).sum()) + n_used * (1 + len(taus))
        n_coef += 0 if self.relative_to_start else 1
        n_eq = int((w > 0).sum()) - (len(segments) if self.relative_to_start else 0)
        if n_eq < n_coef:
            raise ValueError(
                f"{type(self).__name__} has too few rows to fit {n_coef} coefficients: "
                f"{Xa.shape[0]} sample{'' if Xa.shape[0] == 1 else 's'} in {len(segments)} "
                f"test(s) give {n_eq} equations. "
                "Give more rows, fewer sensors or fewer time constants."
            )
        grams, pen = self._grams(F, y_fit, w, bounds)
        chosen, alpha, score, path = select_sensors(
            grams, pen, col_group, sensors, alphas, folds, self.max_sensors, self.selection
        )
        if fit_taus and folds is not None:
            taus, driver_taus = self._fit_taus(
                Xa,
                dt,
                bounds,
                names,
                drivers,
                [sensors[k] for k in chosen],
                taus,
                driver_taus,
                powers,
                y_fit,
                w,
                alphas,
                folds,
            )
            spec, groups, labels, F = build(taus, driver_taus)
            grams, pen = self._grams(F, y_fit, w, bounds)
            cols = _cols_all(col_group, chosen, grams[0].shape[1])
            sc = held_out_scores(grams, cols, alphas, pen, folds)
            alpha, score = float(alphas[np.argmin(sc)]), float(sc.min())
        cols = _cols_all(col_group, chosen, grams[0].shape[1])
        G, b = grams[0].sum(axis=0), grams[1].sum(axis=0)
        coef = np.zeros(grams[0].shape[1])
        coef[cols] = solve_all(G[np.ix_(cols, cols)], b[cols], grams[3].sum(), [alpha], pen[cols])[
            :, 0
        ]

        self.sensors_ = sensors
        self.drivers_ = drivers
        self.selected_sensors_ = [sensors[k] for k in chosen]
        self.time_constants_ = np.asarray(taus, dtype=float)
        self.driver_time_constants_ = np.asarray(driver_taus, dtype=float)
        self.alpha_ = float(alpha)
        self.cv_score_ = float(score)
        stable = bool(path) and len(path[0]) == 2
        # kept as plain lists (a saved model holds no DataFrame); selection_ and
        # gains_ are tables built from them on access
        self._selection_path_ = [list(step) for step in path]
        self._selection_columns_ = (
            ["sensor", "share_of_runs"] if stable else ["sensor", "held_out_rmse", "alpha"]
        )
        self._spec_ = spec
        self._labels_ = labels
        self._col_group_ = col_group
        n_cols = len(col_group)
        self.feature_coef_ = coef[:n_cols]
        self.intercept_ = 0.0 if self.relative_to_start else float(coef[n_cols])
        self.terms_ = self._terms()
        self.step_sizes_ = {s: 1.0 for s in sensors}
        for d in drivers:
            col = Xa[:, names.index(d)]
            self.step_sizes_[d] = _round_step(float(np.abs(col).max()))
        self.step_sizes_ = {c: self.step_sizes_[c] for c in drivers + sensors}
        return self

    def _weights(self, sample_weight, n, segments):
        if sample_weight is None:
            return np.ones(n)
        w = np.asarray(sample_weight, dtype=float).reshape(-1)
        if w.shape[0] != n:
            raise ValueError(
                f"{type(self).__name__}: sample_weight has {w.shape[0]} values for {n} rows."
            )
        bad = first_flagged(~np.isfinite(w) | (w < 0), segments)
        if bad:
            r, test = bad
            raise ValueError(
                f"{type(self).__name__}: sample_weight of row {r} ({test}) is "
                f"{w[r]!r}; weights must be finite and >= 0."
            )
        if w.sum() <= 0:
            raise ValueError(
                f"{type(self).__name__}: every sample_weight is zero; give some rows a "
                "positive weight."
            )
        return w

    def _grams(self, F, y, w, bounds):
        """Per-test raw Grams of the design (ones column last without relative_to_start)."""
        A = F if self.relative_to_start else np.column_stack([F, np.ones(len(F))])
        pen = np.ones(A.shape[1])
        if not self.relative_to_start:
            pen[-1] = 0.0
        return grams_by_test(A, y, w, bounds), pen

    def _fit_taus(
        self,
        Xa,
        dt,
        bounds,
        names,
        drivers,
        chosen_names,
        taus,
        driver_taus,
        powers,
        y,
        w,
        alphas,
        folds,
    ):
        """Variable projection: Nelder–Mead over the log time constants, gains solved inside.

        Only the drivers and the chosen sensors are filtered; the score is the
        mean held-out RMSE (best penalty) of whole tests.
        """
        m = len(taus)

        def unpack(z):
            return np.sort(np.exp(z[:m])), np.sort(np.exp(z[m:]))

        def objective(z):
            ts, td = unpack(z)
            if ts.max() > 1e7 or td.max() > 1e7 or ts.min() < 1.0 or td.min() < 1.0:
                return np.inf
            spec, groups, _ = self._spec(drivers, chosen_names, names, powers, ts, td)
            F = self._design(Xa, dt, bounds, spec)
            grams, pen = self._grams(F, y, w, bounds)
            cols = np.arange(grams[0].shape[1])
            return float(held_out_scores(grams, cols, alphas, pen, folds).min())

        z0 = np.log(np.concatenate([taus, driver_taus]))
        f0 = objective(z0)
        result = minimize(
            objective,
            z0,
            method="Nelder-Mead",
            options={"maxfev": 40 * len(z0), "xatol": 0.02, "fatol": 1e-6 * max(f0, 1e-12)},
        )
        best = result.x if result.fun < f0 else z0
        return unpack(best)

    def predict(self, X):
        """Predicted displacement of every row.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            The columns seen in ``fit``, tests marked as in ``fit``.

        Returns
        -------
        y : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        taus_max = self.time_constants_.max()
        if self.drivers_:
            taus_max = max(taus_max, self.driver_time_constants_.max())
        dt = self._time_steps(X, segments, taus_max)
        bounds = [(s.start, s.stop) for s in segments]
        used = np.flatnonzero(self.feature_coef_ != 0)
        if used.size == 0:
            return np.full(Xa.shape[0], self.intercept_)
        F = self._design(Xa, dt, bounds, self._spec_)
        return F @ self.feature_coef_ + self.intercept_

    def compensator(self):
        """A :class:`greyml.dynamic.Compensator` that runs this model row by row.

        Returns
        -------
        compensator : Compensator
            ``update(row)`` (a mapping with the inputs and ``"time_s"``) returns
            the correction; it equals :meth:`predict` on the same rows of one
            test (to 1e-9).
        """
        check_is_fitted(self)
        from greyml.dynamic._compensator import Compensator

        inputs = list(dict.fromkeys(name for name, _, _, _ in self.terms_))
        return Compensator(
            inputs,
            list(self.terms_),
            self.intercept_,
            relative_to_start=bool(self.relative_to_start),
        )

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags
