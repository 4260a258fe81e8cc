"""The new modalities in the whole diagram: the shipped scenarios are what they say, the flow
sensor reads the current the water model applies, the IMU's heading hold straightens the
swim, the charge estimate drives the behaviour tree, and a tree written out as Eq. (12) runs
the paper's scenario to the last bit."""

import numpy as np
import pytest

from manta_drake.control.behaviour_tree import default_tree
from manta_drake.scenario import load_scenario
from manta_drake.simulate import random_sources, run
from manta_drake.wiring.diagram import build_diagram

QUIET = {"visualization.meshcat": False}


def test_shipped_modality_scenarios_are_what_they_say():
    hold = load_scenario("swim_heading_hold")
    assert hold.imu.enabled and hold.heading_hold.enabled and hold.controller.gait == "swim"
    assert (
        load_scenario("two_behaviors_heading_hold").balloon.schedule
        == load_scenario("two_behaviors").balloon.schedule
    )
    four = load_scenario("four_behaviors")
    tree = four.behaviour_tree()
    assert tree.leaves == ("swim", "trot", "walk", "rest")
    assert set(tree.modalities) == {"z_hat", "flow_hat", "energy_hat"}
    np.testing.assert_array_equal(four.gait("rest").R, 0.0)  # the scenario's own gait file
    np.testing.assert_array_equal(four.gait("rest").X, four.gait("swim").X)
    assert four.balloon.rule.modality == "flow"
    assert not four.current_schedule().is_constant


def test_sensors_add_their_noise_sources_after_the_old_ones():
    """A scenario without the new sensors has the random sources it had before them, in the
    same order (so it draws the same noise); the sensors add theirs at the end."""
    base = load_scenario("two_behaviors", overrides=QUIET)
    more = load_scenario(
        "two_behaviors",
        overrides={
            **QUIET,
            "imu.enabled": True,
            "flow_sensor.enabled": True,
            "altimeter.enabled": True,
        },
    )
    old = [s.get_name() for s in random_sources(build_diagram(base)[0])]
    new = [s.get_name() for s in random_sources(build_diagram(more)[0])]
    assert new[: len(old)] == old
    assert new[len(old) :] == [
        "imu_noise",
        "imu_bias",
        "flow_sensor_noise",
        "altimeter_noise_normal",
        "altimeter_noise_uniform",
    ]


@pytest.mark.slow
def test_a_tree_written_as_eq_12_runs_the_paper_scenario_to_the_last_bit(tmp_path):
    """three_behaviors (the paper's run with the camera: a written tree reading s_hat needs
    it) with Eq. (12)'s tree written out runs as with the default tree, bit for bit."""
    short = {**QUIET, "duration": 2.0}
    plain = run(load_scenario("three_behaviors", overrides=short), tmp_path / "a", progress=False)
    tree = {name: vars(node) for name, node in default_tree().items()}
    written = run(
        load_scenario("three_behaviors", overrides=short, data={"transition": {"tree": tree}}),
        tmp_path / "b",
        progress=False,
    )
    for key in ("joint_angles", "body_xyz", "cpg_params", "behaviour_weights", "s_hat"):
        np.testing.assert_array_equal(plain.log[key], written.log[key])


@pytest.mark.slow
def test_flow_sensor_reads_the_current_on_the_floor(tmp_path):
    """four_behaviors starts on the floor in a 0.1 m/s cross current: the sensor's reading is
    R^T (current - v_head) (computed here from the logged hull state), with its noise's
    spread; the flow estimate is high and the balloon rule keeps the balloon empty."""
    s = load_scenario("four_behaviors", overrides={**QUIET, "duration": 4.0})
    r = run(s, tmp_path, progress=False)
    log = r.log
    # A logger at the sensor's sample time publishes before that time's update: each logged
    # value is the sample taken one period earlier (the first, the sensor's initial value).
    period = 1.0 / s.flow_sensor.rate_hz
    t = log["t_flow_velocity"][2:]
    k = np.searchsorted(log["t"], t - period - 1e-9)
    p_head = np.array(s.flow_sensor.position)
    from scipy.spatial.transform import Rotation

    q = log["body_quat_wxyz"][k]
    R = Rotation.from_quat(np.c_[q[:, 1:], q[:, :1]])
    v_head = log["body_v_world"][k] + np.cross(log["body_w_world"][k], R.apply(p_head))
    expected = R.inv().apply(np.array([0.0, 0.1, 0.0]) - v_head)
    error = log["flow_velocity"][2:] - expected
    sigma = s.flow_sensor.noise_std
    assert np.abs(error.mean(axis=0)).max() < 4 * sigma / np.sqrt(len(t))
    assert error.std(axis=0) == pytest.approx(np.full(3, sigma), rel=0.25)
    assert log["flow_hat"][-1, 0] > 0.3  # rising through its 4 s filter, never below the band
    np.testing.assert_array_equal(log["balloon_command"], 0.0)  # schedule, then the rule


