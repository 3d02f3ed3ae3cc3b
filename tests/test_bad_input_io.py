"""The bad-input matrix over greyml's loaders, simulator, gap diagnosis, metrics and CLI.

The data cases of :mod:`bad_inputs` run against every entry point here that
takes a table of sensors (and a target): the test-data layout checks and CSV
files of :mod:`greyml.io`, :func:`greyml.datasets.bunch_from_frame`, the
measured and the simulated side of :func:`greyml.gap.diagnose_gap`, the gap
functions, the metrics and the ``greyml`` subcommands on CSV files holding the
corrupted data. A case passes when the entry point raises ValueError or
TypeError (FileNotFoundError for a missing file) with a message that matches
the case's regular expressions; a command must exit with code 2 and print one
line ``greyml <command>: error: ...`` with no traceback. Where the entry point
is right to accept the data (a CSV file has no column types; a gap may have a
constant driver), the case must succeed with finite output.

Entry-specific bad parameters (simulator parts and presets, the synthetic data
sets, the gap's own arguments, metric inputs, command-line options) follow in
``test_bad_parameter``.
"""

import math
import re
import warnings

import numpy as np
import pandas as pd
import pytest
from bad_inputs import CASES, SENSORS, TARGET, assert_clear_message, valid_data

from greyml.cli import main
from greyml.datasets import load_caiviac, make_tests
from greyml.datasets._simulated import bunch_from_frame
from greyml.gap import diagnose_gap, gap_breakdown, residual_diagnostics
from greyml.io import check_test_frame, read_tests_csv, write_tests_csv
from greyml.metrics import correlation, improvement, nash_sutcliffe, residual_band, rmse
from greyml.simulation import (
    AmbientProfile,
    Effects,
    FBGSensor,
    HeatingTest,
    HeatSource,
    Programme,
    Segment,
    TemperatureSensor,
    ThermalMachine,
    diurnal,
    door_openings,
    gantry,
    linear_drift,
    simulate_test,
    vmc,
)
from greyml.simulation._ambient import constant
from greyml.simulation._catalogue import gantry_tests, probe_test, vmc_tests

# -- which cases make sense where --------------------------------------------

#: Cases whose X is not a table (a CSV file cannot hold them).
NOT_A_TABLE = {
    "one_dimensional_X",
    "three_dimensional_X",
    "sparse_X",
    "fewer_columns_at_predict_array",
}
#: Non-finite values: greyml's layout allows missing values (empty CSV cells
#: are NaN), so the layout checks and the CSV reader pass them on; whatever
#: uses the values rejects them.
NON_FINITE = {
    "nan_in_sensor",
    "inf_in_sensor",
    "minus_inf_in_sensor",
    "nan_in_target",
    "inf_in_target",
    "pandas_missing_value",
    "nan_in_first_row_of_a_test",
}
#: A CSV file has no column types: numbers written as text read back as numbers.
UNTYPED = {"numbers_as_text", "text_column_at_predict", "categorical_column"}
#: Column names in a CSV file are text: an integer column name reads back as "2".
#: The layout checks and the gap functions need names, not string names.
NAMED_ANYHOW = {"mixed_column_name_types"}
#: The target is a column of the same table, not a second argument.
Y_APART = {"target_length", "target_two_columns", "x_and_y_tests_disagree"}
#: Cases every metric refuses in its one input check (``_check_pair`` of
#: greyml.metrics), in the same words: rmse meets them in the matrix, the other
#: metrics in test_the_metrics_refuse_bad_pairs_in_one_voice.
PAIR_CHECKED = {
    "empty",
    "nan_in_target",
    "inf_in_target",
    "target_length",
    "target_two_columns",
    "target_text",
}


class Entry:
    """One public entry point: ``run(X, y, case, ctx)`` drives it on corrupted data.

    ``has`` are the capabilities of :class:`bad_inputs.Case` ``needs``;
    ``skip`` the cases that make no sense for it (see the sets above);
    ``accepts`` the cases it is right to accept (it must then succeed with
    finite output); ``both_stages`` lets a second-step entry (predict) read
    fit-stage cases of X too, as its input file; ``touches_y`` restricts it
    to cases that corrupt y (or the index it shares with X).
    """

    def __init__(self, name, run, has, skip=(), accepts=(), both_stages=False, touches_y=False):
        self.name = name
        self.run = run
        self.has = frozenset(has)
        self.skip = frozenset(skip)
        self.accepts = frozenset(accepts)
        self.both_stages = both_stages
        self.touches_y = touches_y


def _applies(case, entry):
    if case.name in entry.skip:
        return False
    if case.name in entry.accepts:
        return True
    if entry.touches_y and not ({"y", "index"} & case.needs or case.name == "empty"):
        return False
    if case.stage == "predict" and "fitted" not in entry.has:
        return False
    if entry.both_stages and case.stage == "fit":
        return case.needs <= {"index", "names"}
    return case.needs <= entry.has


# -- adapters ----------------------------------------------------------------


def _table(X, y):
    """Sensors and target in one frame (the target a column named dz_um)."""
    return X.assign(**{TARGET: np.asarray(y)})


def _to_csv(frame, path):
    """A plain CSV of the frame: test, time_s, then the columns (no greyml writer)."""
    frame.reset_index().to_csv(path, index=False)
    return str(path)


def _real(X, y):
    """The measurement that the valid target, given as the simulation, falls 10 % short of
    (a measurement equal to the simulation in every row is no gap, and is refused)."""
    return _table(X, y / 0.9)


def _sim(y):
    """A simulation 10 % off the measured target, on the measured rows."""
    return (0.9 * y).to_frame()


def _pred(y):
    return 0.9 * np.asarray(y.to_numpy(), dtype=float) + 0.1


class CommandFailed(ValueError):
    """A subcommand exited with code 2: its one-line message."""


def _cli(argv, capsys, outputs=()):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    if code == 0:
        assert not re.search(r"\bnan\b|\binf\b", out, re.IGNORECASE), out
        frames = [read_tests_csv(p) for p in outputs]
        return frames[0] if frames else out
    assert code == 2, (code, out, err)
    assert "Traceback" not in err and "Traceback" not in out, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, f"not one line:\n{err}"
    assert re.match(rf"greyml {argv[0]}: error: ", lines[0]), lines[0]
    raise CommandFailed(lines[0])


def run_check(X, y, case, ctx):
    return check_test_frame(X)


def run_write(X, y, case, ctx):
    path = write_tests_csv(X, ctx["tmp"] / "written.csv")
    return read_tests_csv(path)


def run_read(X, y, case, ctx):
    return read_tests_csv(_to_csv(X, ctx["tmp"] / "data.csv"))


def run_bunch(X, y, case, ctx):
    columns = list(X.columns) if isinstance(X, pd.DataFrame) else list(SENSORS)
    data = bunch_from_frame(
        X,
        sensors=columns,
        targets=[],
        sensor_groups=dict.fromkeys(columns, "spindle"),
        description="corrupted",
    )
    return data.frame


def _sensors_of(X):
    return list(X.columns) if isinstance(X, pd.DataFrame) else list(SENSORS)


def _gap_report(report):
    out = [report.gap.to_numpy(), report.corrected.to_numpy()]
    return out + [np.array([report.rmse_before, report.rmse_after, report.noise_floor])]


def run_gap_real(X, y, case, ctx):
    real = _table(X, y) if isinstance(X, pd.DataFrame) else X
    report = diagnose_gap(
        real, ctx["sim"], target=TARGET, sensors=_sensors_of(X), random_state=0, n_placebo=3
    )
    return _gap_report(report)


