"""Speed of the GMC(1,N) time response: O(n) recursion against the literal sum.

Run: ``python benchmarks/bench_gmc_response.py [--n 1000000] [--drivers 5]``

Times, for one parameter set, (a) the response alone from given forcing,
(b) the whole prediction from raw drivers (AGO, forcing, response, IAGO), and
(c) a population of 25 candidates as the optimisers evaluate it, against the
literal O(n²) sum of the formula on a short series, scaled by n².
Target (issue #2): (b) under 50 ms for 10⁶ samples × 5 drivers.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from greyml.grey._kernels import ago
from greyml.grey._response import gmc_predict, gmc_response, gmc_sse_population


def best_of(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def literal(f, b1, x0):
    n = len(f)
    out = np.empty(n)
    out[0] = x0
    for k in range(2, n + 1):
        tau = np.arange(2, k)
        s = (x0 + 0.5 * f[0]) * np.exp(-b1 * (k - 1))
        s += np.sum(np.exp(-b1 * (k - tau)) * f[tau - 1]) + 0.5 * f[k - 1]
        out[k - 1] = s
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1_000_000)
    parser.add_argument("--drivers", type=int, default=5)
    args = parser.parse_args(argv)

    rng = np.random.default_rng(0)
    X = 20 + np.cumsum(rng.normal(scale=0.01, size=(args.n, args.drivers)), axis=0)
    coef = rng.normal(size=args.drivers)
    f = ago(X) @ coef + 0.1

    t_resp = best_of(lambda: gmc_response(f, 0.05, 0.0))
    t_pred = best_of(lambda: gmc_predict(ago(X), 0.05, coef, 0.1))
    n_pop = min(args.n, 100_000)
    Xp, yp = X[:n_pop], np.zeros(n_pop)
    params = np.column_stack(
        [rng.uniform(0.01, 1, 25), rng.normal(size=(25, args.drivers)), np.zeros(25)]
    )
    t_pop = best_of(lambda: gmc_sse_population(ago(Xp), yp, params), repeat=3)

    n_small = 2_000
    t_lit = best_of(lambda: literal(f[:n_small], 0.05, 0.0), repeat=1)
    np.testing.assert_allclose(
        gmc_response(f[:n_small], 0.05, 0.0), literal(f[:n_small], 0.05, 0.0), rtol=1e-9
    )
    t_lit_scaled = t_lit * (args.n / n_small) ** 2

    print(f"GMC time response, {args.n:,} samples x {args.drivers} drivers (best of 7)")
    print(f"  response from forcing (lfilter recursion)   {t_resp * 1e3:8.2f} ms")
    print(
        f"  full prediction from raw drivers             {t_pred * 1e3:8.2f} ms   target < 50 ms: {'PASS' if t_pred < 0.05 else 'MISS'}"
    )
    print(f"  population of 25, {n_pop:,} samples, SSE       {t_pop * 1e3:8.2f} ms")
    print(f"  literal O(n^2) sum, {n_small:,} samples          {t_lit * 1e3:8.2f} ms")
    print(
        f"  literal sum scaled to {args.n:,} samples (n^2)  {t_lit_scaled:8.0f} s   ratio {t_lit_scaled / t_pred:,.0f}x"
    )


if __name__ == "__main__":
    main()
