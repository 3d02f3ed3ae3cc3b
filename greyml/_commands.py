"""What the ``greyml`` subcommands ``demo``, ``simulate``, ``select``, ``fit`` and ``predict`` do.

:mod:`greyml.cli` parses the command line and calls one ``run_*`` function of
this module with plain values (paths, column names, numbers). The functions
check the user's input, call greyml's public API for the numerical work, print
their results to standard output and return the exit code. A user error (a
missing column, an existing output file, a test that is not in the data) is
raised as a :class:`ValueError` whose message names the file, column or test;
the command line prints it as one line.
"""

from __future__ import annotations

import io
import os
import re
import sys
import textwrap
import threading
import time
import unicodedata
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from greyml._command_names import MACHINES, MODEL_NAMES

__all__ = [
    "MODEL_NAMES",
    "Progress",
    "SEED_RESULTS",
    "make_model",
    "parse_programme",
    "printable",
    "rises",
    "run_demo",
    "run_fit",
    "run_predict",
    "run_select",
    "run_simulate",
    "scores",
]

#: Columns that are operating inputs, not sensors: left out of the candidate
#: sensors unless named with ``--sensors``.
OPERATING_COLUMNS = ("spindle_rpm", "feed_mm_min", "c_rpm", "ambient_C")


#: Share of the training data held out as checking data by ANFIS (Abdulshahed et al. (2015)
#: splits its training test into training and checking parts).
CHECKING_FRACTION = 0.15

#: Sensors kept by the selector in ``greyml demo`` (Abdulshahed et al. (2015) keeps five).
DEMO_SENSORS = 5



# ------------------------------------------------------------------------------
# The seeds' numbers
# ------------------------------------------------------------------------------

#: What the seed papers report on their own, measured machines, for the
#: models that ``greyml demo`` fits, with where each number comes from. A
#: number is a float; a bound stated in a paper's text is a string.
SEED_RESULTS = {
    "vmc": {
        "paper": "Abdulshahed et al. (2015)",
        "citation": (
            "Abdulshahed, A. M., Longstaff, A. P. and Fletcher, S. (2015). The application "
            "of ANFIS prediction models for thermal error compensation on CNC machine "
            "tools. Applied Soft Computing 27, 158-168: Section 5 and the Conclusions."
        ),
        "rows": {
            "anfis-grid": {"RMSE": None, "band": "<5", "improvement": ">80"},
            "anfis-fcm": {"RMSE": "1.7 (a)", "band": "<=4", "improvement": "80-94"},
        },
        "notes": (
            "Abdulshahed et al. (2015) gives per-test values in its Tables 6 and 7; the text that greyml "
            "holds states only the bounds quoted here: both ANFIS models keep the residual "
            "within ±5 µm on every validation test and improve accuracy by over 80 %; "
            "ANFIS-FCM keeps it within ±4 µm, with up to 94 % improvement.",
            "(a) ANFIS-FCM's RMSE is on the testing part of Test IV (Abdulshahed et al. (2015), Table 4), "
            "not on the other tests.",
            "Abdulshahed et al. (2015) reports no GMC, GNNMCI or MLP on this machine.",
        ),
    },
    "gantry": {
        "paper": "Abdulshahed et al. (2016)",
        "citation": (
            "Abdulshahed, A. M., Longstaff, A. P., Fletcher, S. and Potdar, A. (2016). "
            "Thermal error modelling of a gantry-type 5-axis machine tool using a Grey "
            "Neural Network Model. Journal of Manufacturing Systems 41, 130-142: Table 4."
        ),
        "rows": {
            "gnnmci": {"R": 0.98, "RMSE": 4.60, "E": 0.94, "band": 9.0},
            "mlp": {"R": 0.95, "RMSE": 6.82, "E": 0.92, "band": 15.0},
            "gmc": {"R": 0.83, "RMSE": 15.26, "E": 0.60, "band": 26.0},
        },
        "notes": (
            "Abdulshahed et al.'s (2016) models use its five inputs FBG-1..4 and one temperature; its MLP "
            "is a 5-10-1 network, its GMC is calibrated by least squares (GMC-LS). It "
            "reports no improvement on the helical test and no ANFIS.",
        ),
    },
}


# ------------------------------------------------------------------------------
# Models
# ------------------------------------------------------------------------------


def make_model(name, *, random_state=0, quick=False, drivers=(), max_sensors=None):
    """A greyml model by its command-line name, with the seeds' settings.

    Parameters
    ----------
    name : {"gmc", "gnnmci", "anfis-grid", "anfis-fcm", "mlp", "transfer-function"}
    random_state : int, default=0
        Seed of the model's random choices.
    quick : bool, default=False
        Smaller swarms, fewer epochs and restarts (``greyml demo --quick``).
    drivers : sequence of str, default=()
        ``"transfer-function"`` only: the columns the controller knows
        (spindle speed, feed), always inputs and not counted as sensors.
    max_sensors : int, optional
        ``"transfer-function"`` only: the budget of temperature sensors.

    Returns
    -------
    model : estimator
        Unfitted.
    description : str
        The settings in words.
    """
    from greyml import ANFISFCM, GMC, GNNMCI, ANFISGrid, MLPBaseline, ThermalTransferFunction

    if name == "transfer-function":
        model = ThermalTransferFunction(
            drivers=tuple(drivers), max_sensors=max_sensors, random_state=random_state
        )
        budget = "all sensors" if max_sensors is None else f"at most {max_sensors} sensors"
        driven = ", ".join(drivers) if drivers else "no drivers"
        return model, (
            f"thermal transfer function: lags of 5, 15, 45, 135 min, {budget}, {driven} "
            "(ThermalTransferFunction; Mares, Horejs et al. (2020))"
        )
    check = f"{100 * CHECKING_FRACTION:.0f} % checking data"
    if name == "gmc":
        return GMC(solver="ls"), "GMC(1,N) calibrated by least squares, b1 >= 0 (GMC-LS)"
    if name == "gnnmci":
        particles, iterations = (20, 20) if quick else (90, 100)
        model = GNNMCI(n_particles=particles, max_iter=iterations, random_state=random_state)
        return model, f"GNNMCI(1,N), swarm of {particles} particles x {iterations} iterations"
    if name == "anfis-grid":
        mfs, epochs = (2, 20) if quick else (3, 100)
        model = ANFISGrid(
            mfs,
            n_epochs=epochs,
            validation_fraction=CHECKING_FRACTION,
            random_state=random_state,
        )
        return model, f"ANFIS, grid of {mfs} MFs per input, {epochs} epochs, {check}"
    if name == "anfis-fcm":
        epochs = 20 if quick else 100
        model = ANFISFCM(
            3, n_epochs=epochs, validation_fraction=CHECKING_FRACTION, random_state=random_state
        )
        return model, f"ANFIS, 3 fuzzy c-means rules, {epochs} epochs, {check}"
    if name == "mlp":
        restarts, epochs = (1, 200) if quick else (5, 5000)
        model = MLPBaseline(10, max_iter=epochs, n_restarts=restarts, random_state=random_state)
        return model, (
            f"MLP, 10 log-sigmoid hidden units, Levenberg-Marquardt, up to {epochs} epochs, "
            f"{restarts} start{'s' if restarts > 1 else ''}, 15 % validation stop"
        )
    raise ValueError(f"unknown model {name!r}; choose one of {', '.join(MODEL_NAMES)}")


