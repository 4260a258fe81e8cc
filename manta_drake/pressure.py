"""The pressure (depth) sensor on the robot's head."""

import numpy as np
from pydrake.systems.framework import LeafSystem


class PressureSensor(LeafSystem):
    """Depth of a point on the robot below the water surface, sampled with noise.

    .. pydrake_system::

        name: PressureSensor
        input_ports:
        - body_poses
        output_ports:
        - depth

    * ``body_poses``: the plant's body poses.
    * ``depth`` (1): h = -z of the sensor point in the world [m] (positive below the
      surface z = 0) plus Gaussian noise, or NaN for a dropped reading; a discrete
      state sampled every ``period`` seconds and held in between.

    The noise and dropout of sample k come from ``numpy.random.default_rng([seed, k])``
    (k is part of the discrete state), so a run is reproducible from its scenario and
    the system holds no mutable random state of its own.
    """

    def __init__(self, plant, body, p_BS, period: float, noise_std: float = 0.0,
                 dropout_rate: float = 0.0, seed: int = 0):
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
        self._seed = int(seed)
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate())
        self._state = self.DeclareDiscreteState([np.nan, 0.0])  # depth, sample index k
        self.DeclareVectorOutputPort(
            "depth", 1, lambda c, o: o.SetAtIndex(0, c.get_discrete_state(self._state)[0]),
            prerequisites_of_calc={self.xd_ticket()})
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
        self.DeclareInitializationDiscreteUpdateEvent(self._reset)

    def true_depth(self, context) -> float:
        """The noiseless depth of the sensor point [m]."""
        X_WB = self._poses.Eval(context)[self.body_index]
        return -float((X_WB @ self.p_BS)[2])

    def _reset(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            [self.true_depth(context), 0.0])

    def _sample(self, context, discrete_state):
        k = int(context.get_discrete_state(self._state)[1])
        rng = np.random.default_rng([self._seed, k])
        noise = rng.normal(0.0, self.noise_std)
        dropped = rng.uniform() < self.dropout_rate
        h = np.nan if dropped else self.true_depth(context) + noise
        discrete_state.get_mutable_vector(self._state).SetFromVector([h, k + 1.0])
