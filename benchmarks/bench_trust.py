"""Trust (issue 39): intervals, probe readings and detection on five CAIVIAC probes and a fleet.

Protocol
--------
* Models: the default greyml model as a user constructs it
  (``bench_dynamic_peers.default_model(drivers)``), fitted with weight 0 on
  the held-out test: ``default_model(drivers).fit(X, y, sample_weight=w)``.
  Its inputs drive the lags over the whole recording, its displacement is
  never seen. Everything is read through the public API:
  ``predict_interval(X, 0.9)``, ``reference_``,
  ``Compensator.from_model(model, coverage=0.9)``, ``update``, ``observe``
  and ``status`` (the fields ``innovation``, ``change_kind`` and
  ``change_start_s`` are read when the compensator has them).
* Data and folds: CAIVIAC/FL_THERMAL, probes ``ch1_um`` ... ``ch5_um``,
  leave one cycle out (5 x 5 folds), read as logged; the simulated fleet of
  ``benchmarks/_fleet.py`` (8 machines, 6-7 tests each), leave one test out,
  every test of every machine.
* Reference: every displacement is in the model's reference
  (``reference_``): "start", the change from each test's first row, or
  "recording", from the recording's zero (CAIVIAC's). It is named with every
  number printed or written.
* 1. No readings: on every row of the held-out test, whether the measured
  displacement is inside the 90 % interval; coverage per test, pooled over a
  probe's (machine's) rows, the worst test; the mean width over the pooled
  RMSE of the prediction.
* 2. Readings: the compensator streams the whole recording (from a test's
  first row ``start_test`` where the model measures tests from their start
  and the clock runs on, ``reset`` where the tests restart); in the held-out
  test only, the measured displacement is given to ``observe`` at the end of
  every full hour (or 4 h) from the test's first row. RMSE and coverage of
  the compensator's interval (``status.half_width``) on every row of the
  held-out test. The standardised innovation of each reading is
  ``status.innovation`` where the compensator reports it; before that, it
  is computed here as (reading - correction at that row before it) /
  (half-width before it / z), z the normal quantile of the interval's
  coverage (1.645 for 90 %), and labelled so. Its SD is the root mean square
  about 0 over the readings of a probe. Detector firings are the rise of
  ``status.changes`` at a reading; false alarms are firings on these
  unchanged held-out tests, over their readings (reported beside: the
  firings on the change runs' unchanged baseline below, and on the fleet).
  Streaming without readings must give batch ``predict_interval``'s
  prediction (checked to 1e-9 µm on every fold).
* 3. Changes (CAIVIAC, every probe): two consecutive cycles held out
  together (1-2, 2-3, 3-4, 4-5: 16 h, 15 hourly readings from the first
  row), the change added to the measured displacement after reading 3, 5, 7
  or 9: a drift of +1.5 µm/h, a step of 5 µm, or a gain change of 20 % on
  one sensor (the model's terms of its first chosen sensor, streamed alone:
  the displacement plus 0.2 x that part's change since the onset). A change
  is detected within 3 readings when the detector first fires after the
  onset at one of the next 3 readings; the share of the change's effect
  removed after 5 readings is 1 - RMS(effect - (correction changed -
  correction unchanged)) / RMS(effect) over the rows from the 5th reading
  after the onset to the end of the stretch.
* 4. Cost: µs per ``update`` with the status read at every row, and per
  ``observe`` (a reading every hour, 1 s late), best of 3, on ch1.
* 5. The acceptance lines of issue 39 that this measures: ``acceptance``
  returns them as :class:`Line` records (the bar, the number, PASS/FAIL).

``--write-docs`` rewrites the generated block of ``docs/trust.rst`` from
``--json`` (or from an earlier run's file with ``--from-json``, running
nothing). Without the CAIVIAC data the script says "CAIVIAC data not found at
...; skipping" for that part and still runs the fleet. A full run takes about
4 min on one core of a shared machine (``--quick``: ch1, ch3 and three
machines, about 1 min).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import bench_dynamic_peers as peers
import numpy as np
from _common import check_docs_flags, chosen_units, find_data, replace_generated, write_json
from bench_generalisation import fmt
from scipy.stats import norm

from greyml.controller import Compensator

PROBES = ("ch1_um", "ch2_um", "ch3_um", "ch4_um", "ch5_um")
QUICK_PROBES = ("ch1_um", "ch3_um")
QUICK_MACHINES = ("vmc-fast-drift", "vmc-doors", "vmc-cold")
COVERAGE = 0.9
#: Reading intervals, from each held-out test's first row.
EVERY = {"1h": 3600.0, "4h": 14400.0}
#: Onsets of the simulated changes: after this many hourly readings.
ONSETS = (3, 5, 7, 9)
DRIFT_UM_PER_H = 1.5
STEP_UM = 5.0
GAIN = 1.2
CHANGES = ("drift", "step", "gain")
#: Readings after the onset within which a change counts as detected, and after which
#: the share of its effect removed is measured.
DETECT_WITHIN = 3
REMOVED_AFTER = 5
#: What a firing's kind is recorded as when the compensator's status has no ``change_kind``.
NOT_REPORTED = "not reported"
REFERENCES = {
    "start": "start reference (change from each test's first row)",
    "recording": "recording reference (from the recording's zero)",
}
ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "trust.json"
DOCS = ROOT / "docs" / "trust.rst"


# Streaming -------------------------------------------------------------------


def rows_of(X):
    """The rows of X as dicts with time_s, in order (what a controller streams)."""
    times = X.index.get_level_values("time_s").to_numpy(dtype=float)
    return [{"time_s": t, **r} for t, r in zip(times, X.to_dict("records"))]


def bounds_of(X):
    """{test: (start, stop)} row numbers of every test, in order."""
    groups = np.asarray(X.index.get_level_values("test")).astype(str)
    out = {}
    for i, g in enumerate(groups):
        start, _ = out.get(g, (i, i))
        out[g] = (start, i + 1)
    return out


def in_reference(y, bounds, reference):
    """The measured displacement in the model's reference (a copy; y is not changed)."""
    y = np.array(y, dtype=float)
    if reference == "start":
        for start, stop in bounds.values():
            y[start:stop] = y[start:stop] - y[start]
    return y


