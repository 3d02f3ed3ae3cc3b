"""The generalisation benchmark of issue 38: its simulated fleet, its acceptance lines, its docs.

``benchmarks/`` is on ``sys.path`` (tests/conftest.py), as for the scripts.
"""

import json
import math
from pathlib import Path

import bench_generalisation as bench
import numpy as np
import pytest
from _fleet import SAMPLE_S, fleet, spec_of

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def machines():
    return fleet()


# The fleet ---------------------------------------------------------------------


def test_fleet_has_eight_machines_of_six_tests_or_more(machines):
    assert len(machines) >= 8
    assert len({m.name for m in machines}) == len(machines)
    for m in machines:
        tests = m.X.index.get_level_values("test")
        assert tests.nunique() >= 6, m.name
        assert list(m.X.index.names) == ["test", "time_s"]
        temperatures = [c for c in m.X.columns if c not in m.drivers]
        assert 6 <= len(temperatures) <= 20, m.name
        assert list(m.X.columns[: len(m.drivers)]) == list(m.drivers)
        assert m.y.index.equals(m.X.index)
        assert np.isfinite(m.X.to_numpy()).all() and np.isfinite(m.y.to_numpy()).all()
        # every driver is used, and the probe moves by more than its noise
        assert (m.X[list(m.drivers)].max() > 0).all(), m.name
        assert float(m.y.abs().max()) > 10.0, m.name


def test_fleet_differs_in_recording_air_and_time_constants(machines):
    carried = [spec_of(m.name).carried for m in machines]
    assert any(carried) and not all(carried)
    for m in machines:
        starts = m.X.groupby(level="test", sort=False).apply(
            lambda g: g.index.get_level_values("time_s")[0]
        )
        if spec_of(m.name).carried:  # pieces of one clock
            assert starts.iloc[0] == 0.0 and (np.diff(starts.to_numpy()) > 0).all(), m.name
        else:  # each test on its own clock
            assert (starts == 0.0).all(), m.name
    assert len({spec_of(m.name).ambient for m in machines}) >= 4
    assert len({spec_of(m.name).slow for m in machines}) >= 4


def test_fleet_is_deterministic():
    one, two = fleet(["vmc-doors", "vmc-fast-drift"]), fleet(["vmc-doors", "vmc-fast-drift"])
    for a, b in zip(one, two):
        assert a.X.equals(b.X) and a.y.equals(b.y)
    other = fleet(["vmc-doors"], seed=1)[0]
    assert not other.y.equals(one[0].y)