@pytest.mark.slow
def test_heading_hold_slows_the_swims_turn(tmp_path):
    """The swim with the printed Phi'_swim lag turns right; held by the IMU it turns about
    a third slower over the steady window (8 s runs; the full measurement is
    swim_heading_hold's metrics; measured with the datasheet servo and the bill of
    materials' masses: -11.2 -> -7.6 deg/s). With the hull's CFD-identified yaw damping the
    turn is fast enough for the trim to saturate at its 0.3 bound, so the hold slows the
    turn rather than stopping it."""
    rate = {}
    for enabled in (False, True):
        s = load_scenario(
            "swim_heading_hold",
            overrides={**QUIET, "duration": 8.0, "heading_hold.enabled": enabled},
        )
        r = run(s, tmp_path / str(enabled), progress=False)
        rate[enabled] = r.metrics["yaw_rate_deg_s"]
        if enabled:
            assert np.abs(r.log["heading_trim"]).max() > 0.0
    assert rate[False] < -5.0
    assert abs(rate[True]) < 0.8 * abs(rate[False])


@pytest.mark.slow
def test_the_charge_estimate_drives_the_tree(tmp_path):
    """Started below the reserve, four_behaviors' tree goes to its rest gait at once."""
    s = load_scenario(
        "four_behaviors", overrides={**QUIET, "duration": 1.0, "actuators.initial_soc": 0.21}
    )
    r = run(s, tmp_path, progress=False)
    rest = s.behaviour_tree().leaves.index("rest")
    assert r.log["energy_hat"][-1, 0] == 1.0
    np.testing.assert_allclose(r.log["behaviour_weights"][-1], np.eye(4)[rest], atol=1e-12)


@pytest.mark.slow
def test_estimators_start_from_the_robots_pose_not_from_zero(tmp_path):
    """Yawed 90 deg at the start, the posture estimate starts at 90 deg (the IMU holds the
    reading at rest in the start pose before its first sample) and the heading hold holds
    that heading: the run is the yaw-0 run turned by 90 deg (the pool is far on every side),
    instead of a hold swinging the robot round to 0."""
    runs = {}
    for yaw in (0.0, 90.0):
        s = load_scenario(
            "swim_heading_hold",
            overrides={
                **QUIET,
                "duration": 3.0,
                "initial_pose.rpy_deg": [0.0, 0.0, yaw],
                "initial_pose.xyz": [0.0, 0.0, -0.045],
            },
        )
        runs[yaw] = run(s, tmp_path / str(yaw), progress=False)
    r, ref = runs[90.0], runs[0.0]
    assert r.log["attitude_hat"][0, 2] == pytest.approx(np.pi / 2, abs=1e-9)
    turned = r.metrics["final_body_rpy_deg"][2] - 90.0
    assert turned == pytest.approx(ref.metrics["final_body_rpy_deg"][2], abs=2.0)
    # The same trim in both (with the foil fins it saturates at its 0.3 bound in the first
    # seconds, against the swim's early turn: docs/behaviours.md).
    np.testing.assert_allclose(r.log["heading_trim"], ref.log["heading_trim"], atol=0.01)


