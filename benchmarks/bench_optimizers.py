"""Benchmark greyml's population optimisers against pyswarms, niapy and mealpy.

Every optimiser gets the same budget (population 25, 100 iterations) on two
problems:

* ``rastrigin10``: the 10-D Rastrigin function on [-5.12, 5.12]^10 (minimum 0);
* ``peaks12``: a 12-parameter nonlinear least-squares fit, four Gaussian peaks
  (amplitude, centre, width) fitted to noisy data generated from known
  parameters; the objective is the sum of squared residuals.

greyml and pyswarms receive the objective in its vectorised form (one call
evaluates the whole population, ``(P, D) -> (P,)``), because that is how both
libraries are designed to be used. niapy and mealpy evaluate one point at a time
and receive a scalar wrapper of the same function (``(D,) -> float``). Only the
minimisation call is timed; building the optimiser and the problem is not.

Run ``python benchmarks/bench_optimizers.py --help`` for the options. The peers
are installed by ``pip install -e .[bench]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from _common import package_versions

# Budget and hyperparameters shared by every optimiser that has the matching knob.
POPULATION = 25
MAX_ITER = 100
QUICK_MAX_ITER = 20
C1 = 2.0
C2 = 2.0
INERTIA = (0.9, 0.4)  # linearly decreasing inertia weight, start -> end
VELOCITY_CLAMP = 0.2  # maximum speed as a fraction of each variable's range
PA = 0.25  # fraction of nests abandoned per iteration
ALPHA = 0.01  # Levy-flight step scale
BETA = 1.5  # Levy exponent

# The project's stated targets, judged on medians over the seeds.
PSO_TIME_RATIO_MAX = 1.0  # greyml PSO time / pyswarms time
PSO_BEST_RATIO_MAX = 1.0  # greyml PSO best / mealpy PSO best
CS_BEST_RATIO_MAX = 1.0  # greyml CS best / niapy CS best
CS_TIME_MAX_MS = 10.0  # greyml CS median wall time

PACKAGES = ("greyml", "numpy", "pyswarms", "niapy", "mealpy")


# --------------------------------------------------------------------------
# Test problems. Each objective accepts one point of shape (D,) or a whole
# population of shape (P, D), so the vectorised and the scalar interface run
# exactly the same arithmetic.
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Problem:
    """A bounded minimisation problem and what is known about its minimum."""

    name: str
    title: str
    fun: Callable[[np.ndarray], np.ndarray]
    lower: np.ndarray
    upper: np.ndarray
    reference: float
    reference_note: str

    @property
    def dim(self):
        return self.lower.shape[0]


def rastrigin(x):
    """Rastrigin function over the last axis of ``x``."""
    return 10.0 * x.shape[-1] + np.sum(x * x - 10.0 * np.cos(2.0 * np.pi * x), axis=-1)


def gaussian_peaks(theta, t):
    """Sum of Gaussian peaks at times ``t``.

    ``theta[..., 3k:3k + 3]`` holds amplitude, centre and width of peak ``k``;
    the result has shape ``theta.shape[:-1] + t.shape``.
    """
    amplitude = theta[..., 0::3, np.newaxis]
    centre = theta[..., 1::3, np.newaxis]
    width = theta[..., 2::3, np.newaxis]
    z = (t - centre) / width
    return np.sum(amplitude * np.exp(-0.5 * z * z), axis=-2)


def peaks_ssr(theta, t, y):
    """Sum of squared residuals of :func:`gaussian_peaks` against ``y``."""
    residual = gaussian_peaks(theta, t) - y
    return np.sum(residual * residual, axis=-1)


def peaks_residual(theta, t, y):
    """Residual vector of one parameter vector, for scipy's least_squares."""
    return gaussian_peaks(theta, t) - y


def make_rastrigin(dim=10):
    """The ``dim``-dimensional Rastrigin problem on the usual box."""
    bound = np.full(dim, 5.12)
    return Problem(
        name=f"rastrigin{dim}",
        title=f"{dim}-D Rastrigin on [-5.12, 5.12]^{dim}",
        fun=rastrigin,
        lower=-bound,
        upper=bound,
        reference=0.0,
        reference_note="global minimum 0 at the origin",
    )


