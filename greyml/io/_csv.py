"""Reading and writing greyml's test-data layout as CSV.

The layout: one row per sample, the key columns ``test`` (label of the
heating/cooling test) and ``time_s`` (seconds from that test's start) first,
then numeric data columns (operating inputs ``spindle_rpm``, ``feed_mm_min``,
``c_rpm``, ``ambient_C``; sensors ``T<k>_C``, ``FBG<k>_ue``; targets ``dx_um``,
``dy_um``, ``dz_um``). Rows of one test are contiguous and in strictly
increasing time. In memory the two key columns become the ``(test, time_s)``
row index (:func:`greyml._sequences.make_test_index`).

Files from spreadsheets are read as they are: a UTF-8 byte-order mark is
skipped, ``;``- or tab-separated files and decimal commas are detected (or
named with ``sep=`` and ``decimal=``). Text cells that a spreadsheet would run
as a formula (a test label or column name starting with ``=``, ``+``, ``-``,
``@``, a tab or a carriage return) are written with a leading ``'`` and read
back without it. A label or name with white space around it, a comma, a quote
or a line break is written in quotes; a quoted cell is read as written, an
unquoted one without the spaces around it, so that what
:func:`write_tests_csv` writes reads back unchanged.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from greyml._atomic import write_atomic
from greyml._sequences import TEST_LEVEL, TIME_LEVEL, make_test_index, segments_by_test
from greyml._time import TIME_UNITS  # the units time_unit= accepts
from greyml._validation import check_unique_columns
from greyml.io._csv_numbers import _data_columns, _read_wide
from greyml.io._csv_records import (
    _check_line_lengths,
    _decimal,
    _header,
    _label_fields,
    _RowLines,
)
from greyml.io._csv_text import (  # noqa: F401 (the module's constants, re-exported)
    _DECIMAL_COMMA,
    _ESCAPED_FORMULA,
    _FORMULA_START,
    _NUMBER,
    _SEPARATORS,
    _SHOWN_CHARS,
    KEYS,
    WIDE_COLUMNS,
    _line,
    _unneutralise,
    neutralise_cell,
)

__all__ = ["read_tests_csv", "write_tests_csv", "check_test_frame"]


#: Longest line (bytes) :func:`read_tests_csv` reads by default: 16 MiB, over
#: 500,000 columns of numbers. A longer line is not a row of tests (a file of
#: one huge line would otherwise take all memory).
MAX_LINE_BYTES = 16 * 2**20

#: Most columns :func:`read_tests_csv` reads by default. Counted in the header
#: before any value is read: a wider file is refused in one line (a file of
#: 1,000,000 columns kept ``greyml select`` busy for minutes before).
MAX_COLUMNS = 100_000

#: Rows :func:`write_tests_csv` formats at a time.
_WRITE_ROWS = 2**16


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
    for c, dtype in zip(frame.columns, frame.dtypes):
        if pd.api.types.is_complex_dtype(dtype):
            raise ValueError(
                f"Column {c!r} of {lower} holds complex numbers (dtype {dtype}); every "
                "data column must hold real numbers."
            )
        if not (pd.api.types.is_numeric_dtype(dtype) and not pd.api.types.is_bool_dtype(dtype)):
            raise ValueError(
                f"Column {c!r} of {lower} is not numeric (non-numeric dtype {dtype}); every "
                "data column must hold numbers."
            )
    segments_by_test(frame)
    return frame


def write_tests_csv(frame, path, *, overwrite=False):
    """Write test data to a CSV file.

    Floats are written with the shortest representation that reads back to
    the same double, so :func:`read_tests_csv` returns the same numbers (NaN,
    a missing value, as an empty cell). Test labels and column names read
    back unchanged: one with white space around it, a comma, a quote or a
    line break is quoted, and one a spreadsheet would run as a formula gets a
    leading ``'`` (:func:`neutralise_cell`).

    Parameters
    ----------
    frame : DataFrame
        Indexed by ``(test, time_s)``; see :func:`check_test_frame`.
    path : str or path-like
        File to create.
    overwrite : bool, default=False
        Replace ``path`` if it is a regular file. Without it an existing file
        is never touched; a folder, symbolic link, named pipe or device is
        never replaced.

    Returns
    -------
    path : pathlib.Path

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is false.
    ValueError
        If ``frame`` does not follow the layout, a test label or column name
        is empty, blank (only white space) or holds a lone surrogate (not
        UTF-8), or a value is infinite: a file would not give them back.
        Nothing is written then. Also if something that is not a regular
        file is at ``path``.

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
    write = _csv_writer(frame)
    # written to a file beside path, then renamed: a failure leaves no partial file
    write_atomic(path, write, overwrite=overwrite, newline="")
    return path


