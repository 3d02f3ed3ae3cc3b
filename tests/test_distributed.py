"""Grid search on a Dask cluster (joblib's ``dask`` backend) equals the sequential run.

A LocalCluster of two worker processes, started and closed here, stands in for
a real cluster: the workers are separate processes started by dask's nanny, as
``dask worker`` starts them, so the search really runs outside this process.
A candidate whose fit raises (ANFISGrid over its rule limit) scores NaN with
sklearn's FitFailedWarning under ``error_score=np.nan``, and its greyml error
comes back from the worker under ``error_score="raise"``.
"""

import os
from contextlib import contextmanager

import dask
import joblib
import numpy as np
import pandas as pd
import pytest
from _recordings import tiled
from distributed import Client, LocalCluster, get_task_stream
from sklearn.base import clone
from sklearn.exceptions import FitFailedWarning
from sklearn.model_selection import GridSearchCV, LeaveOneGroupOut
from sklearn.pipeline import Pipeline
from threadpoolctl import threadpool_info

from greyml import (
    ANFISFCM,
    ANFISGrid,
    GreyInfluenceSelector,
    MLPBaseline,
    RelativeToStart,
    ThermalTransferFunction,
    groups_of,
)
from greyml.datasets import load_vmc_tests
from greyml.fleet import Partitions, fit_fleet
from greyml.io import TestFiles
from greyml.metrics import get_scorer

# the variables dask's nanny sets to 1 before it spawns a worker process
THREAD_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
TIMING_KEYS = {"mean_fit_time", "std_fit_time", "mean_score_time", "std_score_time"}


@contextmanager
def _restored_environ(names):
    """Put these environment variables back as they were on exit."""
    saved = {name: os.environ.get(name) for name in names}
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    """A client of a two-process LocalCluster, one thread per worker."""
    # The nanny copies its pre-spawn variables (and PYTHONHASHSEED) into this
    # process's environment before spawning a worker: undo that afterwards.
    touched = set(dask.config.get("distributed.nanny.pre-spawn-environ")) | {"PYTHONHASHSEED"}
    with _restored_environ(touched | set(THREAD_VARS)):
        # A thread variable already set in the environment would win over
        # dask's default of 1; drop them so the workers show dask's default.
        for name in THREAD_VARS:
            os.environ.pop(name, None)
        with (
            LocalCluster(
                n_workers=2,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",  # any free port: two test processes may each start one
                local_directory=str(tmp_path_factory.mktemp("dask-workers")),
            ) as cluster,
            Client(cluster) as dask_client,
        ):
            dask_client.wait_for_workers(2)
            yield dask_client


@pytest.fixture(scope="module")
def vmc_rises():
    """Six VMC tests, every 4th sensor, as rises from each test's first reading."""
    data = load_vmc_tests()
    X = data.frame[data.sensors].iloc[:, ::4]
    X = RelativeToStart().fit_transform(X)
    return X, data.frame["dy_um"]


def _search(n_jobs):
    pipe = Pipeline(
        [
            ("select", GreyInfluenceSelector(cluster_on="series", random_state=0)),
            ("model", ANFISFCM(random_state=0)),
        ]
    )
    grid = [
        {"select__n_clusters": [3, 5], "model__n_clusters": [2, 3]},
        # a second model in place of ANFIS: random restarts drawn from its own seed
        {
            "select__n_clusters": [3],
            "model": [
                MLPBaseline(hidden_layer_sizes=4, n_restarts=2, max_iter=100, random_state=0)
            ],
        },
    ]
    return GridSearchCV(
        pipe,
        grid,
        scoring={"rmse": get_scorer("neg_rmse"), "r2": "r2"},
        refit="rmse",
        cv=LeaveOneGroupOut(),
        n_jobs=n_jobs,
    )


def _as_comparable(column):
    """A cv_results_ column of parameters as a plain list (estimators by repr)."""
    mask = np.ma.getmaskarray(column) if np.ma.isMaskedArray(column) else [False] * len(column)
    values = column.data if np.ma.isMaskedArray(column) else column
    out = []
    for masked, value in zip(mask, values):
        if masked:
            out.append("<masked>")
        elif isinstance(value, dict):
            out.append({key: repr(val) for key, val in value.items()})
        else:
            out.append(repr(value))
    return out


