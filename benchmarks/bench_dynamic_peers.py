"""Real data, leave one cycle out on CAIVIAC: greyml's default dynamic model against its peers.

Protocol
--------
* Data: the CAIVIAC/FL_THERMAL recording (MIT licence, read where it lies,
  never copied): five 8 h cycles (4 h spindle on, 4 h off), one continuous
  15 s clock, each cycle starting in the state the previous one left. X is the
  spindle speed and the sixteen temperatures, indexed by ``(cycle, time_s)``
  with the raw clock; y is one probe as recorded (from the recording's zero).
* Folds: each of the five cycles is held out once, for ``ch1_um`` and
  ``ch3_um`` (10 folds). Every choice a model makes (penalty, orders, lags,
  sensors) is made on the four training cycles only (nested); the held-out
  cycle's displacement is never seen in a fit. The inputs of the whole
  recording may drive a model's state (a controller has them).
* Scores, RMSE in µm on every 15 s row of the held-out cycle: "start" (the
  headline), displacement and prediction as changes from the cycle's first
  row; "recording", the displacement as recorded against the raw prediction.
* Reported: per-fold tables, median and worst; in how many of the 10 folds
  the default greyml model has the lower start RMSE; the nested fit time per
  fold, summed, over the default model's (after one untimed warm-up fit; one
  BLAS thread).
* ARDL and NARX are free simulations from the held-out cycle's first row,
  their past outputs set to the displacement measured there (the one held-out
  value they get; no other row gets it), then fed their own predictions. They
  run on one row a minute (``--peer-step``), their predictions interpolated
  linearly in time to the 15 s rows for scoring.

A peer that is not installed or raises keeps its row, with the error message.
Warnings raised inside a fit are recorded (counted in the output, listed in
the JSON), not printed. Run with ``--help`` for the options; without the data
the script prints "CAIVIAC data not found at ...; skipping" and exits 0.
"""

from __future__ import annotations

import argparse
import inspect
import sys
import time
import warnings
from collections import namedtuple
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from _common import find_data, package_versions, write_json

TARGETS = ("ch1_um", "ch3_um")
DRIVER = "spindle_rpm"
SENSORS = tuple(f"t{k}_C" for k in range(1, 17))
ALPHAS = np.logspace(-3, 3, 13)
TAUS = (300.0, 900.0, 2700.0, 8100.0)
N_SENSORS = 5
PEER_STEP = 4  # one row a minute for ARDL and NARX
AR_ORDERS, DL_ORDERS = (1, 2, 3, 4), (0, 1, 2, 3, 4)
NARX_LAGS = (1, 2, 4)  # ylag = xlag, chosen inside the training cycles
QUICK_AR, QUICK_DL, QUICK_NARX = (1, 2), (0, 2), (2,)
PACKAGES = ("greyml", "numpy", "scipy", "scikit-learn", "pandas", "statsmodels", "sysidentpy")
REFERENCES = {
    "start": "RMSE µm, change from each held-out cycle's first row",
    "recording": "RMSE µm, from the recording's zero",
}
DEFAULT = "greyml default"
LEGEND = """\
  ridge-16 rises / raw   StandardScaler + RidgeCV(logspace(-3, 3, 13)) on the 16 temperatures: rises
                         from each cycle's first row -> change from it / raw -> y as recorded
  LagFeatures+RidgeCV    LagFeatures(5, 15, 45, 135 min, state="carry") over the whole recording,
                         then StandardScaler + RidgeCV on the training rows
  ARDL via OLS           statsmodels OLS on the ARDL(p, q) design built per cycle (checked equal to
                         ARDL.fit on one cycle), simulated by ARDL.predict(dynamic=True); p 1-4, q 0-4
  NARX FROLS deg d       sysidentpy FROLS(Polynomial(degree=d), LeastSquares()), ylag = xlag 1, 2 or 4;
                         fitted on the training cycles joined end to end (one series); steps_ahead=None
  ARDL, NARX             simulated from the held-out cycle's first row, their past outputs set to the
                         displacement measured there: no other row is given that value
  greyml's sensors       the sensors the default greyml model kept in the fold (its fit timed in)
  top-5 corr             the 5 sensors with the highest |corr| with y on the training rows
  greyml default         default_model().fit(X, y, sample_weight=0 on the held-out cycle), predict(X)
  greyml default, restart  default_model().fit(X[train], y[train]), then predict(X[held]) alone"""


