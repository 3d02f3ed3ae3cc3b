"""``greyml predict``: apply a saved model to tests and write the compensation."""

from __future__ import annotations

import os

from greyml._cli import _flags as flags
from greyml._cli._files import (
    STDOUT,
    _check_output_file,
    _csv_text,
    _load_model_file,
    _output_name,
    _read,
    _require_values,
    _test_labels,
    _time_unit_hint,
    _where,
    _write_stdout,
)
from greyml._cli._fitting import (
    _REFERENCE_WORDS,
    _final_step,
    _measured,
    _predict_quietly,
    _reference,
)
from greyml._cli._printing import _progress, _warn, printable
from greyml._cli._scores import REFERENCE_NAMES, print_table, score_tests
from greyml._docstrings import shared_doc

_PREDICT_EPILOG = """\
DATA.csv needs the columns the model reads (a model fitted with --n-sensors
reads only the sensors it kept; a transfer function its drivers and the sensors
it selected). PRED.csv has the columns test, time_s,
predicted_<target> (the thermal error the model predicts, in the target's
unit) and compensation_<target> = -predicted_<target> (the correction to add to
the axis); a model that predicts the change since each test's first row names
them predicted_<target>_since_start and compensation_<target>_since_start. When
DATA.csv also holds the measured target, a table scores each test (RMSE,
worst |error| and, with --interval, the share of rows inside the interval) in
the same reference (the line above it names it); the tests the model was
fitted on are marked *, and the median and worst are over the others only.
Grey models and transfer functions fitted on separate tests predict the change
since each test's first row; a transfer function fitted on one recording
predicts from the recording's zero, and carries its lags along the file's
clock. For a test that starts mid-run without the rows
before it, give the measured target at its first row with
--initial-displacement (a warning names such a test). A model that predicts NaN or an infinite
value for any row is an error (exit 2), and no PRED.csv is written; the file
is written to a temporary name and renamed, so a failure never leaves a
partial PRED.csv.
Test labels a spreadsheet would run as formulas (=, +, -, @) get a leading '.

How far to trust it (a transfer function fitted on 3 tests or more):
--interval 0.9 adds lower_<target> and upper_<target> beside the prediction:
the interval calibrated in fit on whole held-out tests, widening with the time
since the displacement was known (each test's first row). Its coverage holds
for tests like the training tests, not for a test unlike all of them or a
machine that has changed. --tolerance UM adds trusted: 1 where the interval's
half-width is at most UM. --probe PROBES.csv replays probe readings (columns
test, time_s and the target, in the reference of the prediction; read with
the same --test-column and --time-unit as DATA.csv): the file is streamed
through the model's compensator, and each reading corrects the prediction from
its time on and narrows the interval there; a bias and its rate follow a
drift reading by reading, and a likelihood-ratio test for a step or a ramp
(one false alarm in 1,000 readings on Gaussian innovations) adds the change it
finds. A reading
of a test or time that is not in DATA.csv, or out of order, is an error.

Examples:
  greyml simulate --machine vmc --tests IV --out train.csv
  greyml simulate --machine vmc --tests V,VI --out new-tests.csv
  greyml fit train.csv --target dy_um --model anfis-fcm --n-sensors 5 --out vmc.greyml
  greyml predict vmc.greyml new-tests.csv --out compensation.csv
  greyml predict gmc.greyml tail.csv --out comp.csv --initial-displacement V=-48.5
  greyml predict ch1.greyml cycles.csv --test-column cycle --out ch1-pred.csv \\
      --interval 0.9 --probe probes.csv --tolerance 5
"""


