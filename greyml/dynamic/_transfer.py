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
from scipy.linalg import LinAlgError, cho_factor, cho_solve
from scipy.optimize import minimize
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._sequences import TIME_LEVEL, segment_label
from greyml._validation import column_names, require_y, validate_sequences
from greyml.dynamic._kernels import lag_filter

__all__ = ["ThermalTransferFunction"]

#: Default time constants of the temperature sensors, in seconds (5, 15, 45, 135 min).
DEFAULT_TIME_CONSTANTS = (300.0, 900.0, 2700.0, 8100.0)
#: Ridge penalties tried, per row of the (standardised) design.
DEFAULT_ALPHAS = tuple(np.logspace(-6, 0, 13))
#: Relative improvement of the held-out score below which forward selection adds no sensor.
_RESOLUTION = 1e-6


# ------------------------------------------------------------------------------
# Pure array functions
# ------------------------------------------------------------------------------


def _features(x, dt, bounds, spec, carry):
    """Design columns for inputs ``x`` (n, q) given ``spec``.

    ``spec`` is a list of (column, power, taus) blocks; each block contributes a
    static column ``x[:, column] ** power`` followed by its lags at ``taus``.
    Blocks with the same taus are filtered together (one kernel call).
    Returns ``F`` of shape (n, n_columns).
    """
    n = x.shape[0]
    widths = [1 + len(taus) for _, _, taus in spec]
    F = np.empty((n, int(sum(widths))))
    offsets = np.concatenate(([0], np.cumsum(widths)))
    by_taus = {}
    for b, (_col, _power, taus) in enumerate(spec):
        by_taus.setdefault(tuple(taus), []).append(b)
    for taus, blocks in by_taus.items():
        cols = np.column_stack([x[:, spec[b][0]] ** spec[b][1] for b in blocks])
        for k, b in enumerate(blocks):
            F[:, offsets[b]] = cols[:, k]
        if taus:
            lags, _ = lag_filter(cols, dt, np.asarray(taus), bounds, carry=carry)
            for k, b in enumerate(blocks):
                F[:, offsets[b] + 1 : offsets[b + 1]] = lags[:, k, :]
    return F


def _test_grams(A, y, w, bounds):
    """Per-test weighted Gram matrices ``A'WA``, ``A'Wy``, ``y'Wy`` and weight sums."""
    G, b, yy, sw = [], [], [], []
    for start, stop in bounds:
        a, t, v = A[start:stop], y[start:stop], w[start:stop]
        av = a * v[:, None]
        G.append(av.T @ a)
        b.append(av.T @ t)
        yy.append(float(t @ (v * t)))
        sw.append(float(v.sum()))
    return np.array(G), np.array(b), np.array(yy), np.array(sw)


def _ridge(G, b, alpha, penalised):
    """Solve (G + alpha·diag(penalised)) w = b; falls back to lstsq when singular."""
    M = G + np.diag(alpha * penalised)
    try:
        return cho_solve(cho_factor(M, check_finite=False), b, check_finite=False)
    except (LinAlgError, ValueError):
        return np.linalg.lstsq(M, b, rcond=None)[0]


def _standardised(G, b, sw, pen):
    """Gram of the design with unit weighted standard deviation per column.

    ``G``, ``b`` are the summed raw Grams of some tests and ``sw`` their weight.
    Where a column is unpenalised (the intercept, always last) the others are
    scaled by their centred deviation, which with an unpenalised intercept is
    the same ridge as on centred columns. Returns (G', b', scale).
    """
    m2 = np.diag(G) / sw
    if (pen == 0).any():
        var = m2 - (G[-1] / sw) ** 2
    else:
        var = m2
    scale = np.sqrt(np.maximum(var, 0.0))
    scale = np.where((scale > 0) & (var > 1e-14 * np.maximum(m2, 1e-300)) & (pen > 0), scale, 1.0)
    d = 1.0 / scale
    return G * d[:, None] * d[None, :], b * d, scale


def _solve_all(G, b, sw, alphas, pen):
    """Ridge coefficients (raw units) for every alpha: columns of a (p, n_alphas) array.

    The penalty is ``alpha`` per unit of weight (per row with unit weights) on
    the standardised columns, so a fit on fewer tests is penalised in proportion.
    """
    Gn, bn, scale = _standardised(G, b, sw, pen)
    alphas = np.asarray(alphas, dtype=float)
    if (pen > 0).all():
        # one eigendecomposition serves every alpha
        lam, V = np.linalg.eigh(Gn)
        lam = np.maximum(lam, 0.0)
        coefs = V @ ((V.T @ bn)[:, None] / (lam[:, None] + alphas[None, :] * sw))
    else:
        coefs = np.column_stack([_ridge(Gn, bn, a * sw, pen) for a in alphas])
    return coefs / scale[:, None]


