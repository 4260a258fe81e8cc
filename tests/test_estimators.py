"""The 0-1 estimators of posture, flow, energy and altitude, and their shared ramp and lag."""

import numpy as np
import pytest
from pydrake.math import RollPitchYaw
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from manta_drake.control.altimeter_estimator import (
    AltimeterEstimator,
    AltimeterEstimatorParams,
    floor_membership,
)
from manta_drake.control.energy_estimator import (
    EnergyEstimator,
    EnergyEstimatorParams,
    energy_membership,
)
from manta_drake.control.flow_estimator import (
    FlowEstimator,
    FlowEstimatorParams,
    flow_speed,
)
from manta_drake.control.memberships import (
    lag_coefficient,
    low_pass_step,
    ramp_membership,
)
from manta_drake.control.posture import (
    PostureEstimator,
    PostureEstimatorParams,
    posture_membership,
    tilt_angle,
)

T = 0.02  # the estimators' update period in these tests
T_STEP = 0.51  # the inputs step here, between the updates at 0.50 and 0.52


# --- the shared maths --------------------------------------------------------------------------


def test_ramp_membership_at_and_between_the_thresholds():
    x = [-1.0, 0.1, 0.15, 0.2, 0.25, 0.3, 0.5]
    np.testing.assert_allclose(
        ramp_membership(x, 0.1, 0.3), [0, 0, 0.25, 0.5, 0.75, 1, 1], atol=1e-15
    )
    assert ramp_membership(0.1, 0.1, 0.3) == 0.0 and ramp_membership(0.3, 0.1, 0.3) == 1.0
    assert np.isnan(ramp_membership(np.nan, 0.1, 0.3))
    for low, high in ((0.3, 0.3), (0.3, 0.1), (np.nan, 1.0)):
        with pytest.raises(ValueError, match="ramp_membership: low = .* must be below high"):
            ramp_membership(0.2, low, high)


def test_lag_matches_the_continuous_step_response_at_the_samples():
    """From y = a, a step to b: j updates later y = b + (a - b) exp(-j T / tau), the exact
    solution of tau dy/dt = b - y at the sample times."""
    tau, a, b = 0.3, 0.2, 1.4
    alpha = lag_coefficient(T, tau)
    assert alpha == pytest.approx(1.0 - np.exp(-T / tau), rel=1e-15)
    assert lag_coefficient(T, 0.0) == 1.0  # no filter
    y, seeded = np.array([a]), np.array([True])
    for j in range(1, 40):
        y, seeded = low_pass_step(y, seeded, [b], alpha)
        assert y[0] == pytest.approx(b + (a - b) * np.exp(-j * T / tau), rel=1e-12)


def test_lag_starts_at_the_first_finite_sample_and_holds_through_nan():
    alpha = lag_coefficient(T, 1.0)
    y, seeded = low_pass_step([0.0, 0.0], [False, False], [np.nan, 2.0], alpha)
    np.testing.assert_array_equal(y, [0.0, 2.0])  # the finite channel starts at its sample
    np.testing.assert_array_equal(seeded, [False, True])
    y, seeded = low_pass_step(y, seeded, [3.0, np.inf], alpha)
    np.testing.assert_array_equal(y, [3.0, 2.0])  # seeded now; the infinite one is held
    y2, _ = low_pass_step(y, seeded, [5.0, 4.0], alpha)
    np.testing.assert_allclose(y2, [3.0 + 2.0 * alpha, 2.0 + 2.0 * alpha], rtol=1e-14)


def test_angles_are_filtered_the_short_way_round_the_circle():
    """From 179 deg toward -179 deg is 2 deg counter-clockwise, not 358 deg back."""
    alpha = 0.25
    y, _ = low_pass_step([np.radians(179.0)], [True], [np.radians(-179.0)], alpha, True)
    assert np.degrees(y[0]) == pytest.approx(179.5, abs=1e-9)
    for _ in range(60):
        y, _ = low_pass_step(y, [True], [np.radians(-179.0)], alpha, True)
    assert np.degrees(y[0]) == pytest.approx(-179.0, abs=1e-6)
    assert -np.pi < y[0] <= np.pi
    # The same step on a linear channel goes the long way.
    z, _ = low_pass_step([np.radians(179.0)], [True], [np.radians(-179.0)], alpha, False)
    assert np.degrees(z[0]) == pytest.approx(179.0 - 0.25 * 358.0)


# --- posture -----------------------------------------------------------------------------------


