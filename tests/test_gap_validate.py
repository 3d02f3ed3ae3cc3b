"""greyml.gap on withheld effects: the validation harness (``benchmarks/gap_harness``) and the
recalibration by sensitivities."""

import warnings

import numpy as np
import pandas as pd
import pytest
from gap_harness import random_tests, validate_withheld, withheld_case

from greyml.datasets import make_tests
from greyml.exceptions import GapWarning
from greyml.gap import diagnose_gap, perturb_parameters, simulator_sensitivities
from greyml.simulation import Effects, Programme, vmc


@pytest.fixture(scope="module")
def drift_case():
    return withheld_case(("drift",), 10, 3, param_error=0.05)


def test_withheld_part_peaks_at_size_times_the_noise(drift_case):
    case = drift_case
    sigma = np.std(case.noise)
    assert np.max(np.abs(case.effect)) == pytest.approx(10 * sigma, rel=1e-9)
    # the real target is the exact simulation + the withheld part + noise
    target = case.roles["target"]
    exact = case.real[target].to_numpy() - case.effect - case.noise
    assert np.allclose(exact - case.sim[target].to_numpy(), case.parameter_gap)
    assert case.roles["target"] == "dy_um" and len(case.roles["sensors"]) == 10


def test_perturb_parameters_class_and_element():
    m = vmc()
    rng = np.random.default_rng(0)
    c = perturb_parameters(m, 0.05, rng, kind="class")
    ratios = np.array(c.capacity) / np.array(m.capacity)
    assert np.ptp(ratios) < 1e-12 and abs(ratios[0] - 1) <= 0.05
    e = perturb_parameters(m, 0.05, rng, kind="element")
    ratios = np.array(e.capacity) / np.array(m.capacity)
    assert np.ptp(ratios) > 0.01 and np.all(np.abs(ratios - 1) <= 0.05)
    with pytest.raises(ValueError, match="kind must be"):
        perturb_parameters(m, 0.05, rng, kind="global")


def test_sensitivities_hand_checks():
    # constant air, start at rest, no drift: the rise is linear in every power
    # and the displacement in its weights, so the power sensitivities add up to
    # the simulated target, and the expansion sensitivity is the target itself
    tests = {"A": Programme().run(60, spindle_rpm=8000, feed_mm_min=5000).dwell(60)}
    effects = Effects().without("noise", "probe_drift", "extra_heat_source")
    target = make_tests("vmc", tests, effects=effects).frame["dy_um"]
    S = simulator_sensitivities("vmc", tests, "dy_um", effects=effects)
    assert list(S.columns[:4]) == ["capacity", "conductance", "convection", "expansion"]
    assert not any("nut" in c for c in S.columns)  # switched off: dropped
    assert np.allclose(S["expansion"], target, atol=1e-9)
    power = S[[c for c in S.columns if c.startswith("power")]].sum(axis=1)
    assert np.allclose(power, target, atol=1e-6 * np.abs(target).max())


def test_random_tests_respect_the_machine():
    tests = random_tests("vmc", np.random.default_rng(1), n_tests=3)
    assert [t.label for t in tests] == ["T1", "T2", "T3"]
    for t in tests:
        for seg in t.programme.segments:
            assert 0 <= seg.spindle_rpm <= 8000 and 0 <= seg.feed_mm_min <= 10000


def test_sensitivities_absorb_a_parameter_error_and_leave_the_effect(drift_case):
    case = drift_case
    with_s = diagnose_gap(
        case.real, case.sim, **case.roles, sensitivities=case.sensitivities, random_state=0
    )
    assert with_s.named == ["drift"]
    # the recalibrated parameters leave about the probe noise once drift is added
    assert with_s.rmse_after < 1.15 * np.std(case.noise)
    assert "parameters refitted within ±10%" in with_s.recalibration
    assert "capacity" in with_s.recalibration


def test_sensitivities_must_cover_the_rows(drift_case):
    case = drift_case
    with pytest.raises(ValueError, match="The sensitivities does not cover"):
        diagnose_gap(
            case.real,
            case.sim,
            **case.roles,
            sensitivities=case.sensitivities.iloc[:-5],
            random_state=0,
        )
    bad = case.sensitivities.copy()
    bad.iloc[7, 1] = np.nan
    with pytest.raises(ValueError, match="Sensitivity 'conductance' has NaN in test 'T1'"):
        diagnose_gap(case.real, case.sim, **case.roles, sensitivities=bad, random_state=0)


def test_bad_arguments_fail_before_the_search(drift_case):
    case = drift_case
    with pytest.raises(
        ValueError,
        match=r"'max_effects' parameter of diagnose_gap must be an int in the range \[1, inf\)",
    ):
        diagnose_gap(case.real, case.sim, **case.roles, max_effects=0)
    with pytest.raises(
        ValueError,
        match=r"'tolerance' parameter of diagnose_gap must be a float in the range \[0.0, inf\)",
    ):
        diagnose_gap(case.real, case.sim, **case.roles, tolerance=-0.1)
    uneven = case.real.drop(index=case.real.index[5])
    with pytest.raises(ValueError, match="sampling interval of test 'T1' is not constant"):
        diagnose_gap(uneven, case.sim, **case.roles)


def test_validate_withheld_small_run():
    result = validate_withheld(
        ("ambient",),
        sizes=(10,),
        n_seeds=1,
        param_errors=(0.05,),
        pairs=(),
        n_null=1,
        random_state=5,
    )
    cases = result.cases
    assert list(cases["withheld"]) == ["none", "ambient"]
    assert list(cases["cause"]) == ["none", "ambient"]
    assert result.false_alarms().loc[0.05].tolist() == [0, 1]
    assert result.recall()["top1"].tolist() == [1.0]
    confusion = result.confusion(param_error=0.05)
    assert confusion.loc["ambient", "ambient"] == 1 and confusion.loc["none", "none"] == 1
    shrink = result.shrinkage()
    # the named effect removes most of the noise-free gap
    assert shrink.loc[(0.05, "ambient"), "clean_shrinkage"] > 0.85
    assert result.pairs().empty  # no pair was withheld


