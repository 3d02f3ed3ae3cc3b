"""Checking the gap diagnosis where the answer is known: effects withheld from a simulation.

The harness of :func:`greyml.gap.diagnose_gap`: greyml's simulator plays the
real machine and the simulation lacks an effect that the diagnosis should
name (or nothing, and it should stay silent). The diagnosis never imports
this package.
"""

from greyml.gap_validation._cases import (
    WITHHELD,
    WithheldCase,
    perturb_parameters,
    random_tests,
    simulator_sensitivities,
    withheld_case,
)
from greyml.gap_validation._withheld import WithheldValidation, validate_withheld

__all__ = [
    "WITHHELD",
    "WithheldCase",
    "WithheldValidation",
    "perturb_parameters",
    "random_tests",
    "simulator_sensitivities",
    "validate_withheld",
    "withheld_case",
]
