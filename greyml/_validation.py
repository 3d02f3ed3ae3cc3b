"""Input validation shared by every greyml estimator.

scikit-learn's ``validate_data`` does the bookkeeping (``n_features_in_``,
``feature_names_in_``, dtype conversion, fit/predict column checks); the checks
here add what it cannot know: which *test* and which *column* a bad value sits
in, so that every message names both.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from sklearn.utils.validation import validate_data

from greyml._sequences import TIME_LEVEL, Segment, has_test_index, segment_label, segments_by_test

__all__ = [
    "validate_sequences",
    "validate_grey_tests",
    "column_names",
    "check_unique_columns",
    "check_sampling_interval",
    "check_magnitudes",
    "MAX_INPUT",
    "first_flagged",
    "first_non_finite",
    "param_error",
    "real_values",
    "segment_of",
    "shown_name",
    "shown_names",
    "require_y",
    "standard_scaling",
]


def column_names(estimator, n_features: int) -> list[str]:
    """Names used in messages: ``feature_names_in_`` if fitted on a DataFrame."""
    names = getattr(estimator, "feature_names_in_", None)
    if names is not None and len(names) == n_features:
        return [str(c) for c in names]
    return [f"x{j}" for j in range(n_features)]


def shown_name(name) -> str:
    """A column name as a message shows it: as written, or quoted with its escapes
    (``repr``) when it holds a character a reader cannot see (a zero-width space, a
    byte-order mark, a control character) or white space at an end.

    >>> print(shown_name("ch1_um"), shown_name("\u200bch1_um"), shown_name(" T1"))
    ch1_um '\\u200bch1_um' ' T1'
    """
    text = str(name)
    if text and text.isprintable() and text == text.strip():
        return text
    return repr(text)


def shown_names(names, limit=None) -> str:
    """The names (:func:`shown_name`) joined by commas; past ``limit`` names, ``...``."""
    names = list(names)
    shown = ", ".join(shown_name(n) for n in names[:limit])
    return shown + (", ..." if limit is not None and len(names) > limit else "")


def _upper_first(text: str) -> str:
    return text[:1].upper() + text[1:]


def _where(seg: Segment, row: int) -> str:
    return f"{segment_label(seg)} at row {row} (sample {row - seg.start + 1} of that test)"


def check_unique_columns(columns, what):
    """Raise naming the first column name that ``columns`` holds more than once."""
    seen = set()
    for name in map(str, columns):
        if name in seen:
            raise ValueError(
                f"{what} has the column {name!r} more than once; each column needs a "
                "name of its own."
            )
        seen.add(name)


def segment_of(segments, row: int) -> Segment:
    """The test (:class:`Segment`) that row ``row`` belongs to."""
    return next(s for s in segments if s.start <= row < s.stop)


def first_flagged(mask: np.ndarray, segments) -> tuple[int, str] | None:
    """The first row where the 1-D ``mask`` is True and the test it is in.

    ``(row, "test 'IV'")``, the test named as in messages; ``None`` when no row is.
    """
    rows = np.flatnonzero(mask)
    if not rows.size:
        return None
    row = int(rows[0])
    return row, segment_label(segment_of(segments, row))


#: The largest magnitude a fitted model takes in its training data: far beyond
#: any temperature, speed, strain or displacement in any unit, and small enough
#: that squares (a driver's power 2, Gram matrices, ANFIS's memberships) stay
#: finite in float64. A larger value is a unit or logging error (1e300 rpm).
MAX_INPUT = 1e100


def check_magnitudes(model, A, names, segments):
    """Refuse in one line, naming the column, the test and the row, a value
    beyond :data:`MAX_INPUT` (its squares overflow: a unit or logging error).

    ``A`` is 2-D with one column per entry of ``names``; a name "the target y"
    is printed as such, any other as ``column 'name'``.
    """
    A = np.asarray(A, dtype=float)
    if A.ndim == 1:
        A = A[:, None]
    with np.errstate(invalid="ignore"):
        big = (A > MAX_INPUT) | (A < -MAX_INPUT)  # no copy of A (NaN compares False)
    if not big.any():
        return
    for j in np.flatnonzero(big.any(axis=0)):
        name = names[j] if names is not None else "the target y"
        row, test = first_flagged(big[:, j], segments)
        what = name if name == "the target y" else f"column {name!r}"
        raise ValueError(
            f"{type(model).__name__}: {what} holds {A[row, j]:g} in {test} at row {row}, "
            f"beyond {MAX_INPUT:g}, which no measurement reaches; check its unit."
        )


def first_non_finite(values: np.ndarray) -> tuple[int | None, int]:
    """The row of the first NaN or infinity of the 1-D ``values`` and how many there are.

    ``(None, 0)`` when every value is finite.
    """
    bad = np.flatnonzero(~np.isfinite(values))
    return (int(bad[0]), int(bad.size)) if bad.size else (None, 0)


def float_vector(values, message: str) -> np.ndarray:
    """``values`` as a 1-D float array; a ValueError with ``message`` when they are
    not numbers (text, ragged lists, objects)."""
    try:
        return np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(message) from None


def real_values(series: pd.Series, what: str) -> np.ndarray:
    """A numeric (or boolean) Series as float64, NA as NaN; raise for text or complex."""
    dtype = series.dtype
    numeric = pd.api.types.is_numeric_dtype(dtype) or pd.api.types.is_bool_dtype(dtype)
    if not numeric or pd.api.types.is_complex_dtype(dtype):
        raise ValueError(f"{what} must hold real numbers; it has non-numeric dtype {dtype}.")
    return series.to_numpy(dtype=np.float64, na_value=np.nan)


def check_sampling_interval(t: np.ndarray, seg: Segment, rtol: float = 1e-3) -> float:
    """The constant time step of one test; raise if the steps are not constant.

    A step may deviate from the test's first step by ``rtol`` relative; NaN for
    a test of one row.
    """
    if t.size < 2:
        return math.nan
    dt = (t[-1] - t[0]) / (t.size - 1)
    steps = np.diff(t)
    back = np.flatnonzero(steps <= 0)
    if back.size:
        k = int(back[0])
        raise ValueError(
            f"Time does not increase within {segment_label(seg)}: {TIME_LEVEL} goes "
            f"from {t[k]:g} to {t[k + 1]:g} at row {seg.start + k + 1}."
        )
    off = np.flatnonzero(np.abs(steps - steps[0]) > rtol * steps[0])
    if off.size:
        k = int(off[0])
        raise ValueError(
            f"The sampling interval of {segment_label(seg)} is not constant: "
            f"{steps[0]:g} s from {TIME_LEVEL}={t[0]:g} to {t[1]:g}, but {steps[k]:g} s "
            f"from {TIME_LEVEL}={t[k]:g} to {t[k + 1]:g}. Frequency bands and lags need "
            "evenly spaced samples; resample the test onto a uniform time grid first."
        )
    return float(dt)


def param_error(function: str, name: str, what: str, value) -> ValueError:
    """scikit-learn's message for a bad parameter of a public function."""
    return ValueError(
        f"The {name!r} parameter of {function} must be {what}. Got {value!r} instead."
    )


