"""The joint servo in its firmware's position mode: the torque the plant applies.

A DYNAMIXEL X-series servo (``models/actuators.yaml``: the XW540-T140) closes its own
position loop: its PID turns the position error in encoder pulses into a PWM duty, Goal PWM
limits it, and its H-bridge applies duty x V to the motor (ROBOTIS e-Manual, X-series
"Position PID Gain": K_PP = Position P Gain / 128, I and D gains 0 by default). The motor
(torque constant k_t, terminal resistance R, gear ratio N, gearbox efficiency eta) turns that
voltage into the joint torque

    tau = (k_t N eta / R) (d V - k_t N qdot) = tau_s(V) d - b qdot,
    d   = clip(K_d (q_goal - q), -d_max, d_max),

with

    tau_s(V) = k_t N eta V / R           the stall torque at the bus voltage V,
    b        = (k_t N)^2 eta / R          the back-EMF braking (no-load speed tau_s / b
                                          = V / (k_t N)),
    K_d      = K_PP n_enc / (2 pi) u_pwm  duty per radian of error (n_enc pulses per turn,
                                          u_pwm duty per PWM unit),
    d_max    = PWM limit x u_pwm          (885 x 0.113 % = 100 %).

So the torque-speed line of the datasheet (stall torque at rest, zero torque at the no-load
speed) and the braking of a back-driven joint (up to tau_s d_max + b |qdot|) are the motor's
own, at any speed. The plant applies the saturated term as Drake's implicit PD (kp = tau_s
K_d, kd = 0, effort limit tau_s d_max) and the back-EMF term as the joint's damping, both
implicit in the discrete step, so the loop is stable at the 1 ms step however light the link.

The closed forms the tests hold it to: at 14.8 V tau_s = 8.30 N m and tau_s / b = 9.22 rad/s
(datasheet: 8.3 N m and 88 rev/min = 9.2 rad/s), at 12 V 6.73 N m (datasheet 6.9); K_d =
4.60 /rad at the control table's 800, so the duty saturates 12.4 deg from the goal.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import overload

import numpy as np

from manta_drake.model.actuators import ServoConstants

# A scenario's ``actuators.servo_model``: the plant's PD with RobotParams' chosen gains, or
# this module's servo.
SERVO_MODELS = ("ideal", "datasheet")


@overload
def stall_torque(servo: ServoConstants, voltage: float) -> float: ...
@overload
def stall_torque(servo: ServoConstants, voltage: np.ndarray) -> np.ndarray: ...
def stall_torque(servo: ServoConstants, voltage: float | np.ndarray) -> float | np.ndarray:
    """tau_s = k_t N eta V / R [N m] at the bus voltage ``voltage`` [V] (an array of
    voltages: element-wise)."""
    return (
        servo.torque_constant
        * servo.gear_ratio
        * servo.gearbox_efficiency
        * voltage
        / servo.winding_resistance
    )


def back_emf_damping(servo: ServoConstants) -> float:
    """b = (k_t N)^2 eta / R [N m s/rad]: the motor's braking per joint rate."""
    k_n = servo.torque_constant * servo.gear_ratio
    return k_n * k_n * servo.gearbox_efficiency / servo.winding_resistance


def no_load_speed(servo: ServoConstants, voltage: float) -> float:
    """V / (k_t N) [rad/s]: where the torque-speed line reaches zero torque at full duty."""
    return voltage / (servo.torque_constant * servo.gear_ratio)


def duty_per_radian(servo: ServoConstants) -> float:
    """K_d = (Position P Gain / 128) n_enc / (2 pi) u_pwm [1/rad]."""
    return (
        servo.position_p_gain / 128.0 * servo.encoder_resolution / (2.0 * math.pi) * servo.pwm_unit
    )


def max_duty(servo: ServoConstants) -> float:
    """d_max = PWM limit x duty per unit (at most 1)."""
    return min(servo.pwm_limit * servo.pwm_unit, 1.0)


def joint_gains(servo: ServoConstants, voltage: float) -> tuple[float, float, float]:
    """(kp [N m/rad], effort limit [N m], back-EMF damping [N m s/rad]) of the plant's
    implicit PD and joint damping that apply ``tau`` (module docstring) at ``voltage``."""
    tau_s = stall_torque(servo, voltage)
    return tau_s * duty_per_radian(servo), tau_s * max_duty(servo), back_emf_damping(servo)


def saturation_angle(servo: ServoConstants) -> float:
    """theta_sat = d_max / K_d [rad]: the position error at which the duty saturates, the
    same at any bus voltage (12.4 deg at the control table's defaults)."""
    return max_duty(servo) / duty_per_radian(servo)


