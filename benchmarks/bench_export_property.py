"""Issue 41's acceptance: 10,000 random call sequences in Python and in the compiled C.

Each sequence (10 to 80 calls of ``update`` / ``observe`` / ``recalibrate`` /
``reset`` / a saved state restored, drawn by hypothesis, on the export tests'
scripted compensator with one of three sets of limits: see
``tests/_export_property.py``) runs in Python and in the C export, compiled
once per set of limits with ``gcc -std=c99 -O2 -Wall -Wextra -Wconversion
-pedantic -Werror`` and driven through ctypes. The property: every output
finite and within ``max_correction_um`` (plus half a quantum where rounded) or
the call refused with a status; Python and C refuse and hold the same calls;
output, correction and half-width equal to 1e-9 relative to max(1, |value|).
The test suite runs the same property on 30 sequences
(``tests/test_export_property.py``).

Run ``python benchmarks/bench_export_property.py [--examples 10000] [--seed 0]``
from the repository root; it prints the number of sequences and calls run,
refused and held, and the largest difference between Python and C.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from _export_property import TOLERANCE, run, sequences  # noqa: E402
from hypothesis import HealthCheck, given, seed, settings  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    seen = {"sequences": 0, "calls": 0, "worst": 0.0}
    tally = {}

    @seed(args.seed)
    @settings(
        max_examples=args.examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(sequences)
    def prop(case):
        variant, calls = case
        worst = run(variant, calls, tally)
        seen["sequences"] += 1
        seen["calls"] += len(calls)
        seen["worst"] = max(seen["worst"], worst)

    start = time.perf_counter()
    prop()
    elapsed = time.perf_counter() - start
    print(
        f"{seen['sequences']:,} sequences, {seen['calls']:,} calls, in {elapsed:.0f} s: every "
        f"output finite and within max_correction_um or refused; largest Python-C difference "
        f"{seen['worst']:.2e} (relative to max(1, |value|); bound {TOLERANCE:g})"
    )
    print("rows and readings: " + ", ".join(f"{v:,} {k}" for k, v in sorted(tally.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