def _add_predict_parser(subparsers):
    parser = flags._subparser(subparsers, "predict", _PREDICT_EPILOG)
    parser.add_argument("model", metavar="MODEL.file", help="model file from greyml fit")
    parser.add_argument("data", metavar="DATA.csv", help="tests (CSV) with the model's sensors")
    parser.add_argument(
        "--out",
        required=True,
        metavar="PRED.csv",
        help="CSV file to write; - writes it to standard output and what predict prints to "
        "standard error",
    )
    parser.add_argument("--force", action="store_true", help="replace PRED.csv if it exists")
    parser.add_argument(
        "--initial-displacement",
        metavar="VALUE|TEST=VALUE[,TEST=VALUE]",
        help=(
            "grey models and transfer functions: the measured target at the first row of "
            "every test (VALUE) or of the tests named, for tests that start mid-run"
        ),
    )
    parser.add_argument(
        "--max-displacement",
        type=flags._positive_number,
        metavar="X",
        help=(
            "refuse to write a prediction beyond ±X in the target's unit (default: 1 mm, "
            "i.e. 1000 for a target in µm or unnamed unit, 1 for a '_mm' target; inf: no bound)"
        ),
    )
    trust = parser.add_argument_group(
        "how far to trust it (a transfer function fitted on 3 tests or more)"
    )
    trust.add_argument(
        "--interval",
        type=flags._coverage,
        metavar="COVERAGE",
        help="also write lower_<target> and upper_<target>: the interval that holds this "
        "share of rows (e.g. 0.9), calibrated in fit on whole held-out tests",
    )
    trust.add_argument(
        "--probe",
        metavar="PROBES.csv",
        help="probe readings to replay: test, time_s and the target column, in the "
        "reference of the prediction; each corrects the compensation from its time on",
    )
    trust.add_argument(
        "--tolerance",
        type=flags._positive_number,
        metavar="UM",
        help="with --interval: also write trusted (1 where the interval's half-width is "
        "at most UM, else 0)",
    )
    flags._end_options(parser, flags._calls(run_predict))


def _load(model_path):
    """Load a model file (:func:`greyml.persist.load_model`); return it and its warnings.

    A file that is not a greyml model, was altered, or names a class greyml
    does not create is a ValueError with one line naming the file.
    """

    name = os.fspath(model_path)
    estimator, caught = _load_model_file(model_path)
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
    final = _final_step(estimator)
    if hasattr(final, "selected_sensors_") and hasattr(final, "drivers_"):
        # a transfer function reads its drivers and the sensors it selected only
        read = {*map(str, final.drivers_), *map(str, final.selected_sensors_)}
        return inputs, [c for c in inputs if c in read]
    return inputs, inputs


def _initial_displacement(text, tests, model):
    """``--initial-displacement``: a number, or TEST=VALUE pairs, for ``predict``."""
    import numpy as np

    from greyml.grey._gmc import _GreyConvolutionModel

    if text is None:
        return {}
    from greyml.dynamic import ThermalTransferFunction

    if not isinstance(_final_step(model), (_GreyConvolutionModel, ThermalTransferFunction)):
        raise ValueError(
            "--initial-displacement is for models with a state (gmc, gnnmci, "
            f"transfer-function); this model is {type(_final_step(model)).__name__}, which "
            "maps each row to its prediction without a state to start."
        )

    def number(word, what):
        value = flags._float_or_nan(word)
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
        name, word = flags._name_value(
            item,
            by_name,
            f"--initial-displacement: {item.strip()!r} is not TEST=VALUE for a test of the "
            f"data (its tests: {', '.join(list(by_name)[:10])}).",
        )
        values[by_name[name]] = number(word.strip(), f"the value of test {name!r}")
    return {"initial_displacement": values}


def _require_finite_predictions(pred, frame, model, data):
    """Refuse NaN or infinite predictions: an empty compensation cell moves no axis."""
    import numpy as np

    bad = ~np.isfinite(pred)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        what = "every row" if bad.all() else f"{int(bad.sum())} of {bad.size} rows"
        raise ValueError(
            f"the model {os.fspath(model)!r} predicts {pred[row]} for {what} of "
            f"{os.fspath(data)!r}, first at {_where(frame, row, data)}; its coefficients may "
            "be NaN or the inputs far outside its training range. No compensation written."
        )


#: The largest thermal displacement written by default, in µm: far beyond the
#: tens of µm a machine tool drifts, so only a broken model or input reaches it.
MAX_DISPLACEMENT_UM = 1000.0


def _displacement_bound(target, given):
    """``given``, or 1 mm in the unit the target's name ends with (µm unless '_mm')."""
    if given is not None:
        return given
    return 1.0 if str(target).endswith("_mm") else MAX_DISPLACEMENT_UM


def _require_plausible_predictions(pred, frame, model, data, bound, target):
    """Refuse a prediction beyond ``bound``: no honest thermal model moves an axis by that."""
    import numpy as np

    bad = np.abs(pred) > bound
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"the model {os.fspath(model)!r} predicts {pred[row]:.6g} for {target} at "
            f"{_where(frame, row, data)}, beyond ±{bound:g} (1 mm unless --max-displacement "
            f"says otherwise; {int(bad.sum())} of {bad.size} rows are). Check the inputs' "
            "units and the model; no compensation written."
        )


