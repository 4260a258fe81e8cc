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


def _weights(t, changes, leaves=2):
    """Leaf weights that hand over linearly from one leaf to the next over each (t0, t1,
    from, to) of ``changes``."""
    w = np.zeros((len(t), leaves))
    w[:, changes[0][2]] = 1.0
    for t0, t1, a, b in changes:
        s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        later = t >= t0
        w[later, a], w[later, b] = 1.0 - s[later], s[later]
    return w


def test_leaf_transitions_by_hand():
    """Weights hand over from a to b over 8-12 s (b's share passes 0.1 at 8.4 s, leads from
    10 s); the parameters follow linearly over 8-16 s and arrive (within 0.05 on every
    entry, the 3 rad one last) at 16 - 8 x 0.05 / 3 s."""
    from manta_drake.metrics import leaf_transitions

    a, b = np.zeros(4), np.array([1.0, -2.0, 0.5, 3.0])
    t = np.arange(0.0, 20.0, 0.02)
    w = _weights(t, [(8.0, 12.0, 0, 1)])
    out = leaf_transitions(
        t, w, ("a", "b"), t, _path(t, a, b, 8.0, 16.0), {"a": a, "b": b}, tolerance=0.05
    )
    assert len(out) == 1 and (out[0]["from"], out[0]["to"]) == ("a", "b")
    assert out[0]["start_s"] == pytest.approx(8.4, abs=0.021)
    assert out[0]["dominant_s"] == pytest.approx(10.0, abs=0.021)
    assert out[0]["end_s"] == pytest.approx(16.0 - 8.0 * 0.05 / 3.0, abs=0.03)


def test_a_brief_lead_is_no_change_and_a_change_need_not_arrive():
    """b leads for 1 s (under the 2 s a change must last): no transition; then c takes
    over for good but the parameters never reach it: its end is None; wrapping is on the
    torus (-pi and pi are the same angle)."""
    from manta_drake.metrics import TRANSITION_MIN_LEAD, leaf_transitions, transition_span

    assert TRANSITION_MIN_LEAD == 2.0
    t = np.arange(0.0, 20.0, 0.02)
    w = _weights(t, [(4.0, 4.02, 0, 1), (5.0, 5.02, 1, 0), (10.0, 11.0, 0, 2)], leaves=3)
    vectors = {"a": np.zeros(2), "b": np.ones(2), "c": np.array([np.pi, 1.0])}
    params = np.tile([-np.pi, 0.5], (len(t), 1))  # at c's first entry (wrapped), not its second
    out = leaf_transitions(t, w, ("a", "b", "c"), t, params, vectors, tolerance=0.05)
    assert [(tr["from"], tr["to"]) for tr in out] == [("a", "c")]
    assert out[0]["end_s"] is None and out[0]["dominant_s"] == pytest.approx(10.5, abs=0.021)
    assert transition_span(out[0]) == f"{out[0]['start_s']:.1f}-never"
    params[t >= 13.0, 1] = 1.0  # now it arrives, at 13 s
    arrived = leaf_transitions(t, w, ("a", "b", "c"), t, params, vectors, tolerance=0.05)
    assert arrived[0]["end_s"] == pytest.approx(13.0, abs=0.021)


def test_heading_change_counts_whole_turns():
    from manta_drake.metrics import heading_change_deg

    yaw = np.radians(np.linspace(0.0, -400.0, 801))  # clockwise past a whole turn
    assert heading_change_deg(_yaw_quats(yaw)) == pytest.approx(-400.0, abs=1e-6)


# --- the note says only what happened ----------------------------------------------------------


def _still_log(duration, x=0.0):
    """A hull at rest at x (m) along the pool's axis, logged every 10 ms for ``duration`` s."""
    t = np.arange(0.0, duration + 1e-9, 0.01)
    q = _yaw_quats(0 * t)
    xyz = np.stack([0 * t + x, 0 * t, -0.05 + 0 * t], axis=1)
    return {"t": t, "body_xyz": xyz, "body_quat_wxyz": q, "body_rpy": M.euler_rpy(q)}


