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

import warnings
from dataclasses import replace

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Hidden, Integral, Interval, Real, StrOptions
from greyml._renamed import DEPRECATED
from greyml._sequences import segment_label
from greyml._validation import column_names, require_y, validate_sequences
from greyml.dynamic._gram import (
    _cols_all,
    held_out_scores,
    select_sensors,
    solve_all,
)
from greyml.dynamic._time import (
    STATES,
)
from greyml.dynamic._transfer_checks import (  # noqa: F401 (DEFAULT_*: the model's defaults)
    DEFAULT_ALPHAS,
    DEFAULT_TIME_CONSTANTS,
    check_enough_rows,
    check_fitted_state,
    check_magnitudes,
    check_max_sensors,
    check_params,
    initial_displacements,
    sample_weights,
)
from greyml.dynamic._transfer_design import _TransferDesign, fit_time_constants
from greyml.dynamic._transfer_intervals import _TransferIntervals
from greyml.dynamic._transfer_readout import _round_step, _TransferReadout
from greyml.dynamic._transfer_records import Bank, Data, longer_banks, span
from greyml.dynamic._transfer_stream import _TransferStream
from greyml.dynamic._transfer_update import _TransferUpdate
from greyml.exceptions import WarmStartWarning

__all__ = ["ThermalTransferFunction"]

#: The values of ``reference``.
REFERENCES = ("auto", "start", "recording")


