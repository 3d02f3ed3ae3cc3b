"""ANFIS's numerical kernels: firing strengths, consequents, premise gradient, fuzzy c-means.

Pure array functions that :class:`greyml.ANFISGrid` and :class:`greyml.ANFISFCM`
call after validating their input, vectorised over rules; no validation, no
random state of their own.
"""

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
