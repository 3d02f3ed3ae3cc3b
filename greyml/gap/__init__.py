"""Sim-to-real gap diagnosis: where a simulation misses and which effect it lacks.

:func:`diagnose_gap` and its :class:`GapReport`; the parts of it that stand
alone (:func:`gap_breakdown`, :func:`residual_diagnostics`); the effect
library (:data:`LIBRARY` of :class:`Effect` records, with :data:`EFFECTS` and
:data:`DESCRIPTIONS` its views); and, for a simulation built with
:mod:`greyml.simulation`, its sensitivities to its own parameters
(:func:`simulator_sensitivities`, for ``diagnose_gap(..., sensitivities=)``)
and the machine with its parameters off (:func:`perturb_parameters`).
:class:`~greyml.exceptions.GapWarning` is in :mod:`greyml.exceptions`.
"""

from greyml.gap._diagnose import diagnose_gap
from greyml.gap._effects import DESCRIPTIONS, EFFECTS, LIBRARY, Effect
from greyml.gap._report import GapReport
from greyml.gap._sensitivities import perturb_parameters, simulator_sensitivities
from greyml.gap._where import gap_breakdown, residual_diagnostics

__all__ = [
    "DESCRIPTIONS",
    "EFFECTS",
    "Effect",
    "LIBRARY",
    "GapReport",
    "diagnose_gap",
    "gap_breakdown",
    "perturb_parameters",
    "residual_diagnostics",
    "simulator_sensitivities",
]