def _selector(n, cluster_on, random_state, *, quick=False):
    """GreyInfluenceSelector keeping ``n`` sensors; ``cluster_on=None`` is its default."""
    from greyml import GreyInfluenceSelector

    selector = GreyInfluenceSelector(n, n_init=3 if quick else 10, random_state=random_state)
    if cluster_on is not None:
        selector.set_params(cluster_on=cluster_on)
    return selector


def _progress(total, quiet):
    """Progress on standard error: off with ``quiet``, else on a terminal only."""
    return Progress(total, enabled=False if quiet else None)


def _fit_quietly(estimator, X, y):
    """Fit ``estimator``; return the seconds taken and the distinct warnings raised."""
    from threadpoolctl import threadpool_limits

    # one BLAS thread: the products are small, and on a busy machine more
    # threads only wait for each other (see greyml._threads)
    with threadpool_limits(limits=1, user_api="blas"), warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        start = time.perf_counter()
        estimator.fit(X, y)
        seconds = time.perf_counter() - start
    return seconds, list(dict.fromkeys(f"{x.category.__name__}: {x.message}" for x in w))


def _predict_quietly(estimator, X, **params):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        pred = np.asarray(estimator.predict(X, **params), dtype=float)
    return pred, list(dict.fromkeys(f"{x.category.__name__}: {x.message}" for x in w))


def _warn(command, messages):
    for message in messages:
        print(f"greyml {command}: warning: {printable(message)}", file=sys.stderr)


# ------------------------------------------------------------------------------
# Metrics and inputs
# ------------------------------------------------------------------------------


def scores(y_true, y_pred):
    """The seeds' figures of a prediction: R, RMSE, E, ±residual band, improvement.

    A figure that cannot be computed (a constant prediction has no R) is NaN.
    """
    from greyml import metrics

    out = {}
    for key, fn in (
        ("R", metrics.correlation),
        ("RMSE", metrics.rmse),
        ("E", metrics.nash_sutcliffe),
        ("band", metrics.residual_band),
        ("improvement", metrics.improvement),
    ):
        try:
            out[key] = float(fn(y_true, y_pred))
        except (ValueError, FloatingPointError):
            out[key] = float("nan")
    return out


def rises(X):
    """Each column minus its value at the first row of each test."""
    return X - X.groupby(level="test", sort=False).transform("first")


# ------------------------------------------------------------------------------
# Progress and output paths
# ------------------------------------------------------------------------------


