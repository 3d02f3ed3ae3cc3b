"""Transformations of tests that carry no learned state.

- :class:`RelativeToStart`: each column as its change since its test's first
  row.
"""

from greyml.preprocessing._start import RelativeToStart

__all__ = ["RelativeToStart"]
