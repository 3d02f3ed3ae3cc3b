"""The ``greyml`` command line.

Usage
-----
::

    greyml gap REAL.csv SIM.csv --target COL [--ambient COL] [--drivers A,B]
               [--sensors A,B] [--fbgs A,B] [--effects a,b] [--random-state N]
               [--sensitivities SENS.csv] [--tolerance X] [--custom NAME=COL[,COL]]
               [--json FILE|-]
    greyml demo [--out DIR] [--force] [--quick]
    greyml simulate --machine {vmc,vmc-probe,gantry} --out FILE.csv
                    [--programme SPEC] [--tests seeds|A,B] [--ambient C]
                    [--seed N] [--force]
    greyml select DATA.csv --target COL [--n N] [--cluster-on series|influence]
                  [--train-test LABEL] [--sensors A,B] [--random-state N]
    greyml fit DATA.csv --target COL --model {gmc,gnnmci,anfis-grid,anfis-fcm,mlp}
               --out MODEL.file [--select N] [--cluster-on ...] [--sensors A,B]
               [--train-tests A,B] [--random-state N] [--force]
    greyml predict MODEL.file DATA.csv --out PRED.csv [--force]
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

``greyml demo`` fits the five models on the seeds' simulated tests and prints
them beside the papers' numbers; ``simulate``, ``select``, ``fit`` and
``predict`` are the steps of the same job on a user's CSV files. Each has its
``--help`` with an example. Their work is done in :mod:`greyml._commands`,
on greyml's public API; a user error exits with code 2 and one line
``greyml <command>: error: <message>``.

``python -m greyml`` runs the same command line. The numerical work is done
in :mod:`greyml.gap` and the rest of the package; this module only parses the
arguments, calls it and writes the results.

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
output. The report for people starts with the verdict (within_noise, explained,
partial or unexplained). The JSON holds "verdict", "unexplained_rms", "events"
(located steps and spikes: test, time_s, size), "cause" (null when no effect is
significant), "causes" (one row per effect, with p_value and shrinkage_ci) and
"where" (where the gap lies), and never NaN.

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


class _Parser(argparse.ArgumentParser):
    """An argument parser that can report a usage error on one line.

    With ``one_line=True`` a usage error prints only
    ``greyml <command>: error: <message> (see greyml <command> --help)`` and
    exits with code 2; otherwise it behaves as :class:`argparse.ArgumentParser`
    (usage, then the error).
    """

    def __init__(self, *args, one_line=False, **kwargs):
        super().__init__(*args, **kwargs)
        self.one_line = one_line

    def error(self, message):
        if not self.one_line:
            super().error(message)
        self.exit(EXIT_ERROR, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _count(text):
    """A whole number of at least 1 (a count of sensors)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number; got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1; got {value}")
    return value


def _subparser(subparsers, name, *, help, description, epilog):
    """A subcommand whose usage errors are one line, with a readable help text."""
    return subparsers.add_parser(
        name,
        help=help,
        description=textwrap.fill(description, width=79),
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        one_line=True,
    )


_EXIT_CODES = f"""
Exit codes:
  {EXIT_OK}  success
  {EXIT_ERROR}  usage error, unreadable or unwritable file, or unusable data (one line
     on standard error: greyml <command>: error: <message>)
"""

_DEMO_EPILOG = (
    """\
What it does:
  1. simulates seed 001's six VMC tests and seed 000's three gantry tests
     (greyml.datasets.load_vmc_tests, load_gantry_tests);
  2. on each machine, fits GMC, GNNMCI, ANFISGrid, ANFISFCM and MLPBaseline, each
     after GreyInfluenceSelector (5 sensors) in one Pipeline, on the seeds'
     training tests (VMC: Test IV; gantry: the Z-axis and C-axis tests);
  3. validates them on the other tests and prints R, RMSE, E (Nash-Sutcliffe),
     the residual band and the improvement beside what the papers report;
  4. writes one plot per model and machine (measured and predicted displacement
     over time, the residual and its band) and results.txt to --out.

The full run takes about half a minute; --quick (smaller swarms, fewer epochs)
a few seconds.

Examples:
  greyml demo
  greyml demo --out demo-results --quick
"""
    + _EXIT_CODES
)


