"""``greyml fit``: train a named model and save it."""

from __future__ import annotations

import io
import os

from greyml._cli import _flags as flags
from greyml._cli._files import (
    _check_output_file,
    _load_training,
    _require_columns,
    _require_values,
    _test_labels,
)
from greyml._cli._fitting import (
    _REFERENCE_WORDS,
    _final_step,
    _fit_quietly,
    _measured,
    _predict_quietly,
    _reference,
    _selector,
)
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
    parser.add_argument("data", metavar="DATA.csv", help="training tests (CSV)")
    flags._add_target(parser)
    parser.add_argument("--model", required=True, choices=list(MODEL_NAMES), help="the model")
    parser.add_argument("--out", required=True, metavar="MODEL.file", help="model file to write")
    parser.add_argument(
        "--n-sensors",
        type=flags._count,
        metavar="N",
        dest="select",
        help="keep N sensors with GreyInfluenceSelector before the model",
    )
    parser.add_argument(
        "--cluster-on",
        choices=("series", "influence"),
        help="the selector's grouping, with --n-sensors: " + flags._CLUSTER_HELP.split(": ", 1)[1],
    )
    flags._add_names(
        parser,
        "--drivers",
        "--model transfer-function: columns the controller knows (spindle speed, "
        "feed), always inputs and not counted as sensors",
    )
    parser.add_argument(
        "--max-sensors",
        type=flags._count,
        metavar="N",
        help="--model transfer-function: at most N temperature sensors, chosen inside the "
        "fit on held-out whole tests",
    )
    dynamic = parser.add_argument_group("--model transfer-function")
    dynamic.add_argument(
        "--state",
        choices=("auto", "carry", "restart"),
        help="lags at a test's start: auto (default) carries them from the test before on "
        "the same clock, carry from every test before, restart starts each test anew",
    )
    dynamic.add_argument(
        "--reference",
        choices=("auto", "start", "recording"),
        help="displacement from each test's start or from the recording's zero; auto "
        "(default): the recording's when the tests are one recording",
    )
    dynamic.add_argument(
        "--selection",
        choices=("forward", "stable"),
        help="how --max-sensors sensors are chosen (default: forward)",
    )
    for flag, metavar, help_text in (
        (
            "--time-constants",
            "S,S|fit",
            "the sensors' lags in seconds (default: 300,900,2700,8100), or fit",
        ),
        (
            "--driver-time-constants",
            "S,S",
            "the drivers' lags in seconds (default: the sensors' and one 3 times slower)",
        ),
    ):
        dynamic.add_argument(flag, type=flags._seconds_list, metavar=metavar, help=help_text)
    flags._add_names(
        parser,
        "--sensors",
        "the model's inputs, or the selector's candidates with --n-sensors, "
        + flags._SENSORS_HELP.split("candidate sensor columns, ", 1)[1],
    )
    parser.add_argument(
        "--rises",
        action="store_true",
        help="inputs as rises from each test's first row (RelativeToStart, saved with the "
        "model); --drivers stay as they are",
    )
    flags._add_names(parser, "--train-tests", "train on these tests only (default: all tests)")
    flags._add_random_state(parser, "seed of the model's random choices (default: 0)")
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

    Returns
    -------
    int
        0.
    """
    from sklearn.pipeline import Pipeline

    from greyml._seeds import make_model, scores
    from greyml.persist import save_model
    from greyml.preprocessing import RelativeToStart

    if model not in MODEL_NAMES:
        raise ValueError(f"unknown model {model!r}; choose one of {', '.join(MODEL_NAMES)}.")
    dynamic = model == "transfer-function"
    drivers = list(drivers or [])
    transfer = {
        "state": state,
        "reference": reference,
        "selection": selection,
        "time_constants": time_constants,
        "driver_time_constants": driver_time_constants,
    }
    given = [f"--{k.replace('_', '-')}" for k, v in transfer.items() if v is not None]
    if not dynamic and (drivers or max_sensors is not None or given):
        flag = ", ".join(given) or "--drivers and --max-sensors"
        raise ValueError(
            f"{flag} {'is' if len(given) == 1 else 'are'} for --model transfer-function; "
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
            model,
            random_state=random_state,
            drivers=drivers,
            max_sensors=max_sensors,
            **(transfer if dynamic else {}),
        )
        n_inputs = select if select is not None else len(columns)
        if select is not None and select > len(columns):
            raise ValueError(
                f"--n-sensors {select} asks for more sensors than the {len(columns)} candidate(s)."
            )
        if model == "anfis-grid" and n_inputs > 6:
            raise ValueError(
                f"anfis-grid on {n_inputs} inputs would need {estimator.n_mfs}^{n_inputs} "
                "rules; keep a few sensors with --n-sensors 5 or --sensors, or use anfis-fcm."
            )
        steps = []
        if rises:
            rising = [c for c in columns if c not in drivers]
            steps.append(("rises", RelativeToStart(columns=rising)))
        if select is not None:
            steps.append(("select", _selector(select, cluster_on, random_state)))
        if steps:
            estimator = Pipeline([*steps, ("model", estimator)])
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
        progress.step(f"saving {os.fspath(path)!r}")
        saved = save_model(estimator, path, overwrite=force)
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
        f"R {fit_scores['R']:.3f} (validate on other tests with greyml predict)"
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
