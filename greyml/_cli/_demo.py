"""``greyml demo``: the six models on the seeds' simulated tests, beside the papers."""

from __future__ import annotations

import os
import secrets
import shutil
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

from greyml._atomic import refusal, write_atomic
from greyml._cli import _flags as flags
from greyml._cli._files import OPERATING_COLUMNS, _check_output_folder
from greyml._cli._fitting import _final_step, _fit_quietly, _predict_quietly, _selector
from greyml._cli._interrupt import deferred
from greyml._cli._printing import _progress, _tests_words
from greyml._command_names import MODEL_NAMES

#: Sensors kept by the selector in ``greyml demo`` (Abdulshahed et al. (2015) keeps five).
DEMO_SENSORS = 5


_DEMO_EPILOG = """\
What it does:
  1. simulates Abdulshahed et al.'s (2015) six VMC tests and Abdulshahed et
     al.'s (2016) three gantry tests (greyml.datasets.load_vmc_tests,
     load_gantry_tests);
  2. on each machine, fits GMC, GNNMCI, ANFISGrid, ANFISFCM and MLPBaseline, each
     after GreyInfluenceSelector (5 sensors) in one Pipeline, on the seeds'
     training tests (VMC: Test IV; gantry: the Z-axis and C-axis tests);
  3. validates them on the other tests and prints R, RMSE, E (Nash-Sutcliffe),
     the residual band and the improvement beside what the papers report;
  4. writes one plot per model and machine (measured and predicted displacement
     over time, the residual and its band) and results.txt to --out (first
     into a hidden folder, moved to --out at the end: an interrupted run leaves
     --out as it was).

The full run takes about half a minute; --quick (smaller swarms, fewer epochs)
a few seconds.

Examples:
  greyml demo
  greyml demo --out demo-results --quick
"""


def _add_demo_parser(subparsers):
    parser = flags._subparser(subparsers, "demo", _DEMO_EPILOG)
    parser.add_argument(
        "--out",
        default="greyml-demo",
        metavar="DIR",
        help="folder for the plots and results.txt; created if absent, and it must be "
        "empty unless --force (default: greyml-demo)",
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="write into a folder that is not empty, replacing files of the same names",
    )
    parser.add_argument(
        "--quick", action="store_true", help="smaller swarms and fewer epochs: a first look"
    )
    flags._end_options(parser, flags._calls(run_demo), reads_csv=False)


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
    import numpy as np

    from greyml import TrainOnOneTest, groups_of

    if len(train_tests) == 1:
        return next(TrainOnOneTest(train_tests=list(train_tests)).split(X))
    train = np.isin(groups_of(X), list(train_tests))
    return np.flatnonzero(train), np.flatnonzero(~train)


def _demo_machine(machine, progress, *, quick):
    """Simulate, select, fit and validate the six models on one machine."""
    import numpy as np
    import pandas as pd
    from sklearn.pipeline import Pipeline

    from greyml import datasets, groups_of
    from greyml._seeds import make_model, rises, scores

    progress.step(f"simulating the {machine.label} tests")
    data = getattr(datasets, machine.loader)()
    X = rises(data.frame[data.sensors])
    y = data.frame[machine.target]
    train, valid = _split(X, machine.train)
    valid_tests = list(dict.fromkeys(groups_of(X.iloc[valid])))
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
        groups = groups_of(y_valid)
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
    import numpy as np

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
    for r in ok:
        missed = _missed(seeds["rows"].get(r["name"]), r["scores"])
        if missed:
            lines.append(
                f"  note: {r['label']} misses the paper by far ({missed}): "
                + _WHY_MISSED.get(r["name"], "see the paper's note above.")
            )
    # an unstable GMC (b1 < 0) is reported by its own GreyStabilityWarning below
    for r in run["results"]:
        for message in r.get("warnings", ()):
            lines.append(f"  note: {r['label']} warned: {message}")
    return "\n".join(_wrap(line) for line in lines)


#: Why a model can miss a seed paper's figure by far on greyml's simulated tests, by name.
_WHY_MISSED = {
    "anfis-grid": "a static map of temperatures, with many rules fitted on one test; on tests "
    "at another speed or ambient its rules extrapolate (the simulated machine is not the "
    "paper's).",
    "anfis-fcm": "a static map of temperatures fitted on one test; on tests at another speed "
    "or ambient it extrapolates (the simulated machine is not the paper's).",
    "mlp": "a static network fitted on one test; on tests at another speed or ambient it "
    "extrapolates (the simulated machine is not the paper's).",
    "gmc": "one grey response calibrated on the training test; the validation tests drive the "
    "machine differently (the simulated machine is not the paper's).",
    "gnnmci": "one grey response calibrated on the training test; the validation tests drive "
    "the machine differently (the simulated machine is not the paper's).",
}


def _bound(value):
    """The number in a paper's figure: ``4.6``, ``"<5"`` -> 5, ``"80-94"`` -> 80, else None."""
    import re

    if isinstance(value, (int, float)):
        return float(value)
    found = re.search(r"-?\d+(\.\d+)?", str(value or ""))
    return float(found.group()) if found else None