def test_a_short_run_far_from_the_walls_is_told_short_not_near_a_wall():
    """1.2 s in mid-pool (0.88 m from a side wall): the window 0.6-1.2 s is short because the
    run ended, and the note says that and nothing about a wall."""
    m = compute_metrics(Scenario(steady_after=2.0), _still_log(1.2), 1.0)
    assert m["near_wall_at_s"] is None and m["min_wall_clearance_m"] == pytest.approx(0.88)
    assert m["steady_window_s"] == pytest.approx([0.6, 1.2])
    assert m["note"] == (
        "steady window 0.60-1.20 s is shorter than 1.0 s (the run ended at "
        "1.20 s): no mean velocity"
    )
    assert "wall" not in m["note"]


def test_a_wall_approach_is_named_with_its_time():
    """Swimming at 0.1 m/s from x = 7.0 - 0.19 - 0.3 - 0.25 toward the end wall at 7.5 m
    (clearance 0.3 m reached at 2.5 s... with a 20 s run the window 2.0-2.5 s is short
    only because of the wall, so the run's length is not named."""
    t = np.arange(0.0, 20.0, 0.01)
    x0 = 7.5 - 0.19 - 0.3 - 0.25
    log = _still_log(19.99)
    log["body_xyz"][:, 0] = np.minimum(x0 + 0.1 * t, 7.5 - 0.19)
    m = compute_metrics(Scenario(steady_after=2.0), log, 1.0)
    assert m["near_wall_at_s"] == pytest.approx(2.5, abs=0.011)
    near = m["near_wall_at_s"]
    assert m["note"] == (
        f"steady window 2.00-{near:.2f} s is shorter than 1.0 s (the hull "
        f"came within 0.3 m of a wall at {near:.2f} s): no mean velocity"
    )
    # Both causes at once: a 1.2 s run that also reaches the wall at 0.9 s.
    both = M.short_window_note(0.6, 0.9, 1.0, 1.2, 0.9, 0.3)
    assert both == (
        "steady window 0.60-0.90 s is shorter than 1.0 s (the hull came within "
        "0.3 m of a wall at 0.90 s; the run ended at 1.20 s): no mean velocity"
    )


def test_the_energy_notes_name_what_is_missing():
    t = np.arange(0.0, 1.201, 0.01)
    log = {
        "t_electrical_power": t,
        "electrical_power": 30.0 + 0 * t[:, None],
        "t_joint_mechanical_power": t,
        "joint_mechanical_power": np.ones((len(t), 16)),
        "t_battery": t,
        "battery": np.tile([0.9, 16.0, 2.0], (len(t), 1)),
    }
    short = M.energy_metrics(log, 8.4, 50.0, 0.2, [0.6, 1.2], None)
    assert all(short[k] is None for k in (*M.COT_KEYS, *M.COT_ALIASES))
    assert short["cost_of_transport_note"] == (
        "no mean velocity over the steady window "
        "0.60-1.20 s (the run's note says why): no "
        "cost of transport"
    )
    none = M.energy_metrics(log, 8.4, 50.0, 0.2, None, None)
    assert none["cost_of_transport_note"] == "no steady window: no cost of transport"
    assert none["mean_electrical_power_w"] == pytest.approx(30.0)


def test_costs_of_transport_closed_form():
    cots = M.costs_of_transport(28.0, 5.0, 21.0, 82.4, 8.24, 0.1)
    assert set(cots) == set(M.COT_KEYS) and len(M.COT_KEYS) == 6
    assert cots["cot_electrical_dry_weight"] == pytest.approx(28.0 / 8.24)
    assert cots["cot_net_of_hotel_dry_weight"] == pytest.approx(7.0 / 8.24)
    assert cots["cot_mechanical_weight_in_water"] == pytest.approx(5.0 / 0.824)
    # The weight in water is ten times smaller: every cost by it ten times larger.
    assert cots["cot_electrical_weight_in_water"] == pytest.approx(
        10 * cots["cot_electrical_dry_weight"]
    )
    floating = M.costs_of_transport(28.0, 5.0, 21.0, 82.4, -1.0, 0.1)
    assert floating["cot_electrical_weight_in_water"] is None
    assert floating["cot_electrical_dry_weight"] == cots["cot_electrical_dry_weight"]