def _held_out_scores(grams, cols, alphas, pen, folds):
    """Mean held-out RMSE over ``folds`` for each alpha, on design columns ``cols``.

    ``grams`` are the per-test raw (G, b, yy, sw); each fold holds out one test,
    standardises and solves the ridge on the others exactly as a refit on them
    would, and scores the held-out test from its own Gram. Returns an array
    (n_alphas,) of mean per-test RMSE.
    """
    G, b, yy, sw = grams
    ix = np.ix_(cols, cols)
    Gs = G[:, ix[0], ix[1]]
    bs = b[:, cols]
    Gt, bt, st = Gs.sum(axis=0), bs.sum(axis=0), sw.sum()
    pen = pen[cols]
    out = np.zeros(len(alphas))
    for h in folds:
        coefs = _solve_all(Gt - Gs[h], bt - bs[h], st - sw[h], alphas, pen)
        sse = yy[h] - 2.0 * (bs[h] @ coefs) + np.einsum("ia,ij,ja->a", coefs, Gs[h], coefs)
        out += np.sqrt(np.maximum(sse, 0.0) / sw[h])
    return out / len(folds)


def _train_scores(grams, cols, alphas, pen):
    """Training RMSE (all tests pooled) for each alpha, when too few tests to hold one out."""
    G, b, yy, sw = grams
    ix = np.ix_(cols, cols)
    Gt, bt = G[:, ix[0], ix[1]].sum(axis=0), b[:, cols].sum(axis=0)
    coefs = _solve_all(Gt, bt, sw.sum(), alphas, pen[cols])
    sse = yy.sum() - 2.0 * (bt @ coefs) + np.einsum("ia,ij,ja->a", coefs, Gt, coefs)
    return np.sqrt(np.maximum(sse, 0.0) / sw.sum())


# ------------------------------------------------------------------------------
# The estimator
# ------------------------------------------------------------------------------


def _fmt_tau(tau):
    minutes = tau / 60.0
    if minutes >= 1 and abs(minutes - round(minutes)) < 1e-9:
        return f"{int(round(minutes))} min"
    if minutes >= 1:
        return f"{minutes:.3g} min"
    return f"{tau:.3g} s"


def _round_step(peak):
    """A round step size for a driver: the power of ten below its largest value."""
    if not np.isfinite(peak) or peak <= 0:
        return 1.0
    return float(10.0 ** np.floor(np.log10(peak)))


