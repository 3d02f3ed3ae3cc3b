"""Ctrl-C and SIGTERM stop a ``greyml`` command cleanly (issue 26).

Whenever the signal comes, the command prints one line
``greyml <command>: interrupted`` on standard error (no traceback), exits
with 130 (SIGINT) or 143 (SIGTERM), and leaves no partial output and no
hidden temporary file or folder: ``--out`` is either absent or complete.

``greyml demo --quick`` and ``greyml fit`` run in a subprocess that gets the
signal at 20 moments drawn at random (seeded) across their runs; the model
save, the demo's figures and the moves into place are interrupted on
purpose in-process. No test decides by a clock: the moments only choose
when to send the signal.
"""

import errno
import os
import random
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import greyml
from greyml import make_test_index
from greyml.cli import main
from greyml.io import write_tests_csv
from greyml.persist import load_model

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")

#: The package under test, for ``python -m greyml`` in a subprocess.
ROOT = str(Path(greyml.__file__).resolve().parents[1])
CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}


@pytest.fixture(autouse=True)
def _ctrl_c_heard():
    """Ctrl-C as a terminal delivers it, for this test and the commands it starts.

    A test run started in the background (``nohup pytest &``) inherits SIGINT
    ignored; greyml then rightly leaves it ignored (the user asked for that),
    and so would a command started from here. These tests are about a SIGINT
    that is heard, so they give it Python's usual handler, and restore what
    was there after."""
    before = signal.getsignal(signal.SIGINT)
    if before is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, before)


def _moments(n, longest_s, seed):
    """``n`` (delay after the command started, signal): one delay at random in each
    of ``n`` equal parts of [0, longest_s], SIGINT and SIGTERM at random."""
    rng = random.Random(seed)
    part = longest_s / n
    return [
        (round((k + rng.random()) * part, 2), rng.choice((signal.SIGINT, signal.SIGTERM)))
        for k in range(n)
    ]


#: ``greyml demo --quick`` takes 6-10 s on a 2-core machine; ``greyml fit
#: --model gnnmci`` on the small tests below 2-3 s, most of it importing. The
#: moments stay within the first half of each, so the signal comes while
#: the command works.
DEMO_MOMENTS = _moments(10, 4.0, seed=26)
FIT_MOMENTS = _moments(10, 1.3, seed=9)


def _frame(n=120):
    """Two short heating tests: three temperatures, the spindle speed and dz_um."""
    frames = []
    for k, label in enumerate(["A", "B"]):
        t = 60.0 * np.arange(n)
        heat = 1.0 - np.exp(-t / (900.0 + 300.0 * k))
        rng = np.random.default_rng(k)
        ambient = 20.0 + 0.2 * k + 0.1 * np.sin(t / 2000.0)
        frames.append(
            pd.DataFrame(
                {
                    "spindle_rpm": np.full(n, 4000.0 + 2000.0 * k),
                    "T1_C": ambient + 6.0 * heat + 0.02 * rng.standard_normal(n),
                    "T2_C": ambient + 3.0 * heat**2 + 0.02 * rng.standard_normal(n),
                    "T3_C": ambient + 0.02 * rng.standard_normal(n),
                    "dz_um": -20.0 * heat - 3.0 * heat**2,
                },
                index=make_test_index([label] * n, t),
            )
        )
    return pd.concat(frames)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    return write_tests_csv(_frame(), tmp_path_factory.mktemp("data") / "tests.csv")


def _hidden(folder):
    """Hidden files or folders (greyml's temporaries are ``.NAME.*.part``) in ``folder``."""
    return sorted(p.name for p in Path(folder).iterdir() if p.name.startswith("."))