def test_fleet_has_a_day_long_warm_up_from_cold(machines):
    cold = [spec_of(m.name) for m in machines if spec_of(m.name).cold_test is not None]
    assert len(cold) == 1
    spec = cold[0]
    m = next(m for m in machines if m.name == spec.name)
    first = m.X.loc[spec.cold_test]
    hours = len(first) * SAMPLE_S / 3600.0
    assert 23.0 <= hours <= 25.0
    assert m.X.index.get_level_values("test")[0] == spec.cold_test  # the recording's first test
    air = spec.sensor_names[[c for c, _, _ in spec.sensors].index("air")]
    row = first.iloc[0][spec.sensor_names]
    # at rest in the air: every temperature reads the air within the resolution
    assert float((row - row[air]).abs().max()) <= spec.resolution_C + 1e-9
    # the recording's zero: the probe reads 0 within its noise
    assert abs(float(m.y.iloc[0])) < 4 * spec.probe_noise_um
    # and the machine is still warming after hours: the displacement keeps moving
    y = m.y.loc[spec.cold_test].to_numpy()
    assert abs(y[-1] - y[len(y) // 2]) > 1.0


def test_unknown_machine_is_named():
    with pytest.raises(ValueError, match="no machine 'lathe' in the fleet"):
        spec_of("lathe")


# Summaries and acceptance on hand-made tables --------------------------------


def _table(default, ridge, restart=None, other=None):
    """A result table in the benchmark's layout: start RMSE per fold, recording = start + 1."""

    def recs(values):
        return [
            {"cycle": str(k + 1), "start": v, "recording": v + 1.0, "fit_s": 0.5}
            for k, v in enumerate(values)
        ]

    table = {label: recs([9.0] * len(default)) for label in bench.labels()}
    table[bench.DEFAULT] = recs(default)
    table[bench.RIDGE] = recs(ridge)
    table[bench.RESTART] = recs(restart or default)
    if other is not None:
        table["ARDL via OLS, top-5 corr"] = recs(other)
    return table


def test_summarise_unit_medians_worsts_and_wins():
    s = bench.summarise_unit(_table([1.0, 2.0, 4.0, 3.0, 10.0], [2.0, 1.5, 5.0, 3.0, 6.0]))
    d, r = s[bench.DEFAULT], s[bench.RIDGE]
    assert d["start"] == {"median": 3.0, "worst": 10.0}
    assert d["recording"] == {"median": 4.0, "worst": 11.0}
    assert r["start"] == {"median": 3.0, "worst": 6.0}
    # the default is below ridge in folds 1 and 3 (a tie in fold 4 is not a win)
    assert r["default_better"] == 2
    assert d["default_better"] is None
    assert d["fit_s"] == 2.5 and d["n_folds"] == 5


def test_summarise_unit_keeps_an_error_row():
    table = _table([1.0, 2.0], [2.0, 3.0])
    table[bench.RIDGE][1] = {"cycle": "2", "error": "ValueError: boom"}
    s = bench.summarise_unit(table)
    assert s[bench.RIDGE] == {"error": "ValueError: boom"}
    checks = bench.probe_checks({"ch1_um": s})
    assert checks[0].passed is None and checks[0].bar is None


def test_probe_checks_worst_and_best_peer():
    good = bench.summarise_unit(_table([1.0, 2.0, 3.0], [2.0, 3.0, 4.0], other=[2.5, 2.5, 2.5]))
    bad = bench.summarise_unit(_table([1.0, 2.0, 8.0], [2.0, 3.0, 4.0], other=[1.5, 1.5, 1.5]))
    checks = bench.probe_checks({"ch1_um": good, "ch3_um": bad})
    worst1, median1, worst3, median3 = checks
    assert (worst1.value, worst1.bar, worst1.passed) == (3.0, 4.0, True)
    assert (median1.value, median1.bar, median1.passed) == (2.0, 2.5, True)
    assert median1.detail == "ARDL via OLS, top-5 corr"
    assert (worst3.value, worst3.bar, worst3.passed) == (8.0, 4.0, False)
    assert (median3.value, median3.bar, median3.passed) == (2.0, 1.5, False)


def test_folds_beating_ridge_counts_over_units():
    s = {
        "ch1_um": bench.summarise_unit(_table([1.0, 2.0, 3.0], [2.0, 3.0, 1.0])),  # 2 of 3
        "ch2_um": bench.summarise_unit(_table([1.0, 5.0], [2.0, 3.0])),  # 1 of 2
    }
    check = bench.folds_beating_ridge(s, "caiviac", bar=4.0)
    assert (check.value, check.bar, check.passed) == (3.0, 4.0, False)
    assert "of 5" in check.what


def test_restart_checks_within_a_quarter():
    s = {
        "ch1_um": bench.summarise_unit(_table([2.0, 2.0, 2.0], [3.0] * 3, restart=[2.4] * 3)),
        "ch3_um": bench.summarise_unit(_table([2.0, 2.0, 2.0], [3.0] * 3, restart=[2.6] * 3)),
    }
    one, three = bench.restart_checks(s)
    assert math.isclose(one.value, 1.2) and one.passed
    assert math.isclose(three.value, 1.3) and not three.passed


def test_warmup_ratio_over_the_median_of_later_tests():
    table = _table([3.0, 1.0, 2.0, 4.0], [9.0] * 4)
    # first test 3.0 over the median of 1, 2, 4 = 2.0
    assert bench.warmup_ratio(table, "1") == 1.5
    assert bench.warmup_ratio(table, "9") is None


def test_fleet_checks_medians_over_machines():
    s = {
        "a": bench.summarise_unit(_table([1.0, 1.0, 1.0], [2.0] * 3, other=[1.5] * 3)),
        "b": bench.summarise_unit(_table([3.0, 3.0, 3.0], [2.0] * 3, other=[0.5] * 3)),
        "c": bench.summarise_unit(_table([2.0, 2.0, 2.0], [4.0] * 3, other=[1.0] * 3)),
    }
    median, machines = bench.fleet_checks(s)
    # default medians 1, 3, 2 -> 2; ARDL's 1.5, 0.5, 1.0 -> 1.0, the best peer
    assert (median.value, median.bar, median.passed) == (2.0, 1.0, False)
    assert median.detail == "ARDL via OLS, top-5 corr"
    # the default beats ridge on a and c: 2 of 3 against a bar of 7/8 of 3
    assert (machines.value, machines.passed, machines.detail) == (2.0, False, "a, c")
    assert machines.bar == pytest.approx(2.625)


# The script --------------------------------------------------------------------


def test_quick_run_without_caiviac_runs_the_fleet(tmp_path, capsys):
    out = tmp_path / "gen.json"
    argv = [
        "--quick",
        "--data",
        str(tmp_path / "nowhere.csv"),
        "--probes",
        "ch1_um",
        "--machines",
        "vmc-fast-drift",
        "--json",
        str(out),
    ]
    assert bench.main(argv) == 0
    printed = capsys.readouterr().out
    assert "CAIVIAC data not found at" in printed and "; skipping" in printed
    assert "start reference" in printed and "recording reference" in printed
    data = json.loads(out.read_text())
    assert "caiviac" not in data["results"]
    table = data["results"]["fleet"]["vmc-fast-drift"]
    assert set(table) == set(bench.labels())
    for label, folds in table.items():
        assert [r["cycle"] for r in folds] == ["1", "2", "3", "4", "5", "6"], label
    default = data["summary"]["fleet"]["vmc-fast-drift"][bench.DEFAULT]
    assert default["error"] is None and 0.0 < default["start"]["median"] < 5.0
    ridge = data["summary"]["fleet"]["vmc-fast-drift"][bench.RIDGE]
    assert 0 <= ridge["default_better"] <= 6
    whats = [c["what"] for c in data["acceptance"]]
    assert any("best peer" in w for w in whats)


def test_write_docs_needs_a_json(capsys):
    with pytest.raises(SystemExit):
        bench.main(["--write-docs"])
    assert "--write-docs needs --json or --from-json" in capsys.readouterr().err


# The docs' numbers come from the committed JSON --------------------------------


@pytest.fixture(scope="module")
def results():
    return json.loads((ROOT / "benchmarks" / "results" / "generalisation.json").read_text())


@pytest.mark.parametrize("page", ["benchmarks", "transfer"])
def test_docs_numbers_equal_the_json(results, page):
    text = bench.DOCS[page].read_text(encoding="utf-8")
    assert "\n".join(bench.docs_block(results, page)) in text


def test_docs_block_quotes_the_json_cells(results):
    block = "\n".join(bench.docs_block(results, "benchmarks"))
    for units in results["summary"].values():
        for rows in units.values():
            e = rows[bench.DEFAULT]
            if not e.get("error"):
                assert (
                    f"{bench.fmt(e['start']['median'])} ({bench.fmt(e['start']['worst'])})" in block
                )


def test_replace_block_refuses_a_page_without_one():
    with pytest.raises(ValueError, match="no generated block"):
        bench.replace_block("no markers here", ["x"])
    page = f"before\n{bench.BEGIN}\nold\n{bench.END}\nafter"
    assert bench.replace_block(page, ["new"]) == "before\nnew\nafter"
