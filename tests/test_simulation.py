"""Physics of the thermal network and the seeds' magnitudes (issue 3)."""

import numpy as np
import pytest

from greyml.datasets import load_gantry_tests, load_probe_test, load_vmc_tests
from greyml.simulation import (
    Effects,
    HeatSource,
    Programme,
    TemperatureSensor,
    ThermalMachine,
    diurnal,
    door_openings,
    gantry,
    linear_drift,
    simulate_test,
    vmc,
)
from greyml.simulation._ambient import constant
from greyml.simulation._catalogue import gantry_tests
from greyml.simulation._network import (
    add_lag_states,
    conductance_matrix,
    network_matrices,
    propagate,
    steady_state,
    zoh_discretize,
)

BARE = Effects.none()


def _probe_machine(capacity, links, convection, power_share, power_W=100.0):
    """A small machine whose sensors read each node directly, without noise."""
    nodes = tuple(f"n{k}" for k in range(len(capacity)))
    return ThermalMachine(
        name="probe-net",
        nodes=nodes,
        capacity=tuple(capacity),
        links=tuple((nodes[i], nodes[j], g) for i, j, g in links),
        convection=dict(zip(nodes, convection)),
        sources=(
            HeatSource("heater", "spindle_rpm", dict(zip(nodes, power_share)), power_W, 1000.0),
        ),
        temperature_sensors=tuple(
            TemperatureSensor(f"T{k + 1}_C", "node", {n: 1.0}, noise_C=0.0)
            for k, n in enumerate(nodes)
        ),
        displacement={"dz_um": {nodes[0]: 1.0}},
        inputs=("spindle_rpm",),
        sample_s=60.0,
    )


# ------------------------------------------------------------------ kernels
def test_conductance_matrix_is_laplacian_plus_convection():
    K = conductance_matrix(3, [(0, 1, 2.0), (1, 2, 3.0)], [1.0, 0.0, 0.5])
    expected = np.array([[3.0, -2.0, 0.0], [-2.0, 5.0, -3.0], [0.0, -3.0, 3.5]])
    np.testing.assert_array_equal(K, expected)


def test_steady_state_two_nodes_by_hand():
    # 1 W into node 0; node 0 -(1 W/K)- node 1 -(1 W/K)- air at 20 °C
    np.testing.assert_allclose(steady_state([(0, 1, 1.0)], [0.0, 1.0], [1.0, 0.0], 20.0), [22, 21])


def test_long_run_reaches_analytic_steady_state():
    rng = np.random.default_rng(3)
    n = 6
    capacity = rng.uniform(500, 5000, n)
    links = [(i, i + 1, rng.uniform(0.5, 5)) for i in range(n - 1)] + [(0, 3, 1.0)]
    convection = rng.uniform(0.1, 2.0, n)
    power = rng.uniform(0, 50, n)
    A, B = network_matrices(capacity, links, convection)
    Phi, Gamma = zoh_discretize(A, B, 5.0e4)
    u = np.append(power, 21.0)
    X = propagate(
        Phi[None], Gamma[None], np.zeros(400, int), np.full(n, 21.0), np.tile(u, (400, 1))
    )
    expected = steady_state(links, convection, power, 21.0)
    assert np.max(np.abs(X[-1] - expected)) < 1e-6


def test_simulated_machine_reaches_steady_state():
    m = _probe_machine(
        [2000.0, 5000.0, 8000.0], [(0, 1, 3.0), (1, 2, 2.0)], [0.5, 1.0, 2.0], [0.7, 0.3, 0.0]
    )
    p = Programme().run(hours=2000, spindle_rpm=1000)
    df = simulate_test(m, p, 18.0, BARE, sample_s=36000.0)
    expected = steady_state(m.link_array(), m.convection_vector(), [70.0, 30.0, 0.0], 18.0)
    last = df[["T1_C", "T2_C", "T3_C"]].iloc[-1].to_numpy()
    assert np.max(np.abs(last - expected)) < 1e-6


def test_no_power_constant_ambient_nothing_moves():
    for machine in (vmc(), vmc("probe"), gantry()):
        p = Programme().dwell(hours=10)
        df = simulate_test(machine, p, 21.3, Effects().without("noise", "probe_drift"))
        change = (df - df.iloc[0]).abs().to_numpy().max()
        assert change < 1e-9


