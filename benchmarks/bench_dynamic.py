"""Speed of greyml's dynamic models: LagFeatures on long recordings, Compensator.update per sample.

Run: ``python benchmarks/bench_dynamic.py [--rows 1000000] [--columns 20] [--repeats 3] [--json out.json]``

(a) ``LagFeatures`` with 4 time constants on ``--rows`` × ``--columns`` (15 s
sampling, greyml's (test, time_s) index, 4 tests), DataFrame in and out, against
two peers that compute the same numbers: a plain NumPy loop over the rows
(vectorised over columns and time constants; timed on fewer rows and scaled
linearly) and pandas' ``ewm(halflife=τ·ln 2, times=…, adjust=False).mean()``,
the same first-order lag, per time constant and test. Issue #16's target: under
1 s for 10⁶ rows × 20 columns × 4 time constants.
(b) ``Compensator.update`` per sample for a CAIVIAC-sized model (16
temperatures and the spindle speed, 4 time constants, speed², raw inputs: 89
terms), against a plain per-sample loop over the terms and against the batch
``Pipeline.predict`` per row. Target: under 20 µs per update.

Set ``OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1``; times are the best of
``--repeats``, on a shared machine compare the ratios rather than the times.
"""

from __future__ import annotations

import argparse
import math
import time
import tracemalloc

import numpy as np
import pandas as pd
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from greyml import Compensator, LagFeatures, make_test_index
from greyml.dynamic._kernels import lag_step, steady_state

TAUS = np.array([300.0, 900.0, 2700.0, 8100.0])
STEP = 15.0


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
        del out
    return min(times)


