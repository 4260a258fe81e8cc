"""The station's ``joint_torque`` output: the torques the plant's actuators apply.

The joints are PD-controlled inside the plant (``<drake:controller_gains>``, driven by the
``desired_state`` input, through the servo bus by default). With the discrete SAP plant the
PD is implicit: the torque of the step from t_n to t_n+1 is

    u_n = clamp(Kp (q_a,n - q_n+1) + Kd (v_a,n - v_n+1) + u_ff,n, -effort, effort) - b v_n+1,

evaluated at the step's *end* state (q_n+1 = q_n + dt v_n+1), with q_a, v_a the command the
servos act on in that step, b the datasheet servo's back-EMF braking (0 for the ideal
PD), u_ff the datasheet servo's supply feed-forward (``model.servo.supply_feed_forward``
at the step's start state and the battery's logged terminal voltage; 0 for the ideal PD),
and logged at t_n+1 (the torque applied over the last step). The logged
``joint_torque`` must equal this law computed here from the logged joint state, the logged
desired state put through the bus's timing by hand, and the gains, effort limits and
damping read back from the finalized plant: a wrong port (e.g. the actuation input, without
the PD), a wrong joint order, a wrong bus delay or a wrong logging would break it. The
``stand`` runs saturate some joints as the robot lands (the clamp is exercised); the swim
run has water and oscillating joints.
"""

import numpy as np
import pytest

from manta_drake import simulate
from manta_drake.model.robot_params import NUM_JOINTS
from manta_drake.model.servo import (
    back_emf_damping,
    envelope_ratio,
    saturation_angle,
    supplied_torque,
    supply_feed_forward,
)
from manta_drake.scenario import load_scenario
from manta_drake.wiring.diagram import build_diagram, logger_data
from manta_drake.wiring.station import start_command


def _short_run(name: str, duration: float, servo_model: str = "datasheet", **overrides):
    scenario = load_scenario(name, overrides=overrides)
    scenario.visualization.meshcat = False
    scenario.duration = duration
    scenario.actuators.servo_model = servo_model
    diagram, handles = build_diagram(scenario)
    simulator = simulate.make_simulator(diagram, scenario)
    simulator.AdvanceTo(duration)
    context = simulator.get_context()
    log = simulate.extract_log(handles, context)
    _, desired = logger_data(handles.loggers["desired_state"], context)
    return scenario, handles, log, desired


def _actuator_parameters(handles):
    plant, robot = handles.plant, handles.plant_handles.robot
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(robot)]
    assert tuple(a.joint().name() for a in actuators) == tuple(handles.plant_handles.joint_names)
    assert all(a.has_controller() for a in actuators)
    kp = np.array([a.get_controller_gains().p for a in actuators])
    kd = np.array([a.get_controller_gains().d for a in actuators])
    effort = np.array([a.effort_limit() for a in actuators])
    damping = np.array([a.joint().default_damping() for a in actuators])
    return kp, kd, effort, damping


def _applied(scenario, t, desired):
    """The command each plant step from t_n acts on: the desired state, or through the bus
    the one written a period before the bus's last cycle strictly before t_n (the plant's
    step at a cycle's time reads the bus from before that cycle), the start stance until
    the first is taken up."""
    T = scenario.actuators.bus_period
    if T == 0.0:
        return desired
    dt = scenario.time_step
    last = np.floor((t - dt / 2) / T)  # the bus's last cycle strictly before t_n
    written = np.rint((last - 1) * T / dt).astype(int)  # its command's sample
    out = desired[np.clip(written, 0, None)].copy()
    out[last < 1] = start_command(scenario)
    return out


@pytest.fixture(
    scope="module",
    params=[
        ("stand", 0.3, "datasheet"),
        ("locomotion_swim", 0.5, "datasheet"),
        ("stand", 0.3, "ideal"),
    ],
    ids=["stand", "swim", "stand-ideal"],
)
def run(request):
    return _short_run(*request.param)


@pytest.mark.slow
def test_logged_with_its_own_times(run):
    scenario, _, log, _ = run
    assert log["joint_torque"].shape == (len(log["t"]), NUM_JOINTS)
    assert np.allclose(log["t_joint_torque"], log["t"], rtol=0, atol=1e-12)
    assert np.allclose(log["t_command"], log["t"], rtol=0, atol=1e-12)
    assert np.all(np.isfinite(log["joint_torque"]))


