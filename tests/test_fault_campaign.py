"""The fault campaign (manta_drake.studies.faults) on a few tiny runs: rows, refusals naming
the field, finite numbers for a normal run, a crashed worker recorded as a crash (not a dead
campaign)."""

import math

import pytest

from manta_drake.studies import faults


@pytest.fixture(scope="module")
def fc():
    return faults


@pytest.mark.slow
def test_draws_are_seeded_and_well_formed(fc):
    a, b = fc.draw_specs(40, seed=3), fc.draw_specs(40, seed=3)
    assert a == b
    assert a != fc.draw_specs(40, seed=4)
    for spec in a:
        assert spec["base"] in fc.BASES
        o = spec["overrides"]
        assert 2.0 <= o["duration"] <= 4.0 and o["visualization.meshcat"] is False
        if "time_step" in o and "time_step_bad" not in spec["faults"]:
            assert 0.5e-3 <= o["time_step"] <= 2e-3
            assert o["simulator.max_step_size"] == o["time_step"]
        if "current" in spec["faults"] and "current_over" not in spec["faults"]:
            (key,) = o["water.current_schedule"]  # a constant: the schedule's one key
            assert key["time"] == 0.0 and math.hypot(*key["velocity"]) <= 0.3 + 1e-9


@pytest.mark.slow
def test_rows_in_process(fc, tmp_path):
    specs = [
        fc.make_spec(
            0,
            "locomotion_swim",
            {
                "water.current_schedule": [{"time": 0.0, "velocity": [0.1, -0.05, 0.0]}],
                "pressure_sensor.dropout_rate": 0.3,
            },
        ),
        fc.make_spec(
            1,
            "locomotion_trot",
            {"water.current_schedule": [{"time": 0.0, "velocity": [1.2, 0.3, 0.0]}]},
            expect=["water.current_schedule"],
        ),
        fc.make_spec(
            2, "float_sink", {"camera.depth_noise_std": 0.05}, expect=["camera.depth_noise_std"]
        ),
        fc.make_spec(
            3, "locomotion_walk", {"initial_pose.xyz": [7.6, 0.0, -0.24]}, expect=["initial_pose"]
        ),
    ]
    rows = fc.run_campaign(specs, tmp_path, workers=0, echo=lambda *_: None)
    ok, current, depth, wall = rows
    assert ok["outcome"] == "ok" and ok["expectation"] == "as_expected"
    assert ok["nan_in_log"] is False and ok["left_pool"] is False  # dropout NaNs are modelled
    for key in (
        "max_penetration_m",
        "max_joint_limit_violation_rad",
        "max_joint_speed_rad_s",
        "mean_speed_m_s",
        "max_body_rate_rad_s",
        "wall_time_s",
    ):
        assert math.isfinite(ok[key]), key
    assert ok["sim_time_reached_s"] == pytest.approx(0.3)
    for row, field in (
        (current, "water.current_schedule[0].velocity"),
        (depth, "camera.depth_noise_std"),
        (wall, "initial_pose"),
    ):
        assert row["outcome"] == "refused" and row["cause"] == field, row["message"]
        assert row["message"].startswith(field) and row["expectation"] == "as_expected"
    # The reproduction file loads to the same (accepted) scenario.
    from manta_drake.scenario import load_scenario

    s = load_scenario(tmp_path / "runs" / "run_0000" / "scenario.yaml")
    assert s.current_schedule().velocities.tolist() == [[0.1, -0.05, 0.0]]
    assert s.duration == 0.3
    summary = fc.summarise(rows)
    assert summary["outcomes"]["ok"] == 1 and summary["outcomes"]["refused"] == 3
    assert summary["check_failures"] == {}
    fc.write_outputs(rows, summary, tmp_path)
    assert (tmp_path / "runs.csv").read_text().count("\n") == 5


@pytest.mark.slow
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
    log = {
        "t": t,
        "joint_angles": q,
        "joint_velocities": qd,
        "body_xyz": xyz,
        "body_v_world": v,
        "body_w_world": v,
        "depth": np.full((5, 1), np.nan),
    }
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


