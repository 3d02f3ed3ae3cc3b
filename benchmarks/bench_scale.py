"""A year of a fleet's logs: the default dynamic fit against rows, tests and machines.

The rows are the real CAIVIAC recording (``cycles.csv``: 16 temperatures and
the spindle speed, probe ``ch1_um``, 15 s rows) tiled on one continuous clock
to 10^5, 10^6 and 10^7 rows and cut into few and many tests (a machine's
stops); the model is ``ThermalTransferFunction(drivers=["spindle_rpm"])`` as
constructed, with every choice nested inside the fit and the interval
calibration. The displacement's reference is the recording's zero (the
model's choice on one clock), so no number here depends on it.

Each fit runs in its own child process, which reports its wall and CPU time
and its peak resident memory (``ru_maxrss``), so no fit inherits another's
memory. Measured in the same run, as the yardstick: NumPy's least squares
on the same rows' 17 raw inputs (``numpy.linalg.lstsq``, what a plain static
regression costs), and its ratio to every fit.

* ``memory``: the rows read into one frame, then ``fit``;
* ``chunks``: ``fit_chunks`` on :class:`greyml.io.TestFiles` reading
  Parquet files 200,000 rows at a time (the rows never held whole);
* ``fleet``: :func:`greyml.fleet.fit_fleet` over machines of 10^6 rows each
  (each the recording tiled from another cycle), on a ``LocalCluster`` of
  two worker processes and one after another; the models are compared.

Acceptance lines (printed as PASS/FAIL): 10^6 rows in 5 and in 520 tests
within 1.5x of each other; 10^7 rows in 1,000 tests from Parquet in chunks
under 60 s and 1.5 GB; the in-memory fit of the same rows at most the data's
size + 1 GB; the chunked, in-memory and Dask fits of 10^6 rows the same model
to 1e-9; every fleet model equal to its sequential fit.

Run ``python benchmarks/bench_scale.py --help``; ``--quick`` stops at 10^6
rows and a fleet of 4. Needs the recording (``--data``, ``$GREYML_CAIVIAC`` or
``../shared/realdata/caiviac``), pyarrow, dask and distributed.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import find_data, write_json

TARGET = "ch1_um"
PROBES = ("ch1_um", "ch2_um", "ch3_um", "ch4_um", "ch5_um")
FILE_ROWS = 500_000  # rows per Parquet file
PIECE_ROWS = 200_000  # rows read at a time
SPEC = [  # (rows, tests, paths)
    (100_000, 5, ("memory", "chunks")),
    (100_000, 52, ("memory", "chunks")),
    (1_000_000, 5, ("memory", "chunks")),
    (1_000_000, 520, ("memory", "chunks")),
    (10_000_000, 1_000, ("chunks", "memory")),
]
HERE = Path(__file__).resolve().parent


def write_parquet(cycles, folder, rows, tests, offset=0):
    """The tiled rows as Parquet files of FILE_ROWS rows, written a file at a time."""
    folder.mkdir(parents=True, exist_ok=True)
    if any(folder.glob("*.parquet")):
        return
    for k, start in enumerate(range(0, rows, FILE_ROWS)):
        part = _rows(cycles, rows, tests, offset, start, min(start + FILE_ROWS, rows))
        part.to_parquet(folder / f"part{k:04d}.parquet", index=False)


def _rows(cycles, rows, tests, offset, start, stop):
    """Rows ``start:stop`` of the recording tiled on one clock from row ``offset``, cut
    into ``tests`` tests of equal length: a flat frame (test, time_s, target, inputs)."""
    import pandas as pd

    base = cycles.reset_index(drop=True)
    r = np.arange(start, stop)
    flat = base.iloc[(r + offset) % len(base)].reset_index(drop=True)
    flat.insert(0, "time_s", r * 15.0)
    flat.insert(0, "test", pd.Series([f"t{k:05d}" for k in (r * tests) // rows], dtype=object))
    return flat


def read_cycles(path):
    """CAIVIAC's 16 temperatures, spindle speed and ch1 as a flat frame."""
    from greyml.io import read_tests_csv

    frame = read_tests_csv(path, test_column="cycle").reset_index(drop=True)
    inputs = ["spindle_rpm"] + [c for c in frame.columns if c.endswith("_C")]
    return frame[[TARGET, *inputs]]


# -- one fit in a child process -------------------------------------------------


