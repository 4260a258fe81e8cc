"""The MultibodyPlant: robot + pool in a DiagramBuilder.

A discrete plant (the scenario's time step, 1 ms by default) with SAP contact,
point contact between the robot and the pool's floor and walls, and the
robot's implicit joint PD (``<drake:controller_gains>``) driven through the
plant's desired-state input port.
"""

from __future__ import annotations

import dataclasses as dc
import pathlib

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlant, MultibodyPlantConfig
from pydrake.systems.framework import DiagramBuilder

from manta_drake.robot_params import JOINT_NAMES

MODELS_DIR = pathlib.Path(__file__).resolve().parent.parent / "models"
ROBOT_URL = "package://manta_drake/manta.sdf"
POOL_URL = "package://manta_drake/pool.sdf"


@dc.dataclass
class PlantHandles:
    """What the rest of the diagram needs from the plant."""

    plant: MultibodyPlant
    scene_graph: object
    robot: object  # ModelInstanceIndex
    pool: object
    body: object  # the robot's main body (RigidBody)
    joint_names: tuple = JOINT_NAMES


def make_parser(plant: MultibodyPlant) -> Parser:
    """A Parser that resolves ``package://manta_drake/``."""
    parser = Parser(plant)
    parser.package_map().AddPackageXml(str(MODELS_DIR / "package.xml"))
    return parser


def add_plant(
    builder: DiagramBuilder,
    time_step: float = 1e-3,
    discrete_contact_approximation: str = "sap",
    with_pool: bool = True,
    weld_body: RigidTransform | None = None,
) -> PlantHandles:
    """Adds the robot (and pool) to ``builder`` and finalizes the plant.

    Args:
        builder: the diagram builder.
        time_step: the plant's discrete period [s] (> 0).
        discrete_contact_approximation: ``sap`` (default) or ``lagged``, ...
        with_pool: add the pool (floor, walls) as well.
        weld_body: if given, weld the robot's body to the world at this pose
            (for tests that hold the robot in the air).
    """
    if not time_step > 0:
        raise ValueError(f"time_step: {time_step} must be > 0 (the plant is discrete)")
    config = MultibodyPlantConfig(
        time_step=time_step,
        discrete_contact_approximation=discrete_contact_approximation,
        contact_model="point",
    )
    plant, scene_graph = AddMultibodyPlant(config, builder)
    parser = make_parser(plant)
    (robot,) = parser.AddModels(url=ROBOT_URL)
    pool = parser.AddModels(url=POOL_URL)[0] if with_pool else None
    body = plant.GetBodyByName("body", robot)
    if weld_body is not None:
        plant.WeldFrames(plant.world_frame(), body.body_frame(), weld_body)
    plant.Finalize()
    actuated = tuple(
        plant.get_joint_actuator(i).joint().name() for i in plant.GetJointActuatorIndices(robot)
    )
    if actuated != JOINT_NAMES:  # the CPG's 16-vector relies on this order
        raise RuntimeError(f"actuator order {actuated} differs from {JOINT_NAMES}")
    return PlantHandles(plant, scene_graph, robot, pool, body)


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
