"""Compensator: a linear model of thermal lags, run sample by sample, as a controller runs it.

One class, whole: its parameters checked into the plan of an update (which
row position each term reads, its power, time constant and weight); reading a
row (a mapping, a pandas Series or an array) and refusing one in a line; the
lags stepped by the one lag kernel (:func:`greyml.dynamic._kernels.lag_step`);
the output stage (clamp, quantum, rate limit, hold-last-value:
:func:`greyml.controller._output.limit_output`); and how far to trust the
correction, with the probe filter that readings correct.

Trust. Before any reading, the model's error at a time ``t`` (hours) since the
displacement was last known has the variance ``offset_var + growth_var·t +
noise_var``: the structure :meth:`greyml.ThermalTransferFunction.predict_interval`
is calibrated with, so that the compensator's interval is the batch one.

A probe reading (:meth:`Compensator.observe`) corrects a small Kalman filter
(Kalman, 1960) on the model's error, with three states
(:mod:`greyml.dynamic._observer`): an offset that forgets itself with the
memory ``memory_h`` (an Ornstein-Uhlenbeck process fitted to the held-out
residuals' variogram), and a bias with its rate, both random walks, so that
readings follow a machine that drifts without waiting for a detector. The
filter's noise is chosen on the training tests' held-out residuals (its
innovations there have a mean square of 1).

A change the random walks are too slow for (a step, a ramp that starts) is
found by a generalised likelihood ratio test (Willsky and Jones, 1976) over
the last readings, which fires at most ``false_alarm_rate`` times per
reading on unchanged Gaussian, independent innovations (one in 1,000 by
default; the threshold is raised by their memory on the training tests,
``glr_scale``); on
firing, the change it estimated is added to the states and
:attr:`Compensator.status` says which (``change_kind``) and when it began
(``change_start_s``). The user can open the bias and the rate to a known
change with :meth:`Compensator.recalibrate`.

Inputs outside the training envelope. With an ``envelope`` (the model's
``input_envelope_``), each enveloped input's follower
(:func:`greyml.dynamic._envelope.follow_step`) and a second bank of the
same lags on each term's excess over it give the model's response to the
part of each input training never saw; ``status.half_width`` widens by their
sum in absolute value and ``status.outside`` names the inputs outside, as the
batch :meth:`greyml.ThermalTransferFunction.predict_interval` does.

Rows. A row becomes the float array ``(time_s, *inputs)``; a value that is not
a real number (a bool, bytes, text, a date) is refused in one line, since it
would otherwise become a number and move the axis by it.
"""

from __future__ import annotations

import math
import numbers
from collections import namedtuple
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from greyml._param_validation import (
    Interval,
    Real,
    StrOptions,
    validate_parameter_constraints,
)
from greyml._sequences import TIME_LEVEL
from greyml.controller._from_model import pipeline_terms, transfer_terms
from greyml.controller._output import QUANTA_MAX, OutputLimits, limit_output
from greyml.dynamic._envelope import InputEnvelope, follow_step, reach_of
from greyml.dynamic._kernels import lag_step
from greyml.dynamic._lags import _power_name, _tau_label
from greyml.dynamic._observer import (
    KINDS,
    WINDOW,
    cube,
    glr_advance,
    glr_change,
    glr_reset,
    glr_threshold,
    matmul,
    transition,
    update,
)
from greyml.dynamic._time import MAX_TERMS, gap_message

__all__ = [
    "HISTORY",
    "Compensator",
    "Status",
    "Uncertainty",
    "UpdatePlan",
    "ordered_sum",
    "real",
]

_PREFIX = "Compensator.update:"
_OBSERVE = "Compensator.observe:"

#: The constructor's parameters, in order (what get_params gives).
_PARAMETERS = (
    "inputs",
    "terms",
    "intercept",
    "relative_to_start",
    "nominal_step_s",
    "idle_inputs",
    "max_step_s",
    "row_columns",
    "uncertainty",
    "envelope",
    "interval_quantile",
    "tolerance_um",
    "max_correction_um",
    "probe_noise_um",
    "false_alarm_rate",
    "rate_limit_um_s",
    "quantum_um",
    "clamp_um",
    "on_missing",
)


#: Rows remembered for readings that arrive late (e.g. 2 h of 15 s rows).
HISTORY = 512

Status = namedtuple(
    "Status",
    "time_s correction half_width trusted plausible changes output held innovation "
    "change_kind change_start_s outside",
    module=__name__,
)
Status.__doc__ = """What the last update gave and how far to trust it.

time_s : float or None
    Time of the last row.
correction : float or None
    The correction given for it (probe readings included).
half_width : float
    Half-width of the interval at that row (NaN without an ``uncertainty``).
trusted : bool
    The correction is plausible and its half-width within ``tolerance_um``.
plausible : bool
    The correction is within ``max_correction_um`` (a row whose correction
    is not is refused; a probe reading may move it beyond, and the next row
    is refused then).
changes : int
    How many times the change detector fired (and recalibrated).
output : float
    What the last update gave the axis: the correction clamped, quantised and
    rate limited (0 before any).
held : bool
    The last update had a missing input (NaN or infinite) and gave the
    output before it again; its row changed no state (``time_s`` is the last
    row taken).
innovation : float
    The last reading's standardised innovation (the reading's surprise in
    standard deviations; NaN before any reading of the test).
change_kind : str or None
    What the change detector found last: ``"step"`` or ``"ramp"`` (None
    before it fires).
change_start_s : float
    When that change began, on the rows' clock (NaN before it fires).
outside : tuple of (str, float)
    The inputs outside their training envelope at the last row (an
    ``envelope`` given), each with its excess: how far it is beyond what
    training saw, signed, in the input's own unit; ``()`` inside (or without
    an envelope). ``half_width`` is widened there by the model's response to
    the excess.
"""


@dataclass(frozen=True)
class Uncertainty:
    """How far to trust a :class:`Compensator`'s correction, before and between readings.

    The error of the model's correction at ``t`` hours since the displacement
    was last known has the variance ``offset_var + growth_var_per_h·t +
    noise_var``; a probe reading corrects the offset part, which then
    forgets itself with the memory ``memory_h`` towards ``memory_var``, and
    a bias and its rate, random walks of ``bias_var_per_h`` and
    ``rate_var_per_h3`` (:mod:`greyml.dynamic._observer`). Inside the
    filter every variance is multiplied by ``scale``. Variances in µm².
    :meth:`Compensator.from_model` takes it from a fitted model's
    :class:`~greyml.dynamic.IntervalCalibration`.

    Attributes
    ----------
    offset_var : float
        The variance of the error's slow part at the anchor (≥ 0).
    growth_var_per_h : float
        How fast the variance grows, per hour since the anchor (≥ 0).
    noise_var : float
        The white part, which no reading removes (≥ 0).
    memory_var : float
        The variance the slow part returns to after a reading (≥ 0).
    memory_h : float
        The slow part's memory, in hours (> 0).
    bias_var_per_h : float, default=0.0
        The bias's random walk, µm² per hour (≥ 0).
    rate_var_per_h3 : float, default=0.0
        The bias rate's random walk, µm² per hour³ (≥ 0).
    scale : float, default=1.0
        What the filter multiplies every variance by (> 0).
    glr_scale : float, default=1.0
        What the change detector's threshold is multiplied by (≥ 1): the
        innovations' memory on the training tests.

    Examples
    --------
    An offset uncertain by 2 µm and 1 µm² of white noise: at the first row the
    90 % half-width is 1.645·√(4 + 1) µm.

    >>> from greyml.controller import Compensator, Uncertainty
    >>> u = Uncertainty(offset_var=4.0, growth_var_per_h=0.0, noise_var=1.0,
    ...                 memory_var=4.0, memory_h=1e6)
    >>> comp = Compensator(["T1_C"], [("T1_C", 1, None, 2.0)], uncertainty=u)
    >>> comp.update({"time_s": 0.0, "T1_C": 1.0})
    2.0
    >>> round(comp.status.half_width, 3)
    3.678
    """

    offset_var: float
    growth_var_per_h: float
    noise_var: float
    memory_var: float
    memory_h: float
    bias_var_per_h: float = 0.0
    rate_var_per_h3: float = 0.0
    scale: float = 1.0
    glr_scale: float = 1.0


#: No uncertainty: what the filter's arithmetic assumes without one.
_CERTAIN = Uncertainty(0.0, 0.0, 0.0, 0.0, math.inf, 0.0, 0.0, 1.0, 1.0)


@dataclass(frozen=True)
class RowOrder:
    """Where ``time_s`` and each input stand in an array row of ``size`` values."""

    take: np.ndarray
    size: int


@dataclass(frozen=True)
class EnvelopeStage:
    """The ``envelope`` parameter checked, as an update runs it.

    Attributes
    ----------
    take : ndarray of int
        Each enveloped input's position in a row ``(time_s, *inputs)``.
    low, high, max_rate_per_h : ndarray
        Its range and largest rate of change per hour (see
        :class:`~greyml.dynamic.InputEnvelope`).
    names : tuple of str
        The enveloped inputs, in order.
    by_input : ndarray of shape (n_enveloped, n_terms)
        Each term's weight in the row of its input (0 elsewhere): times the
        excess bank's lags, the model's response to each input's excess.
    """

    take: np.ndarray
    low: np.ndarray
    high: np.ndarray
    max_rate_per_h: np.ndarray
    names: tuple
    by_input: np.ndarray


