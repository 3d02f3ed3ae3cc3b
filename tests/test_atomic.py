"""The one atomic writer (issue 37, item 5; issue 41, finding 1).

Every writer of greyml and of the ``greyml`` command writes whole or not at all,
refuses an existing file without ``overwrite``/``--force``, and never replaces
what is not a regular file: a named pipe, a symbolic link, a character device
(as root, ``greyml export ... --out /dev/null --force`` once turned /dev/null
into a regular file). The device here is a node made in a temporary folder,
never /dev/null itself.
"""

import errno
import json
import os
import re
import stat

import numpy as np
import pandas as pd
import pytest

from greyml import GMC, Compensator, make_test_index
from greyml._atomic import check_target, not_regular, write_atomic
from greyml._cli._files import _write_text
from greyml.cli import main
from greyml.io import read_tests_csv, write_tests_csv
from greyml.persist import load_model, save_model

KINDS = ("fifo", "symlink", "chardev")
WORDS = {
    "fifo": "is a named pipe (FIFO), not a regular file",
    "symlink": "is a symbolic link, not a regular file",
    "chardev": "is a character device, not a regular file",
}


def _make(kind, folder):
    """A ``kind`` of non-regular file at ``folder/target``; skip what this system
    cannot make (a device node needs root)."""
    path = folder / "target"
    if kind == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no named pipes on this system")
        os.mkfifo(path)
    elif kind == "symlink":
        (folder / "aimed_at.txt").write_text("keep me\n")
        try:
            os.symlink(folder / "aimed_at.txt", path)
        except (OSError, NotImplementedError):
            pytest.skip("no symbolic links on this system (or not allowed to make one)")
    else:
        if not hasattr(os, "mknod") or os.geteuid() != 0:
            pytest.skip("making a character device node needs root")
        try:
            os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # what /dev/null is
        except PermissionError:
            pytest.skip("this system does not allow a device node here")
    return path


def _unchanged(kind, path, folder):
    """``path`` is still the ``kind`` it was, and no temporary file is left beside it."""
    mode = os.lstat(path).st_mode
    test = {"fifo": stat.S_ISFIFO, "symlink": stat.S_ISLNK, "chardev": stat.S_ISCHR}[kind]
    assert test(mode), stat.filemode(mode)
    if kind == "symlink":
        assert (folder / "aimed_at.txt").read_text() == "keep me\n"
    assert [p.name for p in folder.iterdir() if p.name.startswith(".")] == []


def _frame():
    t = 60.0 * np.arange(5)
    return pd.DataFrame(
        {"T1_C": 20.0 + t / 600.0, "dz_um": -t / 100.0}, index=make_test_index(["A"] * 5, t)
    )


def _model():
    frame = _frame()
    return GMC().fit(frame[["T1_C"]], frame["dz_um"])


# -- the helper --------------------------------------------------------------------


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("overwrite", [False, True])
def test_the_writer_refuses_what_is_not_a_regular_file(kind, overwrite, tmp_path):
    path = _make(kind, tmp_path)
    with pytest.raises(ValueError, match=re.escape(WORDS[kind])) as info:
        write_atomic(path, "text\n", overwrite=overwrite)
    assert str(info.value) == f"{str(path)!r} {WORDS[kind]}; greyml replaces only a regular file."
    _unchanged(kind, path, tmp_path)


def test_a_folder_and_a_dangling_link_are_refused_too(tmp_path):
    assert not_regular(tmp_path) == "a folder"
    with pytest.raises(ValueError, match="is a folder, not a regular file"):
        write_atomic(tmp_path, "x", overwrite=True)
    dangling = tmp_path / "dangling"
    os.symlink(tmp_path / "nowhere", dangling)
    with pytest.raises(ValueError, match="is a symbolic link"):
        write_atomic(dangling, "x", overwrite=True)
    assert not (tmp_path / "nowhere").exists()
    assert not_regular(tmp_path / "absent") == ""


def test_a_regular_file_is_replaced_only_when_asked(tmp_path):
    path = write_atomic(tmp_path / "a.txt", "first\n")
    with pytest.raises(FileExistsError, match="exists; pass overwrite=True to replace it"):
        write_atomic(path, "second\n")
    mine = ValueError("mine")
    with pytest.raises(ValueError, match="^mine$"):
        check_target(path, False, mine)
    assert path.read_text() == "first\n"
    write_atomic(path, "second\n", overwrite=True)
    write_atomic(tmp_path / "b.bin", b"\x00\x01")
    write_atomic(tmp_path / "c.bin", lambda fh: fh.write(b"\x02"), encoding=None)
    write_atomic(tmp_path / "d.txt", lambda fh: fh.write("é\n"), newline="")
    assert path.read_text() == "second\n"
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"
    assert (tmp_path / "c.bin").read_bytes() == b"\x02"
    assert (tmp_path / "d.txt").read_bytes() == "é\n".encode()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.bin", "c.bin", "d.txt"]


