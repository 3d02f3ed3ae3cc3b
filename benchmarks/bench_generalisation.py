"""Generalisation (issue 38): greyml's default dynamic model on all five CAIVIAC probes and a simulated fleet.

Protocol
--------
* Models: the default greyml model exactly as a user constructs it,
  ``ThermalTransferFunction(drivers=[the machine's drivers])``, every other
  parameter at its default (built in ``bench_dynamic_peers.default_model``, so whatever the model's
  defaults become flows through), against no correction, ridge on all the
  temperatures' rises from each test's first row ("ridge-16" on CAIVIAC),
  ``LagFeatures`` + ``RidgeCV``, statsmodels ARDL (orders chosen inside the
  training tests) and sysidentpy NARX of degree 1 (free-run simulation), the
  last three on the default's sensors and on their own top-5-correlation
  sensors. Every row is a function of ``bench_dynamic_peers.py``: one
  implementation of each peer.
* Data and folds, all in ONE process with the same folds for every row:
  CAIVIAC's probes ``ch1_um`` … ``ch5_um``, leave one cycle out (5 × 5 = 25
  folds), the recording read as logged; the simulated fleet of
  ``benchmarks/_fleet.py`` (8 machines), leave one test out. Every choice a
  model makes is made on the training tests only; the held-out test's inputs
  may drive a model's state (a controller has them), its displacement never.
* "restart": the default fitted on the training tests alone and given the
  held-out test alone (no history).
* Scores: RMSE in µm per held-out test, in the **start** reference (change
  from each held-out test's first row; the headline) and the **recording**
  reference (from the recording's zero) beside it; per probe and per machine
  the median and the worst over folds, and in how many folds the default beats
  ridge; the warm-up machine's first test (24 h from cold) against the median
  of its later tests; the default's nested fit time against ARDL's, CPU time
  (``time.process_time``) with one BLAS thread, in the same run.
* ARDL and NARX run on one row a minute (``--peer-step`` on CAIVIAC's 15 s
  rows; the fleet is sampled every minute), simulated from the held-out
  test's first measured displacement, interpolated back to every row.

The acceptance lines of issue 38 are computed by ``acceptance``, which
returns records (:class:`Check`), printed at the end and written to the JSON.
``--write-docs`` rewrites the generated blocks of ``docs/benchmarks.rst`` and
``docs/dynamic_transfer.rst`` from ``--json`` (or, with ``--from-json``,
from an earlier run's file, without running anything). Without the CAIVIAC
data the script prints "CAIVIAC data not found at ...; skipping" for that
part and still runs the fleet.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import bench_dynamic_peers as peers
import numpy as np
from _common import check_docs_flags, chosen_units, find_data, replace_generated, write_json

PROBES = ("ch1_um", "ch2_um", "ch3_um", "ch4_um", "ch5_um")
QUICK_PROBES = ("ch1_um", "ch3_um")
QUICK_MACHINES = ("vmc-fast-drift", "vmc-doors", "vmc-cold")
DEFAULT = peers.DEFAULT
RESTART = "greyml default, restart"
NONE = "no correction"
RIDGE = "ridge-16 / all temperatures, rises"
REFERENCES = {
    "start": "RMSE µm, start reference (change from each held-out test's first row)",
    "recording": "RMSE µm, recording reference (from the recording's zero)",
}
CPU = "CPU s, one BLAS thread, summed over folds"
ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "generalisation.json"
DOCS = {
    "benchmarks": ROOT / "docs" / "benchmarks.rst",
    "transfer": ROOT / "docs" / "dynamic_transfer.rst",
}
LEGEND = """\
  ridge-16 / all temperatures   StandardScaler + RidgeCV on every temperature's rise from the test's first
                                row -> change from it (CAIVIAC: the 16 temperatures); in the recording
                                reference the test's starting offset counts as its error
  LagFeatures+RidgeCV           LagFeatures(5, 15, 45, 135 min) of the sensors and drivers, RidgeCV
  ARDL via OLS                  statsmodels ARDL(p, q), orders chosen inside the training tests, simulated
  NARX FROLS deg 1              sysidentpy FROLS(Polynomial(degree=1)), free-run simulation (steps_ahead=None)
  greyml's sensors / top-5 corr the default's sensors in the fold / the 5 highest |corr| with y (training rows)
  greyml default                default_model(drivers).fit(X, y, sample_weight=0 on the held-out test)
  greyml default, restart       default_model(drivers).fit(X[train], y[train]).predict(X[held]) alone"""


def rows():
    """(label, function, kwargs) of every row, in the order printed."""
    out = [(NONE, peers.no_correction, {}), (RIDGE, peers.ridge16, {"rises": True})]
    for source, name in (("default", "greyml's sensors"), ("corr", "top-5 corr")):
        out.append((f"LagFeatures+RidgeCV, {name}", peers.lag_ridge, {"source": source}))
    for source, name in (("default", "greyml's sensors"), ("corr", "top-5 corr")):
        out.append((f"ARDL via OLS, {name}", peers.ardl_row, {"source": source}))
    for source, name in (("default", "greyml's sensors"), ("corr", "top-5 corr")):
        out.append((f"NARX FROLS deg 1, {name}", peers.narx_row, {"source": source, "degree": 1}))
    return [*out, (DEFAULT, peers.greyml_default, {}), (RESTART, peers.greyml_restart, {})]


def labels():
    return [label for label, _, _ in rows()]


#: Rows the default is compared with for "the best peer" (not itself nor its restart).
def peer_labels():
    return [label for label in labels() if label not in (DEFAULT, RESTART)]


# Running ---------------------------------------------------------------------


def run_unit(X, y, drivers, temperatures, peer_step, quick, lag_state):
    """Every row on every leave-one-test-out fold of one probe or machine: {label: [record]}."""
    from greyml import groups_of

    groups = np.asarray(groups_of(X)).astype(str)
    table = {label: [] for label in labels()}
    for test in dict.fromkeys(groups):
        fold = peers.prepare_fold(
            X,
            y,
            groups,
            test,
            peer_step,
            quick,
            drivers=tuple(drivers),
            temperatures=tuple(temperatures),
            lag_state=lag_state,
            clock=time.process_time,
        )
        for label, function, kwargs in rows():
            table[label].append(peers.run_row(fold, function, kwargs))
    return table


def run_caiviac(path, probes, peer_step, quick):
    out = {}
    for probe in probes:
        X, y = peers.load(path, probe)
        out[probe] = run_unit(X, y, [peers.DRIVER], peers.SENSORS, peer_step, quick, "carry")
        print(f"  CAIVIAC {probe}: done", flush=True)
    return out


def run_fleet(machines, quick):
    out = {}
    for m in machines:
        temperatures = [c for c in m.X.columns if c not in m.drivers]
        out[m.name] = run_unit(m.X, m.y, m.drivers, temperatures, 1, quick, "auto")
        print(f"  fleet {m.name}: done", flush=True)
    return out


# Summaries and acceptance (functions of result tables: the report quotes them) ----


def summarise_unit(table):
    """Per row of one probe or machine: median and worst per reference, folds the default beats it, CPU s."""
    out = {}
    default = table[DEFAULT]
    for label, folds in table.items():
        errors = [r["error"] for r in folds if "error" in r]
        if errors:
            out[label] = {"error": errors[0]}
            continue
        entry = {"error": None, "n_folds": len(folds)}
        for ref in REFERENCES:
            values = [r[ref] for r in folds]
            entry[ref] = {"median": float(np.median(values)), "worst": float(max(values))}
        entry["default_better"] = (
            None
            if label == DEFAULT
            else int(
                sum("error" not in d and d["start"] < r["start"] for d, r in zip(default, folds))
            )
        )
        entry["fit_s"] = float(sum(r.get("fit_s", 0.0) for r in folds))
        out[label] = entry
    return out


def summarise(results):
    return {
        part: {unit: summarise_unit(t) for unit, t in tables.items()}
        for part, tables in results.items()
    }


@dataclass(frozen=True)
class Check:
    """One acceptance line: what was measured against what bar, and whether it holds."""

    part: str
    unit: str
    what: str
    value: float | None
    bar: float | None
    passed: bool | None
    detail: str = ""


def _stat(entry, stat, ref="start"):
    return None if entry is None or entry.get("error") else entry[ref][stat]


def best_peer(summary, stat="median"):
    """(label, value) of the peer with the lowest ``stat`` in the start reference (None without peers)."""
    scored = [
        (summary[k]["start"][stat], k)
        for k in peer_labels()
        if k in summary and not summary[k]["error"]
    ]
    if not scored:
        return None, None
    value, label = min(scored)
    return label, value


def _le(value, bar, part, unit, what, detail=""):
    ok = None if value is None or bar is None else bool(value <= bar)
    return Check(part, unit, what, value, bar, ok, detail)


def probe_checks(summaries):
    """Per probe: the default's worst ≤ ridge-16's worst, its median ≤ the best peer's median."""
    out = []
    for probe, s in summaries.items():
        d, r = s.get(DEFAULT), s.get(RIDGE)
        out.append(
            _le(
                _stat(d, "worst"),
                _stat(r, "worst"),
                "caiviac",
                probe,
                "default worst <= ridge-16 worst",
            )
        )
        label, value = best_peer(s)
        out.append(
            _le(
                _stat(d, "median"),
                value,
                "caiviac",
                probe,
                "default median <= best peer median",
                label or "",
            )
        )
    return out


