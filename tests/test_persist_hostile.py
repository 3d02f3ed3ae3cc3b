"""Hostile model files (issue 19): bounded memory, no processes and no code from a file.

Every hostile file is built here, from a model fitted in the test; none is
shipped. All of them are loaded in ONE child process (importing greyml takes
seconds) that runs under an address-space limit of 500 MiB beyond what its
imports took (``resource.setrlimit(RLIMIT_AS)``; pandas with pyarrow maps a
large address space of its own): each goes through ``load_model`` and
through ``greyml predict`` (``greyml.cli.main``), and the child reports the
messages, exit codes, standard error, its child processes and its peak
resident memory (``VmHWM``, Linux).
"""

import io
import json
import os
import struct
import subprocess
import sys
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import TRUE_B, TRUE_B1, TRUE_U, exciting_drivers
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.multioutput import MultiOutputRegressor
from sklearn.pipeline import FeatureUnion, Pipeline
from sklearn.preprocessing import MinMaxScaler, PolynomialFeatures, StandardScaler

from greyml import (
    AGO,
    GMC,
    Compensator,
    LagFeatures,
    ThermalTransferFunction,
    make_test_index,
    persist,
)
from greyml.grey._functions import simulate_gmc
from greyml.io import write_tests_csv
from greyml.persist import DEFAULT_MAX_BYTES, load_model, save_model

pytest.importorskip("resource")  # POSIX: the child sets its limit with it

ROOT = Path(__file__).parent.parent
LIMIT = 500 * 2**20  # address space of the child, bytes
COLUMNS = ["T1_C", "T2_C", "T3_C", "T4_C"]

# The child: load every file, then run greyml predict on it; report as JSON.
CHILD = r"""
import contextlib, io, json, os, resource, sys
from greyml.cli import main
from greyml.persist import load_model
import greyml.dynamic, greyml.controller, greyml.selection  # noqa: E401  what a file may name

def address_space():
    with open("/proc/self/status") as handle:
        for line in handle:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0

# the limit is on top of what the imports took (pandas with pyarrow maps a
# large address space of its own): what a file can cost beyond them
limit = address_space() + int(sys.argv[1])
resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

def children():
    me, count = str(os.getpid()), 0
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as handle:
                    fields = handle.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            count += fields[1] == me
    return count

jobs = json.loads(sys.argv[2])
report = {}
for label, job in jobs.items():
    row = {}
    try:
        model = load_model(job["model"])
    except Exception as exc:
        row["error"] = f"{type(exc).__name__}: {exc}"
    else:
        row["loaded"] = type(model).__name__
        row["n_jobs"] = sorted(
            {repr(v) for k, v in model.get_params(deep=True).items() if k.endswith("n_jobs")}
        )
    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        row["exit"] = main(["predict", job["model"], job["data"], "--out", job["out"]])
    row["stderr"] = stderr.getvalue()
    row["children"] = children()
    # the child's own peak resident memory (ru_maxrss would carry the parent's
    # over from fork across exec)
    with open("/proc/self/status") as handle:
        row["peak_kib"] = int(next(l for l in handle if l.startswith("VmHWM:")).split()[1])
    report[label] = row
print(json.dumps(report))
"""


# -- building the files ------------------------------------------------------------


def _frame():
    """Two tests of 40 samples from the GMC response with known coefficients."""
    rng = np.random.default_rng(19)
    frames = []
    for label in ("I", "II"):
        X = exciting_drivers(rng, 40)
        frame = pd.DataFrame(
            X, columns=COLUMNS, index=make_test_index([label] * 40, 10.0 * np.arange(40))
        )
        frame["dz_um"] = simulate_gmc(X, TRUE_B1, TRUE_B, TRUE_U)
        frames.append(frame)
    frame = pd.concat(frames)
    return frame[COLUMNS], frame["dz_um"]


def _members(path):
    with zipfile.ZipFile(path) as archive:
        return {info.filename: archive.read(info) for info in archive.infolist()}


def _index_cost(path):
    """zipfile's index as load_model counts it: 1 KiB per 46 bytes of the zip's
    central directory (46 bytes and the name of each record)."""
    with zipfile.ZipFile(path) as archive:
        directory = sum(
            46 + len(info.filename.encode()) + len(info.extra) + len(info.comment)
            for info in archive.infolist()
        )
    return directory // 46 * 1024


