"""The IMU: its reading against closed forms on a real MultibodyPlant (a free box held,
falling, spinning), the lever-arm terms against finite differences, the noise's
statistics and the bias's seeding, and the parameter checks."""

import math

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.math import SpatialForce, SpatialVelocity
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    ExternallyAppliedSpatialForce,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantValueSource, LogVectorOutput, MatrixGain

from manta_drake.station.imu import (
    ImuParams,
    ImuSensor,
    add_imu,
    imu_noisy_reading,
    imu_true_reading,
    wrap_angle,
)

MASS, SIZE = 2.0, (0.3, 0.2, 0.1)
G = 9.81
QUIET = dict(
    attitude_noise_std_deg=0.0,
    gyro_noise_std_deg_s=0.0,
    gyro_bias_std_deg_s=0.0,
    accel_noise_std=0.0,
    accel_bias_std=0.0,
)


def _box_diagram(params: ImuParams, gravity=True, hold=False, feedback_gain=None):
    """A free box (origin at its centre of mass) in a discrete plant (1 ms, live output
    ports as the station's) with an IMU; ``hold``: an applied force cancelling its weight;
    ``feedback_gain``: a yaw-rate damper fed back from the IMU's gyro z."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=1e-3, use_sampled_output_ports=False), builder
    )
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(MASS, *SIZE))
    if not gravity:
        plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    plant.Finalize()
    imu = add_imu(builder, plant, box, params)
    if hold:
        force = ExternallyAppliedSpatialForce()
        force.body_index = box.index()
        force.p_BoBq_B = np.zeros(3)
        force.F_Bq_W = SpatialForce(np.zeros(3), -MASS * plant.gravity_field().gravity_vector())
        source = builder.AddSystem(ConstantValueSource(AbstractValue.Make([force])))
        builder.Connect(source.get_output_port(), plant.get_applied_spatial_force_input_port())
    if feedback_gain is not None:
        K = np.zeros((6, 9))
        K[2, 5] = -feedback_gain  # torque z = -k * gyro z
        gain = builder.AddSystem(MatrixGain(K))
        builder.Connect(imu.GetOutputPort("imu"), gain.get_input_port())
        builder.Connect(gain.get_output_port(), plant.get_applied_generalized_force_input_port())
    logs = {
        port: LogVectorOutput(imu.GetOutputPort(port), builder, imu.period)
        for port in ("imu", "imu_true")
    }
    diagram = builder.Build()
    simulator = Simulator(diagram)
    return diagram, simulator, plant, box, imu, logs


def _set_state(plant, box, simulator, X_WB, w_W=(0, 0, 0), v_W=(0, 0, 0)):
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetFreeBodyPose(context, box, X_WB)
    plant.SetFreeBodySpatialVelocity(
        context, box, SpatialVelocity(np.asarray(w_W, float), np.asarray(v_W, float))
    )


def _read(imu, simulator, port="imu"):
    return imu.GetOutputPort(port).Eval(imu.GetMyContextFromRoot(simulator.get_context()))


# --- closed forms on a plant ---------------------------------------------------------------------


@pytest.mark.parametrize("rpy", [(0.0, 0.0, 0.7), (0.2, -0.3, 1.0), (-0.4, 0.5, -2.9)])
def test_body_held_at_rest_reads_gravity_up_in_its_frame(rpy):
    """Held against its weight, at rest: the specific force is -g in the body frame, i.e.
    g [-sin(pitch), sin(roll) cos(pitch), cos(roll) cos(pitch)] for ZYX angles (a level
    body: [0, 0, +g]); rate zero; the attitude the pose's angles."""
    _, simulator, plant, box, imu, _ = _box_diagram(ImuParams(**QUIET), hold=True)
    _set_state(plant, box, simulator, RigidTransform(RollPitchYaw(rpy), [0.1, 0.0, 1.0]))
    simulator.AdvanceTo(0.05)
    roll, pitch, _ = rpy
    expected_f = G * np.array(
        [-math.sin(pitch), math.sin(roll) * math.cos(pitch), math.cos(roll) * math.cos(pitch)]
    )
    for port in ("imu", "imu_true"):
        y = _read(imu, simulator, port)
        np.testing.assert_allclose(y[0:3], rpy, rtol=0, atol=1e-9)
        np.testing.assert_allclose(y[3:6], 0.0, atol=1e-9)
        np.testing.assert_allclose(y[6:9], expected_f, rtol=0, atol=1e-9)


