"""Eq. (1) and Table 2 against MultibodyPlant's forward kinematics."""

import numpy as np
import pytest

from manta_drake.model.kinematics import X_BODYDRAKE_BODYNED, dh_transform, fin_tip_pose
from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS


def _elementary(theta, d, a, alpha):
    c, s = np.cos, np.sin
    Rz = np.array([[c(theta), -s(theta), 0, 0], [s(theta), c(theta), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    Tz = np.eye(4); Tz[2, 3] = d
    Tx = np.eye(4); Tx[0, 3] = a
    Rx = np.array([[1, 0, 0, 0], [0, c(alpha), -s(alpha), 0], [0, s(alpha), c(alpha), 0], [0, 0, 0, 1]])
    return Rz @ Tz @ Tx @ Rx


def test_dh_transform_is_the_product_of_elementary_transforms(rng):
    for _ in range(50):
        args = rng.uniform(-3, 3, 4)
        np.testing.assert_allclose(dh_transform(*args), _elementary(*args), atol=1e-14)


def test_ned_to_zup_is_a_proper_rotation():
    R = X_BODYDRAKE_BODYNED[:3, :3]
    assert np.linalg.det(R) == pytest.approx(1.0)
    np.testing.assert_allclose(R @ [0, 0, 1], [0, 0, -1])  # NED down is Drake -z


def test_zero_pose_tips_are_table1_width_apart():
    tips = {leg: fin_tip_pose(leg, np.zeros(4))[:3, 3] for leg in LEGS}
    m = DEFAULT_ROBOT.mount("fl")
    span = DEFAULT_ROBOT.d3 + DEFAULT_ROBOT.dE
    # closed form: base at |y| = 0.10, fin swept back by `sweep`
    assert tips["fl"][1] - tips["fr"][1] == pytest.approx(2 * (abs(m.y) + span * np.cos(m.sweep)))
    assert tips["fl"][0] == pytest.approx(m.x - span * np.sin(m.sweep))
    assert tips["fl"][1] - tips["fr"][1] == pytest.approx(0.85, rel=0.10)  # Table 1
    assert tips["fl"][1] > 0  # left is +y in Drake's z-up body frame
    assert tips["fl"][0] > 0 > tips["rl"][0]


def test_plant_fin_tip_pose_equals_dh_product(robot_plant, rng):
    _, h = robot_plant
    plant = h.plant
    context = plant.CreateDefaultContext()
    joints = [plant.GetJointByName(n, h.robot) for n in h.joint_names]
    body_frame = h.body.body_frame()
    worst = 0.0
    for _ in range(100):
        q = rng.uniform(-np.pi, np.pi, 16)
        for joint, qi in zip(joints, q):
            joint.set_angle(context, qi)
        for k, leg in enumerate(LEGS):
            X_plant = plant.GetFrameByName(f"{leg}_tip", h.robot).CalcPose(context, body_frame)
            X_dh = fin_tip_pose(leg, q[4 * k : 4 * k + 4], DEFAULT_ROBOT)
            worst = max(worst, np.abs(X_plant.GetAsMatrix4() - X_dh).max())
    assert worst < 1e-9