class Progress:
    """Numbered steps and the time elapsed on one line of standard error (tqdm).

    The line shows ``[3/14] fitting ANFISFCM on the VMC… 00:12``: the step,
    what it does and the time since the command started. It is redrawn every
    second while a step runs, and cleared at the end.

    Parameters
    ----------
    total : int
        Number of steps.
    stream : file-like, optional
        Standard error by default.
    enabled : bool, optional
        Whether to show anything; by default only when ``stream`` is a
        terminal (so logs and pipes get no progress lines).
    """

    #: Seconds between redraws while a step runs (the elapsed time moves on).
    REFRESH_S = 1.0

    def __init__(self, total, stream=None, *, enabled=None):
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = bool(enabled)
        self.total = total
        self.done = 0
        self._bar = None
        self._stop = threading.Event()
        self._thread = None
        if self.enabled:
            from tqdm import tqdm

            # tqdm draws nothing on a terminal that reports no size (0 x 0):
            # give it 80 x 24 then
            try:
                size = os.get_terminal_size(self.stream.fileno())
            except (AttributeError, OSError, ValueError):
                size = None
            sized = size is not None and size.columns > 0 and size.lines > 0
            self._bar = tqdm(
                total=total,
                file=self.stream,
                leave=False,
                bar_format="{desc} {elapsed}",
                mininterval=0,
                dynamic_ncols=sized,
                **({} if sized else {"ncols": 80, "nrows": 24}),
            )
            self._thread = threading.Thread(target=self._tick, daemon=True)
            self._thread.start()

    def _tick(self):
        while not self._stop.wait(self.REFRESH_S):
            bar = self._bar
            if bar is not None:
                bar.refresh()

    def step(self, message):
        """Show step ``done + 1``: ``[3/14] fitting ANFISFCM on the VMC… 00:12``."""
        self.done += 1
        if self._bar is not None:
            self._bar.set_description_str(
                f"[{self.done}/{self.total}] {printable(message)}\u2026", refresh=False
            )
            self._bar.update(1)
            self._bar.refresh()

    def close(self):
        """Clear the progress line."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


#: ANSI escape sequences: CSI (ESC [ ... final), OSC (ESC ] ... BEL or ESC \\),
#: and two-character escapes.
_ANSI = re.compile(r"\x1b(?:\[[0-?]*[ -/]*[@-~]|\][^\x07\x1b]*(?:\x07|\x1b\\)?|[@-Z\\-_])")


def printable(text):
    """``text`` without terminal control: ANSI escapes and control characters removed.

    What a model file or a CSV file says (``greyml_version``, ``target_name_``,
    test labels) is printed through this, so a crafted file cannot clear the
    screen or rewrite the terminal's title. Line breaks and tabs become spaces.
    """
    text = _ANSI.sub("", str(text))
    return "".join(
        " " if ch in "\n\r\t" else ch
        for ch in text
        if ch in "\n\r\t" or unicodedata.category(ch) not in ("Cc", "Cf")
    )


def _prepare_output_folder(out, force):
    """Create ``out`` or check that it is an empty folder (any folder with ``force``)."""
    out = Path(out)
    if out.exists():
        if not out.is_dir():
            raise ValueError(f"--out {os.fspath(out)!r} is a file, not a folder.")
        if any(out.iterdir()) and not force:
            raise ValueError(
                f"the output folder {os.fspath(out)!r} is not empty; choose another --out, "
                "or pass --force to write into it (files of the same names are replaced)."
            )
    else:
        try:
            out.mkdir(parents=True)
        except OSError as exc:
            reason = exc.strerror or type(exc).__name__
            raise ValueError(
                f"cannot create the output folder {os.fspath(out)!r}: {reason}."
            ) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write to the output folder {os.fspath(out)!r}.")
    return out


def _check_output_file(path, force, what="--out"):
    """Refuse an existing ``path`` without ``force`` or a folder that does not exist."""
    path = Path(path)
    name = os.fspath(path)
    if path.is_dir():
        raise ValueError(f"{what} {name!r} is a folder; give a file name.")
    if path.exists() and not force:
        raise ValueError(f"{what} {name!r} exists; pass --force to replace it.")
    parent = path.parent
    if parent.exists() and not parent.is_dir():
        raise ValueError(f"cannot write {what} {name!r}: {os.fspath(parent)!r} is not a folder.")
    if not parent.is_dir():
        raise ValueError(f"the folder of {what} {name!r} does not exist: {os.fspath(parent)!r}.")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write {what} {name!r}: its folder is not writable.")
    return path


# ------------------------------------------------------------------------------
# greyml demo
# ------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Machine:
    key: str
    label: str
    loader: str
    target: str
    train: tuple
    what: str


_DEMO_MACHINES = (
    _Machine(
        "vmc",
        "VMC",
        "load_vmc_tests",
        "dy_um",
        ("IV",),
        "Abdulshahed et al.'s (2015) small vertical milling centre, 76 temperature sensors",
    ),
    _Machine(
        "gantry",
        "gantry",
        "load_gantry_tests",
        "dz_um",
        ("Z-axis", "C-axis"),
        "Abdulshahed et al.'s (2016) 5-axis gantry, 12 temperature and 7 FBG strain sensors",
    ),
)


#: Short names in the demo's table where the class name is too wide for it.
_DEMO_LABELS = {"transfer-function": "ThermalTF"}


def _split(X, train_tests):
    """Row positions to train on (``train_tests``) and to validate on (the others).

    One training test is the seeds' protocol as :class:`greyml.TrainOnOneTest`
    splits it; Abdulshahed et al. (2016) trains on two tests of the gantry.
    """
    from greyml import TrainOnOneTest, test_ids

    if len(train_tests) == 1:
        return next(TrainOnOneTest(train_tests=list(train_tests)).split(X))
    train = np.isin(test_ids(X), list(train_tests))
    return np.flatnonzero(train), np.flatnonzero(~train)


def _demo_machine(machine, progress, *, quick):
    """Simulate, select, fit and validate the six models on one machine."""
    from sklearn.pipeline import Pipeline

    from greyml import datasets, test_ids

    progress.step(f"simulating the {machine.label} tests")
    data = getattr(datasets, machine.loader)()
    X = rises(data.frame[data.sensors])
    y = data.frame[machine.target]
    train, valid = _split(X, machine.train)
    valid_tests = list(dict.fromkeys(test_ids(X.iloc[valid])))
    # the dynamic model sees what the controller knows (speeds, feed) beside the
    # temperature rises, and chooses its own sensors
    drivers = [c for c in OPERATING_COLUMNS if c in data.frame.columns and c != "ambient_C"]
    X_dynamic = pd.concat([data.frame[drivers], X], axis=1)
    results = []
    for name, label in MODEL_NAMES.items():
        label = _DEMO_LABELS.get(name, label)
        progress.step(f"fitting {label} on the {machine.label}")
        model, settings = make_model(
            name, random_state=0, quick=quick, drivers=drivers, max_sensors=DEMO_SENSORS
        )
        if name == "transfer-function":
            pipe, X_model = model, X_dynamic
        else:
            pipe, X_model = (
                Pipeline(
                    [
                        ("select", _selector(DEMO_SENSORS, "series", 0, quick=quick)),
                        ("model", model),
                    ]
                ),
                X,
            )
        result = {"name": name, "label": label, "settings": settings}
        try:
            result["fit_s"], result["warnings"] = _fit_quietly(
                pipe, X_model.iloc[train], y.iloc[train]
            )
            pred, more = _predict_quietly(pipe, X_model.iloc[valid])
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
            result["error"] = str(exc)
            results.append(result)
            continue
        result["warnings"] += [m for m in more if m not in result["warnings"]]
        y_valid = y.iloc[valid]
        if name == "transfer-function":
            result["selected"] = list(pipe.selected_sensors_)
        else:
            result["selected"] = list(pipe[0].selected_)
            result["by_selector"] = True
        b1 = getattr(_final_step(pipe), "development_coef_", None)
        result["b1"] = None if b1 is None else float(b1)
        result["scores"] = scores(y_valid.to_numpy(), pred)
        groups = test_ids(y_valid)
        result["per_test"] = {
            t: scores(y_valid.to_numpy()[groups == t], pred[groups == t]) for t in valid_tests
        }
        result["prediction"] = pd.Series(pred, index=y_valid.index)
        results.append(result)
    return {
        "machine": machine,
        "data": data,
        "y": y,
        "train_tests": list(machine.train),
        "valid_tests": valid_tests,
        "results": results,
    }


def _cell(value, digits, width):
    """One table cell with a space before it: a number, a bound from a paper's text, or ``-``.

    A number too wide for the cell is written in powers of ten.
    """
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        text = "-"
    elif isinstance(value, str):
        text = value
    else:
        for d in range(digits, -1, -1):
            text = f"{value:.{d}f}"
            if len(text) <= width - 1:
                break
        else:
            text = f"{value:.0e}"
    return " " + text.rjust(width - 1)


#: Columns of the demo's table: key, header, decimals, width.
_COLUMNS = (
    ("R", "R", 3, 7),
    ("RMSE", "RMSE", 2, 8),
    ("E", "E", 3, 7),
    ("band", "±res", 1, 7),
    ("improvement", "impr%", 0, 7),
)


def _ours(scores_):
    return "".join(
        _cell(100 * scores_[k] if k == "improvement" else scores_[k], d, w)
        for k, _, d, w in _COLUMNS
    )


def _demo_table(run, seeds):
    """The printed table of one machine: the paper's numbers beside ours."""
    machine = run["machine"]
    data = run["data"]
    paper = seeds["paper"]
    unit = "µm"
    lines = [
        f"{machine.label.upper() if machine.key == 'vmc' else machine.label.capitalize()}: "
        f"{machine.what}",
        f"  trained on {_tests_words(run['train_tests'])}, validated on "
        f"{_tests_words(run['valid_tests'])}; target {machine.target} ({unit})",
    ]
    ok = [r for r in run["results"] if "selected" in r]
    by_selector = [r for r in ok if r.get("by_selector")]
    if by_selector:
        kept = ", ".join(
            f"{s} ({data.sensor_groups.get(s, '?')})" for s in by_selector[0]["selected"]
        )
        lines.append(
            f"  sensors kept by GreyInfluenceSelector({DEMO_SENSORS}, cluster_on='series') "
            f"on the training data, from {len(data.sensors)}: {kept}"
        )
    heads = "".join(" " + h.rjust(w - 1) for _, h, _, w in _COLUMNS)
    width = len(heads)
    lw = 12  # the model column
    left = " PAPER, measured"
    right = " OURS: greyml, simulated"
    lines += [
        "",
        f"  {'':{lw}s} |{left:<{width}s} |{right}",
        f"  {'model':{lw}s} |{heads} |{heads} {'fit s':>6s}",
        "  " + "-" * (lw + 1) + "+" + "-" * (width + 1) + "+" + "-" * (width + 7),
    ]
    for r in run["results"]:
        row = seeds["rows"].get(r["name"])
        if row is None:
            left_cells = f"{'(not in the paper)':>{width}s}"
        else:
            left_cells = "".join(_cell(row.get(k), d, w) for k, _, d, w in _COLUMNS)
        if "error" in r:
            right_cells = f" failed: {r['error']}"
        else:
            right_cells = _ours(r["scores"]) + _cell(r["fit_s"], 1, 7)
        lines.append(f"  {r['label']:{lw}s} |{left_cells} |{right_cells}")
    lines += [
        "",
        "  Ours: R, RMSE and E over the validation tests together; ±res is the largest",
        f"  |measured - predicted| on any of them ({unit}); impr% = 1 - ±res / max|measured|.",
    ]
    if len(run["valid_tests"]) > 1:
        lines.append(f"  Ours by test, ±res in {unit} (impr%):")
        for r in ok:
            per = "  ".join(
                f"{t} {_cell(v['band'], 1, 7).strip()} "
                f"({_cell(100 * v['improvement'], 0, 7).strip()})"
                for t, v in r["per_test"].items()
            )
            lines.append(f"    {r['label']:{lw}s} {per}")
    lines.append(f"  Paper ({paper}): {seeds['citation']}")
    for note in seeds["notes"]:
        lines.append(f"  {note}")
    # an unstable GMC (b1 < 0) is reported by its own GreyStabilityWarning below
    for r in run["results"]:
        for message in r.get("warnings", ()):
            lines.append(f"  note: {r['label']} warned: {message}")
    return "\n".join(_wrap(line) for line in lines)


