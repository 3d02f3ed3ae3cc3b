"""LagFeatures: first-order thermal lags of temperatures and drivers as features."""

from __future__ import annotations

import numbers

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from greyml._param_validation import Integral, Interval, Real, StrOptions
from greyml._time import format_duration
from greyml._validation import first_flagged, shown_names, validate_sequences
from greyml.dynamic._kernels import lag_filter
from greyml.dynamic._time import MAX_TERMS, STATES, check_time_constants, timeline

__all__ = ["LagFeatures"]


def _tau_label(seconds):
    """A time constant in a feature name: exact enough that distinct ones differ."""
    return format_duration(seconds, digits=12)


def _power_name(name, power):
    return name if power == 1 else f"{name}^{power:.12g}"


def _is_real(value):
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _real_tuple(values):
    """``values`` as a tuple of floats, or None if it is not a sequence of reals."""
    if _is_real(values):
        values = (values,)
    try:
        items = tuple(values)
    except TypeError:
        return None
    if not items or not all(_is_real(v) for v in items):
        return None
    return tuple(float(v) for v in items)


class LagFeatures(TransformerMixin, BaseEstimator):
    r"""First-order thermal lags of chosen columns, for a bank of time constants.

    For each chosen column :math:`x` and each time constant :math:`\tau` (in
    seconds), the lag

    .. math::

        s_k = a_k\, s_{k-1} + (1 - a_k)\, x_k, \qquad
        a_k = e^{-\Delta t_k / \tau},

    with :math:`\Delta t_k` the step from the previous row, read from the
    ``time_s`` level of the row index (greyml's ``(test, time_s)`` layout, see
    :func:`greyml.make_test_index`). The lag is exact for an input held
    between samples, and right for uneven sampling. A displacement that
    follows its heat sources through a few time constants is close to linear
    in these features, so a linear model behind them is a dynamic thermal
    model; :class:`greyml.dynamic.Compensator` runs such a model sample by
    sample in a controller.

    Read more in the :ref:`User Guide <ug-lag-features>`.

    Parameters
    ----------
    time_constants : float or sequence of float
        Time constants τ in seconds, each finite and > 0, no two equal
        (e.g. ``[300, 900, 2700, 8100]`` for 5, 15, 45 and 135 min).
    columns : list of str or int, optional
        Columns to lag, by name (a DataFrame's columns, or ``"x0"``,
        ``"x1"``, … for an array) or position. ``None``: every column.
        Columns not chosen pass through unchanged, as with
        :class:`~sklearn.compose.ColumnTransformer`'s
        ``remainder="passthrough"``; select columns before this step to drop
        them.
    state : {"auto", "carry", "restart"}, default="auto"
        The lags' state at the start of each test. ``"auto"``: a test whose
        clock runs on from the previous test's last row (a recording cut into
        consecutive pieces, ``time_s`` not restarting) continues the state that
        test left, stepped by the time between them; a test on a clock of its
        own (``time_s`` starting anew), or after a gap longer than the largest
        time constant, starts at rest. ``"carry"``: every test continues the
        one before it, stepped by the time between them, or by the recording's
        nominal step (``nominal_step_s_``) where the clock restarts.
        ``"restart"``: every test starts at rest (every lag equals the input at
        the test's first row).
    powers : sequence of float, or dict, default=(1,)
        Powers of a column to lag (and to pass through with
        ``include_input``): the lag of x**p for each p. A sequence applies to
        every chosen column. A dict maps a column to its powers, e.g.
        ``{"spindle_rpm": (1, 2)}`` (friction heat in spindle bearings grows
        roughly with n^1.5-2); chosen columns it does not name get ``(1,)``.
        Powers must be finite and > 0; a power that is not a whole number
        needs the column to be ≥ 0.
    include_input : bool, default=True
        Pass the chosen columns (and their powers) through beside their lags.
    sample_interval : float, optional
        Seconds between rows when ``X`` has no ``time_s`` index level (a
        NumPy array, a DataFrame with a plain index): every step is this long.
        ``None`` (the default) refuses such ``X``, since the lags need the
        time. A ``time_s`` level, where present, always wins.

    Attributes
    ----------
    time_constants_ : ndarray of shape (n_time_constants,)
        The time constants in seconds, in the order given.
    columns_ : list of str
        The lagged columns, in the order of ``X``.
    powers_ : dict
        Each lagged column's powers, as a tuple of floats.
    nominal_step_s_ : float
        The median step between rows within the tests seen in ``fit`` (or
        ``sample_interval``): the step into a carried test whose clock restarts.
        NaN when no test seen in ``fit`` has two rows.
    terms_ : list of tuple
        ``(input, power, tau_s)`` of every output column, in order: the input
        raised to the power, lagged with ``tau_s`` seconds (None: not lagged).
        :meth:`greyml.Compensator.from_pipeline` reads it.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (``n_features_in_``,)
        Column names seen in ``fit`` (DataFrame input only).

    See Also
    --------
    greyml.Compensator : the lags and a linear model, sample by sample.
    greyml.ThermalTransferFunction : the lags, with the time constants and
        sensors chosen in ``fit``.

    Notes
    -----
    **Output.** First the columns without lag, in the order of ``X``: each
    column not chosen, and each chosen column's powers when
    ``include_input`` is true (``"T4_C"``, ``"spindle_rpm^2"``); then the
    lags, column by column, power by power, time constant by time constant
    (``"T4_C|lag 15 min"``, ``"spindle_rpm^2|lag 45 min"``); see
    :meth:`get_feature_names_out`. A DataFrame in gives a DataFrame out with
    the same index (the tests survive a Pipeline), also under
    ``set_output(transform="pandas")``. The lags are written straight into
    the output's memory (one Fortran-ordered array, which pandas takes
    without a copy).

    **Cross-validating with carried state.** The lags use no target, so they
    may be computed once over the whole recording, before the split: each
    held-out test then starts from the state the recording really was in::

        Z = LagFeatures([300, 900, 2700, 8100]).fit_transform(X)  # the recording
        cross_val_score(make_pipeline(StandardScaler(), RidgeCV()), Z, y,
                        groups=groups_of(Z), cv=LeaveOneGroupOut())

    Inside a Pipeline, with ``state="auto"``, a training fold carries state
    across the tests that follow each other on the recording's clock and
    restarts after the gap a held-out test leaves; the held-out test starts
    at rest.

    **Gaps.** A step longer than the largest time constant inside a test is
    refused: every lag would forget the test's history in it, and a logging
    gap that long usually means two recordings were joined.

    **scikit-learn's estimator checks.** With ``sample_interval`` the
    transformer passes :func:`~sklearn.utils.estimator_checks.check_estimator`
    except ``check_methods_subset_invariance`` and
    ``check_methods_sample_order_invariance``: a lag holds the rows before it,
    so a subset or a reordering of the rows changes every later row's output.
    Pass them as ``expected_failed_checks``.

    Examples
    --------
    The spindle starts at 3000 rpm; its lag with :math:`\tau` = 5 min covers
    :math:`1 - e^{-1}` of the way in each 5 min step:

    >>> import pandas as pd
    >>> from greyml import LagFeatures, make_test_index
    >>> index = make_test_index(["I"] * 4, [0, 300, 600, 900])
    >>> X = pd.DataFrame(
    ...     {"T1_C": [20.0, 21.0, 21.0, 21.0],
    ...      "spindle_rpm": [0.0, 3000.0, 3000.0, 3000.0]},
    ...     index=index,
    ... )
    >>> lags = LagFeatures([300, 3600], columns=["spindle_rpm"]).fit(X)
    >>> list(lags.get_feature_names_out())
    ['T1_C', 'spindle_rpm', 'spindle_rpm|lag 5 min', 'spindle_rpm|lag 1 h']
    >>> lags.transform(X)["spindle_rpm|lag 5 min"].round(1).tolist()
    [0.0, 1896.4, 2594.0, 2850.6]
    """

    _parameter_constraints: dict = {
        "time_constants": [Interval(Real, 0, None, closed="neither"), "array-like"],
        "columns": [None, str, Integral, "array-like"],
        "state": [StrOptions(set(STATES))],
        "powers": [Interval(Real, 0, None, closed="neither"), dict, "array-like"],
        "include_input": ["boolean"],
        "sample_interval": [Interval(Real, 0, None, closed="neither"), None],
    }

    def __init__(
        self,
        time_constants,
        *,
        columns=None,
        state="auto",
        powers=(1,),
        include_input=True,
        sample_interval=None,
    ):
        self.time_constants = time_constants
        self.columns = columns
        self.state = state
        self.powers = powers
        self.include_input = include_input
        self.sample_interval = sample_interval

    # -- parameters ---------------------------------------------------------

    def _check_params(self):
        """Check what the constraints cannot say (the entries of the sequences, a
        repeated time constant or power); return the time constants."""
        name = type(self).__name__
        taus = _real_tuple(self.time_constants)
        if taus is None:
            raise ValueError(
                f"The 'time_constants' parameter of {name} must be a number or a non-empty "
                f"sequence of numbers of seconds. Got {self.time_constants!r} instead."
            )
        taus = tuple(check_time_constants(taus, f"The 'time_constants' parameter of {name}"))
        labels = [_tau_label(t) for t in taus]
        if len(set(labels)) != len(labels):
            dup = next(t for t, lab in zip(taus, labels) if labels.count(lab) > 1)
            raise ValueError(
                f"The 'time_constants' parameter of {name} holds {_tau_label(dup)} "
                "more than once; give each time constant once."
            )
        powers = self.powers
        items = powers.items() if isinstance(powers, dict) else [(None, powers)]
        for column, values in items:
            checked = _real_tuple(values)
            where = "" if column is None else f" for column {str(column)!r}"
            if checked is None or not all(np.isfinite(p) and p > 0 for p in checked):
                raise ValueError(
                    f"The 'powers' parameter of {name} must be a non-empty sequence of finite "
                    f"numbers > 0 (or a dict of them by column); got {values!r}{where}."
                )
            if len(set(checked)) != len(checked):
                raise ValueError(
                    f"The 'powers' parameter of {name} repeats a power{where}: {values!r}."
                )
        if self.columns is not None:
            cols = [self.columns] if isinstance(self.columns, (str, int)) else self.columns
            try:
                cols = list(cols)
            except TypeError:
                cols = None
            if not cols or not all(isinstance(c, (str, numbers.Integral)) for c in cols):
                raise ValueError(
                    f"The 'columns' parameter of {name} must be None or a non-empty list of "
                    f"column names or positions. Got {self.columns!r} instead."
                )
        return np.array(taus, dtype=float)

    def _input_names(self, input_features=None):
        n = self.n_features_in_
        fitted = getattr(self, "feature_names_in_", None)
        if input_features is None:
            if fitted is not None:
                return [str(c) for c in fitted]
            return [f"x{j}" for j in range(n)]
        names = [str(c) for c in np.asarray(input_features, dtype=object)]
        if len(names) != n:
            raise ValueError(
                f"input_features should have length equal to number of features "
                f"({n}), got {len(names)}"
            )
        if fitted is not None and names != [str(c) for c in fitted]:
            raise ValueError("input_features is not equal to feature_names_in_")
        return names

    def _resolve_columns(self, names):
        """Positions of the chosen columns, in the order of X."""
        if self.columns is None:
            return list(range(len(names)))
        cols = [self.columns] if isinstance(self.columns, (str, int)) else list(self.columns)
        chosen = []
        for c in cols:
            if isinstance(c, numbers.Integral):
                if not 0 <= int(c) < len(names):
                    raise ValueError(
                        f"LagFeatures: columns= names position {int(c)}, but X has "
                        f"{len(names)} columns."
                    )
                j = int(c)
            elif c in names:
                j = names.index(c)
            else:
                raise ValueError(
                    f"LagFeatures: the column {c!r} named in columns= is not a column of X "
                    f"(its columns: {shown_names(names, 20)})."
                )
            if j in chosen:
                raise ValueError(f"LagFeatures: columns= names {names[j]!r} more than once.")
            chosen.append(j)
        return sorted(chosen)

    def _resolve_powers(self, names, chosen):
        chosen_names = [names[j] for j in chosen]
        if not isinstance(self.powers, dict):
            powers = _real_tuple(self.powers)
            return {c: powers for c in chosen_names}
        out = {c: (1.0,) for c in chosen_names}
        for column, values in self.powers.items():
            key = str(column) if not isinstance(column, numbers.Integral) else None
            if key is None and 0 <= int(column) < len(names):
                key = names[int(column)]
            if key not in out:
                raise ValueError(
                    f"LagFeatures: powers= names the column {column!r}, which is not among "
                    f"the lagged columns ({', '.join(chosen_names)})."
                )
            out[key] = _real_tuple(values)
        return out

    def _layout(self, names):
        """(column position, power) of the pass-through block and of the lagged inputs."""
        position = {c: j for j, c in enumerate(self._input_names())}
        lagged = {position[c]: self.powers_[c] for c in self.columns_}
        raw, sources = [], []
        for j in range(len(names)):
            if j not in lagged:
                raw.append((j, 1.0))
                continue
            if self.include_input:
                raw.extend((j, p) for p in lagged[j])
            sources.extend((j, p) for p in lagged[j])
        return raw, sources

    # -- time ---------------------------------------------------------------

    def _timeline(self, X, segments, taus, nominal=None):
        """Steps into every row and the tests that carry state (:mod:`greyml.dynamic._time`)."""
        return timeline(
            X,
            segments,
            owner="LagFeatures",
            tau_max=float(taus.max()),
            state=self.state,
            nominal=nominal,
            default_step=self.sample_interval,
        )

    # -- estimator ----------------------------------------------------------

    def fit(self, X, y=None):
        """Check the parameters, the columns and the time of every row.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_features)
            Rows of one or more tests (``test``/``time_s`` row index).
        y : ignored

        Returns
        -------
        self : LagFeatures
        """
        self._validate_params()
        taus = self._check_params()
        Xa, _, segments = validate_sequences(self, X, reset=True)
        names = self._input_names()
        chosen = self._resolve_columns(names)
        powers = self._resolve_powers(names, chosen)
        self.columns_ = [names[j] for j in chosen]
        self.powers_ = powers
        self._check_powered(Xa, segments, chosen, names)
        self.time_constants_ = taus
        self.nominal_step_s_ = self._timeline(X, segments, taus).nominal_step_s
        self.terms_ = self._terms(names)
        return self

    def _check_powered(self, Xa, segments, chosen, names):
        for j in chosen:
            fractional = [p for p in self.powers_[names[j]] if p != round(p)]
            if not fractional:
                continue
            negative = first_flagged(Xa[:, j] < 0, segments)
            if negative:
                k, test = negative
                raise ValueError(
                    f"LagFeatures: column {names[j]!r} is negative ({Xa[k, j]:g}) in "
                    f"{test} at row {k}, so its power {fractional[0]:g} is not "
                    "a real number; use whole powers or a column that is never negative."
                )

    def transform(self, X):
        """The pass-through columns and the lags of every test.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_features)
            The columns seen in ``fit``, tests in order (with
            ``state="carry"``: the consecutive pieces of one recording).

        Returns
        -------
        Z : DataFrame or ndarray of shape (n_samples, n_features_out)
            A DataFrame with ``X``'s index when ``X`` is one, else an array.
        """
        check_is_fitted(self)
        Xa, _, segments = validate_sequences(self, X, reset=False)
        names = self._input_names()
        chosen = [names.index(c) for c in self.columns_]
        self._check_powered(Xa, segments, chosen, names)
        taus = self.time_constants_
        steps = self._timeline(X, segments, taus, nominal=self.nominal_step_s_)
        raw, sources = self._layout(names)
        n, m = Xa.shape[0], taus.size
        # one (features, rows) C-ordered block: its transpose is the (rows,
        # features) output in Fortran order, which pandas takes without a copy
        block = np.empty((len(raw) + len(sources) * m, n))
        # one column a contiguous row (a DataFrame's values usually are already)
        columns = Xa.T if Xa.flags.f_contiguous else np.ascontiguousarray(Xa.T)
        for i, (j, p) in enumerate(raw):
            _power_into(columns[j], p, block[i])
        if [j for j, _ in sources] == list(range(Xa.shape[1])) and all(p == 1 for _, p in sources):
            inputs = columns  # every column as it is: no copy
        else:
            inputs = np.empty((len(sources), n))
            for i, (j, p) in enumerate(sources):
                _power_into(columns[j], p, inputs[i])
        self._check_overflow(block[: len(raw)], raw, inputs, sources, names, segments)
        lags = block[len(raw) :].reshape(len(sources), m, n)
        lag_filter(
            inputs.T,
            steps.dt,
            taus,
            [(s.start, s.stop) for s in segments],
            carry=steps.carried,
            out=lags,
        )
        out = block.T
        if isinstance(X, pd.DataFrame) and self._pandas_out():
            return pd.DataFrame(
                out, index=X.index, columns=self.get_feature_names_out(), copy=False
            )
        return out

    def _pandas_out(self):
        config = getattr(self, "_sklearn_output_config", {}).get("transform", "default")
        return config in ("default", "pandas")

    def _check_overflow(self, raw_block, raw, inputs, sources, names, segments):
        for rows, layout in ((raw_block, raw), (inputs, sources)):
            for i, (j, p) in enumerate(layout):
                if p == 1:
                    continue
                overflow = first_flagged(~np.isfinite(rows[i]), segments)
                if overflow:
                    k, test = overflow
                    raise ValueError(
                        f"LagFeatures: column {names[j]!r} to the power {p:g} overflows to "
                        f"infinity in {test} at row {k}; scale the column "
                        "(e.g. rpm in thousands) or use a smaller power."
                    )

    def _terms(self, names):
        raw, sources = self._layout(names)
        terms = [(names[j], p, None) for j, p in raw]
        terms += [(names[j], p, float(t)) for j, p in sources for t in self.time_constants_]
        return terms

    def get_feature_names_out(self, input_features=None):
        """Names of the output columns, e.g. ``"T4_C|lag 15 min"``.

        Parameters
        ----------
        input_features : array-like of str, optional
            Column names of ``X``; by default those seen in ``fit`` (or
            ``"x0"``, ``"x1"``, … for an array).

        Returns
        -------
        feature_names_out : ndarray of str objects
        """
        check_is_fitted(self)
        names = self._input_names(input_features)
        raw, sources = self._layout(names)
        out = [_power_name(names[j], p) for j, p in raw]
        labels = [_tau_label(t) for t in self.time_constants_]
        for j, p in sources:
            base = _power_name(names[j], p)
            out.extend(f"{base}|lag {label}" for label in labels)
        return np.asarray(out, dtype=object)

    def _check_fitted_state(self):
        """The fitted attributes in their domain and consistent (a model read from a file)."""
        if "time_constants_" not in vars(self):
            return
        what = "The fitted time_constants_ of LagFeatures"
        taus = check_time_constants(self.time_constants_, what)
        names = self._input_names()
        if not set(self.columns_) <= set(names) or set(self.powers_) != set(self.columns_):
            raise ValueError("LagFeatures: the fitted columns_ and powers_ are not columns of X.")
        for column, powers in self.powers_.items():
            checked = _real_tuple(powers)
            if checked is None or not all(np.isfinite(p) and p > 0 for p in checked):
                raise ValueError(f"LagFeatures: the fitted powers of {column!r} are {powers!r}.")
        n_terms = sum(len(p) for p in self.powers_.values()) * (1 + taus.size) + len(names)
        if n_terms > MAX_TERMS:
            raise ValueError(
                f"LagFeatures would give {n_terms:,} columns, more than the {MAX_TERMS:,} a "
                "model may hold."
            )
        step = self.nominal_step_s_
        if not (_is_real(step) and (np.isnan(step) or (np.isfinite(step) and step > 0))):
            raise ValueError(f"LagFeatures: nominal_step_s_ is {step!r}.")
        if "terms_" not in vars(self):  # saved before terms_ was public
            self.terms_ = self._terms(names)
        if [tuple(t) for t in self.terms_] != [tuple(t) for t in self._terms(names)]:
            raise ValueError("LagFeatures: terms_ disagree with the fitted columns and powers.")

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = True
        return tags


def _power_into(column, power, out):
    """``column ** power`` written into ``out``."""
    if power == 1:
        out[...] = column
        return
    # an overflow is reported with the column and test by the caller
    with np.errstate(over="ignore", invalid="ignore"):
        if power == 2:
            np.multiply(column, column, out=out)
        else:
            np.power(column, power, out=out)
