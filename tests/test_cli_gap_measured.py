"""``greyml gap`` on measured-like files: greyml predict's output, quanta, events in time, CAIVIAC."""

import json

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
from greyml.cli import main
from greyml.io import write_tests_csv


def _tests(n_tests=4, n=150, dt=60.0, q=0.0, seed=0):
    """Measured tests (a spindle, two sensors) and an exact simulation of the probe."""
    rng = np.random.default_rng(seed)
    real, sim = [], []
    for k in range(n_tests):
        t = dt * np.arange(n)
        rpm = np.where((t // 1800) % 2 == k % 2, 3000.0 + 1000.0 * k, 0.0)
        heat = np.zeros(n)
        for i in range(1, n):
            heat[i] = heat[i - 1] + (rpm[i] / 4000.0 - heat[i - 1]) * 0.05
        simulated = 10.0 * heat
        measured = simulated + 0.05 * rng.standard_normal(n)
        if q:
            measured = q * np.round(measured / q)
        index = make_test_index([f"T{k}"] * n, t)
        real.append(
            pd.DataFrame(
                {"spindle_rpm": rpm, "T1_C": 20 + 5 * heat, "dz_um": measured}, index=index
            )
        )
        sim.append(pd.DataFrame({"dz_um": simulated}, index=index))
    return pd.concat(real), pd.concat(sim)


def _run(capsys, args):
    code = main(args)
    out, err = capsys.readouterr()
    return code, out, err


def _as_cycle(path, out):
    """A copy of a CSV whose test column is called ``cycle`` (a logger's file)."""
    text = path.read_text(encoding="utf-8")
    assert text.startswith("test,")
    out.write_text("cycle," + text[len("test,") :], encoding="utf-8")
    return str(out)


def test_gap_takes_greyml_predicts_own_output(tmp_path, capsys):
    real, _ = _tests()
    data = write_tests_csv(real, tmp_path / "real.csv")
    model, pred = tmp_path / "tf.greyml", tmp_path / "pred.csv"
    fit = ["fit", str(data), "--target", "dz_um", "--model", "transfer-function"]
    fit += ["--drivers", "spindle_rpm", "--sensors", "T1_C", "--out", str(model), "--quiet"]
    assert _run(capsys, fit)[0] == 0
    assert _run(capsys, ["predict", str(model), str(data), "--out", str(pred), "--quiet"])[0] == 0
    header = pred.read_text(encoding="utf-8").splitlines()[0]
    assert header == "test,time_s,predicted_dz_um_since_start,compensation_dz_um_since_start"
    # the measured file labels its tests 'cycle'; greyml predict's file says 'test'
    logger = _as_cycle(data, tmp_path / "logger.csv")
    args = ["gap", logger, str(pred), "--target", "dz_um", "--test-column", "cycle"]
    code, out, err = _run(capsys, [*args, "--random-state", "0", "--quiet", "--json", "-"])
    assert code == 0, err
    report = json.loads(out)
    assert report["verdict"] in ("within_noise", "explained", "partial", "unexplained")
    note = [line for line in err.splitlines() if "predicted_dz_um_since_start" in line]
    assert len(note) == 1 and "compared from its first row in each test" in note[0]
    assert note[0].startswith("greyml gap: warning:")


def test_the_sim_column_is_named_or_recognised(tmp_path, capsys):
    real, sim = _tests()
    real_path = str(write_tests_csv(real, tmp_path / "real.csv"))
    two = sim.assign(other_um=sim["dz_um"] + 5.0).rename(columns={"dz_um": "model_a"})
    two_path = str(write_tests_csv(two, tmp_path / "two.csv"))
    base = ["gap", real_path, two_path, "--target", "dz_um", "--random-state", "0", "--quiet"]
    code, out, err = _run(capsys, [*base, "--sim-column", "model_a", "--json", "-"])
    assert code == 0 and json.loads(out)["verdict"] == "within_noise", err
    code, out, err = _run(capsys, [*base, "--sim-column", "model_b"])
    assert code == 2 and err.count("\n") == 1
    assert "--sim-column names 'model_b', not a column of" in err
    code, out, err = _run(capsys, base)
    assert code == 2 and err.count("\n") == 1
    assert "no column of the simulated 'dz_um'" in err and "--sim-column" in err
    # greyml predict's predicted_<target>, in a file of other columns, is recognised
    pred = sim.rename(columns={"dz_um": "predicted_dz_um"}).assign(note=0.0)
    pred_path = str(write_tests_csv(pred, tmp_path / "pred.csv"))
    code, out, err = _run(capsys, ["gap", real_path, pred_path, "--target", "dz_um", "--json", "-"])
    assert code == 0 and json.loads(out)["verdict"] == "within_noise", err


@pytest.mark.parametrize(
    "flag, value, words",
    [
        ("--quantum", "-1", "must be a finite number >= 0 (0: continuous readings); got '-1'"),
        ("--quantum", "nan", "must be a finite number >= 0 (0: continuous readings); got 'nan'"),
        ("--step-time", "0", "must be a finite number of seconds > 0; got '0'"),
        ("--step-time", "inf", "must be a finite number of seconds > 0; got 'inf'"),
        ("--driver-window", "-5", "must be a finite number of seconds >= 0; got '-5'"),
    ],
)
def test_bad_event_settings_are_one_line(tmp_path, capsys, flag, value, words):
    real, sim = _tests(n_tests=2, n=20)
    paths = [str(write_tests_csv(f, tmp_path / n)) for f, n in ((real, "r.csv"), (sim, "s.csv"))]
    code, out, err = _run(capsys, ["gap", *paths, "--target", "dz_um", f"{flag}={value}"])
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith(f"greyml gap: error: argument {flag}: {words}")


def test_a_quantised_probe_on_the_command_line(tmp_path, capsys):
    real, sim = _tests(q=1.0)
    paths = [str(write_tests_csv(f, tmp_path / n)) for f, n in ((real, "r.csv"), (sim, "s.csv"))]
    args = ["gap", *paths, "--target", "dz_um", "--drivers", "spindle_rpm", "--random-state", "0"]
    code, out, _ = _run(capsys, [*args, "--quiet", "--json", "-"])
    report = json.loads(out)
    assert code == 0 and report["quantum"] == 1.0
    assert report["verdict"] == "within_noise" and report["events"] == []
    code, out, _ = _run(capsys, [*args, "--quiet", "--quantum", "0", "--json", "-"])
    assert json.loads(out)["quantum"] == 0.0
    # stated continuous: no rounding in the floor, the white part as for
    # Gaussian noise; with the quantum the floor holds the rounding, q/√12
    assert json.loads(out)["noise_floor"] != report["noise_floor"]
    assert report["noise_floor"] >= 1.0 / 12**0.5


def test_help_names_the_new_flags(capsys):
    assert main(["gap", "--help"]) == 0
    text = capsys.readouterr().out
    for flag in ("--quantum Q", "--step-time S", "--driver-window S", "--sim-column COL"):
        assert flag in text
    assert "predicted_<target>_since_start" in text and "at a spindle speed change" in " ".join(
        text.split()
    )


def test_caiviac_events_at_spindle_speed_changes_are_labelled(tmp_path, capsys):
    from conftest import caiviac_csv_or_skip

    data = str(caiviac_csv_or_skip())
    model, pred, report = tmp_path / "tf.greyml", tmp_path / "pred.csv", tmp_path / "gap.json"
    # a model of the temperatures alone: it lacks the probes' response to speed
    common = ["--test-column", "cycle", "--quiet"]
    fit = ["fit", data, "--target", "ch1_um", "--model", "transfer-function"]
    fit += ["--sensors", "t1_C,t2_C,t3_C,t4_C,t5_C", "--out", str(model), *common]
    assert _run(capsys, fit)[0] == 0
    assert _run(capsys, ["predict", str(model), data, "--out", str(pred), *common])[0] == 0
    gap = ["gap", data, str(pred), "--target", "ch1_um", "--drivers", "spindle_rpm"]
    code, out, err = _run(capsys, [*gap, "--random-state", "0", "--json", str(report), *common])
    assert code == 0, err
    saved = json.loads(report.read_text(encoding="utf-8"))
    events = saved["events"]
    # given only a driver, the effects that need sensors or an air column are
    # listed as not tried, with the columns they need, in the JSON and the text
    assert set(saved["not_tried"]) == {"ambient", "sensor_lag", "initial_state", "fbg_temperature"}
    assert "the ambient column" in saved["not_tried"]["ambient"]
    assert "temperature sensor columns" in saved["not_tried"]["sensor_lag"]
    not_tried = [line for line in out.splitlines() if line.startswith("Not tried: ")]
    assert len(not_tried) == 1 and all(e in not_tried[0] for e in saved["not_tried"])
    frame = pd.read_csv(data)
    switches = frame["time_s"].to_numpy()[np.flatnonzero(np.diff(frame["spindle_rpm"])) + 1]
    labelled = [e for e in events if e["at_driver_change"] == "spindle_rpm"]
    assert labelled, events
    for event in events:
        near = np.min(np.abs(switches - event["time_s"])) <= 60.0 + 15.0
        assert (event["at_driver_change"] == "spindle_rpm") == near, event
    for event in labelled:
        assert event["driver_change_s"] in switches
        assert event["driver_before"] != event["driver_after"]
    assert "at a spindle speed change" in out