@pytest.mark.slow
def test_equals_the_implicit_pd_law(run):
    scenario, handles, log, desired = run
    kp, kd, effort, damping = _actuator_parameters(handles)
    datasheet = scenario.actuators.servo_model == "datasheet"
    b = back_emf_damping(scenario.energy_model().servo) if datasheet else 0.0
    assert np.all(kp > 0) and np.all(np.isfinite(effort))
    assert np.all(kd == 0) if datasheet else np.all(kd > 0)
    np.testing.assert_allclose(damping, scenario.robot_params().joint_damping)
    q, v, tau = log["joint_angles"], log["joint_velocities"], log["joint_torque"]
    applied = _applied(scenario, log["t"], desired)
    q_a, v_a = applied[:, :NUM_JOINTS], applied[:, NUM_JOINTS:]
    dt = scenario.time_step
    assert np.isclose(log["t"][1] - log["t"][0], dt)  # one log sample per plant step
    q_next = q[:-1] + dt * v[1:]
    assert np.allclose(q_next, q[1:], rtol=0, atol=1e-12)  # the plant's symplectic step
    u_ff = 0.0
    if datasheet:  # the battery's voltage at each step's start, as the servos saw it
        servo = scenario.energy_model().servo
        u_ff = supply_feed_forward(
            q_a[:-1],
            q[:-1],
            v[:-1],
            log["battery"][:-1, 1:2],
            kp,
            saturation_angle(servo),
            scenario.bus_reference_voltage(),
            dt,
        )
        assert np.ptp(log["battery"][:, 1]) > 0.0  # the bus voltage moves
        # The same law as model.servo's closed form of the loop.
        np.testing.assert_allclose(
            supplied_torque(
                q_a[:-1],
                q[:-1],
                v[:-1],
                q_next,
                v[1:],
                servo,
                log["battery"][:-1, 1:2],
                scenario.bus_reference_voltage(),
                dt,
            ),
            np.clip(kp * (q_a[:-1] - q_next) + u_ff, -effort, effort) - b * v[1:],
            rtol=0,
            atol=1e-12,
        )
    expected = (
        np.clip(kp * (q_a[:-1] - q_next) + kd * (v_a[:-1] - v[1:]) + u_ff, -effort, effort)
        - b * v[1:]
    )
    err = np.abs(tau[1:] - expected)
    assert err.max() < 1e-9, (err.max(), np.unravel_index(err.argmax(), err.shape))
    assert np.abs(tau + b * v).max() <= effort.max() + 1e-12
    # Not a tautology: the torques vary, and the same law at each step's start state (an
    # explicit PD) is a different signal.
    assert np.ptp(tau, axis=0).max() > 0.1
    explicit = (
        np.clip(kp * (q_a[:-1] - q[:-1]) + kd * (v_a[:-1] - v[:-1]), -effort, effort) - b * v[:-1]
    )
    assert np.abs(tau[1:] - explicit).max() > 0.01


@pytest.mark.slow
@pytest.mark.parametrize(
    "servo_model, pose",
    [
        ("ideal", {}),
        # A drop from 0.17 m above the stance, tilted 30 and 20 deg: the landing back-drives a
        # distal joint at twice the motor's no-load speed and saturates its duty.
        ("datasheet", {"initial_pose.xyz": [0.0, 0.0, -0.05], "initial_pose.rpy_deg": [30, 20, 0]}),
    ],
)
def test_stand_exercises_the_effort_limit(servo_model, pose):
    """The ideal PD reaches the plant's effort limit; the datasheet servo reaches full duty
    at the battery's voltage, tau_s(V) d_max (its supply feed-forward keeps it there, below
    the plant's limit at the full pack's voltage), exceeding it only by the implicit step's
    kp_r dt (qdot_next - qdot): 1 % in the landing's impacts."""
    scenario, handles, log, _ = _short_run("stand", 0.4, servo_model, **pose)
    _, _, effort, _ = _actuator_parameters(handles)
    if servo_model == "ideal":
        pd = log["joint_torque"][1:]
        assert (np.abs(pd) >= effort - 1e-9).any(), np.abs(pd).max()
        return
    servo = scenario.energy_model().servo
    ratio = envelope_ratio(
        log["joint_torque"][1:], log["joint_velocities"][1:], servo, log["battery"][:-1, 1:2]
    )
    assert 0.99 < ratio.max() <= 1.02, ratio.max()
    # The plant's own clamp (at the full pack's 16.41 V) never binds: the battery is below.
    pd = log["joint_torque"][1:] + back_emf_damping(servo) * log["joint_velocities"][1:]
    assert np.all(np.abs(pd) < effort - 1e-3), (np.abs(pd).max(), effort.min())
    assert log["battery"][:, 1].max() <= scenario.bus_reference_voltage()


@pytest.mark.slow
def test_standing_torques_balance_gravity_and_the_floor():
    """At rest on the floor (the ``stand`` scenario after 3 s), the joint rows of the
    equations of motion are static: the actuators' torques plus gravity's generalized
    forces (``CalcGravityGeneralizedForces``) plus the floor's (the plant's generalized
    contact forces) sum to ~0; gravity alone does not (the feet push on the floor)."""
    scenario = load_scenario("stand")
    scenario.visualization.meshcat = False
    scenario.duration = 3.0
    diagram, handles = build_diagram(scenario)
    simulator = simulate.make_simulator(diagram, scenario)
    simulator.AdvanceTo(scenario.duration)
    root = simulator.get_context()
    plant, robot = handles.plant, handles.plant_handles.robot
    plant_context = plant.GetMyContextFromRoot(root)
    assert np.abs(plant.GetVelocities(plant_context)).max() < 1e-2  # at rest
    tau = handles.station.GetOutputPort("joint_torque").Eval(
        handles.station.GetMyContextFromRoot(root)
    )
    joints = [plant.GetJointByName(n, robot) for n in handles.plant_handles.joint_names]
    v_index = np.array([j.velocity_start() for j in joints])
    gravity = plant.CalcGravityGeneralizedForces(plant_context)[v_index]
    # The contact port is per model instance: map the robot's velocities to the plant's.
    robot_v = plant.GetVelocitiesFromArray(robot, np.arange(plant.num_velocities(), dtype=float))
    position = {int(round(v)): k for k, v in enumerate(robot_v)}
    contact = plant.get_generalized_contact_forces_output_port(robot).Eval(plant_context)
    contact = contact[[position[i] for i in v_index]]
    assert np.abs(tau).max() > 0.3  # the joints carry load
    assert np.abs(tau + gravity + contact).max() < 1e-3
    assert np.abs(tau + gravity).max() > 0.3  # the floor's share is not negligible
