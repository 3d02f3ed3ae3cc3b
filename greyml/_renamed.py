"""Parameters renamed to one name for one idea, the old names kept for one release.

An estimator declares ``_renamed_params = {"old": "new"}``, keeps ``old`` as a
constructor parameter whose default is ``"deprecated"`` (hidden from its
constraints' messages) and reads the value with :func:`renamed_value`, which
says with a ``FutureWarning`` that the old name was used. :mod:`greyml.persist`
maps a model file that still holds the old name onto the new one.
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


def upgrade_renamed(attributes, cls):
    """A model file's attributes with the old names of ``cls._renamed_params`` moved to the new."""
    for old, new in getattr(cls, "_renamed_params", {}).items():
        if old in attributes and new not in attributes:
            attributes[new] = attributes[old]
            attributes[old] = DEPRECATED
    return attributes