def default_model(drivers=(DRIVER,)):
    """The default greyml model, as a user constructs it: the one place it is built."""
    from greyml import ThermalTransferFunction

    return ThermalTransferFunction(drivers=list(drivers))


def revision():
    """The repository's commit, marked when greyml/ has uncommitted changes; None without git."""
    import subprocess

    def git(*args):
        root = Path(__file__).resolve().parents[1]
        try:
            return subprocess.run(["git", *args], cwd=root, capture_output=True, text=True).stdout
        except OSError:  # no git
            return ""

    head = git("rev-parse", "--short", "HEAD").strip()
    return (
        head + ("+changes in greyml/" if git("status", "--porcelain", "greyml") else "")
    ) or None


# Data ------------------------------------------------------------------------


def load(path, target):
    """(X, y): speed and 16 temperatures, and the probe ``target``, indexed by (cycle, raw time)."""
    import pandas as pd

    from greyml import make_test_index
    from greyml.io import read_tests_csv

    if "test_column" in inspect.signature(read_tests_csv).parameters:
        frame = read_tests_csv(path, test_column="cycle")
    else:
        raw = pd.read_csv(path)
        index = make_test_index(raw["cycle"].astype(str).to_numpy(), raw["time_s"].to_numpy())
        frame = raw.drop(columns=["cycle", "time_s"]).set_index(index)
    return frame[[DRIVER, *SENSORS]].astype(float), frame[target].astype(float)


# Folds -----------------------------------------------------------------------


@dataclass(frozen=True)
class Fold:
    """One held-out cycle, with what the rows share: the default model's fit and the sensors.

    ``drivers`` and ``temperatures`` name X's columns (CAIVIAC's by default),
    ``lag_state`` is the ``state`` of the LagFeatures row, and ``clock`` times
    every fit (wall time by default).
    """

    X: object
    y: object
    groups: np.ndarray
    cycle: str
    peer_step: int
    quick: bool
    default_pred: np.ndarray | None
    default_s: float
    default_error: str | None
    default_warnings: tuple
    sensors: dict
    select_s: dict
    drivers: tuple = (DRIVER,)
    temperatures: tuple = SENSORS
    lag_state: str = "carry"
    clock: object = time.perf_counter

    held = property(lambda self: self.groups == self.cycle)
    train = property(lambda self: self.groups != self.cycle)
    train_cycles = property(lambda self: [c for c in dict.fromkeys(self.groups) if c != self.cycle])


def corr_sensors(X, y, rows, temperatures=SENSORS):
    """The N_SENSORS temperatures with the highest |correlation| with y on ``rows``."""
    yt = y.to_numpy()[rows]
    with np.errstate(invalid="ignore", divide="ignore"):  # a constant column scores 0
        score = [abs(np.corrcoef(X[s].to_numpy()[rows], yt)[0, 1]) for s in temperatures]
    score = np.nan_to_num(score)
    return [temperatures[i] for i in np.argsort(score, kind="stable")[::-1][:N_SENSORS]]


def prepare_fold(X, y, groups, cycle, peer_step, quick, **columns):
    """The fold holding out ``cycle``; ``columns``: Fold's drivers, temperatures, lag_state, clock."""
    held = groups == cycle
    drivers = tuple(columns.get("drivers", (DRIVER,)))
    temperatures = tuple(columns.get("temperatures", SENSORS))
    clock = columns.get("clock", time.perf_counter)
    sensors, select_s, pred, error = {}, {}, None, None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        start = clock()
        try:
            model = default_model(drivers).fit(X, y, sample_weight=(~held).astype(float))
            default_s = clock() - start
            pred = np.asarray(model.predict(X), dtype=float)[held]
            sensors["default"] = list(model.selected_sensors_)
        except Exception as exc:  # the default keeps its row too
            default_s, error = clock() - start, f"{type(exc).__name__}: {exc}"
    caught = tuple((w.category, str(w.message)) for w in caught)
    select_s["default"] = default_s
    start = clock()
    sensors["corr"] = corr_sensors(X, y, ~held, temperatures)
    select_s["corr"] = clock() - start
    return Fold(
        X,
        y,
        groups,
        cycle,
        peer_step,
        quick,
        pred,
        default_s,
        error,
        caught,
        sensors,
        select_s,
        drivers,
        temperatures,
        columns.get("lag_state", "carry"),
        clock,
    )


