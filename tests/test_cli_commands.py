"""The ``greyml`` subcommands demo, simulate, select, fit and predict.

Success paths run the real commands on small data; every user error must
exit with code 2 and one line ``greyml <command>: error: ...`` on standard
error, without a traceback.
"""

import io
import json
import os
import subprocess
import sys
import zipfile

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
from greyml._cli._printing import Progress
from greyml.cli import main
from greyml.datasets import load_vmc_tests
from greyml.io import read_tests_csv, write_tests_csv
from greyml.persist import load_model

MODELS = ("GMC", "GNNMCI", "ANFISGrid", "ANFISFCM", "MLPBaseline", "ThermalTF")


def _tiny_frame(n=60):
    """Two short heating tests: three temperatures, the spindle speed and dz_um."""
    frames = []
    for k, label in enumerate(["A", "B"]):
        t = 60.0 * np.arange(n)
        heat = 1.0 - np.exp(-t / (900.0 + 300.0 * k))
        ambient = 20.0 + 0.2 * k + 0.1 * np.sin(t / 2000.0)
        frames.append(
            pd.DataFrame(
                {
                    "spindle_rpm": np.full(n, 4000.0 + 2000.0 * k),
                    "T1_C": ambient + 6.0 * heat,
                    "T2_C": ambient + 3.0 * heat**2,
                    "T3_C": ambient.copy(),
                    "dz_um": -20.0 * heat - 3.0 * heat**2,
                },
                index=make_test_index([label] * n, t),
            )
        )
    return pd.concat(frames)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """A small CSV of tests and a GMC model file trained on it."""
    folder = tmp_path_factory.mktemp("tiny")
    data = write_tests_csv(_tiny_frame(), folder / "tiny.csv")
    model = folder / "gmc.greyml"
    code = main(["fit", str(data), "--target", "dz_um", "--model", "gmc", "--out", str(model)])
    assert code == 0
    return {"folder": folder, "data": data, "model": model}


