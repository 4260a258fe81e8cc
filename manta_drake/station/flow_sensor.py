"""A flow-velocity sensor on the robot's head: the water's velocity relative to the
sensor, in the body frame, sampled with noise.

What a small pitot or thermal (hot-film) 3-axis flow probe would give: the velocity of
the water past the probe, so a robot swimming forward at u in still water reads -u
along its forward axis, and a robot at rest in a current reads the current turned into
its frame. ``flow_velocity`` is the pure maths; ``FlowVelocitySensor`` the Drake system
that feeds it the plant's kinematics and the water's current (a ``CurrentSchedule``);
``add_flow_sensor`` adds the sensor and its noise source to a diagram.
"""

import dataclasses as dc

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.systems.framework import LeafSystem
from pydrake.systems.primitives import RandomSource

from manta_drake.config_io import check_boolean, check_in_range, check_vector
from manta_drake.model.robot_params import HULL_SENSOR_REACH
from manta_drake.station.current import CurrentSchedule
from manta_drake.station.imu import cross3


@dc.dataclass
class FlowSensorParams:
    """The flow sensor's mounting, rate and noise."""

    enabled: bool = False
    rate_hz: float = 50.0  # Hz, the output data rate
    # Where the probe sits on the hull, in the hull's (body) frame [m]: the head.
    position: list[float] = dc.field(default_factory=lambda: [0.19, 0.0, 0.03])
    noise_std: float = 0.005  # m/s, white noise per axis

    def validate(self, prefix: str = "flow_sensor") -> "FlowSensorParams":
        """Checks every field; ValueError, one line naming ``<prefix>.<field>``, the value
        and the allowed range. Returns self."""
        check_boolean(f"{prefix}.enabled", self.enabled)
        check_in_range(
            f"{prefix}.rate_hz", self.rate_hz, 0.0, 1000.0, "(0, 1000] Hz", open_low=True
        )
        check_in_range(f"{prefix}.noise_std", self.noise_std, 0.0, 0.5, "[0, 0.5] m/s")
        check_vector(f"{prefix}.position", self.position, 3, HULL_SENSOR_REACH, " m")
        return self


def flow_velocity(R_WB, w_W, v_WB, p_BS, current_W) -> np.ndarray:
    """The water's velocity relative to a point S fixed on body B, in B's frame.

    Args:
        R_WB: (3, 3) the body's orientation in the world.
        w_W, v_WB: (3,) its angular velocity and its origin's velocity (world).
        p_BS: (3,) the sensor's position in the body frame [m].
        current_W: (3,) the water's velocity at S (world) [m/s].

    Returns:
        (3,) R_WB^T (current - (v_WB + w_W x R_WB p_BS)) [m/s].
    """
    R_WB = np.asarray(R_WB, dtype=float)
    v_S = np.asarray(v_WB, dtype=float) + cross3(w_W, R_WB @ np.asarray(p_BS, dtype=float))
    return R_WB.T @ (np.asarray(current_W, dtype=float) - v_S)


