"""Compensator.export and ``greyml export`` (issue 29): JSON, names, files and the command.

The JSON holds the numbers the compensator runs and the state layout the C
struct and the function block declare (one description); a hostile name in a
model file reaches the code only as a harmless identifier; the file is
written whole or not at all; the command exports a saved transfer function's
compensator with the limits given, and refuses what it cannot export in one
line.
"""

import json
import math
import re
import subprocess

import numpy as np
import pytest
from _export_cases import C_FLAGS, compiler, fitted, recording

from greyml import GMC, Compensator
from greyml.cli import main
from greyml.controller import Uncertainty
from greyml.controller._export._program import SCHEMA, SCHEMA_VERSION, describe
from greyml.controller._export._write import export_text
from greyml.persist import load_model, save_model

HOSTILE = [
    'x); system("rm -rf /"); //',
    "*/ #include <stdlib.h> /*",
    "(* END_FUNCTION_BLOCK *) T",
    "t1\nEND_VAR",
    "température_C",
    "T1_C",
    "t1_c",  # the same identifier ignoring case, as Structured Text reads it
    "",
    "END_IF",
]


def _hostile():
    inputs = HOSTILE
    terms = [(name, 1, 600.0 * (k + 1), 0.1 * (k + 1)) for k, name in enumerate(inputs)]
    return Compensator(inputs, terms, uncertainty=Uncertainty(1.0, 0.1, 0.1, 1.0, 2.0))


def _strip_comments(text, language):
    pattern = r"/\*.*?\*/" if language == "c" else r"\(\*.*?\*\)"
    return re.sub(pattern, "", text, flags=re.S)


# -- JSON: the one description -----------------------------------------------


def test_the_json_holds_the_terms_limits_and_state_layout_of_c_and_st():
    comp = Compensator.from_model(fitted(), tolerance_um=4.0).set_params(
        rate_limit_um_s=0.5, quantum_um=0.1
    )
    text = export_text(comp, "json", name="ch1")
    data = json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in strict JSON"))
    assert data["schema"] == SCHEMA and data["schema_version"] == SCHEMA_VERSION == 1
    assert [v["name"] for v in data["inputs"]] == list(comp.inputs)
    # the terms as the compensator runs them (shared lags merged, lags first)
    plan = comp.update_plan()
    np.testing.assert_array_equal([t["weight"] for t in data["terms"]], plan.weight)
    np.testing.assert_array_equal([t["tau_s"] for t in data["terms"][: plan.tau.size]], plan.tau)
    assert all(t["tau_s"] is None for t in data["terms"][plan.tau.size :])

    def key(name, power, tau):
        return name, power, -1.0 if tau is None else tau

    assert sorted(key(*t[:3]) for t in comp.terms) == sorted(
        key(data["inputs"][t["input"]]["name"], t["power"], t["tau_s"]) for t in data["terms"]
    )
    assert data["limits"]["rate_limit_um_s"] == 0.5 and data["limits"]["quantum_um"] == 0.1
    assert data["limits"]["on_missing"] == "hold" and data["limits"]["clamp_um"] is None
    assert data["probe_filter"]["offset_var"] == comp.uncertainty.offset_var
    # the probe filter's calibration, and the change detector's threshold as a number:
    # the χ²₁ quantile of 1e-3 / (2·12), 16.79392 (scipy.stats.chi2.isf(1e-3 / 24, 1))
    u, trust = comp.uncertainty, data["probe_filter"]
    for field in ("bias_var_per_h", "rate_var_per_h3", "scale", "memory_h", "noise_var"):
        assert trust[field] == getattr(u, field), field
    assert trust["false_alarm_rate"] == 1e-3 and trust["window"] == 12
    assert trust["glr_threshold"] == pytest.approx(16.79392, abs=1e-5)
    assert trust["white_var"] == u.scale * u.noise_var
    assert trust["reading_var"] == u.scale * u.noise_var + comp.probe_noise_um**2
    assert trust["change_kinds"] == {"none": 0, "step": 1, "ramp": 2}
    assert data["intercept"] == comp.intercept and data["tolerance_um"] == 4.0
    assert data["units"]["output"] == "um" and data["units"]["time"] == "s"
    # the state layout is what the C struct and the function block declare
    c_source = export_text(comp, "c", name="ch1")
    struct = re.search(r"typedef struct \{(.*?)\} ch1_state;", c_source, flags=re.S).group(1)
    members = re.findall(r"^\s+\w+ (\w+)(?:\[(\d+)\])?;", struct, flags=re.M)
    # then the update's work space (issue 41: in the caller's struct, not on the stack)
    work = [(m, int(n or 1)) for m, n in members if m.startswith("work_")]
    assert work[0] == ("work_lag", plan.weight.size)
    assert {m for m, _ in work[1:]} <= {"work_elag", "work_xt", "work_ef", "work_ex", "work_din"}
    assert [(m, int(n or 1)) for m, n in members if not m.startswith("work_")] == [
        (v["name"], v["length"]) for v in data["state"]
    ]
    st_source = export_text(comp, "st", name="ch1")
    assert re.findall(r"^\s+st_(\w+) : ", st_source, flags=re.M) == [
        v["name"] for v in data["state"]
    ]


