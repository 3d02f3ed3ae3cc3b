"""The ``greyml`` command line.

Usage
-----
::

    greyml gap REAL.csv SIM.csv --target COL [--ambient COL] [--drivers A,B]
               [--sensors A,B] [--fbgs A,B] [--effects a,b] [--random-state N]
               [--sensitivities SENS.csv] [--tolerance X] [--json FILE|-]
    greyml --version

``greyml gap`` compares measured tests (``REAL.csv``) with a simulation of
the same tests (``SIM.csv``), both in greyml's CSV layout: the columns
``test`` and ``time_s``, then the data columns (see
:func:`greyml.io.read_tests_csv`). It runs :func:`greyml.gap.diagnose_gap`
and reports where the gap lies and which unmodelled effect causes it:

- without ``--json``, the report for people is printed;
- with ``--json FILE``, the report as JSON is written to ``FILE`` and the
  report for people is printed;
- with ``--json -``, the JSON is written to standard output, and nothing
  else is.

The JSON is strict (no ``NaN``: missing numbers are ``null``). It holds
``cause`` (the first significant effect, or ``null``), ``causes`` (one row
per effect: ``effect``, ``detail``, ``rmse_before``, ``rmse_after``,
``shrinkage``, ``significant`` and more), ``where`` (the gap by test, phase,
time and frequency band) and a summary; see
:meth:`greyml.gap.GapReport.to_dict`.

Exit codes: 0 when the diagnosis ran, whether or not it names a cause; 2 for
a usage error, a file that cannot be read or written, or data that cannot be
diagnosed (the message starts with ``greyml gap: error:``).

``python -m greyml`` runs the same command line. The numerical work is done
in :mod:`greyml.gap`; this module only parses the arguments, calls it and
writes the results.

Examples
--------
::

    greyml gap real.csv sim.csv --target dz_um --ambient ambient_C \\
        --drivers spindle_rpm,feed_mm_min --sensors T1_C,T2_C --random-state 0
    greyml gap real.csv sim.csv --target dz_um --json - | jq .cause
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import textwrap

import greyml
from greyml.gap import EFFECTS, diagnose_gap

__all__ = ["main"]

#: Exit codes, also listed in the ``--help`` text.
EXIT_OK = 0
EXIT_ERROR = 2

_GAP_EPILOG = f"""\
The CSV files have the columns test and time_s, then the data columns; SIM.csv
holds the simulated target (a column named like --target, or a single column)
for every measured (test, time_s) row.

Output: without --json, the report for people is printed. --json FILE also
writes the report as JSON to FILE; --json - writes only the JSON to standard
output. The JSON holds "cause" (null when no effect is significant), "causes"
(one row per effect) and "where" (where the gap lies), and never NaN.

{textwrap.fill("Effects (--effects): " + ", ".join(EFFECTS) + ".", width=79)}

Exit codes:
  {EXIT_OK}  the diagnosis ran (whether or not it names a cause)
  {EXIT_ERROR}  usage error, unreadable or unwritable file, or data that cannot be
     diagnosed (message on standard error)
