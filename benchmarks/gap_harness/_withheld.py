"""Checking the diagnosis where the answer is known: effects withheld from a simulation.

greyml's simulator plays the real machine. The "real" data has every
effect; the "simulation" is the same simulator with one or two effects
switched off (and, optionally, its own parameters a few percent off). The
diagnosis should name what was switched off, stay silent when nothing was,
and shrink the gap nearly as far as adding the true effect back would.

The diagnosis itself never sees anything of this module: it gets measured
columns and the simulated target (plus, here, the simulation's sensitivities
to its own parameters, as a user could compute for theirs).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from gap_harness._cases import (
    _EXTRA,
    CUSTOM_NAME,
    FOREIGN_NAME,
    withheld_case,
)
from greyml.exceptions import GapWarning
from greyml.gap import EFFECTS, diagnose_gap

__all__ = ["WithheldValidation", "validate_withheld"]


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def _run_case(spec, setting, use_sensitivities, kwargs):
    """One case of ``spec``; ``setting``: the keywords of withheld_case every case shares."""
    withheld, size, param_error, seed = spec
    extra = withheld in _EXTRA
    case = withheld_case(withheld, size, seed, param_error=param_error, **setting)
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        # a time constant at its search bound is counted, not raised
        warnings.simplefilter("always", GapWarning)
        report = diagnose_gap(
            case.real,
            case.sim,
            **case.roles,
            sensitivities=case.sensitivities if use_sensitivities else None,
            random_state=seed,
            custom_effects=case.custom_effects,
            **kwargs,
        )
    seconds = time.perf_counter() - start
    located = False
    if case.event is not None:
        test, at, _ = case.event
        events = report.events
        located = bool(
            ((events["test"].astype(str) == test) & ((events["time_s"] - at).abs() <= 600)).any()
        )
    fitted = report.gap.to_numpy() - report.corrected.to_numpy()
    true_gap = case.effect + case.parameter_gap
    ranked = list(report.causes.dropna(subset=["shrinkage"])["effect"])
    clean = _rms(true_gap)
    named_rows = report.causes[report.causes["significant"].astype(bool)]
    lows = [float(ci[0]) for ci in named_rows["shrinkage_ci"]]
    return {
        "withheld": "+".join(withheld) if withheld else "none",
        "size": float(size) if withheld else 0.0,
        "param_error": float(param_error),
        "seed": int(seed),
        "cause": report.cause or "none",
        "named": "+".join(report.named) if report.named else "none",
        "top1": bool(withheld) and report.cause in _named_as(withheld),
        "top2": bool(withheld) and any(w in ranked[:2] for w in _named_as(withheld)),
        "all_named": bool(withheld) and set(_named_as(withheld)) <= set(report.named),
        "physical_named": any(e in EFFECTS for e in report.named),
        "n_named": len(lows),
        "n_named_ci_above_0": sum(low > 0 for low in lows),
        "unexplained_share": report.unexplained_share,
        "event_located": located,
        "event_size": case.event[2] / _rms(case.noise) if case.event else np.nan,
        "false_alarm": not withheld and report.cause is not None,
        "rmse_before": report.rmse_before,
        "rmse_recalibrated": report.rmse_recalibrated,
        "rmse_after": report.rmse_after,
        "noise": _rms(case.noise),
        "shrinkage": report.shrinkage,
        "oracle_shrinkage": 1.0 - _rms(case.noise) / report.rmse_before,
        "extra": extra,
        "clean_shrinkage": 1.0 - _rms(true_gap - fitted) / clean if clean > 0 else np.nan,
        "verdict": report.verdict,
        "remainder_ratio": report.remainder_ratio,
        "n_events": len(report.events),
        "bound_warnings": sum(issubclass(w.category, GapWarning) for w in caught),
        "seconds": seconds,
    }


def _named_as(withheld):
    """The names the diagnosis should give: the custom effect's name for a custom case."""
    if withheld == ("custom",):
        return (CUSTOM_NAME,)
    if withheld == ("foreign_custom",):
        return (FOREIGN_NAME,)
    return withheld


