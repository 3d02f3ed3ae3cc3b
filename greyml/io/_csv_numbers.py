"""The numbers of a CSV file of tests: columns as floats, cells that are not numbers.

Every cell that is not a finite float64 (text, ``inf``, a number too large for
a float) is refused in one line naming the column, the line and the test.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
from pandas.api.types import is_numeric_dtype

from greyml._sequences import TIME_LEVEL
from greyml.io._csv_text import _DECIMAL_COMMA, _NUMBER, _SHOWN_CHARS, WIDE_COLUMNS, _line


def _shown(text) -> str:
    """A cell's text for a message: its repr, the middle left out when it is long."""
    text = str(text)
    if len(text) <= _SHOWN_CHARS:
        return repr(text)
    return f"{text[:24] + '…' + text[-8:]!r} ({len(text):,} characters)"


def _not_finite(col, name, text, line, where=""):
    """The error for a cell holding an infinity or a number beyond a float.

    ``1e400`` or a number of 400 digits is named by its size (the digits are
    shown shortened): a float reads it as infinity, which the file does not
    mean."""
    text = str(text).strip()
    rule = (
        "every data column (sensor, input or target) must hold finite numbers, an empty "
        "cell for a missing value."
    )
    if _NUMBER.match(text):
        digits = sum(c.isdigit() for c in text)
        shown = repr(text) if len(text) <= 24 else f"{text[:4]}…{text[-3:]}, {digits:,} digits"
        return ValueError(
            f"Column {col!r} of {name!r} holds a number too large for a float ({shown}) at "
            f"line {line}{where}; a float holds at most about 1.8e308, and {rule}"
        )
    return ValueError(
        f"Column {col!r} of {name!r} holds {_shown(text)} at line {line}{where}, which is "
        f"not a finite number (an infinity); {rule}"
    )


def _as_floats(text: pd.Series) -> pd.Series:
    """Cells as numbers, NaN where a cell is not one; an integer beyond a float is ±inf.

    pandas reads an integer beyond 64 bits as a Python int, which
    ``pd.to_numeric`` cannot convert; such a column is converted cell by cell.
    ``pd.to_numeric`` is not correctly rounded (it reads 80 ones as
    1.1111111111111113e+79, ``74.4e59`` as 7.439999999999999e+60): it only
    tells which cells are numbers, whose values are read again with Python's
    ``float``, which is. Only a column pandas' reader could not read as
    numbers comes here."""
    try:
        is_number = pd.to_numeric(text, errors="coerce").notna().to_numpy()
    except OverflowError:  # a Python int beyond 64 bits among the cells
        is_number = np.array([isinstance(v, int) or _numeric(v) for v in text], dtype=bool)
    numbers = np.full(len(text), np.nan)
    numbers[is_number] = [_one_number(v) for v in text[is_number]]
    return pd.Series(numbers, index=text.index)


def _numeric(value):
    """Whether pandas reads the one cell ``value`` as a number."""
    return bool(pd.notna(pd.to_numeric(pd.Series([value], dtype=object), errors="coerce").iloc[0]))


def _one_number(value):
    """One cell pandas found to be a number, as the nearest float (an int beyond a float: ±inf)."""
    if isinstance(value, int):
        try:
            return float(value)
        except OverflowError:
            return np.inf if value > 0 else -np.inf
    return float(str(value).strip())


def _numeric_column(values: pd.Series, col, name: str, context=lambda row: "", lines=None):
    """A CSV column as floats (empty cells NaN).

    A cell that is text, an infinity or a number beyond a float raises,
    naming the column, the file, the line (``lines[row]``, or row + 2) and
    ``context(row)``. A column pandas read as numbers is returned as it is."""
    if pd.api.types.is_numeric_dtype(values.dtype):
        return values
    text = values.astype(object)
    present = (text.notna() & (text.astype(str).str.strip() != "")).to_numpy()
    numbers = _as_floats(text.where(present))
    values_ = numbers.to_numpy(copy=True)
    suspects = np.flatnonzero((present & np.isnan(values_)) | np.isinf(values_))
    for row in map(int, suspects):
        cell = str(text.iloc[row]).strip()
        line = _line(row) if lines is None else int(lines[row])
        if np.isnan(values_[row]):
            if not _NUMBER.match(cell) or "," in cell:
                raise ValueError(
                    f"Column {col!r} of {name!r} holds {_shown(cell)} at line {line}"
                    f"{context(row)}, which is not a number: non-numeric text"
                    f"{_what_text(cell)}; every data column must hold numbers."
                )
            # a number pandas gave up on (too many digits for an integer)
            values_[row] = float(cell)
        if np.isinf(values_[row]):
            raise _not_finite(col, name, cell, line, context(row))
    return pd.Series(values_, index=values.index, name=values.name)