def test_body_in_free_fall_reads_no_specific_force():
    _, simulator, plant, box, imu, logs = _box_diagram(ImuParams(**QUIET))
    _set_state(plant, box, simulator, RigidTransform(RollPitchYaw(0.3, 0.2, -0.5), [0, 0, 5.0]))
    simulator.AdvanceTo(0.2)
    z = plant.GetFreeBodyPose(plant.GetMyContextFromRoot(simulator.get_context()), box)
    assert z.translation()[2] < 5.0 - 0.5 * G * 0.19**2  # it fell
    f = logs["imu"].FindLog(simulator.get_context()).data()[6:9]
    np.testing.assert_allclose(f, 0.0, atol=1e-9)  # every sample of the fall
    y = _read(imu, simulator)
    np.testing.assert_allclose(y[:6], [0.3, 0.2, -0.5, 0.0, 0.0, 0.0], atol=1e-9)


def test_spinning_body_reads_its_rate_attitude_and_lever_arm_acceleration():
    """No gravity, a known angular velocity about a non-principal axis: the gyro reads it
    in the body frame, the attitude is the pose's roll-pitch-yaw, and the accelerometer
    at p reads alpha x p + w x (w x p) (body frame) with alpha from Euler's equations,
    I alpha = -w x I w (the centre of mass is at rest)."""
    p = [0.05, -0.04, 0.03]
    _, simulator, plant, box, imu, _ = _box_diagram(ImuParams(position=p, **QUIET), gravity=False)
    rpy = np.array([0.3, -0.4, 2.5])
    R = RotationMatrix(RollPitchYaw(rpy)).matrix()
    w_B = np.array([0.5, -0.2, 1.0])
    _set_state(plant, box, simulator, RigidTransform(RotationMatrix(R), [0, 0, 0]), R @ w_B)
    simulator.Initialize()  # the reading of the initial state
    y = _read(imu, simulator)
    np.testing.assert_allclose(y[0:3], rpy, rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[3:6], w_B, rtol=0, atol=1e-12)
    a, b, c = SIZE
    I_B = MASS / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    alpha_B = -np.cross(w_B, I_B * w_B) / I_B
    expected = np.cross(alpha_B, p) + np.cross(w_B, np.cross(w_B, p))
    np.testing.assert_allclose(y[6:9], expected, rtol=0, atol=1e-9)
    assert np.linalg.norm(np.cross(alpha_B, p)) > 0.005  # the alpha term matters here


def test_yaw_beyond_pi_is_wrapped():
    _, simulator, plant, box, imu, _ = _box_diagram(ImuParams(**QUIET), hold=True)
    _set_state(plant, box, simulator, RigidTransform(RollPitchYaw(0, 0, 3.5), [0, 0, 1]))
    simulator.Initialize()
    assert _read(imu, simulator)[2] == pytest.approx(3.5 - 2 * math.pi, abs=1e-12)
    assert wrap_angle(-math.pi) == math.pi
    np.testing.assert_allclose(
        wrap_angle([math.pi, 3 * math.pi, 0.1 - 2 * math.pi]), [math.pi, math.pi, 0.1], atol=1e-12
    )


def test_imu_feeds_back_without_an_algebraic_loop():
    """A yaw-rate damper on the gyro (torque = -k w_z): the diagram builds (the output
    is held state, no feedthrough from the plant) and the spin decays as the closed
    loop's exp(-k t / I_zz) (within the one-sample delay)."""
    k = 0.02
    _, simulator, plant, box, imu, _ = _box_diagram(
        ImuParams(**QUIET), gravity=False, feedback_gain=k
    )
    _set_state(plant, box, simulator, RigidTransform(), [0.0, 0.0, 2.0])
    simulator.AdvanceTo(1.0)
    a, b, _ = SIZE
    I_zz = MASS / 12.0 * (a * a + b * b)
    w = plant.EvalBodySpatialVelocityInWorld(
        plant.GetMyContextFromRoot(simulator.get_context()), box
    ).rotational()[2]
    assert w == pytest.approx(2.0 * math.exp(-k / I_zz * 1.0), rel=0.02)
    assert _read(imu, simulator)[5] == pytest.approx(w, rel=0.02)  # the gyro follows it
    assert w < 0.5 * 2.0


