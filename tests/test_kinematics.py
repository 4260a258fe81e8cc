"""Eq. (1) and Table 2 against MultibodyPlant's forward kinematics."""

import numpy as np
import pytest

from manta_drake.model.kinematics import X_BODYDRAKE_BODYNED, dh_transform, fin_tip_pose
from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS


def _elementary(theta, d, a, alpha):
    c, s = np.cos, np.sin
    Rz = np.array(
        [[c(theta), -s(theta), 0, 0], [s(theta), c(theta), 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    )
    Tz = np.eye(4)
    Tz[2, 3] = d
    Tx = np.eye(4)
    Tx[0, 3] = a
    Rx = np.array(
        [[1, 0, 0, 0], [0, c(alpha), -s(alpha), 0], [0, s(alpha), c(alpha), 0], [0, 0, 0, 1]]
    )
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


@pytest.mark.parametrize("sweep_deg", [30.0, -15.0])
def test_plant_of_another_fin_sweep_equals_its_dh_product(sweep_deg, rng):
    """``robot.fin_sweep_deg`` reaches the plant: the generated model's tips (read back after
    Finalize) equal Eq. (1) with that theta_offset, and differ from the shipped model's."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant

    params = DEFAULT_ROBOT.with_fin_sweep(np.radians(sweep_deg))
    h = add_plant(DiagramBuilder(), robot_params=params)
    plant = h.plant
    context = plant.CreateDefaultContext()
    joints = [plant.GetJointByName(n, h.robot) for n in h.joint_names]
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(-1.0, 1.0, 16)
        for joint, qi in zip(joints, q):
            joint.set_angle(context, qi)
        for k, leg in enumerate(LEGS):
            X = plant.GetFrameByName(f"{leg}_tip", h.robot).CalcPose(context, h.body.body_frame())
            worst = max(
                worst,
                np.abs(X.GetAsMatrix4() - fin_tip_pose(leg, q[4 * k : 4 * k + 4], params)).max(),
            )
    assert worst < 1e-9
    # closed form at the zero pose: the left front tip swept back (or forward) by the sweep
    for joint in joints:
        joint.set_angle(context, 0.0)
    tip = plant.GetFrameByName("fl_tip", h.robot).CalcPose(context, h.body.body_frame())
    span = DEFAULT_ROBOT.d3 + DEFAULT_ROBOT.dE
    assert tip.translation()[0] == pytest.approx(0.10 - span * np.sin(np.radians(sweep_deg)))


def test_support_diagonal_offsets_closed_form():
    """At the zero pose with no sweep the tips form a rectangle centred on the CG (offsets 0);
    swept back by s, every tip moves back by span * sin(s), and the CG lies that far ahead of
    both diagonals, times the cosine of the diagonals' angle to the y axis."""
    from manta_drake.model.kinematics import support_diagonal_offsets

    flat = DEFAULT_ROBOT.with_fin_sweep(0.0)
    assert support_diagonal_offsets(np.zeros((4, 4)), flat) == pytest.approx((0, 0), abs=1e-12)
    s = np.radians(20.0)
    span = DEFAULT_ROBOT.d3 + DEFAULT_ROBOT.dE
    shift = span * np.sin(s)
    half_x, half_y = 0.10 - 0.0, 0.10 + span * np.cos(s)  # tip rectangle half sides
    cos_angle = 2 * half_y / np.hypot(2 * half_x, 2 * half_y)
    d1, d2 = support_diagonal_offsets(np.zeros((4, 4)), DEFAULT_ROBOT.with_fin_sweep(s))
    assert abs(d1) == pytest.approx(shift * cos_angle, rel=1e-9)
    assert d1 == pytest.approx(-d2, rel=1e-9)


def test_each_readings_stance_is_balanced_at_its_fin_sweep():
    """Why the mirrored reading needs robot.fin_sweep_deg 30 (docs/stance.md): its stance
    turns all four fins forward, so at the shipped 10 deg both trot diagonals pass ~8 cm
    ahead of the CG; at 30 deg (and the paper reading's pinwheel at 10) within 1.5 cm."""
    from manta_drake.control.gaits import BALANCED_FIN_SWEEP_DEG, get_gait
    from manta_drake.model.kinematics import support_diagonal_offsets as offsets

    assert BALANCED_FIN_SWEEP_DEG == {"paper": 10.0, "mirrored": 30.0}
    for reading, sweep in BALANCED_FIN_SWEEP_DEG.items():
        params = DEFAULT_ROBOT.with_fin_sweep(np.radians(sweep))
        assert max(map(abs, offsets(get_gait("trot", reading).X, params))) < 0.015, reading
    assert DEFAULT_ROBOT.mounts[0].sweep == pytest.approx(np.radians(10.0))  # manta.sdf's
    mirrored = get_gait("trot", "mirrored").X
    assert min(map(abs, offsets(mirrored, DEFAULT_ROBOT))) > 0.07