"""


def _version():
    """greyml's version, or the installed distribution's, or ``"unknown"``."""
    version = getattr(greyml, "__version__", None)
    if version is None:
        from importlib.metadata import PackageNotFoundError
        from importlib.metadata import version as dist_version

        try:
            version = dist_version("greyml")
        except PackageNotFoundError:
            version = "unknown"
    return version


def _names(text):
    """Split a comma-separated list of names: whitespace stripped, empty items dropped."""
    return [item.strip() for item in text.split(",") if item.strip()]


def _unique(names):
    """The names in their first order, each once (a flag may be repeated)."""
    return list(dict.fromkeys(names or ()))


def _name(text):
    """One column name, whitespace stripped."""
    return text.strip()


def _add_gap_parser(subparsers):
    """The ``gap`` subcommand: its arguments and its handler."""
    parser = subparsers.add_parser(
        "gap",
        help="diagnose the gap between measured tests and a simulation",
        description=textwrap.fill(
            "Locate the gap between measured tests and a simulation of them (by test, "
            "phase, time and frequency band) and name the unmodelled effect that "
            "explains it, scored on held-out tests against random placebos "
            "(greyml.gap.diagnose_gap).",
            width=79,
        ),
        epilog=_GAP_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("real", metavar="REAL.csv", help="measured tests (CSV)")
    parser.add_argument("sim", metavar="SIM.csv", help="simulation of the same tests (CSV)")
    parser.add_argument(
        "--target", required=True, type=_name, metavar="COL", help="measured target column"
    )
    parser.add_argument("--ambient", type=_name, metavar="COL", help="ambient temperature column")
    lists = {
        "--drivers": "operating drivers, e.g. spindle_rpm,feed_mm_min (zero when off)",
        "--sensors": "temperature sensor columns",
        "--fbgs": "FBG columns (fbg_temperature is tried when the target is one)",
    }
    for flag, help_text in lists.items():
        parser.add_argument(
            flag,
            type=_names,
            action="extend",
            default=None,
            metavar="A,B",
            help=f"{help_text}; comma-separated, may be repeated",
        )
    parser.add_argument(
        "--effects",
        type=_names,
        action="extend",
        default=None,
        metavar="a,b",
        help="effects to try (default: all); comma-separated, may be repeated",
    )
    parser.add_argument(
        "--random-state",
        type=int,
        default=None,
        metavar="N",
        help="seed of the placebos, for a repeatable diagnosis (default: unseeded)",
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
        "--json",
        metavar="FILE|-",
        help="write the report as JSON to FILE, or only JSON to standard output with -",
    )
    parser.set_defaults(handler=_run_gap, parser=parser)
    return parser


def _run_gap(args):
    """Run ``greyml gap`` on parsed arguments; return the exit code."""
    if args.effects is not None and not args.effects:
        raise ValueError("--effects names no effect; leave it out to try them all.")
    report = diagnose_gap(
        args.real,
        args.sim,
        target=args.target,
        ambient=args.ambient,
        drivers=_unique(args.drivers),
        sensors=_unique(args.sensors),
        fbgs=_unique(args.fbgs),
        effects=None if args.effects is None else _unique(args.effects),
        random_state=args.random_state,
        sensitivities=args.sensitivities,
        tolerance=args.tolerance,
    )
    data = report.to_dict()
    if args.json == "-":
        # ASCII-only JSON reads back the same through any stdout encoding.
        sys.stdout.write(json.dumps(data, indent=2, allow_nan=False, ensure_ascii=True) + "\n")
        return EXIT_OK
    if args.json is not None:
        text = json.dumps(data, indent=2, allow_nan=False, ensure_ascii=False) + "\n"
        with open(args.json, "w", encoding="utf-8") as fh:
            fh.write(text)
    print(report)
    return EXIT_OK


def _os_message(exc):
    """A one-line message for a file that cannot be opened, naming the path."""
    path = exc.filename
    if path is None:
        return str(exc)
    path = os.fspath(path)
    if isinstance(exc, FileNotFoundError):
        return f"no such file or directory: {path!r}"
    reason = exc.strerror or type(exc).__name__
    return f"cannot open {path!r}: {reason}"


def build_parser():
    """The argument parser of the ``greyml`` command.

    Returns
    -------
    parser : argparse.ArgumentParser
        With one subparser per subcommand; each sets ``handler`` (a function
        of the parsed arguments returning the exit code) and ``parser``.
    """
    parser = argparse.ArgumentParser(
        prog="greyml",
        description="Thermal-error modelling of CNC machine tools.",
        epilog=f"Exit codes: {EXIT_OK} success, {EXIT_ERROR} error.",
    )
    parser.add_argument("--version", action="version", version=f"greyml {_version()}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_gap_parser(subparsers)
    return parser


def main(argv=None):
    """Run the ``greyml`` command line.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    code : int
        The exit code: 0 on success, 2 on a usage error or when the
        subcommand fails (the message is printed to standard error as
        ``greyml <command>: error: <message>``, without a traceback).
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version and usage errors
        return EXIT_OK if exc.code is None else int(exc.code)
    try:
        return args.handler(args)
    except OSError as exc:
        message = _os_message(exc)
    except ValueError as exc:
        message = str(exc)
    print(f"{args.parser.prog}: error: {message}", file=sys.stderr)
    return EXIT_ERROR
