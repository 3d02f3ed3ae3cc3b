"""No terminal control from a file reaches the terminal, whatever the command (issue 26).

A CSV file whose column names and test labels hold escape sequences (clear
the screen, retitle the window) and other control characters goes through
``greyml select``, ``fit``, ``predict`` and ``gap``: their standard output and
standard error hold no control character but the line break. Every command
prints through one stream that strips them (``greyml._cli._printing``).
"""

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import greyml
from greyml import make_test_index
from greyml._cli._printing import _TerminalText, printable, terminal_safe
from greyml.cli import main
from greyml.io import write_tests_csv

#: Clear the screen; set the window's title; C0, DEL and C1 (CSI) controls; a
#: right-to-left override.
CLEAR, TITLE = "\x1b[2J", "\x1b]0;title\x07"
TARGET = f"dz{CLEAR}\x01_um"
SENSORS = [f"T1{CLEAR}_C", f"T2{TITLE}_C", "T3\x07\x7f\x9b\x08_C"]
LABELS = [f"A{CLEAR}", f"B{TITLE}\x1b[31m", "C\u202e\x0b"]

#: The package under test, for ``python -m greyml`` in a subprocess.
ROOT = str(Path(greyml.__file__).resolve().parents[1])


def _hostile_frame(n=60):
    """Three short heating tests whose labels and column names hold terminal control."""
    frames = []
    for k, label in enumerate(LABELS):
        t = 60.0 * np.arange(n)
        heat = 1.0 - np.exp(-t / (900.0 + 300.0 * k))
        ambient = 20.0 + 0.2 * k + 0.1 * np.sin(t / 2000.0)
        rng = np.random.default_rng(k)
        frames.append(
            pd.DataFrame(
                {
                    "spindle_rpm": np.where(t < 1800, 4000.0 + 1000.0 * k, 0.0),
                    "ambient_C": ambient,
                    SENSORS[0]: ambient + 6.0 * heat + 0.01 * rng.standard_normal(n),
                    SENSORS[1]: ambient + 3.0 * heat**2 + 0.01 * rng.standard_normal(n),
                    SENSORS[2]: ambient + 0.05 * rng.standard_normal(n),
                    TARGET: -20.0 * heat - 3.0 * heat**2 + 0.01 * rng.standard_normal(n),
                },
                index=make_test_index([label] * n, t),
            )
        )
    return pd.concat(frames)


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hostile")
    frame = _hostile_frame()
    data = write_tests_csv(frame, folder / "hostile.csv")
    # the simulation misses a drift of 0.5 µm/h, so that gap has something to say
    hours = frame.index.get_level_values("time_s").to_numpy() / 3600.0
    noise = 0.01 * np.random.default_rng(9).standard_normal((len(frame), 1))
    sim = frame[[TARGET]] - 0.5 * hours[:, None] + noise
    return {"folder": folder, "data": data, "sim": write_tests_csv(sim, folder / "sim.csv")}


