"""Parameters renamed to one name for one idea, the old names kept for one release.

An estimator declares ``_renamed_params = {"old": "new"}``, keeps ``old`` as a
constructor parameter whose default is ``"deprecated"`` (hidden from its
constraints' messages) and reads the value with :func:`renamed_value`, which
says with a ``FutureWarning`` that the old name was used. A fitted attribute
renamed the same way is declared in ``_renamed_attributes`` and kept readable
under its old name by :func:`renamed_attribute`. :mod:`greyml.persist` maps a
model file that still holds an old name onto the new one.

A parameter added since a release is declared in ``_added_params`` (its
name): a model file written before it existed takes its default, which is the
behaviour before it (:func:`upgrade_renamed` does both).
"""

from __future__ import annotations

import inspect
import warnings

from greyml._param_validation import Hidden, StrOptions

DEPRECATED = "deprecated"


def renamed_constraints(old, new, constraint):
    """The ``_parameter_constraints`` entries of a renamed parameter: ``new``
    takes ``constraint``; ``old`` takes it too or its hidden default."""
    return {new: [constraint], old: [constraint, Hidden(StrOptions({DEPRECATED}))]}


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


def renamed_attribute(old, new):
    """A read-only property ``old`` that gives the fitted attribute ``new`` with a FutureWarning."""

    def getter(self):
        if new not in vars(self):  # unfitted: as if neither name existed
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {old!r}")
        warnings.warn(
            f"The fitted attribute {old!r} of {type(self).__name__} was renamed {new!r}, "
            f"the name scikit-learn uses; {old!r} goes away in the next release.",
            FutureWarning,
            stacklevel=2,
        )
        return vars(self)[new]

    return property(getter, doc=f"Old name of ``{new}`` (deprecated).")


def upgrade_renamed(attributes, cls):
    """A model file's attributes with the old names of ``cls._renamed_params`` and
    ``cls._renamed_attributes`` moved to the new, and the parameters of
    ``cls._added_params`` that the file lacks at their defaults."""
    for old, new in getattr(cls, "_renamed_params", {}).items():
        if old in attributes and new not in attributes:
            attributes[new] = attributes[old]
            attributes[old] = DEPRECATED
    for old, new in getattr(cls, "_renamed_attributes", {}).items():
        if old in attributes:
            value = attributes.pop(old)
            attributes.setdefault(new, value)
    added = [name for name in getattr(cls, "_added_params", ()) if name not in attributes]
    if added:
        parameters = inspect.signature(cls.__init__).parameters
        for name in added:
            attributes[name] = parameters[name].default
    return attributes