@shared_doc(csv_and_quiet=flags._CSV_AND_QUIET_DOC)
def run_predict(
    model,
    data,
    out,
    *,
    force=False,
    csv_options=None,
    quiet=False,
    initial_displacement=None,
    max_displacement=None,
    interval=None,
    probe=None,
    tolerance=None,
    stdout=None,
):
    """``greyml predict``: apply a saved model to tests and write the compensation.

    Parameters
    ----------
    model : str or path-like
        Model file written by ``greyml fit``.
    data : str or path-like
        CSV file of tests with the model's sensor columns.
    out : str or path-like
        CSV file to write: ``test``, ``time_s``, ``predicted_<target>``
        (with ``interval``, ``lower_<target>`` and ``upper_<target>`` next to
        it), ``compensation_<target>`` (the negated prediction: the correction
        to add to the axis position) and, with ``tolerance``, ``trusted``;
        ``"-"``: write it to ``stdout``.
    force : bool, default=False
        Replace ``out`` if it exists.
    {csv_and_quiet}
    initial_displacement : str or None, default=None
        Grey models and transfer functions: ``"VALUE"`` (every test) or
        ``"TEST=VALUE,..."``, the measured target at the first row of tests
        that start mid-run (passed to the model's ``predict``).
    max_displacement : float or None, default=None
        Refuse to write any prediction beyond ± this, in the target's unit;
        ``None`` is 1 mm (1000 for a target in µm or of unnamed unit, 1 for a
        column ending in ``_mm``); ``inf`` sets no bound. A probe reading
        beyond it is refused too.
    interval : float or None, default=None
        A coverage in (0, 1): write the bounds of the model's interval
        (:meth:`greyml.ThermalTransferFunction.predict_interval`, or with
        ``probe`` the compensator's, which narrows at each reading).
    probe : str or path-like or None, default=None
        CSV file of probe readings (``test``, ``time_s`` and the target's
        column, in the reference of the prediction), replayed through the
        model's :class:`~greyml.dynamic.Compensator`: each reading corrects
        the rows from its time on.
    tolerance : float or None, default=None
        With ``interval``: write ``trusted``, 1 where the interval's
        half-width is at most this (in the target's unit), else 0.
    stdout : text stream, optional
        The command's standard output, where ``out="-"`` writes the CSV.

    Returns
    -------
    int
        0.

    Raises
    ------
    ValueError
        Besides bad files and columns: when the model predicts NaN, an
        infinite value or a value beyond ``max_displacement`` for any row (no
        compensation file is written then); when ``interval`` or ``probe`` is
        given for a model that is not a transfer function; for a probe
        reading of a test or time that is not in ``data``, out of order, or
        refused by the compensator (one line naming its line, test and time).
    """
    import numpy as np
    import pandas as pd

    from greyml._cli import _predict_trust as trust
    from greyml.io import write_tests_csv

    if tolerance is not None and interval is None:
        raise ValueError(
            "--tolerance compares the interval's half-width with UM: give its coverage with "
            "--interval too (e.g. --interval 0.9)."
        )
    path = _check_output_file(out, force)
    with _progress(4 + (probe is not None), quiet) as progress:
        progress.step(f"reading the model {os.fspath(model)!r}")
        estimator, load_messages = _load(model)
        if interval is not None:
            trust.trust_model(estimator, model, "--interval")
        if probe is not None:
            trust.trust_model(estimator, model, "--probe")
        progress.step(f"reading {os.fspath(data)!r}")
        frame = _read(data, csv_options)
        inputs, used = _model_inputs(estimator, model)
        missing = [c for c in used if c not in frame.columns]
        if missing:
            from greyml._validation import shown_names

            shown = shown_names(frame.columns, 12)
            raise ValueError(
                f"the model {os.fspath(model)!r} needs the sensor column(s) "
                f"{shown_names(missing)}, which {os.fspath(data)!r} lacks (its columns: "
                f"{shown or 'none, 0 features'})."
            )
        _require_values(frame, used, data, "sensor")
        # a selector's dropped candidates are never read: the data need not have them
        X = pd.DataFrame(
            {c: frame[c] if c in frame.columns else 0.0 for c in inputs}, index=frame.index
        )
        progress.step(f"predicting {len(frame)} rows")
        tests = _test_labels(frame)
        params = _initial_displacement(initial_displacement, tests, estimator)
        pred, messages = _predict_quietly(estimator, X, **params)
        _require_finite_predictions(pred, frame, model, data)
        measured = getattr(_final_step(estimator), "target_name_", None) or "target"
        target = printable(measured)
        bound = _displacement_bound(measured, max_displacement)
        _require_plausible_predictions(pred, frame, model, data, bound, target)
        half = replayed = None
        if probe is not None:
            readings = trust.read_probes(probe, csv_options, measured, frame, data)
            progress.step(f"replaying {len(readings)} probe reading(s)")
            replayed = trust.replay(
                estimator,
                X,
                readings,
                params=params,
                coverage=interval,
                tolerance=tolerance,
                bound=bound,
            )
            pred, half = replayed.prediction, replayed.half_width
            _require_finite_predictions(pred, frame, model, data)
            _require_plausible_predictions(pred, frame, model, data, bound, target)
        elif interval is not None:
            half = trust.batch_half_width(estimator, X, interval, params)
        reference = _reference(estimator)
        given = params.get("initial_displacement", {})
        given = given if isinstance(given, dict) else dict.fromkeys(tests)
        # every test started at its measured value: the file's own reference
        suffix = "_since_start" if reference == "start" and len(given) < len(tests) else ""
        predicted, compensation = f"predicted_{target}{suffix}", f"compensation_{target}{suffix}"
        columns = {predicted: pred}
        if interval is not None:
            lower, upper = f"lower_{target}{suffix}", f"upper_{target}{suffix}"
            columns.update({lower: pred - half, upper: pred + half})
        columns[compensation] = -pred
        if tolerance is not None:
            trusted = replayed.trusted if replayed is not None else half <= tolerance
            columns["trusted"] = np.asarray(trusted, dtype=int)
        result = pd.DataFrame(columns, index=frame.index)
        if path == STDOUT:
            progress.step("writing the compensation to standard output")
            _write_stdout(stdout, _csv_text(result))
        else:
            progress.step(f"writing {os.fspath(path)!r}")
            write_tests_csv(result, path, overwrite=force)
    _warn("predict", load_messages)
    _warn("predict", messages)
    hint = _time_unit_hint(frame, data, csv_options)
    _warn("predict", [hint] if hint else [])
    bounds = "" if interval is None else f", {lower} and {upper} (its {interval:g} interval)"
    flag = "" if tolerance is None else f" and trusted (half-width at most {tolerance:g})"
    print(
        f"wrote {len(result)} rows of {len(tests)} test(s) to {_output_name(path)}: "
        f"{predicted}{bounds}{',' if bounds else ' and'} {compensation} = -{predicted}{flag}."
    )
    words = _REFERENCE_WORDS[reference]
    if suffix == "" and reference == "start":
        words = "from the measured value given at each test's first row"
    if replayed is not None:
        n = replayed.readings
        words += (
            f"; corrected by {n} probe reading{'' if n == 1 else 's'} from "
            f"{os.fspath(probe)!r} (in the same reference)"
        )
    print(f"  displacement {words}")
    if replayed is not None:
        print(f"  {_detector_words(replayed.changes)}")
    if measured in frame.columns and not frame[measured].isna().any():
        truth = _measured(frame[measured], reference, given)
        labels = frame.index.get_level_values("test")
        fitted = getattr(_final_step(estimator), "fitted_tests_", None)
        # every test started at a measured value given: the file's own reference
        named = "target" if reference == "start" and not suffix else reference
        print(
            f"  against the measured {target} in {os.fspath(data)!r}, test by test, in the "
            f"reference {REFERENCE_NAMES[named]}:"
        )
        print_table(
            score_tests(labels, truth, pred, half),
            coverage=interval,
            marked=set(fitted or ()),
        )
        if fitted is None:
            print("  (the model does not record the tests it was fitted on)")
    return 0


def _detector_words(changes):
    """What the change detector did while the readings were replayed."""
    if not changes:
        return "the change detector did not fire (no reading fell outside the interval twice)"
    shown = "; ".join(f"test {printable(str(t))!r} at time_s {s:g}" for t, s in changes[:5])
    more = f" and {len(changes) - 5} more" if len(changes) > 5 else ""
    times = "once" if len(changes) == 1 else f"{len(changes)} times"
    return (
        f"the change detector fired {times} and recalibrated (after the readings at {shown}{more})"
    )
