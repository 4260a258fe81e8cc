"""The joint servo in its firmware's position mode (manta_drake.model.servo): its closed
forms against the XW540-T140 datasheet, and the plant applying them (the torque-speed line
bounds a joint's slew; the ideal PD does not)."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from manta_drake import build_station, load_scenario
from manta_drake.model import servo as S
from manta_drake.model.actuators import load_energy_model
from manta_drake.model.robot_params import DEFAULT_ROBOT, JOINT_NAMES

RPM = 2.0 * math.pi / 60.0


@pytest.fixture(scope="module")
def servo():
    return load_energy_model("package://manta_drake/actuators.yaml").servo


@pytest.mark.parametrize(
    "volts, stall, no_load_rpm", [(14.8, 8.3, 88), (12.0, 6.9, 72), (11.1, 6.4, 67)]
)
def test_stall_torque_and_no_load_speed_match_the_datasheet(servo, volts, stall, no_load_rpm):
    # The model derives its constants from the 14.8 V point; the others are independent.
    assert S.stall_torque(servo, volts) == pytest.approx(stall, rel=0.035)
    assert S.no_load_speed(servo, volts) == pytest.approx(no_load_rpm * RPM, rel=0.02)
    # The torque-speed line's slope is the back-EMF braking, the same at every voltage.
    assert S.stall_torque(servo, volts) / S.no_load_speed(servo, volts) == pytest.approx(
        S.back_emf_damping(servo), rel=1e-12
    )


def test_duty_per_radian_is_the_control_tables_gain(servo):
    # K_PP = 800 / 128 PWM units per pulse, 4096 pulses per turn, 0.113 % per unit.
    assert S.duty_per_radian(servo) == pytest.approx(
        800 / 128 * 4096 / (2 * math.pi) * 0.00113, rel=1e-12
    )
    assert math.degrees(S.max_duty(servo) / S.duty_per_radian(servo)) == pytest.approx(
        12.44, abs=0.01
    )


def test_the_servo_torque_follows_the_torque_speed_line(servo):
    tau_s, w0 = S.stall_torque(servo, 14.8), S.no_load_speed(servo, 14.8)
    far = 1.0  # rad of error: full duty
    assert S.servo_torque(far, 0.0, 0.0, servo, 14.8) == pytest.approx(tau_s)
    assert S.servo_torque(far, 0.0, w0, servo, 14.8) == pytest.approx(0.0, abs=1e-12)
    assert S.servo_torque(far, 0.0, w0 / 2, servo, 14.8) == pytest.approx(tau_s / 2)
    # Back-driven against full duty it brakes with more than its stall torque.
    assert S.servo_torque(far, 0.0, -w0, servo, 14.8) == pytest.approx(2 * tau_s)
    # Small errors are linear: kp = tau_s K_d.
    kp = tau_s * S.duty_per_radian(servo)
    assert S.servo_torque(0.01, 0.0, 0.0, servo, 14.8) == pytest.approx(0.01 * kp)


def test_envelope_ratio_is_one_on_the_line_and_below_inside(servo):
    tau_s, w0 = S.stall_torque(servo, 14.8), S.no_load_speed(servo, 14.8)
    on_line = S.envelope_ratio([tau_s, 0.0, tau_s / 2, -tau_s], [0.0, w0, w0 / 2, 0.0], servo, 14.8)
    np.testing.assert_allclose(on_line, 1.0, rtol=1e-12)
    assert S.envelope_ratio(tau_s / 2, 0.0, servo, 14.8) == pytest.approx(0.5)
    # The ideal PD's 6 N m at 18 rad/s: the motor cannot push that fast.
    assert S.envelope_ratio(6.0, 18.0, servo, 14.8) > 2.5


def test_servo_robot_params_put_the_servo_in_the_plant(servo):
    p = S.servo_robot_params(DEFAULT_ROBOT, servo)
    kp, limit, b = S.joint_gains(servo, servo.supply_voltage)
    assert (p.kp, p.kd, p.effort_limit) == (kp, 0.0, limit)
    assert p.joint_damping == pytest.approx(DEFAULT_ROBOT.joint_damping + b)
    assert p.mounts == DEFAULT_ROBOT.mounts  # the geometry is untouched


def _slew(servo_model: str, step_rad: float = 0.8, initial_soc: float = 1.0):
    """A free-falling robot (no water, no floor contact within 0.15 s) whose front-left
    yaw joint is commanded ``step_rad`` from its start, the battery at ``initial_soc``:
    the peak joint rate over the slew, the logged torque's largest envelope ratio at the
    battery's terminal voltage, and the no-load speed at that voltage when the rate
    peaked."""
    s = load_scenario("stand")
    s.visualization.meshcat = False
    s.initial_pose.xyz = [0.0, 0.0, 0.0]  # 0.28 m above its stance: 0.15 s of free fall
    s.actuators.servo_model = servo_model
    s.actuators.bus_period = 0.0  # the servo's own response, not the bus's timing
    s.actuators.initial_soc = initial_soc
    station, handles = build_station(s.validate())
    plant = handles.plant
    simulator = Simulator(station)
    context = simulator.get_mutable_context()
    x0 = station.GetOutputPort("measured_joint_state").Eval(context).copy()
    goal = x0.copy()
    j = JOINT_NAMES.index("fl_yaw")
    goal[j] += step_rad
    goal[16:] = 0.0
    station.GetInputPort("desired_state").FixValue(context, goal)
    rates, ratios, volts = [], [], []
    servo = s.energy_model().servo
    for k in range(1, 151):
        volts.append(station.GetOutputPort("battery").Eval(context)[1])  # the step's bus
        simulator.AdvanceTo(0.001 * k)
        x = station.GetOutputPort("measured_joint_state").Eval(context)
        tau = station.GetOutputPort("joint_torque").Eval(context)
        rates.append(x[16 + j])
        ratios.append(S.envelope_ratio(tau[j], x[16 + j], servo, volts[-1]))
    results = plant.get_contact_results_output_port().Eval(plant.GetMyContextFromRoot(context))
    assert results.num_point_pair_contacts() + results.num_hydroelastic_contacts() == 0
    peak = int(np.argmax(rates))
    return rates[peak], max(ratios), S.no_load_speed(servo, volts[peak]), volts[peak]


@pytest.mark.parametrize("initial_soc", [1.0, 0.3])
def test_the_datasheet_servo_slews_at_its_no_load_speed_at_the_batterys_voltage(initial_soc):
    """The torque-speed line at the bus voltage caps the slew: the battery full (16.4 V
    open circuit) lets the joint run faster than the datasheet's 14.8 V point (9.2 rad/s),
    at 30 % charge (15.0 V) slower; each peak within 7 % below V / (k_t N) at the voltage
    the battery gave then, never above it."""
    peak, ratio, w0, volts = _slew("datasheet", initial_soc=initial_soc)
    assert 0.93 * w0 < peak <= w0 * (1 + 1e-6)
    assert ratio <= 1.0 + 1e-6
    assert (volts > 15.8) if initial_soc == 1.0 else (14.5 < volts < 15.3), volts


def test_the_ideal_pd_slews_past_what_the_motor_can():
    peak, ratio, w0, _ = _slew("ideal")
    assert peak > 1.5 * w0
    assert ratio > 1.5