def run_gap_sim(X, y, case, ctx):
    sim = y.to_frame() if isinstance(y, pd.Series) else y
    report = diagnose_gap(
        ctx["real"], sim, target=TARGET, sensors=list(SENSORS), random_state=0, n_placebo=3
    )
    return _gap_report(report)


def run_breakdown(X, y, case, ctx):
    return gap_breakdown(y, drivers=X)[["n", "rms", "peak", "bias"]].to_numpy()


def run_residuals(X, y, case, ctx):
    whiteness, xcorr = residual_diagnostics(y, X)
    return [np.array([whiteness["ljung_box_q"], whiteness["p_value"]]), xcorr[["peak_corr"]]]


def _metric(function):
    def run(X, y, case, ctx):
        pred = ctx["pred"]
        if (case is None or case.name != "target_length") and len(y) < len(pred):
            pred = pred[: len(y)]
        return np.array([function(y, pred)])

    run.__name__ = function.__name__
    return run


def run_cli_fit(X, y, case, ctx):
    data = _to_csv(_table(X, y), ctx["tmp"] / "train.csv")
    model = ctx["tmp"] / "model.greyml"
    _cli(["fit", data, "--target", TARGET, "--model", "gmc", "--out", model], ctx["capsys"])
    pred = ctx["tmp"] / "pred.csv"
    # a model that was saved predicts finite values on its training data
    return _cli(["predict", model, data, "--out", pred], ctx["capsys"], [pred])


def run_cli_select(X, y, case, ctx):
    data = _to_csv(_table(X, y), ctx["tmp"] / "train.csv")
    return _cli(["select", data, "--target", TARGET, "--n-sensors", "2"], ctx["capsys"])


def run_cli_predict(X, y, case, ctx):
    data = _to_csv(X, ctx["tmp"] / "new.csv")
    pred = ctx["tmp"] / "pred.csv"
    return _cli(["predict", ctx["model"], data, "--out", pred], ctx["capsys"], [pred])


def run_cli_gap_real(X, y, case, ctx):
    real = _to_csv(_table(X, y), ctx["tmp"] / "real.csv")
    sensors = ["--sensors", ",".join(map(str, X.columns))] if len(X.columns) else []
    return _cli(
        ["gap", real, ctx["sim_csv"], "--target", TARGET, *sensors, "--random-state", 0],
        ctx["capsys"],
    )


def run_cli_gap_sim(X, y, case, ctx):
    sim = _to_csv(y.to_frame(), ctx["tmp"] / "sim.csv")
    return _cli(
        ["gap", ctx["real_csv"], sim, "--target", TARGET, "--random-state", 0], ctx["capsys"]
    )


LAYOUT = ("index", "names")
CSV_SKIP = NOT_A_TABLE | NON_FINITE
GAP_FUNCTION_SKIP = {"one_sample"}
ENTRIES = [
    Entry("check_test_frame", run_check, LAYOUT, skip=NON_FINITE, accepts=NAMED_ANYHOW),
    Entry("write_tests_csv", run_write, LAYOUT, skip=NON_FINITE, accepts=NAMED_ANYHOW),
    Entry("read_tests_csv", run_read, LAYOUT, skip=CSV_SKIP, accepts=UNTYPED | NAMED_ANYHOW),
    Entry("bunch_from_frame", run_bunch, LAYOUT, skip=NON_FINITE),
    # the gap may be explained without sensors, and a constant one is no error
    Entry(
        "diagnose_gap[measured]",
        run_gap_real,
        ("y", "index", "names", "model", "params"),
        skip=Y_APART,
        accepts={"no_columns", "constant_sensor"},
    ),
    # the simulation is matched to the measured rows by (test, time_s), not position
    Entry(
        "diagnose_gap[simulated]",
        run_gap_sim,
        ("y", "index"),
        skip={"target_length", "one_sample"},
        accepts={"target_two_columns"},
        touches_y=True,
    ),
    # y is the gap r, X the drivers / signals
    Entry(
        "gap_breakdown",
        run_breakdown,
        LAYOUT,
        accepts={"no_columns", "constant_sensor"} | NAMED_ANYHOW,
    ),
    Entry(
        "residual_diagnostics",
        run_residuals,
        ("index", "names", "model", "params"),
        accepts={"no_columns", "constant_sensor"} | NAMED_ANYHOW,
    ),
    # the metrics compare by position: test labels are for messages only
    Entry("rmse", _metric(rmse), ("y",), accepts={"x_and_y_tests_disagree"}, touches_y=True),
    Entry(
        "residual_band",
        _metric(residual_band),
        ("y",),
        accepts={"x_and_y_tests_disagree"},
        skip=PAIR_CHECKED,
        touches_y=True,
    ),
    Entry(
        "improvement",
        _metric(improvement),
        ("y",),
        accepts={"x_and_y_tests_disagree"},
        skip=PAIR_CHECKED,
        touches_y=True,
    ),
    Entry(
        "correlation",
        _metric(correlation),
        ("y", "model"),
        # overflow-free arithmetic: a metric of any finite numbers is a number
        accepts={"x_and_y_tests_disagree", "huge_in_target"},
        skip=PAIR_CHECKED,
        touches_y=True,
    ),
    Entry(
        "nash_sutcliffe",
        _metric(nash_sutcliffe),
        ("y", "model"),
        # overflow-free arithmetic: a metric of any finite numbers is a number
        accepts={"x_and_y_tests_disagree", "huge_in_target"},
        skip=PAIR_CHECKED,
        touches_y=True,
    ),
    Entry(
        "greyml fit",
        run_cli_fit,
        ("y", "index", "names", "model", "params", "constant"),
        skip=NOT_A_TABLE | Y_APART,
        accepts=UNTYPED | NAMED_ANYHOW,
    ),
    Entry(
        "greyml select",
        run_cli_select,
        ("y", "index", "names", "model", "params", "constant"),
        skip=NOT_A_TABLE | Y_APART,
        accepts=UNTYPED | NAMED_ANYHOW,
    ),
    # predict picks the model's columns by name: their order in the file is free
    # and other columns are left alone; a column renamed to "2" is one it lacks
    Entry(
        "greyml predict",
        run_cli_predict,
        ("index", "names", "fitted"),
        skip=NOT_A_TABLE | NAMED_ANYHOW,
        accepts=UNTYPED | {"column_order_at_predict", "extra_column_at_predict"},
        both_stages=True,
    ),
    Entry(
        "greyml gap[measured]",
        run_cli_gap_real,
        ("y", "index", "names", "model", "params"),
        skip=NOT_A_TABLE | Y_APART,
        accepts=UNTYPED | NAMED_ANYHOW | {"constant_sensor", "no_columns"},
    ),
    Entry(
        "greyml gap[simulated]",
        run_cli_gap_sim,
        ("y", "index"),
        skip=NOT_A_TABLE | {"target_length", "one_sample", "target_two_columns"},
        touches_y=True,
    ),
]

PAIRS = [
    pytest.param(entry, case, id=f"{entry.name}-{case.name}")
    for entry in ENTRIES
    for case in CASES
    if _applies(case, entry)
]


@pytest.fixture(scope="module")
def fitted_model(tmp_path_factory):
    """A GMC model file trained on the valid data with greyml fit."""
    folder = tmp_path_factory.mktemp("model")
    X, y = valid_data()
    data = write_tests_csv(_table(X, y), folder / "train.csv")
    model = folder / "gmc.greyml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code = main(["fit", str(data), "--target", TARGET, "--model", "gmc", "--out", str(model)])
    assert code == 0
    return model


