"""The flow-velocity sensor on a real MultibodyPlant (a free box in zero gravity, so its
velocity stays what the test sets): relative flow against closed forms, the lever arm,
the current schedule, the noise's statistics and the parameter checks."""

import math

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput

from manta_drake.station.current import CurrentPoint, CurrentSchedule
from manta_drake.station.flow_sensor import (
    FlowSensorParams,
    FlowVelocitySensor,
    add_flow_sensor,
    flow_velocity,
)

QUIET = dict(noise_std=0.0)


def _box(params, current=(0.0, 0.0, 0.0), X_WB=None, w_W=(0, 0, 0), v_W=(0, 0, 0)):
    """(simulator, diagram, sensor, logs) of a free box (no gravity) carrying the sensor,
    with the given pose and velocity."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=1e-3, use_sampled_output_ports=False), builder
    )
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(2.0, 0.3, 0.2, 0.1))
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    plant.Finalize()
    sensor = add_flow_sensor(builder, plant, box, params, current)
    logs = {
        port: LogVectorOutput(sensor.GetOutputPort(port), builder, sensor.period)
        for port in ("flow_velocity", "flow_velocity_true")
    }
    diagram = builder.Build()
    simulator = Simulator(diagram)
    plant_context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetFreeBodyPose(plant_context, box, RigidTransform() if X_WB is None else X_WB)
    plant.SetFreeBodySpatialVelocity(
        plant_context,
        box,
        SpatialVelocity(np.asarray(w_W, dtype=float), np.asarray(v_W, dtype=float)),
    )
    return simulator, diagram, sensor, logs


def _read(sensor, simulator, port="flow_velocity"):
    return sensor.GetOutputPort(port).Eval(sensor.GetMyContextFromRoot(simulator.get_context()))


def test_body_moving_in_still_water_reads_minus_its_velocity_in_its_frame():
    rpy = RollPitchYaw(0.1, 0.2, 0.7)
    R = RotationMatrix(rpy).matrix()
    v = np.array([0.12, -0.05, 0.03])
    simulator, _, sensor, logs = _box(
        FlowSensorParams(**QUIET), X_WB=RigidTransform(rpy, [0] * 3), v_W=v
    )
    simulator.AdvanceTo(0.2)
    data = logs["flow_velocity"].FindLog(simulator.get_context()).data()
    assert data.shape[1] >= 10
    np.testing.assert_allclose(
        data, np.tile((-R.T @ v)[:, None], (1, data.shape[1])), rtol=0, atol=1e-12
    )
    # e.g. surging forward at 0.1 m/s, level: the probe sees -0.1 m/s along x.
    simulator, _, sensor, _ = _box(FlowSensorParams(**QUIET), v_W=[0.1, 0.0, 0.0])
    simulator.Initialize()
    np.testing.assert_allclose(_read(sensor, simulator), [-0.1, 0.0, 0.0], atol=1e-15)


def test_body_at_rest_in_a_current_reads_the_current_turned_by_its_yaw():
    """Yawed 90 deg (its x axis along the world's y), in a 0.3 m/s current along the
    world's x: the water comes from its right, -0.3 m/s along its y."""
    X = RigidTransform(RollPitchYaw(0.0, 0.0, math.pi / 2), [0.0, 0.0, 0.0])
    simulator, _, sensor, _ = _box(FlowSensorParams(**QUIET), current=[0.3, 0.0, 0.0], X_WB=X)
    simulator.AdvanceTo(0.1)
    np.testing.assert_allclose(_read(sensor, simulator), [0.0, -0.3, 0.0], atol=1e-12)
    np.testing.assert_allclose(
        _read(sensor, simulator, "flow_velocity_true"), [0.0, -0.3, 0.0], atol=1e-12
    )


@pytest.mark.parametrize("yaw", [0.0, math.pi / 2])
def test_lever_arm_of_the_head_on_a_turning_body(yaw):
    """Turning at 2 rad/s about the vertical, the head (0.19 m ahead) moves sideways at
    0.38 m/s, so the water there comes at it at -0.38 m/s along its y: the same in the
    body frame whatever the heading."""
    X = RigidTransform(RollPitchYaw(0.0, 0.0, yaw), [0.0, 0.0, 0.0])
    simulator, _, sensor, _ = _box(FlowSensorParams(**QUIET), X_WB=X, w_W=[0.0, 0.0, 2.0])
    simulator.Initialize()
    np.testing.assert_allclose(_read(sensor, simulator), [0.0, -0.38, 0.0], atol=1e-12)


def test_flow_velocity_matches_a_finite_difference_of_the_sensor_point():
    """The pure maths: the sensor point's velocity is the derivative of R(t) p + p_o(t)."""
    axis = np.array([0.3, -1.0, 0.4]) / np.linalg.norm([0.3, -1.0, 0.4])
    omega, v_o = 1.7, np.array([0.1, -0.2, 0.05])
    R0 = RotationMatrix(RollPitchYaw(0.2, -0.1, 1.2)).matrix()
    p_BS = np.array([0.19, 0.02, 0.03])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])

    def p_WS(t):
        R = np.eye(3) + math.sin(omega * t) * K + (1 - math.cos(omega * t)) * K @ K
        return v_o * t + R @ R0 @ p_BS

    h = 1e-6
    v_S = (p_WS(h) - p_WS(-h)) / (2 * h)
    current = np.array([0.05, 0.1, 0.0])
    np.testing.assert_allclose(
        flow_velocity(R0, omega * axis, v_o, p_BS, current),
        R0.T @ (current - v_S),
        rtol=0,
        atol=1e-9,
    )


