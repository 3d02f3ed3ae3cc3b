"""The trust benchmark of issue 39: its summaries on hand-made tables, its acceptance lines, its docs.

``benchmarks/`` is on ``sys.path`` (tests/conftest.py), as for the scripts.
"""

import json
import math
from pathlib import Path

import bench_trust as bench
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _record(test, n, inside, rmse, width, rmse_1h=None, innovations=(), fired=0):
    out = {
        "test": test,
        "reference": "recording",
        "n": n,
        "inside": inside,
        "coverage": inside / n,
        "rmse": rmse,
        "mean_width": width,
    }
    if rmse_1h is not None:
        for label in bench.EVERY:
            out |= {
                f"rmse_{label}": rmse_1h,
                f"inside_{label}": inside,
                f"coverage_{label}": inside / n,
                f"readings_{label}": len(innovations),
                f"fired_{label}": fired,
                f"kinds_{label}": [],
                f"innovations_{label}": list(innovations),
            }
    return out


# Coverage: per test and pooled -------------------------------------------------


def test_pooled_coverage_weighs_rows_and_the_worst_test_is_kept():
    # test a: 90 of 100 rows inside; test b: 150 of 300
    s = bench.summarise_unit([_record("a", 100, 90, 1.0, 4.0), _record("b", 300, 150, 2.0, 2.0)])
    assert s["coverage"] == {"a": 0.9, "b": 0.5}
    assert s["rmse"] == {"a": 1.0, "b": 2.0}
    assert s["pooled_coverage"] == pytest.approx(240 / 400)  # not the mean of 0.9 and 0.5
    assert (s["worst_coverage"], s["worst_test"]) == (0.5, "b")
    # RMSE over the 400 rows: sqrt((100 * 1 + 300 * 4) / 400); width (400 + 600) / 400
    assert s["pooled_rmse"] == pytest.approx(math.sqrt(3.25))
    assert s["width_over_rmse"] == pytest.approx(2.5 / math.sqrt(3.25))
    assert s["median_rmse"] == 1.5
    assert (s["n_tests"], s["n_rows"]) == (2, 400)


def test_readings_summary_against_none():
    s = bench.summarise_unit(
        [
            _record("a", 100, 90, 1.0, 4.0, rmse_1h=0.5, innovations=[1.0, -1.0]),
            _record("b", 300, 150, 2.0, 2.0, rmse_1h=2.5, innovations=[2.0, math.nan], fired=1),
        ]
    )
    h = s["1h"]
    assert h["median_rmse"] == 1.5 and h["below_none"] == 0.0  # median 1.5 against 1.5
    assert h["tests_above_none"] == 1  # b: 2.5 > 2.0
    assert h["pooled_coverage"] == pytest.approx(0.6)
    assert h["innovation_sd"] == pytest.approx(math.sqrt(6 / 3))  # NaN left out, about 0
    assert h["innovation_sd_per_test"] == {"a": 1.0, "b": 2.0}
    assert (h["readings"], h["fired"]) == (4, 1)


def test_innovation_sd_is_about_zero_and_none_without_readings():
    assert bench.innovation_sd([3.0, 3.0]) == 3.0  # a bias counts: SD about 0, not the mean
    assert bench.innovation_sd([]) is None
    assert bench.innovation_sd([math.nan]) is None


def test_pooled_over_units_and_the_worst_unit():
    units = {
        "m1": bench.summarise_unit([_record("1", 100, 90, 1.0, 3.0)]),
        "m2": bench.summarise_unit([_record("1", 300, 270, 1.0, 3.0), _record("2", 100, 50, 1, 3)]),
    }
    p = bench.pooled_over(units)
    assert p["pooled_coverage"] == pytest.approx((90 + 320) / 500)
    assert (p["worst_unit"], p["worst_unit_coverage"]) == ("m2", 0.8)
    assert p["worst_test_coverage"] == 0.5


def test_false_alarms_over_units_and_reading_rates():
    a = bench.summarise_unit([_record("a", 10, 9, 1.0, 1.0, rmse_1h=1.0, innovations=[0.0] * 3)])
    b = bench.summarise_unit(
        [_record("b", 10, 9, 1.0, 1.0, rmse_1h=1.0, innovations=[0.0] * 2, fired=1)]
    )
    fa = bench.false_alarms({"a": a, "b": b})
    # b fired once per reading rate; 3 + 2 readings per rate, two rates
    assert fa == {"fired": 2, "readings": 10, "per_300_readings": 60.0}


