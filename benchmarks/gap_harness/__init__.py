"""Checking the gap diagnosis where the answer is known: effects withheld from a simulation.

The harness of :func:`greyml.gap.diagnose_gap`, run by
``benchmarks/bench_gap_validation.py``, ``bench_gap_measured.py`` and the
tests: greyml's simulator plays the real machine and the simulation lacks an
effect that the diagnosis should name (or nothing, and it should stay
silent). It lives beside the benchmarks, outside the package: greyml never
imports it. What a user needs for their own simulation of
:mod:`greyml.simulation` is public in :mod:`greyml.gap`
(:func:`~greyml.gap.simulator_sensitivities`,
:func:`~greyml.gap.perturb_parameters`).

The benchmark scripts import it as they import ``_common`` (their folder is
the first entry of ``sys.path``); the tests put ``benchmarks/`` on
``sys.path`` in ``tests/conftest.py``.
"""

from gap_harness._cases import (
    WITHHELD,
    WithheldCase,
    random_tests,
    withheld_case,
)
from gap_harness._withheld import WithheldValidation, validate_withheld

__all__ = [
    "WITHHELD",
    "WithheldCase",
    "WithheldValidation",
    "random_tests",
    "validate_withheld",
    "withheld_case",
]