def chosen_sensors(fold, source):
    if source == "default" and fold.default_error:
        raise RuntimeError(f"no sensors: the default model failed ({fold.default_error})")
    return fold.sensors[source], fold.select_s[source]


# Static and lag-feature rows -------------------------------------------------


def ridge():
    from sklearn.linear_model import RidgeCV
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    return make_pipeline(StandardScaler(), RidgeCV(alphas=ALPHAS))


def no_correction(fold):
    return np.zeros(int(fold.held.sum())), 0.0, ""


def ridge16(fold, rises):
    start = fold.clock()
    T, y = fold.X[list(fold.temperatures)], fold.y
    if rises:  # temperatures and displacement from each cycle's first row
        T = T - T.groupby(level=0, sort=False).transform("first")
        y = y - y.groupby(level=0, sort=False).transform("first")
    model = ridge().fit(T[fold.train], y[fold.train])
    fit_s = fold.clock() - start
    return model.predict(T[fold.held]), fit_s, f"alpha {model[-1].alpha_:.3g}"


def lag_ridge(fold, source):
    from greyml import LagFeatures

    sensors, select_s = chosen_sensors(fold, source)
    start = fold.clock()
    lags = LagFeatures(list(TAUS), state=fold.lag_state)
    F = lags.fit_transform(fold.X[[*sensors, *fold.drivers]])
    model = ridge().fit(F[fold.train], fold.y[fold.train])
    fit_s = select_s + fold.clock() - start
    return model.predict(F[fold.held]), fit_s, f"alpha {model[-1].alpha_:.3g}; {short(sensors)}"


def greyml_default(fold):
    for category, message in fold.default_warnings:  # recorded by run_row
        warnings.warn(message, category, stacklevel=1)
    if fold.default_error:
        raise RuntimeError(fold.default_error)
    return fold.default_pred, fold.default_s, short(fold.sensors["default"])


def greyml_restart(fold):
    start = fold.clock()
    model = default_model(fold.drivers).fit(fold.X[fold.train], fold.y[fold.train])
    fit_s = fold.clock() - start
    return model.predict(fold.X[fold.held]), fit_s, short(model.selected_sensors_)


# Simulated peers (ARDL, NARX) on one row in ``peer_step`` --------------------


# inputs standardised on the training rows, output, times, and each cycle's row numbers
Series = namedtuple("Series", "x y t segments")


def peer_series(fold, sensors):
    X = fold.X
    keep = X.groupby(level=0, sort=False).cumcount().to_numpy() % fold.peer_step == 0
    x = X[[*fold.drivers, *sensors]].to_numpy(float)[keep]
    rows = fold.train[keep]
    scale = x[rows].std(axis=0)
    x = (x - x[rows].mean(axis=0)) / np.where(scale > 0, scale, 1.0)
    groups = fold.groups[keep]
    segments = {c: np.flatnonzero(groups == c) for c in dict.fromkeys(groups)}
    t = X.index.get_level_values(-1).to_numpy(float)[keep]
    return Series(x, fold.y.to_numpy(float)[keep], t, segments)


def with_history(x, segment, m):
    """The segment's inputs after the ``m`` rows before it (the first row repeated at the start)."""
    before = np.clip(np.arange(segment[0] - m, segment[0]), 0, None)
    return np.vstack([x[before], x[segment]])


def start_rmse(y, pred):
    if not np.all(np.isfinite(pred)):
        return np.inf
    return float(np.sqrt(np.mean(((y - y[0]) - (pred - pred[0])) ** 2)))


def ardl_design(y, x, p, q):
    """ARDL(p, q) target and regressors of one segment, in statsmodels ARDL's column order."""
    m, n = max(p, q), len(y)
    cols = [np.ones(n - m)] + [y[m - lag : n - lag] for lag in range(1, p + 1)]
    for j in range(x.shape[1]):
        cols += [x[m - lag : n - lag, j] for lag in range(q + 1)]
    return y[m:], np.column_stack(cols)


def ardl_fit(order, s, segments):
    from statsmodels.regression.linear_model import OLS

    parts = [ardl_design(s.y[seg], s.x[seg], *order) for seg in segments]
    target = np.concatenate([t for t, _ in parts])
    return order, np.asarray(OLS(target, np.vstack([d for _, d in parts])).fit().params)


