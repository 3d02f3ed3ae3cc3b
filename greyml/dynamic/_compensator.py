"""Compensator: a linear model of thermal lags, run sample by sample."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from greyml._param_validation import (
    Interval,
    Real,
    StrOptions,
    validate_parameter_constraints,
)
from greyml.dynamic._compensator_limits import _Limits, output_from_vars
from greyml.dynamic._compensator_pipeline import pipeline_terms
from greyml.dynamic._compensator_plan import build_plan
from greyml.dynamic._compensator_plan import real as _real
from greyml.dynamic._compensator_rows import bad_time, bad_value, forget_positions, read_row
from greyml.dynamic._compensator_trust import _Trust, filter_from_vars
from greyml.dynamic._kernels import lag_step
from greyml.dynamic._output import limit_output
from greyml.dynamic._time import gap_message

__all__ = ["Compensator"]

_PREFIX = "Compensator.update:"

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
    "interval_quantile",
    "tolerance_um",
    "max_correction_um",
    "probe_noise_um",
    "change_threshold",
    "rate_limit_um_s",
    "quantum_um",
    "clamp_um",
    "on_missing",
)


class Compensator(_Limits, _Trust):
    """A thermal-error correction computed sample by sample, as a controller runs it.

    The correction is a sum of terms, each the input ``x**power`` lagged
    with a time constant ``tau_s`` (or taken as it is) and multiplied by a
    weight::

        correction = intercept + Σ weight · lag_tau(x**power)

    with the first-order lag of :class:`greyml.LagFeatures`,
    s_k = a_k s_{k−1} + (1 − a_k) x_k, a_k = exp(−Δt_k/τ), Δt_k from the
    rows' ``time_s``. Each :meth:`update` costs a few small array operations
    over the terms, whatever the length of the recording. Build one by hand,
    or from a fitted ``Pipeline(LagFeatures, [StandardScaler], linear model)``
    with :meth:`from_pipeline`: streaming a test row by row then gives the
    pipeline's ``predict`` on that test.

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
    uncertainty, interval_quantile, tolerance_um, max_correction_um, probe_noise_um
        How far to trust the correction and how probe readings correct it
        (with ``change_threshold``, the change detector's): see
        :attr:`status` and :meth:`observe` (a
        :meth:`greyml.ThermalTransferFunction.compensator` sets them from its
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
    greyml.ThermalTransferFunction : a model whose ``compensator()`` gives one.

    Notes
    -----
    The first update after construction or :meth:`reset` starts every lag at
    rest at that row's values (``state="restart"``); later updates step by
    the time since the previous row. A step that is longer than a time
    constant is bridged as if the input had been held (``LagFeatures``
    refuses steps longer than its largest time constant inside a test).

    :meth:`update` returns the output a controller writes to the axis: the
    correction (with probe readings, if any) clamped, quantised and rate
    limited, in that order (:func:`greyml.dynamic._output.limit_output`); with
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

    >>> from greyml.dynamic import Compensator
    >>> comp = Compensator(["T1_C"], [("T1_C", 1, 900.0, 10.0)],
    ...                    relative_to_start=True)
    >>> comp.update({"time_s": 0.0, "T1_C": 20.0})
    0.0
    >>> round(comp.update({"time_s": 900.0, "T1_C": 21.0}), 6)  # 1 - exp(-1) of 10 µm
    6.321206
    >>> comp.state_["lags"]
    {'T1_C|lag 15 min': 20.632120558828558}
    """

    _parameter_constraints: dict = {
        "inputs": [list, tuple, np.ndarray],
        "terms": ["array-like"],
        "intercept": [Interval(Real, None, None, closed="neither")],
        "relative_to_start": ["boolean"],
        "nominal_step_s": [Interval(Real, 0, None, closed="neither"), None],
        "idle_inputs": [list, tuple, np.ndarray],
        "max_step_s": [Interval(Real, 0, None, closed="neither"), None],
        "row_columns": [list, tuple, np.ndarray, None],
        "uncertainty": [list, tuple, np.ndarray, None],
        "interval_quantile": [Interval(Real, 0, None, closed="neither")],
        "tolerance_um": [Interval(Real, 0, None, closed="neither"), None],
        "max_correction_um": [Interval(Real, 0, math.inf, closed="right")],
        "probe_noise_um": [Interval(Real, 0, None, closed="left")],
        "change_threshold": [Interval(Real, 0, None, closed="neither")],
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
        interval_quantile=1.6448536269514722,
        tolerance_um=None,
        max_correction_um=1000.0,
        probe_noise_um=0.0,
        change_threshold=5.0,
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
        self.interval_quantile = interval_quantile
        self.tolerance_um = tolerance_um
        self.max_correction_um = max_correction_um
        self.probe_noise_um = probe_noise_um
        self.change_threshold = change_threshold
        self.rate_limit_um_s = rate_limit_um_s
        self.quantum_um = quantum_um
        self.clamp_um = clamp_um
        self.on_missing = on_missing

    # -- parameters and the plan -------------------------------------------

    def _check_params(self):
        """Check the parameters; return the plan of an update (see :func:`build_plan`)."""
        self._validate_params()
        plan = build_plan(self)
        self._uncertainty()
        plan["limits"] = self._checked_limits()
        plan["limited"] = any(v is not None for v in plan["limits"])
        return plan

    def _build(self):
        plan = self._check_params()
        self._plan = plan
        forget_positions(self)
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
        self._reset_trust()
        return self

    def _coefficients(self, dt, plan):
        """``a`` of every term for a step ``dt`` (cached while dt repeats)."""
        n_lags = plan["tau"].size
        a = np.zeros(plan["weight"].size)
        a[:n_lags] = np.exp(-dt / plan["tau"])
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
            ``"filter"`` the probe filter's state (its offset, rate and gain,
            their covariance, the change detector, and the rows remembered
            for late readings), and ``"output"`` the output stage's:
            ``"output_um"`` the last output, ``"credit_um"`` what the rate
            limit still allows (with a quantum), ``"held"`` whether the last
            row was held for a missing input.
        """
        plan = self._plan_or_build()
        lags = None
        if self._lags is not None:
            lags = {label: float(v) for label, v in zip(plan["labels"], self._lags)}  # lags first
        return {
            "time_s": self._time,
            "lags": lags,
            "start": self._start,
            "filter": self._filter_state(),
            "output": self._output_state(),
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
        if not isinstance(state, Mapping) or set(state) - {"filter", "output"} != {
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
        labels = plan["labels"]
        if not isinstance(lags, Mapping) or set(lags) != set(labels):
            raise ValueError(
                "Compensator.set_state: the state's lags are not this compensator's "
                f"({', '.join(labels) or 'none'})."
            )
        values = np.zeros(plan["weight"].size)
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
                self._set_output_state(state["output"], plan["limits"])
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
        labels = plan["labels"]
        try:
            values = np.asarray(lags, dtype=float)
        except (TypeError, ValueError):
            values = None
        if values is None or values.shape != plan["weight"].shape:
            raise ValueError(
                "Compensator: the saved state's lags do not match its terms "
                f"({len(labels)} lags and {plan['weight'].size - len(labels)} inputs without lag)."
            )
        self.set_state(
            {
                "time_s": time,
                "lags": dict(zip(labels, values[: len(labels)].tolist())),
                "start": start,
                "filter": filter_from_vars(saved),
                "output": output_from_vars(saved),
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
        finite (else, with ``on_missing="hold"``, the last output again); the
        correction must be finite. A refused or held row changes no state.

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
        """
        try:
            plan = self._plan
        except AttributeError:
            plan = self._build()
        order = plan["row"]
        if (
            order is not None
            and type(row) is np.ndarray
            and row.dtype == np.float64
            and row.shape == (order["size"],)
        ):
            row = row[order["take"]]  # the fast path of a controller
        else:
            row = read_row(self, row, plan)
        time = float(row[0])
        v = row[plan["index"]]
        if plan["power"].size:
            if plan["fractional"].size and (v[plan["fractional"]] < 0).any():
                return bad_value(self, time, row, plan)
            start, stop = plan["span"]
            v[start:stop] **= plan["power"]
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
            elif dt > plan["max_step"]:
                if not math.isfinite(time):
                    bad_time(time, previous)
                raise ValueError(
                    gap_message(_PREFIX[:-1], "the stream", dt, time, plan["max_step"])
                    + " Call reset() to start anew after a pause."
                )
        if plan["check_all"] and not np.isfinite(row).all():
            return bad_value(self, time, row, plan)
        if previous is None:
            lags = v
            lags[: plan["idle"].size][plan["idle"]] = 0.0
        else:
            if dt != self._dt:
                self._coefficients(dt, plan)
            lags = lag_step(self._lags, v, self._a)
        total = float(plan["weight"] @ lags)
        if not math.isfinite(total) or not math.isfinite(time):
            return bad_value(self, time, row, plan)
        if previous is None:
            self._start = self._first_start(total)
        self._time = time
        self._lags = lags
        if self._start is not None:
            total -= self._start
        if shift:
            self._shift_clock(shift)
        value = self._record(time, self.intercept + total)
        self._held = False
        if not plan["limited"]:
            self._output = self._last = value
            return value
        self._output, self._last, self._credit = limit_output(
            value, dt, self._last, self._credit, *plan["limits"]
        )
        return self._output

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
        >>> from greyml.dynamic import Compensator
        >>> comp = Compensator(["T1_C"], [("T1_C", 1, 900.0, 10.0)], quantum_um=0.1)
        >>> with tempfile.TemporaryDirectory() as d:
        ...     text = comp.export("c", os.path.join(d, "z.c"), name="axis_z").read_text()
        >>> "int axis_z_update(axis_z_state *s, double time_s" in text
        True
        """
        from greyml.dynamic._export import export_compensator

        return export_compensator(
            self, language, path, name=name, description=description, overwrite=overwrite
        )

    # -- from a fitted pipeline ---------------------------------------------

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
