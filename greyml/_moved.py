"""Names that moved or were renamed, still found under the old name for one release.

A package's ``__getattr__`` hands out the object from its new place (a
family's ``kernels`` namespace) or under its new name with a
``FutureWarning`` naming it, for one release; ``__all__`` and the
documentation name the new place only.
"""

from __future__ import annotations

import importlib
import warnings


def moved_getattr(package, names, new_module):
    """A module ``__getattr__`` serving ``names`` from ``new_module`` with a FutureWarning.

    Parameters
    ----------
    package : str
        The package the names used to be imported from (``"greyml.grey"``).
    names : collection of str
        The names that moved.
    new_module : str
        Where they are now (``"greyml.grey.kernels"``).
    """
    names = frozenset(names)

    def __getattr__(name):
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        warnings.warn(
            f"{package}.{name} moved to {new_module}.{name}; import it from there "
            f"(the old name goes away in the next release).",
            FutureWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(new_module), name)

    return __getattr__


def renamed(package, old, new, value):
    """``value``, the object now named ``new``, asked for by its old name ``old``:
    with a FutureWarning at the caller of the package's ``__getattr__``.

    Parameters
    ----------
    package : str
        The package both names belong to (``"greyml"``).
    old, new : str
        The old and the new name.
    value : object
        What the new name holds.
    """
    warnings.warn(
        f"{package}.{old} was renamed {package}.{new}; use the new name (the old one goes "
        "away in the next release).",
        FutureWarning,
        stacklevel=3,
    )
    return value
