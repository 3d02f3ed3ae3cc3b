"""Time a full sim-to-real gap diagnosis: 6 tests × 2,000 rows, every effect.

Issue #6 asks: "A full diagnosis of 6 tests × 2,000 rows with all effects runs
in under 30 s on this machine." This script builds that case from greyml's VMC
simulator and times ``greyml.gap.diagnose_gap`` with its default settings
(recalibration on, 39 placebos per step, at most 3 effects).

The case: six heating/cooling tests sampled every 10 s, each 19,990 s long
(2,000 rows): random blocks of spindle speed and feed for about 3.5 h, then
standing until the end. The air follows a daily cycle of 0.5-2.5 °C amplitude
starting at a random hour; before four of the six tests the machine ran at
4000 or 8000 rpm in the same air, so they start warm. The "measured" tests have
every effect of the simulator and measurement noise; the "simulation" lacks
one effect (``--withheld``, a key of ``gap_harness.WITHHELD``; by
default the coupling of the structure to the ambient air) and noise. The diagnosis gets the two drivers, the ambient column
and ten temperature sensors (``fbgs=()``), so that six of the seven effects of
the library can be tried; ``fbg_temperature`` needs an FBG target.

Printed: the rows, the effects tried and named, each repeat's wall time of the
whole diagnosis with its minimum and median, PASS or MISS against 30 s, and
the time of the "where" part alone (``gap_breakdown`` and
``residual_diagnostics`` on the same gap). ``--blas-threads 1`` runs
everything with one BLAS thread (``threadpoolctl``), for comparison on a busy
machine.

Run: ``python benchmarks/bench_gap.py [--repeats 3] [--withheld ambient]
[--blas-threads N] [--json out.json]``
"""

from __future__ import annotations

import argparse
import platform
import time
from contextlib import nullcontext

import numpy as np
from _common import package_versions, write_json

from greyml.datasets import make_tests
from greyml.gap import diagnose_gap, gap_breakdown, residual_diagnostics

try:
    from gap_harness import WITHHELD
except ImportError:  # --against an older greyml, which carried the harness itself
    try:
        from greyml.gap_validation import WITHHELD
    except ImportError:  # a release before issue 27, whose harness was in greyml.gap
        from greyml.gap import WITHHELD
from greyml.simulation import Effects, HeatingTest, Programme, diurnal

LIMIT_S = 30.0
TARGET = "dy_um"
DRIVERS = ["spindle_rpm", "feed_mm_min"]
AMBIENT = "ambient_C"
#: ten of the VMC's 76 sensors, spread over its groups
SENSORS = [f"T{k}_C" for k in (1, 8, 18, 25, 33, 41, 53, 59, 65, 71)]
PACKAGES = ["greyml", "numpy", "scipy", "pandas"]


def heating_cooling_tests(rng, n_tests=6, rows=2000, sample_s=10.0):
    """``n_tests`` tests of exactly ``rows`` samples: random duty, then standing."""
    length_s = (rows - 1) * sample_s
    tests = []
    for k in range(n_tests):
        programme, on_s = Programme(), 0.0
        while on_s < 0.6 * length_s:
            block_s = 60.0 * float(rng.integers(20, 60))
            programme = programme.run(
                seconds=block_s,
                spindle_rpm=float(rng.choice([2000, 4000, 6000, 8000])),
                feed_mm_min=float(rng.choice([0, 1000, 3000, 5000])),
            )
            on_s += block_s
        programme = programme.dwell(seconds=length_s - on_s)
        air = diurnal(
            20.0 + rng.normal(0.0, 1.0),
            float(rng.uniform(0.5, 2.5)),
            start_hour=float(rng.uniform(0.0, 24.0)),
        )
        history = None
        if k % 3 != 2:  # four of six tests start warm from a run in the same air
            history = Programme().run(
                int(rng.integers(30, 120)), spindle_rpm=float(rng.choice([4000, 8000]))
            )
        tests.append(HeatingTest(f"T{k + 1}", programme, air, history, sample_s=sample_s))
    return tests


def make_case(withheld="ambient", n_tests=6, rows=2000, sample_s=10.0, seed=0):
    """Measured tests (every effect, noise) and a simulation lacking ``withheld``."""
    tests = heating_cooling_tests(np.random.default_rng(seed), n_tests, rows, sample_s)
    real = make_tests("vmc", tests, effects=Effects(), random_state=seed).frame
    sim_effects = Effects().without("noise", WITHHELD[withheld])
    sim = make_tests("vmc", tests, effects=sim_effects, random_state=seed).frame[[TARGET]]
    return real, sim


def diagnose(real, sim):
    return diagnose_gap(
        real,
        sim,
        target=TARGET,
        ambient=AMBIENT,
        drivers=DRIVERS,
        sensors=SENSORS,
        fbgs=(),
        random_state=0,
    )


def where_only(real, sim):
    """The "where" part alone: breakdown and residual diagnostics of the gap."""
    r = (real[TARGET] - sim[TARGET]).rename("gap")
    table = gap_breakdown(r, drivers=real[DRIVERS])
    whiteness, xcorr = residual_diagnostics(r, real[[*DRIVERS, AMBIENT, *SENSORS]])
    return table, whiteness, xcorr


