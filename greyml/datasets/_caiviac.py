"""The real CAIVIAC FL_THERMAL recording, read in place into greyml's layout."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from greyml.datasets._simulated import _X_y, bunch_from_frame
from greyml.io import read_tests_csv
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
    """cycles.csv as :func:`greyml.io.read_tests_csv` reads it (``test_column="cycle"``),
    with the recording's columns, a value in every cell and whole cycle numbers checked;
    a ValueError names the file, column and line."""
    name = os.fspath(file)
    try:
        frame = read_tests_csv(file, test_column="cycle")
    except ValueError as exc:
        if "header" in str(exc) and os.path.getsize(file) == 0:
            raise ValueError(f"{name!r} is empty; is it the CAIVIAC cycles.csv?") from None
        raise
    expected = ["spindle_rpm", *_PROBES, *_TEMPS]
    missing = [c for c in expected if c not in frame.columns]
    if missing:
        raise ValueError(f"{name!r} lacks the column(s) {missing}; is it the CAIVIAC cycles.csv?")
    labels = frame.index.get_level_values("test")
    for col in expected:
        gaps = np.flatnonzero(frame[col].isna().to_numpy())
        if gaps.size:
            row = int(gaps[0])
            raise ValueError(
                f"Column {col!r} of {name!r} has no value at line {_line(row)} "
                f"(cycle {labels[row]})."
            )
    numbers = pd.to_numeric(pd.Series(labels), errors="coerce").to_numpy(dtype=float)
    whole = np.isfinite(numbers) & (numbers == np.round(numbers))
    if not whole.all():
        row = int(np.flatnonzero(~whole)[0])
        raise ValueError(
            f"Column 'cycle' of {name!r} holds {labels[row]} at line {_line(row)}, which is not "
            "a whole cycle number."
        )
    return frame


def load_caiviac(path=None, *, reference="recording", return_X_y=False, target="ch1_um"):
    """Read the real CAIVIAC heating/cooling recording into greyml's layout.

    Five cycles of 4 h spindle on and 4 h off (1250, 2500, 3750, 5000 and
    3500 rpm) measured on a real machine tool, 15 s sampling, published by
    CAIVIAC/FL_THERMAL under the MIT licence. The data is not part of
    greyml: this reads a ``cycles.csv`` you give it (``path``), or else the
    copy of the whole recording that :func:`fetch_caiviac` downloaded and
    cached; it never downloads anything itself.

    The frame is the one :func:`greyml.io.read_tests_csv` reads from the same
    file with ``test_column="cycle"`` (one code path, so the same model from
    either): each cycle is a test labelled by its number (``"1"`` …
    ``"5"``), ``time_s`` runs on along the recording's clock (so a dynamic
    model carries its state from one cycle into the next), and the columns
    are the file's, in its order: ``spindle_rpm``, the five displacement
    probes ``ch1_um`` … ``ch5_um`` as recorded (from the recording's zero),
    ``t1_C`` … ``t16_C``. The upstream data does not say which probe
    measures which axis, so they keep their channel names instead of
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
    reference : {"recording", "cycle"}, default="recording"
        ``"recording"``: the probes as recorded, from the recording's zero
        (the frame ``read_tests_csv`` gives). ``"cycle"``: each probe minus
        its reading at its cycle's first row (like the simulated tests,
        whose displacement starts at 0); nothing else changes. To score a
        model on each cycle's change, prefer the model's own
        ``reference="start"`` on the recording's frame.
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
    ['1', '2', '3', '4', '5']
    """
    if reference not in ("cycle", "recording"):
        raise ValueError(f"reference must be 'recording' or 'cycle'; got {reference!r}.")
    file = _resolve(path)
    frame = _read_checked(file)
    if reference == "cycle":
        frame = frame.copy()
        first = frame[_PROBES].groupby(level="test", sort=False).transform("first")
        frame[_PROBES] = frame[_PROBES] - first
    licence = file.with_name("LICENSE.txt")
    speeds = frame.groupby(level="test", sort=False)["spindle_rpm"].max()
    time = frame.index.get_level_values("time_s")
    hours = (time.max() - time.min()) / 3600.0
    description = (
        "Real heating/cooling recording of a machine tool, CAIVIAC/FL_THERMAL "
        f"(data/data.xlsx, MIT licence), {hours:.1f} h: {len(speeds)} cycles of spindle "
        "on (at " + ", ".join(f"{v:g} rpm" for v in speeds) + ") then off, "
        "15 s sampling, on one clock. Probe channels ch1/ch2 and ch3/ch4 move together; "
        "their axes and the sensor positions are not documented upstream. Displacements "
        + (
            "relative to each cycle's first row."
            if reference == "cycle"
            else "as recorded, from the recording's zero."
        )
    )
    data = bunch_from_frame(
        frame,
        sensors=list(_TEMPS),
        targets=_PROBES,
        sensor_groups=dict.fromkeys(_TEMPS, "undocumented"),
        description=description,
        inputs=["spindle_rpm"],
    )
    data["license"] = licence.read_text(encoding="utf-8") if licence.is_file() else ""
    return _X_y(data, target) if return_X_y else data
