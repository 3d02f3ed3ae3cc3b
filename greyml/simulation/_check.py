"""Checks of the simulator's parts: each names the part, the parameter and the value."""

from __future__ import annotations

import numbers

import numpy as np

__all__ = ["real", "weights", "label", "member"]


def real(value, what, *, low=None, strict=False):
    """``value`` as a float: a finite real number, ``>= low`` (``> low`` if strict)."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    ok = ok and bool(np.isfinite(value))
    if ok and low is not None:
        ok = value > low if strict else value >= low
    if not ok:
        bound = "" if low is None else f" {'>' if strict else '>='} {low:g}"
        raise ValueError(f"{what} must be a finite number{bound}; got {value!r}.")
    return float(value)


def weights(mapping, what, *, total=None, low=0.0):
    """Check node weights: a non-empty mapping of names to finite numbers (summing to ``total``)."""
    if not hasattr(mapping, "items"):
        raise ValueError(
            f"{what}: the node weights must be a mapping of node to weight; got {mapping!r}."
        )
    if total is not None and not mapping:
        raise ValueError(f"{what}: 'nodes' is empty; give at least one node and its weight.")
    for node, value in mapping.items():
        real(value, f"{what}: the weight of node {node!r}", low=low)
    if total is not None:
        s = float(sum(mapping.values()))
        if abs(s - total) > 1e-6 * max(1.0, abs(total)):
            raise ValueError(f"{what}: its node weights (fractions) sum to {s:g}, not {total:g}.")


def label(value, what):
    """A non-empty string naming something."""
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{what} must be a non-empty string; got {value!r}.")
    return value


def member(value, allowed, message):
    """Raise ``ValueError(message)`` unless ``value`` is one of ``allowed``."""
    if value not in allowed:
        raise ValueError(message)