def test_doubling_heat_doubles_every_rise():
    p = Programme().run(60, spindle_rpm=3000, feed_mm_min=4000).dwell(60)
    eff = Effects().without("noise", "probe_drift")
    for machine in (vmc(), vmc("probe")):
        a = simulate_test(machine, p, 20.0, eff)
        b = simulate_test(machine.scaled(2.0), p, 20.0, eff)
        cols = machine.sensor_names + machine.target_names
        rise_a = (a[cols] - a[cols].iloc[0]).to_numpy()
        rise_b = (b[cols] - b[cols].iloc[0]).to_numpy()
        np.testing.assert_allclose(rise_b, 2 * rise_a, rtol=1e-9, atol=1e-9)
    g = gantry()
    q = Programme().cycle(10, 10, 60, feed_mm_min=70000, c_rpm=2500).dwell(60)
    a = simulate_test(g, q, 20.0, eff)
    b = simulate_test(g.scaled(2.0), q, 20.0, eff)
    cols = g.sensor_names + g.target_names
    np.testing.assert_allclose(
        (b[cols] - b[cols].iloc[0]).to_numpy(),
        2 * (a[cols] - a[cols].iloc[0]).to_numpy(),
        rtol=1e-9,
        atol=1e-9,
    )


def fitted_time_constant(t, rise, final):
    """Least-squares slope of log(1 - rise/final) against t."""
    keep = rise < 0.99 * final
    y = np.log1p(-rise[keep] / final)
    slope = np.polyfit(t[keep], y, 1)[0]
    return -1.0 / slope


def test_single_node_time_constant():
    C, G, P = 12000.0, 4.0, 40.0
    m = _probe_machine([C], [], [G], [1.0], power_W=P)
    df = simulate_test(m, Programme().run(hours=20, spindle_rpm=1000), 20.0, BARE, sample_s=30)
    t = df.index.get_level_values("time_s").to_numpy()
    tau = fitted_time_constant(t, df["T1_C"].to_numpy() - 20.0, P / G)
    assert abs(tau / (C / G) - 1) < 1e-3


def test_lag_state_is_first_order():
    # sensor state of a node held at 1: s(t) = 1 - exp(-t/tau)
    A, B = add_lag_states(np.zeros((1, 1)), np.zeros((1, 2)), np.ones((1, 1)), np.zeros(1), [50.0])
    Phi, Gamma = zoh_discretize(A, B, 50.0)
    X = propagate(Phi[None], Gamma[None], np.zeros(1, int), np.array([1.0, 0.0]), np.zeros((1, 2)))
    assert X[1, 1] == pytest.approx(1 - np.exp(-1), rel=1e-12)


def test_step_lengths_share_one_exponential_and_agree():
    m = vmc()
    p = Programme().run(seconds=95, spindle_rpm=5000).dwell(seconds=205)
    coarse = simulate_test(m, p, 20.0, BARE, sample_s=60)
    fine = simulate_test(m, p, 20.0, BARE, sample_s=5)
    common = coarse.index.get_level_values("time_s")
    sel = fine.loc[fine.index.get_level_values("time_s").isin(common)]
    cols = m.sensor_names + m.target_names
    np.testing.assert_allclose(sel[cols].to_numpy(), coarse[cols].to_numpy(), atol=1e-9)


# ------------------------------------------------------------ programmes etc.
def test_programme_builder():
    p = Programme().run(120, spindle_rpm=4000).dwell(60).run(120, spindle_rpm=4000).dwell(180)
    assert p.duration_s == 8 * 3600
    np.testing.assert_array_equal(
        p.at("spindle_rpm", [0, 7199, 7200, 10800, 30000]), [4000, 4000, 0, 4000, 0]
    )
    c = Programme().cycle(10, 10, seconds=45, c_rpm=2500)
    assert [s.duration_s for s in c.segments] == [10, 10, 10, 10, 5]
    np.testing.assert_allclose(c.mean_over("c_rpm", [0.0, 20.0], 20.0), [1250.0, 1250.0])