@pytest.mark.timeout(300)
def test_grid_search_on_dask_equals_sequential(client, vmc_rises):
    X, y = vmc_rises
    groups = groups_of(X)
    sequential = _search(n_jobs=1).fit(X, y, groups=groups)

    with get_task_stream(client) as stream, joblib.parallel_config(backend="dask"):
        distributed = _search(n_jobs=-1).fit(X, y, groups=groups)

    # the fits did run on the cluster's workers, not in this process
    workers = set(client.scheduler_info()["workers"])
    assert stream.data, "no task ran on the cluster"
    assert {task["worker"] for task in stream.data} <= workers

    seq, dist = sequential.cv_results_, distributed.cv_results_
    assert seq.keys() == dist.keys()
    assert len(seq["params"]) == 5
    for key in seq.keys() - TIMING_KEYS:
        if key == "params" or key.startswith("param_"):
            assert _as_comparable(dist[key]) == _as_comparable(seq[key]), key
        else:
            np.testing.assert_array_equal(dist[key], seq[key], err_msg=key)
    assert np.all(np.isfinite(seq["mean_test_rmse"]))

    assert distributed.best_index_ == sequential.best_index_
    assert distributed.best_score_ == sequential.best_score_
    np.testing.assert_array_equal(distributed.predict(X), sequential.predict(X))


