"""Generates ``models/manta.sdf`` and ``models/pool.sdf`` from ``robot_params``.

The committed SDFormat files are outputs of this module (``scripts/generate_models.py``
writes them; a test checks they are up to date), so the DH numbers, masses and
limits live in one place. Link poses come from ``kinematics.link_poses_at_zero``.
"""

from __future__ import annotations

import numpy as np
from pydrake.math import RollPitchYaw, RotationMatrix

from manta_drake.model.kinematics import link_poses_at_zero
from manta_drake.model.robot_params import (
    DEFAULT_POOL,
    DEFAULT_ROBOT,
    JOINTS,
    PoolParams,
    RobotParams,
)

BODY_RGBA = "0.32 0.38 0.46 1"
BELLY_RGBA = "0.85 0.87 0.9 1"
FIN_RGBA = "0.20 0.27 0.36 1"
SERVO_RGBA = "0.1 0.1 0.1 1"


def _f(x: float) -> str:
    # repr round-trips exactly; the FK test compares to 1e-9 m.
    return repr(float(x))


def _vec(v) -> str:
    return " ".join(_f(x) for x in v)


def _pose(X: np.ndarray, relative_to: str | None = None) -> str:
    rpy = RollPitchYaw(RotationMatrix(X[:3, :3])).vector()
    rel = f' relative_to="{relative_to}"' if relative_to else ""
    return f"<pose{rel}>{_vec(X[:3, 3])} {_vec(rpy)}</pose>"


def _xyz_pose(xyz, rpy=(0.0, 0.0, 0.0)) -> str:
    return f"<pose>{_vec(xyz)} {_vec(rpy)}</pose>"


def box_inertia(m: float, size) -> np.ndarray:
    """Principal moments of a solid box of mass m and edge lengths ``size``."""
    x, y, z = size
    return m / 12.0 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])


def ellipsoid_inertia(m: float, semi_axes) -> np.ndarray:
    """Principal moments of a solid ellipsoid of mass m and semi-axes a, b, c."""
    a, b, c = semi_axes
    return m / 5.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])


