"""Files of the ``greyml`` subcommands: reading CSV tests, checking columns, output paths.

A user error (a missing column, an existing output file, a test that is not
in the data) is raised as a :class:`ValueError` whose message names the file,
column or test; the command line prints it as one line.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from greyml._atomic import refusal
from greyml._cli._printing import _unfiltered

#: The ``--out`` or ``--json`` that means standard output, for a command that writes
#: one file: the file goes there, whole, and what the command prints goes to
#: standard error (:func:`greyml._cli._flags._call`).
STDOUT = "-"

#: Columns that are operating inputs, not sensors: left out of the candidate
#: sensors unless named with ``--sensors``.
OPERATING_COLUMNS = ("spindle_rpm", "feed_mm_min", "c_rpm", "ambient_C")


def _check_output_folder(out, force):
    """Check that ``out`` may be written: absent, or an empty folder (any folder with ``force``).

    Creates nothing (``greyml demo`` writes into a temporary folder and moves it there).
    """
    out = Path(out)
    if out.exists():
        if not out.is_dir():
            raise ValueError(f"--out {os.fspath(out)!r} is a file, not a folder.")
        if any(out.iterdir()) and not force:
            raise ValueError(
                f"the output folder {os.fspath(out)!r} is not empty; choose another --out, "
                "or pass --force to write into it (files of the same names are replaced)."
            )
        if not os.access(out, os.W_OK | os.X_OK):
            raise ValueError(f"cannot write to the output folder {os.fspath(out)!r}.")
    return out


def _check_output_file(path, force, what="--out"):
    """Refuse an existing ``path`` without ``force``, anything but a regular file at
    ``path`` even with it, or a folder that does not exist."""
    if os.fspath(path) == STDOUT:
        return STDOUT
    path = Path(path)
    name = os.fspath(path)
    if path.is_dir():
        raise ValueError(f"{what} {name!r} is a folder; give a file name.")
    refused = refusal(path)
    if refused:
        raise ValueError(f"{what} {refused}")
    if path.exists() and not force:
        raise ValueError(f"{what} {name!r} exists; pass --force to replace it.")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise ValueError(f"cannot write {what} {name!r}: {os.fspath(parent)!r} is not a folder.")
    if not parent.is_dir():
        raise ValueError(f"the folder of {what} {name!r} does not exist: {os.fspath(parent)!r}.")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write {what} {name!r}: its folder is not writable.")
    return path


def _refuse_binary_terminal(stdout, what="--out"):
    """Refuse to print a binary file (a model) to a terminal."""
    if _unfiltered(sys.stdout if stdout is None else stdout).isatty():
        raise ValueError(
            f"{what} - would print a binary model file to the terminal; send standard "
            "output to a file or a pipe, or give a file name."
        )


def _write_stdout(stdout, content):
    """Write ``content`` (text, or the bytes of a model file), made whole in memory
    first, to the command's standard output ``stdout`` (``--out -``).

    Text goes through the terminal filter only when ``stdout`` is a terminal; to
    a pipe or a file it goes as it is, so the output is the file, byte for byte.
    """
    stdout = sys.stdout if stdout is None else stdout
    raw = _unfiltered(stdout)
    if isinstance(content, bytes):
        _refuse_binary_terminal(stdout)
        raw.flush()
        raw.buffer.write(content)
        raw.buffer.flush()
        return
    (stdout if raw.isatty() else raw).write(content)
    raw.flush()


def _output_name(path):
    """How a message names an output: ``'file.csv'``, or ``standard output`` for ``-``."""
    return "standard output" if os.fspath(path) == STDOUT else repr(os.fspath(path))


def _csv_text(frame):
    """``frame`` as :func:`greyml.io.write_tests_csv` writes it, as text."""
    import io

    from greyml.io._csv import _csv_writer

    text = io.StringIO(newline="")
    _csv_writer(frame)(text)
    return text.getvalue()


def _write_text(path, text, force):
    """Write ``text`` to ``path`` through a temporary file; an existing file only if ``force``.

    Whatever stops the write (an error, Ctrl-C, SIGTERM) removes the temporary file.
    """
    from greyml._atomic import write_atomic

    exists = ValueError(f"--json {path!r} exists; pass --force to replace it.")
    write_atomic(path, text, overwrite=force, exists=exists)


def _read(path, csv_options=None):
    """Read a CSV of tests; ``csv_options`` are ``time_unit``, ``sep``, ``decimal``."""
    from greyml.io import read_tests_csv

    frame = read_tests_csv(path, **(csv_options or {}))
    _check_magnitudes(frame, path)
    return frame


def _check_magnitudes(frame, path):
    """One line for a cell beyond :data:`MAX_INPUT` (a unit or logging error),
    naming its column and line, before any command computes with it.

    One pass over the numbers (no loop over columns): the first column in the
    file's order that holds such a cell (``time_s`` first), at its first row."""
    import numpy as np

    from greyml._validation import MAX_INPUT

    numbers = frame.select_dtypes(include=[np.floating, np.integer])
    time = frame.index.get_level_values("time_s").to_numpy(dtype=float)
    values = np.column_stack([time, numbers.to_numpy(dtype=float)])
    with np.errstate(invalid="ignore"):
        beyond = np.abs(values) > MAX_INPUT
    columns = np.flatnonzero(beyond.any(axis=0))
    if columns.size:
        at = int(columns[0])
        row = int(np.flatnonzero(beyond[:, at])[0])
        name = "time_s" if at == 0 else numbers.columns[at - 1]
        raise ValueError(
            f"Column {name!r} holds {float(values[row, at]):g} at {_where(frame, row, path)}, "
            f"beyond {MAX_INPUT:g}, which no measurement reaches; check its unit."
        )


