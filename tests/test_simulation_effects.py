"""Each switchable effect changes what it should and nothing else (issue 3).

Every test runs the same programme twice with the same seed, the effect on and
off, and checks which columns changed. Noise stays on (except in the noise
test) to show that the noise streams do not shift when an effect is removed.
"""

import numpy as np
import pytest

from greyml.simulation import Effects, Programme, gantry, linear_drift, simulate_test, vmc
from greyml.simulation._machine import FBG_TEMPERATURE_SENSITIVITY_UE_PER_C


def changed(a, b):
    """Columns whose values differ at all."""
    return {c for c in a.columns if not np.array_equal(a[c].to_numpy(), b[c].to_numpy())}


def run(machine, programme, ambient, effects, **kw):
    return simulate_test(machine, programme, ambient, effects, random_state=11, **kw)


@pytest.fixture(scope="module")
def gantry_programme():
    return Programme().cycle(10, 10, 60, feed_mm_min=70000, c_rpm=2500).dwell(60)


def test_effect_names():
    assert Effects.names() == (
        "ambient_coupling",
        "sensor_lag",
        "initial_disequilibrium",
        "fbg_cross_sensitivity",
        "probe_drift",
        "extra_heat_source",
        "noise",
    )
    with pytest.raises(ValueError, match="Unknown effect"):
        Effects().without("sunshine")


def test_ambient_coupling(gantry_programme):
    g = gantry()
    air = linear_drift(18.0, 1.0)
    on = run(g, gantry_programme, air, Effects())
    off = run(g, gantry_programme, air, Effects().without("ambient_coupling"))
    diff = changed(on, off)
    # inputs and the air itself unchanged; the structure, its sensors, the
    # strain and the displacement change
    assert not diff & {"feed_mm_min", "c_rpm", "ambient_C"}
    assert {"T1_C", "T3_C", "FBG4_ue", "dz_um"} <= diff
    # ambient sensors read the same air, plus a little of the structure
    assert np.max(np.abs(on["T8_C"] - off["T8_C"])) < 0.2 * np.max(np.abs(on["T3_C"] - off["T3_C"]))
    # in constant air the coupling has nothing to carry
    assert not changed(
        run(g, gantry_programme, 18.0, Effects()),
        run(g, gantry_programme, 18.0, Effects().without("ambient_coupling")),
    )


def test_sensor_lag(gantry_programme):
    g = gantry()
    on = run(g, gantry_programme, linear_drift(18.0, 0.5), Effects())
    off = run(g, gantry_programme, linear_drift(18.0, 0.5), Effects().without("sensor_lag"))
    lagged = {s.name for s in g.temperature_sensors if s.lag_s > 0}
    assert changed(on, off) == lagged
    # the delayed reading trails the direct one while heating
    assert (on["T1_C"].iloc[30] - off["T1_C"].iloc[30]) < -0.2


def test_initial_disequilibrium():
    m = vmc()
    p = Programme().run(30, spindle_rpm=4000).dwell(30)
    before = Programme().run(60, spindle_rpm=8000).dwell(20)
    on = run(m, p, 20.0, Effects(), history=before)
    off = run(m, p, 20.0, Effects().without("initial_disequilibrium"), history=before)
    diff = changed(on, off)
    assert not diff & {"spindle_rpm", "feed_mm_min", "ambient_C"}
    assert {"T11_C", "T63_C", "dy_um", "dz_um"} <= diff
    # the warm machine starts hotter than the air
    assert on["T63_C"].iloc[0] > off["T63_C"].iloc[0] + 3
    # and the effect off equals no history at all
    assert not changed(off, run(m, p, 20.0, Effects()))


def test_fbg_cross_sensitivity(gantry_programme):
    g = gantry()
    on = run(g, gantry_programme, 18.0, Effects().without("noise"))
    off = run(g, gantry_programme, 18.0, Effects().without("noise", "fbg_cross_sensitivity"))
    assert changed(on, off) == set(g.fbg_names)
    # FBG4 sits on the beam front: mechanical 10.5 µε/K, grating 8.64 µε/K
    added = (on["FBG4_ue"] - off["FBG4_ue"]).to_numpy()[1:]
    mech = off["FBG4_ue"].to_numpy()[1:]
    np.testing.assert_allclose(added, mech * FBG_TEMPERATURE_SENSITIVITY_UE_PER_C / 10.5, rtol=1e-9)


def test_probe_drift():
    m = vmc()
    p = Programme().run(60, spindle_rpm=6000).dwell(60)
    on = run(m, p, 20.0, Effects())
    off = run(m, p, 20.0, Effects().without("probe_drift"))
    assert changed(on, off) == set(m.target_names)
    hours = on.index.get_level_values("time_s").to_numpy() / 3600
    for t in m.target_names:
        np.testing.assert_allclose(
            (on[t] - off[t]).to_numpy(), m.probe_drift_um_per_h[t] * hours, atol=1e-9
        )


def test_extra_heat_source():
    m = vmc("probe")
    p = Programme().run(60, spindle_rpm=6000, feed_mm_min=5000).dwell(60)
    on = run(m, p, 20.0, Effects())
    off = run(m, p, 20.0, Effects().without("extra_heat_source"))
    diff = changed(on, off)
    assert not diff & {"spindle_rpm", "feed_mm_min", "ambient_C"}
    # ballscrew sensors T6-T8 warm by kelvins, the X error grows
    for screw in ("T6_C", "T7_C", "T8_C"):
        assert on[screw].max() - off[screw].max() > 2.0
    assert on["dx_um"].abs().max() > off["dx_um"].abs().max() + 5
    # no feed, no ballscrew heat: nothing changes
    spindle_only = Programme().run(60, spindle_rpm=6000).dwell(60)
    assert not changed(
        run(m, spindle_only, 20.0, Effects()),
        run(m, spindle_only, 20.0, Effects().without("extra_heat_source")),
    )


def test_noise(gantry_programme):
    g = gantry()
    on = run(g, gantry_programme, 18.0, Effects())
    off = run(g, gantry_programme, 18.0, Effects().without("noise"))
    measured = set(g.sensor_names + g.target_names)
    assert changed(on, off) == measured
    for s in g.temperature_sensors:
        assert np.std(on[s.name] - off[s.name]) == pytest.approx(s.noise_C, rel=0.15)
    assert np.std(on["dz_um"] - off["dz_um"]) == pytest.approx(g.probe_noise_um["dz_um"], rel=0.15)
