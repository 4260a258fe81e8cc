"""The inertial measurement unit on the robot's hull: an AHRS's attitude, gyro and
accelerometer, sampled with noise and a per-run bias.

The part modelled is a MEMS AHRS of the BNO055 / BNO085 class: it reports its fused
attitude as roll, pitch and yaw, its body-frame angular rate and its body-frame specific
force (what an accelerometer measures: the acceleration minus gravity, so a level unit at
rest reads +g up). ``imu_true_reading`` and ``imu_noisy_reading`` are the pure maths;
``ImuSensor`` the Drake system that feeds them the plant's kinematics; ``add_imu`` adds
the sensor and its noise sources to a diagram.
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.math import RollPitchYaw, RotationMatrix
from pydrake.systems.framework import LeafSystem
from pydrake.systems.primitives import RandomSource

from manta_drake.config_io import check_boolean, check_in_range, check_vector
from manta_drake.model.robot_params import HULL_SENSOR_REACH

# A bias RandomSource's sampling interval [s]: far beyond any run, so its sample is one
# constant per run, drawn from the Context's seed.
BIAS_RESAMPLE_PERIOD = 1e9


@dc.dataclass
class ImuParams:
    """The IMU's mounting, rate and noise. Defaults: a BNO055 / BNO085 class part as
    its datasheet and fusion firmware give it (gyro noise density ~0.014 deg/s/sqrt(Hz),
    accelerometer ~150 ug/sqrt(Hz), residual offsets after its calibration), rounded up."""

    enabled: bool = False
    rate_hz: float = 100.0  # Hz, the output data rate
    # Where the unit sits on the hull, in the hull's (body) frame [m].
    position: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.02])
    attitude_noise_std_deg: float = 0.5  # deg, white noise on roll, pitch and yaw
    gyro_noise_std_deg_s: float = 0.3  # deg/s, white noise per axis
    gyro_bias_std_deg_s: float = 0.5  # deg/s, per-run constant offset per axis (std)
    accel_noise_std: float = 0.05  # m/s^2, white noise per axis
    accel_bias_std: float = 0.05  # m/s^2, per-run constant offset per axis (std)

    # (name, low, high, unit, low open): every number's allowed range.
    RANGES = (
        ("rate_hz", 0.0, 1000.0, "Hz", True),
        ("attitude_noise_std_deg", 0.0, 10.0, "deg", False),
        ("gyro_noise_std_deg_s", 0.0, 10.0, "deg/s", False),
        ("gyro_bias_std_deg_s", 0.0, 10.0, "deg/s", False),
        ("accel_noise_std", 0.0, 2.0, "m/s^2", False),
        ("accel_bias_std", 0.0, 2.0, "m/s^2", False),
    )

    def validate(self, prefix: str = "imu") -> "ImuParams":
        """Checks every field; ValueError, one line naming ``<prefix>.<field>``, the value
        and the allowed range. Returns self."""
        check_boolean(f"{prefix}.enabled", self.enabled)
        for name, lo, hi, unit, open_low in self.RANGES:
            check_in_range(
                f"{prefix}.{name}",
                getattr(self, name),
                lo,
                hi,
                f"{'(' if open_low else '['}{lo:g}, {hi:g}] {unit}",
                open_low,
            )
        check_vector(f"{prefix}.position", self.position, 3, HULL_SENSOR_REACH, " m")
        return self

    def noise_std(self) -> np.ndarray:
        """(9,) the white noise's standard deviation per output, in SI units (rad, rad/s,
        m/s^2)."""
        return np.repeat(
            [
                math.radians(self.attitude_noise_std_deg),
                math.radians(self.gyro_noise_std_deg_s),
                self.accel_noise_std,
            ],
            3,
        )

    def bias_std(self) -> np.ndarray:
        """(9,) the bias's standard deviation per output (the attitude has none: the
        fusion corrects it against gravity and the magnetometer), SI units."""
        return np.repeat([0.0, math.radians(self.gyro_bias_std_deg_s), self.accel_bias_std], 3)


# --- pure maths ----------------------------------------------------------------------------------


def wrap_angle(angle):
    """``angle`` [rad] wrapped into (-pi, pi] (an AHRS's convention: +pi, never -pi)."""
    return math.pi - np.mod(math.pi - np.asarray(angle, dtype=float), 2.0 * math.pi)


def cross3(a, b) -> np.ndarray:
    """a x b of two 3-vectors (``np.cross`` costs ~10 us a call on 3-vectors, most of a
    sample's time)."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def imu_true_reading(R_WB, w_W, alpha_W, a_WBo, p_BS, g_W) -> np.ndarray:
    """The noiseless reading of an IMU at ``p_BS`` on body B.

    Args:
        R_WB: (3, 3) the body's orientation in the world.
        w_W, alpha_W: (3,) its angular velocity and angular acceleration (world).
        a_WBo: (3,) the acceleration of its origin Bo (world).
        p_BS: (3,) the sensor's position in the body frame [m].
        g_W: (3,) gravity in the world [m/s^2] (e.g. [0, 0, -9.81]).

    Returns:
        (9,) [roll, pitch, yaw] [rad] (Drake's RollPitchYaw of R_WB, the ZYX angles an
        AHRS reports; roll and yaw wrapped into (-pi, pi]), [wx, wy, wz] = R_WB^T w_W
        [rad/s], and the specific force R_WB^T (a_WS - g_W) [m/s^2] with the sensor
        point's acceleration a_WS = a_WBo + alpha x r + w x (w x r), r = R_WB p_BS.
    """
    R_WB = np.asarray(R_WB, dtype=float)
    w_W = np.asarray(w_W, dtype=float)
    rpy = RollPitchYaw(RotationMatrix(R_WB)).vector()
    rpy[0], rpy[2] = wrap_angle(rpy[0]), wrap_angle(rpy[2])
    r_W = R_WB @ np.asarray(p_BS, dtype=float)
    a_WS = np.asarray(a_WBo, dtype=float) + cross3(alpha_W, r_W) + cross3(w_W, cross3(w_W, r_W))
    return np.concatenate([rpy, R_WB.T @ w_W, R_WB.T @ (a_WS - np.asarray(g_W, dtype=float))])


def imu_noisy_reading(true_reading, noise, bias, noise_std, bias_std) -> np.ndarray:
    """One sample: ``true + noise_std * noise + bias_std * bias`` per output, with roll and
    yaw wrapped again into (-pi, pi].

    Args:
        true_reading: (9,) ``imu_true_reading``.
        noise, bias: (9,) standard normal samples (this sample's and the run's).
        noise_std, bias_std: (9,) ``ImuParams.noise_std()`` and ``bias_std()``.
    """
    out = (
        np.asarray(true_reading, dtype=float)
        + np.asarray(noise_std) * noise
        + np.asarray(bias_std) * bias
    )
    out[0], out[2] = wrap_angle(out[0]), wrap_angle(out[2])
    return out


# --- the system ----------------------------------------------------------------------------------


class ImuSensor(LeafSystem):
    """An AHRS on a body of a MultibodyPlant: attitude, angular rate and specific force,
    sampled with white noise and a per-run bias.

    .. pydrake_system::

        name: ImuSensor
        input_ports:
        - body_poses
        - body_spatial_velocities
        - body_spatial_accelerations
        - noise (optional)
        - bias (optional)
        output_ports:
        - imu
        - imu_true

    * ``body_poses``, ``body_spatial_velocities``, ``body_spatial_accelerations``: the
      plant's outputs of those names.
    * ``noise`` (9, optional): standard normal white noise, one sample per reading (a
      Drake ``RandomSource`` of period ``period``). Unconnected: no noise.
    * ``bias`` (9, optional): standard normal, read once, at initialization, and held for
      the run (a ``RandomSource`` of period ``BIAS_RESAMPLE_PERIOD``: Drake's RandomSource
      draws a new sample at its t = 0 update, which the latch ignores, so the bias is one
      constant from the first reading on). Unconnected: no bias.
    * ``imu`` (9): [roll, pitch, yaw] [rad], [wx, wy, wz] [rad/s] in the body frame,
      [fx, fy, fz] [m/s^2] specific force in the body frame at ``position`` (see
      ``imu_true_reading``), with ``noise_std * noise + bias_std * bias`` added.
    * ``imu_true`` (9): the same reading without noise or bias, sampled at the same times
      (for logs and tests; a controller must not read it).

    Both outputs are discrete state, sampled every ``period`` = 1 / ``rate_hz`` seconds
    (from t = 0) and held in between, set at initialization to the reading of the
    initial state: they have no direct feedthrough, so a controller can feed back on
    ``imu`` without an algebraic loop.

    The acceleration comes from the plant's ``body_spatial_accelerations``. In a discrete
    plant with live output ports (``use_sampled_output_ports=False``, as
    ``manta_drake.model.plant.add_plant`` builds it) that is the acceleration of the step
    about to be taken, (v_next - v) / dt, which the plant's own update computes from the
    same cached solve; with sampled ports it is the last step's (zero before the first).

    Args:
        plant: the finalized MultibodyPlant.
        body: the body (a RigidBody of ``plant``) the IMU is fixed to.
        params: ImuParams (checked; ``enabled`` is the caller's switch, unused here).

    Raises:
        ValueError: a parameter outside its range (``ImuParams.validate``).
    """

    def __init__(self, plant, body, params: ImuParams | None = None):
        super().__init__()
        params = ImuParams() if params is None else params
        params.validate()
        self.params = dc.replace(params, position=list(params.position))
        self.body_index = int(body.index())
        self.p_BS = np.asarray(params.position, dtype=float).reshape(3)
        self.period = 1.0 / float(params.rate_hz)
        self.g_W = np.asarray(plant.gravity_field().gravity_vector(), dtype=float).copy()
        self._noise_std, self._bias_std = params.noise_std(), params.bias_std()
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate()
        )
        self._accelerations = self.DeclareAbstractInputPort(
            "body_spatial_accelerations",
            plant.get_body_spatial_accelerations_output_port().Allocate(),
        )
        self._noise = self.DeclareVectorInputPort("noise", 9)
        self._bias_in = self.DeclareVectorInputPort("bias", 9)
        # Before its first sample the sensor holds the noiseless reading of the body at rest
        # in the plant's default pose: what an estimator initialised on it starts from.
        at_rest = self.rest_reading(plant, body)
        self._reading = self.DeclareDiscreteState(at_rest)
        self._true = self.DeclareDiscreteState(at_rest)
        self._bias = self.DeclareDiscreteState(9)  # the run's bias sample, latched
        self.DeclareStateOutputPort("imu", self._reading)
        self.DeclareStateOutputPort("imu_true", self._true)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._sample)
        self.DeclareInitializationDiscreteUpdateEvent(self._reset)

    def rest_reading(self, plant, body) -> np.ndarray:
        """(9,) the noiseless reading of ``body`` at rest in ``plant``'s default pose."""
        X_WB = plant.EvalBodyPoseInWorld(plant.CreateDefaultContext(), body)
        zero = np.zeros(3)
        return imu_true_reading(X_WB.rotation().matrix(), zero, zero, zero, self.p_BS, self.g_W)

    def true_reading(self, context) -> np.ndarray:
        """(9,) the noiseless reading at ``context`` (``imu_true_reading``)."""
        X_WB = self._poses.Eval(context)[self.body_index]
        V_WB = self._velocities.Eval(context)[self.body_index]
        A_WB = self._accelerations.Eval(context)[self.body_index]
        return imu_true_reading(
            X_WB.rotation().matrix(),
            V_WB.rotational(),
            A_WB.rotational(),
            A_WB.translational(),
            self.p_BS,
            self.g_W,
        )

    def _store(self, context, discrete_state, bias) -> None:
        true = self.true_reading(context)
        noise = self._noise.Eval(context) if self._noise.HasValue(context) else np.zeros(9)
        discrete_state.get_mutable_vector(self._true).SetFromVector(true)
        discrete_state.get_mutable_vector(self._reading).SetFromVector(
            imu_noisy_reading(true, noise, bias, self._noise_std, self._bias_std)
        )

    def _reset(self, context, discrete_state):
        bias = self._bias_in.Eval(context) if self._bias_in.HasValue(context) else np.zeros(9)
        discrete_state.get_mutable_vector(self._bias).SetFromVector(bias)
        self._store(context, discrete_state, bias)

    def _sample(self, context, discrete_state):
        self._store(context, discrete_state, context.get_discrete_state(self._bias).get_value())


def add_imu(builder, plant, body, params: ImuParams | None = None, name: str = "imu") -> ImuSensor:
    """Adds an ImuSensor on ``body`` and its noise to ``builder``, wired to ``plant``.

    Adds three systems: the sensor (named ``name``), a Gaussian ``RandomSource`` of 9
    samples every ``1 / rate_hz`` seconds into its ``noise`` input (``<name>_noise``) and a
    Gaussian ``RandomSource`` of 9 samples every ``BIAS_RESAMPLE_PERIOD`` seconds into its
    ``bias`` input (``<name>_bias``). Connects the plant's ``body_poses``,
    ``body_spatial_velocities`` and ``body_spatial_accelerations`` outputs to the sensor's
    inputs of those names. The outputs ``imu`` and ``imu_true`` are left to the caller
    (to export or connect). The sources' state is in the Context, so seeding them
    (``Diagram.SetRandomContext`` or ``manta_drake.simulate.seed_context``) draws the
    run's noise and bias.

    Returns:
        The sensor, owned by the builder.
    """
    sensor = builder.AddNamedSystem(name, ImuSensor(plant, body, params))
    builder.Connect(plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    builder.Connect(
        plant.get_body_spatial_velocities_output_port(),
        sensor.GetInputPort("body_spatial_velocities"),
    )
    builder.Connect(
        plant.get_body_spatial_accelerations_output_port(),
        sensor.GetInputPort("body_spatial_accelerations"),
    )
    noise = builder.AddNamedSystem(
        f"{name}_noise", RandomSource(RandomDistribution.kGaussian, 9, sensor.period)
    )
    bias = builder.AddNamedSystem(
        f"{name}_bias", RandomSource(RandomDistribution.kGaussian, 9, BIAS_RESAMPLE_PERIOD)
    )
    builder.Connect(noise.get_output_port(), sensor.GetInputPort("noise"))
    builder.Connect(bias.get_output_port(), sensor.GetInputPort("bias"))
    return sensor
