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
    greyml validate DATA.csv --target COL [--reference start|recording] [--json FILE]
                    [the model flags of greyml fit; --model-reference for its --reference]
    greyml predict MODEL.file DATA.csv --out PRED.csv [--force] [--initial-displacement V]
    greyml export MODEL.file --language {c,st,json} --out FILE [--name NAME]
                  [--rate-limit UM_S] [--quantum UM] [--clamp UM] [--on-missing hold|raise]
                  [--force]
    greyml --version

Every command takes ``--quiet`` (no progress on standard error; progress is
shown only when standard error is a terminal). Every command that reads a CSV
file (``select``, ``fit``, ``validate``, ``predict``, ``gap``) takes ``--time-unit s|min|h``
(the unit of the file's ``time_s`` column), ``--sep`` and ``--decimal`` (see
:func:`greyml.io.read_tests_csv`). Options renamed in this release still
work under their old spellings, which ``--help`` no longer shows, with a
one-line deprecation message on standard error that names the new one.

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

Every command: Ctrl-C exits with 130 and SIGTERM with 143, after one line
``greyml <command>: interrupted`` and after removing the files it was
writing (an output is complete or absent). Everything a command prints
passes through one filter that removes terminal control characters
(:func:`greyml._cli._printing.terminal_safe`).

``greyml demo`` fits the six models on the seeds' simulated tests and prints
them beside the papers' numbers; ``simulate``, ``select``, ``fit`` and
``predict`` are the steps of the same job on a user's CSV files. Each has its
``--help`` with an example. Their work is done in :mod:`greyml._cli`,
on greyml's public API; a user error exits with code 2 and one line
``greyml <command>: error: <message>``.

``python -m greyml`` runs the same command line. The numerical work is done
in :mod:`greyml.gap` and the rest of the package; :mod:`greyml._cli` (a module
per subcommand) only parses the arguments, calls it and writes the results.
This module is the command's front door: :func:`main` and :func:`build_parser`.

Examples
--------
::

    greyml gap real.csv sim.csv --target dz_um --ambient ambient_C \\
        --drivers spindle_rpm,feed_mm_min --sensors T1_C,T2_C --random-state 0
    greyml gap real.csv sim.csv --target dz_um --json - | jq .cause
"""

from greyml._cli import build_parser, main  # noqa: F401 (build_parser: docs/conf.py)

__all__ = ["main"]
