"""The LiPo battery: state of charge, terminal voltage and the current a load draws.

The pack is an open-circuit voltage behind a resistance (the Rint model):

    V = OCV(SoC) - R_int I,

with OCV(SoC) the per-cell table of ``models/actuators.yaml`` times the cells in series.
A load of power P draws the current solving P = V(I) I = OCV I - R_int I^2; of its two
roots the physical one is the smaller (the other sits beyond the maximum-power point
V = OCV / 2):

    I = (OCV - sqrt(OCV^2 - 4 R_int P)) / (2 R_int) = 2 P / (OCV + sqrt(OCV^2 - 4 R_int P)),

the second form exact for R_int = 0 (I = P / OCV) and free of cancellation. A negative P
(recovered work) gives a negative, charging current. Above the pack's maximum power
OCV^2 / (4 R_int) no current delivers P; the current is then the maximum-power point's
OCV / (2 R_int) (a real pack's protection would cut the load off first).

The state of charge integrates the current (coulomb counting) at a fixed period dt:

    SoC_{k+1} = SoC_k - I_k dt / (3600 Q),        Q the capacity [Ah],

kept within [0, 1].
"""

import math

import numpy as np
from pydrake.systems.framework import EventStatus, LeafSystem

from manta_drake.jit import njit
from manta_drake.model.actuators import PackConstants


def terminal_voltage(ocv, current, resistance: float):
    """The pack's terminal voltage [V]: OCV - R_int I."""
    return np.asarray(ocv, dtype=float) - resistance * np.asarray(current, dtype=float)


def current_from_power(power, ocv, resistance: float):
    """The current [A] a load of ``power`` [W] draws from a pack of open-circuit voltage
    ``ocv`` [V] and internal resistance ``resistance`` [ohm]: the physical root of
    P = (OCV - R I) I, or the maximum-power point's OCV / (2 R) above the pack's maximum
    power OCV^2 / (4 R). Element-wise; negative power charges (negative current)."""
    power, ocv = np.asarray(power, dtype=float), np.asarray(ocv, dtype=float)
    discriminant = ocv * ocv - 4.0 * resistance * power
    # OCV > 0 (the pack's table is positive), so the denominator is too.
    current = 2.0 * power / (ocv + np.sqrt(np.maximum(discriminant, 0.0)))
    if resistance > 0:
        current = np.where(discriminant < 0.0, ocv / (2.0 * resistance), current)
    return current


def state_of_charge_step(soc, current, dt: float, capacity_ah: float):
    """The state of charge after drawing ``current`` [A] for ``dt`` [s] from ``capacity_ah``:
    SoC - I dt / (3600 Q), within [0, 1]."""
    soc = np.asarray(soc, dtype=float) - np.asarray(current, dtype=float) * (
        dt / (3600.0 * capacity_ah)
    )
    return np.minimum(np.maximum(soc, 0.0), 1.0)


@njit(cache=True)
def battery_kernel(soc, power, soc_grid, pack_ocv, resistance):
    """(OCV, current) at ``soc`` for a load of ``power``: ``np.interp`` on the pack's table and
    ``current_from_power``, compiled (they run once per plant step); the tests hold it to the
    numpy reference."""
    ocv = np.interp(soc, soc_grid, pack_ocv)
    discriminant = ocv * ocv - 4.0 * resistance * power
    if discriminant < 0.0 and resistance > 0.0:
        return ocv, ocv / (2.0 * resistance)
    return ocv, 2.0 * power / (ocv + math.sqrt(max(discriminant, 0.0)))