# One message of each form the package's refusals take, and the field each is filed under.
REFUSAL_FORMS = [
    # check_in_range, check_number, check_integer, check_one_of, check_vector
    ("time_step: 0.05 is outside the allowed range [0.0001, 0.01] s", "time_step"),
    (
        "camera.depth_noise_std: 0.05 is outside the allowed range [0, 0.03] m (the depth-camera "
        "model: a RealSense-class sensor's range noise within its 0.8 m underwater range)",
        "camera.depth_noise_std",
    ),
    ("pressure_sensor.noise_std: 'a' is not a number", "pressure_sensor.noise_std"),
    ("duration: inf is not finite", "duration"),
    ("camera.width: 7.5 is not an integer (allowed: 8 to 1024)", "camera.width"),
    ("controller.gait: 'fly' is not one of swim, trot, walk, turning, crab", "controller.gait"),
    ("water.current: [1.2, 0.0, 0.0] has magnitude above the allowed 1.0 m/s", "water.current"),
    ("water.current[0]: nan is not finite", "water.current[0]"),
    (
        "balloon.schedule[1].time: 0.5 is before the previous command's time 1.0; times must "
        "not decrease",
        "balloon.schedule[1].time",
    ),
    # check_keys (layering) and the dotted-key walk (overrides)
    (
        "scenario.water.curent: unknown key (a typo?); allowed keys: coefficient_scales, "
        "coefficients, current, enabled, update_period",
        "water.curent",
    ),
    ("scenario.time_step: expected a float, got 'abc'", "time_step"),
    ("scenario.water.coefficient_scales key: expected a str, got 1", "water.coefficient_scales"),
    (
        "water.curent: scenario.water has no field 'curent'; allowed: coefficient_scales, "
        "coefficients, current, enabled, update_period",
        "water.curent",
    ),
    (
        "water.coefficient_scales.body.linear_dampnig: unknown coefficient 'body.linear_dampnig'; "
        "allowed: water_density, gravity",
        "water.coefficient_scales.body.linear_dampnig",
    ),
    # the start-pose check
    (
        "initial_pose: the body at [0.0, 0.0, -0.9] m is not in the pool's water (x in (-7.5, "
        "7.5), y in (-1.0, 1.0), z in (-0.5, 0])",
        "initial_pose",
    ),
    # coefficient scales: a bad factor, and a scaled set the coefficient checks refuse
    (
        "water.coefficient_scales.body.added_mass: -0.5 must be a finite number >= 0",
        "water.coefficient_scales.body.added_mass",
    ),
    (
        "water.coefficient_scales.fins.strips_per_plate = 5.2 must be a whole number",
        "water.coefficient_scales.fins.strips_per_plate",
    ),
    (
        "water.coefficient_scales.water_density = 0.0 must be > 0",
        "water.coefficient_scales.water_density",
    ),
    (
        "water.coefficient_scales.body.sealed_volume = 0.00663 m^3 disagrees with "
        "body.sealed_semi_axes (4/3 pi abc = 0.0051 m^3, more than 1% apart); the buoyancy comes "
        "from the semi-axes: change both together",
        "water.coefficient_scales.body.sealed_volume",
    ),
    # a coefficient or actuator file: filed under the scenario field that names it
    (
        "water.coefficients = /tmp/bad_hydro.yaml: bad_hydro.yaml: body.added_mass = "
        "[-1.0, 1.0, 1.0] must be >= 0 (magnitudes)",
        "water.coefficients",
    ),
    (
        "actuators.file = /tmp/bad_act.yaml: actuators file not found: /tmp/bad_act.yaml",
        "actuators.file",
    ),
    # actuators: a bad factor, a scaled set refused, the initial charge
    (
        "actuators.scales.servo.winding_resistance: -1.0 must be a finite number >= 0",
        "actuators.scales.servo.winding_resistance",
    ),
    (
        "actuators.scales.battery.cutoff_soc = 2.0 is outside the allowed range [0, 1)",
        "actuators.scales.battery.cutoff_soc",
    ),
    (
        "actuators.initial_soc: 0.01 is outside the allowed range (cutoff_soc = 0.2, 1]",
        "actuators.initial_soc",
    ),
    # a scenario file's path in front (load_scenario with validation)
    (
        "/work/main/models/scenarios/locomotion_swim.yaml: time_step: 0.5 is outside the allowed "
        "range [0.0001, 0.01] s",
        "time_step",
    ),
    # the System constructors' ValueErrors (build stage)
    ("BalloonBuoyancy.max_volume: 0.0 must be a finite number > 0", "BalloonBuoyancy.max_volume"),
    (
        "HydrodynamicForces.update_period: -1.0 must be a finite number >= 0",
        "HydrodynamicForces.update_period",
    ),
    # no field at the start: grouped by the message's first clause
    ("scenario file not found: nope (shipped scenarios: stand)", "scenario file not found: nope"),
]


