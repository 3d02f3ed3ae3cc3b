"""How greyml's models scale: fit and predict time against samples and inputs.

Every model is fitted with a small, fixed budget (few epochs or iterations), so
the times show how the cost grows, not how long a converged fit takes:

* against the number of samples: 10^3, 10^4 and 10^5 samples of 5 inputs;
* against the number of inputs: 2, 5, 10 and 20 inputs at 10^4 samples.

The data are smooth, sequence-like drivers, as GMC and GNNMCI expect: first-order
heating curves (temperature rises in K, all positive) driven by a random
piecewise-constant power programme, one test per data set, and a target made
by a GMC(1,N) system with known coefficients plus a little noise.

For each model the script fits a straight line to log(fit time) against
log(samples); a slope of 1 is linear cost. Acceptance: every slope <= 1.15.

Run ``python benchmarks/bench_scaling.py --help`` for the options; it writes a
log-log plot to ``--out`` (default ``benchmarks/out/``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from _common import package_versions as _package_versions
from sklearn.base import clone

import greyml

SAMPLE_SIZES = (1_000, 10_000, 100_000)
SAMPLES_N_INPUTS = 5
INPUT_COUNTS = (2, 5, 10, 20)
INPUTS_N_SAMPLES = 10_000

EPOCHS = 10  # epochs / iterations of every iterative model
PSO_POPULATION = 10
PSO_ITERATIONS = 20
LARGE_RULE_BASE = 256  # ANFIS rule bases above this are timed for 1 epoch only

REPEATS = 3  # timed fits per configuration, at most ...
TIME_BUDGET = 3.0  # ... and no more once the fits so far took this many seconds

SLOPE_MAX = 1.15  # acceptance: fit time grows at most ~linearly with samples

SEGMENT = 250  # samples per constant level of the power programme
THREADS = 1  # BLAS / OpenMP threads of each model's process (0: the libraries' default)
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
DEFAULT_OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "out")


# ------------------------------------------------------------------------------
# Data
# ------------------------------------------------------------------------------


def make_sequence(n_samples, n_inputs, seed=0):
    """Heating curves of ``n_inputs`` drivers and a GMC(1,N) target.

    Each driver is a first-order lag (time constant 30-300 samples, gain
    5-15 K) of a power level that changes every ``SEGMENT`` samples, plus 1 K
    and noise of 0.01 K: positive, smooth and drifting, like the temperature
    rises of a machine tool. The target is the GMC(1,N) response with
    b1 = 0.3, random driving coefficients and noise of 1 % of its spread.
    """
    from scipy.signal import lfilter

    from greyml.grey._functions import simulate_gmc

    rng = np.random.default_rng(seed)
    n_segments = -(-n_samples // SEGMENT)
    power = np.repeat(rng.uniform(0.2, 1.0, (n_segments, n_inputs)), SEGMENT, axis=0)
    power = power[:n_samples]
    tau = rng.uniform(30.0, 300.0, n_inputs)
    gain = rng.uniform(5.0, 15.0, n_inputs)
    X = np.empty((n_samples, n_inputs))
    for j in range(n_inputs):
        X[:, j] = lfilter([gain[j] / tau[j]], [1.0, -(1.0 - 1.0 / tau[j])], power[:, j])
    X += 1.0 + 0.01 * rng.standard_normal(X.shape)
    driving = rng.uniform(-0.1, 0.3, n_inputs)
    y = simulate_gmc(X, development=0.3, driving=driving, control=0.0)
    y += 0.01 * np.std(y) * rng.standard_normal(n_samples)
    return X, y


# ------------------------------------------------------------------------------
# Models
# ------------------------------------------------------------------------------


def with_budget(estimator, **budget):
    """Set the budget parameters the estimator has; return it and what was set."""
    known = estimator.get_params()
    applied = {k: v for k, v in budget.items() if k in known}
    return estimator.set_params(**applied), applied


@dataclass(frozen=True)
class Model:
    key: str
    label: str
    build: Callable  # (n_inputs) -> (estimator, settings text) or raises Skip
    per_epoch: bool  # is fit time / n_iter_ meaningful?


class Skip(Exception):
    """A configuration the model does not run, with the reason."""


def gmc_ls(n_inputs):
    return greyml.GMC(solver="ls"), "solver='ls'"


def gmc_pso(n_inputs):
    model = greyml.GMC(
        solver="pso", n_population=PSO_POPULATION, max_iter=PSO_ITERATIONS, random_state=0
    )
    return model, f"solver='pso', n_population={PSO_POPULATION}, max_iter={PSO_ITERATIONS}"


def gnnmci(n_inputs):
    model = greyml.GNNMCI(random_state=0)
    model, applied = with_budget(
        model,
        n_population=PSO_POPULATION,
        max_iter=PSO_ITERATIONS,
    )
    budget = ", ".join(f"{k}={v}" for k, v in applied.items()) or "defaults (no budget knob)"
    return model, budget


def anfis_epochs(n_rules):
    return 1 if n_rules > LARGE_RULE_BASE else EPOCHS


def anfis_grid(n_inputs):
    cls = greyml.ANFISGrid
    max_rules = cls().get_params().get("max_rules")
    n_rules = 2**n_inputs
    if max_rules is not None and n_rules > max_rules:
        raise Skip(
            f"skipped: 2^{n_inputs} = {n_rules:,} rules > max_rules={max_rules:,} "
            "(ANFISGrid's documented limit)"
        )
    epochs = anfis_epochs(n_rules)
    note = f" (>{LARGE_RULE_BASE} rules: 1 epoch only)" if epochs != EPOCHS else ""
    model = cls(n_mfs=2, max_iter=epochs, random_state=0)
    return model, f"n_mfs=2 ({n_rules} rules), max_iter={epochs}{note}"


def anfis_fcm(n_inputs):
    model = greyml.ANFISFCM(n_clusters=3, max_iter=EPOCHS, random_state=0)
    return model, f"n_clusters=3, max_iter={EPOCHS} (c-means defaults)"


def mlp(n_inputs):
    model = greyml.MLPBaseline(hidden_layer_sizes=10, random_state=0)
    model, applied = with_budget(model, max_iter=EPOCHS, n_restarts=1)
    return model, "hidden_layer_sizes=10, " + ", ".join(f"{k}={v}" for k, v in applied.items())


MODELS = (
    Model("gmc-ls", "GMC ls", gmc_ls, False),
    Model("gmc-pso", "GMC pso", gmc_pso, True),
    Model("gnnmci", "GNNMCI", gnnmci, True),
    Model("anfisgrid", "ANFISGrid 2 MFs", anfis_grid, True),
    Model("anfisfcm", "ANFISFCM 3 clusters", anfis_fcm, True),
    Model("mlp", "MLPBaseline", mlp, True),
)


# ------------------------------------------------------------------------------
# Timing
# ------------------------------------------------------------------------------


@dataclass
class Timing:
    model: str
    n_samples: int
    n_inputs: int
    settings: str = ""
    error: str | None = None
    fit_seconds: float | None = None
    predict_seconds: float | None = None
    fit_seconds_all: list = field(default_factory=list)
    n_iter: int | None = None
    epoch_seconds: float | None = None
    train_rmse: float | None = None


def time_config(model, X, y, repeats, budget):
    timing = Timing(model.key, X.shape[0], X.shape[1])
    try:
        estimator, timing.settings = model.build(X.shape[1])
    except Skip as reason:
        timing.error = str(reason)
        return timing
    except Exception as exc:
        timing.error = f"not available: {type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
        return timing
    fits, predicts = [], []
    try:
        while len(fits) < repeats and (not fits or sum(fits) < budget):
            estimator = clone(estimator)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a 10-epoch fit is unconverged by design
                start = time.perf_counter()
                estimator.fit(X, y)
                fits.append(time.perf_counter() - start)
                start = time.perf_counter()
                y_pred = estimator.predict(X)
                predicts.append(time.perf_counter() - start)
    except Exception as exc:
        timing.error = f"failed: {type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
        return timing
    timing.fit_seconds_all = fits
    timing.fit_seconds = float(np.median(fits))
    timing.predict_seconds = float(np.median(predicts))
    timing.train_rmse = float(np.sqrt(np.mean((np.ravel(y_pred) - y) ** 2)))
    n_iter = getattr(estimator, "n_iter_", None)
    if n_iter is not None:
        timing.n_iter = int(np.max(n_iter))
        if model.per_epoch and timing.n_iter > 0:
            timing.epoch_seconds = timing.fit_seconds / timing.n_iter
    return timing


def warm_up(model):
    """One small untimed fit: imports, caches and lazy set-up out of the timings."""
    X, y = make_sequence(1_000, SAMPLES_N_INPUTS, seed=1)
    try:
        estimator, _ = model.build(SAMPLES_N_INPUTS)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            estimator.fit(X, y).predict(X)
    except Exception:
        pass  # the timed configurations report the error


def time_model(model, repeats):
    """Every configuration of one model: {"samples": [...], "inputs": [...]}."""
    warm_up(model)
    samples = []
    for n in SAMPLE_SIZES:
        X, y = make_sequence(n, SAMPLES_N_INPUTS)
        samples.append(time_config(model, X, y, repeats, TIME_BUDGET))
    inputs = []
    for p in INPUT_COUNTS:
        if p == SAMPLES_N_INPUTS and INPUTS_N_SAMPLES in SAMPLE_SIZES:
            inputs.append(samples[SAMPLE_SIZES.index(INPUTS_N_SAMPLES)])
            continue
        X, y = make_sequence(INPUTS_N_SAMPLES, p)
        inputs.append(time_config(model, X, y, repeats, TIME_BUDGET))
    return {"samples": [t.__dict__ for t in samples], "inputs": [t.__dict__ for t in inputs]}


def worker_env(threads):
    env = dict(os.environ)
    if threads > 0:
        env.update({name: str(threads) for name in THREAD_VARIABLES})
    return env


def time_model_isolated(model, repeats, threads):
    """Run :func:`time_model` in a fresh interpreter with ``threads`` BLAS threads.

    On a small, shared machine, BLAS and OpenMP pools that spin while another
    pool works turn linear algorithms into erratic ones; one fresh process per
    model, with a fixed thread count, keeps the slopes about the algorithms.
    """
    command = [sys.executable, os.path.abspath(__file__), "--worker", model.key]
    command += ["--repeats", str(repeats)]
    completed = subprocess.run(
        command, capture_output=True, text=True, check=False, env=worker_env(threads)
    )
    lines = completed.stdout.strip().splitlines()
    if completed.returncode == 0 and lines:
        try:
            payload = json.loads(lines[-1])
            return {sweep: [Timing(**t) for t in payload[sweep]] for sweep in ("samples", "inputs")}
        except (json.JSONDecodeError, KeyError, TypeError):
            pass
    tail = (completed.stderr.strip().splitlines() or ["no output"])[-1][:160]
    error = f"worker exited with code {completed.returncode}: {tail}"
    return {
        "samples": [Timing(model.key, n, SAMPLES_N_INPUTS, error=error) for n in SAMPLE_SIZES],
        "inputs": [Timing(model.key, INPUTS_N_SAMPLES, p, error=error) for p in INPUT_COUNTS],
    }


def loglog_slope(sizes, seconds):
    points = [(n, t) for n, t in zip(sizes, seconds) if t is not None and t > 0]
    if len(points) < 2:
        return None
    n, t = np.log10(np.array(points, dtype=float)).T
    return float(np.polyfit(n, t, 1)[0])


# ------------------------------------------------------------------------------
# Reporting
# ------------------------------------------------------------------------------


def fmt_seconds(value):
    if value is None:
        return "-"
    if value < 1e-3:
        return f"{1e6 * value:.0f} us"
    if value < 1.0:
        return f"{1e3 * value:.1f} ms"
    return f"{value:.2f} s"


def print_sweep(title, column_name, columns, rows, attribute):
    print(f"\n== {title}")
    header = f"{'model':<22}" + "".join(f"{column_name}={c:<10}"[:14].rjust(14) for c in columns)
    print(header)
    print("-" * len(header))
    notes = []
    for model in MODELS:
        cells = []
        for c in columns:
            t = rows[(model.key, c)]
            if t.error:
                cells.append("n/a")
                notes.append(f"  {model.label}, {column_name}={c}: {t.error}")
            else:
                cells.append(fmt_seconds(getattr(t, attribute)))
        print(f"{model.label:<22}" + "".join(f"{cell:>14}" for cell in cells))
    for note in dict.fromkeys(notes):
        print(note)


def make_plot(path, sample_rows, input_rows, slopes):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, (ax_n, ax_p) = plt.subplots(1, 2, figsize=(12, 5))
    for i, model in enumerate(MODELS):
        colour = f"C{i}"
        pts = [
            (n, sample_rows[(model.key, n)])
            for n in SAMPLE_SIZES
            if sample_rows[(model.key, n)].fit_seconds
        ]
        if pts:
            slope = slopes[model.key]
            label = f"{model.label} fit (slope {slope:.2f})" if slope else f"{model.label} fit"
            ax_n.plot(
                [n for n, _ in pts],
                [t.fit_seconds for _, t in pts],
                "o-",
                color=colour,
                label=label,
            )
            ax_n.plot(
                [n for n, _ in pts],
                [t.predict_seconds for _, t in pts],
                "s--",
                color=colour,
                alpha=0.6,
            )
        pts = [
            (p, input_rows[(model.key, p)])
            for p in INPUT_COUNTS
            if input_rows[(model.key, p)].fit_seconds
        ]
        if pts:
            notes = [f"{p} inputs: 1 epoch" for p, t in pts if "1 epoch only" in t.settings]
            notes += [f"{p} inputs: n/a" for p in INPUT_COUNTS if input_rows[(model.key, p)].error]
            label = model.label + (f" ({'; '.join(notes)})" if notes else "")
            ax_p.plot(
                [p for p, _ in pts],
                [t.fit_seconds for _, t in pts],
                "o-",
                color=colour,
                label=label,
            )
    lo, hi = SAMPLE_SIZES[0], SAMPLE_SIZES[-1]
    ref = [t.fit_seconds for t in sample_rows.values() if t.fit_seconds]
    if ref:
        y0 = float(np.median(ref)) / 10
        ax_n.plot([lo, hi], [y0, y0 * hi / lo], ":", color="grey", label="linear (slope 1)")
    ax_n.plot([], [], "k--", alpha=0.6, label="predict (dashed)")
    ax_n.set(
        xscale="log",
        yscale="log",
        xlabel="training samples (count)",
        ylabel="wall time (s)",
        title=f"Fit and predict time vs samples ({SAMPLES_N_INPUTS} inputs)",
    )
    ax_p.set(
        xscale="log",
        yscale="log",
        xlabel="inputs (count)",
        ylabel="fit time (s)",
        title=f"Fit time vs inputs ({INPUTS_N_SAMPLES:,} samples)",
    )
    ax_p.set_xticks(INPUT_COUNTS, [str(p) for p in INPUT_COUNTS])
    ax_p.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    for ax in (ax_n, ax_p):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(
        f"greyml scaling, small budgets ({EPOCHS} epochs; PSO {PSO_POPULATION} x {PSO_ITERATIONS})"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def package_versions():
    return _package_versions(("greyml", "numpy", "scipy", "scikit-learn", "scikit-fuzzy"))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out", default=DEFAULT_OUT, help="folder for the plot (created if missing)"
    )
    parser.add_argument("--json", metavar="PATH", help="also write the timings as JSON")
    parser.add_argument(
        "--repeats",
        type=int,
        default=REPEATS,
        help=f"timed fits per configuration (default {REPEATS}; fewer once the fits so far "
        f"took {TIME_BUDGET:g} s)",
    )
    parser.add_argument(
        "--threads",
        type=int,
        default=THREADS,
        help=f"BLAS/OpenMP threads for each model's process (default {THREADS}; 0 keeps the "
        "libraries' defaults)",
    )
    parser.add_argument(
        "--no-fail", action="store_true", help="exit 0 even when a slope exceeds the limit"
    )
    parser.add_argument("--worker", metavar="KEY", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.worker:  # child process: one model, its timings as JSON on the last line
        model = {m.key: m for m in MODELS}[args.worker]
        print(json.dumps(time_model(model, args.repeats)))
        return 0

    try:
        load = os.getloadavg()[0]
    except OSError:
        load = float("nan")
    print("greyml scaling: fit and predict time against samples and inputs")
    print(
        f"Python {platform.python_version()}, {os.cpu_count()} CPUs, load average {load:.2f}; "
        + ", ".join(f"{k} {v}" for k, v in package_versions().items())
    )
    print(
        f"Budgets: {EPOCHS} epochs/iterations; GMC pso {PSO_POPULATION} particles x "
        f"{PSO_ITERATIONS} iterations; ANFIS rule bases > {LARGE_RULE_BASE} rules: 1 epoch. "
        f"Median of up to {args.repeats} fits (fewer once they took {TIME_BUDGET:g} s), "
        "after one untimed warm-up fit per model. Predict is timed on the training inputs."
    )
    print(
        "Each model runs in a fresh process with "
        + (
            f"{args.threads} BLAS/OpenMP thread(s) ({', '.join(THREAD_VARIABLES)})."
            if args.threads > 0
            else "the libraries' default thread counts."
        )
    )
    print(
        "Data: first-order heating curves (temperature rises 1-16 K, one test), GMC(1,N) "
        "target with 1 % noise."
    )

    sample_rows, input_rows, settings = {}, {}, {}
    for model in MODELS:
        timings = time_model_isolated(model, args.repeats, args.threads)
        for n, t in zip(SAMPLE_SIZES, timings["samples"]):
            sample_rows[(model.key, n)] = t
        for p, t in zip(INPUT_COUNTS, timings["inputs"]):
            input_rows[(model.key, p)] = t
        settings[model.key] = next(
            (t.settings for t in timings["samples"] + timings["inputs"] if t.settings), ""
        )
        print(f"  timed {model.label}", file=sys.stderr, flush=True)

    print("\nsettings:")
    for model in MODELS:
        print(f"  {model.label}: {settings.get(model.key) or '-'}")

    print_sweep(
        f"fit time vs samples ({SAMPLES_N_INPUTS} inputs)",
        "n",
        SAMPLE_SIZES,
        sample_rows,
        "fit_seconds",
    )
    print_sweep(
        f"fit time per epoch/iteration vs samples ({SAMPLES_N_INPUTS} inputs)",
        "n",
        SAMPLE_SIZES,
        sample_rows,
        "epoch_seconds",
    )
    print_sweep(
        f"predict time vs samples ({SAMPLES_N_INPUTS} inputs)",
        "n",
        SAMPLE_SIZES,
        sample_rows,
        "predict_seconds",
    )
    print_sweep(
        f"fit time vs inputs ({INPUTS_N_SAMPLES:,} samples)",
        "p",
        INPUT_COUNTS,
        input_rows,
        "fit_seconds",
    )
    print_sweep(
        f"fit time per epoch/iteration vs inputs ({INPUTS_N_SAMPLES:,} samples)",
        "p",
        INPUT_COUNTS,
        input_rows,
        "epoch_seconds",
    )

    print(
        f"\n== log-log slope of time vs samples (10^3-10^5, least squares; "
        f"acceptance: fit slope <= {SLOPE_MAX})"
    )
    print(f"{'model':<22}{'fit slope':>10}{'10^4->10^5':>12}{'predict slope':>15}  result")
    slopes, failed, summary = {}, [], []
    for model in MODELS:
        rows = [sample_rows[(model.key, n)] for n in SAMPLE_SIZES]
        fit_slope = loglog_slope(SAMPLE_SIZES, [r.fit_seconds for r in rows])
        tail_slope = loglog_slope(SAMPLE_SIZES[-2:], [r.fit_seconds for r in rows[-2:]])
        predict_slope = loglog_slope(SAMPLE_SIZES, [r.predict_seconds for r in rows])
        slopes[model.key] = fit_slope
        if fit_slope is None:
            status = "FAIL (not measured)"
            failed.append(model.label)
        elif fit_slope <= SLOPE_MAX:
            status = "PASS"
        else:
            status = "FAIL"
            failed.append(model.label)
        summary.append(
            {
                "model": model.key,
                "fit_slope": fit_slope,
                "fit_slope_1e4_1e5": tail_slope,
                "predict_slope": predict_slope,
                "status": status,
            }
        )
        print(
            f"{model.label:<22}{'-' if fit_slope is None else f'{fit_slope:.2f}':>10}"
            f"{'-' if tail_slope is None else f'{tail_slope:.2f}':>12}"
            f"{'-' if predict_slope is None else f'{predict_slope:.2f}':>15}  {status}"
        )

    os.makedirs(args.out, exist_ok=True)
    plot_path = os.path.join(args.out, "bench_scaling.png")
    make_plot(plot_path, sample_rows, input_rows, slopes)
    print(f"\nplot written to {plot_path}")

    if args.json:
        payload = {
            "environment": {
                "python": platform.python_version(),
                "cpu_count": os.cpu_count(),
                "load_average": load,
                "packages": package_versions(),
            },
            "threads": args.threads,
            "budgets": {
                "epochs": EPOCHS,
                "pso_population": PSO_POPULATION,
                "pso_iterations": PSO_ITERATIONS,
                "large_rule_base": LARGE_RULE_BASE,
            },
            "settings": settings,
            "samples": [t.__dict__ for t in sample_rows.values()],
            "inputs": [t.__dict__ for t in input_rows.values()],
            "slopes": summary,
        }
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(payload, handle, indent=2)
        print(f"timings written to {args.json}")

    if failed and not args.no_fail:
        print(f"\nslope acceptance failed for: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