def _csv_writer(frame):
    """The function that writes ``frame`` (checked) as :func:`write_tests_csv` does to
    the text handle it is given; every refusal is raised before it is returned."""
    # the texts first: pandas with pyarrow cannot even hold a label that is not UTF-8
    # once it is a column
    extra = [n for n in frame.index.names if n not in KEYS]
    _check_texts([*extra, *frame.columns], pd.unique(frame.index.get_level_values(TEST_LEVEL)))
    out = frame.copy()
    for c, dtype in zip(out.columns, out.dtypes):
        if pd.api.types.is_float_dtype(dtype) and dtype != np.float64:
            out[c] = out[c].astype(np.float64)
    out = out.reset_index(level=[n for n in out.index.names if n not in KEYS] or None)
    out = out.reset_index()[[*KEYS, *[c for c in out.columns if c not in KEYS]]]
    _check_writable(out)
    # a label or name a spreadsheet would run as a formula gets a leading ';
    # one with spaces around it, a comma, a quote or a line break is quoted
    header = ",".join(_csv_cell(str(neutralise_cell(c))) for c in out.columns)
    codes, tests = pd.factorize(out[TEST_LEVEL])
    cells = np.array([_csv_cell(str(neutralise_cell(t))) for t in tests], dtype=object)[codes]
    body = out.iloc[:, 1:]

    def write(fh):
        fh.write(header + "\n")
        for start in range(0, len(body), _WRITE_ROWS):
            rows = body.iloc[start : start + _WRITE_ROWS].to_csv(
                header=False, index=False, lineterminator="\n"
            )
            labels = cells[start : start + _WRITE_ROWS]
            fh.writelines(f"{t},{r}\n" for t, r in zip(labels, rows.split("\n")))

    return write


def _csv_cell(text):
    """``text`` as a CSV cell: quoted (its quotes doubled) when it holds a comma, a quote
    or a line break or starts or ends with white space, so that it reads back unchanged."""
    if text != text.strip() or any(c in text for c in ',"\r\n'):
        return '"' + text.replace('"', '""') + '"'
    return text


def _text_fault(text):
    """Why ``text`` cannot be a test label or column name in a CSV file, or ''."""
    if text == "":
        return "is empty"
    if not text.strip():
        return "is blank (only white space)"
    try:
        text.encode("utf-8")
    except UnicodeEncodeError as exc:
        return (
            f"holds {text[exc.start]!r} at position {exc.start}, which UTF-8 cannot encode "
            "(a lone surrogate)"
        )
    return ""


def _check_texts(names, labels):
    """Refuse a column name or test label a CSV file would not give back: empty, blank
    or not UTF-8."""
    for c in names:
        fault = _text_fault(str(c))
        if fault:
            raise ValueError(
                f"The frame's column name {c!r} {fault}; a CSV header needs a name that "
                "reads back as written. Rename the column."
            )
    for t in labels:
        fault = _text_fault(str(t))
        if fault:
            raise ValueError(
                f"Test label {t!r} {fault}; every row of a CSV file must name its test "
                "with a label that reads back as written. Rename the test."
            )


