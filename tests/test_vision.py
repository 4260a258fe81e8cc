"""WallDetector: synthetic clouds made here, and the rendered pool."""

import numpy as np
import pytest
from pydrake.perception import PointCloud

from manta_drake.control.vision import (
    STATUS_FIELDS,
    WallDetector,
    WallDetectorParams,
    detect,
    downsample_with_normals,
    finite_points,
    is_expected_frame_failure,
    normal_dbscan,
    wall_score,
)
from manta_drake.scenario import (
    ControllerConfig,
    InitialPose,
    Scenario,
    VisualizationConfig,
)

P = WallDetectorParams()
CAMERA = np.array([0.0, 0.0, -0.25])


def plane(origin, u, v, nu, nv, rng, noise=0.004):
    """Points on a rectangle origin + s u + t v, with Gaussian noise."""
    s, t = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv))
    pts = origin + s.ravel()[:, None] * u + t.ravel()[:, None] * v
    return pts + rng.normal(0, noise, pts.shape)


def corner_scene(rng):
    floor = plane(
        np.array([0.0, -0.5, -0.5]), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), 40, 40, rng
    )
    wall = plane(
        np.array([1.0, -0.5, -0.5]), np.array([0, 0, 0.5]), np.array([0, 1.0, 0]), 25, 40, rng
    )
    return floor, wall


def test_wall_meeting_floor_is_two_clusters_but_plain_dbscan_merges(rng):
    floor, wall = corner_scene(rng)
    cloud = np.vstack([floor, wall])
    det = detect(cloud, P, CAMERA)
    planes = [c for c in det.clusters if c.label != "object"]
    assert sorted(c.label for c in planes) == ["floor", "wall"]
    assert sum(c.size for c in planes) > 0.85 * det.num_points
    # What is left is the curved band along the corner line, labelled an object.
    for c in det.clusters:
        if c.label == "object":
            assert c.size < 0.2 * min(p.size for p in planes)
            assert c.centroid[0] == pytest.approx(1.0, abs=0.08)
            assert c.centroid[2] == pytest.approx(-0.5, abs=0.08)
    wall_cluster = next(c for c in planes if c.label == "wall")
    assert abs(wall_cluster.normal[0]) > 0.95
    assert wall_cluster.centroid[0] == pytest.approx(1.0, abs=0.02)
    # The same cloud, the same eps and min_points, without the normal test: one cluster.
    down, normals, _ = downsample_with_normals(cloud, P)
    plain = normal_dbscan(down, None, P.eps, P.min_points, None)
    assert len(set(plain[plain >= 0])) == 1
    assert (plain >= 0).mean() > 0.95


def test_floor_wall_ceiling_and_small_object_labels(rng):
    floor, wall = corner_scene(rng)
    ceiling = plane(
        np.array([0.0, -0.5, 0.0]), np.array([0.8, 0, 0]), np.array([0, 1.0, 0]), 30, 35, rng
    )
    ball = np.array([0.5, 0.0, -0.35]) + 0.05 * rng.normal(size=(300, 3)) / np.sqrt(3)
    outliers = rng.uniform(-1, 1, (15, 3))
    nans = np.full((50, 3), np.nan)
    det = detect(np.vstack([floor, wall, ceiling, ball, outliers, nans]), P, CAMERA)
    labels = {c.label for c in det.clusters if c.size >= P.min_cluster_size}
    assert {"floor", "wall", "ceiling"} <= labels
    near_ball = [c for c in det.clusters if np.linalg.norm(c.centroid - [0.5, 0, -0.35]) < 0.05]
    assert near_ball and all(c.label == "object" for c in near_ball)
    ceiling_cluster = next(c for c in det.clusters if c.label == "ceiling")
    assert ceiling_cluster.centroid[2] == pytest.approx(0.0, abs=0.02)


@pytest.mark.parametrize(
    "cloud", [np.zeros((0, 3)), np.full((500, 3), np.nan), np.array([[0.0, 0.0, 0.0]])]
)
def test_empty_or_nan_cloud_gives_zero_without_error(cloud):
    det = detect(cloud, P, CAMERA)
    assert det.s_hat == 0.0 and det.wall_size == 0


def test_finite_points_accepts_drake_layout():
    xyz = np.array([[0, 1, np.nan, 3], [0, 1, 2, 3], [0, 1, 2, 3]], dtype=float)  # (3, N)
    np.testing.assert_array_equal(finite_points(xyz), [[0, 0, 0], [1, 1, 1], [3, 3, 3]])