def folds_beating_ridge(summaries, part, bar_fraction=None, bar=None):
    """The folds (over every probe or machine) where the default's start RMSE is below ridge's."""
    won = sum((s.get(RIDGE) or {}).get("default_better") or 0 for s in summaries.values())
    total = sum((s.get(DEFAULT) or {}).get("n_folds") or 0 for s in summaries.values())
    if bar is None and bar_fraction is not None:
        bar = bar_fraction * total
    passed = None if bar is None else bool(won >= bar)
    return Check(
        part,
        "all",
        f"folds where the default beats ridge, of {total} (holds: at least the bar)",
        float(won),
        bar,
        passed,
    )


def fleet_checks(summaries):
    """The default's median over machines ≤ the best peer's; machines where it beats ridge (median)."""
    out = []
    if not summaries:
        return out
    medians = {label: [] for label in labels()}
    for s in summaries.values():
        for label in labels():
            medians[label].append(_stat(s.get(label), "median"))
    over = {k: float(np.median(v)) for k, v in medians.items() if v and None not in v}
    peer = [(v, k) for k, v in over.items() if k in peer_labels()]
    d = over.get(DEFAULT)
    best = min(peer) if peer else (None, "")
    out.append(
        _le(d, best[0], "fleet", "all", "default median over machines <= best peer's", best[1])
    )
    beats = [
        m
        for m, s in summaries.items()
        if _stat(s.get(DEFAULT), "median") is not None
        and _stat(s.get(RIDGE), "median") is not None
        and _stat(s[DEFAULT], "median") < _stat(s[RIDGE], "median")
    ]
    n = len(summaries)
    bar = 7.0 * n / 8.0
    out.append(
        Check(
            "fleet",
            "all",
            f"machines where the default's median beats ridge (of {n})",
            float(len(beats)),
            bar,
            bool(len(beats) >= bar),
            ", ".join(beats),
        )
    )
    return out


