"""The joint servos' electrical power: geared DC motors drawing from the battery.

Each joint is a DC motor of torque constant k_t (= its back-EMF constant in SI units)
and terminal resistance R behind a gearbox of ratio N and efficiency eta. For a joint
torque tau at joint rate qdot the motor's current is

    i = tau / (k_t N) eta^(2 b - 1),    b = clip(-sign(tau) qdot / qdot_b, 0, 1),

so i = tau / (k_t N eta) when the motor drives the load or holds it (b = 0) and
i = tau eta / (k_t N) when the load back-drives the motor at qdot_b (``backdrive_speed``)
or faster (b = 1): the gearbox loses the share 1 - eta of the power through it in either
direction, and between rest and qdot_b the gear train's static friction takes a linearly
falling share of a back-driving load (the sign of tau qdot alone would make a standing
robot's holding current jump by eta^-4 with the sign of its rest creep; qdot_b = 0 is that
sharp switch). The servo draws

    P = R i^2 + max(e i, 0) + I_standby V_supply,       e = k_t N qdot (the back-EMF),

the copper loss, the motor's share of the mechanical power (tau qdot / eta driving; the
negative share tau qdot eta of back-driven work is dissipated unless
``recover_negative_work``, when P may go below the standby draw and even below zero) and
the servo's electronics. The robot's total adds the computers' constant draw.

The closed forms the tests hold it to: at zero speed (stall, or holding a torque)
P = R (tau / (k_t N eta))^2 + standby; at zero torque (a dry joint, no load) P = standby;
and the voltage the driver must apply, R i + e, equals the supply at the datasheet's
stall torque (qdot = 0) and at its no-load speed (tau = 0).

The parameters (``models/actuators.yaml``) are those of the servo class chosen for the plant's
limits; the paper names no servo.
"""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from manta_drake.jit import njit
from manta_drake.model.actuators import ServoConstants


def back_driven_share(tau, qdot, servo: ServoConstants) -> np.ndarray:
    """b in [0, 1]: 0 while the motor drives or holds the load, 1 once the load back-drives
    the joint at ``backdrive_speed`` or faster (linear in between)."""
    tau, qdot = np.asarray(tau, dtype=float), np.asarray(qdot, dtype=float)
    against = -np.sign(tau) * qdot  # > 0: the joint moves against its torque
    if servo.backdrive_speed > 0:
        return np.clip(against / servo.backdrive_speed, 0.0, 1.0)
    return (against > 0).astype(float)


def motor_current(tau, qdot, servo: ServoConstants) -> np.ndarray:
    """The motor current [A] (signed like ``tau``) for joint torques ``tau`` [N m] at joint
    rates ``qdot`` [rad/s]: tau / (k_t N) eta^(2 b - 1); element-wise over any shape."""
    tau = np.asarray(tau, dtype=float)
    # Holding (qdot = 0) counts as driving: the datasheet's stall torque per ampere is
    # k_t N eta, measured with the motor pushing against the load.
    b = back_driven_share(tau, qdot, servo)
    return (
        tau
        / (servo.torque_constant * servo.gear_ratio)
        * servo.gearbox_efficiency ** (2.0 * b - 1.0)
    )


def back_emf(qdot, servo: ServoConstants) -> np.ndarray:
    """The motor's back-EMF [V] at joint rates ``qdot``: k_t N qdot."""
    return servo.torque_constant * servo.gear_ratio * np.asarray(qdot, dtype=float)


def voltage_demand(tau, qdot, servo: ServoConstants) -> np.ndarray:
    """The voltage the servo's driver must apply to the motor [V]: R i + e. Where its
    magnitude exceeds ``supply_voltage`` the real servo cannot give ``tau`` at ``qdot``
    (the plant clamps torque and rate separately, not this envelope)."""
    return servo.winding_resistance * motor_current(tau, qdot, servo) + back_emf(qdot, servo)


def servo_power_terms(tau, qdot, servo: ServoConstants) -> dict[str, np.ndarray]:
    """Each servo's electrical power [W] by where it goes, element-wise over any shape:
    ``copper`` R i^2 (heat in the windings), ``shaft`` max(e i, 0) (converted to the motor
    shaft's work: the joint's tau qdot plus the gearbox's loss; e i without the max with
    ``recover_negative_work``) and ``standby`` I_standby V_supply (the servo's electronics)."""
    i = motor_current(tau, qdot, servo)
    shaft = back_emf(qdot, servo) * i
    if not servo.recover_negative_work:
        shaft = np.maximum(shaft, 0.0)
    return {
        "copper": servo.winding_resistance * i * i,
        "shaft": shaft,
        "standby": np.full(np.shape(i), servo.standby_power),
    }


def servo_electrical_power(tau, qdot, servo: ServoConstants) -> np.ndarray:
    """Each servo's electrical power [W]: R i^2 + max(e i, 0) + standby (the max dropped with
    ``recover_negative_work``), the sum of ``servo_power_terms``; element-wise over any shape."""
    terms = servo_power_terms(tau, qdot, servo)
    return terms["copper"] + terms["shaft"] + terms["standby"]