def test_only_walls_ahead_count(rng):
    floor, wall = corner_scene(rng)  # the wall's normal is along x
    cloud = np.vstack([floor, wall])
    ahead = detect(cloud, P, CAMERA, view_direction=[1.0, 0.0, -0.2])
    side = detect(cloud, P, CAMERA, view_direction=[0.0, 1.0, -0.2])
    assert ahead.s_hat > 0.9 and ahead.wall_size > P.c_max
    assert side.s_hat == 0.0  # the same wall seen side-on is a side wall


def test_wall_score_is_eq10_sigmoid():
    c_mid = (P.c_min + P.c_max) / 2
    k = 10 / (P.c_max - P.c_min)
    for c in (5, 20, 70, 120, 300):
        assert wall_score(c, P) == pytest.approx(1 / (1 + np.exp(-k * (c - c_mid))))
    assert wall_score(c_mid, P) == pytest.approx(0.5)
    assert wall_score(0, P) == 0.0


def test_system_holds_output_between_frames_and_survives_empty_input(rng):
    from pydrake.systems.analysis import Simulator

    floor, wall = corner_scene(rng)
    system = WallDetector(period=0.2)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    cloud = PointCloud(len(floor) + len(wall))
    cloud.mutable_xyzs()[:] = np.vstack([floor, wall]).T
    port = system.GetInputPort("point_cloud")
    port.FixValue(context, cloud)
    s_hat = system.GetOutputPort("s_hat")
    assert s_hat.Eval(context)[0] == 0.0  # nothing seen before the first frame
    simulator.AdvanceTo(0.1)  # the frame at t = 0 has run
    first = s_hat.Eval(context)[0]
    assert first > 0.9
    port.FixValue(context, PointCloud(0))  # the camera goes blind
    simulator.AdvanceTo(0.19)
    assert s_hat.Eval(context)[0] == first  # held between frames
    simulator.AdvanceTo(0.25)  # the frame at t = 0.2 saw nothing
    assert s_hat.Eval(context)[0] == 0.0
    detection = system.GetOutputPort("clusters").Eval(context)
    assert detection.clusters == [] and detection.time == pytest.approx(0.2)
    status = dict(zip(STATUS_FIELDS, system.GetOutputPort("detector_status").Eval(context)))
    assert status["frames"] == 2 and status["failed_frames"] == 0
    # the best frame so far is the first one, with its wall
    best = system.GetOutputPort("best_clusters").Eval(context)
    assert best.time == 0.0 and best.wall_size > 0


def test_a_bug_in_a_frame_fails_the_run_with_its_reason(rng, monkeypatch):
    """Only expected per-frame failures are counted; anything else is raised."""
    from pydrake.systems.analysis import Simulator

    import manta_drake.control.vision as vision

    def buggy(*args, **kwargs):
        return None + 1  # a TypeError, as a wrong-typed parameter would give

    monkeypatch.setattr(vision, "detect", buggy)
    system = WallDetector(period=0.2)
    simulator = Simulator(system)
    cloud = PointCloud(100)
    cloud.mutable_xyzs()[:] = rng.normal(size=(3, 100))
    system.GetInputPort("point_cloud").FixValue(simulator.get_mutable_context(), cloud)
    with pytest.raises(RuntimeError, match="WallDetector: frame at t = 0.000 s failed: TypeError"):
        simulator.AdvanceTo(0.1)


def test_expected_frame_failures():
    assert is_expected_frame_failure(np.linalg.LinAlgError("SVD did not converge"))
    assert is_expected_frame_failure(RuntimeError("[Open3D ERROR] bad cloud"))
    assert not is_expected_frame_failure(TypeError("unsupported operand"))
    assert not is_expected_frame_failure(RuntimeError("something else"))


def _rendered_s_hat(x_body: float, tmp_path, depth_noise_std: float = 0.005) -> float:
    from manta_drake.simulate import run

    s = Scenario(
        name="camera",
        duration=0.45,
        initial_stance="trot",
        controller=ControllerConfig(mode="hold", gait="trot"),
        initial_pose=InitialPose(xyz=[x_body, 0.0, -0.237]),
        visualization=VisualizationConfig(meshcat=False),
    )
    s.camera.enabled = True
    s.camera.depth_noise_std = depth_noise_std
    result = run(s.validate(), tmp_path, progress=False, write_outputs=False)
    status = dict(zip(STATUS_FIELDS, result.log["detector_status"][-1]))
    assert status["frames"] == 2 and status["failed_frames"] == 0  # logged before t = 0.4's frame
    return float(result.log["s_hat"][-1, 0])


