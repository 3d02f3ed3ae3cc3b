"""Fuzzing greyml's CSV files (issue 26): what write_tests_csv writes, read_tests_csv
gives back exactly (test labels, column names, numbers bit for bit), or one of them
refuses it with one clear line naming what is wrong.

Each example writes a file of a few rows to a folder of its own. Test labels and
column names are drawn from any Unicode text, with the characters that CSV, pandas
and spreadsheets treat specially mixed in (spaces, line breaks, quotes, separators,
formula starts, NUL, lone surrogates); numbers from all floats, the limits of a float
(±1.7976931348623157e308, 5e-324, -0.0, subnormals), integers of 64 bits, NaN (a
missing value) and, now and then, an infinity. The oracle says beforehand whether the
frame can be written: a blank or empty label or name, a key name, a repeated name, a
lone surrogate or an infinity must be refused by name; anything else must come back
unchanged.

A second property writes cells as text, as a person or another program would: a
number must read as Python reads it (a float from the same decimal text), and any
other cell (an infinity, a number beyond a float, NaN or text) must be refused in one
line naming the column, the line and the test.
"""

import math
import re
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from greyml.io import read_tests_csv, write_tests_csv

ROUND_TRIP_EXAMPLES = 2000
CELL_EXAMPLES = 400

FUZZ = settings(
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
    database=None,
)

#: Characters and strings CSV, pandas or spreadsheets treat specially.
SPECIAL = [
    " ",
    "\t",
    "\n",
    "\r",
    "\r\n",
    '"',
    '""',
    ",",
    ";",
    "'",
    "=",
    "+",
    "-",
    "@",
    "#",
    "\\",
    "\x00",
    "\x1f",
    "\x85",
    "\xa0",
    "\u2028",
    "\u3000",
    "\ufeff",
    "nan",
    "NA",
    "inf",
    "1e400",
    "-0",
    "",
]
KEYS = ["test", "time_s"]

piece = st.one_of(
    st.text(max_size=3),
    st.sampled_from(SPECIAL),
    st.characters(codec="utf-8"),
)


@st.composite
def text(draw):
    """A label or name: a few pieces; now and then a key name, a lone surrogate, or
    one that is empty or blank."""
    kind = draw(st.integers(0, 79))
    if kind == 0:
        return draw(st.sampled_from(KEYS))
    if kind == 1:
        return draw(st.characters(categories=["Cs"])) + draw(piece)
    if kind == 2:
        return draw(st.sampled_from(["", " ", "\t", "\r\n", "\u3000 \x85"]))
    joined = "".join(draw(st.lists(piece, min_size=1, max_size=4)))
    return joined if joined.strip() else joined + draw(st.sampled_from(["x", "\u00e9", "1"]))


#: The limits of a float64.
LIMITS = [
    1.7976931348623157e308,
    -1.7976931348623157e308,
    5e-324,
    -5e-324,
    2.2250738585072014e-308,  # the smallest normal
    2.225073858507201e-308,  # the largest subnormal
    -0.0,
    0.0,
    math.nan,
]
number = st.one_of(
    st.sampled_from(LIMITS),
    st.floats(allow_infinity=False),
    st.floats(min_value=-2.2250738585072014e-308, max_value=2.2250738585072014e-308),
)