def ardl_simulate(fitted, s, segment, y0):
    from statsmodels.tsa.ardl import ARDL

    (p, q), params = fitted
    m = max(p, q)
    xx = with_history(s.x, segment, m)
    # endog is y0 throughout: only its first m values (the pre-start lags) are read
    model = ARDL(np.full(len(xx), y0), p, xx, q)
    return np.asarray(model.predict(params, start=m, end=len(xx) - 1, dynamic=True), dtype=float)


def check_ardl_design(s, segment):
    """OLS on ``ardl_design`` must give statsmodels ARDL's own fit on one cycle."""
    from statsmodels.tsa.ardl import ARDL

    own = ardl_fit((2, 2), s, [segment])[1]
    ref = np.asarray(ARDL(s.y[segment], 2, s.x[segment], 2).fit().params)
    if not np.allclose(own, ref, rtol=1e-6, atol=1e-8):
        raise RuntimeError("the per-cycle ARDL design does not reproduce statsmodels ARDL.fit")


def narx_fit(config, s, segments):
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    lag, degree = config
    model = FROLS(
        ylag=lag,
        xlag=[list(range(1, lag + 1))] * s.x.shape[1],
        basis_function=Polynomial(degree=degree),
        estimator=LeastSquares(),
    )
    rows = np.concatenate(segments)
    return model.fit(X=s.x[rows], y=s.y[rows].reshape(-1, 1))


def narx_simulate(model, s, segment, y0):
    m = model.max_lag
    out = model.predict(X=with_history(s.x, segment, m), y=np.full((m, 1), y0), steps_ahead=None)
    return np.asarray(out, dtype=float).reshape(-1)[m:]


def nested(fold, s, candidates, fit, simulate):
    """(choice, model refitted on the training cycles, inner mean RMSE per candidate)."""
    inner = {}
    cycles = fold.train_cycles
    if len(candidates) > 1:
        for cand in candidates:
            errors = []
            for c in cycles:
                seg = s.segments[c]
                try:
                    model = fit(cand, s, [s.segments[k] for k in cycles if k != c])
                    errors.append(start_rmse(s.y[seg], simulate(model, s, seg, s.y[seg[0]])))
                except Exception:  # a candidate that cannot be fitted ranks last
                    errors.append(np.inf)
            inner[cand] = float(np.mean(errors))
    best = min(candidates, key=lambda c: inner.get(c, 0.0))
    return best, fit(best, s, [s.segments[k] for k in cycles]), inner


def simulated_peer(fold, source, candidates, fit, simulate):
    sensors, select_s = chosen_sensors(fold, source)
    start = fold.clock()
    s = peer_series(fold, sensors)
    best, model, inner = nested(fold, s, candidates, fit, simulate)
    fit_s = select_s + fold.clock() - start
    seg = s.segments[fold.cycle]
    pred = simulate(model, s, seg, s.y[seg[0]])
    t_held = fold.X.index.get_level_values(-1).to_numpy(float)[fold.held]
    return np.interp(t_held, s.t[seg], pred), fit_s, (best, inner, sensors)


def ardl_row(fold, source):
    ar, dl = (QUICK_AR, QUICK_DL) if fold.quick else (AR_ORDERS, DL_ORDERS)
    s = peer_series(fold, fold.sensors["corr"])  # untimed check of the design
    check_ardl_design(s, s.segments[fold.train_cycles[0]])
    orders = [(p, q) for p in ar for q in dl]
    pred, fit_s, (best, _, sensors) = simulated_peer(fold, source, orders, ardl_fit, ardl_simulate)
    return pred, fit_s, f"p={best[0]} q={best[1]}; {short(sensors)}"


def narx_row(fold, source, degree):
    lags = QUICK_NARX if fold.quick else NARX_LAGS
    configs = [(lag, degree) for lag in lags]
    pred, fit_s, (best, _, sensors) = simulated_peer(fold, source, configs, narx_fit, narx_simulate)
    return pred, fit_s, f"lag {best[0]}; {short(sensors)}"


def rows():
    """(label, function, kwargs) of every row, in the order printed."""
    out = [
        ("no correction", no_correction, {}),
        ("ridge-16 rises", ridge16, {"rises": True}),
        ("ridge-16 raw", ridge16, {"rises": False}),
    ]
    for source, name in (("default", "greyml's sensors"), ("corr", "top-5 corr")):
        out.append((f"LagFeatures+RidgeCV, {name}", lag_ridge, {"source": source}))
    for source, name in (("default", "greyml's sensors"), ("corr", "top-5 corr")):
        out.append((f"ARDL via OLS, {name}", ardl_row, {"source": source}))
    for degree in (1, 2):
        for source, name in (("default", "greyml's sensors"), ("corr", "top-5 corr")):
            label = f"NARX FROLS deg {degree}, {name}"
            out.append((label, narx_row, {"source": source, "degree": degree}))
    out += [(DEFAULT, greyml_default, {}), ("greyml default, restart", greyml_restart, {})]
    return out


