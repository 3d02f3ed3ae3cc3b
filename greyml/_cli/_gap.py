"""``greyml gap``: where the gap between measured tests and a simulation lies, and why."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import textwrap
import warnings

from greyml._cli import _flags as flags
from greyml._cli._files import _check_output_file, _read, _require_columns, _write_text
from greyml._cli._fitting import _distinct_warnings
from greyml._cli._printing import _progress, _warn

_GAP_EPILOG = """\
The CSV files have the columns test and time_s, then the data columns; SIM.csv
holds the simulated target for every measured (test, time_s) row: the column
--sim-column names, else one named like --target, else greyml predict's
predicted_<target> or predicted_<target>_since_start, else its only column. A
file that greyml predict wrote (test, time_s, predicted_<target>,
compensation_<target>) is read as it wrote it (a test column and seconds),
whatever --test-column and --time-unit say of REAL.csv; with a _since_start
prediction the measured target is compared from its first row in each test.

Events are changes of the gap completed within --step-time seconds (2 min by
default), found the same at any row rate; an event within --driver-window
seconds of a switch of a --drivers column is reported at that switch (e.g. at
a spindle speed change) rather than as a knock. The noise floor includes the
step in which the target is read (--quantum; detected when not given).

Output: without --json, the report for people is printed. --json FILE also
writes the report as JSON to FILE; --json - writes only the JSON to standard
output. The report for people starts with the verdict (within_noise, explained,
partial or unexplained). The JSON holds "verdict", "unexplained_rms", "events"
(located steps and spikes: test, time_s, kind, size, end_s, z, and
at_driver_change, driver_change_s, driver_before, driver_after for one at a
driver's switch), "noise_floor" and "quantum", "cause" (null when no effect is
significant), "causes" (one row per effect, with p_value and shrinkage_ci) and
"where" (where the gap lies), and never NaN. An existing FILE is replaced only
with --force.

{effects}

Warnings and progress go to standard error, never to standard output.