@pytest.mark.parametrize(
    "build, match",
    [
        (lambda: Programme().run(-1, spindle_rpm=100), "positive"),
        (lambda: Programme().run(10, seconds=5), "exactly one"),
        (lambda: Programme().run(10, spindle_rpm=-5), "'spindle_rpm'"),
        (lambda: Programme().cycle(0, 10, 5), "'on_s'"),
    ],
)
def test_programme_errors(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_simulate_rejects_inputs_the_machine_lacks():
    with pytest.raises(ValueError, match="'c_rpm' in segment 0"):
        simulate_test(vmc(), Programme().run(10, c_rpm=100), 20.0)
    with pytest.raises(ValueError, match="above the maximum 8000"):
        simulate_test(vmc(), Programme().dwell(5).run(10, spindle_rpm=9000), 20.0)
    with pytest.raises(ValueError, match="empty"):
        simulate_test(vmc(), Programme(), 20.0)
    with pytest.raises(ValueError, match="ambient"):
        simulate_test(vmc(), Programme().dwell(5), "warm")


def test_ambient_profiles():
    assert constant(19.0)(100.0) == 19.0
    assert linear_drift(20.0, 0.6)(1800.0) == pytest.approx(20.3)
    d = diurnal(20.0, 2.0, peak_hour=15.0, start_hour=3.0)
    assert d(0.0) == pytest.approx(18.0) and d(12 * 3600.0) == pytest.approx(22.0)
    door = door_openings(linear_drift(20.0, 0.0), [100.0, 500.0], drop_C=1.5, duration_s=50.0)
    np.testing.assert_allclose(door([99.0, 100.0, 149.0, 150.0, 520.0]), [20, 18.5, 18.5, 20, 18.5])
    np.testing.assert_array_equal(door.breakpoints(), [100.0, 150.0, 500.0, 550.0])


def test_same_seed_same_data_bit_for_bit():
    p = Programme().run(30, spindle_rpm=5000).dwell(30)
    a = simulate_test(vmc(), p, 20.0, random_state=7)
    b = simulate_test(vmc(), p, 20.0, random_state=7)
    c = simulate_test(vmc(), p, 20.0, random_state=8)
    assert a.equals(b) and not a.equals(c)


# --------------------------------------------------------- seed magnitudes
def peak(frame, column):
    return float(frame[column].abs().max())


def within(value, reference, tolerance=0.3):
    return abs(value / reference - 1) <= tolerance


@pytest.fixture(scope="module")
def vmc_data():
    return load_vmc_tests()


@pytest.fixture(scope="module")
def gantry_data():
    return load_gantry_tests()


def test_vmc_8000rpm_one_hour_magnitudes(vmc_data):
    vi = vmc_data.frame.xs("VI", level="test")
    assert within(peak(vi, "dx_um"), 3.0)
    assert within(peak(vi, "dy_um"), 79.0)
    assert within(peak(vi, "dz_um"), 22.0)


def test_probe_test_magnitudes():
    df = load_probe_test().frame
    assert within(peak(df, "dx_um"), 20.0)
    assert within(peak(df, "dy_um"), 18.0)
    assert within(peak(df, "dz_um"), 58.0)


def test_gantry_magnitudes(gantry_data):
    f = gantry_data.frame
    z, c, h = (f.xs(k, level="test") for k in ("Z-axis", "C-axis", "helical"))
    assert 100 < peak(z, "dz_um") < 160
    assert 80 < peak(c, "dz_um") < 120
    assert within(peak(h, "dz_um"), 95.0)
    rise = c.max() - c.iloc[0]
    assert within(rise["T1_C"], 7.0)
    assert rise["T2_C"] < 4.0
    assert within(rise["T3_C"], 1.0) and within(rise["T4_C"], 1.0)
    assert rise["T1_C"] > rise["T2_C"] > max(rise["T3_C"], rise["T4_C"])


def test_higher_speed_larger_error(vmc_data):
    f = vmc_data.frame
    assert peak(f.xs("VI", level="test"), "dy_um") > 2 * peak(f.xs("I", level="test"), "dy_um")
    p = {s: Programme().run(60, spindle_rpm=s).dwell(60) for s in (2000, 4000, 6000, 8000)}
    peaks = [peak(simulate_test(vmc(), q, 20.0, BARE), "dy_um") for q in p.values()]
    assert np.all(np.diff(peaks) > 0)


def test_same_programme_other_ambient_other_error(vmc_data):
    f = vmc_data.frame
    ii, iii = f.xs("II", level="test"), f.xs("III", level="test")
    assert abs(peak(ii, "dy_um") - peak(iii, "dy_um")) > 5
    v, vi = f.xs("V", level="test"), f.xs("VI", level="test")
    assert abs(peak(v, "dy_um") - peak(vi, "dy_um")) > 5
    p = Programme().run(60, spindle_rpm=6000).dwell(120)
    eff = Effects().without("noise", "probe_drift")
    still = simulate_test(gantry(), Programme().dwell(180), 20.0, eff)
    warm = simulate_test(gantry(), Programme().dwell(180), linear_drift(20.0, 1.0), eff)
    assert peak(still, "dz_um") < 1e-9 and peak(warm, "dz_um") > 2.0
    a = simulate_test(vmc(), p, 20.0, eff)
    b = simulate_test(vmc(), p, linear_drift(20.0, -1.0), eff)
    assert np.max(np.abs(a["dz_um"] - b["dz_um"])) > 1.0


def test_surface_sensors_lag_the_displacement():
    """Abdulshahed et al. (2016) Sec. 3.1: T2 (ram rear) follows the displacement ~10 min late."""
    g = gantry()
    eff = Effects().without("noise", "probe_drift")
    for spec in gantry_tests()[1:]:  # C-axis and helical
        df = simulate_test(g, spec.programme, 20.0, eff)
        t = df.index.get_level_values("time_s").to_numpy()
        lag = t[np.argmax(df["T2_C"].to_numpy())] - t[np.argmax(-df["dz_um"].to_numpy())]
        assert 5 * 60 <= lag <= 20 * 60
        # without the sensor delay the lag shrinks
        quick = simulate_test(g, spec.programme, 20.0, eff.without("sensor_lag"))
        lag_quick = (
            t[np.argmax(quick["T2_C"].to_numpy())] - t[np.argmax(-quick["dz_um"].to_numpy())]
        )
        assert lag_quick < lag
