"""The whole CAIVIAC recording for every user: downloaded once, checked, cached.

scikit-learn's convention for published data: a ``fetch_*`` function that
downloads from the source into a cache folder (``get_data_home``), checks
the file against a checksum, and works offline once cached.

Nothing in the cache is trusted: ``data.xlsx`` is checked against the
SHA-256 pinned here and ``cycles.csv`` against the SHA-256 recorded in
``SHA256SUMS`` when it was made from the checked workbook, on every call; a
link, pipe or device under one of the cache's names is refused, never
followed. The download has one deadline for all of it (connection, headers,
every byte), enforced by shutting its socket down when it passes.
"""

from __future__ import annotations

import functools
import hashlib
import http.client
import math
import os
import re
import socket
import ssl
import stat
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pandas as pd

from greyml._atomic import not_regular, write_atomic
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
#: Seconds the whole download may take by default (3 MB at 10 kB/s).
TIMEOUT_S = 300.0
_CHUNK = 1 << 16
#: The names fetch_caiviac keeps in its cache folder.
_XLSX, _CSV, _SUMS, _LICENSE = "data.xlsx", "cycles.csv", "SHA256SUMS", "LICENSE.txt"

#: What the cache keeps beside the data: where its licence notice is.
LICENSE_TEXT = (
    "The CAIVIAC/FL_THERMAL recording (data/data.xlsx) is published under the MIT "
    "licence; its copyright and permission notice, which must be kept with any copy, are "
    "in the LICENSE file of https://github.com/CAIVIAC/FL_THERMAL at commit "
    "9fa40bd4c3d8a67b802c19719ff9b20bbba085d7.\n"
)


class _Deadline:
    """One deadline for a whole download: every socket the download connects is
    registered, and when the deadline passes a timer shuts them down, which ends
    whatever read or write is waiting on them (a server sending a byte a second
    never waits out a per-read timeout). Name lookup is not covered."""

    def __init__(self, seconds):
        self.seconds = seconds
        self.end = time.monotonic() + seconds
        self.passed = False
        self._sockets = []
        self._lock = threading.Lock()
        self._timer = threading.Timer(seconds, self._shut)
        self._timer.daemon = True

    def left(self):
        """Seconds left; raises ``TimeoutError`` once none are."""
        left = self.end - time.monotonic()
        if left <= 0 or self.passed:
            self.passed = True
            raise TimeoutError("the deadline passed")
        return left

    def connect(self, address, timeout=None, source_address=None, **kwargs):
        """:func:`socket.create_connection` within the time left, the socket registered."""
        sock = socket.create_connection(address, self.left(), source_address, **kwargs)
        with self._lock:
            if self.passed:
                sock.close()
                raise TimeoutError("the deadline passed")
            self._sockets.append(sock.dup())  # the same connection, whatever wraps sock
        return sock

    def _shut(self):
        with self._lock:
            self.passed = True
            for sock in self._sockets:
                try:
                    sock.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def __enter__(self):
        self._timer.start()
        return self

    def __exit__(self, *exc):
        self._timer.cancel()
        with self._lock:
            for sock in self._sockets:
                sock.close()
            self._sockets.clear()


def _connection(cls, deadline, host, **kwargs):
    """An ``http.client`` connection whose sockets ``deadline`` connects and can shut."""
    connection = cls(host, **kwargs)
    connection._create_connection = deadline.connect
    return connection


class _HTTPHandler(urllib.request.HTTPHandler):
    def __init__(self, deadline):
        super().__init__()
        self.deadline = deadline

    def http_open(self, req):
        return self.do_open(
            functools.partial(_connection, http.client.HTTPConnection, self.deadline), req
        )


class _HTTPSHandler(urllib.request.HTTPSHandler):
    def __init__(self, deadline):
        super().__init__()
        self.deadline = deadline
        self.tls = ssl.create_default_context()

    def https_open(self, req):
        return self.do_open(
            functools.partial(_connection, http.client.HTTPSConnection, self.deadline),
            req,
            context=self.tls,
        )


def _upper_first(text):
    return text[:1].upper() + text[1:]


def _one_line(text):
    return re.sub(r"\s+", " ", str(text)).strip()


def _by_hand(folder, url=None, sha256=None):
    """How to place a copy in the cache by hand."""
    url, sha256 = url or URL, sha256 or SHA256
    return (
        f"to use a copy, download {url} by other means and save it as "
        f"{os.fspath(Path(folder) / _XLSX)!r} (SHA-256 {sha256}): fetch_caiviac reads it "
        "from there without the network"
    )