def warmup_ratio(table, cold_test):
    """The default's start RMSE on ``cold_test`` over the median of its other tests' (None on error)."""
    records = [r for r in table[DEFAULT] if "error" not in r]
    first = [r["start"] for r in records if r["cycle"] == cold_test]
    later = [r["start"] for r in records if r["cycle"] != cold_test]
    if not first or not later:
        return None
    return float(first[0] / np.median(later))


def warmup_check(fleet_results):
    from _fleet import spec_of

    out = []
    for name, table in fleet_results.items():
        cold = spec_of(name).cold_test
        if cold is not None:
            ratio = warmup_ratio(table, cold)
            out.append(_le(ratio, 2.0, "fleet", name, "cold warm-up RMSE / median of later tests"))
    return out


def restart_checks(summaries, part="caiviac"):
    """Per probe: the restart median within 25 % of the carried median (restart ≤ 1.25 × carried)."""
    out = []
    for unit, s in summaries.items():
        d, r = _stat(s.get(DEFAULT), "median"), _stat(s.get(RESTART), "median")
        ratio = None if d is None or r is None or d == 0 else r / d
        out.append(_le(ratio, 1.25, part, unit, "restart median / carried median"))
    return out


def speed_checks(summaries, part):
    """The default's nested fit time (CPU) against ARDL's (top-5 corr: its own sensors) in the same run."""
    d = sum((s.get(DEFAULT) or {}).get("fit_s") or 0.0 for s in summaries.values())
    a = sum(
        (s.get("ARDL via OLS, top-5 corr") or {}).get("fit_s") or 0.0 for s in summaries.values()
    )
    if not summaries:
        return []
    return [
        _le(
            d,
            a,
            part,
            "all",
            "default nested fit CPU s <= ARDL's nested fit CPU s",
            f"default {d:.1f} s, ARDL {a:.1f} s",
        )
    ]


