"""Start-pose checks: is the robot in the pool's water, clear of its floor and walls?

``start_pose_problem`` is what a scenario's ``initial_pose`` is checked with at load time
(and what the fault campaign draws its near-wall starts against): bounding checks from
the kinematics of Eq. (1), then a collision query on a real MultibodyPlant of the robot
and the pool (``deepest_start_contact``), built once per fin sweep and process.
"""

import functools

import numpy as np
from pydrake.math import RollPitchYaw
from pydrake.systems.framework import DiagramBuilder

from manta_drake.model.kinematics import fin_tip_pose
from manta_drake.model.plant import add_plant, body_pose, set_initial_state
from manta_drake.model.robot_params import DEFAULT_POOL, LEGS, robot_with_fin_sweep_deg

# A resting contact: collision geometry may start this far inside the pool [m].
START_PENETRATION_TOLERANCE = 0.002


@functools.lru_cache(maxsize=2)
def _collision_model(fin_sweep_deg: float):
    """A robot + pool plant (no water) and a context, built once per geometry."""
    builder = DiagramBuilder()
    handles = add_plant(builder, robot_params=robot_with_fin_sweep_deg(fin_sweep_deg))
    diagram = builder.Build()
    return diagram, handles, diagram.CreateDefaultContext()


def deepest_start_contact(xyz, rpy_deg, q, fin_sweep_deg: float) -> tuple[float, tuple]:
    """The deepest penetration [m] between the robot's collision geometry (hull, fin plates,
    feet) and the pool's, with the body at ``xyz``, ``rpy_deg`` (world, deg), joint angles
    ``q`` and fins swept back ``fin_sweep_deg``; and the pair's geometry names (empty: no
    contact)."""
    _, handles, context = _collision_model(float(fin_sweep_deg))
    pc = handles.plant.GetMyMutableContextFromRoot(context)
    set_initial_state(handles, pc, body_pose(xyz, rpy_deg), np.ravel(q))
    query = handles.plant.get_geometry_query_input_port().Eval(pc)
    deepest = max(query.ComputePointPairPenetration(), key=lambda pair: pair.depth, default=None)
    if deepest is None:
        return 0.0, ()
    inspector = query.inspector()
    return float(deepest.depth), tuple(inspector.GetName(g) for g in (deepest.id_A, deepest.id_B))


def start_pose_problem(
    xyz, rpy_deg, q, fin_sweep_deg: float, stance_name: str = "given"
) -> str | None:
    """Why a start pose is not inside the pool's water clear of its floor and walls, or None.

    Checked at the joint angles ``q`` (4x4, rows fl, fr, rl, rr; the stance called
    ``stance_name`` in the messages): the hull's centre in the water (below the surface,
    above the floor); the hull (an ellipsoid) and the four fin tips (the middle of each
    distal plate's end) inside the walls and above the floor; then every collision
    geometry of the robot (the fin plates' edges and corners included) overlapping the
    pool's by at most 2 mm (a resting contact).
    """
    pool, robot = DEFAULT_POOL, robot_with_fin_sweep_deg(fin_sweep_deg)
    p = np.asarray(xyz, dtype=float)
    q = np.asarray(q, dtype=float).reshape(len(LEGS), 4)
    R = RollPitchYaw(np.radians(rpy_deg)).ToRotationMatrix().matrix()
    floor, half_x, half_y = -pool.depth, pool.length / 2, pool.width / 2
    if not (floor < p[2] <= 0.0 and abs(p[0]) < half_x and abs(p[1]) < half_y):
        return (
            f"the body at {list(map(float, p))} m is not in the pool's water "
            f"(x in (-{half_x}, {half_x}), y in (-{half_y}, {half_y}), z in ({floor}, 0])"
        )
    # Hull: an ellipsoid's extent along world axis k is sqrt(sum_i (R[k, i] a_i)^2).
    extent = np.sqrt(((R * np.asarray(robot.body_semi_axes)) ** 2).sum(axis=1))
    boxes = [("hull", p - extent, p + extent)]
    for leg, q_leg in zip(LEGS, q):
        tip = p + R @ fin_tip_pose(leg, q_leg, robot)[:3, 3]
        boxes.append((f"{leg} fin tip", tip, tip))
    for name, low, high in boxes:
        if low[2] < floor - START_PENETRATION_TOLERANCE:
            return (
                f"the {name} reaches z = {low[2]:.3f} m, below the floor at {floor} m "
                f"(body z = {p[2]} m with the '{stance_name}' stance)"
            )
        if max(abs(low[0]), abs(high[0])) > half_x or max(abs(low[1]), abs(high[1])) > half_y:
            return (
                f"the {name} at x, y = {0.5 * (low[0] + high[0]):.3f}, "
                f"{0.5 * (low[1] + high[1]):.3f} m is inside or beyond a wall (the walls "
                f"are at x = +-{half_x}, y = +-{half_y} m)"
            )
    depth, names = deepest_start_contact(p, rpy_deg, q, fin_sweep_deg)
    if depth <= START_PENETRATION_TOLERANCE:
        return None
    return (
        f"the robot starts {depth * 1e3:.1f} mm inside the pool "
        f"({' and '.join(sorted(names))} overlap; at most "
        f"{START_PENETRATION_TOLERANCE * 1e3:g} mm allowed)"
    )