@dataclass(frozen=True)
class UpdatePlan:
    """What an update runs: the parameters checked, as arrays over terms.

    Built from ``inputs`` and ``terms`` (never taken from a file) by
    :meth:`Compensator.update_plan`; the exports write the same plan.

    Attributes
    ----------
    index : ndarray of int
        Each term's position in a row ``(time_s, *inputs)``: the lags first,
        then the inputs without lag (taken as lags with ``a = 0``).
    idle : ndarray of bool
        The lags that start at 0 (``idle_inputs``).
    max_step : float
        The longest step between rows the lags bridge, in seconds.
    row : RowOrder or None
        The order of an array row (``row_columns``), or None.
    span : tuple of int
        The slice of terms raised to a power other than 1.
    fractional : ndarray of int
        The terms whose power is not a whole number.
    power, tau, weight : ndarray
        Each powered term's power; each lag's time constant (s); each term's weight.
    labels : list of str
        Each lag's name, as ``get_state`` gives it.
    names : list of str
        The inputs, in order.
    shape : tuple
        The shape of a row ``(time_s, *inputs)``.
    check_all : bool
        Some input feeds no term: every value of a row is checked.
    limits : OutputLimits
        The output stage's clamp, quantum and rate limit, checked.
    limited : bool
        Any of the three is set.
    uncertainty : Uncertainty or None
        Checked.
    envelope : EnvelopeStage or None
        The input envelope, checked, with the positions it reads.
    """

    index: np.ndarray
    idle: np.ndarray
    max_step: float
    row: RowOrder | None
    span: tuple
    fractional: np.ndarray
    power: np.ndarray
    tau: np.ndarray
    weight: np.ndarray
    labels: list
    names: list
    shape: tuple
    check_all: bool
    limits: OutputLimits = field(default_factory=OutputLimits)
    limited: bool = False
    uncertainty: Uncertainty | None = field(default=None)
    envelope: EnvelopeStage | None = field(default=None)


def ordered_sum(values):
    """The sum of ``values`` along the last axis, left to right (one addition after the
    other, as the C and Structured Text exports add them).

    A sum of terms of mixed signs depends on its order by rounding (numpy's pairwise
    sum and BLAS's dot product each choose their own); this one is the order every
    export writes, so that they give Python's number to the last bit where their
    products are the same.
    """
    values = np.asarray(values, dtype=float)
    if values.shape[-1] == 0:
        return np.zeros(values.shape[:-1]) if values.ndim > 1 else 0.0
    out = np.add.accumulate(values, axis=-1)[..., -1]
    return out if values.ndim > 1 else float(out)


def real(value):
    """A finite real number (not a bool)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


_real = real


def _numbers_only(values, names):
    """Refuse, in one line, a value of a row that is not a real number.

    A bool, bytes, text, a date or a duration would otherwise become a
    number (``True`` is 1, ``b"21"`` is 21, a datetime64 is its count of
    seconds since 1970) and move the axis by it. ``names`` (or the keys) say
    which entries to check.
    """
    for key in names if names is not None else values:
        value = values[key]
        if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (numbers.Real, np.integer, np.floating)
        ):
            kind = type(value).__name__
            where = f"position {key}" if names is None else repr(key)
            raise ValueError(
                f"{_PREFIX} the row's {where} is {value!r} (a {kind}), not a real number."
            )


def bad_time(time, previous):
    """Refuse a time that is not finite or not later than the previous row's, in one line."""
    if not math.isfinite(time):
        raise ValueError(f"{_PREFIX} time_s is {time!r}; it must be a finite number.")
    what = "repeats" if time == previous else "goes back"
    raise ValueError(
        f"{_PREFIX} time_s {what} from {previous:g} to {time:g} s; rows must come in "
        "increasing time (or give nominal_step_s= to read a restarting clock as the "
        "next test of the same recording)."
    )


def output_from_vars(saved):
    """The output stage's state (as ``get_state`` gives it) from a compensator's saved
    attributes, or None when it has none (nothing is trusted: ``set_state`` checks it)."""
    if not all(k in saved for k in ("_output", "_credit", "_held")):
        return None
    return {"output_um": saved["_output"], "credit_um": saved["_credit"], "held": saved["_held"]}


def _glr_dict(bank):
    """The likelihood test's bank as a saved state holds it (checked by ``set_state``)."""
    try:
        D, A, B, T0, n = bank
        return {"response": D, "sum_rho_nu": A, "sum_rho2": B, "start_h": T0, "open": n}
    except (TypeError, ValueError):
        raise ValueError("Compensator: the saved probe filter is not valid.") from None


def _found_dict(found):
    try:
        kind, start, innovation = found
        return {"kind": kind, "start_s": start, "innovation": innovation}
    except (TypeError, ValueError):
        raise ValueError("Compensator: the saved probe filter is not valid.") from None


def _positive_semidefinite(P):
    """A covariance: its eigenvalues ≥ 0, up to rounding."""
    sym = 0.5 * (P + P.T)
    return bool((np.linalg.eigvalsh(sym) >= -1e-9 * max(1.0, float(np.abs(sym).max()))).all())


def _number(value):
    """A float or an int (NaN allowed), not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def envelope_from_vars(saved):
    """The envelope follower's state (as ``get_state`` gives it) from a compensator's saved
    attributes, or None when it has none (nothing is trusted: ``set_state`` checks it)."""
    keys = ("_follow", "_beyond", "_elags", "_estart")
    if not all(k in saved for k in keys):
        return None
    follower, beyond, elags, estart = (saved[k] for k in keys)
    return {"follower": follower, "excess": beyond, "excess_lags": elags, "excess_start": estart}


def filter_from_vars(saved):
    """The filter's state (as ``get_state`` gives it) from a compensator's saved
    attributes, or None when it has none (a file from before probe readings).

    Nothing is trusted: the values are checked by ``set_state`` afterwards.
    """
    keys = ("_fx", "_fP", "_ft0", "_adjusted", "_glr", "_changes", "_last_reading", "_found")
    if not all(k in saved for k in (*keys, "_model", "_corr", "_ht", "_hm", "_hn")):
        return None
    try:
        n = int(saved["_hn"])
        ht = np.asarray(saved["_ht"], dtype=float)
        hm = np.asarray(saved["_hm"], dtype=float)
        if not (0 <= n and ht.shape == hm.shape == (HISTORY,)):
            raise ValueError
        t, m = ht[: min(n, HISTORY)], hm[: min(n, HISTORY)]
        order = np.argsort(t, kind="stable")
    except (TypeError, ValueError, OverflowError):
        raise ValueError("Compensator: the saved probe filter is not valid.") from None
    return {
        "x": saved["_fx"],
        "P": saved["_fP"],
        "t0": saved["_ft0"],
        "adjusted": saved["_adjusted"],
        "glr": _glr_dict(saved["_glr"]),
        "changes": saved["_changes"],
        "found": _found_dict(saved["_found"]),
        "last_reading": saved["_last_reading"],
        "model": saved["_model"],
        "correction": saved["_corr"],
        "history_time_s": t[order].tolist(),
        "history_model": m[order].tolist(),
    }


def build_plan(name, inputs, terms, idle_inputs, max_step_s, row_columns):
    """Check the terms and inputs one by one (after the constraints); return the plan
    of an update: arrays over terms, in the order the update runs them.

    ``name`` is the owner's, for the messages."""
    inputs = [str(v) for v in inputs]
    if len(set(inputs)) != len(inputs) or TIME_LEVEL in inputs:
        bad = TIME_LEVEL if TIME_LEVEL in inputs else next(v for v in inputs if inputs.count(v) > 1)
        raise ValueError(
            f"The 'inputs' parameter of {name} names {bad!r} "
            + ("more than once." if bad != TIME_LEVEL else "; time_s is read apart.")
        )
    if isinstance(terms, (str, Mapping)) or not hasattr(terms, "__iter__"):
        raise ValueError(
            f"The 'terms' parameter of {name} must be a list of "
            f"(input_name, power, tau_s, weight). Got {terms!r} instead."
        )
    too_many = f"{name} holds more than the {MAX_TERMS:,} terms or inputs a compensator may hold."
    if len(inputs) > MAX_TERMS:
        raise ValueError(too_many)
    position = {v: j for j, v in enumerate(inputs)}
    raw, lagged = {}, {}
    for k, term in enumerate(terms):
        if k >= MAX_TERMS:
            raise ValueError(too_many)
        try:
            column, power, tau, weight = term
        except (TypeError, ValueError):
            raise ValueError(
                f"Term {k} of {name} must be (input_name, power, tau_s, weight); got {term!r}."
            ) from None
        if str(column) not in position:
            raise ValueError(
                f"Term {k} of {name} names the input {column!r}, which is not in "
                f"inputs ({', '.join(inputs)})."
            )
        if not (_real(power) and power > 0):
            raise ValueError(
                f"Term {k} of {name} ({column!r}) has power {power!r}; it must be a "
                "finite number > 0."
            )
        if tau is not None and not (_real(tau) and tau > 0):
            raise ValueError(
                f"Term {k} of {name} ({column!r}) has the time constant {tau!r}; it "
                "must be a finite number of seconds > 0, or None for no lag."
            )
        if not _real(weight):
            raise ValueError(
                f"Term {k} of {name} ({column!r}) has weight {weight!r}; it must be a "
                "finite number."
            )
        key = (position[str(column)], float(power))
        if tau is None:
            raw[key] = raw.get(key, 0.0) + float(weight)
        else:
            key = (*key, float(tau))
            lagged[key] = lagged.get(key, 0.0) + float(weight)
    used = {k[0] for k in raw} | {k[0] for k in lagged}
    # one vector for every term: the lags first, then the inputs without lag,
    # taken as lags with a = 0 (s = 1·x + 0·s is x, exactly); the terms with
    # a power other than 1 in the middle, so one slice holds them all
    lag_keys = sorted(lagged, key=lambda k: k[1] != 1.0)
    raw_keys = sorted(raw, key=lambda k: k[1] == 1.0)
    keys = lag_keys + raw_keys
    powered = [i for i, k in enumerate(keys) if k[1] != 1.0]
    start, stop = (powered[0], powered[-1] + 1) if powered else (0, 0)
    idle = _names_in(name, idle_inputs, "idle_inputs", inputs)
    taus = [k[2] for k in lag_keys]
    max_step = max_step_s
    if max_step is None:
        max_step = max(taus) if taus else math.inf
    return UpdatePlan(
        # positions in a row ("time_s", *inputs)
        index=np.array([k[0] + 1 for k in keys], dtype=np.intp),
        # only lags start idle: an input without lag is the input itself
        idle=np.array([inputs[k[0]] in idle for k in lag_keys], dtype=bool),
        max_step=float(max_step),
        row=_row_positions(name, row_columns, inputs),
        span=(start, stop),
        # terms whose power is not a whole number: a negative input has no real power
        fractional=np.array(
            [i for i in range(start, stop) if keys[i][1] != round(keys[i][1])], dtype=np.intp
        ),
        power=np.array([k[1] for k in keys[start:stop]], dtype=float),
        tau=np.array([k[2] for k in lag_keys], dtype=float),
        weight=np.array([lagged[k] for k in lag_keys] + [raw[k] for k in raw_keys]),
        labels=[f"{_power_name(inputs[k[0]], k[1])}|lag {_tau_label(k[2])}" for k in lag_keys],
        names=inputs,
        shape=(len(inputs) + 1,),
        check_all=len(used) < len(inputs),
    )


