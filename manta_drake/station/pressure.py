"""The pressure (depth) sensor on the robot's head."""

import numpy as np
from pydrake.systems.framework import LeafSystem


def pressure_depth_sample(true_depth: float, noise_std: float, dropout_rate: float,
                          normal_sample: float, uniform_sample: float) -> float:
    """One reading: ``true_depth + noise_std * normal_sample``, or NaN (a dropped reading)
    when ``uniform_sample < dropout_rate``."""
    if uniform_sample < dropout_rate:
        return np.nan
    return true_depth + noise_std * normal_sample


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
    """

    def __init__(self, plant, body, p_BS, period: float, noise_std: float = 0.0,
                 dropout_rate: float = 0.0):
        super().__init__()
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"PressureSensor.period: {period} must be > 0")
        if not (np.isfinite(noise_std) and noise_std >= 0):
            raise ValueError(f"PressureSensor.noise_std: {noise_std} must be >= 0")
        if not 0.0 <= dropout_rate <= 1.0:
            raise ValueError(f"PressureSensor.dropout_rate: {dropout_rate} is outside [0, 1]")
        self.body_index = int(body.index())
        self.p_BS = np.asarray(p_BS, dtype=float).reshape(3)
        self.noise_std, self.dropout_rate = float(noise_std), float(dropout_rate)
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate())
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
        discrete_state.get_mutable_vector(self._state).SetAtIndex(0, pressure_depth_sample(
            self.true_depth(context), self.noise_std, self.dropout_rate, n, u))