@pytest.mark.slow
def test_rendered_pool_wall_near_and_far(tmp_path):
    camera_x = 0.19  # the camera frame's offset ahead of the body origin
    assert _rendered_s_hat(7.5 - 0.5 - camera_x, tmp_path / "near") > 0.9
    assert _rendered_s_hat(7.5 - 5.0 - camera_x, tmp_path / "far") < 0.1


@pytest.mark.slow
def test_rendered_wall_is_kept_at_the_largest_supported_noise(tmp_path):
    """Without the depth median filter and the PCA labelling of leftover points, at 12 mm of
    range noise and more the voxelised wall becomes a double sheet that fails the curvature
    guard, and the wall is lost at 0.4-0.6 m; with them the detector keeps it to the loader's
    bound (30 mm), and out of range the noise does not make a wall up."""
    from manta_drake.scenario import MAX_DEPTH_NOISE

    camera_x = 0.19
    assert MAX_DEPTH_NOISE == 0.03
    assert _rendered_s_hat(7.5 - 0.5 - camera_x, tmp_path / "near", 0.03) > 0.9
    assert _rendered_s_hat(7.5 - 1.0 - camera_x, tmp_path / "far", 0.03) < 0.1


def test_range_along_each_ray_against_the_pinhole_closed_form():
    """ray_scale is |(u - cx)/fx, (v - cy)/fy, 1| per pixel; beyond_ray_range cuts where
    depth times it exceeds the range: a plane facing the camera at depth z keeps exactly
    the pixels inside the circle of radius sqrt((R/z)^2 - 1) (in focal units)."""
    from manta_drake.station.depth_image_noise import beyond_ray_range, ray_scale

    w, h, f, cx, cy = 160, 120, 100.0, 79.5, 59.5
    k = ray_scale(w, h, f, f, cx, cy)
    assert k.shape == (h, w)
    assert k[60, 80] == pytest.approx(np.sqrt(1 + (0.5 / f) ** 2 * 2), rel=1e-6)
    assert k[0, 0] == pytest.approx(np.hypot(1, np.hypot(79.5 / f, 59.5 / f)), rel=1e-6)
    z, R = 0.7, 0.8
    depth = np.full((h, w), z, dtype=np.float32)
    depth[0, 0], depth[1, 1] = np.nan, np.inf  # dropouts and no-returns stay as they are
    out = beyond_ray_range(depth, k, R)
    u, v = np.meshgrid((np.arange(w) - cx) / f, (np.arange(h) - cy) / f)
    inside = u**2 + v**2 <= (R / z) ** 2 - 1
    kept = np.isfinite(out)
    kept[0, 0] = True  # the NaN pixel
    np.testing.assert_array_equal(kept[2:], inside[2:])
    assert np.isnan(out[0, 0]) and np.isinf(out[1, 1])
    np.testing.assert_array_equal(out[np.isfinite(out)], np.float32(z))  # depths unchanged


def test_median_filter_equals_scipy_and_handles_missing_pixels(rng):
    from scipy.ndimage import median_filter

    from manta_drake.control.vision import median_filter_depth

    d = (0.5 + 0.01 * rng.standard_normal((30, 40))).astype(np.float32)
    d[rng.uniform(size=d.shape) < 0.05] = np.nan
    d[:, :3] = np.inf  # out of range
    expected = median_filter(np.where(np.isfinite(d), d, np.inf), size=5, mode="nearest")
    np.testing.assert_array_equal(median_filter_depth(d, 5), expected)
    np.testing.assert_array_equal(
        median_filter_depth(d[:, :, None], 3)[:, :, 0],
        median_filter(np.where(np.isfinite(d), d, np.inf), size=3, mode="nearest"),
    )
    assert np.isfinite(median_filter_depth(d, 5)[:, 5:]).all()  # lone dropouts filled
    assert np.isinf(median_filter_depth(d, 5)[:, 0]).all()  # no-return region stays