def _what_text(text) -> str:
    """What a non-number cell seems to be, for the message: '' or ' (a complex number)'."""
    text = str(text).strip()
    if _DECIMAL_COMMA.match(text):
        return " (a decimal comma; pass decimal=',' or --decimal ,)"
    if text.lower() in ("nan", "-nan", "+nan", "na", "n/a", "null", "none"):
        return " (a missing value; leave the cell empty)"
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


def _number_or_nan(text):
    """A cell of a wide file: a finite number, or NaN when empty.

    Anything else raises ValueError, leaving the file to pandas' reader and
    its messages: an infinity, a number beyond a float and what Python reads
    but a CSV cell does not hold (``1_000``, digits of other scripts)."""
    text = text.strip()
    if not text:
        return np.nan
    if "_" in text or not text.isascii():
        raise ValueError(text)
    value = float(text)
    if not np.isfinite(value):
        raise ValueError(text)
    return value


def _read_wide(path, header, positions, sep, decimal):
    """The columns at ``positions`` of a wide file of plain numbers, or None.

    With :data:`WIDE_COLUMNS` columns or more, a decimal point and no text
    cell, NumPy's parser reads the file in one 2-D float64 array (empty cells
    NaN); any other file (or any cell NumPy cannot read, or reads as an
    infinity or NaN) is left to pandas.
    """
    if len(header) < WIDE_COLUMNS or decimal != ".":
        return None
    options = dict(
        delimiter=sep,
        skiprows=1,
        usecols=positions,
        dtype=np.float64,
        ndmin=2,
        encoding="utf-8-sig",
        comments=None,
        quotechar='"',
    )
    try:
        values = np.loadtxt(path, **options)
        if not np.isfinite(values).all():  # 'inf', 'nan' or 1e400: pandas names them
            return None
    except (ValueError, UnicodeDecodeError):
        try:  # empty cells are missing values: slower, still linear
            values = np.loadtxt(path, converters=_number_or_nan, **options)
        except (ValueError, UnicodeDecodeError):
            return None
    return pd.DataFrame(values, columns=positions, copy=False)


def _data_columns(raw, labels, name, lines, cell_text):
    """The time and the data columns of ``raw`` as numbers, in time linear in their count.

    pandas' reader gives one block per column, and removing a column from a
    frame splits its blocks: operations on such frames cost time growing with
    the square of the column count. So the frame is built once, without the
    time: from one 2-D array when the columns share a dtype (the usual case),
    else from the columns one by one, text columns converted to numbers.

    A cell that is not a finite number raises, naming the column, the line
    (``lines[row]``) and the test; ``cell_text(column, row)`` is the cell as
    written in the file, for the message.
    """
    where = lambda row: f" (test {labels.iloc[row]!r})"  # noqa: E731
    names = list(raw.columns)
    at = names.index(TIME_LEVEL)
    del names[at]
    dtypes = list(raw.dtypes)
    data_dtypes = set(dtypes[:at] + dtypes[at + 1 :])
    if len(data_dtypes) == 1 and all(is_numeric_dtype(dt) for dt in dtypes):
        (dtype,) = data_dtypes
        if dtype == np.float64 or all(dt == dtype for dt in dtypes):
            values = raw.to_numpy(dtype=np.float64 if dtype == np.float64 else dtype)
            _check_finite(values, list(raw.columns), name, lines, cell_text, where)
            time = pd.Series(values[:, at], name=TIME_LEVEL)
            data = pd.DataFrame(np.delete(values, at, axis=1), columns=names, copy=False)
            return time, data
    columns = {}
    for col, values in raw.items():
        if not is_numeric_dtype(values.dtype):
            values = _numeric_column(values, col, name, where, lines)
        values = values.to_numpy()
        _check_finite(values[:, None], [col], name, lines, cell_text, where)
        columns[col] = values
    time = pd.Series(columns.pop(TIME_LEVEL), name=TIME_LEVEL)
    return time, pd.DataFrame(columns, copy=False)


def _check_finite(values, columns, name, lines, cell_text, where):
    """Raise for the first infinity of the 2-D ``values`` (NaN, an empty cell, is allowed)."""
    if values.dtype.kind != "f":
        return
    infinite = np.isinf(values)
    if not infinite.any():
        return
    k = int(np.flatnonzero(infinite.any(axis=0))[0])
    row = int(np.flatnonzero(infinite[:, k])[0])
    col = columns[k]
    raise _not_finite(col, name, cell_text(col, row), int(lines[row]), where(row))
