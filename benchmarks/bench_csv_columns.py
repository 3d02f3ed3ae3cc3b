"""How ``greyml.io.read_tests_csv`` scales with the number of columns.

Writes two CSV files of 5 rows, one with 4,000 and one with 40,000 data
columns, reads each ``--repeat`` times and reports the best time of each and
their ratio. Reading is linear in the number of columns when the ratio is
near 10 (the acceptance bound is 12); a per-column loop that grows the frame
one column at a time makes it about 30 (20 s against 0.7 s before the fix).

Run::

    OMP_NUM_THREADS=1 python benchmarks/bench_csv_columns.py
    python benchmarks/bench_csv_columns.py --repeat 5 --json csv_columns.json
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(__file__))

from _common import write_json  # noqa: E402

from greyml.io import read_tests_csv  # noqa: E402

ROWS = 5
SIZES = (4_000, 40_000)


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
    ratio = results[SIZES[1]] / results[SIZES[0]]
    print(f"ratio {SIZES[1]:,} / {SIZES[0]:,} columns: {ratio:.1f}x (linear: 10x, bound 12x)")
    if args.json:
        write_json(
            args.json,
            {"seconds": {str(k): v for k, v in results.items()}, "ratio": ratio},
            packages=["greyml", "pandas", "numpy"],
            rows=ROWS,
            repeat=args.repeat,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
