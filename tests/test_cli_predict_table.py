"""greyml predict: a table test by test that marks the tests the model was fitted on, and a
file with only the columns the model uses."""

import numpy as np
import pytest
from test_cli_validate import _recording

from greyml.cli import main
from greyml.io import read_tests_csv, write_tests_csv
from greyml.persist import load_model


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("table")
    frame = _recording()
    data = write_tests_csv(frame, folder / "rec.csv")
    model = folder / "m.greyml"
    argv = ["fit", str(data), "--target", "dz_um", "--model", "transfer-function"]
    argv += ["--drivers", "spindle_rpm", "--max-sensors", "1", "--time-constants", "900,2700"]
    argv += ["--train-tests", "c1,c2,c3", "--out", str(model), "--quiet"]
    assert main(argv) == 0
    return {"frame": frame, "data": data, "model": model, "folder": folder}


def test_the_table_marks_the_tests_fitted_on(fitted, capsys):
    capsys.readouterr()
    out_csv = fitted["folder"] / "p.csv"
    argv = ["predict", str(fitted["model"]), str(fitted["data"]), "--out", str(out_csv)]
    assert main([*argv, "--force", "--quiet"]) == 0
    out = capsys.readouterr().out
    model = load_model(fitted["model"])
    assert model.fitted_tests_ == ["c1", "c2", "c3"]
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line[2:3] == "c"}
    assert [rows[t][1] for t in ("c1", "c2", "c3")] == ["*", "*", "*"]
    assert rows["c4"][1] != "*"
    # the summary is over c4 alone: its RMSE, computed here from the written prediction
    frame, pred = fitted["frame"], read_tests_csv(out_csv)
    held = frame.loc["c4", "dz_um"].to_numpy()
    predicted = pred.loc["c4"].iloc[:, 0].to_numpy()
    assert model.reference_ == "recording"  # one recording: predicted from its zero
    rmse = np.sqrt(np.mean((held - predicted) ** 2))
    median = next(line for line in out.splitlines() if line.split()[:1] == ["median"])
    assert float(median.split()[1]) == pytest.approx(rmse, rel=1e-2)
    assert "* fitted on this test" in out and "over the tests not fitted on" in out
    assert "in the reference recording" in out


def test_a_file_with_only_the_used_columns_predicts_the_same(fitted, capsys):
    model = load_model(fitted["model"])
    used = ["spindle_rpm", *model.selected_sensors_]
    assert len(used) == 2  # one of the two sensors is left out
    small = write_tests_csv(fitted["frame"][used], fitted["folder"] / "small.csv")
    full_csv, small_csv = fitted["folder"] / "full.csv", fitted["folder"] / "s.csv"
    for data, out in ((fitted["data"], full_csv), (small, small_csv)):
        argv = ["predict", str(fitted["model"]), str(data), "--out", str(out)]
        assert main([*argv, "--interval", "0.9", "--force", "--quiet"]) == 0
    capsys.readouterr()
    assert read_tests_csv(small_csv).equals(read_tests_csv(full_csv))
    # a file without a used column: one line naming it
    lacking = write_tests_csv(fitted["frame"][["spindle_rpm"]], fitted["folder"] / "no.csv")
    argv = ["predict", str(fitted["model"]), str(lacking), "--out", str(small_csv), "--force"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"needs the sensor column(s) {model.selected_sensors_[0]}" in err


def test_the_caiviac_table_of_the_command_line_page(tmp_path, capsys):
    """The table docs/command_line.rst shows is what greyml predict prints on CAIVIAC."""
    from conftest import caiviac_csv_or_skip
    from test_cli_validate import ROOT

    path = str(caiviac_csv_or_skip())
    model = str(tmp_path / "ch1.greyml")
    fit = ["fit", path, "--test-column", "cycle", "--target", "ch1_um"]
    fit += ["--model", "transfer-function", "--drivers", "spindle_rpm", "--max-sensors", "5"]
    assert main([*fit, "--train-tests", "1,2,3,4", "--out", model, "--quiet"]) == 0
    predict = ["predict", model, path, "--test-column", "cycle", "--interval", "0.9"]
    capsys.readouterr()
    assert main([*predict, "--out", str(tmp_path / "p.csv"), "--quiet"]) == 0
    printed = [line.strip() for line in capsys.readouterr().out.splitlines()]
    page = (ROOT / "docs" / "command_line.rst").read_text(encoding="utf-8")
    block = page.split("fitted on cycles 1 to 4 as above", 1)[1].split(".. code-block:: text")[1]
    table = block.strip().split("\n\n")[0].splitlines()[1:]  # after the line naming the file
    assert len(table) == 9
    for line in table:
        assert line.strip() in printed
