"""Takagi–Sugeno fuzzy inference (ANFIS) with Jang's hybrid learning."""

from greyml.fuzzy._anfis import ANFISFCM, ANFISGrid
from greyml.fuzzy._kernels import (
    JangStepSize,
    anfis_forward,
    fcm_memberships,
    fuzzy_cmeans,
    hybrid_learning,
    log_firing,
    normalised_firing,
    premise_gradient,
    solve_consequents,
)

__all__ = [
    "ANFISFCM",
    "ANFISGrid",
    "JangStepSize",
    "anfis_forward",
    "fcm_memberships",
    "fuzzy_cmeans",
    "hybrid_learning",
    "log_firing",
    "normalised_firing",
    "premise_gradient",
    "solve_consequents",
]