def _check_numeric_frame(X, what="X"):
    if isinstance(X, pd.DataFrame):
        check_unique_columns(X.columns, what)
        for col in X.columns:
            dtype = X[col].dtype
            if not (pd.api.types.is_numeric_dtype(dtype) or pd.api.types.is_bool_dtype(dtype)):
                raise ValueError(
                    f"Column {str(col)!r} of {what} has non-numeric dtype {dtype}; "
                    "greyml models need numeric sensor values."
                )


def _check_columns(estimator, X, reset):
    """X has at least one column and, after fit, the fitted columns in their order."""
    name = type(estimator).__name__
    shape = getattr(X, "shape", None)
    if shape is not None and len(shape) == 2 and shape[1] == 0:
        raise ValueError(
            f"Found array with 0 feature(s) (shape={tuple(shape)}) while a minimum of 1 "
            f"is required by {name}: X has no sensor columns."
        )
    fitted = getattr(estimator, "feature_names_in_", None)
    if reset or fitted is None or not isinstance(X, pd.DataFrame):
        return
    given = [str(c) for c in X.columns]
    fitted = [str(c) for c in fitted]
    if given != fitted and sorted(given) == sorted(fitted):
        k = next(i for i, (a, b) in enumerate(zip(given, fitted)) if a != b)
        # scikit-learn's wording first, so its estimator checks recognise it
        raise ValueError(
            "The feature names should match those that were passed during fit.\n"
            "Feature names must be in the same order as they were in fit: column "
            f"{k + 1} of X is {given[k]!r} where {name} was fitted with {fitted[k]!r}. "
            f"Reorder the columns, e.g. X[{name.lower()}.feature_names_in_]."
        )


