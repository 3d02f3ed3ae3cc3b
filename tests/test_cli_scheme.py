"""The command line's common scheme (issues 15 and 19): flags, units, spreadsheet
files, progress, light start-up, and what greyml writes and prints.

Every case runs through ``greyml.cli.main`` (or ``python -m greyml``) and checks
the exit code, that an error is one line on standard error, and what it names.
"""

import csv
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest

from greyml import GreyInfluenceSelector, MLPBaseline, make_test_index
from greyml.cli import main
from greyml.io import read_tests_csv, write_tests_csv

FORMULAS = ["=cmd|' /C calc'!A0", "+1+1", "-2", "@SUM(A1)"]


def _frame(labels=("A", "B"), n=40):
    """Short heating tests: three temperatures and dz_um, 60 s apart."""
    frames = []
    for k, label in enumerate(labels):
        t = 60.0 * np.arange(n)
        heat = 1.0 - np.exp(-t / (600.0 + 200.0 * k))
        frames.append(
            pd.DataFrame(
                {
                    "T1_C": 20.0 + 6.0 * heat,
                    "T2_C": 20.0 + 3.0 * heat**2,
                    "T3_C": 20.0 + 0.1 * np.sin(t / 500.0 + k),
                    "dz_um": -20.0 * heat - 3.0 * heat**2,
                },
                index=make_test_index([label] * n, t),
            )
        )
    return pd.concat(frames)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """A CSV of two tests and an MLP model file fitted on it."""
    folder = tmp_path_factory.mktemp("scheme")
    data = write_tests_csv(_frame(), folder / "data.csv")
    model = folder / "mlp.greyml"
    argv = ["fit", data, "--target", "dz_um", "--model", "mlp", "--out", model, "--quiet"]
    assert main([str(a) for a in argv]) == 0
    return {"data": data, "model": model}


