"""Real data, leave one cycle out on CAIVIAC: dynamic models and sensor selection against ridge-16.

By default (issue 16) the script compares, with the same folds, ridge on all
sixteen temperatures, the seed-model search described below (on one row a
minute, ``--seed-step``), and ``ThermalTransferFunction`` with at most five
sensors plus the spindle speed (forward and stable selection) and with all
sixteen, for ch1 and ch3, with displacement and temperatures from each
cycle's first row and from the recording's first row. The transfer
functions carry their lags through the whole recording, on the temperatures
as read (never re-zeroed at a cycle's start): each is given every row with
sample weight 0 on the held-out cycle (its displacement is never seen). It also times ``ThermalTransferFunction(max_sensors=5).fit`` on all
five cycles. ``--seed-only`` runs the issue-5 search alone, as follows.

The real recording CAIVIAC/FL_THERMAL (MIT licence; read where it lies by
``greyml.datasets.load_caiviac``, never copied into greyml): five heating and
cooling cycles of one machine tool, 4 h spindle on then 4 h off at 1250,
2500, 3750, 5000 and 3500 rpm, sixteen temperature sensors, five displacement
probes, 15 s sampling. Issue #5 asks how the best pipeline with at most five
selected sensors compares with a ridge regression on all sixteen, cycle by
held-out cycle (goal: a median RMSE at least 30 % lower than the ridge's).

Protocol
--------
* **Target**: ``ch1_um`` by default (``--target``). ch1 and ch2 move
  together and follow the spindle: up while it runs, down while it stands.
  ch3/ch4 carry large excursions about a day apart that look environmental
  (see the data's SOURCE.md), which five spindle cycles cannot teach a model.
* **Reference** (``--reference``, default ``cycle``): displacement from each
  cycle's first reading and temperatures as rises from the same reading, the
  seeds' convention of one heating/cooling test per sequence (greyml's
  simulated tests start at 0 too). ``recording``: displacement from the start
  of the recording and temperatures as rises from the recording's first
  reading. Each cycle starts in the state the previous one left, so the two
  are different targets and their RMSEs cannot be compared with each other.
* **Sampling**: every ``--step``-th row of each cycle; by default all of
  them (``--step 1``, 15 s, 9,631 rows). ``--step 4`` (one row a minute)
  takes about 70 s instead of 115 s; its results are in ``benchmarks/README.md``.
  The dynamic models (AGO, GMC) are fitted and evaluated on the grid given.
* **Baseline**: ``StandardScaler`` + ``RidgeCV(alphas=logspace(-3, 3, 13))`` on
  all sixteen sensors; its alpha is chosen inside each training fold
  (RidgeCV's efficient leave-one-row-out).
* **Best pipeline, chosen honestly**: for each held-out cycle, a
  ``GridSearchCV`` over ``Pipeline([("select", GreyInfluenceSelector),
  ("model", ...)])`` with an inner leave-one-cycle-out on the four training
  cycles (mean inner RMSE), refitted on all four and scored once on the
  held-out cycle. The grid holds every model of the issue with the seeds'
  settings; it was not pruned or tuned by held-out scores: the
  selector with ``n_clusters`` 3, 4, 5 and ``cluster_on`` "influence",
  "series" (range normalisation, ``random_state=0``), times five models on the
  selected sensors: ridge (the baseline's model), ``GMC(solver="pso")`` with b1 in
  [0, 100] (a stable response), ``ANFISFCM(3)`` (Abdulshahed et al.'s (2015) 3 rules),
  ``MLPBaseline()`` (Abdulshahed et al.'s (2016) 10 hidden units) and
  ``AGO() -> AccumulatedTargetRegressor(RidgeCV)`` (the grey recipe for a
  static regressor): 30 configurations. GNNMCI is left out: with its default
  separable search it fits the same GMC response as ``GMC(solver="pso")`` (on
  fixed selections, one row a minute, their leave-one-cycle-out RMSEs agreed
  within 0.01 µm) at three times the cost.
* ``--hindsight`` adds, as a labelled *optimistic bound*, the configuration
  with the lowest median held-out RMSE when all 30 are scored on the held-out
  cycles (choosing by those scores is what the nested search avoids).

Warnings raised during the fits (rank-deficient GM(1,N) systems, models that
stop at their iteration limit) are silenced; a configuration whose fit raises
scores NaN, ranks last, and is counted in the output.

Run ``python benchmarks/bench_caiviac.py --help`` for the options. The script
prints "CAIVIAC data not found at ...; skipping" and exits 0 when the
recording is absent. It always exits 0: the 30 % line is printed as PASS or
MISS, not enforced.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
import warnings
from collections import Counter

import numpy as np
from _common import caiviac_files, write_json
from _common import package_versions as _package_versions

TARGET = "ch1_um"
REFERENCE = "cycle"
STEP = 1  # every row of each cycle (15 s); 4: one a minute
ALPHAS = np.logspace(-3, 3, 13)
N_CLUSTERS = (3, 4, 5)
CLUSTER_ON = ("influence", "series")
GOAL = 0.30  # issue #5: median RMSE at least 30 % below ridge on all sensors
RANDOM_STATE = 0
N_JOBS = 2
SPEEDS = {"cycle1": 1250, "cycle2": 2500, "cycle3": 3750, "cycle4": 5000, "cycle5": 3500}

PACKAGES = ("greyml", "numpy", "scipy", "scikit-learn", "pandas", "scikit-fuzzy")


# ------------------------------------------------------------------------------
# Data
# ------------------------------------------------------------------------------


def load(path=None, target=TARGET, reference=REFERENCE, step=STEP):
    """(X, y, data): sixteen temperature rises and one probe, every ``step``-th row."""
    from greyml import RelativeToStart
    from greyml.datasets import load_caiviac

    file = find_file(path)
    if file is None:
        raise FileNotFoundError(where_looked(path))
    data = load_caiviac(file, reference=reference, target=target)
    frame = data.frame
    if step > 1:
        frame = frame[frame.groupby(level="test", sort=False).cumcount().to_numpy() % step == 0]
    X = frame[data.sensors]
    if reference == "cycle":
        X = RelativeToStart().fit_transform(X)
    else:  # rises from the first reading of the recording (its displacement datum)
        X = X - X.iloc[0]
    return X, frame[target], data


def with_driver(X, rpm):
    """``X`` with the spindle speed as its first column (the transfer functions' driver)."""
    Xd = X.copy()
    Xd.insert(0, DRIVER, np.asarray(rpm))
    return Xd


def load_or_say(args, target, reference):
    """``load`` at every row, or None after saying where the data was looked for."""
    try:
        return load(args.data, target, reference, 1)
    except FileNotFoundError:
        print(f"CAIVIAC data not found at {where_looked(args.data)}; skipping")
        return None


def find_file(path):
    """The first of the files ``caiviac_files`` names that exists, or None."""
    return next((p for p in caiviac_files(path) if p.is_file()), None)


def where_looked(path):
    if path is not None:
        return str(path)
    return ", ".join(str(p) for p in caiviac_files(path))


# ------------------------------------------------------------------------------
# Models
# ------------------------------------------------------------------------------


def ridge_all():
    """The baseline: standardised sensors, alpha chosen in the training fold."""
    from sklearn.linear_model import RidgeCV
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    return make_pipeline(StandardScaler(), RidgeCV(alphas=ALPHAS))


def candidate_models():
    """(label, estimator) of the models tried on the selected sensors."""
    from sklearn.linear_model import RidgeCV
    from sklearn.pipeline import make_pipeline

    from greyml import AGO, ANFISFCM, GMC, AccumulatedTargetRegressor, MLPBaseline

    return [
        ("ridge", ridge_all()),
        ("GMC-PSO", GMC(solver="pso", bounds=(0.0, 100.0), random_state=RANDOM_STATE)),
        ("ANFIS-FCM", ANFISFCM(3, random_state=RANDOM_STATE)),
        ("MLP", MLPBaseline(random_state=RANDOM_STATE)),
        ("AGO-ridge", make_pipeline(AGO(), AccumulatedTargetRegressor(RidgeCV(alphas=ALPHAS)))),
    ]


def search_space():
    """(pipeline, param_grid, {id(model): label})."""
    from sklearn.pipeline import Pipeline

    from greyml import GreyInfluenceSelector

    models = candidate_models()
    pipeline = Pipeline(
        [("select", GreyInfluenceSelector(random_state=RANDOM_STATE)), ("model", models[0][1])]
    )
    grid = {
        "select__n_clusters": list(N_CLUSTERS),
        "select__cluster_on": list(CLUSTER_ON),
        "model": [model for _, model in models],
    }
    return pipeline, grid, {id(model): label for label, model in models}


def config_label(model_label, n_clusters, cluster_on):
    return f"{model_label}, {n_clusters} {cluster_on}"


# ------------------------------------------------------------------------------
# Leave-one-cycle-out
# ------------------------------------------------------------------------------


def nested(X, y, n_jobs=N_JOBS):
    """One record per held-out cycle: the nested search's choice and the baseline."""
    from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut

    from greyml import groups_of
    from greyml.metrics import get_scorer, residual_band, rmse

    groups = np.asarray(groups_of(X))
    records = []
    for cycle in dict.fromkeys(groups):
        train, held = groups != cycle, groups == cycle
        pipeline, grid, labels = search_space()
        search = GridSearchCV(
            pipeline,
            grid,
            scoring=get_scorer("neg_rmse"),
            cv=LeaveOneGroupOut(),
            n_jobs=n_jobs,
            error_score=np.nan,
        )
        start = time.perf_counter()
        search.fit(X[train], y[train], groups=groups[train])
        search_s = time.perf_counter() - start
        y_true = y[held].to_numpy()
        best = search.best_estimator_
        y_best = np.asarray(best.predict(X[held]), dtype=float)
        baseline = ridge_all().fit(X[train], y[train])
        y_ridge = np.asarray(baseline.predict(X[held]), dtype=float)

        results = search.cv_results_
        ranking = []
        for i in np.argsort(results["rank_test_score"], kind="stable"):
            ranking.append(
                {
                    "model": labels[id(results["param_model"][i])],
                    "n_clusters": int(results["param_select__n_clusters"][i]),
                    "cluster_on": str(results["param_select__cluster_on"][i]),
                    "inner_rmse": float(-results["mean_test_score"][i]),
                }
            )
        params = search.best_params_
        records.append(
            {
                "cycle": str(cycle),
                "rpm": SPEEDS.get(str(cycle)),
                "model": labels[id(params["model"])],
                "n_clusters": int(params["select__n_clusters"]),
                "cluster_on": str(params["select__cluster_on"]),
                "selected": list(best["select"].selected_),
                "inner_rmse": float(-search.best_score_),
                "rmse": float(rmse(y_true, y_best)),
                "band": float(residual_band(y_true, y_best)),
                "ridge_rmse": float(rmse(y_true, y_ridge)),
                "ridge_band": float(residual_band(y_true, y_ridge)),
                "ridge_alpha": float(baseline[-1].alpha_),
                "failed_configs": int(np.isnan(results["mean_test_score"]).sum()),
                "search_s": search_s,
                "inner_ranking": ranking,
            }
        )
    return records


def hindsight(X, y):
    """Every configuration scored on every held-out cycle (an optimistic bound)."""
    from sklearn.base import clone
    from sklearn.model_selection import ParameterGrid

    from greyml import groups_of
    from greyml.metrics import rmse

    groups = np.asarray(groups_of(X))
    pipeline, grid, labels = search_space()
    rows = []
    for params in ParameterGrid(grid):
        per_cycle = {}
        for cycle in dict.fromkeys(groups):
            train, held = groups != cycle, groups == cycle
            model = clone(pipeline).set_params(**params)
            try:
                model.fit(X[train], y[train])
                pred = np.asarray(model.predict(X[held]), dtype=float)
                per_cycle[str(cycle)] = float(rmse(y[held].to_numpy(), pred))
            except Exception:  # a failing configuration keeps its row
                per_cycle[str(cycle)] = float("nan")
        rows.append(
            {
                "model": labels[id(params["model"])],
                "n_clusters": int(params["select__n_clusters"]),
                "cluster_on": str(params["select__cluster_on"]),
                "rmse": per_cycle,
                "median": float(np.median(list(per_cycle.values()))),
            }
        )
    rows.sort(key=lambda r: (np.isnan(r["median"]), r["median"]))
    return rows


def summary(records):
    best = float(np.median([r["rmse"] for r in records]))
    ridge = float(np.median([r["ridge_rmse"] for r in records]))
    reduction = 1.0 - best / ridge
    configs = Counter(config_label(r["model"], r["n_clusters"], r["cluster_on"]) for r in records)
    return {
        "median_rmse": best,
        "median_ridge_rmse": ridge,
        "reduction": reduction,
        "goal": GOAL,
        "passed": bool(reduction >= GOAL),
        "chosen_configs": dict(configs.most_common()),
        "chosen_models": dict(Counter(r["model"] for r in records).most_common()),
        "chosen_n_clusters": dict(Counter(r["n_clusters"] for r in records).most_common()),
        "chosen_cluster_on": dict(Counter(r["cluster_on"] for r in records).most_common()),
    }


# ------------------------------------------------------------------------------
# Printing
# ------------------------------------------------------------------------------


def short(sensors):
    return " ".join(s.removesuffix("_C") for s in sensors)


def print_table(records, summ, n_rows, n_configs):
    print(
        f"\n{'held out':8s} {'rpm':>5s}  {'chosen by the inner search':26s} {'inner':>6s}  "
        f"{'selected sensors':22s} {'RMSE':>6s} {'±res':>6s} | {'ridge-16':>8s} {'±res':>6s} "
        f"{'alpha':>6s}"
    )
    print("-" * 112)
    for r in records:
        chosen = config_label(r["model"], r["n_clusters"], r["cluster_on"])
        print(
            f"{r['cycle']:8s} {r['rpm'] or 0:5d}  {chosen:26s} {r['inner_rmse']:6.2f}  "
            f"{short(r['selected']):22s} {r['rmse']:6.2f} {r['band']:6.1f} | "
            f"{r['ridge_rmse']:8.2f} {r['ridge_band']:6.1f} {r['ridge_alpha']:6.3g}"
        )
    print("-" * 112)
    print(
        f"{'median':8s} {'':5s}  {'':26s} {'':6s}  {'':22s} {summ['median_rmse']:6.2f} "
        f"{'':6s} | {summ['median_ridge_rmse']:8.2f}"
    )
    verdict = "PASS" if summ["passed"] else "MISS"
    print(
        f"\nreduction 1 - median(best) / median(ridge-16) = {100 * summ['reduction']:.1f} % "
        f"(goal >= {100 * GOAL:.0f} %): {verdict}"
    )
    print(
        "chosen per fold: "
        + "; ".join(f"{k} x{v}" for k, v in summ["chosen_configs"].items())
        + "\n  models: "
        + ", ".join(f"{k} x{v}" for k, v in summ["chosen_models"].items())
        + "; n_clusters: "
        + ", ".join(f"{k} x{v}" for k, v in summ["chosen_n_clusters"].items())
        + "; cluster_on: "
        + ", ".join(f"{k} x{v}" for k, v in summ["chosen_cluster_on"].items())
    )
    failed = sum(r["failed_configs"] for r in records)
    print(
        f"inner searches: {n_configs} configurations x 4 inner folds per held-out cycle, "
        f"{n_rows} rows in all; configurations whose fit raised: {failed}"
    )
    print("runner-up configurations of each inner search (mean inner RMSE):")
    for r in records:
        others = r["inner_ranking"][1:4]
        print(
            f"  {r['cycle']}: "
            + "; ".join(
                f"{config_label(o['model'], o['n_clusters'], o['cluster_on'])} "
                f"{o['inner_rmse']:.2f}"
                for o in others
            )
        )


def print_hindsight(rows, summ):
    print(
        "\nOptimistic bound (NOT a validation result): each configuration scored on every "
        "held-out cycle,\nthe lowest medians first. Choosing one of these by its held-out "
        "scores is what the nested search avoids."
    )
    cycles = list(rows[0]["rmse"])
    print(f"  {'configuration':26s} " + " ".join(f"{c:>7s}" for c in cycles) + f" {'median':>7s}")
    for r in rows[:5]:
        label = config_label(r["model"], r["n_clusters"], r["cluster_on"])
        print(
            f"  {label:26s} "
            + " ".join(f"{r['rmse'][c]:7.2f}" for c in cycles)
            + f" {r['median']:7.2f}"
        )
    best = rows[0]["median"]
    print(
        f"  best in hindsight: median {best:.2f} µm, "
        f"{100 * (1 - best / summ['median_ridge_rmse']):.1f} % below ridge-16"
    )


# ------------------------------------------------------------------------------
# Dynamic models: ThermalTransferFunction against ridge-16 and the seed search
# ------------------------------------------------------------------------------

DRIVER = "spindle_rpm"
MAX_SENSORS = 5
DYN_TARGETS = ("ch1_um", "ch3_um")
DYN_REFERENCES = ("cycle", "recording")
SEED_STEP = 4  # the seed search runs on one row a minute (see --seed-step)
# issue #16: median RMSE below ridge-16's by at least this share (cycle reference)
DYN_GOALS = {"ch1_um": 0.35, "ch3_um": 0.25}


def transfer_models(reference):
    """(label, estimator, carry?) of the ThermalTransferFunction variants compared."""
    from greyml import ThermalTransferFunction

    relative = reference == "cycle"
    out = [
        (
            f"TTF<={MAX_SENSORS}",
            ThermalTransferFunction(
                drivers=[DRIVER],
                max_sensors=MAX_SENSORS,
                state="carry",
                reference="start" if relative else "recording",
            ),
            True,
        ),
        (
            f"TTF<={MAX_SENSORS} stable",
            ThermalTransferFunction(
                drivers=[DRIVER],
                max_sensors=MAX_SENSORS,
                state="carry",
                reference="start" if relative else "recording",
                selection="stable",
            ),
            True,
        ),
        (
            "TTF-16",
            ThermalTransferFunction(
                drivers=[DRIVER],
                state="carry",
                reference="start" if relative else "recording",
            ),
            True,
        ),
    ]
    if reference == "cycle":
        # fitted to the displacement from the recording's start (one intercept for
        # every cycle), scored on the held-out cycle's change since its first row
        out.append(
            (
                f"TTF<={MAX_SENSORS} rec-fit",
                ThermalTransferFunction(
                    drivers=[DRIVER],
                    max_sensors=MAX_SENSORS,
                    state="carry",
                    reference="recording",
                ),
                "recording",
            )
        )
        out.append(
            (
                f"TTF<={MAX_SENSORS} restart",
                ThermalTransferFunction(drivers=[DRIVER], max_sensors=MAX_SENSORS),
                False,
            )
        )
    return out


def dynamic_loco(X, y, rpm, reference, recording=None, raw=None):
    """Per held-out cycle: ridge-16 and every ThermalTransferFunction variant.

    Carried lags: each model is given the whole recording with sample weight
    0 on the held-out cycle's rows (its temperatures and speed drive the lags
    as a controller's would; its displacement is never seen) and predicts the
    whole recording, scored on the held-out rows. Restarted lags: the model
    sees the four training cycles only and predicts the held-out cycle alone.
    Variants marked ``"recording"`` (cycle reference only; ``recording`` is
    the (X, y) of the recording reference) are fitted to the displacement
    from the recording's start and scored on the held-out cycle's change
    since its first row: their prediction minus its value at that row. So is
    "ridge-16 rec-fit", ridge-16 trained the same way.
    """
    from sklearn.base import clone

    from greyml import groups_of
    from greyml.metrics import rmse

    # the transfer functions carry their lags through the recording: they get the
    # temperatures as read (raw), never re-zeroed at each cycle's start
    Xd = with_driver(X if raw is None else raw, rpm)
    groups = np.asarray(groups_of(X))
    models = transfer_models(reference)
    rows = []
    for cycle in dict.fromkeys(groups):
        train, held = groups != cycle, groups == cycle
        y_true = y[held].to_numpy()
        ridge = ridge_all().fit(X[train], y[train])
        row = {
            "cycle": str(cycle),
            "rpm": SPEEDS.get(str(cycle)),
            "rmse": {"ridge-16": float(rmse(y_true, ridge.predict(X[held])))},
            "selected": {},
            "alpha": {},
        }
        if recording is not None:
            Xr, yr = recording
            pred = ridge_all().fit(Xr[train], yr[train]).predict(Xr[held])
            row["rmse"]["ridge-16 rec-fit"] = float(rmse(y_true, pred - pred[0]))
        for label, template, carry in models:
            model = clone(template)
            if carry == "recording":
                if recording is None:
                    continue
                Xr, yr = recording
                Xrd = with_driver(Xr, rpm)
                model.fit(Xrd, yr, sample_weight=train.astype(float))
                pred = model.predict(Xrd)[held]
                pred = pred - pred[0]
            elif carry:
                model.fit(Xd, y, sample_weight=train.astype(float))
                pred = model.predict(Xd)[held]
            else:
                model.fit(Xd[train], y[train])
                pred = model.predict(Xd[held])
            row["rmse"][label] = float(rmse(y_true, pred))
            row["selected"][label] = list(model.selected_sensors_)
            row["alpha"][label] = model.alpha_
        rows.append(row)
    return rows


def fit_timing(X, rpm, y, repeats=3):
    """Seconds to fit ThermalTransferFunction(max_sensors=5) on all five cycles (best of 3)."""
    from greyml import ThermalTransferFunction

    Xd = with_driver(X, rpm)
    out = {}
    for state in ("restart", "carry"):
        best = np.inf
        for _ in range(repeats):
            start = time.perf_counter()
            ThermalTransferFunction(drivers=[DRIVER], max_sensors=MAX_SENSORS, state=state).fit(
                Xd, y
            )
            best = min(best, time.perf_counter() - start)
        out[state] = best
    return out, Xd.shape


def dyn_summary(rows, labels):
    out = {}
    for label in labels:
        values = np.array([r["rmse"][label] for r in rows])
        out[label] = {"median": float(np.median(values)), "worst": float(values.max())}
    ridge = out["ridge-16"]
    for label in labels:
        out[label]["median_ratio"] = out[label]["median"] / ridge["median"]
        out[label]["worst_ratio"] = out[label]["worst"] / ridge["worst"]
    return out


def print_dynamic(target, reference, rows, summ, labels, seed_note):
    ref = (
        "each cycle from its first row"
        if reference == "cycle"
        else "the recording from its first row"
    )
    print(f"\n== {target}, reference: {ref} ==")
    print(f"{'held out':8s} {'rpm':>5s} " + " ".join(f"{lab:>16s}" for lab in labels))
    for r in rows:
        print(
            f"{r['cycle']:8s} {r['rpm'] or 0:5d} "
            + " ".join(
                f"{r['rmse'][lab]:16.2f}"
                if np.isfinite(r["rmse"].get(lab, np.nan))
                else f"{'-':>16s}"
                for lab in labels
            )
        )
    for key in ("median", "worst"):
        print(f"{key:8s} {'':5s} " + " ".join(f"{summ[lab][key]:16.2f}" for lab in labels))
    print(
        f"{'/ridge':8s} {'':5s} "
        + " ".join(
            f"{summ[lab]['median_ratio']:7.2f} {summ[lab]['worst_ratio']:8.2f}" for lab in labels
        )
        + "   (median ratio, worst ratio)"
    )
    label = f"TTF<={MAX_SENSORS}"
    for r in rows:
        print(
            f"  {r['cycle']}: {label} chose {short(r['selected'][label])}; stable chose "
            f"{short(r['selected'][label + ' stable'])}"
        )
    if seed_note:
        print("  " + seed_note)
    for label in (
        f"TTF<={MAX_SENSORS}",
        f"TTF<={MAX_SENSORS} stable",
        f"TTF<={MAX_SENSORS} rec-fit",
    ):
        if reference != "cycle" or target not in DYN_GOALS:
            break
        goal = DYN_GOALS[target]
        red = 1.0 - summ[label]["median_ratio"]
        worst_ok = summ[label]["worst"] <= summ["ridge-16"]["worst"]
        print(
            f"  ACCEPTANCE {target}: {label} median {summ[label]['median']:.2f} um, "
            f"{100 * red:.1f} % below ridge-16 {summ['ridge-16']['median']:.2f} "
            f"(goal >= {100 * goal:.0f} %): {'PASS' if red >= goal else 'MISS'}; worst cycle "
            f"{summ[label]['worst']:.2f} vs ridge-16's worst {summ['ridge-16']['worst']:.2f}: "
            f"{'PASS' if worst_ok else 'MISS'}"
        )
        if "ridge-16 rec-fit" in summ:
            other = summ["ridge-16 rec-fit"]
            print(
                f"    beside ridge-16 fitted the same way (rec-fit: median {other['median']:.2f}, "
                f"worst {other['worst']:.2f} um): "
                f"{100 * (1.0 - summ[label]['median'] / other['median']):.1f} % below"
            )


SENSITIVITY_BANKS = {"5/15/45/135 min": None, "10/45/180 min": (600.0, 2700.0, 10800.0)}
SENSITIVITY_BUDGETS = (4, 5, 6)


def run_sensitivity(args):
    """How far the issue-16 lines depend on reasonable choices of the design.

    Every combination of sensor budget (4, 5, 6), time-constant bank (the
    default and a coarser one) and selection (forward, stable) is scored with
    the same folds as ``dynamic_loco``; per target and reference it prints the
    median reduction against ridge-16 and whether the worst cycle stays under
    ridge-16's worst. None of these variants is chosen by its held-out score:
    the table says how much the verdict of one variant can be trusted.
    """
    from sklearn.base import clone
    from threadpoolctl import threadpool_limits

    from greyml import ThermalTransferFunction, groups_of
    from greyml.metrics import rmse

    out = {}
    for reference in args.reference:
        for target in args.target:
            loaded = load_or_say(args, target, reference)
            if loaded is None:
                return None
            X, y, data = loaded
            # the transfer functions get the temperatures as read (raw)
            Xd = with_driver(data.frame[data.sensors], data.frame[DRIVER])
            fits = {"": (Xd, y, reference == "cycle", False)}
            if reference == "cycle":
                # fitted from the recording's start, scored on each cycle's change
                Xr, yr, _ = load(args.data, target, "recording", 1)
                Xrd = with_driver(Xr, data.frame[DRIVER])
                fits["rec-fit"] = (Xrd, yr, False, True)
            groups = np.asarray(groups_of(X))
            cycles = list(dict.fromkeys(groups))
            ridge = []
            for cycle in cycles:
                train, held = groups != cycle, groups == cycle
                fitted = ridge_all().fit(X[train], y[train])
                ridge.append(float(rmse(y[held].to_numpy(), fitted.predict(X[held]))))
            ridge_median, ridge_worst = float(np.median(ridge)), max(ridge)
            goal = DYN_GOALS.get(target, 0.0)
            print(
                f"\n== sensitivity, {target}, {reference} reference: ridge-16 median "
                f"{ridge_median:.2f}, worst {ridge_worst:.2f} um; goal {100 * goal:.0f} % =="
            )
            rows = []
            variants = [
                (fit, budget, bank_label, bank, selection)
                for fit in fits
                for budget in SENSITIVITY_BUDGETS
                for bank_label, bank in SENSITIVITY_BANKS.items()
                for selection in ("forward", "stable")
            ]
            for fit, budget, bank_label, bank, selection in variants:
                Xf, yf, relative, rezero = fits[fit]
                template = ThermalTransferFunction(
                    drivers=[DRIVER],
                    max_sensors=budget,
                    time_constants=bank,
                    state="carry",
                    reference="start" if relative else "recording",
                    selection=selection,
                )
                per = []
                with threadpool_limits(limits=1):
                    for cycle in cycles:
                        held = groups == cycle
                        model = clone(template).fit(Xf, yf, sample_weight=(~held).astype(float))
                        pred = model.predict(Xf)[held]
                        if rezero:
                            pred = pred - pred[0]
                        per.append(float(rmse(y[held].to_numpy(), pred)))
                median, worst = float(np.median(per)), max(per)
                reduction = 1.0 - median / ridge_median
                ok = reduction >= goal and worst <= ridge_worst
                rows.append(
                    {
                        "fit": fit or reference,
                        "max_sensors": budget,
                        "bank": bank_label,
                        "selection": selection,
                        "rmse": per,
                        "median": median,
                        "worst": worst,
                        "reduction": reduction,
                        "both_lines": bool(ok),
                    }
                )
                print(
                    f"  {fit or '':7s} <= {budget} sensors, {bank_label:15s} {selection:8s} "
                    + " ".join(f"{v:6.2f}" for v in per)
                    + f" | median {median:5.2f} ({100 * reduction:+4.0f} %), worst "
                    f"{worst:5.2f}: {'both lines hold' if ok else 'a line misses'}"
                )
            for fit in fits:
                mine = [r for r in rows if r["fit"] == (fit or reference)]
                print(
                    f"  {fit or 'fitted in this reference'}: both lines hold in "
                    f"{sum(r['both_lines'] for r in mine)} of {len(mine)} variants"
                )
            held_lines = sum(r["both_lines"] for r in rows)
            out[f"{target}/{reference}"] = {
                "ridge": ridge,
                "variants": rows,
                "both_lines_hold": held_lines,
            }
    if args.json:
        write_json(args.json, {"sensitivity": out}, packages=PACKAGES)
    return out


def run_dynamic(args):
    """The issue-16 comparison: every target and reference, same folds."""
    from threadpoolctl import threadpool_limits

    from greyml.exceptions import GreyConditioningWarning

    results = {}
    start_all = time.perf_counter()
    timing = None
    for reference in args.reference:
        for target in args.target:
            loaded = load_or_say(args, target, reference)
            if loaded is None:
                return None
            X, y, data = loaded
            rpm = data.frame[DRIVER]
            recording = None
            labels = ["ridge-16"]
            if reference == "cycle":
                Xr, yr, _ = load(args.data, target, "recording", 1)
                recording = (Xr, yr)
                labels.append("ridge-16 rec-fit")
            start = time.perf_counter()
            with threadpool_limits(limits=1):
                rows = dynamic_loco(X, y, rpm, reference, recording, data.frame[data.sensors])
            dyn_s = time.perf_counter() - start
            labels += [lab for lab, _, _ in transfer_models(reference)]
            seed_note = ""
            seed_records = None
            if not args.no_seed_search:
                Xs, ys, _ = load(args.data, target, reference, args.seed_step)
                start = time.perf_counter()
                with threadpool_limits(limits=1), warnings.catch_warnings():
                    warnings.simplefilter("ignore", GreyConditioningWarning)
                    seed_records = nested(Xs, ys, args.jobs)
                seed_s = time.perf_counter() - start
                for row, rec in zip(rows, seed_records):
                    row["rmse"]["seed search"] = rec["rmse"]
                    row["seed_choice"] = config_label(
                        rec["model"], rec["n_clusters"], rec["cluster_on"]
                    )
                labels.insert(1, "seed search")
                seed_note = (
                    f"seed search: nested GridSearchCV over the 30 configurations on one row in "
                    f"{args.seed_step} ({15 * args.seed_step} s), scored on those rows, {seed_s:.0f} s; "
                    "chose " + "; ".join(f"{r['cycle']} {r['seed_choice']}" for r in rows)
                )
            summ = dyn_summary(rows, labels)
            print_dynamic(target, reference, rows, summ, labels, seed_note)
            print(f"  ThermalTransferFunction fits and ridge-16: {dyn_s:.1f} s")
            results[f"{target}/{reference}"] = {"rows": rows, "summary": summ}
            if timing is None and reference == "cycle":
                with threadpool_limits(limits=1):
                    timing, shape = fit_timing(X, rpm, y)
                print(
                    f"\nTIMING ThermalTransferFunction(drivers=[{DRIVER!r}], max_sensors=5).fit on "
                    f"all five cycles ({shape[0]} rows x {shape[1]} columns), best of 3, one BLAS "
                    f"thread: state='restart' {timing['restart']:.2f} s, state='carry' "
                    f"{timing['carry']:.2f} s (goal < 5 s)"
                )
    elapsed = time.perf_counter() - start_all
    print(
        f"\nTotal {elapsed:.1f} s; python {platform.python_version()}, "
        + ", ".join(f"{k} {v}" for k, v in versions().items() if v)
    )
    if args.json:
        write_json(
            args.json,
            {"results": results, "fit_timing_s": timing},
            packages=PACKAGES,
            elapsed_s=elapsed,
        )
    return results


def versions():
    return _package_versions(PACKAGES, missing=None)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--target",
        choices=[f"ch{k}_um" for k in range(1, 6)],
        action="append",
        help="probe channel, may be repeated (default: ch1_um and ch3_um; "
        f"{TARGET} with --seed-only)",
    )
    parser.add_argument(
        "--reference",
        choices=("cycle", "recording"),
        action="append",
        help="displacement and temperature rises from each cycle's first reading "
        "or from the recording's first reading; may be repeated (default: both; "
        f"{REFERENCE} with --seed-only)",
    )
    parser.add_argument(
        "--step",
        type=int,
        default=STEP,
        help=f"keep every STEP-th row of each cycle (default {STEP}: all, 15 s; 4: 60 s)",
    )
    parser.add_argument("--data", metavar="PATH", help="cycles.csv or the folder holding it")
    parser.add_argument(
        "--jobs", type=int, default=N_JOBS, help=f"GridSearchCV n_jobs (default {N_JOBS})"
    )
    parser.add_argument(
        "--hindsight",
        action="store_true",
        help="also score every configuration on the held-out cycles (optimistic bound)",
    )
    parser.add_argument("--json", metavar="PATH", help="also write every number as JSON")
    parser.add_argument(
        "--seed-only",
        action="store_true",
        help="only the seed-model search of issue #5 (one --target, one --reference, "
        "--step), as before issue #16",
    )
    parser.add_argument(
        "--no-seed-search",
        action="store_true",
        help="dynamic comparison without the seed-model search (about 10 s instead of ~5 min)",
    )
    parser.add_argument(
        "--seed-step",
        type=int,
        default=SEED_STEP,
        help=f"rows of the seed search in the dynamic comparison (default {SEED_STEP}: "
        "one a minute)",
    )
    parser.add_argument(
        "--sensitivity",
        action="store_true",
        help="ThermalTransferFunction with 4/5/6 sensors x two time-constant banks x "
        "forward/stable selection: how much the issue-16 lines depend on these choices "
        "(about 2 min)",
    )
    args = parser.parse_args(argv)
    if args.step < 1 or args.seed_step < 1:
        parser.error("--step and --seed-step must be at least 1")
    if args.sensitivity:
        args.target = list(args.target or DYN_TARGETS)
        args.reference = list(args.reference or DYN_REFERENCES)
        run_sensitivity(args)
        return 0
    if not args.seed_only:
        args.target = list(args.target or DYN_TARGETS)
        args.reference = list(args.reference or DYN_REFERENCES)
        run_dynamic(args)
        return 0
    args.target = (args.target or [TARGET])[0]
    args.reference = (args.reference or [REFERENCE])[0]

    try:
        X, y, _ = load(args.data, args.target, args.reference, args.step)
    except FileNotFoundError:
        print(f"CAIVIAC data not found at {where_looked(args.data)}; skipping")
        return 0

    from threadpoolctl import threadpool_limits

    _, grid, _ = search_space()
    n_configs = int(np.prod([len(v) for v in grid.values()]))
    reference = (
        "each cycle's first reading"
        if args.reference == "cycle"
        else "the recording's first reading"
    )
    print(
        "CAIVIAC/FL_THERMAL (real machine tool, MIT licence): leave-one-cycle-out, "
        f"target {args.target},\n  displacement and 16 temperature rises from {reference}, "
        f"one row in {args.step} ({15 * args.step} s)"
    )
    print(
        f"  best pipeline: nested GridSearchCV, {n_configs} configurations = GreyInfluenceSelector"
        f"(n_clusters {'/'.join(map(str, N_CLUSTERS))}, cluster_on "
        f"{'/'.join(CLUSTER_ON)}) x {{{', '.join(label for label, _ in candidate_models())}}}"
    )
    print("  baseline ridge-16: StandardScaler + RidgeCV(alphas=logspace(-3, 3, 13)), all sensors")

    start = time.perf_counter()
    with threadpool_limits(limits=1), warnings.catch_warnings():
        # GM(1,N) of 16 near-collinear sensors is rank deficient in some folds:
        # the selector says so and uses the minimum-norm weights
        from greyml.exceptions import GreyConditioningWarning

        warnings.simplefilter("ignore", GreyConditioningWarning)
        records = nested(X, y, args.jobs)
        bound = hindsight(X, y) if args.hindsight else None
    elapsed = time.perf_counter() - start
    summ = summary(records)
    print_table(records, summ, len(X), n_configs)
    if bound is not None:
        print_hindsight(bound, summ)
    print(
        f"\nTotal {elapsed:.1f} s with n_jobs={args.jobs}, one BLAS thread; "
        f"python {platform.python_version()}, "
        + ", ".join(f"{k} {v}" for k, v in versions().items() if v)
    )
    if args.json:
        write_json(
            args.json,
            {"records": records, "summary": summ, "hindsight": bound},
            packages=PACKAGES,
            argv=argv,
            target=args.target,
            reference=args.reference,
            step=args.step,
            n_rows=len(X),
            n_configs=n_configs,
            elapsed_s=elapsed,
            n_jobs=args.jobs,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
