"""Whole diagrams, short runs: locomotion, the two transition experiments, failure logs."""

import json

import numpy as np
import pytest

from manta_drake.control.gaits import GAITS
from manta_drake.control.transition import wrap
from manta_drake.scenario import load_scenario
from manta_drake.simulate import SimulationError, run


def _scenario(name, **overrides):
    s = load_scenario(name)
    s.visualization.meshcat = False
    for key, value in overrides.items():
        setattr(s, key, value)
    return s.validate()


@pytest.mark.slow
@pytest.mark.parametrize("fin_model, frequency", [("foil", 0.25), ("cross_flow", 0.5)])
def test_trot_on_the_floor_moves_forward(fin_model, frequency, tmp_path):
    """The trot walks on the floor, upright on its fins: with the foil fins (the default) at
    a quarter hertz, with the cross-flow fins at the gait's own half hertz. With the foil fins
    at 0.5 Hz the water's reaction on the swinging plates' added mass (~4 kg a leg) exceeds
    the stance's friction (0.8 x 8.3 N of net weight) and the feet slip (docs/design.md,
    section 4), so the 0.5 Hz foil trot is not a walking test."""
    s = _scenario("locomotion_trot", duration=10.0, steady_after=4.0)
    s.water.fin_model = fin_model
    s.cpg.frequency_hz = frequency
    result = run(s.validate(), tmp_path, progress=False, write_outputs=False)
    u, v = result.metrics["mean_velocity_body"]
    assert u > 0.02  # forward, m/s
    assert abs(np.degrees(result.log["body_rpy"][:, 0])).max() < 30  # upright on its fins
    assert result.log["body_xyz"][-1, 2] < -0.2  # on the floor


@pytest.mark.slow
def test_two_behaviours_swim_to_trot_by_depth(tmp_path):
    """Deflated early, the robot sinks and the depth estimate moves the CPG to the trot. At
    half charge (15.2 V on the servos' bus): with a full pack's 16.4 V the trot rears the
    hull up 20-35 deg once a cycle, which lifts the head's pressure sensor and the depth
    estimate with it (docs/design.md, section 3)."""
    s = _scenario("two_behaviors", duration=20.0)
    s.balloon.schedule[0].time = 1.0  # deflate early to keep the test short
    s.actuators.initial_soc = 0.5
    result = run(s, tmp_path, progress=False, write_outputs=False)
    log, m = result.log, result.metrics
    assert log["z_hat"][:10, 0].max() < 0.3  # swimming at the surface
    assert log["z_hat"][-50:, 0].min() > 0.9  # on the floor after deflating
    # the commanded joints settle on the trot pattern: CPG params at trot ...
    assert np.abs(wrap(log["cpg_params"][-1] - GAITS["trot"].to_vector())).max() < 0.05
    # ... and the joints oscillate with trot's offsets X and amplitudes |R| (last CPG period)
    tc = log["t_command"]
    last = tc >= tc[-1] - 2.0
    q = log["commanded_joint_angles"][last]
    np.testing.assert_allclose(0.5 * (q.max(0) + q.min(0)), GAITS["trot"].X.ravel(), atol=0.05)
    np.testing.assert_allclose(
        0.5 * (q.max(0) - q.min(0)), np.abs(GAITS["trot"].R.ravel()), atol=0.05
    )
    assert [(tr["from"], tr["to"]) for tr in m["transitions"]] == [("swim", "trot")]
    assert m["max_joint_step_rad"] < 0.01  # no jump in any commanded joint angle


@pytest.mark.slow
def test_a_switch_tree_arrives_at_the_trot(tmp_path):
    """A tree that switches between the swim and the trot on the depth (root: z_hat, switch)
    moves the target by exactly pi on the Phi entries where the two gaits are antipodal.
    Without the tie-break at the antipode (``transition.tie_broken_sine``) those 8 entries
    stayed there for good and ``transitions`` was empty (the robot ran the trot's
    amplitudes with the swim's phases); with it the trot is reached (measured: 6.48-10.26 s;
    the potential weight's own tree 3.96-8.40 s)."""
    from manta_drake.control.behaviour_tree import BlendNode

    s = _scenario("two_behaviors", duration=14.0)
    s.balloon.schedule[0].time = 1.0
    s.transition.tree = {
        "root": BlendNode(modality="z_hat", weight="switch", children=["swim", "trot"])
    }
    result = run(s.validate(), tmp_path, progress=False, write_outputs=False)
    swim, trot = s.gaits()["swim"].to_vector(), s.gaits()["trot"].to_vector()
    assert (np.abs(np.abs(wrap(trot - swim)) - np.pi) < 1e-9).sum() >= 8  # the antipodes
    assert [(tr["from"], tr["to"]) for tr in result.metrics["transitions"]] == [("swim", "trot")]
    np.testing.assert_allclose(wrap(result.log["cpg_params"][-1] - trot), 0.0, atol=0.05)