def make_peak_fit(seed=20240611, n_samples=201, noise=0.02):
    """Four Gaussian peaks (12 parameters) fitted to noisy synthetic data.

    Each peak has its own window for the centre, so the labelling of the peaks
    is fixed and the problem has one basin around the generating parameters.
    The reference value is the sum of squares that scipy's ``least_squares``
    reaches when started at the generating parameters.
    """
    from scipy.optimize import least_squares

    truth = np.array(
        [
            [1.0, 1.4, 0.5],
            [2.0, 3.9, 0.8],
            [1.5, 6.1, 0.6],
            [0.8, 8.6, 1.0],
        ]
    )
    n_peaks = truth.shape[0]
    t = np.linspace(0.0, 10.0, n_samples)
    rng = np.random.default_rng(seed)
    y = gaussian_peaks(truth.ravel(), t) + noise * rng.standard_normal(n_samples)

    window = 10.0 / n_peaks
    lower = np.array([[0.0, k * window, 0.1] for k in range(n_peaks)]).ravel()
    upper = np.array([[3.0, (k + 1) * window, 2.0] for k in range(n_peaks)]).ravel()
    fit = least_squares(peaks_residual, truth.ravel(), bounds=(lower, upper), args=(t, y))
    reference = float(peaks_ssr(fit.x, t, y))
    return Problem(
        name=f"peaks{truth.size}",
        title=(
            f"{truth.size}-parameter least-squares fit: {n_peaks} Gaussian peaks, "
            f"{n_samples} samples, noise sd {noise}"
        ),
        fun=partial(peaks_ssr, t=t, y=y),
        lower=lower,
        upper=upper,
        reference=reference,
        reference_note=(f"least_squares from the generating parameters reaches {reference:.4g}"),
    )


class VectorObjective:
    """Population objective ``(P, D) -> (P,)`` that counts evaluated points."""

    def __init__(self, fun):
        self.fun = fun
        self.nfev = 0

    def __call__(self, x):
        self.nfev += x.shape[0]
        return self.fun(x)


class ScalarObjective:
    """Point objective ``(D,) -> float`` that counts evaluated points."""

    def __init__(self, fun):
        self.fun = fun
        self.nfev = 0

    def __call__(self, x):
        self.nfev += 1
        return float(self.fun(x))


# --------------------------------------------------------------------------
# One runner per optimiser. Each imports its library itself, so a missing or
# broken peer fails on its own row, builds the optimiser outside the timed
# region and returns (best value, best x, seconds, counted nfev, reported nfev).
# --------------------------------------------------------------------------


@dataclass
class Run:
    best: float
    x: np.ndarray
    seconds: float
    nfev: int
    reported_nfev: int | None


def run_greyml_pso(problem, seed, max_iter):
    from greyml.optimize import ParticleSwarm

    optimiser = ParticleSwarm(
        n_population=POPULATION,
        max_iter=max_iter,
        c1=C1,
        c2=C2,
        inertia=INERTIA,
        velocity_clamp=VELOCITY_CLAMP,
    )
    objective = VectorObjective(problem.fun)
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    result = optimiser.minimize(objective, (problem.lower, problem.upper), rng)
    seconds = time.perf_counter() - start
    return Run(float(result.fun), result.x, seconds, objective.nfev, int(result.nfev))


def run_greyml_cs(problem, seed, max_iter):
    from greyml.optimize import CuckooSearch

    optimiser = CuckooSearch(
        n_population=POPULATION, max_iter=max_iter, pa=PA, alpha=ALPHA, beta=BETA
    )
    objective = VectorObjective(problem.fun)
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    result = optimiser.minimize(objective, (problem.lower, problem.upper), rng)
    seconds = time.perf_counter() - start
    return Run(float(result.fun), result.x, seconds, objective.nfev, int(result.nfev))


def _ignore_logging_config(*args, **kwargs):
    """Do nothing; stands in for pyswarms' logging set-up."""