def _check_writable(out):
    """Refuse what a CSV file would not give back: a column name or test label that is
    empty, blank or not UTF-8 (:func:`_check_texts`), and an infinity (NaN is written
    as an empty cell)."""
    _check_texts(out.columns[1:], pd.unique(out[TEST_LEVEL]))
    for c, dtype in zip(out.columns[1:], out.dtypes.iloc[1:]):
        if not pd.api.types.is_float_dtype(dtype):
            continue
        infinite = np.flatnonzero(np.isinf(out[c].to_numpy(dtype=float)))
        if infinite.size:
            row = int(infinite[0])
            test, time_s = out[TEST_LEVEL].iloc[row], out[TIME_LEVEL].iloc[row]
            what = f"The {TIME_LEVEL!r} index level" if c == TIME_LEVEL else f"Column {c!r}"
            more = f", the first of {infinite.size} infinities" if infinite.size > 1 else ""
            raise ValueError(
                f"{what} holds {out[c].iloc[row]} in test {test!r} at row {row} (time_s "
                f"{time_s:g}){more}: a CSV file of tests holds finite numbers (NaN is written "
                "as an empty cell). Replace or drop the infinities."
            )


def read_tests_csv(
    path,
    *,
    time_unit="s",
    sep=None,
    decimal=None,
    max_line_bytes=None,
    test_column=None,
    max_columns=None,
):
    """Read test data written by :func:`write_tests_csv` (or by hand, or a spreadsheet).

    Parameters
    ----------
    path : str or path-like
        CSV file with a header; columns ``test``, ``time_s`` and numeric
        data columns. Empty cells are missing values (NaN). A UTF-8
        byte-order mark (as Excel writes) is skipped. A quoted test label or
        column name is read as written between its quotes (spaces and line
        breaks kept); an unquoted one without the spaces around it.
    time_unit : {"s", "min", "h"}, default="s"
        The unit of the ``time_s`` column in the file; it is converted to
        seconds (the column keeps its name). A file in minutes read as
        seconds would make every time constant 60 times too short.
    sep : str, optional
        The separator. By default the first of ``,``, ``;`` and tab that
        splits the header into ``test`` and ``time_s``.
    decimal : {".", ","}, optional
        The decimal mark. By default ``.``, or ``,`` when the separator is
        not a comma and the first 50 data lines hold numbers like ``20,5``.
    max_line_bytes : int, optional
        The longest line read, :data:`MAX_LINE_BYTES` (16 MiB) by default; a
        longer one is an error, so a file of one huge line cannot exhaust
        memory.
    test_column : str, optional
        The column that labels the tests, when it is not called ``test``
        (a logger's ``cycle``, ``run`` or ``part``); it becomes the ``test``
        level of the index. A file whose ``time_s`` runs on across its tests
        is one recording cut into consecutive pieces, and greyml's dynamic
        models carry their state from one piece into the next.
    max_columns : int, optional
        The most columns read, :data:`MAX_COLUMNS` (100,000) by default. The
        header's columns are counted before any value is read, so a wider file
        is refused at once; a column name longer than 1,000 characters is
        refused too.

    Returns
    -------
    frame : DataFrame
        Indexed by ``(test, time_s)``; test labels are strings, ``time_s``
        floats (seconds).

    Raises
    ------
    ValueError
        With the line of the file (the header is line 1) or the column, for:
        an empty file or header, a repeated column name, a missing ``test``
        or ``time_s`` column, a missing test label or time, a value that is
        not a number (``nan`` included: leave a missing value's cell empty),
        an infinity (``inf``) or a number too large for a float (``1e400``,
        a number of 400 digits), two rows with the same test and time, time
        that does not increase within a test, a test whose rows are not
        contiguous, a line longer than ``max_line_bytes``, a header of more than
        ``max_columns`` columns or a name of over 1,000 characters, a quoted field
        that is never closed, a file that is not UTF-8, a path that is not a
        regular file (a folder, pipe or device), or an unknown ``time_unit``.

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

    A spreadsheet's file, time in minutes:

    >>> text = "\\ufefftest;time_s;T1_C\\nA;0;20,0\\nA;1;20,5\\n"
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "b.csv")
    ...     with open(p, "w", encoding="utf-8") as fh:
    ...         _ = fh.write(text)
    ...     df = read_tests_csv(p, time_unit="min")
    >>> df.index.get_level_values("time_s").tolist(), df["T1_C"].tolist()
    ([0.0, 60.0], [20.0, 20.5])

    A logger's recording, its pieces labelled in a column ``cycle`` on one clock:

    >>> text = "time_s,cycle,T1_C\\n0,1,20.0\\n15,1,20.5\\n30,2,21.0\\n"
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "c.csv")
    ...     with open(p, "w") as fh:
    ...         _ = fh.write(text)
    ...     df = read_tests_csv(p, test_column="cycle")
    >>> df.index.tolist()
    [('1', 0.0), ('1', 15.0), ('2', 30.0)]
    """
    name = os.fspath(path)
    if time_unit not in TIME_UNITS:
        raise ValueError(
            f"time_unit must be one of {', '.join(map(repr, TIME_UNITS))} (the unit of the "
            f"'time_s' column in the file); got {time_unit!r}."
        )
    if sep is not None and (not isinstance(sep, str) or len(sep) != 1 or sep in '"\r\n'):
        raise ValueError(f"sep must be one character, such as ',', ';' or a tab; got {sep!r}.")
    if decimal is not None and decimal not in (".", ","):
        raise ValueError(f"decimal must be '.' or ','; got {decimal!r}.")
    if decimal is not None and decimal == sep:
        raise ValueError(f"decimal {decimal!r} cannot also be the separator sep={sep!r}.")
    if test_column is not None and (
        not isinstance(test_column, str) or not test_column.strip() or test_column == TIME_LEVEL
    ):
        raise ValueError(
            f"test_column must name the column of test labels (not {TIME_LEVEL!r}); got "
            f"{test_column!r}."
        )
    if max_line_bytes is None:
        max_line_bytes = MAX_LINE_BYTES
    if (
        not isinstance(max_line_bytes, int)
        or isinstance(max_line_bytes, bool)
        or max_line_bytes < 1
    ):
        raise ValueError(f"max_line_bytes must be a whole number >= 1; got {max_line_bytes!r}.")
    if max_columns is None:
        max_columns = MAX_COLUMNS
    if not isinstance(max_columns, int) or isinstance(max_columns, bool) or max_columns < 3:
        raise ValueError(f"max_columns must be a whole number >= 3; got {max_columns!r}.")
    if os.path.exists(path) and not os.path.isfile(path):
        what = "a folder" if os.path.isdir(path) else "not a regular file (a pipe or device)"
        raise ValueError(f"{name!r} is {what}; give a CSV file (it is read more than once).")
    _check_line_lengths(path, name, max_line_bytes)
    test_key = TEST_LEVEL if test_column is None else test_column
    header, sep, header_lines, first_records = _header(
        path, sep, max_line_bytes, (test_key, TIME_LEVEL), max_columns
    )
    if len(header) == len(KEYS):
        raise ValueError(
            f"{name!r} has no data columns (0 features): its header holds only {', '.join(header)}."
        )
    decimal = _decimal(first_records, header, sep, name, decimal, test_key)
    if not first_records:
        raise ValueError(f"{name!r} has a header but no rows (0 samples).")
    options = dict(
        sep=sep,
        decimal=decimal,
        encoding="utf-8-sig",
        header=None,
        skiprows=1,
        skipinitialspace=True,
        keep_default_na=False,
        na_values=[""],
        low_memory=False,
    )
    position = header.index(test_key)
    try:
        # the labels are text (read alone: a dtype for one column slows the
        # whole read down with the square of the column count)
        labels = pd.read_csv(path, usecols=[position], dtype=object, **options)[position]
        positions = [k for k in range(len(header)) if k != position]
        raw = _read_wide(path, header, positions, sep, decimal)
        if raw is None or len(raw) != len(labels):
            raw = pd.read_csv(path, names=list(range(len(header))), usecols=positions, **options)
    except pd.errors.ParserError as exc:
        raise ValueError(f"{name!r} is not a well-formed CSV file: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{name!r} is not UTF-8 text ({exc.reason} at byte {exc.start}); save it as UTF-8 CSV."
        ) from None
    if raw.empty:
        raise ValueError(f"{name!r} has a header but no rows (0 samples).")
    raw.columns = [header[k] for k in positions]
    lines = _RowLines(path, sep, name, max_line_bytes, len(labels), 1 + header_lines)
    labels = labels.astype(object).where(labels.notna(), "").astype(str)
    stripped = labels.str.strip()
    if (stripped != labels).any() or labels.str.contains("[\r\n]").any():
        # a quoted label keeps its spaces; only the file tells which are quoted
        found = _label_fields(path, sep, name, position, labels.tolist(), max_line_bytes)
        if found is None:
            labels = stripped
        else:
            labels = pd.Series(found[0], index=labels.index, dtype=object)
            lines.known = found[1]
    missing = (stripped == "").to_numpy()
    if missing.any():
        row = int(np.flatnonzero(missing)[0])
        raise ValueError(
            f"Line {lines[row]} of {name!r} (data row {row}) has no test label in column "
            f"{test_key!r} (a missing test label); every row must name its test."
        )
    labels = labels.map(_unneutralise)

    def cell_text(col, row):
        """The cell of column ``col`` at data row ``row`` as written in the file."""
        at = header.index(col)
        return pd.read_csv(path, usecols=[at], dtype=object, **options)[at].iloc[row]

    time, data = _data_columns(raw, labels, name, lines, cell_text)
    time = time.astype(float) * TIME_UNITS[time_unit]
    if time.isna().any():
        row = int(np.flatnonzero(time.isna().to_numpy())[0])
        raise ValueError(
            f"Line {lines[row]} of {name!r} (test {labels.iloc[row]!r}) has no value "
            "in column 'time_s': the time is missing."
        )
    if np.isinf(time).any():  # finite in the file's unit, beyond a float in seconds
        row = int(np.flatnonzero(np.isinf(time).to_numpy())[0])
        raise ValueError(
            f"Line {lines[row]} of {name!r} (test {labels.iloc[row]!r}) holds a time too "
            f"large for a float in seconds ({cell_text(TIME_LEVEL, row).strip()} "
            f"{time_unit})."
        )
    keys = pd.DataFrame({TEST_LEVEL: labels.to_numpy(), TIME_LEVEL: time.to_numpy()})
    dup = keys.duplicated(keep=False).to_numpy()
    if dup.any():
        rows = np.flatnonzero(dup)
        first = rows[0]
        same = rows[
            (labels.to_numpy()[rows] == labels.iloc[first])
            & (time.to_numpy()[rows] == time.iloc[first])
        ]
        raise ValueError(
            f"{name!r} has duplicate rows for test {labels.iloc[first]!r} at "
            f"time_s {time.iloc[first]:g}: lines " + ", ".join(str(lines[r]) for r in same) + "."
        )
    frame = data
    frame.index = make_test_index(labels.to_numpy(dtype=object), time.to_numpy())
    try:
        segments_by_test(frame)
    except ValueError as exc:
        if np.array_equal(lines.all(), np.arange(len(labels)) + 2):
            where = "row r of the data is line r + 2 of the file"
        else:
            where = f"rows count from 0 at the first data row, line {lines[0]} of the file"
        raise ValueError(f"{name!r}: {exc} ({where})") from None
    return frame