def _wrap(line, width=100):
    """Wrap a long prose line of the report, keeping its indent."""
    if len(line) <= width or "|" in line:
        return line
    indent = line[: len(line) - len(line.lstrip())]
    return textwrap.fill(
        line.strip(), width=width, initial_indent=indent, subsequent_indent=indent + "  "
    )


def _tests_words(tests):
    tests = [printable(t) for t in tests]
    names = [f"Test {t}" if len(t) <= 4 else f"the {t} test" for t in tests]
    if len(names) == 1:
        return names[0]
    return ", ".join(names[:-1]) + " and " + names[-1]


def _plot(path, run, result):
    """Measured against predicted over time, and the residual with its band, per test."""
    from matplotlib.figure import Figure

    machine = run["machine"]
    y = run["y"]
    pred = result["prediction"]
    tests = run["valid_tests"]
    width = max(3.0 * len(tests) + 1.5, 7.0)
    fig = Figure(figsize=(width, 6.0), layout="constrained")
    axes = fig.subplots(2, len(tests), squeeze=False, sharex="col")
    quantity = machine.target.removesuffix("_um")
    for k, test in enumerate(tests):
        measured = y.xs(test, level="test").to_numpy()
        predicted = pred.xs(test, level="test").to_numpy()
        minutes = y.xs(test, level="test").index.to_numpy(dtype=float) / 60.0
        residual = measured - predicted
        band = result["per_test"][test]["band"]
        top, bottom = axes[0, k], axes[1, k]
        top.plot(minutes, measured, color="black", lw=1.5, label="measured (simulated)")
        top.plot(minutes, predicted, color="C1", lw=1.5, ls="--", label="predicted")
        span = np.ptp(measured) or 1.0
        if np.all(np.isfinite(predicted)) and np.ptp(np.r_[measured, predicted]) <= 5 * span:
            pass
        else:  # keep the measurement readable when the prediction runs away
            top.set_ylim(measured.min() - span, measured.max() + span)
            top.text(
                0.5,
                0.5,
                "prediction off the scale",
                transform=top.transAxes,
                ha="center",
                color="C1",
            )
        if np.isfinite(band):
            bottom.axhspan(-band, band, color="C0", alpha=0.15, label="residual band")
            bottom.set_ylim(-1.15 * band, 1.15 * band)
        bottom.axhline(0.0, color="grey", lw=0.8)
        bottom.plot(minutes, residual, color="C0", lw=1.2, label="residual")
        name = _tests_words([test])
        top.set_title(f"{name[:1].upper()}{name[1:]}: ±{band:.3g} µm")
        bottom.set_xlabel("time from the test's start (min)")
        if k == 0:
            top.set_ylabel(f"thermal error {quantity} (µm)")
            bottom.set_ylabel("measured - predicted (µm)")
            top.legend(loc="best", fontsize="small")
            bottom.legend(loc="best", fontsize="small")
    title = (
        f"{result['label']} on the {machine.label} (greyml, simulated data): trained on "
        f"{_tests_words(run['train_tests'])}, validated on the tests shown"
    )
    fig.suptitle(textwrap.fill(title, width=int(11 * width)))
    fig.savefig(path, dpi=90)


