"""The MultibodyPlant: robot + pool in a DiagramBuilder.

A discrete plant (the scenario's time step, 1 ms by default) with SAP contact,
hydroelastic contact between the robot (rigid) and the pool's floor and walls
(compliant), and the
robot's implicit joint PD (``<drake:controller_gains>``) driven through the
plant's desired-state input port.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import RoleAssign, SceneGraph
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    ModelInstanceIndex,
    PlanarJoint,
    RigidBody,
    RotationalInertia,
    SpatialInertia,
)
from pydrake.systems.framework import DiagramBuilder

from manta_drake.config_io import Range
from manta_drake.model import package_map
from manta_drake.model.added_mass import (
    fin_plates,
    heave_body_inertia,
    plate_added_mass,
    split_added_inertia,
    split_added_mass,
    split_hull_added_mass,
)
from manta_drake.model.model_sdf import robot_sdf
from manta_drake.model.robot_params import DEFAULT_ROBOT, JOINT_NAMES, JOINTS_PER_LEG, LEGS

ROBOT_URL = "package://manta_drake/manta.sdf"
FIN_ADDED_MASS = ("hinge", "bodies")
FIN_ADDED_MASS_INSTANCE = "manta_fin_added_mass"
# The foot-floor Coulomb friction (static = dynamic): set_contact_friction's mu and the
# scenario's contact.friction. Above 2 no wet pair of materials grips.
FRICTION = Range(0.0, 2.0, open_low=True)
POOL_URL = "package://manta_drake/pool.sdf"


@dc.dataclass
class PlantHandles:
    """What the rest of the diagram needs from the plant."""

    plant: MultibodyPlant
    scene_graph: SceneGraph
    robot: ModelInstanceIndex
    pool: ModelInstanceIndex | None  # None: no pool
    body: RigidBody  # the robot's main body
    joint_names: tuple = JOINT_NAMES
    added_mass_iso: float = 0.0  # kg of isotropic hull added mass in the mass matrix


def make_parser(plant: MultibodyPlant) -> Parser:
    """A Parser that resolves ``package://manta_drake/`` (``models/package.xml``)."""
    parser = Parser(plant)
    parser.package_map().AddMap(package_map())
    return parser