# --- the end wall at the edge of the camera's range (three_behaviors, t = 24-40 s) ---------
#
# In three_behaviors the robot trotted up to 0.8-0.93 m (camera to wall) from the end wall
# and s_hat flipped between 1 (body yawed 10-20 deg) and 0 (facing the wall squarely). The
# detector is not the cause: the wall is beyond the camera's range there (max_range 0.8 m),
# and the station's RgbdSensor clips the *z-depth* (distance along the optical axis) at
# max_range, not the range along each ray. A view tilted against the wall (yaw, or the
# 10 deg camera pitch plus the trot's pitch) has z-depth < ray range over part of the wall,
# so a slice of the wall 0.8-1.05 m away along the rays is kept; facing it squarely, the
# whole wall's z-depth is its distance and it is clipped away. The station's sensor model
# (DepthImageNoise) now cuts on the range along each ray; these tests pin both halves.


def _standing_detections(camera_to_wall: float, yaws_deg, max_range: float | None = None):
    """The robot standing in the trot stance on the pool floor, its camera ``camera_to_wall``
    m from the end wall (x = 7.5 m), body yawed by each of ``yaws_deg``: the detector's
    Detection of one frame through the controller's real chain (station depth noise,
    median filter, DepthImageToPointCloud), and the camera's distance to the wall."""
    from manta_drake.model.plant import body_pose, set_initial_state
    from manta_drake.model.robot_params import RobotParams
    from manta_drake.wiring.diagram import build_diagram

    s = Scenario(
        name="camera",
        duration=0.45,
        initial_stance="trot",
        controller=ControllerConfig(mode="hold", gait="trot"),
        visualization=VisualizationConfig(meshcat=False),
    )
    s.camera.enabled = True
    if max_range is not None:
        s.camera.max_range = max_range
    diagram, h = build_diagram(s.validate())
    root = diagram.CreateDefaultContext()
    plant_context = h.plant.GetMyMutableContextFromRoot(root)
    to_cloud = h.systems["depth_to_cloud"]
    cloud_context = to_cloud.GetMyContextFromRoot(root)
    camera_x = RobotParams().camera_position[0]
    out = []
    for yaw in yaws_deg:
        x = 7.5 - camera_to_wall - camera_x * np.cos(np.radians(yaw))
        set_initial_state(
            h.plant_handles,
            plant_context,
            body_pose([x, 0.0, -0.25], [0.0, 0.0, yaw]),
            s.initial_joint_angles(),
        )
        X_WC = to_cloud.camera_pose_input_port().Eval(cloud_context)
        xyz = to_cloud.point_cloud_output_port().Eval(cloud_context).xyzs()
        det = detect(xyz, s.wall_detector, X_WC.translation(), 0.0, X_WC.rotation().matrix()[:, 2])
        out.append((det, 7.5 - X_WC.translation()[0]))
    return out


@pytest.mark.slow
def test_wall_ahead_is_seen_squarely_and_yawed_when_in_range():
    """Within the camera's range the detector finds the end wall ahead whether the robot
    faces it squarely or at +-15 deg (the trot's yaw swing); and with the range long enough
    to reach it, also 0.9 m away (where three_behaviors lost it when facing squarely): the
    squarely facing frame is no harder for the detector than the yawed ones."""
    for camera_to_wall, max_range in ((0.7, None), (0.9, 1.2)):
        dets = _standing_detections(camera_to_wall, (0.0, 15.0, -15.0), max_range)
        for (det, d), yaw in zip(dets, (0.0, 15.0, -15.0)):
            assert d == pytest.approx(camera_to_wall, abs=1e-3)
            assert det.s_hat > 0.9, (camera_to_wall, yaw, det.wall_size)
            assert det.wall_size > 3 * P.c_max, (camera_to_wall, yaw, det.wall_size)
            wall = max((c for c in det.clusters if c.label == "wall"), key=lambda c: c.size)
            assert abs(wall.normal[0]) > 0.98  # the end wall, not a side wall
            assert wall.centroid[0] == pytest.approx(7.5, abs=0.02)


def test_wall_beyond_the_cameras_range_is_not_seen_at_any_yaw():
    """0.85 m away the end wall is beyond max_range = 0.8 m along every ray: no view may see
    it. Facing it squarely none did; yawed by 15 deg the renderer's z-depth clip kept a
    slice of it (rays 0.8-1.0 m long) and s_hat was 1, the flip-flop of three_behaviors,
    until the station's sensor model cut on the range along each ray."""
    dets = _standing_detections(0.85, (0.0, 15.0, -15.0))
    assert dets[0][0].s_hat < 0.1  # squarely: out of range, as it should be
    assert all(det.s_hat < 0.1 for det, _ in dets), [det.wall_size for det, _ in dets]