def run_demo(out="greyml-demo", *, force=False, quick=False, quiet=False):
    """``greyml demo``: the six models on the seeds' simulated tests, beside the papers.

    Simulates Abdulshahed et al.'s (2015) VMC tests and Abdulshahed et al.'s (2016) gantry tests
    (:func:`greyml.datasets.load_vmc_tests`, :func:`~greyml.datasets.load_gantry_tests`),
    fits GMC, GNNMCI, ANFISGrid, ANFISFCM and MLPBaseline, each in a Pipeline
    after :class:`greyml.GreyInfluenceSelector`, on the seeds' training tests,
    validates them on the other tests, prints a table per machine beside the
    seeds' numbers (:data:`SEED_RESULTS`) and writes a plot per model and
    machine to ``out``.

    Parameters
    ----------
    out : str or path-like, default="greyml-demo"
        Folder for the plots and ``results.txt``; created if absent. An
        existing folder must be empty unless ``force``.
    force : bool, default=False
        Write into a non-empty folder, replacing files of the same names.
    quick : bool, default=False
        Smaller swarms, fewer epochs (for tests and a first look).
    quiet : bool, default=False
        No progress on standard error.

    Returns
    -------
    int
        0.
    """
    start = time.perf_counter()
    folder = _prepare_output_folder(out, force)
    progress = _progress(len(_DEMO_MACHINES) * (2 + len(MODEL_NAMES)), quiet)
    runs = []
    written = []
    try:
        for machine in _DEMO_MACHINES:
            run = _demo_machine(machine, progress, quick=quick)
            progress.step(f"plotting the {machine.label} models")
            for r in run["results"]:
                if "prediction" in r:
                    path = folder / f"{machine.key}_{r['name']}.png"
                    _plot(path, run, r)
                    written.append(path.name)
            runs.append(run)
    finally:
        progress.close()
    elapsed = time.perf_counter() - start
    mode = "--quick: smaller swarms, fewer epochs" if quick else "the seeds' settings"
    settings = {r["label"]: r["settings"] for r in runs[0]["results"]}
    parts = [
        "greyml demo: six thermal-error models on simulated copies of the seeds' tests, "
        "beside the numbers the seed papers report for their measured machines. The "
        "simulated machines are not the papers' machines: compare the shape of the results, "
        "not the digits.",
        "",
    ]
    for run in runs:
        parts += [_demo_table(run, SEED_RESULTS[run["machine"].key]), ""]
    parts.append(f"Model settings ({mode}); inputs are sensor rises from each test's start:")
    lw = max([12] + [len(label) for label in settings])
    parts += [f"  {label:{lw}s} {text}" for label, text in settings.items()]
    parts += [
        "",
        f"Ran in {elapsed:.1f} s with one BLAS thread. Plots (measured vs predicted over time, "
        f"residual band): {len(written)} PNG files in {os.fspath(folder)!r}; this report "
        "also in results.txt there.",
    ]
    text = "\n".join(_wrap(p) for p in parts)
    (folder / "results.txt").write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0


# ------------------------------------------------------------------------------
# greyml simulate
# ------------------------------------------------------------------------------


def parse_programme(spec, inputs):
    """A :class:`greyml.simulation.Programme` from a short text.

    Parameters
    ----------
    spec : str
        Segments separated by commas. A segment is ``MINUTES`` (everything
        stopped, the machine cools) or ``MINUTES:NAME=VALUE`` with one or more
        ``:NAME=VALUE`` parts, NAME one of ``inputs``. ``120:spindle_rpm=4000,60``
        runs the spindle at 4000 rpm for 120 min, then stops it for 60 min.
    inputs : sequence of str
        The operating inputs the machine has.

    Returns
    -------
    Programme
    """
    from greyml.simulation import Programme

    programme = Programme(name=spec.strip())
    segments = [s.strip() for s in spec.split(",")]
    if not spec.strip() or any(not s for s in segments):
        raise ValueError(
            f"--programme {spec!r} has an empty segment; write segments like "
            "'120:spindle_rpm=4000,60' separated by commas."
        )
    for segment in segments:
        minutes, *levels = [p.strip() for p in segment.split(":")]
        try:
            minutes = float(minutes)
        except ValueError:
            raise ValueError(
                f"segment {segment!r} of --programme does not start with its length in "
                "minutes (e.g. '120:spindle_rpm=4000' or '60')."
            ) from None
        values = {}
        for level in levels:
            name, sep, value = level.partition("=")
            name = name.strip()
            if not sep or name not in inputs:
                raise ValueError(
                    f"segment {segment!r} of --programme: {level!r} must be NAME=VALUE with "
                    f"NAME one of {', '.join(inputs)} (this machine's inputs)."
                )
            try:
                values[name] = float(value)
            except ValueError:
                raise ValueError(
                    f"segment {segment!r} of --programme: {value.strip()!r} is not a number."
                ) from None
        programme = programme.run(minutes, **values)
    return programme


def run_simulate(
    machine, out, *, programmes=None, tests=None, ambient=20.0, seed=0, force=False, quiet=False
):
    """``greyml simulate``: write simulated tests of a machine to a CSV file.

    Parameters
    ----------
    machine : {"vmc", "vmc-probe", "gantry"}
    out : str or path-like
        CSV file to write (:func:`greyml.io.write_tests_csv`).
    programmes : list of str, optional
        Programme specs (:func:`parse_programme`), one test each, labelled
        ``P1``, ``P2``, … Default: the seeds' tests of the machine.
    tests : list of str, optional
        Only these of the seeds' tests (by label); all by default.
    ambient : float, default=20.0
        Constant air temperature (°C) of the ``programmes`` tests.
    seed : int, default=0
        Seed of the measurement noise (``--random-state``). The seeds' tests
        with seed 0 are the data of :func:`greyml.datasets.load_vmc_tests` and
        its siblings.
    force : bool, default=False
        Replace ``out`` if it exists.
    quiet : bool, default=False
        No progress on standard error.

    Returns
    -------
    int
        0.
    """
    from greyml.datasets import make_tests
    from greyml.io import write_tests_csv
    from greyml.simulation import gantry, vmc

    if machine not in MACHINES:
        raise ValueError(f"unknown machine {machine!r}; choose one of {', '.join(MACHINES)}.")
    path = _check_output_file(out, force)
    if programmes and tests:
        raise ValueError("give --programme or --tests, not both.")
    with _progress(2, quiet) as progress:
        progress.step(f"simulating the {machine}'s tests")
        if programmes:
            preset = (
                gantry()
                if machine == "gantry"
                else vmc("probe" if machine == "vmc-probe" else "ncdt")
            )
            specs = {
                f"P{k + 1}": parse_programme(p, preset.inputs) for k, p in enumerate(programmes)
            }
            data = make_tests(machine, specs, ambient=ambient, random_state=seed)
            frame = data.frame
        else:
            data = make_tests(machine, None, random_state=seed)
            frame = data.frame
            if tests:
                missing = [t for t in tests if t not in data.tests]
                if missing:
                    raise ValueError(
                        f"--tests {', '.join(missing)}: the seeds' tests of the {machine} are "
                        f"{', '.join(data.tests)}."
                    )
                keep = frame.index.get_level_values("test").isin(tests)
                frame = frame[keep]
        progress.step(f"writing {os.fspath(path)!r}")
        write_tests_csv(frame, path, overwrite=force)
    labels = list(dict.fromkeys(frame.index.get_level_values("test")))
    print(
        f"wrote {len(frame)} rows of {len(labels)} simulated test(s) of the {machine} "
        f"({', '.join(labels)}) to {os.fspath(path)!r}: columns test, time_s, "
        f"{len(data.inputs)} operating inputs, {len(data.sensors)} sensors, targets "
        f"{', '.join(data.targets)}."
    )
    return 0


