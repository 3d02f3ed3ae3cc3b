"""Sim-to-real gap diagnosis: where the gap lies, which effect causes it, how far it shrinks."""

from greyml.gap._diagnose import diagnose_gap
from greyml.gap._effects import DESCRIPTIONS, EFFECTS
from greyml.gap._report import GapReport

__all__ = ["DESCRIPTIONS", "EFFECTS", "GapReport", "diagnose_gap"]
