"""What ``greyml/dynamic/`` still reads of the old-name layer, until it goes.

Nothing was released, so nothing is deprecated: every other package has
dropped its old names. ``LagFeatures`` (``sample_step_s``) and
``ThermalTransferFunction`` (``relative_to_start``) still import these two
names; once they do not, this module goes too.
"""

from __future__ import annotations

import warnings

DEPRECATED = "deprecated"


def renamed_value(estimator, old, new):
    """The value of parameter ``new``, or of ``old`` with a FutureWarning if it was given."""
    value = getattr(estimator, old, DEPRECATED)
    if isinstance(value, str) and value == DEPRECATED:
        return getattr(estimator, new)
    warnings.warn(
        f"The {old!r} parameter of {type(estimator).__name__} was renamed {new!r}, the "
        f"name every greyml model and optimiser uses; {old!r} goes away in the next "
        f"release. Use {new}={value!r}.",
        FutureWarning,
        stacklevel=3,
    )
    return value