def test_pairs_summarise_both_named_by_parameter_error():
    from gap_harness import WithheldValidation

    cases = pd.DataFrame(
        {
            "withheld": ["ambient+drift", "ambient+drift", "ambient+drift", "drift"],
            "param_error": [0.0, 0.0, 0.05, 0.0],
            "all_named": [True, False, True, True],
            "top1": [True, True, False, True],
        }
    )
    pairs = WithheldValidation(cases).pairs()
    assert pairs.loc[(0.0, "ambient+drift")].tolist() == [0.5, 1.0, 2]
    assert pairs.loc[(0.05, "ambient+drift")].tolist() == [1.0, 0.0, 1]
    assert len(pairs) == 2  # the single effect is not a pair


def test_withheld_case_rejects_unknown_effects():
    with pytest.raises(ValueError, match="Cannot withhold"):
        withheld_case(("sensor_lag",), 10, 0)


def test_an_effect_hidden_by_a_parameter_error_of_opposite_sign_is_found():
    # In this case the withheld air and the simulation's parameter error
    # partly cancel: refitting the parameters alone makes the held-out gap
    # larger (1.09 against 0.81 µm), and only the search with the parameters
    # refitted together with the air finds it.
    case = withheld_case(("ambient",), 30, 105, param_error=0.05)
    # one of the air's two lags ends at a bound of the search (the shortest
    # since no false event is held fixed any longer: the fit is as close)
    with pytest.warns(GapWarning, match="time constant of 'ambient' ended at the shortest"):
        report = diagnose_gap(
            case.real, case.sim, **case.roles, sensitivities=case.sensitivities, random_state=0
        )
    assert report.rmse_recalibrated > report.rmse_before
    assert report.named == ["ambient"] and report.recalibration_kept
    assert report.rmse_after < 1.1 * np.std(case.noise)


def test_backward_pruning_drops_an_effect_that_two_others_explain():
    from types import SimpleNamespace

    from greyml.gap._effects import Candidate
    from greyml.gap._fit import evaluate
    from greyml.gap._naming import EffectSearch, Named

    rng = np.random.default_rng(0)
    bounds = [(0, 200), (200, 400), (400, 600), (600, 800)]
    t = np.concatenate([np.linspace(0, 1, 200)] * 4)
    wave = np.concatenate([np.sin(np.linspace(0, k + 2, 200)) for k in range(4)])
    r = t + wave + 0.01 * rng.standard_normal(800)

    def fixed(name, x):
        return Candidate(name, [name], [()], lambda s: x[:, None, None], lambda v, s: v, 1)

    both, drift, other = fixed("both", t + wave), fixed("drift", t), fixed("other", wave)
    base = [np.zeros((800, 0))] * 4
    search = EffectSearch(
        SimpleNamespace(r=r, bounds=bounds),
        SimpleNamespace(base=base),
        rng,
        n_placebo=1,
        min_shrinkage=0.05,
        max_effects=3,
        tie_tolerance=0.02,
    )
    named = []
    for cand in (both, drift, other):
        fold = [np.hstack([b] + [n.candidate.make(())[:, 0, :] for n in named]) for b in base]
        named.append(Named(cand, evaluate(r, fold, cand.make, cand.settings, bounds), None))
    assert search._prune(named, None) == [both]


def _diagnosed(withheld, size, seed, param_error=0.05):
    """The diagnosis of one case of the suite, as ``validate_withheld`` runs it."""
    case = withheld_case(withheld, size, seed, param_error=param_error)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", GapWarning)  # a time constant at its bound
        return diagnose_gap(
            case.real,
            case.sim,
            **case.roles,
            sensitivities=case.sensitivities,
            random_state=seed,
            custom_effects=case.custom_effects,
        )


def test_effects_that_leave_most_of_a_foreign_gap_are_not_named():
    # the suite's foreign heater at seed 24 (5 % parameter error): initial_state
    # with sensor_lag, each supported on its own, took up part of the heater's
    # 60-120 min lag and were named; together they leave 91 % of the gap that
    # refitting the parameters leaves, so they do not account for it (and the
    # searches without initial_state, then without the next, name nothing)
    report = _diagnosed(("foreign",), 30.0, 24)
    assert report.named == [] and report.verdict == "unexplained"
    assert report.unexplained_share == pytest.approx(1.0)
    tried = report.causes.set_index("effect").loc[["initial_state", "sensor_lag"]]
    assert not tried["significant"].any()
    assert (
        tried["detail"]
        .str.contains(r"initial_state \+ sensor_lag would leave 91% of the held-out gap")
        .all()
    )
    assert "Tried, not supported: initial_state (held-out shrinkage 39%" in str(report)
    # told of the heater, the diagnosis names it: the rule takes nothing from
    # an effect that accounts for the gap
    given = _diagnosed(("foreign_custom",), 30.0, 24)
    assert given.named == ["fixture"] and given.verdict == "explained"


def test_a_search_that_does_not_account_for_the_gap_runs_again_without_its_first_effect():
    # initial_state at 30x with 5 % parameter error (seed 33 of the suite's
    # ten-seed cells): the first search names an effect that leaves most of the
    # gap; without it, the search names initial_state, which accounts for it
    report = _diagnosed(("initial_state",), 30.0, 33)
    assert report.cause == "initial_state"
    assert report.unexplained_share < 0.5