def test_without_hard_links_an_existing_file_is_still_refused(tmp_path, monkeypatch):
    """The gap --json writer used to replace it when os.link failed (issue 37)."""

    def no_links(source, target, *args, **kwargs):
        raise OSError(errno.EPERM, "hard links not supported")

    path = tmp_path / "report.json"
    monkeypatch.setattr(os, "link", no_links)
    write_atomic(path, "{}\n")  # a new file: renamed into place
    assert path.read_text() == "{}\n"
    check = os.path.lexists
    calls = []

    def appears_meanwhile(name):  # the file appears between the first check and the rename
        calls.append(name)
        return check(name) if len(calls) > 1 else False

    monkeypatch.setattr(os.path, "lexists", appears_meanwhile)
    with pytest.raises(ValueError, match=r"--json .* exists; pass --force to replace it\."):
        _write_text(str(path), "[]\n", force=False)
    monkeypatch.setattr(os.path, "lexists", check)
    assert path.read_text() == "{}\n"
    _write_text(str(path), "[]\n", force=True)
    assert path.read_text() == "[]\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]


@pytest.mark.parametrize("existing", [False, True])
def test_ctrl_c_leaves_no_half_written_file_and_no_temporary(existing, tmp_path):
    path = tmp_path / "out.csv"
    if existing:
        path.write_text("old\n")

    def interrupted(fh):
        fh.write("half a")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomic(path, interrupted, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == (["out.csv"] if existing else [])
    if existing:
        assert path.read_text() == "old\n"


# -- the library's writers -------------------------------------------------------

WRITERS = {
    "write_tests_csv": lambda path, overwrite: write_tests_csv(_frame(), path, overwrite=overwrite),
    "save_model": lambda path, overwrite: save_model(_model(), path, overwrite=overwrite),
    "Compensator.export": lambda path, overwrite: Compensator(
        ["T1_C"], [("T1_C", 1, 600.0, 1.0)]
    ).export("json", path, overwrite=overwrite),
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("writer", WRITERS)
def test_each_writer_refuses_what_is_not_a_regular_file(writer, kind, tmp_path):
    path = _make(kind, tmp_path)
    for overwrite in (False, True):
        with pytest.raises(ValueError, match=re.escape(WORDS[kind])):
            WRITERS[writer](path, overwrite)
        _unchanged(kind, path, tmp_path)


@pytest.mark.parametrize("writer", WRITERS)
def test_each_writer_replaces_a_regular_file_with_overwrite(writer, tmp_path):
    path = tmp_path / "target"
    path.write_text("old\n")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        WRITERS[writer](path, False)
    assert path.read_text() == "old\n"
    WRITERS[writer](path, True)
    if writer == "write_tests_csv":
        assert read_tests_csv(path).equals(_frame())
    elif writer == "Compensator.export":
        assert json.loads(path.read_text())["inputs"][0]["name"] == "T1_C"
    else:
        assert isinstance(load_model(path), GMC)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["target"]


# -- the greyml command's writers -------------------------------------------------


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("atomic")
    data = write_tests_csv(_frame(), folder / "data.csv")
    model = save_model(_model(), folder / "gmc.greyml")
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)])
    compensator = save_model(comp, folder / "comp.greyml")
    t = 60.0 * np.arange(8)
    three = pd.concat(
        pd.DataFrame(
            {"T1_C": 20.0 + (k + 1) * t / 600.0, "dz_um": -(k + 1) * t / 100.0 + 0.01 * (t % 7)},
            index=make_test_index([label] * 8, t),
        )
        for k, label in enumerate("ABC")
    )
    three = write_tests_csv(three, folder / "three.csv")
    return {
        k: str(v) for k, v in locals().items() if k in ("data", "model", "compensator", "three")
    }