# --- the lever-arm maths against finite differences -----------------------------------------------


def test_specific_force_lever_arm_terms_match_finite_differences():
    """A body turning about a fixed axis with constant angular acceleration while its
    origin accelerates: the sensor point's position p_WS(t), differenced twice, gives
    the acceleration imu_true_reading uses (minus gravity, in the body frame)."""
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    theta0, omega0, alpha = 0.4, 1.3, -0.8
    p0, v0, a0 = np.array([0.1, 0.2, -0.3]), np.array([0.3, 0.0, 0.1]), np.array([0.2, -1.0, 0.5])
    R0 = RotationMatrix(RollPitchYaw(0.1, 0.2, 0.3)).matrix()
    p_BS = np.array([0.19, -0.05, 0.03])
    g_W = np.array([0.0, 0.0, -G])

    def rotation(t):
        angle = theta0 + omega0 * t + 0.5 * alpha * t * t
        K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        return (np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K) @ R0

    def p_WS(t):
        return p0 + v0 * t + 0.5 * a0 * t * t + rotation(t) @ p_BS

    h = 1e-4
    a_WS = (p_WS(h) - 2 * p_WS(0.0) + p_WS(-h)) / (h * h)
    R = rotation(0.0)
    y = imu_true_reading(R, omega0 * axis, alpha * axis, a0, p_BS, g_W)
    np.testing.assert_allclose(y[6:9], R.T @ (a_WS - g_W), rtol=0, atol=1e-5)
    np.testing.assert_allclose(y[3:6], R.T @ (omega0 * axis), atol=1e-15)


def test_noisy_reading_adds_scaled_noise_and_bias():
    true = np.array([0.1, 0.0, math.pi - 0.001, 0, 0, 0, 0, 0, G])
    noise, bias = np.arange(9.0) / 10, -np.ones(9)
    params = ImuParams()
    y = imu_noisy_reading(true, noise, bias, params.noise_std(), params.bias_std())
    s = params.noise_std()
    assert y[0] == pytest.approx(0.1 + math.radians(0.5) * 0.0)
    assert y[2] == pytest.approx(math.pi - 0.001 + s[2] * 0.2 - 2 * math.pi)  # wrapped
    assert y[4] == pytest.approx(math.radians(0.3) * 0.4 - math.radians(0.5))
    assert y[8] == pytest.approx(G + 0.05 * 0.8 - 0.05)


# --- noise and bias in a simulation ---------------------------------------------------------------


def _noise_run(params, seed, duration):
    diagram, simulator, plant, box, _, logs = _box_diagram(params, hold=True)
    _set_state(plant, box, simulator, RigidTransform(RollPitchYaw(0.1, -0.1, 0.3), [0, 0, 1]))
    context = simulator.get_mutable_context()
    diagram.SetRandomContext(context, RandomGenerator(seed))
    _set_state(plant, box, simulator, RigidTransform(RollPitchYaw(0.1, -0.1, 0.3), [0, 0, 1]))
    bias_source = diagram.GetSubsystemByName("imu_bias")
    bias_sample = (
        bias_source.get_output_port().Eval(bias_source.GetMyContextFromRoot(context)).copy()
    )
    simulator.AdvanceTo(duration)
    y = logs["imu"].FindLog(context).data()
    true = logs["imu_true"].FindLog(context).data()
    return y - true, bias_sample


def test_noise_has_the_configured_std_and_is_white():
    params = ImuParams(
        rate_hz=500.0,
        attitude_noise_std_deg=2.0,
        gyro_noise_std_deg_s=1.0,
        gyro_bias_std_deg_s=0.0,
        accel_noise_std=0.3,
        accel_bias_std=0.0,
    )
    diff, _ = _noise_run(params, seed=7, duration=4.0)
    n = diff.shape[1]
    assert n >= 2000
    std = params.noise_std()
    np.testing.assert_allclose(diff.std(axis=1), std, rtol=0.08)  # 5 sigma of the estimate
    assert np.all(np.abs(diff.mean(axis=1)) < 5 * std / math.sqrt(n))
    for row in diff / std[:, None]:  # independent samples: no lag-1 correlation
        assert abs(np.corrcoef(row[:-1], row[1:])[0, 1]) < 5 / math.sqrt(n)