def add_plant(
    builder: DiagramBuilder,
    time_step: float = 1e-3,
    discrete_contact_approximation: str = "sap",
    with_pool: bool = True,
    weld_body: RigidTransform | None = None,
    hydro=None,
    robot_params=None,
    fin_added_mass: str = "hinge",
) -> PlantHandles:
    """Adds the robot (and pool) to ``builder`` and finalizes the plant.

    Args:
        builder: the diagram builder.
        time_step: the plant's discrete period [s] (> 0).
        discrete_contact_approximation: ``sap`` (default) or ``lagged``, ...
        with_pool: add the pool (floor, walls) as well.
        weld_body: if given, weld the robot's body to the world at this pose
            (for tests that hold the robot in the air).
        hydro: HydroCoefficients. If given (the robot is in water), the added mass
            that belongs in the mass matrix is put there: the isotropic part of the
            hull's added mass and its added rotational inertia as a body welded to the
            hull at its centre of mass (model instance ``manta_added_mass``, so the
            robot's own mass stays 8.4 kg; HydrodynamicForces cancels its weight), and
            each fin's added inertia about its hinge as the actuator's rotor inertia.
        robot_params: RobotParams of another geometry than the shipped model's
            (``manta.sdf`` is ``DEFAULT_ROBOT``); its SDFormat is generated here.
        fin_added_mass: where the fins' added mass goes (with ``hydro``): ``"hinge"``, each
            fin's added inertia about its hinges at the zero pose as the actuators' rotor
            inertia (joint-diagonal: nothing of it reaches the hull); ``"bodies"``, a body
            per plate on a planar joint (``add_fin_added_mass_bodies``: its mass acts along
            the plate's normal on every body of the tree, at every pose).
    """
    if fin_added_mass not in FIN_ADDED_MASS:
        raise ValueError(
            f"fin_added_mass: {fin_added_mass!r} is not one of {', '.join(FIN_ADDED_MASS)}"
        )
    if not time_step > 0:
        raise ValueError(f"time_step: {time_step} must be > 0 (the plant is discrete)")
    config = MultibodyPlantConfig(
        time_step=time_step,
        discrete_contact_approximation=discrete_contact_approximation,
        # The robot is rigid hydroelastic, the pool compliant (model_sdf); a pair without
        # a hydroelastic representation would fall back to point contact.
        contact_model="hydroelastic_with_fallback",
        # Live (not sampled) output ports: HydrodynamicForces differences the hull's
        # velocity between steps, and a sampled port would already show the next step's
        # value during the update event.
        use_sampled_output_ports=False,
    )
    plant, scene_graph = AddMultibodyPlant(config, builder)
    parser = make_parser(plant)
    if robot_params is None or robot_params == DEFAULT_ROBOT:
        (robot,) = parser.AddModels(url=ROBOT_URL)
    else:
        (robot,) = parser.AddModelsFromString(robot_sdf(robot_params), "sdf")
    pool = parser.AddModels(url=POOL_URL)[0] if with_pool else None
    body = plant.GetBodyByName("body", robot)
    if weld_body is not None:
        plant.WeldFrames(plant.world_frame(), body.body_frame(), weld_body)
    bodies = hydro is not None and fin_added_mass == "bodies"
    iso, heave = _add_hydro_inertia(plant, body, hydro, bodies) if hydro is not None else (0.0, 0.0)
    if bodies:
        add_fin_added_mass_bodies(
            plant,
            robot,
            robot_params or DEFAULT_ROBOT,
            hydro.water_density.value,
            hydro.fins.added_mass_factor.value,
        )
        add_hull_heave_body(plant, body, heave)
    plant.Finalize()
    if hydro is not None and not bodies:
        _set_hinge_added_inertia(plant, robot, hydro.fins.hinge_added_inertia.value)
    actuated = tuple(
        plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(robot)
    )
    if actuated != JOINT_NAMES:  # the CPG's 16-vector relies on this order
        raise RuntimeError(f"actuator order {actuated} differs from {JOINT_NAMES}")
    return PlantHandles(plant, scene_graph, robot, pool, body, added_mass_iso=iso)


def _add_hydro_inertia(plant, body, hydro, bodies: bool) -> tuple[float, float]:
    """Puts the implicit part of the hull's added mass into the plant (before Finalize):
    isotropic, or with the added-mass bodies the part ``split_hull_added_mass`` leaves
    outside the heave body. Returns (isotropic mass, heave body's mass; 0 without bodies)."""
    if bodies:
        iso, _, heave = split_hull_added_mass(
            hydro.body.added_mass.value, hydro.fins.hull_interaction_added_mass.value
        )
        carried = heave_body_inertia(heave)
    else:
        iso, _ = split_added_mass(hydro.body.added_mass.value, body.default_mass())
        heave, carried = 0.0, (0.0, 0.0, 0.0)
    Ixx, Iyy, Izz = split_added_inertia(hydro.body.added_inertia.value, carried)[0]
    instance = plant.AddModelInstance("manta_added_mass")
    added = plant.AddRigidBody(
        "added_mass",
        instance,
        SpatialInertia.MakeFromCentralInertia(iso, np.zeros(3), RotationalInertia(Ixx, Iyy, Izz)),
    )
    p_BoBcm = body.default_com()
    plant.WeldFrames(body.body_frame(), added.body_frame(), RigidTransform(p_BoBcm))
    return iso, heave


