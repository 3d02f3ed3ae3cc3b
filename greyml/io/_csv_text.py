"""The text of greyml's CSV files: key columns, separators, number patterns, formulas.

Shared by the reader's records (:mod:`greyml.io._csv_records`), its numbers
(:mod:`greyml.io._csv_numbers`) and the writer (:mod:`greyml.io._csv`).
"""

from __future__ import annotations

import re

from greyml._sequences import TEST_LEVEL, TIME_LEVEL

KEYS = (TEST_LEVEL, TIME_LEVEL)

#: From this many columns on, a file of plain numbers is read with NumPy's
#: parser (every data column float64): pandas' reader spends time per column
#: that grows faster than the column count.
WIDE_COLUMNS = 1000

#: Separators tried when ``sep`` is not given, the usual one first.
_SEPARATORS = (",", ";", "\t")

#: A text cell starting with one of these is run as a formula by spreadsheets.
_FORMULA_START = re.compile(r"^'*[=+\-@\t\r]")
_ESCAPED_FORMULA = re.compile(r"^'(?='*[=+\-@\t\r])")

#: A number written with a decimal comma: ``20,5``, ``-0,25``, ``1,5e-3``.
_DECIMAL_COMMA = re.compile(r"^[+-]?\d*,\d+([eE][+-]?\d+)?$")

#: A number in decimal notation, with a decimal point or comma: ``20``, ``-1.5e3``.
_NUMBER = re.compile(r"^[+-]?(\d+[.,]?\d*|[.,]\d+)([eE][+-]?\d+)?$")

#: Text of a cell shown whole in a message; a longer one is shortened.
_SHOWN_CHARS = 40


def neutralise_cell(text):
    """``text`` with a leading ``'`` if a spreadsheet would run it as a formula.

    Cells starting with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return
    (after any ``'``) get one more ``'``; :func:`read_tests_csv` removes it
    again, so labels read back unchanged. Non-text values are returned as they
    are: a negative number is a number, not a formula.
    """
    if isinstance(text, str) and _FORMULA_START.match(text):
        return "'" + text
    return text


def _unneutralise(text):
    if isinstance(text, str):
        return _ESCAPED_FORMULA.sub("", text, count=1)
    return text


def _line(row: int) -> int:
    """File line of data row ``row`` (0-based): the header is line 1."""
    return int(row) + 2
