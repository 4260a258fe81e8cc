"""The servos at the battery's voltage: the supply feed-forward against the firmware's law
at that voltage, and ServoSupply's ports."""

import numpy as np
import pytest

from manta_drake.model import servo as S
from manta_drake.model.actuators import load_energy_model
from manta_drake.station.servo_supply import ServoSupply, supply_feed_forward_kernel

SERVO = load_energy_model("package://manta_drake/actuators.yaml").servo
V_R = 16.4116


def test_saturation_angle_is_the_duty_limit_over_the_gain():
    assert S.saturation_angle(SERVO) == pytest.approx(np.radians(12.4), abs=np.radians(0.05))
    assert S.saturation_angle(SERVO) * S.duty_per_radian(SERVO) == pytest.approx(S.max_duty(SERVO))


@pytest.mark.parametrize("volts", [16.4116, 14.8, 12.0, 11.1])
def test_the_pd_at_the_reference_plus_the_feed_forward_is_the_firmware_at_the_voltage(volts):
    """kp_r e + u_ff (the PD's part at the step's start, q_next = q) equals the firmware's
    duty at V, tau_s(V) clip(K_d e, +-d_max) (``servo_torque`` without braking), inside and
    beyond the saturation, for a joint at rest."""
    kp_r = S.joint_gains(SERVO, V_R)[0]
    theta = S.saturation_angle(SERVO)
    e = np.linspace(-1.0, 1.0, 401)
    u_ff = S.supply_feed_forward(e, 0.0, 0.0, volts, kp_r, theta, V_R, 1e-3)
    firmware = S.stall_torque(SERVO, volts) * np.clip(
        S.duty_per_radian(SERVO) * e, -S.max_duty(SERVO), S.max_duty(SERVO)
    )
    np.testing.assert_allclose(kp_r * e + u_ff, firmware, rtol=0, atol=1e-12)
    np.testing.assert_allclose(firmware, S.servo_torque(e, 0.0, 0.0, SERVO, volts), atol=1e-12)
    # At the reference voltage only the saturation is fed forward.
    if volts == V_R:
        assert np.all(u_ff[np.abs(e) <= theta] == 0.0)


def test_a_saturated_servo_gets_the_implicit_steps_braking_back():
    """Beyond the saturation the implicit PD's kp_r (q_next - q) would brake a moving joint
    by kp_r dt qdot_next; the feed-forward returns kp_r dt qdot: with qdot_next = qdot the
    torque is the full-duty torque less the back-EMF's b qdot, the torque-speed line."""
    kp_r, _, b = S.joint_gains(SERVO, V_R)
    dt, qdot = 1e-3, 6.0
    tau = S.supplied_torque(1.0, 0.0, qdot, dt * qdot, qdot, SERVO, 14.8, V_R, dt)
    line = S.stall_torque(SERVO, 14.8) * S.max_duty(SERVO) - b * qdot
    assert tau == pytest.approx(line, rel=1e-12)
    # Inside the saturation the step's own kp_r dt qdot_next stays (the P term at the end).
    e = 0.1
    inside = S.supplied_torque(e, 0.0, qdot, dt * qdot, qdot, SERVO, 14.8, V_R, dt)
    assert inside == pytest.approx(
        S.joint_gains(SERVO, 14.8)[0] * e - kp_r * dt * qdot - b * qdot, rel=1e-12
    )


def test_servo_supply_ports_give_the_feed_forward():
    kp_r, theta = S.joint_gains(SERVO, V_R)[0], S.saturation_angle(SERVO)
    system = ServoSupply(3, kp_r, theta, V_R, 1e-3)
    context = system.CreateDefaultContext()
    goal = np.array([0.5, -0.1, 0.0, 9.0, 9.0, 9.0])  # the goal's rates are not read
    state = np.array([0.0, 0.0, 0.1, 2.0, -1.0, 0.5])
    system.GetInputPort("servo_goal").FixValue(context, goal)
    system.GetInputPort("joint_state").FixValue(context, state)
    system.GetInputPort("battery").FixValue(context, [0.8, 15.2, 3.0])
    got = system.GetOutputPort("feed_forward").Eval(context)
    expected = S.supply_feed_forward(goal[:3], state[:3], state[3:], 15.2, kp_r, theta, V_R, 1e-3)
    np.testing.assert_allclose(got, expected, rtol=0, atol=0)
    # By hand: joint 0 saturated (0.5 rad), joint 1 inside (-0.1), joint 2 inside (-0.1).
    s = 1 - 15.2 / V_R
    np.testing.assert_allclose(
        got,
        [kp_r * (-(0.5 - theta) - s * theta + 1e-3 * 2.0), kp_r * (s * 0.1), kp_r * (s * 0.1)],
        rtol=1e-12,
    )
    with pytest.raises(ValueError, match="ServoSupply.reference_voltage: 0.0"):
        ServoSupply(3, kp_r, theta, 0.0, 1e-3)


def test_the_kernel_equals_the_numpy_reference():
    rng = np.random.default_rng(5)
    kp_r, theta = S.joint_gains(SERVO, V_R)[0], S.saturation_angle(SERVO)
    out = np.empty(16)
    for _ in range(50):
        goal, state = rng.uniform(-1, 1, 32), rng.uniform(-1, 1, 32)
        state[16:] = rng.normal(scale=5.0, size=16)
        volts = rng.uniform(11.0, 17.0)
        supply_feed_forward_kernel(goal, state, volts, kp_r, theta, V_R, 1e-3, out)
        expected = S.supply_feed_forward(
            goal[:16], state[:16], state[16:], volts, kp_r, theta, V_R, 1e-3
        )
        assert np.abs(goal[:16] - state[:16]).max() > theta  # both zones are exercised
        np.testing.assert_allclose(out, expected, rtol=1e-13, atol=1e-13)