def _add_demo_parser(subparsers):
    parser = _subparser(
        subparsers,
        "demo",
        help="fit the five models on the seeds' simulated tests, beside the papers",
        description=(
            "The main job on greyml's embedded data: select sensors, fit the five "
            "thermal-error models, validate them the seeds' way (train on one test, "
            "validate on the others) and print the results beside the numbers the "
            "seed papers report, with plots."
        ),
        epilog=_DEMO_EPILOG,
    )
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
    parser.set_defaults(handler=_run_demo, parser=parser)


def _run_demo(args):
    from greyml._commands import run_demo

    return run_demo(args.out, force=args.force, quick=args.quick)


_SIMULATE_EPILOG = (
    """\
The CSV has the columns test and time_s, then the operating inputs, the sensors
(T<k>_C, FBG<k>_ue) and the displacements (dx_um, dy_um, dz_um); read it with
greyml.io.read_tests_csv.

Tests (default: all the seeds' tests of the machine):
  vmc        seed 001's Tests I-VI (76 temperature sensors, every minute)
  vmc-probe  seeds 002/004's 200-min probing test (9 sensors, every 10 s)
  gantry     seed 000's Z-axis, C-axis and helical tests (12 temperatures and
             7 FBGs, every 20 s)
--tests A,B keeps only these of the seeds' tests.

--programme SPEC simulates a test of your own instead (repeat it for several
tests; they are labelled P1, P2, ...). SPEC is segments separated by commas:
MINUTES alone stops everything (the machine cools); MINUTES:NAME=VALUE runs an
operating input, NAME one of spindle_rpm, feed_mm_min (vmc, vmc-probe, gantry)
or c_rpm (gantry). The air stays at --ambient degrees C.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml simulate --machine vmc --tests IV,V --out vmc-iv-v.csv
  greyml simulate --machine vmc --out mine.csv \\
      --programme 120:spindle_rpm=4000,60 --programme 60:spindle_rpm=8000,60
  greyml simulate --machine gantry --out c.csv --programme 120:c_rpm=2500,120
"""
    + _EXIT_CODES
)


def _add_simulate_parser(subparsers):
    from greyml._commands import MACHINES

    parser = _subparser(
        subparsers,
        "simulate",
        help="write simulated heating/cooling tests of a machine to a CSV file",
        description=(
            "Simulate heating/cooling tests of one of greyml's machines (the seeds' tests, "
            "or programmes of your own) and write them as a CSV file of tests "
            "(greyml.datasets.make_tests, greyml.io.write_tests_csv)."
        ),
        epilog=_SIMULATE_EPILOG,
    )
    parser.add_argument(
        "--machine", required=True, choices=MACHINES, help="the machine to simulate"
    )
    parser.add_argument("--out", required=True, metavar="FILE.csv", help="CSV file to write")
    parser.add_argument(
        "--programme",
        action="append",
        metavar="SPEC",
        help="a test of your own, e.g. 120:spindle_rpm=4000,60 (may be repeated)",
    )
    parser.add_argument(
        "--tests",
        metavar="seeds|A,B",
        help="the seeds' tests (default), or only the ones named, e.g. IV,V",
    )
    parser.add_argument(
        "--ambient",
        type=float,
        default=20.0,
        metavar="C",
        help="air temperature in degrees C of --programme tests (default: 20)",
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        metavar="N",
        help="seed of the measurement noise (default: 0, the data of greyml.datasets)",
    )
    parser.add_argument("--force", action="store_true", help="replace FILE.csv if it exists")
    parser.set_defaults(handler=_run_simulate, parser=parser)


def _run_simulate(args):
    from greyml._commands import run_simulate

    tests = None
    if args.tests is not None and args.tests.strip() != "seeds":
        tests = _unique(_names(args.tests))
        if not tests:
            raise ValueError("--tests names no test; write seeds or labels like IV,V.")
    return run_simulate(
        args.machine,
        args.out,
        programmes=args.programme,
        tests=tests,
        ambient=args.ambient,
        seed=args.seed,
        force=args.force,
    )


_SENSORS_HELP = (
    "candidate sensor columns, comma-separated (default: every column except the "
    "target, the displacements *_um and the operating inputs spindle_rpm, "
    "feed_mm_min, c_rpm, ambient_C)"
)
_CLUSTER_HELP = (
    "what fuzzy c-means groups: series (default; sensors that move together) or "
    "influence (seed 001: sensors of similar influence weight)"
)

