"""``greyml fit``: train a named model and save it."""

from __future__ import annotations

import io
import os

from greyml._cli import _flags as flags
from greyml._cli._files import (
    STDOUT,
    _check_output_file,
    _load_training,
    _refuse_binary_terminal,
    _test_labels,
    _write_stdout,
)
from greyml._cli._fitting import (
    _REFERENCE_WORDS,
    _final_step,
    _fit_quietly,
    _measured,
    _predict_quietly,
    _reference,
)
from greyml._cli._model import add_model_flags, build, model_choice
from greyml._cli._printing import _progress, _tests_words, _warn, printable
from greyml._command_names import MODEL_NAMES
from greyml._docstrings import shared_doc

_FIT_EPILOG = """\
Models (the seeds' settings):
  gmc         GMC(1,N) by least squares, b1 >= 0 (GMC-LS)
  gnnmci      GNNMCI(1,N), particle swarm of 90 x 100 iterations (Abdulshahed et al. (2016))
  anfis-grid  ANFIS with 3 Gaussian MFs per input, 100 epochs (Abdulshahed et al. (2015);
              3^5 = 243 rules on 5 inputs, so give few inputs)
  anfis-fcm   ANFIS with 3 fuzzy c-means rules, 100 epochs (Abdulshahed et al. (2015))
  mlp         one hidden layer of 10, Levenberg-Marquardt (Abdulshahed et al.'s (2016) baseline)
  transfer-function
              thermal transfer functions: each input through first-order lags of
              5, 15, 45 and 135 min (Mares, Horejs et al. (2020)); --drivers for
              what the controller knows, --max-sensors for a sensor budget. Tests
              on one clock (a recording cut into cycles, --test-column cycle)
              carry their lags from one into the next, and the displacement is
              taken from the recording's zero (--state, --reference to choose)

--n-sensors N puts GreyInfluenceSelector before the model in one Pipeline, so the
saved model chooses its own sensors. The model is saved with
greyml.persist.save_model (a file that holds no code); apply it with greyml
predict.

Inputs are used as they are in the file. When tests start at different
temperatures, the static models (anfis-grid, anfis-fcm, mlp) carry over to new
tests far better on temperature rises from each test's start than on absolute
temperatures (greyml demo uses rises): --rises puts greyml.RelativeToStart
first in the saved Pipeline, so every input but the --drivers becomes its
rise from each test's first row, in fit and in greyml predict alike.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml fit vmc.csv --target dy_um --model anfis-fcm --n-sensors 5 \\
      --train-tests IV --out vmc-anfis.greyml
  greyml fit vmc.csv --target dy_um --model gmc --sensors T18_C,T55_C,T63_C \\
      --out vmc-gmc.greyml
  greyml fit vmc.csv --target dy_um --model mlp --n-sensors 5 --rises \\
      --out vmc-mlp.greyml
  greyml fit vmc.csv --target dy_um --model transfer-function \\
      --drivers spindle_rpm --max-sensors 5 --out vmc-ttf.greyml
  greyml fit cycles.csv --test-column cycle --target ch1_um \\
      --model transfer-function --drivers spindle_rpm --max-sensors 5 \\
      --train-tests 1,2,3,4 --out ch1.greyml
"""


def _add_fit_parser(subparsers):
    parser = flags._subparser(subparsers, "fit", _FIT_EPILOG)
    parser.add_argument(
        "data",
        metavar="DATA.csv",
        help="training tests (CSV); for transfer-function also a folder or a glob of CSV and "
        "Parquet files, read piece by piece",
    )
    flags._add_target(parser)
    parser.add_argument(
        "--out",
        required=True,
        metavar="MODEL.file",
        help="model file to write; - writes it to standard output (a pipe or a file, never a "
        "terminal) and what fit prints to standard error",
    )
    add_model_flags(parser)
    flags._add_names(parser, "--train-tests", "train on these tests only (default: all tests)")
    parser.add_argument("--force", action="store_true", help="replace MODEL.file if it exists")
    flags._end_options(parser, flags._calls(run_fit))