def test_tilt_angle_is_the_angle_between_body_z_and_the_vertical(rng):
    """Against Drake's roll-pitch-yaw rotation: the angle between R e_z and e_z."""
    rpy = rng.uniform([-np.pi, -np.pi / 2, -np.pi], [np.pi, np.pi / 2, np.pi], (200, 3))
    z_body = np.array([RollPitchYaw(r).ToRotationMatrix().matrix()[:, 2] for r in rpy])
    expected = np.arccos(np.clip(z_body[:, 2], -1.0, 1.0))
    np.testing.assert_allclose(tilt_angle(rpy[:, 0], rpy[:, 1]), expected, atol=1e-7)
    assert tilt_angle(np.radians(-25.0), 0.0) == pytest.approx(np.radians(25.0))
    assert tilt_angle(np.radians(45.0), np.radians(45.0)) == pytest.approx(np.radians(60.0))


def test_posture_membership_at_and_between_the_thresholds():
    p = PostureEstimatorParams()  # 10 and 30 deg
    roll = np.radians([0.0, 10.0, 15.0, 20.0, -30.0, 90.0])
    np.testing.assert_allclose(
        posture_membership(roll, 0.0, p), [0, 0, 0.25, 0.5, 1, 1], atol=1e-12
    )
    # A 60 deg tilt from 45 deg of roll and of pitch; yaw never enters.
    assert posture_membership(np.radians(45.0), np.radians(45.0), p) == 1.0
    assert posture_membership(np.radians(8.0), np.radians(8.0), p) == pytest.approx(
        (np.degrees(np.arccos(np.cos(np.radians(8.0)) ** 2)) - 10.0) / 20.0
    )


def _imu(roll=0.0, pitch=0.0, yaw=0.0, wz=0.0):
    return np.array([roll, pitch, yaw, 0.01, -0.02, wz, 0.0, 0.0, 9.81])


def _simulate_step(system, port, before, after, times):
    """Simulates ``system`` with its ``port`` input stepping from ``before`` to ``after`` at
    T_STEP (zero-order hold); returns {output name: values at ``times``}."""
    builder = DiagramBuilder()
    builder.AddSystem(system)
    before, after = np.asarray(before, float), np.asarray(after, float)
    trajectory = PiecewisePolynomial.ZeroOrderHold(
        [0.0, T_STEP, 100.0], np.column_stack([before, after, after])
    )
    source = builder.AddSystem(TrajectorySource(trajectory))
    builder.Connect(source.get_output_port(), system.GetInputPort(port))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = system.GetMyContextFromRoot(simulator.get_context())
    out = {system.get_output_port(i).get_name(): [] for i in range(system.num_output_ports())}
    for t in times:
        simulator.AdvanceTo(t)
        for name, values in out.items():
            values.append(system.GetOutputPort(name).Eval(context).copy())
    return {name: np.array(values) for name, values in out.items()}


# Evaluated half-way between updates: k updates after the step's at 0.52 have happened.
_K = np.arange(0, 40, 3)
_TIMES = np.concatenate([[0.005, 0.25], 0.52 + (_K + 0.5) * T])
_J = np.concatenate([[0, 0], _K + 1])  # updates that saw the stepped input


def _lagged(a, b, tau):
    """Closed form at _TIMES: the value a until the step, then b + (a - b) exp(-j T / tau)."""
    return b + (a - b) * np.exp(-_J * T / tau)


def _continuous(a, b, tau):
    """The continuous lag's value at _TIMES (the step at T_STEP)."""
    elapsed = np.maximum(_TIMES - T_STEP, 0.0)
    return b + (a - b) * np.exp(-elapsed / tau)


