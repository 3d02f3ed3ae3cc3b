"""The result of a gap diagnosis."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

__all__ = ["GapReport"]

#: Units of greyml's column suffixes, for axis labels.
_UNITS = {"um": "µm", "mm": "mm", "C": "°C", "ue": "µε"}


def _plain(value):
    """JSON-ready copy: NaN to None, numpy scalars to Python."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating, float)):
        return None if not np.isfinite(value) else float(value)
    return value


@dataclass
class GapReport:
    """Where the gap lies and which unmodelled effect explains it.

    Attributes
    ----------
    where : DataFrame
        The gap by test, phase, time since the start and frequency band: one
        row per segment with ``by``, ``segment``, ``n``, ``rms``, ``peak``,
        ``bias`` and ``share`` (of the total squared gap).
    causes : DataFrame
        Every effect, best first: ``effect``, ``detail``, ``rmse_before``,
        ``rmse_after`` (held-out, µm or the target's unit), ``shrinkage``
        (1 − after/before), ``significant``, ``step`` (the order in which
        named effects were added, 0 for the others), ``placebo_shrinkage``
        (the best placebo at that step), ``peak_before``, ``peak_after``.
    cause : str or None
        The first significant effect, or None: no significant unmodelled
        effect.
    named : list of str
        Every effect added, in order.
    rmse_before, rmse_after, peak_before, peak_after : float
        Held-out RMSE and peak ``|gap|`` of the simulation alone and with the
        named effects added.
    rmse_recalibrated : float
        Held-out RMSE once the simulation's own parameters (or gain and
        timing) are refitted within their tolerance (NaN with
        ``recalibrate=False``); the effects are scored from here.
    recalibration : str
        What the recalibration refitted, with the mean relative changes.
    recalibration_kept : bool
        Whether it was kept: the effects are searched for with and without
        it, and the search that leaves less of the gap held out is reported.
    noise_floor : float
        White-noise level of the gap (from its first differences).
    whiteness : dict
        Ljung–Box test of the gap.
    cross_correlation : DataFrame
        Peak cross-correlation of the gap with every driver, the ambient and
        the sensors, with its lag.
    gap, corrected : Series
        The gap, and what is left of it on held-out tests once the named
        effects are added.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from greyml import make_test_index
    >>> from greyml.gap import diagnose_gap
    >>> t = np.arange(120) * 60.0
    >>> index = make_test_index(tests=np.repeat(["A", "B", "C"], 120), times=np.tile(t, 3))
    >>> sim = pd.DataFrame({"dz_um": np.tile(5 * (1 - np.exp(-t / 3600)), 3)}, index=index)
    >>> noise = 0.01 * np.random.default_rng(0).standard_normal(360)
    >>> real = sim.assign(dz_um=sim["dz_um"] + 0.5 * np.tile(t, 3) / 3600 + noise)
    >>> report = diagnose_gap(real, sim, target="dz_um", random_state=0)
    >>> report.named
    ['drift']
    >>> report.where.loc[report.where["by"] == "test", ["segment", "share"]].round(2)
      segment  share
    1       A   0.33
    2       B   0.33
    3       C   0.33
    >>> sorted(report.to_dict())[:4]
    ['cause', 'causes', 'cross_correlation', 'named']
    """

    target: str
    where: pd.DataFrame
    causes: pd.DataFrame
    cause: str | None
    named: list
    rmse_before: float
    rmse_recalibrated: float
    rmse_after: float
    peak_before: float
    peak_after: float
    noise_floor: float
    whiteness: dict
    cross_correlation: pd.DataFrame
    gap: pd.Series
    corrected: pd.Series
    descriptions: dict = field(default_factory=dict)
    recalibration: str = ""
    recalibration_kept: bool = False

    @property
    def shrinkage(self):
        """Held-out 1 − RMSE_after / RMSE_before with every named effect added."""
        if not self.rmse_before > 0:  # a simulation that matches: nothing to shrink
            return 0.0
        return 1.0 - self.rmse_after / self.rmse_before

    def to_dict(self):
        """A JSON-ready dict with ``cause``, ``causes``, ``where`` and the summary."""
        return _plain(
            {
                "target": self.target,
                "cause": self.cause,
                "named": list(self.named),
                "causes": self.causes.to_dict(orient="records"),
                "where": self.where.to_dict(orient="records"),
                "rmse_before": self.rmse_before,
                "rmse_recalibrated": self.rmse_recalibrated,
                "recalibration": self.recalibration,
                "recalibration_kept": self.recalibration_kept,
                "rmse_after": self.rmse_after,
                "peak_before": self.peak_before,
                "peak_after": self.peak_after,
                "shrinkage": self.shrinkage,
                "noise_floor": self.noise_floor,
                "whiteness": dict(self.whiteness),
                "cross_correlation": self.cross_correlation.to_dict(orient="records"),
            }
        )

    def to_json(self, **kwargs):
        """:meth:`to_dict` as JSON text."""
        return json.dumps(self.to_dict(), ensure_ascii=False, **kwargs)

    def __str__(self):
        lines = [
            f"Gap of {self.target}: held-out RMSE {self.rmse_before:.3g}, peak "
            f"{self.peak_before:.3g}; noise floor {self.noise_floor:.3g}."
        ]
        if self.recalibration and self.recalibration_kept:
            lines.append(f"Recalibrated ({self.recalibration}): RMSE {self.rmse_recalibrated:.3g}.")
        elif self.recalibration:
            lines.append(
                f"Recalibration not kept ({self.recalibration}): held-out RMSE "
                f"{self.rmse_recalibrated:.3g}; the effects leave less without it."
            )
        if self.cause is None:
            lines.append("No significant unmodelled effect.")
        else:
            for _, row in self.causes[self.causes["significant"]].iterrows():
                lines.append(
                    f"{int(row['step'])}. {row['effect']} ({row['detail']}): RMSE "
                    f"{row['rmse_before']:.3g} -> {row['rmse_after']:.3g} "
                    f"(shrinkage {row['shrinkage']:.0%}, best placebo "
                    f"{row['placebo_shrinkage']:.0%})"
                )
            ratio = (
                f" ({self.rmse_after / self.noise_floor:.1f}× the noise floor)"
                if self.noise_floor > 0
                else ""
            )
            lines.append(
                f"With {', '.join(self.named)} added: RMSE {self.rmse_after:.3g}{ratio}, "
                f"peak {self.peak_after:.3g}."
            )
        return "\n".join(lines)

    def plot(self, axes=None):
        """Gap over time by test (before and after), where it lies, and the ranking.

        Returns
        -------
        fig : matplotlib Figure
        """
        import matplotlib.pyplot as plt

        if axes is None:
            fig, axes = plt.subplots(1, 3, figsize=(14, 4), layout="constrained")
        else:
            fig = np.ravel(axes)[0].figure
        ax_time, ax_where, ax_rank = np.ravel(axes)[:3]
        offset = 0.0
        for label, r in self.gap.groupby(level="test", sort=False):
            t = r.index.get_level_values("time_s").to_numpy() / 3600.0
            after = self.corrected.loc[r.index]
            ax_time.plot(offset + t, r.to_numpy(), color="0.6", lw=1)
            ax_time.plot(offset + t, after.to_numpy(), color="C3", lw=1)
            ax_time.axvline(offset, color="0.85", lw=0.8)
            ax_time.text(
                offset,
                1.0,
                f" {label}",
                transform=ax_time.get_xaxis_transform(),
                va="top",
                fontsize=8,
            )
            offset += t[-1] + 0.5
        unit = _UNITS.get(self.target.rpartition("_")[2], "target's unit")
        ax_time.set(xlabel="time, tests end to end (h)", ylabel=f"gap of {self.target} ({unit})")
        ax_time.set_title("held-out gap (grey), after the effects (red)", fontsize=10)
        parts = self.where[self.where["by"].isin(["phase", "band"])]
        ax_where.barh(
            [f"{b}: {s}" for b, s in zip(parts["by"], parts["segment"])], parts["share"].to_numpy()
        )
        ax_where.set(xlabel="share of the squared gap (fraction)")
        ax_where.set_title("where the gap lies", fontsize=10)
        ranked = self.causes.dropna(subset=["shrinkage"])
        colors = ["C3" if s else "0.6" for s in ranked["significant"]]
        ax_rank.barh(
            ranked["effect"].to_numpy()[::-1],
            ranked["shrinkage"].to_numpy()[::-1],
            color=colors[::-1],
        )
        ax_rank.set(xlabel="held-out shrinkage (fraction of the RMSE)")
        ax_rank.set_title("effects (red: significant)", fontsize=10)
        return fig
