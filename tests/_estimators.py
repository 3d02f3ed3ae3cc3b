"""The one table of greyml's estimators for the suites that run over all of them.

Every suite that cuts across the estimators takes its instances from
:data:`TABLE`: scikit-learn's estimator checks (``test_sklearn_compat.py``),
the bad-input matrix (``test_bad_input.py``), greyml's model files, pickle and
joblib (``test_roundtrip.py``). A new estimator is one entry here, and every
suite it belongs to meets it; ``test_the_table_covers_every_estimator`` (in
``test_sklearn_compat.py``) fails when one is missing.

Each entry is an unfitted instance sized for speed (small swarms, few
iterations, one or two lags), used as it is by every suite it names:

``suites``
    ``"checks"``: scikit-learn's estimator checks. They give plain arrays of
    10-30 rows without greyml's ``time_s`` level, so a sequence model there
    has a ``sample_interval`` (where a ``time_s`` level is present, it wins)
    and names no column; the checks of the class alone (constructor,
    parameters, validation of bad input) run on a class's first entry, the
    checks that fit and predict on every entry. ``"bad_input"``: the bad-input matrix of
    :mod:`bad_inputs`, on two test-indexed heating tests (``make_test_index``,
    levels ``TEST_LEVEL`` and ``TIME_LEVEL``) of three sensors ``T1_C`` to
    ``T3_C``. ``"roundtrip"``: greyml's model files, pickle and joblib, fitted
    on test-indexed tests of four sensors ``T1_C`` to ``T4_C``.
``needs``
    What the bad-input matrix may ask of the entry, as the ``needs`` of
    :class:`bad_inputs.Case`: ``"y"`` (it takes a target), ``"index"`` (it
    reads test boundaries), ``"names"`` (it keeps column names), ``"fitted"``
    (a second step after fit), ``"model"`` (it learns, so one sample is too
    few), ``"params"`` (it knows how many coefficients it fits),
    ``"constant"`` (it rejects a constant sensor). ``steps`` are the methods
    after fit that the matrix calls.
``cases``
    ``None``: every case that applies. A set of case names: only those (a
    solver of a class whose other entry meets them all: its input passes the
    same validation, so only the cases whose data reach the solver are its
    own; ``test_bad_input.py::test_a_solver_is_refused_in_its_class_words``
    shows the other cases give the same messages).
``build``
    For the :class:`~greyml.Compensator`, the runtime a controller runs: the
    entry's estimator is the model it is built from (fitted first); the
    round trip then saves and pickles the compensator with its running state.
    It has no ``fit``: never in the checks nor in the bad-input matrix.

Estimators are imported through greyml's public names only.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from sklearn.linear_model import Ridge, RidgeCV
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler

from greyml import (
    AGO,
    ANFISFCM,
    GMC,
    GNNMCI,
    AccumulatedTargetRegressor,
    ANFISGrid,
    Compensator,
    GreyInfluenceSelector,
    LagFeatures,
    MLPBaseline,
    RelativeToStart,
    ThermalTransferFunction,
    TrainOnOneTest,
)

ALL = frozenset({"checks", "bad_input", "roundtrip"})
CHECKS = frozenset({"checks"})
NAMED = frozenset({"bad_input", "roundtrip"})  # names columns: not for the checks' arrays
ROUNDTRIP = frozenset({"roundtrip"})

# what a learning model meets in the bad-input matrix
MODEL = frozenset({"y", "index", "names", "fitted", "model", "params", "constant"})
# a transformer that reads the test layout and keeps names
LAYOUT = frozenset({"index", "names", "fitted"})

# the cases whose data reach a GMC solver: the fit itself runs on them
SOLVER_CASES = frozenset({"huge_sensor_values", "huge_target", "huge_values_at_predict"})


@dataclass(frozen=True)
class Entry:
    """One estimator of the table (see the module's docstring)."""

    name: str
    estimator: object
    suites: frozenset = ALL
    needs: frozenset = frozenset()
    steps: tuple = ("predict",)
    cases: frozenset | None = None
    build: Callable | None = None


def _compensator_from_pipeline(model):
    return Compensator.from_pipeline(model)


def _compensator_of(model):
    return Compensator.from_model(model)


TABLE = [
    Entry("AGO", AGO(), needs=LAYOUT, steps=("transform", "inverse_transform")),
    Entry("GMC-ls", GMC(solver="ls"), needs=MODEL),
    # the swarms and nests are cut for time (the cuckoo search's 25 × 100 cost the
    # most of any estimator over scikit-learn's checks, Abdulshahed et al.'s (2016)
    # 90 × 100 swarm ~40 s), as scikit-learn does for its own iterative
    # estimators; the default budgets are exercised in tests/test_gmc.py and
    # tests/test_gnnmci.py
    Entry(
        "GMC-pso",
        GMC(solver="pso", n_population=6, max_iter=3, random_state=0),
        needs=MODEL,
        cases=SOLVER_CASES,
    ),
    Entry(
        "GMC-cs",
        GMC(solver="cs", n_population=6, max_iter=3, random_state=0),
        needs=MODEL,
        cases=SOLVER_CASES,
    ),
    Entry("GNNMCI", GNNMCI(n_population=6, max_iter=3, random_state=0), needs=MODEL),
    Entry("ANFISGrid", ANFISGrid(max_iter=3, random_state=0), needs=MODEL),
    Entry("ANFISFCM", ANFISFCM(n_clusters=2, max_iter=3, random_state=0), needs=MODEL),
    # the defaults: scikit-learn's checks fit as few as 20 rows of 3 columns,
    # fewer than the 51 weights of a 3-10-1 network, which trains (damped
    # Levenberg-Marquardt) and warns (UnderdeterminedWarning, test_mlp.py)
    Entry("MLPBaseline", MLPBaseline(), CHECKS),
    Entry(
        "MLPBaseline-small",
        MLPBaseline(hidden_layer_sizes=2, max_iter=5, n_restarts=1, random_state=0),
        NAMED,
        # fewer rows than weights trains and warns, it is not refused:
        # test_mlp.py::test_fewer_rows_than_weights_trains_and_warns
        needs=MODEL - {"params"},
    ),
    Entry(
        "GreyInfluenceSelector",
        GreyInfluenceSelector(n_clusters=2, random_state=0),
        needs=MODEL,
        steps=("transform",),
    ),
    Entry("AccumulatedTargetRegressor", AccumulatedTargetRegressor(), CHECKS),
    # X goes to the wrapped regressor unchanged: its columns are that regressor's business
    Entry(
        "AccumulatedTargetRegressor-Ridge",
        AccumulatedTargetRegressor(Ridge()),
        needs=frozenset({"y", "index", "names", "fitted", "model"}),
    ),
    # the checks' plain arrays: evenly spaced rows sample_interval seconds apart
    Entry("LagFeatures", LagFeatures([2.0, 10.0], sample_interval=1.0), CHECKS | ROUNDTRIP),
    Entry(
        "LagFeatures-carry",
        LagFeatures([5.0], state="carry", powers=(1, 2), include_input=False, sample_interval=1.0),
        CHECKS,
    ),
    # issue 30's instance: a machine's bank, rows 15 s apart
    Entry(
        "LagFeatures-bank",
        LagFeatures(time_constants=(300.0, 2700.0), sample_interval=15.0),
        CHECKS,
    ),
    Entry(
        "LagFeatures-named-powers",
        LagFeatures([60.0, 600.0], powers={"T1_C": (1, 2)}),
        frozenset({"bad_input"}),
        needs=LAYOUT,
        steps=("transform",),
    ),
    # the recommended model. scikit-learn's checks fit as few as 10 rows of up to
    # 4 columns: fewer than the 4 x 5 gains of the default bank of four lags,
    # which the model refuses; one lag (2 gains per column; the rows said to be
    # 1 s apart) fits them
    Entry(
        "ThermalTransferFunction",
        ThermalTransferFunction(time_constants=[30.0], sample_interval=1.0),
        CHECKS,
    ),
    Entry(
        "ThermalTransferFunction-recording",
        ThermalTransferFunction(
            time_constants=[30.0], max_sensors=1, reference="recording", sample_interval=1.0
        ),
        CHECKS,
    ),
    Entry(
        "ThermalTransferFunction-restart",
        ThermalTransferFunction(
            time_constants=[30.0], reference="start", state="restart", sample_interval=1.0
        ),
        CHECKS,
    ),
    # issue 30's instance: the default bank of four lags, rows 15 s apart; the
    # checks' 10-20 rows are fewer than its 11 gains, which the ridge penalty
    # fits (UnderdeterminedWarning, test_transfer.py)
    Entry(
        "ThermalTransferFunction-bank",
        ThermalTransferFunction(max_sensors=2, sample_interval=15.0),
        CHECKS,
    ),
    # as a user fits it: a driver the controller knows (a column named in the
    # data, which the checks' arrays do not have) and a budget of sensors
    Entry(
        "ThermalTransferFunction-driver",
        ThermalTransferFunction(drivers=["T1_C"], max_sensors=2, time_constants=[60.0, 600.0]),
        NAMED,
        # fewer rows than gains fits with the ridge penalty and warns, and a
        # constant sensor is a sensor of zero gain, not an error: both checked
        # in test_bad_input.py as the model says them
        needs=MODEL - {"params", "constant"},
    ),
    # each row minus its test's first row: a subset that drops the first row
    # changes every other row (a sequence transformation, though it learns nothing)
    Entry(
        "RelativeToStart",
        RelativeToStart(),
        CHECKS | frozenset({"bad_input"}),
        needs=LAYOUT,
        steps=("transform",),
    ),
    Entry("RelativeToStart-columns", RelativeToStart(columns=[0]), CHECKS),
    # -- compositions: round-tripped (the first also in the bad-input matrix) -----
    Entry(
        "selector-GMC",
        Pipeline(
            [
                # three groups of three sensors: all kept, so GMC stays well specified
                ("select", GreyInfluenceSelector(n_clusters=3, random_state=0)),
                ("model", GMC()),
            ]
        ),
        NAMED,
        needs=MODEL,
    ),
    Entry(
        "AGO-AccumulatedTargetRegressor",
        Pipeline([("ago", AGO()), ("model", AccumulatedTargetRegressor(Ridge(alpha=0.1)))]),
        ROUNDTRIP,
    ),
    Entry(
        "LagFeatures-Ridge",
        Pipeline([("lags", LagFeatures([600.0, 1800.0])), ("model", Ridge(alpha=0.1))]),
        ROUNDTRIP,
    ),
    Entry(
        "RelativeToStart-Ridge",
        Pipeline([("rises", RelativeToStart(columns=["T1_C"])), ("model", Ridge(alpha=0.1))]),
        ROUNDTRIP,
    ),
    Entry(
        "scaler-ANFISFCM",
        Pipeline(
            [
                ("scale", StandardScaler().set_output(transform="pandas")),
                ("model", ANFISFCM(n_clusters=2, max_iter=3, random_state=0)),
            ]
        ),
        ROUNDTRIP,
    ),
    # TrainOnOneTest is a splitter, not an estimator: it travels as RidgeCV's cv
    Entry(
        "RidgeCV-TrainOnOneTest",
        RidgeCV(alphas=[0.1, 1.0, 10.0], cv=TrainOnOneTest(train_tests=["II"])),
        ROUNDTRIP,
    ),
    # -- the runtime, built from a fitted model, saved with its running state -----
    Entry(
        "Compensator-LagFeatures-Ridge",
        Pipeline(
            [("lags", LagFeatures([600.0, 1800.0], powers=(1, 2))), ("model", Ridge(alpha=0.1))]
        ),
        ROUNDTRIP,
        build=_compensator_from_pipeline,
    ),
    Entry(
        "Compensator-ThermalTransferFunction",
        ThermalTransferFunction(drivers=["T1_C"], max_sensors=2, time_constants=[600.0, 1800.0]),
        ROUNDTRIP,
        build=_compensator_of,
    ),
]

assert len({entry.name for entry in TABLE}) == len(TABLE), "two entries of one name"


def entries(suite):
    """The entries of one suite ("checks", "bad_input" or "roundtrip"), in order."""
    return [entry for entry in TABLE if suite in entry.suites]