def _check_numeric_target(y):
    """y holds numbers: a clear message for text, dates or objects in the target."""
    values = y.to_numpy() if isinstance(y, (pd.Series, pd.DataFrame)) else y
    arr = np.asarray(values)
    if arr.dtype.kind in "biufc":
        return
    if arr.dtype.kind not in "Mm":
        try:
            np.asarray(arr, dtype=np.float64)
            return
        except (TypeError, ValueError):
            pass
    example = arr.reshape(-1)[0] if arr.size else None
    name = getattr(y, "name", None)
    label = f" ({str(name)!r})" if name is not None else ""
    raise ValueError(
        f"The target y{label} has non-numeric values (dtype {arr.dtype}, first value "
        f"{example!r}); give the measured target as numbers."
    )


def _check_finite(A: np.ndarray, names, segments, what: str):
    bad = ~np.isfinite(A)
    if not bad.any():
        return
    if A.ndim == 1:
        A = A[:, None]
        bad = bad[:, None]
    for seg in segments:
        block = bad[seg.slice]
        if block.any():
            r, c = np.argwhere(block)[0]
            row = seg.start + int(r)
            value = A[row, c]
            kind = "NaN" if np.isnan(value) else "infinity (inf)"
            name = names[c] if names is not None else None
            where = f"column {name!r}" if name is not None else "the target y"
            # scikit-learn's wording first, so its estimator checks recognise it
            if np.isnan(value):
                prefix = f"Input {what} contains NaN"
            else:
                prefix = f"Input {what} contains infinity or a value too large for dtype('float64')"
            raise ValueError(f"{prefix}: {where} has {kind} in {_where(seg, row)}.")


def _check_constant(A, names, segments):
    if A.shape[0] < 2:
        return
    spread = np.ptp(A, axis=0)
    for j in np.flatnonzero(spread == 0):
        tests = ", ".join(segment_label(s) for s in segments)
        raise ValueError(
            f"Column {names[j]!r} is constant ({A[0, j]:g}) in every row of "
            f"{tests}: a constant sensor carries no information. Remove it or "
            "check that it was logged."
        )


def _segments_of(X, y):
    if has_test_index(X):
        segments = segments_by_test(X)
        if y is not None and has_test_index(y):
            if not np.array_equal(
                np.asarray(X.index.get_level_values("test"), dtype=object),
                np.asarray(y.index.get_level_values("test"), dtype=object),
            ):
                raise ValueError(
                    "X and y disagree on which rows belong to which test: their "
                    "'test' index levels differ. Align them (e.g. y = y.loc[X.index])."
                )
        return segments
    if y is not None and has_test_index(y):
        return segments_by_test(y)
    return None


