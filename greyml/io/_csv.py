"""Reading and writing greyml's test-data layout as CSV.

The layout: one row per sample, the key columns ``test`` (label of the
heating/cooling test) and ``time_s`` (seconds from that test's start) first,
then numeric data columns (operating inputs ``spindle_rpm``, ``feed_mm_min``,
``c_rpm``, ``ambient_C``; sensors ``T<k>_C``, ``FBG<k>_ue``; targets ``dx_um``,
``dy_um``, ``dz_um``). Rows of one test are contiguous and in strictly
increasing time. In memory the two key columns become the ``(test, time_s)``
row index (:func:`greyml._sequences.make_test_index`).
"""

from __future__ import annotations

import csv
import os
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from greyml._sequences import TEST_LEVEL, TIME_LEVEL, make_test_index, test_segments
from greyml._validation import check_unique_columns

__all__ = ["read_tests_csv", "write_tests_csv", "check_test_frame"]

KEYS = (TEST_LEVEL, TIME_LEVEL)


def _line(row: int) -> int:
    """File line of data row ``row`` (0-based): the header is line 1."""
    return int(row) + 2


def describe_input(obj) -> str:
    """How an input that is not a table is named in messages: ``"a 1-D ndarray of shape (5,)"``."""
    try:
        from scipy import sparse

        if sparse.issparse(obj):
            return f"a sparse matrix ({type(obj).__name__}) of shape {obj.shape}"
    except ImportError:  # pragma: no cover - scipy is a dependency
        pass
    shape = getattr(obj, "shape", None)
    if shape is not None:
        return f"a {len(shape)}-D {type(obj).__name__} of shape {tuple(shape)}"
    return f"a {type(obj).__name__}"


def check_test_frame(frame, *, what="The frame"):
    """Check that a DataFrame follows greyml's test-data layout.

    Parameters
    ----------
    frame : DataFrame
        Indexed by ``(test, time_s)``, numeric columns.
    what : str, default="The frame"
        How to name the frame in error messages.

    Returns
    -------
    frame : DataFrame
        The same frame.

    Raises
    ------
    ValueError
        If ``frame`` is not a DataFrame, has no rows or no data columns, the
        index lacks the ``test`` or ``time_s`` level, a column is not
        numeric (or complex) or clashes with a key, column names repeat, a
        test label or time is missing, a test's rows are not contiguous or its
        time does not strictly increase.

    Examples
    --------
    >>> import pandas as pd
    >>> from greyml._sequences import make_test_index
    >>> df = pd.DataFrame({"T1_C": [20.0, 20.1]},
    ...                   index=make_test_index(["I", "I"], [0, 10]))
    >>> check_test_frame(df) is df
    True
    """
    if not isinstance(frame, pd.DataFrame):
        raise ValueError(
            f"{what} must be a 2-D pandas DataFrame indexed by (test, time_s); got "
            f"{describe_input(frame)}."
        )
    names = list(frame.index.names or [])
    for key in KEYS:
        if key not in names:
            raise ValueError(
                f"{what} has no '{key}' index level (index levels: {names}); "
                "index the rows by (test, time_s), e.g. with "
                "frame.set_index(['test', 'time_s'])."
            )
    if frame.shape[0] == 0:
        raise ValueError(f"{what} has no rows (0 samples); every test needs at least one row.")
    if frame.shape[1] == 0:
        raise ValueError(f"{what} has no data columns (0 features) besides test and time_s.")
    for c in map(str, frame.columns):
        if c in KEYS:
            raise ValueError(f"{what} has a data column named '{c}', which is a key name.")
    check_unique_columns(frame.columns, what)
    lower = what.lower() if what[:1].isupper() and what[1:2].islower() else what
    for c in frame.columns:
        dtype = frame[c].dtype
        if pd.api.types.is_complex_dtype(dtype):
            raise ValueError(
                f"Column '{c}' of {lower} holds complex numbers (dtype {dtype}); every "
                "data column must hold real numbers."
            )
        if not (pd.api.types.is_numeric_dtype(dtype) and not pd.api.types.is_bool_dtype(dtype)):
            raise ValueError(
                f"Column '{c}' of {lower} is not numeric (non-numeric dtype {dtype}); every "
                "data column must hold numbers."
            )
    test_segments(frame)
    return frame


