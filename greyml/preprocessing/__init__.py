"""Transformations of tests that carry no learned state."""

from greyml.preprocessing._start import RelativeToStart

__all__ = ["RelativeToStart"]
