"""How ``greyml.io.read_tests_csv`` scales with the number of columns.

Writes two CSV files of 5 rows, one with 4,000 and one with 40,000 data
columns, reads each ``--repeat`` times and reports the best time of each and
their ratio. Reading is linear in the number of columns when the ratio is
near 10 (the acceptance bound is 12); a per-column loop that grows the frame
one column at a time makes it about 30 (20 s against 0.7 s before the fix).

Then the refusal of a file wider than ``read_tests_csv``'s ``max_columns``
(issue 41, finding 4): a file of 3 rows and 1,000,000 columns (30 MB) is
refused from its header, before a value is read. Its time is measured in
``read_tests_csv`` and end to end for ``greyml predict|fit|select|gap`` (each a
new Python process, its import included; bound 5 s each, one line on standard
error, exit 2). Before the bound, ``greyml predict`` took 195 s to refuse that
file and ``select`` and ``fit`` ran past 300 s. Last, the commands' magnitude
check on the 40,000-column frame (one pass over the numbers since issue 41).

Run::

    OMP_NUM_THREADS=1 python benchmarks/bench_csv_columns.py
    python benchmarks/bench_csv_columns.py --repeat 5 --json csv_columns.json
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(__file__))

from _common import write_json  # noqa: E402

from greyml.io import read_tests_csv  # noqa: E402

ROWS = 5
SIZES = (4_000, 40_000)
#: The file refused from its header: rows and columns.
WIDE = (3, 1_000_000)
#: The bound on each command's refusal of it (wall time, seconds).
REFUSAL_BOUND_S = 5.0


def write_wide(path, n_columns, rows=ROWS):
    """A CSV of one test, ``rows`` rows and ``n_columns`` data columns of numbers."""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("test,time_s," + ",".join(f"T{k}_C" for k in range(n_columns)) + "\n")
        for r in range(rows):
            cells = ",".join(f"{20 + 0.001 * ((k * 7 + r) % 997):.3f}" for k in range(n_columns))
            fh.write(f"A,{60 * r}," + cells + "\n")


def best_time(path, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        frame = read_tests_csv(path)
        times.append(time.perf_counter() - start)
    return min(times), frame.shape


def refusal(folder, model):
    """Seconds ``read_tests_csv`` and each command take to refuse the 1,000,000-column file."""
    path = os.path.join(folder, "wide_refused.csv")
    write_wide(path, WIDE[1], rows=WIDE[0])
    start = time.perf_counter()
    try:
        read_tests_csv(path)
        raise AssertionError(f"{path} was read")
    except ValueError as exc:
        message = str(exc)
    seconds = {"read_tests_csv": time.perf_counter() - start}
    print(
        f"{WIDE[1]:,} columns x {WIDE[0]} rows: read_tests_csv refuses in {seconds['read_tests_csv']:.3f} s"
    )
    print(f"  {message}")
    commands = {
        "predict": ["predict", model, path, "--out", os.path.join(folder, "p.csv")],
        "fit": [
            "fit",
            path,
            "--target",
            "dz_um",
            "--model",
            "gmc",
            "--out",
            os.path.join(folder, "f.greyml"),
        ],
        "select": ["select", path, "--target", "dz_um"],
        "gap": ["gap", path, path, "--target", "dz_um"],
    }
    code = "import sys; from greyml.cli import main; sys.exit(main(sys.argv[1:]))"
    ok = True
    for command, args in commands.items():
        start = time.perf_counter()
        run = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True)
        seconds[command] = time.perf_counter() - start
        lines = run.stderr.count("\n")
        good = run.returncode == 2 and lines == 1 and seconds[command] < REFUSAL_BOUND_S
        ok &= good
        print(
            f"  greyml {command}: exit {run.returncode}, {lines} line(s) on stderr, "
            f"{seconds[command]:.2f} s (bound {REFUSAL_BOUND_S:g} s): {'pass' if good else 'FAIL'}"
        )
    return seconds, ok


def magnitude_check(path):
    """Seconds the commands' magnitude check takes on the frame of ``path``."""
    from greyml._cli._files import _check_magnitudes

    frame = read_tests_csv(path)
    start = time.perf_counter()
    _check_magnitudes(frame, path)
    return time.perf_counter() - start


def small_model(folder):
    """A GMC fitted on a few rows, for ``greyml predict`` to load."""
    import numpy as np
    import pandas as pd

    from greyml import GMC, make_test_index
    from greyml.persist import save_model

    t = 60.0 * np.arange(6)
    X = pd.DataFrame({"T1_C": 20 + t / 600}, index=make_test_index(["A"] * 6, t))
    return str(save_model(GMC().fit(X, -t / 100), os.path.join(folder, "m.greyml")))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="reads per file (best kept)")
    parser.add_argument("--json", metavar="FILE", help="also write the numbers as JSON")
    args = parser.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        for n in SIZES:
            path = os.path.join(folder, f"wide_{n}.csv")
            write_wide(path, n)
            seconds, shape = best_time(path, args.repeat)
            results[n] = seconds
            size = os.path.getsize(path) / 2**20
            print(f"{n:>6,} columns x {ROWS} rows ({size:.1f} MiB): {seconds:.3f} s, {shape}")
            if n == SIZES[1]:
                magnitudes = magnitude_check(path)
                print(f"  magnitude check of its {n:,} columns: {magnitudes:.3f} s")
        ratio = results[SIZES[1]] / results[SIZES[0]]
        print(f"ratio {SIZES[1]:,} / {SIZES[0]:,} columns: {ratio:.1f}x (linear: 10x, bound 12x)")
        refused, ok = refusal(folder, small_model(folder))
    if args.json:
        write_json(
            args.json,
            {
                "seconds": {str(k): v for k, v in results.items()},
                "ratio": ratio,
                "magnitude_check_s": magnitudes,
                "refusal_s": refused,
                "refusal_ok": ok,
            },
            packages=["greyml", "pandas", "numpy"],
            rows=ROWS,
            repeat=args.repeat,
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
