"""The fault campaign (manta_drake.studies.faults) on a few tiny runs: rows, refusals naming
the field, finite numbers for a normal run, a crashed worker recorded as a crash (not a dead
campaign)."""

import math

import pytest

from manta_drake.studies import faults


@pytest.fixture(scope="module")
def fc():
    return faults


def test_draws_are_seeded_and_well_formed(fc):
    a, b = fc.draw_specs(40, seed=3), fc.draw_specs(40, seed=3)
    assert a == b
    assert a != fc.draw_specs(40, seed=4)
    for spec in a:
        assert spec["base"] in fc.BASES
        o = spec["overrides"]
        assert 2.0 <= o["duration"] <= 4.0 and o["visualization.meshcat"] is False
        if "time_step" in o and "time_step_bad" not in spec["faults"]:
            assert 0.5e-3 <= o["time_step"] <= 2e-3 and o["simulator.max_step_size"] == o["time_step"]
        if "current" in spec["faults"] and "current_over" not in spec["faults"]:
            assert math.hypot(*o["water.current"]) <= 0.3 + 1e-9


def test_rows_in_process(fc, tmp_path):
    specs = [
        fc.make_spec(0, "locomotion_swim", {"water.current": [0.1, -0.05, 0.0],
                                            "pressure_sensor.dropout_rate": 0.3}),
        fc.make_spec(1, "locomotion_trot", {"water.current": [1.2, 0.3, 0.0]},
                     expect=["water.current"]),
        fc.make_spec(2, "float_sink", {"camera.depth_noise_std": 0.05},
                     expect=["camera.depth_noise_std"]),
        fc.make_spec(3, "locomotion_walk", {"initial_pose.xyz": [7.6, 0.0, -0.24]},
                     expect=["initial_pose"]),
    ]
    rows = fc.run_campaign(specs, tmp_path, workers=0, echo=lambda *_: None)
    ok, current, depth, wall = rows
    assert ok["outcome"] == "ok" and ok["expectation"] == "as_expected"
    assert ok["nan_in_log"] is False and ok["left_pool"] is False  # dropout NaNs are modelled
    for key in ("max_penetration_m", "max_joint_limit_violation_rad", "max_joint_speed_rad_s",
                "mean_speed_m_s", "max_body_rate_rad_s", "wall_time_s"):
        assert math.isfinite(ok[key]), key
    assert ok["sim_time_reached_s"] == pytest.approx(0.3)
    for row, field in ((current, "water.current"), (depth, "camera.depth_noise_std"),
                       (wall, "initial_pose")):
        assert row["outcome"] == "refused" and row["cause"] == field, row["message"]
        assert row["message"].startswith(field) and row["expectation"] == "as_expected"
    # The reproduction file loads to the same (accepted) scenario.
    from manta_drake.scenario import load_scenario

    s = load_scenario(tmp_path / "runs" / "run_0000" / "scenario.yaml")
    assert s.water.current == [0.1, -0.05, 0.0] and s.duration == 0.3
    summary = fc.summarise(rows)
    assert summary["outcomes"]["ok"] == 1 and summary["outcomes"]["refused"] == 3
    assert summary["check_failures"] == {}
    fc.write_outputs(rows, summary, tmp_path)
    assert (tmp_path / "runs.csv").read_text().count("\n") == 5


def test_worker_crash_is_recorded_not_fatal(fc, tmp_path):
    crash = fc.make_spec(0, "stand", duration=0.1)
    crash["inject_crash"] = True  # segfaults the worker process executing it
    specs = [crash, fc.make_spec(1, "stand", duration=0.1)]
    rows = fc.run_campaign(specs, tmp_path, workers=1, echo=lambda *_: None)
    assert [r["outcome"] for r in rows] == ["crashed", "ok"]
    assert fc.summarise(rows)["check_failures"] == {"crashed": [0]}


def test_log_stats_flags_pool_exit_limits_and_nan(fc):
    import numpy as np

    t = np.linspace(0.0, 1.0, 5)
    q = np.zeros((5, 16))
    q[2, 0] = np.radians(60) + 0.05  # fl_yaw 0.05 rad past its +60 deg limit
    qd = np.zeros((5, 16))
    qd[3, 5] = -9.0
    xyz = np.tile([0.0, 0.0, -0.2], (5, 1))
    xyz[4] = [7.6, 0.0, -0.2]  # through the end wall
    v = np.zeros((5, 3))
    log = {"t": t, "joint_angles": q, "joint_velocities": qd, "body_xyz": xyz,
           "body_v_world": v, "body_w_world": v, "depth": np.full((5, 1), np.nan)}
    s = fc.log_stats(log, dropout=0.2)
    assert s["nan_in_log"] is False  # depth NaNs are the modelled dropout
    assert s["left_pool"] and s["pool_exit"] == "x=7.600"
    assert s["max_joint_limit_violation_rad"] == pytest.approx(0.05)
    assert s["max_joint_speed_rad_s"] == 9.0
    assert fc.log_stats(log, dropout=0.0)["nan_keys"] == "depth"


def test_initial_penetration_of_an_accepted_start(fc):
    from manta_drake.scenario import load_scenario

    s = load_scenario("stand")
    assert fc.initial_penetration(s)[0] < 0.0025  # the shipped start: no contact
    s.initial_pose.xyz, s.initial_pose.rpy_deg = [0.0, 0.0, -0.19], [90.0, 0.0, 0.0]
    depth, pair = fc.initial_penetration(s)
    assert depth > 0.0025 and "floor" in pair