_SELECT_EPILOG = (
    """\
DATA.csv has the columns test and time_s, then the data columns (as greyml
simulate writes them). For every candidate sensor, GM(1,N) of the target
gives an influence weight; fuzzy c-means sorts the sensors into --n groups and
the most influential sensor of each group is kept (greyml.GreyInfluenceSelector).
The sensors are used as they are in the file.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml select vmc.csv --target dy_um --n 5 --train-test IV
  greyml select vmc.csv --target dy_um --cluster-on influence --sensors T1_C,T2_C,T3_C
"""
    + _EXIT_CODES
)


def _add_select_parser(subparsers):
    parser = _subparser(
        subparsers,
        "select",
        help="choose a few sensors by grey influence and fuzzy c-means",
        description=(
            "Choose the few sensors that matter for a target: print the sensors "
            "GreyInfluenceSelector keeps, with their group and influence weight."
        ),
        epilog=_SELECT_EPILOG,
    )
    parser.add_argument("data", metavar="DATA.csv", help="tests (CSV)")
    parser.add_argument(
        "--target", required=True, type=_name, metavar="COL", help="target column, e.g. dy_um"
    )
    parser.add_argument(
        "--n", type=_count, default=5, metavar="N", help="sensors to keep (default: 5)"
    )
    parser.add_argument(
        "--cluster-on", choices=("series", "influence"), default="series", help=_CLUSTER_HELP
    )
    parser.add_argument(
        "--train-test",
        type=_name,
        metavar="LABEL",
        help="select on this test only (default: all tests)",
    )
    parser.add_argument(
        "--sensors", type=_names, action="extend", metavar="A,B", help=_SENSORS_HELP
    )
    parser.add_argument(
        "--random-state",
        type=int,
        default=0,
        metavar="N",
        help="seed of the c-means starts (default: 0)",
    )
    parser.set_defaults(handler=_run_select, parser=parser)


def _run_select(args):
    from greyml._commands import run_select

    return run_select(
        args.data,
        args.target,
        n=args.n,
        cluster_on=args.cluster_on,
        train_test=args.train_test,
        sensors=_unique(args.sensors),
        random_state=args.random_state,
    )


_FIT_EPILOG = (
    """\
Models (the seeds' settings):
  gmc         GMC(1,N) by least squares (seed 000's GMC-LS)
  gnnmci      GNNMCI(1,N), particle swarm of 90 x 100 iterations (seed 000)
  anfis-grid  ANFIS with 3 Gaussian MFs per input, 100 epochs (seed 001;
              3^5 = 243 rules on 5 inputs, so give few inputs)
  anfis-fcm   ANFIS with 3 fuzzy c-means rules, 100 epochs (seed 001)
  mlp         one hidden layer of 10, Levenberg-Marquardt (seed 000's baseline)

--select N puts GreyInfluenceSelector before the model in one Pipeline, so the
saved model chooses its own sensors. The model is saved with
greyml.persist.save_model (a file that holds no code); apply it with greyml
predict.

Inputs are used as they are in the file. When tests start at different
temperatures, the static models (anfis-grid, anfis-fcm, mlp) carry over to new
tests far better on temperature rises from each test's start than on absolute
temperatures (greyml demo uses rises): write rises into the CSV if so.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml fit vmc.csv --target dy_um --model anfis-fcm --select 5 \\
      --train-tests IV --out vmc-anfis.greyml
  greyml fit vmc.csv --target dy_um --model gmc --sensors T18_C,T55_C,T63_C \\
      --out vmc-gmc.greyml
"""
    + _EXIT_CODES
)