@st.composite
def frames(draw):
    """A frame of 1-3 tests of 1-3 rows, 1-3 columns (floats or int64), and the faults
    the oracle expects the writer to name (empty when it must write it)."""
    # repeats dropped rather than filtered out while drawing: cheaper
    labels = list(dict.fromkeys(draw(st.lists(text(), min_size=1, max_size=3))))
    names = list(dict.fromkeys(draw(st.lists(text(), min_size=1, max_size=3))))
    if draw(st.integers(0, 19)) == 0:  # now and then a name twice
        names.append(names[0])
    # times within ±1e307, so that the steps between them stay finite (segments_by_test
    # takes np.diff of the times, which overflows near the largest float)
    time = st.one_of(
        st.sampled_from([-0.0, 5e-324, -5e-324, 2.225073858507201e-308, 1e307, -1e307]),
        st.floats(-1e307, 1e307),
    )
    sizes, times = [], []
    for _ in labels:
        drawn = sorted(set(draw(st.lists(time, min_size=1, max_size=3))))
        sizes.append(len(drawn))
        times += drawn
    n = len(times)
    columns = {}
    for k, _ in enumerate(names):
        if draw(st.integers(0, 4)) == 0:
            cells = draw(st.lists(st.integers(-(2**63), 2**63 - 1), min_size=n, max_size=n))
            columns[k] = np.array(cells, dtype=np.int64)
        else:
            cells = draw(st.lists(number, min_size=n, max_size=n))
            if draw(st.integers(0, 24)) == 0:  # now and then an infinity
                cells[draw(st.integers(0, n - 1))] = draw(st.sampled_from([math.inf, -math.inf]))
            columns[k] = np.array(cells, dtype=np.float64)
    frame = pd.DataFrame(columns)
    # Python strings (pandas with pyarrow stores text as UTF-8, which a lone surrogate
    # is not): the writer must refuse them, whatever pandas could hold
    frame.columns = pd.Index(names, dtype=object)
    tests = pd.Index(np.repeat(np.array(labels, dtype=object), sizes), dtype=object)
    frame.index = pd.MultiIndex.from_arrays([tests, times], names=KEYS)
    return frame, _faults(labels, names, frame)


def _text_fault(value):
    if value.strip() == "":
        return True
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        return True
    return False


def _faults(labels, names, frame):
    """What the writer must name: reprs of bad labels and names, and 'inf' for infinities."""
    faults = [repr(t) for t in labels if _text_fault(t)]
    faults += [repr(c) for c in names if _text_fault(c) or c in KEYS or names.count(c) > 1]
    for c in range(frame.shape[1]):
        values = frame.iloc[:, c].to_numpy()
        if values.dtype.kind == "f" and np.isinf(values).any():
            faults.append("inf")
    return faults


def assert_one_clear_line(message, names_one_of):
    assert message and "\n" not in message and "\r" not in message, message
    assert "Traceback" not in message and not re.search(r'File "|ufunc|numpy\.core', message)
    assert any(name in message for name in names_one_of), (names_one_of, message)


