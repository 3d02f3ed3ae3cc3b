"""The real CAIVIAC FL_THERMAL recording, read in place into greyml's layout."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from greyml._sequences import make_test_index
from greyml.datasets._simulated import _X_y, bunch_from_frame
from greyml.io import check_test_frame
from greyml.io._csv_numbers import _numeric_column
from greyml.io._csv_text import _line

__all__ = ["load_caiviac"]

_FILE = "cycles.csv"
_PROBES = [f"ch{k}_um" for k in range(1, 6)]
_TEMPS = [f"t{k}_C" for k in range(1, 17)]


def cache_folder(data_home=None):
    """Where :func:`~greyml.datasets.fetch_caiviac` keeps the recording:
    ``<data_home>/greyml/caiviac``, ``data_home`` as for
    :func:`sklearn.datasets.get_data_home` (nothing is created here)."""
    if data_home is None:
        data_home = os.environ.get("SCIKIT_LEARN_DATA", Path("~") / "scikit_learn_data")
    return Path(os.path.expanduser(os.fspath(data_home))) / "greyml" / "caiviac"


def _resolve(path):
    if path is not None:
        p = Path(path)
        p = p / _FILE if p.is_dir() or p.suffix != ".csv" else p
        if not p.is_file():
            raise FileNotFoundError(f"No CAIVIAC recording at {os.fspath(p)!r}.")
        return p
    p = cache_folder() / _FILE
    if p.is_file():
        return p
    raise FileNotFoundError(
        f"The CAIVIAC recording is not in fetch_caiviac's cache ({os.fspath(p)!r}) and no "
        "path was given: pass load_caiviac(path=...) (cycles.csv or the folder holding it), "
        "or call greyml.datasets.fetch_caiviac() once to download and cache it."
    )


def _read_checked(file):
    """cycles.csv as a DataFrame of numbers; a ValueError names the file, column and line."""
    name = os.fspath(file)
    try:
        raw = pd.read_csv(file)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{name!r} is empty; is it the CAIVIAC cycles.csv?") from None
    except pd.errors.ParserError as exc:
        raise ValueError(f"{name!r} is not a well-formed CSV file: {exc}") from None
    expected = ["time_s", "cycle", "spindle_rpm", *_PROBES, *_TEMPS]
    missing = [c for c in expected if c not in raw.columns]
    if missing:
        raise ValueError(f"{name!r} lacks the column(s) {missing}; is it the CAIVIAC cycles.csv?")
    if raw.empty:
        raise ValueError(f"{name!r} has a header but no rows.")
    for col in expected:
        values = raw[col] = _numeric_column(raw[col], col, name)
        numbers = values.to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(numbers))
        if bad.size:
            row = int(bad[0])
            cyc = raw["cycle"].iloc[row]
            where = (
                f"line {_line(row)} (cycle {cyc:g})"
                if np.isfinite(float(cyc))
                else f"line {_line(row)}"
            )
            if np.isnan(numbers[row]):
                raise ValueError(f"Column {col!r} of {name!r} has no value at {where}.")
            raise ValueError(f"Column {col!r} of {name!r} holds {numbers[row]!r} (inf) at {where}.")
    cycle = raw["cycle"].to_numpy(dtype=float)
    fraction = np.flatnonzero(cycle != np.round(cycle))
    if fraction.size:
        row = int(fraction[0])
        raise ValueError(
            f"Column 'cycle' of {name!r} holds {cycle[row]:g} at line {_line(row)}, which is not "
            "a whole cycle number."
        )
    return raw


def load_caiviac(path=None, *, reference="cycle", return_X_y=False, target="ch1_um"):
    """Read the real CAIVIAC heating/cooling recording into greyml's layout.

    Five cycles of 4 h spindle on and 4 h off (1250, 2500, 3750, 5000 and
    3500 rpm) measured on a real machine tool, 15 s sampling, published by
    CAIVIAC/FL_THERMAL under the MIT licence. The data is not part of
    greyml: this reads a ``cycles.csv`` you give it (``path``), or else the
    copy of the whole recording that :func:`fetch_caiviac` downloaded and
    cached; it never downloads anything itself.

    Each cycle becomes a test labelled ``"cycle1"`` … ``"cycle5"`` with
    ``time_s`` from the cycle's first row. Columns: ``spindle_rpm``,
    ``t1_C`` … ``t16_C`` (the file's names, kept so that a model fitted
    here takes rows read from the file) and the five displacement
    probes ``ch1_um`` … ``ch5_um``. The upstream data does not say which
    probe measures which axis, so they keep their channel names instead of
    ``dx_um``/``dy_um``/``dz_um``; nor does it say where the temperature
    sensors are or whether any reads the air, so every sensor's group is
    ``"undocumented"``. There is no ``ambient_C`` column.

    Parameters
    ----------
    path : str or path-like, optional
        ``cycles.csv`` or the folder holding it. By default the copy in
        :func:`fetch_caiviac`'s cache (``<data home>/greyml/caiviac``,
        scikit-learn's data home: ``$SCIKIT_LEARN_DATA`` or
        ``~/scikit_learn_data``).
    reference : {"cycle", "recording"}, default="cycle"
        ``"cycle"``: probe readings relative to each cycle's first row (like
        the simulated tests, whose displacement starts at 0). ``"recording"``:
        as recorded, relative to the start of the whole recording. Each cycle
        starts in the thermal state the previous one left either way.
    return_X_y : bool, default=False
        Return the 16 temperature columns and one probe channel.
    target : str, default="ch1_um"

    Returns
    -------
    data : Bunch or (X, y)
        As :func:`make_tests`, with ``license`` (the MIT notice text) added.

    Raises
    ------
    FileNotFoundError
        If there is no file at ``path``, or, without ``path``, no cached copy;
        the message names the place and both ways to give the data.
    ValueError
        If the file is empty, lacks one of the expected columns, holds a cell
        that is not a finite number, or a cycle whose rows are not contiguous
        and in increasing time (the message names the column and line).

    Examples
    --------
    >>> from greyml.datasets import load_caiviac
    >>> data = load_caiviac("shared/realdata/caiviac")  # doctest: +SKIP
    >>> data.tests  # doctest: +SKIP
    ['cycle1', 'cycle2', 'cycle3', 'cycle4', 'cycle5']
    """
    if reference not in ("cycle", "recording"):
        raise ValueError(f"reference must be 'cycle' or 'recording'; got {reference!r}.")
    file = _resolve(path)
    raw = _read_checked(file)
    cycle = raw["cycle"].to_numpy()
    time = raw["time_s"].to_numpy(dtype=float)
    start = pd.Series(time).groupby(cycle).transform("min").to_numpy()
    frame = pd.DataFrame({"spindle_rpm": raw["spindle_rpm"].to_numpy(dtype=float)})
    sensors = []
    for col in _TEMPS:  # the file's own names, so rows read from it fit a model from here
        frame[col] = raw[col].to_numpy(dtype=float)
        sensors.append(col)
    for col in _PROBES:
        values = raw[col].to_numpy(dtype=float)
        if reference == "cycle":
            first = pd.Series(values).groupby(cycle).transform("first").to_numpy()
            values = values - first
        frame[col] = values
    labels = np.array([f"cycle{int(c)}" for c in cycle], dtype=object)
    frame.index = make_test_index(labels, time - start)
    try:
        check_test_frame(frame)
    except ValueError as exc:
        raise ValueError(
            f"{os.fspath(file)!r}: {exc} (data row r is line r + 2 of the file)"
        ) from None
    licence = file.with_name("LICENSE.txt")
    speeds = frame.groupby(level="test", sort=False)["spindle_rpm"].max()
    hours = (time.max() - time.min()) / 3600.0
    description = (
        "Real heating/cooling recording of a machine tool, CAIVIAC/FL_THERMAL "
        f"(data/data.xlsx, MIT licence), {hours:.1f} h: {len(speeds)} cycles of spindle "
        "on (at " + ", ".join(f"{v:g} rpm" for v in speeds) + ") then off, "
        "15 s sampling. Probe channels ch1/ch2 and ch3/ch4 move together; their "
        "axes and the sensor positions are not documented upstream. Displacements "
        + (
            "relative to each cycle's first row."
            if reference == "cycle"
            else "relative to the start of the recording."
        )
    )
    data = bunch_from_frame(
        frame,
        sensors=sensors,
        targets=_PROBES,
        sensor_groups=dict.fromkeys(sensors, "undocumented"),
        description=description,
        inputs=["spindle_rpm"],
    )
    data["license"] = licence.read_text(encoding="utf-8") if licence.is_file() else ""
    return _X_y(data, target) if return_X_y else data
