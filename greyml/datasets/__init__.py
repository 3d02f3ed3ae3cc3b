"""Data sets in greyml's test-data layout.

Simulated from the seed papers' machines and tests (:func:`load_vmc_tests`,
:func:`load_probe_test`, :func:`load_gantry_tests`, :func:`make_tests`) and
the real CAIVIAC recording: read where it lies beside a checkout
(:func:`load_caiviac`), or downloaded once, checked and cached for any user
(:func:`fetch_caiviac`). Every
loader returns a Bunch with ``frame`` (indexed by ``test`` and ``time_s``),
``sensors``, ``targets``, ``inputs``, ``sensor_groups``, ``tests`` and
``description``, or ``(X, y)`` with ``return_X_y=True``.
"""

from greyml.datasets._caiviac import caiviac_candidates, load_caiviac
from greyml.datasets._fetch import fetch_caiviac
from greyml.datasets._simulated import (
    bunch_from_frame,
    load_gantry_tests,
    load_probe_test,
    load_vmc_tests,
    make_tests,
)

__all__ = [
    "bunch_from_frame",
    "caiviac_candidates",
    "fetch_caiviac",
    "load_caiviac",
    "load_gantry_tests",
    "load_probe_test",
    "load_vmc_tests",
    "make_tests",
]