def test_posture_estimator_follows_a_step_with_the_first_order_lag():
    """roll 5 -> 40 deg, yaw 170 -> -170 deg (across +-pi), wz 0.1 -> -0.3 rad/s, with a
    constant pitch of 3 deg: each is the closed-form lag of its step, the yaw on the circle,
    and posture_hat is the ramp of the filtered tilt."""
    tau = 0.2
    system = PostureEstimator(PostureEstimatorParams(time_constant=tau), period=T)
    r0, r1, p, y0, y1 = np.radians([5.0, 40.0, 3.0, 170.0, -170.0])
    out = _simulate_step(system, "imu", _imu(r0, p, y0, 0.1), _imu(r1, p, y1, -0.3), _TIMES)
    roll = _lagged(r0, r1, tau)
    np.testing.assert_allclose(out["attitude_hat"][:, 0], roll, rtol=1e-12)
    np.testing.assert_allclose(out["attitude_hat"][:, 1], p, rtol=1e-12)
    # 170 deg turning 20 deg counter-clockwise to -170 deg, wrapped to (-180, 180].
    yaw = np.radians(170.0 + 20.0 * (1.0 - np.exp(-_J * T / tau)))
    np.testing.assert_allclose(out["attitude_hat"][:, 2], np.angle(np.exp(1j * yaw)), atol=1e-12)
    np.testing.assert_allclose(out["yaw_rate_hat"][:, 0], _lagged(0.1, -0.3, tau), rtol=1e-12)
    tilt_deg = np.degrees(np.arccos(np.cos(roll) * np.cos(p)))
    np.testing.assert_allclose(
        out["posture_hat"][:, 0], np.clip((tilt_deg - 10) / 20, 0, 1), atol=1e-12
    )
    assert out["posture_hat"][0, 0] == 0.0 and out["posture_hat"][-1, 0] == pytest.approx(1.0)
    # Within one period's discretisation of the continuous lag.
    bound = (r1 - r0) * (1.0 - np.exp(-T / tau))
    assert np.all(np.abs(roll - _continuous(r0, r1, tau)) <= bound + 1e-12)


def test_posture_estimator_starts_at_the_first_reading():
    """A constant IMU: the estimate is the reading from the first instant (the
    initialization event, so another system's update at t = 0 reads it), not a lag from
    zero, and stays there."""
    builder = DiagramBuilder()
    system = builder.AddSystem(PostureEstimator(period=T))
    reading = _imu(np.radians(20.0), np.radians(-4.0), np.radians(-120.0), 0.25)
    source = builder.AddSystem(ConstantVectorSource(reading))
    builder.Connect(source.get_output_port(), system.get_input_port())
    simulator = Simulator(builder.Build())
    context = system.GetMyContextFromRoot(simulator.get_context())
    np.testing.assert_array_equal(system.GetOutputPort("attitude_hat").Eval(context), 0.0)
    simulator.Initialize()  # the initialization event only, before the update at t = 0
    assert simulator.get_num_discrete_updates() == 1
    np.testing.assert_allclose(
        system.GetOutputPort("attitude_hat").Eval(context), reading[:3], rtol=1e-12
    )
    for t in (0.0, 0.3, 1.0):
        simulator.AdvanceTo(t)
        np.testing.assert_allclose(
            system.GetOutputPort("attitude_hat").Eval(context), reading[:3], rtol=1e-12
        )
        assert system.GetOutputPort("yaw_rate_hat").Eval(context)[0] == pytest.approx(0.25)
        assert system.GetOutputPort("posture_hat").Eval(context)[0] == pytest.approx(
            (np.degrees(np.arccos(np.cos(np.radians(20.0)) * np.cos(np.radians(4.0)))) - 10) / 20
        )


def _update(system, context, port, value):
    system.GetInputPort(port).FixValue(context, np.asarray(value, dtype=float))
    context.SetDiscreteState(
        system.EvalUniquePeriodicDiscreteUpdate(context).get_vector().CopyToVector()
    )


def test_posture_estimator_holds_channels_through_dropout():
    system = PostureEstimator(PostureEstimatorParams(time_constant=0.1), period=T)
    context = system.CreateDefaultContext()
    alpha = 1.0 - np.exp(-T / 0.1)
    _update(system, context, "imu", _imu(0.1, 0.2, 0.3, 0.4))
    _update(system, context, "imu", [np.nan, 0.3, np.nan, 0, 0, np.nan, np.nan, 0, 0])
    np.testing.assert_allclose(
        system.GetOutputPort("attitude_hat").Eval(context),
        [0.1, 0.2 + 0.1 * alpha, 0.3],
        rtol=1e-12,
    )
    assert system.GetOutputPort("yaw_rate_hat").Eval(context)[0] == 0.4
    held = context.get_discrete_state_vector().CopyToVector()
    _update(system, context, "imu", np.full(9, np.nan))
    np.testing.assert_array_equal(context.get_discrete_state_vector().CopyToVector(), held)
    assert system.HasDirectFeedthrough(0, 0) is False


# --- flow --------------------------------------------------------------------------------------


