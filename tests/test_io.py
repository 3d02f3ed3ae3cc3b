"""CSV reading and writing of greyml's test-data layout (issue 3)."""

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
