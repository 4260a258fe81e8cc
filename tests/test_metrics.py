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


# --- behaviour transitions ---------------------------------------------------------------------

def _path(t, a, b, t0, t1):
    """Parameters moving linearly from a to b between t0 and t1."""
    s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)[:, None]
    return a + s * (b - a)


def test_transition_times_from_a_linear_path_with_jitter_at_the_start():
    from manta_drake.metrics import behaviour_transitions

    a, b = np.zeros(4), np.array([1.0, -2.0, 0.5, 3.0])
    t = np.arange(0.0, 20.0, 0.02)
    params = _path(t, a, b, 8.0, 16.0)
    # Jitter near the start behaviour from 0.4 s: 0.2 rad on one parameter (outside the 0.05
    # tolerance, 5 % of the way): the transition must still start at 8 s, not 0.4 s.
    params[(t > 0.4) & (t < 8.0), 1] += 0.2 * np.sin(t[(t > 0.4) & (t < 8.0)])
    out = behaviour_transitions(t, params, {"a": a, "b": b}, tolerance=0.05)
    assert len(out) == 1 and (out[0]["from"], out[0]["to"]) == ("a", "b")
    # Progress 0.1 of the way is 0.8 s after the linear path starts (d_s/(d_s+d_t) = s).
    assert out[0]["start_s"] == pytest.approx(8.8, abs=0.03)
    # Within 0.05 rad on every parameter: the largest one (3 rad) is the last to arrive.
    assert out[0]["end_s"] == pytest.approx(16.0 - 8.0 * 0.05 / 3.0, abs=0.03)


def test_an_excursion_that_returns_is_no_transition_and_wrapping_is_on_the_torus():
    from manta_drake.metrics import behaviour_transitions, transition_progress

    a, b = np.zeros(2), np.array([np.pi, -np.pi / 2])
    t = np.arange(0.0, 10.0, 0.05)
    params = np.where(((t > 2) & (t < 4))[:, None], 0.5 * b, a)  # halfway, then back
    assert behaviour_transitions(t, params, {"a": a, "b": b}) == []
    # -pi and pi are the same angle: progress 1 at b written either way.
    np.testing.assert_allclose(transition_progress(np.array([[-np.pi, -np.pi / 2]]), a, b), 1.0)
    np.testing.assert_allclose(transition_progress(np.array([a]), a, b), 0.0)