# ------------------------------------------------------------------------------
# Reading data for select, fit and predict
# ------------------------------------------------------------------------------


def _read(path, csv_options=None):
    """Read a CSV of tests; ``csv_options`` are ``time_unit``, ``sep``, ``decimal``."""
    from greyml.io import read_tests_csv

    return read_tests_csv(path, **(csv_options or {}))


def _where(frame, row, path):
    """``line L (test 'T', time_s S)`` of data row ``row`` of ``path``."""
    test, time_s = frame.index[row]
    return f"line {row + 2} of {os.fspath(path)!r} (test {test!r}, time_s {time_s:g})"


def _require_columns(frame, columns, path, flag):
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        have = ", ".join(map(str, frame.columns[:12])) + (", ..." if frame.shape[1] > 12 else "")
        raise ValueError(
            f"{flag} names {', '.join(repr(c) for c in missing)}, not a column of "
            f"{os.fspath(path)!r} (its columns: {have})."
        )


def _require_values(frame, columns, path, role):
    """Every cell of ``columns`` must hold a number."""
    for c in columns:
        gaps = np.flatnonzero(frame[c].isna().to_numpy())
        if gaps.size:
            raise ValueError(
                f"{role} column {c!r} has no value (NaN) at {_where(frame, gaps[0], path)}; "
                f"{gaps.size} row(s) are empty. Fill or drop them first."
            )


def _candidates(frame, target, sensors, path):
    if sensors:
        _require_columns(frame, sensors, path, "--sensors")
        if target in sensors:
            raise ValueError(f"--sensors names the target {target!r}; leave it out.")
        return list(sensors)
    names = [
        c
        for c in frame.columns
        if c != target and c not in OPERATING_COLUMNS and not str(c).endswith("_um")
    ]
    if not names:
        raise ValueError(
            f"{os.fspath(path)!r} has no sensor columns (0 features) besides the target "
            f"{target!r}; name them with --sensors."
        )
    return names


def _rows_of_tests(frame, tests, path, flag):
    from greyml import test_ids

    labels = test_ids(frame)
    have = list(dict.fromkeys(labels))
    missing = [t for t in tests if t not in have]
    if missing:
        raise ValueError(
            f"{flag}: test {', '.join(repr(t) for t in missing)} is not in "
            f"{os.fspath(path)!r} (its tests: {', '.join(map(str, have))})."
        )
    return np.isin(labels, list(tests))


def _load_training(data, target, sensors, tests, flag, csv_options=None):
    """The rows and columns to train on, checked."""
    frame = _read(data, csv_options)
    _require_columns(frame, [target], data, "--target")
    columns = _candidates(frame, target, sensors, data)
    if tests:
        frame = frame[_rows_of_tests(frame, tests, data, flag)]
    _require_values(frame, [target], data, "target")
    _require_values(frame, columns, data, "sensor")
    return frame, columns


# ------------------------------------------------------------------------------
# greyml select
# ------------------------------------------------------------------------------


def run_select(
    data,
    target,
    *,
    n=5,
    cluster_on=None,
    train_tests=None,
    sensors=None,
    random_state=0,
    csv_options=None,
    quiet=False,
):
    """``greyml select``: the sensors GreyInfluenceSelector keeps, with group and influence.

    Parameters
    ----------
    data : str or path-like
        CSV file of tests (:func:`greyml.io.read_tests_csv`).
    target : str
        Target column (a displacement).
    n : int, default=5
        Sensors to keep (c-means groups; ``--n-sensors``).
    cluster_on : {"series", "influence"}, optional
        GreyInfluenceSelector's default (``"influence"``) when None.
    train_tests : list of str, optional
        Select on these tests only; all tests by default.
    sensors : list of str, optional
        Candidate sensors; by default every column except the target, the
        displacements (``*_um``) and the operating inputs.
    random_state : int, default=0
    csv_options : dict, optional
        ``time_unit``, ``sep`` and ``decimal`` of :func:`greyml.io.read_tests_csv`.
    quiet : bool, default=False
        No progress on standard error.

    Returns
    -------
    int
        0.
    """
    with _progress(2, quiet) as progress:
        progress.step(f"reading {os.fspath(data)!r}")
        frame, columns = _load_training(
            data, target, sensors, train_tests, "--train-tests", csv_options
        )
        if n > len(columns):
            raise ValueError(
                f"--n-sensors {n} asks for more sensors than the {len(columns)} candidate(s) "
                f"of {os.fspath(data)!r}."
            )
        selector = _selector(n, cluster_on, random_state)
        cluster_on = selector.cluster_on
        progress.step(f"grouping {len(columns)} sensors with GreyInfluenceSelector")
        _, messages = _fit_quietly(selector, frame[columns], frame[target])
    _warn("select", messages)
    names = list(selector.feature_names_in_)
    tests = list(dict.fromkeys(frame.index.get_level_values("test")))
    print(
        f"GreyInfluenceSelector(n_clusters={n}, cluster_on={cluster_on!r}) on "
        f"{_tests_words(tests)} ({len(frame)} rows) of {os.fspath(data)!r}, target "
        f"{printable(target)!r}: "
        f"kept {len(selector.selected_)} of {len(columns)} candidate sensors."
    )
    print(f"  {'rank':>4s}  {'sensor':14s} {'group':>5s} {'influence':>10s}  sensors in the group")
    for rank, name in enumerate(selector.selected_, start=1):
        j = names.index(name)
        group = int(selector.clusters_[j])
        members = [names[i] for i in np.flatnonzero(selector.clusters_ == group)]
        listed = ", ".join(members[:6]) + (", ..." if len(members) > 6 else "")
        print(
            f"  {rank:4d}  {name:14s} {group + 1:5d} {selector.influence_[j]:10.4g}  "
            f"{len(members)}: {listed}"
        )
    print(
        "Influence: the sensor's GM(1,N) weight on the target (sensors scaled to [0, 1]); "
        "each group keeps its sensor of largest |influence|."
    )
    return 0


