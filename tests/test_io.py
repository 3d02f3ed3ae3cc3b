"""CSV reading and writing of greyml's test-data layout (issue 3)."""

import os

import numpy as np
import pandas as pd
import pytest

from greyml._sequences import make_test_index
from greyml.datasets import load_gantry_tests
from greyml.io import check_test_frame, read_tests_csv, write_tests_csv

HEADER = "test,time_s,spindle_rpm,T1_C,dz_um\n"


def write(tmp_path, text, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_round_trip_is_lossless(tmp_path):
    frame = load_gantry_tests().frame
    path = write_tests_csv(frame, tmp_path / "gantry.csv")
    back = read_tests_csv(path)
    assert back.equals(frame)
    assert list(back.index.get_level_values("test").unique()) == ["Z-axis", "C-axis", "helical"]


def test_round_trip_awkward_values(tmp_path):
    rng = np.random.default_rng(0)
    n = 50
    frame = pd.DataFrame(
        {
            "T1_C": rng.standard_normal(n) * 1e-7,
            "dz_um": rng.standard_normal(n) * 1e6,
            "spindle_rpm": rng.integers(0, 9000, n),
            "FBG1_ue": np.where(rng.random(n) < 0.2, np.nan, rng.random(n)),
            "T2_C": rng.standard_normal(n).astype(np.float32).astype(np.float64),
        },
        index=make_test_index(
            ["a, b"] * 20 + ["7"] * 30, np.r_[np.arange(20) * 0.1, np.arange(30) / 3]
        ),
    )
    back = read_tests_csv(write_tests_csv(frame, tmp_path / "x.csv"))
    assert back.equals(frame)


def test_never_overwrites(tmp_path):
    frame = load_gantry_tests().frame.iloc[:5]
    path = write(tmp_path, "keep me\n")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_tests_csv(frame, path)
    assert path.read_text() == "keep me\n"
    write_tests_csv(frame, path, overwrite=True)
    assert read_tests_csv(path).equals(frame)


@pytest.mark.parametrize(
    "text, match",
    [
        ("", "empty"),
        ("time_s,T1_C\n0,20\n", "no 'test' column"),
        ("test,T1_C\nA,20\n", "no 'time_s' column"),
        ("test,time_s,T1_C,T1_C\nA,0,1,2\n", "column 'T1_C' more than once"),
        ("test,time_s,,T1_C\nA,0,1,2\n", "Column 3 of the header"),
        (HEADER, "no rows"),
        (HEADER + "A,0,0,20.0,0\nA,60,0,hot,0\n", "Column 'T1_C' .* 'hot' at line 3"),
        (HEADER + "A,0,0,20.0,0\nA,x,0,20.1,0\n", "Column 'time_s' .* 'x' at line 3"),
        (HEADER + "A,0,0,20.0,0\n,60,0,20.1,0\n", "Line 3 .* no test label"),
        (HEADER + "A,0,0,20.0,0\nA,,0,20.1,0\n", "Line 3 .* no value in column 'time_s'"),
        (
            HEADER + "A,0,0,20,0\nA,60,0,20,0\nA,60,0,20,0\n",
            "duplicate rows for test 'A' at time_s 60: lines 3, 4",
        ),
        (
            HEADER + "A,0,0,20,0\nA,120,0,20,0\nA,60,0,20,0\n",
            "Time does not increase within test 'A'.*row 2",
        ),
        (HEADER + "A,0,0,20,0\nB,0,0,20,0\nA,60,0,20,0\n", "Test 'A' appears in two separate runs"),
    ],
)
def test_malformed_files(tmp_path, text, match):
    path = write(tmp_path, text)
    with pytest.raises(ValueError, match=match):
        read_tests_csv(path)


def test_missing_values_are_nan(tmp_path):
    path = write(tmp_path, HEADER + "A,0,0,,0\nA,60,1000,20.5,1.5\n")
    frame = read_tests_csv(path)
    assert np.isnan(frame["T1_C"].iloc[0]) and frame["dz_um"].iloc[1] == 1.5


def test_write_checks_the_frame(tmp_path):
    good = pd.DataFrame({"T1_C": [20.0, 20.1]}, index=make_test_index(["A", "A"], [0, 10]))
    with pytest.raises(ValueError, match="no 'test' index level"):
        write_tests_csv(good.reset_index(level="test", drop=True), tmp_path / "a.csv")
    with pytest.raises(ValueError, match="Column 'note' .* not numeric"):
        write_tests_csv(good.assign(note=["x", "y"]), tmp_path / "b.csv")
    backwards = pd.DataFrame({"T1_C": [20.0, 20.1]}, index=make_test_index(["A", "A"], [10, 0]))
    with pytest.raises(ValueError, match="Time does not increase"):
        write_tests_csv(backwards, tmp_path / "c.csv")
    with pytest.raises(ValueError, match="key name"):
        check_test_frame(good.assign(time_s=1.0))
    assert not (tmp_path / "a.csv").exists()


# ------------------------------------------------------------------------------
# Files from spreadsheets, time units, long lines, formula cells (issues 15 and 19)
# ------------------------------------------------------------------------------


def test_byte_order_mark_is_skipped(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufefftest,time_s,T1_C\nA,0,20.0\nA,60,20.5\n".encode())
    frame = read_tests_csv(path)
    assert list(frame.columns) == ["T1_C"]
    assert frame["T1_C"].tolist() == [20.0, 20.5]


@pytest.mark.parametrize("sep", [";", "\t"])
def test_other_separators_and_decimal_commas_are_detected(tmp_path, sep):
    rows = ["test|time_s|T1_C|dz_um", "A|0|20,25|-1,5", "A|60|20,75|-3,0e0", "B|0|19|0"]
    path = write(tmp_path, "\n".join(r.replace("|", sep) for r in rows) + "\n")
    frame = read_tests_csv(path)
    assert frame["T1_C"].tolist() == [20.25, 20.75, 19.0]
    assert frame["dz_um"].tolist() == [-1.5, -3.0, 0.0]
    assert frame.index.get_level_values("test").tolist() == ["A", "A", "B"]


def test_separator_and_decimal_can_be_named(tmp_path):
    path = write(tmp_path, "test;time_s;T1_C\nA;0;20.5\nA;60;21.0\n")
    assert read_tests_csv(path, sep=";", decimal=".")["T1_C"].tolist() == [20.5, 21.0]
    path = write(tmp_path, "test;time_s;T1_C\nA;0;20,5\nA;60;21\n", "b.csv")
    assert read_tests_csv(path, sep=";", decimal=",")["T1_C"].tolist() == [20.5, 21.0]
    with pytest.raises(ValueError, match=r"decimal ',' cannot also be the separator"):
        read_tests_csv(path, sep=",", decimal=",")


def test_decimal_commas_in_a_comma_separated_file_are_named(tmp_path):
    path = write(tmp_path, "test,time_s,T1_C\nA,0,20,5\nA,60,21,0\n")
    match = r"Line 2 .* 4 fields but the header has 3.*decimal commas"
    with pytest.raises(ValueError, match=match):
        read_tests_csv(path)


def test_a_quoted_decimal_comma_is_named(tmp_path):
    path = write(tmp_path, 'test,time_s,T1_C\nA,0,"20,5"\n')
    with pytest.raises(ValueError, match=r"'T1_C'.*'20,5'.*line 2.*decimal comma"):
        read_tests_csv(path)


@pytest.mark.parametrize("unit, factor", [("s", 1.0), ("min", 60.0), ("h", 3600.0)])
def test_time_unit_converts_to_seconds(tmp_path, unit, factor):
    path = write(tmp_path, "test,time_s,T1_C\nA,0,20\nA,1.5,21\nA,3,22\n")
    frame = read_tests_csv(path, time_unit=unit)
    assert frame.index.get_level_values("time_s").tolist() == [0.0, 1.5 * factor, 3 * factor]
    assert frame.index.names == ["test", "time_s"]


def test_unknown_time_unit_is_named(tmp_path):
    path = write(tmp_path, "test,time_s,T1_C\nA,0,20\n")
    with pytest.raises(ValueError, match=r"time_unit must be one of 's', 'min', 'h'.*'hours'"):
        read_tests_csv(path, time_unit="hours")


@pytest.mark.parametrize("line", [1, 3])
def test_a_line_longer_than_the_limit_is_one_error(tmp_path, line):
    rows = ["test,time_s,T1_C", "A,0,20", "A,60,21"]
    rows[line - 1] += "," + "9" * 5000
    path = write(tmp_path, "\n".join(rows) + "\n")
    with pytest.raises(ValueError, match=rf"Line {line} of .* longer than 4,096 bytes"):
        read_tests_csv(path, max_line_bytes=4096)
    ok = read_tests_csv(write(tmp_path, "test,time_s,T1_C\nA,0,20\n", "ok.csv"), max_line_bytes=16)
    assert ok["T1_C"].tolist() == [20]


def test_a_file_without_newlines_is_refused_without_reading_it_whole(tmp_path):
    path = tmp_path / "one-line.csv"
    with open(path, "wb") as fh:
        for _ in range(8):
            fh.write(b"1," * 2**19)  # 8 MiB, no newline
    with pytest.raises(ValueError, match=r"Line 1 of .* longer than 1,048,576 bytes"):
        read_tests_csv(path, max_line_bytes=2**20)


@pytest.mark.parametrize(
    "label", ["=cmd|' /C calc'!A0", "+1+1", "-2", "@SUM(A1)", "'=x", "''+y", "plain", "'quoted"]
)
def test_formula_labels_are_neutralised_and_read_back(tmp_path, label):
    frame = pd.DataFrame(
        {"T1_C": [-1.5, 2.0], "=dz_um": [-3.0, 4.0]}, index=make_test_index([label] * 2, [0, 60])
    )
    path = write_tests_csv(frame, tmp_path / "f.csv")
    cells = [line.split(",") for line in path.read_text().splitlines()]
    assert cells[0] == ["test", "time_s", "T1_C", "'=dz_um"]
    for row in cells[1:]:
        # no text cell starts like a formula; numbers (negative too) stay numbers
        assert not row[0].startswith(("=", "+", "-", "@", "\t", "\r"))
        assert row[2] in ("-1.5", "2.0")
    back = read_tests_csv(path)
    assert back.index.get_level_values("test").tolist() == [label, label]
    assert list(back.columns) == ["T1_C", "=dz_um"]
    assert back["T1_C"].tolist() == [-1.5, 2.0]


def test_a_failed_write_leaves_no_file(tmp_path, monkeypatch):
    frame = load_gantry_tests().frame.iloc[:5]

    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", fail)
    with pytest.raises(OSError, match="No space left"):
        write_tests_csv(frame, tmp_path / "out.csv")
    assert list(tmp_path.iterdir()) == []


def test_wide_files_keep_column_order_and_dtypes(tmp_path):
    n = 300
    header = "test,T0_C,time_s," + ",".join(f"c{k}" for k in range(n))
    body = "".join(
        f"A,{r}.5,{r}," + ",".join(str(k + r) for k in range(n)) + "\n" for r in range(3)
    )
    frame = read_tests_csv(write(tmp_path, header + "\n" + body))
    assert list(frame.columns) == ["T0_C", *[f"c{k}" for k in range(n)]]
    assert frame["T0_C"].tolist() == [0.5, 1.5, 2.5]
    assert frame["c7"].tolist() == [7, 8, 9]
    assert frame["c7"].dtype == np.int64 and frame["T0_C"].dtype == np.float64


@pytest.mark.parametrize("gap", [False, True])
def test_very_wide_files_read_the_same_numbers(tmp_path, gap):
    n = 1200  # past WIDE_COLUMNS: NumPy's parser, or pandas' when a cell is empty
    header = "test,time_s," + ",".join(f"c{k}" for k in range(n))
    rows = [f"A,{60 * r}," + ",".join(f"{k + r / 4}" for k in range(n)) for r in range(3)]
    if gap:
        rows[1] = rows[1].replace(",1.25,", ",,", 1)
    frame = read_tests_csv(write(tmp_path, "\n".join([header, *rows]) + "\n"))
    assert frame.shape == (3, n)
    assert frame["c7"].tolist() == [7.0, 7.25, 7.5]
    assert frame["c1"].isna().tolist() == [False, gap, False]
    assert frame.index.get_level_values("time_s").tolist() == [0.0, 60.0, 120.0]


def test_a_folder_or_pipe_is_not_read(tmp_path):
    with pytest.raises(ValueError, match=r"is a folder; give a CSV file"):
        read_tests_csv(tmp_path)
    fifo = tmp_path / "pipe.csv"
    if not hasattr(os, "mkfifo"):
        pytest.skip("no named pipes on this system")
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"not a regular file \(a pipe or device\)"):
        read_tests_csv(fifo)  # without the check, opening it would wait for a writer


# ------------------------------------------------------------------------------
# What write_tests_csv writes reads back unchanged, or is refused (issue 26, item 7a)
# ------------------------------------------------------------------------------

AWKWARD_LABELS = ["A", " A ", "A ", "A\nB", "x\r\ny", "A\r", '"q"', "a, b", "\xa0nbsp", "'=x "]
AWKWARD_NAMES = ["T1", " T1", "T1\nC", "T2\r", '"', "c,d", "\t=x", "x\u2028"]


def _awkward_frame(labels=AWKWARD_LABELS, names=AWKWARD_NAMES, objects=False):
    """A frame with these test labels and column names; with ``objects`` kept as Python
    strings (pandas with pyarrow stores text as UTF-8, which a lone surrogate is not)."""
    n = 2 * len(labels)
    values = np.arange(n * len(names), dtype=float).reshape(n, len(names)) / 7 - 3
    times = np.tile([0.0, 60.0], len(labels))
    if objects:
        tests = pd.Index(np.repeat(np.array(labels, dtype=object), 2), dtype=object)
        index = pd.MultiIndex.from_arrays([tests, times], names=["test", "time_s"])
        return pd.DataFrame(values, columns=pd.Index(names, dtype=object), index=index)
    index = make_test_index(np.repeat(labels, 2), times)
    return pd.DataFrame(values, columns=names, index=index)


def test_labels_and_names_with_spaces_and_line_breaks_read_back(tmp_path):
    frame = _awkward_frame()
    path = write_tests_csv(frame, tmp_path / "awkward.csv")
    back = read_tests_csv(path)
    assert back.equals(frame)
    assert back.index.get_level_values("test").unique().tolist() == AWKWARD_LABELS
    assert back.columns.tolist() == AWKWARD_NAMES
    text = path.read_bytes().decode()
    # quoted where needed, and only there
    assert text.startswith('test,time_s,T1," T1","T1\nC","T2\r","""","c,d",\'\t=x,"x\u2028"\n')
    assert '\n" A ",0.0,' in text and "\nA,0.0," in text and '\n"A ",0.0,' in text


def test_quoted_labels_read_back_in_a_wide_file(tmp_path):
    names = [f"c{k}" for k in range(1200)]  # NumPy's parser reads the numbers
    frame = _awkward_frame(labels=["A\nB", " C ", "D"], names=names)
    back = read_tests_csv(write_tests_csv(frame, tmp_path / "wide.csv"))
    assert back.equals(frame)


def test_spaces_around_unquoted_cells_are_still_dropped(tmp_path):
    text = (
        'test , time_s , T1_C ," T2_C "\n'
        "A    , 0      , 20.5 , 1\n"
        "A    , 60     , 21.0 , 2\n"
        '" B ", 0      , 22.0 , 3\n'
        '"C"  , 0      , 23.0 , 4\n'
    )
    frame = read_tests_csv(write(tmp_path, text))
    assert frame.index.tolist() == [("A", 0.0), ("A", 60.0), (" B ", 0.0), ("C", 0.0)]
    assert frame.columns.tolist() == ["T1_C", " T2_C "]
    assert frame["T1_C"].tolist() == [20.5, 21.0, 22.0, 23.0]


def test_line_numbers_count_the_line_breaks_inside_labels(tmp_path):
    text = 'test,time_s,"T1\nC"\n"A\nB",0,20\n"A\nB",60,21\nC,0,hot\n'
    with pytest.raises(ValueError, match=r"holds 'hot' at line 7 \(test 'C'\)") as err:
        read_tests_csv(write(tmp_path, text))
    assert "\n" not in str(err.value)
    text = 'test,time_s,T1\n"A\nB",0,20\n"A\nB",0,21\n'
    with pytest.raises(ValueError, match=r"test 'A\\nB' at time_s 0: lines 2, 4\."):
        read_tests_csv(write(tmp_path, text, "dup.csv"))


def test_a_quote_that_is_never_closed_is_one_error(tmp_path):
    path = write(tmp_path, 'test,time_s,"T1_C\nA,0,20\n')
    with pytest.raises(ValueError, match=r'Line 1 of .* quoted field \(opened by "\) is never'):
        read_tests_csv(path)


@pytest.mark.parametrize(
    "labels, names, match",
    [
        (["A", ""], ["T1_C"], r"^Test label '' is empty; "),
        (["A", "  "], ["T1_C"], r"^Test label '  ' is blank \(only white space\); "),
        (["\r\n", "B"], ["T1_C"], r"^Test label '\\r\\n' is blank"),
        (["A", "x\ud800"], ["T1_C"], r"^Test label 'x\\ud800' holds '\\ud800' at position 1, "),
        (["A"], ["T1_C", ""], r"^The frame's column name '' is empty; "),
        (["A"], [" \n"], r"^The frame's column name ' \\n' is blank"),
        (["A"], ["\udcff"], r"^The frame's column name '\\udcff' holds .* lone surrogate"),
    ],
)
def test_labels_and_names_a_file_cannot_give_back_are_refused(tmp_path, labels, names, match):
    frame = _awkward_frame(labels=labels, names=names, objects=True)
    with pytest.raises(ValueError, match=match) as err:
        write_tests_csv(frame, tmp_path / "out.csv")
    assert "\n" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------
# Numbers a float cannot hold, infinities and NaN written as text (issue 26, item 8)
# ------------------------------------------------------------------------------

BIG = "1" + "0" * 399


@pytest.mark.parametrize(
    "cell, match",
    [
        (BIG, r"holds a number too large for a float \(1000…000, 400 digits\) at line 4 "),
        ("-" + BIG + ".5", r"holds a number too large for a float \(-100…0\.5, 401 digits\) at "),
        ("9" * 5000, r"holds a number too large for a float \(9999…999, 5,000 digits\) at "),
        ("1e400", r"holds a number too large for a float \('1e400'\) at line 4 "),
        ("-1.5E+309", r"holds a number too large for a float \('-1\.5E\+309'\) at line 4 "),
        ("inf", r"holds 'inf' at line 4 \(test 'A'\), which is not a finite number"),
        ("-Infinity", r"holds '-Infinity' at line 4 \(test 'A'\), which is not a finite"),
        ("nan", r"holds 'nan' at line 4 \(test 'A'\), which is not a number: .*leave the cell"),
    ],
)
@pytest.mark.parametrize("layout", ["floats", "integers", "text", "wide"])
def test_a_cell_beyond_a_float_is_one_error(tmp_path, cell, match, layout):
    cells = {"floats": ["20.5", "21"], "integers": ["20", "21"], "text": ["20", "21"]}
    first, second = cells.get(layout, ["20.5", "21"])
    extra = ",hot" if layout == "text" else ""
    pad = "".join(f",{k}" for k in range(1000)) if layout == "wide" else ""
    header = "test,time_s,T1_C,dz_um" + ("".join(f",c{k}" for k in range(1000)) if pad else "")
    lines = [
        header + (",note" if extra else ""),
        f"A,0,{first},0{pad}" + (",1" if extra else ""),
        f"A,60,{second},1{pad}" + (",2" if extra else ""),
        f"A,120,{cell},2{pad}" + extra,
    ]
    path = write(tmp_path, "\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=rf"^Column 'T1_C' of '.*data\.csv' {match}") as err:
        read_tests_csv(path)
    assert "\n" not in str(err.value)


def test_a_time_beyond_a_float_is_one_error(tmp_path):
    path = write(tmp_path, f"test,time_s,T1_C\nA,0,20\nA,{BIG},21\n")
    match = r"^Column 'time_s' of .* too large for a float \(1000…000, 400 digits\) at line 3 "
    with pytest.raises(ValueError, match=match):
        read_tests_csv(path)
    path = write(tmp_path, "test,time_s,T1_C\nA,0,20\nA,1e306,21\n", "hours.csv")
    with pytest.raises(ValueError, match=r"Line 3 .* time too large for a float in seconds"):
        read_tests_csv(path, time_unit="h")


def test_long_numbers_a_float_can_hold_are_read(tmp_path):
    cells = ["1" + "0" * 300, "0." + "0" * 400 + "1", "2." + "5" * 500, "1" * 25]
    path = write(
        tmp_path, "test,time_s,T1_C\n" + "".join(f"A,{k},{c}\n" for k, c in enumerate(cells))
    )
    assert read_tests_csv(path)["T1_C"].tolist() == [float(c) for c in cells]


def test_write_refuses_infinities(tmp_path):
    frame = _awkward_frame(labels=["A", "B"], names=["T1_C", "dz_um"])
    frame.iloc[3, 1] = -np.inf
    frame.iloc[2, 1] = np.inf
    match = r"^Column 'dz_um' holds inf in test 'B' at row 2 \(time_s 0\), the first of 2 "
    with pytest.raises(ValueError, match=match):
        write_tests_csv(frame, tmp_path / "out.csv")
    assert list(tmp_path.iterdir()) == []
    frame.iloc[2:, 1] = np.nan  # a missing value is an empty cell
    back = read_tests_csv(write_tests_csv(frame, tmp_path / "out.csv"))
    assert back.equals(frame) and back["dz_um"].isna().tolist() == [False, False, True, True]


@pytest.fixture
def small_model(tmp_path):
    from greyml.cli import main

    rng = np.random.default_rng(0)
    rows = [
        f"{t},{10 * k},{20 + rng.random():.3f},{21 + rng.random():.3f},{rng.random():.3f}"
        for t in "AB"
        for k in range(20)
    ]
    good = write(tmp_path, "test,time_s,T1_C,T2_C,dz_um\n" + "\n".join(rows) + "\n", "good.csv")
    model = tmp_path / "m.greyml"
    args = ["fit", str(good), "--target", "dz_um", "--model", "gmc", "--out", str(model)]
    assert main([*args, "--quiet"]) == 0
    rows[4] = rows[4].rsplit(",", 1)[0] + "," + BIG
    return model, write(tmp_path, "test,time_s,T1_C,T2_C,dz_um\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize("command", ["select", "fit", "predict"])
def test_commands_name_a_number_beyond_a_float_in_one_line(tmp_path, capsys, small_model, command):
    from greyml.cli import main

    model, data = small_model
    argv = {
        "select": ["select", data, "--target", "dz_um"],
        "fit": ["fit", data, "--target", "dz_um", "--model", "gmc", "--out", tmp_path / "f.greyml"],
        "predict": ["predict", model, data, "--out", tmp_path / "p.csv"],
    }[command]
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert err.startswith(
        f"greyml {command}: error: Column 'dz_um' of {str(data)!r} holds a number too large "
        "for a float (1000…000, 400 digits) at line 6 (test 'A'); "
    ), err


# -- the shape of a file bounds the work before a value is read (issue 41, finding 4) --


def _no_value_read(monkeypatch):
    """Make reading any value fail: a refusal must come from the header alone."""
    import greyml.io._csv as csv_module

    def refuse(*args, **kwargs):
        raise AssertionError("a value was read")

    monkeypatch.setattr(csv_module.pd, "read_csv", refuse)
    monkeypatch.setattr(csv_module, "_read_wide", refuse)


@pytest.mark.parametrize("sep", [",", ";", "\t", None])
def test_a_file_wider_than_max_columns_is_refused_from_its_header(tmp_path, monkeypatch, sep):
    s = sep or ","
    names = s.join(["test", "time_s", *(f"T{k}_C" for k in range(9))])
    path = write(tmp_path, names + "\n" + s.join(["A", "0", *["x"] * 9]) + "\n")
    _no_value_read(monkeypatch)
    with pytest.raises(ValueError) as info:
        read_tests_csv(path, sep=sep, max_columns=10)
    assert str(info.value) == (
        f"The header of {str(path)!r} has 11 columns (separator {s!r}), more than the 10 a CSV "
        "file of tests may have (max_columns): is it a file of tests, one sample per line and "
        "one column per sensor?"
    )


def test_a_quoted_header_is_counted_by_its_fields(tmp_path, monkeypatch):
    """A separator inside a quoted name is no column: 11 fields, not 12."""
    header = 'test,time_s,"T,0",' + ",".join(f"T{k}" for k in range(1, 9))
    path = write(tmp_path, header + "\nA,0," + ",".join(["1"] * 9) + "\n")
    assert read_tests_csv(path, max_columns=11).shape == (1, 9)
    _no_value_read(monkeypatch)
    with pytest.raises(ValueError, match=r"has 11 columns \(separator ','\), more than the 10"):
        read_tests_csv(path, max_columns=10)


def test_the_column_bound_is_checked_and_100000_by_default(tmp_path):
    from greyml.io._csv import MAX_COLUMNS

    assert MAX_COLUMNS == 100_000
    path = write(tmp_path, "test,time_s,T1_C\nA,0,1\n")
    for bad in (2, 0, 2.5, True, "9"):
        with pytest.raises(
            ValueError, match=rf"max_columns must be a whole number >= 3; got {bad!r}"
        ):
            read_tests_csv(path, max_columns=bad)
    assert read_tests_csv(path, max_columns=3).shape == (1, 1)


def test_a_column_name_longer_than_1000_characters_is_refused(tmp_path, monkeypatch):
    path = write(tmp_path, "test,time_s,T1_C," + "n" * 1001 + "\nA,0,1,2\n")
    _no_value_read(monkeypatch)
    with pytest.raises(ValueError) as info:
        read_tests_csv(path)
    assert str(info.value) == (
        f"Column 4 of the header of {str(path)!r} has a name of 1,001 characters, more than "
        f"1,000 (starting {'n' * 40!r})."
    )


@pytest.fixture(scope="module")
def too_wide(tmp_path_factory):
    """A file of 3 rows and MAX_COLUMNS + 1 columns (100,003 with the keys), and a model."""
    from greyml.cli import main

    folder = tmp_path_factory.mktemp("wide")
    n = 100_001
    names = ",".join(f"T{k}_C" for k in range(n - 1))
    cells = ",".join(["1"] * n)
    path = write(
        folder, f"test,time_s,{names},dz_um\n" + "".join(f"A,{r},{cells}\n" for r in range(3))
    )
    rows = "".join(f"A,{60 * k},{20 + k / 10},{k / 3}\n" for k in range(6))
    good = write(folder, "test,time_s,T0_C,dz_um\n" + rows, "good.csv")
    model = folder / "m.greyml"
    assert (
        main(
            [
                "fit",
                str(good),
                "--target",
                "dz_um",
                "--model",
                "gmc",
                "--out",
                str(model),
                "--quiet",
            ]
        )
        == 0
    )
    return path, model


@pytest.mark.parametrize("command", ["predict", "fit", "select", "gap", "validate"])
def test_every_command_refuses_a_too_wide_file_in_one_line(tmp_path, capsys, too_wide, command):
    """Before the bound a 1,000,000-column file kept predict busy for 195 s (the time is
    measured in benchmarks/bench_csv_columns.py; here the refusal itself)."""
    from greyml.cli import main

    path, model = too_wide
    argv = {
        "predict": ["predict", model, path, "--out", tmp_path / "p.csv"],
        "fit": ["fit", path, "--target", "dz_um", "--model", "gmc", "--out", tmp_path / "f.greyml"],
        "select": ["select", path, "--target", "dz_um"],
        "gap": ["gap", path, path, "--target", "dz_um"],
        "validate": ["validate", path, "--target", "dz_um"],
    }[command]
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == (
        f"greyml {command}: error: The header of {str(path)!r} has 100,003 columns (separator "
        "','), more than the 100,000 a CSV file of tests may have (max_columns): is it a file "
        "of tests, one sample per line and one column per sensor?\n"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == []


# -- a name with a character no one sees is shown with its escapes (issue 41, finding 6) --

INVISIBLE = ["\u200bch1_um", "\ufeffch1_um", "ch1\x07_um", "ch1_um "]


@pytest.mark.parametrize("name", INVISIBLE)
def test_a_column_name_with_an_invisible_character_is_shown_escaped(tmp_path, capsys, name):
    """It read "'ch1_um' is not a column (its columns: ..., ch1_um, ...)"."""
    from greyml.cli import main

    quoted = '"' + name + '"' if name != name.strip() else name
    rows = "".join(f"A,{60 * k},{20 + k},{k}\n" for k in range(4))
    path = write(tmp_path, f"test,time_s,T1_C,{quoted}\n" + rows)
    assert read_tests_csv(path).columns[1] == name
    capsys.readouterr()
    assert main(["select", str(path), "--target", "ch1_um"]) == 2
    out, err = capsys.readouterr()
    assert err == (
        f"greyml select: error: --target names 'ch1_um', not a column of {str(path)!r} (its "
        f"columns: T1_C, {name!r}).\n"
    )
    assert "\\" in repr(name) or name != name.strip()  # what the line shows is visible


def test_shown_names():
    from greyml._validation import shown_name, shown_names

    assert shown_name("T1_C") == "T1_C" and shown_name("t1(°C)") == "t1(°C)"
    assert shown_name("\u200bch1_um") == "'\\u200bch1_um'"
    assert shown_name("\ufeffT1") == "'\\ufeffT1'" and shown_name("a\tb") == "'a\\tb'"
    assert shown_name("") == "''" and shown_name(3) == "3"
    assert shown_names(["a", "b", "c"], 2) == "a, b, ..." and shown_names(["a", " b"]) == "a, ' b'"
