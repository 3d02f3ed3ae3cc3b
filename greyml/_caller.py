"""Warnings attributed to the user's call, however deep inside greyml they are raised.

``warnings.warn(..., stacklevel=n)`` names the file and line ``n`` frames up.
A fixed ``n`` breaks as soon as a helper is added between the public function
and the ``warn`` call, or a decorator wraps the public function (greyml's
:func:`~greyml._param_validation.validate_params` runs it from scikit-learn's
``_param_validation`` module, which a fixed ``n`` then blames).
:func:`warn_user` counts the frames instead: up to the first one that is
neither greyml's nor that wrapper's. Python 3.12's ``skip_file_prefixes`` does
the same; greyml supports 3.11.
"""

from __future__ import annotations

import sys
import warnings

__all__ = ["user_stacklevel", "warn_user"]

#: Modules outside greyml whose frames belong to greyml's own calls.
_WRAPPERS = ("sklearn.utils._param_validation",)


def _ours(frame):
    name = frame.f_globals.get("__name__", "")
    return name == "greyml" or name.startswith("greyml.") or name in _WRAPPERS


def user_stacklevel():
    """The ``stacklevel`` of a ``warnings.warn`` in the caller that names the user's line.

    The first frame, from the caller up, that is neither greyml's nor a
    wrapper's of greyml's functions.
    """
    frame = sys._getframe(1)
    level = 1
    while frame is not None and _ours(frame):
        frame = frame.f_back
        level += 1
    return level


def warn_user(message, category):
    """``warnings.warn(message, category)`` at the user's line that called into greyml.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_user("a message", UserWarning)
    >>> caught[0].message.args[0]
    'a message'
    """
    warnings.warn(message, category, stacklevel=user_stacklevel())
