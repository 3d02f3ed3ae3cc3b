"""The checks of a ThermalTransferFunction: its parameters, weights, inputs and fitted state.

Functions of the model (its first argument), kept apart from the estimator's
fitting code in :mod:`greyml.dynamic._transfer`: the parameters the
constraints cannot check, the sensors and rows a fit needs, the sample
weights, inputs too large for float64, the initial displacements of
:meth:`~greyml.ThermalTransferFunction.predict`, and the fitted state of a
model read from a file.
"""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Mapping

import numpy as np

from greyml._caller import warn_user
from greyml._renamed import DEPRECATED
from greyml._validation import MAX_INPUT, check_magnitudes, first_flagged
from greyml.dynamic._time import MAX_TERMS, check_time_constants
from greyml.dynamic._transfer_records import Settings
from greyml.exceptions import UnderdeterminedWarning

__all__ = [
    "DEFAULT_ALPHAS",
    "DEFAULT_TIME_CONSTANTS",
    "MAX_INPUT",
    "check_enough_rows",
    "check_fitted_state",
    "check_magnitudes",
    "check_max_sensors",
    "check_params",
    "initial_displacements",
    "sample_weights",
]

#: Default time constants of the temperature sensors, in seconds (5, 15, 45, 135 min).
DEFAULT_TIME_CONSTANTS = (300.0, 900.0, 2700.0, 8100.0)
#: Ridge penalties tried, per row of the (standardised) design.
DEFAULT_ALPHAS = tuple(np.logspace(-6, 0, 13))


def _taus(model, name, value, default):
    if value is None:
        return np.asarray(default, dtype=float)
    return check_time_constants(value, f"The {name!r} parameter of {type(model).__name__}")


def check_params(model):
    """The settings of a fit: what the constraints cannot check (entries of sequences)."""
    name = type(model).__name__
    fit_taus = isinstance(model.time_constants, str) and model.time_constants == "fit"
    taus = _taus(
        model, "time_constants", None if fit_taus else model.time_constants, DEFAULT_TIME_CONSTANTS
    )
    dtaus = model.driver_time_constants
    driver_taus = (
        np.append(taus, 3.0 * taus.max())
        if dtaus is None
        else _taus(model, "driver_time_constants", dtaus, DEFAULT_TIME_CONSTANTS)
    )
    powers = tuple(model.driver_powers)
    if not powers or any(
        not isinstance(p, numbers.Real) or isinstance(p, bool) or not np.isfinite(p) or p <= 0
        for p in powers
    ):
        raise ValueError(
            f"The 'driver_powers' parameter of {name} must be a non-empty sequence of "
            f"finite numbers > 0. Got {model.driver_powers!r} instead."
        )
    alphas = np.asarray(DEFAULT_ALPHAS if model.alphas is None else model.alphas, dtype=float)
    if alphas.ndim != 1 or alphas.size == 0 or not (np.isfinite(alphas) & (alphas > 0)).all():
        raise ValueError(
            f"The 'alphas' parameter of {name} must be a non-empty sequence of finite "
            f"floats > 0. Got {model.alphas!r} instead."
        )
    extend = model.time_constants is None and model.driver_time_constants is None
    return Settings(taus, driver_taus, fit_taus, powers, alphas, _reference_asked(model), extend)


def _reference_asked(model):
    """``reference``, or the deprecated ``relative_to_start`` with a FutureWarning."""
    old = model.relative_to_start
    if isinstance(old, str) and old == DEPRECATED:
        return model.reference
    new = "start" if old else "recording"
    warnings.warn(
        f"The 'relative_to_start' parameter of {type(model).__name__} is replaced by "
        f"'reference' and goes away in the next release; use reference={new!r}.",
        FutureWarning,
        stacklevel=4,
    )
    return new


