"""The fin links' transforms for ``/tf``: the robot's own MultibodyPlant (no pool, no water)
posed at the logged joint angles gives, for each of the 16 joints, the pose of its child
link in its parent link (the tree ``robot_state_publisher`` would publish from a URDF:
``base -> fl_link1 -> fl_link2 -> fl_link3 -> fl_link4``, and so for each leg)."""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import DiagramBuilder

from manta_drake.model.plant import add_plant


class FinLinks:
    """q (16 joint angles, the plant's joint order) -> [(parent, child, xyz, quat_wxyz)].

    Args:
        robot_params: the scenario's RobotParams (its geometry); None: the shipped model.
        base: the frame id of the hull (the plant's body ``body``).
    """

    def __init__(self, robot_params=None, base: str = "base_link"):
        builder = DiagramBuilder()
        handles = add_plant(builder, with_pool=False, robot_params=robot_params)
        self._diagram = builder.Build()
        self._plant = handles.plant
        self._context = self._plant.GetMyMutableContextFromRoot(
            self._diagram.CreateDefaultContext()
        )
        joints = [self._plant.GetJointByName(n, handles.robot) for n in handles.joint_names]
        self._starts = np.array([j.position_start() for j in joints])
        self._frames = [(j.parent_body().body_frame(), j.child_body().body_frame()) for j in joints]
        hull = handles.body.name()
        self._names = [
            tuple(base if b.name() == hull else b.name() for b in (j.parent_body(), j.child_body()))
            for j in joints
        ]

    def __call__(self, q) -> list[tuple]:
        positions = self._plant.GetPositions(self._context)
        positions[self._starts] = np.asarray(q, dtype=float)
        self._plant.SetPositions(self._context, positions)
        out = []
        for (parent, child), (P, C) in zip(self._names, self._frames):
            X = self._plant.CalcRelativeTransform(self._context, P, C)
            out.append((parent, child, X.translation(), X.rotation().ToQuaternion().wxyz()))
        return out
