"""Test data in files, read piece by piece: the rows of a fit larger than memory.

:class:`TestFiles` names some files (a list, a folder, or a glob pattern) and,
each time it is iterated, reads them in order, a bounded number of rows at a
time, as ``(X, y)`` pieces in greyml's layout (a ``(test, time_s)`` index):
what :meth:`greyml.ThermalTransferFunction.fit_chunks` takes. CSV files are
read with pandas in chunks, Parquet files (the ``parquet`` extra, pyarrow) by
record batches; neither is ever held whole.

Each file holds one test (its label is the file's name) or a recording whose
tests a column labels, as the user says (``each``).
"""

from __future__ import annotations

import glob
import os
from pathlib import Path

import numpy as np
import pandas as pd

from greyml._sequences import make_test_index

__all__ = ["MAX_FILE_COLUMNS", "TestFiles", "piece_of"]

#: The most columns a file read piece by piece may have (checked on its header
#: before any row is read): a thermal test logs tens of sensors, not thousands.
MAX_FILE_COLUMNS = 10_000
#: The longest header line read (bytes).
_MAX_HEADER_BYTES = 1 << 20
_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}
_EACH = ("auto", "test", "recording")


class TestFiles:
    """Test data in files, read a bounded number of rows at a time.

    Parameters
    ----------
    paths : str, path-like or sequence of them
        The files, in the order of their rows; a folder (its ``*.csv`` and
        ``*.parquet`` files, sorted by name); or a glob pattern
        (``"logs/2026-*.parquet"``, sorted by name).
    target : str
        The displacement column (e.g. ``"dx_um"``); every other column but
        the test's and ``time_s`` is an input.
    each : {"auto", "test", "recording"}, default="auto"
        ``"test"``: every file is one test, labelled by the file's name
        (without its suffix); ``"recording"``: the column ``test_column``
        labels the tests of a file (a test may run on into the next file);
        ``"auto"``: a file with the column ``test_column`` is a recording, one
        without it a test.
    test_column : str, default="test"
        The column that labels the tests, with ``each="recording"``.
    time_unit : {"s", "min", "h"}, default="s"
        The unit of the ``time_s`` column.
    rows : int, default=100_000
        Rows read at a time (the memory of one piece).
    inputs : list of str, optional
        The input columns, in this order; by default every column but the
        test's, ``time_s`` and the target.

    Examples
    --------
    >>> from greyml import ThermalTransferFunction
    >>> from greyml.io import TestFiles
    >>> logs = TestFiles("logs/", target="dx_um")  # doctest: +SKIP
    >>> model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(logs)  # doctest: +SKIP
    """

    __test__ = False  # a data source, not a pytest test class

    def __init__(
        self,
        paths,
        target,
        *,
        each="auto",
        test_column="test",
        time_unit="s",
        rows=100_000,
        inputs=None,
    ):
        if each not in _EACH:
            raise ValueError(
                f"TestFiles: each must be 'auto', 'test' or 'recording'; got {each!r}."
            )
        if time_unit not in _UNITS:
            raise ValueError(f"TestFiles: time_unit must be 's', 'min' or 'h'; got {time_unit!r}.")
        if isinstance(rows, bool) or not isinstance(rows, int) or rows < 1:
            raise ValueError(f"TestFiles: rows must be an integer >= 1; got {rows!r}.")
        self.paths = _files(paths)
        self.target = str(target)
        self.each = each
        self.test_column = str(test_column)
        self.time_unit = time_unit
        self.rows = rows
        self.inputs = None if inputs is None else [str(c) for c in inputs]

    def __repr__(self):
        return f"TestFiles({len(self.paths)} files, target={self.target!r}, each={self.each!r})"

    def __iter__(self):
        for path in self.paths:
            yield from self._pieces(path)

    def _pieces(self, path):
        columns = _header(path)
        each = self.each
        if each == "auto":
            each = "recording" if self.test_column in columns else "test"
        needed = ["time_s", self.target] + ([self.test_column] if each == "recording" else [])
        needed += self.inputs or []
        missing = [c for c in needed if c not in columns]
        if missing:
            raise ValueError(
                f"TestFiles: {path} has no column {missing[0]!r} (its columns: "
                f"{', '.join(map(repr, columns[:20]))}{', …' if len(columns) > 20 else ''})."
            )
        if each == "test" and self.test_column in columns:
            raise ValueError(
                f"TestFiles: {path} has a {self.test_column!r} column; read it with "
                "each='recording' (its tests labelled by that column)."
            )
        label = Path(path).stem
        first = 0
        for frame in _frames(path, self.rows, self.test_column):
            X, y = piece_of(
                frame,
                target=self.target,
                test_column=self.test_column if each == "recording" else None,
                time_unit=self.time_unit,
                where=path,
                label=label,
            )
            X = X if self.inputs is None else X[self.inputs]
            # where a message about this piece should point (greyml's readers look)
            X.attrs["greyml_source"] = f"{path}, data rows {first:,}-{first + len(X) - 1:,}"
            first += len(X)
            yield X, y

    def columns(self):
        """The columns of the first file, read from its header."""
        return _header(self.paths[0])


