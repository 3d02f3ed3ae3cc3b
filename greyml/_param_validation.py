"""The one door to scikit-learn's parameter validation.

greyml declares each estimator's parameters in ``_parameter_constraints`` and
checks them with ``self._validate_params()`` at the start of ``fit``; public
functions use :func:`validate_params`. The constraint classes live in
scikit-learn's *private* module ``sklearn.utils._param_validation``, which may
move or change between releases. Every greyml module imports them from here, so
that such a move is one change in this file (imbalanced-learn goes further and
keeps a copy of the module).
"""

from __future__ import annotations

from numbers import Integral, Real

from sklearn.utils._param_validation import (
    HasMethods,
    Hidden,
    Interval,
    InvalidParameterError,
    Options,
    StrOptions,
    validate_parameter_constraints,
    validate_params,
)

__all__ = [
    "HasMethods",
    "Hidden",
    "Integral",
    "Interval",
    "InvalidParameterError",
    "Options",
    "Real",
    "StrOptions",
    "validate_parameter_constraints",
    "validate_params",
]