def test_each_export_names_the_model_inputs_units_reference_and_version():
    import greyml

    comp = Compensator.from_model(fitted()).set_params(rate_limit_um_s=0.5)
    for language in ("c", "st"):
        text = export_text(comp, language, name="ch1", description="ch1 of the CAIVIAC")
        head = text[: text.index("*/" if language == "c" else "*)")]
        for words in (
            f"greyml {greyml.__version__}",
            "Model: ch1 of the CAIVIAC",
            *comp.inputs,
            "um (micrometres)",
            "Reference: the model's own zero",
            "Time: time_s in seconds",
            "rate limit 0.5 um/s",
            "Not safety-certified",
        ):
            assert words in head, (language, words)


# -- hostile names -------------------------------------------------------------


def test_a_hostile_sensor_name_exports_as_a_harmless_identifier(tmp_path):
    comp = _hostile()
    program = describe(comp, name="hostile")
    identifiers = [v.identifier for v in program.inputs]
    for ident in identifiers:
        assert re.fullmatch(r"x_[A-Za-z0-9]+(_[A-Za-z0-9]+)*", ident), ident
        assert len(ident) <= 31
    assert len({i.lower() for i in identifiers}) == len(identifiers)  # unique ignoring case
    assert identifiers[0] == "x_x_system_rm_rf"
    for language in ("c", "st"):
        text = export_text(comp, language, name="hostile")
        code = _strip_comments(text, language)
        for word in ("system(", "rm -rf", "#include <stdlib", "température", "\nEND_VAR\nt"):
            assert word not in code, (language, word)
        opener, closer = ("/*", "*/") if language == "c" else ("(*", "*)")
        assert text.count(opener) == text.count(closer)  # no comment ends early
        assert text.isascii()
    c_text = export_text(comp, "c", name="hostile")
    assert '"' not in c_text and "\\" not in c_text  # no string in the C at all
    data = json.loads(export_text(comp, "json", name="hostile"))
    assert [v["name"] for v in data["inputs"]] == HOSTILE  # JSON keeps them, escaped
    if compiler() is not None:
        (tmp_path / "hostile.c").write_text(c_text)
        subprocess.run(
            [compiler(), *C_FLAGS, "-c", "hostile.c"], cwd=tmp_path, check=True, capture_output=True
        )


@pytest.mark.parametrize(
    "name", ['x); system("ls"); //', "1abc", "a__b", "end_if", "Int", "x" * 32, "", "ab_"]
)
def test_a_name_that_is_not_a_safe_identifier_is_refused_in_one_line(name, tmp_path):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)])
    with pytest.raises(ValueError, match="is not a C and Structured Text identifier") as info:
        comp.export("c", tmp_path / "x.c", name=name)
    assert "\n" not in str(info.value) and "system(" not in str(info.value)
    assert list(tmp_path.iterdir()) == []


