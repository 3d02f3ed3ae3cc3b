"""Utilities for working with greyml itself (as :mod:`sklearn.utils`).

:mod:`greyml.utils.discovery` lists the estimators greyml defines.
"""

__all__: list[str] = []