def _error(capsys, argv, command=None):
    """Run ``greyml argv``; check exit code 2 and one clean error line; return it."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    command = command or argv[0]
    assert code == 2, (out, err)
    assert "Traceback" not in err
    assert err.startswith(f"greyml {command}: error: "), err
    assert err.endswith("\n") and err.count("\n") == 1, err
    return err


def _write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------------------------------------
# User errors: exit code 2, one line
# ------------------------------------------------------------------------------


def test_missing_data_file(capsys, tmp_path):
    missing = tmp_path / "nowhere.csv"
    err = _error(capsys, ["select", missing, "--target", "dz_um"])
    assert "no such file" in err and str(missing) in err


def test_wrong_target_column(capsys, tiny):
    err = _error(capsys, ["select", tiny["data"], "--target", "dy_um"])
    assert "'dy_um'" in err and "--target" in err and "tiny.csv" in err


def test_missing_target_option(capsys, tiny):
    err = _error(
        capsys, ["fit", tiny["data"], "--model", "gmc", "--out", tiny["folder"] / "x.greyml"]
    )
    assert "--target" in err and "greyml fit --help" in err


def test_empty_csv(capsys, tmp_path):
    empty = _write(tmp_path / "empty.csv", "")
    err = _error(capsys, ["select", empty, "--target", "dz_um"])
    assert "empty" in err and "empty.csv" in err


def test_csv_without_test_and_time_columns(capsys, tmp_path):
    bare = _write(tmp_path / "bare.csv", "T1_C,dz_um\n20.0,0.0\n20.5,1.0\n")
    err = _error(capsys, ["fit", bare, "--target", "dz_um", "--model", "gmc", "--out", "m"])
    assert "'test'" in err and "bare.csv" in err


def test_csv_with_text_in_a_number_column(capsys, tmp_path):
    bad = _write(tmp_path / "bad.csv", "test,time_s,T1_C,dz_um\nA,0,20.0,0\nA,60,warm,1\n")
    err = _error(capsys, ["select", bad, "--target", "dz_um", "--n-sensors", "1"])
    assert "'warm'" in err and "line 3" in err


def test_unknown_model(capsys, tiny):
    err = _error(
        capsys, ["fit", tiny["data"], "--target", "dz_um", "--model", "lstm", "--out", "m"]
    )
    assert "'lstm'" in err and "anfis-fcm" in err


def test_unknown_machine(capsys, tmp_path):
    err = _error(capsys, ["simulate", "--machine", "lathe", "--out", tmp_path / "x.csv"])
    assert "'lathe'" in err and "gantry" in err


@pytest.mark.parametrize("value", ["0", "-3", "five"])
def test_bad_n(capsys, tiny, value):
    err = _error(capsys, ["select", tiny["data"], "--target", "dz_um", "--n-sensors", value])
    assert "--n-sensors" in err


def test_n_larger_than_the_candidates(capsys, tiny):
    err = _error(capsys, ["select", tiny["data"], "--target", "dz_um", "--n-sensors", "4"])
    assert "--n-sensors 4" in err and "3 candidate" in err


def test_unwritable_output_folder(capsys, tmp_path):
    # a regular file where the folder should be: unwritable even for root
    blocker = _write(tmp_path / "blocker", "not a folder")
    err = _error(capsys, ["simulate", "--machine", "vmc", "--out", blocker / "vmc.csv"])
    assert str(blocker) in err
    err = _error(capsys, ["demo", "--quick", "--out", blocker / "demo"])
    assert "cannot create the output folder" in err and str(blocker) in err


def test_read_only_output_folder(capsys, tiny, tmp_path, monkeypatch):
    # the permission check itself, also where the tests run as root (who may
    # write anywhere): os.access says the folder is read-only
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access

    def access(path, mode, *args, **kwargs):
        if os.path.abspath(path) == str(locked) and mode & os.W_OK:
            return False
        return real_access(path, mode, *args, **kwargs)

    monkeypatch.setattr(os, "access", access)
    err = _error(capsys, ["predict", tiny["model"], tiny["data"], "--out", locked / "p.csv"])
    assert "not writable" in err


def test_existing_output_without_force(capsys, tiny, tmp_path):
    taken = _write(tmp_path / "taken.csv", "keep me\n")
    err = _error(capsys, ["simulate", "--machine", "vmc", "--tests", "I", "--out", taken])
    assert "exists" in err and "--force" in err
    err = _error(capsys, ["predict", tiny["model"], tiny["data"], "--out", taken])
    assert "exists" in err
    err = _error(
        capsys, ["fit", tiny["data"], "--target", "dz_um", "--model", "gmc", "--out", taken]
    )
    assert "exists" in err
    assert taken.read_text() == "keep me\n"


def test_non_empty_demo_folder_without_force(capsys, tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    err = _error(capsys, ["demo", "--quick", "--out", tmp_path])
    assert "not empty" in err and "--force" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_demo_out_is_a_file(capsys, tmp_path):
    file = _write(tmp_path / "demo", "")
    err = _error(capsys, ["demo", "--quick", "--out", file])
    assert "is a file, not a folder" in err


def test_model_file_that_is_not_a_model(capsys, tiny, tmp_path):
    fake = _write(tmp_path / "fake.greyml", "test,time_s\nA,0\n")
    err = _error(capsys, ["predict", fake, tiny["data"], "--out", tmp_path / "p.csv"])
    assert "fake.greyml" in err and "not a greyml model" in err


def test_missing_model_file(capsys, tiny, tmp_path):
    err = _error(
        capsys, ["predict", tmp_path / "none.greyml", tiny["data"], "--out", tmp_path / "p.csv"]
    )
    assert "none.greyml" in err and "does not exist" in err


def _retouch(source, target, edit):
    """Copy a model file, passing its model.json through ``edit``."""
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(target, "w") as new:
        for info in old.infolist():
            data = old.read(info)
            if info.filename == "model.json":
                data = json.dumps(edit(json.loads(data))).encode()
            new.writestr(info, data)
    return target


def test_tampered_model_file_naming_a_foreign_class(capsys, tiny, tmp_path):
    def to_popen(doc):
        text = json.dumps(doc).replace('"greyml.GMC"', '"subprocess.Popen"')
        return json.loads(text)

    evil = _retouch(tiny["model"], tmp_path / "evil.greyml", to_popen)
    err = _error(capsys, ["predict", evil, tiny["data"], "--out", tmp_path / "p.csv"])
    assert "evil.greyml" in err and "subprocess.Popen" in err and "Refusing" in err
    assert not (tmp_path / "p.csv").exists()


def test_tampered_model_file_with_damaged_bytes(capsys, tiny, tmp_path):
    raw = bytearray(tiny["model"].read_bytes())
    middle = len(raw) // 2
    raw[middle : middle + 16] = bytes(16)
    damaged = tmp_path / "damaged.greyml"
    damaged.write_bytes(bytes(raw))
    err = _error(capsys, ["predict", damaged, tiny["data"], "--out", tmp_path / "p.csv"])
    assert "damaged.greyml" in err


def test_predict_on_data_without_the_model_sensors(capsys, tiny, tmp_path):
    frame = read_tests_csv(tiny["data"]).drop(columns=["T2_C"])
    data = write_tests_csv(frame, tmp_path / "no_t2.csv")
    err = _error(capsys, ["predict", tiny["model"], data, "--out", tmp_path / "p.csv"])
    assert "T2_C" in err and "no_t2.csv" in err


def test_nan_in_a_sensor(capsys, tiny, tmp_path):
    frame = read_tests_csv(tiny["data"])
    frame.iloc[65, frame.columns.get_loc("T1_C")] = np.nan  # row 5 of test B
    data = write_tests_csv(frame, tmp_path / "gap.csv")
    argv = ["fit", data, "--target", "dz_um", "--model", "gmc", "--out", tmp_path / "m.greyml"]
    err = _error(capsys, argv)
    assert "'T1_C'" in err and "line 67" in err and "test 'B'" in err
    err = _error(capsys, ["predict", tiny["model"], data, "--out", tmp_path / "p.csv"])
    assert "'T1_C'" in err and "line 67" in err


def test_target_missing_for_fit(capsys, tiny, tmp_path):
    frame = read_tests_csv(tiny["data"])
    frame.iloc[3, frame.columns.get_loc("dz_um")] = np.nan
    data = write_tests_csv(frame, tmp_path / "no_target.csv")
    argv = ["fit", data, "--target", "dz_um", "--model", "gmc", "--out", tmp_path / "m.greyml"]
    err = _error(capsys, argv)
    assert "target column 'dz_um'" in err and "line 5" in err and "test 'A'" in err


def test_unknown_training_test(capsys, tiny, tmp_path):
    argv = ["fit", tiny["data"], "--target", "dz_um", "--model", "gmc"]
    err = _error(capsys, [*argv, "--train-tests", "A,Z", "--out", tmp_path / "m.greyml"])
    assert "'Z'" in err and "A, B" in err
    err = _error(capsys, ["select", tiny["data"], "--target", "dz_um", "--train-tests", "Q"])
    assert "'Q'" in err


def test_sensor_that_is_not_a_column(capsys, tiny, tmp_path):
    argv = ["fit", tiny["data"], "--target", "dz_um", "--model", "mlp", "--sensors", "T1_C,T9_C"]
    err = _error(capsys, [*argv, "--out", tmp_path / "m.greyml"])
    assert "'T9_C'" in err and "--sensors" in err


def test_anfis_grid_on_too_many_inputs(capsys, tmp_path):
    frame = load_vmc_tests().frame
    data = write_tests_csv(frame[frame.index.get_level_values("test") == "IV"], tmp_path / "iv.csv")
    argv = ["fit", data, "--target", "dy_um", "--model", "anfis-grid"]
    err = _error(capsys, [*argv, "--out", tmp_path / "m.greyml"])
    assert "76 inputs" in err and "--n-sensors" in err


@pytest.mark.parametrize(
    ("spec", "words"),
    [
        ("ten:spindle_rpm=4000", "minutes"),
        ("60:laser=on", "spindle_rpm"),
        ("60:spindle_rpm=fast", "'fast'"),
        ("60,,60", "empty segment"),
        ("-5", "positive"),
    ],
)
def test_bad_programme(capsys, tmp_path, spec, words):
    argv = ["simulate", "--machine", "vmc", "--programme", spec, "--out", tmp_path / "p.csv"]
    err = _error(capsys, argv)
    assert words in err


def test_programme_and_tests_together(capsys, tmp_path):
    argv = ["simulate", "--machine", "vmc", "--programme", "60", "--tests", "I"]
    err = _error(capsys, [*argv, "--out", tmp_path / "p.csv"])
    assert "not both" in err
    err = _error(capsys, ["simulate", "--machine", "gantry", "--tests", "IV", "--out", "x.csv"])
    assert "Z-axis" in err


# ------------------------------------------------------------------------------
# Success paths
# ------------------------------------------------------------------------------


def test_simulate_select_fit_predict_round_trip(capsys, tmp_path):
    train_csv, new_csv = tmp_path / "train.csv", tmp_path / "new.csv"
    assert main(["simulate", "--machine", "vmc", "--tests", "I,IV", "--out", str(train_csv)]) == 0
    assert "I, IV" in capsys.readouterr().out
    assert main(["simulate", "--machine", "vmc", "--tests", "V", "--out", str(new_csv)]) == 0
    capsys.readouterr()
    data = read_tests_csv(train_csv)
    assert list(dict.fromkeys(data.index.get_level_values("test"))) == ["I", "IV"]

    argv = [
        "select",
        str(train_csv),
        "--target",
        "dy_um",
        "--n-sensors",
        "3",
        "--train-tests",
        "IV",
    ]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "kept 3 of 76 candidate sensors" in out
    kept = [line.split()[1] for line in out.splitlines() if line.strip()[:1].isdigit()]
    assert len(kept) == 3 and all(k in data.columns for k in kept)

    model = tmp_path / "anfis.greyml"
    argv = ["fit", str(train_csv), "--target", "dy_um", "--model", "anfis-fcm", "--n-sensors", "3"]
    assert main([*argv, "--train-tests", "IV", "--out", str(model)]) == 0
    out = capsys.readouterr().out
    assert "trained ANFISFCM" in out and "saved to" in out
    assert f"inputs: {', '.join(kept)}" in out  # the same selection as greyml select

    pred_csv = tmp_path / "pred.csv"
    assert main(["predict", str(model), str(new_csv), "--out", str(pred_csv)]) == 0
    out, err = capsys.readouterr()
    assert "against the measured dy_um" in out and err == ""
    pred = read_tests_csv(pred_csv)
    assert list(pred.columns) == ["predicted_dy_um", "compensation_dy_um"]
    new = read_tests_csv(new_csv)
    assert pred.index.equals(new.index)
    np.testing.assert_array_equal(pred["compensation_dy_um"], -pred["predicted_dy_um"])
    saved = load_model(model)
    assert list(saved[0].selected_) == kept
    expected = saved.predict(new[list(saved.feature_names_in_)])
    np.testing.assert_allclose(pred["predicted_dy_um"], expected, rtol=0, atol=1e-12)

    # the data need only the sensors the model kept; --force replaces the output
    only_kept = write_tests_csv(new[kept], tmp_path / "kept.csv")
    assert main(["predict", str(model), str(only_kept), "--out", str(pred_csv), "--force"]) == 0
    np.testing.assert_array_equal(read_tests_csv(pred_csv), pred)
    short = write_tests_csv(new[kept[1:]], tmp_path / "short.csv")
    err = _error(capsys, ["predict", model, short, "--out", tmp_path / "p2.csv"])
    assert kept[0] in err and "short.csv" in err
    # a starting displacement is for grey models only
    argv = ["predict", model, new_csv, "--out", tmp_path / "p3.csv", "--initial-displacement", "3"]
    err = _error(capsys, argv)
    assert "--initial-displacement is for models with a state (gmc, gnnmci, " in err
    assert "this model is ANFISFCM" in err


def test_predict_a_test_that_starts_mid_run(capsys, tiny, tmp_path):
    # the last third of test B as a test of its own: it starts hot, at -21.8 um
    frame = _tiny_frame().xs("B", level="test").iloc[40:]
    frame.index = make_test_index(["B-tail"] * len(frame), frame.index - frame.index[0])
    data = write_tests_csv(frame, tmp_path / "tail.csv")
    start = float(frame["dz_um"].iloc[0])

    argv = ["predict", tiny["model"], data, "--out", tmp_path / "cold.csv"]
    assert main([str(a) for a in argv]) == 0
    out, err = capsys.readouterr()
    assert err.count("\n") == 1, err  # one line, naming the test and the column
    head = "greyml predict: warning: GreyWarmStartWarning: GMC predicts test 'B-tail'"
    assert err.startswith(head), err
    assert "column 'T1_C' starts at 25" in err and "--initial-displacement" in err
    # a grey model predicts the change since the test's first row, and says so
    assert "displacement as its change since each test's first row" in out
    cold = read_tests_csv(tmp_path / "cold.csv")["predicted_dz_um_since_start"].to_numpy()

    argv += ["--initial-displacement", f"B-tail={start!r}"]
    argv[4] = tmp_path / "warm.csv"
    assert main([str(a) for a in argv]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert "from the measured value given at each test's first row" in out
    warm = read_tests_csv(tmp_path / "warm.csv")["predicted_dz_um"].to_numpy()
    measured = frame["dz_um"].to_numpy()
    assert warm[0] == pytest.approx(start, rel=1e-12)
    cold_rmse = np.sqrt(np.mean((cold - measured) ** 2))
    warm_rmse = np.sqrt(np.mean((warm - measured) ** 2))
    assert warm_rmse < 0.2 * cold_rmse, (warm_rmse, cold_rmse)
    # one number is every test's start; a test the data lacks is a usage error
    argv[-1] = repr(start)
    argv[4] = tmp_path / "warm2.csv"
    assert main([str(a) for a in argv]) == 0
    capsys.readouterr()
    np.testing.assert_array_equal(read_tests_csv(tmp_path / "warm2.csv")["predicted_dz_um"], warm)
    argv[4], argv[-1] = tmp_path / "none.csv", "C=1.0"
    err = _error(capsys, argv)
    assert "'C=1.0' is not TEST=VALUE for a test of the data (its tests: B-tail)" in err
    argv[-1] = "B-tail=hot"
    assert "the value of test 'B-tail' must be a finite number; got 'hot'" in _error(capsys, argv)


def test_simulate_the_seeds_tests_is_the_embedded_data(capsys, tmp_path):
    path = tmp_path / "vmc.csv"
    assert main(["simulate", "--machine", "vmc", "--tests", "seeds", "--out", str(path)]) == 0
    assert "6 simulated test(s)" in capsys.readouterr().out
    pd.testing.assert_frame_equal(read_tests_csv(path), load_vmc_tests().frame)


def test_simulate_a_programme_of_ones_own(capsys, tmp_path):
    path = tmp_path / "gantry.csv"
    argv = ["simulate", "--machine", "gantry", "--programme", "30:c_rpm=2500,30"]
    argv += ["--programme", "20:feed_mm_min=70000:c_rpm=1000,10", "--ambient", "22.5"]
    assert main([*argv, "--random-state", "3", "--out", str(path)]) == 0
    frame = read_tests_csv(path)
    tests = frame.index.get_level_values("test")
    assert list(dict.fromkeys(tests)) == ["P1", "P2"]
    p1 = frame.xs("P1", level="test")
    assert p1.index.max() == pytest.approx(3600.0)
    assert p1["c_rpm"].iloc[0] == 2500 and p1["c_rpm"].iloc[-1] == 0
    assert frame["ambient_C"].iloc[0] == pytest.approx(22.5)


def test_fit_without_selection_on_named_sensors(capsys, tiny, tmp_path):
    model = tmp_path / "mlp.greyml"
    argv = ["fit", str(tiny["data"]), "--target", "dz_um", "--model", "mlp"]
    assert main([*argv, "--sensors", "T1_C, T2_C", "--out", str(model)]) == 0
    assert "inputs (2): T1_C, T2_C" in capsys.readouterr().out
    assert list(load_model(model).feature_names_in_) == ["T1_C", "T2_C"]


def test_help_of_every_command_has_an_example(capsys):
    for command in ("demo", "simulate", "select", "fit", "predict"):
        assert main([command, "--help"]) == 0
        out = capsys.readouterr().out
        assert f"usage: greyml {command}" in out and "Examples:" in out, command


def test_python_m_greyml_demo_help():
    proc = subprocess.run(
        [sys.executable, "-m", "greyml", "demo", "--help"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert "usage: greyml demo" in proc.stdout and "greyml demo --out" in proc.stdout


def test_progress_shows_steps_on_a_terminal_only():
    class Terminal(io.StringIO):
        def isatty(self):
            return True

    screen = Terminal()
    progress = Progress(2, stream=screen)
    progress.step("fitting ANFISFCM on the VMC")
    progress.step("plotting")
    progress.close()
    text = screen.getvalue()
    assert "[1/2] fitting ANFISFCM on the VMC\u2026" in text and "[2/2] plotting" in text
    assert text.endswith("\r")  # the line is cleared at the end

    pipe = io.StringIO()
    quiet = Progress(2, stream=pipe)
    quiet.step("fitting")
    quiet.close()
    assert pipe.getvalue() == ""


def _check_demo_output(out, folder):
    for machine in ("VMC:", "Gantry:"):
        assert machine in out
    assert out.count("PAPER, measured") == 2
    assert "Paper (Abdulshahed et al. (2015))" in out and "Paper (Abdulshahed et al. (2016))" in out
    assert out.count("OURS: greyml, simulated") == 2
    for label in MODELS:
        assert out.count(f"  {label} ") >= 2, label
    # Abdulshahed et al.'s (2016) Table 4, beside ours
    assert "4.60" in out and "15.26" in out and "Journal of Manufacturing Systems" in out
    pngs = sorted(p.name for p in folder.glob("*.png"))
    assert len(pngs) == 12, pngs
    assert "vmc_anfis-fcm.png" in pngs and "gantry_gnnmci.png" in pngs
    for name in pngs:
        assert (folder / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (folder / "results.txt").read_text(encoding="utf-8").strip() == out.strip()


def test_demo_quick(capsys, tmp_path):
    folder = tmp_path / "demo"
    assert main(["demo", "--quick", "--out", str(folder)]) == 0
    out, err = capsys.readouterr()
    assert err == ""  # no progress when standard error is not a terminal
    _check_demo_output(out, folder)
    assert "--quick" in out

    # --force writes into the non-empty folder and leaves other files alone
    (folder / "notes.txt").write_text("mine")
    assert main(["demo", "--quick", "--out", str(folder), "--force"]) == 0
    capsys.readouterr()
    assert (folder / "notes.txt").read_text() == "mine"


@pytest.mark.slow
def test_full_demo_runs(capsys, tmp_path):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    _check_demo_output(out, tmp_path)
    assert "the seeds' settings" in out and "90 particles x 100 iterations" in out


def _driven_frame():
    """Three tests of 300 rows (30 s apart), each starting at rest: the target
    follows the spindle speed through a 45-min lag and sensor T1_C (a 20-min
    lag of the speed plus a drift of the room); T2_C is an unrelated random
    walk."""
    from greyml import make_test_index
    from greyml.dynamic._kernels import lag_filter

    rng = np.random.default_rng(7)
    n, tests = 300, ["a", "b", "c"]
    k = np.arange(n)
    rpm = np.concatenate(
        [np.where((k >= 20) & (k < 150 + 30 * i), 2000.0 * (i + 1), 0.0) for i in range(3)]
    )
    bounds = [(i * n, (i + 1) * n) for i in range(3)]
    dt = np.full(3 * n, 30.0)
    lags, _ = lag_filter(rpm[:, None], dt, np.array([1200.0, 2700.0]), bounds)
    # T1 also drifts with the room (a random walk the speed cannot explain)
    t1 = 20.0 + 1e-3 * lags[:, 0, 0] + np.cumsum(rng.normal(0, 0.02, 3 * n))
    t2 = 20.0 + np.cumsum(rng.normal(0, 0.02, 3 * n))
    y = 2e-3 * lags[:, 0, 1] + 1.5 * (t1 - 20.0)
    index = make_test_index(np.repeat(tests, n), np.tile(np.arange(n) * 30.0, 3))
    return pd.DataFrame(
        {"spindle_rpm": rpm, "T1_C": t1, "T2_C": t2, "dz_um": y + rng.normal(0, 0.01, 3 * n)},
        index=index,
    )


def test_fit_transfer_function_with_drivers_and_a_sensor_budget(capsys, tmp_path):
    data = write_tests_csv(_driven_frame(), tmp_path / "driven.csv")
    model = tmp_path / "ttf.greyml"
    argv = ["fit", str(data), "--target", "dz_um", "--model", "transfer-function"]
    code = main([*argv, "--drivers", "spindle_rpm", "--max-sensors", "1", "--out", str(model)])
    out = capsys.readouterr().out
    assert code == 0
    assert (
        "inputs: drivers spindle_rpm; sensors T1_C (chosen inside the fit on held-out whole tests from 2)"
        in out
    )
    assert "spindle_rpm: " in out and "µm per 1000 rpm" in out
    loaded = load_model(model)
    assert loaded.selected_sensors_ == ["T1_C"] and loaded.drivers_ == ["spindle_rpm"]
    pred = tmp_path / "pred.csv"
    assert main(["predict", str(model), str(data), "--out", str(pred)]) == 0
    out = capsys.readouterr().out
    # a table test by test, each test marked as fitted on
    rows = [line.split() for line in out.splitlines() if line.split()[1:2] == ["*"]]
    assert [r[0] for r in rows] == ["a", "b", "c"]
    assert all(float(r[3]) < 0.05 for r in rows)  # the noise is 0.01 µm; the peak about 6 µm
    assert "* fitted on this test" in out and "none, every test was fitted on" in out


@pytest.mark.parametrize(
    "extra, match",
    [
        (["--model", "gmc", "--drivers", "spindle_rpm"], "are for --model transfer-function"),
        (["--model", "transfer-function", "--drivers", "rpm"], "--drivers names 'rpm'"),
        (["--model", "transfer-function", "--n-sensors", "1"], "--max-sensors instead"),
        (
            ["--model", "transfer-function", "--drivers", "spindle_rpm", "--max-sensors", "3"],
            "more than the 2 sensor",
        ),
    ],
)
def test_transfer_function_flags_are_checked(capsys, tmp_path, extra, match):
    data = write_tests_csv(_driven_frame(), tmp_path / "driven.csv")
    argv = ["fit", str(data), "--target", "dz_um", *extra, "--out", str(tmp_path / "m.greyml")]
    assert match in _error(capsys, argv)


def test_fit_with_rises_equals_a_csv_of_rises_and_predict_applies_them(capsys, tmp_path):
    frame = _tiny_frame()
    rises = frame.copy()
    sensors = ["T1_C", "T2_C", "T3_C"]
    for label in ("A", "B"):
        rows = rises.index.get_level_values("test") == label
        rises.loc[rows, sensors] -= frame.loc[rows, sensors].iloc[0].to_numpy()
    raw_csv = write_tests_csv(frame, tmp_path / "raw.csv")
    rise_csv = write_tests_csv(rises, tmp_path / "rises.csv")
    common = ["--target", "dz_um", "--model", "mlp", "--sensors", "T1_C,T2_C,T3_C"]
    assert (
        main([str(a) for a in ["fit", raw_csv, *common, "--rises", "--out", tmp_path / "r.greyml"]])
        == 0
    )
    out = capsys.readouterr().out
    assert "inputs enter as rises from each test's first row (RelativeToStart)" in out
    assert main([str(a) for a in ["fit", rise_csv, *common, "--out", tmp_path / "h.greyml"]]) == 0
    capsys.readouterr()
    with_rises, by_hand = load_model(tmp_path / "r.greyml"), load_model(tmp_path / "h.greyml")
    assert [name for name, _ in with_rises.steps] == ["rises", "model"]
    assert with_rises["rises"].columns_ == sensors
    np.testing.assert_allclose(
        with_rises.predict(frame[sensors]), by_hand.predict(rises[sensors]), rtol=0, atol=1e-9
    )
    # greyml predict reads absolute temperatures and applies the saved rises
    assert (
        main(
            [
                str(a)
                for a in ["predict", tmp_path / "r.greyml", raw_csv, "--out", tmp_path / "p.csv"]
            ]
        )
        == 0
    )
    capsys.readouterr()
    written = read_tests_csv(tmp_path / "p.csv")
    np.testing.assert_allclose(
        written["predicted_dz_um"].to_numpy(), by_hand.predict(rises[sensors]), rtol=0, atol=1e-6
    )


def test_fit_with_rises_keeps_the_drivers_as_levels(capsys, tmp_path):
    data = write_tests_csv(_tiny_frame(), tmp_path / "tiny.csv")
    argv = ["fit", data, "--target", "dz_um", "--model", "transfer-function"]
    argv += ["--drivers", "spindle_rpm", "--max-sensors", "1", "--rises"]
    assert main([str(a) for a in [*argv, "--out", tmp_path / "t.greyml"]]) == 0
    capsys.readouterr()
    saved = load_model(tmp_path / "t.greyml")
    assert saved["rises"].columns_ == ["T1_C", "T2_C", "T3_C"]


def test_demo_marks_a_model_that_misses_the_paper_by_far():
    from greyml._cli._demo import _missed

    paper = {"RMSE": None, "band": "<5", "improvement": ">80"}
    ours = {"R": 0.034, "RMSE": 9.0, "E": -0.5, "band": 12.3, "improvement": -1.46}
    assert _missed(paper, ours) == "±res 12.3 against <5 µm; impr% -146 against >80"
    close = {"R": 0.97, "RMSE": 5.0, "E": 0.9, "band": 9.5, "improvement": 0.85}
    assert _missed({"RMSE": 4.6, "band": 9.0}, close) is None
    assert _missed(None, ours) is None
