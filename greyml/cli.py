"""The ``greyml`` command line.

Usage
-----
::

    greyml gap REAL.csv SIM.csv --target COL [--ambient COL] [--drivers A,B]
               [--sensors A,B] [--fbgs A,B] [--effects a,b] [--random-state N]
               [--sensitivities SENS.csv] [--tolerance X] [--custom NAME=COL[,COL]]
               [--json FILE|-] [--force]
    greyml demo [--out DIR] [--force] [--quick]
    greyml simulate --machine {vmc,vmc-probe,gantry} --out FILE.csv
                    [--programme SPEC] [--tests seeds|A,B] [--ambient C]
                    [--random-state N] [--force]
    greyml select DATA.csv --target COL [--n-sensors N] [--cluster-on series|influence]
                  [--train-tests A,B] [--sensors A,B] [--random-state N]
    greyml fit DATA.csv --target COL --model {gmc,gnnmci,anfis-grid,anfis-fcm,mlp}
               --out MODEL.file [--n-sensors N] [--cluster-on ...] [--sensors A,B]
               [--train-tests A,B] [--random-state N] [--force]
    greyml predict MODEL.file DATA.csv --out PRED.csv [--force] [--initial-displacement V]
    greyml --version

Every command takes ``--quiet`` (no progress on standard error; progress is
shown only when standard error is a terminal). Every command that reads a CSV
file (``select``, ``fit``, ``predict``, ``gap``) takes ``--time-unit s|min|h``
(the unit of the file's ``time_s`` column), ``--sep`` and ``--decimal`` (see
:func:`greyml.io.read_tests_csv`). The spellings ``--seed`` (simulate), ``--n``
(select), ``--select`` (fit) and ``--train-test`` (select) still work in this
release, with a one-line deprecation message on standard error.

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

``--json FILE`` refuses to replace an existing ``FILE`` unless ``--force``.

Exit codes: 0 when the diagnosis ran, whether or not it names a cause; 2 for
a usage error, a file that cannot be read or written, or data that cannot be
diagnosed (one line starting with ``greyml gap: error:``).

``greyml demo`` fits the six models on the seeds' simulated tests and prints
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

# Only light modules here: ``greyml --help`` and ``--version`` must answer
# without importing NumPy, pandas or scikit-learn (each command imports what
# it needs when it runs).
from greyml import __version__
from greyml._command_names import CSV_TIME_UNITS, MACHINES, MODEL_NAMES

__all__ = ["main"]

#: Exit codes, also listed in the ``--help`` text.
EXIT_OK = 0
EXIT_ERROR = 2

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

Exit codes:
  {ok}  the diagnosis ran (whether or not it names a cause)
  {error}  usage error, unreadable or unwritable file, or data that cannot be
     diagnosed (one line on standard error: greyml gap: error: <message>)
"""


def _gap_epilog():
    """The gap epilog, listing the effects (imported only when the help is shown)."""
    from greyml.gap import EFFECTS

    effects = textwrap.fill("Effects (--effects): " + ", ".join(EFFECTS) + ".", width=79)
    return _GAP_EPILOG.format(effects=effects, ok=EXIT_OK, error=EXIT_ERROR)


def _version():
    """greyml's version, or the installed distribution's, or ``"unknown"``."""
    version = __version__
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

    def format_help(self):
        if callable(self.epilog):  # an epilog that needs a heavy import, made when shown
            self.epilog = self.epilog()
        return super().format_help()


class _Deprecated(argparse.Action):
    """An old spelling of an option: works, with a one-line message on standard error.

    ``new`` is the option to use instead; ``extend=True`` adds the value to a
    list (as ``action="extend"``), ``as_list=True`` adds one value.
    """

    def __init__(self, option_strings, dest, *, new, extend=False, as_list=False, **kwargs):
        self.new = new
        self.extend = extend
        self.as_list = as_list
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None):
        print(
            f"{parser.prog}: warning: {option_string} is deprecated and will be removed in the "
            f"next release; use {self.new}",
            file=sys.stderr,
        )
        if self.extend or self.as_list:
            items = list(getattr(namespace, self.dest, None) or [])
            items += values if self.extend else [values]
            values = items
        setattr(namespace, self.dest, values)


def _add_quiet(parser):
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="no progress on standard error (shown only on a terminal, for steps that "
        "can take seconds)",
    )


def _separator(text):
    """``--sep``: one character; ``tab`` or ``\\t`` for a tab."""
    value = {"tab": "\t", "\\t": "\t"}.get(text.strip().lower(), text)
    if len(value) != 1:
        raise argparse.ArgumentTypeError(f"must be one character or 'tab'; got {text!r}")
    return value