@pytest.mark.parametrize("message, field", REFUSAL_FORMS)
def test_refused_field_of_each_message_form(fc, message, field):
    assert fc.refused_field(message) == field


def test_refusal_naming_the_scaled_entry_is_as_expected(fc):
    """A scaled coefficient set refused in the ``X = v must ...`` form names the expected
    field (not refused_other_field); an index names its vector."""
    spec = fc.make_spec(
        0, "locomotion_swim", expect=["water.coefficient_scales.fins.strips_per_plate"]
    )
    message = "water.coefficient_scales.fins.strips_per_plate = 5.2 must be a whole number"
    row = {"outcome": "refused", "cause": fc.refused_field(message), "message": message}
    assert fc.finish_row(spec, row)["expectation"] == "as_expected"
    spec = fc.make_spec(1, "locomotion_swim", expect=["water.current"])
    row = {"outcome": "refused", "cause": fc.refused_field("water.current[2]: nan is not finite")}
    assert fc.finish_row(spec, row)["expectation"] == "as_expected"
    row = {"outcome": "refused", "cause": fc.refused_field("time_step: 0.05 is outside ...")}
    assert fc.finish_row(spec, row)["expectation"] == "refused_other_field"


def test_refused_field_of_the_package_own_refusals(fc):
    """The package's current messages (not copies): each refusal is filed under its field."""
    from manta_drake.scenario import ScenarioError

    cases = [
        (
            {"water.coefficient_scales": {"fins.strips_per_plate": 1.3}},
            "water.coefficient_scales.fins.strips_per_plate",
        ),
        ({"water.coefficient_scales": {"gravity": 0.0}}, "water.coefficient_scales.gravity"),
        (
            {"water.coefficient_scales": {"body.added_mass": -0.5}},
            "water.coefficient_scales.body.added_mass",
        ),
        (
            {"actuators.scales": {"servo.winding_resistance": -1.0}},
            "actuators.scales.servo.winding_resistance",
        ),
        ({"actuators.initial_soc": 0.01}, "actuators.initial_soc"),
        ({"time_step": "abc"}, "time_step"),
        ({"initial_pose.xyz": [0.0, 0.0, -0.9]}, "initial_pose"),
    ]
    for overrides, field in cases:
        with pytest.raises(ScenarioError) as e:
            fc.load_run_scenario(fc.make_spec(0, "locomotion_swim", overrides))
        assert fc.refused_field(str(e.value)) == field, str(e.value)


def _row(run, base, outcome, cause="", expectation="as_expected", **values):
    return {
        "run": run,
        "base": base,
        "outcome": outcome,
        "cause": cause,
        "expectation": expectation,
        "expect_refused": "",
        **values,
    }


def test_the_printed_summary_puts_each_number_in_its_place(fc):
    rows = [
        _row(0, "stand", "ok", sim_time_reached_s=2.0, max_penetration_m=0.001,
             max_joint_speed_rad_s=9.5, max_joint_limit_violation_rad=0.0, wall_time_s=1.0,
             mean_speed_m_s=0.1, max_speed_m_s=0.3, max_body_rate_rad_s=2.0),
        _row(1, "stand", "ok", sim_time_reached_s=2.0, max_penetration_m=0.007,
             max_joint_speed_rad_s=3.0, max_joint_limit_violation_rad=0.0, wall_time_s=3.0,
             mean_speed_m_s=0.2, max_speed_m_s=0.5, max_body_rate_rad_s=4.0, nan_in_log=True),
        _row(2, "locomotion_swim", "refused", "water.current"),
        _row(3, "locomotion_swim", "refused", "water.current"),
        _row(4, "locomotion_swim", "refused", "initial_pose", "unexpected_refusal"),
        _row(5, "float_sink", "crashed", "worker process died", "unexpected_failure",
             wall_time_s=5.0),
    ]  # fmt: skip
    s = fc.summarise(rows, wall_time=12.4)
    lines = fc.format_summary(s).splitlines()
    # Column layout: outcome left in 14, count right in 6, then the causes.
    assert lines[:7] == [
        "fault campaign: 6 runs",
        "",
        "outcome         runs  most common causes",
        "ok                 2  ",
        "refused            3     2 x water.current",
        "                         1 x initial_pose",
        "build_failed       0  ",
    ]
    assert "crashed            1     1 x worker process died" in lines
    assert "expectation: as_expected 4, unexpected_failure 1, unexpected_refusal 1" in lines
    assert "  refused without a must-refuse fault: initial_pose x1" in lines
    assert "NaN/inf in the log: 1 runs; in runs that ended ok: 1 [1]" in lines
    # The ok runs' penetrations 1 and 7 mm: median 4 mm, p95 6.7 mm; one above 5 mm.
    assert "penetration (ok runs): median 0.004, p95 0.0067, max 0.007 m (n 2); > 5 mm: 1" in lines
    assert "joint speed: median 6.25, p95 9.175, max 9.5 rad/s (n 2); > 8 rad/s: 1" in lines
    assert (
        "wall time: campaign 12 s, sum of runs 9 s, per simulated run median 3, p95 4.8, "
        "max 5 s (n 3)"
    ) in lines
    assert "per base: float_sink: crashed 1; locomotion_swim: refused 3; stand: ok 2" in lines
    assert lines[-1] == 'CHECK: FAIL {"crashed": [5], "nan_without_failing": [1]}'


