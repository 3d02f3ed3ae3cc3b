"""The result of a gap diagnosis."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from greyml.exceptions import GapWarning
from greyml.gap._departures import DEPARTURE_COLUMNS, describe_departure
from greyml.gap._events import EVENT_COLUMNS, describe_event

__all__ = ["GapReport", "GapWarning", "VERDICTS"]

#: The verdicts of a diagnosis, from best to worst.
VERDICTS = ("within_noise", "explained", "partial", "unexplained")
#: A held-out remainder up to this multiple of the noise floor counts as noise.
NOISE_RATIO = 1.5


#: Units of greyml's column suffixes, for axis labels.
_UNITS = {"um": "µm", "mm": "mm", "C": "°C", "ue": "µε"}
#: the families of ``GapReport.where`` that :meth:`GapReport.plot` draws
_FAMILIES = {"phase": "by phase", "time": "by time since start", "band": "by period"}


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
        What the instrument alone puts into the gap: √(white² + quantum²/12),
        the white part a robust spread about a local line at the step time's
        resolution (see :mod:`greyml.gap._noise`).
    quantum : float
        The step in which the target is read, stated or detected (0.0:
        continuous readings).
    whiteness : dict
        Ljung–Box test of the gap.
    cross_correlation : DataFrame
        Peak cross-correlation of the gap with every driver, the ambient and
        the sensors, with its lag.
    gap, corrected : Series
        The gap, and what is left of it on held-out tests once the named
        effects are added.
    verdict : str
        ``"within_noise"``, ``"explained"``, ``"partial"`` or
        ``"unexplained"`` (see :attr:`verdict`).
    unexplained_rms, remainder_ratio : float
        Held-out RMSE of the remainder, and its ratio to the noise floor.
    events : DataFrame
        Located events (a step or a spike in one test, a change completed
        within the step time), never attributed to an effect: ``test``,
        ``time_s`` (its first row at the new level), ``kind`` (``"step"`` or
        ``"spike"``), ``size`` (its height, in the target's unit), ``end_s``
        (a spike's last row), ``z`` (its size less one quantum, in standard
        errors), and, for an event at a switch of a driver,
        ``at_driver_change`` (the driver's name), ``driver_change_s``,
        ``driver_before`` and ``driver_after`` (empty otherwise).
    n_placebo : int
        Placebos drawn in the whole diagnosis. ``causes`` gains, per effect
        scored against placebos, ``p_value`` (sequential, Besag and
        Clifford (1991)), ``n_placebo`` and ``shrinkage_ci``, a 95 %
        interval of the held-out shrinkage over the held-out tests
        (bootstrap of tests).
    remainder_where, remainder_whiteness, remainder_cross_correlation
        ``where``, ``whiteness`` and ``cross_correlation`` of the remainder.
    not_tried : dict
        The library's effects that were not tried, each with why: the
        columns it needs (e.g. "needs the ambient column (ambient=)"), or
        not asked for in ``effects=``.
    untestable : dict
        Effects that leave one test out cannot score, each with why: only
        one test shows them (a custom column that is on in one test only).
    inconsistent_sensors : DataFrame
        Sensors whose relation to the other sensors changes in one test
        (swapped, moved or mislabelled?), found before the search and left
        out of the effects built from the sensors: ``test``, ``sensor``,
        ``error_ratio`` (its held-out error predicted from the others in
        that test over its median in the other tests) and ``swapped_with``
        (the sensor it reads as swapped with, or None).
    unexplained_share : float
        The part of the held-out gap above the noise floor that the named
        effects leave (see :attr:`unexplained_share`).
    departures : DataFrame
        Where, in time, what the named effects leave departs smoothly from
        its test's slow pattern (a door, a draught: a transient of tens of
        minutes, which is no event; :mod:`greyml.gap._departures`):
        ``test``, ``start_s`` (the first row that leaves the pattern),
        ``peak_s`` (the end of its rise), ``end_s`` (back within a third of
        its size, or the test's last row), ``size`` (at the peak, from the
        test's pattern, in the target's unit) and ``z`` (standard errors).
        They do not change the verdict.
    reference : {"recording", "start"}
        What the displacements of the report are measured from:
        ``"recording"``, the measured and simulated target as given (from
        the recording's zero); ``"start"``, both as changes from each test's
        first row (``greyml gap`` with a ``_since_start`` prediction).
    min_shrinkage : float
        The smallest held-out shrinkage that could count as an effect (the
        diagnosis's setting), for the report's words on the placebos.

    Examples
    --------
    Three tests in which the probe jumps by 2 µm at 60 min of test C only,
    which the simulation lacks. No effect explains a step: it is located (in
    ``where`` and ``events``) but not named. :func:`diagnose_gap` shows a
    gap that an effect explains.

    >>> import numpy as np, pandas as pd
    >>> from greyml import make_test_index
    >>> from greyml.gap import diagnose_gap
    >>> t = np.arange(120) * 60.0
    >>> index = make_test_index(tests=np.repeat(["A", "B", "C"], 120), times=np.tile(t, 3))
    >>> sim = pd.DataFrame({"dz_um": np.tile(5 * (1 - np.exp(-t / 3600)), 3)}, index=index)
    >>> noise = 0.01 * np.random.default_rng(0).standard_normal(360)
    >>> step = np.r_[np.zeros(300), np.full(60, 2.0)]  # test C from 60 min
    >>> report = diagnose_gap(sim + (step + noise)[:, None], sim, target="dz_um", random_state=0)
    >>> report.named, report.verdict
    ([], 'unexplained')
    >>> report.where.loc[report.where["by"] == "test", ["segment", "share"]].round(2)
      segment  share
    1       A    0.0
    2       B    0.0
    3       C    1.0
    >>> report.events[["test", "time_s", "kind", "size"]].round(1)
      test  time_s  kind  size
    0    C  3600.0  step   2.0
    >>> sorted(report.to_dict())[:4]
    ['cause', 'causes', 'cross_correlation', 'departures']
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
    events: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=EVENT_COLUMNS))
    n_placebo: int = 0
    remainder_where: pd.DataFrame | None = None
    remainder_whiteness: dict = field(default_factory=dict)
    remainder_cross_correlation: pd.DataFrame | None = None
    not_tried: dict = field(default_factory=dict)
    untestable: dict = field(default_factory=dict)
    inconsistent_sensors: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(
            columns=["test", "sensor", "error_ratio", "swapped_with"]
        )
    )
    quantum: float = 0.0
    departures: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=DEPARTURE_COLUMNS)
    )
    reference: str = "recording"
    min_shrinkage: float = 0.05

    def _quantum_words(self):
        """How the floor holds the readings' step, in words ("" without one)."""
        if not self.quantum > 0:
            return ""
        return f" (readings in steps of {self.quantum:.4g}: quantum²/12 included)"

    @property
    def unexplained_rms(self):
        """Held-out RMSE of what the named effects leave (``rmse_after``)."""
        return self.rmse_after

    @property
    def remainder_ratio(self):
        """``unexplained_rms`` over the noise floor (inf when the floor is 0 and a gap remains)."""
        if self.noise_floor > 0:
            return self.rmse_after / self.noise_floor
        return np.inf if self.rmse_after > 0 else 0.0

    @property
    def unexplained_share(self):
        """Share of the held-out gap above the noise that the named effects leave.

        (``rmse_after``² − floor²) / (start² − floor²), clipped to [0, 1],
        with floor the noise floor and start the held-out RMSE the effects
        were searched from (``rmse_recalibrated`` when the recalibration was
        kept, else ``rmse_before``): 1 when nothing is explained, 0 when what
        is left is noise; 0 when the gap itself is within the noise.
        """
        floor2 = self.noise_floor**2
        start = self.rmse_recalibrated if self.recalibration_kept else self.rmse_before
        above = start**2 - floor2
        if not above > 0:
            return 0.0
        return float(np.clip((self.rmse_after**2 - floor2) / above, 0.0, 1.0))

    def not_supported(self, top=None):
        """The effects tried but not named, best first, each with its shrinkage and why.

        ``top``: at most this many (None: all). A list of str.
        """
        rows = self.causes[
            ~self.causes["significant"].astype(bool) & self.causes["shrinkage"].notna()
        ]
        out = []
        for _, row in (rows if top is None else rows.head(top)).iterrows():
            why = row["detail"].rpartition("not supported: ")[2]
            low, high = row["shrinkage_ci"]
            out.append(
                f"{row['effect']} (held-out shrinkage {row['shrinkage']:.0%}, 95% CI over tests "
                f"{low:.0%} to {high:.0%}: {why})"
            )
        return out

    @property
    def verdict(self):
        """``"within_noise"``, ``"explained"``, ``"partial"`` or ``"unexplained"``.

        A remainder is significant when it exceeds 1.5 times the noise floor
        or holds a located event; with no effect named the verdict is
        ``"within_noise"`` or ``"unexplained"``, with effects named
        ``"explained"`` or ``"partial"``.
        """
        remains = self.remainder_ratio > NOISE_RATIO or len(self.events) > 0
        if self.named:
            return "partial" if remains else "explained"
        return "unexplained" if remains else "within_noise"

    @property
    def remainder_held_out(self):
        """Whether ``rmse_after`` is held out: an effect named or the recalibration kept.

        With neither, nothing was fitted to the gap and ``rmse_after`` is
        the gap itself over all rows.
        """
        return bool(self.named) or bool(self.recalibration_kept)

    def _remainder_words(self):
        if self.remainder_held_out:
            return "held-out remainder"
        return "gap over all rows (nothing fitted to it)"

    def reference_sentence(self):
        """What the report compared, from which zero, and what was held out and how."""
        if self.reference == "start":
            zero = (
                'reference "start": the measured and simulated target each from its '
                "test's first row"
            )
        else:
            zero = (
                'reference "recording": the measured and simulated target as given, from '
                "the recording's zero"
            )
        return (
            f"Compared: the gap = measured − simulated {self.target} on every row ({zero}). "
            "Held out: leave one test out; each effect (and the recalibration) is fitted on "
            "all tests but one and scored on the test left out, in turn; an RMSE called "
            "held-out is over those left-out predictions, one over all rows has nothing "
            "fitted to it."
        )

    def placebo_sentence(self):
        """How many placebos were drawn, and why none when none were."""
        if self.n_placebo > 0:
            return (
                f"Placebos drawn: {self.n_placebo} (random walks given each candidate's "
                "freedom; an effect is named only when it beats all of them)."
            )
        tried = self.causes["shrinkage"].notna().any() if len(self.causes) else False
        if not tried:
            return "Placebos drawn: none, since no effect could be tried on these columns."
        return (
            "Placebos drawn: none. They are drawn only for an effect whose held-out shrinkage "
            f"exceeds min_shrinkage={self.min_shrinkage:g} with its 95% interval over tests "
            "above 0, and no effect tried did."
        )

    def next_steps(self):
        """What to do next when the gap is not explained (a list of str, empty otherwise)."""
        if self.verdict not in ("partial", "unexplained"):
            return []
        steps = [
            "an effect the library lacks (a coolant, a hydraulic unit, a fixture heater) can be "
            "tried under its own name from the column that logs it (custom_effects=)"
        ]
        follows = self.events["follows"] if "follows" in self.events else []
        inputs = sorted({f for f in follows if isinstance(f, str)})
        if inputs:
            steps.append(
                f"located events follow {', '.join(inputs)}: the simulation lacks a fast path "
                f"from {'it' if len(inputs) == 1 else 'them'} to the target (a bracket, the air "
                "on the probe)"
            )
        if len(self.departures):
            steps.append(
                "the departures above say when the gap leaves its pattern: look for what "
                "happened then (a door, a draught) and log it as an input"
            )
        n_tests = self.where["by"].eq("test").sum() if len(self.where) else 0
        if n_tests < 4 or self.untestable:
            steps.append(
                f"a longer recording with more tests (here {n_tests}) lets an effect seen in "
                "few tests be scored on a test left out"
            )
        xcorr = self.remainder_cross_correlation
        if xcorr is not None and len(xcorr):
            top = xcorr.loc[xcorr["peak_corr"].abs().idxmax()]
            if abs(top["peak_corr"]) >= 0.3:
                steps.append(
                    f"the remainder still follows {top['signal']} ({top['peak_corr']:+.2f} at "
                    f"{top['peak_lag_s']:g} s): a path from it that the simulation lacks"
                )
        return steps

    def verdict_sentence(self):
        """The verdict in one sentence."""
        ratio = self.remainder_ratio
        floor = f"noise floor {self.noise_floor:.3g}"
        named = ", ".join(self.named)
        events = len(self.events)
        at = f"; {events} located event{'s' if events != 1 else ''}" if events else ""
        if self.verdict == "within_noise":
            return (
                f"Verdict: within noise. The {self._remainder_words()} (RMSE "
                f"{self.rmse_after:.3g}) is {ratio:.1f}× the {floor}; the data need no "
                "unmodelled effect."
            )
        if self.verdict == "explained":
            return (
                f"Verdict: explained. {named} bring{'s' if len(self.named) == 1 else ''} the "
                f"gap from RMSE {self.rmse_before:.3g} (all rows) to {self.rmse_after:.3g} "
                f"held out, {ratio:.1f}× the {floor}."
            )
        share = f"{self.unexplained_share:.0%} of the gap above the noise is unexplained"
        if self.verdict == "partial":
            return (
                f"Verdict: partial. {named} explain{'s' if len(self.named) == 1 else ''} part of "
                f"the gap (RMSE {self.rmse_before:.3g} over all rows -> {self.rmse_after:.3g} "
                "held out), but "
                f"{ratio:.1f}× the {floor} remains{at}; {share}."
            )
        return (
            f"Verdict: unexplained. A {self._remainder_words()} of RMSE {self.rmse_after:.3g}, "
            f"{ratio:.1f}× the {floor}{at}, that no effect tried explains; {share}."
        )

    def where_remains(self):
        """Where the remainder lies, in a few lines (empty when it is within the noise)."""
        lines = []
        if self.verdict in ("within_noise", "explained"):
            return lines
        table = self.remainder_where if self.remainder_where is not None else self.where
        parts = []
        for by in ("test", "time", "band"):
            rows = table[table["by"] == by]
            if len(rows) > 1:
                top = rows.loc[rows["share"].idxmax()]
                label = {"test": "test ", "time": "", "band": "band "}[by]
                parts.append(f"{label}{top['segment']} ({top['share']:.0%})")
        if parts:
            lines.append(
                "Where it remains (share of the squared remainder): " + ", ".join(parts) + "."
            )
        white = self.remainder_whiteness or self.whiteness
        if white:
            state = "white" if white.get("white") else "not white"
            lines.append(
                f"The remainder is {state} (Ljung-Box p = {white['p_value']:.2g}, lag-1 "
                f"autocorrelation {white['lag1_autocorrelation']:.2f})."
            )
        xcorr = (
            self.remainder_cross_correlation
            if self.remainder_cross_correlation is not None
            else self.cross_correlation
        )
        if xcorr is not None and len(xcorr):
            top = xcorr.loc[xcorr["peak_corr"].abs().idxmax()]
            lines.append(
                f"Strongest cross-correlation: {top['signal']} {top['peak_corr']:+.2f} at a lag "
                f"of {top['peak_lag_s']:g} s."
            )
        for _, event in self.events.iterrows():
            lines.append(describe_event(event))
        for _, departure in self.departures.iterrows():
            lines.append(describe_departure(departure))
        return lines

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
                "verdict": self.verdict,
                "unexplained_rms": self.unexplained_rms,
                "remainder_ratio": self.remainder_ratio,
                "events": self.events.to_dict(orient="records"),
                "departures": self.departures.to_dict(orient="records"),
                "n_placebo": self.n_placebo,
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
                "quantum": self.quantum,
                "whiteness": dict(self.whiteness),
                "cross_correlation": self.cross_correlation.to_dict(orient="records"),
                "remainder_where": (
                    None
                    if self.remainder_where is None
                    else self.remainder_where.to_dict(orient="records")
                ),
                "remainder_whiteness": dict(self.remainder_whiteness),
                "unexplained_share": self.unexplained_share,
                "not_supported": self.not_supported(),
                "reference": self.reference,
                "remainder_held_out": self.remainder_held_out,
                "next_steps": self.next_steps(),
                "not_tried": dict(self.not_tried),
                "untestable": dict(self.untestable),
                "inconsistent_sensors": self.inconsistent_sensors.to_dict(orient="records"),
            }
        )

    def to_json(self, **kwargs):
        """:meth:`to_dict` as JSON text."""
        return json.dumps(self.to_dict(), ensure_ascii=False, **kwargs)

    def __str__(self):
        lines = [self.verdict_sentence(), *self.where_remains()]
        lines += [
            self.reference_sentence(),
            f"Gap of {self.target} over all rows (nothing fitted): RMSE {self.rmse_before:.3g}, "
            f"peak {self.peak_before:.3g}; noise floor {self.noise_floor:.3g}"
            f"{self._quantum_words()}.",
        ]
        if self.recalibration and self.recalibration_kept:
            lines.append(f"Recalibrated ({self.recalibration}): RMSE {self.rmse_recalibrated:.3g}.")
        elif self.recalibration:
            lines.append(
                f"Recalibration not kept ({self.recalibration}): held-out RMSE "
                f"{self.rmse_recalibrated:.3g}; the effects leave less without it."
            )
        for _, row in self.inconsistent_sensors.iterrows():
            swap = row["swapped_with"]
            how = f"swapped with {swap}?" if swap else "swapped, moved or mislabelled?"
            lines.append(
                f"Inconsistent sensor: {row['sensor']} in test {row['test']} relates to the other "
                f"sensors differently than in the other tests (held-out error "
                f"{row['error_ratio']:.0f}× theirs): {how} Left out of the effects built from "
                "the sensors."
            )
        if self.cause is None:
            lines.append("No effect tried is supported by the held-out tests.")
        else:
            for _, row in self.causes[self.causes["significant"]].iterrows():
                lines.append(
                    f"{int(row['step'])}. {row['effect']} ({row['detail']}): RMSE "
                    f"{row['rmse_before']:.3g} -> {row['rmse_after']:.3g} "
                    f"(shrinkage {row['shrinkage']:.0%}, 95% CI over tests "
                    f"{row['shrinkage_ci'][0]:.0%} to {row['shrinkage_ci'][1]:.0%}; best placebo "
                    f"{row['placebo_shrinkage']:.0%}, p = {row['p_value']:.3f})"
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
        unsupported = self.not_supported(top=None)
        if unsupported:
            lines.append("Tried, not supported: " + "; ".join(unsupported) + ".")
        for effect, why in self.untestable.items():
            lines.append(f"Untestable: {effect}, {why}.")
        if self.not_tried:
            lines.append(
                "Not tried: "
                + "; ".join(f"{effect} ({why})" for effect, why in self.not_tried.items())
                + "."
            )
        lines.append(self.placebo_sentence())
        steps = self.next_steps()
        if steps:
            lines.append("What to do next: " + "; ".join(steps) + ".")
        return "\n".join(lines)

    def plot(self, axes=None):
        """The gap over time, where it lies, and the effects against the placebos.

        Four panels: the gap (measured − simulated) of every test end to end
        with what is left of it on held-out tests once the named effects are
        added; its share by phase (by time since the start without drivers);
        its share by period, or frequency band (each family's shares sum to 1);
        and each effect's held-out shrinkage beside the best placebo of its
        step, the bar an effect has to beat.

        Parameters
        ----------
        axes : sequence of 4 matplotlib Axes, optional
            Where to draw the four panels, in that order. ``None``: a new
            figure, the gap over the full width above the three others.

        Returns
        -------
        fig : matplotlib Figure
        """
        import matplotlib.pyplot as plt
        from matplotlib.patches import Patch

        if axes is None:
            fig, named = plt.subplot_mosaic(
                [["time"] * 3, ["phase", "band", "rank"]],
                figsize=(10, 6.5),
                layout="constrained",
                height_ratios=(1, 1.1),
                width_ratios=(1, 1, 1.5),
            )
            axes = [named[k] for k in ("time", "phase", "band", "rank")]
        axes = list(np.ravel(axes))
        if len(axes) != 4:
            raise ValueError(
                "GapReport.plot: axes must hold 4 Axes (gap over time, phase, band, "
                f"effects); got {len(axes)}."
            )
        fig = axes[0].figure
        ax_time, ax_phase, ax_band, ax_rank = axes
        unit = _UNITS.get(self.target.rpartition("_")[2], "target's unit")
        offset = 0.0
        for label, r in self.gap.groupby(level="test", sort=False):
            t = r.index.get_level_values("time_s").to_numpy() / 3600.0
            after = self.corrected.loc[r.index]
            first = offset == 0.0
            for series, color, name in (
                (r, "0.55", "gap: measured − simulated"),
                (after, "C3", "left after the named effects (held-out tests)"),
            ):
                ax_time.plot(
                    offset + t, series.to_numpy(), color=color, lw=1, label=name if first else None
                )
            ax_time.axvline(offset, color="0.85", lw=0.8)
            ax_time.text(
                offset,
                1.0,
                f" {label}",
                transform=ax_time.get_xaxis_transform(),
                va="top",
                fontsize="small",
            )
            offset += t[-1] + 0.5
        ax_time.axhline(0.0, color="0.7", lw=0.6)
        ax_time.set(
            xlabel="time, tests end to end (h, from each test's start)",
            ylabel=f"{self.target} ({unit})",
        )
        ax_time.legend(fontsize="small", loc="best")
        ax_time.set_title(f"The gap of {self.target}, and what the named effects leave")
        # the phases need drivers; without them, the time since each test's start
        first = "phase" if (self.where["by"] == "phase").any() else "time"
        for ax, by in ((ax_phase, first), (ax_band, "band")):
            part = self.where[self.where["by"] == by]
            ax.barh(part["segment"].astype(str).to_numpy()[::-1], part["share"].to_numpy()[::-1])
            ax.set_xlim(0.0, 1.0)
            ax.set_xlabel("share of the squared gap\n(sums to 1)")
            ax.set_title(f"Gap {_FAMILIES[by]}")
        ranked = self.causes.dropna(subset=["shrinkage"])
        names = ranked["effect"].to_numpy()[::-1]
        positions = np.arange(len(names))
        ax_rank.barh(
            positions,
            ranked["shrinkage"].to_numpy()[::-1],
            color=["C3" if s else "0.6" for s in ranked["significant"]][::-1],
        )
        placebo = ranked["placebo_shrinkage"].to_numpy(dtype=float)[::-1]
        ax_rank.scatter(
            placebo,
            positions,
            marker="|",
            s=250,
            color="k",
            zorder=3,
            label="best placebo",
        )
        ax_rank.set_yticks(positions, names)
        ax_rank.axvline(0.0, color="0.5", lw=0.8)
        ax_rank.set_xlabel("held-out shrinkage\n(1 − RMSE after / before)")
        ax_rank.set_title("Effects")
        handles = ax_rank.get_legend_handles_labels()[0] + [
            Patch(color="C3", label="significant"),
            Patch(color="0.6", label="not significant"),
        ]
        ax_rank.legend(handles=handles, fontsize="x-small", loc="lower right")
        return fig
