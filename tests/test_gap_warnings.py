"""A GapWarning is one line attributed to the line that called diagnose_gap."""

import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from greyml import make_test_index
from greyml._caller import user_stacklevel, warn_user
from greyml.exceptions import GapWarning
from greyml.gap import diagnose_gap
from greyml.gap._effects import first_order_lag


def _minutes_case():
    """A 40-min air lag with time_s holding minutes: 'ambient' ends at the shortest bound."""
    rng = np.random.default_rng(0)
    n, dt = 300, 30.0
    frames, sims = [], []
    for k in range(4):
        t = dt * np.arange(n)
        air = 20 + rng.normal(0, 1) + np.sin(2 * np.pi * t / 86400 * 4 + k)
        gap = -2.0 * first_order_lag(air - air[0], 2400.0, [dt], [(0, n)])
        index = make_test_index([f"T{k}"] * n, t / 60.0)  # minutes, labelled seconds
        sim = np.zeros(n)
        frames.append(
            pd.DataFrame(
                {"ambient_C": air, "dz_um": sim + gap + 0.05 * rng.standard_normal(n)},
                index=index,
            )
        )
        sims.append(pd.DataFrame({"dz_um": sim}, index=index))
    return pd.concat(frames), pd.concat(sims)


def test_a_gap_warning_names_the_callers_line_in_one_line():
    real, sim = _minutes_case()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        diagnose_gap(real, sim, target="dz_um", ambient="ambient_C", random_state=0)  # here
    gap_warnings = [w for w in caught if issubclass(w.category, GapWarning)]
    assert gap_warnings, [str(w.message) for w in caught]
    for w in gap_warnings:
        # before issue 27, scikit-learn's _param_validation.py was blamed
        assert w.filename == __file__, w.filename
        line = Path(w.filename).read_text(encoding="utf-8").splitlines()[w.lineno - 1]
        assert "diagnose_gap(real, sim" in line
        assert "\n" not in str(w.message)


def _ours_then_user():
    # this module is not greyml's: the first frame outside greyml is this one
    return user_stacklevel()


def test_user_stacklevel_stops_at_the_first_frame_outside_greyml():
    assert _ours_then_user() == 1
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_user("from inside greyml", UserWarning)
    assert caught[0].filename == __file__