def _finite(out):
    arrays = out if isinstance(out, list) else [out]
    for a in arrays:
        if isinstance(a, str):  # a command's report
            continue
        if isinstance(a, pd.DataFrame):
            a = a.select_dtypes("number")
        values = np.asarray(a, dtype=float)
        assert np.isfinite(values).all(), "output holds NaN or inf"


@pytest.mark.parametrize("entry, case", PAIRS)
def test_bad_input(entry, case, tmp_path, capsys, request):
    X, y = valid_data()
    X0, y0 = X.copy(), y.copy()
    ctx = {
        "tmp": tmp_path,
        "capsys": capsys,
        "sim": _sim(y),
        "real": _real(X, y),
        "pred": _pred(y),
    }
    if entry.name == "greyml predict":
        ctx["model"] = request.getfixturevalue("fitted_model")
    if entry.name.startswith("greyml gap"):
        ctx["sim_csv"] = _to_csv(_sim(y), tmp_path / "sim_valid.csv")
        ctx["real_csv"] = _to_csv(_real(X, y), tmp_path / "real_valid.csv")
    Xb, yb = case.corrupt(X, y)
    capsys.readouterr()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            out = entry.run(Xb, yb, case, ctx)
    except (ValueError, TypeError) as err:
        assert case.name not in entry.accepts, f"{entry.name} rejected {case.name}: {err}"
        assert_clear_message(entry.name, case, str(err))
    else:
        assert case.finite_ok or case.name in entry.accepts, (
            f"{entry.name} accepted {case.name} without an error"
        )
        _finite(out)
    # nothing the user gave is modified
    assert X.equals(X0) and y.equals(y0)


METRICS = {"rmse": rmse, "residual_band": residual_band, "improvement": improvement}
METRICS |= {"correlation": correlation, "nash_sutcliffe": nash_sutcliffe}


def test_the_metrics_refuse_bad_pairs_in_one_voice():
    """Each metric refuses the cases of its one input check in rmse's words (which
    the matrix checks name what was wrong)."""
    X, y = valid_data()
    X0, y0 = X.copy(), y.copy()
    ctx = {"pred": _pred(y)}
    for case in CASES:
        if case.name not in PAIR_CHECKED:
            continue
        Xb, yb = case.corrupt(X, y)
        messages = {}
        for name, function in METRICS.items():
            with pytest.raises((ValueError, TypeError)) as err:
                _metric(function)(Xb, yb, case, ctx)
            messages[name] = (type(err.value), str(err.value))
        assert len(set(messages.values())) == 1, (case.name, messages)
    # nothing the user gave is modified
    assert X.equals(X0) and y.equals(y0)


def test_matrix_size():
    """At least 30 cases run; every entry point meets a good share of them."""
    assert len(CASES) >= 30
    per_entry = {e.name: sum(_applies(c, e) for c in CASES) for e in ENTRIES}
    # (with the cases of their one input check, met in rmse's words above)
    per_entry |= {name: per_entry[name] + len(PAIR_CHECKED) for name in METRICS if name != "rmse"}
    assert min(per_entry.values()) >= 8, per_entry
    assert len(PAIRS) >= 250, len(PAIRS)
    assert len(PAIRS) + len(PARAM_CASES) + len(CLI_CASES) >= 450


# -- bad parameters of each entry point ---------------------------------------


def _machine(**changes):
    """A one-node machine (the docstring's) with some parts replaced."""
    parts = dict(
        name="block",
        nodes=("spindle",),
        capacity=(1000.0,),
        links=(),
        convection={"spindle": 10.0},
        sources=(HeatSource("motor", "spindle_rpm", {"spindle": 1.0}, 100.0, 1000.0),),
        temperature_sensors=(TemperatureSensor("T1_C", "spindle", {"spindle": 1.0}),),
        displacement={"dz_um": {"spindle": 2.0}},
        inputs=("spindle_rpm",),
        sample_s=60.0,
    )
    parts.update(changes)
    return ThermalMachine(**parts)


RUN = Programme().run(10, spindle_rpm=1000)


def _two_nodes(**changes):
    parts = dict(nodes=("spindle", "column"), capacity=(1000.0, 5000.0))
    return _machine(**{"links": (("spindle", "column", 2.0),), **parts, **changes})


def _caiviac_file(tmp_path, edit=None, text=None):
    """A tiny fake cycles.csv (two cycles of three rows) in tmp_path, corrupted."""
    probes = [f"ch{k}_um" for k in range(1, 6)]
    temps = [f"t{k}_C" for k in range(1, 17)]
    n = 6
    raw = pd.DataFrame(
        {
            "time_s": 15.0 * np.arange(n),
            "cycle": [1, 1, 1, 2, 2, 2],
            "spindle_rpm": [1250.0] * 3 + [2500.0] * 3,
            **{c: np.linspace(0.0, 1.0, n) + k for k, c in enumerate(probes)},
            **{c: 20.0 + np.linspace(0.0, 2.0, n) + k for k, c in enumerate(temps)},
        }
    )
    if edit is not None:
        raw = edit(raw)
    path = tmp_path / "cycles.csv"
    if text is not None:
        path.write_text(text)
    else:
        raw.to_csv(path, index=False)
    return path


def _set_cell(col, row, value):
    def edit(raw):
        raw = raw.astype({col: object if isinstance(value, str) else float})
        raw.loc[row, col] = value
        return raw

    return edit


def _gap_args(real, sim, **kwargs):
    return lambda: diagnose_gap(real, sim, **{"target": TARGET, "random_state": 0, **kwargs})


def _r():
    X, y = valid_data()
    return y - 0.9 * y, X


X_VALID, Y_VALID = valid_data()
REAL, SIM = _table(X_VALID, Y_VALID), _sim(Y_VALID)
GAP, SIGNALS = _r()
PRED = _pred(Y_VALID)