class FlowVelocitySensor(LeafSystem):
    """The water's velocity relative to a point on a body, in the body frame, sampled with
    white noise.

    .. pydrake_system::

        name: FlowVelocitySensor
        input_ports:
        - body_poses
        - body_spatial_velocities
        - noise (optional)
        output_ports:
        - flow_velocity
        - flow_velocity_true

    * ``body_poses``, ``body_spatial_velocities``: the plant's outputs of those names.
    * ``noise`` (3, optional): standard normal white noise, one sample per reading (a
      Drake ``RandomSource`` of period ``period``). Unconnected: no noise.
    * ``flow_velocity`` (3) [m/s]: ``flow_velocity`` of the sensor point at the
      schedule's current at the sample's time, plus ``noise_std`` times the noise.
    * ``flow_velocity_true`` (3) [m/s]: the same without noise, sampled at the same times
      (for logs and tests; a controller must not read it).

    Both outputs are discrete state, sampled every ``period`` = 1 / ``rate_hz`` seconds
    (from t = 0), held in between and set at initialization to the initial state's
    reading: no direct feedthrough, so a controller can feed back on them.

    Args:
        plant: the finalized MultibodyPlant.
        body: the body (a RigidBody of ``plant``) the sensor is fixed to.
        params: FlowSensorParams (checked; ``enabled`` is the caller's switch).
        current: a ``CurrentSchedule``, or a constant (3,) current [m/s] (world frame),
            the water's velocity; the same the water's forces use.

    Raises:
        ValueError: a parameter outside its range, or a bad current.
    """

    def __init__(
        self, plant, body, params: FlowSensorParams | None = None, current=(0.0, 0.0, 0.0)
    ):
        super().__init__()
        params = FlowSensorParams() if params is None else params
        params.validate()
        if not isinstance(current, CurrentSchedule):
            current = CurrentSchedule(current, constant_field="FlowVelocitySensor.current")
        self.params = dc.replace(params, position=list(params.position))
        self.current_schedule = current
        self.body_index = int(body.index())
        self.p_BS = np.asarray(params.position, dtype=float).reshape(3)
        self.period = 1.0 / float(params.rate_hz)
        self.noise_std = float(params.noise_std)
        self._current_now = np.empty(3)  # scratch for the schedule's value
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate()
        )
        self._noise = self.DeclareVectorInputPort("noise", 3)
        # Before its first sample the sensor holds the noiseless reading of the body at rest
        # in the plant's default pose in the current at t = 0: what an estimator initialised
        # on it starts from.
        X_WB = plant.EvalBodyPoseInWorld(plant.CreateDefaultContext(), body)
        zero = np.zeros(3)
        at_rest = flow_velocity(X_WB.rotation().matrix(), zero, zero, self.p_BS, current.at(0.0))
        self._reading = self.DeclareDiscreteState(at_rest)
        self._true = self.DeclareDiscreteState(at_rest)
        self.DeclareStateOutputPort("flow_velocity", self._reading)
        self.DeclareStateOutputPort("flow_velocity_true", self._true)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._sample)
        self.DeclareInitializationDiscreteUpdateEvent(self._sample)

    def true_reading(self, context) -> np.ndarray:
        """(3,) the noiseless relative flow at ``context`` [m/s], body frame."""
        X_WB = self._poses.Eval(context)[self.body_index]
        V_WB = self._velocities.Eval(context)[self.body_index]
        current = self.current_schedule.at(context.get_time(), out=self._current_now)
        return flow_velocity(
            X_WB.rotation().matrix(), V_WB.rotational(), V_WB.translational(), self.p_BS, current
        )

    def _sample(self, context, discrete_state):
        true = self.true_reading(context)
        noise = self._noise.Eval(context) if self._noise.HasValue(context) else np.zeros(3)
        discrete_state.get_mutable_vector(self._true).SetFromVector(true)
        discrete_state.get_mutable_vector(self._reading).SetFromVector(
            true + self.noise_std * noise
        )


def add_flow_sensor(
    builder,
    plant,
    body,
    params: FlowSensorParams | None = None,
    current_schedule=(0.0, 0.0, 0.0),
    name: str = "flow_sensor",
) -> FlowVelocitySensor:
    """Adds a FlowVelocitySensor on ``body`` and its noise to ``builder``, wired to
    ``plant``.

    Adds two systems: the sensor (named ``name``) and a Gaussian ``RandomSource`` of 3
    samples every ``1 / rate_hz`` seconds into its ``noise`` input (``<name>_noise``).
    Connects the plant's ``body_poses`` and ``body_spatial_velocities`` outputs to the
    sensor's inputs of those names. The outputs ``flow_velocity`` and
    ``flow_velocity_true`` are left to the caller. ``current_schedule``: a
    CurrentSchedule or a constant (3,) current, the one the water's forces use.

    Returns:
        The sensor, owned by the builder.
    """
    sensor = builder.AddNamedSystem(name, FlowVelocitySensor(plant, body, params, current_schedule))
    builder.Connect(plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    builder.Connect(
        plant.get_body_spatial_velocities_output_port(),
        sensor.GetInputPort("body_spatial_velocities"),
    )
    noise = builder.AddNamedSystem(
        f"{name}_noise", RandomSource(RandomDistribution.kGaussian, 3, sensor.period)
    )
    builder.Connect(noise.get_output_port(), sensor.GetInputPort("noise"))
    return sensor
