"""The ``greyml`` command line: ``greyml gap`` on small synthetic CSV files."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from greyml import make_test_index
from greyml.cli import main
from greyml.exceptions import GapWarning
from greyml.io import write_tests_csv

CAUSE_FIELDS = {"effect", "detail", "rmse_before", "rmse_after", "shrinkage", "significant"}
ROLES = ["--ambient", "ambient_C", "--drivers", "spindle_rpm", "--sensors", "T1_C,T2_C"]


def _strict_json(text):
    """Parse JSON, refusing the non-standard constants NaN, Infinity and -Infinity."""

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def _tests(drift_um_per_h, *, n_tests=4, n=150, seed=0):
    """Measured and simulated tests: real = sim + drift·hours + white noise (0.01 µm)."""
    rng = np.random.default_rng(seed)
    real, sim = [], []
    for k in range(n_tests):
        t = 60.0 * np.arange(n)
        hours = t / 3600.0
        rpm = np.where((t // 1800) % 2 == k % 2, 3000.0 + 1000.0 * k, 0.0)
        ambient = 20.0 + 0.5 * np.sin(2 * np.pi * hours / 6 + k)
        heat = np.zeros(n)
        for i in range(1, n):
            heat[i] = heat[i - 1] + (rpm[i] / 4000.0 - heat[i - 1]) * 0.05
        simulated = 10.0 * heat + 2.0 * np.sin(hours)
        measured = simulated + drift_um_per_h * hours + 0.01 * rng.standard_normal(n)
        index = make_test_index([f"T{k}"] * n, t)
        real.append(
            pd.DataFrame(
                {
                    "spindle_rpm": rpm,
                    "ambient_C": ambient,
                    "T1_C": ambient + 5.0 * heat,
                    "T2_C": ambient + 3.0 * heat + 0.1 * rng.standard_normal(n),
                    "dz_um": measured,
                },
                index=index,
            )
        )
        sim.append(pd.DataFrame({"dz_um": simulated}, index=index))
    return pd.concat(real), pd.concat(sim)


def _write_case(directory, drift_um_per_h):
    real, sim = _tests(drift_um_per_h)
    real_path = write_tests_csv(real, directory / "real.csv")
    sim_path = write_tests_csv(sim, directory / "sim.csv")
    return str(real_path), str(sim_path)


@pytest.fixture(scope="module")
def drift_case(tmp_path_factory):
    """CSV paths of a case whose gap is a drift of 0.02 µm/h."""
    return _write_case(tmp_path_factory.mktemp("drift"), 0.02)


@pytest.fixture(scope="module")
def null_case(tmp_path_factory):
    """CSV paths of a case whose gap is white noise only."""
    return _write_case(tmp_path_factory.mktemp("null"), 0.0)


def _gap(paths, *extra):
    return ["gap", *paths, "--target", "dz_um", *ROLES, "--random-state", "0", *extra]


def test_json_to_stdout_is_strict_and_names_drift(drift_case, capsys):
    code = main(_gap(drift_case, "--json", "-"))
    out, err = capsys.readouterr()
    assert code == 0, err
    data = _strict_json(out)  # stdout holds the JSON and nothing else
    assert {"cause", "causes", "where"} <= set(data)
    assert data["cause"] == "drift"
    assert data["causes"], "no effect rows"
    for row in data["causes"]:
        assert CAUSE_FIELDS <= set(row)
    assert data["causes"][0]["effect"] == "drift"
    assert data["causes"][0]["significant"] is True
    assert data["where"] and {"by", "segment", "rms"} <= set(data["where"][0])
    # effects that could not be tried (no FBG here) have no numbers: null, not NaN
    untried = [row for row in data["causes"] if row["detail"].startswith("not tried")]
    assert untried and all(row["shrinkage"] is None for row in untried)


def test_json_file_and_human_report(drift_case, tmp_path, capsys):
    target = tmp_path / "report.json"
    code = main(_gap(drift_case, "--json", str(target)))
    out, err = capsys.readouterr()
    assert code == 0, err
    data = _strict_json(target.read_text(encoding="utf-8"))
    assert data["cause"] == "drift"
    # the verdict comes first (issue 17), then the report as before
    assert out.startswith("Verdict: explained. drift brings the gap from RMSE")
    assert "(all rows) to" in out.splitlines()[0] and "held out" in out.splitlines()[0]
    assert out.splitlines()[1].startswith("Compared: the gap = measured − simulated dz_um")
    assert "Gap of dz_um over all rows (nothing fitted):" in out
    assert "1. drift" in out
    with pytest.raises(json.JSONDecodeError):
        json.loads(out)


def test_human_report_without_json(drift_case, tmp_path, capsys):
    assert main(_gap(drift_case)) == 0
    out, _ = capsys.readouterr()
    assert out.startswith("Verdict: explained.") and "Gap of dz_um over all rows" in out
    assert "drift" in out
    assert list(tmp_path.iterdir()) == []


def test_null_case_has_no_cause(null_case, capsys):
    code = main(_gap(null_case, "--json", "-"))
    out, err = capsys.readouterr()
    assert code == 0, err
    data = _strict_json(out)
    assert data["cause"] is None
    assert not any(row["significant"] for row in data["causes"])
    assert data["verdict"] == "within_noise" and data["events"] == []
    assert main(_gap(null_case)) == 0
    out = capsys.readouterr().out
    assert out.startswith("Verdict: within noise.")
    assert "No effect tried is supported by the held-out tests." in out
    # what was not tried is said, with the columns it would need
    assert data["not_tried"] == {"fbg_temperature": "needs an FBG target (the target among fbgs=)"}
    # in the command's words: the flag, not the Python keyword
    assert "Not tried: fbg_temperature (needs an FBG target (the target among --fbgs))." in out
    assert "fbgs=" not in out


def _error(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    assert err.startswith("greyml gap: error:")
    assert "Traceback" not in err
    return err


def test_missing_target_column(drift_case, capsys):
    err = _error(capsys, ["gap", *drift_case, "--target", "dx_um", "--json", "-"])
    assert "'dx_um'" in err


def test_missing_driver_column(drift_case, capsys):
    err = _error(capsys, ["gap", *drift_case, "--target", "dz_um", "--drivers", "feed_mm_min"])
    assert "'feed_mm_min'" in err


@pytest.mark.parametrize("which", [0, 1])
def test_missing_file(drift_case, tmp_path, capsys, which):
    missing = str(tmp_path / "no_such.csv")
    paths = list(drift_case)
    paths[which] = missing
    err = _error(capsys, ["gap", *paths, "--target", "dz_um", "--json", "-"])
    assert missing in err


def test_unwritable_json_file(drift_case, tmp_path, capsys):
    target = tmp_path / "no_such_dir" / "report.json"
    err = _error(capsys, _gap(drift_case, "--json", str(target)))
    assert str(target) in err


def test_unknown_effect(drift_case, capsys):
    err = _error(capsys, _gap(drift_case, "--effects", "drift, warp_drive"))
    assert "warp_drive" in err


def test_empty_effects(drift_case, capsys):
    err = _error(capsys, _gap(drift_case, "--effects", " , "))
    assert "--effects" in err


def test_usage_errors_exit_2(drift_case, capsys):
    assert main(["gap", *drift_case]) == 2  # --target missing
    assert "--target" in capsys.readouterr().err
    assert main([]) == 2
    assert main(["gap", *drift_case, "--target", "dz_um", "--random-state", "x"]) == 2


def test_comma_lists_strip_spaces_and_empty_items(drift_case, capsys):
    argv = [
        "gap",
        *drift_case,
        "--target",
        " dz_um ",
        "--ambient",
        "ambient_C",
        "--drivers",
        " spindle_rpm , ,",
        "--sensors",
        "T1_C, T2_C,",
        "--effects",
        "drift , ambient,",
        "--random-state",
        "0",
        "--json",
        "-",
    ]
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 0, err
    data = _strict_json(out)
    assert data["cause"] == "drift"
    assert {row["effect"] for row in data["causes"]} == {"drift", "ambient"}
    assert {row["signal"] for row in data["cross_correlation"]} == {
        "spindle_rpm",
        "ambient_C",
        "T1_C",
        "T2_C",
    }


def test_repeated_list_flags_add_up(drift_case, capsys):
    argv = ["gap", *drift_case, "--target", "dz_um", "--random-state", "0", "--json", "-"]
    argv += ["--sensors", "T1_C", "--sensors", "T2_C,T1_C", "--effects", "drift"]
    argv += ["--effects", "ambient", "--effects", "drift"]
    code = main(argv)
    out, err = capsys.readouterr()
    assert code == 0, err
    data = _strict_json(out)
    # each effect once; ambient is listed as not tried, as no ambient column is given
    assert [row["effect"] for row in data["causes"]] == ["drift", "ambient"]
    assert data["causes"][1]["detail"].startswith("not tried")
    signals = [row["signal"] for row in data["cross_correlation"]]
    assert signals == ["T1_C", "T2_C"]


def test_version(capsys):
    import greyml

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"greyml {greyml.__version__}"


def test_help_documents_exit_codes(capsys):
    assert main(["gap", "--help"]) == 0
    out = capsys.readouterr().out
    assert "Exit codes" in out and "--json FILE|-" in out


def test_python_m_greyml(drift_case):
    argv = ["gap", *drift_case, "--target", "dz_um", "--random-state", "0", "--json", "-"]
    proc = subprocess.run([sys.executable, "-m", "greyml", *argv], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert "cause" in _strict_json(proc.stdout)
    script = shutil.which("greyml")
    if script is not None:  # the console script, when it is installed on PATH
        proc = subprocess.run([script, "--version"], capture_output=True, text=True)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.startswith("greyml ")


def test_sensitivities_recalibrate_a_simulation_off_by_five_percent(tmp_path, capsys):
    from gap_harness import withheld_case

    case = withheld_case(("drift",), 10, 3, param_error=0.05)
    real = write_tests_csv(case.real, tmp_path / "real.csv")
    sim = write_tests_csv(case.sim, tmp_path / "sim.csv")
    sens = write_tests_csv(case.sensitivities, tmp_path / "sens.csv")
    roles = case.roles
    argv = [
        "gap",
        str(real),
        str(sim),
        "--target",
        roles["target"],
        "--ambient",
        roles["ambient"],
        "--drivers",
        ",".join(roles["drivers"]),
        "--sensors",
        ",".join(roles["sensors"]),
        "--random-state",
        "0",
        "--sensitivities",
        str(sens),
        "--tolerance",
        "0.1",
        "--json",
        "-",
    ]
    assert main(argv) == 0
    data = _strict_json(capsys.readouterr().out)
    assert data["cause"] == "drift" and data["named"] == ["drift"]
    assert data["recalibration"].startswith("parameters refitted within ±10%: capacity")


def test_custom_effect_from_the_command_line(tmp_path, capsys):
    # the gap follows a logged pump column through a 30-min lag; the pump is
    # not a driver, only a custom effect
    real, sim = _tests(0.0)
    rows = []
    for _, frame in real.groupby(level="test", sort=False):
        t = frame.index.get_level_values("time_s").to_numpy()
        pump = ((t // 2400) % 2 == 1).astype(float)
        lag = np.zeros(len(t))
        for i in range(1, len(t)):
            lag[i] = lag[i - 1] + (pump[i] - lag[i - 1]) * (1 - np.exp(-60 / 1800))
        rows.append(frame.assign(pump_on=pump, dz_um=frame["dz_um"] + 0.2 * lag))
    real = pd.concat(rows)
    paths = [
        str(write_tests_csv(real, tmp_path / "real.csv")),
        str(write_tests_csv(sim, tmp_path / "sim.csv")),
    ]
    # the faster of the two lags ends at the shortest searched: said in a one-line
    # warning on standard error, as every command says its warnings
    assert main(_gap(paths, "--custom", "hydraulics=pump_on", "--json", "-")) == 0
    out, err = capsys.readouterr()
    assert err.startswith(
        f"greyml gap: warning: {GapWarning.__name__}: diagnose_gap: the time constant of "
        "'hydraulics' ended at the shortest time constant"
    )
    assert err.count("\n") == 1
    data = _strict_json(out)
    assert data["named"] == ["hydraulics"] and data["verdict"] == "explained"
    assert data["unexplained_rms"] == pytest.approx(0.01, rel=0.3)
    assert data["events"] == [] and data["n_placebo"] >= 39
    top = data["causes"][0]
    assert top["effect"] == "hydraulics" and top["p_value"] == pytest.approx(1 / 40)
    low, high = top["shrinkage_ci"]
    assert low <= top["shrinkage"] <= high and low > 0.8
    assert "the shortest time constant searched (120 s = 2 min)" in top["detail"]
    assert main(_gap(paths, "--custom", "hydraulics")) == 2
    assert "expected NAME=COL[,COL]" in capsys.readouterr().err
