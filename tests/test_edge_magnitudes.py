"""Numbers at the edges of float64 get one line, on every command (issue 26 item 7c-d).

A cell of about 1e300 (a unit or logging error) used to reach NumPy and SciPy
and fail deep inside with a message that named no column, or to be fitted
silently into a useless model. A gap of about 1e-170 made the diagnosis fail
inside ruptures (its penalty underflowed to 0). Both are refused in one line
that names what is wrong and where.
"""

import re

import numpy as np
import pandas as pd
import pytest

from greyml import GMC, MLPBaseline, make_test_index
from greyml._validation import MAX_INPUT
from greyml.cli import main
from greyml.gap import diagnose_gap
from greyml.io import write_tests_csv


def _frame(n_tests=3, n=60):
    """Heating tests: two sensors, a spindle and a displacement."""
    frames = []
    for k in range(n_tests):
        t = 60.0 * np.arange(n)
        heat = 1.0 - np.exp(-t / (900.0 + 200.0 * k))
        rng = np.random.default_rng(k)
        frames.append(
            pd.DataFrame(
                {
                    "spindle_rpm": np.where(t < 1800, 4000.0, 0.0),
                    "T1_C": 20.0 + 5.0 * heat + 0.02 * rng.standard_normal(n),
                    "T2_C": 20.0 + 2.0 * heat**2 + 0.02 * rng.standard_normal(n),
                    "dz_um": -12.0 * heat + 0.05 * rng.standard_normal(n),
                },
                index=make_test_index([f"T{k + 1}"] * n, t),
            )
        )
    return pd.concat(frames)