def child(args):
    """Fit once (``--child memory|chunks|yardstick FOLDER``) and print a JSON line."""

    from greyml import ThermalTransferFunction
    from greyml.io import TestFiles

    kind, folder = args.child, args.folder
    files = TestFiles(folder, TARGET, each="recording", rows=PIECE_ROWS)
    out = {}
    if kind == "chunks":
        model = ThermalTransferFunction(drivers=["spindle_rpm"])
        w0, c0 = time.perf_counter(), time.process_time()
        model.fit_chunks(files)
    else:
        X, y = load_frame(files.paths)
        out["data_bytes"] = int(X.memory_usage(deep=True).sum() + y.nbytes)
        out["loaded_peak_bytes"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        w0, c0 = time.perf_counter(), time.process_time()
        if kind == "yardstick":
            A = np.column_stack([X.to_numpy(), np.ones(len(X))])
            np.linalg.lstsq(A, y, rcond=None)
            model = None
        else:
            model = ThermalTransferFunction(drivers=["spindle_rpm"]).fit(X, y)
    out.update(
        wall_s=time.perf_counter() - w0,
        cpu_s=time.process_time() - c0,
        peak_bytes=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024,
    )
    if model is not None:
        out["model"] = _summary(model)
    print(json.dumps(out))


def load_frame(paths):
    """The Parquet files as one frame in greyml's layout, built in place: one float
    block filled file by file, so that loading costs the data's size and a file."""
    import pandas as pd
    import pyarrow.parquet as pq

    n = sum(pq.ParquetFile(p).metadata.num_rows for p in paths)
    names = [c for c in pq.ParquetFile(paths[0]).schema_arrow.names if c not in ("test", "time_s")]
    inputs = [c for c in names if c != TARGET]
    block = np.empty((len(inputs), n))  # pandas keeps a float frame as (columns, rows)
    y, time, codes, labels = np.empty(n), np.empty(n), np.empty(n, dtype=np.int32), {}
    r0 = 0
    for path in paths:
        part = pq.read_table(path).to_pandas()
        r1 = r0 + len(part)
        block[:, r0:r1] = part[inputs].to_numpy(dtype=float).T
        y[r0:r1], time[r0:r1] = part[TARGET].to_numpy(), part["time_s"].to_numpy()
        codes[r0:r1] = [labels.setdefault(t, len(labels)) for t in part["test"]]
        r0 = r1
        del part
    tests = pd.Categorical.from_codes(codes, categories=list(labels))
    index = pd.MultiIndex.from_arrays([tests, time], names=["test", "time_s"])
    return pd.DataFrame(block.T, columns=inputs, index=index, copy=False), y


def _summary(model):
    cal = model.interval_calibration_
    return {
        "coef": model.feature_coef_.tolist(),
        "intercept": model.intercept_,
        "sensors": list(model.selected_sensors_),
        "calibration": [
            float(getattr(cal, f)) for f in ("anchor_var", "growth_var_per_h", "filter_scale")
        ]
        + [float(np.sum(cal.scores))],
    }


def run_child(kind, folder):
    command = [sys.executable, __file__, "--child", kind, "--folder", str(folder)]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode:
        raise RuntimeError(f"{kind} on {folder} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def same(a, b, tol=1e-9):
    """Whether two fits' summaries agree to ``tol`` (relative to each array's scale)."""
    if a["sensors"] != b["sensors"]:
        return False
    for key in ("coef", "calibration"):
        u, v = np.asarray(a[key]), np.asarray(b[key])
        if np.max(np.abs(u - v), initial=0.0) > tol * max(np.max(np.abs(u), initial=0.0), 1e-300):
            return False
    return abs(a["intercept"] - b["intercept"]) <= tol * max(abs(a["intercept"]), 1.0)


# -- the fleet ---------------------------------------------------------------------


def fleet(cycles, root, n_machines, rows, recording, reference):
    """The fleet's fits one after another and on a LocalCluster; and the model of the
    Parquet files ``recording`` from a dask.dataframe's partitions, against
    ``reference`` (its in-memory fit's summary)."""
    import dask.dataframe as dd
    from distributed import Client, LocalCluster

    from greyml import ThermalTransferFunction
    from greyml.fleet import Partitions, fit_fleet
    from greyml.io import TestFiles

    machines = {}
    for k in range(n_machines):
        folder = root / f"machine{k:02d}"
        write_parquet(cycles, folder, rows, 52, offset=k * 1931)
        machines[f"m{k:02d}"] = TestFiles(folder, TARGET, each="recording", rows=PIECE_ROWS)
    model = ThermalTransferFunction(drivers=["spindle_rpm"])
    w0 = time.perf_counter()
    alone = fit_fleet(model, machines)
    sequential = time.perf_counter() - w0
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as cluster,
        Client(cluster) as client,
    ):
        w0 = time.perf_counter()
        on_cluster = fit_fleet(model, machines, client=client)
        clustered = time.perf_counter() - w0
        frame = dd.read_parquet(sorted(str(p) for p in Path(recording).glob("*.parquet")))
        w0 = time.perf_counter()
        from_dask = ThermalTransferFunction(drivers=["spindle_rpm"]).fit_chunks(
            Partitions(frame, TARGET)
        )
        dask_s = time.perf_counter() - w0
    # to 1e-9: the workers run one BLAS thread (dask's nanny sets it), this process
    # the library's default, and BLAS sums a Gram in another order with more threads
    equal = all(same(_summary(on_cluster[m]), _summary(alone[m])) for m in machines)
    bitwise = sum(same(_summary(on_cluster[m]), _summary(alone[m]), tol=0.0) for m in machines)
    return {
        "machines": n_machines,
        "rows_each": rows,
        "sequential_s": sequential,
        "cluster_s": clustered,
        "speedup": sequential / clustered,
        "all_equal": equal,
        "bit_for_bit": int(bitwise),
        "dask_frame_s": dask_s,
        "dask_frame_equal": same(_summary(from_dask), reference),
    }


# -- main --------------------------------------------------------------------------


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", help="cycles.csv or its folder (default: found)")
    parser.add_argument("--quick", action="store_true", help="up to 10^6 rows, a fleet of 4")
    parser.add_argument("--machines", type=int, default=20, help="machines in the fleet")
    parser.add_argument("--work", help="folder for the Parquet files (default: a temp folder)")
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--folder", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        return child(args)
    path = find_data(args.data)
    if path is None:
        print("bench_scale: the CAIVIAC recording was not found (--data); nothing measured.")
        return 0
    cycles = read_cycles(path)
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="greyml-scale-"))
    spec = [s for s in SPEC if not (args.quick and s[0] > 1_000_000)]
    results, lines = {"fits": [], "acceptance": []}, []
    print(
        f"{'rows':>12} {'tests':>6} {'path':>7} {'wall s':>8} {'CPU s':>8} {'peak GB':>8} "
        f"{'data GB':>8} {'x lstsq':>8}"
    )
    for rows, tests, paths in spec:
        folder = work / f"rows{rows}_tests{tests}"
        write_parquet(cycles, folder, rows, tests)
        yard = run_child("yardstick", folder) if rows <= 1_000_000 else None
        for kind in paths:
            r = run_child(kind, folder)
            r.update(rows=rows, tests=tests, path=kind)
            r["yardstick_s"] = None if yard is None else yard["wall_s"]
            results["fits"].append(r)
            ratio = f"{r['wall_s'] / yard['wall_s']:8.0f}" if yard else f"{'-':>8}"
            data = f"{r['data_bytes'] / 1e9:8.2f}" if "data_bytes" in r else f"{'-':>8}"
            print(
                f"{rows:>12,} {tests:>6} {kind:>7} {r['wall_s']:8.1f} {r['cpu_s']:8.1f} "
                f"{r['peak_bytes'] / 1e9:8.2f} {data} {ratio}",
                flush=True,
            )

    def fit(rows, tests, kind):
        return next(
            (
                f
                for f in results["fits"]
                if (f["rows"], f["tests"], f["path"]) == (rows, tests, kind)
            ),
            None,
        )

    def accept(text, ok):
        results["acceptance"].append({"line": text, "pass": bool(ok)})
        lines.append(f"{'PASS' if ok else 'FAIL'}  {text}")

    few, many = fit(1_000_000, 5, "memory"), fit(1_000_000, 520, "memory")
    ratio = max(few["wall_s"], many["wall_s"]) / min(few["wall_s"], many["wall_s"])
    accept(
        f"10^6 rows in 5 and in 520 tests: {few['wall_s']:.1f} s and {many['wall_s']:.1f} s, "
        f"{ratio:.2f}x (bar 1.5x)",
        ratio <= 1.5,
    )
    chunked = fit(1_000_000, 520, "chunks")
    accept(
        "10^6 rows: the chunked and the in-memory fit the same model to 1e-9",
        same(chunked["model"], many["model"]),
    )
    big, big_memory = fit(10_000_000, 1_000, "chunks"), fit(10_000_000, 1_000, "memory")
    if big is not None:
        accept(
            f"10^7 rows, 1,000 tests, Parquet in chunks: {big['wall_s']:.1f} s (bar 60 s), "
            f"peak {big['peak_bytes'] / 1e9:.2f} GB (bar 1.5 GB)",
            big["wall_s"] < 60 and big["peak_bytes"] < 1.5e9,
        )
        limit = big_memory["data_bytes"] + 1e9
        accept(
            f"10^7 rows in memory: peak {big_memory['peak_bytes'] / 1e9:.2f} GB, data "
            f"{big_memory['data_bytes'] / 1e9:.2f} GB (bar data + 1 GB)",
            big_memory["peak_bytes"] <= limit,
        )
        accept(
            "10^7 rows: the chunked and the in-memory fit the same model to 1e-9",
            same(big["model"], big_memory["model"]),
        )
    n_machines = 4 if args.quick else args.machines
    results["fleet"] = fleet(
        cycles,
        work / "fleet",
        n_machines,
        1_000_000,
        work / "rows1000000_tests520",
        many["model"],
    )
    f = results["fleet"]
    print(
        f"fleet of {n_machines} x 10^6 rows: one after another {f['sequential_s']:.1f} s, "
        f"LocalCluster of 2 workers {f['cluster_s']:.1f} s ({f['speedup']:.2f}x)"
    )
    accept(
        f"fleet of {n_machines}: every model equals its sequential fit to 1e-9 "
        f"({f['bit_for_bit']} bit for bit)",
        f["all_equal"],
    )
    accept(
        "10^6 rows: the fit from a dask.dataframe's partitions (LocalCluster) the in-memory "
        f"model to 1e-9 ({f['dask_frame_s']:.1f} s)",
        f["dask_frame_equal"],
    )
    print("\n".join(lines))
    if args.json:
        write_json(
            args.json, results, packages=["greyml", "numpy", "pyarrow", "dask"], work=str(work)
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
