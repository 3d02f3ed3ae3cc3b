"""Validate the gap diagnosis on withheld effects of greyml's simulator (issue #6).

For each parameter error of the simulation (exact, and every physical
parameter class off by up to ±5 %), ``gap_harness.validate_withheld`` (beside this script) builds
cases from the VMC simulator: 20 with nothing withheld; ambient, heat_source,
initial_state and drift withheld one at a time at gap peaks of 2, 5, 10 and
30 times the probe noise (5 seeds each); and two pairs withheld at once
(ambient + drift, heat_source + initial_state; each part at 10 times the
noise). Every case has its own six random heating/cooling tests (about 2,150
rows). Since issue 27 it adds, per parameter error, cases with a heater on
the fixture that neither the simulation nor the library has (a lag of 60-120
min, ``--foreign`` not given to the diagnosis and as many given as a custom
effect), and counts the named effects whose interval over tests lies above 0. The diagnosis gets the drivers, the ambient column, ten sensors and
the simulation's sensitivities to its parameters.

Printed: top-1/top-2 recall by effect and size, the confusion matrix (sizes
of at least 10× the noise, and the null cases), both-named rate of the pairs,
false alarms of the null cases, median held-out shrinkage against the
oracle's (the true effect added back: what is left is the probe noise) and
the noise-free shrinkage (how much of the true, noise-free gap the named
effects remove), and the time per diagnosis.

Run: ``python benchmarks/bench_gap_validation.py [--seeds 5] [--null 20]
[--kind class|element] [--no-sensitivities] [--n-jobs 2] [--foreign 10]
[--random-state 0] [--json out.json]``; ``--random-state 100`` gives other
cases to develop a rule on, keeping the default ones for its measure.
It takes about 15 min with two jobs on a two-core machine.
"""

from __future__ import annotations

import argparse
import time

import pandas as pd
from _common import package_versions, write_json
from gap_harness import validate_withheld


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--null", type=int, default=20)
    parser.add_argument("--sizes", default="2,5,10,30")
    parser.add_argument("--param-errors", default="0,0.05")
    parser.add_argument("--kind", choices=("class", "element"), default="class")
    parser.add_argument("--no-sensitivities", action="store_true")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--effects", default="ambient,heat_source,initial_state,drift")
    parser.add_argument("--pair-seeds", type=int, default=None, help="seeds per pair (--seeds)")
    parser.add_argument("--events", type=int, default=10, help="step cases per parameter error")
    parser.add_argument("--custom", type=int, default=10, help="custom-effect cases per error")
    parser.add_argument("--custom-size", type=float, default=30.0)
    parser.add_argument(
        "--foreign",
        type=int,
        default=10,
        help="fixture-heater cases per error, not given and given as a custom effect (each)",
    )
    parser.add_argument("--foreign-size", type=float, default=30.0)
    parser.add_argument("--random-state", type=int, default=0, help="the first case's seed")
    parser.add_argument("--json", default=None)
    parser.add_argument(
        "--verbose",
        type=int,
        default=5,
        help="joblib's progress on standard error while the cases run (0: none; default 5)",
    )
    args = parser.parse_args(argv)

    start = time.perf_counter()
    effects = tuple(e for e in args.effects.split(",") if e)
    result = validate_withheld(
        effects,
        pairs=(("ambient", "drift"), ("heat_source", "initial_state"))
        if args.pair_seeds != 0
        else (),
        n_events=args.events,
        n_custom=args.custom,
        custom_size=args.custom_size,
        n_foreign=args.foreign,
        foreign_size=args.foreign_size,
        sizes=tuple(float(s) for s in args.sizes.split(",")) if args.sizes else (),
        n_seeds=args.seeds,
        param_errors=tuple(float(p) for p in args.param_errors.split(",")),
        n_null=args.null,
        kind=args.kind,
        sensitivities=not args.no_sensitivities,
        n_jobs=args.n_jobs,
        verbose=args.verbose,
        random_state=args.random_state,
    )
    wall = time.perf_counter() - start
    pd.set_option("display.width", 160)
    cases = result.cases
    print(
        f"{len(cases)} cases in {wall:.0f} s; parameter error kind {args.kind!r}; "
        f"sensitivities {'no' if args.no_sensitivities else 'yes'}"
    )
    print("\nTop-1 / top-2 recall by effect and size (peak / probe noise):")
    print(result.recall().round(2).to_string())
    for pe in sorted(cases["param_error"].unique()):
        print(f"\nConfusion (rows withheld, columns named), parameter error {pe:g}, size >= 10:")
        print(result.confusion(param_error=pe, min_size=10).to_string())
    print("\nTwo effects withheld (each at 10× the noise):")
    print(result.pairs().round(2).to_string())
    print("\nNull cases: false alarms / cases:")
    print(result.false_alarms().to_string())
    print("\nVerdicts by case:")
    print(result.verdicts().to_string())
    if args.events:
        print("\nStep of 3-6x the noise in one test: verdict unexplained/partial, no physical")
        print("effect named (clean), located in the right test within 10 min:")
        print(result.events().round(2).to_string())
    if args.custom:
        print(
            f"\nHeat input driven by a logged column, given only as a custom effect ({args.custom_size:g}x):"
        )
        print(result.custom().round(3).to_string())
        extra = cases[cases["withheld"] == "custom"]
        print(f"  oracle shrinkage median {extra['oracle_shrinkage'].median():.3f}")
    if args.foreign:
        print(
            f"\nHeater on the fixture (lag 60-120 min, {args.foreign_size:g}x), not in the library:"
            " not given (foreign: no library effect named, verdict unexplained/partial, median"
            " unexplained share) and given as the custom effect 'fixture' (foreign_custom: named,"
            " median shrinkage against the oracle's, share within 0.05 of it):"
        )
        print(result.foreign().round(3).to_string())
    intervals = result.named_intervals()
    print(
        f"\nNamed effects in all cases: {intervals['named']}; with their 95% interval over "
        f"tests above 0: {intervals['interval_above_0']}"
    )
    print("\nMedian held-out shrinkage (size >= 10): named effects, oracle, noise-free:")
    print(result.shrinkage(min_size=10).round(3).to_string())
    print(
        f"\nDiagnosis time per case: median {cases['seconds'].median():.1f} s, "
        f"max {cases['seconds'].max():.1f} s"
    )
    if args.json:
        write_json(
            args.json,
            {"cases": cases.to_dict(orient="records"), "wall_s": wall},
            packages=package_versions(["numpy", "scipy", "pandas", "greyml"]),
            argv=argv,
        )


if __name__ == "__main__":
    main()