class ThermalTransferFunction(RegressorMixin, BaseEstimator):
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
        if isinstance(value, str):
            also = " or 'fit'" if name == "time_constants" else ""
            raise ValueError(
                f"The {name!r} parameter of {type(self).__name__} must be a sequence of "
                f"time constants in seconds{also} or None. Got {value!r} instead."
            )
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
        name = type(self).__name__
        if self.state not in ("restart", "carry"):
            raise ValueError(
                f"The 'state' parameter of {name} must be 'restart' or 'carry'. "
                f"Got {self.state!r} instead."
            )
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
        if self.max_sensors is not None and (
            not isinstance(self.max_sensors, numbers.Integral)
            or isinstance(self.max_sensors, bool)
            or self.max_sensors < 1
        ):
            raise ValueError(
                f"The 'max_sensors' parameter of {name} must be an int in the range "
                f"[1, inf) or None. Got {self.max_sensors!r} instead."
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
        if self.selection not in ("forward", "stable"):
            raise ValueError(
                f"The 'selection' parameter of {name} must be 'forward' or 'stable'. "
                f"Got {self.selection!r} instead."
            )
        if not isinstance(self.relative_to_start, (bool, np.bool_)):
            raise ValueError(
                f"The 'relative_to_start' parameter of {name} must be True or False. "
                f"Got {self.relative_to_start!r} instead."
            )
        if isinstance(self.drivers, str):
            raise ValueError(
                f"The 'drivers' parameter of {name} must be a sequence of column names, "
                f"e.g. [{self.drivers!r}]. Got the string {self.drivers!r} instead."
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
        F = _features(x, dt, bounds, spec, self.state == "carry")
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
        chosen, alpha, score, path = self._select(grams, pen, col_group, sensors, alphas, folds)
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
            cols = self._cols_all(col_group, chosen, grams[0].shape[1])
            sc = _held_out_scores(grams, cols, alphas, pen, folds)
            alpha, score = float(alphas[np.argmin(sc)]), float(sc.min())
        cols = self._cols_all(col_group, chosen, grams[0].shape[1])
        G, b = grams[0].sum(axis=0), grams[1].sum(axis=0)
        coef = np.zeros(grams[0].shape[1])
        coef[cols] = _solve_all(G[np.ix_(cols, cols)], b[cols], grams[3].sum(), [alpha], pen[cols])[
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
        bad = np.flatnonzero(~np.isfinite(w) | (w < 0))
        if bad.size:
            r = int(bad[0])
            seg = next(s for s in segments if s.start <= r < s.stop)
            raise ValueError(
                f"{type(self).__name__}: sample_weight of row {r} ({segment_label(seg)}) is "
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
        return _test_grams(A, y, w, bounds), pen

    @staticmethod
    def _cols(col_group, chosen):
        keep = np.isin(col_group, [-1, *chosen])
        return np.flatnonzero(keep)

    def _cols_all(self, col_group, chosen, n_total):
        cols = list(self._cols(col_group, chosen))
        if n_total > len(col_group):
            cols.append(len(col_group))
        return np.asarray(cols, dtype=int)

    def _score(self, grams, cols, alphas, pen, folds):
        if folds is None:
            return _train_scores(grams, cols, alphas, pen)
        return _held_out_scores(grams, cols, alphas, pen, folds)

    def _select(self, grams, pen, col_group, sensors, alphas, folds):
        """Forward selection of whole sensors; returns (chosen, alpha, score, path)."""
        n_total = grams[0].shape[1]

        def evaluate(chosen):
            cols = self._cols_all(col_group, chosen, n_total)
            sc = self._score(grams, cols, alphas, pen, folds)
            i = int(np.argmin(sc))
            return float(sc[i]), float(alphas[i])

        everything = list(range(len(sensors)))
        if self.max_sensors is None:
            score, alpha = evaluate(everything)
            return everything, alpha, score, []
        if self.selection == "stable" and folds is not None and len(folds) >= 4:
            return self._stable(grams, pen, col_group, sensors, alphas, folds, evaluate)
        return self._forward(evaluate, everything, sensors, col_group, n_total)

    def _stable(self, grams, pen, col_group, sensors, alphas, folds, evaluate):
        """Forward selection repeated without each test in turn; keep the sensors most runs chose.

        A sensor enters when at least half of the runs chose it (at most
        ``max_sensors``, most votes first, then earliest on average); the
        penalty is then chosen by leave one test out on all tests.
        """
        votes, rank = {}, {}
        n_total = grams[0].shape[1]
        for t in folds:
            without = tuple(a.copy() for a in grams)
            for a in without:
                a[t] = 0.0
            rest = [f for f in folds if f != t]

            def evaluate_without(chosen, without=without, rest=rest):
                cols = self._cols_all(col_group, chosen, n_total)
                sc = _held_out_scores(without, cols, alphas, pen, rest)
                i = int(np.argmin(sc))
                return float(sc[i]), float(alphas[i])

            keep, _, _, _ = self._forward(
                evaluate_without, list(range(len(sensors))), sensors, col_group, n_total
            )
            for position, k in enumerate(keep):
                votes[k] = votes.get(k, 0) + 1
                rank[k] = rank.get(k, 0) + position
        order = sorted(votes, key=lambda k: (-votes[k], rank[k] / votes[k], k))
        chosen = [k for k in order if 2 * votes[k] >= len(folds)][: self.max_sensors]
        if not chosen and order:
            chosen = order[:1]
        score, alpha = evaluate(chosen)
        path = [(sensors[k], float(votes[k]) / len(folds)) for k in order]
        return chosen, alpha, score, path

    def _forward(self, evaluate, everything, sensors, col_group, n_total):
        """Greedy forward selection; the best prefix up to ``max_sensors`` by held-out score.

        A longer prefix is kept only when it lowers the score by more than
        ``_RESOLUTION`` times the first step's score: a sensor whose gain is
        at the level of rounding (noise-free data fitted to 1e-7) is not
        chosen by the last digits of a floating-point sum.
        """
        chosen, path, prefixes = [], [], []
        if (col_group == -1).any() or n_total > len(col_group):
            score, alpha = evaluate([])
            path.append((None, score, alpha))
            prefixes.append((score, [], alpha))
        for _ in range(self.max_sensors):
            trial = []
            for k in everything:
                if k in chosen:
                    continue
                score, alpha = evaluate([*chosen, k])
                trial.append((score, k, alpha))
            if not trial:
                break
            score, k, alpha = min(trial)
            chosen = [*chosen, k]
            path.append((sensors[k], score, alpha))
            prefixes.append((score, list(chosen), alpha))
        lowest = min(score for score, _, _ in prefixes)
        within = lowest + _RESOLUTION * abs(prefixes[0][0])
        score, keep, alpha = next(p for p in prefixes if p[0] <= within)
        return keep, alpha, score, path

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
            return float(_held_out_scores(grams, cols, alphas, pen, folds).min())

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

    # -- readable -------------------------------------------------------------

    @property
    def selection_(self):
        """The selection's path as a table (see the class's Attributes)."""
        check_is_fitted(self)
        return pd.DataFrame(self._selection_path_, columns=self._selection_columns_)

    @property
    def gains_(self):
        """Each input's gains as a table (see the class's Attributes)."""
        check_is_fitted(self)
        return self._gain_table()

    def _terms(self):
        terms = []
        c = 0
        for (_col, power, taus), (name, _) in zip(self._spec_, self._labels_):
            for tau in (None, *taus):
                weight = float(self.feature_coef_[c])
                if weight != 0.0:
                    terms.append((name, power, None if tau is None else float(tau), weight))
                c += 1
        return terms

    def _gain_table(self):
        rows, index = [], []
        all_taus = sorted({t for _, _, taus in self._spec_ for t in taus})
        columns = ["static"] + [f"lag {_fmt_tau(t)}" for t in all_taus]
        c = 0
        for (_col, power, taus), (name, _) in zip(self._spec_, self._labels_):
            row = dict.fromkeys(columns, np.nan)
            row["static"] = self.feature_coef_[c]
            for j, tau in enumerate(taus):
                row[f"lag {_fmt_tau(tau)}"] = self.feature_coef_[c + 1 + j]
            c += 1 + len(taus)
            group_in = name in self.drivers_ or name in self.selected_sensors_
            if group_in:
                rows.append(row)
                index.append((name, power))
        table = pd.DataFrame(rows, columns=columns)
        table.index = pd.MultiIndex.from_tuples(index, names=["input", "power"])
        return table

    def step_response(self, input, step=None, *, start=0.0, times=None):
        """Displacement after a step of one input, all other inputs held.

        Parameters
        ----------
        input : str
            A driver or a selected sensor.
        step : float, optional
            Size of the step in the input's unit; default ``step_sizes_[input]``
            (1 K for a sensor, e.g. 1000 rpm for a spindle).
        start : float, default=0.0
            Value before the step (matters for powers above 1).
        times : array-like, optional
            Seconds after the step; default 0 to five times the largest time
            constant, 200 points.

        Returns
        -------
        response : Series
            Displacement change (units of y) indexed by ``time_s``.
        """
        check_is_fitted(self)
        if input not in self.step_sizes_:
            raise ValueError(
                f"step_response: {input!r} is not an input of this model (inputs: "
                f"{', '.join(self.step_sizes_)})."
            )
        step = self.step_sizes_[input] if step is None else float(step)
        if times is None:
            top = 5.0 * max(self.time_constants_.max(), self.driver_time_constants_.max())
            times = np.linspace(0.0, top, 200)
        times = np.asarray(times, dtype=float)
        out = np.zeros_like(times)
        for name, power, tau, weight in self.terms_:
            if name != input:
                continue
            jump = (start + step) ** power - start**power
            shape = np.ones_like(times) if tau is None else 1.0 - np.exp(-times / tau)
            out += weight * jump * shape
        return pd.Series(out, index=pd.Index(times, name=TIME_LEVEL), name=input)

    def describe(self, unit="µm", *, file=None):
        """Print one line per input: its step response in words.

        Parameters
        ----------
        unit : str, default="µm"
            Unit of the displacement.
        file : file-like, optional
            Where to print (default standard output).

        Returns
        -------
        text : str
            The lines printed.
        """
        check_is_fitted(self)
        lines = []
        for name in self.drivers_ + self.selected_sensors_:
            step = self.step_sizes_[name]
            is_driver = name in self.drivers_
            per = f"{step:g} {'rpm' if 'rpm' in name else 'units'}" if is_driver else "1 K"
            long = 5.0 * max(self.time_constants_.max(), self.driver_time_constants_.max())
            grid = np.linspace(0.0, long, 2001)
            r = self.step_response(name, step, times=grid).to_numpy()
            final = float(self.step_response(name, step, times=[np.inf]).iloc[0])
            at_once = r[0]
            at45 = float(self.step_response(name, step, times=[2700.0]).iloc[0])
            if abs(final) > 0:
                reached = np.flatnonzero(np.abs(r - at_once) >= 0.632 * abs(final - at_once))
                t63 = grid[reached[0]] / 60.0 if reached.size and final != at_once else 0.0
                within = f"63 % of the lagged part within {t63:.0f} min"
            else:
                within = "no response"
            lines.append(
                f"{name}: {final:.3g} {unit} per {per} at steady state, {at_once:.3g} {unit} "
                f"at once, {at45:.3g} {unit} after 45 min; {within}"
            )
        text = "\n".join(lines)
        print(text, file=file)
        return text

    # -- predict --------------------------------------------------------------

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
