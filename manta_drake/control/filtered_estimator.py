"""The estimators' shared base: chosen channels of one sensor, low-passed and held.

Every 0-1 estimator of a sensor (posture from the IMU, flow from the flow probe, energy
from the battery monitor, ...) does the same before its own
membership: it samples channels ``channels`` of its sensor input every ``period`` seconds
and filters each with the sampled first-order lag of ``memberships.low_pass_step``::

    y_{k+1} = y_k + alpha (x_k - y_k),   alpha = 1 - exp(-period / time_constant)

(angles on the circle where ``circular``), each channel starting at its first finite
sample and holding its value while the input is NaN or infinite (a dropout). A subclass
declares its outputs as functions of the filtered channels (``DeclareEstimateOutputPort``)
and nothing else, so the estimators differ only in what they compute from the filter.
"""

from collections.abc import Callable

import numpy as np
from pydrake.systems.framework import LeafSystem

from manta_drake.config_io import check_in_range
from manta_drake.control.memberships import lag_coefficient, low_pass_step


class FilteredEstimator(LeafSystem):
    """Low-passed channels of one sensor input, for a subclass's outputs to read.

    .. pydrake_system::

        name: FilteredEstimator
        input_ports:
        - <sensor>
        output_ports:
        - <the subclass's estimates>

    Discrete state (2n for n channels): the filtered channels and whether each has seen a
    finite reading (default: ``initial`` and unseeded). Updated every ``period`` seconds
    from t = 0 with ``alpha = 1 - exp(-period / time_constant)``; a channel starts at its
    first finite reading (an initialization event reads the input when a Simulator
    initializes, so a consumer's first update already sees it) and holds its value while
    its input is NaN or infinite. The outputs depend on the state only (no direct
    feedthrough).

    Args:
        sensor: the input port's name (the station's sensor port).
        size: the input's length.
        channels: the input's entries filtered, in the state's order.
        period: the update period [s], in (0, ``max_period``] (the sensor's sample period).
        time_constant: the lag's time constant [s] (0: no filter).
        initial: the filtered values before the first reading (default zeros).
        circular: which channels are angles [rad] (a boolean for all, or one per channel).
        max_period: the largest period allowed [s].

    Raises:
        ValueError: the period outside its range, naming the subclass.
    """

    def __init__(
        self,
        sensor: str,
        size: int,
        channels,
        period: float,
        time_constant: float,
        initial=None,
        circular=False,
        max_period: float = 1.0,
    ):
        super().__init__()
        name = type(self).__name__
        check_in_range(
            f"{name}.period", period, 0.0, max_period, f"(0, {max_period:g}] s", open_low=True
        )
        self.period = float(period)
        self._channels = np.asarray(channels, dtype=int)
        n = self._channels.size
        self._circular = np.broadcast_to(np.asarray(circular, dtype=bool), (n,)).copy()
        self._alpha = lag_coefficient(self.period, time_constant)
        start = np.zeros(n) if initial is None else np.asarray(initial, dtype=float)
        self._state = self.DeclareDiscreteState(np.concatenate([start, np.zeros(n)]))
        self._sensor = self.DeclareVectorInputPort(sensor, size)
        # Seeds the filter from the first reading when a Simulator initializes, before any
        # consumer's first update reads the estimate.
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._update)

    def filtered(self, context) -> np.ndarray:
        """The filtered channels (n,) in ``context``."""
        return context.get_discrete_state(self._state).get_value()[: self._channels.size]

    def DeclareEstimateOutputPort(self, name: str, size: int, calc: Callable[[np.ndarray], object]):
        """Declares output ``name`` (``size``) as ``calc(filtered channels)``."""

        def _calc(context, output):
            output.SetFromVector(
                np.reshape(np.asarray(calc(self.filtered(context)), dtype=float), size)
            )

        return self.DeclareVectorOutputPort(
            name, size, _calc, prerequisites_of_calc={self.xd_ticket()}
        )

    def _initialize(self, context, discrete_state):
        self._step(context, discrete_state, 0.0)  # seeds unseeded channels, moves no other

    def _update(self, context, discrete_state):
        self._step(context, discrete_state, self._alpha)

    def _step(self, context, discrete_state, alpha):
        n = self._channels.size
        x = context.get_discrete_state(self._state).get_value()
        sample = np.asarray(self._sensor.Eval(context), dtype=float)[self._channels]
        value, seeded = low_pass_step(x[:n], x[n:] > 0.5, sample, alpha, self._circular)
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            np.concatenate([value, seeded.astype(float)])
        )