def _import_pyswarms_quietly():
    """Import pyswarms without letting it reconfigure logging.

    Every pyswarms ``Reporter`` (three are built at import time, one more per
    optimiser) calls ``logging.config.dictConfig``, which sends INFO records of
    every library to stderr and creates ``./report.log``.
    """
    import logging.config

    configure = logging.config.dictConfig
    logging.config.dictConfig = _ignore_logging_config
    try:
        from pyswarms.utils.reporter import Reporter
    finally:
        logging.config.dictConfig = configure
    Reporter._setup_logger = _ignore_logging_config


def run_pyswarms_pso(problem, seed, max_iter):
    _import_pyswarms_quietly()
    from pyswarms.single import GlobalBestPSO

    span = problem.upper - problem.lower
    # pyswarms draws from NumPy's global random state only.
    np.random.seed(seed)  # noqa: NPY002
    optimiser = GlobalBestPSO(
        n_population=POPULATION,
        dimensions=problem.dim,
        options={"c1": C1, "c2": C2, "w": INERTIA[0]},
        bounds=(problem.lower, problem.upper),
        velocity_clamp=(-VELOCITY_CLAMP * span, VELOCITY_CLAMP * span),
        # pyswarms' linear schedule ends at w = 0.4, which is INERTIA[1].
        oh_strategy={"w": "lin_variation"},
    )
    objective = VectorObjective(problem.fun)
    start = time.perf_counter()
    best, x = optimiser.optimize(objective, iters=max_iter, verbose=False)
    seconds = time.perf_counter() - start
    return Run(float(best), x, seconds, objective.nfev, None)


def _niapy_task(problem, objective, max_iter):
    from niapy.problems import Problem as NiapyProblem
    from niapy.task import Task

    class Wrapped(NiapyProblem):
        def _evaluate(self, x):
            return objective(x)

    wrapped = Wrapped(dimension=problem.dim, lower=problem.lower, upper=problem.upper)
    return Task(problem=wrapped, max_iters=max_iter)


def _run_niapy(algorithm, problem, max_iter):
    objective = ScalarObjective(problem.fun)
    task = _niapy_task(problem, objective, max_iter)
    start = time.perf_counter()
    x, best = algorithm.run(task)
    seconds = time.perf_counter() - start
    return Run(float(best), x, seconds, objective.nfev, int(task.evals))


def run_niapy_pso(problem, seed, max_iter):
    from niapy.algorithms.basic import ParticleSwarmAlgorithm

    span = problem.upper - problem.lower
    # No inertia schedule in niapy: its default constant w = 0.7 is kept.
    algorithm = ParticleSwarmAlgorithm(
        population_size=POPULATION,
        c1=C1,
        c2=C2,
        min_velocity=-VELOCITY_CLAMP * span,
        max_velocity=VELOCITY_CLAMP * span,
        seed=seed,
    )
    return _run_niapy(algorithm, problem, max_iter)


def run_niapy_cs(problem, seed, max_iter):
    from niapy.algorithms.basic import CuckooSearch

    # niapy's Levy flight uses alpha = 0.01 and beta = 1.5, as greyml here.
    algorithm = CuckooSearch(population_size=POPULATION, pa=PA, seed=seed)
    return _run_niapy(algorithm, problem, max_iter)


def _run_mealpy(model, problem, seed):
    from mealpy import FloatVar
    from mealpy import Problem as MealpyProblem

    objective = ScalarObjective(problem.fun)
    task = MealpyProblem(
        bounds=FloatVar(lb=problem.lower, ub=problem.upper),
        minmax="min",
        obj_func=objective,
        log_to=None,
    )
    start = time.perf_counter()
    agent = model.solve(task, seed=seed)
    seconds = time.perf_counter() - start
    return Run(
        float(agent.target.fitness),
        agent.solution,
        seconds,
        objective.nfev,
        int(model.nfe_counter),
    )


def run_mealpy_pso(problem, seed, max_iter):
    from mealpy.swarm_based.PSO import OriginalPSO

    # Constant inertia: mealpy's default w = 0.4 is kept.
    model = OriginalPSO(epoch=max_iter, pop_size=POPULATION, c1=C1, c2=C2)
    return _run_mealpy(model, problem, seed)