COMMANDS = {
    "fit": lambda f, out: ["fit", f["data"], "--target", "dz_um", "--model", "gmc", "--out", out],
    "simulate": lambda f, out: ["simulate", "--machine", "vmc", "--tests", "I", "--out", out],
    "predict": lambda f, out: ["predict", f["model"], f["data"], "--out", out],
    "gap": lambda f, out: ["gap", f["data"], f["data"], "--target", "dz_um", "--json", out],
    "export": lambda f, out: ["export", f["model"], "--language", "c", "--out", out],
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("command", COMMANDS)
def test_each_command_refuses_what_is_not_a_regular_file(command, kind, files, tmp_path, capsys):
    path = _make(kind, tmp_path)
    flag = "--json" if command == "gap" else "--out"
    for force in ([], ["--force"]):
        code = main([*COMMANDS[command](files, str(path)), *force])
        out, err = capsys.readouterr()
        assert code == 2, (out, err)
        assert err == f"greyml {command}: error: {flag} {str(path)!r} {WORDS[kind]}; " + (
            "greyml replaces only a regular file.\n"
        )
        _unchanged(kind, path, tmp_path)


@pytest.mark.parametrize("command", ["fit", "predict"])
def test_a_command_replaces_a_regular_file_with_force(command, files, tmp_path, capsys):
    path = tmp_path / "target"
    path.write_text("old\n")
    assert main(COMMANDS[command](files, str(path))) == 2
    assert "exists; pass --force to replace it" in capsys.readouterr().err
    assert main([*COMMANDS[command](files, str(path)), "--force"]) == 0
    capsys.readouterr()
    assert path.read_bytes() != b"old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["target"]


@pytest.mark.parametrize("kind", KINDS)
def test_demo_force_replaces_no_link_pipe_or_device_in_its_folder(
    kind, tmp_path, monkeypatch, capsys
):
    """``greyml demo --force`` writes into a folder: a file of its own names that is
    not a regular file stops it before the first file moves."""
    import greyml._cli._demo as demo

    def report(staging, folder, **kwargs):  # the demo's writing, without its fitting
        demo._write_whole(staging / "a.txt", lambda fh: fh.write(b"a\n"))
        demo._write_whole(staging / "target", lambda fh: fh.write(b"results\n"))
        return "report"

    monkeypatch.setattr(demo, "_demo_report", report)
    path = _make(kind, tmp_path)
    code = main(["demo", "--quick", "--out", str(tmp_path), "--force"])
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert err == f"greyml demo: error: --out {str(tmp_path)!r}: {str(path)!r} {WORDS[kind]}; " + (
        "greyml replaces only a regular file.\n"
    )
    _unchanged(kind, path, tmp_path)
    assert not (tmp_path / "a.txt").exists()
    path.unlink()
    (tmp_path / "target").write_text("old\n")  # a regular file is replaced
    assert main(["demo", "--quick", "--out", str(tmp_path), "--force"]) == 0
    assert (tmp_path / "target").read_text() == "results\n"


# -- "-" is standard output for a command that writes one file --------------------

STDOUT_COMMANDS = {
    "simulate": lambda f, out: ["simulate", "--machine", "vmc", "--tests", "I", "--out", out],
    "predict": lambda f, out: ["predict", f["model"], f["data"], "--out", out],
    "export": lambda f, out: ["export", f["compensator"], "--language", "st", "--out", out],
    "validate": lambda f, out: [
        *("validate", f["three"], "--target", "dz_um", "--model", "gmc", "--json", out),
    ],
}


@pytest.mark.parametrize("command", STDOUT_COMMANDS)
def test_dash_writes_the_one_file_to_standard_output(command, files, tmp_path, capsys):
    """``--out -`` (``--json -``): standard output holds the file, byte for byte what
    ``--out FILE`` writes, and what the command prints goes to standard error."""
    path = tmp_path / "out"
    assert main([*STDOUT_COMMANDS[command](files, str(path)), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert main([*STDOUT_COMMANDS[command](files, "-"), "--quiet"]) == 0
    out, err = capsys.readouterr()
    if command == "validate":  # the same numbers; the seconds it took differ
        numbers = [json.loads(text) for text in (out, path.read_text())]
        for record in numbers:
            del record["fit_seconds"], record["seconds"]
        assert numbers[0] == numbers[1]
        table = printed.splitlines()[-2]  # the table's last line (the first says the seconds)
        assert table in err.splitlines() and "wrote" not in err
    else:
        assert out == path.read_text()
        assert printed and printed.replace(repr(str(path)), "standard output") in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_dash_writes_the_model_file_and_the_numbers_to_standard_output(
    files, tmp_path, capsysbinary
):
    args = ["fit", files["data"], "--target", "dz_um", "--model", "gmc", "--out", "-"]
    assert main(args) == 0
    out, err = capsysbinary.readouterr()
    (tmp_path / "m.greyml").write_bytes(out)
    again = load_model(tmp_path / "m.greyml")
    assert isinstance(again, GMC) and again.target_name_ == "dz_um"
    assert err.decode().endswith("saved to standard output\n")


def test_dash_never_prints_a_model_file_to_a_terminal(files, capsys, monkeypatch):
    import sys

    monkeypatch.setattr(sys.stdout, "isatty", lambda: True)
    args = ["fit", files["data"], "--target", "dz_um", "--model", "gmc", "--out", "-"]
    assert main(args) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == (
        "greyml fit: error: --out - would print a binary model file to the terminal; send "
        "standard output to a file or a pipe, or give a file name.\n"
    )