class Battery(LeafSystem):
    """The battery pack: its state of charge, and the voltage and current of its last step.

    .. pydrake_system::

        name: Battery
        input_ports:
        - electrical_power
        output_ports:
        - battery

    * ``electrical_power`` (1) [W]: what the loads draw (held over each period).
    * ``battery`` (3): [state of charge (0-1), terminal voltage V = OCV(SoC) - R_int I [V],
      current I [A]] with I the physical root of P = V I (the module docstring): the
      state of charge now, the voltage and current over the last period (at the start:
      the open-circuit voltage and no current).

    The three are the system's discrete state, updated every ``period`` seconds (the plant's
    step, so no integrator step is added) from the power drawn at the period's start,
    P_k: (V_k, I_k) at SoC_k, then SoC_{k+1} = SoC_k - I_k period / (3600 Q), so the charge
    falls by exactly the sum of I dt. The output is that state (a state output port: its
    readers, the servos' supply among them at every step, cost no Python call). When the
    charge has reached ``pack.cutoff_soc`` and ``stop_at_cutoff`` is set, a publish event
    at the same period returns ``EventStatus.ReachedTermination``: the Simulator's
    ``AdvanceTo`` returns early, at the end of a whole step, with the reason in its status.
    (From a publish, not from the update: a termination returned by an update returns
    before the step is taken, and a caller that calls ``AdvanceTo`` again re-applies that
    time's updates of every system, the plant's included, at the same time; after a
    publish-time stop another ``AdvanceTo`` takes ordinary whole steps.)
    """

    def __init__(
        self,
        pack: PackConstants,
        period: float,
        initial_soc: float = 1.0,
        stop_at_cutoff: bool = True,
    ):
        super().__init__()
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"Battery.period: {period} must be a finite number > 0")
        if not (np.isfinite(pack.capacity_ah) and pack.capacity_ah > 0):
            raise ValueError(f"Battery.pack.capacity_ah: {pack.capacity_ah} must be > 0")
        if not (np.isfinite(pack.internal_resistance) and pack.internal_resistance >= 0):
            raise ValueError(
                f"Battery.pack.internal_resistance: {pack.internal_resistance} must be >= 0"
            )
        if not 0.0 <= initial_soc <= 1.0:
            raise ValueError(f"Battery.initial_soc: {initial_soc} is outside [0, 1]")
        self.pack, self.period = pack, float(period)
        self.stop_at_cutoff = bool(stop_at_cutoff)
        self._power = self.DeclareVectorInputPort("electrical_power", 1)
        self._state = self.DeclareDiscreteState(self._at_rest(float(initial_soc)))
        self._ocv_soc = np.asarray(pack.ocv_soc, dtype=float)
        self._ocv_pack = pack.cells_in_series * np.asarray(pack.ocv_cell_voltage, dtype=float)
        self._soc_per_coulomb = self.period / (3600.0 * pack.capacity_ah)
        self.DeclareStateOutputPort("battery", self._state)
        self.DeclarePeriodicDiscreteUpdateEvent(self.period, 0.0, self._update)
        if self.stop_at_cutoff:
            self.DeclarePeriodicPublishEvent(self.period, 0.0, self._check_cutoff)

    def _at_rest(self, soc: float) -> list:
        """The state at ``soc`` with no current drawn yet: [SoC, OCV(SoC), 0]."""
        return [soc, float(self.pack.open_circuit_voltage(soc)), 0.0]

    def _update(self, context, discrete_state):
        soc = context.get_discrete_state(self._state).GetAtIndex(0)
        r = self.pack.internal_resistance
        # np.interp holds the end values outside the table, as a clip to [0, 1] would.
        ocv, current = battery_kernel(
            soc, self._power.Eval(context)[0], self._ocv_soc, self._ocv_pack, r
        )
        # state_of_charge_step's arithmetic, in Python floats (the same operations in the
        # same order, so the same bits).
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            [min(max(soc - current * self._soc_per_coulomb, 0.0), 1.0), ocv - r * current, current]
        )

    def _check_cutoff(self, context):
        soc = context.get_discrete_state(self._state).GetAtIndex(0)
        if soc <= self.pack.cutoff_soc:
            return EventStatus.ReachedTermination(
                self,
                f"battery empty at t = {context.get_time():.3f} s: state of charge "
                f"{soc:.4f} <= cutoff_soc {self.pack.cutoff_soc:g}",
            )
        return EventStatus.Succeeded()

    def state_of_charge(self, context) -> float:
        """The state of charge in this system's context."""
        return context.get_discrete_state(self._state).GetAtIndex(0)

    def set_state_of_charge(self, context, soc: float) -> None:
        """Sets the state of charge in this system's context (no current drawn yet)."""
        if not 0.0 <= soc <= 1.0:
            raise ValueError(f"Battery.set_state_of_charge: {soc} is outside [0, 1]")
        context.get_mutable_discrete_state(self._state).SetFromVector(self._at_rest(float(soc)))