def run_mealpy_ldw_pso(problem, seed, max_iter):
    from mealpy.swarm_based.PSO import LDW_PSO

    model = LDW_PSO(
        epoch=max_iter,
        pop_size=POPULATION,
        c1=C1,
        c2=C2,
        w_min=INERTIA[1],
        w_max=INERTIA[0],
    )
    return _run_mealpy(model, problem, seed)


def run_mealpy_cs(problem, seed, max_iter):
    from mealpy.swarm_based.CSA import OriginalCSA

    model = OriginalCSA(epoch=max_iter, pop_size=POPULATION, p_a=PA)
    return _run_mealpy(model, problem, seed)


@dataclass(frozen=True)
class Optimiser:
    key: str
    label: str
    interface: str
    runner: Callable


OPTIMISERS = (
    Optimiser("greyml-pso", "greyml ParticleSwarm", "vector", run_greyml_pso),
    Optimiser("pyswarms-pso", "pyswarms GlobalBestPSO", "vector", run_pyswarms_pso),
    Optimiser("niapy-pso", "niapy ParticleSwarmAlgorithm", "scalar", run_niapy_pso),
    Optimiser("mealpy-pso", "mealpy OriginalPSO", "scalar", run_mealpy_pso),
    Optimiser("mealpy-ldwpso", "mealpy LDW_PSO", "scalar", run_mealpy_ldw_pso),
    Optimiser("greyml-cs", "greyml CuckooSearch", "vector", run_greyml_cs),
    Optimiser("niapy-cs", "niapy CuckooSearch", "scalar", run_niapy_cs),
    Optimiser("mealpy-cs", "mealpy OriginalCSA", "scalar", run_mealpy_cs),
)


# --------------------------------------------------------------------------
# Running and reporting.
# --------------------------------------------------------------------------


@dataclass
class Record:
    """All runs of one optimiser on one problem."""

    best: list = field(default_factory=list)
    seconds: list = field(default_factory=list)
    nfev: list = field(default_factory=list)
    reported_nfev: list = field(default_factory=list)
    error: str | None = None
    notes: list = field(default_factory=list)

    def median(self, name):
        values = getattr(self, name)
        return float(np.median(values)) if values and self.error is None else None


def check_run(problem, run):
    """Problems with a returned result: outside the box, or a value that is
    not the objective at the returned point."""
    notes = []
    x = np.asarray(run.x, dtype=float)
    if np.any(x < problem.lower) or np.any(x > problem.upper):
        notes.append("returned x lies outside the bounds")
    value = float(problem.fun(x))
    if not np.isclose(value, run.best, rtol=1e-9, atol=1e-12):
        notes.append(f"reported best {run.best:.6g} but f(x) = {value:.6g}")
    return notes


def benchmark(problem, optimiser, seeds, max_iter, warm_up):
    """Run ``optimiser`` on ``problem`` once per seed; never raises."""
    record = Record()
    try:
        if warm_up:
            optimiser.runner(problem, seeds[0], max_iter)
        for seed in seeds:
            run = optimiser.runner(problem, seed, max_iter)
            record.best.append(run.best)
            record.seconds.append(run.seconds)
            record.nfev.append(run.nfev)
            record.reported_nfev.append(run.reported_nfev)
            for note in check_run(problem, run):
                if note not in record.notes:
                    record.notes.append(note)
    except Exception as exc:  # a failing peer is reported, not hidden
        record.error = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return record


def ratio(numerator, denominator):
    if numerator is None or denominator is None:
        return None
    if denominator == 0.0:
        return 1.0 if numerator == 0.0 else float("inf")
    return numerator / denominator


def targets(records):
    """The four target lines for one problem: (text, value, limit)."""
    greyml_pso, greyml_cs = records["greyml-pso"], records["greyml-cs"]
    cs_ms = greyml_cs.median("seconds")
    return [
        (
            "PSO at pyswarms' speed (time greyml / pyswarms)",
            ratio(greyml_pso.median("seconds"), records["pyswarms-pso"].median("seconds")),
            PSO_TIME_RATIO_MAX,
        ),
        (
            "PSO as accurate as mealpy (best greyml / mealpy OriginalPSO)",
            ratio(greyml_pso.median("best"), records["mealpy-pso"].median("best")),
            PSO_BEST_RATIO_MAX,
        ),
        (
            "CS at least as accurate as niapy (best greyml / niapy CS)",
            ratio(greyml_cs.median("best"), records["niapy-cs"].median("best")),
            CS_BEST_RATIO_MAX,
        ),
        (
            f"CS within {CS_TIME_MAX_MS:g} ms (greyml CS median time, ms)",
            None if cs_ms is None else 1e3 * cs_ms,
            CS_TIME_MAX_MS,
        ),
    ]