def recording(n_rows, n_columns, n_tests=4, seed=0):
    rng = np.random.default_rng(seed)
    values = 20.0 + np.cumsum(rng.normal(scale=0.01, size=(n_rows, n_columns)), axis=0)
    per = -(-n_rows // n_tests)
    labels = np.repeat([f"test{i}" for i in range(n_tests)], per)[:n_rows]
    times = STEP * (np.arange(n_rows) % per)
    columns = [f"T{j + 1}_C" for j in range(n_columns)]
    return pd.DataFrame(values, index=make_test_index(labels, times), columns=columns)


def numpy_loop(X, taus):
    """The lag recursion, one row at a time, vectorised over columns and time constants."""
    values = X.to_numpy()
    time_s = X.index.get_level_values("time_s").to_numpy()
    n, p = values.shape
    out = np.empty((n, p, taus.size))
    state = None
    for k in range(n):
        if k == 0 or time_s[k] <= time_s[k - 1]:
            state = np.repeat(values[k][:, None], taus.size, axis=1)
        else:
            a = np.exp(-(time_s[k] - time_s[k - 1]) / taus)
            state = (1.0 - a) * values[k][:, None] + a * state
        out[k] = state
    return out


def pandas_ewm(X, taus):
    """pandas' exponentially weighted mean with times: the same lag, per test."""
    stamps = pd.to_datetime(X.index.get_level_values("time_s"), unit="s")
    frame = X.reset_index(drop=True)
    labels = X.index.get_level_values("test")
    pieces = []
    for label in pd.unique(labels):
        rows = np.flatnonzero(labels == label)
        part = frame.iloc[rows[0] : rows[-1] + 1]
        part_times = stamps[rows[0] : rows[-1] + 1]
        lags = [
            part.ewm(
                halflife=pd.Timedelta(seconds=tau * math.log(2.0)), times=part_times, adjust=False
            )
            .mean()
            .add_suffix(f"|lag {tau:g} s")
            for tau in taus
        ]
        pieces.append(pd.concat(lags, axis=1))
    out = pd.concat(pieces)
    out.index = X.index
    return out


def bench_lags(args, results):
    X = recording(args.rows, args.columns)
    lags = LagFeatures(TAUS).fit(X)
    t_fit = best_of(lambda: LagFeatures(TAUS).fit(X), args.repeats)
    t_transform = best_of(lambda: lags.transform(X), args.repeats)
    Z = lags.transform(X)
    out = Z.to_numpy()
    fortran = bool(out.flags.f_contiguous)
    n_out = Z.shape[1]
    one_block = getattr(getattr(Z, "_mgr", None), "nblocks", None)
    # memory: a copy of the output on the way to pandas would double the peak
    del Z, out
    tracemalloc.start()
    Z = lags.transform(X)
    peak = tracemalloc.get_traced_memory()[1] / Z.to_numpy().nbytes
    tracemalloc.stop()
    del Z
    # the same without pandas: an array in (sample_interval), an array out
    plain = recording(args.rows, args.columns).to_numpy()
    array_lags = LagFeatures(TAUS, sample_interval=STEP).fit(plain[:10])
    t_array = best_of(lambda: array_lags.transform(plain), args.repeats)

    n_loop = min(args.rows, args.loop_rows)
    small = X.iloc[:n_loop]
    t_loop = best_of(lambda: numpy_loop(small, TAUS), 1) * args.rows / n_loop
    expected = numpy_loop(small, TAUS).reshape(n_loop, -1)
    got = LagFeatures(TAUS, include_input=False).fit_transform(small).to_numpy()
    loop_diff = float(np.abs(got - expected).max())

    t_ewm = best_of(lambda: pandas_ewm(X, TAUS), max(1, args.repeats - 1))
    ewm = pandas_ewm(X.iloc[:n_loop], TAUS).to_numpy()
    # pandas orders tau by tau; greyml column by column
    ewm = ewm.reshape(n_loop, TAUS.size, args.columns).transpose(0, 2, 1).reshape(n_loop, -1)
    ewm_diff = float(np.abs(got - ewm).max())

    total = t_fit + t_transform
    print(
        f"(a) LagFeatures, {args.rows:,} rows x {args.columns} columns x {TAUS.size} time "
        f"constants -> {n_out} columns (best of {args.repeats})"
    )
    print(f"  fit (checks)                                {t_fit:8.3f} s")
    print(f"  transform, DataFrame in and out             {t_transform:8.3f} s")
    print(
        f"  fit + transform                             {total:8.3f} s   target < 1 s: "
        f"{'PASS' if total < 1.0 else 'MISS'}"
    )
    print(f"  transform, array in and out                 {t_array:8.3f} s")
    print(
        f"  output: Fortran-ordered {fortran}, pandas blocks {one_block}, peak memory of "
        f"transform {peak:.2f}x the output (2 or more would mean a copy)"
    )
    print(
        f"  plain NumPy row loop ({n_loop:,} rows, scaled)  {t_loop:8.2f} s   ratio "
        f"{t_loop / t_transform:6.1f}x   max |diff| {loop_diff:.1e}"
    )
    print(
        f"  pandas ewm(times=, adjust=False)            {t_ewm:8.3f} s   ratio "
        f"{t_ewm / t_transform:6.1f}x   max |diff| {ewm_diff:.1e}"
    )
    results["lags"] = {
        "rows": args.rows,
        "columns": args.columns,
        "time_constants": TAUS.tolist(),
        "fit_s": t_fit,
        "transform_s": t_transform,
        "fit_transform_s": total,
        "transform_array_s": t_array,
        "pandas_blocks": one_block,
        "peak_memory_over_output": peak,
        "numpy_loop_scaled_s": t_loop,
        "pandas_ewm_s": t_ewm,
        "ratio_numpy_loop": t_loop / t_transform,
        "ratio_pandas_ewm": t_ewm / t_transform,
        "max_diff_numpy_loop": loop_diff,
        "max_diff_pandas_ewm": ewm_diff,
    }


class PlainLoop:
    """The compensator written plainly: every term on its own, Python floats."""

    def __init__(self, comp):
        self.terms = comp.terms
        self.position = {name: j + 1 for j, name in enumerate(comp.inputs)}
        self.intercept = comp.intercept
        self.state = [None] * len(self.terms)
        self.time = None

    def update(self, row):
        t = row[0]
        total = self.intercept
        for k, (name, power, tau, weight) in enumerate(self.terms):
            x = float(row[self.position[name]]) ** power
            if tau is None:
                total += weight * x
                continue
            if self.time is None:
                self.state[k] = x
            else:
                a = math.exp(-(t - self.time) / tau)
                self.state[k] = (1.0 - a) * x + a * self.state[k]
            total += weight * self.state[k]
        self.time = t
        return total


class NumpyLoop:
    """The compensator as one would first write it with NumPy: the kernel's lag_step
    on an (inputs × time constants) state, exp recomputed every sample, then sums."""

    def __init__(self, comp, model):
        lags, scaler, ridge = (step for _, step in model.steps)
        names = list(comp.inputs)
        raw, sources = lags._layout(names)
        self.sources = sources
        self.raw = raw
        self.taus = lags.time_constants_
        weights = ridge.coef_ / scaler.scale_
        self.w_raw = weights[: len(raw)]
        self.w_lag = weights[len(raw) :].reshape(len(sources), self.taus.size)
        self.intercept = ridge.intercept_ - weights @ scaler.mean_
        self.state = None
        self.time = None

    def update(self, row):
        x = row[1:]
        inputs = np.array([x[j] ** p for j, p in self.sources])
        if self.state is None:
            self.state = steady_state(inputs, self.taus.size)
        else:
            a = np.exp(-(row[0] - self.time) / self.taus)
            self.state = lag_step(self.state, inputs[:, None], a)
        self.time = row[0]
        raw = np.array([x[j] ** p for j, p in self.raw])
        return float(self.intercept + np.sum(self.w_lag * self.state) + self.w_raw @ raw)


def bench_compensator(args, results):
    rng = np.random.default_rng(1)
    n = args.updates
    X = recording(n, 16, n_tests=1)
    X.insert(0, "spindle_rpm", np.repeat(rng.uniform(0, 8, n // 200 + 1), 200)[:n])
    y = rng.normal(size=n)
    model = make_pipeline(
        LagFeatures(TAUS, powers={"spindle_rpm": (1, 2)}), StandardScaler(), Ridge()
    ).fit(X, y)
    # array rows are read in the order declared (the controller's fast path)
    comp = Compensator.from_pipeline(model, row_columns=["time_s", *X.columns])
    rows = np.column_stack([X.index.get_level_values("time_s"), X.to_numpy()])

    def stream(obj):
        if hasattr(obj, "reset"):
            obj.reset()
        return [obj.update(r) for r in rows]

    t_comp = best_of(lambda: stream(comp), args.repeats) / n
    plain = PlainLoop(comp)
    t_plain = best_of(lambda: stream(PlainLoop(comp)), args.repeats) / n
    t_numpy = best_of(lambda: stream(NumpyLoop(comp, model)), args.repeats) / n
    numpy_diff = float(np.abs(np.array(stream(NumpyLoop(comp, model))) - model.predict(X)).max())
    t_batch = best_of(lambda: model.predict(X), args.repeats) / n
    diff = float(np.abs(np.array(stream(comp)) - model.predict(X)).max())
    plain_diff = float(np.abs(np.array(stream(plain)) - model.predict(X)).max())
    dicts = X.reset_index(level="time_s").to_dict("records")[:2000]
    comp.reset()
    t0 = time.perf_counter()
    for r in dicts:
        comp.update(r)
    t_dict = (time.perf_counter() - t0) / len(dicts)
    print(
        f"(b) Compensator.update, {len(comp.terms)} terms ({len(comp.inputs)} inputs), "
        f"{n:,} samples"
    )
    print(
        f"  update, array row                           {t_comp * 1e6:8.2f} us   target < 20 us: "
        f"{'PASS' if t_comp < 20e-6 else 'MISS'}"
    )
    print(f"  update, dict row                            {t_dict * 1e6:8.2f} us")
    print(
        f"  plain per-term loop                         {t_plain * 1e6:8.2f} us   ratio "
        f"{t_plain / t_comp:6.1f}x   max |diff| {plain_diff:.1e}"
    )
    print(
        f"  plain NumPy loop (lag_step, exp each sample) {t_numpy * 1e6:7.2f} us   ratio "
        f"{t_numpy / t_comp:6.1f}x   max |diff| {numpy_diff:.1e}"
    )
    print(
        f"  batch Pipeline.predict, per row             {t_batch * 1e6:8.2f} us   ratio "
        f"{t_batch / t_comp:6.2f}x   streaming vs batch max |diff| {diff:.1e}"
    )
    results["compensator"] = {
        "terms": len(comp.terms),
        "inputs": len(comp.inputs),
        "samples": n,
        "update_us": t_comp * 1e6,
        "update_dict_us": t_dict * 1e6,
        "plain_loop_us": t_plain * 1e6,
        "numpy_loop_us": t_numpy * 1e6,
        "ratio_numpy_loop": t_numpy / t_comp,
        "max_diff_numpy_loop": numpy_diff,
        "batch_predict_per_row_us": t_batch * 1e6,
        "ratio_plain_loop": t_plain / t_comp,
        "ratio_batch": t_batch / t_comp,
        "max_diff_batch": diff,
        "max_diff_plain_loop": plain_diff,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--columns", type=int, default=20)
    parser.add_argument("--loop-rows", type=int, default=20_000)
    parser.add_argument("--updates", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    results = {}
    bench_lags(args, results)
    bench_compensator(args, results)
    if args.json:
        from _common import write_json

        write_json(args.json, results, packages=["greyml", "numpy", "scipy", "pandas"])


if __name__ == "__main__":
    main()
