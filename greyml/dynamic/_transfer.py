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
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Hidden, Integral, Interval, StrOptions
from greyml._renamed import DEPRECATED
from greyml._sequences import segment_label
from greyml._validation import column_names, first_flagged, require_y, validate_sequences
from greyml.dynamic._gram import (
    _cols_all,
    design,
    grams_by_test,
    held_out_scores,
    select_sensors,
    solve_all,
)
from greyml.dynamic._time import (
    MAX_TERMS,
    STATES,
    Timeline,
    check_time_constants,
    timeline,
)
from greyml.dynamic._transfer_readout import _round_step, _TransferReadout
from greyml.exceptions import WarmStartWarning

__all__ = ["ThermalTransferFunction"]

#: Default time constants of the temperature sensors, in seconds (5, 15, 45, 135 min).
DEFAULT_TIME_CONSTANTS = (300.0, 900.0, 2700.0, 8100.0)
#: Ridge penalties tried, per row of the (standardised) design.
DEFAULT_ALPHAS = tuple(np.logspace(-6, 0, 13))
#: The values of ``reference``.
REFERENCES = ("auto", "start", "recording")


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
      RMSE most, then keeping the shortest list (up to ``max_sensors``)
      whose mean held-out RMSE is within one standard error (over the
      held-out tests) of the lowest, the one-standard-error rule of Breiman
      et al. (1984): with a handful of tests, smaller differences are noise
      (and never within less than one part in a million of the first step's
      RMSE, so that rounding never adds a sensor). Forward selection rather
      than a group
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
        what heat does in a machine structure, from a cover plate to a column;
        with three tests or more, once the sensors are chosen on that bank,
        it is also tried extended by a lag three times slower at a time (with
        the drivers' bank) as far as the longest stretch of the training data
        without a restart, and the bank with the lowest held-out RMSE is kept
        (slow dynamics, such as a warm-up that goes on for a day).
        ``"fit"``: start from that bank and fit the time constants by
        variable projection on held-out tests (three tests or more).
    state : {"auto", "carry", "restart"}, default="auto"
        Lag state at a test's start. ``"auto"``: a test whose clock runs on
        from the previous test's last row (a recording cut into consecutive
        pieces: ``time_s`` does not restart) continues the lags that test
        left; a test on a clock of its own, or after a gap longer than the
        largest time constant, starts without history. ``"carry"``: every
        test continues the one before it (stepping by the recording's nominal
        step where the clock restarts). ``"restart"``: every test starts
        without history. A test without history starts with its temperatures'
        lags at rest at their first values and its drivers' lags at 0 (the
        heat source idle before the test); see ``initial_displacement`` in
        :meth:`predict` for a test that starts mid-run.
    random_state : int, RandomState instance or None, default=None
        Unused (the fit is deterministic); kept so the model is searchable
        alongside the stochastic greyml models.
    driver_powers : sequence of int, default=(1, 2)
        Powers of each driver that enter as inputs.
    driver_time_constants : sequence of float or None, default=None
        Lags of the drivers, in seconds. ``None``: the sensors' time
        constants and one three times slower than the largest (405 min by
        default), since a heat source's effect outlasts the sensors' lags.
    reference : {"auto", "start", "recording"}, default="auto"
        Where the displacement is measured from. ``"start"``: each test's
        first row; the model is fitted to and predicts ``y - y₀`` from
        features minus their first-row values, without intercept.
        ``"recording"``: the recording's own zero (the probe's datum), with an
        intercept; right for one recording cut into pieces, whose pieces start
        where the previous one left off. ``"auto"``: ``"recording"`` when
        every test continues the one before it (one recording) and the
        displacement is not zero at every test's first row, else
        ``"start"``. The choice is ``reference_``.
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
    reference_ : {"start", "recording"}
        Where the displacement is measured from (see ``reference``):
        :meth:`predict` returns it in this reference.
    state_ : {"carry", "restart"}
        ``"carry"`` when the training tests carried their lags from one to
        the next (every test after the first), else ``"restart"``.
    nominal_step_s_ : float
        The median step between rows of the training tests.
    gap_limit_s_ : float
        The longest step the lags bridge, within a test or from one test into
        the next (the largest time constant of the bank given): a longer one
        inside a test is refused, between tests it restarts the lags, in
        ``fit``, :meth:`predict` and the compensator alike.
    bank_scores_ : dict
        With the default bank and three tests or more: the mean held-out
        RMSE of each bank tried, keyed by its number of sensor time
        constants (empty otherwise).
    alpha_ : float
        The ridge penalty chosen (per row of the standardised design).
    terms_ : list of tuple
        ``(input, power, tau_s or None, weight)``: the feature ``x**power``
        lagged with ``tau_s`` (None: the raw value), times ``weight``, in the
        inputs' units. The prediction is ``intercept_`` plus their sum (minus
        its first-row value per test with ``reference_="start"``).
    feature_coef_ : ndarray of shape (n_terms,)
        The weights of the lag features in the order of ``terms_`` (named
        ``feature_coef_``, not ``coef_``: there is one per term, not one per
        input column).
    intercept_ : float
        Constant term (0 with ``reference_="start"``).
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
    Breiman, L., Friedman, J. H., Olshen, R. A., Stone, C. J. (1984).
    Classification and Regression Trees. Wadsworth (the one-standard-error
    rule).

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
        "state": [StrOptions(set(STATES))],
        "random_state": ["random_state"],
        "driver_powers": ["array-like"],
        "driver_time_constants": ["array-like", None],
        "reference": [StrOptions(set(REFERENCES))],
        "alphas": ["array-like", None],
        "selection": [StrOptions({"forward", "stable"})],
        "relative_to_start": ["boolean", Hidden(StrOptions({DEPRECATED}))],
    }

    def __init__(
        self,
        *,
        drivers=(),
        max_sensors=None,
        time_constants=None,
        state="auto",
        random_state=None,
        driver_powers=(1, 2),
        driver_time_constants=None,
        reference="auto",
        alphas=None,
        selection="forward",
        relative_to_start=DEPRECATED,
    ):
        self.drivers = drivers
        self.max_sensors = max_sensors
        self.time_constants = time_constants
        self.state = state
        self.random_state = random_state
        self.driver_powers = driver_powers
        self.driver_time_constants = driver_time_constants
        self.reference = reference
        self.alphas = alphas
        self.selection = selection
        self.relative_to_start = relative_to_start

    # -- parameters -----------------------------------------------------------

    def _taus(self, name, value, default):
        if value is None:
            return np.asarray(default, dtype=float)
        return check_time_constants(value, f"The {name!r} parameter of {type(self).__name__}")

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
        extend = self.time_constants is None and self.driver_time_constants is None
        return _Settings(
            taus, driver_taus, fit_taus, powers, alphas, self._reference_asked(), extend
        )

    def _reference_asked(self):
        """``reference``, or the deprecated ``relative_to_start`` with a FutureWarning."""
        old = self.relative_to_start
        if isinstance(old, str) and old == DEPRECATED:
            return self.reference
        new = "start" if old else "recording"
        warnings.warn(
            f"The 'relative_to_start' parameter of {type(self).__name__} is replaced by "
            f"'reference' and goes away in the next release; use reference={new!r}.",
            FutureWarning,
            stacklevel=4,
        )
        return new

    # -- data -----------------------------------------------------------------

    def _timeline(self, X, segments, tau_max, nominal=None):
        return timeline(
            X,
            segments,
            owner=type(self).__name__,
            tau_max=tau_max,
            state=self.state,
            nominal=nominal,
            default_step=1.0,
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

    def _data(self, X, y, sample_weight, settings):
        """Validated training data: arrays, tests, inputs, weights and time."""
        Xa, ya, segments = validate_sequences(self, X, y, reset=True)
        names = column_names(self, Xa.shape[1])
        _check_magnitudes(self, Xa, names, segments)
        _check_magnitudes(self, ya[:, None], ["the target y"], segments)
        drivers, sensors = self._inputs(names)
        if self.max_sensors is not None and self.max_sensors > len(sensors):
            raise ValueError(
                f"The 'max_sensors' parameter of {type(self).__name__} is {self.max_sensors}, "
                f"more than the {len(sensors)} temperature sensor(s) given "
                f"({', '.join(sensors) or 'none'})."
            )
        w = self._weights(sample_weight, Xa.shape[0], segments)
        tau_max = settings.taus.max()
        if drivers:
            tau_max = max(tau_max, settings.driver_taus.max())
        steps = self._timeline(X, segments, tau_max)
        bounds = [(s.start, s.stop) for s in segments]
        return _Data(Xa, ya, w, segments, bounds, names, drivers, sensors, steps, float(tau_max))

    @staticmethod
    def _choose_reference(asked, data):
        """``reference`` as given, or the one ``"auto"`` means for these tests."""
        if asked != "auto":
            return asked
        one_recording = bool(data.steps.carried[1:].all())
        zeroed = all(data.y[start] == 0 for start, _ in data.bounds)
        return "recording" if one_recording and not zeroed else "start"

    def _check_enough_rows(self, data, settings, n_driver_columns, reference):
        n_used = len(data.sensors) if self.max_sensors is None else self.max_sensors
        n_coef = n_driver_columns + n_used * (1 + len(settings.taus))
        relative = reference == "start"
        n_coef += 0 if relative else 1
        n_eq = int((data.w > 0).sum()) - (len(data.segments) if relative else 0)
        if n_eq < n_coef:
            n = data.X.shape[0]
            raise ValueError(
                f"{type(self).__name__} has too few rows to fit {n_coef} coefficients: "
                f"{n} sample{'' if n == 1 else 's'} in {len(data.segments)} "
                f"test(s) give {n_eq} equations. "
                "Give more rows, fewer sensors or fewer time constants."
            )

    # -- fit ------------------------------------------------------------------

    def fit(self, X, y, sample_weight=None):
        """Fit the gains (and choose sensors, penalty and time constants) on tests.

        Five steps: check the data and decide which tests carry state and the
        reference; build the lag features of every input on the bank; choose
        the sensors and the penalty on held-out tests; with
        ``time_constants="fit"``, fit the time constants of what was chosen;
        solve the gains on all tests.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            Drivers and temperature sensors, tests marked by the ``test`` index
            level (and ``time_s`` in seconds within each test).
        y : array-like of shape (n_samples,)
            Displacement.
        sample_weight : array-like of shape (n_samples,), optional
            Weight of each row in the fit. Rows of weight 0 still drive the
            lags (give the whole recording and weight 0 on the rows of a
            held-out test: its inputs carry the state on, its displacement is
            never seen), and a test whose weights are all 0 is never held out
            for scoring.

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
        settings = self._check_params()
        data = self._data(X, y, sample_weight, settings)
        reference = self._choose_reference(settings.reference, data)
        y_fit = data.y.copy()
        if reference == "start":
            for start, stop in data.bounds:
                y_fit[start:stop] -= data.y[start]
        scored = [i for i, s in enumerate(data.segments) if data.w[s.slice].sum() > 0]
        folds = scored if len(scored) >= 3 else None
        n_driver_columns = (
            len(data.drivers) * len(settings.powers) * (1 + len(settings.driver_taus))
        )
        self._check_enough_rows(data, settings, n_driver_columns, reference)
        base = self._fit_bank(
            data, settings, y_fit, folds, reference, settings.taus, settings.driver_taus
        )
        fits = [base]
        if settings.extend and folds is not None:
            # the sensors chosen on the bank, then the bank made longer for them
            fits += [
                replace(
                    self._fit_bank(data, settings, y_fit, folds, reference, *b, chosen=base.chosen),
                    path=base.path,
                )
                for b in _longer_banks(settings.taus, settings.driver_taus, _span(data))
            ]
        bank = min(fits, key=lambda f: f.score)  # the first of equal scores: the shortest
        if settings.fit_taus and folds is not None:
            chosen_names = [data.sensors[k] for k in bank.chosen]
            taus, driver_taus = self._fit_taus(
                data, chosen_names, settings, y_fit, folds, reference
            )
            bank = self._fit_bank(
                data, settings, y_fit, folds, reference, taus, driver_taus, chosen=bank.chosen
            )
        cols = _cols_all(bank.col_group, bank.chosen, bank.grams[0].shape[1])
        G, b = bank.grams[0].sum(axis=0), bank.grams[1].sum(axis=0)
        coef = np.zeros(bank.grams[0].shape[1])
        coef[cols] = solve_all(
            G[np.ix_(cols, cols)], b[cols], bank.grams[3].sum(), [bank.alpha], bank.pen[cols]
        )[:, 0]
        self._store(data, reference, bank, coef)
        self.bank_scores_ = {len(f.taus): f.score for f in fits} if len(fits) > 1 else {}
        self.selected_sensors_ = [data.sensors[k] for k in bank.chosen]
        self.time_constants_ = np.asarray(bank.taus, dtype=float)
        self.driver_time_constants_ = np.asarray(bank.driver_taus, dtype=float)
        self.gap_limit_s_ = float(data.gap_limit)
        return self

    def _fit_bank(self, data, settings, y, folds, reference, taus, driver_taus, chosen=None):
        """Lag features on one bank, the sensors and penalty chosen on held-out tests.

        With ``chosen`` the sensors are kept and only the penalty is chosen.
        """
        spec, groups, labels = self._spec(
            data.drivers, data.sensors, data.names, settings.powers, taus, driver_taus
        )
        col_group = np.repeat(groups, [1 + len(b[2]) for b in spec])
        F = self._design(data.X, data.steps, data.bounds, spec, groups, reference)
        grams, pen = self._grams(F, y, data.w, data.bounds, reference)
        if chosen is None:
            chosen, alpha, score, path = select_sensors(
                grams,
                pen,
                col_group,
                data.sensors,
                settings.alphas,
                folds,
                self.max_sensors,
                self.selection,
            )
        else:
            cols = _cols_all(col_group, chosen, grams[0].shape[1])
            sc = held_out_scores(grams, cols, settings.alphas, pen, folds)
            alpha, score, path = float(settings.alphas[np.argmin(sc)]), float(sc.min()), []
        return _Bank(
            np.asarray(taus, dtype=float),
            np.asarray(driver_taus, dtype=float),
            spec,
            groups,
            labels,
            col_group,
            grams,
            pen,
            list(chosen),
            float(alpha),
            float(score),
            path,
        )

    def _store(self, data, reference, bank, coef):
        """The fitted attributes of one solution."""
        spec, groups, labels, col_group = bank.spec, bank.groups, bank.labels, bank.col_group
        alpha, score, path = bank.alpha, bank.score, bank.path
        self.sensors_ = data.sensors
        self.drivers_ = data.drivers
        self.reference_ = reference
        self.state_ = (
            "carry" if len(data.segments) > 1 and data.steps.carried[1:].all() else ("restart")
        )
        self.nominal_step_s_ = data.steps.nominal_step_s
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
        self._groups_ = list(groups)
        self._labels_ = labels
        self._col_group_ = col_group
        n_cols = len(col_group)
        self.feature_coef_ = coef[:n_cols]
        self.intercept_ = 0.0 if reference == "start" else float(coef[n_cols])
        self.terms_ = self._terms()
        self.step_sizes_ = {s: 1.0 for s in data.sensors}
        for d in data.drivers:
            col = data.X[:, data.names.index(d)]
            self.step_sizes_[d] = _round_step(float(np.abs(col).max()))
        self.step_sizes_ = {c: self.step_sizes_[c] for c in data.drivers + data.sensors}

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

    @staticmethod
    def _grams(F, y, w, bounds, reference):
        """Per-test raw Grams of the design (a ones column last in the recording reference)."""
        relative = reference == "start"
        A = F if relative else np.column_stack([F, np.ones(len(F))])
        pen = np.ones(A.shape[1])
        if not relative:
            pen[-1] = 0.0
        return grams_by_test(A, y, w, bounds), pen

    def _fit_taus(self, data, chosen_names, settings, y, folds, reference):
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
            spec, groups, _ = self._spec(
                data.drivers, chosen_names, data.names, settings.powers, ts, td
            )
            F = self._design(data.X, data.steps, data.bounds, spec, groups, reference)
            grams, pen = self._grams(F, y, data.w, data.bounds, reference)
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

    # -- predict --------------------------------------------------------------

    def predict(self, X, initial_displacement=None):
        """Predicted displacement of every row, in the reference ``reference_``.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            The columns seen in ``fit``, tests marked as in ``fit``. Tests
            that follow each other on one clock carry the lags from one to the
            next as in ``fit`` (``state``); give a test together with the rows
            before it to start it from its history.
        initial_displacement : float or dict, optional
            The displacement measured at the first row of every test (a
            number) or of the tests named (a dict from test label to number),
            in the reference ``reference_``: such a test's prediction is moved
            to start there. Without it, a test that starts later on its clock
            than 0 without the rows before it gets a
            :class:`~greyml.exceptions.WarmStartWarning` (unless
            ``state="restart"``: every test starting at rest is then the
            model's assumption).

        Returns
        -------
        y : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        _check_magnitudes(self, Xa, column_names(self, Xa.shape[1]), segments)
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        given = self._initial_displacements(initial_displacement, segments)
        if not (self.feature_coef_ != 0).any():
            pred = np.full(Xa.shape[0], self.intercept_)
        else:
            F = self._design(Xa, steps, bounds, self._spec_, self._groups_, self.reference_)
            pred = F @ self.feature_coef_ + self.intercept_
        for i, seg in enumerate(segments):
            if i in given:
                pred[seg.slice] += given[i] - pred[seg.start]
            elif (
                self.state != "restart"  # restarting each test is then what was asked
                and (i == 0 or not steps.carried[i])
                and steps.starts[i] > self.nominal_step_s_
            ):
                warnings.warn(
                    f"{type(self).__name__}: {segment_label(seg)} starts at time_s = "
                    f"{steps.starts[i]:g} s of its clock without the rows before it, so its "
                    "lags start from an assumed state (temperatures at rest, drivers idle). "
                    "Give the rows before it (the state carries on along one clock), or the "
                    "displacement measured at its first row with initial_displacement=.",
                    WarmStartWarning,
                    stacklevel=2,
                )
        return pred

    def _initial_displacements(self, value, segments):
        """``initial_displacement`` as {test position: finite number}."""
        if value is None:
            return {}
        name = type(self).__name__
        if isinstance(value, Mapping):
            labels = {str(s.label): i for i, s in enumerate(segments)}
            out = {}
            for label, v in value.items():
                if str(label) not in labels:
                    raise ValueError(
                        f"{name}.predict: initial_displacement names the test {label!r}, which "
                        f"is not in X (its tests: {', '.join(list(labels)[:10])})."
                    )
                out[labels[str(label)]] = _finite(v, f"the initial displacement of {label!r}")
            return out
        v = _finite(value, "initial_displacement")
        return dict.fromkeys(range(len(segments)), v)

    def compensator(self, *, nominal_step_s=None, row_columns=None):
        """A :class:`greyml.dynamic.Compensator` that runs this model row by row.

        Streaming a test from its first row (after construction or
        :meth:`~greyml.Compensator.reset`) equals :meth:`predict` on that test
        alone, and streaming the tests of one recording one after another
        equals :meth:`predict` on all of them, in the reference
        ``reference_`` (to 1e-9).

        Parameters
        ----------
        nominal_step_s : float, optional
            For a recording whose clock restarts in every piece: the step into
            a row whose ``time_s`` is not later than the previous row's (the
            next piece). By default such a row is refused, unless the model
            carried state across restarting clocks in ``fit``
            (``state="carry"``), which steps by ``nominal_step_s_``.
        row_columns : list of str, optional
            The order of the values in an array row (``"time_s"`` and every
            input, in any order); without it only mappings and Series are
            taken.

        Returns
        -------
        compensator : Compensator
        """
        check_is_fitted(self)
        from greyml.dynamic._compensator import Compensator

        if nominal_step_s is None and self.state == "carry":
            nominal_step_s = self.nominal_step_s_
        inputs = list(dict.fromkeys(name for name, _, _, _ in self.terms_))
        return Compensator(
            inputs,
            list(self.terms_),
            self.intercept_,
            relative_to_start=self.reference_ == "start",
            nominal_step_s=nominal_step_s,
            idle_inputs=[d for d in self.drivers_ if d in inputs],
            max_step_s=self.gap_limit_s_,
            row_columns=row_columns,
        )

    def _check_fitted_state(self):
        """Every fitted attribute in its domain and consistent with the others.

        Run on a model read from a file (:func:`greyml.persist.load_model`),
        which could hold anything: a negative time constant would make every
        prediction grow without bound, a block naming a column the model does
        not have would read the wrong sensor. Raises a one-line ValueError.
        """
        if "feature_coef_" not in vars(self):
            return  # not fitted: nothing but parameters
        name = type(self).__name__
        if "gap_limit_s_" not in vars(self) or "reference_" not in vars(self):
            raise ValueError(
                f"{name} was saved by an earlier greyml, before it had a reference and a gap "
                "limit; fit it again."
            )
        n_in = int(self.n_features_in_)
        check_time_constants(self.time_constants_, f"The fitted time_constants_ of {name}")
        check_time_constants(
            self.driver_time_constants_, f"The fitted driver_time_constants_ of {name}"
        )
        spec = list(self._spec_)
        width = 0
        for column, power, taus in spec:
            if not (isinstance(column, numbers.Integral) and 0 <= column < n_in):
                raise ValueError(f"{name}: a fitted block reads column {column!r} of {n_in}.")
            if not (_is_real(power) and np.isfinite(power) and power > 0):
                raise ValueError(f"{name}: a fitted block has the power {power!r}.")
            if taus:
                check_time_constants(taus, f"A fitted block of {name}")
            width += 1 + len(taus)
        if width > MAX_TERMS:
            raise ValueError(
                f"{name} holds {width:,} terms, more than the {MAX_TERMS:,} a model may hold."
            )
        coef = np.asarray(self.feature_coef_, dtype=float)
        if coef.shape != (width,) or not np.isfinite(coef).all():
            raise ValueError(
                f"{name}: feature_coef_ must be {width} finite numbers, one per term of the "
                f"fitted blocks; it has shape {coef.shape}."
            )
        if not (_is_real(self.intercept_) and np.isfinite(self.intercept_)):
            raise ValueError(f"{name}: the intercept_ {self.intercept_!r} is not finite.")
        if len(self._groups_) != len(spec) or len(self._labels_) != len(spec):
            raise ValueError(f"{name}: the fitted blocks and their groups disagree.")
        if self.reference_ not in ("start", "recording"):
            raise ValueError(f"{name}: reference_ is {self.reference_!r}.")
        if not (_is_real(self.gap_limit_s_) and np.isfinite(self.gap_limit_s_)):
            raise ValueError(f"{name}: gap_limit_s_ is {self.gap_limit_s_!r}.")
        if self.gap_limit_s_ <= 0:
            raise ValueError(f"{name}: gap_limit_s_ is {self.gap_limit_s_!r}.")
        step = self.nominal_step_s_
        if not (_is_real(step) and (np.isnan(step) or (np.isfinite(step) and step > 0))):
            raise ValueError(f"{name}: nominal_step_s_ is {step!r}.")
        if [tuple(t) for t in self.terms_] != [tuple(t) for t in self._terms()]:
            raise ValueError(f"{name}: terms_ disagree with the fitted blocks and gains.")

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags


@dataclass(frozen=True)
class _Settings:
    """The checked parameters of one fit."""

    taus: np.ndarray
    driver_taus: np.ndarray
    fit_taus: bool
    powers: tuple
    alphas: np.ndarray
    reference: str
    extend: bool


@dataclass(frozen=True)
class _Data:
    """The checked training data of one fit."""

    X: np.ndarray
    y: np.ndarray
    w: np.ndarray
    segments: list
    bounds: list
    names: list
    drivers: list
    sensors: list
    steps: Timeline
    gap_limit: float


@dataclass(frozen=True)
class _Bank:
    """One bank of time constants with the sensors and penalty chosen on it."""

    taus: np.ndarray
    driver_taus: np.ndarray
    spec: list
    groups: list
    labels: list
    col_group: np.ndarray
    grams: tuple
    pen: np.ndarray
    chosen: list
    alpha: float
    score: float
    path: list


def _span(data):
    """The longest stretch of time that the lags run through without a restart."""
    t = np.cumsum(np.nan_to_num(data.steps.dt, nan=0.0))
    longest, start = 0.0, 0.0
    for i, (first, stop) in enumerate(data.bounds):
        if i == 0 or not data.steps.carried[i]:
            start = t[first]
        longest = max(longest, t[stop - 1] - start)
    return longest


def _longer_banks(taus, driver_taus, span):
    """The bank extended by a lag three times slower at a time, while it fits in ``span``."""
    out = []
    ts, td = list(taus), list(driver_taus)
    while 3.0 * ts[-1] <= span:
        ts = [*ts, 3.0 * ts[-1]]
        td = [*td, 3.0 * td[-1]]
        out.append((np.asarray(ts), np.asarray(td)))
    return out


#: The largest input a transfer function takes: far beyond any temperature,
#: speed or displacement, and small enough that its square (a driver's power 2)
#: and the Gram matrices of its lags stay finite in float64.
MAX_INPUT = 1e100


def _check_magnitudes(model, A, names, segments):
    """Refuse in one line, naming the column, the test and the row, an input so
    large that the lag features' squares overflow (a unit error: 1e300 rpm)."""
    for j, name in enumerate(names):
        found = first_flagged(np.abs(A[:, j]) > MAX_INPUT, segments)
        if found:
            row, test = found
            what = name if name == "the target y" else f"column {name!r}"
            raise ValueError(
                f"{type(model).__name__}: {what} holds {A[row, j]:g} in {test} at row {row}, "
                f"beyond {MAX_INPUT:g}, which no measurement reaches; check its unit."
            )


def _is_real(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _finite(value, what):
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
        raise ValueError(
            f"ThermalTransferFunction.predict: {what} must be a finite number of the "
            f"target's unit; got {value!r}."
        )
    return float(value)
