"""The whole CAIVIAC recording for every user: downloaded once, checked, cached.

scikit-learn's convention for published data: a ``fetch_*`` function that
downloads from the source into a cache folder (``get_data_home``), checks
the file against a checksum, and works offline once cached.
"""

from __future__ import annotations

import hashlib
import os
import urllib.request

import numpy as np
import pandas as pd

from greyml._atomic import write_atomic
from greyml.datasets._caiviac import _PROBES, _TEMPS, cache_folder, load_caiviac

__all__ = ["fetch_caiviac"]

#: The file, at the commit it is pinned to (MIT licence; see LICENSE_TEXT).
URL = (
    "https://raw.githubusercontent.com/CAIVIAC/FL_THERMAL/"
    "9fa40bd4c3d8a67b802c19719ff9b20bbba085d7/data/data.xlsx"
)
SHA256 = "663328610bb57ce3597f9880619f57f13d0b9007713c21d9e4e272799bfbbb28"
SIZE = 3_188_640
#: The sheet and its 23 columns in order: time, speed, 5 probes, 16 temperatures.
SHEET = "工作表1"
COLUMNS = ["time_s", "spindle_rpm", *_PROBES, *_TEMPS]
_TIMEOUT_S = 60.0
_CHUNK = 1 << 16

#: What the cache keeps beside the data: where its licence notice is.
LICENSE_TEXT = (
    "The CAIVIAC/FL_THERMAL recording (data/data.xlsx) is published under the MIT "
    "licence; its copyright and permission notice, which must be kept with any copy, are "
    "in the LICENSE file of https://github.com/CAIVIAC/FL_THERMAL at commit "
    "9fa40bd4c3d8a67b802c19719ff9b20bbba085d7.\n"
)


def _folder(data_home):
    folder = cache_folder(data_home)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _download(url, target, sha256, size):
    """``url`` to ``target``: at most ``size`` bytes, its SHA-256 checked, written whole."""

    def write(out):
        digest = hashlib.sha256()
        got = 0
        with urllib.request.urlopen(url, timeout=_TIMEOUT_S) as response:
            while True:
                chunk = response.read(_CHUNK)
                if not chunk:
                    break
                got += len(chunk)
                if got > size:
                    raise OSError(
                        f"fetch_caiviac: {url} sent more than the {size:,} bytes expected; "
                        "nothing was kept."
                    )
                digest.update(chunk)
                out.write(chunk)
        if digest.hexdigest() != sha256:
            raise OSError(
                f"fetch_caiviac: the file downloaded from {url} ({got:,} bytes) has SHA-256 "
                f"{digest.hexdigest()}, not the expected {sha256}; nothing was kept."
            )

    write_atomic(target, write, overwrite=True, encoding=None)


def _sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(_CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _cycles(rpm):
    """Cycle numbers: 1 from the first row, then one more at each spindle start."""
    on = rpm > 0
    starts = np.zeros(rpm.size, dtype=int)
    starts[1:] = on[1:] & ~on[:-1]
    first_on = np.flatnonzero(on)
    if first_on.size:
        starts[first_on[0]] = 0  # the first start belongs to cycle 1 (after its idle)
    return 1 + np.cumsum(starts)


def _as_cycles_csv(xlsx, target):
    """The workbook's sheet as a CSV in ``cycles.csv``'s layout, written whole."""
    try:
        import openpyxl  # noqa: F401 (pandas reads .xlsx through it)
    except ImportError:
        raise ImportError(
            "fetch_caiviac reads the recording's .xlsx file with openpyxl; install it "
            "with `pip install greyml[data]` (or `pip install openpyxl`)."
        ) from None
    sheet = pd.read_excel(xlsx, sheet_name=SHEET, header=0, engine="openpyxl")
    if sheet.shape[1] != len(COLUMNS):
        raise ValueError(
            f"{os.fspath(xlsx)!r}: the sheet {SHEET!r} has {sheet.shape[1]} columns, not the "
            f"{len(COLUMNS)} of the CAIVIAC recording."
        )
    sheet.columns = COLUMNS
    frame = sheet.apply(pd.to_numeric, errors="coerce")
    frame.insert(1, "cycle", _cycles(frame["spindle_rpm"].to_numpy(dtype=float)))
    write_atomic(target, lambda fh: frame.to_csv(fh, index=False), overwrite=True, newline="")


def fetch_caiviac(
    *,
    data_home=None,
    download_if_missing=True,
    reference="recording",
    return_X_y=False,
    target="ch1_um",
):
    """Download (once) and read the whole CAIVIAC heating/cooling recording.

    The recording of CAIVIAC/FL_THERMAL (``data/data.xlsx`` at commit
    9fa40bd, MIT licence): a real machine tool's spindle run through 4 h on,
    4 h off cycles at several speeds, 16 temperatures and 5 displacement
    probes, 15 s sampling. The file is downloaded into
    ``<data_home>/greyml/caiviac`` (scikit-learn's data home by default,
    ``~/scikit_learn_data`` or ``$SCIKIT_LEARN_DATA``), its size and SHA-256
    checked before it is kept, and converted once to a CSV in the layout of
    :func:`load_caiviac`; later calls read the cache and need no network.
    Each spindle start begins a cycle (cycle 1 also holds the idle rows
    before the first start).

    Parameters
    ----------
    data_home : str or path-like, optional
        Where to cache the data (see :func:`sklearn.datasets.get_data_home`).
    download_if_missing : bool, default=True
        Without a cached copy: download it (True) or raise OSError (False).
    reference, return_X_y, target
        As for :func:`load_caiviac`, which reads the cached ``cycles.csv``: the
        frame is the one :func:`greyml.io.read_tests_csv` reads from it with
        ``test_column="cycle"``.

    Returns
    -------
    data : Bunch, or (X, y) with ``return_X_y=True``
        As :func:`load_caiviac` returns it, for the whole recording.

    Raises
    ------
    OSError
        When the file is missing and ``download_if_missing=False``, when the
        download fails, or when the file downloaded is not the expected one
        (its size or checksum; nothing is kept then).
    ImportError
        When openpyxl, which reads the .xlsx file, is not installed.

    See Also
    --------
    load_caiviac : the same reader, for a copy of cycles.csv you give it.

    Examples
    --------
    >>> from greyml.datasets import fetch_caiviac
    >>> data = fetch_caiviac()  # doctest: +SKIP
    >>> data.frame.index.get_level_values("test").unique()[:3]  # doctest: +SKIP
    Index(['1', '2', '3'], dtype='object', name='test')
    """
    folder = _folder(data_home)
    xlsx, csv = folder / "data.xlsx", folder / "cycles.csv"
    if not csv.is_file():
        if xlsx.is_file() and _sha256(xlsx) != SHA256:
            xlsx.unlink()  # not the file we downloaded: fetch it again
        if not xlsx.is_file():
            if not download_if_missing:
                raise OSError(
                    f"fetch_caiviac: no cached copy in {os.fspath(folder)!r}, and "
                    "download_if_missing=False."
                )
            _download(URL, xlsx, SHA256, SIZE)
        _as_cycles_csv(xlsx, csv)
        write_atomic(folder / "LICENSE.txt", LICENSE_TEXT, overwrite=True)
    return load_caiviac(csv, reference=reference, return_X_y=return_X_y, target=target)
