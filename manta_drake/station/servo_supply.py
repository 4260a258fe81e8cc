"""The servos' supply: their torque at the battery's terminal voltage.

A servo's stall torque is proportional to its bus voltage, tau_s(V) = k_t N eta V / R
(``model.servo``), and the bus is the battery: its terminal voltage sags with the charge and
the current. The plant's implicit PD holds the servo's loop at a fixed reference voltage
V_r (the pack's full-charge open-circuit voltage): kp_r = tau_s(V_r) K_d. This system adds
the feed-forward actuation that turns it into the loop at the present voltage V:

    u_ff = -kp_r [(e - sat(e)) + (1 - V / V_r) sat(e)] + [abs(e) > theta_sat] kp_r dt qdot,
    e = q_goal - q,   sat(e) = clip(e, -theta_sat, theta_sat),   theta_sat = d_max / K_d,

so the PD's torque kp_r (e - (q_next - q)) plus u_ff is

    tau_s(V) K_d sat(e) - kp_r (q_next - q)        inside theta_sat,
    tau_s(V) d_max sign(e) - kp_r dt (qdot_next - qdot)   beyond it,

the firmware's duty at the bus voltage (``model.servo.supplied_torque``; the plant's
effort limit tau_s(V_r) d_max is not reached while V <= V_r). The implicit step's
kp_r (q_next - q) = kp_r dt qdot_next acts as kp_r dt = 0.04 N m s/rad of extra damping;
in the linear zone it is the loop's own (its P term at the step's end), but a saturated
servo's torque does not depend on its position, so there the feed-forward gives it back
at the step's start rate (without it a free joint slews 4.5 % below the motor's no-load
speed). The implicit step keeps the stiff loop stable; the explicit feed-forward is at
most kp_r (1 - V/V_r) <= 0.35 kp_r of stiffness and kp_r dt of negative damping, against
the back-EMF's implicit b = 0.90 N m s/rad.

``model.servo.supply_feed_forward`` is the pure maths, ``supply_feed_forward_kernel`` its
compiled twin; ``ServoSupply`` the Drake system that feeds the kernel the servos' goal, the
joints' state and the battery.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from manta_drake.jit import njit


@njit(cache=True)
def supply_feed_forward_kernel(
    goal, state, voltage, kp_reference, saturation, reference_voltage, time_step, out
):
    """``model.servo.supply_feed_forward`` compiled, into ``out`` (n) from the servos' goal
    (2n) and the joints' state (2n): one loop instead of a dozen numpy calls on 16 values,
    once per plant step; the tests hold it to the numpy reference."""
    n = out.shape[0]
    scale = 1.0 - voltage / reference_voltage
    for j in range(n):
        e = goal[j] - state[j]
        sat = min(max(e, -saturation), saturation)
        u = -(e - sat) - scale * sat
        if abs(e) > saturation:
            u += time_step * state[n + j]
        out[j] = kp_reference * u


class ServoSupply(LeafSystem):
    """The feed-forward that puts the servos' loop at the battery's voltage.

    .. pydrake_system::

        name: ServoSupply
        input_ports:
        - servo_goal
        - joint_state
        - battery
        output_ports:
        - feed_forward

    ``servo_goal`` (2n): the [q, qdot] the servos act on (the bus's applied command);
    ``joint_state`` (2n): the joints' true [q, qdot]; ``battery`` (3): [state of charge,
    terminal voltage V, current] (``Battery``); ``feed_forward`` (n) [N m]: into the
    plant's actuation input. The output depends on the inputs only (no state).

    Args:
        num_joints: n.
        kp_reference: kp_r [N m/rad], the plant's PD gain (set at ``reference_voltage``).
        saturation: theta_sat [rad].
        reference_voltage: V_r [V] (> 0).
        time_step: dt [s], the plant's step.
    """

    def __init__(
        self,
        num_joints: int,
        kp_reference: float,
        saturation: float,
        reference_voltage: float,
        time_step: float,
    ):
        super().__init__()
        for name, value in (
            ("kp_reference", kp_reference),
            ("saturation", saturation),
            ("reference_voltage", reference_voltage),
            ("time_step", time_step),
        ):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"ServoSupply.{name}: {value} must be a finite number > 0")
        self.num_joints = int(num_joints)
        self.kp_reference, self.saturation = float(kp_reference), float(saturation)
        self.reference_voltage, self.time_step = float(reference_voltage), float(time_step)
        n = self.num_joints
        self._goal = self.DeclareVectorInputPort("servo_goal", 2 * n)
        self._state = self.DeclareVectorInputPort("joint_state", 2 * n)
        self._battery = self.DeclareVectorInputPort("battery", 3)
        self.DeclareVectorOutputPort("feed_forward", n, self._calc)

    def _calc(self, context, output: BasicVector):
        supply_feed_forward_kernel(
            self._goal.Eval(context),
            self._state.Eval(context),
            self._battery.Eval(context)[1],
            self.kp_reference,
            self.saturation,
            self.reference_voltage,
            self.time_step,
            output.get_mutable_value(),
        )