@pytest.mark.slow
def test_runs_dir_holds_the_campaign_and_runs_is_the_count(tmp_path, capsys):
    from manta_drake.studies.faults import main

    runs_dir = tmp_path / "campaign"
    argv = ["--runs", "2", "--seed", "3", "--duration", "0.3", "--workers", "0"]
    assert main([*argv, "--runs-dir", str(runs_dir)], prog="manta-drake study faults") == 0
    assert sorted(p.name for p in runs_dir.iterdir()) == [
        "runs",
        "runs.csv",
        "specs.json",
        "summary.json",
    ]
    assert sorted(p.name for p in (runs_dir / "runs").iterdir()) == ["run_0000", "run_0001"]
    assert (runs_dir / "runs.csv").read_text().count("\n") == 3  # the header and two runs
    printed = capsys.readouterr().out
    assert "fault campaign: 2 runs" in printed and str(runs_dir / "summary.json") in printed
    # The runs folder was --out before; that name is refused in one line.
    from manta_drake.config_io import ScenarioError

    with pytest.raises(ScenarioError, match=r"unrecognized arguments: --out .* \(see --help\)$"):
        main([*argv, "--out", str(tmp_path / "x")], prog="manta-drake study faults")
    assert not (tmp_path / "x").exists()


def test_a_second_call_keeps_the_finished_runs_and_runs_the_rest(fc, tmp_path):
    """A restart reuses each run whose folder holds its row and the spec's own scenario
    file, and runs again one whose spec changed or whose row is missing."""
    over = {"water.current_schedule": [{"time": 0.0, "velocity": [1.2, 0.0, 0.0]}]}
    specs = [
        fc.make_spec(i, "locomotion_swim", over, expect=["water.current_schedule"])
        for i in range(3)
    ]
    lines: list[str] = []
    first = fc.run_campaign(specs, tmp_path, workers=0, echo=lines.append)
    assert [r["outcome"] for r in first] == ["refused"] * 3
    marker = tmp_path / "runs" / "run_0000" / "started.json"
    started = marker.read_text()
    (tmp_path / "runs" / "run_0001" / "row.json").unlink()  # ended without its row
    changed = dict(specs[2], overrides={**over, "duration": 0.5})  # another draw
    lines.clear()
    second = fc.run_campaign([specs[0], specs[1], changed], tmp_path, workers=0, echo=lines.append)
    assert marker.read_text() == started  # run 0 did not run again
    assert [("(earlier)" in line) for line in lines[:3]] == [True, False, False]
    assert second[0]["from_earlier_call"] is True and "from_earlier_call" not in second[1]
    assert second[0]["message"] == first[0]["message"]
    assert "duration: 0.5" in (tmp_path / "runs" / "run_0002" / "scenario.yaml").read_text()
    summary = fc.summarise(second, wall_time=12.0)
    assert summary["outcomes"]["refused"] == 3
    summary["runs_from_earlier_call"] = 1
    assert "campaign 12 s (this call; runs from an earlier call: 1)," in fc.format_summary(summary)
    fresh = fc.run_campaign(specs, tmp_path, workers=0, echo=lines.append, resume=False)
    assert marker.read_text() != started and not any("from_earlier_call" in r for r in fresh)