def _failed(url, folder, what, sha256=None):
    """The one-line OSError of a download that failed; nothing was kept."""
    return OSError(
        f"fetch_caiviac: could not download {url} into {os.fspath(folder)!r}: "
        f"{_one_line(what)}; nothing was kept. {_upper_first(_by_hand(folder, url, sha256))}."
    )


def _download(url, target, sha256, size, timeout):
    """``url`` to ``target``: at most ``size`` bytes within ``timeout`` seconds in
    all, its SHA-256 checked, written whole; every failure one line (OSError)."""
    folder = Path(target).parent
    with _Deadline(timeout) as deadline:
        opener = urllib.request.build_opener(_HTTPHandler(deadline), _HTTPSHandler(deadline))

        def write(out):
            digest = hashlib.sha256()
            got = 0
            with opener.open(url, timeout=deadline.left()) as response:
                kind = response.headers.get_content_type()
                declared = response.headers.get("Content-Length", "")
                if declared.isdigit() and int(declared) > size:
                    raise _failed(
                        url,
                        folder,
                        f"it announces {int(declared):,} bytes, more than the "
                        f"{size:,} of the recording",
                        sha256,
                    )
                while chunk := response.read(_CHUNK):
                    got += len(chunk)
                    if got > size:
                        raise _failed(
                            url, folder, f"it sent more than the {size:,} bytes expected", sha256
                        )
                    digest.update(chunk)
                    out.write(chunk)
                    deadline.left()
            if deadline.passed:
                raise TimeoutError("the deadline passed")
            if declared.isdigit() and got != int(declared):
                raise _failed(
                    url,
                    folder,
                    f"the connection closed after {got:,} of the {int(declared):,} bytes it "
                    "announced",
                    sha256,
                )
            if digest.hexdigest() != sha256:
                page = " (an HTML page, not the file)" if kind == "text/html" else ""
                raise _failed(
                    url,
                    folder,
                    f"the file it sent{page} ({got:,} bytes) has SHA-256 "
                    f"{digest.hexdigest()}, not the expected {sha256}",
                    sha256,
                )

        try:
            write_atomic(target, write, overwrite=True, encoding=None)
        except OSError as exc:
            if str(exc).startswith("fetch_caiviac:"):
                raise
            if deadline.passed or isinstance(exc, TimeoutError):
                raise _failed(
                    url, folder, f"not done within {timeout:g} s (timeout=)", sha256
                ) from None
            if isinstance(exc, urllib.error.HTTPError):
                exc.close()  # it holds the server's answer open
                what = f"the server answered HTTP {exc.code} {exc.reason}"
            elif isinstance(exc, urllib.error.URLError):
                what = f"{type(exc.reason).__name__}: {exc.reason}"
            else:
                what = f"{type(exc).__name__}: {exc}"
            raise _failed(url, folder, what, sha256) from None
        except (http.client.HTTPException, ValueError) as exc:
            if deadline.passed:
                raise _failed(
                    url, folder, f"not done within {timeout:g} s (timeout=)", sha256
                ) from None
            raise _failed(url, folder, f"{type(exc).__name__}: {exc}", sha256) from None


def _open_regular(path):
    """A file descriptor of the regular file ``path``, never through a link; None
    if there is nothing there."""
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        fd = os.open(path, flags | getattr(os, "O_BINARY", 0))
    except FileNotFoundError:
        return None
    if not stat.S_ISREG(os.fstat(fd).st_mode):  # pragma: no cover - lstat refused it first
        os.close(fd)
        raise OSError(f"fetch_caiviac: {os.fspath(path)!r} is not a regular file.")
    return fd


