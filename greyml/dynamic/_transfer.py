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
out, from three tests on; ten folds of consecutive tests beyond ten tests):
the ridge penalty, which temperature sensors to use
(a group lasso over whole sensors, or forward selection) and, with
``time_constants="fit"``, the time constants. Every held-out score is
computed from per-test Gram matrices, so a candidate costs a few small linear
solves, not a refit.

One class, whole, in this module: the checks of its parameters, data and
fitted state; the design (time, inputs, blocks of lags, per-test Grams); the
fit's records (settings, data, one bank); ``fit`` as named steps; the
intervals' calibration (kernels in :mod:`greyml.dynamic._intervals`);
``partial_fit``; and what a fitted model says (tables, step responses,
``describe``). The runtime that streams it, :class:`greyml.Compensator`,
lives in :mod:`greyml.controller` and is built from the fitted attributes
(:meth:`greyml.Compensator.from_model`).
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from functools import partial

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted

from greyml._caller import warn_user
from greyml._param_validation import Integral, Interval, Real, StrOptions
from greyml._sequences import TIME_LEVEL, segment_label
from greyml._time import format_duration
from greyml._validation import (
    MAX_INPUT,
    check_magnitudes,
    column_names,
    first_flagged,
    require_y,
    validate_sequences,
)
from greyml.dynamic import _gram
from greyml.dynamic._envelope import InputEnvelope, envelope_of, follow, union
from greyml.dynamic._gram import (
    DesignRows,
    GramBlocks,
    _cols_all,
    _score,
    fold_groups,
    grams_of_rows,
    held_out_rmse,
    held_out_scores,
    row_pieces,
    select_sensors,
    solve_all,
)
from greyml.dynamic._intervals import (
    IntervalCalibration,
    compress_scores,
    scale_fit,
    scale_of,
    variogram_fit,
    weights_by_test,
)
from greyml.dynamic._observer import READING_HOURS, observer_noise
from greyml.dynamic._rows import Rows, read_rows
from greyml.dynamic._sparse import RIDGE, group_lasso_at, group_lasso_select
from greyml.dynamic._time import (
    MAX_TERMS,
    STATES,
    Timeline,
    check_time_constants,
    timeline,
    timeline_of,
)
from greyml.exceptions import UnderdeterminedWarning, WarmStartWarning

__all__ = ["DEFAULT_ALPHAS", "DEFAULT_TIME_CONSTANTS", "MAX_INPUT", "ThermalTransferFunction"]

#: The values of ``reference``.
REFERENCES = ("auto", "start", "recording")
#: Default time constants of the temperature sensors, in seconds (5, 15, 45, 135 min).
DEFAULT_TIME_CONSTANTS = (300.0, 900.0, 2700.0, 8100.0)
#: Ridge penalties tried, per row of the (standardised) design.
DEFAULT_ALPHAS = tuple(np.logspace(-6, 0, 13))


class _EnvelopeRows:
    """The :class:`InputEnvelope` of the inputs ``used``, from the rows of positive
    weight (see :mod:`greyml.dynamic._envelope`), added up piece by piece as the rows
    pass (each piece with the last row of the one before, so that the change between
    them counts)."""

    def __init__(self, data, used):
        self.data, self.used = data, used
        self.columns = [data.names.index(c) for c in used]
        self.starts = np.array([a for a, _ in data.bounds], dtype=int)
        self.envelope, self.last = None, None

    def passing(self, chunks):
        """``chunks`` as they are, each added on its way."""
        for r0, x in chunks:
            self.add(r0, x)
            yield r0, x

    def add(self, r0, x):
        data = self.data
        dt, w, carried = data.steps.dt, data.w, data.steps.carried
        r1 = r0 + x.shape[0]
        parts = row_pieces(self.starts, data.bounds, r0, r1)
        lo = r0 - (self.last is not None)
        local = [(a - lo, b - lo) for _, a, b in parts]
        links = [bool(carried[i]) for i, _, _ in parts]
        rows = x[:, self.columns]
        if self.last is not None:
            rows = np.vstack([self.last, rows])
            if parts[0][1] > data.bounds[parts[0][0]][0]:  # the test runs on
                local[0] = (0, local[0][1])
            else:
                local, links = [(0, 1), *local], [False, *links]
        seen = envelope_of(rows, dt[lo:r1], local, w[lo:r1], self.used, links)
        self.envelope = seen if self.envelope is None else union(self.envelope, seen)
        self.last = x[-1:, self.columns]


#: Rows of a frame above which ``fit`` reads it in pieces of this many rows.
WHOLE_ROWS = 1 << 20


class _FramePieces:
    """A frame's rows (with their targets and weights) as pieces of :data:`WHOLE_ROWS`."""

    def __init__(self, X, y, sample_weight):
        self.X, self.y, self.w = X, y, sample_weight

    def __iter__(self):
        for a in range(0, self.X.shape[0], WHOLE_ROWS):
            b = a + WHOLE_ROWS
            yield self.X.iloc[a:b], _rows_of(self.y, a, b), _rows_of(self.w, a, b)


def _rows_of(values, a, b):
    """Rows ``a:b`` of a target or weights (None stays None)."""
    if values is None:
        return None
    if isinstance(values, (pd.Series, pd.DataFrame)):
        return values.iloc[a:b]
    return np.asarray(values)[a:b]


# -- the records of one fit -----------------------------------------------------


@dataclass(frozen=True)
class Settings:
    """The checked parameters of one fit."""

    taus: np.ndarray
    driver_taus: np.ndarray
    fit_taus: bool
    powers: tuple
    alphas: np.ndarray
    reference: str
    extend: bool


@dataclass(frozen=True)
class Data:
    """The checked training data of one fit."""

    X: np.ndarray | None
    y: np.ndarray
    w: np.ndarray
    segments: list
    bounds: list
    names: list
    drivers: list
    sensors: list
    steps: Timeline
    gap_limit: float
    #: the tests of each fold where several share one (None: one test per fold)
    fold_tests: list | None = None
    #: the rows as read (:class:`~greyml.dynamic._rows.Rows`): their inputs piece by piece
    rows: Rows | None = None


@dataclass(frozen=True)
class Bank:
    """One bank of time constants with the sensors and penalty chosen on it."""

    taus: np.ndarray
    driver_taus: np.ndarray
    spec: list
    groups: list
    labels: list
    col_group: np.ndarray
    grams: GramBlocks
    pen: np.ndarray
    chosen: list
    alpha: float
    score: float
    path: list
    #: "group" (group lasso), "forward", "stable" or "all" (every sensor, ridge)
    method: str = "all"
    #: the group lasso's coefficients on all tests and its penalty (None for a ridge)
    coef: np.ndarray | None = None
    lam: float | None = None
    #: the group lasso's coefficients without each scored test (None for a ridge)
    without: dict | None = None


def _comparison_score(bank):
    """A candidate's mean held-out RMSE on tests none of its choices saw but the penalty:
    the sensors chosen again without each test where they were chosen by a search."""
    if bank.without is None or bank.method == "group":
        return bank.score
    errors = [held_out_rmse(bank.grams, k, coef) for k, coef in bank.without.items()]
    return float(np.mean(errors))


def span(data):
    """The longest stretch of time that the lags run through without a restart."""
    t = np.cumsum(np.nan_to_num(data.steps.dt, nan=0.0))
    longest, start = 0.0, 0.0
    for i, (first, stop) in enumerate(data.bounds):
        if i == 0 or not data.steps.carried[i]:
            start = t[first]
        longest = max(longest, t[stop - 1] - start)
    return longest


def longer_banks(taus, driver_taus, span):
    """The bank extended by a lag three times slower at a time, while it fits in ``span``."""
    out = []
    ts, td = list(taus), list(driver_taus)
    while 3.0 * ts[-1] <= span:
        ts = [*ts, 3.0 * ts[-1]]
        td = [*td, 3.0 * td[-1]]
        out.append((np.asarray(ts), np.asarray(td)))
    return out


