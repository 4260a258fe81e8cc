"""The station's ``joint_torque`` output: the torques the plant's actuators apply.

The joints are PD-controlled inside the plant (``<drake:controller_gains>``, driven by the
``desired_state`` input). With the discrete SAP plant the PD is implicit: the torque of
the step from t_n to t_n+1 is

    u_n = clamp(Kp (q_d,n - q_n+1) + Kd (v_d,n - v_n+1), -effort, effort),

evaluated at the step's *end* state (q_n+1 = q_n + dt v_n+1). The logged ``joint_torque``
must equal this law computed here from the logged joint state, the logged desired state
and the gains and effort limits read back from the finalized plant: a wrong port (e.g.
the actuation input, without the PD), a wrong joint order or a wrong logging would break
it. The ``stand`` run saturates some joints as the robot lands (the clamp is exercised);
the swim run has water and oscillating joints.
"""

import numpy as np
import pytest

from manta_drake import simulate
from manta_drake.wiring.diagram import build_diagram, logger_data
from manta_drake.model.robot_params import NUM_JOINTS
from manta_drake.scenario import load_scenario


def _short_run(name: str, duration: float):
    scenario = load_scenario(name)
    scenario.visualization.meshcat = False
    scenario.duration = duration
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
    return kp, kd, effort


@pytest.fixture(scope="module", params=[("stand", 0.3), ("locomotion_swim", 0.5)],
                ids=["stand", "swim"])
def run(request):
    return _short_run(*request.param)


def test_logged_with_its_own_times(run):
    scenario, _, log, _ = run
    assert log["joint_torque"].shape == (len(log["t"]), NUM_JOINTS)
    assert np.allclose(log["t_joint_torque"], log["t"], rtol=0, atol=1e-12)
    assert np.allclose(log["t_command"], log["t"], rtol=0, atol=1e-12)
    assert np.all(np.isfinite(log["joint_torque"]))


def test_equals_the_implicit_pd_law(run):
    scenario, handles, log, desired = run
    kp, kd, effort = _actuator_parameters(handles)
    assert np.all(kp > 0) and np.all(kd > 0) and np.all(np.isfinite(effort))
    q, v, tau = log["joint_angles"], log["joint_velocities"], log["joint_torque"]
    q_d, v_d = desired[:, :NUM_JOINTS], desired[:, NUM_JOINTS:]
    dt = scenario.time_step
    assert np.isclose(log["t"][1] - log["t"][0], dt)  # one log sample per plant step
    q_next = q[:-1] + dt * v[1:]
    assert np.allclose(q_next, q[1:], rtol=0, atol=1e-12)  # the plant's symplectic step
    expected = np.clip(kp * (q_d[:-1] - q_next) + kd * (v_d[:-1] - v[1:]), -effort, effort)
    err = np.abs(tau[:-1] - expected)
    assert err.max() < 1e-9, (err.max(), np.unravel_index(err.argmax(), err.shape))
    assert np.abs(tau).max() <= effort.max() + 1e-12
    # Not a tautology: the torques vary, and the PD at the logged (start-of-step) state
    # is a different signal.
    assert np.ptp(tau, axis=0).max() > 0.1
    explicit = np.clip(kp * (q_d - q) + kd * (v_d - v), -effort, effort)
    assert np.abs(tau - explicit).max() > 0.01


def test_stand_exercises_the_effort_limit():
    _, handles, log, _ = _short_run("stand", 0.15)
    _, _, effort = _actuator_parameters(handles)
    saturated = np.abs(log["joint_torque"]) >= effort - 1e-9
    assert saturated.any(), np.abs(log["joint_torque"]).max()


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
        handles.station.GetMyContextFromRoot(root))
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