def test_flow_speed_along_each_axis():
    v = np.array([[-0.06, -0.08, 0.0], [0.03, 0.04, 0.12]])
    np.testing.assert_allclose(flow_speed(v, "magnitude"), [0.1, 0.13])
    np.testing.assert_allclose(flow_speed(v, "surge"), [0.06, -0.03])  # from ahead: positive
    np.testing.assert_allclose(flow_speed(v, "sway"), [0.08, 0.04])
    with pytest.raises(ValueError, match="axis: 'heave' is not one of magnitude, surge, sway"):
        flow_speed(v, "heave")


@pytest.mark.parametrize("axis", ["magnitude", "surge", "sway"])
def test_flow_estimator_follows_a_step_with_the_first_order_lag(axis):
    """The velocity steps from a to b; the filtered vector is a + (b - a)(1 - exp(-j T / tau))
    and the speed and flow_hat are its speed along the axis and that speed's ramp."""
    tau = 0.25
    params = FlowEstimatorParams(time_constant=tau, axis=axis)
    a, b = np.array([-0.01, 0.015, 0.0]), np.array([-0.09, -0.09, 0.02])
    out = _simulate_step(FlowEstimator(params, period=T), "flow_velocity", a, b, _TIMES)
    v = b + np.outer(np.exp(-_J * T / tau), a - b)
    speed = {"magnitude": np.linalg.norm(v, axis=1), "surge": -v[:, 0], "sway": np.abs(v[:, 1])}[
        axis
    ]
    np.testing.assert_allclose(out["flow_speed_hat"][:, 0], speed, rtol=1e-12)
    np.testing.assert_allclose(
        out["flow_hat"][:, 0], np.clip((speed - 0.03) / 0.05, 0, 1), atol=1e-12
    )
    assert out["flow_hat"][0, 0] == 0.0 and out["flow_hat"][-1, 0] > 0.75


def test_flow_estimator_filters_the_vector_not_the_noisy_speed(rng):
    """Still water read with 3 cm/s of noise per axis: the mean norm of a noisy reading is
    sqrt(8 / pi) 0.03 = 4.8 cm/s, above speed_low, but the filtered vector's speed stays near
    0 and flow_hat at 0. A NaN reading holds the estimate."""
    system = FlowEstimator(period=T)  # tau = 1 s
    context = system.CreateDefaultContext()
    noise = rng.normal(0.0, 0.03, (500, 3))
    assert np.linalg.norm(noise, axis=1).mean() > 0.045
    for reading in noise:
        _update(system, context, "flow_velocity", reading)
    assert system.GetOutputPort("flow_speed_hat").Eval(context)[0] < 0.015
    assert system.GetOutputPort("flow_hat").Eval(context)[0] == 0.0
    held = context.get_discrete_state_vector().CopyToVector()
    _update(system, context, "flow_velocity", [np.nan, np.nan, np.inf])
    np.testing.assert_array_equal(context.get_discrete_state_vector().CopyToVector(), held)


# --- energy ------------------------------------------------------------------------------------


def test_energy_membership_at_and_between_the_thresholds():
    soc = [0.0, 0.2, 0.25, 0.3, 0.4, 0.9]
    np.testing.assert_allclose(
        energy_membership(soc, EnergyEstimatorParams()), [1, 1, 0.75, 0.5, 0, 0], atol=1e-12
    )


def test_energy_estimator_follows_a_step_with_the_first_order_lag():
    tau = 0.4
    system = EnergyEstimator(EnergyEstimatorParams(time_constant=tau), period=T)
    out = _simulate_step(system, "battery", [0.55, 7.4, 1.2], [0.1, 6.9, 2.5], _TIMES)
    soc = _lagged(0.55, 0.1, tau)
    np.testing.assert_allclose(out["soc_hat"][:, 0], soc, rtol=1e-12)
    np.testing.assert_allclose(
        out["energy_hat"][:, 0], 1 - np.clip((soc - 0.2) / 0.2, 0, 1), atol=1e-12
    )
    assert out["energy_hat"][0, 0] == 0.0 and out["energy_hat"][-1, 0] == 1.0


def test_energy_estimator_reads_full_until_the_first_reading_and_holds_nan():
    system = EnergyEstimator(EnergyEstimatorParams(time_constant=1.0), period=0.1)
    context = system.CreateDefaultContext()
    assert system.GetOutputPort("soc_hat").Eval(context)[0] == 1.0
    assert system.GetOutputPort("energy_hat").Eval(context)[0] == 0.0  # not "low energy"
    _update(system, context, "battery", [np.nan, 7.0, 1.0])
    assert system.GetOutputPort("soc_hat").Eval(context)[0] == 1.0  # still unseeded
    _update(system, context, "battery", [0.3, 7.0, 1.0])
    assert system.GetOutputPort("soc_hat").Eval(context)[0] == 0.3
    assert system.GetOutputPort("energy_hat").Eval(context)[0] == pytest.approx(0.5)
    _update(system, context, "battery", [np.inf, np.nan, np.nan])
    assert system.GetOutputPort("soc_hat").Eval(context)[0] == 0.3
    _update(system, context, "battery", [0.1, np.nan, np.nan])  # voltage, current unused
    assert system.GetOutputPort("soc_hat").Eval(context)[0] == pytest.approx(
        0.3 - 0.2 * (1 - np.exp(-0.1))
    )