def _seconds_per_call(objective, points, n_calls, n_blocks=9):
    """Mean time of one call of ``objective`` in the fastest of ``n_blocks``
    blocks (as ``timeit`` advises: slower blocks were disturbed)."""
    blocks = []
    for _ in range(n_blocks):
        start = time.perf_counter()
        for k in range(n_calls):
            objective(points[k % len(points)])
        blocks.append((time.perf_counter() - start) / n_calls)
    return min(blocks)


def objective_cost(problem, n_calls=100, seed=0):
    """Seconds per call of the objective alone, for each interface.

    ``"vector"`` is one call on a population of ``POPULATION`` points,
    ``"scalar"`` one call on a single point, both through the counting wrappers
    the optimisers get.
    """
    rng = np.random.default_rng(seed)
    span = problem.upper - problem.lower
    points = problem.lower + rng.random((n_calls, POPULATION, problem.dim)) * span
    return {
        "vector": _seconds_per_call(VectorObjective(problem.fun), points, n_calls),
        "scalar": _seconds_per_call(ScalarObjective(problem.fun), points[:, 0], n_calls),
    }


def objective_seconds(cost, interface, nfev):
    """Estimated time spent inside the objective for ``nfev`` points."""
    if interface == "vector":
        return cost["vector"] * nfev / POPULATION
    return cost["scalar"] * nfev


def print_problem(problem, records, cost, judge):
    """Print the table and the target lines of one problem; return the
    verdicts (True, False or None when a number is missing)."""
    print(f"\n{problem.name}: {problem.title}")
    print(f"  reference: {problem.reference_note}")
    print(
        f"  objective alone: {1e6 * cost['vector']:.1f} us per {POPULATION}-point "
        f"call, {1e6 * cost['scalar']:.1f} us per single-point call"
    )
    header = (
        f"  {'optimiser':<29}{'objective':<10}{'median best':>12}{'min best':>10}"
        f"{'max best':>10}{'median ms':>11}{'overhead ms':>13}{'nfev':>6}"
        f"{'lib nfev':>10}"
    )
    print(header)
    print("  " + "-" * (len(header) - 2))
    for optimiser in OPTIMISERS:
        record = records[optimiser.key]
        start = f"  {optimiser.label:<29}{optimiser.interface:<10}"
        if record.error is not None:
            print(start + f"ERROR {record.error}")
            continue
        seconds = record.median("seconds")
        nfev = int(np.median(record.nfev))
        reported = record.reported_nfev[0]
        overhead = seconds - objective_seconds(cost, optimiser.interface, nfev)
        print(
            start
            + f"{record.median('best'):>12.5g}{min(record.best):>10.4g}"
            + f"{max(record.best):>10.4g}{1e3 * seconds:>11.2f}"
            + f"{1e3 * overhead:>13.2f}{nfev:>6d}"
            + f"{'-' if reported is None else reported:>10}"
        )
    for optimiser in OPTIMISERS:
        for note in records[optimiser.key].notes:
            print(f"  note: {optimiser.label}: {note}")

    print("  targets:")
    verdicts = []
    for text, value, limit in targets(records):
        if value is None:
            verdict, word = None, "MISS"
        else:
            verdict = value <= limit
            word = "PASS" if verdict else "MISS"
        if not judge:
            word = "----"
        shown = "n/a (an optimiser failed)" if value is None else f"{value:.3g}"
        print(f"    {word}  {text}: {shown} (target <= {limit:g})")
        verdicts.append(verdict)
    return verdicts


def environment():
    versions = package_versions(PACKAGES)
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "versions": versions,
    }