def _run(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _error(capsys, argv):
    """Exit code 2, nothing on stdout, one line ``greyml <command>: error: ...``."""
    code, out, err = _run(capsys, argv)
    assert code == 2, (out, err)
    assert out == ""
    assert "Traceback" not in err
    assert err.startswith(f"greyml {argv[0]}: error: "), err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    return err


def _write(path, text, encoding="utf-8"):
    path.write_text(text, encoding=encoding)
    return path


def _minutes_csv(path, frame, sep=",", decimal=".", bom=False):
    """``frame`` as a spreadsheet would write it: time in minutes, chosen separator."""
    out = frame.reset_index()
    out["time_s"] = out["time_s"] / 60.0
    text = out.to_csv(index=False, sep=sep, decimal=decimal, lineterminator="\n")
    return _write(path, ("\ufeff" if bom else "") + text)


# ------------------------------------------------------------------------------
# Light start-up: --version and --help import no numerical library
# ------------------------------------------------------------------------------


@pytest.mark.parametrize("argv", [["--version"], ["--help"], ["gap", "--help"]])
def test_version_and_help_import_no_heavy_module(argv):
    code = textwrap.dedent(
        f"""
        import sys
        from greyml.cli import main
        code = main({argv!r})
        heavy = {{"numpy", "pandas", "scipy", "sklearn", "matplotlib", "tqdm", "skfuzzy"}}
        loaded = sorted(heavy & {{name.split(".")[0] for name in sys.modules}})
        print("LOADED", loaded, code)
        """
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )
    assert proc.returncode == 0, proc.stderr
    last = proc.stdout.strip().splitlines()[-1]
    if argv == ["gap", "--help"]:  # the effects' names come from greyml.gap, when shown
        assert last.endswith(" 0") and "Effects (--effects)" in proc.stdout
    else:
        assert last == "LOADED [] 0", proc.stdout


def test_lazy_package_attributes_are_the_classes():
    import greyml
    from greyml.grey import GMC

    assert greyml.GMC is GMC
    assert set(greyml.__all__) <= set(dir(greyml))
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        greyml.nothing  # noqa: B018


# ------------------------------------------------------------------------------
# One flag scheme
# ------------------------------------------------------------------------------


def test_select_takes_n_sensors_and_train_tests(case, capsys):
    new = ["select", case["data"], "--target", "dz_um", "--n-sensors", "2", "--train-tests", "A"]
    code, _, err = _run(capsys, new)
    assert code == 0 and err == "", err


def test_select_clusters_as_the_selector_does_by_default(case, capsys):
    default = GreyInfluenceSelector().cluster_on
    code, out, _ = _run(capsys, ["select", case["data"], "--target", "dz_um", "--n-sensors", "2"])
    assert code == 0
    assert f"cluster_on={default!r}" in out
    code, out, _ = _run(
        capsys,
        ["select", case["data"], "--target", "dz_um", "--n-sensors", "2", "--cluster-on", "series"],
    )
    assert code == 0 and "cluster_on='series'" in out


def test_fit_select_is_n_sensors(case, capsys, tmp_path):
    argv = ["fit", case["data"], "--target", "dz_um", "--model", "gmc", "--quiet"]
    code, out, err = _run(capsys, [*argv, "--n-sensors", "2", "--out", tmp_path / "b.greyml"])
    assert code == 0 and err == ""
    err = _error(capsys, [*argv, "--n-sensors", "9", "--out", tmp_path / "c.greyml"])
    assert "--n-sensors 9" in err and "3 candidate" in err


def _subcommands():
    """The ``greyml`` parser and its subcommands' parsers, by name."""
    import argparse

    from greyml._cli._parser import build_parser

    parser = build_parser()
    (subs,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return parser, subs.choices


def test_no_help_speaks_of_deprecation(capsys):
    parser, commands = _subcommands()
    assert re.search(r"--n-sensors N\s", commands["select"].format_help())  # help is read
    for name, text in [("greyml", parser.format_help())] + [
        (f"greyml {command}", sub.format_help()) for command, sub in commands.items()
    ]:
        assert "deprecat" not in text.lower(), name


def test_simulate_seed_is_random_state(capsys, tmp_path):
    argv = ["simulate", "--machine", "vmc-probe", "--programme", "10:spindle_rpm=3000,5"]
    code, _, err = _run(capsys, [*argv, "--random-state", "3", "--out", tmp_path / "new.csv"])
    assert code == 0 and err == ""
    code, _, err = _run(capsys, [*argv, "--random-state", "3", "--out", tmp_path / "again.csv"])
    assert code == 0 and err == ""
    assert (tmp_path / "new.csv").read_bytes() == (tmp_path / "again.csv").read_bytes()
    code, _, _ = _run(capsys, [*argv, "--random-state", "4", "--out", tmp_path / "other.csv"])
    assert (tmp_path / "other.csv").read_bytes() != (tmp_path / "new.csv").read_bytes()


@pytest.mark.parametrize(
    "argv, words",
    [
        (["gap", "real.csv"], "the following arguments are required: SIM.csv, --target"),
        (["gap", "a.csv", "b.csv", "--target", "z", "--random-state", "x"], "'x'"),
        (["gap", "a.csv", "b.csv", "--target", "z", "--tolerance"], "expected one argument"),
        (["select", "a.csv", "--target", "z", "--time-unit", "hours"], "'hours'"),
    ],
)
def test_usage_errors_are_one_line(capsys, argv, words):
    err = _error(capsys, argv)
    assert words in err and f"(see greyml {argv[0]} --help)" in err


def test_gap_json_file_is_not_replaced_without_force(capsys, tmp_path):
    report = _write(tmp_path / "report.json", "mine\n")
    argv = ["gap", "real.csv", "sim.csv", "--target", "dz_um", "--json", report]
    err = _error(capsys, argv)
    assert repr(str(report)) in err and "--force" in err
    assert report.read_text() == "mine\n"


# ------------------------------------------------------------------------------
# Time units and spreadsheet files
# ------------------------------------------------------------------------------


def test_time_unit_minutes_through_predict(case, capsys, tmp_path):
    minutes = _minutes_csv(tmp_path / "minutes.csv", _frame())
    out_csv = tmp_path / "pred.csv"
    argv = ["predict", case["model"], minutes, "--out", out_csv, "--time-unit", "min"]
    code, _, err = _run(capsys, argv)
    assert code == 0, err
    pred = read_tests_csv(out_csv)
    expected = read_tests_csv(case["data"])
    # time_s is in seconds again: 60 s apart, as in the original file
    assert pred.index.equals(expected.index)
    assert pred.index.get_level_values("time_s")[:3].tolist() == [0.0, 60.0, 120.0]


def test_spreadsheet_file_is_read_like_the_plain_one(case, capsys, tmp_path):
    plain = tmp_path / "plain.csv"
    code, _, err = _run(capsys, ["predict", case["model"], case["data"], "--out", plain])
    assert code == 0, err
    sheet = _minutes_csv(tmp_path / "sheet.csv", _frame(), sep=";", decimal=",", bom=True)
    assert sheet.read_bytes().startswith(b"\xef\xbb\xbftest;time_s;")
    assert ",5" in sheet.read_text(encoding="utf-8-sig")  # decimal commas
    from_sheet = tmp_path / "sheet-pred.csv"
    argv = ["predict", case["model"], sheet, "--out", from_sheet, "--time-unit", "min"]
    code, _, err = _run(capsys, argv)
    assert code == 0, err
    pd.testing.assert_frame_equal(read_tests_csv(from_sheet), read_tests_csv(plain))
    # named explicitly, the same
    argv += ["--sep", ";", "--decimal", ",", "--force"]
    assert _run(capsys, argv)[0] == 0
    pd.testing.assert_frame_equal(read_tests_csv(from_sheet), read_tests_csv(plain))


def test_tab_separated_file(case, capsys, tmp_path):
    tabs = _minutes_csv(tmp_path / "tabs.tsv", _frame(), sep="\t")
    argv = ["select", tabs, "--target", "dz_um", "--n-sensors", "2", "--time-unit", "min"]
    code, out, err = _run(capsys, argv)
    assert code == 0, err
    assert "kept 2 of 3 candidate sensors" in out
    code, out, err = _run(capsys, [*argv, "--sep", "tab"])
    assert code == 0, err


def test_decimal_commas_in_a_comma_file_are_named(case, capsys, tmp_path):
    bad = _write(tmp_path / "bad.csv", "test,time_s,T1_C,T2_C,T3_C\nA,0,20,5,20,1,20,0\n")
    err = _error(capsys, ["predict", case["model"], bad, "--out", tmp_path / "p.csv"])
    assert "Line 2 of" in err and "8 fields but the header has 5" in err
    assert "decimal commas" in err
    assert not (tmp_path / "p.csv").exists()


def test_a_huge_line_is_one_error(case, capsys, tmp_path, monkeypatch):
    import greyml.io._csv as csv_module

    monkeypatch.setattr(csv_module, "MAX_LINE_BYTES", 4096)
    huge = tmp_path / "huge.csv"
    huge.write_text("test,time_s," + ",".join(["T1_C"] * 20_000))  # one line, no newline
    err = _error(capsys, ["select", huge, "--target", "dz_um"])
    assert "Line 1 of" in err and "longer than 4,096 bytes" in err


def test_a_huge_line_under_a_memory_limit(tmp_path):
    """A 24 MiB single-line file (over the 16 MiB default) under a 1 GiB address-space cap."""
    if not sys.platform.startswith("linux"):
        pytest.skip("RLIMIT_AS caps memory on Linux only")
    resource = pytest.importorskip("resource")
    huge = tmp_path / "huge.csv"
    with open(huge, "wb") as fh:
        fh.write(b"test,time_s")
        for _ in range(24):
            fh.write(b",1.5" * (2**18))
    limit = 2**30

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    proc = subprocess.run(
        [sys.executable, "-m", "greyml", "select", str(huge), "--target", "dz_um"],
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=cap,
        env=env,
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "Line 1 of" in proc.stderr and "longer than 16,777,216 bytes" in proc.stderr


# ------------------------------------------------------------------------------
# What greyml writes: no formulas, no partial files, no empty compensation
# ------------------------------------------------------------------------------


def test_predict_writes_no_cell_a_spreadsheet_would_run(case, capsys, tmp_path):
    data = write_tests_csv(_frame(labels=FORMULAS, n=10), tmp_path / "labels.csv")
    out_csv = tmp_path / "pred.csv"
    code, _, err = _run(capsys, ["predict", case["model"], data, "--out", out_csv])
    assert code == 0, err
    with open(out_csv, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["test", "time_s", "predicted_dz_um", "compensation_dz_um"]
    negative = 0
    for row in rows[1:]:
        assert row[0].startswith("'") and row[0][1:] in FORMULAS
        for cell in row[1:]:
            float(cell)  # numbers, negative ones too, stay numbers
            negative += cell.startswith("-")
    assert negative > 0
    labels = read_tests_csv(out_csv).index.get_level_values("test")
    assert list(dict.fromkeys(labels)) == FORMULAS


def test_predicting_nan_is_an_error_and_writes_nothing(case, capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(MLPBaseline, "predict", lambda self, X: np.full(len(X), np.nan))
    out_csv = tmp_path / "pred.csv"
    err = _error(capsys, ["predict", case["model"], case["data"], "--out", out_csv])
    assert "predicts nan for every row" in err and "test 'A'" in err
    assert "No compensation written" in err
    assert list(tmp_path.iterdir()) == []


def test_a_failing_write_leaves_no_file(case, capsys, tmp_path, monkeypatch):
    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", full_disk)
    out_csv = tmp_path / "pred.csv"
    err = _error(capsys, ["predict", case["model"], case["data"], "--out", out_csv])
    assert "No space left on device" in err
    assert list(tmp_path.iterdir()) == []


def test_terminal_control_in_metadata_is_not_printed(capsys, tmp_path):
    target = "dz\x1b]0;pwned\x07\x1b[2J_um"
    frame = _frame().rename(columns={"dz_um": target})
    data = write_tests_csv(frame, tmp_path / "ansi.csv")
    model = tmp_path / "m.greyml"
    argv = ["fit", data, "--target", target, "--model", "gmc", "--out", model]
    code, out, err = _run(capsys, argv)
    assert code == 0, err
    code, out2, err2 = _run(capsys, ["predict", model, data, "--out", tmp_path / "p.csv"])
    assert code == 0, err2
    for text in (out, err, out2, err2):
        assert "\x1b" not in text and "\x07" not in text
    assert "dz_um" in out and "predicted_dz_um" in out2


def test_printable_strips_escapes():
    from greyml._cli._printing import printable

    assert printable("0.1\x1b]0;title\x07\x1b[2J\x1b[31m.dev\x1b[0m\u202e\nX") == "0.1.dev X"


# ------------------------------------------------------------------------------
# Progress on standard error (a terminal), never on standard output
# ------------------------------------------------------------------------------


def _on_a_terminal(argv):
    """Run ``python -m greyml argv`` with standard error on a pseudo-terminal."""
    pty = pytest.importorskip("pty")
    master, slave = pty.openpty()
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "greyml", *map(str, argv)],
            stdout=subprocess.PIPE,
            stderr=slave,
            env=dict(os.environ, COLUMNS="120"),
        )
        os.close(slave)
        screen = b""
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # the child closed the terminal
                break
            if not chunk:
                break
            screen += chunk
        out = proc.stdout.read()
        proc.stdout.close()
        proc.wait(timeout=120)
    finally:
        os.close(master)
    return proc.returncode, out.decode(), screen.decode(errors="replace")


def test_progress_on_a_terminal_and_quiet(case, tmp_path):
    argv = ["predict", case["model"], case["data"], "--out", tmp_path / "p.csv"]
    code, out, screen = _on_a_terminal(argv)
    assert code == 0, screen
    for step in ("[1/4] reading the model", "[2/4] reading", "[3/4] predicting 80 rows"):
        assert step in screen, screen
    assert "[4/4] writing" in screen
    assert re.search(r"\d\d:\d\d", screen), screen  # an elapsed time is shown, whatever it is
    assert "\r" not in out and "[1/4]" not in out and out.startswith("wrote 80 rows")
    code, out, screen = _on_a_terminal([*argv, "--force", "--quiet"])
    assert code == 0 and screen == "" and out.startswith("wrote 80 rows")


def test_progress_redraws_the_elapsed_time_while_a_step_runs(monkeypatch):
    import io
    import threading

    from greyml._cli._printing import Progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    redrawn = threading.Event()
    screen = Terminal()
    monkeypatch.setattr(Progress, "REFRESH_S", 0.01)
    progress = Progress(1, stream=screen)
    progress.step("fitting GNNMCI")
    before = screen.getvalue().count("fitting GNNMCI")
    for _ in range(500):  # up to 5 s: wait for two redraws by the timer
        if screen.getvalue().count("fitting GNNMCI") >= before + 2:
            redrawn.set()
            break
        redrawn.wait(0.01)
    progress.close()
    assert redrawn.is_set()
    assert "[1/1] fitting GNNMCI\u2026 00:00" in screen.getvalue()
