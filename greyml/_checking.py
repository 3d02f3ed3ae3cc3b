"""Checking (validation) data for the learning models, taken the seeds' way.

ANFIS (Abdulshahed et al. (2015), after MATLAB's ``anfis``) and the MLP
(Abdulshahed et al. (2016), after MATLAB's ``trainlm``) keep the parameters of
the epoch with the lowest error on *checking* data. With several tests,
checking data must be whole tests: rows of a test are strongly autocorrelated,
so rows held out from a test that is also trained on measure interpolation, not
generalisation. With a single test the checking part is the end of that test
(Abdulshahed et al. (2015) splits Test IV into training, checking and testing
parts in time order).
"""

from __future__ import annotations

import numpy as np

from greyml._sequences import Segment, segment_label

__all__ = ["checking_split"]


def checking_split(segments: list[Segment], fraction: float, rng: np.random.Generator):
    """Rows for training and rows for checking.

    Parameters
    ----------
    segments : list of Segment
        The tests, as :func:`greyml._sequences.segments_by_test` returns them.
    fraction : float in [0, 1)
        Share of the data to hold out. 0 holds nothing out.
    rng : numpy.random.Generator
        Chooses which whole tests are held out when there are several.

    Returns
    -------
    train, check : ndarray of int
        Row positions; ``check`` is empty when ``fraction`` is 0.
    description : str
        What was held out, for ``checking_`` attributes and messages.
    """
    n = segments[-1].stop if segments else 0
    rows = np.arange(n)
    if fraction == 0.0:
        return rows, rows[:0], "no checking data"
    if len(segments) > 1:
        n_check = min(len(segments) - 1, max(1, int(round(fraction * len(segments)))))
        chosen = np.sort(rng.choice(len(segments), size=n_check, replace=False))
        mask = np.zeros(n, dtype=bool)
        for i in chosen:
            mask[segments[i].slice] = True
        labels = ", ".join(segment_label(segments[i]) for i in chosen)
        return rows[~mask], rows[mask], f"whole tests held out: {labels}"
    n_check = int(round(fraction * n))
    n_check = min(max(n_check, 1), n - 1)
    return rows[: n - n_check], rows[n - n_check :], f"last {n_check} of {n} rows"