Exit codes:
  {ok}    the diagnosis ran (whether or not it names a cause)
  {error}    usage error, unreadable or unwritable file, or data that cannot be
       diagnosed (one line on standard error: greyml gap: error: <message>)
{interrupted}"""


def _gap_epilog():
    """The gap epilog, listing the effects (imported only when the help is shown)."""
    from greyml.gap import EFFECTS

    effects = textwrap.fill("Effects (--effects): " + ", ".join(EFFECTS) + ".", width=79)
    return _GAP_EPILOG.format(
        effects=effects,
        ok=flags.EXIT_OK,
        error=flags.EXIT_ERROR,
        interrupted=flags._EXIT_INTERRUPTED_HELP,
    )


def _add_gap_parser(subparsers):
    """The ``gap`` subcommand: its arguments and its handler."""
    parser = flags._subparser(subparsers, "gap", _gap_epilog, exit_codes=False)
    _add_gap_arguments(parser)
    return parser


def _add_gap_arguments(parser):
    """The arguments of ``greyml gap``."""
    parser.add_argument("real", metavar="REAL.csv", help="measured tests (CSV)")
    parser.add_argument(
        "sim",
        metavar="SIM.csv",
        help="simulation of the same tests (CSV), or the output of greyml predict",
    )
    flags._add_target(parser, "measured target column")
    parser.add_argument(
        "--sim-column",
        type=flags._name,
        metavar="COL",
        help="the column of SIM.csv with the simulated target (default: see below)",
    )
    parser.add_argument(
        "--ambient", type=flags._name, metavar="COL", help="ambient temperature column"
    )
    lists = {
        "--drivers": "operating drivers, e.g. spindle_rpm,feed_mm_min (zero when off)",
        "--sensors": "temperature sensor columns",
        "--fbgs": "FBG columns (fbg_temperature is tried when the target is one)",
    }
    for flag, help_text in lists.items():
        flags._add_names(parser, flag, f"{help_text}; comma-separated, may be repeated")
    flags._add_names(
        parser,
        "--effects",
        "effects to try (default: all); comma-separated, may be repeated",
        metavar="a,b",
    )
    flags._add_random_state(
        parser,
        "seed of the placebos, for a repeatable diagnosis (default: unseeded)",
        default=None,
    )
    parser.add_argument(
        "--sensitivities",
        metavar="SENS.csv",
        help="the simulation's sensitivities to its uncertain parameters on the same rows "
        "(CSV, one column per parameter); they are refitted within --tolerance first",
    )
    parser.add_argument(
        "--tolerance",
        type=float,
        default=0.1,
        metavar="X",
        help="how far (relative) the simulation's parameters may be off (default: 0.1)",
    )
    parser.add_argument(
        "--quantum",
        type=_quantum,
        default=None,
        metavar="Q",
        help="the step in which the target is read, in its unit (1 for a probe that reads "
        "whole micrometres; 0: continuous readings; default: detected in the readings)",
    )
    parser.add_argument(
        "--step-time",
        type=_step_time,
        default=120.0,
        metavar="S",
        help="a change of the gap completed within S seconds is a step, an event (default: 120)",
    )
    parser.add_argument(
        "--driver-window",
        type=_driver_window,
        default=60.0,
        metavar="S",
        help="an event within S seconds of a switch of a --drivers column is reported at "
        "that switch (default: 60)",
    )
    parser.add_argument(
        "--custom",
        type=_custom_effect,
        action="append",
        default=None,
        metavar="NAME=COL[,COL]",
        help="an effect the library lacks: the columns through two thermal lags, reported "
        "as NAME; may be repeated",
    )
    parser.add_argument(
        "--json",
        metavar="FILE|-",
        help="write the report as JSON to FILE, or only JSON to standard output with -",
    )
    parser.add_argument("--force", action="store_true", help="replace the --json FILE if it exists")
    flags._end_options(parser, _run_gap)


def _number(text, what, low, strict):
    """A finite float from ``text``, above ``low`` (or at it, unless ``strict``)."""
    value = flags._float_or_nan(text)
    if not math.isfinite(value) or value < low or (strict and value == low):
        raise argparse.ArgumentTypeError(f"must be {what}; got {text!r}")
    return value


def _quantum(text):
    """``--quantum Q``: a finite number >= 0."""
    return _number(text, "a finite number >= 0 (0: continuous readings)", 0.0, False)


def _step_time(text):
    """``--step-time S``: seconds, > 0."""
    return _number(text, "a finite number of seconds > 0", 0.0, True)


def _driver_window(text):
    """``--driver-window S``: seconds, >= 0."""
    return _number(text, "a finite number of seconds >= 0", 0.0, False)


def _predict_header(path):
    """The predicted column if ``path`` is a file greyml predict wrote, else None.

    greyml predict writes ``test,time_s,predicted_<t>,compensation_<t>``
    (``<t>`` possibly ending in ``_since_start``), comma-separated, in seconds.
    """
    try:
        with open(path, encoding="utf-8-sig", newline="") as handle:
            line = handle.readline(1 << 16)
    except (OSError, UnicodeDecodeError):
        return None  # the reader says what is wrong with the file
    names = [n.strip().strip('"') for n in line.rstrip("\r\n").split(",")]
    if len(names) != 4 or names[:2] != ["test", "time_s"]:
        return None
    predicted, compensation = names[2], names[3]
    own = predicted.startswith("predicted_") and predicted != "predicted_"
    if own and compensation == "compensation_" + predicted[len("predicted_") :]:
        return predicted
    return None


def _sim_column(frame, path, target, given):
    """The column of the simulation frame that holds the simulated target."""
    if given is not None:
        _require_columns(frame, [given], path, "--sim-column")
        return given
    for name in (target, f"predicted_{target}", f"predicted_{target}_since_start"):
        if name in frame.columns:
            return name
    if frame.shape[1] == 1:
        return frame.columns[0]
    from greyml._validation import shown_names

    have = shown_names(frame.columns, 12)
    raise ValueError(
        f"{os.fspath(path)!r} has no column of the simulated {target!r} (looked for "
        f"{target}, predicted_{target} and predicted_{target}_since_start; its columns: "
        f"{have}); name it with --sim-column."
    )


def _read_sim(path, options, target, given):
    """The simulated target (a one-column frame), and the notes to print about it.

    A file of greyml predict is read as it wrote it (a ``test`` column,
    seconds); a ``_since_start`` prediction means the measured target must be
    compared from each test's first row (the second return value says so).
    """
    own = _predict_header(path)
    frame = _read(path, None if own else options)
    column = _sim_column(frame, path, target, given)
    return frame[[column]], str(column).endswith("_since_start")


def _since_start(real, target):
    """``real`` with ``target`` measured from its first row in each test."""
    first = real.groupby(level="test", sort=False)[target].transform("first")
    return real.assign(**{target: real[target] - first})


def _custom_effect(text):
    """``NAME=COL[,COL]`` -> (name, [columns])."""
    name, sep, columns = text.partition("=")
    names = [c.strip() for c in columns.split(",") if c.strip()]
    if not sep or not name.strip() or not names:
        raise argparse.ArgumentTypeError(f"expected NAME=COL[,COL], got {text!r}")
    return name.strip(), names


def _run_gap(args):
    """Run ``greyml gap`` on parsed arguments; return the exit code."""
    from greyml.gap import diagnose_gap

    if args.effects is not None and not args.effects:
        raise ValueError("--effects names no effect; leave it out to try them all.")
    if args.json not in (None, "-"):
        _check_output_file(args.json, args.force, what="--json")
    options = flags._csv_options(args)
    with _progress(3, args.quiet) as progress:
        progress.step(f"reading {args.real!r} and {args.sim!r}")
        real = _read(args.real, options)
        sim, since_start = _read_sim(args.sim, options, args.target, args.sim_column)
        notes = []
        if since_start and args.target in real.columns:
            real = _since_start(real, args.target)
            notes.append(
                f"{sim.columns[0]} in {args.sim!r} is the change since each test's first row "
                f"(greyml predict's _since_start): the measured {args.target} is compared from "
                "its first row in each test too."
            )
        sensitivities = args.sensitivities
        if sensitivities is not None:
            sensitivities = _read(sensitivities, options)
        progress.step("diagnosing the gap (effects against random placebos)")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            report = diagnose_gap(
                real,
                sim,
                target=args.target,
                ambient=args.ambient,
                drivers=flags._unique(args.drivers),
                sensors=flags._unique(args.sensors),
                fbgs=flags._unique(args.fbgs),
                effects=None if args.effects is None else flags._unique(args.effects),
                random_state=args.random_state,
                sensitivities=sensitivities,
                tolerance=args.tolerance,
                custom_effects=dict(args.custom) if args.custom else None,
                quantum=args.quantum,
                step_time_s=args.step_time,
                driver_window_s=args.driver_window,
            )
        if since_start:
            report.reference = "start"
        data = report.to_dict()
        if args.json not in (None, "-"):
            progress.step(f"writing {args.json!r}")
            text = json.dumps(data, indent=2, allow_nan=False, ensure_ascii=False) + "\n"
            _write_text(args.json, text, args.force)
    _warn("gap", notes + _distinct_warnings(caught))
    if args.json == "-":
        # ASCII-only JSON reads back the same through any stdout encoding.
        sys.stdout.write(json.dumps(data, indent=2, allow_nan=False, ensure_ascii=True) + "\n")
        return flags.EXIT_OK
    print(_as_flags(str(report)))
    return flags.EXIT_OK


#: How the report names what to give, and the flag that gives it here.
_FLAGS = {
    "(ambient=)": "(--ambient)",
    "(drivers=)": "(--drivers)",
    "(sensors=)": "(--sensors)",
    "(the target among fbgs=)": "(the target among --fbgs)",
    "(effects=)": "(--effects)",
    "(custom_effects=)": "(--custom NAME=COL)",
}


def _as_flags(text):
    """The report's text with the keyword arguments it suggests as this command's flags."""
    for keyword, flag in _FLAGS.items():
        text = text.replace(keyword, flag)
    return text