def timed(function, repeats):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = function()
        times.append(time.perf_counter() - start)
    return times, out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--withheld", choices=list(WITHHELD), default="ambient")
    parser.add_argument("--rows", type=int, default=2000, help="rows per test")
    parser.add_argument(
        "--blas-threads", type=int, default=None, help="limit BLAS threads (threadpoolctl)"
    )
    parser.add_argument("--json", metavar="PATH", help="also write the results as JSON")
    parser.add_argument(
        "--against",
        metavar="DIR",
        help="also time the same diagnosis with the greyml package found in DIR (e.g. the "
        "previous release unpacked there: git archive 55e1ca1 greyml | tar -x -C DIR), in a "
        "subprocess, and print the ratio of the two",
    )
    parser.add_argument("--peer", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.peer:  # run by --against: time this process's greyml, print JSON
        import json

        real, sim = make_case(args.withheld, rows=args.rows)
        times, report = timed(lambda: diagnose(real, sim), args.repeats)
        cpu = []
        for _ in range(args.repeats):
            start = time.process_time()
            diagnose(real, sim)
            cpu.append(time.process_time() - start)
        print(json.dumps({"wall": times, "cpu": cpu, "named": list(report.named)}))
        return

    real, sim = make_case(args.withheld, rows=args.rows)
    per_test = real.groupby(level="test", sort=False).size()
    sizes = " or ".join(str(n) for n in sorted(set(per_test)))
    print(
        f"VMC simulator: {len(per_test)} tests × {sizes} rows = {len(real)} rows "
        f"(10 s sampling); simulation without {args.withheld!r}; "
        f"target {TARGET}, {len(DRIVERS)} drivers, ambient, {len(SENSORS)} sensors."
    )
    print(
        f"Environment: Python {platform.python_version()}, "
        + ", ".join(f"{k} {v}" for k, v in package_versions(PACKAGES).items())
        + f", BLAS threads {'default' if args.blas_threads is None else args.blas_threads}"
    )

    if args.blas_threads is None:
        limit = nullcontext()
    else:
        from threadpoolctl import threadpool_limits

        limit = threadpool_limits(limits=args.blas_threads, user_api="blas")
    with limit:
        full, report = timed(lambda: diagnose(real, sim), args.repeats)
        where, _ = timed(lambda: where_only(real, sim), args.repeats)

    causes = report.causes
    tried = causes.loc[causes["shrinkage"].notna(), "effect"].tolist()
    skipped = causes.loc[causes["shrinkage"].isna(), "effect"].tolist()
    print(f"\nEffects tried: {', '.join(tried)}; not tried: {', '.join(skipped) or 'none'}.")
    print(
        f"Named: {', '.join(report.named) or 'nothing'}; held-out RMSE "
        f"{report.rmse_before:.3g} -> {report.rmse_after:.3g} µm "
        f"(shrinkage {report.shrinkage:.0%}, noise floor {report.noise_floor:.3g} µm)."
    )
    best, median = min(full), float(np.median(full))
    verdict = "PASS" if median < LIMIT_S else "MISS"
    print(
        f"\ndiagnose_gap, {args.repeats} repeats: "
        + ", ".join(f"{t:.2f}" for t in full)
        + f" s; min {best:.2f} s, median {median:.2f} s  [{verdict}: limit {LIMIT_S:g} s]"
    )
    print(
        "where alone (gap_breakdown + residual_diagnostics): "
        + ", ".join(f"{t:.3f}" for t in where)
        + f" s; min {min(where):.3f} s, median {float(np.median(where)):.3f} s"
    )

    peer = None
    if args.against:
        import json
        import os
        import subprocess
        import sys

        env = dict(os.environ, PYTHONPATH=os.path.abspath(args.against))
        here = os.path.dirname(os.path.abspath(__file__))
        cmd = [
            sys.executable,
            os.path.join(here, "bench_gap.py"),
            "--peer",
            "--repeats",
            str(args.repeats),
            "--withheld",
            args.withheld,
            "--rows",
            str(args.rows),
        ]
        # the same measurement here, CPU time too, interleaved with the peer's
        cpu = []
        for _ in range(args.repeats):
            start = time.process_time()
            diagnose(real, sim)
            cpu.append(time.process_time() - start)
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True).stdout
        peer = json.loads(out.strip().splitlines()[-1])
        ratio_wall = float(np.median(peer["wall"])) / median
        ratio_cpu = float(np.median(peer["cpu"])) / float(np.median(cpu))
        print(
            f"\nAgainst greyml in {args.against}: median "
            f"{float(np.median(peer['wall'])):.2f} s wall, {float(np.median(peer['cpu'])):.2f} s CPU "
            f"(named {', '.join(peer['named']) or 'nothing'}); this greyml "
            f"{median:.2f} s wall, {float(np.median(cpu)):.2f} s CPU. "
            f"Speed-up: {ratio_wall:.1f}x wall, {ratio_cpu:.1f}x CPU."
        )

    if args.json:
        write_json(
            args.json,
            {
                "rows": len(real),
                "rows_per_test": {str(k): int(v) for k, v in per_test.items()},
                "withheld": args.withheld,
                "effects_tried": tried,
                "named": list(report.named),
                "shrinkage": report.shrinkage,
                "diagnose_s": full,
                "diagnose_min_s": best,
                "diagnose_median_s": median,
                "where_s": where,
                "limit_s": LIMIT_S,
                "under_limit": bool(median < LIMIT_S),
                "peer": peer,
            },
            packages=PACKAGES,
            argv=argv,
            repeats=args.repeats,
            blas_threads=args.blas_threads,
        )


if __name__ == "__main__":
    main()
