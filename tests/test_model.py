"""The SDFormat robot and pool: Table 1, joint set-up, strict parsing, generated files."""

import pathlib
import subprocess
import sys

import numpy as np
import pytest
from pydrake.geometry import Role, Shape
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import RevoluteJoint

from manta_drake.model import MODELS_DIR
from manta_drake.model.model_sdf import pool_sdf, robot_sdf
from manta_drake.model.plant import add_plant, make_parser
from manta_drake.model.robot_params import DEFAULT_ROBOT, JOINT_NAMES


def test_generated_models_are_up_to_date():
    assert (MODELS_DIR / "manta.sdf").read_text() == robot_sdf()
    assert (MODELS_DIR / "pool.sdf").read_text() == pool_sdf()


@pytest.mark.parametrize("name", ["manta.sdf", "pool.sdf"])
def test_models_parse_without_warnings(name):
    plant = MultibodyPlant(1e-3)
    parser = make_parser(plant)
    parser.SetStrictParsing()  # warnings become errors
    parser.AddModels(url=f"package://manta_drake/{name}")
    plant.Finalize()


def test_bodies_joints_and_total_mass(robot_plant):
    _, h = robot_plant
    plant = h.plant
    bodies = plant.GetBodyIndices(h.robot)
    assert len(bodies) == 17
    joints = [plant.get_joint(i) for i in plant.GetJointIndices(h.robot)]
    revolute = [j.name() for j in joints if isinstance(j, RevoluteJoint)]
    assert sorted(revolute) == sorted(JOINT_NAMES)
    mass = plant.CalcTotalMass(plant.CreateDefaultContext(), [h.robot])
    assert mass == pytest.approx(8.4, rel=0.01)
    assert DEFAULT_ROBOT.total_mass == pytest.approx(mass, rel=1e-12)


def _aabb_in_world(shape: Shape, X_WG) -> tuple:
    """Independent AABB of a box, ellipsoid or sphere posed at X_WG."""
    R, p = X_WG.rotation().matrix(), X_WG.translation()
    kind = type(shape).__name__
    if kind == "Box":
        half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
        ext = np.abs(R) @ half
    elif kind == "Ellipsoid":
        A = np.diag([shape.a(), shape.b(), shape.c()])
        ext = np.sqrt(np.diag(R @ A @ A @ R.T))
    elif kind == "Sphere":
        ext = np.full(3, shape.radius())
    else:
        raise AssertionError(f"unexpected shape {kind}")
    return p - ext, p + ext


def test_zero_pose_bounding_box_matches_table1(robot_plant):
    diagram, h = robot_plant
    context = diagram.CreateDefaultContext()
    plant_context = h.plant.GetMyContextFromRoot(context)
    query = h.plant.get_geometry_query_input_port().Eval(plant_context)
    inspector = query.inspector()
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    n = 0
    for body_index in h.plant.GetBodyIndices(h.robot):
        frame_id = h.plant.GetBodyFrameIdOrThrow(body_index)
        for gid in inspector.GetGeometries(frame_id, Role.kIllustration):
            a, b = _aabb_in_world(inspector.GetShape(gid), query.GetPoseInWorld(gid))
            lo, hi = np.minimum(lo, a), np.maximum(hi, b)
            n += 1
    assert n > 17
    size = hi - lo
    for measured, table, axis in zip(size, (0.38, 0.85, 0.14), "LWH"):
        assert measured == pytest.approx(table, rel=0.10), f"{axis}: {measured:.3f} m vs {table} m"


def test_every_joint_has_limits_effort_and_gains(robot_plant):
    _, h = robot_plant
    plant = h.plant
    for name in JOINT_NAMES:
        joint = plant.GetJointByName(name, h.robot)
        lo, hi = joint.position_lower_limits()[0], joint.position_upper_limits()[0]
        assert -np.pi < lo < 0 < hi < np.pi, name
        assert joint.velocity_upper_limits()[0] == pytest.approx(DEFAULT_ROBOT.velocity_limit)
    for index in plant.GetJointActuatorIndices(h.robot):
        actuator = plant.get_joint_actuator(index)
        assert actuator.effort_limit() == pytest.approx(DEFAULT_ROBOT.effort_limit)
        assert actuator.has_controller()
        gains = actuator.get_controller_gains()
        assert gains.p == pytest.approx(DEFAULT_ROBOT.kp)
        assert gains.d == pytest.approx(DEFAULT_ROBOT.kd)