# --- altitude ----------------------------------------------------------------------------------


def test_floor_membership_falls_from_the_on_floor_to_the_off_floor_range():
    p = AltimeterEstimatorParams()  # 0.23 and 0.28 m
    r = [0.0, 0.2, 0.23, 0.2425, 0.255, 0.28, 0.4, 50.0]
    np.testing.assert_allclose(floor_membership(r, p), [1, 1, 1, 0.75, 0.5, 0, 0, 0], atol=1e-12)


def test_altimeter_estimator_follows_a_step_with_the_first_order_lag():
    """Rising off the floor: the range 0.18 -> 0.40 m; the filtered range is the closed-form
    lag and floor_hat its falling ramp."""
    tau = 0.5
    system = AltimeterEstimator(AltimeterEstimatorParams(time_constant=tau), period=T)
    out = _simulate_step(system, "altitude", [0.18], [0.40], _TIMES)
    r = _lagged(0.18, 0.40, tau)
    np.testing.assert_allclose(out["altitude_hat"][:, 0], r, rtol=1e-12)
    np.testing.assert_allclose(out["floor_hat"][:, 0], np.clip((0.28 - r) / 0.05, 0, 1), atol=1e-12)
    assert out["floor_hat"][0, 0] == 1.0 and out["floor_hat"][-1, 0] == 0.0


def test_altimeter_estimator_reads_free_water_until_an_echo_and_holds_dropouts():
    system = AltimeterEstimator(AltimeterEstimatorParams(time_constant=1.0), period=0.1)
    context = system.CreateDefaultContext()
    assert system.GetOutputPort("altitude_hat").Eval(context)[0] == 0.28
    assert system.GetOutputPort("floor_hat").Eval(context)[0] == 0.0  # not "on the floor"
    _update(system, context, "altitude", [np.nan])  # a dropout before any echo
    assert system.GetOutputPort("altitude_hat").Eval(context)[0] == 0.28
    _update(system, context, "altitude", [0.2])
    assert system.GetOutputPort("floor_hat").Eval(context)[0] == 1.0
    _update(system, context, "altitude", [np.inf])  # no echo: held
    assert system.GetOutputPort("altitude_hat").Eval(context)[0] == 0.2
    _update(system, context, "altitude", [0.5])
    assert system.GetOutputPort("altitude_hat").Eval(context)[0] == pytest.approx(
        0.2 + 0.3 * (1 - np.exp(-0.1))
    )