def test_current_schedule_is_read_at_each_samples_time():
    schedule = CurrentSchedule(
        points=[CurrentPoint(0.0, [0.0, 0.0, 0.0]), CurrentPoint(1.0, [0.2, 0.1, 0.0])]
    )
    params = FlowSensorParams(rate_hz=10.0, **QUIET)
    simulator, _, sensor, logs = _box(params, current=schedule)
    for t, expected in ((0.5, [0.1, 0.05, 0.0]), (1.5, [0.2, 0.1, 0.0])):
        simulator.AdvanceTo(t + 1e-4)  # just after the sample at t
        np.testing.assert_allclose(_read(sensor, simulator), expected, atol=1e-12)
    log = logs["flow_velocity_true"].FindLog(simulator.get_context())
    times, data = log.sample_times(), log.data()
    # The ramp, held: a log entry at t shows the sample of t - period (Drake publishes
    # before the discrete update of the same time), the first the initial reading.
    np.testing.assert_allclose(data[0], 0.2 * np.clip(times - 0.1, 0, 1), atol=1e-12)
    np.testing.assert_allclose(data[1], 0.5 * data[0], atol=1e-12)


def test_noise_has_the_configured_std_and_is_white():
    params = FlowSensorParams(rate_hz=500.0, noise_std=0.02)
    simulator, diagram, _, logs = _box(params, current=[0.1, 0.0, 0.0])
    context = simulator.get_mutable_context()
    diagram.SetRandomContext(context, RandomGenerator(11))
    simulator.AdvanceTo(4.0)
    diff = (
        logs["flow_velocity"].FindLog(context).data()
        - logs["flow_velocity_true"].FindLog(context).data()
    )
    n = diff.shape[1]
    assert n >= 2000
    np.testing.assert_allclose(diff.std(axis=1), 0.02, rtol=0.08)
    assert np.all(np.abs(diff.mean(axis=1)) < 5 * 0.02 / math.sqrt(n))
    for row in diff:
        assert abs(np.corrcoef(row[:-1], row[1:])[0, 1]) < 5 / math.sqrt(n)
    # Another seed, other noise.
    simulator2, diagram2, _, logs2 = _box(params, current=[0.1, 0.0, 0.0])
    context2 = simulator2.get_mutable_context()
    diagram2.SetRandomContext(context2, RandomGenerator(12))
    simulator2.AdvanceTo(0.1)
    other = logs2["flow_velocity"].FindLog(context2).data()
    first = logs["flow_velocity"].FindLog(context).data()[:, : other.shape[1]]
    assert np.all(np.abs(other - first) > 1e-9)


def test_add_flow_sensor_wires_the_plant_and_the_source():
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(2.0, 0.3, 0.2, 0.1))
    plant.Finalize()
    sensor = add_flow_sensor(builder, plant, box, FlowSensorParams(rate_hz=20.0), name="pitot")
    assert sensor.get_name() == "pitot" and sensor.period == pytest.approx(0.05)
    for i in range(sensor.num_input_ports()):
        assert builder.IsConnectedOrExported(sensor.get_input_port(i))
    assert "pitot_noise" in {s.get_name() for s in builder.GetSystems()}
    assert sensor.GetOutputPort("flow_velocity").size() == 3
    np.testing.assert_array_equal(sensor.current_schedule.at(3.0), [0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (
            dict(rate_hz=0.0),
            r"flow_sensor.rate_hz: 0.0 is outside the allowed range \(0, 1000\] Hz",
        ),
        (dict(rate_hz=float("inf")), r"flow_sensor.rate_hz: inf is not finite"),
        (
            dict(noise_std=-0.001),
            r"flow_sensor.noise_std: -0.001 is outside the allowed range "
            r"\[0, 0.5\] m/s",
        ),
        (dict(noise_std=None), r"flow_sensor.noise_std: None is not a number"),
        (dict(position=[0.19, 0.0]), r"flow_sensor.position: expected 3 finite numbers"),
        (dict(position=[0.0, 0.0, 5.0]), r"flow_sensor.position: .* magnitude above the allowed"),
        (dict(enabled=1), r"flow_sensor.enabled: 1 is not true or false"),
    ],
)
def test_bad_params_name_the_field_and_range(kwargs, match):
    with pytest.raises(ValueError, match=match):
        FlowSensorParams(**kwargs).validate()


def test_constructor_rejects_a_bad_current():
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(2.0, 0.3, 0.2, 0.1))
    plant.Finalize()
    with pytest.raises(
        ValueError,
        match=r"FlowVelocitySensor.current: \[3.0, 0.0, 0.0\] has "
        r"magnitude 3 m/s",
    ):
        FlowVelocitySensor(plant, box, FlowSensorParams(), [3.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="flow_sensor.rate_hz"):
        FlowVelocitySensor(plant, box, FlowSensorParams(rate_hz=-1.0))
    p = FlowSensorParams().validate()
    assert not p.enabled and p.rate_hz == 50.0 and p.position == [0.19, 0.0, 0.03]
    assert p.noise_std == 0.005
