"""``greyml validate``: leave one test out with the model ``greyml fit`` would build."""

from __future__ import annotations

import os
from dataclasses import replace

from greyml._cli import _flags as flags
from greyml._cli._files import (
    STDOUT,
    _check_output_file,
    _load_training,
    _test_labels,
    _write_stdout,
    _write_text,
)
from greyml._cli._fitting import _final_step, _fit_quietly, _predict_quietly, _reference
from greyml._cli._model import add_model_flags, build, model_choice
from greyml._cli._printing import _progress, _warn, printable
from greyml._cli._scores import REFERENCE_NAMES, print_table, score_tests
from greyml._command_names import MODEL_NAMES
from greyml._docstrings import shared_doc

#: The interval whose coverage the table reports, when the model has one.
COVERAGE = 0.9

_VALIDATE_EPILOG = """\
Each test is held out once. The model greyml fit would build from the same
flags is fitted on the whole file with weight 0 on the held-out test's rows
(its inputs carry the lags on along the file's clock; its displacement is never
seen), predicts every row, and is scored on the held-out test's rows. A model
that takes no sample weights, or one with a sensor selector before it (which
would see the held-out displacement), is fitted on the other tests' rows only
(the table says which). The table gives each test's rows, RMSE, worst |error|
and, for a model with an interval (a transfer function), the share of its rows
inside the 90 % interval; then the median and the worst over the tests.

--reference start (default) scores the change since each test's first row,
of the measured target and of the prediction alike; --reference recording
scores the values from the recording's zero, as the target in the file (for a
model that predicts from it). The interval's coverage is measured in the
reference the model predicts in, where it was calibrated. The model's own
reference is --model-reference (greyml fit's --reference).

Examples:
  greyml validate cycles.csv --test-column cycle --target ch1_um
  greyml validate cycles.csv --test-column cycle --target ch1_um \\
      --drivers spindle_rpm --max-sensors 5 --reference recording --json ch1.json
  greyml validate vmc.csv --target dy_um --model anfis-fcm --n-sensors 5 --rises
"""


def _add_validate_parser(subparsers):
    parser = flags._subparser(subparsers, "validate", _VALIDATE_EPILOG)
    parser.add_argument("data", metavar="DATA.csv", help="tests (CSV), each held out once")
    flags._add_target(parser)
    parser.add_argument(
        "--reference",
        choices=("start", "recording"),
        default="start",
        help="score the change since each test's first row (start, default) or the values "
        "from the recording's zero (recording)",
    )
    parser.add_argument(
        "--json",
        metavar="FILE",
        help="also write the numbers to FILE (JSON), whole or not at all; - writes them to "
        "standard output and the table to standard error",
    )
    parser.add_argument("--force", action="store_true", help="replace the --json FILE if it exists")
    add_model_flags(parser, model_default="transfer-function", reference_flag="--model-reference")
    flags._end_options(parser, flags._calls(run_validate))


def _weighted(estimator):
    """Whether ``estimator`` can be fitted on every row with weight 0 on some: its final
    step takes ``sample_weight`` and no step before it learns from the target."""
    import inspect

    steps = getattr(estimator, "steps", None)
    if steps and any(hasattr(step, "get_support") for _, step in steps[:-1]):
        return False
    fit = getattr(_final_step(estimator), "fit", None)
    return fit is not None and "sample_weight" in inspect.signature(fit).parameters


def _in_reference(values, labels, reference):
    """``values`` as their change since each test's first row (``"start"``), or as they are."""
    import numpy as np
    import pandas as pd

    values = np.asarray(values, dtype=float)
    if reference != "start":
        return values
    first = pd.Series(values).groupby(np.asarray(labels, dtype=object), sort=False)
    return values - first.transform("first").to_numpy(dtype=float)


