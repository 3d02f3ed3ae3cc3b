"""Real data: how much of the CAIVIAC error is the choice of sensors, not the model.

The default ``ThermalTransferFunction`` chooses at most five of sixteen
temperature sensors on the training cycles. This script asks what the same
model class (each sensor and the spindle speed through a static gain and the
default bank of first-order lags, carried over the one recording; a ridge
penalty chosen inside the training cycles) would score on each held-out cycle
with every possible set of ``k`` sensors, and what choosing the set by
exhaustive search on the training cycles gives. It separates two claims:
"no model of this class can do better on these five cycles" and "four cycles
cannot tell which sensors to use".

Protocol
--------
* Data, folds and scores as ``bench_dynamic_peers.py``: leave one cycle out,
  ``ch1_um`` and ``ch3_um``; RMSE on every 15 s row of the held-out cycle,
  "start" (change from the cycle's first row, the headline) and "recording"
  (from the recording's zero).
* Features: ``LagFeatures(5, 15, 45, 135 min, state="carry")`` of every
  sensor over the whole recording, and the speed (krpm) and its square with
  those lags and 405 min: the default model's first bank. An intercept; the
  columns standardised on the training rows; ridge penalties 1e-6 to 1 per
  row, as the default model.
* For every set of ``k`` sensors and every held-out cycle, the penalty is
  chosen by leave one cycle out inside the four training cycles (mean
  recording RMSE, the default model's criterion). Reported per fold: the
  spread of the held-out start RMSE over all sets (best, quartiles), and
  **the oracle**: the best set chosen on the held-out cycle itself. The
  oracle is not a model anyone can run; it bounds what a better choice of
  sensors could reach in this class.
* **Exhaustive selection, nested**: the set with the lowest mean inner
  held-out RMSE, by the recording criterion and by the start criterion.
* The default model, fitted as in ``bench_dynamic_peers.py``, on the same folds.

Every held-out score is computed from per-cycle Gram matrices (the held-out
cycle's first row and sums give its start-reference score), so a set costs a
few small solves. Without the data the script prints "CAIVIAC data not found
at ...; skipping" and exits 0.
"""

from __future__ import annotations

import argparse
import time
import warnings
from itertools import combinations

import numpy as np
from _common import package_versions, write_json
from bench_dynamic_peers import (
    DRIVER,
    SENSORS,
    TARGETS,
    TAUS,
    default_model,
    find_data,
    load,
    revision,
)

from greyml.dynamic._transfer import DEFAULT_ALPHAS

ALPHAS = np.asarray(DEFAULT_ALPHAS)  # the default model's penalties
DRIVER_TAUS = (*TAUS, 3.0 * TAUS[-1])
PACKAGES = ("greyml", "numpy", "scipy", "scikit-learn", "pandas")


def features(X):
    """Sensor blocks (one (n, 5) array per sensor) and the driver block (n, 12)."""
    from greyml import LagFeatures

    S = LagFeatures(list(TAUS), state="carry").fit_transform(X[list(SENSORS)])
    blocks = [S[[s, *(c for c in S.columns if c.startswith(f"{s}|"))]].to_numpy() for s in SENSORS]
    krpm = X[DRIVER].to_numpy(float) / 1000.0
    D = X[[DRIVER]].iloc[:, :0].assign(n=krpm, n2=krpm**2)
    lagged = LagFeatures(list(DRIVER_TAUS), state="carry").fit_transform(D)
    return blocks, lagged.to_numpy()


