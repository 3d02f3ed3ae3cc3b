"""The MLP's numerical kernels: forward pass, Jacobian, Levenberg–Marquardt.

Pure array functions that :class:`greyml.MLPBaseline` calls after validating
its input; the weights travel as one flat vector (``pack``/``unpack``), no
validation, no random state of their own.
"""

from greyml.neural._kernels import (
    ACTIVATIONS,
    LMResult,
    hidden,
    init_nguyen_widrow,
    levenberg_marquardt,
    mlp_forward,
    mlp_jacobian,
    mlp_residuals,
    n_params,
    pack,
    unpack,
)

__all__ = [
    "ACTIVATIONS",
    "LMResult",
    "hidden",
    "init_nguyen_widrow",
    "levenberg_marquardt",
    "mlp_forward",
    "mlp_jacobian",
    "mlp_residuals",
    "n_params",
    "pack",
    "unpack",
]