@pytest.mark.slow
def test_three_behaviours_wall_seen_then_turning(tmp_path):
    """On the floor in trot, facing the end wall just beyond the camera's range: the camera,
    the wall detector and the tree put the robot in the turning gait. With the cross-flow
    fins, whose trot walks at the gait's 0.5 Hz. How fast that gait turns the robot is the
    gait's physics, measured in the locomotion table (README), not here: on the floor the
    trot itself drifts 5 deg/s."""
    s = _scenario("three_behaviors", duration=18.0)
    s.water.fin_model = "cross_flow"
    s.initial_pose.xyz = [7.5 - 0.19 - 1.0, 0.0, -0.25]  # camera 1.0 m from the wall
    s.initial_stance = "trot"
    s.controller.gait = "trot"
    s.balloon.initial_fill = 0.0
    s.balloon.schedule = []
    result = run(s, tmp_path, progress=False, write_outputs=False)
    log, m = result.log, result.metrics
    assert log["s_hat"][0, 0] < 0.1  # the wall is out of range at first
    assert log["s_hat"][:, 0].max() > 0.9  # seen once the robot trots closer
    t_seen = log["t_s_hat"][np.argmax(log["s_hat"][:, 0] > 0.9)]
    # Within 4 s of the wall's detection the tree's weight moves to the turning leaf and the
    # CPG's fin-to-fin phase biases (where the turning gait differs from the trot: its R and
    # X are the trot's) come close to the turning gait's. They need not stay: the estimate
    # flickers as the turning robot loses the wall from view, and the tree follows it
    # (measured: weight 0.98, phases within 0.13 rad at 12.2 s, then back toward the trot).
    tw, weights = log["t_behaviour_weights"], log["behaviour_weights"]
    turning = s.behaviour_tree().leaves.index("turning")
    assert weights[tw < t_seen, turning].max() < 0.1
    soon = (tw >= t_seen) & (tw <= t_seen + 4.0)
    assert weights[soon, turning].max() > 0.9
    trot, turn = s.gaits()["trot"].to_vector(), s.gaits()["turning"].to_vector()
    differ = np.abs(wrap(turn - trot)) > 1.0
    assert differ.sum() >= 4 and np.all(np.flatnonzero(differ) >= 48)  # Phi' entries only
    tp = log["t_cpg_params"]
    psi = log["cpg_params"][(tp >= t_seen) & (tp <= t_seen + 4.0)][:, differ]
    assert np.abs(wrap(psi - turn[differ])).mean(axis=1).min() < 0.3
    assert m["max_joint_step_rad"] < 0.01


@pytest.mark.slow
def test_failed_run_still_writes_its_log_and_why(tmp_path, monkeypatch):
    import manta_drake.station.hydro as hydro

    original = hydro.HydrodynamicForces._forces_now

    def broken(self, context):
        if context.get_time() > 0.5:
            raise RuntimeError("injected fault")
        return original(self, context)

    monkeypatch.setattr(hydro.HydrodynamicForces, "_forces_now", broken)
    s = _scenario("locomotion_swim", duration=2.0)
    with pytest.raises(SimulationError, match="t = 0.5"):
        run(s, tmp_path, progress=False, write_outputs=False)
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["status"] == "failed"
    assert "injected fault" in metrics["failure"]["reason"]
    assert metrics["failure"]["time_s"] == pytest.approx(0.5, abs=0.01)
    log = np.load(tmp_path / "log.npz")
    assert 0.45 < log["t"][-1] <= 0.51  # the log up to the failure


@pytest.mark.slow
def test_meshcat_recording_does_not_change_the_simulation(tmp_path):
    """The visualizer's publish period lies on the step grid: same run with or without it."""
    logs = []
    for meshcat in (True, False):
        s = _scenario("locomotion_swim", duration=1.5)
        s.visualization.meshcat = meshcat
        logs.append(run(s, tmp_path / str(meshcat), progress=False, write_outputs=False).log)
    np.testing.assert_allclose(logs[0]["body_xyz"], logs[1]["body_xyz"], atol=1e-9)
    np.testing.assert_allclose(logs[0]["joint_angles"], logs[1]["joint_angles"], atol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("sweep_deg", [None, 10.0])
def test_mirrored_trot_stands_level_and_goes_straight_only_on_its_balanced_sweep(
    sweep_deg, tmp_path
):
    """The mirror rule makes the trot's command symmetric under "mirror, then half a period
    later", so on a balanced stance it goes straight: no side drift, no turn (docs/stance.md).
    On the paper reading's 10 deg sweep its support is ahead of the CG and it stands nose
    up (6.7 deg against 3.5 on its balanced sweep, with the bill of materials' masses; it
    still walks, 0.060 m/s). With the cross-flow fins, as docs/stance.md measured it; on
    the balanced sweep it walks 0.025 m/s with the hydroelastic feet and the servos at the
    battery's voltage (0.06 before)."""
    s = _scenario("locomotion_trot", duration=10.0, steady_after=4.0)
    s.water.fin_model = "cross_flow"
    s.controller.gait_reading = "mirrored"
    s.robot.fin_sweep_deg = sweep_deg
    result = run(s.validate(), tmp_path, progress=False, write_outputs=False)
    u, v = result.metrics["mean_velocity_body"]
    window = result.log["t"] >= 4.0
    pitch = np.degrees(result.log["body_rpy"][window, 1]).mean()  # + nose down
    if sweep_deg is None:  # the reading's own, 30 deg
        assert result.metrics["fin_sweep_deg"] == 30.0
        assert u > 0.015
        assert abs(v) < 0.2 * u
        assert abs(result.metrics["yaw_rate_deg_s"]) < 1.5
        assert abs(pitch) < 5.0
    else:
        assert pitch < -5.0  # nose up: the support is ahead of the CG