@dataclass
class WithheldValidation:
    """Every case's outcome (``cases``) and its summaries.

    Made by :func:`validate_withheld`: ``recall()``, ``confusion()``,
    ``pairs()``, ``false_alarms()`` and ``shrinkage()`` summarise ``cases``.

    Examples
    --------
    >>> import pandas as pd
    >>> cases = pd.DataFrame({"withheld": ["none", "drift"], "size": [0.0, 10.0],
    ...                       "param_error": [0.0, 0.0], "cause": ["none", "drift"],
    ...                       "top1": [False, True], "top2": [False, True],
    ...                       "false_alarm": [False, False]})
    >>> WithheldValidation(cases).confusion().values.tolist()
    [[1, 0], [0, 1]]
    """

    cases: pd.DataFrame

    def _library(self):
        """Cases of the library's effects and null cases (not the event and custom ones)."""
        if "extra" not in self.cases:
            return self.cases
        return self.cases[~self.cases["extra"].astype(bool)]

    def events(self):
        """Step cases: verdict not explained, no physical effect named, the step located."""
        cases = self.cases[self.cases["withheld"] == "event"]
        ok = cases["verdict"].isin(["unexplained", "partial"])
        return (
            cases.assign(verdict_ok=ok, clean=ok & ~cases["physical_named"].astype(bool))
            .groupby("param_error")[["verdict_ok", "clean", "event_located"]]
            .mean()
            .assign(n=cases.groupby("param_error").size())
        )

    def custom(self):
        """Custom-effect cases: named under the custom name, median held-out shrinkage."""
        cases = self.cases[self.cases["withheld"] == "custom"]
        return (
            cases.groupby("param_error")
            .agg(
                top1=("top1", "mean"),
                named=("all_named", "mean"),
                shrinkage=("shrinkage", "median"),
            )
            .assign(n=cases.groupby("param_error").size())
        )

    def foreign(self):
        """Foreign heat source cases, not given and given as a custom effect, by parameter error.

        Not given (``foreign``): how often no library effect is named, the
        verdict is ``"unexplained"`` or ``"partial"``, and the median
        unexplained share. Given (``foreign_custom``): how often it is named,
        the median held-out shrinkage and the oracle's, and how often the
        shrinkage is within 0.05 of the oracle's.
        """
        cases = self.cases[self.cases["withheld"].isin(["foreign", "foreign_custom"])]
        out = cases.assign(
            no_library=~cases["physical_named"].astype(bool),
            verdict_ok=cases["verdict"].isin(["unexplained", "partial"]),
            near_oracle=(cases["shrinkage"] - cases["oracle_shrinkage"]).abs() <= 0.05,
        )
        return (
            out.groupby(["withheld", "param_error"])
            .agg(
                no_library=("no_library", "mean"),
                verdict_ok=("verdict_ok", "mean"),
                unexplained_share=("unexplained_share", "median"),
                named=("all_named", "mean"),
                shrinkage=("shrinkage", "median"),
                oracle=("oracle_shrinkage", "median"),
                near_oracle=("near_oracle", "mean"),
            )
            .assign(n=out.groupby(["withheld", "param_error"]).size())
        )

    def named_intervals(self):
        """Named effects over all cases, and how many have their 95 % interval above 0."""
        return pd.Series(
            {
                "named": int(self.cases["n_named"].sum()),
                "interval_above_0": int(self.cases["n_named_ci_above_0"].sum()),
            }
        )

    def verdicts(self):
        """Verdicts by withheld effect (rows) and parameter error."""
        return pd.crosstab(
            [self.cases["param_error"], self.cases["withheld"]], self.cases["verdict"]
        )

    def recall(self):
        """Top-1 and top-2 recall by parameter error, withheld effect and size."""
        single = self._library()
        single = single[~single["withheld"].str.contains(r"\+|none")]
        return (
            single.groupby(["param_error", "withheld", "size"])[["top1", "top2"]]
            .agg(["mean"])
            .droplevel(1, axis=1)
            .assign(n=single.groupby(["param_error", "withheld", "size"]).size())
        )

    def confusion(self, param_error=None, min_size=None):
        """Withheld effect (rows, single effects and none) against the named cause."""
        cases = self._library()
        cases = cases[~cases["withheld"].str.contains(r"\+")]
        if param_error is not None:
            cases = cases[np.isclose(cases["param_error"], param_error)]
        if min_size is not None:
            cases = cases[(cases["size"] >= min_size) | (cases["withheld"] == "none")]
        return pd.crosstab(cases["withheld"], cases["cause"])

    def pairs(self):
        """Two effects withheld: how often both were named, by parameter error."""
        two = self.cases[self.cases["withheld"].str.contains(r"\+")]
        return (
            two.groupby(["param_error", "withheld"])[["all_named", "top1"]]
            .mean()
            .assign(n=two.groupby(["param_error", "withheld"]).size())
        )

    def false_alarms(self):
        """Null cases (nothing withheld): false alarms and cases, by parameter error."""
        null = self.cases[self.cases["withheld"] == "none"]
        return null.groupby("param_error")["false_alarm"].agg(["sum", "count"])

    def shrinkage(self, min_size=None):
        """Median held-out shrinkage, the oracle's and the noise-free one."""
        cases = self._library()
        cases = cases[cases["withheld"] != "none"]
        if min_size is not None:
            cases = cases[cases["size"] >= min_size]
        return cases.groupby(["param_error", "withheld"])[
            ["shrinkage", "oracle_shrinkage", "clean_shrinkage"]
        ].median()