PARAM_CASES = [
    # -- simulator parts: constructors --------------------------------------
    (
        "HeatSource-power_W-negative",
        lambda: HeatSource("motor", "spindle_rpm", {"s": 1.0}, -5.0, 1000.0),
        r"'power_W'.*'motor'.*-5",
    ),
    (
        "HeatSource-power_W-nan",
        lambda: HeatSource("motor", "spindle_rpm", {"s": 1.0}, np.nan, 1000.0),
        r"'power_W'.*'motor'.*nan",
    ),
    (
        "HeatSource-reference-zero",
        lambda: HeatSource("motor", "spindle_rpm", {"s": 1.0}, 100.0, 0.0),
        r"'reference'.*'motor'.*0",
    ),
    (
        "HeatSource-exponent-nan",
        lambda: HeatSource("motor", "spindle_rpm", {"s": 1.0}, 100.0, 1.0, np.nan),
        r"'exponent'.*'motor'.*nan",
    ),
    (
        "HeatSource-input-unknown",
        lambda: HeatSource("motor", "laser_W", {"s": 1.0}, 100.0, 1.0),
        r"'input'.*'motor'.*'laser_W'.*spindle_rpm",
    ),
    (
        "HeatSource-nodes-empty",
        lambda: HeatSource("motor", "spindle_rpm", {}, 100.0, 1.0),
        r"'nodes'.*'motor'.*empty",
    ),
    (
        "HeatSource-nodes-sum",
        lambda: HeatSource("motor", "spindle_rpm", {"a": 0.5, "b": 0.2}, 100.0, 1.0),
        r"'motor'.*fractions.*sum to 0.7",
    ),
    (
        "HeatSource-nodes-negative",
        lambda: HeatSource("motor", "spindle_rpm", {"a": 1.5, "b": -0.5}, 100.0, 1.0),
        r"'motor'.*'b'.*-0.5",
    ),
    (
        "TemperatureSensor-lag-negative",
        lambda: TemperatureSensor("T1_C", "spindle", {"s": 1.0}, lag_s=-60.0),
        r"'lag_s'.*'T1_C'.*-60",
    ),
    (
        "TemperatureSensor-noise-nan",
        lambda: TemperatureSensor("T1_C", "spindle", {"s": 1.0}, noise_C=np.nan),
        r"'noise_C'.*'T1_C'.*nan",
    ),
    (
        "TemperatureSensor-offset-inf",
        lambda: TemperatureSensor("T1_C", "spindle", {"s": 1.0}, offset_C=np.inf),
        r"'offset_C'.*'T1_C'.*inf",
    ),
    (
        "TemperatureSensor-weights-sum",
        lambda: TemperatureSensor("T1_C", "spindle", {"s": 0.5}),
        r"'T1_C'.*weights.*sum to 0.5",
    ),
    (
        "TemperatureSensor-name-empty",
        lambda: TemperatureSensor("", "spindle", {"s": 1.0}),
        r"name.*''",
    ),
    (
        "FBGSensor-noise-negative",
        lambda: FBGSensor("FBG1_ue", "ram", {"s": 1.0}, {"s": 1.0}, noise_ue=-1.0),
        r"'noise_ue'.*'FBG1_ue'.*-1",
    ),
    (
        "FBGSensor-strain-nan",
        lambda: FBGSensor("FBG1_ue", "ram", {"s": np.nan}, {"s": 1.0}),
        r"'FBG1_ue'.*strain.*'s'.*nan",
    ),
    (
        "ThermalMachine-capacity-length",
        lambda: _machine(capacity=(1.0, 2.0)),
        r"capacity.*2 values.*1 node",
    ),
    (
        "ThermalMachine-capacity-negative",
        lambda: _machine(capacity=(-1000.0,)),
        r"capacity.*'spindle'.*-1000",
    ),
    (
        "ThermalMachine-capacity-nan",
        lambda: _machine(capacity=(np.nan,)),
        r"capacity.*'spindle'.*nan",
    ),
    ("ThermalMachine-capacity-zero", lambda: _machine(capacity=(0.0,)), r"capacity.*'spindle'.*0"),
    (
        "ThermalMachine-nodes-duplicate",
        lambda: _machine(nodes=("spindle", "spindle"), capacity=(1.0, 1.0)),
        r"node 'spindle'.*more than once",
    ),
    (
        "ThermalMachine-link-unknown-node",
        lambda: _two_nodes(links=(("spindle", "bed", 2.0),)),
        r"link.*'bed'.*nodes",
    ),
    (
        "ThermalMachine-link-negative",
        lambda: _two_nodes(links=(("spindle", "column", -2.0),)),
        r"conductance.*'spindle'.*'column'.*-2",
    ),
    (
        "ThermalMachine-link-nan",
        lambda: _two_nodes(links=(("spindle", "column", np.nan),)),
        r"conductance.*'spindle'.*'column'.*nan",
    ),
    (
        "ThermalMachine-link-self",
        lambda: _two_nodes(links=(("spindle", "spindle", 1.0),)),
        r"link.*'spindle'.*itself",
    ),
    (
        "ThermalMachine-link-shape",
        lambda: _two_nodes(links=(("spindle", 2.0),)),
        r"link.*\(node, node, conductance\)",
    ),
    (
        "ThermalMachine-convection-negative",
        lambda: _machine(convection={"spindle": -1.0}),
        r"convection.*'spindle'.*-1",
    ),
    (
        "ThermalMachine-convection-unknown",
        lambda: _machine(convection={"head": 1.0}),
        r"convection.*'head'.*nodes",
    ),
    (
        "ThermalMachine-sensor-unknown-node",
        lambda: _machine(temperature_sensors=(TemperatureSensor("T1_C", "x", {"nowhere": 1.0}),)),
        r"'T1_C'.*node 'nowhere'.*nodes",
    ),
    (
        "ThermalMachine-source-unknown-node",
        lambda: _machine(sources=(HeatSource("motor", "spindle_rpm", {"rotor": 1.0}, 1.0, 1.0),)),
        r"'motor'.*node 'rotor'",
    ),
    (
        "ThermalMachine-source-input-missing",
        lambda: _machine(sources=(HeatSource("nut", "feed_mm_min", {"spindle": 1.0}, 1.0, 1.0),)),
        r"'nut'.*'feed_mm_min'.*inputs",
    ),
    (
        "ThermalMachine-sensor-duplicate",
        lambda: _machine(
            temperature_sensors=(TemperatureSensor("T1_C", "a", {"spindle": 1.0}),) * 2
        ),
        r"'T1_C'.*more than once",
    ),
    (
        "ThermalMachine-displacement-unknown-node",
        lambda: _machine(displacement={"dz_um": {"ram": 1.0}}),
        r"'dz_um'.*node 'ram'",
    ),
    (
        "ThermalMachine-displacement-nan",
        lambda: _machine(displacement={"dz_um": {"spindle": np.nan}}),
        r"'dz_um'.*'spindle'.*nan",
    ),
    ("ThermalMachine-sample_s-zero", lambda: _machine(sample_s=0.0), r"sample_s.*0"),
    (
        "ThermalMachine-inputs-unknown",
        lambda: _machine(inputs=("spindle_rpm", "laser_W")),
        r"inputs.*'laser_W'",
    ),
    (
        "ThermalMachine-max_input-negative",
        lambda: _machine(max_input={"spindle_rpm": -1.0}),
        r"max_input.*'spindle_rpm'.*-1",
    ),
    (
        "ThermalMachine-probe_noise-negative",
        lambda: _machine(probe_noise_um={"dz_um": -0.1}),
        r"probe_noise_um.*'dz_um'.*-0.1",
    ),
    (
        "ThermalMachine-probe_drift-unknown",
        lambda: _machine(probe_drift_um_per_h={"dq_um": 0.1}),
        r"probe_drift_um_per_h.*'dq_um'",
    ),
    ("Segment-duration-zero", lambda: Segment(0.0), r"duration_s.*0"),
    ("Segment-duration-nan", lambda: Segment(np.nan), r"duration_s.*nan"),
    ("Segment-level-negative", lambda: Segment(60.0, spindle_rpm=-100.0), r"'spindle_rpm'.*-100"),
    (
        "Programme-segments-type",
        lambda: Programme(segments=(60.0,)),
        r"segment 0 is a float.*Segment",
    ),
    ("Programme-run-zero", lambda: Programme().run(0), r"duration of segment 0.*positive.*0"),
    ("Programme-run-negative", lambda: Programme().run(-5), r"duration of segment 0.*-300"),
    ("Programme-run-nan", lambda: Programme().run(np.nan), r"duration of segment 0.*nan"),
    ("Programme-run-none", lambda: Programme().run(), r"exactly one of minutes"),
    (
        "Programme-run-level-negative",
        lambda: Programme().run(10, spindle_rpm=-1),
        r"'spindle_rpm' of segment 0.*-1",
    ),
    (
        "Programme-run-level-nan",
        lambda: Programme().dwell(5).run(10, feed_mm_min=np.nan),
        r"'feed_mm_min' of segment 1.*nan",
    ),
    (
        "Programme-run-level-text",
        lambda: Programme().run(10, spindle_rpm="fast"),
        r"'spindle_rpm' of segment 0.*'fast'",
    ),
    (
        "Programme-cycle-on-zero",
        lambda: Programme().cycle(0, 10, minutes=5),
        r"'on_s'.*positive.*0",
    ),
    ("Programme-levels-unknown", lambda: RUN.levels("laser_W"), r"'laser_W'"),
    ("constant-nan", lambda: constant(np.nan), r"ambient.*finite.*nan"),
    ("constant-text", lambda: constant("warm"), r"ambient.*'warm'"),
    ("linear_drift-nan", lambda: linear_drift(np.nan, 0.3), r"'start_C'.*nan"),
    ("linear_drift-rate-inf", lambda: linear_drift(20.0, np.inf), r"'rate_C_per_h'.*inf"),
    ("diurnal-period-zero", lambda: diurnal(period_h=0.0), r"'period_h'.*0"),
    ("diurnal-amplitude-nan", lambda: diurnal(amplitude_C=np.nan), r"'amplitude_C'.*nan"),
    ("door_openings-duration-nan", lambda: door_openings(duration_s=np.nan), r"duration_s.*nan"),
    ("door_openings-duration-zero", lambda: door_openings(duration_s=0), r"duration_s.*0"),
    ("door_openings-at-nan", lambda: door_openings(at_s=[60.0, np.nan]), r"at_s.*nan"),
    ("door_openings-drop-inf", lambda: door_openings(drop_C=np.inf), r"drop_C.*inf"),
    ("HeatingTest-label-empty", lambda: HeatingTest("", RUN), r"label.*''"),
    ("HeatingTest-programme-type", lambda: HeatingTest("A", "60 min"), r"programme.*'A'.*str"),
    (
        "HeatingTest-programme-empty",
        lambda: HeatingTest("A", Programme()),
        r"programme.*'A'.*empty",
    ),
    (
        "HeatingTest-ambient-nan",
        lambda: HeatingTest("A", RUN, ambient=np.nan),
        r"ambient.*'A'.*nan",
    ),
    ("HeatingTest-sample_s-zero", lambda: HeatingTest("A", RUN, sample_s=0.0), r"sample_s.*'A'.*0"),
    (
        "HeatingTest-history-type",
        lambda: HeatingTest("A", RUN, history="hot"),
        r"history.*'A'.*str",
    ),
    # -- simulate_test ----------------------------------------------------------
    (
        "simulate_test-machine-name",
        lambda: simulate_test("vmc", RUN),
        r"machine.*ThermalMachine.*str",
    ),
    (
        "simulate_test-programme-empty",
        lambda: simulate_test(_machine(), Programme()),
        r"programme is empty",
    ),
    (
        "simulate_test-programme-type",
        lambda: simulate_test(_machine(), [60.0]),
        r"programme.*Programme.*list",
    ),
    (
        "simulate_test-ambient-nan",
        lambda: simulate_test(_machine(), RUN, np.nan),
        r"ambient.*finite.*nan",
    ),
    (
        "simulate_test-ambient-text",
        lambda: simulate_test(_machine(), RUN, "warm"),
        r"ambient.*'warm'",
    ),
    (
        "simulate_test-sample_s-zero",
        lambda: simulate_test(_machine(), RUN, sample_s=0),
        r"sample_s.*positive.*0",
    ),
    (
        "simulate_test-sample_s-negative",
        lambda: simulate_test(_machine(), RUN, sample_s=-10),
        r"sample_s.*positive.*-10",
    ),
    (
        "simulate_test-sample_s-nan",
        lambda: simulate_test(_machine(), RUN, sample_s=np.nan),
        r"sample_s.*nan",
    ),
    (
        "simulate_test-sample_s-longer",
        lambda: simulate_test(_machine(), RUN, sample_s=7200),
        r"sample_s.*7200.*longer.*600",
    ),
    (
        "simulate_test-effects-type",
        lambda: simulate_test(_machine(), RUN, effects="none"),
        r"effects.*Effects.*'none'",
    ),
    ("simulate_test-effect-unknown", lambda: Effects().without("rain"), r"Unknown effect.*'rain'"),
    (
        "simulate_test-input-missing",
        lambda: simulate_test(_machine(), Programme().run(5, feed_mm_min=100)),
        r"'feed_mm_min'.*segment 0.*no such input",
    ),
    (
        "simulate_test-input-above-max",
        lambda: simulate_test(vmc(), Programme().run(5, spindle_rpm=2e12)),
        r"'spindle_rpm' = 2e\+12.*segment 0.*maximum 8000",
    ),
    (
        "simulate_test-label-none",
        lambda: simulate_test(_machine(), RUN, label=None),
        r"label.*None",
    ),
    (
        "simulate_test-random_state-text",
        lambda: simulate_test(_machine(), RUN, random_state="x"),
        r"random_state.*'x'",
    ),
    (
        "simulate_test-history-empty",
        lambda: simulate_test(_machine(), RUN, history=Programme()),
        r"history is empty",
    ),
    (
        "simulate_test-history_ambient-nan",
        lambda: simulate_test(_machine(), RUN, history=RUN, history_ambient=np.nan),
        r"history_ambient.*finite.*nan",
    ),
    # -- presets and the catalogue ---------------------------------------------
    ("vmc-measurement-unknown", lambda: vmc("laser"), r"measurement.*'laser'"),
    ("vmc-measurement-type", lambda: vmc(3), r"measurement.*3"),
    ("gantry-argument", lambda: gantry("big"), r"gantry\(\).*argument"),
    ("vmc_tests-argument", lambda: vmc_tests("I"), r"vmc_tests\(\).*argument"),
    ("probe_test-argument", lambda: probe_test(9000), r"probe_test\(\).*argument"),
    ("gantry_tests-argument", lambda: gantry_tests(3), r"gantry_tests\(\).*argument"),
    # -- the synthetic data sets ------------------------------------------------
    ("make_tests-machine-unknown", lambda: make_tests("lathe"), r"machine.*'lathe'"),
    ("make_tests-programmes-empty", lambda: make_tests("vmc", []), r"programmes is empty"),
    (
        "make_tests-programmes-item",
        lambda: make_tests("vmc", {"A": "60:spindle_rpm=4000"}),
        r"Item 'A'.*str.*Programme",
    ),
    (
        "make_tests-programme-empty",
        lambda: make_tests("vmc", {"A": Programme()}),
        r"programme of test 'A' is empty",
    ),
    (
        "make_tests-ambient-nan",
        lambda: make_tests("vmc", RUN, ambient=np.nan),
        r"ambient.*finite.*nan",
    ),
    (
        "make_tests-ambient-missing-label",
        lambda: make_tests("vmc", {"A": RUN, "B": RUN}, ambient={"A": 20.0}),
        r"ambient.*test 'B'",
    ),
    (
        "make_tests-labels-duplicate",
        lambda: make_tests("vmc", [HeatingTest("A", RUN)] * 2),
        r"unique.*'A'",
    ),
    ("make_tests-sample_s-zero", lambda: make_tests("vmc", RUN, sample_s=0), r"sample_s.*0"),
    (
        "make_tests-target-unknown",
        lambda: make_tests("vmc", RUN, return_X_y=True, target="dq_um"),
        r"target.*'dq_um'",
    ),
    (
        "make_tests-random_state-text",
        lambda: make_tests("vmc", RUN, random_state="x"),
        r"random_state.*'x'",
    ),
    (
        "bunch_from_frame-sensor-missing",
        lambda: bunch_from_frame(
            REAL, sensors=["T9_C"], targets=[TARGET], sensor_groups={"T9_C": "x"}, description=""
        ),
        r"sensors.*'T9_C'.*not a column",
    ),
    (
        "bunch_from_frame-target-missing",
        lambda: bunch_from_frame(
            REAL,
            sensors=SENSORS,
            targets=["dq_um"],
            sensor_groups=dict.fromkeys(SENSORS, "x"),
            description="",
        ),
        r"targets.*'dq_um'.*not a column",
    ),
    (
        "bunch_from_frame-group-missing",
        lambda: bunch_from_frame(
            REAL, sensors=SENSORS, targets=[TARGET], sensor_groups={"T1_C": "x"}, description=""
        ),
        r"sensor_groups.*'T2_C'",
    ),
    (
        "bunch_from_frame-sensors-string",
        lambda: bunch_from_frame(
            REAL, sensors="T1_C", targets=[TARGET], sensor_groups={}, description=""
        ),
        r"sensors.*list.*'T1_C'",
    ),
    (
        "bunch_from_frame-not-indexed",
        lambda: bunch_from_frame(
            REAL.reset_index(),
            sensors=SENSORS,
            targets=[TARGET],
            sensor_groups=dict.fromkeys(SENSORS, "x"),
            description="",
        ),
        r"'test' index level",
    ),
    # -- the real-data loader on a missing or corrupt file ----------------------
    (
        "load_caiviac-missing-folder",
        lambda tmp: load_caiviac(tmp / "nowhere"),
        r"No CAIVIAC recording.*nowhere",
    ),
    (
        "load_caiviac-missing-file",
        lambda tmp: load_caiviac(tmp / "cycles.csv"),
        r"No CAIVIAC recording.*cycles\.csv",
    ),
    (
        "load_caiviac-empty-file",
        lambda tmp: load_caiviac(_caiviac_file(tmp, text="")),
        r"cycles\.csv.*empty",
    ),
    (
        "load_caiviac-header-only",
        lambda tmp: load_caiviac(_caiviac_file(tmp, edit=lambda r: r.iloc[:0])),
        r"cycles\.csv.*no rows",
    ),
    (
        "load_caiviac-column-missing",
        lambda tmp: load_caiviac(_caiviac_file(tmp, edit=lambda r: r.drop(columns="t7_C"))),
        r"cycles\.csv.*'t7_C'",
    ),
    (
        "load_caiviac-text-cell",
        lambda tmp: load_caiviac(_caiviac_file(tmp, _set_cell("t3_C", 4, "err"))),
        r"'t3_C'.*'err'.*line 6.*not a number",
    ),
    (
        "load_caiviac-nan-cell",
        lambda tmp: load_caiviac(_caiviac_file(tmp, _set_cell("ch2_um", 1, np.nan))),
        r"'ch2_um'.*no value.*line 3.*cycle 1",
    ),
    (
        "load_caiviac-inf-cell",
        lambda tmp: load_caiviac(_caiviac_file(tmp, _set_cell("t1_C", 2, np.inf))),
        r"'t1_C'.*inf.*line 4",
    ),
    (
        "load_caiviac-cycle-fraction",
        lambda tmp: load_caiviac(_caiviac_file(tmp, _set_cell("cycle", 5, 2.5))),
        r"'cycle'.*2\.5.*line 7",
    ),
    (
        "load_caiviac-cycle-missing",
        lambda tmp: load_caiviac(_caiviac_file(tmp, _set_cell("cycle", 0, np.nan))),
        r"Line 2.*no test label in column 'cycle'",
    ),
    (
        "load_caiviac-time-back",
        lambda tmp: load_caiviac(_caiviac_file(tmp, _set_cell("time_s", 2, 0.0))),
        r"duplicate rows for test '1' at time_s 0: lines 2, 4",
    ),
    (
        "load_caiviac-cycle-split",
        lambda tmp: load_caiviac(_caiviac_file(tmp, lambda r: r.iloc[[0, 3, 1, 2, 4, 5]])),
        r"'1'.*two separate runs",
    ),
    (
        "load_caiviac-reference",
        lambda tmp: load_caiviac(_caiviac_file(tmp), reference="start"),
        r"reference.*'start'",
    ),
    (
        "load_caiviac-target",
        lambda tmp: load_caiviac(_caiviac_file(tmp), return_X_y=True, target="dz_um"),
        r"target.*'dz_um'",
    ),
    # -- the gap's own arguments -------------------------------------------------
    (
        "diagnose_gap-target-missing",
        _gap_args(REAL, SIM, target="dx_um"),
        r"target column 'dx_um' is not in the measured data",
    ),
    (
        "diagnose_gap-target-type",
        _gap_args(REAL, SIM, target=["dz_um"]),
        r"target.*one column name.*\['dz_um'\]",
    ),
    (
        "diagnose_gap-ambient-missing",
        _gap_args(REAL, SIM, ambient="air_C"),
        r"ambient column 'air_C' is not in the measured data",
    ),
    (
        "diagnose_gap-ambient-two",
        _gap_args(REAL, SIM, ambient=["T1_C", "T2_C"]),
        r"ambient.*one column",
    ),
    (
        "diagnose_gap-driver-missing",
        _gap_args(REAL, SIM, drivers=["spindle_rpm"]),
        r"drivers column 'spindle_rpm'",
    ),
    (
        "diagnose_gap-effect-unknown",
        _gap_args(REAL, SIM, effects=["rain"]),
        r"Unknown effect.*'rain'",
    ),
    ("diagnose_gap-effects-empty", _gap_args(REAL, SIM, effects=[]), r"effects= names no effect"),
    (
        "diagnose_gap-max_effects-zero",
        _gap_args(REAL, SIM, max_effects=0),
        r"'max_effects'.*diagnose_gap.*\[1, inf\).*Got 0",
    ),
    ("diagnose_gap-max_effects-float", _gap_args(REAL, SIM, max_effects=1.5), r"max_effects.*1\.5"),
    (
        "diagnose_gap-tolerance-negative",
        _gap_args(REAL, SIM, tolerance=-0.1),
        r"'tolerance'.*diagnose_gap.*\[0\.0, inf\).*Got -0\.1",
    ),
    ("diagnose_gap-tolerance-nan", _gap_args(REAL, SIM, tolerance=np.nan), r"tolerance.*nan"),
    (
        "diagnose_gap-n_placebo-zero",
        _gap_args(REAL, SIM, n_placebo=0),
        r"'n_placebo'.*diagnose_gap.*\[1, inf\).*Got 0",
    ),
    ("diagnose_gap-n_placebo-float", _gap_args(REAL, SIM, n_placebo=2.5), r"n_placebo.*2\.5"),
    (
        "diagnose_gap-min_shrinkage-nan",
        _gap_args(REAL, SIM, min_shrinkage=np.nan),
        r"min_shrinkage.*nan",
    ),
    (
        "diagnose_gap-tie_tolerance-negative",
        _gap_args(REAL, SIM, tie_tolerance=-1.0),
        r"tie_tolerance.*-1",
    ),
    (
        "diagnose_gap-random_state-text",
        _gap_args(REAL, SIM, random_state="x"),
        r"random_state.*'x'",
    ),
    (
        "diagnose_gap-one-test",
        _gap_args(
            REAL.loc[["A"]],
            SIM,
        ),
        r"at least 2 tests.*1 \('A'",
    ),
    (
        "diagnose_gap-short-test",
        _gap_args(REAL.iloc[:35], SIM),
        r"Test 'B' has 5 rows.*at least 10.*5 samples",
    ),
    (
        "diagnose_gap-uneven-sampling",
        _gap_args(
            _table(
                *(
                    lambda X, y: (
                        X.iloc[[*range(10), *range(11, 56)]],
                        y.iloc[[*range(10), *range(11, 56)]],
                    )
                )(X_VALID, Y_VALID)
            ),
            SIM,
        ),
        r"sampling interval of test 'A' is not constant",
    ),
    (
        "diagnose_gap-sim-missing-rows",
        _gap_args(REAL, SIM.iloc[:-4]),
        r"simulation.*differ.*test 'B'",
    ),
    (
        "diagnose_gap-sim-no-target",
        _gap_args(REAL, SIM.assign(dx_um=1.0).rename(columns={TARGET: "dy_um"})),
        r"simulation has no column 'dz_um'",
    ),
    (
        "diagnose_gap-sim-callable",
        _gap_args(REAL, lambda real: real[TARGET].to_numpy()),
        r"callable sim.*ndarray",
    ),
    (
        "diagnose_gap-sim-nan",
        _gap_args(REAL, SIM.assign(dz_um=SIM[TARGET].where(SIM[TARGET].index != ("B", 100.0)))),
        r"simulated target 'dz_um' has NaN in test 'B' at time_s=100",
    ),
    (
        "diagnose_gap-sensitivities-nan",
        _gap_args(
            REAL, SIM, sensitivities=SIM.rename(columns={TARGET: "gain"}).assign(gain=np.nan)
        ),
        r"Sensitivity 'gain' has NaN in test 'A'",
    ),
    (
        "diagnose_gap-real-type",
        _gap_args(REAL.to_numpy(), SIM),
        r"measured data.*DataFrame.*2-D ndarray",
    ),
    (
        "diagnose_gap-real-missing-file",
        lambda tmp: diagnose_gap(tmp / "real.csv", SIM, target=TARGET),
        r"real\.csv",
    ),
    ("gap_breakdown-r-type", lambda: gap_breakdown(GAP.to_numpy()), r"gap r.*Series.*ndarray"),
    (
        "gap_breakdown-r-no-time",
        lambda: gap_breakdown(GAP.reset_index(drop=True)),
        r"'time_s' level",
    ),
    (
        "gap_breakdown-r-nan",
        lambda: gap_breakdown(GAP.where(GAP.index != ("B", 20.0))),
        r"gap has NaN in test 'B' at time_s=20",
    ),
    (
        "gap_breakdown-r-text",
        lambda: gap_breakdown(GAP.astype(str)),
        r"gap r must hold real numbers.*non-numeric dtype",
    ),
    (
        "gap_breakdown-drivers-rows",
        lambda: gap_breakdown(GAP, drivers=SIGNALS.iloc[:-1]),
        r"drivers.*r has 56 rows, drivers has 55",
    ),
    (
        "gap_breakdown-time_edges-order",
        lambda: gap_breakdown(GAP, time_edges_s=[100.0, 0.0]),
        r"'time_edges_s'.*\[100\.0, 0\.0\]",
    ),
    (
        "gap_breakdown-time_edges-short",
        lambda: gap_breakdown(GAP, time_edges_s=[0.0, 60.0]),
        r"time.*bins|edges.*rows|leave",
    ),
    (
        "gap_breakdown-bands-negative",
        lambda: gap_breakdown(GAP, bands_s=[-60.0]),
        r"'bands_s'.*-60",
    ),
    (
        "residual_diagnostics-max_lag-negative",
        lambda: residual_diagnostics(GAP, SIGNALS, max_lag_s=-1.0),
        r"'max_lag_s'.*-1",
    ),
    (
        "residual_diagnostics-max_lag-nan",
        lambda: residual_diagnostics(GAP, SIGNALS, max_lag_s=np.nan),
        r"'max_lag_s'.*nan",
    ),
    (
        "residual_diagnostics-n_lags-zero",
        lambda: residual_diagnostics(GAP, SIGNALS, n_lags_whiteness=0),
        r"'n_lags_whiteness'.*0",
    ),
    (
        "residual_diagnostics-signals-type",
        lambda: residual_diagnostics(GAP, SIGNALS.to_numpy()),
        r"signals.*DataFrame.*ndarray",
    ),
    (
        "residual_diagnostics-signals-rows",
        lambda: residual_diagnostics(GAP, SIGNALS.iloc[::-1]),
        r"signals.*row 0",
    ),
    # -- metrics ------------------------------------------------------------------
    (
        "rmse-y_pred-nan",
        lambda: rmse(Y_VALID, np.where(np.arange(56) == 40, np.nan, PRED)),
        r"y_pred.*nan.*position 40",
    ),
    (
        "rmse-y_pred-inf",
        lambda: rmse(Y_VALID, np.where(np.arange(56) == 3, -np.inf, PRED)),
        r"y_pred.*inf.*position 3",
    ),
    ("rmse-lengths", lambda: rmse(Y_VALID, PRED[:50]), r"y_true has 56 values, y_pred has 50"),
    ("rmse-empty", lambda: rmse([], []), r"empty.*0 samples"),
    ("rmse-scalar", lambda: rmse(1.0, 1.0), r"y_true.*scalar"),
    (
        "rmse-2d-pred",
        lambda: rmse(Y_VALID, np.column_stack([PRED, PRED])),
        r"y_pred.*shape \(56, 2\)",
    ),
    (
        "rmse-text-pred",
        lambda: rmse([1.0, 2.0], ["1.0", "x"]),
        r"y_pred.*real numbers|y_pred.*dtype",
    ),
    ("rmse-complex", lambda: rmse([1.0, 2.0], [1.0 + 1j, 2.0]), r"y_pred.*complex"),
    (
        "correlation-constant-true",
        lambda: correlation(np.full(5, 3.0), np.arange(5.0)),
        r"y_true is constant.*undefined",
    ),
    (
        "correlation-constant-pred",
        lambda: correlation(np.arange(5.0), np.zeros(5)),
        r"y_pred is constant.*undefined",
    ),
    (
        "nash_sutcliffe-constant-true",
        lambda: nash_sutcliffe(np.full(5, 3.0), np.arange(5.0)),
        r"y_true is constant.*undefined",
    ),
    (
        "improvement-zero-true",
        lambda: improvement(np.zeros(5), np.arange(5.0)),
        r"y_true is all zero.*undefined",
    ),
]