def test_a_hostile_model_file_exports_harmless_code_from_the_command_line(tmp_path, capsys):
    path = save_model(_hostile(), tmp_path / "hostile.greyml")
    out = tmp_path / "hostile.c"
    assert main(["export", str(path), "--language", "c", "--out", str(out)]) == 0
    assert "system(" not in _strip_comments(out.read_text(), "c")
    assert "system(" not in capsys.readouterr().out


# -- files and refusals -------------------------------------------------------------


def test_the_file_is_written_whole_and_never_over_another_without_overwrite(tmp_path):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)])
    path = comp.export("json", tmp_path / "a.json")
    before = path.read_text()
    with pytest.raises(FileExistsError, match="pass overwrite=True"):
        comp.set_params(quantum_um=0.1).export("json", path)
    assert path.read_text() == before
    comp.export("json", path, overwrite=True)
    assert json.loads(path.read_text())["limits"]["quantum_um"] == 0.1
    with pytest.raises(ValueError, match="is a folder"):
        comp.export("c", tmp_path)
    with pytest.raises(ValueError, match="'python' is not one of 'c', 'st', 'json'"):
        comp.export("python", tmp_path / "a.py")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]  # no temporary left


@pytest.mark.parametrize(
    "params, words",
    [
        ({"false_alarm_rate": math.inf}, "'false_alarm_rate' parameter of Compensator"),
        ({"rate_limit_um_s": math.inf}, "'rate_limit_um_s' parameter of Compensator"),
        ({"intercept": math.nan}, "'intercept' parameter of Compensator"),
    ],
)
def test_an_infinite_number_is_refused_in_one_line(params, words, tmp_path):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)], **params)
    with pytest.raises(ValueError, match=re.escape(words)) as info:
        comp.export("c", tmp_path / "x.c")
    assert "\n" not in str(info.value)


def test_no_bound_on_the_correction_exports_as_no_bound(tmp_path):
    comp = Compensator(["T1_C"], [("T1_C", 1, 600.0, 1.0)], max_correction_um=math.inf)
    import json

    spec = json.loads(comp.export("json", tmp_path / "x.json").read_text(encoding="utf-8"))
    assert "max_correction_um" in json.dumps(spec)  # a JSON without inf: it would not parse
    text = comp.export("c", tmp_path / "x.c").read_text(encoding="utf-8")
    assert "fabs(s->correction_um) <= HUGE_VAL" in text  # C99's infinity: every value plausible


# -- the command line ---------------------------------------------------------------


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    return save_model(fitted(), tmp_path_factory.mktemp("export") / "ch1.greyml")