def acceptance(results, summary):
    """Every acceptance line of issue 38 that this benchmark measures, as :class:`Check` records."""
    checks = []
    cai, fl = summary.get("caiviac", {}), summary.get("fleet", {})
    if cai:
        checks += probe_checks(cai)
        checks.append(folds_beating_ridge(cai, "caiviac", bar=20.0 * len(cai) / 5.0))
        checks += restart_checks(cai)
        checks += speed_checks(cai, "caiviac")
    if fl:
        checks += fleet_checks(fl)
        checks.append(folds_beating_ridge(fl, "fleet"))
        checks += warmup_check(results.get("fleet", {}))
        checks += speed_checks(fl, "fleet")
    return checks


# Printing --------------------------------------------------------------------


def fmt(value):
    """A score as printed and written to the docs: 2 decimals, 3 significant digits past 10,000."""
    if value is None:
        return "n/a"
    if not np.isfinite(value):
        return "diverged"
    return f"{value:.2f}" if abs(value) < 1e4 else f"{value:.2e}"


def number(value, width=7):
    return f"{fmt(value):>{width}s}"


def print_folds(part, unit, table, summary):
    tests = [r["cycle"] for r in table[DEFAULT]]
    for ref in REFERENCES:
        print(f"\n{part} {unit}: {REFERENCES[ref]}")
        head = "".join(f"{t[:8]:>9s}" for t in tests)
        print(f"{'model':38s}{head} | {'median':>8s} {'worst':>8s}")
        for label, folds in table.items():
            entry = summary[label]
            if entry["error"]:
                print(f"{label:38s}  {entry['error'][:100]}")
                continue
            cells = "".join(number(r[ref], 9) for r in folds)
            print(
                f"{label:38s}{cells} | {number(entry[ref]['median'], 8)} {number(entry[ref]['worst'], 8)}"
            )


def print_summary(part, summaries):
    units = list(summaries)
    print(
        f"\nSummary, {part}: median / worst over folds, RMSE µm; 'start' = start reference "
        "(change from each held-out test's first row), 'rec' = recording reference (from its zero)"
    )
    for unit in units:
        s = summaries[unit]
        n = (s.get(DEFAULT) or {}).get("n_folds", "?")
        print(f"\n{unit} ({n} folds)")
        print(
            f"  {'model':38s}{'start med':>10s}{'worst':>8s}{'rec med':>9s}{'worst':>8s}"
            f"{'default better':>16s}{'fit CPU s':>11s}"
        )
        for label, e in s.items():
            if e["error"]:
                print(f"  {label:38s}  {e['error'][:90]}")
                continue
            better = (
                "-" if e["default_better"] is None else f"{e['default_better']} of {e['n_folds']}"
            )
            print(
                f"  {label:38s}{number(e['start']['median'], 10)}{number(e['start']['worst'], 8)}"
                f"{number(e['recording']['median'], 9)}{number(e['recording']['worst'], 8)}"
                f"{better:>16s}{e['fit_s']:11.2f}"
            )


def print_acceptance(checks):
    print("\nAcceptance (issue 38), start reference unless named:")
    for c in checks:
        mark = {True: "yes", False: "NO", None: "n/a"}[c.passed]
        value = "n/a" if c.value is None else f"{c.value:.4g}"
        bar = "n/a" if c.bar is None else f"{c.bar:.4g}"
        detail = f"  [{c.detail}]" if c.detail else ""
        print(f"  {mark:4s} {c.part:8s} {c.unit:18s} {c.what}: {value} (bar {bar}){detail}")


# Docs ------------------------------------------------------------------------

