"""``greyml gap``: where the gap between measured tests and a simulation lies, and why."""

from __future__ import annotations

import argparse
import json
import sys
import textwrap
import warnings

from greyml._cli import _flags as flags
from greyml._cli._files import _check_output_file, _read, _write_text
from greyml._cli._fitting import _distinct_warnings
from greyml._cli._printing import _progress, _warn

_GAP_EPILOG = """\
The CSV files have the columns test and time_s, then the data columns; SIM.csv
holds the simulated target (a column named like --target, or a single column)
for every measured (test, time_s) row.

Output: without --json, the report for people is printed. --json FILE also
writes the report as JSON to FILE; --json - writes only the JSON to standard
output. The report for people starts with the verdict (within_noise, explained,
partial or unexplained). The JSON holds "verdict", "unexplained_rms", "events"
(located steps and spikes: test, time_s, size), "cause" (null when no effect is
significant), "causes" (one row per effect, with p_value and shrinkage_ci) and
"where" (where the gap lies), and never NaN. An existing FILE is replaced
only with --force.

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
    parser.add_argument("sim", metavar="SIM.csv", help="simulation of the same tests (CSV)")
    flags._add_target(parser, "measured target column")
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
        sim = _read(args.sim, options)
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
            )
        data = report.to_dict()
        if args.json not in (None, "-"):
            progress.step(f"writing {args.json!r}")
            text = json.dumps(data, indent=2, allow_nan=False, ensure_ascii=False) + "\n"
            _write_text(args.json, text, args.force)
    _warn("gap", _distinct_warnings(caught))
    if args.json == "-":
        # ASCII-only JSON reads back the same through any stdout encoding.
        sys.stdout.write(json.dumps(data, indent=2, allow_nan=False, ensure_ascii=True) + "\n")
        return flags.EXIT_OK
    print(report)
    return flags.EXIT_OK