def test_greyml_export_writes_a_transfer_functions_compensator(model_file, tmp_path, capsys):
    out = tmp_path / "ch1.json"
    argv = ["export", str(model_file), "--language", "json", "--out", str(out)]
    limits = ["--rate-limit", "0.5", "--quantum", "0.1", "--clamp", "100", "--name", "ch1"]
    assert main([*argv, *limits, "--tolerance", "4"]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {str(out)!r} (json" in printed and "rate limit 0.5 µm/s" in printed
    assert "trusted while the half-width is at most 4 µm" in printed  # issue 41
    data = json.loads(out.read_text())
    assert data["tolerance_um"] == 4.0
    comp = Compensator.from_model(load_model(model_file))
    assert data["name"] == "ch1" and [v["name"] for v in data["inputs"]] == comp.inputs
    assert data["limits"] == {**data["limits"], "rate_limit_um_s": 0.5, "clamp_um": 100.0}
    assert data["probe_filter"] is not None  # the calibration came with it
    assert data["model"].startswith("ThermalTransferFunction from ch1.greyml")
    # the same text as the Python export of the same compensator
    comp.set_params(rate_limit_um_s=0.5, quantum_um=0.1, clamp_um=100.0, tolerance_um=4.0)
    assert out.read_text() == export_text(comp, "json", name="ch1", description=data["model"])
    c_file = tmp_path / "ch1.c"
    assert main(["export", str(model_file), "--language", "c", "--out", str(c_file), *limits]) == 0
    assert "trusted whenever plausible (no --tolerance)" in capsys.readouterr().out
    assert "(void)half, 1" in c_file.read_text()  # without a tolerance: plausible is trusted


def _error(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert code == 2 and "Traceback" not in err, (out, err)
    assert err.startswith("greyml export: error: ") and err.count("\n") == 1, err
    return err


def test_greyml_export_refuses_in_one_line(model_file, tmp_path, capsys):
    out = tmp_path / "x.st"
    base = ["export", model_file, "--language", "st", "--out", out]
    out.write_text("mine")
    assert "exists; pass --force" in _error(capsys, base)
    assert out.read_text() == "mine"
    out.unlink()
    assert "whole number of quanta" in _error(capsys, [*base, "--quantum", "0.3", "--clamp", "1"])
    assert "not a C and Structured Text identifier" in _error(capsys, [*base, "--name", "a b"])
    not_a_model = tmp_path / "m.greyml"
    not_a_model.write_text("hello")
    assert "m.greyml" in _error(capsys, ["export", not_a_model, "--language", "c", "--out", out])
    assert "does not exist" in _error(
        capsys, ["export", tmp_path / "none.greyml", "--language", "c", "--out", out]
    )
    gmc = tmp_path / "gmc.greyml"
    frame = _frame()
    save_model(GMC().fit(frame.iloc[:200, :3], frame.iloc[:200, 3]), gmc)
    assert "holds a GMC; greyml export takes a Compensator" in _error(
        capsys, ["export", gmc, "--language", "c", "--out", out]
    )
    assert not out.exists()


def _frame():
    X, y, _ = recording()
    frame = X.iloc[:, :3].copy()
    frame["y"] = y
    return frame


def test_an_infinite_bound_is_written_as_no_bound(tmp_path):
    # max_correction_um, tolerance_um and the change detector's threshold as bounds that
    # nothing passes
    # (the Compensator's constraints refuse them today; an export must not write 'inf')
    import dataclasses

    from greyml.controller._export._write import LANGUAGES

    comp = Compensator(
        ["T1_C"], [("T1_C", 1, 600.0, 1.0)], uncertainty=Uncertainty(1.0, 0.1, 0.1, 1.0, 2.0)
    )
    program = describe(comp, name="unbounded")
    program = dataclasses.replace(
        program,
        max_correction_um=math.inf,
        tolerance_um=math.inf,
        trust=dataclasses.replace(program.trust, glr_threshold=math.inf),
    )
    data = json.loads(LANGUAGES["json"](program))
    assert data["max_correction_um"] is None and data["tolerance_um"] is None
    assert data["probe_filter"]["glr_threshold"] is None
    assert "GLR_THRESHOLD : LREAL := 1.7976931348623157E308" in LANGUAGES["st"](program)
    assert "if (stat > HUGE_VAL)" in LANGUAGES["c"](program)
    st_text = LANGUAGES["st"](program)
    assert "inf" not in _strip_comments(st_text, "st").lower().replace("initial", "")
    assert "ABS(ProbeUm) > 1.7976931348623157E308" in st_text
    c_text = LANGUAGES["c"](program)
    assert "fabs(measured_um) > HUGE_VAL" in c_text
    if compiler() is None:
        return
    (tmp_path / "unbounded.c").write_text(c_text)
    subprocess.run(
        [compiler(), *C_FLAGS, "-c", "unbounded.c"], cwd=tmp_path, check=True, capture_output=True
    )