def add_fin_added_mass_bodies(plant, robot, params, rho: float, factors) -> list:
    """Adds each fin plate's added mass as a body on a planar joint at the plate's centre
    (before Finalize), in the model instance ``FIN_ADDED_MASS_INSTANCE`` with gravity off
    (added mass has no weight).

    The joint's frame has z along the plate's normal (``FinPlate.R_LF``): the body moves
    with the plate along the normal and turns with it about the plate's in-plane axes, so
    its mass ``plate_added_mass`` acts in the mass matrix along the normal, and its moments
    about the chord and span lines are the plate's added inertia; in the plate's plane it
    is free (a thin plate moves no water edgewise). ``HydrodynamicForces`` keeps it centred
    with a force on it alone (which the joint does not pass on) and adds the velocity
    terms of Kirchhoff's equations.

    Args:
        factors: the 3-D factor K of the proximal and distal plates.

    Returns:
        The planar joints, leg by leg (proximal, distal).
    """
    factors = [float(f) for f in factors]
    if len(factors) != 2 or not all(f > 0 for f in factors):
        raise ValueError(
            f"fins.added_mass_factor: {factors!r} must be 2 numbers > 0 (the "
            "proximal and the distal plate's 3-D factor)"
        )
    instance = plant.AddModelInstance(FIN_ADDED_MASS_INSTANCE)
    joints = []
    for leg in LEGS:
        for plate, factor in zip(fin_plates(params), factors):
            mass, (i_chord, i_span, i_normal) = plate_added_mass(
                plate.chord, plate.span, rho, factor
            )
            name = f"{leg}_{plate.name}_added_mass"
            link = plant.GetBodyByName(f"{leg}_link{plate.link}", robot)
            frame = plant.AddFrame(
                FixedOffsetFrame(
                    f"{name}_frame",
                    link.body_frame(),
                    RigidTransform(RotationMatrix(np.array(plate.R_LF)), np.array(plate.center)),
                )
            )
            body = plant.AddRigidBody(
                name,
                instance,
                SpatialInertia.MakeFromCentralInertia(
                    mass, np.zeros(3), RotationalInertia(i_chord, i_span, i_normal)
                ),
            )
            joints.append(plant.AddJoint(PlanarJoint(name, frame, body.body_frame())))
    plant.mutable_gravity_field().set_enabled(instance, False)
    return joints


def add_hull_heave_body(plant, hull, mass: float):
    """Adds the hull's heave added mass (``split_hull_added_mass``) as a body on a planar
    joint at the hull's origin, the ellipsoid's centre (before Finalize), free in the hull's
    x-y plane: its mass acts along the hull's z only; in the model instance
    ``FIN_ADDED_MASS_INSTANCE`` (gravity off), where ``HydrodynamicForces`` keeps it centred
    and adds Kirchhoff's velocity terms as for a plate's body. Returns the joint."""
    if not mass > 0:
        raise ValueError(f"hull heave added mass {mass!r} must be > 0 kg")
    instance = plant.GetModelInstanceByName(FIN_ADDED_MASS_INSTANCE)
    heave = plant.AddRigidBody(
        "body_heave_added_mass",
        instance,
        SpatialInertia.MakeFromCentralInertia(
            mass, np.zeros(3), RotationalInertia(*heave_body_inertia(mass))
        ),
    )
    return plant.AddJoint(
        PlanarJoint("body_heave_added_mass", hull.body_frame(), heave.body_frame())
    )


def _set_hinge_added_inertia(plant, robot, hinge) -> None:
    """Each fin's added inertia about its hinge as its actuator's reflected inertia
    (gear ratio 1, rotor inertia = added inertia), in the plant's default parameters.

    After Finalize: before it, ``GetJointActuatorIndices`` is still empty, which once
    left the hinge inertia silently unapplied. The values are read back from a
    default context, so a setting that did not take effect fails loudly.
    """
    indices = plant.GetJointActuatorIndices(robot)
    expected = [hinge[i % JOINTS_PER_LEG] for i in range(len(indices))]
    for index, value in zip(indices, expected):
        actuator = plant.get_mutable_joint_actuator(index)
        actuator.set_default_gear_ratio(1.0)
        actuator.set_default_rotor_inertia(value)
    context = plant.CreateDefaultContext()
    applied = [plant.get_joint_actuator(i).calc_reflected_inertia(context) for i in indices]
    if len(indices) == 0 or not np.allclose(applied, expected, rtol=0, atol=1e-15):
        raise RuntimeError(f"hinge added inertia did not take effect: {applied} != {expected}")