def reading_rows(times, start, stop, every_s):
    """Row numbers in [start, stop) at the end of every ``every_s`` from the row ``start``."""
    out, k = [], 1
    while True:
        row = start + int(np.searchsorted(times[start:stop], times[start] + k * every_s - 1e-9))
        if row >= stop:
            return out
        out.append(row)
        k += 1


@dataclass(frozen=True)
class Reading:
    """What one probe reading did: its standardised innovation and whether the detector fired."""

    row: int
    innovation: float
    fired: bool
    kind: str | None
    start_s: float | None


@dataclass(frozen=True)
class Stream:
    """A recording streamed through the compensator: every row's correction and half-width."""

    correction: np.ndarray
    half_width: np.ndarray
    readings: list
    innovation_source: str | None  # None without readings


def stream(model, rows, firsts, y_ref, readings):
    """Stream ``rows`` through ``Compensator.from_model(model)``; ``observe`` at ``readings``.

    ``firsts`` holds the row numbers that start a test; ``y_ref`` is the
    measured displacement in the model's reference.
    """
    comp = Compensator.from_model(model, coverage=COVERAGE)
    from_start, carry = model.reference_ == "start", model.state_ == "carry"
    z = float(norm.ppf(0.5 + COVERAGE / 2.0))
    corr, half = np.empty(len(rows)), np.empty(len(rows))
    wanted, done, source = set(readings), [], None
    for i, row in enumerate(rows):
        if i in firsts and i > 0 and not carry:
            comp.reset()
        if i in firsts and i > 0 and carry and from_start:
            comp.start_test(row)
        else:
            comp.update(row)
        s = comp.status
        if i in wanted:
            after = comp.observe(row["time_s"], float(y_ref[i]))
            innovation = getattr(after, "innovation", None)
            source = "status.innovation"
            if innovation is None:  # before the compensator reports it: from the half-width
                source = "(reading - correction) / (half-width / z), computed by the bench"
                innovation = (y_ref[i] - s.correction) / (s.half_width / z)
            done.append(
                Reading(
                    i,
                    float(innovation),
                    after.changes > s.changes,
                    getattr(after, "change_kind", NOT_REPORTED),
                    getattr(after, "change_start_s", None),
                )
            )
            s = comp.status
        corr[i], half[i] = s.correction, s.half_width
    return Stream(corr, half, done, source)


def sensor_part(model, rows, firsts):
    """The model's terms of its first chosen sensor (not a driver), streamed alone (µm), and its name."""
    sensor = next(t[0] for t in model.terms_ if t[0] not in model.drivers)
    comp = Compensator(
        [sensor],
        [t for t in model.terms_ if t[0] == sensor],
        0.0,
        nominal_step_s=model.nominal_step_s_ if model.state_ == "carry" else None,
        max_step_s=model.gap_limit_s_,
    )
    out = np.empty(len(rows))
    for i, r in enumerate(rows):
        if i in firsts and i > 0 and model.state_ != "carry":
            comp.reset()
        out[i] = comp.update({"time_s": r["time_s"], sensor: r[sensor]})
    return out, sensor


def rmse(e):
    return float(np.sqrt(np.mean(np.square(e))))


# 1 and 2: held-out tests, without and with readings ---------------------------


def fit_without(X, y, drivers, held):
    """The default model fitted with weight 0 on the rows ``held``."""
    return peers.default_model(drivers).fit(X, y, sample_weight=(~held).astype(float))


def held_out(X, y, drivers, unit):
    """One record per held-out test of one probe or machine (leave one test out)."""
    bounds = bounds_of(X)
    firsts = {start for start, _ in bounds.values()}
    rows = rows_of(X)
    times = np.array([r["time_s"] for r in rows])
    out = []
    for test, (start, stop) in bounds.items():
        held = np.zeros(len(rows), dtype=bool)
        held[start:stop] = True
        model = fit_without(X, y, drivers, held)
        y_ref = in_reference(y.to_numpy(), bounds, model.reference_)
        iv = model.predict_interval(X, COVERAGE)
        h = slice(start, stop)
        inside = (y_ref[h] >= iv[h, 1]) & (y_ref[h] <= iv[h, 2])
        record = {
            "test": test,
            "reference": model.reference_,
            "n": stop - start,
            "rmse": rmse(y_ref[h] - iv[h, 0]),
            "inside": int(inside.sum()),
            "coverage": float(inside.mean()),
            "mean_width": float(np.mean(iv[h, 2] - iv[h, 1])),
        }
        none = stream(model, rows, firsts, y_ref, [])
        record["stream_vs_batch"] = float(np.max(np.abs(none.correction - iv[:, 0])))
        for label, every in EVERY.items():
            s = stream(model, rows, firsts, y_ref, reading_rows(times, start, stop, every))
            e = y_ref[h] - s.correction[h]
            covered = np.abs(e) <= s.half_width[h]
            record |= {
                f"rmse_{label}": rmse(e),
                f"inside_{label}": int(covered.sum()),
                f"coverage_{label}": float(covered.mean()),
                f"readings_{label}": len(s.readings),
                f"fired_{label}": sum(r.fired for r in s.readings),
                f"kinds_{label}": [r.kind for r in s.readings if r.fired],
                f"innovations_{label}": [round(r.innovation, 4) for r in s.readings],
            }
            record["innovation_source"] = record.get("innovation_source") or s.innovation_source
        out.append(record)
        print(
            f"  {unit} test {test}: {REFERENCES[model.reference_].split(' (')[0]}; no readings "
            f"RMSE {record['rmse']:.2f} µm, coverage {record['coverage']:.3f}, width/RMSE "
            f"{record['mean_width'] / record['rmse']:.2f}; hourly RMSE {record['rmse_1h']:.2f} "
            f"(coverage {record['coverage_1h']:.3f}, fired {record['fired_1h']} of "
            f"{record['readings_1h']}); 4-hourly RMSE {record['rmse_4h']:.2f} (coverage "
            f"{record['coverage_4h']:.3f}, fired {record['fired_4h']} of {record['readings_4h']})",
            flush=True,
        )
    return out