def _add_csv_options(parser):
    """``--time-unit``, ``--sep`` and ``--decimal`` of a command that reads CSV files."""
    group = parser.add_argument_group("reading the CSV files")
    group.add_argument(
        "--time-unit",
        choices=CSV_TIME_UNITS,
        default="s",
        help="unit of the time_s column in the files, converted to seconds (default: s)",
    )
    group.add_argument(
        "--sep",
        type=_separator,
        metavar="C",
        help="separator: one character, or tab (default: the first of , ; and tab that "
        "splits the header into test and time_s)",
    )
    group.add_argument(
        "--decimal",
        choices=(".", ","),
        help="decimal mark (default: '.', or ',' when a ;- or tab-separated file "
        "has numbers like 20,5)",
    )


def _csv_options(args):
    """The keyword arguments of ``read_tests_csv`` from the parsed options."""
    return {"time_unit": args.time_unit, "sep": args.sep, "decimal": args.decimal}


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
  1. simulates Abdulshahed et al.'s (2015) six VMC tests and Abdulshahed et al.'s (2016) three gantry tests
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
        help="fit the six models on the seeds' simulated tests, beside the papers",
        description=(
            "The main job on greyml's embedded data: select sensors, fit the six "
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
    _add_quiet(parser)
    parser.set_defaults(handler=_run_demo, parser=parser)


def _run_demo(args):
    from greyml._commands import run_demo

    return run_demo(args.out, force=args.force, quick=args.quick, quiet=args.quiet)


_SIMULATE_EPILOG = (
    """\
The CSV has the columns test and time_s, then the operating inputs, the sensors
(T<k>_C, FBG<k>_ue) and the displacements (dx_um, dy_um, dz_um); read it with
greyml.io.read_tests_csv.

Tests (default: all the seeds' tests of the machine):
  vmc        Abdulshahed et al.'s (2015) Tests I-VI (76 temperature sensors, every minute)
  vmc-probe  Abdulshahed et al.'s (2017) 200-min probing test (9 sensors, every 10 s)
  gantry     Abdulshahed et al.'s (2016) Z-axis, C-axis and helical tests (12 temperatures and
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
  greyml simulate --machine vmc --out mine.csv --random-state 1 \\
      --programme 120:spindle_rpm=4000,60 --programme 60:spindle_rpm=8000,60
  greyml simulate --machine gantry --out c.csv --programme 120:c_rpm=2500,120
"""
    + _EXIT_CODES
)


def _add_simulate_parser(subparsers):
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
        "--random-state",
        type=int,
        default=0,
        metavar="N",
        help="seed of the measurement noise (default: 0, the data of greyml.datasets); "
        "--seed N is its deprecated spelling",
    )
    parser.add_argument(
        "--seed",
        dest="random_state",
        type=int,
        action=_Deprecated,
        new="--random-state",
        metavar="N",
        help=argparse.SUPPRESS,
    )
    parser.add_argument("--force", action="store_true", help="replace FILE.csv if it exists")
    _add_quiet(parser)
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
        seed=args.random_state,
        force=args.force,
        quiet=args.quiet,
    )


_SENSORS_HELP = (
    "candidate sensor columns, comma-separated (default: every column except the "
    "target, the displacements *_um and the operating inputs spindle_rpm, "
    "feed_mm_min, c_rpm, ambient_C)"
)
_CLUSTER_HELP = (
    "what fuzzy c-means groups: influence (default, as GreyInfluenceSelector; "
    "Abdulshahed et al. (2015): sensors of similar influence weight) or series "
    "(sensors that move together)"
)

