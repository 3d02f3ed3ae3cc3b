"""Sim-to-real gap diagnosis: where a simulation misses and which effect it lacks."""

from greyml.gap._diagnose import diagnose_gap
from greyml.gap._effects import DESCRIPTIONS, EFFECTS, LIBRARY, Effect
from greyml.gap._report import GapReport, GapWarning
from greyml.gap._where import gap_breakdown, residual_diagnostics

__all__ = [
    "DESCRIPTIONS",
    "EFFECTS",
    "Effect",
    "LIBRARY",
    "GapReport",
    "GapWarning",
    "diagnose_gap",
    "gap_breakdown",
    "residual_diagnostics",
]
