"""Run metrics against closed forms: free-water windows, wall clearance."""

import numpy as np
import pytest

from manta_drake import metrics as M
from manta_drake.scenario import Scenario
from manta_drake.simulate import compute_metrics

HULL = (0.19, 0.12, 0.07)


def _yaw_quats(yaw):
    return np.stack([np.cos(yaw / 2), 0 * yaw, 0 * yaw, np.sin(yaw / 2)], axis=1)


def test_wall_clearance_of_the_hull_ellipsoid():
    xyz = np.array([[6.0, 0.0, -0.2], [0.0, 0.5, -0.2], [0.0, 0.5, -0.2]])
    q = _yaw_quats(np.array([0.0, 0.0, np.pi / 2]))
    c = M.wall_clearance(xyz, q, HULL, 7.5, 1.0)
    # end wall 1.5 - 0.19 ahead; side wall 0.5 - 0.12 beside; yawed 90 deg: 0.5 - 0.19
    np.testing.assert_allclose(c, [min(1.5 - 0.19, 1.0 - 0.12), 0.5 - 0.12, 0.5 - 0.19])


def test_speed_is_averaged_over_free_water_only():
    """A robot swims at 0.1 m/s toward the end wall and is then pinned against it: the mean
    velocity is its free-water speed, the window ends 0.3 m before the wall."""
    t = np.arange(0.0, 20.0, 0.01)
    x = np.minimum(5.5 + 0.1 * t, 7.5 - 0.19)  # pinned once the hull's nose touches
    xyz = np.stack([x, 0 * t, -0.05 + 0 * t], axis=1)
    q = _yaw_quats(0 * t)
    log = {"t": t, "body_xyz": xyz, "body_quat_wxyz": q, "body_rpy": M.euler_rpy(q)}
    s = Scenario(steady_after=2.0)
    m = compute_metrics(s, log, 1.0)
    t_near = (7.5 - 0.19 - 0.3 - 5.5) / 0.1  # clearance reaches 0.3 m at 15.1 s
    assert m["near_wall_at_s"] == pytest.approx(t_near, abs=0.011)
    assert m["steady_window_s"] == pytest.approx([2.0, t_near], abs=0.011)
    assert m["mean_velocity_body"][0] == pytest.approx(0.1, rel=1e-6)
    assert m["touched_wall"]
    # averaged over the whole steady part it would have been 10 % slower
    assert (x[-1] - x[200]) / 18.0 < 0.09
    # no free water at all: no speed is reported
    log2 = dict(log, body_xyz=np.stack([0 * t + 7.2, 0 * t, -0.05 + 0 * t], axis=1))
    m2 = compute_metrics(s, log2, 1.0)
    assert m2["mean_velocity_body"] is None and "shorter than" in m2["note"]
