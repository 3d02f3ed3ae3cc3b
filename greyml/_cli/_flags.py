"""Flags shared by the ``greyml`` subcommands: argument types, the one-line parser.

Light on purpose: :mod:`greyml._cli._parser` builds ``greyml --help`` from
these without importing NumPy, pandas or scikit-learn.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import inspect
import sys
import textwrap

from greyml._command_names import CSV_TIME_UNITS

#: Exit codes, also listed in the ``--help`` text.
EXIT_OK = 0
EXIT_ERROR = 2
#: Stopped by Ctrl-C (SIGINT) or SIGTERM: 128 + the signal's number, as a shell reports it.
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 143


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


class _Names(argparse.Action):
    """``action="extend"`` that keeps each name once, in its first order."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, _unique([*(getattr(namespace, self.dest) or []), *values]))


def _add_names(parser, flag, help, *, metavar="A,B", dest=None):
    """``flag A,B``: a comma-separated list of names; repeating the flag adds to it.

    The list keeps each name once, in its first order; None when the flag is not given.
    """
    dest = dest or flag.lstrip("-").replace("-", "_")
    parser.add_argument(flag, type=_names, action=_Names, metavar=metavar, dest=dest, help=help)


def _add_target(parser, help="target column, e.g. dy_um"):
    """The required ``--target COL``."""
    parser.add_argument("--target", required=True, type=_name, metavar="COL", help=help)


def _add_random_state(parser, help, default=0, dest="random_state"):
    """``--random-state N``, the seed of the command's random choices."""
    parser.add_argument(
        "--random-state", type=int, default=default, metavar="N", dest=dest, help=help
    )


def _name_value(text, names, error):
    """``NAME=VALUE`` with NAME (whitespace stripped) one of ``names``: ``(NAME, VALUE)``.

    Anything else (no ``=``, another NAME) is a ValueError with the message ``error``.
    """
    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep or name not in names:
        raise ValueError(error)
    return name, value


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
    group.add_argument(
        "--test-column",
        type=_name,
        metavar="NAME",
        help="the column that labels the tests, e.g. cycle (default: test); a file whose "
        "time_s runs on across its tests is one recording cut into consecutive pieces",
    )


def _csv_options(args):
    """The keyword arguments of ``read_tests_csv`` from the parsed options."""
    return {
        "time_unit": args.time_unit,
        "sep": args.sep,
        "decimal": args.decimal,
        "test_column": args.test_column,
    }


def _call(run, args, **values):
    """``run(...)``, a ``run_<command>`` function, on the parsed arguments ``args``.

    Every parameter of ``run`` takes ``values[name]`` if given, else the parsed
    argument of its name (``csv_options``: :func:`_csv_options`); a parameter
    that is neither is a KeyError.

    A command that writes one file takes ``stdout``: with ``--out -`` (or
    ``--json -``) it writes the file there, and everything else the command
    prints goes to standard error meanwhile.
    """
    from greyml._cli._files import STDOUT

    parsed = dict(vars(args))
    if "time_unit" in parsed:
        parsed["csv_options"] = _csv_options(args)
    parsed.update(values)
    names = inspect.signature(run).parameters
    if "stdout" not in names:
        return run(**{name: parsed[name] for name in names})
    parsed["stdout"] = sys.stdout
    if STDOUT not in (parsed.get("out"), parsed.get("json")):
        return run(**{name: parsed[name] for name in names})
    with contextlib.redirect_stdout(sys.stderr):
        return run(**{name: parsed[name] for name in names})


def _calls(run):
    """The handler that calls ``run`` on the parsed arguments (see :func:`_call`)."""
    return functools.partial(_call, run)


def _end_options(parser, handler, *, reads_csv=True):
    """What every subcommand ends with: the CSV options if it reads CSV files, ``--quiet``.

    Also sets ``handler`` (a function of the parsed arguments returning the
    exit code, such as :func:`_calls`'s) and ``parser`` on the parsed arguments.
    """
    if reads_csv:
        _add_csv_options(parser)
    _add_quiet(parser)
    parser.set_defaults(handler=handler, parser=parser)


def _float_or_nan(text):
    """``text`` as a float, or NaN when it is not a number (NaN fails every range check)."""
    try:
        return float(text)
    except ValueError:
        return float("nan")