def composite_inertia(parts) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass, centre of mass, 3x3 inertia about it) of rigid ``parts``, each (mass, centre
    (3,), principal moments (3,) along the frame's axes), by the parallel-axis theorem:
    I = sum_i diag(moments_i) + m_i (|d_i|^2 E - d_i d_i^T), d_i = centre_i - centre."""
    masses = np.array([m for m, _, _ in parts], dtype=float)
    centres = np.array([c for _, c, _ in parts], dtype=float).reshape(-1, 3)
    total = float(masses.sum())
    com = masses @ centres / total
    inertia = np.zeros((3, 3))
    for m, c, moments in parts:
        d = np.asarray(c, dtype=float) - com
        inertia += np.diag(moments) + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total, com, inertia


def _inertial(m: float, inertia, xyz=(0.0, 0.0, 0.0)) -> str:
    """An <inertial> of mass m, inertia (3 principal moments or a 3x3 matrix) about the
    centre of mass ``xyz``."""
    inertia = np.asarray(inertia, dtype=float)
    if inertia.shape == (3,):
        inertia = np.diag(inertia)
    entries = "".join(f"<i{a}{b}>{_f(inertia[i, j])}</i{a}{b}>" for a, b, i, j in
                      (("x", "x", 0, 0), ("y", "y", 1, 1), ("z", "z", 2, 2),
                       ("x", "y", 0, 1), ("x", "z", 0, 2), ("y", "z", 1, 2)))
    return f"<inertial>{_xyz_pose(xyz)}<mass>{_f(m)}</mass><inertia>{entries}</inertia></inertial>"


def _servo_visual(name: str, xyz, p: RobotParams) -> str:
    return (f"<visual name='{name}'>{_xyz_pose(xyz)}<geometry><box><size>"
            f"{_vec(p.servo_size)}</size></box></geometry>{_material(SERVO_RGBA)}</visual>")


def link_inertias(leg: str, p: RobotParams) -> dict[int, tuple]:
    """(mass, centre of mass, 3x3 inertia) of each link 1-4 of a leg-fin in its own frame:
    the servo the link carries (links 1-3, ``model.bill_of_materials``) as a solid block
    at the next joint's axis, and the rest of the link's mass spread over its solid (the
    servo block on links 1 and 2, the fin plate on links 3 and 4)."""
    poses = link_poses_at_zero(leg, p)
    plates = fin_plate_geometry(p)
    solids = {1: (None, p.servo_size), 2: (None, p.servo_size),
              3: (plates["proximal"]["center"], plates["proximal"]["size"]),
              4: (plates["distal"]["center"], plates["distal"]["size"])}
    out = {}
    for i, m in enumerate(p.link_masses, start=1):
        servo_at = poses["X_Lprev_L"][i - 1][:3, 3] if i <= 3 else None
        rest = m - (p.servo_mass if servo_at is not None else 0.0)
        centre, size = solids[i]
        parts = [] if servo_at is None else [(p.servo_mass, servo_at,
                                              box_inertia(p.servo_mass, p.servo_size))]
        if rest > 1e-12:
            parts.append((rest, servo_at if centre is None else centre, box_inertia(rest, size)))
        out[i] = composite_inertia(parts)
    return out


def body_inertia(p: RobotParams) -> tuple:
    """(mass, centre of mass, 3x3 inertia) of the hull body: the hull's parts as a solid
    ellipsoid of the hull's shape, the residual as the same ellipsoid centred at
    ``residual_position`` (the ballast's trim), and each yaw servo as a solid block at its
    leg's mount."""
    servo = box_inertia(p.servo_mass, p.servo_size)
    rest = p.body_mass - len(p.mounts) * p.servo_mass - p.residual_mass
    parts = [(rest, (0.0, 0.0, 0.0), ellipsoid_inertia(rest, p.body_semi_axes)),
             (p.residual_mass, p.residual_position,
              ellipsoid_inertia(p.residual_mass, p.body_semi_axes))]
    parts += [(p.servo_mass, link_poses_at_zero(m.name, p)["X_Body_L1"][:3, 3], servo)
              for m in p.mounts]
    return composite_inertia(parts)


def _material(rgba: str) -> str:
    return f"<material><diffuse>{rgba}</diffuse><ambient>{rgba}</ambient></material>"


def _contact_props(p: RobotParams) -> str:
    """The robot's proximity properties: rigid hydroelastic (the pool is compliant: see
    ``pool_sdf``), SAP's default dissipation (relaxation time 0.1 s)."""
    return (
        "<drake:proximity_properties><drake:rigid_hydroelastic/>"
        f"<drake:mesh_resolution_hint>{_f(p.hydroelastic_resolution)}</drake:mesh_resolution_hint>"
        f"<drake:mu_dynamic>{_f(p.friction)}</drake:mu_dynamic>"
        f"<drake:mu_static>{_f(p.friction)}</drake:mu_static>"
        "</drake:proximity_properties>"
    )


def fin_plate_geometry(p: RobotParams = DEFAULT_ROBOT) -> dict:
    """Centres and sizes of the fin plates in their link frames.

    Link 3 (after pitch): x = plate normal, y = chord, z = span (outward).
    Link 4 (after roll2): x = plate normal, y = -span, z = chord.
    """
    t = p.fin_thickness
    return {
        "proximal": {"center": (0.0, 0.0, p.d3 / 2), "size": (t, p.proximal_chord, p.d3)},
        "distal": {"center": (0.0, -p.dE / 2, 0.0), "size": (t, p.dE, p.distal_chord)},
        "tip": (0.0, -p.dE, 0.0),
    }


def _leg_sdf(leg: str, p: RobotParams) -> str:
    poses = link_poses_at_zero(leg, p)
    plates = fin_plate_geometry(p)
    inertial = {i: _inertial(m, inertia, com)
                for i, (m, com, inertia) in link_inertias(leg, p).items()}
    lines = []
    parents = ["body", f"{leg}_link1", f"{leg}_link2", f"{leg}_link3"]
    X_parent = [poses["X_Body_L1"]] + poses["X_Lprev_L"]
    servo = {i: _servo_visual("servo", poses["X_Lprev_L"][i - 1][:3, 3], p) for i in (1, 2, 3)}
    prox, dist = plates["proximal"], plates["distal"]
    link_body = {
        1: inertial[1] + servo[1],
        2: inertial[2] + servo[2],
        3: inertial[3] + servo[3]
        + f"<visual name='fin'>{_xyz_pose(prox['center'])}<geometry><box><size>"
        f"{_vec(prox['size'])}</size></box></geometry>{_material(FIN_RGBA)}</visual>"
        + f"<collision name='fin'>{_xyz_pose(prox['center'])}<geometry><box><size>"
        f"{_vec(prox['size'])}</size></box></geometry>{_contact_props(p)}</collision>",
        4: inertial[4]
        + f"<visual name='fin'>{_xyz_pose(dist['center'])}<geometry><box><size>"
        f"{_vec(dist['size'])}</size></box></geometry>{_material(FIN_RGBA)}</visual>"
        + f"<collision name='fin'>{_xyz_pose(dist['center'])}<geometry><box><size>"
        f"{_vec(dist['size'])}</size></box></geometry>{_contact_props(p)}</collision>",
    }
    for i, joint in enumerate(JOINTS, start=1):
        link = f"{leg}_link{i}"
        lo, hi = p.position_limits[i - 1]
        lines.append(
            f"<link name='{link}'>{_pose(X_parent[i - 1], parents[i - 1])}{link_body[i]}</link>"
        )
        lines.append(
            f"<joint name='{leg}_{joint}' type='revolute'><parent>{parents[i - 1]}</parent>"
            f"<child>{link}</child><axis><xyz>0 0 1</xyz>"
            f"<limit><lower>{_f(lo)}</lower><upper>{_f(hi)}</upper>"
            f"<effort>{_f(p.effort_limit)}</effort><velocity>{_f(p.velocity_limit)}</velocity></limit>"
            f"<dynamics><damping>{_f(p.joint_damping)}</damping></dynamics></axis>"
            f"<drake:controller_gains p='{_f(p.kp)}' d='{_f(p.kd)}'/></joint>"
        )
    lines.append(
        f"<frame name='{leg}_tip' attached_to='{leg}_link4'>{_pose(poses['X_L4_Tip'])}</frame>"
    )
    return "\n    ".join(lines)


def camera_pose(p: RobotParams = DEFAULT_ROBOT) -> np.ndarray:
    """Pose of the camera frame in the Drake body frame (Drake camera convention:
    +z optical axis forward, +x right, +y down), pitched down by ``camera_pitch_down``."""
    R_level = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    R = RotationMatrix.MakeYRotation(p.camera_pitch_down).matrix() @ R_level
    X = np.eye(4)
    X[:3, :3] = R
    X[:3, 3] = p.camera_position
    return X


def robot_sdf(p: RobotParams = DEFAULT_ROBOT) -> str:
    """SDFormat text of the manta-ray robot (17 bodies, 16 revolute joints)."""
    a, b, c = p.body_semi_axes
    mass, com, inertia = body_inertia(p)
    yaw_servos = "".join(_servo_visual(f"servo_{m.name}",
                                       link_poses_at_zero(m.name, p)["X_Body_L1"][:3, 3], p)
                         for m in p.mounts)
    body = (
        f"<link name='body'>{_inertial(mass, inertia, com)}{yaw_servos}"
        f"<visual name='hull'><geometry><ellipsoid><radii>{_vec((a, b, c))}</radii></ellipsoid>"
        f"</geometry>{_material(BODY_RGBA)}</visual>"
        f"<visual name='belly'>{_xyz_pose((0.0, 0.0, -0.3 * c))}<geometry><ellipsoid><radii>"
        f"{_vec((0.97 * a, 0.97 * b, 0.72 * c))}</radii></ellipsoid></geometry>"
        f"{_material(BELLY_RGBA)}</visual>"
        f"<collision name='hull'><geometry><ellipsoid><radii>{_vec((a, b, c))}</radii>"
        f"</ellipsoid></geometry>{_contact_props(p)}</collision></link>"
    )
    legs = "\n    ".join(_leg_sdf(leg.name, p) for leg in p.mounts)
    members = "".join(
        f"<drake:member>{name}</drake:member>"
        for name in ["body"] + [f"{m.name}_link{i}" for m in p.mounts for i in range(1, 5)]
    )
    return f"""<?xml version="1.0"?>
<!-- GENERATED by scripts/generate_models.py from manta_drake/model/robot_params.py. Do not edit. -->
<sdf version="1.9" xmlns:drake="http://drake.mit.edu">
  <model name="manta">
    {body}
    {legs}
    <frame name="camera" attached_to="body">{_pose(camera_pose(p))}</frame>
    <drake:collision_filter_group name="robot_self">{members}
      <drake:ignored_collision_filter_group>robot_self</drake:ignored_collision_filter_group>
    </drake:collision_filter_group>
  </model>
</sdf>
"""


def pool_sdf(pool: PoolParams = DEFAULT_POOL) -> str:
    """SDFormat text of the pool: floor, four walls, and a visual-only water surface at z = 0."""
    L, W, D = pool.length, pool.width, pool.depth
    t, tf = pool.wall_thickness, pool.floor_thickness
    h = D + pool.wall_height_above_water
    zc = -D + h / 2
    props = (
        "<drake:proximity_properties><drake:compliant_hydroelastic/>"
        f"<drake:hydroelastic_modulus>{_f(pool.hydroelastic_modulus)}</drake:hydroelastic_modulus>"
        f"<drake:mu_dynamic>{_f(pool.friction)}</drake:mu_dynamic>"
        f"<drake:mu_static>{_f(pool.friction)}</drake:mu_static>"
        "</drake:proximity_properties>"
    )
    boxes = {
        "floor": ((0.0, 0.0, -D - tf / 2), (L + 2 * t, W + 2 * t, tf), "0.55 0.62 0.66 1"),
        "wall_east": ((L / 2 + t / 2, 0.0, zc), (t, W + 2 * t, h), "0.70 0.74 0.78 1"),
        "wall_west": ((-L / 2 - t / 2, 0.0, zc), (t, W + 2 * t, h), "0.70 0.74 0.78 1"),
        "wall_north": ((0.0, W / 2 + t / 2, zc), (L, t, h), "0.70 0.74 0.78 1"),
        "wall_south": ((0.0, -W / 2 - t / 2, zc), (L, t, h), "0.70 0.74 0.78 1"),
    }
    parts = []
    for name, (xyz, size, rgba) in boxes.items():
        geom = f"<geometry><box><size>{_vec(size)}</size></box></geometry>"
        parts.append(
            f"<visual name='{name}'>{_xyz_pose(xyz)}{geom}{_material(rgba)}</visual>"
            f"<collision name='{name}'>{_xyz_pose(xyz)}{geom}{props}</collision>"
        )
    # Water surface: a visual only (no collision). The depth camera sees it from below as
    # the paper's "ceiling", and it hides the walls above the waterline, as real water does.
    parts.append(
        f"<visual name='water_surface'>{_xyz_pose((0.0, 0.0, -0.0005))}<geometry><box><size>"
        f"{_vec((L, W, 0.001))}</size></box></geometry>{_material('0.2 0.5 0.9 0.25')}</visual>"
    )
    body = "\n      ".join(parts)
    return f"""<?xml version="1.0"?>
<!-- GENERATED by scripts/generate_models.py from manta_drake/model/robot_params.py. Do not edit. -->
<sdf version="1.9" xmlns:drake="http://drake.mit.edu">
  <model name="pool">
    <static>true</static>
    <link name="pool">
      {body}
    </link>
  </model>
</sdf>
"""