def _same_floats(a, b):
    """Equal bit for bit, NaN (a missing value, written as an empty cell) as NaN."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    nan = np.isnan(a)
    return np.array_equal(nan, np.isnan(b)) and np.array_equal(
        a[~nan].view(np.int64), b[~nan].view(np.int64)
    )


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


@settings(FUZZ, max_examples=ROUND_TRIP_EXAMPLES)
@given(case=frames())
def test_written_files_read_back_exactly_or_are_refused(folder, case):
    frame, faults = case
    with tempfile.TemporaryDirectory(dir=folder) as where:
        path = Path(where) / "tests.csv"
        try:
            write_tests_csv(frame, path)
        except ValueError as exc:
            assert faults, f"refused a frame it can write: {exc}"
            assert_one_clear_line(str(exc), faults)
            assert not path.exists()
            event("refused by write_tests_csv")
            return
        assert not faults, f"wrote a frame with {faults}"
        event("read back")
        awkward = [
            t
            for t in [*frame.columns, *set(frame.index.get_level_values("test"))]
            if t != t.strip() or re.search('[\r\n",]', t)
        ]
        if awkward:
            event("read back, with a label or name that is quoted")
        back = read_tests_csv(path)
    assert (
        back.index.get_level_values("test").tolist()
        == frame.index.get_level_values("test").tolist()
    )
    assert back.columns.tolist() == frame.columns.tolist()
    assert _same_floats(
        back.index.get_level_values("time_s"), frame.index.get_level_values("time_s")
    )
    for k in range(frame.shape[1]):
        written, read = frame.iloc[:, k], back.iloc[:, k]
        assert read.dtype == written.dtype, (frame.columns[k], read.dtype, written.dtype)
        if written.dtype.kind == "i":
            assert read.tolist() == written.tolist()
        else:
            assert _same_floats(read, written), (written.tolist(), read.tolist())


# -- cells written as text ------------------------------------------------------

DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


@st.composite
def decimal_text(draw):
    """A number in decimal notation, of a few digits or of hundreds (repeated)."""
    digits = st.text("0123456789", min_size=1, max_size=4)
    whole = draw(digits) * draw(st.sampled_from([1, 1, 1, 80, 100, 120]))
    point = draw(st.sampled_from(["", ".", "." + draw(digits) * draw(st.integers(1, 120))]))
    if draw(st.booleans()) and point[1:]:
        whole = ""
    exponent = draw(st.sampled_from(["", "e", "E"]))
    if exponent:
        exponent += draw(st.sampled_from(["", "+", "-"])) + str(draw(st.integers(0, 999)))
    return draw(st.sampled_from(["", "+", "-"])) + whole + point + exponent


cell = st.one_of(
    decimal_text(),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.floats(min_value=-2.2250738585072014e-308, max_value=2.2250738585072014e-308).map(repr),
    st.integers(-(2**70), 2**70).map(str),
    st.sampled_from(
        ["inf", "-inf", "+inf", "Infinity", "-INF", "nan", "NaN", "1e400", "-1e400", "1e-400"]
        + ["", " ", "1_000", "0x10", "hot", "1,5", "\u0661\u0662", "1e", ".", "--1", "1.5.2"]
    ),
    st.text(max_size=4),
)


def _quoted(value):
    if value != value.strip() or any(c in value for c in ',"\r\n'):
        return '"' + value.replace('"', '""') + '"'
    return value


@settings(FUZZ, max_examples=CELL_EXAMPLES)
@given(value=cell, row=st.integers(0, 2), column=st.sampled_from(["T1_C", "dz_um"]))
def test_a_cell_as_text_reads_as_its_number_or_is_refused(folder, value, row, column):
    cells = [["20.5", "0"], ["21", "1.5"], ["22", "3"]]
    cells[row][column == "dz_um"] = _quoted(value)
    content = "test,time_s,T1_C,dz_um\n" + "".join(
        f"A,{60 * k},{a},{b}\n" for k, (a, b) in enumerate(cells)
    )
    stripped = value.strip()
    number = DECIMAL.fullmatch(stripped) is not None
    with tempfile.TemporaryDirectory(dir=folder) as where:
        path = Path(where) / "cells.csv"
        path.write_text(content, encoding="utf-8", newline="")
        try:
            back = read_tests_csv(path)
        except ValueError as exc:
            message = str(exc)
            assert_one_clear_line(message, [f"Column {column!r}"])
            assert f"at line {row + 2} (test 'A')" in message, message
            assert not (number and math.isfinite(float(stripped))), message
            if number:
                assert "too large for a float" in message, message
            event("refused by read_tests_csv")
            return
    event("read")
    got = back[column].iloc[row]
    if stripped == "":
        assert math.isnan(got)
        return
    assert number and math.isfinite(float(stripped)), f"read {value!r} as {got!r}"
    if back[column].dtype.kind in "iu":
        assert int(got) == int(stripped)
    else:
        assert _same_floats([got], [float(stripped)]), (value, got)


@pytest.mark.parametrize(
    "text",
    [
        "+" + "1" * 80,  # pd.to_numeric: 1.1111111111111113e+79
        "74.4e59",  # pd.to_numeric: 7.439999999999999e+60
        "+344004806608440426935413848863857262126144287750063.69",
        "-7979873.87e-267",
    ],
)
def test_a_column_beside_an_integer_beyond_64_bits_reads_each_cell_exactly(tmp_path, text):
    """An integer beyond 64 bits makes pandas hand the column over as text; every
    other cell of it must still read as Python's float of its text, bit for bit."""
    big = "1" + "0" * 25
    path = tmp_path / "cells.csv"
    path.write_text(f"test,time_s,dz_um\nA,0,{big}\nA,60,{text}\n", encoding="utf-8")
    back = read_tests_csv(path)["dz_um"].to_numpy()
    assert back[0] == float(big)
    assert back[1] == float(text)
    assert back[1].hex() == float(text).hex()
