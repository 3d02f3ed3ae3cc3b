"""Data sets in greyml's test-data layout.

- :func:`load_vmc_tests`, :func:`load_probe_test`, :func:`load_gantry_tests`:
  the seed papers' machines and test programmes, simulated;
- :func:`make_tests`: tests of one's own programmes on those machines;
- :func:`fetch_caiviac`: the real CAIVIAC recording, downloaded once, checked
  and cached;
- :func:`load_caiviac`: the same recording read from a folder you give, or
  from :func:`fetch_caiviac`'s cache.

Every loader returns a Bunch with ``frame`` (indexed by ``test`` and
``time_s``), ``sensors``, ``targets``, ``inputs``, ``sensor_groups``,
``tests`` and ``description``, or ``(X, y)`` with ``return_X_y=True``.
"""

from greyml.datasets._caiviac import load_caiviac
from greyml.datasets._fetch import fetch_caiviac
from greyml.datasets._simulated import (
    load_gantry_tests,
    load_probe_test,
    load_vmc_tests,
    make_tests,
)

__all__ = [
    "fetch_caiviac",
    "load_caiviac",
    "load_gantry_tests",
    "load_probe_test",
    "load_vmc_tests",
    "make_tests",
]