def write_tests_csv(frame, path, *, overwrite=False):
    """Write test data to a CSV file.

    Floats are written with the shortest representation that reads back to
    the same double, so :func:`read_tests_csv` returns the same numbers.

    Parameters
    ----------
    frame : DataFrame
        Indexed by ``(test, time_s)``; see :func:`check_test_frame`.
    path : str or path-like
        File to create.
    overwrite : bool, default=False
        Replace ``path`` if it exists. Without it an existing file is never
        touched.

    Returns
    -------
    path : pathlib.Path

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is false.
    ValueError
        If ``frame`` does not follow the layout.

    Examples
    --------
    >>> import tempfile, os
    >>> from greyml.datasets import load_probe_test
    >>> df = load_probe_test().frame
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = write_tests_csv(df, os.path.join(d, "probe.csv"))
    ...     back = read_tests_csv(p)
    >>> back.equals(df)
    True
    """
    check_test_frame(frame)
    path = Path(path)
    out = frame.copy()
    for c in out.columns:
        if pd.api.types.is_float_dtype(out[c].dtype) and out[c].dtype != np.float64:
            out[c] = out[c].astype(np.float64)
    out = out.reset_index(level=[n for n in out.index.names if n not in KEYS] or None)
    out = out.reset_index()[[*KEYS, *[c for c in out.columns if c not in KEYS]]]
    mode = "w" if overwrite else "x"
    try:
        with open(path, mode, newline="", encoding="utf-8") as fh:
            out.to_csv(fh, index=False, lineterminator="\n")
    except FileExistsError:
        raise FileExistsError(
            f"{os.fspath(path)!r} exists; pass overwrite=True to replace it."
        ) from None
    return path


def _header(path):
    with open(path, newline="", encoding="utf-8") as fh:
        try:
            header = next(csv.reader(fh))
        except StopIteration:
            raise ValueError(f"{os.fspath(path)!r} is empty: expected a header line.") from None
    header = [h.strip() for h in header]
    seen = set()
    for k, name in enumerate(header):
        if name == "":
            raise ValueError(f"Column {k + 1} of the header of {os.fspath(path)!r} has no name.")
        if name in seen:
            raise ValueError(
                f"The header of {os.fspath(path)!r} names column '{name}' more than once."
            )
        seen.add(name)
    for key in KEYS:
        if key not in seen:
            raise ValueError(
                f"{os.fspath(path)!r} has no '{key}' column; the header must contain "
                f"'{TEST_LEVEL}' and '{TIME_LEVEL}' (found {header})."
            )
    return header


def _first_bad(values: pd.Series):
    """Row and text of the first cell that is present but not a number."""
    text = values.astype(object)
    present = text.notna() & (text.astype(str).str.strip() != "")
    numbers = pd.to_numeric(text.where(present), errors="coerce")
    bad = np.flatnonzero((present & numbers.isna()).to_numpy())
    return (int(bad[0]), text.iloc[bad[0]]) if bad.size else (None, None)


def _numeric_column(values: pd.Series, col, name: str, context=lambda row: ""):
    """A CSV column as floats (empty cells NaN); a cell that is text raises,
    naming the column, the file, the line and ``context(row)``."""
    if pd.api.types.is_numeric_dtype(values.dtype):
        return values
    row, text = _first_bad(values)
    if row is not None:
        raise ValueError(
            f"Column '{col}' of {name!r} holds {text!r} at line {_line(row)}{context(row)}, "
            f"which is not a number: non-numeric text{_what_text(text)}; every data column "
            "must hold numbers."
        )
    return pd.to_numeric(values.astype(object), errors="coerce").astype(float)