def _one_line_error(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert code == 2, (code, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.mark.parametrize("command", ["fit", "select", "predict", "gap"])
def test_huge_cell_is_refused_by_every_command(command, tmp_path, capsys):
    good = _frame()
    model = tmp_path / "m.greyml"
    write_tests_csv(good, tmp_path / "good.csv")
    assert (
        main(
            [
                "fit",
                str(tmp_path / "good.csv"),
                "--target",
                "dz_um",
                "--model",
                "gmc",
                "--out",
                str(model),
            ]
        )
        == 0
    )
    capsys.readouterr()
    bad = good.copy()
    bad.iloc[70, bad.columns.get_loc("T2_C")] = 3e300  # test 'T2', row 10 of it
    path = write_tests_csv(bad, tmp_path / "bad.csv")
    argv = {
        "fit": [
            "fit",
            path,
            "--target",
            "dz_um",
            "--model",
            "gmc",
            "--out",
            tmp_path / "m2.greyml",
        ],
        "select": ["select", path, "--target", "dz_um", "--n-sensors", "1"],
        "predict": ["predict", model, path, "--out", tmp_path / "p.csv"],
        "gap": ["gap", path, tmp_path / "good.csv", "--target", "dz_um", "--sensors", "T1_C,T2_C"],
    }[command]
    line = _one_line_error(argv, capsys)
    assert re.search(r"'T2_C' holds 3e\+300 at line 72 .*test 'T2', time_s 600", line), line
    assert "check its unit" in line
    assert not (tmp_path / "m2.greyml").exists() and not (tmp_path / "p.csv").exists()


@pytest.mark.parametrize("make", [GMC, lambda: MLPBaseline(max_iter=3, n_restarts=1)])
def test_huge_training_value_names_column_test_and_row(make):
    data = _frame()
    X, y = data[["T1_C", "T2_C"]].copy(), data["dz_um"].copy()
    X.iloc[130, 0] = -1e150
    with pytest.raises(ValueError, match=r"column 'T1_C' holds -1e\+150 in test 'T3' at row 130"):
        make().fit(X, y)
    y.iloc[5] = 2 * MAX_INPUT
    with pytest.raises(ValueError, match=r"the target y holds 2e\+100 in test 'T1' at row 5"):
        make().fit(data[["T1_C", "T2_C"]], y)


def test_the_largest_plausible_value_is_accepted():
    data = _frame()
    X = data[["T1_C", "T2_C"]].copy()
    X.iloc[3, 0] = MAX_INPUT  # at the bound: no error (the fit may be poor)
    GMC().fit(X, data["dz_um"])


def _gap_frames(scale):
    real = _frame(n=80)
    sim = real[["dz_um"]].copy()
    sim["dz_um"] = real["dz_um"] + scale * np.sin(np.arange(len(real)) / 7.0)
    return real, sim


def test_a_gap_below_any_resolution_is_refused_in_one_line():
    real, sim = _gap_frames(1.0)
    real["dz_um"] *= 1e-170
    sim["dz_um"] *= 0.9e-170
    with pytest.raises(ValueError, match=r"at most \d\.\d+e-170 in every row, below 1e-100"):
        diagnose_gap(real, sim, target="dz_um", random_state=0, n_placebo=3)


def test_no_gap_at_all_is_refused_in_one_line():
    real, _ = _gap_frames(0.0)
    with pytest.raises(ValueError, match=r"agree exactly in every row: there is no gap"):
        diagnose_gap(real, real[["dz_um"]], target="dz_um", random_state=0, n_placebo=3)


def test_cli_gap_on_a_tiny_target(tmp_path, capsys):
    real, sim = _gap_frames(1.0)
    real["dz_um"] *= 1e-170
    sim["dz_um"] *= 0.9e-170
    a = write_tests_csv(real, tmp_path / "real.csv")
    b = write_tests_csv(sim, tmp_path / "sim.csv")
    line = _one_line_error(["gap", a, b, "--target", "dz_um", "--json", "-"], capsys)
    assert "too small to diagnose" in line
    assert capsys.readouterr().out == ""


def test_predict_refuses_a_correction_beyond_1_mm(tmp_path, capsys):
    """Issue 26, plausible outputs: 1 mm by default, --max-displacement to change it."""
    good = _frame()
    write_tests_csv(good, tmp_path / "good.csv")
    model = tmp_path / "m.greyml"
    argv = ["fit", tmp_path / "good.csv", "--target", "dz_um", "--model", "gmc", "--out", model]
    assert main([str(a) for a in argv]) == 0
    hot = good.copy()
    hot[["T1_C", "T2_C"]] *= 1000.0  # a logger in milli-degrees, read as °C
    path = write_tests_csv(hot, tmp_path / "hot.csv")
    out = tmp_path / "p.csv"
    capsys.readouterr()
    line = _one_line_error(["predict", model, path, "--out", out], capsys)
    assert re.search(r"predicts -?\d[\d.e+]* for dz_um at line \d+ .* beyond ±1000 ", line), line
    assert not out.exists()
    assert (
        main([str(a) for a in ["predict", model, path, "--out", out, "--max-displacement", "inf"]])
        == 0
    )
    assert out.exists()
    capsys.readouterr()
    line = _one_line_error(
        [
            "predict",
            model,
            tmp_path / "good.csv",
            "--out",
            tmp_path / "q.csv",
            "--max-displacement",
            "1e-3",
        ],
        capsys,
    )
    assert "beyond ±0.001" in line


def test_the_magnitude_check_names_the_first_column_in_file_order_at_its_first_row():
    """One pass over the numbers (issue 41, finding 4) keeps the old loop's answer:
    ``time_s`` first, then the columns in order, the first row of that column; text
    columns are not numbers and are passed over."""
    from greyml._cli._files import _check_magnitudes

    frame = pd.DataFrame(
        {
            "note": ["a", "b", "c"],
            "T1_C": [20.0, 20.0, 20.0],
            "count": np.array([1, 2, 3], dtype=np.int64),
            "T2_C": [20.0, -2e100, 3e100],
            "T3_C": [5e100, 20.0, 20.0],
        },
        index=make_test_index(["A", "A", "B"], [0.0, 60.0, 0.0]),
    )
    with pytest.raises(ValueError) as info:
        _check_magnitudes(frame, "d.csv")
    assert str(info.value) == (
        "Column 'T2_C' holds -2e+100 at line 3 of 'd.csv' (test 'A', time_s 60), beyond 1e+100, "
        "which no measurement reaches; check its unit."
    )
    late = frame.set_index(make_test_index(["A", "A", "B"], [0.0, 2e101, 0.0]))
    with pytest.raises(ValueError, match=r"^Column 'time_s' holds 2e\+101 at line 3 "):
        _check_magnitudes(late, "d.csv")
    _check_magnitudes(frame.drop(columns=["T2_C", "T3_C"]), "d.csv")  # nothing beyond
