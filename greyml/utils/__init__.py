"""Utilities for working with greyml itself (as :mod:`sklearn.utils`).

- :mod:`greyml.utils.discovery`: :func:`~greyml.utils.discovery.all_estimators`,
  the estimators greyml defines.
"""

__all__: list[str] = []