def test_collision_geometry_on_body_and_distal_links(robot_plant):
    _, h = robot_plant
    plant = h.plant
    for name in ["body"] + [f"{leg}_link4" for leg in ("fl", "fr", "rl", "rr")]:
        body = plant.GetBodyByName(name, h.robot)
        assert len(plant.GetCollisionGeometriesForBody(body)) >= 1, name


def test_camera_frame_looks_forward(robot_plant):
    diagram, h = robot_plant
    context = h.plant.CreateDefaultContext()
    X_BC = h.plant.GetFrameByName("camera", h.robot).CalcPose(context, h.body.body_frame())
    optical_axis = X_BC.rotation().matrix()[:, 2]  # Drake cameras look along +z
    assert optical_axis[0] > 0.95  # forward, slightly down
    assert optical_axis[2] < 0
    assert X_BC.translation()[0] == pytest.approx(DEFAULT_ROBOT.body_semi_axes[0])


def test_pool_geometry(robot_plant):
    diagram, h = robot_plant
    context = diagram.CreateDefaultContext()
    query = h.plant.get_geometry_query_input_port().Eval(h.plant.GetMyContextFromRoot(context))
    inspector = query.inspector()
    frame_id = h.plant.GetBodyFrameIdOrThrow(h.plant.GetBodyByName("pool").index())
    boxes = {
        inspector.GetName(g).split("::")[-1]: _aabb_in_world(
            inspector.GetShape(g), query.GetPoseInWorld(g)
        )
        for g in inspector.GetGeometries(frame_id, Role.kProximity)
    }
    assert boxes["floor"][1][2] == pytest.approx(-0.5)
    assert boxes["wall_east"][0][0] == pytest.approx(7.5)
    assert boxes["wall_west"][1][0] == pytest.approx(-7.5)
    assert boxes["wall_north"][0][1] == pytest.approx(1.0)
    assert boxes["wall_south"][1][1] == pytest.approx(-1.0)


def test_generate_models_check_mode():
    result = subprocess.run(
        [sys.executable, "scripts/generate_models.py", "--check"],
        cwd=pathlib.Path(__file__).resolve().parent.parent,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr


def test_hinge_added_inertia_slows_the_joint_as_i_link_plus_i_added():
    """A torque step on a fin's roll1 joint (body welded, no gravity): the first step's
    joint velocity is tau dt / (I_link + I_added + dt kd + dt^2 kp + dt d_joint), with
    I_link the outboard bodies' inertia about the joint axis computed independently from
    their spatial inertias, I_added the YAML's hinge added inertia (the implicit PD and the
    joint damping enter a discrete step implicitly)."""
    from pydrake.math import RigidTransform
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.coefficients import load_coefficients
    from manta_drake.model.robot_params import DEFAULT_ROBOT as P

    coeffs = load_coefficients()
    dt, tau = 1e-3, 0.5
    builder = DiagramBuilder()
    h = add_plant(builder, time_step=dt, with_pool=False, weld_body=RigidTransform(), hydro=coeffs)
    plant = h.plant
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
    diagram = builder.Build()
    joint = plant.GetJointByName("fl_roll1", h.robot)
    context = diagram.CreateDefaultContext()
    pc = plant.GetMyMutableContextFromRoot(context)
    plant.get_desired_state_input_port(h.robot).FixValue(pc, np.zeros(32))
    u = np.zeros(16)
    u[1] = tau  # fl_roll1 (actuator order = joint order)
    plant.get_actuation_input_port(h.robot).FixValue(pc, u)
    # I_link: the bodies outboard of the joint, about its axis through its origin.
    outboard = [plant.GetBodyByName(f"fl_link{i}", h.robot).index() for i in (2, 3, 4)]
    frame = joint.frame_on_child()
    M = plant.CalcSpatialInertia(pc, frame, outboard)
    axis = joint.revolute_axis()
    I_link = float(axis @ M.CalcRotationalInertia().CopyToFullMatrix3() @ axis)
    I_added = coeffs.fins.hinge_added_inertia.value[1]
    assert I_added > 2 * I_link  # the fin's water is most of what the servo moves
    simulator = Simulator(diagram, context)
    simulator.AdvanceTo(dt)
    v1 = joint.get_angular_rate(plant.GetMyContextFromRoot(simulator.get_context()))
    expected = tau * dt / (I_link + I_added + dt * P.kd + dt * dt * P.kp + dt * P.joint_damping)
    assert v1 == pytest.approx(expected, rel=0.02)
    without = tau * dt / (I_link + dt * P.kd + dt * dt * P.kp + dt * P.joint_damping)
    assert abs(v1 - without) > 0.5 * without  # what the unapplied inertia gave
