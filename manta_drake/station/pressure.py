"""The pressure (depth) sensor on the robot's head."""

import math

import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RigidBody
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import Range, check_in_range, short_repr

# The probability that a reading is lost (NaN): the constructor's dropout_rate and the
# scenario's pressure_sensor.dropout_rate.
DROPOUT_RATE = Range(0.0, 1.0)


def pressure_depth_sample(
    true_depth: float,
    noise_std: float,
    dropout_rate: float,
    normal_sample: float,
    uniform_sample: float,
) -> float:
    """One reading: ``true_depth + noise_std * normal_sample``, or NaN (a dropped reading)
    when ``uniform_sample < dropout_rate``."""
    if uniform_sample < dropout_rate:
        return np.nan
    return true_depth + noise_std * normal_sample


def check_plant_body(owner: str, plant, body) -> int:
    """The index of ``body`` after checking that ``plant`` is a MultibodyPlant and ``body``
    one of its RigidBodies; ValueError naming ``owner``'s argument otherwise."""
    if not isinstance(plant, MultibodyPlant):
        raise ValueError(f"{owner}.plant: expected a MultibodyPlant, got {type(plant).__name__}")
    if not isinstance(body, RigidBody):
        raise ValueError(f"{owner}.body: expected a RigidBody, got {type(body).__name__}")
    index = int(body.index())
    if index >= plant.num_bodies() or plant.get_body(body.index()) is not body:
        raise ValueError(f"{owner}.body: {short_repr(body.name())} is not a body of the plant")
    return index


def check_point(field: str, value, what: str) -> np.ndarray:
    """``value`` as a (3,) float array; ValueError naming ``field`` unless it is 3 finite
    numbers."""
    try:
        point = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        point = None
    if point is None or point.shape != (3,) or not np.all(np.isfinite(point)):
        raise ValueError(f"{field}: {short_repr(value)} must be 3 finite numbers ({what}, m)")
    return point.copy()


class PressureSensor(LeafSystem):
    """Depth of a point on the robot below the water surface, sampled with noise.

    .. pydrake_system::

        name: PressureSensor
        input_ports:
        - body_poses
        - noise (optional)
        output_ports:
        - depth

    * ``body_poses``: the plant's body poses.
    * ``noise`` (2, optional): [standard normal sample, uniform [0, 1) sample], from
      Drake ``RandomSource`` systems (so the noise lives in the Context and
      ``SetRandomContext`` draws it anew). Unconnected: a noiseless sensor.
    * ``depth`` (1): h = -z of the sensor point in the world [m] (positive below the
      surface z = 0) plus ``noise_std`` times the normal sample, or NaN for a dropped
      reading (uniform sample < ``dropout_rate``); a discrete state sampled every
      ``period`` seconds and held in between. It starts at the true depth.

    Args:
        plant: the MultibodyPlant (double) whose body poses the sensor reads.
        body: the RigidBody of ``plant`` the sensor is fixed to.
        p_BS: the sensor point in the body's frame, 3 finite numbers [m].
        period: the sample period [s], > 0.
        noise_std: the reading's noise standard deviation [m], >= 0.
        dropout_rate: the probability of a NaN reading, in [0, 1].

    Raises:
        ValueError: one line naming the argument and what is allowed.
    """

    def __init__(
        self, plant, body, p_BS, period: float, noise_std: float = 0.0, dropout_rate: float = 0.0
    ):
        super().__init__()
        self.body_index = check_plant_body("PressureSensor", plant, body)
        self.p_BS = check_point("PressureSensor.p_BS", p_BS, "the sensor point in the body frame")
        check_in_range("PressureSensor.period", period, 0.0, math.inf, "(0, inf) s", open_low=True)
        check_in_range("PressureSensor.noise_std", noise_std, 0.0, math.inf, "[0, inf) m")
        DROPOUT_RATE.check("PressureSensor.dropout_rate", dropout_rate)
        self.noise_std, self.dropout_rate = float(noise_std), float(dropout_rate)
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._noise = self.DeclareVectorInputPort("noise", 2)
        self._state = self.DeclareDiscreteState([np.nan])
        self.DeclareStateOutputPort("depth", self._state)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
        self.DeclareInitializationDiscreteUpdateEvent(self._reset)

    def true_depth(self, context) -> float:
        """The noiseless depth of the sensor point [m]."""
        X_WB = self._poses.Eval(context)[self.body_index]
        return -float((X_WB @ self.p_BS)[2])

    def _reset(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._state).SetAtIndex(0, self.true_depth(context))

    def _sample(self, context, discrete_state):
        n, u = self._noise.Eval(context) if self._noise.HasValue(context) else (0.0, 1.0)
        discrete_state.get_mutable_vector(self._state).SetAtIndex(
            0,
            pressure_depth_sample(
                self.true_depth(context), self.noise_std, self.dropout_rate, n, u
            ),
        )
