"""Sim-to-real gap diagnosis: where a simulation misses and which effect it lacks."""

from greyml.gap._diagnose import diagnose_gap
from greyml.gap._effects import DESCRIPTIONS, EFFECTS
from greyml.gap._report import GapReport, GapWarning
from greyml.gap._validate import (
    WITHHELD,
    WithheldCase,
    WithheldValidation,
    perturb_parameters,
    random_tests,
    simulator_sensitivities,
    validate_withheld,
    withheld_case,
)
from greyml.gap._where import gap_breakdown, residual_diagnostics

__all__ = [
    "DESCRIPTIONS",
    "EFFECTS",
    "GapReport",
    "GapWarning",
    "WITHHELD",
    "WithheldCase",
    "WithheldValidation",
    "diagnose_gap",
    "gap_breakdown",
    "perturb_parameters",
    "random_tests",
    "residual_diagnostics",
    "simulator_sensitivities",
    "validate_withheld",
    "withheld_case",
]
