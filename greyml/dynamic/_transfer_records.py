"""The records of one ThermalTransferFunction fit, and its banks of time constants.

Small frozen dataclasses that travel between the steps of
:meth:`greyml.ThermalTransferFunction.fit` (the checked settings, the
checked data, one bank with the sensors and penalty chosen on it), and the
longer banks tried for slow dynamics. No validation, no pandas.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from greyml.dynamic._time import Timeline

__all__ = ["Bank", "Data", "Settings", "longer_banks", "span"]


@dataclass(frozen=True)
class Settings:
    """The checked parameters of one fit."""

    taus: np.ndarray
    driver_taus: np.ndarray
    fit_taus: bool
    powers: tuple
    alphas: np.ndarray
    reference: str
    extend: bool


@dataclass(frozen=True)
class Data:
    """The checked training data of one fit."""

    X: np.ndarray
    y: np.ndarray
    w: np.ndarray
    segments: list
    bounds: list
    names: list
    drivers: list
    sensors: list
    steps: Timeline
    gap_limit: float


@dataclass(frozen=True)
class Bank:
    """One bank of time constants with the sensors and penalty chosen on it."""

    taus: np.ndarray
    driver_taus: np.ndarray
    spec: list
    groups: list
    labels: list
    col_group: np.ndarray
    grams: tuple
    pen: np.ndarray
    chosen: list
    alpha: float
    score: float
    path: list


def span(data):
    """The longest stretch of time that the lags run through without a restart."""
    t = np.cumsum(np.nan_to_num(data.steps.dt, nan=0.0))
    longest, start = 0.0, 0.0
    for i, (first, stop) in enumerate(data.bounds):
        if i == 0 or not data.steps.carried[i]:
            start = t[first]
        longest = max(longest, t[stop - 1] - start)
    return longest


def longer_banks(taus, driver_taus, span):
    """The bank extended by a lag three times slower at a time, while it fits in ``span``."""
    out = []
    ts, td = list(taus), list(driver_taus)
    while 3.0 * ts[-1] <= span:
        ts = [*ts, 3.0 * ts[-1]]
        td = [*td, 3.0 * td[-1]]
        out.append((np.asarray(ts), np.asarray(td)))
    return out