def piece_of(frame, *, target, test_column, time_unit="s", where="the frame", label=None):
    """``(X, y)`` in greyml's layout from a flat ``frame`` of columns ``time_s``,
    ``target``, the inputs, and the test labels ``test_column`` (or, without one,
    every row of the test ``label``)."""
    for column in ("time_s", target, test_column):
        if column is not None and column not in frame.columns:
            raise ValueError(f"{where} has no column {column!r}.")
    time = pd.to_numeric(frame["time_s"], errors="coerce").to_numpy(dtype=float)
    if np.isnan(time).any():
        row = int(np.flatnonzero(np.isnan(time))[0])
        raise ValueError(f"{where}: 'time_s' is not a number at data row {row}.")
    if test_column is not None:
        tests = frame[test_column].astype(str).to_numpy()
    else:
        tests = np.full(len(frame), label, dtype=object)
    drop = ["time_s", target] + ([test_column] if test_column is not None else [])
    X = frame.drop(columns=drop)
    X.index = make_test_index(tests, time * _UNITS[time_unit])
    return X, frame[target].to_numpy()


def _files(paths):
    """The files ``paths`` names, in order."""
    if isinstance(paths, (str, os.PathLike)):
        text = os.fspath(paths)
        if os.path.isdir(text):
            found = sorted(
                p for p in Path(text).iterdir() if p.suffix in (".csv", ".parquet") and p.is_file()
            )
            if not found:
                raise ValueError(f"TestFiles: the folder {text} holds no .csv or .parquet file.")
            return [str(p) for p in found]
        if os.path.isfile(text):
            return [text]
        found = sorted(glob.glob(text))
        if not found:
            raise ValueError(f"TestFiles: no file matches {text!r}.")
        return found
    out = [os.fspath(p) for p in paths]
    if not out:
        raise ValueError("TestFiles: no files given.")
    for p in out:
        if not os.path.isfile(p):
            raise ValueError(f"TestFiles: {p} is not a file.")
    return out


def _header(path):
    """The column names of a CSV or Parquet file, read before any row."""
    if str(path).endswith(".parquet"):
        schema = _parquet().ParquetFile(path).schema_arrow
        names = list(schema.names)
    else:
        with open(path, "rb") as fh:
            line = fh.readline(_MAX_HEADER_BYTES + 1)
        if len(line) > _MAX_HEADER_BYTES:
            raise ValueError(f"TestFiles: {path}: the header line is longer than 1 MiB.")
        if line.count(b",") >= MAX_FILE_COLUMNS:
            raise ValueError(
                f"TestFiles: {path} has more than {MAX_FILE_COLUMNS:,} columns; a thermal "
                "test logs far fewer."
            )
        names = list(pd.read_csv(path, nrows=0).columns)
    if len(names) > MAX_FILE_COLUMNS:
        raise ValueError(f"TestFiles: {path} has more than {MAX_FILE_COLUMNS:,} columns.")
    return names


def _frames(path, rows, test_column):
    """The rows of one file, ``rows`` at a time, as DataFrames."""
    if str(path).endswith(".parquet"):
        for batch in _parquet().ParquetFile(path).iter_batches(batch_size=rows):
            yield batch.to_pandas()
        return
    yield from pd.read_csv(path, chunksize=rows, dtype={test_column: str})


def _parquet():
    try:
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - the extra is installed in the test env
        raise ImportError(
            "Reading Parquet files needs pyarrow: pip install 'greyml[parquet]'."
        ) from None
    return pq
