"""The ``greyml`` command line, one module per subcommand (see :mod:`greyml.cli`).

- :mod:`greyml._cli._parser`: the argument parser and :func:`main`;
- :mod:`greyml._cli._demo`, ``_simulate``, ``_select``, ``_fit``, ``_validate``,
  ``_predict``, ``_export`` and ``_gap``: each subcommand's flags, help text and work;
- :mod:`greyml._cli._flags` (argument types and the one-line usage errors),
  :mod:`greyml._cli._printing` (progress, warnings, text safe for a terminal),
  :mod:`greyml._cli._files` (reading CSV tests, checking columns and output
  paths), :mod:`greyml._cli._fitting` (fitting with warnings collected),
  :mod:`greyml._cli._model` (the model built from the flags) and
  :mod:`greyml._cli._scores` (scores test by test, and their table): what the
  subcommands share.

The seeds' settings and numbers that ``greyml demo`` prints are in
:mod:`greyml._seeds`. Importing this package loads no NumPy, pandas or
scikit-learn: each subcommand imports them when it runs.
"""

from greyml._cli._parser import build_parser, main

__all__ = ["build_parser", "main"]