def _what_text(text) -> str:
    """What a non-number cell seems to be, for the message: '' or ' (a complex number)'."""
    text = str(text).strip()
    try:
        complex(text.replace(" ", ""))
        return " (a complex number; give the real part)"
    except ValueError:
        pass
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            pd.Timestamp(text)
            return " (a date/time; give seconds or degrees as a number)"
        except (ValueError, TypeError, OverflowError):
            return ""


def read_tests_csv(path):
    """Read test data written by :func:`write_tests_csv` (or by hand).

    Parameters
    ----------
    path : str or path-like
        CSV file with a header; columns ``test``, ``time_s`` and numeric
        data columns. Empty cells are missing values (NaN).

    Returns
    -------
    frame : DataFrame
        Indexed by ``(test, time_s)``; test labels are strings, ``time_s``
        floats.

    Raises
    ------
    ValueError
        With the line of the file (the header is line 1) or the column, for:
        an empty file or header, a repeated column name, a missing ``test``
        or ``time_s`` column, a missing test label or time, a value that is
        not a number, two rows with the same test and time, time that does not
        increase within a test, or a test whose rows are not contiguous.

    Examples
    --------
    >>> import io, tempfile, os
    >>> text = "test,time_s,T1_C,dz_um\\nA,0,20.0,0.0\\nA,60,20.5,1.5\\n"
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "a.csv")
    ...     with open(p, "w") as fh:
    ...         _ = fh.write(text)
    ...     df = read_tests_csv(p)
    >>> df.index.names, df.shape
    (FrozenList(['test', 'time_s']), (2, 2))
    """
    name = os.fspath(path)
    header = _header(path)
    if len(header) == len(KEYS):
        raise ValueError(
            f"{name!r} has no data columns (0 features): its header holds only {', '.join(header)}."
        )
    try:
        raw = pd.read_csv(
            path,
            dtype={TEST_LEVEL: object},
            skipinitialspace=True,
            keep_default_na=False,
            na_values=[""],
        )
    except pd.errors.ParserError as exc:
        raise ValueError(f"{name!r} is not a well-formed CSV file: {exc}") from None
    if raw.empty:
        raise ValueError(f"{name!r} has a header but no rows (0 samples).")
    labels = raw[TEST_LEVEL]
    missing = labels.isna() | (labels.astype(str).str.strip() == "")
    if missing.any():
        row = int(np.flatnonzero(missing.to_numpy())[0])
        raise ValueError(
            f"Line {_line(row)} of {name!r} (data row {row}) has no test label in column "
            "'test' (a missing test label); every row must name its test."
        )
    raw[TEST_LEVEL] = labels.astype(str).str.strip()
    for col in raw.columns:
        if col == TEST_LEVEL:
            continue
        raw[col] = _numeric_column(
            raw[col], col, name, lambda row: f" (test {raw[TEST_LEVEL].iloc[row]!r})"
        )
    time = raw[TIME_LEVEL].astype(float)
    if time.isna().any():
        row = int(np.flatnonzero(time.isna().to_numpy())[0])
        raise ValueError(
            f"Line {_line(row)} of {name!r} (test {raw[TEST_LEVEL].iloc[row]!r}) has no value "
            "in column 'time_s': the time is missing."
        )
    dup = raw.duplicated([TEST_LEVEL, TIME_LEVEL], keep=False).to_numpy()
    if dup.any():
        rows = np.flatnonzero(dup)
        first = rows[0]
        same = rows[
            (raw[TEST_LEVEL].to_numpy()[rows] == raw[TEST_LEVEL].iloc[first])
            & (time.to_numpy()[rows] == time.iloc[first])
        ]
        raise ValueError(
            f"{name!r} has duplicate rows for test {raw[TEST_LEVEL].iloc[first]!r} at "
            f"time_s {time.iloc[first]:g}: lines " + ", ".join(str(_line(r)) for r in same) + "."
        )
    index = make_test_index(raw[TEST_LEVEL].to_numpy(dtype=object), time.to_numpy())
    frame = raw.drop(columns=list(KEYS))
    frame.index = index
    try:
        test_segments(frame)
    except ValueError as exc:
        raise ValueError(f"{name!r}: {exc} (row r of the data is line r + 2 of the file)") from None
    return frame