def to_json(problems, results, costs, env, config):
    out = {"config": config, "environment": env, "problems": {}}
    for problem in problems:
        entry = {
            "title": problem.title,
            "reference": problem.reference,
            "objective_seconds_per_call": costs[problem.name],
            "optimisers": {},
        }
        for optimiser in OPTIMISERS:
            record = results[problem.name][optimiser.key]
            entry["optimisers"][optimiser.key] = {
                "label": optimiser.label,
                "objective": optimiser.interface,
                "best": record.best,
                "seconds": record.seconds,
                "nfev": record.nfev,
                "reported_nfev": record.reported_nfev,
                "error": record.error,
                "notes": record.notes,
            }
        entry["targets"] = [
            {"target": text, "value": value, "limit": limit}
            for text, value, limit in targets(results[problem.name])
        ]
        out["problems"][problem.name] = entry
    return out


def parse_args(argv=None):
    parser = argparse.ArgumentParser(
        description=(
            "Compare greyml's ParticleSwarm and CuckooSearch with pyswarms, niapy "
            "and mealpy on 10-D Rastrigin and a 12-parameter least-squares fit."
        )
    )
    parser.add_argument("--seeds", type=int, default=5, help="number of seeds (default: 5)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help=(
            f"smoke test: {QUICK_MAX_ITER} iterations and no warm-up run; "
            "the targets are then not judged"
        ),
    )
    parser.add_argument("--json", metavar="PATH", help="also write the raw numbers to PATH")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")
    return args


def main(argv=None):
    args = parse_args(argv)
    max_iter = QUICK_MAX_ITER if args.quick else MAX_ITER
    seeds = list(range(args.seeds))
    env = environment()
    problems = [make_rastrigin(), make_peak_fit()]

    print("greyml optimiser benchmark")
    print(
        f"  budget: population {POPULATION}, {max_iter} iterations, "
        f"seeds {seeds[0]}..{seeds[-1]}"
        + ("" if args.quick else ", one untimed warm-up run per optimiser")
    )
    print(
        f"  shared settings: c1 = {C1}, c2 = {C2}, inertia {INERTIA[0]} -> "
        f"{INERTIA[1]}, speed <= {VELOCITY_CLAMP} x range, pa = {PA}, "
        f"alpha = {ALPHA}, beta = {BETA} (where a library has the knob)"
    )
    print(
        "  objective: 'vector' = whole population per call (P, D) -> (P,); "
        "'scalar' = one point per call (D,) -> float"
    )
    print("  time: wall time of the minimisation call only, median over seeds")
    print(
        "  overhead: median time minus the objective's own share, estimated by "
        "timing the objective alone"
    )
    print("  nfev: points evaluated, counted in the objective; lib nfev: the library's own count")
    print(
        "  "
        + ", ".join(f"{name} {version}" for name, version in env["versions"].items())
        + f"; Python {env['python']}, {env['cpus']} CPUs"
    )

    results = {}
    costs = {}
    all_verdicts = []
    for problem in problems:
        costs[problem.name] = cost = objective_cost(problem)
        records = {
            optimiser.key: benchmark(problem, optimiser, seeds, max_iter, warm_up=not args.quick)
            for optimiser in OPTIMISERS
        }
        results[problem.name] = records
        all_verdicts += print_problem(problem, records, cost, judge=not args.quick)

    if args.quick:
        print(f"\nTargets not judged: they are stated for {MAX_ITER} iterations.")
    else:
        passed = sum(verdict is True for verdict in all_verdicts)
        print(f"\n{passed} of {len(all_verdicts)} target lines pass.")
        if args.seeds < 5:
            print(f"Only {args.seeds} seed(s): medians are rough.")

    if args.json:
        config = {
            "population": POPULATION,
            "max_iter": max_iter,
            "seeds": seeds,
            "quick": args.quick,
            "c1": C1,
            "c2": C2,
            "inertia": list(INERTIA),
            "velocity_clamp": VELOCITY_CLAMP,
            "pa": PA,
            "alpha": ALPHA,
            "beta": BETA,
        }
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(to_json(problems, results, costs, env, config), handle, indent=2)
        print(f"Raw numbers written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
