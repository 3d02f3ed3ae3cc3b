"""greyml validate: leave one test out, a table test by test, the same numbers as by hand."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import caiviac_csv_or_skip

from greyml import ThermalTransferFunction, make_test_index
from greyml.cli import main
from greyml.io import read_tests_csv, write_tests_csv

STEP = 60.0
ROOT = Path(__file__).resolve().parent.parent


def _recording(seed=0):
    """Four cycles on one clock: a spindle on then off, T1 its heat, T2 the air."""
    rng = np.random.default_rng(seed)
    frames, clock = [], 0.0
    for i, rpm in enumerate([1000.0, 3000.0, 2000.0, 4000.0]):
        t = np.arange(0.0, 4 * 3600, STEP)
        n = np.where(t < 7200, rpm, 0.0)
        t1 = 20 + np.cumsum(n) * 2e-6 + 0.01 * rng.standard_normal(t.size)
        t2 = 20 + 0.4 * np.sin((clock + t) / 3000)
        y = 2.0 * (t1 - 20) + 1.5 * (t2 - 20) + 0.02 * rng.standard_normal(t.size)
        index = make_test_index([f"c{i + 1}"] * t.size, clock + t)
        clock += 4 * 3600
        frames.append(
            pd.DataFrame({"spindle_rpm": n, "T1_C": t1, "T2_C": t2, "dz_um": y}, index=index)
        )
    return pd.concat(frames)


def _by_hand(frame, target, columns, model):
    """Leave one test out in Python: weight 0 on the held-out test, start reference."""
    X, y = frame[columns], frame[target].to_numpy()
    labels = frame.index.get_level_values("test")
    out = {}
    for test in dict.fromkeys(labels):
        held = np.asarray(labels == test)
        fitted = model.fit(X, y, sample_weight=(~held).astype(float))
        pred = fitted.predict(X)[held]
        measured = y[held]
        error = (measured - measured[0]) - (pred - pred[0])
        out[test] = (float(np.sqrt(np.mean(error**2))), float(np.abs(error).max()))
    return out


def test_validate_equals_leave_one_test_out_by_hand(tmp_path, capsys):
    frame = _recording()
    data = write_tests_csv(frame, tmp_path / "rec.csv")
    out_json = tmp_path / "v.json"
    argv = ["validate", str(data), "--target", "dz_um", "--drivers", "spindle_rpm"]
    argv += ["--time-constants", "900,2700", "--json", str(out_json), "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "in the reference start (the change since each test's first row)" in out
    assert "weight 0 on the held-out test's rows" in out
    record = json.loads(out_json.read_text())
    model = ThermalTransferFunction(
        drivers=("spindle_rpm",), time_constants=[900.0, 2700.0], random_state=0
    )
    expected = _by_hand(read_tests_csv(data), "dz_um", ["spindle_rpm", "T1_C", "T2_C"], model)
    assert [t["test"] for t in record["tests"]] == ["c1", "c2", "c3", "c4"]
    for row in record["tests"]:
        rmse, worst = expected[row["test"]]
        assert row["rmse"] == pytest.approx(rmse, abs=1e-9)
        assert row["worst"] == pytest.approx(worst, abs=1e-9)
        assert 0.0 <= row["coverage"] <= 1.0  # four tests: three calibrate the interval
    rmses = [expected[t][0] for t in expected]
    assert record["summary"]["median_rmse"] == pytest.approx(np.median(rmses), abs=1e-9)
    assert record["summary"]["worst_rmse"] == pytest.approx(max(rmses), abs=1e-9)
    # the table prints each test's RMSE
    for test, (rmse, _) in expected.items():
        line = next(s for s in out.splitlines() if s.split()[:1] == [test])
        assert float(line.split()[2]) == pytest.approx(rmse, rel=1e-2)


def test_recording_reference_needs_a_model_that_predicts_from_it(tmp_path, capsys):
    frame = _recording()
    data = write_tests_csv(frame, tmp_path / "rec.csv")
    argv = ["validate", str(data), "--target", "dz_um", "--drivers", "spindle_rpm"]
    argv += ["--time-constants", "900,2700", "--model-reference", "start"]
    assert main([*argv, "--reference", "recording", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--reference recording: the model predicts the change since each test's first" in err


def test_a_static_model_is_fitted_on_the_other_tests(tmp_path, capsys):
    frame = _recording()
    data = write_tests_csv(frame, tmp_path / "rec.csv")
    argv = ["validate", str(data), "--target", "dz_um", "--model", "gmc", "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "fitted on the other tests' rows" in out
    assert "90 % interval" not in out  # a GMC gives no interval: the column shows -


def test_one_test_is_refused(tmp_path, capsys):
    frame = _recording().loc[["c1"]]
    data = write_tests_csv(frame, tmp_path / "one.csv")
    assert main(["validate", str(data), "--target", "dz_um", "--quiet"]) == 2
    assert "leaving one out needs at least 2" in capsys.readouterr().err


def test_validate_on_caiviac_equals_the_python_leave_one_cycle_out(tmp_path, capsys):
    path = caiviac_csv_or_skip()
    out_json = tmp_path / "ch1.json"
    argv = ["validate", str(path), "--test-column", "cycle", "--target", "ch1_um"]
    assert main([*argv, "--json", str(out_json), "--quiet"]) == 0
    printed = [line.strip() for line in capsys.readouterr().out.splitlines()]
    record = json.loads(out_json.read_text())
    # the table docs/command_line.rst shows is the one the command prints
    page = (ROOT / "docs" / "command_line.rst").read_text(encoding="utf-8")
    section = page.split("Validating: each test held out once", 1)[1].split("``--json FILE``")[0]
    table = section.split(".. code-block:: text", 1)[1].strip().splitlines()
    assert len(table) == 9
    for line in table:
        assert line.strip() in printed
    frame = read_tests_csv(path, test_column="cycle")
    sensors = [f"t{k}_C" for k in range(1, 17)]  # the candidates: not the speed, not a probe
    expected = _by_hand(frame, "ch1_um", sensors, ThermalTransferFunction(random_state=0))
    assert record["reference"] == "start" and record["model_reference"] == "recording"
    got = {row["test"]: row["rmse"] for row in record["tests"]}
    assert list(got) == ["1", "2", "3", "4", "5"]
    for test, (rmse, _) in expected.items():
        assert got[test] == pytest.approx(rmse, abs=1e-6)


def test_a_speed_column_left_out_of_the_model_is_named(tmp_path, capsys):
    data = write_tests_csv(_recording(), tmp_path / "rec.csv")
    assert main(["validate", str(data), "--target", "dz_um", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert (
        "greyml validate: warning: no --drivers given, so the model does not use "
        "'spindle_rpm'; name what the controller knows (spindle speed, feed) with "
        "--drivers spindle_rpm"
    ) in err
    argv = ["validate", str(data), "--target", "dz_um", "--drivers", "spindle_rpm", "--quiet"]
    assert main(argv) == 0
    assert "no --drivers given" not in capsys.readouterr().err