def test_a_floating_robot_has_no_cost_of_transport_by_its_weight_in_water():
    t = np.arange(0.0, 2.001, 0.01)
    log = {
        "t_electrical_power": t,
        "electrical_power": 30.0 + 0 * t[:, None],
        "t_joint_mechanical_power": t,
        "joint_mechanical_power": np.ones((len(t), 16)),
        "t_battery": t,
        "battery": np.tile([0.9, 16.0, 2.0], (len(t), 1)),
    }
    e = M.energy_metrics(
        log, 8.4, 50.0, 0.2, [1.0, 2.0], [0.1, 0.0], weight_in_water_kg=-0.2, hotel_power_w=20.0
    )
    assert e["cot_net_of_hotel_dry_weight"] == pytest.approx(10.0 / (8.4 * 9.81 * 0.1))
    assert e["cot_mechanical_dry_weight"] == pytest.approx(16.0 / (8.4 * 9.81 * 0.1))
    assert e["cot_electrical_weight_in_water"] is None
    # The original names stand for the dry-weight electrical and mechanical costs.
    assert e["cost_of_transport"] == pytest.approx(30.0 / (8.4 * 9.81 * 0.1))
    assert e["cost_of_transport_mechanical"] == pytest.approx(16.0 / (8.4 * 9.81 * 0.1))
    assert "floats" in e["cost_of_transport_note"]


def test_power_breakdown_means_each_term_over_the_window():
    t = np.arange(0.0, 2.001, 0.01)
    ramp = np.tile(t[:, None], (1, 4))  # 4 joints, each t watts at time t
    b = M.power_breakdown(t, {"computers": np.full(len(t), 11.0), "copper": ramp}, [1.0, 2.0])
    assert b["computers_w"] == pytest.approx(11.0)
    # Each sample holds the step that ends at it: the mean of 4 t over (1, 2] on a 10 ms grid.
    assert b["copper_w"] == pytest.approx(4 * np.mean(t[(t > 1.0) & (t <= 2.0 + 1e-9)]))
    assert b["total_w"] == pytest.approx(b["computers_w"] + b["copper_w"])
    assert b["window_s"] == [1.0, 2.0]
    assert M.power_breakdown(t, {"copper": ramp})["window_s"] == [0.0, 2.0]


# --- Euler angles through the gimbal lock ------------------------------------------------------