def _names_in(name, names, what, inputs):
    if isinstance(names, str):
        names = [names]
    names = [str(v) for v in names]
    for v in names:
        if v not in inputs:
            raise ValueError(
                f"The {what!r} parameter of {name} names {v!r}, which is "
                f"not in inputs ({', '.join(inputs)})."
            )
    return set(names)


def _row_positions(name, row_columns, inputs):
    """Positions of ``time_s`` and each input in an array row, or None (no order declared)."""
    if row_columns is None:
        return None
    columns = [str(v) for v in row_columns]
    if len(set(columns)) != len(columns):
        twice = next(v for v in columns if columns.count(v) > 1)
        raise ValueError(f"The 'row_columns' parameter of {name} names {twice!r} more than once.")
    missing = [v for v in (TIME_LEVEL, *inputs) if v not in columns]
    if missing:
        raise ValueError(
            f"The 'row_columns' parameter of {name} lacks "
            f"{', '.join(map(repr, missing))}; an array row must hold time_s and every input."
        )
    return RowOrder(
        take=np.array([columns.index(v) for v in (TIME_LEVEL, *inputs)], dtype=np.intp),
        size=len(columns),
    )


class Compensator:
    """A thermal-error correction computed sample by sample, as a controller runs it.

    The correction is a sum of terms, each the input ``x**power`` lagged
    with a time constant ``tau_s`` (or taken as it is) and multiplied by a
    weight::

        correction = intercept + Σ weight · lag_tau(x**power)

    with the first-order lag of :class:`greyml.LagFeatures`,
    s_k = a_k s_{k−1} + (1 − a_k) x_k, a_k = exp(−Δt_k/τ), Δt_k from the
    rows' ``time_s``. Each :meth:`update` costs a few small array operations
    over the terms, whatever the length of the recording. Build one by hand,
    from a fitted :class:`greyml.ThermalTransferFunction` with
    :meth:`from_model`, or from a fitted ``Pipeline(LagFeatures,
    [StandardScaler], linear model)`` with :meth:`from_pipeline`: streaming a
    test row by row then gives the model's ``predict`` on that test.

    Read more in the :ref:`User Guide <ug-compensator>`.

    Parameters
    ----------
    inputs : list of str
        Names of the inputs, in the order of an array row after ``time_s``.
    terms : list of tuple
        ``(input_name, power, tau_s, weight)``: ``input_name`` one of
        ``inputs``; ``power`` a finite number > 0; ``tau_s`` the time
        constant in seconds (finite, > 0), or ``None`` for the input itself
        without lag; ``weight`` a finite number. Terms with the same input,
        power and time constant share one lag.
    intercept : float, default=0.0
    relative_to_start : bool, default=False
        Subtract the sum of the terms at the first sample (after
        construction or :meth:`reset`), so the correction is ``intercept``
        plus the predicted change since the start.
    nominal_step_s : float, optional
        What to do with a row whose ``time_s`` is not later than the
        previous row's. ``None``: refuse it (time went back). A step in
        seconds: the row starts the next piece of the same recording, whose
        clock starts anew (``LagFeatures(state="carry")``), and the lags
        step into it by this much.
    idle_inputs : list of str, default=()
        Inputs whose lags start at 0 at the first row (a driver whose heat
        source was off before), instead of at that row's value; as
        :class:`greyml.ThermalTransferFunction` starts its drivers in a test
        without history.
    max_step_s : float, optional
        The longest step between rows that the lags bridge; a longer one is
        refused with the message batch ``predict`` gives for it (call
        :meth:`reset` to start anew after a pause). By default the largest
        time constant of the terms.
    row_columns : list of str, optional
        The order of the values of an array row: ``"time_s"`` and every input,
        in any order (other names are skipped). Without it an array row is
        refused, since nothing could tell a wrong order; a mapping or a
        Series is always read by name.
    envelope : InputEnvelope, optional
        What training saw of the inputs (each one's range and fastest change;
        :meth:`from_model` takes the model's ``input_envelope_``). Where a
        row leaves it, :attr:`status` names the inputs outside (``outside``)
        and widens ``half_width`` by the model's own response to each input's
        excess (summed in absolute value), as
        :meth:`greyml.ThermalTransferFunction.predict_interval` does. Its
        inputs must be among ``inputs``.
    uncertainty, interval_quantile, tolerance_um, max_correction_um, probe_noise_um
        How far to trust the correction and how probe readings correct it
        (with ``false_alarm_rate``, the change detector's): see
        :attr:`status` and :meth:`observe` (a
        :meth:`from_model` sets them from a fitted model's
        calibration).
    rate_limit_um_s : float, optional
        The output moves by at most this many µm per second of the rows'
        clock (the step the lags take); it starts at 0 and ramps (see Notes).
    quantum_um : float, optional
        The output is a whole number of this many µm (the controller's unit,
        e.g. 0.1), the correction rounded to the nearest (halves away from
        zero); with a rate limit it moves a whole number of quanta at a time.
    clamp_um : float, optional
        The output is at most this far from 0 (with a quantum, a whole number
        of quanta).
    on_missing : {"hold", "raise"}, default="hold"
        A row whose input is NaN or infinite (a sensor missing): ``"hold"``
        gives the last output again, leaves the state as it was and says so
        in :attr:`status` (``held``); ``"raise"`` refuses it with one line.
        A time that is not a finite number is always refused.

    Attributes
    ----------
    state_ : dict
        The running state, as :meth:`get_state` returns it.

    See Also
    --------
    greyml.LagFeatures : the same lags, computed for whole tests.
    greyml.ThermalTransferFunction : a model :meth:`from_model` runs.

    Notes
    -----
    The first update after construction or :meth:`reset` starts every lag at
    rest at that row's values (``state="restart"``); later updates step by
    the time since the previous row. A step that is longer than a time
    constant is bridged as if the input had been held (``LagFeatures``
    refuses steps longer than its largest time constant inside a test).

    :meth:`update` returns the output a controller writes to the axis: the
    correction (with probe readings, if any) clamped, quantised and rate
    limited, in that order (:func:`greyml.controller._output.limit_output`); with
    none of the three it is the correction. The output starts at 0 (nothing
    written to the axis yet) and :meth:`reset` keeps it: with a rate limit
    the first row after either holds it, and the output ramps from there
    instead of jumping. :meth:`export` writes the same computation as C,
    IEC 61131-3 Structured Text or JSON.

    The state (:meth:`get_state`, :meth:`set_state`) is plain numbers, and
    :func:`greyml.persist.save_model` saves a compensator with its state, so
    a controller can stop and resume exactly where it was.

    Examples
    --------
    A 10 µm/°C expansion that follows a sensor through a 15 min lag:

    >>> from greyml.controller import Compensator
    >>> comp = Compensator(["T1_C"], [("T1_C", 1, 900.0, 10.0)],
    ...                    relative_to_start=True)
    >>> comp.update({"time_s": 0.0, "T1_C": 20.0})
    0.0
    >>> round(comp.update({"time_s": 900.0, "T1_C": 21.0}), 6)  # 1 - exp(-1) of 10 µm
    6.321206
    >>> comp.state_["lags"]
    {'T1_C|lag 15 min': 20.632120558828558}
    """

    #: Caches rebuilt on use (``persist`` never saves them): the update plan, made
    #: from the parameters, and the positions of time_s and the inputs in the
    #: last pandas index a row came with.
    _derived_attributes = ("_plan", "_series_positions")

    _parameter_constraints: dict = {
        "inputs": [list, tuple, np.ndarray],
        "terms": ["array-like"],
        "intercept": [Interval(Real, None, None, closed="neither")],
        "relative_to_start": ["boolean"],
        "nominal_step_s": [Interval(Real, 0, None, closed="neither"), None],
        "idle_inputs": [list, tuple, np.ndarray],
        "max_step_s": [Interval(Real, 0, None, closed="neither"), None],
        "row_columns": [list, tuple, np.ndarray, None],
        "uncertainty": [Uncertainty, None],
        "envelope": [InputEnvelope, None],
        "interval_quantile": [Interval(Real, 0, None, closed="neither")],
        "tolerance_um": [Interval(Real, 0, None, closed="neither"), None],
        "max_correction_um": [Interval(Real, 0, math.inf, closed="right")],
        "probe_noise_um": [Interval(Real, 0, None, closed="left")],
        "false_alarm_rate": [Interval(Real, 0, 1, closed="neither")],
        "rate_limit_um_s": [Interval(Real, 0, None, closed="neither"), None],
        "quantum_um": [Interval(Real, 0, None, closed="neither"), None],
        "clamp_um": [Interval(Real, 0, None, closed="neither"), None],
        "on_missing": [StrOptions({"hold", "raise"})],
    }

    def __init__(
        self,
        inputs,
        terms,
        intercept=0.0,
        *,
        relative_to_start=False,
        nominal_step_s=None,
        idle_inputs=(),
        max_step_s=None,
        row_columns=None,
        uncertainty=None,
        envelope=None,
        interval_quantile=1.6448536269514722,
        tolerance_um=None,
        max_correction_um=1000.0,
        probe_noise_um=0.0,
        false_alarm_rate=1e-3,
        rate_limit_um_s=None,
        quantum_um=None,
        clamp_um=None,
        on_missing="hold",
    ):
        self.inputs = inputs
        self.terms = terms
        self.intercept = intercept
        self.relative_to_start = relative_to_start
        self.nominal_step_s = nominal_step_s
        self.idle_inputs = idle_inputs
        self.max_step_s = max_step_s
        self.row_columns = row_columns
        self.uncertainty = uncertainty
        self.envelope = envelope
        self.interval_quantile = interval_quantile
        self.tolerance_um = tolerance_um
        self.max_correction_um = max_correction_um
        self.probe_noise_um = probe_noise_um
        self.false_alarm_rate = false_alarm_rate
        self.rate_limit_um_s = rate_limit_um_s
        self.quantum_um = quantum_um
        self.clamp_um = clamp_um
        self.on_missing = on_missing

    # -- parameters and the plan -------------------------------------------

    def _check_params(self):
        """Check the parameters; return the plan of an update (see :func:`build_plan`)."""
        self._validate_params()
        plan = build_plan(
            type(self).__name__,
            self.inputs,
            self.terms,
            self.idle_inputs,
            self.max_step_s,
            self.row_columns,
        )
        uncertainty = self._uncertainty()
        limits = self._checked_limits()
        return replace(
            plan,
            limits=limits,
            limited=limits.any,
            uncertainty=uncertainty,
            envelope=self._envelope_stage(plan),
        )

    def update_plan(self):
        """The parameters checked, as the :class:`UpdatePlan` an update runs.

        Returns
        -------
        plan : UpdatePlan
        """
        return self._check_params()

    def _build(self):
        plan = self._check_params()
        self._plan = plan
        self._forget_positions()
        self._reset_output()
        self.reset()
        return plan

    # -- parameters, as every greyml object gives them ----------------------

    def get_params(self, deep=True):
        """The parameters given to the constructor, by name.

        Parameters
        ----------
        deep : bool, default=True
            Ignored (a compensator holds no other object).

        Returns
        -------
        params : dict
        """
        return {name: getattr(self, name) for name in _PARAMETERS}

    def set_params(self, **params):
        """Set parameters by name; the state is reset.

        Parameters
        ----------
        **params : dict

        Returns
        -------
        self : Compensator
        """
        for name in params:
            if name not in _PARAMETERS:
                raise ValueError(
                    f"Invalid parameter {name!r} for Compensator; its parameters are "
                    f"{', '.join(_PARAMETERS)}."
                )
        for name, value in params.items():
            setattr(self, name, value)
        self.__dict__.pop("_plan", None)
        self._build()
        return self

    def _validate_params(self):
        """The constraints of ``_parameter_constraints``, with scikit-learn's messages."""
        validate_parameter_constraints(
            self._parameter_constraints, self.get_params(), caller_name=type(self).__name__
        )

    def __repr__(self):
        terms = self.terms if isinstance(self.terms, (list, tuple)) else list(self.terms)
        return f"Compensator(inputs={list(self.inputs)!r}, {len(terms)} terms)"

    # -- state --------------------------------------------------------------

    def reset(self, initial_displacement=None):
        """Forget the state: the next update starts a test without history.

        Its lags start at rest at that row's values (at 0 for
        ``idle_inputs``), as batch ``predict`` starts a test without the rows
        before it. The output is kept (it is what the axis has): with a rate
        limit the next row holds it and the output ramps from there.

        Parameters
        ----------
        initial_displacement : float, optional
            The displacement measured at the next row: the correction there is
            made to equal it, and every later one moves with it (as
            ``predict(X, initial_displacement=...)``).

        Returns
        -------
        self : Compensator
        """
        if initial_displacement is not None and not _real(initial_displacement):
            raise ValueError(
                "Compensator.reset: initial_displacement must be a finite number; got "
                f"{initial_displacement!r}."
            )
        if "_plan" not in self.__dict__:
            self._build()  # checks the parameters first, so the next update keeps this reset
        self._time = None
        self._lags = None
        self._start = None
        self._dt = None
        self._a = None
        self._initial = None if initial_displacement is None else float(initial_displacement)
        self._credit = 0.0
        self._held = False
        self._reset_envelope()
        self._reset_trust()
        return self

    def _coefficients(self, dt, plan):
        """``a`` of every term for a step ``dt`` (cached while dt repeats)."""
        n_lags = plan.tau.size
        a = np.zeros(plan.weight.size)
        a[:n_lags] = np.exp(-dt / plan.tau)
        self._a, self._dt = a, dt

    def get_state(self):
        """The running state, as plain numbers.

        Returns
        -------
        state : dict
            ``"time_s"`` of the last row (``None`` before the first update),
            ``"lags"`` a dict from each lag's name (e.g.
            ``"T4_C|lag 15 min"``) to its value, and ``"start"`` what is
            subtracted from the sum of the terms: their sum at the first row
            with ``relative_to_start=True``, moved by an initial displacement
            given to :meth:`reset` (``None`` when nothing is subtracted), and
            ``"filter"`` the probe filter's state (its offset, bias and rate,
            their covariance, the change detector's bank, and the rows remembered
            for late readings), and ``"output"`` the output stage's:
            ``"output_um"`` the last output, ``"credit_um"`` what the rate
            limit still allows (with a quantum), ``"held"`` whether the last
            row was held for a missing input; and ``"envelope"`` (None
            without an ``envelope``): each enveloped input's follower, its
            excess at the last row, the excess bank's lags, each input's
            response (the bank's weighted sum over its terms) at the first
            row when subtracted (``"excess_start"``) and at the last row
            (``"excess_sum"``, read only).
        """
        plan = self._plan_or_build()
        lags = None
        if self._lags is not None:
            lags = {label: float(v) for label, v in zip(plan.labels, self._lags)}  # lags first
        return {
            "time_s": self._time,
            "lags": lags,
            "start": self._start,
            "filter": self._filter_state(),
            "output": self._output_state(),
            "envelope": self._envelope_state(),
        }

    @property
    def state_(self):
        """The running state (see :meth:`get_state`)."""
        return self.get_state()

    def set_state(self, state):
        """Resume from a state :meth:`get_state` returned.

        Parameters
        ----------
        state : dict

        Returns
        -------
        self : Compensator
        """
        plan = self._plan_or_build()
        if not isinstance(state, Mapping) or set(state) - {"filter", "output", "envelope"} != {
            "time_s",
            "lags",
            "start",
        }:
            raise ValueError(
                "Compensator.set_state needs a dict with the keys 'time_s', 'lags', "
                "'start', 'filter' and 'output', as get_state returns it."
            )
        before = dict(self.__dict__)
        if state["time_s"] is None:
            self.reset()
            self._set_output(state, plan, before)
            return self
        lags = state["lags"]
        labels = plan.labels
        if not isinstance(lags, Mapping) or set(lags) != set(labels):
            raise ValueError(
                "Compensator.set_state: the state's lags are not this compensator's "
                f"({', '.join(labels) or 'none'})."
            )
        values = np.zeros(plan.weight.size)
        values[: len(labels)] = [lags[label] for label in labels]
        start = state["start"]
        if (
            not _real(state["time_s"])
            or not np.isfinite(values).all()
            or (self.relative_to_start and not _real(start))
            or not (start is None or _real(start))
        ):
            raise ValueError("Compensator.set_state: the state holds a value that is not finite.")
        self.reset()
        self._time = float(state["time_s"])
        self._lags = values
        self._start = None if start is None else float(start)
        self._set_output(state, plan, before)
        return self

    def _set_output(self, state, plan, before):
        """The probe filter and the output stage from ``state`` (checked), if given;
        on a refusal, the attributes ``before``, as after any refused input."""
        try:
            if state.get("filter") is not None:
                self._set_filter_state(state["filter"])
            if state.get("output") is not None:
                self._set_output_state(state["output"], plan.limits)
            self._set_envelope_state(state.get("envelope"), plan)
        except ValueError:
            self.__dict__.clear()
            self.__dict__.update(before)
            raise

    def _check_fitted_state(self):
        """Rebuild the update plan from the terms, and check the running state.

        Run on a compensator read from a file (:func:`greyml.persist.load_model`):
        the plan an update runs is always made anew from ``inputs`` and
        ``terms`` (never taken from the file, which could make it read the
        wrong sensor or cost any memory), cached coefficients are dropped, and
        the saved state must pass :meth:`set_state`'s checks against the
        terms: a NaN start or a lag of the wrong length is refused with one
        line.
        """
        saved = dict(vars(self))
        time, lags, start = saved.get("_time"), saved.get("_lags"), saved.get("_start")
        for key in ("_plan", "_dt", "_a", "_b"):
            self.__dict__.pop(key, None)
        plan = self._build()  # checks the parameters, the number of terms, and resets
        if time is None:
            self.set_state(
                {"time_s": None, "lags": None, "start": None, "output": output_from_vars(saved)}
            )
            return
        labels = plan.labels
        try:
            values = np.asarray(lags, dtype=float)
        except (TypeError, ValueError):
            values = None
        if values is None or values.shape != plan.weight.shape:
            raise ValueError(
                "Compensator: the saved state's lags do not match its terms "
                f"({len(labels)} lags and {plan.weight.size - len(labels)} inputs without lag)."
            )
        self.set_state(
            {
                "time_s": time,
                "lags": dict(zip(labels, values[: len(labels)].tolist())),
                "start": start,
                "filter": filter_from_vars(saved),
                "output": output_from_vars(saved),
                "envelope": envelope_from_vars(saved),
            }
        )

    def _plan_or_build(self):
        try:
            return self._plan
        except AttributeError:
            return self._build()

    # -- one sample ---------------------------------------------------------

    def update(self, row):
        """Take one row and return the output for the axis.

        The checks run in this order, in every export too: an input taken
        to a fractional power must not be negative; ``time_s`` must be finite
        and later than the previous row's (or start the next piece, with
        ``nominal_step_s``), by at most ``max_step_s``; every input must be
        finite (else, with ``on_missing="hold"``, the last output again: on
        the first row, the output the axis has, and the next row is the
        first); the sum of the terms must be finite; the correction, probe
        filter included, must be finite and within ``max_correction_um``.
        Every check runs before anything is kept: a refused or held row
        changes no state (``time_s`` included), and what this returns is
        always finite and within ``max_correction_um`` (plus half a quantum
        where rounded).

        Parameters
        ----------
        row : dict, pandas Series or 1-D array
            A mapping (or Series) holding ``"time_s"`` and every input, or an
            array ordered as ``row_columns``.

        Returns
        -------
        output : float
            The correction, clamped, quantised and rate limited as the
            parameters say (the correction itself with none of them).

        Raises
        ------
        ValueError
            With one line naming the time (and the input), for a refused row.
        """
        with np.errstate(over="ignore", invalid="ignore"):  # every overflow is checked
            return self._update_row(row)

    def _update_row(self, row):
        try:
            plan = self._plan
        except AttributeError:
            plan = self._build()
        order = plan.row
        if (
            order is not None
            and type(row) is np.ndarray
            and row.dtype == np.float64
            and row.shape == (order.size,)
        ):
            row = row[order.take]  # the fast path of a controller
        else:
            row = self._read_row(row, plan)
        time = float(row[0])
        v = row[plan.index]
        if plan.power.size:
            if plan.fractional.size and (v[plan.fractional] < 0).any():
                return self._bad_value(time, row, plan)
            start, stop = plan.span
            v[start:stop] **= plan.power
        previous = self._time
        shift = 0.0
        dt = None
        if previous is not None:
            dt = time - previous
            if not dt > 0:
                if self.nominal_step_s is None or not math.isfinite(time):
                    bad_time(time, previous)
                dt = self.nominal_step_s
                shift = previous + dt - time
            elif dt > plan.max_step:
                if not math.isfinite(time):
                    bad_time(time, previous)
                raise ValueError(
                    gap_message(_PREFIX[:-1], "the stream", dt, time, plan.max_step)
                    + " Call reset() to start anew after a pause."
                )
        if not np.isfinite(row).all():  # every input, before any state changes
            return self._bad_value(time, row, plan)
        followed = excess = None
        if plan.envelope is not None:
            followed, excess = self._excess_terms(row, v, dt, plan)
        if previous is None:
            lags = v
            lags[: plan.idle.size][plan.idle] = 0.0
        else:
            if dt != self._dt:
                self._coefficients(dt, plan)
            lags = lag_step(self._lags, v, self._a)
        total = ordered_sum(plan.weight * lags)
        if not math.isfinite(total):
            return self._bad_value(time, row, plan)
        # the correction this row would give, computed before anything is kept
        start = self._first_start(total) if previous is None else self._start
        if start is not None:
            total -= start
        model = self.intercept + total
        value = model
        if self._adjusted:
            value = self._corrected(model, time, self._ft0 - shift)
        self._refuse_implausible(time, value)
        if previous is None:
            self._start = start
        if followed is not None:
            self._step_excess(row, followed, excess, previous is None, plan)
        self._time = time
        self._lags = lags
        if shift:
            self._shift_clock(shift)
        value = self._record(time, model, value)
        self._held = False
        if not plan.limited:
            self._output = self._last = value
            return value
        self._output, self._last, self._credit = limit_output(
            value, dt, self._last, self._credit, plan.limits
        )
        return self._output

    def _refuse_implausible(self, time, value):
        """Refuse, in one line, a row whose correction is not finite or beyond
        ``max_correction_um`` (nothing has been kept of it yet)."""
        if not math.isfinite(value):
            raise ValueError(
                f"{_PREFIX} the correction overflows at time_s = {time:g} s (the probe "
                "filter's states or a power of an input too large); the row is refused."
            )
        if abs(value) > self.max_correction_um:
            raise ValueError(
                f"{_PREFIX} the correction {value:g} um at time_s = {time:g} s is beyond "
                f"+-{self.max_correction_um:g} um (max_correction_um), not a thermal "
                "displacement; the row is refused (reset to start anew)."
            )

    def _first_start(self, total):
        """What is subtracted from the sum of the terms from the first row on."""
        if self._initial is not None:
            return self.intercept + total - self._initial
        return total if self.relative_to_start else None

    # -- to a controller -----------------------------------------------------

    def export(
        self, language, path, *, name="greyml_compensator", description=None, overwrite=False
    ):
        """Write this compensator as C, IEC 61131-3 Structured Text or JSON.

        Every export computes what :meth:`update` does (the lags, the
        reference, the order of checks, the clamp, quantum, rate limit and
        hold-last-value policy) and, with an ``uncertainty``, what
        :meth:`observe` and :attr:`status` do; each starts with a comment
        naming the model, the inputs in order with their units, the
        reference, the time step it assumes and the greyml version. Names
        from the model reach the code only as identifiers made of letters,
        digits and single underscores (``x_`` and the name's letters), and in
        comments as a short run of harmless characters. Read more in
        :ref:`export`.

        Parameters
        ----------
        language : {"c", "st", "json"}
            ``"c"``: one self-contained C99 file (a state struct,
            ``<name>_init``, ``<name>_reset``, ``<name>_update`` and, with an
            ``uncertainty``, ``<name>_observe``, ``<name>_recalibrate``,
            ``<name>_half_width`` and ``<name>_trusted``); ``"st"``: a
            Structured Text ``FUNCTION_BLOCK`` (TwinCAT 3 / CODESYS);
            ``"json"``: the coefficients, limits, state layout and units, with
            its own schema and version.
        path : str or path-like
            The file to write (written beside it and renamed: a failure
            leaves none).
        name : str, default="greyml_compensator"
            The function and function block name: a letter, then letters,
            digits and single underscores, at most 31 characters.
        description : str, optional
            The model, in words, for the header (only harmless characters are
            kept).
        overwrite : bool, default=False
            Replace ``path`` if it exists.

        Returns
        -------
        path : pathlib.Path

        Examples
        --------
        >>> import os, tempfile
        >>> from greyml.controller import Compensator
        >>> comp = Compensator(["T1_C"], [("T1_C", 1, 900.0, 10.0)], quantum_um=0.1)
        >>> with tempfile.TemporaryDirectory() as d:
        ...     text = comp.export("c", os.path.join(d, "z.c"), name="axis_z").read_text()
        >>> "int axis_z_update(axis_z_state *s, double time_s" in text
        True
        """
        from greyml.controller._export._write import export_compensator

        return export_compensator(
            self, language, path, name=name, description=description, overwrite=overwrite
        )

    # -- from a fitted pipeline ---------------------------------------------

    @classmethod
    def from_model(
        cls,
        model,
        *,
        nominal_step_s=None,
        row_columns=None,
        coverage=0.9,
        tolerance_um=None,
        probe_noise_um=0.0,
        max_correction_um=1000.0,
        false_alarm_rate=1e-3,
        rate_limit_um_s=None,
        quantum_um=None,
        clamp_um=None,
        on_missing="hold",
    ):
        """The compensator that runs a fitted :class:`greyml.ThermalTransferFunction`.

        Streaming a test from its first row (after construction or
        :meth:`reset`) equals the model's ``predict`` on that test alone, and
        streaming the tests of one recording one after another equals
        ``predict`` on all of them, in the model's reference ``reference_``
        (to 1e-9). A fitted ``Pipeline(LagFeatures, [StandardScaler], linear
        model)`` is taken too (see :meth:`from_pipeline`).

        Parameters
        ----------
        model : ThermalTransferFunction or Pipeline
            Fitted.
        nominal_step_s : float, optional
            For a recording whose clock restarts in every piece: the step into
            a row whose ``time_s`` is not later than the previous row's (the
            next piece). By default such a row is refused, unless the model
            carried state across restarting clocks in ``fit``
            (``state="carry"``), which steps by its ``nominal_step_s_``.
        row_columns : list of str, optional
            The order of the values in an array row (``"time_s"`` and every
            input, in any order); without it only mappings and Series are
            taken.
        coverage : float, default=0.9
            Of the interval :attr:`status` reports (as the model's
            ``predict_interval``); with probe readings it narrows at each
            reading (:meth:`observe`). Without a calibration (fewer than 3
            tests in ``fit``) the compensator gives no interval.
        tolerance_um : float, optional
            A correction is trusted while its interval's half-width is at
            most this (and the correction plausible).
        probe_noise_um : float, default=0.0
            The standard deviation of a probe reading.
        max_correction_um, false_alarm_rate, rate_limit_um_s, quantum_um, clamp_um, on_missing
            The plausibility bound, the change detector's threshold and the
            output stage (clamp, quantum, rate limit, what a missing input
            does), as the class takes them; they can also be changed later
            with :meth:`set_params`.

        Returns
        -------
        compensator : Compensator
        """
        if hasattr(model, "steps"):
            params = pipeline_terms(model)
            params.update(tolerance_um=tolerance_um, probe_noise_um=probe_noise_um)
        else:
            params = transfer_terms(
                model, coverage=coverage, tolerance_um=tolerance_um, probe_noise_um=probe_noise_um
            )
        if nominal_step_s is not None:
            params["nominal_step_s"] = nominal_step_s
        calibration = params.pop("calibration", None)
        if calibration is not None:
            params["uncertainty"] = Uncertainty(
                offset_var=calibration.anchor_var - calibration.noise_var,
                growth_var_per_h=calibration.growth_var_per_h,
                noise_var=calibration.noise_var,
                memory_var=calibration.memory_var,
                memory_h=calibration.memory_h,
                bias_var_per_h=calibration.bias_var_per_h,
                rate_var_per_h3=calibration.rate_var_per_h3,
                scale=calibration.filter_scale,
                glr_scale=calibration.glr_scale,
            )
        return cls(
            **params,
            row_columns=row_columns,
            max_correction_um=max_correction_um,
            false_alarm_rate=false_alarm_rate,
            rate_limit_um_s=rate_limit_um_s,
            quantum_um=quantum_um,
            clamp_um=clamp_um,
            on_missing=on_missing,
        )

    @classmethod
    def from_pipeline(cls, pipeline, *, row_columns=None):
        """The compensator of a fitted ``Pipeline(LagFeatures, [StandardScaler], linear model)``.

        The scaler and the model's coefficients are folded into the terms'
        weights and the intercept, so that streaming a test row by row gives
        ``pipeline.predict`` on that test (to rounding). With
        ``LagFeatures(state="carry")``, ``nominal_step_s`` is the lags'
        ``nominal_step_s_``, so streaming the tests of a recording one after
        the other gives ``predict`` on all of them.

        Parameters
        ----------
        pipeline : Pipeline
            Fitted; its steps a :class:`greyml.LagFeatures`, optionally a
            :class:`~sklearn.preprocessing.StandardScaler`, and a linear
            regressor with ``coef_`` and ``intercept_`` (``Ridge``,
            ``RidgeCV``, ``ElasticNet``, ``LinearRegression``, …) with one
            target. ``"passthrough"`` steps are skipped.
        row_columns : list of str, optional
            The order of the values of an array row (see the class).

        Returns
        -------
        Compensator
        """
        return cls(**pipeline_terms(pipeline), row_columns=row_columns)

    # -- rows ---------------------------------------------------------------

    def _forget_positions(self):
        """Drop the Series positions remembered for this compensator (its inputs may
        have changed)."""
        self.__dict__.pop("_series_positions", None)

    def _read_row(self, row, plan):
        """The row as an array ``(time_s, *inputs)`` from a mapping, a Series or an array."""
        names = plan.names
        if isinstance(row, pd.Series):
            index = row.index
            seen, positions = self.__dict__.get("_series_positions", (None, None))
            if row.dtype.kind not in "fiu":
                if index.has_duplicates:
                    twice = index[index.duplicated()][0]
                    raise ValueError(f"{_PREFIX} the row names {twice!r} more than once.")
                _numbers_only(row.to_dict(), [v for v in (TIME_LEVEL, *names) if v in index])
            if index is not seen:
                if index.has_duplicates:
                    twice = index[index.duplicated()][0]
                    raise ValueError(f"{_PREFIX} the row names {twice!r} more than once.")
                positions = index.get_indexer([TIME_LEVEL, *names])
                if (positions < 0).any():
                    missing = [TIME_LEVEL, *names][int(np.flatnonzero(positions < 0)[0])]
                    raise ValueError(f"{_PREFIX} the row has no {missing!r}.")
                self._series_positions = (index, positions)
            try:
                return row.to_numpy(dtype=float)[positions]
            except (TypeError, ValueError):
                raise ValueError(f"{_PREFIX} the row holds a value that is not a number.") from None
        if isinstance(row, Mapping):
            try:
                values = [row[TIME_LEVEL], *(row[v] for v in names)]
            except KeyError as exc:
                raise ValueError(f"{_PREFIX} the row has no {exc.args[0]!r}.") from None
            _numbers_only(dict(zip([TIME_LEVEL, *names], values)), [TIME_LEVEL, *names])
            try:
                return np.asarray(values, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"{_PREFIX} the row holds a value that is not a number.") from None
        order = plan.row
        if order is None:
            raise ValueError(
                f"{_PREFIX} an array row has no names, so a wrong order cannot be told; pass "
                "a mapping or a Series by name, or declare the order of array rows with "
                f"row_columns= (e.g. {[TIME_LEVEL, *names][:4]})."
            )
        given = np.asarray(row)
        if given.dtype.kind not in "fiu":
            _numbers_only(dict(enumerate(given.reshape(-1).tolist())), None)
        try:
            values = np.asarray(row, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{_PREFIX} the row holds a value that is not a number.") from None
        if values.shape != (order.size,):
            raise ValueError(
                f"{_PREFIX} an array row must hold the {order.size} values of row_columns; "
                f"got shape {values.shape}."
            )
        return values[order.take]

    def _bad_value(self, time, row, plan):
        """Refuse the row in one line, or hold the last output for a missing input."""
        if not math.isfinite(time):
            bad_time(time, self._time)
        bad = np.flatnonzero(~np.isfinite(row[1:]))
        if bad.size:
            if self.on_missing == "hold":
                return self._hold()
            j = int(bad[0])
            raise ValueError(
                f"{_PREFIX} input {plan.names[j]!r} is {float(row[j + 1])!r} at "
                f"time_s = {time:g} s."
            )
        start, stop = plan.span
        for k, power in zip(range(start, stop), plan.power):
            j = int(plan.index[k]) - 1
            if power != round(power) and row[j + 1] < 0:
                raise ValueError(
                    f"{_PREFIX} input {plan.names[j]!r} is negative ({float(row[j + 1])!r}) "
                    f"at time_s = {time:g} s, and a term takes it to the power {power:g}, which "
                    "is not a real number."
                )
        raise ValueError(
            f"{_PREFIX} the correction overflows at time_s = {time:g} s (a power of an "
            "input too large); scale the inputs."
        )

    # -- the output stage: clamp, quantum, rate limit, hold ------------------

    def _checked_limits(self):
        """The output stage's :class:`OutputLimits`, checked."""
        return OutputLimits.checked(self.clamp_um, self.quantum_um, self.rate_limit_um_s)

    def _reset_output(self):
        """Nothing written to the axis yet: the output is 0."""
        self._last = 0.0
        self._output = 0.0
        self._credit = 0.0
        self._held = False

    def _output_state(self):
        return {"output_um": self._output, "credit_um": self._credit, "held": self._held}

    def _set_output_state(self, state, limits):
        """Restore :meth:`_output_state`'s dict, every value checked against the
        ``limits`` (:meth:`_checked_limits`)."""
        clamp, quantum = limits.clamp_um, limits.quantum_um
        bad = ValueError("Compensator.set_state: the state's output is not valid.")
        try:
            output, credit, held = state["output_um"], state["credit_um"], state["held"]
        except (KeyError, TypeError):
            raise bad from None
        if not (real(output) and real(credit) and credit >= 0 and isinstance(held, bool)):
            raise bad
        output, last = float(output), float(output)
        if clamp is not None and abs(output) > clamp * (1 + 1e-12):
            raise ValueError(
                f"Compensator.set_state: the state's output {output:g} µm is beyond the "
                f"clamp ±{clamp:g} µm."
            )
        if quantum is not None:
            last = output / quantum
            if abs(last) > QUANTA_MAX or abs(last - round(last)) > 1e-6:
                raise ValueError(
                    f"Compensator.set_state: the state's output {output:g} µm is not a whole "
                    f"number of quanta ({quantum:g} µm)."
                )
            last = float(round(last))
            output = last * quantum
        self._last, self._output, self._credit, self._held = last, output, float(credit), held

    def _hold(self):
        """The last output again, for a row with a missing input (the state is unchanged)."""
        self._held = True
        return self._output

    # -- inputs outside the training envelope ---------------------------------

    def _envelope_stage(self, plan):
        """``envelope`` checked (finite, ``low <= high``, rates >= 0, its inputs among
        the plan's inputs) as an :class:`EnvelopeStage`, or None."""
        env = self.envelope
        if env is None:
            return None
        names = plan.names
        env = env.check("The 'envelope' parameter of Compensator")
        missing = [v for v in env.names if v not in names]
        if missing:
            raise ValueError(
                f"The 'envelope' parameter of Compensator names {missing[0]!r}, which is not "
                f"in inputs ({', '.join(names)})."
            )
        take = np.array([names.index(v) + 1 for v in env.names], dtype=np.intp)
        # each term's weight in the response to its input's excess (a row per input)
        by_input = np.zeros((len(env.names), plan.weight.size))
        for slot, position in enumerate(take):
            terms = plan.index == position
            by_input[slot, terms] = plan.weight[terms]
        return EnvelopeStage(take, env.low, env.high, env.max_rate_per_h, env.names, by_input)

    def _reset_envelope(self):
        self._follow = None  # the follower of each enveloped input
        self._beyond = None  # the inputs minus their follower at the last row (None: 0)
        self._outside_now = ()  # Status.outside of the last row
        self._elags = None  # the excess bank's lags (None: never outside)
        self._estart = None  # each input's response at the first row, when subtracted
        self._widening = 0.0  # Σ|Δ_i|, the responses to the excess at the last row
        self._edt = None  # the step the follower's reach was computed for
        self._reach = None

    def _excess_terms(self, row, v, dt, plan):
        """``(followed, excess)``: the follower of the enveloped inputs at this row, and
        each term's value minus its value on the follower (None when no input is outside)."""
        env = plan.envelope
        x = row[env.take]
        if dt is None or self._follow is None:
            followed = follow_step(None, x, None, env.low, env.high)
        else:
            if dt != self._edt:
                self._reach, self._edt = reach_of(env.max_rate_per_h, dt), dt
            followed = follow_step(self._follow, x, self._reach, env.low, env.high)
        if followed.tobytes() == x.tobytes():  # inside (the cheapest exact test)
            return followed, None
        inside = row.copy()
        inside[env.take] = followed
        w = inside[plan.index]
        if plan.power.size:
            start, stop = plan.span
            w[start:stop] **= plan.power
        return followed, v - w

    def _step_excess(self, row, followed, excess, first, plan):
        """The excess bank: the same lags (:func:`lag_step`) on the terms' excess; its
        weighted sum over each input's terms is Δ_i, the model's response to the part of
        input i beyond the envelope, and the widening is Σ_i |Δ_i|."""
        elags = self._elags
        if first:
            elags = excess
            if elags is not None:
                elags[: plan.idle.size][plan.idle] = 0.0
        elif elags is not None:
            elags = lag_step(elags, 0.0 if excess is None else excess, self._a)
        elif excess is not None:
            elags = lag_step(np.zeros(plan.weight.size), excess, self._a)
        self._follow, self._elags = followed, elags
        if excess is None:
            self._beyond, self._outside_now = None, ()
        else:
            self._set_beyond(row[plan.envelope.take] - followed, plan)
        if elags is None:
            if first:
                zero = np.zeros(plan.envelope.take.size)
                self._estart = zero if self._start is not None else None
            self._widening = 0.0
            return
        delta = ordered_sum(plan.envelope.by_input * elags)
        if first:
            self._estart = delta.copy() if self._start is not None else None
        if self._estart is not None:
            delta -= self._estart
        self._widening = ordered_sum(np.abs(delta))

    def _set_beyond(self, beyond, plan):
        """The inputs minus their follower, and :attr:`Status.outside` from them."""
        names = plan.envelope.names
        self._beyond = beyond
        self._outside_now = tuple((names[j], float(beyond[j])) for j in beyond.nonzero()[0])

    def _restart_excess(self):
        """The reference starts anew (:meth:`start_test`): so does the excess bank's."""
        if self._plan.envelope is None:
            return
        self._estart = self._responses() if self._start is not None else None
        self._widening = self._widening_of(self._responses(), self._estart)

    def _responses(self):
        """Each enveloped input's response (the excess bank's weighted sum), before any
        start is subtracted."""
        env = self._plan.envelope
        if self._elags is None:
            return np.zeros(env.take.size)
        return ordered_sum(env.by_input * self._elags)

    @staticmethod
    def _widening_of(responses, start):
        return ordered_sum(np.abs(responses if start is None else responses - start))

    def _outside(self):
        """:attr:`Status.outside`: (input, excess) of the inputs outside at the last row."""
        return self._outside_now

    def _envelope_state(self):
        if self._plan_or_build().envelope is None:
            return None
        return {
            "follower": None if self._follow is None else self._follow.tolist(),
            "excess": None if self._beyond is None else self._beyond.tolist(),
            "excess_lags": None if self._elags is None else self._elags.tolist(),
            "excess_start": None if self._estart is None else self._estart.tolist(),
            # each input's response at the last row (read only): what excess_start
            # becomes where the reference starts anew (as start_test does)
            "excess_sum": self._responses().tolist(),
        }

    def _set_envelope_state(self, state, plan):
        """Restore :meth:`_envelope_state`'s dict (checked); the widening at the last row
        is recomputed from it."""
        env = plan.envelope
        if env is None or state is None:
            return
        bad = ValueError("Compensator.set_state: the state's envelope follower is not valid.")
        try:
            follower, beyond = state["follower"], state["excess"]
            elags, estart = state["excess_lags"], state["excess_start"]
            follower = None if follower is None else np.asarray(follower, dtype=float)
            beyond = None if beyond is None else np.asarray(beyond, dtype=float)
            elags = None if elags is None else np.asarray(elags, dtype=float)
            estart = None if estart is None else np.asarray(estart, dtype=float)
        except (KeyError, TypeError, ValueError):
            raise bad from None
        if (
            (follower is not None and (follower.shape != env.low.shape))
            or (beyond is not None and (beyond.shape != env.low.shape))
            or not all(a is None or np.isfinite(a).all() for a in (follower, beyond))
            or (elags is not None and elags.shape != plan.weight.shape)
            or not all(a is None or np.isfinite(a).all() for a in (follower, elags))
            or not (estart is None or (estart.shape == env.low.shape and np.isfinite(estart).all()))
            or (follower is not None and ((follower < env.low) | (follower > env.high)).any())
        ):
            raise bad
        self._follow, self._elags, self._estart = follower, elags, estart
        self._widening = self._widening_of(self._responses(), estart)
        self._beyond, self._outside_now = None, ()
        if beyond is not None:
            self._set_beyond(beyond, plan)

    # -- trust: intervals, probe readings, recalibration ---------------------

    # -- parameters -----------------------------------------------------------

    def _uncertainty(self):
        """``uncertainty`` checked (an :class:`Uncertainty` in its domain), or None."""
        u = self.uncertainty
        if u is None:
            return None
        values = []
        if isinstance(u, Uncertainty):
            values = [getattr(u, f, math.nan) for f in Uncertainty.__dataclass_fields__]
            values = [v if real(v) else math.nan for v in values]
        if (
            len(values) != 9
            or not all(map(math.isfinite, values))
            or min(values) < 0
            or values[4] <= 0
            or values[7] <= 0
            or values[8] < 1
        ):
            raise ValueError(
                "The 'uncertainty' parameter of Compensator must be an Uncertainty of nine "
                "finite numbers (offset_var, growth_var_per_h, noise_var, memory_var >= 0, "
                "memory_h > 0, bias_var_per_h, rate_var_per_h3 >= 0, scale > 0 and "
                f"glr_scale >= 1); got {u!r}."
            )
        return Uncertainty(*(float(v) for v in values))

    # -- state ----------------------------------------------------------------

    def _reset_trust(self):
        u = self._plan_or_build().uncertainty
        offset_var = u.offset_var * u.scale if u else 0.0
        self._fx = np.zeros(3)  # offset, bias, bias rate per hour: at _ft0
        self._fP = np.diag([offset_var, 0.0, 0.0])
        self._ft0 = None
        self._adjusted = False
        self._glr = glr_reset()
        self._found = (None, math.nan, math.nan)  # the last change: kind, start, innovation
        self._changes = 0
        self._last_reading = None
        self._corr = None
        self._model = None
        self._ht = np.full(HISTORY, -np.inf)
        self._hm = np.zeros(HISTORY)
        self._hn = 0

    def start_test(self, row, initial_displacement=None):
        """Take the first row of a test that continues the state: its lags carry on,
        and the reference starts anew there.

        For a recording whose tests follow each other on one clock: the
        correction at ``row`` is 0 with ``relative_to_start=True`` (or the
        ``initial_displacement`` given), as batch ``predict`` measures each
        test from its first row, while the lags keep the history that
        :meth:`reset` would forget. Probe readings of the previous test no
        longer apply (the displacement is known again here).

        Parameters
        ----------
        row : dict, pandas Series or 1-D array
            As for :meth:`update`.
        initial_displacement : float, optional
            The displacement measured at ``row``.

        Returns
        -------
        correction : float
        """
        if initial_displacement is not None and not real(initial_displacement):
            raise ValueError(
                "Compensator.start_test: initial_displacement must be a finite number; got "
                f"{initial_displacement!r}."
            )
        previous = self._time
        before = (self._last, self._credit)  # the output stage before this row
        self.update(row)
        if self._held:
            return self._output  # a missing input: nothing moved, not even the reference
        total = ordered_sum(self._plan.weight * self._lags)
        self._initial = None if initial_displacement is None else float(initial_displacement)
        self._start = self._first_start(total)
        self._restart_excess()
        model = self.intercept + total - (self._start or 0.0)
        if self._start is not None:  # the displacement is known here: the filter starts anew
            self._anchor_trust(self._time, model)
        else:
            self._corr = self._corrected(model, self._time) if self._adjusted else model
        plan = self._plan
        if not plan.limited:
            self._output = self._last = self._corr
            return self._corr
        dt = None if previous is None else self._time - previous
        if dt is not None and not dt > 0:
            dt = self.nominal_step_s
        self._output, self._last, self._credit = limit_output(
            self._corr, dt, before[0], before[1], plan.limits
        )
        return self._output

    def _anchor_trust(self, time, model):
        """The displacement is known at ``time`` (a new test's first row): the filter
        starts anew there; the rows remembered stay, the last one given ``model``."""
        history = (self._ht.copy(), self._hm.copy(), self._hn)
        self._reset_trust()
        self._ht, self._hm, self._hn = history
        self._hm[(self._hn - 1) % HISTORY] = model
        self._ft0, self._model, self._corr = time, model, model

    def _record(self, time, model, corrected):
        """Remember the model's correction ``model`` at ``time``; return the correction
        given (``corrected``, with the probe filter's states, computed before)."""
        if self._ft0 is None:
            self._ft0 = time
        i = self._hn % HISTORY
        self._ht[i] = time
        self._hm[i] = model
        self._hn += 1
        self._model = model
        self._corr = corrected = float(corrected)
        return corrected

    def _corrected(self, model, time, ft0=None):
        """The model's correction with the filter's states carried to ``time`` (from the
        filter's time, or from ``ft0``)."""
        offset, bias, rate = (float(v) for v in self._fx)  # floats: an overflow is inf
        dh = (time - (self._ft0 if ft0 is None else ft0)) / 3600.0
        u = self._plan_or_build().uncertainty or _CERTAIN
        phi = math.exp(-dh / u.memory_h) if math.isfinite(u.memory_h) else 1.0
        return model + offset * phi + bias + rate * dh

    def _transition(self, dh):
        u = self._plan_or_build().uncertainty or _CERTAIN
        return transition(
            dh, u.memory_h, u.memory_var, u.bias_var_per_h, u.rate_var_per_h3, u.scale
        )

    def _propagated(self, time):
        """The filter's states and covariance carried from its time to ``time``."""
        dh = max(0.0, (time - self._ft0) / 3600.0)
        F, Q = self._transition(dh)
        return matmul(F, self._fx), matmul(matmul(F, self._fP), F.T) + Q, dh

    def _variance_at(self, time, model):
        """Variance of the error of the correction given at ``time`` (model part ``model``)."""
        u = self._plan_or_build().uncertainty
        if not self._adjusted:  # the batch calibration, from the first row
            dh = max(0.0, (time - self._ft0) / 3600.0)
            return u.offset_var + u.growth_var_per_h * dh + u.noise_var
        # H (F P Fᵀ + Q) Hᵀ with H F = (φ, 1, dh), in scalars (read at every row)
        dh = max(0.0, (time - self._ft0) / 3600.0)
        phi = math.exp(-dh / u.memory_h) if math.isfinite(u.memory_h) else 1.0
        # Python floats: an overflow is inf (no warning), as in C
        (p00, p01, p02), (_, p11, p12), (_, _, p22) = self._fP.tolist()
        hph = phi * phi * p00 + p11 + dh * dh * p22 + 2.0 * (phi * p01 + phi * dh * p02 + dh * p12)
        hqh = u.memory_var * (1.0 - phi * phi) + u.bias_var_per_h * dh
        hqh += u.rate_var_per_h3 * cube(dh) / 3.0
        var = hph + u.scale * hqh
        if var != var:  # inf - inf: nothing is known
            var = math.inf
        return max(var, 0.0) + u.scale * u.noise_var

    @property
    def status(self):
        """:class:`Status` of the last update: correction, half-width, trust."""
        u = self._plan_or_build().uncertainty
        kind, start, innovation = self._found
        corr, half, trusted, plausible, outside = None, math.nan, False, False, ()
        if self._time is not None and self._corr is not None:
            corr = self._corr
            plausible = abs(corr) <= self.max_correction_um
            if u is not None:
                half = self.interval_quantile * math.sqrt(
                    self._variance_at(self._time, self._model)
                )
            half += self._widening
            trusted = plausible and (
                self.tolerance_um is None or (math.isfinite(half) and half <= self.tolerance_um)
            )
            outside = self._outside()
        return Status(
            self._time,
            corr,
            half,
            bool(trusted),
            bool(plausible),
            self._changes,
            self._output,
            self._held,
            innovation,
            kind,
            start,
            outside,
        )

    # -- readings -------------------------------------------------------------

    def _history(self):
        """The rows remembered, in time order: (time_s, model correction)."""
        n = min(self._hn, HISTORY)
        t, m = self._ht[:n], self._hm[:n]
        if self._hn > HISTORY:
            order = np.argsort(t, kind="stable")
            t, m = t[order], m[order]
        return t, m

    def _model_at(self, time_s):
        """The model's correction at ``time_s`` from the rows remembered (linear between)."""
        t, m = self._history()
        if t.size == 0:
            raise ValueError(
                f"{_OBSERVE} no row is remembered since the state was set, so the reading at "
                f"time_s = {time_s:g} s cannot be placed; update with its row first."
            )
        if time_s < t[0]:
            raise ValueError(
                f"{_OBSERVE} the reading at time_s = {time_s:g} s is older than the "
                f"{t.size} rows remembered (from {t[0]:g} s); it cannot be placed."
            )
        return float(np.interp(time_s, t, m))

    def _shift_clock(self, shift):
        """The rows' clock restarted (a new piece): move the filter's times with it."""
        if self._ft0 is not None:
            self._ft0 -= shift
        if self._last_reading is not None:
            self._last_reading -= shift
        self._ht = self._ht - shift
        # the likelihood test's open onsets and the last change found are times too
        D, A, B, T0, n = self._glr
        T0 = T0.copy()
        T0[:n] -= shift / 3600.0
        self._glr = (D, A, B, T0, n)
        kind, start, innovation = self._found
        self._found = (kind, start - shift, innovation)

    def observe(self, time_s, measured_um):
        """Correct the compensator with a displacement measured at ``time_s``.

        The reading moves the filter's offset, bias and rate, which every
        later correction carries, and feeds the change detector (a step or a
        ramp found is added to them; :attr:`status` says which, and when it
        began); the interval narrows at the reading and widens again with the
        time since.
        A reading may arrive late (up to 512 rows back), never from the
        future of the last update, nor before the previous reading.

        Parameters
        ----------
        time_s : float
            When the displacement was measured, on the rows' clock.
        measured_um : float
            The measured displacement, in the compensator's reference.

        Returns
        -------
        status : Status
            After the reading (at the last update's row).

        Raises
        ------
        ValueError
            With one line naming the time and the value, for a reading that is
            not a finite number, beyond ``max_correction_um``, after the last
            update, before the previous reading, or older than the rows
            remembered, or that would make the filter's states, their
            covariance or the change detector's sums overflow. The state is
            unchanged then.
        """
        self._plan_or_build()
        for what, value in (("time_s", time_s), ("measured_um", measured_um)):
            if not real(value):
                raise ValueError(
                    f"{_OBSERVE} {what} is {value!r} (reading at time_s = {time_s!r}); it must "
                    "be a finite number."
                )
        time_s, z = float(time_s), float(measured_um)
        if self._time is None:
            raise ValueError(
                f"{_OBSERVE} the reading {z:g} at time_s = {time_s:g} s comes before the first "
                "update; update with the row of that time first."
            )
        if self._plan_or_build().uncertainty is None:
            raise ValueError(
                f"{_OBSERVE} the reading {z:g} at time_s = {time_s:g} s cannot be weighed: this "
                "compensator has no uncertainty (its model was fitted on fewer than 3 tests, "
                "or give uncertainty=)."
            )
        if abs(z) > self.max_correction_um:
            raise ValueError(
                f"{_OBSERVE} the reading {z:g} at time_s = {time_s:g} s is beyond "
                f"±{self.max_correction_um:g} (max_correction_um); not a thermal displacement."
            )
        if time_s > self._time:
            raise ValueError(
                f"{_OBSERVE} the reading {z:g} at time_s = {time_s:g} s is after the last "
                f"update ({self._time:g} s); update with that row first."
            )
        if self._last_reading is not None and time_s <= self._last_reading:
            raise ValueError(
                f"{_OBSERVE} the reading {z:g} at time_s = {time_s:g} s is not after the "
                f"previous reading ({self._last_reading:g} s); readings must come in order."
            )
        m = self._model_at(time_s)
        u = self._plan_or_build().uncertainty or _CERTAIN
        previous = self._ft0
        x, P, dh = self._propagated(time_s)
        if not self._adjusted:
            # the first reading: the batch variance there, all in the offset (the
            # bias and its rate walk from here on, uncertain only where recalibrate
            # opened them)
            x = np.zeros(3)
            P = self._fP.copy()
            P[0, 0] = u.scale * (u.offset_var + u.growth_var_per_h * dh)
        F, _ = self._transition(dh)
        R = u.scale * u.noise_var + self.probe_noise_um * self.probe_noise_um
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            x, P, innovation, S, K = update(x, P, z - m, R)
            glr, (stat, kind, slot) = glr_advance(
                self._glr, F, K, innovation, S, time_s / 3600.0, previous / 3600.0
            )
            kind_name, start, changes = self._found[0], self._found[1], self._changes
            if stat > glr_threshold(self.false_alarm_rate) * u.glr_scale:
                dx, dP, size, start_h = glr_change(glr, kind, slot, time_s / 3600.0)
                # a few readings cannot tell a step from a ramp: the bias and the rate
                # are opened by the size found (its effect here, and that per hour since
                # it began), so that the next readings settle which
                span = max(time_s / 3600.0 - start_h, 1e-9)
                # products, not powers: an overflow is inf (refused below), as in C
                effect2 = (size * span) * (size * span) if kind else size * size
                x, P = x + dx, P + dP + np.diag([0.0, effect2, effect2 / (span * span)])
                kind_name, start = KINDS[kind], start_h * 3600.0
                changes += 1
                glr = glr_reset()
            P = 0.5 * (P + P.T)
            standardised = innovation / math.sqrt(S)
            # the last update's correction, with the filter's new state
            dh_last = (self._time - time_s) / 3600.0
            phi = math.exp(-dh_last / u.memory_h) if math.isfinite(u.memory_h) else 1.0
            offset, bias, rate = (float(v) for v in x)
            corrected = self._model + offset * phi + bias + rate * dh_last
        if not (
            np.isfinite(x).all()
            and np.isfinite(P).all()
            and all(np.isfinite(a).all() for a in glr[:4])
            and math.isfinite(standardised)
            and math.isfinite(corrected)
        ):
            raise ValueError(
                f"{_OBSERVE} the reading {z:g} at time_s = {time_s:g} s overflows the probe "
                "filter (its covariance or the change detector's sums are not finite); it "
                "is refused and the filter is as before."
            )
        self._fx, self._fP, self._ft0, self._glr = x, P, time_s, glr
        self._adjusted = True
        self._last_reading = time_s
        self._found = (kind_name, start, standardised)
        self._changes = changes
        self._corr = corrected
        return self.status

    def recalibrate(self, size_um=None):
        """Let the next readings estimate a step and a drift (the machine changed).

        The change detector does this itself for the change it estimated;
        call it after a change you know of (a crash, a new spindle, a
        season): the bias and its rate become uncertain, and the next
        readings estimate them (no refit from scratch).

        Parameters
        ----------
        size_um : float, optional
            How far off the model is thought to be: a step of that size, and a
            drift of that size per hour, become possible (by default the
            interval's standard deviation at the anchor). At most
            ``max_correction_um`` in absolute value.

        Returns
        -------
        self : Compensator

        Raises
        ------
        ValueError
            For a size that is not a finite number, is beyond
            ``max_correction_um``, or would make the filter's covariance
            overflow; the state is unchanged then.
        """
        self._plan_or_build()
        if size_um is None:
            u = self._plan_or_build().uncertainty or _CERTAIN
            size_um = math.sqrt(max(u.offset_var + u.noise_var, 0.0)) or 1.0
        elif not real(size_um) or abs(size_um) > self.max_correction_um:
            raise ValueError(
                f"Compensator.recalibrate: size_um is {size_um!r}; it must be a finite number "
                f"within +-{self.max_correction_um:g} um (max_correction_um)."
            )
        size2 = float(size_um) * float(size_um)
        P = self._fP + np.diag([0.0, size2, size2])
        if not np.isfinite(P).all():
            raise ValueError(
                f"Compensator.recalibrate: size_um {size_um!r} overflows the probe filter's "
                "covariance; the filter is as before."
            )
        self._fP = P
        self._changes += 1
        self._glr = glr_reset()
        return self

    # -- saved state ----------------------------------------------------------

    def _filter_state(self):
        t, m = self._history()
        D, A, B, T0, n = self._glr
        kind, start, innovation = self._found
        return {
            "x": self._fx.tolist(),
            "P": self._fP.tolist(),
            "t0": self._ft0,
            "adjusted": self._adjusted,
            "glr": {
                "response": D.tolist(),
                "sum_rho_nu": A.tolist(),
                "sum_rho2": B.tolist(),
                "start_h": T0.tolist(),
                "open": n,
            },
            "changes": self._changes,
            "found": {"kind": kind, "start_s": start, "innovation": innovation},
            "last_reading": self._last_reading,
            "model": self._model,
            "correction": self._corr,
            "history_time_s": t.tolist(),
            "history_model": m.tolist(),
        }

    def _set_filter_state(self, state):
        """Restore :meth:`_filter_state`'s dict, every value checked."""
        bad = ValueError("Compensator.set_state: the state's probe filter is not valid.")
        try:
            x = np.asarray(state["x"], dtype=float)
            P = np.asarray(state["P"], dtype=float)
            ht = np.asarray(state["history_time_s"], dtype=float)
            hm = np.asarray(state["history_model"], dtype=float)
            glr = state["glr"]
            D = np.asarray(glr["response"], dtype=float)
            A = np.asarray(glr["sum_rho_nu"], dtype=float)
            B = np.asarray(glr["sum_rho2"], dtype=float)
            T0 = np.asarray(glr["start_h"], dtype=float)
            n = glr["open"]
            found = state["found"]
            kind, start, innovation = found["kind"], found["start_s"], found["innovation"]
            changes = state["changes"]
            adjusted = state["adjusted"]
            scalars = [state["t0"], state["last_reading"], state["model"], state["correction"]]
        except (KeyError, TypeError, ValueError, OverflowError):
            raise bad from None
        if (
            x.shape != (3,)
            or P.shape != (3, 3)
            or not (np.isfinite(x).all() and np.isfinite(P).all())
            or not np.allclose(P, P.T)
            or not _positive_semidefinite(P)
            or ht.shape != hm.shape
            or ht.ndim != 1
            or ht.size > HISTORY
            or not (np.isfinite(ht).all() and np.isfinite(hm).all())
            or (np.diff(ht) < 0).any()
            or not (isinstance(changes, int) and not isinstance(changes, bool) and changes >= 0)
            or not isinstance(adjusted, bool)
            or D.shape != (2, WINDOW, 3)
            or A.shape != (2, WINDOW)
            or B.shape != (2, WINDOW)
            or T0.shape != (WINDOW,)
            or not all(np.isfinite(v).all() for v in (D, A, B, T0))
            or (B < 0).any()
            or not (isinstance(n, int) and not isinstance(n, bool) and 0 <= n <= WINDOW)
            or kind not in (None, *KINDS)
            or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in (start, innovation)
            )
            or not all(v is None or real(v) for v in scalars)
        ):
            raise bad
        self._fx, self._fP = x, P
        self._ft0, self._last_reading, self._model, self._corr = scalars
        self._adjusted = adjusted
        self._glr = (D, A, B, T0, n)
        self._found = (kind, float(start), float(innovation))
        self._changes = changes
        self._ht = np.full(HISTORY, -np.inf)
        self._hm = np.zeros(HISTORY)
        self._ht[: ht.size], self._hm[: hm.size] = ht, hm
        self._hn = ht.size
