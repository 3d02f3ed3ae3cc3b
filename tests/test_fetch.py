"""fetch_caiviac: downloaded once with its size and checksum checked, cached, offline
afterwards; nothing half-written is kept (issue 30). A local HTTP server stands in
for GitHub: the test suite needs no network."""

import functools
import hashlib
import http.server
import threading
import urllib.request

import numpy as np
import pandas as pd
import pytest
from conftest import caiviac_csv_or_skip

from greyml.datasets import _fetch, fetch_caiviac, load_caiviac
from greyml.io import read_tests_csv

pytest.importorskip("openpyxl")


def _workbook(path, n_cycles=3, rows_per_half=40):
    """A small recording in the upstream sheet's layout: 23 columns, spindle on then off."""
    rng = np.random.default_rng(0)
    idle = 6
    rpm = [0.0] * idle
    for k in range(n_cycles):
        rpm += [1000.0 * (k + 1)] * rows_per_half + [0.0] * rows_per_half
    n = len(rpm)
    values = {"時間(s)": 15.0 * np.arange(n), "spindle(RPM)": rpm}
    for k in range(1, 6):
        values[f"ch{k}(um)"] = np.cumsum(rng.normal(0, 0.1, n))
    for k in range(1, 17):
        values[f"t{k}(°C)"] = 22.0 + np.cumsum(rng.normal(0, 0.01, n))
    pd.DataFrame(values).to_excel(path, sheet_name=_fetch.SHEET, index=False)
    return np.asarray(rpm)


@pytest.fixture
def served(tmp_path, monkeypatch):
    """The workbook served over HTTP on localhost; URL, size and checksum pointed at it."""
    folder = tmp_path / "www"
    folder.mkdir()
    rpm = _workbook(folder / "data.xlsx")
    data = (folder / "data.xlsx").read_bytes()
    handler = functools.partial(http.server.SimpleHTTPRequestHandler, directory=str(folder))
    handler.log_message = lambda *a: None
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    monkeypatch.setattr(_fetch, "URL", f"http://127.0.0.1:{server.server_port}/data.xlsx")
    monkeypatch.setattr(_fetch, "SHA256", hashlib.sha256(data).hexdigest())
    monkeypatch.setattr(_fetch, "SIZE", len(data))
    yield rpm
    server.shutdown()
    server.server_close()


def _no_network(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the network was used")

    monkeypatch.setattr(urllib.request, "urlopen", refuse)


def test_downloaded_once_then_read_offline(served, tmp_path, monkeypatch):
    home = tmp_path / "home"
    data = fetch_caiviac(data_home=home)
    assert data.tests == ["1", "2", "3"]
    speeds = data.frame.groupby(level="test", sort=False)["spindle_rpm"].max().tolist()
    assert speeds == [1000.0, 2000.0, 3000.0]
    assert data.sensors == [f"t{k}_C" for k in range(1, 17)]
    assert "3 cycles" in data.description and "MIT" in data.license
    _no_network(monkeypatch)
    again = fetch_caiviac(data_home=home, reference="cycle")
    assert len(again.frame) == len(data.frame)
    # one loader: the cached file gives the frame read_tests_csv gives from it
    cached = home / "greyml" / "caiviac" / "cycles.csv"
    read = read_tests_csv(cached, test_column="cycle")
    pd.testing.assert_frame_equal(fetch_caiviac(data_home=home).frame, read)
    pd.testing.assert_frame_equal(load_caiviac(cached).frame, read)
    assert sorted(p.name for p in (home / "greyml" / "caiviac").iterdir()) == [
        "LICENSE.txt",
        "cycles.csv",
        "data.xlsx",
    ]


def test_a_wrong_file_is_not_kept(served, tmp_path, monkeypatch):
    monkeypatch.setattr(_fetch, "SHA256", "0" * 64)
    home = tmp_path / "home"
    with pytest.raises(OSError, match=r"has SHA-256 [0-9a-f]{64}, not the expected 0{64}"):
        fetch_caiviac(data_home=home)
    assert list((home / "greyml" / "caiviac").iterdir()) == []


def test_a_file_larger_than_expected_is_cut_off(served, tmp_path, monkeypatch):
    monkeypatch.setattr(_fetch, "SIZE", 1000)
    home = tmp_path / "home"
    with pytest.raises(OSError, match=r"sent more than the 1,000 bytes expected"):
        fetch_caiviac(data_home=home)
    assert list((home / "greyml" / "caiviac").iterdir()) == []


def test_a_tampered_cache_is_fetched_again(served, tmp_path):
    home = tmp_path / "home"
    folder = home / "greyml" / "caiviac"
    folder.mkdir(parents=True)
    (folder / "data.xlsx").write_bytes(b"not the recording")
    assert fetch_caiviac(data_home=home).tests == ["1", "2", "3"]


def test_offline_without_a_cache(tmp_path, monkeypatch):
    _no_network(monkeypatch)
    with pytest.raises(OSError, match=r"no cached copy in .* download_if_missing=False"):
        fetch_caiviac(data_home=tmp_path, download_if_missing=False)


def test_without_openpyxl(served, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "openpyxl", None)
    with pytest.raises(ImportError, match=r"pip install greyml\[data\]"):
        fetch_caiviac(data_home=tmp_path)


def test_cycles_from_spindle_starts_match_the_published_cycles():
    """The rule fetch_caiviac numbers cycles by gives cycles.csv's own cycle column."""
    raw = pd.read_csv(caiviac_csv_or_skip())
    cycles = _fetch._cycles(raw["spindle_rpm"].to_numpy(dtype=float))
    np.testing.assert_array_equal(cycles, raw["cycle"].to_numpy())


def test_cycles_by_hand():
    rpm = np.array([0, 0, 5, 5, 0, 0, 7, 0, 3, 3])
    np.testing.assert_array_equal(_fetch._cycles(rpm), [1, 1, 1, 1, 1, 1, 2, 2, 3, 3])