def supply_scale(voltage, reference_voltage: float):
    """1 - V / V_ref: the share of the torque of a loop set at ``reference_voltage`` that the
    bus voltage ``voltage`` does not deliver (negative above the reference)."""
    return 1.0 - np.asarray(voltage, dtype=float) / reference_voltage


def supply_feed_forward(
    q_goal,
    q,
    qdot,
    voltage,
    kp_reference: float,
    saturation: float,
    reference_voltage: float,
    time_step: float,
) -> np.ndarray:
    """The feed-forward [N m] that turns the plant's PD, set at ``reference_voltage`` V_r
    with gain kp_r, into the servo's loop at the bus ``voltage`` V (element-wise):

        u_ff = -kp_r [(e - sat(e)) + (1 - V / V_r) sat(e)] + [abs(e) > theta_sat] kp_r dt qdot,

    e = q_goal - q, sat = clip(., +-theta_sat), theta_sat = ``saturation``, dt =
    ``time_step`` (``station.servo_supply`` explains each term)."""
    e = np.asarray(q_goal, dtype=float) - np.asarray(q, dtype=float)
    sat = np.clip(e, -saturation, saturation)
    return kp_reference * (
        -(e - sat)
        - supply_scale(voltage, reference_voltage) * sat
        + (np.abs(e) > saturation) * time_step * np.asarray(qdot, dtype=float)
    )


def supplied_torque(
    q_goal,
    q,
    qdot,
    q_next,
    qdot_next,
    servo: ServoConstants,
    voltage: float,
    reference_voltage: float,
    time_step: float,
) -> np.ndarray:
    """The torque the station's servo loop applies over one plant step [N m]: the plant's
    implicit PD, set at ``reference_voltage``, at the step's end state, plus
    ``supply_feed_forward``, within the effort limit, less the back-EMF braking:

        u = clip(kp_r (q_goal - q_next) + u_ff, +-L_r) - b qdot_next,

    kp_r and L_r the gains at V_r: the firmware's duty at V (``servo_torque``), up to the
    implicit step's kp_r dt terms."""
    kp, limit, b = joint_gains(servo, reference_voltage)
    u_ff = supply_feed_forward(
        q_goal, q, qdot, voltage, kp, saturation_angle(servo), reference_voltage, time_step
    )
    pd = kp * (np.asarray(q_goal, dtype=float) - np.asarray(q_next, dtype=float))
    return np.clip(pd + u_ff, -limit, limit) - b * np.asarray(qdot_next, dtype=float)


def servo_torque(q_goal, q, qdot, servo: ServoConstants, voltage: float) -> np.ndarray:
    """tau = tau_s clip(K_d (q_goal - q), -d_max, d_max) - b qdot [N m], element-wise."""
    kp, limit, b = joint_gains(servo, voltage)
    error = np.asarray(q_goal, dtype=float) - np.asarray(q, dtype=float)
    return np.clip(kp * error, -limit, limit) - b * np.asarray(qdot, dtype=float)


def envelope_ratio(tau, qdot, servo: ServoConstants, voltage: float | np.ndarray) -> np.ndarray:
    """|tau + b qdot| / (tau_s d_max): the duty a torque ``tau`` at joint rate ``qdot``
    needs, over the most the servo has; above 1 it is outside the torque-speed envelope
    (element-wise; ``voltage`` an array broadcasts against ``tau``: a bus voltage per
    sample). ``joint_gains``' effort limit and damping."""
    limit = stall_torque(servo, voltage) * max_duty(servo)
    b = back_emf_damping(servo)
    return np.abs(np.asarray(tau, dtype=float) + b * np.asarray(qdot, dtype=float)) / limit


def servo_robot_params(params, servo: ServoConstants, voltage: float | None = None):
    """``params`` (a RobotParams) with the plant's joint gains, effort limit and damping of
    ``servo`` at ``voltage`` (None: its ``supply_voltage``): kp = tau_s K_d, kd = 0 (no D or
    velocity feed-forward in the firmware's defaults), the effort limit tau_s d_max, and the
    back-EMF braking b added to the gear train's own viscous friction. The station sets
    them at the bus's highest voltage and scales them down to the battery's
    (``supplied_torque``)."""
    kp, limit, b = joint_gains(servo, servo.supply_voltage if voltage is None else voltage)
    return dc.replace(
        params, kp=kp, kd=0.0, effort_limit=limit, joint_damping=params.joint_damping + b
    )