# --- parameters --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make, message",
    [
        (
            lambda: PostureEstimatorParams(tilt_low_deg=-1.0),
            r"tilt_low_deg: -1.0 is outside the allowed range \[0, 180\) deg",
        ),
        (
            lambda: PostureEstimatorParams(tilt_low_deg=180.0),
            r"tilt_low_deg: 180.0 is outside the allowed range \[0, 180\) deg",
        ),
        (
            lambda: PostureEstimatorParams(tilt_high_deg=10.0),
            r"tilt_high_deg: 10.0 is outside the allowed range \(tilt_low_deg = 10, 180\] deg",
        ),
        (
            lambda: PostureEstimatorParams(tilt_high_deg=181.0),
            r"tilt_high_deg: 181.0 is outside the allowed range",
        ),
        (
            lambda: PostureEstimatorParams(time_constant=-0.1),
            r"time_constant: -0.1 is outside the allowed range \[0, 100\] s",
        ),
        (lambda: PostureEstimatorParams(time_constant=np.nan), r"time_constant: nan is not finite"),
        (lambda: PostureEstimatorParams(tilt_low_deg="10"), r"tilt_low_deg: '10' is not a number"),
        (
            lambda: FlowEstimatorParams(speed_low=-0.01),
            r"speed_low: -0.01 is outside the allowed range \[0, 10\) m/s",
        ),
        (
            lambda: FlowEstimatorParams(speed_high=0.02),
            r"speed_high: 0.02 is outside the allowed range \(speed_low = 0.03, 10\] m/s",
        ),
        (
            lambda: FlowEstimatorParams(time_constant=200.0),
            r"time_constant: 200.0 is outside the allowed range \[0, 100\] s",
        ),
        (
            lambda: FlowEstimatorParams(axis="heave"),
            r"axis: 'heave' is not one of magnitude, surge, sway",
        ),
        (
            lambda: EnergyEstimatorParams(soc_low=1.0),
            r"soc_low: 1.0 is outside the allowed range \[0, 1\)",
        ),
        (
            lambda: EnergyEstimatorParams(soc_high=0.1),
            r"soc_high: 0.1 is outside the allowed range \(soc_low = 0.2, 1\]",
        ),
        (
            lambda: EnergyEstimatorParams(time_constant=-5.0),
            r"time_constant: -5.0 is outside the allowed range \[0, 1000\] s",
        ),
        (
            lambda: AltimeterEstimatorParams(on_floor_range=-0.1),
            r"on_floor_range: -0.1 is outside the allowed range \[0, 100\) m",
        ),
        (
            lambda: AltimeterEstimatorParams(off_floor_range=0.23),
            r"off_floor_range: 0.23 is outside the allowed range \(on_floor_range = 0.23, 100\] m",
        ),
        (
            lambda: AltimeterEstimatorParams(time_constant=-1.0),
            r"time_constant: -1.0 is outside the allowed range \[0, 100\] s",
        ),
    ],
)
def test_every_parameter_error_names_the_field_and_range(make, message):
    with pytest.raises(ValueError, match=message):
        make().validate()


@pytest.mark.parametrize(
    "make, message",
    [
        (
            lambda: PostureEstimator(period=0.0),
            r"PostureEstimator.period: 0.0 is outside .*\(0, 1\]",
        ),
        (lambda: FlowEstimator(period=2.0), r"FlowEstimator.period: 2.0 is outside .*\(0, 1\]"),
        (
            lambda: EnergyEstimator(period=-1.0),
            r"EnergyEstimator.period: -1.0 is outside .*\(0, 10\]",
        ),
        (
            lambda: AltimeterEstimator(period=1.5),
            r"AltimeterEstimator.period: 1.5 is outside .*\(0, 1\]",
        ),
        (
            lambda: PostureEstimator(PostureEstimatorParams(tilt_high_deg=5.0)),
            r"tilt_high_deg: 5.0",
        ),
        (lambda: FlowEstimator(FlowEstimatorParams(axis="")), r"axis: '' is not one of"),
        (lambda: EnergyEstimator(EnergyEstimatorParams(soc_low=0.5)), r"soc_high: 0.4 is outside"),
    ],
)
def test_systems_check_at_construction(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_flow_estimator_ports_and_default_period():
    """The ports are the documented sizes, and the default update period is the flow
    sensor's default sample period (1 / 50 Hz), so each reading is filtered once."""
    from manta_drake.station.flow_sensor import FlowSensorParams

    system = FlowEstimator()
    assert system.GetInputPort("flow_velocity").size() == 3
    assert system.GetOutputPort("flow_hat").size() == 1
    assert system.GetOutputPort("flow_speed_hat").size() == 1
    assert system.period == pytest.approx(1.0 / FlowSensorParams().rate_hz, rel=1e-15)
    assert system.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == system.period


@pytest.mark.parametrize(
    "good",
    [
        {"speed_low": 9.99, "speed_high": 10.0},
        {"time_constant": 100.0},
        {"time_constant": 0.0},
    ],
)
def test_flow_parameter_edges_pass(good):
    FlowEstimatorParams(**good).validate()
    FlowEstimator(period=1.0)


@pytest.mark.parametrize(
    "make, message",
    [
        (
            lambda: FlowEstimatorParams(speed_low=10.0, speed_high=10.0).validate(),
            r"speed_low: 10.0 is outside the allowed range \[0, 10\) m/s",
        ),
        (lambda: FlowEstimatorParams(speed_high=12.0).validate(), r"speed_high: 12.0 is outside"),
        (
            lambda: FlowEstimatorParams(time_constant=120.0).validate(),
            r"time_constant: 120.0 is outside",
        ),
        (lambda: FlowEstimator(period=1.2), r"FlowEstimator.period: 1.2 is outside"),
    ],
)
def test_flow_parameters_just_past_the_edges_are_refused(make, message):
    with pytest.raises(ValueError, match=message):
        make()
