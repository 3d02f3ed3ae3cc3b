"""Shared fixtures: multi-test data with known GMC coefficients, where the real data lies.

``benchmarks/`` goes on ``sys.path`` here, so that the tests import the gap
diagnosis's validation harness (``benchmarks/gap_harness``) as the benchmark
scripts do: the harness is not part of the package.
"""

import os
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from greyml import make_test_index
from greyml.grey._functions import simulate_gmc

#: Where this repository's checkout keeps the real CAIVIAC recording (never copied in).
_SHARED_CAIVIAC = Path(__file__).resolve().parents[1].parent / "shared" / "realdata" / "caiviac"


def caiviac_csv():
    """The CAIVIAC ``cycles.csv`` the tests read, or None when it is absent.

    ``$GREYML_CAIVIAC`` (the folder holding it) if set, else
    ``../shared/realdata/caiviac`` beside this checkout. greyml itself reads
    only a path it is given or :func:`greyml.datasets.fetch_caiviac`'s cache.
    """
    folder = Path(os.environ.get("GREYML_CAIVIAC") or _SHARED_CAIVIAC)
    path = folder / "cycles.csv"
    return path if path.is_file() else None


def caiviac_csv_or_skip():
    """:func:`caiviac_csv`, or skip the test when the recording is absent."""
    path = caiviac_csv()
    if path is None:
        pytest.skip(
            "the CAIVIAC recording ($GREYML_CAIVIAC or ../shared/realdata/caiviac) is absent"
        )
    return path


BENCHMARKS = str(Path(__file__).resolve().parents[1] / "benchmarks")
if BENCHMARKS not in sys.path:
    sys.path.insert(0, BENCHMARKS)

TRUE_B1 = 0.3
TRUE_B = np.array([0.8, -0.5, 0.3, 0.2])
TRUE_U = -2.0


def exciting_drivers(rng, n, n_drivers=4):
    """Smoothed random walks around 20 °C: persistently exciting, not collinear."""
    steps = lfilter([0.3], [1.0, -0.7], rng.normal(size=(n, n_drivers)), axis=0)
    return 20.0 + 0.5 * np.cumsum(steps, axis=0)


@pytest.fixture
def gmc_tests():
    """Four tests (different lengths) from the GMC response with known coefficients."""
    rng = np.random.default_rng(42)
    frames = []
    for label, n in [("I", 80), ("II", 100), ("III", 90), ("IV", 110)]:
        X = exciting_drivers(rng, n)
        y = simulate_gmc(X, TRUE_B1, TRUE_B, TRUE_U)
        index = make_test_index([label] * n, 10.0 * np.arange(n))
        frame = pd.DataFrame(X, index=index, columns=[f"T{j + 1}_C" for j in range(4)])
        frame["dz_um"] = y
        frames.append(frame)
    return pd.concat(frames)


def rewrite_model_file(path, out, edit):
    """Copy a greyml.persist model file to ``out`` after ``edit(state)`` changed
    the top object's attribute table: a file as an older greyml wrote it."""
    import json
    import zipfile

    with zipfile.ZipFile(path) as z:
        members = {n: z.read(n) for n in z.namelist()}
    tree = json.loads(members["model.json"])
    edit(tree["tree"]["state"])
    members["model.json"] = json.dumps(tree).encode()
    with zipfile.ZipFile(out, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    return out