# 3: simulated changes --------------------------------------------------------


def hours_along(times, start, stop, step_s):
    """Hours from row ``start`` along the rows' steps (a clock that restarts steps by ``step_s``)."""
    steps = np.diff(times[start:stop], prepend=times[start])
    steps[steps < 0] = step_s
    return np.cumsum(steps) / 3600.0


def effect_of(kind, hours, part, onset):
    """The change ``kind`` added from row ``onset`` on (rows before it: 0), µm."""
    after = np.arange(len(hours)) > onset
    if kind == "drift":
        return np.where(after, DRIFT_UM_PER_H * (hours - hours[onset]), 0.0)
    if kind == "step":
        return np.where(after, STEP_UM, 0.0)
    return np.where(after, (GAIN - 1.0) * (part - part[onset]), 0.0)


def share_removed(effect, corr_changed, corr_unchanged):
    """1 - RMS(effect not followed) / RMS(effect): the share of a change the correction took up
    (None for no effect)."""
    size = rmse(effect)
    return None if size == 0 else 1.0 - rmse(effect - (corr_changed - corr_unchanged)) / size


def changed(X, y, drivers, unit):
    """One record per (pair of cycles held out, change, onset) on one probe, and one per pair
    streamed unchanged with its hourly readings."""
    bounds = bounds_of(X)
    tests = list(bounds)
    firsts = {start for start, _ in bounds.values()}
    rows = rows_of(X)
    times = np.array([r["time_s"] for r in rows])
    out, pairs = [], []
    for a, b in zip(tests[:-1], tests[1:]):
        start, stop = bounds[a][0], bounds[b][1]
        held = np.zeros(len(rows), dtype=bool)
        held[start:stop] = True
        model = fit_without(X, y, drivers, held)
        if model.reference_ == "start":  # a reading in b would start anew: not this design
            raise ValueError(f"{unit}: the change runs need the recording reference")
        y_ref = in_reference(y.to_numpy(), bounds, model.reference_)
        readings = reading_rows(times, start, stop, 3600.0)
        base = stream(model, rows, firsts, y_ref, readings)
        pairs.append(
            {
                "probe": unit,
                "tests": f"{a}-{b}",
                "reference": model.reference_,
                "readings": len(base.readings),
                "fired": sum(r.fired for r in base.readings),
                "innovations": [round(r.innovation, 4) for r in base.readings],
            }
        )
        part, sensor = sensor_part(model, rows, firsts)
        hours = hours_along(times, start, stop, model.nominal_step_s_)
        for kind in CHANGES:
            for n in ONSETS:
                onset = readings[n - 1]
                effect = np.zeros(len(rows))
                effect[start:stop] = effect_of(kind, hours, part[start:stop], onset - start)
                s = stream(model, rows, firsts, y_ref + effect, readings)
                later = s.readings[n:]
                first = next((k + 1 for k, r in enumerate(later) if r.fired), None)
                window = slice(readings[n - 1 + REMOVED_AFTER], stop)
                record = {
                    "probe": unit,
                    "tests": f"{a}-{b}",
                    "reference": model.reference_,
                    "change": kind,
                    "sensor": sensor if kind == "gain" else None,
                    "onset_reading": n,
                    "readings_after": len(later),
                    "fired_before": sum(r.fired for r in s.readings[:n]),
                    "delay_readings": first,
                    "kind_said": None if first is None else later[first - 1].kind,
                    "start_said_s": None if first is None else later[first - 1].start_s,
                    "onset_s": float(times[onset]),
                    "effect_rms": rmse(effect[window]),
                    "share_removed": share_removed(
                        effect[window], s.correction[window], base.correction[window]
                    ),
                }
                out.append(record)
        print(
            f"  {unit} cycles {a}-{b} held out ({REFERENCES[model.reference_].split(' (')[0]}): "
            + "; ".join(
                f"{kind} delays "
                + ",".join(
                    str(r["delay_readings"] or "-")
                    for r in out
                    if r["change"] == kind and r["tests"] == f"{a}-{b}"
                )
                for kind in CHANGES
            ),
            flush=True,
        )
    return out, pairs


# 4: cost ---------------------------------------------------------------------


def cost(X, y, drivers):
    """µs per update with the status read, and per observe (best of 3)."""
    model = peers.default_model(drivers).fit(X, y)
    rows = rows_of(X)[:2000]
    order = ["time_s", *X.columns]
    arrays = [np.array([r[c] for c in order], dtype=float) for r in rows]
    best_u, best_o = math.inf, math.inf
    for _ in range(3):
        comp = Compensator.from_model(model, coverage=COVERAGE, row_columns=order)
        spent_u, spent_o, k = 0.0, 0.0, 0
        for i, a in enumerate(arrays):
            start = time.perf_counter()
            comp.update(a)
            comp.status  # noqa: B018 (the status is read at every row)
            spent_u += time.perf_counter() - start
            if i % 240 == 239:  # a reading every hour, 1 s late: interpolated
                start = time.perf_counter()
                comp.observe(float(a[0]) - 1.0, float(y.iloc[i]))
                spent_o += time.perf_counter() - start
                k += 1
        best_u = min(best_u, spent_u / len(arrays))
        best_o = min(best_o, spent_o / k)
    return {"update_us": best_u * 1e6, "observe_us": best_o * 1e6}