# Running and scoring ---------------------------------------------------------


def score(y, pred):
    pred = np.asarray(pred, dtype=float).reshape(-1)
    if pred.shape != y.shape or not np.all(np.isfinite(pred)):
        return {"start": np.inf, "recording": np.inf}
    return {"start": start_rmse(y, pred), "recording": float(np.sqrt(np.mean((y - pred) ** 2)))}


def run_row(fold, function, kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            pred, fit_s, choice = function(fold, **kwargs)
            y = fold.y.to_numpy(float)[fold.held]
            record = {"cycle": fold.cycle, **score(y, pred), "fit_s": fit_s, "choice": choice}
        except Exception as exc:  # the row keeps its place with the message
            record = {"cycle": fold.cycle, "error": f"{type(exc).__name__}: {exc}"}
    record["warnings"] = sorted({f"{w.category.__name__}: {w.message}" for w in caught})
    return record


def evaluate(path, targets, peer_step, quick):
    from greyml import groups_of

    results = {}
    for target in targets:
        X, y = load(path, target)
        groups = np.asarray(groups_of(X)).astype(str)
        table = {label: [] for label, _, _ in rows()}
        for cycle in dict.fromkeys(groups):
            fold = prepare_fold(X, y, groups, cycle, peer_step, quick)
            for label, function, kwargs in rows():
                table[label].append(run_row(fold, function, kwargs))
        results[target] = table
    return results


def summarise(results):
    """Per row: median and worst per probe and reference, wins of the default, fit time."""
    out = {}
    default_s = sum(r.get("fit_s", 0.0) for t in results.values() for r in t[DEFAULT])
    for label, _, _ in rows():
        folds = [(target, r) for target, t in results.items() for r in t[label]]
        errors = [r["error"] for _, r in folds if "error" in r]
        entry = {"error": errors[0] if errors else None}
        if errors:
            out[label] = entry
            continue
        for target, table in results.items():
            for ref in REFERENCES:
                values = [r[ref] for r in table[label]]
                entry[f"{target}/{ref}"] = {
                    "median": float(np.median(values)),
                    "worst": max(values),
                }
        better = 0
        for table in results.values():
            for mine, default in zip(table[label], table[DEFAULT]):
                better += "error" not in default and default["start"] < mine["start"]
        entry["default_better"] = None if label == DEFAULT else int(better)
        entry["n_folds"] = len(folds)
        entry["fit_s"] = float(sum(r["fit_s"] for _, r in folds))
        entry["fit_ratio"] = entry["fit_s"] / default_s if default_s > 0 else None
        entry["warnings"] = sum(len(r["warnings"]) for _, r in folds)
        out[label] = entry
    return out


# Printing --------------------------------------------------------------------


def short(sensors):
    return " ".join(s.removesuffix("_C") for s in sensors)


def number(value, width=7):
    return f"{'diverged':>{width}s}" if not np.isfinite(value) else f"{value:{width}.2f}"


def print_fold_table(target, ref, table, summary):
    cycles = [r["cycle"] for r in table[DEFAULT]]
    print(f"\n{target}: {REFERENCES[ref]}")
    head = "".join(f"{'cycle ' + c:>9s}" for c in cycles)
    print(f"{'model':40s}{head} | {'median':>8s} {'worst':>8s}")
    print("-" * (40 + 9 * len(cycles) + 20))
    for label, folds in table.items():
        entry = summary[label]
        if entry["error"]:
            print(f"{label:40s}  {entry['error'][:90]}")
            continue
        cells = "".join(number(r[ref], 9) for r in folds)
        stats = entry[f"{target}/{ref}"]
        print(f"{label:40s}{cells} | {number(stats['median'], 8)} {number(stats['worst'], 8)}")


def print_summary(results, summary):
    targets = list(results)
    n = sum(len(t[DEFAULT]) for t in results.values())
    print(f"\nSummary: start reference (change from each held-out cycle's first row), {n} folds")
    print("default better: folds where the default greyml model's RMSE is lower (ties not counted)")
    cols = "".join(f"{t + ' med':>12s}{'worst':>9s}" for t in targets)
    print(f"{'model':40s}{cols}  {'default better':>14s} {'fit s':>8s} {'x default':>10s}")
    print("-" * (40 + 21 * len(targets) + 36))
    for label, entry in summary.items():
        if entry["error"]:
            print(f"{label:40s}  {entry['error'][:90]}")
            continue
        cells = "".join(
            number(entry[f"{t}/start"]["median"], 12) + number(entry[f"{t}/start"]["worst"], 9)
            for t in targets
        )
        better = "-" if entry["default_better"] is None else f"{entry['default_better']} of {n}"
        ratio = "-" if entry["fit_ratio"] is None else f"{entry['fit_ratio']:.1f}"
        print(f"{label:40s}{cells}  {better:>14s} {entry['fit_s']:8.2f} {ratio:>10s}")


def print_choices(results, summary):
    print("\nChoices made inside each fold's training cycles (per held-out cycle):")
    for target, table in results.items():
        print(f"  {target}")
        for label, folds in table.items():
            if summary[label]["error"] or not any(r.get("choice") for r in folds):
                continue
            print(f"    {label}")
            for r in folds:
                print(f"      cycle {r['cycle']}: {r['choice']}")
    noisy = {k: v["warnings"] for k, v in summary.items() if v.get("warnings")}
    if noisy:
        print(
            "  warnings recorded inside fits (listed in the JSON): "
            + ", ".join(f"{k} {v}" for k, v in noisy.items())
        )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", metavar="PATH", help="cycles.csv or the folder holding it")
    parser.add_argument("--json", metavar="PATH", help="also write every number as JSON")
    parser.add_argument(
        "--peer-step",
        type=int,
        default=PEER_STEP,
        help=f"ARDL and NARX on every PEER_STEP-th row of each cycle (default {PEER_STEP}: one "
        "a minute; 1: every 15 s row, about 4 min)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"smoke test: ch1_um only, ARDL p in {QUICK_AR} and q in {QUICK_DL}, NARX lag "
        f"{QUICK_NARX[0]} (a few seconds)",
    )
    args = parser.parse_args(argv)
    if args.peer_step < 1:
        parser.error("--peer-step must be at least 1")
    path = find_data(args.data)
    if path is None:
        return 0
    from threadpoolctl import threadpool_limits

    targets = TARGETS[:1] if args.quick else TARGETS
    print(f"CAIVIAC/FL_THERMAL (real machine tool, MIT licence) from {path}")
    print(
        f"leave one cycle out, probes {', '.join(targets)}; ARDL and NARX on one row in "
        f"{args.peer_step} ({15 * args.peer_step} s), predictions interpolated to the 15 s rows"
        + ("; --quick: fewer orders and lags" if args.quick else "")
    )
    print(LEGEND)
    start = time.perf_counter()
    with threadpool_limits(limits=1):
        X, y = load(path, targets[0])
        with warnings.catch_warnings():  # warm-up, untimed: first-call costs
            warnings.simplefilter("ignore")
            default_model().fit(X, y)
        results = evaluate(path, targets, args.peer_step, args.quick)
    elapsed = time.perf_counter() - start
    summary = summarise(results)
    for target, table in results.items():
        for ref in REFERENCES:
            print_fold_table(target, ref, table, summary)
    print_summary(results, summary)
    print_choices(results, summary)
    versions = package_versions(PACKAGES, missing=None)
    print(
        f"\nTotal {elapsed:.0f} s, one BLAS thread; "
        + ", ".join(f"{k} {v}" for k, v in versions.items() if v)
        + f"; repository {revision() or 'unknown'}"
    )
    if args.json:
        ar, dl, lags = (
            (QUICK_AR, QUICK_DL, QUICK_NARX) if args.quick else (AR_ORDERS, DL_ORDERS, NARX_LAGS)
        )
        write_json(
            args.json,
            {"results": results, "summary": summary},
            packages=PACKAGES,
            argv=argv,
            data=str(path),
            targets=list(targets),
            peer_step=args.peer_step,
            peer_sampling_s=15 * args.peer_step,
            quick=args.quick,
            ardl_p=ar,
            ardl_q=dl,
            narx_lags=lags,
            elapsed_s=elapsed,
            revision=revision(),
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