# Changes ---------------------------------------------------------------------


def _change(probe, delay, share, kind="step", said="step"):
    return {
        "probe": probe,
        "change": kind,
        "delay_readings": delay,
        "kind_said": said if delay is not None else None,
        "share_removed": share,
        "effect_rms": 5.0,
        "fired_before": 0,
    }


def test_summarise_changes_detection_within_three_and_share_removed():
    runs = [
        _change("ch1_um", 1, 0.9),
        _change("ch1_um", 3, 0.7, said="ramp"),
        _change("ch2_um", 4, 0.5),
        _change("ch2_um", None, None),
    ]
    s = bench.summarise_changes(runs)["step"]
    assert s["runs"] == 4
    assert s["detected_within"] == 0.5  # delays 1 and 3; 4 is too late
    assert s["detected"] == 0.75 and s["median_delay"] == 3.0
    assert s["median_share_removed"] == pytest.approx(0.7) and s["min_share_removed"] == 0.5
    assert s["kinds_said"] == {"step": 2, "ramp": 1}
    assert s["median_effect_rms"] == 5.0
    assert s["by_probe"]["ch1_um"] == {
        "runs": 2,
        "detected_within": 2,
        "median_share_removed": pytest.approx(0.8),
    }
    assert s["by_probe"]["ch2_um"]["detected_within"] == 0


def test_effects_of_the_simulated_changes():
    hours = np.array([0.0, 1.0, 2.0, 3.0])
    part = np.array([10.0, 11.0, 13.0, 16.0])
    # from row 1 on: nothing at or before the onset's row
    assert bench.effect_of("drift", hours, part, 1).tolist() == [0.0, 0.0, 1.5, 3.0]
    assert bench.effect_of("step", hours, part, 1).tolist() == [0.0, 0.0, 5.0, 5.0]
    assert bench.effect_of("gain", hours, part, 1) == pytest.approx([0.0, 0.0, 0.4, 1.0])


def test_share_removed():
    effect = np.array([2.0, 4.0])
    assert bench.share_removed(effect, np.array([1.0, 2.0]), np.zeros(2)) == pytest.approx(0.5)
    assert bench.share_removed(effect, effect + 3.0, np.full(2, 3.0)) == 1.0
    assert bench.share_removed(np.zeros(2), np.zeros(2), np.zeros(2)) is None


# Streaming helpers ---------------------------------------------------------------


def test_in_reference_start_subtracts_each_tests_first_row_and_copies():
    y = np.array([5.0, 6.0, 8.0, 1.0, 3.0])
    bounds = {"a": (0, 3), "b": (3, 5)}
    assert bench.in_reference(y, bounds, "start").tolist() == [0.0, 1.0, 3.0, 0.0, 2.0]
    assert bench.in_reference(y, bounds, "recording").tolist() == y.tolist()
    assert y.tolist() == [5.0, 6.0, 8.0, 1.0, 3.0]  # unchanged


def test_reading_rows_at_the_end_of_every_hour_from_the_first_row():
    times = 100.0 + 900.0 * np.arange(10)  # 15 min rows, 2 h 15 min
    assert bench.reading_rows(times, 0, 10, 3600.0) == [4, 8]
    assert bench.reading_rows(times, 2, 10, 3600.0) == [6]


# Acceptance lines ----------------------------------------------------------------


def test_line_holds_inside_its_bar():
    assert bench.line("p", "u", "w", 0.9, 0.85, 0.95).passed is True
    assert bench.line("p", "u", "w", 0.96, 0.85, 0.95).passed is False
    assert bench.line("p", "u", "w", 0.2, 0.5).passed is False
    assert bench.line("p", "u", "w", 25.0, high=30.0).passed is True
    assert bench.line("p", "u", "w", None, 0.5).passed is None
    assert bench.line("p", "u", "w", math.nan, 0.5).passed is None
    assert bench.bar_text(0.85, 0.95) == "0.85-0.95" and bench.bar_text(None, 4.0) == "<= 4"
    reported = bench.line("p", "u", "w", 3.0)  # no bar: reported, neither PASS nor FAIL
    assert reported.passed is None and bench.bar_text(None, None) == "none (reported)"


