"""The balloon variable buoyancy system (BVBS, section 2.1, Fig. 1e)."""

import numpy as np
from pydrake.systems.framework import LeafSystem


def pump_step(
    volume: float, command: float, max_volume: float, pump_rate: float, dt: float
) -> float:
    """One step of the pump: move toward ``command`` by at most ``pump_rate * dt``,
    staying inside [0, max_volume]. A NaN command holds the volume."""
    if not np.isfinite(command):
        return volume
    target = min(max(command, 0.0), max_volume)
    step = pump_rate * dt
    return float(volume + np.clip(target - volume, -step, step))


class BalloonBuoyancy(LeafSystem):
    """Balloon volume with a pump-rate-limited inflation/deflation toward a command.

    .. pydrake_system::

        name: BalloonBuoyancy
        input_ports:
        - volume_command
        output_ports:
        - balloon_volume

    * ``volume_command`` (1): wanted balloon volume [m^3] (clipped to [0, max_volume]).
    * ``balloon_volume`` (1): the balloon's volume [m^3]; a discrete state updated every
      ``period`` seconds, so the output depends on the state only.
    """

    def __init__(
        self, max_volume: float, pump_rate: float, period: float, initial_volume: float = 0.0
    ):
        super().__init__()
        for name, value in (
            ("max_volume", max_volume),
            ("pump_rate", pump_rate),
            ("period", period),
        ):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"BalloonBuoyancy.{name}: {value} must be a finite number > 0")
        if not 0 <= initial_volume <= max_volume:
            raise ValueError(
                f"BalloonBuoyancy.initial_volume: {initial_volume} is outside "
                f"[0, max_volume = {max_volume}]"
            )
        self.max_volume, self.pump_rate, self.period = max_volume, pump_rate, period
        self._state = self.DeclareDiscreteState([initial_volume])
        self._command = self.DeclareVectorInputPort("volume_command", 1)
        self.DeclareStateOutputPort("balloon_volume", self._state)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state):
        volume = context.get_discrete_state(self._state).GetAtIndex(0)
        command = self._command.Eval(context)[0]
        discrete_state.get_mutable_vector(self._state).SetAtIndex(
            0, pump_step(volume, command, self.max_volume, self.pump_rate, self.period)
        )

    def set_volume(self, context, volume: float) -> None:
        """Sets the balloon's volume in this system's context."""
        if not 0 <= volume <= self.max_volume:
            raise ValueError(
                f"BalloonBuoyancy.set_volume: {volume} is outside [0, {self.max_volume}]"
            )
        context.get_mutable_discrete_state(self._state).SetAtIndex(0, volume)