def validate_withheld(
    effects=("ambient", "heat_source", "initial_state", "drift"),
    *,
    sizes=(2, 5, 10, 30),
    n_seeds=5,
    param_errors=(0.0, 0.05),
    pairs=(("ambient", "drift"), ("heat_source", "initial_state")),
    pair_size=10,
    n_null=20,
    machine="vmc",
    target=None,
    kind="class",
    n_tests=6,
    n_sensors=10,
    sensitivities=True,
    random_state=0,
    n_jobs=None,
    n_events=0,
    n_custom=0,
    custom_size=10,
    n_foreign=0,
    foreign_size=30,
    verbose=0,
    **diagnose_kwargs,
):
    """Run the diagnosis on many withheld-effect cases of greyml's simulator.

    For every parameter error in ``param_errors``: ``n_null`` cases with
    nothing withheld; every effect at every size (the withheld part's peak
    as a multiple of the probe noise) with ``n_seeds`` seeds; every pair at
    ``pair_size`` with ``n_seeds`` seeds. Each case has its own random tests
    (:func:`random_tests`).

    Parameters
    ----------
    effects : sequence of str
        Effects to withhold one at a time (keys of ``WITHHELD``).
    sizes : sequence of float
        Peak of the withheld part over the probe noise's standard deviation.
    n_seeds : int
    param_errors : sequence of float
        Relative error of the simulation's own parameters (0: exact).
    pairs : sequence of (str, str)
        Effects withheld together; each part is scaled to ``pair_size``.
    pair_size : float
    n_null : int
        Cases with nothing withheld, per parameter error.
    machine : str or ThermalMachine, default="vmc"
    target : str, optional
        The machine's main displacement by default (``dy_um`` on the VMC).
    kind : {"class", "element"}
        How the parameters are off (:func:`perturb_parameters`).
    n_tests, n_sensors : int
        Tests per case and temperature sensors handed to the diagnosis.
    sensitivities : bool, default=True
        Hand the simulation's parameter sensitivities to the diagnosis.
    random_state : int
        Seeds the cases (case seeds are ``random_state`` + a case counter).
    n_jobs : int, optional
        Cases run in parallel with joblib (module-level workers, so that
        joblib's ``dask`` backend runs them on a cluster with the same
        results).
    verbose : int, default=0
        joblib's progress messages on standard error (cases done, time
        elapsed) for long runs; 0 prints nothing.
    n_events : int, default=0
        Cases per parameter error with a step of 3-6 times the probe noise in
        the probe reading of one test (``withheld == "event"``).
    n_custom : int, default=0
        Cases per parameter error with a heat input driven by a logged
        column that the diagnosis is told of only as a custom effect
        (``withheld == "custom"``), at ``custom_size`` times the noise.
    custom_size : float, default=10
    n_foreign : int, default=0
        Cases per parameter error with a heater on the fixture, not in the
        library, reaching the probe through a lag of 60-120 min: as many
        not given to the diagnosis (``withheld == "foreign"``) as given as
        the custom effect ``"fixture"`` (``"foreign_custom"``).
    foreign_size : float, default=30
        Peak of the heater's part over the probe noise's standard deviation.
    **diagnose_kwargs
        Passed to :func:`diagnose_gap`.

    Returns
    -------
    WithheldValidation

    Examples
    --------
    One case with a withheld probe drift and one with nothing withheld:

    >>> v = validate_withheld(("drift",), sizes=(10,), n_seeds=1, param_errors=(0.0,),
    ...                       pairs=(), n_null=1, n_tests=3, n_sensors=3)
    >>> v.cases[["withheld", "cause"]].values.tolist()
    [['none', 'none'], ['drift', 'drift']]
    """
    from joblib import Parallel, delayed

    specs = []
    counter = int(random_state)
    for param_error in param_errors:
        for _ in range(n_null):
            specs.append(((), 0.0, param_error, counter))
            counter += 1
        for effect in effects:
            for size in sizes:
                for _ in range(n_seeds):
                    specs.append(((effect,), size, param_error, counter))
                    counter += 1
        for pair in pairs:
            for _ in range(n_seeds):
                specs.append((tuple(pair), pair_size, param_error, counter))
                counter += 1
        for _ in range(n_events):
            specs.append((("event",), 0.0, param_error, counter))
            counter += 1
        for _ in range(n_custom):
            specs.append((("custom",), custom_size, param_error, counter))
            counter += 1
        for given in ("foreign", "foreign_custom"):
            for _ in range(n_foreign):
                specs.append(((given,), foreign_size, param_error, counter))
                counter += 1
    setting = dict(machine=machine, target=target, kind=kind, n_tests=n_tests, n_sensors=n_sensors)
    rows = Parallel(n_jobs=n_jobs, verbose=verbose)(
        delayed(_run_case)(spec, setting, sensitivities, diagnose_kwargs) for spec in specs
    )
    return WithheldValidation(pd.DataFrame(rows))