def _thread_report():
    """Run in a worker: its thread variables and native thread pools."""
    import greyml  # noqa: F401  (loads numpy's, scipy's and scikit-learn's native libraries)
    from greyml._threads import SMALL_WORK, blas_threads_for

    pools = [(info["user_api"], info["num_threads"]) for info in threadpool_info()]
    with blas_threads_for(10 * SMALL_WORK):  # a large product: greyml leaves the setting alone
        large = [info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"]
    with blas_threads_for(SMALL_WORK / 10):  # a small one: greyml asks for one thread
        small = [info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"]
    env = {name: os.environ.get(name) for name in THREAD_VARS}
    return {"env": env, "pools": pools, "large": large, "small": small}


@pytest.mark.timeout(300)
def test_workers_run_one_thread_each(client):
    assert set(client.nthreads().values()) == {1}

    reports = client.run(_thread_report)
    assert len(reports) == 2
    for report in reports.values():
        # dask's nanny starts every worker with the BLAS/OpenMP variables at 1 ...
        assert report["env"] == dict.fromkeys(THREAD_VARS, "1")
        # ... so every native pool has one thread, BLAS included
        assert any(api == "blas" for api, _ in report["pools"])
        assert all(n == 1 for _, n in report["pools"]), report["pools"]
        # and greyml's own limit never raises it, for large products or small
        assert report["large"] and set(report["large"]) == {1}
        assert report["small"] and set(report["small"]) == {1}


# -- a candidate that fails ----------------------------------------------------

# ANFISGrid on the 4 drivers of conftest's gmc_tests: n_mfs=1 or 2 give 1 or 16
# rules; n_mfs=3 gives 81, over max_rules=20, so its fit raises greyml's ValueError
FAILING_MFS = 3
MAX_RULES_MESSAGE = (
    r"n_mfs=3 on 4 inputs would have 3 × 3 × 3 × 3 = 81 rules, more than max_rules=20"
)


def _search_with_a_failing_candidate(error_score, n_jobs):
    return GridSearchCV(
        ANFISGrid(max_iter=3, max_rules=20),
        {"n_mfs": [1, FAILING_MFS, 2]},
        scoring=get_scorer("neg_rmse"),
        cv=LeaveOneGroupOut(),
        error_score=error_score,
        n_jobs=n_jobs,
    )


def _fit_expecting_failures(search, X, y, groups):
    """Fit, requiring sklearn's warnings about the failed candidate (and only those)."""
    with (
        pytest.warns(UserWarning, match="test scores are non-finite"),
        pytest.warns(FitFailedWarning, match=MAX_RULES_MESSAGE) as caught,
    ):
        search.fit(X, y, groups=groups)
    return search, [str(w.message) for w in caught if w.category is FitFailedWarning]


@pytest.fixture
def four_drivers(gmc_tests):
    X, y = gmc_tests[["T1_C", "T2_C", "T3_C", "T4_C"]], gmc_tests["dz_um"]
    return X, y, groups_of(X)


@pytest.mark.timeout(300)
def test_failing_candidate_on_dask_scores_nan_and_others_finish(client, four_drivers):
    X, y, groups = four_drivers
    n_splits = len(set(groups))
    sequential, _ = _fit_expecting_failures(
        _search_with_a_failing_candidate(np.nan, n_jobs=1), X, y, groups
    )

    with get_task_stream(client) as stream, joblib.parallel_config(backend="dask"):
        distributed, messages = _fit_expecting_failures(
            _search_with_a_failing_candidate(np.nan, n_jobs=-1), X, y, groups
        )

    assert stream.data, "no task ran on the cluster"
    # sklearn's summary names how many fits failed and carries greyml's reason
    (message,) = messages
    assert f"{n_splits} fits failed out of a total of {3 * n_splits}" in message
    assert "ValueError" in message and "Use ANFISFCM" in message

    results = distributed.cv_results_
    failing = [p["n_mfs"] == FAILING_MFS for p in results["params"]]
    assert failing == [False, True, False]
    for i, fails in enumerate(failing):
        split_scores = [results[f"split{k}_test_score"][i] for k in range(n_splits)]
        if fails:
            assert np.all(np.isnan(split_scores))
            assert np.isnan(results["mean_test_score"][i])
            assert results["rank_test_score"][i] == 3  # ranked last
        else:
            assert np.all(np.isfinite(split_scores))
    # the candidates that worked score exactly as in the sequential run
    for key in ("mean_test_score", "std_test_score", "rank_test_score"):
        np.testing.assert_array_equal(results[key], sequential.cv_results_[key], err_msg=key)
    assert distributed.best_params_["n_mfs"] != FAILING_MFS
    assert distributed.best_index_ == sequential.best_index_
    np.testing.assert_array_equal(distributed.predict(X), sequential.predict(X))


@pytest.mark.timeout(300)
def test_failing_candidate_on_dask_raises_greyml_error(client, four_drivers):
    X, y, groups = four_drivers
    search = _search_with_a_failing_candidate("raise", n_jobs=-1)
    # pytest turns any warning into an error here (filterwarnings=error), so a
    # FitFailedWarning in place of the exception would fail this test
    with (
        get_task_stream(client) as stream,
        joblib.parallel_config(backend="dask"),
        pytest.raises(ValueError, match=MAX_RULES_MESSAGE) as exc_info,
    ):
        search.fit(X, y, groups=groups)
    assert stream.data, "no task ran on the cluster"
    # greyml's own exception, its whole message, back from the worker process
    assert type(exc_info.value) is ValueError
    assert str(exc_info.value).startswith("ANFISGrid with n_mfs=3 on 4 inputs")
    assert str(exc_info.value).endswith("fewer MFs, or fewer inputs.")
    assert not hasattr(search, "best_estimator_")


@pytest.mark.timeout(300)
def test_validate_withheld_on_dask_equals_the_sequential_run(client):
    from gap_harness import validate_withheld

    kwargs = dict(
        effects=("drift",),
        sizes=(10,),
        n_seeds=1,
        param_errors=(0.0,),
        pairs=(),
        n_null=1,
        n_events=1,
        n_tests=3,
        n_sensors=3,
        n_placebo=9,
        random_state=7,
    )
    sequential = validate_withheld(**kwargs).cases
    with get_task_stream(client) as stream, joblib.parallel_config(backend="dask"):
        distributed = validate_withheld(n_jobs=-1, **kwargs).cases
    assert stream.data, "no case ran on the cluster"
    assert list(distributed["withheld"]) == ["none", "drift", "event"]
    assert list(distributed["cause"]) == ["none", "drift", "none"]
    # every outcome identical, only the wall time differs
    columns = [c for c in sequential.columns if c != "seconds"]
    pd.testing.assert_frame_equal(distributed[columns], sequential[columns])


def test_a_fleet_on_dask_equals_each_machine_fitted_alone(client, tmp_path):
    """Three machines, each its own Parquet files read by the worker that fits it:
    every model equals the machine's sequential fit, bit for bit."""
    pytest.importorskip("pyarrow")
    machines = {}
    for k in range(3):
        X, y = tiled(3, hours=12.0, seed=k)
        folder = tmp_path / f"machine{k}"
        folder.mkdir()
        flat = X.reset_index().assign(dx_um=y)
        flat.iloc[:300].to_parquet(folder / "a.parquet")
        flat.iloc[300:].to_parquet(folder / "b.parquet")
        machines[f"vmc-{k}"] = TestFiles(folder, "dx_um", each="recording", rows=500)
    model = ThermalTransferFunction(drivers=["spindle_rpm"])
    alone = fit_fleet(model, machines)
    with get_task_stream(client) as stream:
        on_cluster = fit_fleet(model, machines, client=client)
    assert {task["worker"] for task in stream.data} - {None}  # ran on the workers
    assert list(on_cluster) == ["vmc-0", "vmc-1", "vmc-2"]
    for name, fitted in on_cluster.items():
        np.testing.assert_array_equal(fitted.feature_coef_, alone[name].feature_coef_)
        assert fitted.selected_sensors_ == alone[name].selected_sensors_
        np.testing.assert_array_equal(
            fitted.interval_calibration_.scores, alone[name].interval_calibration_.scores
        )


def test_one_model_from_a_dask_dataframes_partitions_equals_fit(client):
    import dask.dataframe as dd

    X, y = tiled(5, hours=30.0)
    flat = X.reset_index().assign(dx_um=y)
    frame = dd.from_pandas(flat, npartitions=4, sort=False)
    model = ThermalTransferFunction(drivers=["spindle_rpm"])
    whole = clone(model).fit(X, y)
    parts = clone(model).fit_chunks(Partitions(frame, "dx_um"))
    np.testing.assert_array_equal(parts.feature_coef_, whole.feature_coef_)
    assert parts.selected_sensors_ == whole.selected_sensors_