BEGIN = ".. generalisation: generated from benchmarks/results/generalisation.json by bench_generalisation.py --write-docs; do not edit by hand"
END = ".. generalisation: end of generated block"
SHORT = {
    NONE: "no correction",
    RIDGE: "ridge-16 rises",
    "LagFeatures+RidgeCV, greyml's sensors": "LagFeatures + RidgeCV, greyml's sensors",
    "LagFeatures+RidgeCV, top-5 corr": "LagFeatures + RidgeCV, top-5 corr",
    "ARDL via OLS, greyml's sensors": "ARDL, greyml's sensors",
    "ARDL via OLS, top-5 corr": "ARDL, top-5 corr",
    "NARX FROLS deg 1, greyml's sensors": "NARX deg 1, greyml's sensors",
    "NARX FROLS deg 1, top-5 corr": "NARX deg 1, top-5 corr",
    DEFAULT: "**greyml default**",
    RESTART: "greyml default, restart",
}


def _cell(entry, ref="start"):
    if entry is None or entry.get("error"):
        return "error"
    return f"{fmt(entry[ref]['median'])} ({fmt(entry[ref]['worst'])})"


def _table(title, units, summaries, ref):
    lines = [f".. list-table:: {title}", "   :header-rows: 1", "", "   * - model"]
    lines += [f"     - {u.removesuffix('_um')}" for u in units]
    for label in labels():
        lines.append(f"   * - {SHORT[label]}")
        lines += [f"     - {_cell(summaries[u].get(label), ref)}" for u in units]
    return lines


def _check_lines(checks):
    out = []
    for c in checks:
        mark = {True: "yes", False: "no", None: "n/a"}[c["passed"]]
        value = "n/a" if c["value"] is None else f"{c['value']:.4g}"
        bar = "n/a" if c["bar"] is None else f"{c['bar']:.4g}"
        unit = "" if c["unit"] == "all" else f" {c['unit'].removesuffix('_um')}"
        detail = f" ({c['detail']})" if c["detail"] else ""
        out.append(f"   * - {c['part']}{unit}: {c['what']}{detail}")
        out += [f"     - {value}", f"     - {bar}", f"     - {mark}"]
    return out


def docs_block(data, page):
    """The generated rst block of ``page`` ("benchmarks" or "transfer") from the JSON ``data``."""
    summary, checks, meta = data["summary"], data["acceptance"], data["meta"]
    stamp = (
        f"Measured by ``python benchmarks/bench_generalisation.py`` on greyml at "
        f"{meta.get('revision') or 'an unknown revision'}, {meta.get('elapsed_s', 0) / 60:.0f} min "
        "wall time on a shared two-core machine; RMSE µm, median over the held-out tests (worst "
        "in brackets)."
    )
    cai, fl = summary.get("caiviac", {}), summary.get("fleet", {})
    lines = [BEGIN, "", stamp, ""]
    if page == "transfer":
        if cai:
            lines += _table(
                "CAIVIAC, leave one cycle out, start reference (change from each held-out "
                "cycle's first row)",
                list(cai),
                cai,
                "start",
            )
            won = sum((u.get(RIDGE) or {}).get("default_better") or 0 for u in cai.values())
            total = sum((u.get(DEFAULT) or {}).get("n_folds") or 0 for u in cai.values())
            lines += [
                "",
                f"The default's start-reference RMSE is below ridge-16's in {won} of the {total} "
                "(probe, cycle) folds.",
            ]
        else:
            lines += ["(CAIVIAC was not available to this run.)"]
        return [*lines, "", END]
    for title, part, ref in (
        (
            "CAIVIAC, leave one cycle out, start reference (change from each held-out cycle's first row)",
            cai,
            "start",
        ),
        (
            "CAIVIAC, leave one cycle out, recording reference (from the recording's zero)",
            cai,
            "recording",
        ),
        (
            "Simulated fleet, leave one test out, start reference (change from each held-out test's first row)",
            fl,
            "start",
        ),
        (
            "Simulated fleet, leave one test out, recording reference (from the recording's zero)",
            fl,
            "recording",
        ),
    ):
        if part:
            lines += [*_table(title, list(part), part, ref), ""]
    lines += [
        ".. list-table:: Acceptance lines of issue 38 (start reference unless named)",
        "   :header-rows: 1",
        "",
        "   * - line",
        "     - measured",
        "     - bar",
        "     - holds",
    ]
    lines += _check_lines(checks)
    return [*lines, "", END]