def _add_fit_parser(subparsers):
    from greyml._commands import MODEL_NAMES

    parser = _subparser(
        subparsers,
        "fit",
        help="train a thermal-error model on tests and save it",
        description=(
            "Train one of greyml's thermal-error models (optionally after sensor "
            "selection) on the tests of a CSV file and save it to a model file."
        ),
        epilog=_FIT_EPILOG,
    )
    parser.add_argument("data", metavar="DATA.csv", help="training tests (CSV)")
    parser.add_argument(
        "--target", required=True, type=_name, metavar="COL", help="target column, e.g. dy_um"
    )
    parser.add_argument("--model", required=True, choices=list(MODEL_NAMES), help="the model")
    parser.add_argument("--out", required=True, metavar="MODEL.file", help="model file to write")
    parser.add_argument(
        "--select",
        type=_count,
        metavar="N",
        help="keep N sensors with GreyInfluenceSelector before the model",
    )
    parser.add_argument(
        "--cluster-on",
        choices=("series", "influence"),
        default="series",
        help="the selector's grouping, with --select: " + _CLUSTER_HELP.split(": ", 1)[1],
    )
    parser.add_argument(
        "--sensors",
        type=_names,
        action="extend",
        metavar="A,B",
        help="the model's inputs, or the selector's candidates with --select, "
        + _SENSORS_HELP.split("candidate sensor columns, ", 1)[1],
    )
    parser.add_argument(
        "--train-tests",
        type=_names,
        action="extend",
        metavar="A,B",
        help="train on these tests only (default: all tests)",
    )
    parser.add_argument(
        "--random-state",
        type=int,
        default=0,
        metavar="N",
        help="seed of the model's random choices (default: 0)",
    )
    parser.add_argument("--force", action="store_true", help="replace MODEL.file if it exists")
    parser.set_defaults(handler=_run_fit, parser=parser)


def _run_fit(args):
    from greyml._commands import run_fit

    return run_fit(
        args.data,
        args.target,
        args.model,
        args.out,
        select=args.select,
        cluster_on=args.cluster_on,
        sensors=_unique(args.sensors),
        train_tests=_unique(args.train_tests),
        random_state=args.random_state,
        force=args.force,
    )


_PREDICT_EPILOG = (
    """\
DATA.csv needs the sensor columns the model reads (a model fitted with --select
reads only the sensors it kept). PRED.csv has the columns test, time_s,
predicted_<target> (the thermal error the model predicts, in the target's
unit) and compensation_<target> = -predicted_<target> (the correction to add to
the axis). When DATA.csv also holds the measured target, the accuracy is
printed.

Examples:
  greyml simulate --machine vmc --tests IV --out train.csv
  greyml simulate --machine vmc --tests V,VI --out new-tests.csv
  greyml fit train.csv --target dy_um --model anfis-fcm --select 5 --out vmc.greyml
  greyml predict vmc.greyml new-tests.csv --out compensation.csv
"""
    + _EXIT_CODES
)


def _add_predict_parser(subparsers):
    parser = _subparser(
        subparsers,
        "predict",
        help="apply a saved model to tests and write the compensation",
        description=(
            "Apply a model saved by greyml fit to new tests and write the predicted "
            "thermal error and the compensation value of every row to a CSV file."
        ),
        epilog=_PREDICT_EPILOG,
    )
    parser.add_argument("model", metavar="MODEL.file", help="model file from greyml fit")
    parser.add_argument("data", metavar="DATA.csv", help="tests (CSV) with the model's sensors")
    parser.add_argument("--out", required=True, metavar="PRED.csv", help="CSV file to write")
    parser.add_argument("--force", action="store_true", help="replace PRED.csv if it exists")
    parser.set_defaults(handler=_run_predict, parser=parser)


def _run_predict(args):
    from greyml._commands import run_predict

    return run_predict(args.model, args.data, args.out, force=args.force)


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
    parser.set_defaults(handler=_run_gap, parser=parser)
    return parser


def _custom_effect(text):
    """``NAME=COL[,COL]`` -> (name, [columns])."""
    name, sep, columns = text.partition("=")
    names = [c.strip() for c in columns.split(",") if c.strip()]
    if not sep or not name.strip() or not names:
        raise argparse.ArgumentTypeError(f"expected NAME=COL[,COL], got {text!r}")
    return name.strip(), names


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
        custom_effects=dict(args.custom) if args.custom else None,
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
    subparsers = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=_Parser
    )
    _add_demo_parser(subparsers)
    _add_simulate_parser(subparsers)
    _add_select_parser(subparsers)
    _add_fit_parser(subparsers)
    _add_predict_parser(subparsers)
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

    Examples
    --------
    >>> from greyml.cli import main
    >>> main(["--version"])  # doctest: +ELLIPSIS
    greyml ...
    0
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