_SELECT_EPILOG = (
    """\
DATA.csv has the columns test and time_s, then the data columns (as greyml
simulate writes them). For every candidate sensor, GM(1,N) of the target
gives an influence weight; fuzzy c-means sorts the sensors into --n-sensors
groups and the most influential sensor of each group is kept
(greyml.GreyInfluenceSelector). The sensors are used as they are in the file.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml select vmc.csv --target dy_um --n-sensors 5 --train-tests IV
  greyml select vmc.csv --target dy_um --cluster-on series --sensors T1_C,T2_C,T3_C
  greyml select spreadsheet.csv --target dz_um --time-unit min --sep ';' --decimal ,
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
        "--n-sensors",
        type=_count,
        default=5,
        metavar="N",
        help="sensors to keep (default: 5); --n N is its deprecated spelling",
    )
    parser.add_argument(
        "--n",
        dest="n_sensors",
        type=_count,
        action=_Deprecated,
        new="--n-sensors",
        metavar="N",
        help=argparse.SUPPRESS,
    )
    parser.add_argument("--cluster-on", choices=("series", "influence"), help=_CLUSTER_HELP)
    parser.add_argument(
        "--train-tests",
        type=_names,
        action="extend",
        metavar="A,B",
        help="select on these tests only (default: all tests); --train-test LABEL is its "
        "deprecated spelling",
    )
    parser.add_argument(
        "--train-test",
        dest="train_tests",
        type=_name,
        action=_Deprecated,
        new="--train-tests",
        as_list=True,
        metavar="LABEL",
        help=argparse.SUPPRESS,
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
    _add_csv_options(parser)
    _add_quiet(parser)
    parser.set_defaults(handler=_run_select, parser=parser)


def _run_select(args):
    from greyml._commands import run_select

    return run_select(
        args.data,
        args.target,
        n=args.n_sensors,
        cluster_on=args.cluster_on,
        train_tests=_unique(args.train_tests),
        sensors=_unique(args.sensors),
        random_state=args.random_state,
        csv_options=_csv_options(args),
        quiet=args.quiet,
    )


_FIT_EPILOG = (
    """\
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
              what the controller knows, --max-sensors for a sensor budget

--n-sensors N puts GreyInfluenceSelector before the model in one Pipeline, so the
saved model chooses its own sensors. The model is saved with
greyml.persist.save_model (a file that holds no code); apply it with greyml
predict.

Inputs are used as they are in the file. When tests start at different
temperatures, the static models (anfis-grid, anfis-fcm, mlp) carry over to new
tests far better on temperature rises from each test's start than on absolute
temperatures (greyml demo uses rises): write rises into the CSV if so.

Examples:
  greyml simulate --machine vmc --out vmc.csv
  greyml fit vmc.csv --target dy_um --model anfis-fcm --n-sensors 5 \\
      --train-tests IV --out vmc-anfis.greyml
  greyml fit vmc.csv --target dy_um --model gmc --sensors T18_C,T55_C,T63_C \\
      --out vmc-gmc.greyml
  greyml fit vmc.csv --target dy_um --model transfer-function \\
      --drivers spindle_rpm --max-sensors 5 --out vmc-ttf.greyml
"""
    + _EXIT_CODES
)


def _add_fit_parser(subparsers):
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
        "--n-sensors",
        type=_count,
        metavar="N",
        help="keep N sensors with GreyInfluenceSelector before the model; --select N is "
        "its deprecated spelling",
    )
    parser.add_argument(
        "--select",
        dest="n_sensors",
        type=_count,
        action=_Deprecated,
        new="--n-sensors",
        metavar="N",
        help=argparse.SUPPRESS,
    )
    parser.add_argument(
        "--cluster-on",
        choices=("series", "influence"),
        help="the selector's grouping, with --n-sensors: " + _CLUSTER_HELP.split(": ", 1)[1],
    )
    parser.add_argument(
        "--drivers",
        type=_names,
        action="extend",
        metavar="A,B",
        help="--model transfer-function: columns the controller knows (spindle speed, "
        "feed), always inputs and not counted as sensors",
    )
    parser.add_argument(
        "--max-sensors",
        type=_count,
        metavar="N",
        help="--model transfer-function: at most N temperature sensors, chosen inside the "
        "fit on held-out whole tests",
    )
    parser.add_argument(
        "--sensors",
        type=_names,
        action="extend",
        metavar="A,B",
        help="the model's inputs, or the selector's candidates with --n-sensors, "
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
    _add_csv_options(parser)
    _add_quiet(parser)
    parser.set_defaults(handler=_run_fit, parser=parser)


def _run_fit(args):
    from greyml._commands import run_fit

    return run_fit(
        args.data,
        args.target,
        args.model,
        args.out,
        select=args.n_sensors,
        cluster_on=args.cluster_on,
        sensors=_unique(args.sensors),
        train_tests=_unique(args.train_tests),
        random_state=args.random_state,
        force=args.force,
        csv_options=_csv_options(args),
        quiet=args.quiet,
        drivers=_unique(args.drivers),
        max_sensors=args.max_sensors,
    )


_PREDICT_EPILOG = (
    """\
DATA.csv needs the sensor columns the model reads (a model fitted with --select
reads only the sensors it kept). PRED.csv has the columns test, time_s,
predicted_<target> (the thermal error the model predicts, in the target's
unit) and compensation_<target> = -predicted_<target> (the correction to add to
the axis). When DATA.csv also holds the measured target, the accuracy is
printed. A grey model predicts the change since each test's first row: for a
test that starts mid-run, give the measured target there with
--initial-displacement (a warning names a test whose sensors start away from
where the training tests started).
printed. A model that predicts NaN or an infinite value for any row is an
error (exit 2), and no PRED.csv is written; the file is written to a
temporary name and renamed, so a failure never leaves a partial PRED.csv.
Test labels a spreadsheet would run as formulas (=, +, -, @) get a leading '.

Examples:
  greyml simulate --machine vmc --tests IV --out train.csv
  greyml simulate --machine vmc --tests V,VI --out new-tests.csv
  greyml fit train.csv --target dy_um --model anfis-fcm --select 5 --out vmc.greyml
  greyml predict vmc.greyml new-tests.csv --out compensation.csv
  greyml predict gmc.greyml tail.csv --out comp.csv --initial-displacement V=-48.5
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
    parser.add_argument(
        "--initial-displacement",
        metavar="VALUE|TEST=VALUE[,TEST=VALUE]",
        help=(
            "grey models (gmc, gnnmci) only: the measured target at the first row of "
            "every test (VALUE) or of the tests named, for tests that start mid-run"
        ),
    )
    _add_csv_options(parser)
    _add_quiet(parser)
    parser.set_defaults(handler=_run_predict, parser=parser)


def _run_predict(args):
    from greyml._commands import run_predict

    return run_predict(
        args.model,
        args.data,
        args.out,
        force=args.force,
        initial_displacement=args.initial_displacement,
        csv_options=_csv_options(args),
        quiet=args.quiet,
    )


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
        epilog=_gap_epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        one_line=True,
    )
    _add_gap_arguments(parser)
    return parser


