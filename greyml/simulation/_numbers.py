"""A number that a caller gave, as a finite float, or a ValueError saying what it must be."""

from __future__ import annotations

import numpy as np


def as_float(value, not_a_number, out_of_range, *, low=None):
    """``value`` as a finite float, at least ``low`` if given; else a ValueError.

    Its message is ``not_a_number`` when ``float(value)`` fails and
    ``out_of_range`` when the number is not finite or is below ``low``, each
    followed by ``"; got <value>."``.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{not_a_number}; got {value!r}.") from None
    if not np.isfinite(number) or (low is not None and number < low):
        raise ValueError(f"{out_of_range}; got {number!r}.")
    return number