# ------------------------------------------------------------------------------
# greyml fit and greyml predict
# ------------------------------------------------------------------------------


def _final_step(estimator):
    steps = getattr(estimator, "steps", None)
    return steps[-1][1] if steps else estimator


def run_fit(
    data,
    target,
    model,
    out,
    *,
    select=None,
    cluster_on=None,
    sensors=None,
    train_tests=None,
    random_state=0,
    force=False,
    csv_options=None,
    quiet=False,
    drivers=None,
    max_sensors=None,
):
    """``greyml fit``: train a named model and save it with :func:`greyml.persist.save_model`.

    Parameters
    ----------
    data : str or path-like
        CSV file of tests.
    target : str
        Target column.
    model : {"gmc", "gnnmci", "anfis-grid", "anfis-fcm", "mlp"}
    out : str or path-like
        Model file to write.
    select : int, optional
        Put a GreyInfluenceSelector keeping this many sensors before the
        model, in one Pipeline.
    cluster_on : {"series", "influence"}, optional
        The selector's grouping; GreyInfluenceSelector's default when None.
    sensors : list of str, optional
        The model's inputs, or the selector's candidates with ``select``.
    train_tests : list of str, optional
        Train on these tests; all by default.
    random_state : int, default=0
    force : bool, default=False
        Replace ``out`` if it exists.
    csv_options : dict, optional
        ``time_unit``, ``sep`` and ``decimal`` of :func:`greyml.io.read_tests_csv`.
    quiet : bool, default=False
        No progress on standard error.
    drivers : list of str, optional
        ``"transfer-function"`` only: columns the controller knows (spindle
        speed, feed), always inputs, not counted as sensors.
    max_sensors : int, optional
        ``"transfer-function"`` only: the budget of temperature sensors, chosen
        inside the fit on held-out whole tests.

    Returns
    -------
    int
        0.
    """
    from sklearn.pipeline import Pipeline

    from greyml.persist import save_model

    if model not in MODEL_NAMES:
        raise ValueError(f"unknown model {model!r}; choose one of {', '.join(MODEL_NAMES)}.")
    dynamic = model == "transfer-function"
    drivers = list(drivers or [])
    if not dynamic and (drivers or max_sensors is not None):
        raise ValueError(
            "--drivers and --max-sensors are for --model transfer-function; "
            f"{model} takes its inputs from --sensors or --n-sensors."
        )
    if dynamic and select is not None:
        raise ValueError(
            "--model transfer-function chooses its own sensors: give the budget with "
            "--max-sensors instead of --n-sensors."
        )
    path = _check_output_file(out, force)
    with _progress(4, quiet) as progress:
        progress.step(f"reading {os.fspath(data)!r}")
        frame, columns = _load_training(
            data, target, sensors, train_tests, "--train-tests", csv_options
        )
        if dynamic:
            _require_columns(frame, drivers, data, "--drivers")
            _require_values(frame, drivers, data, "driver")
            columns = drivers + [c for c in columns if c not in drivers]
            if max_sensors is not None and max_sensors > len(columns) - len(drivers):
                raise ValueError(
                    f"--max-sensors {max_sensors} is more than the {len(columns) - len(drivers)} "
                    "sensor column(s) besides the drivers."
                )
        estimator, settings = make_model(
            model, random_state=random_state, drivers=drivers, max_sensors=max_sensors
        )
        n_inputs = select if select is not None else len(columns)
        if select is not None and select > len(columns):
            raise ValueError(
                f"--n-sensors {select} asks for more sensors than the {len(columns)} "
                "candidate(s)."
            )
        if model == "anfis-grid" and n_inputs > 6:
            raise ValueError(
                f"anfis-grid on {n_inputs} inputs would need {estimator.n_mfs}^{n_inputs} "
                "rules; keep a few sensors with --n-sensors 5 or --sensors, or use anfis-fcm."
            )
        if select is not None:
            estimator = Pipeline(
                [("select", _selector(select, cluster_on, random_state)), ("model", estimator)]
            )
        X, y = frame[columns], frame[target]
        progress.step(f"fitting {MODEL_NAMES[model]} on {len(frame)} rows")
        seconds, fit_messages = _fit_quietly(estimator, X, y)
        progress.step("predicting the training rows")
        pred, messages = _predict_quietly(estimator, X)
        fit_scores = scores(y.to_numpy(), pred)
        final = _final_step(estimator)
        # predict names its columns after the target: remember it in the model
        final.target_name_ = str(target)
        progress.step(f"saving {os.fspath(path)!r}")
        saved = save_model(estimator, path, overwrite=force)
    _warn("fit", fit_messages)
    _warn("fit", messages)
    inputs = list(estimator[0].selected_) if select is not None else columns
    tests = list(dict.fromkeys(frame.index.get_level_values("test")))
    print(f"trained {MODEL_NAMES[model]} ({settings}) in {seconds:.1f} s")
    print(
        f"  data: {_tests_words(tests)} of {os.fspath(data)!r} ({len(frame)} rows), "
        f"target {printable(target)!r}"
    )
    if select is not None:
        print(
            f"  inputs: {', '.join(inputs)} (kept by GreyInfluenceSelector from "
            f"{len(columns)} candidates)"
        )
    elif dynamic:
        kept = ", ".join(map(printable, estimator.selected_sensors_)) or "none"
        print(
            f"  inputs: drivers {', '.join(map(printable, drivers)) or 'none'}; sensors {kept} "
            f"(chosen inside the fit from {len(columns) - len(drivers)})"
        )
        buffer = io.StringIO()
        estimator.describe(file=buffer)
        for line in buffer.getvalue().splitlines():
            print(f"  {line}")
    else:
        shown = ", ".join(inputs[:10]) + (", ..." if len(inputs) > 10 else "")
        print(f"  inputs ({len(inputs)}): {shown}")
    print(
        f"  on the training rows: RMSE {fit_scores['RMSE']:.3g}, ±res {fit_scores['band']:.3g}, "
        f"R {fit_scores['R']:.3f} (validate on other tests with greyml predict)"
    )
    print(f"saved to {os.fspath(saved)!r}")
    return 0