def test_bias_is_one_constant_per_run_drawn_from_the_seed():
    params = ImuParams(
        attitude_noise_std_deg=0.0,
        gyro_noise_std_deg_s=0.0,
        gyro_bias_std_deg_s=0.8,
        accel_noise_std=0.0,
        accel_bias_std=0.1,
    )
    diff, sample = _noise_run(params, seed=3, duration=0.5)
    assert diff.shape[1] >= 50
    # Constant over the run, from the first reading on: the bias source's seeded sample
    # times the bias std (the attitude has none).
    np.testing.assert_allclose(
        diff, np.tile((params.bias_std() * sample)[:, None], (1, diff.shape[1])), rtol=0, atol=1e-9
    )
    assert np.all(np.abs(diff[3:, 0]) > 0)
    again, _ = _noise_run(params, seed=3, duration=0.1)
    np.testing.assert_array_equal(again[:, 0], diff[:, 0])  # same seed, same bias
    other, _ = _noise_run(params, seed=4, duration=0.1)
    assert np.all(np.abs(other[3:, 0] - diff[3:, 0]) > 1e-6)  # another seed, another bias


def test_add_imu_wires_the_plant_and_both_sources():
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(MASS, *SIZE))
    plant.Finalize()
    imu = add_imu(builder, plant, box, ImuParams(rate_hz=50.0), name="ahrs")
    assert imu.get_name() == "ahrs" and imu.period == pytest.approx(0.02)
    for i in range(imu.num_input_ports()):
        assert builder.IsConnectedOrExported(imu.get_input_port(i))
    names = {s.get_name() for s in builder.GetSystems()}
    assert {"ahrs_noise", "ahrs_bias"} <= names
    assert imu.GetOutputPort("imu").size() == 9 and imu.GetOutputPort("imu_true").size() == 9


# --- parameter checks -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(rate_hz=0.0), r"imu.rate_hz: 0.0 is outside the allowed range \(0, 1000\] Hz"),
        (dict(rate_hz=5000.0), r"imu.rate_hz: 5000.0 is outside"),
        (dict(rate_hz="fast"), r"imu.rate_hz: 'fast' is not a number"),
        (
            dict(attitude_noise_std_deg=-1.0),
            r"imu.attitude_noise_std_deg: -1.0 is outside the allowed range \[0, 10\] deg",
        ),
        (dict(gyro_noise_std_deg_s=float("nan")), r"imu.gyro_noise_std_deg_s: nan is not finite"),
        (dict(gyro_bias_std_deg_s=11.0), r"imu.gyro_bias_std_deg_s: 11.0 is outside"),
        (dict(accel_noise_std=3.0), r"imu.accel_noise_std: 3.0 is outside .* \[0, 2\] m/s\^2"),
        (dict(accel_bias_std=-0.1), r"imu.accel_bias_std: -0.1 is outside"),
        (dict(position=[0.0, 0.0]), r"imu.position: expected 3 finite numbers"),
        (dict(position=[2.0, 0.0, 0.0]), r"imu.position: .* magnitude above the allowed 1.0 m"),
        (dict(enabled="yes"), r"imu.enabled: 'yes' is not true or false"),
    ],
)
def test_bad_params_name_the_field_and_range(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ImuParams(**kwargs).validate()
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=1e-3), builder)
    box = plant.AddRigidBody("box", SpatialInertia.SolidBoxWithMass(MASS, *SIZE))
    plant.Finalize()
    with pytest.raises(ValueError, match=match):
        ImuSensor(plant, box, ImuParams(**kwargs))


def test_default_params_are_valid_and_in_si_units():
    p = ImuParams().validate()
    assert not p.enabled and p.rate_hz == 100.0 and p.position == [0.0, 0.0, 0.02]
    np.testing.assert_allclose(
        p.noise_std(), np.repeat([math.radians(0.5), math.radians(0.3), 0.05], 3)
    )
    np.testing.assert_allclose(p.bias_std(), np.repeat([0.0, math.radians(0.5), 0.05], 3))
    assert ImuParams(rate_hz=1000.0, **QUIET).validate().rate_hz == 1000.0  # the edges