def _add_gap_arguments(parser):
    """The arguments of ``greyml gap``."""
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
    parser.add_argument("--force", action="store_true", help="replace the --json FILE if it exists")
    _add_csv_options(parser)
    _add_quiet(parser)
    parser.set_defaults(handler=_run_gap, parser=parser)


def _custom_effect(text):
    """``NAME=COL[,COL]`` -> (name, [columns])."""
    name, sep, columns = text.partition("=")
    names = [c.strip() for c in columns.split(",") if c.strip()]
    if not sep or not name.strip() or not names:
        raise argparse.ArgumentTypeError(f"expected NAME=COL[,COL], got {text!r}")
    return name.strip(), names


def _run_gap(args):
    """Run ``greyml gap`` on parsed arguments; return the exit code."""
    from greyml._commands import _check_output_file, _progress, _read
    from greyml.gap import diagnose_gap

    if args.effects is not None and not args.effects:
        raise ValueError("--effects names no effect; leave it out to try them all.")
    if args.json not in (None, "-"):
        _check_output_file(args.json, args.force, what="--json")
    options = _csv_options(args)
    with _progress(3, args.quiet) as progress:
        progress.step(f"reading {args.real!r} and {args.sim!r}")
        real = _read(args.real, options)
        sim = _read(args.sim, options)
        sensitivities = args.sensitivities
        if sensitivities is not None:
            sensitivities = _read(sensitivities, options)
        progress.step("diagnosing the gap (effects against random placebos)")
        report = diagnose_gap(
            real,
            sim,
            target=args.target,
            ambient=args.ambient,
            drivers=_unique(args.drivers),
            sensors=_unique(args.sensors),
            fbgs=_unique(args.fbgs),
            effects=None if args.effects is None else _unique(args.effects),
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
    if args.json == "-":
        # ASCII-only JSON reads back the same through any stdout encoding.
        sys.stdout.write(json.dumps(data, indent=2, allow_nan=False, ensure_ascii=True) + "\n")
        return EXIT_OK
    print(report)
    return EXIT_OK


def _write_text(path, text, force):
    """Write ``text`` to ``path`` through a temporary file; an existing file only if ``force``."""
    import secrets

    folder = os.path.dirname(os.path.abspath(path))
    temp = os.path.join(folder, f".{os.path.basename(path)}.{secrets.token_hex(4)}.part")
    fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with open(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        if force:
            os.replace(temp, path)
        else:
            try:
                os.link(temp, path)  # FileExistsError if the file appeared meanwhile
            except FileExistsError:
                raise ValueError(f"--json {path!r} exists; pass --force to replace it.") from None
            except OSError:  # no hard links on this file system
                os.replace(temp, path)
            else:
                os.unlink(temp)
    finally:
        if os.path.exists(temp):
            os.unlink(temp)


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
    from greyml._commands import printable

    print(f"{args.parser.prog}: error: {printable(message)}", file=sys.stderr)
    return EXIT_ERROR