def _positive_number(text):
    """A number > 0 (``inf`` allowed: no bound), for bounds such as ``--max-displacement``."""
    value = _float_or_nan(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0; got {text!r}")
    return value


def _coverage(text):
    """A share strictly between 0 and 1, for an interval's coverage (``--interval 0.9``)."""
    value = _float_or_nan(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(
            f"expected a coverage between 0 and 1 (e.g. 0.9); got {text!r}"
        )
    return value


def _seconds_list(text):
    """``--time-constants``: comma-separated seconds (each finite and > 0), or ``fit``."""
    if text.strip().lower() == "fit":
        return "fit"
    values = []
    for item in _names(text):
        value = _float_or_nan(item)
        if not (value > 0 and value != float("inf")):
            raise argparse.ArgumentTypeError(
                f"must be seconds > 0 separated by commas, or fit; got {item!r}"
            )
        values.append(value)
    if not values:
        raise argparse.ArgumentTypeError(f"must name at least one time constant; got {text!r}")
    return values


def _count(text):
    """A whole number of at least 1 (a count of sensors)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number; got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1; got {value}")
    return value


def _subparser(subparsers, name, epilog, *, exit_codes=True):
    """The subcommand ``name`` of :data:`_COMMANDS`: one-line usage errors, a readable help.

    ``epilog`` ends its help, followed by :data:`_EXIT_CODES` unless
    ``exit_codes=False`` (an epilog that lists its own).
    """
    help, description = _COMMANDS[name]
    return subparsers.add_parser(
        name,
        help=help,
        description=textwrap.fill(description, width=79),
        epilog=epilog + _EXIT_CODES if exit_codes else epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        one_line=True,
    )


#: The lines of the exit codes 130 and 143 in every subcommand's help (the
#: end of :data:`_EXIT_CODES`, and of ``greyml gap``'s own list).
_EXIT_INTERRUPTED_HELP = f"""\
  {EXIT_INTERRUPTED}  interrupted by Ctrl-C (SIGINT)
  {EXIT_TERMINATED}  stopped by SIGTERM
       (one line on standard error: greyml <command>: interrupted; no partial
       or temporary file is left: each output is either complete or absent)
"""

_EXIT_CODES = f"""
Exit codes:
  {EXIT_OK}    success
  {EXIT_ERROR}    usage error, unreadable or unwritable file, or unusable data (one line
       on standard error: greyml <command>: error: <message>)
{_EXIT_INTERRUPTED_HELP}"""


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

#: The subcommands: the one-line help that ``greyml --help`` lists, and the
#: description that starts ``greyml <command> --help`` (filled to 79 columns).
_COMMANDS = {
    "demo": (
        "fit the six models on the seeds' simulated tests, beside the papers",
        "The main job on greyml's embedded data: select sensors, fit the six "
        "thermal-error models, validate them the seeds' way (train on one test, "
        "validate on the others) and print the results beside the numbers the "
        "seed papers report, with plots.",
    ),
    "simulate": (
        "write simulated heating/cooling tests of a machine to a CSV file",
        "Simulate heating/cooling tests of one of greyml's machines (the seeds' tests, "
        "or programmes of your own) and write them as a CSV file of tests "
        "(greyml.datasets.make_tests, greyml.io.write_tests_csv).",
    ),
    "select": (
        "choose a few sensors by grey influence and fuzzy c-means",
        "Choose the few sensors that matter for a target: print the sensors "
        "GreyInfluenceSelector keeps, with their group and influence weight.",
    ),
    "fit": (
        "train a thermal-error model on tests and save it",
        "Train one of greyml's thermal-error models (optionally after sensor "
        "selection) on the tests of a CSV file and save it to a model file.",
    ),
    "validate": (
        "score a model on each test held out in turn (leave one test out)",
        "Leave one test out with the model greyml fit would build from the same "
        "flags: each test is held out once and scored, and a table gives each "
        "test's RMSE, worst error and interval coverage in a named reference.",
    ),
    "predict": (
        "apply a saved model to tests and write the compensation",
        "Apply a model saved by greyml fit to new tests and write the predicted "
        "thermal error and the compensation value of every row to a CSV file.",
    ),
    "export": (
        "write a saved compensator as C, Structured Text or JSON for a controller",
        "Write the compensator of a saved transfer function (or a saved Compensator) "
        "as a C99 file, an IEC 61131-3 Structured Text function block or JSON, with "
        "the controller's rate limit, quantum, clamp and hold-last-value policy "
        "(greyml.Compensator.export).",
    ),
    "gap": (
        "diagnose the gap between measured tests and a simulation",
        "Locate the gap between measured tests and a simulation of them (by test, "
        "phase, time and frequency band) and name the unmodelled effect that "
        "explains it, scored on held-out tests against random placebos "
        "(greyml.gap.diagnose_gap).",
    ),
}


#: The parameters that several ``run_<command>`` functions share, for their
#: docstrings (:func:`greyml._docstrings.shared_doc`).
_CSV_AND_QUIET_DOC = """csv_options : dict, optional
        ``time_unit``, ``sep``, ``decimal`` and ``test_column`` of
        :func:`greyml.io.read_tests_csv`.
    quiet : bool, default=False
        No progress on standard error."""