def joint_mechanical_power(tau, qdot) -> np.ndarray:
    """The power each actuator delivers to its joint [W]: tau qdot (negative: the joint
    does work on the actuator)."""
    return np.asarray(tau, dtype=float) * np.asarray(qdot, dtype=float)


def total_electrical_power(tau, qdot, servo: ServoConstants, electronics_power: float) -> float:
    """The robot's electrical power [W]: every servo's plus the computers' constant draw."""
    return float(np.sum(servo_electrical_power(tau, qdot, servo)) + electronics_power)


@njit(cache=True)
def total_electrical_power_kernel(
    tau,
    qdot,
    gear_ratio,
    efficiency,
    torque_constant,
    resistance,
    standby_power,
    recover,
    backdrive_speed,
    electronics_power,
):
    """``total_electrical_power`` compiled (one loop instead of a dozen numpy calls of ~1 us
    each, once per plant step); the tests hold it to the numpy reference."""
    k_n = torque_constant * gear_ratio
    total = 0.0
    for j in range(tau.shape[0]):
        t, w = tau[j], qdot[j]
        against = -np.sign(t) * w
        if backdrive_speed > 0.0:
            b = min(max(against / backdrive_speed, 0.0), 1.0)
        else:
            b = 1.0 if against > 0.0 else 0.0
        i = t / k_n * efficiency ** (2.0 * b - 1.0)
        conversion = k_n * w * i
        if not recover and conversion < 0.0:
            conversion = 0.0
        total += resistance * i * i + conversion + standby_power
    return total + electronics_power


class ServoPower(LeafSystem):
    """The electrical power the joint servos and the computers draw from the battery.

    .. pydrake_system::

        name: ServoPower
        input_ports:
        - joint_torque
        - measured_joint_state
        output_ports:
        - electrical_power
        - servo_power
        - joint_mechanical_power

    * ``joint_torque`` (n) [N m]: each actuator's torque over the step that ends at the
      current time, in the joint order of ``measured_joint_state``. (The plant's live
      net-actuation port reports the step *about to be taken*, whose torque is paired with
      the velocity at its end; the station's ``joint_torque`` holds it for one step, so
      that here torque and rate belong to the same step and tau qdot dt is exactly the
      step's work.)
    * ``measured_joint_state`` (2n): joint angles then joint rates [rad, rad/s].
    * ``electrical_power`` (1) [W]: sum over the servos of R i^2 + max(e i, 0) + I_standby
      V_supply (the module docstring), plus ``electronics_power``.
    * ``servo_power`` (n) [W]: each servo's share (standby included).
    * ``joint_mechanical_power`` (n) [W]: tau qdot per joint.

    No state; it applies no force (the plant's dynamics do not see it).
    """

    def __init__(self, servo: ServoConstants, electronics_power: float, num_joints: int):
        super().__init__()
        for name in ("gear_ratio", "torque_constant", "gearbox_efficiency", "supply_voltage"):
            value = getattr(servo, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"ServoPower.servo.{name}: {value} must be a finite number > 0")
        for name in ("winding_resistance", "standby_current", "backdrive_speed"):
            value = getattr(servo, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"ServoPower.servo.{name}: {value} must be a finite number >= 0")
        if servo.gearbox_efficiency > 1:
            raise ValueError(
                f"ServoPower.servo.gearbox_efficiency: {servo.gearbox_efficiency} must be <= 1"
            )
        if not (np.isfinite(electronics_power) and electronics_power >= 0):
            raise ValueError(
                f"ServoPower.electronics_power: {electronics_power} must be a finite number >= 0"
            )
        if int(num_joints) != num_joints or num_joints < 1:
            raise ValueError(f"ServoPower.num_joints: {num_joints} must be a whole number >= 1")
        self.servo, self.electronics_power = servo, float(electronics_power)
        self.num_joints = n = int(num_joints)
        self._torque = self.DeclareVectorInputPort("joint_torque", n)
        self._state = self.DeclareVectorInputPort("measured_joint_state", 2 * n)
        self.DeclareVectorOutputPort("electrical_power", 1, self._calc_total)
        self.DeclareVectorOutputPort("servo_power", n, self._calc_servos)
        self.DeclareVectorOutputPort("joint_mechanical_power", n, self._calc_mechanical)

    def _torque_and_rate(self, context) -> tuple[np.ndarray, np.ndarray]:
        return self._torque.Eval(context), self._state.Eval(context)[self.num_joints :]

    def _calc_total(self, context, output: BasicVector):
        tau, qdot = self._torque_and_rate(context)
        s = self.servo
        output.SetAtIndex(
            0,
            total_electrical_power_kernel(
                tau,
                qdot,
                s.gear_ratio,
                s.gearbox_efficiency,
                s.torque_constant,
                s.winding_resistance,
                s.standby_power,
                s.recover_negative_work,
                s.backdrive_speed,
                self.electronics_power,
            ),
        )

    def _calc_servos(self, context, output: BasicVector):
        output.SetFromVector(servo_electrical_power(*self._torque_and_rate(context), self.servo))

    def _calc_mechanical(self, context, output: BasicVector):
        output.SetFromVector(joint_mechanical_power(*self._torque_and_rate(context)))