def _write(path, members, compression=None):
    """A zip of ``members`` (deflated, as greyml writes; ``compression`` maps a
    member to another zip method)."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, content in members.items():
            archive.writestr(name, content, compress_type=(compression or {}).get(name))
    return path


def _tamper(source, out, edit=None, extra=None, text=None, compression=None):
    """A copy of ``source`` with model.json edited (``edit(header)``, then ``text``
    on its JSON text) and members added."""
    members = _members(source)
    header = json.loads(members["model.json"])
    if edit is not None:
        edit(header)
    raw = json.dumps(header)
    members["model.json"] = (raw if text is None else text(raw)).encode()
    members.update(extra or {})
    return _write(out, members, compression)


def _npy(array):
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def _npy_header_only(shape, descr):
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": descr, "fortran_order": False, "shape": shape}
    )
    return buffer.getvalue()


def _deflated(head, mib_of_zeros):
    """A raw deflate stream of ``head`` and then ``mib_of_zeros`` MiB of zeros,
    built without compressing them: after a full flush, each MiB of zeros
    compresses to the same bytes, so one is repeated."""
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    start = compressor.compress(head) + compressor.flush(zlib.Z_FULL_FLUSH)
    block = compressor.compress(bytes(2**20)) + compressor.flush(zlib.Z_FULL_FLUSH)
    return start + block * mib_of_zeros + compressor.flush()


def _raw_zip(path, members):
    """A zip written by hand: ``members`` are (name, method, data as stored,
    CRC, size declared), so the declared size can be anything."""
    out, directory = bytearray(), bytearray()
    for name, method, data, crc, size in members:
        name = name.encode()
        fields = (20, 0, method, 0, 0x21, crc, len(data), size, len(name))
        directory += struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 20, *fields, 0, 0, 0, 0, 0, len(out))
        directory += name
        out += struct.pack("<4s5H3L2H", b"PK\x03\x04", *fields, 0) + name + data
    end = struct.pack(
        "<4s4H2LH", b"PK\x05\x06", 0, 0, len(members), len(members), len(directory), len(out), 0
    )
    path.write_bytes(bytes(out + directory + end))
    return path


def _many_records(path, count):
    """A zip whose central directory lists one empty member ``count`` times."""
    name = b"arrays/0.npy"
    fields = (20, 0, 0, 0, 0x21, 0, 0, 0, len(name))
    local = struct.pack("<4s5H3L2H", b"PK\x03\x04", *fields, 0) + name
    record = struct.pack("<4s6H3L5H2L", b"PK\x01\x02", 20, *fields, 0, 0, 0, 0, 0, 0) + name
    end = struct.pack(
        "<4s4H2LH", b"PK\x05\x06", 0, 0, 0xFFFF, 0xFFFF, len(record) * count, len(local), 0
    )
    path.write_bytes(local + record * count + end)
    return path


def _state(header):
    return header["tree"]["state"]


def _set(**attributes):
    return lambda header: _state(header).update(attributes)


def _ndarray(name):
    return {"kind": "ndarray", "file": name}


def _build(folder):
    """Every hostile file, each with what the test expects of it."""
    X, y = _frame()
    data = write_tests_csv(pd.concat([X, y], axis=1), folder / "tests.csv")
    gmc = save_model(GMC().fit(X, y), folder / "gmc.greyml")
    union = save_model(
        Pipeline(
            [
                ("union", FeatureUnion([("std", StandardScaler()), ("minmax", MinMaxScaler())])),
                ("linear", LinearRegression()),
            ]
        ).fit(X, y),
        folder / "union.greyml",
    )
    ago = save_model(AGO().fit(X), folder / "ago.greyml")
    coef = _state(json.loads(_members(gmc)["model.json"]))["driving_coef_"]["file"]
    files = {}

    # 1. one 16 MiB member referenced 200 times (3.2 GB if each were inflated)
    zeros = _npy(np.zeros(2 * 2**20))
    files["1-shared-member"] = _tamper(
        gmc,
        folder / "shared.greyml",
        _set(extra_=[_ndarray("arrays/99.npy")] * 200),
        extra={"arrays/99.npy": zeros},
    )
    # ... in bzip2, which zipfile inflates without a bound per read
    files["1-bzip2"] = _tamper(
        gmc,
        folder / "bzip2.greyml",
        _set(extra_=[_ndarray("arrays/99.npy")] * 200),
        extra={"arrays/99.npy": _npy(np.zeros(100))},
        compression={"arrays/99.npy": zipfile.ZIP_BZIP2},
    )

    # 2. GMC's coefficients followed by 600 MiB of zeros in the same member,
    # which declares only the coefficients' size (a 0.6 MB file)
    members = _members(gmc)
    declared = members[coef]
    bomb = _deflated(declared, 600)
    stored = [
        (name, zipfile.ZIP_STORED, content, zlib.crc32(content), len(content))
        for name, content in members.items()
        if name != coef
    ]
    for label, crc in (("crc-of-declared", zlib.crc32(declared)), ("other-crc", 0)):
        bombed = (coef, zipfile.ZIP_DEFLATED, bomb, crc, len(declared))
        files[f"2-inflates-{label}"] = _raw_zip(folder / f"{label}.greyml", [*stored, bombed])
    # a member that declares more than the whole limit
    files["2-declares-too-much"] = _raw_zip(
        folder / "declares.greyml",
        [*stored, (coef, zipfile.ZIP_DEFLATED, bomb, 0, DEFAULT_MAX_BYTES + 1)],
    )

    # a central directory of a million records (58 MB), which zipfile's index
    # would hold in ~560 MB
    files["2-zip-index"] = _many_records(folder / "index.greyml", 10**6)

    # 3. shapes that cost nothing to load
    names = {"kind": "object_array", "shape": [10**18, 0], "items": []}
    files["3-names-1e18x0"] = _tamper(
        gmc, folder / "empty-axis.greyml", _set(feature_names_in_=names)
    )
    files["3-names-U0"] = _tamper(
        gmc,
        folder / "u0.greyml",
        _set(feature_names_in_=_ndarray("arrays/98.npy")),
        extra={"arrays/98.npy": _npy_header_only((10**15,), "<U0")},
    )
    five = {"kind": "object_array", "shape": [5], "items": [*COLUMNS, "T5_C"]}
    files["3-names-5-for-4"] = _tamper(gmc, folder / "five.greyml", _set(feature_names_in_=five))
    files["3-coef-3-for-4"] = _tamper(
        gmc,
        folder / "coef3.greyml",
        _set(driving_coef_=_ndarray("arrays/97.npy")),
        extra={"arrays/97.npy": _npy(np.ones(3))},
    )

    # 4. n_jobs=64 in the FeatureUnion and the LinearRegression of a pipeline
    def many_jobs(header):
        for _, step in (pair["items"] for pair in _state(header)["steps"]):
            step["state"]["n_jobs"] = 64

    files["4-n_jobs"] = _tamper(union, folder / "jobs.greyml", many_jobs)

    # 5. attributes the loader would call, or that hide the class's own
    add = {"kind": "ufunc", "name": "numpy.add"}
    files["5-check-params-on-AGO"] = _tamper(
        ago, folder / "ago-add.greyml", _set(_check_params=add)
    )
    files["5-check-common-params"] = _tamper(
        gmc, folder / "gmc-add.greyml", _set(_check_common_params=add)
    )
    files["5-property"] = _tamper(gmc, folder / "property.greyml", _set(_repr_html_="<b>"))
    files["5-method"] = _tamper(gmc, folder / "method.greyml", _set(_html_repr=1))

    # 7. not a regular file; numbers that overflow
    fifo = folder / "model.fifo"
    os.mkfifo(fifo)
    files["7-fifo"] = fifo
    files["7-dev-zero"] = Path("/dev/zero")
    files["7-1e999"] = _tamper(
        gmc,
        folder / "inf.greyml",
        _set(control_="HUGE"),
        text=lambda s: s.replace('"HUGE"', "1e999"),
    )
    files["7-float32-overflow"] = _tamper(
        gmc,
        folder / "f4.greyml",
        _set(control_={"kind": "scalar", "dtype": "<f4", "value": 1e300}),
    )

    # issue 26: a dynamic model's fitted state, checked before it is used
    ttf = save_model(
        ThermalTransferFunction(time_constants=[30.0, 90.0]).fit(X, y), folder / "ttf.greyml"
    )

    def negative_tau(header):
        _state(header)["_spec_"][0]["items"][2]["items"][0] = -30.0

    files["26-negative-time-constant"] = _tamper(ttf, folder / "negative.greyml", negative_tau)
    lags = save_model(
        Pipeline([("lags", LagFeatures([30.0])), ("ridge", Ridge())]).fit(X, y),
        folder / "lags.greyml",
    )

    def bank_of_50000(header):
        step = _state(header)["steps"][0]["items"][1]["state"]
        step["time_constants"] = {"kind": "ndarray", "file": "arrays/96.npy"}
        step["time_constants_"] = {"kind": "ndarray", "file": "arrays/96.npy"}

    files["26-bank-of-50000"] = _tamper(
        lags,
        folder / "bank.greyml",
        bank_of_50000,
        extra={"arrays/96.npy": _npy(np.linspace(10.0, 1e5, 50_000))},
    )
    comp = Compensator(COLUMNS, [(c, 1, 60.0, 1.0) for c in COLUMNS], relative_to_start=True)
    comp.update({"time_s": 0.0, **dict(zip(COLUMNS, X.iloc[0]))})
    comp = save_model(comp, folder / "comp.greyml")
    files["26-compensator-nan-start"] = _tamper(
        comp, folder / "nan-start.greyml", _set(_start={"kind": "float", "value": "nan"})
    )

    # issue 41: sizes a file declares, bounded and checked against each other (a
    # PolynomialFeatures of 4 inputs, degree 2: 15 outputs with the bias, then Ridge)
    poly = save_model(
        Pipeline([("poly", PolynomialFeatures(2)), ("ridge", Ridge())]).fit(X, y),
        folder / "poly.greyml",
    )

    def poly_state(**attributes):
        return lambda header: _state(header)["steps"][0]["items"][1]["state"].update(attributes)

    for label, value in (("1e9", 10**9), ("1e9-float", 1e9), ("inf", "INF"), ("nan", "NAN")):
        text = {"INF": {"kind": "float", "value": "inf"}, "NAN": {"kind": "float", "value": "nan"}}
        files[f"41-poly-outputs-{label}"] = _tamper(
            poly,
            folder / f"poly-{label}.greyml",
            poly_state(n_output_features_=text.get(value, value)),
        )
    files["41-poly-outputs-16-for-15"] = _tamper(
        poly, folder / "poly-16.greyml", poly_state(n_output_features_=16, _n_out_full=16)
    )
    # consistent in itself (interaction terms only: 1 + 4 + 6 = 11), not with the Ridge's 15
    files["41-poly-11-into-15"] = _tamper(
        poly,
        folder / "poly-11.greyml",
        poly_state(interaction_only=True, n_output_features_=11, _n_out_full=11),
    )
    files["41-inputs-1e9"] = _tamper(gmc, folder / "inputs.greyml", _set(n_features_in_=10**9))
    files["41-poly-degree-1e9"] = _tamper(
        poly, folder / "degree.greyml", poly_state(_max_degree=10**9)
    )
    return data, files


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    if not Path("/proc/self/stat").exists():
        pytest.skip("counting child processes reads /proc (Linux)")
    folder = tmp_path_factory.mktemp("hostile")
    data, files = _build(folder)
    jobs = {
        label: {"model": str(path), "data": str(data), "out": str(folder / f"{i}.csv")}
        for i, (label, path) in enumerate(files.items())
    }
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        "OMP_NUM_THREADS": "1",
        "OPENBLAS_NUM_THREADS": "1",
        "MKL_NUM_THREADS": "1",
    }
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(LIMIT), json.dumps(jobs)],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    rows = json.loads(done.stdout)
    for label, row in rows.items():
        row["model"] = jobs[label]["model"]
        row["out"] = Path(jobs[label]["out"])
    return rows


def _refused(row, *matches):
    """One-line ValueError naming the file, and greyml predict: exit 2, one line."""
    assert "error" in row, row
    message = row["error"]
    assert message.startswith("ValueError: Cannot load "), message
    assert "\n" not in message and row["model"] in message
    for match in matches:
        assert match in message, message
    _cli_refused(row)
    return message


def _cli_refused(row):
    assert row["exit"] == 2, row
    lines = row["stderr"].splitlines()
    assert len(lines) == 1 and lines[0].startswith("greyml predict: error: "), row["stderr"]
    assert "Traceback" not in row["stderr"]
    assert not row["out"].exists() or row["out"].stat().st_size == 0


def _small(row):
    assert row["peak_kib"] * 1024 < LIMIT  # peak resident memory of the child
    assert row["children"] == 0  # no process started


def test_1_a_member_referenced_many_times_is_counted_per_reference(report):
    row = report["1-shared-member"]
    # 200 references x (2 Mi float64 + 128 header bytes) = 3,355,468,800 bytes, plus
    # model.json 128 times, GMC's own arrays as their members hold them, its 4
    # feature names (8 bytes each) and zipfile's index at 1 KiB per member
    members = _members(Path(row["model"]))
    own = sum(
        len(content)
        for name, content in members.items()
        if name.startswith("arrays/") and name != "arrays/99.npy"
    )
    total = (
        200 * (2 * 2**20 * 8 + 128)
        + 128 * len(members["model.json"])
        + own
        + 4 * 8
        + _index_cost(Path(row["model"]))
    )
    _refused(
        row, "loading it would build", f" {total:,} bytes, over the limit max_bytes=268,435,456 "
    )
    _small(row)
    _refused(
        report["1-bzip2"], "arrays/99.npy is compressed with zip method 12; greyml writes deflate"
    )
    _small(report["1-bzip2"])


def test_1_each_member_is_inflated_once_and_each_reference_is_its_own(tmp_path, monkeypatch):
    X, y = _frame()
    gmc = save_model(GMC().fit(X, y), tmp_path / "gmc.greyml")
    extra = {"arrays/99.npy": _npy(np.arange(5.0))}  # 128 header + 40 data bytes
    path = _tamper(
        gmc, tmp_path / "three.greyml", _set(extra_=[_ndarray("arrays/99.npy")] * 3), extra
    )
    reads = []
    read_npy = persist._read_npy

    def counting(archive, info, header):
        reads.append(info.filename)
        return read_npy(archive, info, header)

    monkeypatch.setattr(persist._reader, "_read_npy", counting)  # where load_model reads
    model = load_model(path)
    arrays = sorted(name for name in _members(path) if name.startswith("arrays/"))
    assert sorted(reads) == arrays and "arrays/99.npy" in arrays  # each inflated once
    a, b, c = model.extra_
    assert a.tolist() == b.tolist() == c.tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
    a[0] = 9.0  # each reference its own array, as greyml writes them
    assert b[0] == c[0] == 0.0
    # what the members declare (model.json 128 times, the index at 1 KiB per 46
    # bytes of its directory) passes; the load counts two more copies of arrays/99.npy (2 x 168
    # bytes) and the 4 feature names (8 each)
    members = _members(path)
    declared = (
        _index_cost(path)
        + 128 * len(members["model.json"])
        + sum(len(content) for name, content in members.items() if name != "model.json")
    )
    with pytest.raises(ValueError, match=f"build .* {declared + 2 * 168 + 4 * 8:,} bytes, over"):
        load_model(path, max_bytes=declared)
    assert load_model(path, max_bytes=declared + 2 * 168 + 4 * 8).extra_[2].shape == (5,)


def test_2_a_member_is_read_only_to_its_declared_size(report):
    # a CRC that is not the declared part's: refused after reading only that
    _refused(report["2-inflates-other-crc"], "Bad CRC-32")
    _small(report["2-inflates-other-crc"])
    # CRC of the declared part: the 600 MiB behind it are never inflated
    row = report["2-inflates-crc-of-declared"]
    assert row["loaded"] == "GMC" and row["exit"] == 0, row
    _small(row)
    _refused(report["2-declares-too-much"], "its members declare", "over the limit max_bytes=")
    _small(report["2-declares-too-much"])
    # 58,000,000 bytes of records of at least 46 bytes, 1 KiB each counted
    _refused(report["2-zip-index"], f"its members would take {58_000_000 // 46 * 1024:,} bytes")
    _small(report["2-zip-index"])


def test_2_max_bytes_is_a_limit_the_caller_sets(tmp_path):
    X, y = _frame()
    path = save_model(GMC().fit(X, y), tmp_path / "gmc.greyml")
    size = path.stat().st_size
    with pytest.raises(
        ValueError, match=f"the file holds {size:,} bytes, over the limit max_bytes=100 "
    ):
        load_model(path, max_bytes=100)
    assert load_model(path, max_bytes=2**20).driving_coef_.shape == (4,)
    with pytest.raises(TypeError, match="max_bytes must be a whole number"):
        load_model(path, max_bytes=1e9)
    with pytest.raises(ValueError, match="max_bytes must be positive"):
        load_model(path, max_bytes=0)


def test_3_shapes_must_agree_with_the_estimator(report):
    # 10**18 x 0 object entries: 8 * 10**18 bytes counted, refused before any is built
    _refused(report["3-names-1e18x0"], "loading it would build")
    # 10**15 zero-width strings count one byte each
    _refused(report["3-names-U0"], "loading it would build")
    _refused(
        report["3-names-5-for-4"],
        "feature_names_in_ has shape (5,), but its n_features_in_ = 4 implies (4)",
    )
    _refused(
        report["3-coef-3-for-4"],
        "driving_coef_ has shape (3,), but its n_features_in_ = 4 implies (4)",
    )
    for label in ("3-names-1e18x0", "3-names-U0", "3-names-5-for-4", "3-coef-3-for-4"):
        _small(report[label])


def test_4_processes_are_not_taken_from_the_file(report):
    row = report["4-n_jobs"]
    assert row["loaded"] == "Pipeline"
    assert row["n_jobs"] == ["None"]  # the FeatureUnion's and the LinearRegression's
    assert row["exit"] == 0 and row["stderr"] == "", row
    assert row["out"].stat().st_size > 0
    _small(row)


def test_4_n_jobs_is_reset_in_process(tmp_path):
    X, y = _frame()
    union = Pipeline([("union", FeatureUnion([("s", StandardScaler())])), ("ridge", Ridge())])
    path = save_model(union.fit(X, y), tmp_path / "u.greyml")

    def many_jobs(header):
        _state(header)["steps"][0]["items"][1]["state"]["n_jobs"] = 64

    model = load_model(_tamper(path, tmp_path / "jobs.greyml", many_jobs))
    assert model.named_steps["union"].n_jobs is None
    assert np.array_equal(model.predict(X), union.predict(X))

    # a trusted class is trusted to exist, not to choose the processes
    multi = MultiOutputRegressor(Ridge()).fit(X, np.column_stack([y, 2 * y]))
    path = save_model(multi, tmp_path / "multi.greyml")
    model = load_model(
        _tamper(path, tmp_path / "multi-jobs.greyml", _set(n_jobs=64)),
        trusted=["sklearn.multioutput.MultiOutputRegressor"],
    )
    assert model.n_jobs is None
    assert np.array_equal(model.predict(X), multi.predict(X))


def test_5_only_data_comes_from_a_file(report):
    _refused(
        report["5-check-params-on-AGO"],
        "sets the attribute '_check_params' to a function (numpy.add); only data may come",
    )
    _refused(report["5-check-common-params"], "'_check_common_params' to a function (numpy.add)")
    _refused(report["5-property"], "sets the forbidden attribute '_repr_html_'")
    _refused(report["5-method"], "sets the forbidden attribute '_html_repr'")
    for label in ("5-check-params-on-AGO", "5-check-common-params", "5-property", "5-method"):
        _small(report[label])


def test_7_only_regular_files_are_opened(report):
    for label in ("7-fifo", "7-dev-zero"):
        row = report[label]
        _refused(row, "it is not a regular file (a device, pipe or socket)")
        _small(row)


def test_7_numbers_that_overflow_are_refused(report):
    _refused(report["7-1e999"], "the JSON holds the number 1e999, which overflows a float")
    _refused(report["7-float32-overflow"], "the value 1e+300 overflows a NumPy float32 scalar")
    for label in ("7-1e999", "7-float32-overflow"):
        _small(report[label])


def test_7_whole_numbers_are_bounded(tmp_path):
    X, y = _frame()
    path = save_model(GMC().fit(X, y), tmp_path / "gmc.greyml")
    long = _tamper(
        path, tmp_path / "long.greyml", _set(n_iter_="N"), text=lambda s: s.replace('"N"', "9" * 61)
    )
    with pytest.raises(ValueError, match="a whole number of 61 digits; greyml writes at most 60"):
        load_model(long)
    wide = _tamper(
        path,
        tmp_path / "i8.greyml",
        _set(n_iter_={"kind": "scalar", "dtype": "<i8", "value": 2**70}),
    )
    with pytest.raises(ValueError, match="overflows a NumPy int64 scalar"):
        load_model(wide)


def test_arrays_read_through_the_bounded_reader_are_exact(tmp_path):
    X, y = _frame()
    model = AGO().fit(X)
    model.extra_ = [
        np.asfortranarray(np.arange(6.0).reshape(2, 3)),
        np.arange(3, dtype=">i4"),
        np.array([True, False]),
        np.array(["T1_C", "ü"]),
        np.zeros((0, 3)),
        np.float32(1.5),
    ]
    loaded = load_model(save_model(model, tmp_path / "ago.greyml"))
    for saved, read in zip(model.extra_, loaded.extra_):
        assert type(read) is type(saved) and read.dtype == saved.dtype
        assert np.array_equal(read, saved) and np.shape(read) == np.shape(saved)
    assert loaded.extra_[0].flags.f_contiguous and loaded.extra_[0][1, 2] == 5.0
    assert loaded.extra_[1].tolist() == [0, 1, 2]


@pytest.mark.parametrize(
    "attributes, match",
    [
        ({"response": "euler"}, r"invalid parameter: The 'response' parameter of GMC must be"),
        ({"n_population": -1}, r"invalid parameter: The 'n_population' parameter of GMC"),
    ],
)
def test_a_parameter_outside_its_constraints_is_refused(tmp_path, attributes, match):
    """Loading runs the estimator's own _validate_params: a value that fit would
    refuse is refused, one line naming the file and the parameter."""
    X, y = _frame()
    gmc = save_model(GMC().fit(X, y), tmp_path / "gmc.greyml")
    bad = _tamper(gmc, tmp_path / "gmc-bad.greyml", _set(**attributes))
    with pytest.raises(ValueError, match=match) as info:
        load_model(bad)
    assert "\n" not in str(info.value) and "gmc-bad.greyml" in str(info.value)


def test_26_a_dynamic_models_fitted_state_is_checked_within_the_limit(report):
    _refused(report["26-negative-time-constant"], "time constant -30.0 s", "not a finite number")
    _refused(report["26-bank-of-50000"], "50,000 time constants, more than the 1,000")
    _refused(report["26-compensator-nan-start"], "the state holds a value that is not finite")
    for label in ("26-negative-time-constant", "26-bank-of-50000", "26-compensator-nan-start"):
        _small(report[label])


def test_41_sizes_a_file_declares_are_bounded_and_agree(report):
    """A PolynomialFeatures declaring 1e9 outputs made greyml predict die with NumPy's
    MemoryError and exit 1 (issue 41, finding 7): each size is checked at load."""
    for label, shown in (
        ("1e9", "1000000000"),
        ("1e9-float", "1000000000.0"),
        ("inf", "inf"),
        ("nan", "nan"),
    ):
        _refused(
            report[f"41-poly-outputs-{label}"],
            f"the sklearn.preprocessing.PolynomialFeatures object's n_output_features_ is {shown}, "
            "not a whole number in [1, 100,000]",
        )
    _refused(
        report["41-poly-outputs-16-for-15"],
        "n_output_features_ is 16, but its 4 inputs and degrees 0 to 2 give 15",
    )
    _refused(
        report["41-poly-11-into-15"],
        "the sklearn.pipeline.Pipeline object's step Ridge takes 15 columns, but the step "
        "before it (PolynomialFeatures) gives 11",
    )
    _refused(
        report["41-inputs-1e9"],
        "the greyml.GMC object's n_features_in_ is 1000000000, not a whole number in [1, 100,000]",
    )
    _refused(report["41-poly-degree-1e9"], "_max_degree is 1000000000, not a whole number in [0,")
    for label in report:
        if label.startswith("41-"):
            _small(report[label])