class ThermalTransferFunction(
    _TransferDesign,
    _TransferReadout,
    _TransferIntervals,
    _TransferUpdate,
    _TransferStream,
    RegressorMixin,
    BaseEstimator,
):
    r"""Displacement as a sum of each input's first-order thermal responses.

    Every input :math:`x` reaches the displacement through a static gain and
    one gain per first-order lag of it, for a bank of time constants
    :math:`\tau` (seconds):

    .. math::

        s_k = a_k\, s_{k-1} + (1 - a_k)\, x_k, \qquad
        a_k = e^{-\Delta t_k / \tau},

    with :math:`\Delta t_k` the step from the previous row. Drivers (columns
    the controller knows, such as the spindle speed) enter with their powers
    (:math:`n` and :math:`n^2` by default: bearing friction heat grows faster
    than linearly with speed) and a slower extra lag; every other column is a
    temperature sensor. The gains are one ridge regression; the
    penalty, the sensors (``max_sensors``) and, on request, the time
    constants are chosen inside ``fit`` on whole held-out tests (see Notes).
    This is the structure of the thermal transfer functions that Mareš,
    Horejš et al. (2020) identify per heat source and run in the CNC.

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
        where the previous one left off. ``"auto"``: ``"recording"`` when the
        tests are pieces of one recording (each starts on one clock after the
        last row of the one before, directly or after a gap, where its lags
        restart) and the displacement is not zero at every test's first row,
        else ``"start"``. The choice is ``reference_``.
    alphas : sequence of float or None, default=None
        Ridge penalties per row of the standardised design; ``None``: 13
        values from 1e-6 to 1 (log spaced).
    selection : {"forward", "stable"}, default="forward"
        How ``max_sensors`` sensors are chosen: one forward selection on
        held-out tests, or the sensors chosen by at least half of the forward
        selections run without each test in turn (needs four tests; with
        fewer, ``"forward"``).
    sample_interval : float or None, default=None
        Seconds between rows when ``X`` has no ``time_s`` index level (a
        NumPy array, a DataFrame with a plain index): every step is this
        long. ``None``: such rows are refused, in one line that asks for
        this or for the ``time_s`` level (as :class:`LagFeatures` does). A
        ``time_s`` level, where present, always wins.

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
    interval_scale_ : ndarray of shape (5,) or None
        ``(a, b, c, s2, memory_h)`` of the held-out residuals (refits on all
        tests but one): ``s(t)² = a + b·t`` their squared scale at ``t``
        hours since the displacement was last known (the test's first row;
        ``b = 0`` in the "recording" reference, where no row is known),
        which :meth:`predict_interval` uses; ``c`` (≤ a) their white part,
        and ``s2`` and ``memory_h`` the variance and memory (hours) of their
        slow part, from their variogram, which the compensator's probe
        filter uses. None when fewer than 3 tests were scored.
    conformity_scores_ : ndarray of shape (n_held_out_rows,) or None
        The held-out residuals divided by ``s(t)``, sorted: the residuals of
        refits on all tests but one (sensors chosen again without it), which
        calibrate :meth:`predict_interval`.
    normal_gram_, normal_rhs_, normal_weight_ : ndarray, ndarray, float
        The normal equations of the final solve (the raw Gram matrix of the
        chosen columns, its right-hand side, the weight of the rows), which
        :meth:`partial_fit` adds new tests to.
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
    **What fit chooses.** For fixed time constants the model is linear in its
    gains: they are one ridge regression on the standardised lag features.
    Everything else is chosen inside ``fit`` on whole held-out tests (leave
    one test out) when ``fit`` has three tests or more, never on rows of a
    test being predicted:

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
      than a group lasso because it scores exactly what is asked (held-out
      error of whole tests with a hard budget of sensors), its penalty does
      not shrink the gains that are kept, and with per-test Gram matrices a
      step costs only small linear solves;
    * with ``time_constants="fit"``, the time constants (variable
      projection: a Nelder–Mead search over their logarithms, the gains
      solved for each candidate), after the sensors are chosen on the bank.
      The search starts from the given driver lags and the default sensor
      bank, and fits the drivers' and the chosen sensors' lags (a shared
      bank for the sensors).

    ``selection="stable"`` (four tests or more) repeats the forward selection
    without each test in turn and keeps the sensors that at least half of the
    runs chose (stability selection, Meinshausen and Bühlmann (2010)): fewer
    sensors that fit one test's peculiarities.

    With fewer than three tests the penalty and the sensors are chosen by
    training error (which favours the smallest penalty), and
    ``time_constants="fit"`` keeps the default bank: there is no whole test
    to hold out that leaves two to fit.

    **Time.** Without a ``time_s`` index level the rows are taken as
    ``sample_interval`` seconds apart (without either, ``fit`` and
    ``predict`` refuse them: a guessed spacing would scale every time
    constant by the true step). A sampling gap
    longer than the largest time constant is refused: the lags would have
    forgotten everything before it.

    With fewer equations than gains (rows, less one per test with reference
    ``"start"``), the ridge penalty keeps the fit defined and ``fit`` warns
    (:class:`~greyml.exceptions.UnderdeterminedWarning`) as ``MLPBaseline`` does.

    **scikit-learn's estimator checks.** With ``sample_interval`` the model
    passes :func:`~sklearn.utils.estimator_checks.check_estimator` but for
    three checks that take rows as independent, which a sequence model's are
    not: a subset, a reordering, a repeated or a removed row changes the lags
    of every later row (``check_methods_subset_invariance``,
    ``check_methods_sample_order_invariance``,
    ``check_sample_weight_equivalence_on_dense_data``). With
    ``reference="start"`` ``check_regressors_train`` fails too: the check's
    targets are not zero at the first row. Pass them as ``expected_failed_checks``.

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

    >>> import numpy as np
    >>> import pandas as pd
    >>> from greyml import ThermalTransferFunction, make_test_index
    >>> t = np.arange(0.0, 4 * 3600, 60.0)
    >>> rpm = np.where((t >= 600) & (t < 2 * 3600), 3000.0, 0.0)
    >>> a = np.exp(-60.0 / 900.0)  # one 60 s step of a 15 min lag
    >>> lag = np.zeros_like(rpm)
    >>> for k in range(1, rpm.size):
    ...     lag[k] = a * lag[k - 1] + (1 - a) * rpm[k]
    >>> index = make_test_index(["I"] * t.size, t)
    >>> X = pd.DataFrame({"spindle_rpm": rpm}, index=index)
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
        "sample_interval": [Interval(Real, 0, None, closed="neither"), None],
        "relative_to_start": ["boolean", Hidden(StrOptions({DEPRECATED}))],
    }
    _added_params = ("sample_interval",)  # a file from before it lacks it (greyml._renamed)

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
        sample_interval=None,
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
        self.sample_interval = sample_interval
        self.relative_to_start = relative_to_start

    # -- parameters -----------------------------------------------------------

    def _check_params(self):
        """Check what the constraints cannot say (see :func:`check_params`)."""
        return check_params(self)

    def _check_fitted_state(self):
        """The fitted attributes in their domain (see :func:`check_fitted_state`)."""
        check_fitted_state(self)

    # -- data -----------------------------------------------------------------

    def _data(self, X, y, sample_weight, settings):
        """Validated training data: arrays, tests, inputs, weights and time."""
        Xa, ya, segments = validate_sequences(self, X, y, reset=True)
        # the inputs' values first (a NaN weight is reported as such), then their layout
        w = sample_weights(self, sample_weight, Xa.shape[0], segments)
        names = column_names(self, Xa.shape[1])
        check_magnitudes(self, Xa, names, segments)
        check_magnitudes(self, ya[:, None], ["the target y"], segments)
        drivers, sensors = self._inputs(names)
        check_max_sensors(self, sensors, names)
        tau_max = settings.taus.max()
        if drivers:
            tau_max = max(tau_max, settings.driver_taus.max())
        steps = self._timeline(X, segments, tau_max)
        bounds = [(s.start, s.stop) for s in segments]
        return Data(Xa, ya, w, segments, bounds, names, drivers, sensors, steps, float(tau_max))

    @staticmethod
    def _choose_reference(asked, data):
        """``reference`` as given, or the one ``"auto"`` means for these tests."""
        if asked != "auto":
            return asked
        # one clock: every test starts after the last row of the one before it
        # (carried on, or after a gap that restarts its lags): one recording;
        # without a time_s level each test's rows count from 0 (carried only)
        firsts = [start for start, _ in data.bounds[1:]]
        one_recording = bool((data.steps.carried[1:] | (data.steps.dt[firsts] > 0)).all())
        zeroed = all(data.y[start] == 0 for start, _ in data.bounds)
        return "recording" if one_recording and not zeroed else "start"

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
        check_enough_rows(self, data, settings, n_driver_columns, reference)
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
                for b in longer_banks(settings.taus, settings.driver_taus, span(data))
            ]
        bank = min(fits, key=lambda f: f.score)  # the first of equal scores: the shortest
        if settings.fit_taus and folds is not None:
            chosen_names = [data.sensors[k] for k in bank.chosen]
            taus, driver_taus = fit_time_constants(
                self, data, chosen_names, settings, y_fit, folds, reference
            )
            bank = self._fit_bank(
                data, settings, y_fit, folds, reference, taus, driver_taus, chosen=bank.chosen
            )
        cols = _cols_all(bank.col_group, bank.chosen, bank.grams[0].shape[1])
        G, b = bank.grams[0].sum(axis=0), bank.grams[1].sum(axis=0)
        G, b, sw = G[np.ix_(cols, cols)], b[cols], bank.grams[3].sum()
        coef = np.zeros(bank.grams[0].shape[1])
        coef[cols] = solve_all(G, b, sw, [bank.alpha], bank.pen[cols])[:, 0]
        self._store(data, reference, bank, coef)
        self._keep_normal_equations(G, b, sw, cols, bank.pen[cols])
        self.bank_scores_ = {len(f.taus): f.score for f in fits} if len(fits) > 1 else {}
        self.selected_sensors_ = [data.sensors[k] for k in bank.chosen]
        self.time_constants_ = np.asarray(bank.taus, dtype=float)
        self.driver_time_constants_ = np.asarray(bank.driver_taus, dtype=float)
        self.gap_limit_s_ = float(data.gap_limit)
        self._calibrate(data, bank, reference, y_fit, folds, settings.alphas)
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
        return Bank(
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
        check_magnitudes(self, Xa, column_names(self, Xa.shape[1]), segments)
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        given = initial_displacements(self, initial_displacement, segments)
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

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags
