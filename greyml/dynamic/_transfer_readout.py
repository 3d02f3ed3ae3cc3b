"""What a fitted ThermalTransferFunction says: its gains, step responses and a summary.

A mixin of the estimator's readable side (tables, step responses,
``describe``), kept apart from the fitting code.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_is_fitted

from greyml._sequences import TIME_LEVEL
from greyml._time import format_duration

__all__ = []


def _round_step(peak):
    """A round step size for a driver: the power of ten below its largest value."""
    if not np.isfinite(peak) or peak <= 0:
        return 1.0
    return float(10.0 ** np.floor(np.log10(peak)))


class _TransferReadout:
    """Tables, step responses and ``describe`` of a fitted transfer function."""

    @property
    def selection_(self):
        """Forward selection step by step, as a table: the sensor added, the mean
        held-out RMSE and the penalty, one row per step (empty without
        ``max_sensors``); with ``selection="stable"``, each sensor any run
        chose and the share of runs that chose it.
        """
        check_is_fitted(self)
        return pd.DataFrame(self._selection_path_, columns=self._selection_columns_)

    @property
    def gains_(self):
        """Each input's gains as a table: one row per input and power, one column
        per term (``static``, ``lag 5 min`` and so on), each the weight of its
        term in ``terms_`` (µm per unit of the input raised to the power, for a
        displacement in µm).
        """
        check_is_fitted(self)
        return self._gain_table()

    def _terms(self):
        terms = []
        c = 0
        for (_col, power, taus), (name, _) in zip(self._spec_, self._labels_):
            for tau in (None, *taus):
                weight = float(self.feature_coef_[c])
                if weight != 0.0:
                    terms.append((name, power, None if tau is None else float(tau), weight))
                c += 1
        return terms

    def _gain_table(self):
        rows, index = [], []
        all_taus = sorted({t for _, _, taus in self._spec_ for t in taus})
        columns = ["static"] + [f"lag {format_duration(t)}" for t in all_taus]
        c = 0
        for (_col, power, taus), (name, _) in zip(self._spec_, self._labels_):
            row = dict.fromkeys(columns, np.nan)
            row["static"] = self.feature_coef_[c]
            for j, tau in enumerate(taus):
                row[f"lag {format_duration(tau)}"] = self.feature_coef_[c + 1 + j]
            c += 1 + len(taus)
            group_in = name in self.drivers_ or name in self.selected_sensors_
            if group_in:
                rows.append(row)
                index.append((name, power))
        table = pd.DataFrame(rows, columns=columns)
        table.index = pd.MultiIndex.from_tuples(index, names=["input", "power"])
        return table

    def step_response(self, input, step=None, *, start=0.0, times=None):
        """Displacement after a step of one input, all other inputs held.

        Parameters
        ----------
        input : str
            A driver or a selected sensor.
        step : float, optional
            Size of the step in the input's unit; default ``step_sizes_[input]``
            (1 K for a sensor, e.g. 1000 rpm for a spindle).
        start : float, default=0.0
            Value before the step (matters for powers above 1).
        times : array-like, optional
            Seconds after the step; default 0 to five times the largest time
            constant, 200 points.

        Returns
        -------
        response : Series
            Displacement change (units of y) indexed by ``time_s``.
        """
        check_is_fitted(self)
        if input not in self.step_sizes_:
            raise ValueError(
                f"step_response: {input!r} is not an input of this model (inputs: "
                f"{', '.join(self.step_sizes_)})."
            )
        step = self.step_sizes_[input] if step is None else float(step)
        if times is None:
            top = 5.0 * max(self.time_constants_.max(), self.driver_time_constants_.max())
            times = np.linspace(0.0, top, 200)
        times = np.asarray(times, dtype=float)
        out = np.zeros_like(times)
        for name, power, tau, weight in self.terms_:
            if name != input:
                continue
            jump = (start + step) ** power - start**power
            shape = np.ones_like(times) if tau is None else 1.0 - np.exp(-times / tau)
            out += weight * jump * shape
        return pd.Series(out, index=pd.Index(times, name=TIME_LEVEL), name=input)

    def describe(self, unit="µm", *, file=None):
        """Print one line per input: its step response in words.

        Parameters
        ----------
        unit : str, default="µm"
            Unit of the displacement.
        file : file-like, optional
            Where to print (default standard output).

        Returns
        -------
        text : str
            The lines printed.
        """
        check_is_fitted(self)
        lines = []
        for name in self.drivers_ + self.selected_sensors_:
            step = self.step_sizes_[name]
            is_driver = name in self.drivers_
            per = f"{step:g} {'rpm' if 'rpm' in name else 'units'}" if is_driver else "1 K"
            long = 5.0 * max(self.time_constants_.max(), self.driver_time_constants_.max())
            grid = np.linspace(0.0, long, 2001)
            r = self.step_response(name, step, times=grid).to_numpy()
            final = float(self.step_response(name, step, times=[np.inf]).iloc[0])
            at_once = r[0]
            at45 = float(self.step_response(name, step, times=[2700.0]).iloc[0])
            if abs(final) > 0:
                reached = np.flatnonzero(np.abs(r - at_once) >= 0.632 * abs(final - at_once))
                t63 = grid[reached[0]] / 60.0 if reached.size and final != at_once else 0.0
                within = f"63 % of the lagged part within {t63:.0f} min"
            else:
                within = "no response"
            lines.append(
                f"{name}: {final:.3g} {unit} per {per} at steady state, {at_once:.3g} {unit} "
                f"at once, {at45:.3g} {unit} after 45 min; {within}"
            )
        text = "\n".join(lines)
        print(text, file=file)
        return text

    # -- predict --------------------------------------------------------------