class CycleGrams:
    """Per-cycle Grams of [features, 1] and y (greyml's own), with first rows and sums.

    The ridge is the default model's (:func:`greyml.dynamic._gram.solve_all`:
    standardised columns, an unpenalised intercept); the first row and the
    sums of a held-out cycle turn its recording SSE into its start SSE.
    """

    def __init__(self, A, y, groups, cycles):
        from greyml.dynamic._gram import grams_by_test

        self.cycles = list(cycles)
        A = np.column_stack([A, np.ones(len(A))])
        bounds = []
        for c in self.cycles:
            rows = np.flatnonzero(groups == c)
            bounds.append((rows[0], rows[-1] + 1))  # each cycle's rows are contiguous
        blocks = grams_by_test(A, y, np.ones(len(y)), bounds)
        self.G, self.b, self.yy, self.n = blocks.G, blocks.b, blocks.yy, blocks.sw
        self.first = [(A[a], y[a]) for a, _ in bounds]
        self.sums = [(A[a:b].sum(axis=0), y[a:b].sum()) for a, b in bounds]
        self.pen = np.r_[np.ones(A.shape[1] - 1), 0.0]

    def solve(self, cols, train):
        """Ridge coefficients (columns ``cols`` then the intercept) for every penalty."""
        from greyml.dynamic._gram import solve_all

        full = [*cols, self.G.shape[1] - 1]
        ix = np.ix_(full, full)
        G = self.G[train][:, ix[0], ix[1]].sum(axis=0)
        b = self.b[train][:, full].sum(axis=0)
        return solve_all(G, b, self.n[train].sum(), ALPHAS, self.pen[full]), full

    def scores(self, coefs, full, h):
        """(start, recording) RMSE of cycle ``h`` for every column of ``coefs``."""
        G = self.G[h][np.ix_(full, full)]
        sse = (
            self.yy[h] - 2.0 * (self.b[h][full] @ coefs) + np.einsum("ia,ij,ja->a", coefs, G, coefs)
        )
        a0, y0 = self.first[h]
        sa, sy = self.sums[h]
        e0 = a0[full] @ coefs - y0
        se = sa[full] @ coefs - sy
        start = sse - 2.0 * e0 * se + e0**2 * self.n[h]
        n = self.n[h]
        return np.sqrt(np.maximum(start, 0.0) / n), np.sqrt(np.maximum(sse, 0.0) / n)


def evaluate_set(grams, cols, h):
    """Held-out (start, recording) RMSE of cycle ``h`` and the inner criteria, for one set.

    Returns (outer start and recording RMSE with the penalty each inner
    criterion chose, and the inner mean RMSE by each criterion).
    """
    k = len(grams.cycles)
    inner = [i for i in range(k) if i != h]
    inner_start, inner_rec = np.zeros(len(ALPHAS)), np.zeros(len(ALPHAS))
    for i in inner:
        train = np.array([j not in (h, i) for j in range(k)])
        coefs, full = grams.solve(cols, train)
        s, r = grams.scores(coefs, full, i)
        inner_start += s / len(inner)
        inner_rec += r / len(inner)
    coefs, full = grams.solve(cols, np.arange(k) != h)
    s, r = grams.scores(coefs, full, h)
    a_rec, a_start = int(np.argmin(inner_rec)), int(np.argmin(inner_start))
    return {
        "by_rec": (float(s[a_rec]), float(r[a_rec])),
        "by_start": (float(s[a_start]), float(r[a_start])),
        "inner_rec": float(inner_rec[a_rec]),
        "inner_start": float(inner_start[a_start]),
    }


def default_scores(X, y, groups, cycles):
    out = []
    for c in cycles:
        held = groups == c
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = default_model().fit(X, y, sample_weight=(~held).astype(float))
        e = np.asarray(model.predict(X))[held] - y.to_numpy()[held]
        out.append(
            {
                "start": float(np.sqrt(np.mean((e - e[0]) ** 2))),
                "recording": float(np.sqrt(np.mean(e**2))),
                "sensors": [s.removesuffix("_C") for s in model.selected_sensors_],
            }
        )
    return out


def run_target(path, target, ks):
    X, y = load(path, target)
    groups = np.asarray(X.index.get_level_values(0)).astype(str)
    cycles = list(dict.fromkeys(groups))
    blocks, drivers = features(X)
    widths = [b.shape[1] for b in blocks]
    A = np.column_stack([drivers, *blocks])
    offsets = drivers.shape[1] + np.concatenate(([0], np.cumsum(widths)))
    grams = CycleGrams(A, y.to_numpy(float), groups, cycles)
    driver_cols = list(range(drivers.shape[1]))
    result = {"default": default_scores(X, y, groups, cycles), "k": {}}
    for k in ks:
        per_fold = []
        for h, cycle in enumerate(cycles):
            rows = []
            for subset in combinations(range(len(SENSORS)), k):
                cols = driver_cols + [c for s in subset for c in range(offsets[s], offsets[s + 1])]
                rows.append((subset, evaluate_set(grams, cols, h)))
            held = np.array([r["by_rec"][0] for _, r in rows])
            oracle = int(np.argmin(held))
            nested = {
                crit: min(rows, key=lambda row, crit=crit: row[1][f"inner_{crit}"])
                for crit in ("rec", "start")
            }
            per_fold.append(
                {
                    "cycle": cycle,
                    "n_sets": len(rows),
                    "spread": [float(q) for q in np.percentile(held, [0, 25, 50, 75, 100])],
                    "oracle": {"sensors": _names(rows[oracle][0]), "start": float(held[oracle])},
                    **{
                        f"nested_{crit}": {
                            "sensors": _names(row[0]),
                            "start": row[1][f"by_{crit}"][0],
                            "recording": row[1][f"by_{crit}"][1],
                        }
                        for crit, row in nested.items()
                    },
                }
            )
        result["k"][k] = per_fold
    return result


