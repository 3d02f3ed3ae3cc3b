"""Reading the records of a CSV file of tests: lines, fields, quoting, the header.

A small tokenizer reads the header and the first records, so that a quoted
label or column name reads exactly as written (see :mod:`greyml.io._csv`).
"""

from __future__ import annotations

import functools
import itertools
import os
import re

import numpy as np

from greyml._sequences import TEST_LEVEL, TIME_LEVEL
from greyml.io._csv_text import (
    _DECIMAL_COMMA,
    _SEPARATORS,
    KEYS,
    _unneutralise,
)


def _check_line_lengths(path, name, max_line_bytes):
    """Refuse a file with a line longer than ``max_line_bytes``, reading it in chunks."""
    line = 1  # the line the next byte belongs to
    run = 0  # bytes of that line seen so far
    with open(path, "rb") as fh:
        while chunk := fh.read(2**20):
            ends = np.flatnonzero(np.frombuffer(chunk, dtype=np.uint8) == 10)
            lengths = np.diff(ends, prepend=-1) - 1
            if ends.size:
                lengths[0] += run
                long = np.flatnonzero(lengths > max_line_bytes)
                if long.size:
                    _too_long(name, line + int(long[0]), max_line_bytes)
                line += ends.size
                run = len(chunk) - int(ends[-1]) - 1
            else:
                run += len(chunk)
            if run > max_line_bytes:
                _too_long(name, line, max_line_bytes)


def _too_long(name, line, max_line_bytes):
    raise ValueError(
        f"Line {line} of {name!r} is longer than {max_line_bytes:,} bytes (max_line_bytes), "
        "too long for a row of tests: is it a CSV file of tests, one sample per line?"
    )


@functools.lru_cache(maxsize=8)
def _field_pattern(sep):
    """One field of a record and the separator after it (or the record's end).

    Spaces before a field are skipped (as ``skipinitialspace`` does). A field
    starting with ``"`` is quoted: group 1 is its text with quotes doubled,
    group 2 what follows the closing quote (a quote followed by a quote is a
    doubled one, never the closing one); else group 3 is the field. No match:
    a quoted field without its closing quote."""
    s = re.escape(sep)
    return re.compile(rf'[ ]*(?:"([^"]*(?:""[^"]*)*)"(?!")([^{s}]*)|(?!")([^{s}]*))({s}|\Z)', re.S)


def _split(text, sep):
    """The fields of the record ``text`` (its line end removed), or None if a quote is open.

    Each field is ``(text, after)``: ``after`` is None for an unquoted field,
    else what followed the closing quote. :func:`_value` makes a field a cell.
    """
    if '"' not in text:
        return [(field, None) for field in text.split(sep)]
    pattern = _field_pattern(sep)
    fields, at = [], 0
    while True:
        match = pattern.match(text, at)
        if match is None:
            return None
        quoted, after, plain, end = match.groups()
        fields.append((plain, None) if quoted is None else (quoted.replace('""', '"'), after))
        if not end:
            return fields
        at = match.end()


def _value(field):
    """A field as greyml reads it: an unquoted one without the spaces around it, a
    quoted one as written between its quotes (spaces after the closing quote dropped)."""
    text, after = field
    if after is None:
        return text.strip()
    return text + after.rstrip()


def _parsed(field):
    """A field as pandas' reader gives it (``skipinitialspace=True``)."""
    text, after = field
    return text.lstrip(" ") if after is None else text + after