def test_false_alarms_of_the_unchanged_pairs():
    pairs = [
        {"fired": 1, "readings": 15},
        {"fired": 0, "readings": 15},
        {"fired": 2, "readings": 15},
    ]
    s = bench.summarise({"unchanged_pairs": pairs})["unchanged_pairs"]
    assert s == {
        "fired": 3,
        "readings": 45,
        "per_300_readings": 20.0,
        "runs_fired": 2,
        "runs": 3,
    }
    (alarms,) = bench.acceptance({"unchanged_pairs": s})
    assert (alarms.value, alarms.passed) == (20.0, None)
    assert alarms.detail == "3 firings in 45 readings, 2 of 3 runs"


def test_acceptance_on_a_hand_made_summary():
    units = {
        "ch1_um": bench.summarise_unit(
            [
                _record("1", 100, 90, 2.0, 6.0, rmse_1h=0.8, innovations=[1.0, -1.0]),
                _record("2", 100, 60, 2.0, 6.0, rmse_1h=0.8, innovations=[1.0, -1.0], fired=1),
            ]
        )
    }
    summary = {"caiviac": {"units": units, "false_alarms": bench.false_alarms(units)}}
    lines = {c.what: c for c in bench.acceptance(summary)}
    assert lines["no readings: pooled coverage"].value == 0.75
    assert lines["no readings: pooled coverage"].passed is False
    worst = lines["no readings: worst cycle's coverage"]
    assert (worst.value, worst.passed, worst.detail) == (0.6, False, "cycle 2")
    assert lines["no readings: mean width / RMSE"].value == 3.0
    assert lines["hourly readings: median RMSE below none (share)"].value == pytest.approx(0.6)
    assert lines["innovation SD, hourly readings, unchanged held-out cycles"].value == 1.0
    alarms = next(c for w, c in lines.items() if w.startswith("false alarms"))
    # once per reading rate in cycle 2: 2 firings in 2 cycles x 2 readings x 2 rates
    assert alarms.value == 300 * 2 / 8 and alarms.passed is False
    assert alarms.detail == "2 firings in 8 readings"


# The script --------------------------------------------------------------------


def test_run_on_one_machine_without_caiviac(tmp_path, capsys):
    out = tmp_path / "trust.json"
    argv = ["--data", str(tmp_path / "nowhere.csv"), "--machines", "vmc-steps", "--json", str(out)]
    assert bench.main(argv) == 0
    printed = capsys.readouterr().out
    assert "CAIVIAC data not found at" in printed and "; skipping" in printed
    assert "recording reference (from the recording's zero)" in printed
    data = json.loads(out.read_text())
    tests = data["results"]["fleet"]["vmc-steps"]
    assert [r["test"] for r in tests] == [str(k) for k in range(1, 8)]
    for r in tests:
        assert r["stream_vs_batch"] < 1e-9  # streaming without readings is batch predict
        assert r["readings_1h"] >= 1 and len(r["innovations_1h"]) == r["readings_1h"]
        assert 0.0 <= r["coverage"] <= 1.0
    s = data["summary"]["fleet"]["units"]["vmc-steps"]
    assert set(s["coverage"]) == {r["test"] for r in tests}
    whats = [c["what"] for c in data["acceptance"]]
    assert "no readings: worst machine's pooled coverage" in whats


def test_write_docs_needs_a_json(capsys):
    with pytest.raises(SystemExit):
        bench.main(["--write-docs"])
    assert "--write-docs needs --json or --from-json" in capsys.readouterr().err


# The docs' numbers come from the committed JSON --------------------------------


def test_docs_numbers_equal_the_json():
    path = bench.RESULTS
    if not path.is_file():
        pytest.skip(f"{path} is absent: run benchmarks/bench_trust.py --json {path}")
    data = json.loads(path.read_text(encoding="utf-8"))
    assert "\n".join(bench.docs_block(data)) in bench.DOCS.read_text(encoding="utf-8")


def test_replace_block_refuses_a_page_without_one():
    with pytest.raises(ValueError, match="no generated block"):
        bench.replace_block("no markers here", ["x"])
    page = f"before\n{bench.BEGIN}\nold\n{bench.END}\nafter"
    assert bench.replace_block(page, ["new"]) == "before\nnew\nafter"