def _where(frame, row, path):
    """``line L (test 'T', time_s S)`` of data row ``row`` of ``path``."""
    test, time_s = frame.index[row]
    return f"line {row + 2} of {os.fspath(path)!r} (test {test!r}, time_s {time_s:g})"


def _test_labels(frame):
    """The labels of the tests of ``frame``, each once, in the order they first appear."""
    return list(dict.fromkeys(frame.index.get_level_values("test")))


def _require_columns(frame, columns, path, flag):
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        from greyml._validation import shown_names

        have = shown_names(frame.columns, 12)
        raise ValueError(
            f"{flag} names {', '.join(repr(c) for c in missing)}, not a column of "
            f"{os.fspath(path)!r} (its columns: {have})."
        )


def _require_values(frame, columns, path, role):
    """Every cell of ``columns`` must hold a number."""
    import numpy as np

    for c in columns:
        gaps = np.flatnonzero(frame[c].isna().to_numpy())
        if gaps.size:
            raise ValueError(
                f"{role} column {c!r} has no value (NaN) at {_where(frame, gaps[0], path)}; "
                f"{gaps.size} row(s) are empty. Fill or drop them first."
            )


def _candidates(frame, target, sensors, path):
    if sensors:
        _require_columns(frame, sensors, path, "--sensors")
        if target in sensors:
            raise ValueError(f"--sensors names the target {target!r}; leave it out.")
        return list(sensors)
    names = [
        c
        for c in frame.columns
        if c != target and c not in OPERATING_COLUMNS and not str(c).endswith("_um")
    ]
    if not names:
        raise ValueError(
            f"{os.fspath(path)!r} has no sensor columns (0 features) besides the target "
            f"{target!r}; name them with --sensors."
        )
    return names


def _rows_of_tests(frame, tests, path, flag):
    import numpy as np

    from greyml import groups_of

    labels = groups_of(frame)
    have = list(dict.fromkeys(labels))
    missing = [t for t in tests if t not in have]
    if missing:
        raise ValueError(
            f"{flag}: test {', '.join(repr(t) for t in missing)} is not in "
            f"{os.fspath(path)!r} (its tests: {', '.join(map(str, have))})."
        )
    return np.isin(labels, list(tests))


def _load_training(data, target, sensors, tests, flag, csv_options=None):
    """The rows and columns to train on, checked."""
    frame = _read(data, csv_options)
    _require_columns(frame, [target], data, "--target")
    columns = _candidates(frame, target, sensors, data)
    if tests:
        frame = frame[_rows_of_tests(frame, tests, data, flag)]
    _require_values(frame, [target], data, "target")
    _require_values(frame, columns, data, "sensor")
    return frame, columns


def _time_unit_hint(frame, path, csv_options=None):
    """A warning when the file's time looks like minutes or hours read as seconds.

    Thermal tests last hours and are sampled every few seconds or more: a
    median step under 1 s, or tests that last under 10 min in all, is usually a
    ``time_s`` column in minutes or hours read as seconds (every time
    constant would be 60 or 3600 times too short). None when the time looks
    like seconds, or the unit was given with ``--time-unit``.
    """
    import numpy as np

    if (csv_options or {}).get("time_unit", "s") != "s":
        return None
    time = np.asarray(frame.index.get_level_values("time_s"), dtype=float)
    tests = np.asarray(frame.index.get_level_values("test"), dtype=object)
    same = tests[1:] == tests[:-1]
    steps = np.diff(time)[same]
    if steps.size == 0:
        return None
    total = float(steps.sum())
    median = float(np.median(steps))
    if median < 1.0 or total < 600.0:
        return (
            f"the time_s of {os.fspath(path)!r} steps by {median:g} s and its tests last "
            f"{total:g} s in all: if time_s holds minutes or hours, say so with "
            "--time-unit min or --time-unit h"
        )
    return None


def _load_model_file(model_path):
    """``(model, warnings caught)`` of a model file; every failure one line naming it.

    A missing file or a folder, a file that is not a greyml model, was altered
    or names a class greyml does not create: a ValueError (or persist's own
    one-line OSError/ValueError).
    """
    import warnings
    from pathlib import Path

    from greyml.persist import load_model

    name = os.fspath(model_path)
    if not Path(model_path).is_file():
        what = "is a folder, not a model file" if Path(model_path).is_dir() else "does not exist"
        raise ValueError(f"the model file {name!r} {what}.")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            model = load_model(model_path)
        except (OSError, ValueError):  # persist's messages are one line naming the file
            raise
        except Exception as exc:  # anything else: still the file's fault
            raise ValueError(
                f"{name!r} is not a greyml model file ({type(exc).__name__}: {exc})."
            ) from None
    return model, caught