# Summaries (functions of result tables) ---------------------------------------


def innovation_sd(values):
    """Root mean square about 0 of standardised innovations (1 when calibrated); None without any."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2))) if v.size else None


def summarise_unit(records):
    """One probe's or machine's held-out tests: pooled and per-test figures."""
    n = sum(r["n"] for r in records)
    pooled_rmse = math.sqrt(sum(r["n"] * r["rmse"] ** 2 for r in records) / n)
    worst = min(records, key=lambda r: r["coverage"])
    none = float(np.median([r["rmse"] for r in records]))
    out = {
        "reference": records[0]["reference"],
        "n_tests": len(records),
        "n_rows": n,
        "coverage": {r["test"]: r["coverage"] for r in records},
        "rmse": {r["test"]: r["rmse"] for r in records},
        "pooled_coverage": sum(r["inside"] for r in records) / n,
        "worst_coverage": worst["coverage"],
        "worst_test": worst["test"],
        "pooled_rmse": pooled_rmse,
        "width_over_rmse": sum(r["n"] * r["mean_width"] for r in records) / n / pooled_rmse,
        "median_rmse": none,
        "stream_vs_batch": max(r.get("stream_vs_batch", 0.0) for r in records),
    }
    for label in EVERY:
        if f"rmse_{label}" not in records[0]:
            continue
        median = float(np.median([r[f"rmse_{label}"] for r in records]))
        out[label] = {
            "median_rmse": median,
            "below_none": 1.0 - median / none,
            "tests_above_none": sum(r[f"rmse_{label}"] > r["rmse"] for r in records),
            "coverage": {r["test"]: r[f"coverage_{label}"] for r in records},
            "rmse": {r["test"]: r[f"rmse_{label}"] for r in records},
            "innovation_sd_per_test": {
                r["test"]: innovation_sd(r[f"innovations_{label}"]) for r in records
            },
            "pooled_coverage": sum(r[f"inside_{label}"] for r in records) / n,
            "worst_coverage": min(r[f"coverage_{label}"] for r in records),
            "innovation_sd": innovation_sd([v for r in records for v in r[f"innovations_{label}"]]),
            "readings": sum(r[f"readings_{label}"] for r in records),
            "fired": sum(r[f"fired_{label}"] for r in records),
        }
    return out


def pooled_over(summaries):
    """Pooled coverage over several units' rows, and the worst unit by its pooled coverage."""
    n = sum(s["n_rows"] for s in summaries.values())
    pooled = sum(s["pooled_coverage"] * s["n_rows"] for s in summaries.values()) / n
    worst = min(summaries, key=lambda u: summaries[u]["pooled_coverage"])
    return {
        "pooled_coverage": pooled,
        "worst_unit": worst,
        "worst_unit_coverage": summaries[worst]["pooled_coverage"],
        "worst_test_coverage": min(s["worst_coverage"] for s in summaries.values()),
    }


def false_alarms(summaries, labels=tuple(EVERY)):
    """Detector firings and readings on unchanged held-out tests, pooled over units and labels."""
    fired = sum(s[label]["fired"] for s in summaries.values() for label in labels)
    readings = sum(s[label]["readings"] for s in summaries.values() for label in labels)
    return {
        "fired": fired,
        "readings": readings,
        "per_300_readings": 300.0 * fired / readings if readings else None,
    }