def validate_sequences(
    estimator,
    X,
    y=None,
    *,
    reset: bool,
    min_samples_per_test: int = 1,
    min_rows: int | None = None,
    n_params_msg: str | None = None,
    reject_constant: bool = False,
    static: bool = False,
    bounded: bool = True,
):
    """Validate ``X`` (and ``y``) and find the test boundaries.

    Returns ``(X, y, segments)`` with ``X`` a float64 array, ``y`` a float64 1-D
    array (or ``None``) and ``segments`` the list of :class:`Segment`.
    ``min_rows`` is the number of equations the estimator needs (an int, or a
    function of the number of columns), counted as rows minus one per test (the
    first sample of each test only starts it). ``static=True`` is for models
    whose rows are independent equations (ANFIS, MLP): every row counts.
    ``bounded=True`` refuses, when fitting, a value beyond :data:`MAX_INPUT`
    (a unit or logging error); a plain transform (the AGO) passes False.
    """
    segments = _segments_of(X, y)
    _check_numeric_frame(X)
    _check_columns(estimator, X, reset)
    if y is not None:
        _check_numeric_target(y)
        if isinstance(y, pd.DataFrame) and y.shape[1] == 1:
            y = y.iloc[:, 0]
        y_arr = np.asarray(y)
        if y_arr.dtype.kind in "fc" and y_arr.size:
            y_flat = y_arr.reshape(-1) if y_arr.ndim == 2 and 1 in y_arr.shape else y_arr
            if y_flat.ndim == 1:
                segs = segments or [Segment(None, 0, len(y_flat))]
                _check_finite(y_flat, None, segs, "y")
        Xa, ya = validate_data(
            estimator,
            X,
            y,
            reset=reset,
            ensure_all_finite=False,
            dtype=np.float64,
            y_numeric=True,
        )
        ya = np.asarray(ya, dtype=np.float64)
    else:
        Xa = validate_data(estimator, X, reset=reset, ensure_all_finite=False, dtype=np.float64)
        ya = None
    if segments is None:
        segments = [Segment(None, 0, Xa.shape[0])]
    names = column_names(estimator, Xa.shape[1])
    _check_finite(Xa, names, segments, "X")
    if ya is not None:
        _check_finite(ya, None, segments, "y")
    if reset and bounded:
        check_magnitudes(estimator, Xa, names, segments)
        if ya is not None and ya.ndim == 1:
            check_magnitudes(estimator, ya, ["the target y"], segments)

    name = type(estimator).__name__
    for seg in segments:
        if seg.n < min_samples_per_test:
            raise ValueError(
                f"{_upper_first(segment_label(seg))} has {seg.n} sample"
                f"{'' if seg.n == 1 else 's'}; {name} needs at least "
                f"{min_samples_per_test} samples per test."
            )
    if callable(min_rows):
        min_rows = min_rows(Xa.shape[1])
    if callable(n_params_msg):
        n_params_msg = n_params_msg(Xa.shape[1])
    if min_rows is not None:
        n_eq = Xa.shape[0] - (0 if static else len(segments))
        if n_eq < min_rows:
            what = n_params_msg or f"{min_rows} coefficients"
            raise ValueError(
                f"{name} has too few samples to fit {what}: {Xa.shape[0]} samples "
                f"in {len(segments)} test(s) give {n_eq} equations, fewer than "
                f"{min_rows}. Give more samples or fewer columns."
            )
    if reject_constant:
        _check_constant(Xa, names, segments)
    return Xa, ya, segments


def validate_grey_tests(estimator, X, y, *, extra: int, coefficients: str):
    """:func:`validate_sequences` for a grey equation fitted on training tests.

    Every test needs two rows (its first only starts the accumulation), the
    equations must be at least the ``p + extra`` coefficients of ``p`` columns,
    named in messages as ``"{p + extra} {coefficients}"``, and a constant
    column (which makes the grey equation singular) is refused.
    """
    return validate_sequences(
        estimator,
        X,
        y,
        reset=True,
        min_samples_per_test=2,
        min_rows=lambda p: p + extra,
        n_params_msg=lambda p: f"{p + extra} {coefficients}",
        reject_constant=True,
    )


def require_y(estimator, y, why="give the measured target (e.g. the displacement) of every row"):
    """A supervised greyml estimator got ``y=None``: say so, and why it needs y."""
    if y is None:
        raise ValueError(
            f"{type(estimator).__name__} requires y to be passed, but the target y is None: {why}."
        )


def _std(A):
    """Standard deviation along axis 0 that does not overflow for |values| ~ 1e200."""
    with np.errstate(over="ignore", invalid="ignore"):
        std = np.asarray(A.std(axis=0))
    if np.isfinite(std).all():
        return std
    peak = np.max(np.abs(A), axis=0)
    peak = np.where(peak > 0, peak, 1.0)
    return np.where(np.isfinite(std), std, peak * (A / peak).std(axis=0))


def standard_scaling(X, y):
    """Means and standard deviations that standardise ``X`` (per column) and ``y``.

    A column (or a target) without spread keeps unit scale, so nothing is
    divided by zero. Returns ``(x_mean, x_scale, y_mean, y_scale)``.
    """
    x_scale = _std(X)
    y_scale = float(_std(y))
    return (
        X.mean(axis=0),
        np.where(x_scale > 0, x_scale, 1.0),
        float(y.mean()),
        y_scale if y_scale > 0 else 1.0,
    )