def _missed(row, ours):
    """What of our scores misses the paper's by far (twice its error, or 30 points less
    improvement), as text; None when nothing does or the paper gives no figure."""
    if not row:
        return None
    out = []
    for key, what in (("RMSE", "RMSE"), ("band", "±res")):
        paper = _bound(row.get(key))
        if paper and ours.get(key, 0) > 2 * paper:
            out.append(f"{what} {ours[key]:.3g} against {row[key]} µm")
    paper = _bound(row.get("improvement"))
    if paper is not None and 100 * ours.get("improvement", 0) < paper - 30:
        out.append(f"impr% {100 * ours['improvement']:.0f} against {row['improvement']}")
    return "; ".join(out) or None


def _wrap(line, width=100):
    """Wrap a long prose line of the report, keeping its indent."""
    if len(line) <= width or "|" in line:
        return line
    indent = line[: len(line) - len(line.lstrip())]
    return textwrap.fill(
        line.strip(), width=width, initial_indent=indent, subsequent_indent=indent + "  "
    )


def _plot(path, run, result):
    """Measured against predicted over time, and the residual with its band, per test."""
    import numpy as np
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
    _write_whole(path, lambda fh: fig.savefig(fh, format="png", dpi=90))


def _write_whole(path, write):
    """``write(file)`` to a temporary file beside ``path``, then renamed to ``path``.

    Whatever stops the writing (a full disk, Ctrl-C) removes the temporary
    file, so ``path`` is whole or absent: never an empty or half-drawn PNG.
    """
    write_atomic(path, write, overwrite=True, encoding=None)


class _Staging:
    """A hidden folder that receives the demo's files, moved to ``--out`` at the end.

    When ``out`` does not exist, the folder is made beside it (with any
    missing parent folders) and renamed to ``out`` at the end; when ``out``
    exists (empty, or any folder with ``--force``), it is made inside it and
    its files are moved into ``out`` at the end. :meth:`discard` removes what
    it made, so Ctrl-C or an error leave ``--out`` as it was: a next run is
    not refused for a half-filled folder.
    """

    def __init__(self, out):
        self.out = Path(out)
        self.inside = self.out.exists()
        parent = self.out if self.inside else self.out.parent
        self.made = []  # parent folders created for it, innermost last
        name = self.out.name or "greyml-demo"
        self.folder = parent / f".{name}.{os.getpid()}.{secrets.token_hex(4)}.part"
        try:
            for folder in reversed([parent, *parent.parents]):
                if not folder.exists():
                    folder.mkdir()
                    self.made.append(folder)
            self.folder.mkdir()
        except OSError as exc:
            self.discard()
            reason = exc.strerror or type(exc).__name__
            raise ValueError(
                f"cannot create the output folder {os.fspath(self.out)!r}: {reason}."
            ) from None

    def publish(self):
        """Move the files to ``out``: a rename of the folder, or file by file into it
        (replacing only regular files: a link, pipe or device of the same name stops it)."""
        if self.inside:
            for path in self.folder.iterdir():  # all checked before the first moves
                refused = refusal(self.out / path.name)
                if refused:
                    raise ValueError(f"--out {os.fspath(self.out)!r}: {refused}")
            with deferred():  # Ctrl-C waits for the last file: no half-filled folder
                for path in sorted(self.folder.iterdir()):
                    os.replace(path, self.out / path.name)
                self.folder.rmdir()
            return
        try:
            os.rename(self.folder, self.out)
        except OSError:
            if self.out.exists():
                raise ValueError(
                    f"the output folder {os.fspath(self.out)!r} was made by something else "
                    "while the demo ran; choose another --out."
                ) from None
            raise
        self.made = []

    def discard(self):
        """Remove the hidden folder and the parent folders made for it (if still empty)."""
        shutil.rmtree(self.folder, ignore_errors=True)
        for folder in reversed(self.made):
            try:
                folder.rmdir()
            except OSError:
                break
        self.made = []


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
    _check_output_folder(out, force)
    folder = Path(out)
    staging = _Staging(folder)
    try:
        text = _demo_report(staging.folder, folder, quick=quick, quiet=quiet, start=start)
        staging.publish()
    except OSError as exc:  # a full disk, a folder removed meanwhile
        reason = exc.strerror or str(exc)
        raise ValueError(
            f"cannot write the demo's files to {os.fspath(folder)!r}: {reason}; "
            "nothing was written there."
        ) from None
    finally:
        staging.discard()
    print(text)
    return 0


def _demo_report(staging, folder, *, quick, quiet, start):
    """Fit, plot and write ``results.txt`` into ``staging``; return the report's text.

    ``folder`` is where the files will be (named in the report).
    """
    from greyml._seeds import SEED_RESULTS

    progress = _progress(len(_DEMO_MACHINES) * (2 + len(MODEL_NAMES)), quiet)
    runs = []
    written = []
    try:
        for machine in _DEMO_MACHINES:
            run = _demo_machine(machine, progress, quick=quick)
            progress.step(f"plotting the {machine.label} models")
            for r in run["results"]:
                if "prediction" in r:
                    name = f"{machine.key}_{r['name']}.png"
                    _plot(staging / name, run, r)
                    written.append(name)
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
    _write_whole(staging / "results.txt", lambda fh: fh.write((text + "\n").encode("utf-8")))
    return text