def _names(subset):
    return [SENSORS[s].removesuffix("_C") for s in subset]


def print_target(target, result):
    default = result["default"]
    print(f"\n{target}: held-out RMSE µm, change from each cycle's first row (start reference)")
    cycles = [f["cycle"] for f in next(iter(result["k"].values()))]
    head = (
        f"{'':44}"
        + "".join(f"{'cycle ' + c:>9}" for c in cycles)
        + f" | {'median':>7} {'worst':>7}"
    )
    print(head)
    print("-" * len(head))

    def row(label, values):
        v = np.asarray(values)
        cells = "".join(f"{x:9.2f}" for x in v)
        print(f"{label:44}{cells} | {np.median(v):7.2f} {v.max():7.2f}")

    row("greyml default (<= 5 sensors, forward)", [d["start"] for d in default])
    for k, folds in result["k"].items():
        n = folds[0]["n_sets"]
        row(
            f"k={k}: oracle (set chosen on the held-out cycle)",
            [f["oracle"]["start"] for f in folds],
        )
        for q, name in ((1, "25th percentile"), (2, "median"), (3, "75th percentile")):
            row(f"k={k}: all {n} sets, {name}", [f["spread"][q] for f in folds])
        row(
            f"k={k}: exhaustive, nested, recording criterion",
            [f["nested_rec"]["start"] for f in folds],
        )
        row(
            f"k={k}: exhaustive, nested, start criterion",
            [f["nested_start"]["start"] for f in folds],
        )
    print("\nsets chosen (default; then per k: oracle / nested recording / nested start)")
    for i, d in enumerate(default):
        parts = [" ".join(d["sensors"])]
        for folds in result["k"].values():
            f = folds[i]
            parts += [
                " ".join(f["oracle"]["sensors"]),
                " ".join(f["nested_rec"]["sensors"]),
                " ".join(f["nested_start"]["sensors"]),
            ]
        print(f"  cycle {cycles[i]}: " + " | ".join(parts))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", metavar="PATH", help="cycles.csv or the folder holding it")
    parser.add_argument("--json", metavar="PATH", help="also write every number as JSON")
    parser.add_argument(
        "--k",
        type=int,
        nargs="+",
        default=[3],
        help="sizes of the sensor sets (default 3: 560 sets, about 10 s; 5: 4368 sets, about a minute)",
    )
    args = parser.parse_args(argv)
    if any(k < 1 or k > len(SENSORS) for k in args.k):
        parser.error(f"--k must be between 1 and {len(SENSORS)}")
    path = find_data(args.data)
    if path is None:
        return 0
    from threadpoolctl import threadpool_limits

    print(f"CAIVIAC/FL_THERMAL (real machine tool, MIT licence) from {path}")
    print("leave one cycle out; every set of k sensors in the default model's class")
    start = time.perf_counter()
    results = {}
    with threadpool_limits(limits=1):
        for target in TARGETS:
            results[target] = run_target(path, target, args.k)
            print_target(target, results[target])
    elapsed = time.perf_counter() - start
    versions = package_versions(PACKAGES, missing=None)
    print(
        f"\nTotal {elapsed:.0f} s, one BLAS thread; "
        + ", ".join(f"{k} {v}" for k, v in versions.items() if v)
        + f"; repository {revision() or 'unknown'}"
    )
    if args.json:
        write_json(
            args.json,
            results,
            packages=PACKAGES,
            argv=argv,
            data=str(path),
            k=args.k,
            elapsed_s=elapsed,
            revision=revision(),
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
