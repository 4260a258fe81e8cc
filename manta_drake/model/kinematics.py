"""Leg-fin kinematics: Eq. (1) and the DH chain of Table 2.

Everything here is plain numpy on 4x4 homogeneous transforms, so the tests can
check the MultibodyPlant model against it directly, and the model generator
derives the SDFormat link poses from it (one source of truth).

Conventions (see ``robot_params``): the DH chain is written in the paper's NED
body frame; ``X_BODYDRAKE_BODYNED`` is the single NED -> z-up conversion.
Joint i of Table 2 rotates about z_{i-1}; its constant part (theta_offset on
link 1, pi/2 on link 2) is split off as ``JOINT_THETA_CONST``.
"""

from __future__ import annotations

import numpy as np

from manta_drake.model.robot_params import DEFAULT_ROBOT, JOINTS, LEGS, RobotParams

# Rotation by pi about x: the paper's NED body axes (x fwd, y right, z down)
# expressed in Drake's z-up body axes (x fwd, y left, z up).
X_BODYDRAKE_BODYNED = np.diag([1.0, -1.0, -1.0, 1.0])

# Table 2, links 1..4: alpha_i [rad] and a_i [m] (all zero).
DH_ALPHA = np.array([-np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2])


def dh_transform(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Eq. (1): ^{i-1}T_i = R_z(theta) T_z(d) T_x(a) R_x(alpha), a 4x4 numpy array."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def rot_z(theta: float) -> np.ndarray:
    """Homogeneous rotation about z."""
    return dh_transform(theta, 0.0, 0.0, 0.0)


def leg_dh_table(leg: str, params: RobotParams = DEFAULT_ROBOT) -> dict:
    """Table 2 with this model's numbers for one leg-fin.

    Returns:
        dict with ``theta_init``, ``a0``, and per joint 1..4 arrays ``theta_const``,
        ``d``, ``a``, ``alpha``, plus ``dE``. Joint i's DH angle is
        ``q_i + theta_const[i]``.
    """
    m = params.mount(leg)
    return {
        "theta_init": m.theta_init,
        "a0": m.a0,
        "theta_const": np.array([m.theta_offset, np.pi / 2, 0.0, 0.0]),
        "d": np.array([0.0, 0.0, params.d3, 0.0]),
        "a": np.zeros(4),
        "alpha": DH_ALPHA.copy(),
        "dE": params.dE,
    }


def leg_frames_ned(leg: str, q, params: RobotParams = DEFAULT_ROBOT) -> list:
    """The DH frames F_0..F_4 and F_E of one leg-fin in the NED body frame.

    Args:
        leg: one of ``fl fr rl rr``.
        q: the leg-fin's four joint angles (yaw, roll1, pitch, roll2) [rad].

    Returns:
        list of six 4x4 transforms ``X_BodyNed_Fi``.
    """
    q = np.asarray(q, dtype=float).reshape(len(JOINTS))
    t = leg_dh_table(leg, params)
    X = dh_transform(t["theta_init"], 0.0, t["a0"], 0.0)
    frames = [X]
    for i in range(4):
        X = X @ dh_transform(q[i] + t["theta_const"][i], t["d"][i], t["a"][i], t["alpha"][i])
        frames.append(X)
    frames.append(X @ dh_transform(np.pi / 2, t["dE"], 0.0, 0.0))
    return frames


def fin_tip_pose(leg: str, q, params: RobotParams = DEFAULT_ROBOT) -> np.ndarray:
    """Fin-tip frame F_E in Drake's z-up body frame: the product of Eq. (1) transforms."""
    return X_BODYDRAKE_BODYNED @ leg_frames_ned(leg, q, params)[-1]


def fin_tips_xy(stance, params: RobotParams = DEFAULT_ROBOT) -> np.ndarray:
    """The four fin tips' horizontal positions (4x2, rows fl, fr, rl, rr) [m] in Drake's body
    frame (x forward, y left) with the joints at ``stance`` (4x4, e.g. a gait's X)."""
    q = np.asarray(stance, dtype=float)
    return np.array([fin_tip_pose(leg, q[k], params)[:2, 3] for k, leg in enumerate(LEGS)])


def support_diagonal_offsets(stance, params: RobotParams = DEFAULT_ROBOT) -> tuple:
    """How far the CG (the body origin) is from the trot's two support diagonals.

    Args:
        stance: 4x4 joint angles (rows fl, fr, rl, rr), e.g. a gait's X.
        params: the robot's geometry.

    Returns:
        (d_fl_rr, d_fr_rl): signed horizontal distances [m] of the CG from the lines through
        the fin tips fl-rr and fr-rl (both 0 when the CG lies on both diagonals).
    """
    tips = fin_tips_xy(stance, params)

    def offset(a, b):
        d = b - a
        return float((a[0] * d[1] - a[1] * d[0]) / np.linalg.norm(d))

    return offset(tips[0], tips[3]), offset(tips[1], tips[2])


def link_poses_at_zero(leg: str, params: RobotParams = DEFAULT_ROBOT) -> dict:
    """Fixed poses the SDFormat model needs, derived from the DH table.

    Each link body i (1..4) carries the frame ``F_{i-1} R_z(theta_const_i) R_z(q_i)``,
    so joint i rotates about the link's own z axis at its origin.

    Returns:
        dict with ``X_Body_L1`` (link 1 in the Drake body frame at q = 0),
        ``X_Lprev_L`` (list of three poses of link i in link i-1, i = 2..4, at
        q = 0) and ``X_L4_Tip`` (the fin-tip frame F_E in link 4).
    """
    t = leg_dh_table(leg, params)
    F0 = dh_transform(t["theta_init"], 0.0, t["a0"], 0.0)
    X_Body_L1 = X_BODYDRAKE_BODYNED @ F0 @ rot_z(t["theta_const"][0])

    def fixed(i):  # the part of ^{i-1}T_i after the joint rotation
        return dh_transform(0.0, t["d"][i], t["a"][i], t["alpha"][i])

    X_Lprev_L = [fixed(i - 1) @ rot_z(t["theta_const"][i]) for i in range(1, 4)]
    X_L4_Tip = fixed(3) @ dh_transform(np.pi / 2, t["dE"], 0.0, 0.0)
    return {"X_Body_L1": X_Body_L1, "X_Lprev_L": X_Lprev_L, "X_L4_Tip": X_L4_Tip}
