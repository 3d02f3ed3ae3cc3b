"""Embedded data sets and the CAIVIAC loader (issue 3)."""

import numpy as np
import pandas as pd
import pytest
from conftest import caiviac_csv_or_skip

from greyml._sequences import segments_by_test
from greyml.controller import Compensator
from greyml.datasets import (
    load_caiviac,
    load_gantry_tests,
    load_probe_test,
    load_vmc_tests,
    make_tests,
)
from greyml.simulation import Effects, HeatingTest, Programme, linear_drift, vmc

LOADERS = [load_vmc_tests, load_probe_test, load_gantry_tests]


@pytest.mark.parametrize("loader", LOADERS)
def test_loader_layout_and_determinism(loader):
    data = loader()
    frame = data.frame
    assert frame.index.names == ["test", "time_s"]
    segments = segments_by_test(frame)
    assert [s.label for s in segments] == data.tests
    for seg in segments:
        assert frame.index.get_level_values("time_s")[seg.start] == 0.0
    assert set(data.sensor_groups) == set(data.sensors)
    assert all(c.endswith(("_C", "_ue")) for c in data.sensors)
    assert set(data.targets) <= {"dx_um", "dy_um", "dz_um"}
    assert "ambient_C" in data.inputs
    assert list(frame.columns) == data.inputs + data.sensors + data.targets
    assert np.isfinite(frame.to_numpy()).all()
    assert loader().frame.equals(frame)
    X, y = loader(return_X_y=True)
    assert list(X.columns) == data.sensors and y.name in data.targets


def test_vmc_sensor_layout_matches_seed_001():
    data = load_vmc_tests()
    assert len(data.sensors) == 76
    groups = data.sensor_groups
    assert groups["T18_C"] == "spindle carrier strip 1"
    assert groups["T55_C"] == "spindle carrier strip 2"
    assert groups["T63_C"] == "spindle boss"
    assert groups["T68_C"] == "ambient near the column"
    assert groups["T71_C"] == "ambient near the base"
    assert sum("ambient" in g for g in groups.values()) >= 4
    assert data.tests == ["I", "II", "III", "IV", "V", "VI"]
    iv = data.frame.xs("IV", level="test")
    assert iv.index[-1] == 8 * 3600
    rpm = iv["spindle_rpm"].to_numpy()
    assert rpm[:120].min() == 4000 and rpm[121:180].max() == 0 and rpm[181:300].min() == 4000


def test_gantry_and_probe_sensor_counts():
    g = load_gantry_tests()
    assert sum(c.startswith("T") for c in g.sensors) == 12
    assert sum(c.startswith("FBG") for c in g.sensors) == 7
    assert sum(v == "ambient" for v in g.sensor_groups.values()) == 6
    p = load_probe_test()
    assert len(p.sensors) == 9 and p.frame.index[1][1] == 10.0


def test_effects_reach_the_loaders():
    plain = load_probe_test(effects=Effects().without("noise"))
    noisy = load_probe_test()
    assert not plain.frame.equals(noisy.frame)
    assert "noise" in plain.description