def _records(read, sep, name, max_chars, line=1):
    """The records of CSV text, blank lines skipped: ``(line, fields)`` each.

    ``read()`` returns the next physical line ('' at the end); ``line`` is
    the number of the first. A quoted field may hold line breaks, so a record
    may span lines; ``line`` is the one it starts on (lines counted by
    ``\\n``)."""
    while text := read():
        start = line
        line += text.count("\n")
        if not text.strip(" \t\r\n"):
            continue
        while (fields := _split(text.rstrip("\r\n"), sep)) is None:
            more = read()
            if not more:
                raise ValueError(
                    f"Line {start} of {name!r} is not well-formed CSV: a quoted field (opened "
                    'by ") is never closed.'
                )
            text += more
            line += more.count("\n")
            if len(text) > max_chars:
                raise ValueError(
                    f"Line {start} of {name!r} is not well-formed CSV: a quoted field (opened "
                    f'by ") is not closed within {max_chars:,} bytes (max_line_bytes).'
                )
        yield start, fields


def _header(path, sep, max_line_bytes, keys=KEYS, max_columns=None):
    """The header's names, the separator, the header's line count and the first
    data records (up to 50, as ``(line, fields)``).

    ``keys`` are the columns that hold the test labels and the time. A header of
    more than ``max_columns`` fields (counted before any name is looked at) or a
    name longer than :data:`MAX_NAME_CHARS` is refused before a data line is read."""
    name = os.fspath(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            lines = []  # the lines read so far: each separator tried reads them anew

            def reader():
                k = 0

                def read():
                    nonlocal k
                    if k == len(lines):
                        lines.append(fh.readline(max_line_bytes + 1))
                    k += 1
                    return lines[k - 1]

                return read

            def first(candidate):
                try:
                    return next(_records(reader(), candidate, name, max_line_bytes))[1]
                except ValueError:  # a quote never closed: not this separator
                    return []

            # the header is the first line (pandas skips one line to reach the data)
            if not reader()().strip():
                raise ValueError(f"{name!r} is empty: expected a header line.")
            if sep is None:
                sep = ","
                for candidate in _SEPARATORS:
                    # so many separators that the header is refused: no keys to look for
                    wide = max_columns is not None and lines[0].count(candidate) >= max_columns
                    if wide or all(key in map(_value, first(candidate)) for key in keys):
                        sep = candidate
                        break
            if max_columns is not None and '"' not in lines[0]:  # counted, not split
                _check_columns(lines[0].count(sep) + 1, name, sep, max_columns)
            records = _records(reader(), sep, name, max_line_bytes)
            fields = next(records)[1]
            _check_columns(len(fields), name, sep, max_columns)
            _check_names(fields, name)
            data = list(itertools.islice(records, 50))
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{name!r} is not UTF-8 text ({exc.reason} at byte {exc.start}); save it as UTF-8 CSV."
        ) from None
    header = [_unneutralise(_value(f)) for f in fields]
    seen = set()
    for k, col in enumerate(header):
        if col == "":
            raise ValueError(f"Column {k + 1} of the header of {name!r} has no name.")
        if col in seen:
            raise ValueError(f"The header of {name!r} names column {col!r} more than once.")
        seen.add(col)
    for key in keys:
        if key not in seen:
            hint = ""
            if key == TEST_LEVEL:
                hint = " If another column names the tests (e.g. 'cycle'), pass test_column="
                hint += "'cycle' (--test-column cycle on the command line)."
            raise ValueError(
                f"{name!r} has no '{key}' column; the header must contain "
                f"'{keys[0]}' and '{TIME_LEVEL}' (found {header[:12]}"
                f"{'...' if len(header) > 12 else ''}; separator {sep!r}).{hint}"
            )
    if keys[0] != TEST_LEVEL and TEST_LEVEL in seen:
        raise ValueError(
            f"{name!r} has a '{TEST_LEVEL}' column as well as the test column "
            f"'{keys[0]}' named by test_column; rename one of them."
        )
    header_lines = 1 + sum(text.count("\n") for text, _ in fields)
    return header, sep, header_lines, data


#: The longest column name :func:`~greyml.io.read_tests_csv` reads, in characters.
MAX_NAME_CHARS = 1000


