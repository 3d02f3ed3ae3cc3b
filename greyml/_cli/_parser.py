"""The ``greyml`` argument parser and :func:`main` (see :mod:`greyml.cli`)."""

from __future__ import annotations

import argparse
import os
import signal
import sys

# Only light modules here: ``greyml --help`` and ``--version`` must answer
# without importing NumPy, pandas or scikit-learn (each command imports what
# it needs when it runs).
from greyml import __version__
from greyml._cli._demo import _add_demo_parser
from greyml._cli._export import _add_export_parser
from greyml._cli._fit import _add_fit_parser
from greyml._cli._flags import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_TERMINATED,
    _Parser,
)
from greyml._cli._gap import _add_gap_parser
from greyml._cli._interrupt import interrupts
from greyml._cli._predict import _add_predict_parser
from greyml._cli._printing import printable, terminal_safe
from greyml._cli._select import _add_select_parser
from greyml._cli._simulate import _add_simulate_parser
from greyml._cli._validate import _add_validate_parser

__all__ = ["build_parser", "main"]


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
        epilog=f"Exit codes: {EXIT_OK} success, {EXIT_ERROR} error, {EXIT_INTERRUPTED} "
        f"interrupted (Ctrl-C), {EXIT_TERMINATED} terminated (SIGTERM).",
    )
    parser.add_argument("--version", action="version", version=f"greyml {_version()}")
    subparsers = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=_Parser
    )
    _add_demo_parser(subparsers)
    _add_simulate_parser(subparsers)
    _add_select_parser(subparsers)
    _add_fit_parser(subparsers)
    _add_validate_parser(subparsers)
    _add_predict_parser(subparsers)
    _add_export_parser(subparsers)
    _add_gap_parser(subparsers)
    return parser


def main(argv=None):
    """Run the ``greyml`` command line.

    Everything the command prints passes through
    :func:`greyml._cli._printing.terminal_safe` (no terminal control from a
    file reaches the terminal), and Ctrl-C or SIGTERM stop it cleanly
    (:func:`greyml._cli._interrupt.interrupts`): the files it was writing are
    removed, one line ``greyml <command>: interrupted`` is printed, and the
    exit code says which signal it was.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after the program name; ``sys.argv[1:]`` by default.

    Returns
    -------
    code : int
        The exit code: 0 on success; 2 on a usage error or when the
        subcommand fails (the message is printed to standard error as
        ``greyml <command>: error: <message>``, without a traceback); 130
        when interrupted by Ctrl-C (SIGINT), 143 by SIGTERM.

    Examples
    --------
    >>> from greyml.cli import main
    >>> main(["--version"])  # doctest: +ELLIPSIS
    greyml ...
    0
    """
    with terminal_safe(), interrupts() as signals:
        prog = "greyml"
        try:
            parser = build_parser()
            try:
                args = parser.parse_args(argv)
            except SystemExit as exc:  # --help, --version and usage errors
                code = EXIT_OK if exc.code is None else int(exc.code)
            else:
                prog = args.parser.prog
                code = _run(args, signals)
            signals.disarm()  # from here on, a signal is only noted
        except KeyboardInterrupt as exc:
            signals.disarm()
            signum = getattr(exc, "signum", signal.SIGINT)
        except Exception:
            signals.disarm()
            if signals.first is None:
                raise
            signum = signals.first  # an error the interrupt caused, reported as one
        else:
            if signals.first is None:
                return code
            signum = signals.first  # the interrupt was swallowed on the way
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_TERMINATED if signum == signal.SIGTERM else EXIT_INTERRUPTED


def _run(args, signals):
    """Run the parsed command; a user error is one line on standard error and code 2.

    An error after a signal (``signals.first``) is left to :func:`main`, which
    reports the interrupt instead.
    """
    try:
        return args.handler(args)
    except (OSError, ValueError) as exc:
        if signals.first is not None:
            raise
        message = _os_message(exc) if isinstance(exc, OSError) else str(exc)
    print(f"{args.parser.prog}: error: {printable(message)}", file=sys.stderr)
    return EXIT_ERROR