def _ambient_bad():
    class Broken(AmbientProfile):
        def __call__(self, t):
            return np.full(np.shape(t), np.nan)

    return simulate_test(_machine(), RUN, Broken())


PARAM_CASES.append(("simulate_test-ambient-profile-nan", _ambient_bad, r"ambient.*NaN.*time_s"))

# -- command-line options and files -------------------------------------------


def _sim_cli(*args):
    return lambda tmp: ["simulate", "--machine", "vmc", "--out", tmp / "s.csv", *args]


CLI_CASES = [
    (
        "simulate-machine",
        lambda tmp: ["simulate", "--machine", "lathe", "--out", tmp / "s.csv"],
        r"--machine.*'lathe'",
    ),
    ("simulate-programme-text", _sim_cli("--programme", "abc"), r"segment 'abc'.*minutes"),
    (
        "simulate-programme-zero",
        _sim_cli("--programme", "0:spindle_rpm=4000"),
        r"duration of segment 0.*positive.*0",
    ),
    ("simulate-programme-negative", _sim_cli("--programme", "-5"), r"duration of segment 0.*-300"),
    ("simulate-programme-nan", _sim_cli("--programme", "nan"), r"duration of segment 0.*nan"),
    ("simulate-programme-empty-segment", _sim_cli("--programme", "60,,30"), r"empty segment"),
    (
        "simulate-programme-level-negative",
        _sim_cli("--programme", "60:spindle_rpm=-1"),
        r"'spindle_rpm' of segment 0.*-1",
    ),
    (
        "simulate-programme-level-nan",
        _sim_cli("--programme", "60:spindle_rpm=nan"),
        r"'spindle_rpm' of segment 0.*nan",
    ),
    (
        "simulate-programme-level-text",
        _sim_cli("--programme", "60:spindle_rpm=fast"),
        r"'fast' is not a number",
    ),
    (
        "simulate-programme-input",
        _sim_cli("--programme", "60:c_rpm=100"),
        r"'c_rpm=100'.*spindle_rpm, feed_mm_min",
    ),
    (
        "simulate-programme-above-max",
        _sim_cli("--programme", "60:spindle_rpm=1e12"),
        r"'spindle_rpm' = 1e\+12.*maximum 8000",
    ),
    (
        "simulate-ambient-nan",
        _sim_cli("--programme", "60", "--ambient", "nan"),
        r"ambient.*finite.*nan",
    ),
    (
        "simulate-ambient-inf",
        _sim_cli("--programme", "60", "--ambient", "inf"),
        r"ambient.*finite.*inf",
    ),
    (
        "simulate-ambient-text",
        _sim_cli("--programme", "60", "--ambient", "warm"),
        r"--ambient.*'warm'",
    ),
    ("simulate-tests-unknown", _sim_cli("--tests", "IX"), r"--tests IX.*I, II"),
    ("simulate-tests-empty", _sim_cli("--tests", ","), r"--tests names no test"),
    (
        "simulate-programme-and-tests",
        _sim_cli("--programme", "60", "--tests", "IV"),
        r"--programme or --tests",
    ),
    (
        "simulate-seed-negative",
        _sim_cli("--programme", "60", "--random-state", "-1"),
        r"random_state|seed.*-1",
    ),
    (
        "simulate-out-folder",
        lambda tmp: ["simulate", "--machine", "vmc", "--out", tmp],
        r"is a folder",
    ),
    (
        "fit-missing-file",
        lambda tmp: [
            "fit",
            tmp / "none.csv",
            "--target",
            TARGET,
            "--model",
            "gmc",
            "--out",
            tmp / "m",
        ],
        r"none\.csv",
    ),
    (
        "fit-target-missing",
        lambda tmp: [
            "fit",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            "dx_um",
            "--model",
            "gmc",
            "--out",
            tmp / "m",
        ],
        r"--target names 'dx_um'",
    ),
    (
        "fit-sensor-missing",
        lambda tmp: [
            "fit",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--model",
            "gmc",
            "--sensors",
            "T9_C",
            "--out",
            tmp / "m",
        ],
        r"--sensors names 'T9_C'",
    ),
    (
        "fit-train-test-missing",
        lambda tmp: [
            "fit",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--model",
            "gmc",
            "--train-tests",
            "Z",
            "--out",
            tmp / "m",
        ],
        r"--train-tests: test 'Z'",
    ),
    (
        "fit-select-too-many",
        lambda tmp: [
            "fit",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--model",
            "gmc",
            "--n-sensors",
            "9",
            "--out",
            tmp / "m",
        ],
        r"--n-sensors 9.*3 candidate",
    ),
    (
        "fit-select-zero",
        lambda tmp: [
            "fit",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--model",
            "gmc",
            "--n-sensors",
            "0",
            "--out",
            tmp / "m",
        ],
        r"--n-sensors.*at least 1.*0",
    ),
    (
        "fit-model-unknown",
        lambda tmp: [
            "fit",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--model",
            "svm",
            "--out",
            tmp / "m",
        ],
        r"--model.*'svm'",
    ),
    (
        "select-n-too-many",
        lambda tmp: [
            "select",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--n-sensors",
            "9",
        ],
        r"--n-sensors 9.*3 candidate",
    ),
    (
        "select-n-zero",
        lambda tmp: [
            "select",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--n-sensors",
            "0",
        ],
        r"--n-sensors.*at least 1",
    ),
    (
        "select-train-test-missing",
        lambda tmp: [
            "select",
            _to_csv(REAL, tmp / "d.csv"),
            "--target",
            TARGET,
            "--train-tests",
            "Z",
        ],
        r"--train-tests: test 'Z'",
    ),
    (
        "predict-model-missing",
        lambda tmp: [
            "predict",
            tmp / "none.greyml",
            _to_csv(REAL, tmp / "d.csv"),
            "--out",
            tmp / "p.csv",
        ],
        r"none\.greyml.*does not exist",
    ),
    (
        "predict-model-not-a-model",
        lambda tmp: [
            "predict",
            _to_csv(REAL, tmp / "d.csv"),
            _to_csv(REAL, tmp / "e.csv"),
            "--out",
            tmp / "p.csv",
        ],
        r"d\.csv",
    ),
    (
        "gap-target-missing",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            "dx_um",
        ],
        r"target column 'dx_um'",
    ),
    (
        "gap-ambient-missing",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            TARGET,
            "--ambient",
            "air_C",
        ],
        r"ambient column 'air_C'",
    ),
    (
        "gap-effect-unknown",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            TARGET,
            "--effects",
            "rain",
        ],
        r"Unknown effect.*'rain'",
    ),
    (
        "gap-effects-empty",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            TARGET,
            "--effects",
            ",",
        ],
        r"--effects names no effect",
    ),
    (
        "gap-tolerance-negative",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            TARGET,
            "--tolerance",
            "-0.1",
        ],
        r"tolerance.*-0\.1",
    ),
    (
        "gap-tolerance-nan",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            TARGET,
            "--tolerance",
            "nan",
        ],
        r"tolerance.*nan",
    ),
    (
        "gap-sim-rows",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM.iloc[:-4], tmp / "s.csv"),
            "--target",
            TARGET,
        ],
        r"simulation.*differ.*test 'B'",
    ),
    (
        "gap-sim-nan",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(
                SIM.assign(dz_um=SIM[TARGET].where(SIM[TARGET].index != ("B", 100.0))),
                tmp / "s.csv",
            ),
            "--target",
            TARGET,
        ],
        r"simulated target 'dz_um' has NaN in test 'B' at time_s=100",
    ),
    (
        "gap-sensitivities-missing",
        lambda tmp: [
            "gap",
            _to_csv(REAL, tmp / "r.csv"),
            _to_csv(SIM, tmp / "s.csv"),
            "--target",
            TARGET,
            "--sensitivities",
            tmp / "sens.csv",
        ],
        r"sens\.csv",
    ),
]