def check_max_sensors(model, sensors, names):
    """``max_sensors`` at most the temperature sensors (the columns of X that are
    not drivers)."""
    if model.max_sensors is not None and model.max_sensors > len(sensors):
        raise ValueError(
            f"The 'max_sensors' parameter of {type(model).__name__} is {model.max_sensors}, "
            f"more than the {len(sensors)} temperature sensor(s) "
            f"({', '.join(sensors) or 'none'}) among the {len(names)} feature(s) of X."
        )


def check_enough_rows(model, data, settings, n_driver_columns, reference):
    """Refuse fewer than two equations; warn when the gains outnumber them.

    An equation is a row of positive weight, less the first row of each test
    in the ``"start"`` reference. With fewer equations than gains the ridge
    penalty keeps the solve defined, and the model says so as
    :class:`~greyml.MLPBaseline` does (:class:`~greyml.exceptions.UnderdeterminedWarning`).
    """
    name = type(model).__name__
    n_used = len(data.sensors) if model.max_sensors is None else model.max_sensors
    n_coef = n_driver_columns + n_used * (1 + len(settings.taus))
    relative = reference == "start"
    n_coef += 0 if relative else 1
    n_eq = int((data.w > 0).sum()) - (len(data.segments) if relative else 0)
    n = data.X.shape[0]
    rows = (
        f"{n} sample{'' if n == 1 else 's'} in {len(data.segments)} test(s) give "
        f"{n_eq} equation{'' if n_eq == 1 else 's'}"
    )
    if n_eq < 2:
        raise ValueError(
            f"{name} has too few rows to fit: {rows}, and a fit needs at least 2. Give more rows."
        )
    if n_eq < n_coef:
        warn_user(
            f"{name} is under-determined: {rows} for {n_coef} coefficients. The ridge "
            "penalty keeps the fit defined, but it can interpolate the training rows; "
            "give more rows, fewer sensors (max_sensors) or fewer time constants.",
            UnderdeterminedWarning,
        )


def sample_weights(model, sample_weight, n, segments):
    """``sample_weight`` as finite weights >= 0, not all 0 (ones without it)."""
    if sample_weight is None:
        return np.ones(n)
    w = np.asarray(sample_weight, dtype=float).reshape(-1)
    if w.shape[0] != n:
        raise ValueError(
            f"{type(model).__name__}: sample_weight has {w.shape[0]} values for {n} rows."
        )
    bad = first_flagged(~np.isfinite(w) | (w < 0), segments)
    if bad:
        r, test = bad
        value = "NaN" if np.isnan(w[r]) else f"{w[r]:g}"
        raise ValueError(
            f"{type(model).__name__}: sample_weight of row {r} ({test}) is "
            f"{value}; weights must be finite and >= 0."
        )
    if w.sum() <= 0:
        raise ValueError(
            f"{type(model).__name__}: every sample_weight is zero; give some rows a "
            "positive weight."
        )
    return w


def initial_displacements(model, value, segments):
    """``initial_displacement`` as {test position: finite number}."""
    if value is None:
        return {}
    name = type(model).__name__
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