@pytest.mark.slow
def test_the_wall_estimate_fills_the_balloon_and_turns_the_held_heading(tmp_path):
    """wall_and_back's rule and heading change, on the floor facing the end wall 0.6 m away
    (the camera sees it from its first frame): from the rule's ``after`` (1 s here) the
    balloon rule commands a full balloon for good (the one-way band [0, 0.9]), the schedule's
    empty one before; and the held heading becomes the heading at the hold's first update
    that read s_hat > 0.9 (0.02 s) plus 180 deg."""
    s = load_scenario(
        "wall_and_back",
        overrides={
            **QUIET,
            "duration": 4.0,
            "initial_pose.xyz": [7.5 - 0.19 - 0.6, 0.0, -0.25],
            "initial_stance": "trot",
            "balloon.initial_fill": 0.0,
            "balloon.schedule": [],
            "balloon.rule.after": 1.0,
        },
    )
    result = run(s, tmp_path, progress=False, write_outputs=False)
    log, hold = result.log, result.handles.systems["heading_hold"]
    assert log["s_hat"][1:, 0].min() > 0.9  # seen from the first frame on
    tc, fill = log["t_balloon_command"], log["balloon_command"][:, 0]
    np.testing.assert_array_equal(fill[tc < 1.0], 0.0)
    np.testing.assert_array_equal(fill[tc >= 1.0 + 0.02], 1.0)
    yaw = np.interp(s.heading_hold.period, log["t"], np.unwrap(log["body_rpy"][:, 2]))
    target = hold.target(hold.GetMyContextFromRoot(result.context))
    assert abs(np.angle(np.exp(1j * (target - (yaw + np.pi))))) < 0.02
    # Without the change the target would be the start's heading, 0.
    assert abs(target) > 3.0


@pytest.mark.slow
def test_the_altimeter_reads_the_hulls_height_and_the_tree_starts_on_the_floor(tmp_path):
    """nose_up_trot, 3 s: every reading is the transducer's height above the floor computed
    here from the logged hull pose (over cos of the tilt beyond the 15 deg half-beam), within
    the noise and the pose's motion between a ping and its log sample; the tree reading
    floor_hat starts on the trot (its initial estimate is the start pose's) and stays there."""
    from pydrake.math import RollPitchYaw

    scenario = load_scenario("nose_up_trot", overrides={**QUIET, "duration": 3.0})
    log = run(scenario, tmp_path / "run", progress=False).log
    p_BS = np.asarray(scenario.altimeter.position)
    k = np.searchsorted(log["t"], log["t_altitude"] - 1e-9)
    height, tilt = [], []
    for i in k:
        R = RollPitchYaw(log["body_rpy"][i]).ToRotationMatrix().matrix()
        height.append(log["body_xyz"][i, 2] + (R @ p_BS)[2] + 0.5)  # floor at z = -0.5
        tilt.append(np.arccos(R[2, 2]))
    beam = np.radians(scenario.altimeter.beam_half_angle_deg)
    expected = np.array(height) / np.cos(np.maximum(np.array(tilt) - beam, 0.0))
    error = log["altitude"][:, 0] - expected
    assert np.all(np.isfinite(error)) and np.median(np.abs(error)) < 0.01
    assert np.max(np.degrees(tilt)) > 15.0  # the run pitches past the beam
    np.testing.assert_array_equal(log["floor_hat"][:, 0], 1.0)
    np.testing.assert_array_equal(log["behaviour_weights"][:, 1], 1.0)  # the nose-up trot


def test_the_behaviours_page_names_every_modality_and_carries_the_registry_section():
    """docs/behaviours.md (written by the behaviours study) names each registered modality's
    estimate, and holds the registry/altimeter sections of the study's template verbatim: a
    page regenerated from an older generator, without the altimeter, fails here."""
    import pathlib

    from manta_drake.modalities import MODALITIES
    from manta_drake.studies.report import TEMPLATES

    page = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "behaviours.md").read_text()
    template = (TEMPLATES / "behaviours.md.j2").read_text()
    start = template.index("* `altitude` (`altimeter.enabled`")
    section = template[start : template.index("## Feedback from posture", start)]
    assert "{" not in section and "## Floor detection from the altimeter" in section
    assert section in page
    for modality in MODALITIES:
        assert f"`{modality.estimate}`" in page, modality.estimate