def _greyml(*argv):
    """``python -m greyml argv``: exit code, standard output and error as bytes."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run(
        [sys.executable, "-m", "greyml", *map(str, argv)],
        capture_output=True,
        env=env,
        timeout=300,
        check=False,
    )
    return proc.returncode, proc.stdout, proc.stderr


def _assert_no_control(raw, where):
    """No control character but the line break: C0, DEL and C1 (as bytes and as text)."""
    bad = sorted({b for b in raw if (b < 0x20 and b != 0x0A) or b == 0x7F})
    assert not bad, f"{where}: control bytes {bad} in {raw!r}"
    text = raw.decode("utf-8")  # C1 controls are two bytes in UTF-8: check the characters
    c1 = sorted({hex(ord(ch)) for ch in text if 0x80 <= ord(ch) <= 0x9F})
    assert not c1, f"{where}: C1 controls {c1} in {text!r}"


def _check(code, out, err, where):
    assert code == 0, err.decode(errors="replace")
    _assert_no_control(out, f"{where} stdout")
    _assert_no_control(err, f"{where} stderr")
    return out.decode("utf-8"), err.decode("utf-8")


def test_select_prints_no_terminal_control(hostile):
    out, _ = _check(
        *_greyml("select", hostile["data"], "--target", TARGET, "--n-sensors", "2"), "select"
    )
    # what the names hold besides the control is still shown, and the table aligned
    assert "Test A, Test B and Test C" in out and "target 'dz_um'" in out
    rows = [line for line in out.splitlines() if line.startswith(("     1  ", "     2  "))]
    assert len(rows) == 2
    assert all(line[8:22].rstrip() in ("T1_C", "T2_C", "T3_C") for line in rows), rows


def test_fit_and_predict_print_no_terminal_control(hostile):
    folder = hostile["folder"]
    model = folder / "gmc.greyml"
    argv = ["fit", hostile["data"], "--target", TARGET, "--model", "gmc", "--out", model]
    out, _ = _check(*_greyml(*argv), "fit gmc")
    assert "inputs (3): T1_C, T2_C, T3_C" in out
    # a transfer function describes each input's response, by name
    dynamic = folder / "ttf.greyml"
    argv = ["fit", hostile["data"], "--target", TARGET, "--model", "transfer-function"]
    argv += ["--drivers", "spindle_rpm", "--out", dynamic]
    out, _ = _check(*_greyml(*argv), "fit transfer-function")
    assert "T1_C: " in out
    # predict prints what the model file says (its target's name) and the labels
    for saved in (model, dynamic):
        pred = folder / f"{saved.stem}.csv"
        out, _ = _check(*_greyml("predict", saved, hostile["data"], "--out", pred), "predict")
        assert "predicted_dz_um" in out


def test_gap_prints_no_terminal_control(hostile):
    roles = ["--ambient", "ambient_C", "--drivers", "spindle_rpm", "--sensors", ",".join(SENSORS)]
    argv = ["gap", hostile["data"], hostile["sim"], "--target", TARGET, *roles]
    argv += ["--effects", "drift,ambient", "--random-state", "0"]
    out, _ = _check(*_greyml(*argv), "gap")
    assert out.startswith("Verdict:") and "dz_um" in out
    # --json -: only the JSON on standard output, the names in it escaped (\u001b)
    code, out, err = _greyml(*argv, "--json", "-")
    out, _ = _check(code, out, err, "gap --json -")
    data = json.loads(out)
    assert "drift" in {row["effect"] for row in data["causes"]}


def test_gap_json_to_stdout_with_progress_on_a_terminal(hostile):
    """With standard error on a terminal, the progress goes there; stdout is only JSON."""
    pty = pytest.importorskip("pty")
    master, slave = pty.openpty()
    argv = ["gap", hostile["data"], hostile["sim"], "--target", TARGET, "--ambient", "ambient_C"]
    argv += ["--drivers", "spindle_rpm", "--effects", "drift", "--random-state", "0"]
    screen = []

    def read_terminal():
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # the child closed the terminal
                return
            if not chunk:
                return
            screen.append(chunk)

    reader = threading.Thread(target=read_terminal, daemon=True)
    reader.start()
    env = dict(os.environ, PYTHONPATH=ROOT, COLUMNS="120")
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "greyml", *map(str, argv), "--json", "-"],
            stdout=subprocess.PIPE,
            stderr=slave,
            env=env,
            timeout=300,
            check=False,
        )
    finally:
        os.close(slave)
        reader.join(timeout=60)
        os.close(master)
    shown = b"".join(screen).decode(errors="replace")
    assert proc.returncode == 0, shown
    assert "[1/3] reading" in shown and "[2/3] diagnosing the gap" in shown
    _assert_no_control(proc.stdout, "gap --json - stdout")
    data = json.loads(proc.stdout)  # nothing but the JSON
    assert data["causes"][0]["effect"] == "drift"


def test_an_error_naming_the_columns_prints_no_terminal_control(hostile):
    code, out, err = _greyml("select", hostile["data"], "--target", "dx_um")
    assert code == 2 and out == b""
    _assert_no_control(err, "select error")
    assert err.decode().startswith("greyml select: error: --target names 'dx_um'")


def test_one_printing_path_in_process(hostile, capsys, tmp_path):
    """``main`` prints through the stripping stream, and puts the streams back after."""
    before = sys.stdout, sys.stderr
    argv = ["fit", hostile["data"], "--target", TARGET, "--model", "mlp"]
    assert main([*map(str, argv), "--out", str(tmp_path / "m.greyml")]) == 0
    assert (sys.stdout, sys.stderr) == before
    out, err = capsys.readouterr()
    for text in (out, err):
        _assert_no_control(text.encode("utf-8"), "fit mlp")
    assert "T2_C" in out and "Test A, Test B and Test C" in out


def test_terminal_text_strips_control_and_keeps_line_breaks():
    import io

    raw = io.StringIO()
    stream = _TerminalText(raw)
    stream.write(f"a{CLEAR}b\t{TITLE}c\r\n")
    stream.writelines(["\x1b]0;unterminated\n", "d\x9b\x7f\u202ee\n"])
    assert raw.getvalue() == "ab c \n\nde\n"
    assert printable("x\ny\tz\x1b[0m") == "x y z"
    # terminal_safe wraps both streams once, and puts them back
    with terminal_safe():
        inner = sys.stdout
        assert isinstance(inner, _TerminalText)
        with terminal_safe():
            assert sys.stdout.unfiltered is inner.unfiltered
        assert sys.stdout is inner
    assert not isinstance(sys.stdout, _TerminalText)
