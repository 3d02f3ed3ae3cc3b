"""The gap diagnosis on cases built like real measurements (issue 27, items 1 and 2).

Families (``gap_harness._measured``, beside this script), each over ``--seeds`` seeds
at rows every 15 s, 60 s and 5 min (a seed is the same six random
heating/cooling tests of the VMC simulator at every rate, 5.5 h each):

- quantised nulls: nothing withheld, the probe reads the exact simulation
  plus its noise (0.1 µm) rounded to steps of 0.25 µm and 1 µm;
- Gaussian nulls: the same without rounding;
- slow-noise nulls: the probe noise a first-order autoregression with a
  correlation time of 60 s (a sensor that averages), same 0.1 µm;
- drop: the air drops by 2 °C for 20 min in one test, which the probe's
  bracket feels within a minute (10× the noise); the simulation has the
  air but not the bracket;
- smooth: a fixture heater, switched in 20-90 min blocks and not handed to
  the diagnosis, through a 60-120 min lag (10× and 30× the noise).
- door (issue 42): a door open for 20 min in one test that neither the
  ambient column nor the simulation sees, the structure's smooth response
  peaking at 1-2 µm, located as a departure (``report.departures``);
  ``bench_gap_thermal.py`` prints its acceptance line.

Printed, with issue 27's acceptance beside each number: the share of
quantised nulls ``"within_noise"`` with no event (>= 95 %), of Gaussian nulls
(100 %), of slow-noise nulls; the share of drops located in the right test
within 10 min at every rate (>= 90 %) and whether the 15 s and 5 min rows
place it within 10 min of each other; the false events per test of the
smooth cases at every rate (<= 0.1); the noise floor against the true
measurement error; the time per diagnosis.

Run: ``python benchmarks/bench_gap_measured.py [--seeds 20] [--families a,b]
[--n-jobs 1] [--json out.json]``. With 20 seeds: 480 cases, about 20 min of
CPU with one BLAS thread.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from _common import package_versions, write_json
from gap_harness._measured import FAMILIES, summarise_measured, validate_measured
from threadpoolctl import threadpool_limits


def _counts(series):
    return {str(k): int(v) for k, v in series.value_counts().items()}


def _share(mask):
    return f"{mask.mean():.1%} ({int(mask.sum())} of {mask.size})"


def _drops(drop, family, by_rate):
    """The lines of a drop family: located at each rate, and at 15 s and 5 min alike."""
    out = []
    if not len(drop):
        return out
    out.append(
        f"\n{family} (20 min, 10x the noise): located in its test within 10 min, bar >= 90 %"
    )
    for rate in by_rate:
        g = drop[drop["sample_s"] == rate]
        out.append(
            f"  {rate:>5g} s rows: {_share(g['located'])}; false events per test "
            f"{(g['false_events'] / g['n_tests']).mean():.3f}; named when missed: "
            f"{_counts(g.loc[~g['located'].astype(bool), 'named'])}"
        )
    every = drop.groupby("seed")["located"].all()
    out.append(f"  located at every rate: {_share(every)}")
    wide = drop.pivot_table(index="seed", columns="sample_s", values="located_s")
    if {15.0, 300.0} <= set(wide.columns):
        both = wide[[15.0, 300.0]].dropna()
        same = (both[15.0] - both[300.0]).abs() <= 600
        out.append(
            f"  15 s and 5 min rows place it within 10 min of each other: {_share(same)} "
            f"of the seeds located at both (largest difference "
            f"{(both[15.0] - both[300.0]).abs().max():g} s)"
        )
    return out


def _report(cases):
    out = []
    by_rate = sorted(cases["sample_s"].unique())
    nulls = cases[cases["family"].str.endswith("_null")]
    for (family, quantum), group in nulls.groupby(["family", "quantum"]):
        bar = {"quantised_null": ">= 95 %", "gaussian_null": "100 %"}.get(family, "-")
        ok = (group["verdict"] == "within_noise") & (group["n_events"] == 0)
        out.append(f"\n{family} (quantum {quantum:g}): within_noise with no event, bar {bar}")
        out.append(f"  all rates: {_share(ok)}")
        for rate in by_rate:
            at = group["sample_s"] == rate
            if at.any():
                g = group[at]
                ratio = (g["noise_floor"] / g["true_noise"]).median()
                out.append(
                    f"  {rate:>5g} s rows: {_share(ok[at])}; verdicts "
                    f"{_counts(g['verdict'])}; events {int(g['n_events'].sum())}; "
                    f"floor / true error median {ratio:.2f}"
                )
    for family in ("drop", "drop_unlogged"):
        out += _drops(cases[cases["family"] == family], family, by_rate)
    smooth = cases[cases["family"] == "smooth"]
    if len(smooth):
        out.append("\nsmooth (60-120 min lag, not given): false events per test, bar <= 0.1")
        for (size, rate), g in smooth.groupby(["size", "sample_s"]):
            out.append(
                f"  size {size:g}x, {rate:>5g} s rows: {(g['false_events'] / g['n_tests']).mean():.3f}"
                f" ({int(g['false_events'].sum())} events in {int(g['n_tests'].sum())} tests); "
                f"verdicts {_counts(g['verdict'])}"
            )
    out.append("\nTime per diagnosis (s), by rate:")
    out.append(cases.groupby("sample_s")["seconds"].describe()[["count", "50%", "max"]].to_string())
    return "\n".join(out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--families", default=",".join(FAMILIES))
    parser.add_argument("--n-jobs", type=int, default=1)
    parser.add_argument("--random-state", type=int, default=0)
    parser.add_argument("--json", default=None)
    parser.add_argument("--verbose", type=int, default=0)
    args = parser.parse_args(argv)
    families = tuple(f for f in args.families.split(",") if f)
    start, cpu = time.perf_counter(), time.process_time()
    with threadpool_limits(limits=1, user_api="blas"):
        cases = validate_measured(
            families,
            n_seeds=args.seeds,
            random_state=args.random_state,
            n_jobs=args.n_jobs,
            verbose=args.verbose,
        )
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    pd.set_option("display.width", 160)
    print(
        f"{len(cases)} cases ({args.seeds} seeds per family, rate and size) in {wall:.0f} s "
        f"wall, {cpu:.0f} s CPU of this process"
    )
    print(_report(cases))
    print("\nSummary table:")
    print(summarise_measured(cases).round(3).to_string())
    if args.json:
        write_json(
            args.json,
            {"cases": cases.replace({np.nan: None}).to_dict(orient="records"), "wall_s": wall},
            packages=package_versions(["numpy", "scipy", "pandas", "greyml"]),
            argv=argv,
        )


if __name__ == "__main__":
    main()