def check_fitted_state(model):
    """Every fitted attribute in its domain and consistent with the others.

    Run on a model read from a file (:func:`greyml.persist.load_model`),
    which could hold anything: a negative time constant would make every
    prediction grow without bound, a block naming a column the model does
    not have would read the wrong sensor. Raises a one-line ValueError.
    """
    if "feature_coef_" not in vars(model):
        return  # not fitted: nothing but parameters
    name = type(model).__name__
    if "gap_limit_s_" not in vars(model) or "reference_" not in vars(model):
        raise ValueError(
            f"{name} was saved by an earlier greyml, before it had a reference and a gap "
            "limit; fit it again."
        )
    n_in = int(model.n_features_in_)
    check_time_constants(model.time_constants_, f"The fitted time_constants_ of {name}")
    check_time_constants(
        model.driver_time_constants_, f"The fitted driver_time_constants_ of {name}"
    )
    spec = list(model._spec_)
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
    coef = np.asarray(model.feature_coef_, dtype=float)
    if coef.shape != (width,) or not np.isfinite(coef).all():
        raise ValueError(
            f"{name}: feature_coef_ must be {width} finite numbers, one per term of the "
            f"fitted blocks; it has shape {coef.shape}."
        )
    if not (_is_real(model.intercept_) and np.isfinite(model.intercept_)):
        raise ValueError(f"{name}: the intercept_ {model.intercept_!r} is not finite.")
    if len(model._groups_) != len(spec) or len(model._labels_) != len(spec):
        raise ValueError(f"{name}: the fitted blocks and their groups disagree.")
    if model.reference_ not in ("start", "recording"):
        raise ValueError(f"{name}: reference_ is {model.reference_!r}.")
    if not (_is_real(model.gap_limit_s_) and np.isfinite(model.gap_limit_s_)):
        raise ValueError(f"{name}: gap_limit_s_ is {model.gap_limit_s_!r}.")
    if model.gap_limit_s_ <= 0:
        raise ValueError(f"{name}: gap_limit_s_ is {model.gap_limit_s_!r}.")
    step = model.nominal_step_s_
    if not (_is_real(step) and (np.isnan(step) or (np.isfinite(step) and step > 0))):
        raise ValueError(f"{name}: nominal_step_s_ is {step!r}.")
    if [tuple(t) for t in model.terms_] != [tuple(t) for t in model._terms()]:
        raise ValueError(f"{name}: terms_ disagree with the fitted blocks and gains.")
    _check_interval_state(model, name)
    _check_normal_equations(model, name, width + (0 if model.reference_ == "start" else 1))


def _check_normal_equations(model, name, n_total):
    """partial_fit's normal equations: a symmetric finite Gram on valid columns, or none."""
    keys = ("normal_gram_", "normal_rhs_", "normal_weight_", "_normal_cols_", "_normal_pen_")
    present = [k in vars(model) for k in keys]
    if not any(present):
        return  # saved before partial_fit existed: it then says fit again
    bad = ValueError(f"{name}: the saved normal equations (normal_gram_, ...) are not valid.")
    if not all(present):
        raise bad
    try:
        cols = np.asarray(model._normal_cols_)
        G = np.asarray(model.normal_gram_, dtype=float)
        b = np.asarray(model.normal_rhs_, dtype=float)
        pen = np.asarray(model._normal_pen_, dtype=float)
        weight = float(model.normal_weight_)
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


#: The most held-out residuals a saved model may keep for its intervals.
MAX_CONFORMITY_SCORES = 10_000_000


def _check_interval_state(model, name):
    """The intervals' calibration: both None, or a scale (a, b, c) and sorted scores."""
    scale = vars(model).setdefault("interval_scale_", None)
    scores = vars(model).setdefault("conformity_scores_", None)
    if scale is None and scores is None:
        return
    scale = np.asarray(scale, dtype=float) if scale is not None else np.zeros(0)
    if (
        scale.shape != (5,)
        or not np.isfinite(scale).all()
        or scale[0] <= 0
        or (scale[1:] < 0).any()
        or scale[2] > scale[0]
        or scale[4] <= 0
    ):
        raise ValueError(
            f"{name}: interval_scale_ must be five finite numbers (a > 0, b >= 0, "
            f"0 <= c <= a, s2 >= 0, memory_h > 0); got {model.interval_scale_!r}."
        )
    scores = np.asarray(scores, dtype=float) if scores is not None else np.zeros((0, 0))
    if (
        scores.ndim != 1
        or not 0 < scores.size <= MAX_CONFORMITY_SCORES
        or not np.isfinite(scores).all()
        or (scores < 0).any()
        or (np.diff(scores) < 0).any()
    ):
        raise ValueError(
            f"{name}: conformity_scores_ must be 1 to {MAX_CONFORMITY_SCORES:,} finite, "
            "non-negative numbers in increasing order."
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