def _quat_rpy(roll, pitch, yaw):
    """The quaternion (w, x, y, z) of Rz(yaw) Ry(pitch) Rx(roll), by the half-angle product
    qz * qy * qx written out (the closed form, independent of the code under test)."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array(
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ]
    )


def _wrapped(a):
    return np.angle(np.exp(1j * np.asarray(a)))


@pytest.mark.parametrize("roll, yaw", [(0.3, 0.5), (2.9, -2.8), (-1.0, 3.0), (0.0, 0.0)])
def test_euler_angles_at_the_gimbal_lock_keep_the_determined_combination(roll, yaw):
    """At pitch +90 deg Rz(y) Ry(90) Rx(r) depends on y - r only, at -90 deg on y + r: the
    angles must give back that combination (no 0/0, no warning), split as Drake does
    (yaw = -roll at +90, yaw = roll at -90)."""
    import warnings

    q = np.array([_quat_rpy(roll, np.pi / 2, yaw), _quat_rpy(roll, -np.pi / 2, yaw)])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rpy = M.euler_rpy(q)
    up, down = rpy
    assert up[1] == pytest.approx(np.pi / 2, abs=1e-7)
    assert down[1] == pytest.approx(-np.pi / 2, abs=1e-7)
    assert _wrapped(up[2] - up[0] - (yaw - roll)) == pytest.approx(0.0, abs=1e-7)
    assert _wrapped(down[2] + down[0] - (yaw + roll)) == pytest.approx(0.0, abs=1e-7)
    assert up[2] == pytest.approx(-up[0], abs=1e-12) and down[2] == pytest.approx(down[0])
    # The angles given back describe the same orientation (the closed form again).
    np.testing.assert_allclose(
        np.abs(np.einsum("ij,ij->i", q, [_quat_rpy(*a) for a in rpy])), 1.0, atol=1e-12
    )


@pytest.mark.parametrize("offset", [1e-3, 1e-6])
def test_euler_angles_near_the_gimbal_lock_are_the_true_ones(offset):
    """Just short of the lock every angle is still determined, and recovered."""
    for pitch in (np.pi / 2 - offset, -np.pi / 2 + offset):
        rpy = M.euler_rpy(_quat_rpy(0.3, pitch, -2.0)[None])[0]
        np.testing.assert_allclose(rpy, [0.3, pitch, -2.0], atol=1e-15 / offset + 1e-9)


def test_euler_angles_match_drakes_roll_pitch_yaw_everywhere():
    """Random orientations, and orientations at and near the lock, against Drake's own
    RollPitchYaw (an independent implementation)."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RollPitchYaw

    rng = np.random.default_rng(3)
    q = rng.normal(size=(300, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    lock = [
        _quat_rpy(r, p, y)
        for r, y in rng.uniform(-3, 3, (20, 2))
        for p in (np.pi / 2, -np.pi / 2, np.pi / 2 - 1e-8)
    ]
    q = np.vstack([q, lock])
    expected = np.array([RollPitchYaw(Quaternion(x / np.linalg.norm(x))).vector() for x in q])
    np.testing.assert_allclose(M.euler_rpy(q), expected, atol=1e-9)


def test_yaw_rate_of_a_robot_nearly_on_its_nose_is_its_turn():
    """Pitched 0.01 deg short of -90 (nose down), rolled 20 deg and turning about the
    world's vertical at 10 deg/s: the yaw rate is 10 deg/s."""
    t = np.arange(0.0, 3.0, 0.01)
    pitch = -np.pi / 2 + np.radians(0.01)
    q = np.array([_quat_rpy(np.radians(20.0), pitch, yaw) for yaw in np.radians(10.0) * t])
    assert M.yaw_rate_deg_s(t, q, 0.0) == pytest.approx(10.0, abs=1e-6)


def test_the_trajectory_is_drawn_at_the_paths_scale():
    """A short path far from the walls gets its own box plus 0.5 m; one near a wall shows
    the wall (the box stops 0.5 m beyond it); a path shorter than 1 m is widened to 1 m."""
    from manta_drake.plots import trajectory_limits

    (x0, x1), (y0, y1) = trajectory_limits(np.array([[1.0, 0.0], [2.0, 0.2]]))
    assert (x0, x1) == pytest.approx((0.5, 2.5)) and (y0, y1) == pytest.approx((-0.5, 0.7))
    (_, _), (y0, y1) = trajectory_limits(np.array([[1.0, 0.7], [1.1, 0.9]]))
    assert y1 == pytest.approx(1.4) and y1 > 1.0  # the wall at y = 1 is inside the view
    (x0, x1), _ = trajectory_limits(np.array([[7.3, 0.0], [7.4, 0.0]]))
    assert x1 == pytest.approx(7.9) and x0 == pytest.approx(6.8)  # the end wall at 7.5 shows
    (x0, x1), _ = trajectory_limits(np.array([[-9.0, 0.0], [9.0, 0.0]]))  # beyond the pool
    assert (x0, x1) == pytest.approx((-8.0, 8.0))
    (x0, x1), _ = trajectory_limits(np.array([[0.0, 0.0], [0.0, 0.0]]))
    assert x1 - x0 == pytest.approx(1.0)