@shared_doc(csv_and_quiet=flags._CSV_AND_QUIET_DOC)
def run_validate(
    data,
    target,
    *,
    reference="start",
    json=None,
    force=False,
    model="transfer-function",
    select=None,
    cluster_on=None,
    sensors=None,
    drivers=None,
    max_sensors=None,
    rises=False,
    random_state=0,
    state=None,
    model_reference=None,
    selection=None,
    time_constants=None,
    driver_time_constants=None,
    csv_options=None,
    quiet=False,
    stdout=None,
):
    """``greyml validate``: leave one test out and print a table test by test.

    Parameters
    ----------
    data : str or path-like
        CSV file of tests.
    target : str
        Target column.
    reference : {"start", "recording"}, default="start"
        The reference of the scores: the change since each test's first row,
        or the values from the recording's zero (the target as in the file).
    json : str or path-like, optional
        Also write the numbers there (JSON, through a temporary file); ``"-"``:
        write them to ``stdout``, the table to standard error.
    force : bool, default=False
        Replace ``json`` if it exists.
    model, select, cluster_on, sensors, drivers, max_sensors, rises, random_state
        As for :func:`greyml._cli._fit.run_fit`.
    state, model_reference, selection, time_constants, driver_time_constants : optional
        ``"transfer-function"`` only: the parameters ``state``, ``reference``,
        ``selection``, ``time_constants`` and ``driver_time_constants`` of
        :class:`greyml.ThermalTransferFunction` (None: its default).
    {csv_and_quiet}
    stdout : text stream, optional
        The command's standard output, where ``json="-"`` writes the numbers.

    Returns
    -------
    int
        0.
    """
    import json as json_module
    import time

    import numpy as np
    from sklearn.base import clone

    from greyml._cli import _predict_trust as trust

    choice = model_choice(
        model,
        select=select,
        cluster_on=cluster_on,
        sensors=sensors,
        drivers=drivers,
        max_sensors=max_sensors,
        rises=rises,
        random_state=random_state,
        reference_flag="--model-reference",
        state=state,
        reference=model_reference,
        selection=selection,
        time_constants=time_constants,
        driver_time_constants=driver_time_constants,
    )
    if json is not None:
        _check_output_file(json, force, "--json")
    frame, columns = _load_training(data, target, sensors, None, "", csv_options)
    tests = _test_labels(frame)
    if len(tests) < 2:
        raise ValueError(
            f"{os.fspath(data)!r} holds {len(tests)} test; leaving one out needs at least 2 "
            "(label them with a test column, --test-column)."
        )
    built = build(choice, frame, columns, data)
    X, y = frame[built.columns], frame[target]
    labels = np.asarray(frame.index.get_level_values("test"), dtype=object)
    weighted = _weighted(built.estimator)
    predicted = np.empty(len(frame))
    half = np.full(len(frame), np.nan)
    references = set()
    messages = []
    seconds = 0.0
    start = time.perf_counter()
    with _progress(len(tests), quiet) as progress:
        for test in tests:
            progress.step(f"test {printable(str(test))} held out")
            held = labels == test
            estimator = clone(built.estimator)
            if weighted:
                w = (~held).astype(float)
                params = {"model__sample_weight": w} if built.steps else {"sample_weight": w}
                fit_s, caught = _fit_quietly(estimator, X, y, **params)
                rows = X
            else:
                fit_s, caught = _fit_quietly(estimator, X[~held], y[~held])
                rows = X[held]
            seconds += fit_s
            pred, more = _predict_quietly(estimator, rows)
            messages += caught + more
            final = _final_step(estimator)
            predicted[held] = pred[held] if weighted else pred
            references.add(_reference(estimator))
            if getattr(final, "interval_calibration_", None) is not None:
                width = trust.batch_half_width(estimator, rows, COVERAGE, {})
                half[held] = width[held] if weighted else width
    elapsed = time.perf_counter() - start
    if len(references) > 1:
        raise ValueError(
            "the model predicted in different references in different folds "
            f"({', '.join(sorted(references))}); choose one with --model-reference."
        )
    (predicts_in,) = references
    if reference == "recording" and predicts_in != "recording" and predicts_in != "target":
        raise ValueError(
            "--reference recording: the model predicts the change since each test's first "
            "row, so it cannot be scored from the recording's zero; score it with --reference "
            "start, or fit it from the recording's zero (--model-reference recording)."
        )
    measured = y.to_numpy(dtype=float)
    scored = score_tests(
        labels,
        _in_reference(measured, labels, reference),
        _in_reference(predicted, labels, reference),
    )
    if np.isfinite(half).all():
        native = _in_reference(measured, labels, "start" if predicts_in == "start" else "")
        coverage = score_tests(labels, native, predicted, half)
        scored = [replace(s, coverage=c.coverage) for s, c in zip(scored, coverage)]
        interval = COVERAGE
    else:
        interval = None
    _warn("validate", [built.hint] if built.hint else [])
    _warn("validate", list(dict.fromkeys(messages)))
    how = (
        "fitted on the whole file with weight 0 on the held-out test's rows"
        if weighted
        else "fitted on the other tests' rows"
    )
    print(
        f"validated {MODEL_NAMES[choice.model]} ({built.settings}) on "
        f"{os.fspath(data)!r}, target {printable(target)!r}: each of its {len(tests)} tests "
        f"held out once ({how}); {seconds:.1f} s fitting, {elapsed:.1f} s in all"
    )
    print(f"  displacement in the reference {REFERENCE_NAMES[reference]}:")
    summary = print_table(scored, coverage=interval)
    if interval is not None and predicts_in != reference:
        print(
            f"  the interval's coverage is measured in the model's own reference, "
            f"{REFERENCE_NAMES[predicts_in]}, where it was calibrated"
        )
    if json is not None:
        record = {
            "data": os.fspath(data),
            "target": str(target),
            "model": choice.model,
            "settings": built.settings,
            "reference": reference,
            "model_reference": predicts_in,
            "held_out": "weight 0" if weighted else "other tests only",
            "coverage": interval,
            "tests": [s.as_dict() for s in scored],
            "summary": summary.as_dict(),
            "fit_seconds": seconds,
            "seconds": elapsed,
        }
        text = json_module.dumps(record, indent=1, allow_nan=False) + "\n"
        if json == STDOUT:
            _write_stdout(stdout, text)
        else:
            _write_text(json, text, force)
            print(f"wrote {os.fspath(json)!r}")
    return 0