@shared_doc(csv_and_quiet=flags._CSV_AND_QUIET_DOC)
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
    rises=False,
    state=None,
    reference=None,
    selection=None,
    time_constants=None,
    driver_time_constants=None,
    stdout=None,
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
        Model file to write; ``"-"``: write it to ``stdout`` (never to a
        terminal).
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
    {csv_and_quiet}
    drivers : list of str, optional
        ``"transfer-function"`` only: columns the controller knows (spindle
        speed, feed), always inputs, not counted as sensors.
    max_sensors : int, optional
        ``"transfer-function"`` only: the budget of temperature sensors, chosen
        inside the fit on held-out whole tests.
    rises : bool, default=False
        Put :class:`greyml.RelativeToStart` first in the saved Pipeline: every
        input but the drivers as its rise from each test's first row.
    state, reference, selection, time_constants, driver_time_constants : optional
        ``"transfer-function"`` only: the parameters of
        :class:`greyml.ThermalTransferFunction` of these names (None: its
        default).
    stdout : text stream, optional
        The command's standard output, where ``out="-"`` writes the model file.

    Returns
    -------
    int
        0.
    """
    from greyml._seeds import scores
    from greyml.persist import save_model
    from greyml.persist._writer import _archive_writer

    choice = model_choice(
        model,
        select=select,
        cluster_on=cluster_on,
        sensors=sensors,
        drivers=drivers,
        max_sensors=max_sensors,
        rises=rises,
        random_state=random_state,
        state=state,
        reference=reference,
        selection=selection,
        time_constants=time_constants,
        driver_time_constants=driver_time_constants,
    )
    dynamic, drivers = choice.dynamic, choice.drivers
    path = _check_output_file(out, force)
    if path == STDOUT:
        _refuse_binary_terminal(stdout)
    if _many_files(data):
        if path == STDOUT:
            raise ValueError("--out - is for a model fitted on one CSV file; name a file.")
        return _fit_files(
            data, target, choice, path, force, csv_options, quiet, train_tests, sensors, rises
        )
    with _progress(4, quiet) as progress:
        progress.step(f"reading {os.fspath(data)!r}")
        frame, columns = _load_training(
            data, target, sensors, train_tests, "--train-tests", csv_options
        )
        built = build(choice, frame, columns, data)
        estimator, settings, columns, steps = (
            built.estimator,
            built.settings,
            built.columns,
            built.steps,
        )
        X, y = frame[columns], frame[target]
        progress.step(f"fitting {MODEL_NAMES[model]} on {len(frame)} rows")
        seconds, fit_messages = _fit_quietly(estimator, X, y)
        progress.step("predicting the training rows")
        pred, messages = _predict_quietly(estimator, X)
        reference = _reference(estimator)
        measured = _measured(y, reference)
        fit_scores = scores(measured, pred)
        final = _final_step(estimator)
        # predict names its columns after the target: remember it in the model
        final.target_name_ = str(target)
        if not hasattr(final, "fitted_tests_"):  # greyml predict marks the tests fitted on
            final.fitted_tests_ = [str(t) for t in _test_labels(frame)]
        if path == STDOUT:
            progress.step("writing the model file to standard output")
            archive = io.BytesIO()
            _archive_writer(estimator)(archive)
            _write_stdout(stdout, archive.getvalue())
            saved = "standard output"
        else:
            progress.step(f"saving {os.fspath(path)!r}")
            saved = repr(os.fspath(save_model(estimator, path, overwrite=force)))
    _warn("fit", [built.hint] if built.hint else [])
    _warn("fit", fit_messages)
    _warn("fit", messages)
    _warn("fit", _careless(frame, data, fit_scores, csv_options))
    model_step = estimator[-1] if steps else estimator
    inputs = list(estimator["select"].selected_) if select is not None else columns
    tests = _test_labels(frame)
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
        kept = ", ".join(map(printable, model_step.selected_sensors_)) or "none"
        n_candidates = len(columns) - len(drivers)
        how = (
            f"chosen inside the fit on held-out whole tests from {n_candidates}"
            if len(_test_labels(frame)) >= 3
            else f"chosen on the training rows from {n_candidates}: fewer than 3 tests, so "
            "none is held out"
        )
        print(
            f"  inputs: drivers {', '.join(map(printable, drivers)) or 'none'}; sensors {kept} "
            f"({how})"
        )
        print(
            "  lags: "
            + (
                "carried from each test into the next on the file's clock"
                if model_step.state_ == "carry"
                else "each test starts without history"
            )
        )
        buffer = io.StringIO()
        model_step.describe(file=buffer)
        for line in buffer.getvalue().splitlines():
            print(f"  {line}")
    else:
        shown = ", ".join(inputs[:10]) + (", ..." if len(inputs) > 10 else "")
        print(f"  inputs ({len(inputs)}): {shown}")
    if rises:
        print("  inputs enter as rises from each test's first row (RelativeToStart)")
    print(f"  displacement {_REFERENCE_WORDS[reference]}")
    print(
        f"  on the training rows: RMSE {fit_scores['RMSE']:.3g}, ±res {fit_scores['band']:.3g}, "
        f"R {fit_scores['R']:.3f} (score each test held out with greyml validate)"
    )
    print(f"saved to {saved}")
    return 0


def _many_files(data):
    """Whether ``data`` names many files: a folder, or a glob pattern."""
    text = os.fspath(data)
    return os.path.isdir(text) or (not os.path.exists(text) and any(c in text for c in "*?["))


def _fit_files(data, target, choice, path, force, csv_options, quiet, train_tests, sensors, rises):
    """``greyml fit`` on a folder or a glob of files: read piece by piece, never whole."""
    import pandas as pd

    from greyml._cli._files import _candidates
    from greyml._seeds import make_model
    from greyml.io import TestFiles
    from greyml.persist import save_model

    where = os.fspath(data)
    if not choice.dynamic:
        raise ValueError(
            f"{where!r} names many files: only --model transfer-function reads files piece by "
            "piece; give the other models one CSV file."
        )
    for flag, given in (("--train-tests", train_tests), ("--rises", rises)):
        if given:
            raise ValueError(
                f"{flag} is not taken with many files; put the tests to train on in their own "
                "folder."
            )
    options = csv_options or {}
    if options.get("sep") or options.get("decimal"):
        raise ValueError(
            "--sep and --decimal are for one CSV file; many files are read as CSV "
            "with commas and dots, or Parquet."
        )
    test_column = options.get("test_column") or "test"
    files = TestFiles(
        data, target, test_column=test_column, time_unit=options.get("time_unit") or "s"
    )
    header = [c for c in files.columns() if c not in (test_column, "time_s")]
    if target not in header:
        raise ValueError(f"--target: {files.paths[0]!r} has no column {target!r}.")
    columns = _candidates(pd.DataFrame(columns=header), target, sensors, files.paths[0])
    columns = choice.drivers + [c for c in columns if c not in choice.drivers]
    files.inputs = columns
    estimator, settings = make_model(
        choice.model,
        random_state=choice.random_state,
        drivers=choice.drivers,
        max_sensors=choice.max_sensors,
        **choice.transfer,
    )
    with _progress(2, quiet) as progress:
        progress.step(f"fitting {MODEL_NAMES[choice.model]} on {len(files.paths)} files")
        seconds, fit_messages = _fit_quietly(estimator, files, None, chunks=True)
        estimator.target_name_ = str(target)
        progress.step(f"saving {os.fspath(path)!r}")
        saved = save_model(estimator, path, overwrite=force)
    _warn("fit", fit_messages)
    print(f"trained {MODEL_NAMES[choice.model]} ({settings}) in {seconds:.1f} s")
    print(
        f"  data: {len(estimator.fitted_tests_)} tests in {len(files.paths)} files of "
        f"{where!r}, target {printable(target)!r}"
    )
    kept = ", ".join(map(printable, estimator.selected_sensors_)) or "none"
    print(
        f"  inputs: drivers {', '.join(map(printable, choice.drivers)) or 'none'}; sensors "
        f"{kept} (chosen inside the fit on held-out whole tests from "
        f"{len(columns) - len(choice.drivers)})"
    )
    buffer = io.StringIO()
    estimator.describe(file=buffer)
    for line in buffer.getvalue().splitlines():
        print(f"  {line}")
    print(f"  displacement {_REFERENCE_WORDS[_reference(estimator)]}")
    print(
        "  (files read piece by piece: no scores on the training rows; "
        "score held-out tests with greyml validate)"
    )
    print(f"saved to {os.fspath(saved)!r}")
    return 0


def _careless(frame, data, fit_scores, csv_options):
    """Warnings about data that fits but is probably not what was meant."""
    from greyml._cli._files import _time_unit_hint

    out = []
    hint = _time_unit_hint(frame, data, csv_options)
    if hint:
        out.append(hint)
    efficiency = fit_scores.get("E", float("nan"))
    if efficiency < 0:
        out.append(
            f"the model's Nash-Sutcliffe E on its own training rows is {efficiency:.3g}, below "
            "0: it predicts them worse than their mean would; check the inputs, the target "
            "and the model before using it"
        )
    return out
