"""Random generators for estimators: never the global NumPy state."""

from __future__ import annotations

import numbers

import numpy as np

from greyml._param_validation import Integral, Interval

__all__ = ["RANDOM_STATE_CONSTRAINT", "make_generator"]

#: The ``_parameter_constraints`` entry of every ``random_state``: what
#: :func:`make_generator` accepts (scikit-learn's ``"random_state"`` plus a
#: ``Generator``, and any non-negative int rather than ints below 2**32).
RANDOM_STATE_CONSTRAINT = [
    Interval(Integral, 0, None, closed="left"),
    np.random.RandomState,
    np.random.Generator,
    None,
]


def make_generator(random_state) -> np.random.Generator:
    """A :class:`numpy.random.Generator` from an estimator's ``random_state``.

    ``None`` gives a fresh generator seeded from the operating system (the global
    NumPy state is neither read nor advanced); an int gives a reproducible one; a
    ``Generator`` is used as is; a legacy ``RandomState`` seeds a new generator
    from one draw (so, as in scikit-learn, passing the same instance to several
    fits gives different but reproducible streams).
    """
    if random_state is None:
        return np.random.default_rng()
    if isinstance(random_state, np.random.Generator):
        return random_state
    if isinstance(random_state, numbers.Integral) and not isinstance(random_state, bool):
        if random_state < 0:
            raise ValueError(f"random_state must be a non-negative int; got {random_state}.")
        return np.random.default_rng(int(random_state))
    if isinstance(random_state, np.random.RandomState):
        return np.random.default_rng(int(random_state.randint(np.iinfo(np.int32).max)))
    raise ValueError(
        "random_state must be None, an int, a numpy.random.Generator or a "
        f"numpy.random.RandomState; got {random_state!r}."
    )