def test_make_tests_inputs():
    p = Programme(name="warm-up").run(30, spindle_rpm=5000).dwell(30)
    by_dict = make_tests(
        "vmc", {"a": p, "b": p}, {"a": 20.0, "b": linear_drift(20, 2)}, random_state=1
    )
    assert by_dict.tests == ["a", "b"]
    assert not by_dict.frame.xs("a", level="test").equals(by_dict.frame.xs("b", level="test"))
    by_list = make_tests("vmc", [p], random_state=1)
    assert by_list.tests == ["warm-up"]
    spec = HeatingTest("x", p, 19.0, history=Programme().run(20, spindle_rpm=8000))
    assert make_tests(vmc(), spec, random_state=0).tests == ["x"]
    # same random_state, same data
    assert make_tests("gantry", random_state=3).frame.equals(
        make_tests("gantry", random_state=3).frame
    )


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"machine": "lathe"}, "machine must be"),
        ({"programmes": []}, "empty"),
        ({"programmes": [42]}, "expected a Programme"),
        ({"programmes": {"a": Programme().dwell(5)}, "ambient": "cold"}, "ambient"),
        ({"programmes": [Programme(name="p").dwell(5)] * 2}, "unique"),
        ({"return_X_y": True, "target": "dw_um"}, "target must be"),
    ],
)
def test_make_tests_errors(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_tests(**kwargs)


# ------------------------------------------------------------------ CAIVIAC
def _caiviac_or_skip():
    return load_caiviac(caiviac_csv_or_skip())


def test_caiviac_layout():
    data = _caiviac_or_skip()
    frame = data.frame
    assert data.tests == [str(k) for k in range(1, 6)]
    assert frame.shape == (9631, 22)
    assert len(data.sensors) == 16 and data.targets == [f"ch{k}_um" for k in range(1, 6)]
    # one clock: each cycle starts 15 s after the last row of the one before
    segments = segments_by_test(frame)
    times = frame.index.get_level_values("time_s").to_numpy()
    assert times[0] == 0.0
    for before, seg in zip(segments, segments[1:]):
        assert times[seg.start] - times[before.stop - 1] == 15.0
    speeds = frame.groupby(level="test", sort=False)["spindle_rpm"].max().tolist()
    assert speeds == [1250, 2500, 3750, 5000, 3500]
    assert "MIT" in data.license
    # the file's own column names, so rows read from the file reach a model fitted here
    assert data.sensors == [f"t{k}_C" for k in range(1, 17)]


def test_caiviac_one_loader():
    """load_caiviac and read_tests_csv give the same frame from the same file, so the same
    model: the same labels, clock, reference, columns and dtypes."""
    from greyml.io import read_tests_csv

    path = caiviac_csv_or_skip()
    read = read_tests_csv(path, test_column="cycle")
    pd.testing.assert_frame_equal(load_caiviac(path).frame, read)
    raw = pd.read_csv(path)  # as recorded, from the recording's zero
    np.testing.assert_array_equal(read["ch3_um"].to_numpy(), raw["ch3_um"].to_numpy())
    np.testing.assert_array_equal(read["t5_C"].to_numpy(), raw["t5_C"].to_numpy())


def test_caiviac_model_takes_rows_read_from_the_file():
    from greyml import ThermalTransferFunction
    from greyml.io import read_tests_csv

    data = _caiviac_or_skip()
    frame = data.frame.loc[["1", "2"]]
    model = ThermalTransferFunction(drivers=["spindle_rpm"], max_sensors=2, time_constants=[900.0])
    model.fit(frame[["spindle_rpm", *data.sensors]], frame["ch1_um"])
    comp = Compensator.from_model(model, nominal_step_s=15.0)
    raw = read_tests_csv(caiviac_csv_or_skip(), test_column="cycle")
    row = raw.iloc[0][["spindle_rpm", *data.sensors]].to_dict()
    correction = comp.update({"time_s": raw.index[0][1], **row})
    assert np.isfinite(correction)


def test_caiviac_reference_cycle():
    path = caiviac_csv_or_skip()
    rec, cyc = load_caiviac(path).frame, load_caiviac(path, reference="cycle").frame
    probes = [f"ch{k}_um" for k in range(1, 6)]
    for seg in segments_by_test(cyc):
        part = cyc.iloc[seg.slice]
        np.testing.assert_array_equal(part[probes].iloc[0].to_numpy(), 0.0)
        shift = rec.iloc[seg.start][probes].to_numpy()
        np.testing.assert_allclose(part[probes], rec.iloc[seg.slice][probes] - shift, atol=0)
    pd.testing.assert_frame_equal(cyc.drop(columns=probes), rec.drop(columns=probes))


def test_caiviac_one_loader_on_a_small_file(tmp_path):
    from test_bad_input_io import _caiviac_file

    from greyml.io import read_tests_csv

    path = _caiviac_file(tmp_path)
    data = load_caiviac(path)
    pd.testing.assert_frame_equal(data.frame, read_tests_csv(path, test_column="cycle"))
    assert data.tests == ["1", "2"]
    assert data.frame.index.get_level_values("time_s").tolist() == [0, 15, 30, 45, 60, 75]


def test_caiviac_missing_gives_clear_error(tmp_path, monkeypatch):
    with pytest.raises(FileNotFoundError, match="No CAIVIAC recording"):
        load_caiviac(tmp_path)
    # without a path and with nothing in fetch_caiviac's cache, the message names
    # the cache and both ways to give the data; no folder beside the checkout is read
    monkeypatch.setenv("SCIKIT_LEARN_DATA", str(tmp_path / "home"))
    monkeypatch.setenv("GREYML_CAIVIAC", str(tmp_path))
    with pytest.raises(
        FileNotFoundError,
        match=r"not in fetch_caiviac's cache .*home.greyml.caiviac.cycles\.csv.*path=.*fetch_caiviac\(\)",
    ):
        load_caiviac()
    assert not (tmp_path / "home").exists()  # looking creates nothing


def test_caiviac_wrong_file(tmp_path):
    bad = tmp_path / "cycles.csv"
    bad.write_text("time_s,cycle,spindle_rpm\n0,1,0\n")
    with pytest.raises(ValueError, match="lacks the column"):
        load_caiviac(tmp_path)


def test_caiviac_without_a_path_reads_fetch_caiviacs_cache(tmp_path, monkeypatch):
    from test_bad_input_io import _caiviac_file

    cache = tmp_path / "home" / "greyml" / "caiviac"
    cache.mkdir(parents=True)
    given = load_caiviac(_caiviac_file(cache))
    monkeypatch.setenv("SCIKIT_LEARN_DATA", str(tmp_path / "home"))
    cached = load_caiviac()
    pd.testing.assert_frame_equal(cached.frame, given.frame)
    assert cached.tests == ["1", "2"]