def _round_step(peak):
    """A round step size for a driver: the power of ten below its largest value."""
    if not np.isfinite(peak) or peak <= 0:
        return 1.0
    return float(10.0 ** np.floor(np.log10(peak)))


def elapsed_hours(dt, bounds):
    """Hours since each test's first row, from the steps ``dt`` into the rows."""
    hours = np.zeros(dt.size)
    for start, stop in bounds:
        if stop - start > 1:
            hours[start + 1 : stop] = np.cumsum(dt[start + 1 : stop]) / 3600.0
    return hours


def _is_real(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _finite(value, what):
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
        raise ValueError(
            f"ThermalTransferFunction.predict: {what} must be a finite number of the "
            f"target's unit; got {value!r}."
        )
    return float(value)


#: The most held-out residuals a saved model may keep for its intervals.
MAX_CONFORMITY_SCORES = 10_000_000
#: A test starts at rest when its temperatures at its first row lie within this
#: many resolutions of each other (about ±3 of a sensor's noise or quantum).
REST_RESOLUTIONS = 6.0
#: How a test's lags start: the values of ``test_starts_``.
START_STATES = ("carried", "at rest", "assumed at rest")


def sensor_resolution(x, bounds):
    """The resolution of one sensor's readings ``x`` in the tests ``bounds``:
    :func:`resolution_of_changes` of its changes within the tests."""
    parts = [np.diff(x[a:b]) for a, b in bounds if b - a > 1]
    return resolution_of_changes(np.concatenate(parts) if parts else np.zeros(0))


def resolution_of_changes(d):
    """The resolution of one sensor's readings: its quantum or its noise, the larger,
    from ``d``, its changes between successive readings.

    The quantum is the smallest change; the noise the robust spread of the
    changes (a random walk's step, so divided by √2). A reading that never
    changes has resolution 0.
    """
    moved = np.abs(d[d != 0])
    if not moved.size:
        return 0.0
    noise = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(2.0)
    return float(max(moved.min(), noise))


def start_states(x, bounds, carried, columns, resolution):
    """How each test's lags start: carried on, at rest (a cold start), or assumed at rest.

    A test that does not carry the state of the one before starts at rest
    when its temperatures ``columns`` (two or more) at its first row agree
    within :data:`REST_RESOLUTIONS` times ``resolution``: the machine at one
    temperature, its lags settled. Otherwise the lags are assumed at rest
    without that evidence (a test cut from a running machine).
    """
    states = []
    for i, (start, _) in enumerate(bounds):
        if i > 0 and carried[i]:
            states.append("carried")
        elif (
            len(columns) >= 2
            and resolution is not None
            and np.ptp(x[start, columns]) <= REST_RESOLUTIONS * resolution
        ):
            states.append("at rest")
        else:
            states.append("assumed at rest")
    return states


class ThermalTransferFunction(RegressorMixin, BaseEstimator):
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
        Budget of temperature sensors (every column that is not a driver),
        counted as whole sensors whatever chooses them. ``None``: as many as
        the held-out tests support (the group lasso), or all of them (the
        ridge), whichever scores better.
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
    selection : {"auto", "group", "forward", "stable"}, default="auto"
        How the sensors are chosen (see Notes). ``"group"``: a group lasso
        over each sensor's whole group of terms, its penalty chosen on
        held-out tests (three tests or more; with fewer, as ``"forward"``).
        ``"forward"``: one forward selection of whole sensors on held-out
        tests under ``max_sensors`` (every sensor, ridge only, without it).
        ``"stable"``: the sensors chosen by at least half of the forward
        selections run without each test in turn (needs four tests; with
        fewer, ``"forward"``). ``"auto"``: the group lasso and ``"forward"``
        both, and the one with the lower held-out RMSE on tests its choices
        did not see.
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
        The sensors in the model: in the order forward selection added them,
        those the group lasso kept (in column order), or all sensors.
    selection_method_ : {"group", "forward", "stable", "all"}
        What chose them: the group lasso, forward or stable selection, or
        none (every sensor, with ``max_sensors=None`` and a ridge).
    group_penalty_ : float or None
        The group lasso's penalty (per row, on the standardised design), None
        when the gains are a ridge solution.
    sensor_resolution_ : float
        The temperature sensors' resolution in the training data (the largest
        of each sensor's quantum or noise, K): temperatures within six of it of
        each other at a test's first row are a machine at rest.
    test_starts_ : dict
        How each training test's lags started: ``"carried"`` on from the test
        before, ``"at rest"`` (a cold start: its temperatures agreed at its
        first row, so the lags at rest at them and the drivers idle are what
        happened) or ``"assumed at rest"`` (no history and temperatures that
        disagree: the state at rest is the model's assumption, as for a test
        cut from a running machine). :meth:`predict` warns only for the last.
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
    interval_calibration_ : IntervalCalibration or None
        The interval's calibration on the held-out residuals (refits on all
        tests but one, sensors chosen again without it): the variance
        ``s(t)² = anchor_var + growth_var_per_h·t`` at ``t`` hours since the
        displacement was last known (the test's first row;
        ``growth_var_per_h = 0`` in the "recording" reference, where no row
        is known), the white and slow parts the compensator's probe filter
        uses, and the sorted conformity scores that :meth:`predict_interval`
        takes its quantile from (see
        :class:`~greyml.dynamic.IntervalCalibration`). None when fewer than 3
        tests were scored.
    input_envelope_ : InputEnvelope or None
        What the training rows (positive weight) saw of each input the model
        reads (its drivers, then its selected sensors):
        its lowest and highest value and its largest rate of change per hour
        between consecutive rows (of one test, or across into a test that
        carries the state of the one before; see
        :class:`~greyml.dynamic.InputEnvelope`). :meth:`outside_envelope`
        tells the rows beyond it, and :meth:`predict_interval` widens there.
        None for a model saved before it existed.
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
        runs that chose it. With the group lasso: its path, one row per
        penalty (the number of sensors it keeps and the mean held-out RMSE).
    cv_score_ : float
        Mean held-out RMSE of the chosen model (training RMSE with fewer than
        three tests).
    step_sizes_ : dict
        Default step of each input for :meth:`step_response` and
        :meth:`describe`: 1 for a sensor, the power of ten below a driver's
        largest training value (1000 for a spindle up to 5000 rpm).
    fitted_tests_ : list of str
        The labels of the tests the gains were fitted on (those with a
        positive ``sample_weight``), in their order; ``""`` for data without
        test labels. ``greyml predict`` marks these tests in its table.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)
        Defined only when ``X`` has string column names.

    See Also
    --------
    greyml.GMC : one first-order grey response driven by all sensors.
    greyml.LagFeatures : the same lags as a transformer, for any linear model.
    greyml.Compensator : runs a fitted model row by row (``Compensator.from_model``).

    Notes
    -----
    **What fit chooses.** For fixed time constants the model is linear in its
    gains: they are one ridge regression on the standardised lag features.
    Everything else is chosen inside ``fit`` on whole held-out tests (leave
    one test out; with more than ten tests, ten folds of consecutive tests,
    Hastie, Tibshirani and Friedman (2009)) when ``fit`` has three tests or
    more, never on rows of a test being predicted:

    * the ridge penalty, from ``alphas``;
    * which temperature sensors, by two candidates, and between them the
      one whose held-out RMSE is lower (``selection="auto"``). The first is
      a **group lasso** (Yuan and Lin, 2006): a sensor's static term and
      its lags form one group, penalised by the Euclidean norm of their
      standardised gains, so a sensor enters or leaves whole and the gains
      kept are shrunk together, which is what lets many correlated
      temperatures share a displacement without one test's peculiarities
      deciding which of them carries it; the drivers are never dropped. Its
      penalty is chosen on held-out tests along a path of 13 from the one at
      which no sensor enters down to a thousandth of it: the lowest mean
      held-out RMSE (with ``max_sensors``, among those that keep at most that
      many sensors), not the sparsest within one standard error of it, since
      a sensor dropped for parsimony can be the one a test unlike the
      training tests needs. The
      second is a ridge on every sensor or, with ``max_sensors``, on those
      that forward selection chooses. The candidates are compared on the
      tests their choices did not see: with four tests or more, forward
      selection is run again without each test (its own held-out RMSE,
      computed on the tests that chose the sensors, would flatter it), while
      the ridge and the group lasso are scored as chosen, having chosen only
      a penalty;
    * **forward selection** (``"auto"`` with ``max_sensors``, or ``"forward"``)
      of whole sensors (a sensor's static term and all its lags enter
      together), each step adding the sensor that lowers the mean held-out
      RMSE most, then keeping the shortest list (up to ``max_sensors``)
      whose mean held-out RMSE is within one standard error (over the
      held-out tests) of the lowest, the one-standard-error rule of Breiman
      et al. (1984): with a handful of tests, smaller differences are noise
      (and never within less than one part in a million of the first step's
      RMSE, so that rounding never adds a sensor). It scores exactly what
      a hard budget asks (held-out error of whole tests with at most
      ``max_sensors``) and does not shrink the gains it keeps; on many
      correlated sensors its greedy steps fit the held-out tests that choose
      them, which is why it is not alone;
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

    **Cost.** Time linear in rows and flat in the number of tests; memory
    flat in rows but for 24 bytes a row: the lag features are computed
    32,768 rows at a time, never held whole, and a frame of more than 2^20
    rows is read in pieces. :meth:`fit_chunks` fits rows given in pieces
    (files larger than memory), the same model.

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
    Boyd, S., Parikh, N., Chu, E., Peleato, B., Eckstein, J. (2011).
    Distributed optimization and statistical learning via the alternating
    direction method of multipliers. Foundations and Trends in Machine
    Learning 3(1), 1–122 (how the group lasso is solved).

    Breiman, L., Friedman, J. H., Olshen, R. A., Stone, C. J. (1984).
    Classification and Regression Trees. Wadsworth (the one-standard-error
    rule).

    Mareš, M., Horejš, O., Havlík, L. (2020). Thermal error compensation of a
    5-axis machine tool using indigenous temperature sensors and CNC
    integrated Python code validated with a machined test piece. Precision
    Engineering 66, 21–30.

    Yuan, M., Lin, Y. (2006). Model selection and estimation in regression
    with grouped variables. Journal of the Royal Statistical Society B 68(1),
    49–67.

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
        "selection": [StrOptions({"auto", "group", "forward", "stable"})],
        "sample_interval": [Interval(Real, 0, None, closed="neither"), None],
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
        selection="auto",
        sample_interval=None,
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

    # -- parameters -----------------------------------------------------------

    def _check_params(self):
        """The settings of a fit: what the constraints cannot check (entries of sequences)."""
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
        return Settings(taus, driver_taus, fit_taus, powers, alphas, self.reference, extend)

    def _check_fitted_state(self):
        """Every fitted attribute in its domain and consistent with the others.

        Run on a self read from a file (:func:`greyml.persist.load_model`),
        which could hold anything: a negative time constant would make every
        prediction grow without bound, a block naming a column the self does
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
                f"{name} holds {width:,} terms, more than the {MAX_TERMS:,} a self may hold."
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
        self._check_interval_state(name)
        self._check_envelope_state(name)
        self._check_selection_state(name)
        self._check_normal_equations(name, width + (0 if self.reference_ == "start" else 1))

    # -- data -----------------------------------------------------------------

    def _data(self, X, y, sample_weight, settings):
        """Validated training data: arrays, tests, inputs, weights and time.

        A frame of more than :data:`WHOLE_ROWS` rows is read in pieces of that
        many rows at every pass, as :meth:`fit_chunks` reads its pieces: no
        float copy of it is held beside it (the model is the same).
        """
        n = getattr(X, "shape", (0,))[0]
        if isinstance(X, pd.DataFrame) and n > WHOLE_ROWS:
            return self._data_of(_FramePieces(X, y, sample_weight), settings, keep=False)
        return self._data_of([(X, y, sample_weight)], settings, keep=True)

    def _data_of(self, pieces, settings, keep):
        """:meth:`_data` of rows given in pieces (held in memory with ``keep``)."""
        rows = read_rows(
            self,
            pieces,
            weights=partial(self._sample_weights, whole=False),
            default_step=self.sample_interval,
            keep=keep,
        )
        names = rows.names
        drivers, sensors = self._inputs(names)
        self._check_max_sensors(sensors, names)
        tau_max = settings.taus.max()
        if drivers:
            tau_max = max(tau_max, settings.driver_taus.max())
        steps = timeline_of(
            rows.t,
            rows.clocked,
            rows.labelled,
            rows.segments,
            owner=type(self).__name__,
            tau_max=tau_max,
            state=self.state,
        )
        bounds = [(s.start, s.stop) for s in rows.segments]
        return Data(
            rows.X,
            rows.y,
            rows.w,
            rows.segments,
            bounds,
            names,
            drivers,
            sensors,
            steps,
            float(tau_max),
            rows=rows,
        )

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
        self._check_drivers_given()
        self._validate_params()
        require_y(self, y)
        settings = self._check_params()
        return self._fit_data(self._data(X, y, sample_weight, settings), settings)

    def fit_chunks(self, chunks):
        """Fit on rows given in pieces, as ``fit`` on all of them stacked.

        For data larger than memory: the pieces are read once to check them
        and keep each row's time, target and weight (24 bytes a row), then
        again for the Grams and again for the held-out predictions of the
        intervals (more often with ``time_constants="fit"``); the lag
        features are never held whole. The result equals ``fit`` on the
        stacked rows to rounding (the same sums, cut at other places).

        Parameters
        ----------
        chunks : sequence of (X, y) or (X, y, sample_weight)
            The pieces in the order of the rows, each as ``fit`` takes them;
            a test may run on from one piece into the next (the same label,
            its time running on), but not come back after another test. It is
            iterated at every pass, so it must give the same pieces each time:
            a list, or :class:`greyml.io.TestFiles` to read files piece by
            piece; a generator (read once) is refused.

        Returns
        -------
        self : ThermalTransferFunction
        """
        if iter(chunks) is chunks:
            raise ValueError(
                f"{type(self).__name__}.fit_chunks reads its pieces more than once; give a "
                "sequence (a list, or greyml.io.TestFiles), not a generator or iterator."
            )
        self._check_drivers_given()
        self._validate_params()
        settings = self._check_params()
        return self._fit_data(self._data_of(chunks, settings, keep=False), settings)

    def _check_drivers_given(self):
        if isinstance(self.drivers, str):
            # before the constraints, which would only say "an array-like"
            raise ValueError(
                f"The 'drivers' parameter of {type(self).__name__} must be a sequence of "
                f"column names, e.g. [{self.drivers!r}]. Got the string {self.drivers!r} "
                "instead."
            )

    def _fit_data(self, data, settings):
        """The fit proper, on checked :class:`Data`."""
        reference = self._choose_reference(settings.reference, data)
        y_fit = data.y  # from the recording's zero as it is; else each test's change
        if reference == "start":
            y_fit = data.y.copy()
            for start, stop in data.bounds:
                y_fit[start:stop] -= data.y[start]
        scored = [i for i, s in enumerate(data.segments) if data.w[s.slice].sum() > 0]
        folds = scored if len(scored) >= 3 else None
        if folds is not None and len(scored) > len(fold_groups(scored)):
            # more tests than folds: each fold's Grams are its tests' summed
            data = replace(data, fold_tests=fold_groups(scored))
            folds = list(range(len(data.fold_tests)))
        n_driver_columns = (
            len(data.drivers) * len(settings.powers) * (1 + len(settings.driver_taus))
        )
        self._check_enough_rows(data, settings, n_driver_columns, reference)
        longer = []
        if settings.extend and folds is not None:
            longer = longer_banks(settings.taus, settings.driver_taus, span(data))
        # every bank's Grams from the longest's (each bank's lags are a prefix of its)
        widest = self._spec(
            data.drivers,
            data.sensors,
            data.names,
            settings.powers,
            *(longer[-1] if longer else (settings.taus, settings.driver_taus)),
        )
        grams_of = self._bank_grams(data, widest[0], widest[1], y_fit, reference)
        base = self._fit_bank(
            data,
            settings,
            y_fit,
            folds,
            reference,
            settings.taus,
            settings.driver_taus,
            grams_of=grams_of,
        )
        fits = [base]
        # the sensors chosen on the bank, then the bank made longer for them
        fits += [
            replace(
                self._fit_bank(
                    data,
                    settings,
                    y_fit,
                    folds,
                    reference,
                    *b,
                    base.chosen,
                    base.method,
                    base.lam,
                    grams_of=grams_of,
                ),
                path=base.path,
            )
            for b in longer
        ]
        bank = min(fits, key=lambda f: f.score)  # the first of equal scores: the shortest
        if settings.fit_taus and folds is not None:
            chosen_names = [data.sensors[k] for k in bank.chosen]
            taus, driver_taus = self._fit_time_constants(
                data, chosen_names, settings, y_fit, folds, reference
            )
            bank = self._fit_bank(
                data,
                settings,
                y_fit,
                folds,
                reference,
                taus,
                driver_taus,
                bank.chosen,
                bank.method,
                bank.lam,
            )
        cols = _cols_all(bank.col_group, bank.chosen, bank.grams.n_columns)
        G, b = bank.grams.G.sum(axis=0), bank.grams.b.sum(axis=0)
        G, b, sw = G[np.ix_(cols, cols)], b[cols], bank.grams.sw.sum()
        if bank.coef is not None:
            coef = bank.coef
        else:
            coef = np.zeros(bank.grams.n_columns)
            coef[cols] = solve_all(G, b, sw, [bank.alpha], bank.pen[cols])[:, 0]
        self._store(data, reference, bank, coef)
        self._keep_normal_equations(G, b, sw, cols, bank.pen[cols], bank.lam)
        self.bank_scores_ = {len(f.taus): f.score for f in fits} if len(fits) > 1 else {}
        self.selected_sensors_ = [data.sensors[k] for k in bank.chosen]
        self.time_constants_ = np.asarray(bank.taus, dtype=float)
        self.driver_time_constants_ = np.asarray(bank.driver_taus, dtype=float)
        self.gap_limit_s_ = float(data.gap_limit)
        # one pass over the rows for the held-out predictions and the envelope
        seen = _EnvelopeRows(data, self._used_inputs())
        chunks = seen.passing(data.rows.chunks())
        self.interval_calibration_ = self._calibrate(
            data, bank, reference, y_fit, folds, settings.alphas, chunks
        )
        for _ in chunks:  # what the calibration did not read (all of it without one)
            pass
        self.input_envelope_ = seen.envelope
        columns = [data.names.index(c) for c in data.sensors]
        self.sensor_resolution_ = max(
            (resolution_of_changes(data.rows.changes[:, k]) for k in columns), default=0.0
        )
        firsts = [(i, i + 1) for i in range(len(data.bounds))]
        states = start_states(
            data.rows.first_rows, firsts, data.steps.carried, columns, self.sensor_resolution_
        )
        self.test_starts_ = {
            ("" if seg.label is None else str(seg.label)): state
            for seg, state in zip(data.segments, states)
        }
        # the labels of the tests whose displacement the fit saw (weight > 0)
        self.fitted_tests_ = [
            "" if data.segments[i].label is None else str(data.segments[i].label) for i in scored
        ]
        return self

    def _fit_bank(
        self,
        data,
        settings,
        y,
        folds,
        reference,
        taus,
        driver_taus,
        chosen=None,
        method=None,
        lam=None,
        grams_of=None,
    ):
        """Lag features on one bank, the sensors and penalty chosen on held-out tests.

        With ``chosen`` (and the ``method`` that chose them) the sensors are
        kept and only the ridge penalty is chosen (the group lasso keeps its
        penalty ``lam``). ``grams_of(spec)`` gives the bank's Grams from a
        wider bank's (by default they are computed).
        """
        spec, groups, labels = self._spec(
            data.drivers, data.sensors, data.names, settings.powers, taus, driver_taus
        )
        col_group = np.repeat(groups, [1 + len(b[2]) for b in spec])
        if grams_of is None:
            grams, pen = self._grams(data, spec, groups, y, reference)
        else:
            grams, pen = grams_of(spec)
        bank = partial(
            Bank, np.asarray(taus, dtype=float), np.asarray(driver_taus, dtype=float), spec
        )
        bank = partial(bank, groups, labels, col_group, grams, pen)
        if chosen is not None:
            if method == "group":
                return bank(*self._group_lasso_on(grams, pen, col_group, chosen, folds, lam))
            cols = _cols_all(col_group, chosen, grams.n_columns)
            sc = held_out_scores(grams, cols, settings.alphas, pen, folds)
            alpha, score = float(settings.alphas[np.argmin(sc)]), float(sc.min())
            return bank(list(chosen), alpha, score, [], method=method)
        candidates = []
        group_lasso = self.selection in ("auto", "group") and folds is not None
        if group_lasso and data.sensors:
            coef, picked, lam, score, path, without = group_lasso_select(
                grams, pen, col_group, folds, self.max_sensors
            )
            candidates.append(bank(picked, RIDGE, score, path, "group", coef, lam, without))
        if self.selection != "group" or not candidates:
            # "group" here: fewer than three tests, nothing to choose its penalty on
            forward = "forward" if self.selection in ("auto", "group") else self.selection
            picked, alpha, score, path = select_sensors(
                grams,
                pen,
                col_group,
                data.sensors,
                settings.alphas,
                folds,
                self.max_sensors,
                forward,
            )
            if self.max_sensors is None:
                forward = "all"
            elif forward == "stable" and not (path and len(path[0]) == 2):
                forward = "forward"  # fewer than four tests: stable is forward
            chosen_bank = bank(list(picked), float(alpha), float(score), path, forward)
            if candidates and forward != "all" and len(folds) >= 4:
                # sensors chosen on the same held-out tests that score them: compared
                # with the group lasso on tests the selection never saw (a selection
                # without one test holds out three more: four tests or more)
                without = {
                    k: self._selection_without(chosen_bank, data.sensors, settings.alphas, k, folds)
                    for k in folds
                }
                chosen_bank = replace(chosen_bank, without=without)
            candidates.append(chosen_bank)
        # the lowest held-out RMSE; the group lasso first among equals
        return min(candidates, key=_comparison_score)

    def _selection_without(self, bank, sensors, alphas, k, folds):
        """Coefficients with the sensors and penalty chosen again without test ``k``."""
        grams, n_total = bank.grams.without(k), bank.grams.n_columns
        other = [f for f in folds if f != k]
        inner = other if len(other) >= 2 else None
        chosen = bank.chosen
        if bank.method != "all":
            chosen, _, _, _ = select_sensors(
                grams,
                bank.pen,
                bank.col_group,
                sensors,
                alphas,
                inner,
                self.max_sensors,
                bank.method,
            )
        cols = _cols_all(bank.col_group, chosen, n_total)
        alpha = float(alphas[np.argmin(_score(grams, cols, alphas, bank.pen, inner))])
        coef = np.zeros(n_total)
        coef[cols] = solve_all(
            grams.G[:, cols][:, :, cols].sum(axis=0),
            grams.b[:, cols].sum(axis=0),
            grams.sw.sum(),
            [alpha],
            bank.pen[cols],
        )[:, 0]
        return coef

    @staticmethod
    def _group_lasso_on(grams, pen, col_group, chosen, folds, lam):
        """The group lasso at the penalty ``lam`` chosen on the first bank, on the columns
        of the sensors it kept (another bank of the same sensors)."""
        n = grams.n_columns
        cols = _cols_all(col_group, chosen, n)
        sub = GramBlocks(grams.G[:, cols][:, :, cols], grams.b[:, cols], grams.yy, grams.sw)
        inside = cols[cols < len(col_group)]
        coef, _, lam, score, path, without = group_lasso_select(
            sub, pen[cols], col_group[inside], folds, None, lambdas=[lam]
        )

        def full(c):
            out = np.zeros(n)
            out[cols] = c
            return out

        without = {k: full(c) for k, c in without.items()}
        return list(chosen), RIDGE, score, path, "group", full(coef), lam, without

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
        self.selection_method_ = bank.method
        self.group_penalty_ = None if bank.lam is None else float(bank.lam)
        # kept as plain lists (a saved model holds no DataFrame); selection_ and
        # gains_ are tables built from them on access
        self._selection_path_ = [list(step) for step in path]
        self._selection_columns_ = {
            "group": ["penalty", "n_sensors", "held_out_rmse"],
            "stable": ["sensor", "share_of_runs"],
        }.get(bank.method, ["sensor", "held_out_rmse", "alpha"])
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
            self.step_sizes_[d] = _round_step(float(data.rows.peaks[data.names.index(d)]))
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
            than 0 without the rows before it, and whose temperatures at its
            first row disagree (a machine not at rest), gets a
            :class:`~greyml.exceptions.WarmStartWarning` (unless
            ``state="restart"``: every test starting at rest is then the
            model's assumption).

        Returns
        -------
        y : ndarray of shape (n_samples,)
        """
        check_is_fitted(self)
        present = self._sensors_given(X)
        X = self._with_unused_columns(X)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        names = column_names(self, Xa.shape[1])
        check_magnitudes(self, Xa, names, segments)
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        given = self._initial_displacements(initial_displacement, segments)
        states = start_states(
            Xa,
            bounds,
            steps.carried,
            [names.index(c) for c in present],
            vars(self).get("sensor_resolution_"),
        )
        if not (self.feature_coef_ != 0).any():
            pred = np.full(Xa.shape[0], self.intercept_)
        else:
            coef = np.append(self.feature_coef_, self.intercept_)
            pred = self._predictions(
                self._chunks(Xa),
                Xa.shape[0],
                steps,
                bounds,
                self._spec_,
                self._groups_,
                "start" if self.reference_ == "start" else "recording",
                dict.fromkeys(range(len(bounds)), coef),
            )
        for i, seg in enumerate(segments):
            if i in given:
                pred[seg.slice] += given[i] - pred[seg.start]
            elif (
                self.state != "restart"  # restarting each test is then what was asked
                and states[i] == "assumed at rest"
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

    def _sensors_given(self, X):
        """The temperature sensors whose readings ``X`` holds (a frame may lack unused ones)."""
        sensors = list(map(str, getattr(self, "sensors_", ())))
        if isinstance(X, pd.DataFrame):
            given = set(map(str, X.columns))
            return [c for c in sensors if c in given]
        return sensors

    def _with_unused_columns(self, X):
        """``X``, or a new frame with the fitted columns it lacks that the model never reads.

        A DataFrame needs only the drivers and the selected sensors: a fitted
        column it lacks that the model does not use is filled with 0.0 in a new
        frame (the user's is never modified); its gains are 0, so it is never
        read. A used column it lacks is one ValueError naming it.
        """
        fitted = getattr(self, "feature_names_in_", None)
        if fitted is None or not isinstance(X, pd.DataFrame):
            return X
        given = set(map(str, X.columns))
        missing = [str(c) for c in fitted if str(c) not in given]
        if not missing or not given <= set(map(str, fitted)):
            return X  # all there, or columns never seen: scikit-learn's checks say which
        used = [*map(str, getattr(self, "drivers_", ())), *map(str, self.selected_sensors_)]
        lacking = [c for c in used if c in missing]
        if lacking:
            # scikit-learn's wording first, so its estimator checks recognise it
            raise ValueError(
                "Feature names seen at fit time, yet now missing:\n"
                + "".join(f"- {c}\n" for c in sorted(lacking))
                + f"{type(self).__name__}.predict: X lacks the column(s) "
                f"{', '.join(map(repr, lacking))}, which the model uses (its drivers and "
                f"selected sensors: {', '.join(used) or 'none'}); the others may be left out."
            )
        by_name = {str(c): c for c in X.columns}
        columns = {str(c): X[by_name[str(c)]] if str(c) in by_name else 0.0 for c in fitted}
        return pd.DataFrame(columns, index=X.index)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags

    # -- checks of parameters, data and fitted state -----------------------------

    def _taus(self, name, value, default):
        if value is None:
            return np.asarray(default, dtype=float)
        return check_time_constants(value, f"The {name!r} parameter of {type(self).__name__}")

    def _check_max_sensors(self, sensors, names):
        """``max_sensors`` at most the temperature sensors (the columns of X that are
        not drivers)."""
        if self.max_sensors is not None and self.max_sensors > len(sensors):
            raise ValueError(
                f"The 'max_sensors' parameter of {type(self).__name__} is {self.max_sensors}, "
                f"more than the {len(sensors)} temperature sensor(s) "
                f"({', '.join(sensors) or 'none'}) among the {len(names)} feature(s) of X."
            )

    def _check_enough_rows(self, data, settings, n_driver_columns, reference):
        """Refuse fewer than two equations; warn when the gains outnumber them.

        An equation is a row of positive weight, less the first row of each test
        in the ``"start"`` reference. With fewer equations than gains the ridge
        penalty keeps the solve defined, and the self says so as
        :class:`~greyml.MLPBaseline` does (:class:`~greyml.exceptions.UnderdeterminedWarning`).
        """
        name = type(self).__name__
        n_used = len(data.sensors) if self.max_sensors is None else self.max_sensors
        n_coef = n_driver_columns + n_used * (1 + len(settings.taus))
        relative = reference == "start"
        n_coef += 0 if relative else 1
        n_eq = int((data.w > 0).sum()) - (len(data.segments) if relative else 0)
        n = data.y.shape[0]
        rows = (
            f"{n} sample{'' if n == 1 else 's'} in {len(data.segments)} test(s) give "
            f"{n_eq} equation{'' if n_eq == 1 else 's'}"
        )
        if n_eq < 2:
            raise ValueError(
                f"{name} has too few rows to fit: {rows}, and a fit needs at least 2. "
                "Give more rows."
            )
        if n_eq < n_coef:
            warn_user(
                f"{name} is under-determined: {rows} for {n_coef} coefficients. The ridge "
                "penalty keeps the fit defined, but it can interpolate the training rows; "
                "give more rows, fewer sensors (max_sensors) or fewer time constants.",
                UnderdeterminedWarning,
            )

    def _sample_weights(self, sample_weight, n, segments, whole=True):
        """``sample_weight`` as finite weights >= 0, not all 0 (ones without it);
        the rows of one piece of the data (which may all be 0) unless ``whole``."""
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
            value = "NaN" if np.isnan(w[r]) else f"{w[r]:g}"
            raise ValueError(
                f"{type(self).__name__}: sample_weight of row {r} ({test}) is "
                f"{value}; weights must be finite and >= 0."
            )
        if whole and w.sum() <= 0:
            raise ValueError(
                f"{type(self).__name__}: every sample_weight is zero; give some rows a "
                "positive weight."
            )
        return w

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

    def _check_normal_equations(self, name, n_total):
        """partial_fit's normal equations: a symmetric finite Gram on valid columns, or none."""
        keys = ("normal_gram_", "normal_rhs_", "normal_weight_", "_normal_cols_", "_normal_pen_")
        present = [k in vars(self) for k in keys]
        if not any(present):
            return  # saved before partial_fit existed: it then says fit again
        bad = ValueError(f"{name}: the saved normal equations (normal_gram_, ...) are not valid.")
        if not all(present):
            raise bad
        try:
            cols = np.asarray(self._normal_cols_)
            G = np.asarray(self.normal_gram_, dtype=float)
            b = np.asarray(self.normal_rhs_, dtype=float)
            pen = np.asarray(self._normal_pen_, dtype=float)
            weight = float(self.normal_weight_)
        except (TypeError, ValueError):
            raise bad from None
        k = cols.size
        if (
            cols.ndim != 1
            or cols.dtype.kind not in "iu"
            or (cols.size and (cols.min() < 0 or cols.max() >= n_total))
            or np.unique(cols).size != k
            or G.shape != (k, k)
            or b.shape != (k,)
            or pen.shape != (k,)
            or not (np.isfinite(G).all() and np.isfinite(b).all() and np.isfinite(pen).all())
            or not np.allclose(G, G.T)
            or (pen < 0).any()
            or not (np.isfinite(weight) and weight > 0)
        ):
            raise bad

    def _check_selection_state(self, name):
        """What chose the sensors, and the group lasso's penalty: None or finite >= 0."""
        resolution = vars(self).setdefault("sensor_resolution_", None)
        if resolution is not None and not (
            _is_real(resolution) and np.isfinite(resolution) and resolution >= 0
        ):
            raise ValueError(f"{name}: sensor_resolution_ is {resolution!r}.")
        starts = vars(self).setdefault("test_starts_", {})
        if not isinstance(starts, dict) or any(v not in START_STATES for v in starts.values()):
            raise ValueError(
                f"{name}: test_starts_ must map test labels to one of {', '.join(START_STATES)}."
            )
        method = vars(self).setdefault("selection_method_", "forward")
        if method not in ("group", "forward", "stable", "all"):
            raise ValueError(f"{name}: selection_method_ is {method!r}.")
        for key in ("group_penalty_", "_normal_lambda_"):
            value = vars(self).setdefault(key, None)
            if value is not None and not (_is_real(value) and np.isfinite(value) and value >= 0):
                raise ValueError(
                    f"{name}: {key} must be None or a finite number >= 0; got {value!r}."
                )

    def _check_interval_state(self, name):
        """The intervals' calibration: None, or an :class:`IntervalCalibration` in its
        domain (a > 0, b >= 0, 0 <= c <= a, s2 >= 0, memory_h > 0, sorted scores)."""
        cal = vars(self).setdefault("interval_calibration_", None)
        if cal is None:
            return
        if not isinstance(cal, IntervalCalibration):
            raise ValueError(
                f"{name}: interval_calibration_ must be an IntervalCalibration or None; "
                f"got {type(cal).__name__}."
            )
        try:
            scale = np.array(
                [cal.anchor_var, cal.growth_var_per_h, cal.noise_var, cal.memory_var, cal.memory_h],
                dtype=float,
            )
        except (AttributeError, TypeError, ValueError):
            scale = np.zeros(0)
        if (
            scale.shape != (5,)
            or not np.isfinite(scale).all()
            or scale[0] <= 0
            or (scale[1:] < 0).any()
            or scale[2] > scale[0]
            or scale[4] <= 0
        ):
            raise ValueError(
                f"{name}: interval_calibration_ must hold five finite numbers (anchor_var > 0, "
                "growth_var_per_h >= 0, 0 <= noise_var <= anchor_var, memory_var >= 0, "
                f"memory_h > 0); got {scale.tolist()!r}."
            )
        try:
            scores = np.asarray(cal.scores, dtype=float)
        except (AttributeError, TypeError, ValueError):
            scores = np.zeros((0, 0))
        if (
            scores.ndim != 1
            or not 0 < scores.size <= MAX_CONFORMITY_SCORES
            or not np.isfinite(scores).all()
            or (scores < 0).any()
            or (np.diff(scores) < 0).any()
        ):
            raise ValueError(
                f"{name}: interval_calibration_.scores must be 1 to "
                f"{MAX_CONFORMITY_SCORES:,} finite, non-negative numbers in increasing order."
            )

    # -- the design: time, inputs, blocks, lag features, Grams -------------------

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

    @staticmethod
    def _design_rows(steps, bounds, spec, groups, reference):
        """The :class:`DesignRows` of the blocks ``spec``; drivers (group -1) start idle
        without history; each test's first row's subtracted in the "start" reference."""
        idle = [b for b, g in enumerate(groups) if g == -1]
        return DesignRows(
            steps.dt, bounds, spec, steps.carried, idle, start_rows=reference == "start"
        )

    @staticmethod
    def _chunks(x):
        """``(r0, rows)`` of ``x`` in pieces of :data:`CHUNK_ROWS`."""
        rows = _gram.CHUNK_ROWS
        return ((r0, x[r0 : r0 + rows]) for r0 in range(0, x.shape[0], rows))

    def _grams(self, data, spec, groups, y, reference):
        """Per-test raw Grams of the design of ``spec`` (a ones column last in the
        recording reference), summed by fold where several tests share one."""
        relative = reference == "start"
        rows = self._design_rows(data.steps, data.bounds, spec, groups, reference)
        grams = grams_of_rows(
            rows, data.rows.chunks(), y, data.w, not relative, groups=data.fold_tests
        )
        pen = np.ones(grams.n_columns)
        if not relative:
            pen[-1] = 0.0
        return grams, pen

    def _bank_grams(self, data, spec, groups, y, reference):
        """``grams_of(spec)``: the Grams of any bank whose lags are a prefix of
        ``spec``'s, from ``spec``'s computed once."""
        wide, pen = self._grams(data, spec, groups, y, reference)
        offsets = np.concatenate(([0], np.cumsum([1 + len(b[2]) for b in spec])))

        def grams_of(sub):
            cols = [offsets[k] + np.arange(1 + len(b[2])) for k, b in enumerate(sub)]
            if reference != "start":
                cols.append([offsets[-1]])
            cols = np.concatenate(cols).astype(int)
            return wide.columns(cols), pen[cols]

        return grams_of

    def _predictions(self, chunks, n, steps, bounds, spec, groups, reference, coefs):
        """Each of the ``n`` rows' prediction (their inputs ``chunks``, as
        :meth:`Rows.chunks` gives them) by the coefficients ``coefs[test]`` of its
        test (a ones column last); rows of other tests 0."""
        rows = self._design_rows(steps, bounds, spec, groups, reference)
        pred = np.zeros(n)
        width = rows.order.size
        inner = {}  # each test's coefficients in the order the rows compute the columns
        for r0, chunk in chunks:
            FT = rows.rows(r0, chunk)
            for i, start, stop in rows.pieces(r0, r0 + chunk.shape[0]):
                if i in coefs:
                    c = coefs[i]
                    if i not in inner:
                        inner[i] = (c[:width][rows.order], c[width] if c.size > width else 0.0)
                    ci, c0 = inner[i]
                    pred[start:stop] = ci @ FT[:, start - r0 : stop - r0] + c0
        return pred

    def _fit_time_constants(self, data, chosen_names, settings, y, folds, reference):
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
            grams, pen = self._grams(data, spec, groups, y, reference)
            cols = np.arange(grams.n_columns)
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

    # -- intervals ---------------------------------------------------------------

    def _calibrate(self, data, bank, reference, y, folds, alphas, chunks):
        """The interval's :class:`IntervalCalibration` from the held-out tests.

        ``None`` when fewer than 3 tests were scored (nothing was held out, so
        there is nothing honest to calibrate on).
        """
        if folds is None:
            return None
        # the sensors and the penalty are chosen again without each test, the
        # penalty on every other value of the grid (half the cost; the residuals
        # of a choice that saw the test would be too small)
        grid = np.asarray(alphas, dtype=float)[::2]

        def choose(k):
            if bank.without is not None:  # computed when the candidates were compared
                return bank.without[k]
            return self._selection_without(bank, data.sensors, grid, k, folds)

        # each held-out test predicted by the model chosen and solved without its fold
        tests = {k: [k] if data.fold_tests is None else data.fold_tests[k] for k in folds}
        coefs = {t: coef for k in folds for coef in [choose(k)] for t in tests[k]}
        pred = self._predictions(
            chunks,
            data.y.size,
            data.steps,
            data.bounds,
            bank.spec,
            bank.groups,
            reference,
            coefs,
        )
        resid = np.subtract(y, pred, out=pred)  # in place: one array of rows
        hours_all = elapsed_hours(data.steps.dt, data.bounds)
        hours, residuals = [], []
        for t in (t for k in folds for t in tests[k]):
            start, stop = data.bounds[t]
            used = data.w[start:stop] > 0
            if used.all():  # views, not copies
                hours.append(hours_all[start:stop])
                residuals.append(resid[start:stop])
            else:
                hours.append(hours_all[start:stop][used])
                residuals.append(resid[start:stop][used])
        series = [(h, r) for h, r in zip(hours, residuals) if r.size]
        hours, residuals = [h for h, _ in series], [r for _, r in series]
        # the white part: what decorrelates faster than the shortest reading
        # interval the filter is chosen for (15 min)
        c, s2, memory_h = variogram_fit(
            residuals, data.steps.nominal_step_s, min_hours=READING_HOURS[0]
        )
        sizes = [r.size for r in residuals]
        per_test = [1.0 / (len(sizes) * m) for m in sizes]  # weights_by_test's, per row
        if reference == "start":
            a, b = scale_fit(hours, residuals, per_test)
        else:
            # from the recording's zero the displacement is never known at a row,
            # so nothing anchors a width that grows: one width for every row
            flat = [np.broadcast_to(0.0, r.shape) for r in residuals]
            a, b = scale_fit(flat, residuals, per_test)[0], 0.0
        noise = float(min(c, a))

        def prior(h):  # the offset's variance before the first reading, h hours in
            return a - noise + b * h

        qb, qr, scale, glr_scale = observer_noise(series, prior, noise, memory_h, s2)
        scores = np.concatenate([np.abs(r) / scale_of(h, a, b) for h, r in series])
        weights = weights_by_test(sizes)
        order = np.argsort(scores, kind="stable")
        scores, weights = scores[order], weights[order]
        del order
        kept, kept_weights = compress_scores(scores, weights)
        return IntervalCalibration(
            anchor_var=float(a),
            growth_var_per_h=float(b),
            noise_var=noise,
            memory_var=float(s2),
            memory_h=float(memory_h),
            scores=kept,
            score_weights=kept_weights,
            n_tests=len(series),
            filter_scale=float(scale),
            bias_var_per_h=float(qb),
            rate_var_per_h3=float(qr),
            glr_scale=float(glr_scale),
        )

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
        width = q * self.interval_calibration_.scale(np.asarray(hours, dtype=float))
        return float(width) if np.ndim(width) == 0 else width

    def _quantile(self, coverage):
        name = type(self).__name__
        if self.interval_calibration_ is None:
            if not isinstance(coverage, (int, float, np.floating)) or not 0 < coverage < 1:
                raise ValueError(
                    f"{name}.predict_interval: coverage must be a number in (0, 1); "
                    f"got {coverage!r}."
                )
            raise ValueError(
                f"{name} was fitted on fewer than 3 tests with a weight, so no test was held "
                "out and its intervals could not be calibrated; fit it on at least 3 tests."
            )
        return self.interval_calibration_.quantile(coverage, name)

    def predict_interval(self, X, coverage=0.9, initial_displacement=None):
        """Prediction and its ``coverage`` interval for every row, in ``reference_``.

        The interval is calibrated in ``fit`` on whole held-out tests
        (split-conformal on the leave-one-test-out residuals, scaled by a
        width that grows with the time since the displacement was last known;
        see :mod:`greyml.dynamic._intervals`). Its coverage is a promise over
        tests like the training tests, held out whole; it says nothing about
        a test unlike all of them.

        Where an input leaves what training saw (its range or its fastest
        change, ``input_envelope_``), the half-width grows by ``Σ_i |Δ_i|``,
        the model's own response to the part of each input beyond the
        envelope: ``Δ_i = predict(X) − predict(X̃_i)`` with input ``i``
        replaced by its follower (see :meth:`outside_envelope`), summed in
        absolute value so that two inputs' responses never cancel. Rows inside
        it keep the calibrated half-width exactly.

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
        X = self._with_unused_columns(X)
        pred = self.predict(X, initial_displacement=initial_displacement)
        _, _, segments = validate_sequences(self, X, reset=False)
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        half = q * self.interval_calibration_.scale(elapsed_hours(steps.dt, bounds))
        half = half + self._envelope_widening(X, initial_displacement)
        return np.column_stack([pred, pred - half, pred + half])

    # -- inputs outside the training envelope ------------------------------------

    def _used_inputs(self):
        """The inputs the model reads: its drivers, then its selected sensors."""
        return [*map(str, self.drivers_), *map(str, self.selected_sensors_)]

    def _followed(self, X):
        """``(Xa, followed, columns, segments)``: the rows of ``X`` as an array, the
        follower of each enveloped input (the envelope's order), its columns in ``Xa``."""
        X = self._with_unused_columns(X)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        names = column_names(self, Xa.shape[1])
        steps = self._timeline(X, segments, self.gap_limit_s_, self.nominal_step_s_)
        bounds = [(s.start, s.stop) for s in segments]
        env = self.input_envelope_
        columns = [names.index(c) for c in env.names]
        followed = follow(Xa[:, columns], steps.dt, bounds, env, carry=steps.carried)
        return Xa, followed, columns, segments

    def _envelope_widening(self, X, initial_displacement=None):
        """``Σ_i |Δ_i|`` of every row: the model's own response to each input's excess.

        Δ_i = predict(X) − predict(X with input i replaced by its follower),
        through :meth:`predict` itself (the same lags, reference and
        ``initial_displacement``), summed in absolute value over the inputs, so
        that the responses to two inputs' excesses never cancel: exactly 0 on
        rows whose inputs never left the envelope since the test's start.
        """
        X = self._with_unused_columns(X)
        env = vars(self).get("input_envelope_")
        if env is None:
            return 0.0
        Xa, followed, columns, _ = self._followed(X)
        widening = np.zeros(Xa.shape[0])
        with warnings.catch_warnings():
            # predict_interval's own predict has already warned of a warm start
            warnings.simplefilter("ignore", WarmStartWarning)
            pred = None
            for j, k in enumerate(columns):
                if np.array_equal(followed[:, j], Xa[:, k]):
                    continue  # never outside: no response
                if pred is None:
                    pred = self.predict(X, initial_displacement)
                if isinstance(X, pd.DataFrame):
                    inside = X.copy()
                    inside.isetitem(k, followed[:, j])
                else:
                    inside = np.array(Xa, dtype=float)
                    inside[:, k] = followed[:, j]
                widening += np.abs(pred - self.predict(inside, initial_displacement))
        return widening

    def outside_envelope(self, X):
        """How far each input the model reads is outside its training envelope, row by row.

        The envelope (``input_envelope_``) is each input's range and fastest
        change over the training rows with a positive weight. The excess of a
        row is the input minus its *follower*, the nearest signal that never
        leaves the envelope (clipped to the range, moving at most the largest
        rate; see :mod:`greyml.dynamic._envelope`): 0 inside, signed and in the
        input's own unit outside. :meth:`predict_interval` widens its interval
        by the model's response to these excesses.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            As for :meth:`predict`.

        Returns
        -------
        excess : DataFrame of shape (n_samples, n_used_inputs)
            One column per input the model reads (a term with a weight, in the
            envelope's order: the inputs :meth:`greyml.Compensator.from_model`
            streams), on ``X``'s index when ``X`` is a DataFrame. A row is
            outside where any value is not 0.

        Examples
        --------
        >>> import numpy as np
        >>> import pandas as pd
        >>> from greyml import ThermalTransferFunction, make_test_index
        >>> t = np.arange(0.0, 6 * 3600, 60.0)
        >>> temp = 20.0 + np.minimum(t / 3600.0, 2.0)  # 20 to 22 °C at 1 K/h
        >>> index = make_test_index(["I"] * t.size, t)
        >>> X = pd.DataFrame({"T1_C": temp}, index=index)
        >>> model = ThermalTransferFunction().fit(X, 3.0 * (temp - 20.0))
        >>> hot = pd.DataFrame({"T1_C": temp + 1.0}, index=index)  # 1 K above training
        >>> float(model.outside_envelope(hot)["T1_C"].iloc[-1])
        1.0
        """
        check_is_fitted(self)
        env = vars(self).get("input_envelope_")
        if env is None:
            raise ValueError(
                f"{type(self).__name__} was saved by an earlier greyml, without its input "
                "envelope; fit it again to tell the rows outside it."
            )
        Xa, followed, columns, _ = self._followed(X)
        index = X.index if isinstance(X, pd.DataFrame) else None
        excess = pd.DataFrame(Xa[:, columns] - followed, columns=list(env.names), index=index)
        read = {name for name, _, _, _ in self.terms_}  # a selected sensor may have no weight
        return excess[[c for c in env.names if c in read]]

    def _check_envelope_state(self, name):
        """``input_envelope_``: None (saved before it existed), or an envelope in its
        domain over exactly the inputs the terms read."""
        env = vars(self).setdefault("input_envelope_", None)
        if env is None:
            return
        if not isinstance(env, InputEnvelope):
            raise ValueError(
                f"{name}: input_envelope_ must be an InputEnvelope or None; "
                f"got {type(env).__name__}."
            )
        env = env.check(name)
        if list(env.names) != self._used_inputs():
            raise ValueError(
                f"{name}: input_envelope_ names {', '.join(env.names) or 'no input'}, not the "
                f"inputs its terms read ({', '.join(self._used_inputs()) or 'none'})."
            )
        self.input_envelope_ = env

    # -- partial_fit -------------------------------------------------------------

    def _keep_normal_equations(self, G, b, sw, cols, pen, lam=None):
        """What ``partial_fit`` adds to: the chosen columns' raw Gram, its rhs, the weight
        (and the group lasso's penalty, None for a ridge)."""
        self.normal_gram_ = np.asarray(G, dtype=float)
        self.normal_rhs_ = np.asarray(b, dtype=float)
        self.normal_weight_ = float(sw)
        self._normal_cols_ = np.asarray(cols, dtype=int)
        self._normal_pen_ = np.asarray(pen, dtype=float)
        self._normal_lambda_ = None if lam is None else float(lam)

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
        w = self._sample_weights(sample_weight, Xa.shape[0], segments)
        y_fit = ya.copy()
        if self.reference_ == "start":
            for start, stop in bounds:
                y_fit[start:stop] -= ya[start]
        rows = self._design_rows(steps, bounds, self._spec_, self._groups_, self.reference_)
        new = grams_of_rows(rows, self._chunks(Xa), y_fit, w, self.reference_ != "start")
        n_cols = len(self._col_group_)
        cols = self._normal_cols_
        G = forgetting * self.normal_gram_ + new.G.sum(axis=0)[np.ix_(cols, cols)]
        b = forgetting * self.normal_rhs_ + new.b.sum(axis=0)[cols]
        weight = forgetting * self.normal_weight_ + float(new.sw.sum())
        coef = np.zeros(n_cols + (0 if self.reference_ == "start" else 1))
        lam = vars(self).get("_normal_lambda_")
        if lam is None:
            coef[cols] = solve_all(G, b, weight, [self.alpha_], self._normal_pen_)[:, 0]
        else:  # the group lasso again, at its penalty, on the sensors it kept
            inside = cols[cols < len(self._col_group_)]
            coef[cols] = group_lasso_at(
                G, b, weight, self._normal_pen_, self._col_group_[inside], lam
            )
        self.feature_coef_ = coef[:n_cols]
        self.intercept_ = 0.0 if self.reference_ == "start" else float(coef[n_cols])
        self.terms_ = self._terms()
        self._keep_normal_equations(G, b, weight, cols, self._normal_pen_, lam)
        if vars(self).get("input_envelope_") is not None:  # what the new tests saw, too
            names = column_names(self, Xa.shape[1])
            env = self.input_envelope_
            columns = [names.index(c) for c in env.names]
            seen = envelope_of(Xa[:, columns], steps.dt, bounds, w, env.names, steps.carried)
            self.input_envelope_ = union(env, seen)
        return self

    # -- what a fitted model says -------------------------------------------------

    @property
    def selection_(self):
        """Forward selection step by step, as a table: the sensor added, the mean
        held-out RMSE and the penalty, one row per step (empty without
        ``max_sensors``); with ``selection="stable"``, each sensor any run
        chose and the share of runs that chose it.
        """
        check_is_fitted(self)
        return pd.DataFrame(self._selection_path_, columns=self._selection_columns_)

    @property
    def gains_(self):
        """Each input's gains as a table: one row per input and power, one column
        per term (``static``, ``lag 5 min`` and so on), each the weight of its
        term in ``terms_`` (µm per unit of the input raised to the power, for a
        displacement in µm).
        """
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
        columns = ["static"] + [f"lag {format_duration(t)}" for t in all_taus]
        c = 0
        for (_col, power, taus), (name, _) in zip(self._spec_, self._labels_):
            row = dict.fromkeys(columns, np.nan)
            row["static"] = self.feature_coef_[c]
            for j, tau in enumerate(taus):
                row[f"lag {format_duration(tau)}"] = self.feature_coef_[c + 1 + j]
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
        """Print one line per input: its step response in words; then how far to trust
        the model (its 90 % interval and probe filter, when calibrated) and how the
        training tests started.

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
        lines.append(self._trust_line(unit))
        lines.append(self._starts_line())
        text = "\n".join(line for line in lines if line)
        print(text, file=file)
        return text

    def _trust_line(self, unit):
        """One line: the 90 % interval's calibration and the probe filter's, or ''."""
        cal = vars(self).get("interval_calibration_")
        if cal is None:
            return ""
        where = (
            f"where the displacement was last known, its variance growing "
            f"{cal.growth_var_per_h:.3g} {unit}² per hour since"
            if cal.growth_var_per_h > 0
            else "at every row"
        )
        n = cal.n_tests or "the"
        return (
            f"90 % interval: ±{self.interval_half_width(0.0, 0.9):.3g} {unit} {where} "
            f"(from {n} held-out tests; "
            f"{cal.promise(0.9)}); probe filter: innovations' RMS "
            f"{math.sqrt(cal.filter_scale):.2f} on them before calibration, change "
            f"detector's threshold ×{cal.glr_scale:.2f} for their memory"
        )

    def _starts_line(self):
        """One line: which training tests carried their state, started at rest, or were assumed."""
        starts = vars(self).get("test_starts_") or {}
        parts = []
        for state, words in (
            ("carried", "carried on from the test before"),
            ("at rest", "at rest at their first row (cold starts)"),
            ("assumed at rest", "without history, their lags assumed at rest"),
        ):
            labels = [label for label, s in starts.items() if s == state]
            if labels:
                shown = ", ".join(labels[:8]) + (" ..." if len(labels) > 8 else "")
                parts.append(f"{words}: {shown}")
        return ("training tests " + "; ".join(parts)) if parts else ""

    # -- predict --------------------------------------------------------------