def _load(model_path):
    """Load a model file (:func:`greyml.persist.load_model`); return it and its warnings.

    A file that is not a greyml model, was altered, or names a class greyml
    does not create is a ValueError with one line naming the file.
    """
    from greyml.persist import load_model

    name = os.fspath(model_path)
    if not Path(model_path).is_file():
        what = "is a folder, not a model file" if Path(model_path).is_dir() else "does not exist"
        raise ValueError(f"the model file {name!r} {what}.")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            estimator = load_model(model_path)
        except (OSError, ValueError):  # persist's messages are one line naming the file
            raise
        except Exception as exc:  # anything else: still the file's fault
            raise ValueError(
                f"{name!r} is not a greyml model file ({type(exc).__name__}: {exc})."
            ) from None
    if not hasattr(estimator, "predict"):
        raise ValueError(
            f"{name!r} holds a {type(estimator).__name__}, which does not predict; "
            "give a model written by greyml fit."
        )
    return estimator, [str(w.message) for w in caught]


def _model_inputs(estimator, path):
    """The columns a model takes, and those it reads (after its selector, if any)."""
    inputs = getattr(estimator, "feature_names_in_", None)
    if inputs is None:
        raise ValueError(
            f"the model {os.fspath(path)!r} does not record its input columns; "
            "train it on a CSV file with greyml fit."
        )
    inputs = [str(c) for c in inputs]
    steps = getattr(estimator, "steps", None)
    first = steps[0][1] if steps else None
    if first is not None and hasattr(first, "get_support") and len(steps) > 1:
        return inputs, [c for c, kept in zip(inputs, first.get_support()) if kept]
    return inputs, inputs


def _initial_displacement(text, tests, model):
    """``--initial-displacement``: a number, or TEST=VALUE pairs, for ``predict``."""
    from greyml.grey._gmc import _GreyConvolutionModel

    if text is None:
        return {}
    if not isinstance(_final_step(model), _GreyConvolutionModel):
        raise ValueError(
            "--initial-displacement is for grey models (gmc, gnnmci); this model is "
            f"{type(_final_step(model)).__name__}, which predicts each row on its own."
        )

    def number(word, what):
        try:
            value = float(word)
        except ValueError:
            value = float("nan")
        if not np.isfinite(value):
            raise ValueError(
                f"--initial-displacement: {what} must be a finite number; got {word!r}."
            )
        return value

    if "=" not in text:
        return {"initial_displacement": number(text.strip(), "VALUE")}
    by_name = {str(t): t for t in tests}
    values = {}
    for item in text.split(","):
        name, sep, word = item.partition("=")
        name = name.strip()
        if not sep or name not in by_name:
            raise ValueError(
                f"--initial-displacement: {item.strip()!r} is not TEST=VALUE for a test of the "
                f"data (its tests: {', '.join(list(by_name)[:10])})."
            )
        values[by_name[name]] = number(word.strip(), f"the value of test {name!r}")
    return {"initial_displacement": values}


def _require_finite_predictions(pred, frame, model, data):
    """Refuse NaN or infinite predictions: an empty compensation cell moves no axis."""
    bad = ~np.isfinite(pred)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        what = "every row" if bad.all() else f"{int(bad.sum())} of {bad.size} rows"
        raise ValueError(
            f"the model {os.fspath(model)!r} predicts {pred[row]} for {what} of "
            f"{os.fspath(data)!r}, first at {_where(frame, row, data)}; its coefficients may "
            "be NaN or the inputs far outside its training range. No compensation written."
        )


def run_predict(
    model, data, out, *, force=False, csv_options=None, quiet=False, initial_displacement=None
):
    """``greyml predict``: apply a saved model to tests and write the compensation.

    Parameters
    ----------
    model : str or path-like
        Model file written by ``greyml fit``.
    data : str or path-like
        CSV file of tests with the model's sensor columns.
    out : str or path-like
        CSV file to write: ``test``, ``time_s``, ``predicted_<target>`` and
        ``compensation_<target>`` (the negated prediction: the correction to
        add to the axis position).
    force : bool, default=False
        Replace ``out`` if it exists.
    csv_options : dict, optional
        ``time_unit``, ``sep`` and ``decimal`` of :func:`greyml.io.read_tests_csv`.
    quiet : bool, default=False
        No progress on standard error.
    initial_displacement : str or None, default=None
        Grey models only: ``"VALUE"`` (every test) or ``"TEST=VALUE,..."``, the
        measured target at the first row of tests that start mid-run (passed to
        the model's ``predict``).

    Returns
    -------
    int
        0.

    Raises
    ------
    ValueError
        Besides bad files and columns: when the model predicts NaN or an
        infinite value for any row (no compensation file is written then).
    """
    from greyml.io import write_tests_csv

    path = _check_output_file(out, force)
    with _progress(4, quiet) as progress:
        progress.step(f"reading the model {os.fspath(model)!r}")
        estimator, load_messages = _load(model)
        progress.step(f"reading {os.fspath(data)!r}")
        frame = _read(data, csv_options)
        inputs, used = _model_inputs(estimator, model)
        missing = [c for c in used if c not in frame.columns]
        if missing:
            have = [str(c) for c in frame.columns]
            shown = ", ".join(have[:12]) + (", ..." if len(have) > 12 else "")
            raise ValueError(
                f"the model {os.fspath(model)!r} needs the sensor column(s) "
                f"{', '.join(missing)}, which {os.fspath(data)!r} lacks (its columns: "
                f"{shown or 'none, 0 features'})."
            )
        _require_values(frame, used, data, "sensor")
        # a selector's dropped candidates are never read: the data need not have them
        X = pd.DataFrame(
            {c: frame[c] if c in frame.columns else 0.0 for c in inputs}, index=frame.index
        )
        progress.step(f"predicting {len(frame)} rows")
        tests = list(dict.fromkeys(frame.index.get_level_values("test")))
        params = _initial_displacement(initial_displacement, tests, estimator)
        pred, messages = _predict_quietly(estimator, X, **params)
        _require_finite_predictions(pred, frame, model, data)
        measured = getattr(_final_step(estimator), "target_name_", None) or "target"
        target = printable(measured)
        result = pd.DataFrame(
            {f"predicted_{target}": pred, f"compensation_{target}": -pred}, index=frame.index
        )
        progress.step(f"writing {os.fspath(path)!r}")
        write_tests_csv(result, path, overwrite=force)
    _warn("predict", load_messages)
    _warn("predict", messages)
    print(
        f"wrote {len(result)} rows of {len(tests)} test(s) to {os.fspath(path)!r}: "
        f"predicted_{target} and compensation_{target} = -predicted_{target}."
    )
    if measured in frame.columns and not frame[measured].isna().any():
        s = scores(frame[measured].to_numpy(), pred)
        print(
            f"  against the measured {target} in {os.fspath(data)!r}: RMSE {s['RMSE']:.3g}, "
            f"±res {s['band']:.3g}, R {s['R']:.3f}, E {s['E']:.3f}"
        )
    return 0