def finite_median(values):
    """The median of the finite values, None without any."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else None


def summarise_changes(records):
    """Per change: detection within DETECT_WITHIN readings, the share removed, what the detector
    said; over every run and per probe."""
    out = {}
    for kind in dict.fromkeys(r["change"] for r in records):
        rs = [r for r in records if r["change"] == kind]
        delays = [r["delay_readings"] for r in rs if r["delay_readings"] is not None]
        shares = [r["share_removed"] for r in rs if r["share_removed"] is not None]
        kinds = {}
        for r in rs:
            if r["delay_readings"] is not None:
                kinds[str(r["kind_said"])] = kinds.get(str(r["kind_said"]), 0) + 1
        by_probe = {}
        for probe in dict.fromkeys(r["probe"] for r in rs):
            mine = [r for r in rs if r["probe"] == probe]
            by_probe[probe] = {
                "runs": len(mine),
                "detected_within": sum(
                    r["delay_readings"] is not None and r["delay_readings"] <= DETECT_WITHIN
                    for r in mine
                ),
                "median_share_removed": finite_median(
                    [r["share_removed"] for r in mine if r["share_removed"] is not None]
                ),
            }
        out[kind] = {
            "runs": len(rs),
            "detected_within": sum(d <= DETECT_WITHIN for d in delays) / len(rs),
            "detected": len(delays) / len(rs),
            "median_delay": float(np.median(delays)) if delays else None,
            "median_share_removed": finite_median(shares),
            "median_effect_rms": finite_median([r["effect_rms"] for r in rs]),
            "min_share_removed": float(np.min(shares)) if shares else None,
            "kinds_said": kinds,
            "runs_fired_before_onset": sum(r["fired_before"] > 0 for r in rs),
            "by_probe": by_probe,
        }
    return out


def summarise(results):
    """Every summary of a run's result tables (the JSON's ``results``)."""
    out = {}
    for part in ("caiviac", "fleet"):
        if results.get(part):
            units = {u: summarise_unit(t) for u, t in results[part].items()}
            out[part] = {"units": units, "pooled": pooled_over(units)}
            if "1h" in next(iter(units.values())):
                out[part]["false_alarms"] = false_alarms(units)
                out[part]["innovation_source"] = sorted(
                    {r["innovation_source"] for t in results[part].values() for r in t} - {None}
                )
    if results.get("changes"):
        out["changes"] = summarise_changes(results["changes"])
    if results.get("unchanged_pairs"):
        fired = sum(r["fired"] for r in results["unchanged_pairs"])
        readings = sum(r["readings"] for r in results["unchanged_pairs"])
        out["unchanged_pairs"] = {
            "fired": fired,
            "readings": readings,
            "per_300_readings": 300.0 * fired / readings if readings else None,
            "runs_fired": sum(r["fired"] > 0 for r in results["unchanged_pairs"]),
            "runs": len(results["unchanged_pairs"]),
        }
    return out


# 5: acceptance ----------------------------------------------------------------


@dataclass(frozen=True)
class Line:
    """One acceptance line: the number measured, its bar [low, high], and whether it holds."""

    part: str
    unit: str
    what: str
    value: float | None
    low: float | None
    high: float | None
    passed: bool | None
    detail: str = ""


def line(part, unit, what, value, low=None, high=None, detail=""):
    ok = None
    if value is not None and np.isfinite(value) and (low is not None or high is not None):
        ok = bool((low is None or value >= low) and (high is None or value <= high))
    return Line(part, unit, what, value, low, high, ok, detail)


def bar_text(low, high):
    if low is None and high is None:
        return "none (reported)"
    if low is not None and high is not None:
        return f"{low:g}-{high:g}"
    return f">= {low:g}" if low is not None else f"<= {high:g}"


def probe_lines(units):
    """Per CAIVIAC probe: coverage, worst cycle, width, innovations, readings."""
    out = []
    for probe, s in units.items():
        out += [
            line(
                "caiviac", probe, "no readings: pooled coverage", s["pooled_coverage"], 0.85, 0.95
            ),
            line(
                "caiviac",
                probe,
                "no readings: worst cycle's coverage",
                s["worst_coverage"],
                0.70,
                detail=f"cycle {s['worst_test']}",
            ),
            line(
                "caiviac", probe, "no readings: mean width / RMSE", s["width_over_rmse"], high=4.0
            ),
        ]
        if "1h" not in s:
            continue
        h, f = s["1h"], s["4h"]
        out += [
            line(
                "caiviac",
                probe,
                "innovation SD, hourly readings, unchanged held-out cycles",
                h["innovation_sd"],
                0.8,
                1.25,
                detail=f"{h['readings']} readings",
            ),
            line(
                "caiviac",
                probe,
                "hourly readings: median RMSE below none (share)",
                h["below_none"],
                0.5,
                detail=f"{fmt(s['median_rmse'])} -> {fmt(h['median_rmse'])} µm",
            ),
            line(
                "caiviac",
                probe,
                "4-hourly readings: median RMSE over none's",
                f["median_rmse"] / s["median_rmse"],
                high=1.0,
                detail=f"{f['tests_above_none']} of {s['n_tests']} cycles above none",
            ),
            line(
                "caiviac",
                probe,
                "hourly readings: pooled coverage",
                h["pooled_coverage"],
                0.85,
                0.95,
            ),
            line(
                "caiviac",
                probe,
                "4-hourly readings: pooled coverage",
                f["pooled_coverage"],
                0.85,
                0.95,
            ),
        ]
    return out


def acceptance(summary):
    """Every acceptance line of issue 39 this benchmark measures, as :class:`Line` records."""
    out = []
    cai, fl, ch = summary.get("caiviac"), summary.get("fleet"), summary.get("changes")
    if cai:
        out += probe_lines(cai["units"])
        fa = cai.get("false_alarms")
        if fa:
            out.append(
                line(
                    "caiviac",
                    "all",
                    "false alarms per 300 readings, unchanged held-out cycles (hourly and "
                    "4-hourly readings)",
                    fa["per_300_readings"],
                    high=1.0,
                    detail=f"{fa['fired']} firings in {fa['readings']} readings",
                )
            )
    pairs = summary.get("unchanged_pairs")
    if pairs:
        out.append(
            line(
                "caiviac",
                "all",
                "false alarms per 300 readings, two cycles held out unchanged (hourly readings, "
                "the change runs' baseline)",
                pairs["per_300_readings"],
                detail=f"{pairs['fired']} firings in {pairs['readings']} readings, "
                f"{pairs['runs_fired']} of {pairs['runs']} runs",
            )
        )
    fleet_alarms = (fl or {}).get("false_alarms")
    if fleet_alarms:
        out.append(
            line(
                "fleet",
                "all",
                "false alarms per 300 readings, unchanged held-out tests (hourly and 4-hourly "
                "readings)",
                fleet_alarms["per_300_readings"],
                detail=f"{fleet_alarms['fired']} firings in {fleet_alarms['readings']} readings",
            )
        )
    if ch:
        if "step" in ch:
            out.append(
                line(
                    "caiviac",
                    "all",
                    f"5 µm step detected within {DETECT_WITHIN} readings (share of runs)",
                    ch["step"]["detected_within"],
                    0.5,
                    detail=f"{ch['step']['runs']} runs",
                )
            )
        if "drift" in ch:
            d = ch["drift"]
            out.append(
                line(
                    "caiviac",
                    "all",
                    f"+1.5 µm/h drift: share of its effect removed after {REMOVED_AFTER} readings "
                    "(median over runs)",
                    d["median_share_removed"],
                    0.8,
                    detail=f"{d['runs']} runs, min {fmt(d['min_share_removed'])}",
                )
            )
    if fl:
        p = fl["pooled"]
        out += [
            line(
                "fleet",
                "all",
                "no readings: pooled coverage over the fleet",
                p["pooled_coverage"],
                0.87,
                0.93,
            ),
            line(
                "fleet",
                "all",
                "no readings: worst machine's pooled coverage",
                p["worst_unit_coverage"],
                0.80,
                detail=p["worst_unit"],
            ),
        ]
    for part in ("caiviac", "fleet"):
        units = (summary.get(part) or {}).get("units", {})
        if units:
            out.append(
                line(
                    part,
                    "all",
                    "streaming without readings against batch predict: largest difference, µm",
                    max(s["stream_vs_batch"] for s in units.values()),
                    high=1e-9,
                )
            )
    if "cost" in summary:
        c = summary["cost"]
        out += [
            line("cost", "ch1_um", "µs per update with the status read", c["update_us"], high=30.0),
            line("cost", "ch1_um", "µs per observe", c["observe_us"], high=1000.0),
        ]
    return out


# Printing --------------------------------------------------------------------


def print_unit(part, unit, s):
    ref = REFERENCES[s["reference"]]
    per_test = " ".join(f"{t}:{c:.3f}" for t, c in s["coverage"].items())
    rmses = " ".join(f"{t}:{fmt(e)}" for t, e in s["rmse"].items())
    print(
        f"{part} {unit} ({ref}; {s['n_tests']} tests): no readings: RMSE µm per test {rmses}; "
        f"coverage per test {per_test}; "
        f"pooled {s['pooled_coverage']:.3f}, worst {s['worst_coverage']:.3f} (test "
        f"{s['worst_test']}); mean width / RMSE {s['width_over_rmse']:.2f}; median RMSE "
        f"{fmt(s['median_rmse'])} µm; stream vs batch {s['stream_vs_batch']:.1e} µm"
    )
    for label in EVERY:
        if label not in s:
            continue
        h = s[label]
        per_test = " ".join(f"{t}:{c:.3f}" for t, c in h["coverage"].items())
        rmses = " ".join(f"{t}:{fmt(e)}" for t, e in h["rmse"].items())
        sds = " ".join(f"{t}:{fmt(v)}" for t, v in h["innovation_sd_per_test"].items())
        sd = "n/a" if h["innovation_sd"] is None else f"{h['innovation_sd']:.2f}"
        print(
            f"  readings every {label}: RMSE µm per test {rmses}; innovation SD per test {sds}; "
            f"median RMSE {fmt(h['median_rmse'])} µm "
            f"({h['below_none']:+.0%} below none; {h['tests_above_none']} tests above none); "
            f"coverage per test {per_test}; pooled {h['pooled_coverage']:.3f}, worst "
            f"{h['worst_coverage']:.3f}; innovation SD {sd}; fired {h['fired']} in "
            f"{h['readings']} readings"
        )


def print_changes(summary):
    print(
        "\nSimulated changes (CAIVIAC, two cycles held out, hourly readings, change after "
        f"reading {', '.join(map(str, ONSETS))}; recording reference):"
    )
    for kind, c in summary.items():
        delay = "n/a" if c["median_delay"] is None else f"{c['median_delay']:g}"
        print(
            f"  {kind}: {c['runs']} runs (RMS of the effect after {REMOVED_AFTER} readings: median "
            f"{fmt(c['median_effect_rms'])} µm); detected within {DETECT_WITHIN} readings "
            f"{c['detected_within']:.0%}, at all {c['detected']:.0%} (median delay {delay} "
            f"readings); share of the effect removed after {REMOVED_AFTER} readings median "
            f"{fmt(c['median_share_removed'])}, min {fmt(c['min_share_removed'])}; the "
            f"detector said {c['kinds_said'] or 'nothing'}; fired before the onset in "
            f"{c['runs_fired_before_onset']} runs"
        )
        print(
            "    per probe: "
            + "; ".join(
                f"{p.removesuffix('_um')} detected within {DETECT_WITHIN} in {b['detected_within']} "
                f"of {b['runs']}, median share removed {fmt(b['median_share_removed'])}"
                for p, b in c["by_probe"].items()
            )
        )


def print_acceptance(lines):
    print("\nAcceptance (issue 39), in the model's reference (CAIVIAC: the recording's zero):")
    for c in lines:
        mark = {True: "PASS", False: "FAIL", None: "n/a"}[c.passed]
        value = "n/a" if c.value is None else f"{c.value:.4g}"
        detail = f"  [{c.detail}]" if c.detail else ""
        print(
            f"  {mark:4s} {c.part:7s} {c.unit:7s} {c.what}: {value} "
            f"(bar {bar_text(c.low, c.high)}){detail}"
        )


# Docs ------------------------------------------------------------------------

BEGIN = ".. trust: generated from benchmarks/results/trust.json by bench_trust.py --write-docs; do not edit by hand"
END = ".. trust: end of generated block"


def _list_table(title, header, body):
    lines = [f".. list-table:: {title}", "   :header-rows: 1", ""]
    for row in [header, *body]:
        lines.append(f"   * - {row[0]}")
        lines += [f"     - {cell}" for cell in row[1:]]
    return [*lines, ""]


def _c(value):
    return "n/a" if value is None else f"{value:.3f}"


def _pct(value):
    return "n/a" if value is None else f"{value:.0%}"


def docs_block(data):
    """The generated rst block of docs/trust.rst from the JSON ``data``."""
    summary, lines_, meta = data["summary"], data["acceptance"], data["meta"]
    lines = [
        BEGIN,
        "",
        f"Measured by ``python benchmarks/bench_trust.py`` on greyml at "
        f"{meta.get('revision') or 'an unknown revision'}, {meta.get('elapsed_s', 0) / 60:.0f} "
        "min wall time on one core of a shared machine; 90 % intervals, every test held out "
        "in turn (its displacement never seen in the fit).",
        "",
    ]
    cai, fl = summary.get("caiviac"), summary.get("fleet")
    if cai:
        units = cai["units"]
        ref = REFERENCES[next(iter(units.values()))["reference"]]
        tests = list(next(iter(units.values()))["coverage"])
        lines += _list_table(
            f"CAIVIAC, no readings: coverage per held-out cycle, {ref}",
            ["probe", *[f"cycle {t}" for t in tests], "pooled", "width / RMSE", "median RMSE µm"],
            [
                [
                    p.removesuffix("_um"),
                    *[_c(s["coverage"].get(t)) for t in tests],
                    _c(s["pooled_coverage"]),
                    fmt(s["width_over_rmse"]),
                    fmt(s["median_rmse"]),
                ]
                for p, s in units.items()
            ],
        )
        if "1h" in next(iter(units.values())):
            body = []
            for p, s in units.items():
                h, f = s["1h"], s["4h"]
                body.append(
                    [
                        p.removesuffix("_um"),
                        f"{fmt(s['median_rmse'])} / {fmt(h['median_rmse'])} / {fmt(f['median_rmse'])}",
                        f"{_c(h['pooled_coverage'])} ({_c(h['worst_coverage'])})",
                        f"{_c(f['pooled_coverage'])} ({_c(f['worst_coverage'])})",
                        fmt(h["innovation_sd"]),
                        f"{h['fired'] + f['fired']} in {h['readings'] + f['readings']}",
                    ]
                )
            lines += _list_table(
                f"CAIVIAC, probe readings every hour and every 4 h, {ref}",
                [
                    "probe",
                    "median RMSE µm: none / hourly / 4-hourly",
                    "coverage hourly: pooled (worst cycle)",
                    "coverage 4-hourly: pooled (worst cycle)",
                    "innovation SD, hourly",
                    "detector fired (in readings)",
                ],
                body,
            )
            lines += [
                "Innovations: " + "; ".join(cai.get("innovation_source", [])) + ".",
                "",
            ]
            lines += _list_table(
                f"CAIVIAC, RMSE µm per held-out cycle without readings / hourly / 4-hourly, {ref}",
                ["probe", *[f"cycle {t}" for t in tests]],
                [
                    [
                        p.removesuffix("_um"),
                        *[
                            f"{fmt(s['rmse'].get(t))} / {fmt(s['1h']['rmse'].get(t))} / "
                            f"{fmt(s['4h']['rmse'].get(t))}"
                            for t in tests
                        ],
                    ]
                    for p, s in units.items()
                ],
            )
    if fl:
        body = []
        for m, s in fl["units"].items():
            per = " ".join(_c(c) for c in s["coverage"].values())
            body.append(
                [
                    m,
                    s["reference"],
                    per,
                    _c(s["pooled_coverage"]),
                    fmt(s["width_over_rmse"]),
                    f"{_c(s['1h']['pooled_coverage'])} / {_c(s['4h']['pooled_coverage'])}"
                    if "1h" in s
                    else "n/a",
                    f"{s['1h']['fired'] + s['4h']['fired']} in "
                    f"{s['1h']['readings'] + s['4h']['readings']}"
                    if "1h" in s
                    else "n/a",
                ]
            )
        lines += _list_table(
            "Simulated fleet, no readings: coverage per held-out test (reference: the model's, "
            "'start' = change from each test's first row, 'recording' = from the recording's zero)",
            [
                "machine",
                "reference",
                "coverage per test",
                "pooled",
                "width / RMSE",
                "coverage with hourly / 4-hourly readings",
                "detector fired (in readings)",
            ],
            body,
        )
        p = fl["pooled"]
        lines += [
            f"Over the fleet: pooled coverage {_c(p['pooled_coverage'])}, worst machine "
            f"{p['worst_unit']} ({_c(p['worst_unit_coverage'])}), worst test "
            f"{_c(p['worst_test_coverage'])}.",
            "",
        ]
    ch = summary.get("changes")
    if ch:
        lines += _list_table(
            "CAIVIAC, simulated changes after 3, 5, 7 or 9 hourly readings (two cycles held out, "
            "recording reference)",
            [
                "change",
                "runs",
                f"RMS of the effect after {REMOVED_AFTER} readings, µm (median)",
                f"detected within {DETECT_WITHIN} readings",
                "detected at all (median delay, readings)",
                f"share of the effect removed after {REMOVED_AFTER} readings: median (min)",
                "what the detector said",
                f"per probe: detected within {DETECT_WITHIN} / runs; median share removed",
            ],
            [
                [
                    {
                        "drift": "+1.5 µm/h drift",
                        "step": "5 µm step",
                        "gain": "20 % gain, one sensor",
                    }[k],
                    str(c["runs"]),
                    fmt(c["median_effect_rms"]),
                    _pct(c["detected_within"]),
                    f"{_pct(c['detected'])} ({fmt(c['median_delay'])})",
                    f"{fmt(c['median_share_removed'])} ({fmt(c['min_share_removed'])})",
                    ", ".join(f"{n} {k_}" for k_, n in c["kinds_said"].items()) or "nothing",
                    "; ".join(
                        f"{p.removesuffix('_um')} {b['detected_within']}/{b['runs']}, "
                        f"{fmt(b['median_share_removed'])}"
                        for p, b in c["by_probe"].items()
                    ),
                ]
                for k, c in ch.items()
            ],
        )
    if "cost" in summary:
        c = summary["cost"]
        lines += [
            f"Cost: ``update`` with the status read {c['update_us']:.1f} µs, ``observe`` "
            f"{c['observe_us']:.0f} µs (best of 3, Python).",
            "",
        ]
    body = []
    for c in lines_:
        unit = "" if c["unit"] == "all" else f" {c['unit'].removesuffix('_um')}"
        detail = f" ({c['detail']})" if c["detail"] else ""
        body.append(
            [
                f"{c['part']}{unit}: {c['what']}{detail}",
                "n/a" if c["value"] is None else f"{c['value']:.4g}",
                bar_text(c["low"], c["high"]),
                {True: "PASS", False: "FAIL", None: "n/a"}[c["passed"]],
            ]
        )
    lines += _list_table(
        "Acceptance lines of issue 39 (displacements in the model's reference: CAIVIAC's is "
        "the recording's zero)",
        ["line", "measured", "bar", "holds"],
        body,
    )
    return [*lines, END]


def replace_block(text, block):
    """``text`` with its generated block replaced by ``block`` (lines); an error when it has none."""
    return replace_generated(text, block, BEGIN, END)


def write_docs(data, path=DOCS):
    text = path.read_text(encoding="utf-8")
    path.write_text(replace_block(text, docs_block(data)), encoding="utf-8")
    print(f"rewrote the generated block of {path}")


# Main ------------------------------------------------------------------------


def run(data_path, probes, machine_names, changes):
    """(results, elapsed s) of one run: CAIVIAC (if found), the fleet and the cost."""
    from _fleet import fleet

    results = {}
    start = time.perf_counter()
    path = find_data(data_path) if probes else None
    if path is not None:
        print(f"CAIVIAC/FL_THERMAL from {path}: probes {', '.join(probes)}, leave one cycle out")
        results["caiviac"] = {}
        results["changes"], results["unchanged_pairs"] = [], []
        for probe in probes:
            X, y = peers.load(path, probe)
            results["caiviac"][probe] = held_out(X, y, (peers.DRIVER,), probe)
            if changes:
                runs, pairs = changed(X, y, (peers.DRIVER,), probe)
                results["changes"] += runs
                results["unchanged_pairs"] += pairs
        X, y = peers.load(path, probes[0])
        results["cost"] = cost(X, y, (peers.DRIVER,))
    if machine_names:
        print(f"simulated fleet: {', '.join(machine_names)}, leave one test out")
        results["fleet"] = {
            m.name: held_out(m.X, m.y, m.drivers, m.name) for m in fleet(machine_names)
        }
    return results, time.perf_counter() - start


def main(argv=None):
    from _fleet import names

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--data", metavar="PATH", help="CAIVIAC cycles.csv or the folder holding it"
    )
    parser.add_argument("--json", metavar="PATH", help="write every number as JSON")
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"a subset: probes {', '.join(QUICK_PROBES)}, machines {', '.join(QUICK_MACHINES)}",
    )
    parser.add_argument(
        "--probes", nargs="*", metavar="PROBE", help=f"CAIVIAC probes (default all of {PROBES})"
    )
    parser.add_argument(
        "--machines", nargs="*", metavar="NAME", help=f"fleet machines (default all: {names()})"
    )
    parser.add_argument("--no-changes", action="store_true", help="skip the simulated changes")
    parser.add_argument(
        "--write-docs", action="store_true", help="rewrite the generated block of docs/trust.rst"
    )
    parser.add_argument(
        "--from-json",
        metavar="PATH",
        help="with --write-docs: take the numbers from this earlier run's JSON, run nothing",
    )
    args = parser.parse_args(argv)
    if check_docs_flags(parser, args, write_docs):
        return 0
    probes, machines = chosen_units(parser, args, PROBES, QUICK_PROBES, names(), QUICK_MACHINES)
    with warnings.catch_warnings():  # the folds' fit warnings are not the subject here
        warnings.simplefilter("ignore")
        results, elapsed = run(args.data, probes, machines, not args.no_changes)
    summary = summarise(results)
    if "cost" in results:
        summary["cost"] = results["cost"]
    print("\nSummary, 90 % intervals, in the model's reference (named on every line)")
    for part in ("caiviac", "fleet"):
        for unit, s in summary.get(part, {}).get("units", {}).items():
            print_unit(part, unit, s)
        if part in summary:
            p = summary[part]["pooled"]
            print(
                f"{part}: pooled coverage {p['pooled_coverage']:.3f}, worst unit {p['worst_unit']} "
                f"({p['worst_unit_coverage']:.3f}), worst test {p['worst_test_coverage']:.3f}"
            )
            fa = summary[part].get("false_alarms")
            if fa:
                print(
                    f"{part}: detector fired {fa['fired']} times in {fa['readings']} readings on "
                    "unchanged held-out tests"
                )
    if "unchanged_pairs" in summary:
        u = summary["unchanged_pairs"]
        print(
            f"caiviac, two cycles held out unchanged (the change runs' baseline): detector fired "
            f"{u['fired']} times in {u['readings']} hourly readings ({u['runs_fired']} of "
            f"{u['runs']} runs)"
        )
    if "changes" in summary:
        print_changes(summary["changes"])
    if "cost" in summary:
        c = summary["cost"]
        print(
            f"\ncost: update with status {c['update_us']:.1f} µs, observe {c['observe_us']:.1f} µs"
        )
    checks = acceptance(summary)
    print_acceptance(checks)
    print(f"\nTotal {elapsed:.0f} s wall; repository {peers.revision() or 'unknown'}")
    if args.json:
        write_json(
            args.json,
            {"results": results, "summary": summary, "acceptance": [asdict(c) for c in checks]},
            packages=("greyml", "numpy", "scipy", "scikit-learn"),
            argv=argv,
            probes=list(probes),
            machines=list(machines),
            quick=args.quick,
            elapsed_s=elapsed,
            revision=peers.revision(),
        )
        if args.write_docs:
            write_docs(json.loads(Path(args.json).read_text(encoding="utf-8")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