def _sha256(path):
    """The SHA-256 of the regular file ``path`` (never read through a link), or None."""
    fd = _open_regular(path)
    if fd is None:
        return None
    digest = hashlib.sha256()
    with os.fdopen(fd, "rb") as fh:
        for chunk in iter(lambda: fh.read(_CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _recorded(folder):
    """The SHA-256 of each file by name, as ``SHA256SUMS`` records them ({} if absent
    or not in its format)."""
    fd = _open_regular(folder / _SUMS)
    if fd is None:
        return {}
    with os.fdopen(fd, "rb") as fh:
        text = fh.read(4096).decode("ascii", "replace")
    found = re.findall(r"^([0-9a-f]{64})  (\S+)$", text, flags=re.M)
    return {name: digest for digest, name in found}


def _check_names(folder):
    """Refuse, in one line, a cache folder or a file of the cache's names that is not
    what fetch_caiviac makes (a link, a pipe, a device, a folder): never followed."""
    names = (folder.parent, folder, *(folder / n for n in (_XLSX, _CSV, _SUMS, _LICENSE)))
    for path in names:
        kind = not_regular(path)
        if path in (folder.parent, folder) and kind in ("", "a folder"):
            continue
        if kind:
            raise OSError(
                f"fetch_caiviac: {os.fspath(path)!r} is {kind}, which fetch_caiviac did not "
                "make and does not follow; remove it (and anything else you put in the "
                f"cache folder {os.fspath(folder)!r}) and call fetch_caiviac again."
            )


def _make_folders(folder):
    """Create ``folder`` and the folders above it that are missing (none through a
    link in the part made here); the list of those created, deepest last."""
    made = []
    missing = []
    path = Path(folder)
    while not os.path.lexists(path):
        missing.append(path)
        path = path.parent
    for path in reversed(missing):
        os.mkdir(path)
        made.append(path)
    return made


def _remove_made(made):
    """Remove the folders fetch_caiviac made, deepest first, if still empty."""
    for path in reversed(made):
        try:
            os.rmdir(path)
        except OSError:
            pass


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
    timeout=TIMEOUT_S,
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

    Nothing in the cache is trusted, on every call: ``data.xlsx`` must have
    the pinned SHA-256 and ``cycles.csv`` the SHA-256 recorded in
    ``SHA256SUMS`` when it was made from that workbook; a file that differs
    is made again (an edited ``cycles.csv`` from the workbook, offline; an
    edited workbook downloaded again). A link, pipe, device or folder under
    one of the cache's names (``data.xlsx``, ``cycles.csv``, ``SHA256SUMS``,
    ``LICENSE.txt``), or a cache folder that is a link, is refused and never
    followed.

    Parameters
    ----------
    data_home : str or path-like, optional
        Where to cache the data (see :func:`sklearn.datasets.get_data_home`).
    download_if_missing : bool, default=True
        Without a cached copy: download it (True) or raise OSError (False).
    timeout : float, default=300
        Seconds the whole download may take: connecting, the server's answer
        and every byte (a server that sends a byte a second is stopped at the
        deadline). Looking the host name up is left to the system.
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
        One line naming the URL and the cache folder, and saying how to place
        a copy there by hand: when the file is missing and
        ``download_if_missing=False``, when the download fails (no network, an
        HTTP error, a broken answer, an HTML page, a wrong file, a file larger
        than the recording, the deadline); nothing is kept then, not even a
        folder it made. Also when a name in the cache is not a regular file.
    ValueError
        If ``timeout`` is not a number of seconds > 0.
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
    if (
        isinstance(timeout, bool)
        or not isinstance(timeout, int | float)
        or not math.isfinite(timeout)
        or timeout <= 0
    ):
        raise ValueError(f"timeout must be a number of seconds > 0; got {timeout!r}.")
    folder = cache_folder(data_home)
    _check_names(folder)
    xlsx, csv = folder / _XLSX, folder / _CSV
    recorded = _recorded(folder)
    have = _sha256(xlsx)
    fresh = (
        have == recorded.get(_XLSX) == SHA256
        and recorded.get(_CSV) is not None
        and _sha256(csv) == recorded[_CSV]
    )
    if not fresh:
        if have is not None and have != SHA256:
            xlsx.unlink()  # not the file we downloaded: fetch it again
            have = None
        if have is None:
            if not download_if_missing:
                raise OSError(
                    f"fetch_caiviac: no cached copy of {URL} in {os.fspath(folder)!r}, and "
                    f"download_if_missing=False; {_by_hand(folder)}."
                )
            made = _make_folders(folder)
            try:
                _download(URL, xlsx, SHA256, SIZE, timeout)
            except BaseException:
                _remove_made(made)
                raise
        _as_cycles_csv(xlsx, csv)
        write_atomic(folder / _LICENSE, LICENSE_TEXT, overwrite=True)
        sums = f"{SHA256}  {_XLSX}\n{_sha256(csv)}  {_CSV}\n"
        write_atomic(folder / _SUMS, sums, overwrite=True, encoding="ascii", newline="\n")
    return load_caiviac(csv, reference=reference, return_X_y=return_X_y, target=target)