@pytest.mark.parametrize("call, match", [pytest.param(c, m, id=n) for n, c, m in PARAM_CASES])
def test_bad_parameter(call, match, tmp_path):
    """Out-of-range, wrongly typed or inconsistent parameters fail, named."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises((ValueError, TypeError, FileNotFoundError)) as info:
            call(tmp_path) if call.__code__.co_argcount else call()
    message = str(info.value)
    assert re.search(match, message), f"message lacks {match!r}:\n{message}"
    assert not re.search(r"^\s*File |numpy\.core|ufunc", message), message


@pytest.mark.parametrize("argv, match", [pytest.param(a, m, id=n) for n, a, m in CLI_CASES])
def test_bad_command_line(argv, match, tmp_path, capsys, fitted_model):
    argv = [str(a) for a in argv(tmp_path)]
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2, (out, err)
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"greyml {argv[0]}: error: "), lines[0]
    assert re.search(match, lines[0]), f"message lacks {match!r}:\n{lines[0]}"


def test_valid_calls_are_quick_and_clean(tmp_path, capsys):
    """The valid data passes every data entry point (the matrix's baseline)."""
    X, y = valid_data()
    ctx = {
        "tmp": tmp_path,
        "capsys": capsys,
        "sim": _sim(y),
        "real": _real(X, y),
        "pred": _pred(y),
    }
    ctx["model"] = None
    ctx["sim_csv"] = _to_csv(_sim(y), tmp_path / "sim_valid.csv")
    ctx["real_csv"] = _to_csv(_real(X, y), tmp_path / "real_valid.csv")
    for entry in ENTRIES:
        if entry.name == "greyml predict":
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            _finite(entry.run(X, y, None, ctx))
    assert math.isfinite(rmse(y, _pred(y)))