def _handles_sigterm(pid):
    """Whether process ``pid`` catches SIGTERM (from /proc; None where there is none)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    for line in status.splitlines():
        if line.startswith("SigCgt:"):
            return bool(int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1)
    return None


def _interrupt(argv, delay_s, signum):
    """Run ``python -m greyml argv``; send ``signum`` ``delay_s`` after it started.

    "Started" is when ``greyml.cli.main`` catches SIGTERM: Python's own start-up
    before it writes nothing. Returns the exit code and standard error.
    """
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen(
        [sys.executable, "-m", "greyml", *map(str, argv)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env=env,
        start_new_session=True,
    )
    try:
        while True:
            caught = _handles_sigterm(proc.pid)
            if caught is None:  # no /proc: Python starts in well under a second
                time.sleep(1.0)
                break
            if caught:
                break
            # a command that never catches SIGTERM would end killed by it
            assert proc.poll() is None, "greyml ended without ever catching SIGTERM"
            time.sleep(0.002)
        time.sleep(delay_s)
        if proc.poll() is None:
            proc.send_signal(signum)
        _, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err.decode("utf-8", errors="replace")


def _check_interrupted(code, err, command, signum):
    """The exit code says which signal, and the last line of stderr is the one line."""
    assert code == CODES[signum], (code, err)
    assert "Traceback" not in err, err
    lines = err.splitlines()
    assert lines and lines[-1] == f"greyml {command}: interrupted", err
    assert err.count("interrupted") == 1, err


def _check_demo_folder(out):
    """A demo folder is complete: results.txt and the 12 whole PNG files."""
    names = sorted(p.name for p in out.iterdir())
    assert "results.txt" in names and len(names) == 13, names
    for name in names:
        if name.endswith(".png"):
            assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


@pytest.mark.parametrize(("delay_s", "signum"), DEMO_MOMENTS)
def test_interrupting_demo(tmp_path, delay_s, signum):
    out = tmp_path / "greyml-demo"
    code, err = _interrupt(["demo", "--quick", "--out", out], delay_s, signum)
    if code == 0:  # finished before the signal came: complete, and nothing else
        _check_demo_folder(out)
    else:
        _check_interrupted(code, err, "demo", signum)
        # no half-filled folder to block the next run
        assert not out.exists(), sorted(p.name for p in out.iterdir())
    assert _hidden(tmp_path) == []


@pytest.mark.parametrize(("delay_s", "signum"), FIT_MOMENTS)
def test_interrupting_fit(data, tmp_path, delay_s, signum):
    model = tmp_path / "m.greyml"
    argv = ["fit", data, "--target", "dz_um", "--model", "gnnmci", "--out", model]
    code, err = _interrupt(argv, delay_s, signum)
    if code != 0:
        _check_interrupted(code, err, "fit", signum)
    if model.exists():  # saved before the signal came: a whole model
        assert load_model(model).predict(_frame()[["T1_C", "T2_C", "T3_C"]]).shape == (240,)
    assert sorted(p.name for p in tmp_path.iterdir() if p != model) == []


# ------------------------------------------------------------------------------
# Interrupted on purpose, in-process: the save, the figures, the moves
# ------------------------------------------------------------------------------


def _signal_now(signum):
    """Send ``signum`` to this process; its handler raises here at the latest."""
    # without greyml's handler, SIGTERM would end the test run itself
    assert callable(signal.getsignal(signum)), f"no handler for signal {signum}"
    os.kill(os.getpid(), signum)
    for _ in range(1000):
        time.sleep(0.001)  # Python runs the handler between two sleeps
    raise AssertionError(f"signal {signum} was not handled")


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
@pytest.mark.parametrize("force", [False, True])
def test_a_signal_during_the_model_save_leaves_no_file(
    data, tmp_path, capsys, monkeypatch, signum, force
):
    model = tmp_path / "m.greyml"
    if force:
        model.write_bytes(b"the model before")
    writestr = zipfile.ZipFile.writestr
    calls = []

    def write_then_signal(self, name, payload, *args, **kwargs):
        calls.append(name)
        writestr(self, name, payload, *args, **kwargs)
        if len(calls) == 2:  # half-way through the archive
            _signal_now(signum)

    monkeypatch.setattr(zipfile.ZipFile, "writestr", write_then_signal)
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    argv = ["fit", str(data), "--target", "dz_um", "--model", "gmc", "--out", str(model)]
    code = main(argv + ["--force"] * force)
    _, err = capsys.readouterr()
    assert len(calls) == 2
    _check_interrupted(code, err, "fit", signum)
    # the handlers main put in place are gone again
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == (["m.greyml"] if force else [])
    if force:
        assert model.read_bytes() == b"the model before"


def _quick_demo(monkeypatch):
    """``greyml demo`` with GMC alone: seconds, not tens of them."""
    import greyml._cli._demo as demo

    monkeypatch.setattr(demo, "MODEL_NAMES", {"gmc": "GMC"})


@pytest.mark.parametrize("existing", [None, "empty", "forced"])
def test_a_signal_while_a_figure_is_drawn_leaves_out_as_it_was(
    tmp_path, capsys, monkeypatch, existing
):
    from matplotlib.figure import Figure

    _quick_demo(monkeypatch)
    out = tmp_path / "sub" / "demo"
    if existing:
        out.mkdir(parents=True)
    if existing == "forced":
        (out / "notes.txt").write_text("mine")

    def half_a_png_then_sigint(self, fh, **kwargs):
        fh.write(b"\x89PNG\r\n\x1a\n")
        _signal_now(signal.SIGINT)

    monkeypatch.setattr(Figure, "savefig", half_a_png_then_sigint)
    code = main(["demo", "--quick", "--out", str(out)] + ["--force"] * (existing == "forced"))
    _, err = capsys.readouterr()
    _check_interrupted(code, err, "demo", signal.SIGINT)
    if existing is None:  # the folders made for --out are gone again
        assert list(tmp_path.iterdir()) == []
    else:
        assert sorted(p.name for p in out.iterdir()) == ["notes.txt"] * (existing == "forced")
        assert _hidden(out.parent) == []


def test_a_full_disk_leaves_no_empty_figure(tmp_path, capsys, monkeypatch):
    from matplotlib.figure import Figure

    _quick_demo(monkeypatch)

    def full_disk(self, fh, **kwargs):
        fh.write(b"\x89PNG")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", full_disk)
    out = tmp_path / "demo"
    code = main(["demo", "--quick", "--out", str(out)])
    _, err = capsys.readouterr()
    assert code == 2 and "Traceback" not in err and err.count("\n") == 1, err
    assert err.startswith(f"greyml demo: error: cannot write the demo's files to '{out}'")
    assert "No space left on device" in err
    assert list(tmp_path.iterdir()) == []


def test_a_signal_while_the_files_move_waits_for_the_last(tmp_path, capsys, monkeypatch):
    """Into an existing folder the files move one by one: a signal meanwhile lets
    them all arrive, then stops the command (complete, not half-filled)."""
    _quick_demo(monkeypatch)
    real_replace = os.replace
    moved = []

    def replace(source, target):
        real_replace(source, target)
        if Path(target).parent == out:  # a move out of the staging folder into --out
            moved.append(Path(target).name)
            if len(moved) == 1:
                os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(os, "replace", replace)
    out = tmp_path / "demo"
    out.mkdir()
    code = main(["demo", "--quick", "--out", str(out)])
    _, err = capsys.readouterr()
    _check_interrupted(code, err, "demo", signal.SIGTERM)
    assert sorted(moved) == ["gantry_gmc.png", "results.txt", "vmc_gmc.png"]
    assert sorted(p.name for p in out.iterdir()) == sorted(moved)
    assert _hidden(tmp_path) == []


def test_a_signal_during_the_json_write_leaves_no_file(tmp_path, capsys, monkeypatch):
    real = _frame()
    hours = real.index.get_level_values("time_s").to_numpy() / 3600.0
    sim = real[["dz_um"]].assign(dz_um=real["dz_um"] - 0.5 * hours)
    real = write_tests_csv(real, tmp_path / "real.csv")
    sim = write_tests_csv(sim, tmp_path / "sim.csv")
    real_link = os.link

    def link_then_signal(source, target, *args, **kwargs):
        real_link(source, target, *args, **kwargs)
        _signal_now(signal.SIGTERM)

    monkeypatch.setattr(os, "link", link_then_signal)
    report = tmp_path / "report.json"
    argv = ["gap", str(real), str(sim), "--target", "dz_um", "--drivers", "spindle_rpm"]
    argv += ["--sensors", "T1_C,T2_C", "--effects", "drift", "--random-state", "0"]
    code = main([*argv, "--json", str(report)])
    _, err = capsys.readouterr()
    _check_interrupted(code, err, "gap", signal.SIGTERM)
    # the report was whole when the signal came: in place, and no temporary beside it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["real.csv", "report.json", "sim.csv"]


def test_one_exception_per_command_and_handlers_put_back():
    from greyml._cli._interrupt import Interrupted, deferred, interrupts

    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    with interrupts() as signals:
        with pytest.raises(Interrupted) as raised:
            _signal_now(signal.SIGTERM)
        assert raised.value.signum == signal.SIGTERM
        # a second signal (Ctrl-C again during the cleanup) is noted, not raised
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)
        assert signals.first == signal.SIGTERM and not signals.armed
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before

    # deferred: the block runs to its end, then the signal stops the command
    done = []
    with interrupts(), pytest.raises(Interrupted):
        with deferred():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)
            done.append("all of it")
    assert done == ["all of it"]


def test_a_signal_dropped_in_a_finaliser_still_stops_the_command():
    """Python drops an exception raised in ``__del__`` or a weak reference's
    callback ("Exception ignored in ..."): the signal comes back after it."""
    import threading

    from greyml._cli._interrupt import Interrupted, interrupts

    class Finalised:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.001)  # the handler runs here: inside the finaliser

    with interrupts(), pytest.raises(Interrupted) as raised:
        Finalised()
        threading.Event().wait(60)  # the signal ends the wait, raised again
    assert raised.value.signum == signal.SIGTERM
    assert raised.traceback[-1].name != "__del__"