def _check_columns(count, name, sep, max_columns):
    """Refuse a header of ``count`` columns, more than ``max_columns``: what reading the
    file would cost is bounded before a value is read."""
    if max_columns is not None and count > max_columns:
        raise ValueError(
            f"The header of {name!r} has {count:,} columns (separator {sep!r}), more than "
            f"the {max_columns:,} a CSV file of tests may have (max_columns): is it a file "
            "of tests, one sample per line and one column per sensor?"
        )


def _check_names(fields, name):
    """Refuse a header name longer than :data:`MAX_NAME_CHARS`."""
    long = next((k for k, (text, _) in enumerate(fields) if len(text) > MAX_NAME_CHARS), None)
    if long is not None:
        raise ValueError(
            f"Column {long + 1} of the header of {name!r} has a name of "
            f"{len(fields[long][0]):,} characters, more than {MAX_NAME_CHARS:,} (starting "
            f"{fields[long][0][:40]!r})."
        )


def _decimal(records, header, sep, name, decimal, test_key=TEST_LEVEL):
    """The decimal mark: ``decimal``, or ``","`` when the first data records use it."""
    if decimal is not None:
        if decimal == sep:
            raise ValueError(f"decimal {decimal!r} cannot also be the separator {sep!r}.")
        return decimal
    found = "."
    for line, fields in records:
        cells = [_value(f) for f in fields]
        if len(cells) > len(header):
            hint = ""
            if sep == ",":
                hint = (
                    "; if its numbers have decimal commas (20,5), save the file with ';' "
                    "as the separator or '.' as the decimal mark"
                )
            raise ValueError(
                f"Line {line} of {name!r} has {len(cells)} fields but the header has "
                f"{len(header)} (separator {sep!r}){hint}."
            )
        if sep != "," and any(
            _DECIMAL_COMMA.match(c) for j, c in enumerate(cells) if header[j] != test_key
        ):
            found = ","
    return found


class _RowLines:
    """The line of the file each data row starts on, looked up when a message names it.

    Data row r starts on line r + ``first`` unless blank lines or line breaks
    inside quoted cells come before it; the first look-up reads the file
    again to find out (only a message needs it). ``known`` are the lines when
    found already."""

    def __init__(self, path, sep, name, max_line_bytes, n_rows, first):
        self.path, self.sep, self.name = path, sep, name
        self.max_line_bytes, self.n_rows, self.first = max_line_bytes, n_rows, first
        self.known = None

    def all(self):
        if self.known is None:
            starts = []
            try:
                with open(self.path, newline="", encoding="utf-8-sig") as fh:
                    records = _records(fh.readline, self.sep, self.name, self.max_line_bytes)
                    starts = [line for line, _ in itertools.islice(records, 1, None)]
            except (OSError, ValueError):
                pass
            if len(starts) != self.n_rows:  # not as pandas split it: count the rows
                starts = range(self.first, self.first + self.n_rows)
            self.known = np.asarray(starts)
        return self.known

    def __getitem__(self, row):
        return int(self.all()[row])


def _label_fields(path, sep, name, position, parsed, max_line_bytes):
    """Test labels as greyml reads them and the line each data row starts on.

    ``parsed`` are the labels as pandas read them (in row order). A quoted
    label keeps its spaces and line breaks, an unquoted one is stripped.
    Returns None when the file does not split into the same records (a file
    pandas reads leniently, such as one with a stray quote): the caller then
    strips every label."""
    labels, lines = [], []
    with open(path, newline="", encoding="utf-8-sig") as fh:
        records = _records(fh.readline, sep, name, max_line_bytes)
        next(records, None)  # the header
        for record, expected in itertools.zip_longest(records, parsed):
            if record is None or expected is None or len(record[1]) <= position:
                return None
            line, fields = record
            field = fields[position]
            if _parsed(field) != expected:
                return None
            labels.append(_value(field))
            lines.append(line)
    if len(labels) != len(parsed):
        return None
    return labels, np.asarray(lines)