def floor_geometries(handles: PlantHandles) -> list:
    """The pool's floor: its collision geometries whose name holds ``floor``."""
    inspector = handles.scene_graph.model_inspector()
    pool = handles.plant.GetBodyByName("pool", handles.pool)
    return [
        g
        for g in handles.plant.GetCollisionGeometriesForBody(pool)
        if "floor" in inspector.GetName(g)
    ]


def set_contact_friction(handles: PlantHandles, mu: float) -> None:
    """Sets the Coulomb friction (static = dynamic = ``mu``) of every collision geometry
    of the robot and the pool, so the foot-floor pair has exactly ``mu`` (Drake combines
    two materials' coefficients as 2 mu1 mu2 / (mu1 + mu2)). Read back from the model."""

    FRICTION.check("set_contact_friction.mu", mu)
    plant, scene_graph = handles.plant, handles.scene_graph
    inspector = scene_graph.model_inspector()
    instances = [handles.robot] + ([handles.pool] if handles.pool is not None else [])
    geometries = [
        g
        for instance in instances
        for index in plant.GetBodyIndices(instance)
        for g in plant.GetCollisionGeometriesForBody(plant.get_body(index))
    ]
    for geometry in geometries:
        props = inspector.GetProximityProperties(geometry)
        props.UpdateProperty("material", "coulomb_friction", CoulombFriction(mu, mu))
        scene_graph.AssignRole(plant.get_source_id(), geometry, props, RoleAssign.kReplace)
    for geometry in geometries:
        friction = inspector.GetProximityProperties(geometry).GetProperty(
            "material", "coulomb_friction"
        )
        if friction.dynamic_friction() != mu or friction.static_friction() != mu:
            raise RuntimeError(f"contact friction {mu} did not take effect on {geometry}")


def body_pose(xyz, rpy_deg) -> RigidTransform:
    """A RigidTransform from a position and roll-pitch-yaw in degrees."""
    return RigidTransform(RollPitchYaw(np.radians(rpy_deg)), np.asarray(xyz, dtype=float))


def set_initial_state(handles: PlantHandles, plant_context, X_WB: RigidTransform, q_joints) -> None:
    """Sets the body pose (if floating) and the 16 joint angles in ``plant_context``."""
    plant = handles.plant
    if handles.body.is_floating_base_body():
        plant.SetFreeBodyPose(plant_context, handles.body, X_WB)
    q_joints = np.asarray(q_joints, dtype=float).reshape(-1)
    for name, q in zip(handles.joint_names, q_joints):
        plant.GetJointByName(name, handles.robot).set_angle(plant_context, q)


def joint_state_selector(handles: PlantHandles) -> np.ndarray:
    """(32, nx) matrix that picks the joints' [q, v] out of the plant's state vector."""
    plant = handles.plant
    nq = plant.num_positions()
    joints = [plant.GetJointByName(n, handles.robot) for n in handles.joint_names]
    rows = [j.position_start() for j in joints] + [nq + j.velocity_start() for j in joints]
    S = np.zeros((len(rows), plant.num_multibody_states()))
    S[np.arange(len(rows)), rows] = 1.0
    return S


def joint_torque_port(handles: PlantHandles):
    """The plant's net actuation output of the robot: the joint actuators' torques
    (including the implicit PD's), in actuator order, which must be the joint order of
    ``measured_joint_state`` (``handles.joint_names``); checked here."""
    plant = handles.plant
    names = tuple(
        plant.get_joint_actuator(i).joint().name()
        for i in plant.GetJointActuatorIndices(handles.robot)
    )
    if names != tuple(handles.joint_names):
        raise RuntimeError(
            f"joint_torque: actuator order {names} is not the joint order {handles.joint_names}"
        )
    return plant.get_net_actuation_output_port(handles.robot)