def replace_block(text, block):
    """``text`` with its generated block replaced by ``block`` (lines); an error when it has none."""
    return replace_generated(text, block, BEGIN, END)


def write_docs(data):
    for page, path in DOCS.items():
        text = path.read_text(encoding="utf-8")
        path.write_text(replace_block(text, docs_block(data, page)), encoding="utf-8")
        print(f"rewrote the generated block of {path.relative_to(ROOT)}")


# Main ------------------------------------------------------------------------


def run(data_path, probes, machine_names, peer_step, quick):
    """(results, summary, checks, elapsed s) of one run: CAIVIAC (if found) and the fleet."""
    from _fleet import fleet
    from threadpoolctl import threadpool_limits

    results = {}
    start = time.perf_counter()
    with threadpool_limits(limits=1):
        path = find_data(data_path) if probes else None
        if path is not None:
            print(
                f"CAIVIAC/FL_THERMAL from {path}: probes {', '.join(probes)}, leave one cycle out"
            )
            X, y = peers.load(path, probes[0])
            with warnings.catch_warnings():  # warm-up, untimed: first-call costs
                warnings.simplefilter("ignore")
                peers.default_model().fit(X, y)
            results["caiviac"] = run_caiviac(path, probes, peer_step, quick)
        if machine_names:
            machines = fleet(machine_names)
            print(f"simulated fleet: {len(machines)} machines, leave one test out")
            for m in machines:
                print(f"  {m.name}: {m.description}")
            results["fleet"] = run_fleet(machines, quick)
    elapsed = time.perf_counter() - start
    summary = summarise(results)
    return results, summary, acceptance(results, summary), elapsed


def main(argv=None):
    from _fleet import names

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--data", metavar="PATH", help="CAIVIAC cycles.csv or the folder holding it"
    )
    parser.add_argument("--json", metavar="PATH", help="write every number as JSON")
    parser.add_argument(
        "--peer-step",
        type=int,
        default=peers.PEER_STEP,
        help=f"CAIVIAC: ARDL and NARX on every PEER_STEP-th 15 s row (default {peers.PEER_STEP})",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"a subset: probes {', '.join(QUICK_PROBES)}, machines "
        f"{', '.join(QUICK_MACHINES)}, fewer ARDL orders and NARX lags",
    )
    parser.add_argument(
        "--probes", nargs="*", metavar="PROBE", help=f"CAIVIAC probes (default all of {PROBES})"
    )
    parser.add_argument(
        "--machines", nargs="*", metavar="NAME", help=f"fleet machines (default all: {names()})"
    )
    parser.add_argument(
        "--write-docs",
        action="store_true",
        help="rewrite the generated blocks of docs/benchmarks.rst and docs/dynamic_transfer.rst",
    )
    parser.add_argument(
        "--from-json",
        metavar="PATH",
        help="with --write-docs: take the numbers from this earlier run's JSON, run nothing",
    )
    args = parser.parse_args(argv)
    if args.peer_step < 1:
        parser.error("--peer-step must be at least 1")
    if check_docs_flags(parser, args, write_docs):
        return 0
    probes, machines = chosen_units(parser, args, PROBES, QUICK_PROBES, names(), QUICK_MACHINES)
    print(LEGEND)
    results, summary, checks, elapsed = run(args.data, probes, machines, args.peer_step, args.quick)
    for part, tables in results.items():
        for unit, table in tables.items():
            print_folds(part, unit, table, summary[part][unit])
    for part, s in summary.items():
        print_summary(part, s)
    print(f"\nfit times: {CPU}")
    print_acceptance(checks)
    print(f"\nTotal {elapsed:.0f} s wall; repository {peers.revision() or 'unknown'}")
    data = {"results": results, "summary": summary, "acceptance": [asdict(c) for c in checks]}
    if args.json:
        write_json(
            args.json,
            data,
            packages=peers.PACKAGES,
            argv=argv,
            probes=list(probes),
            machines=list(machines),
            peer_step=args.peer_step,
            quick=args.quick,
            elapsed_s=elapsed,
            revision=peers.revision(),
        )
        if args.write_docs:
            write_docs(json.loads(Path(args.json).read_text(encoding="utf-8")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
