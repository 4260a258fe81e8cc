"""A catalogue of bad inputs: each fails at load (or construction) time with one line that
names the field, the value's problem and, where there is one, the allowed range."""

import math

import numpy as np
import pytest

from manta_drake.cli import main
from manta_drake.model import MODELS_DIR

BAD_SCENARIOS = [
    # (YAML text, the field the message must name, a further text it must contain)
    ("duration: 0\n", "duration", "(0, 3600]"),
    ("duration: -5\n", "duration", "(0, 3600]"),
    ("duration: .nan\n", "duration", "not finite"),
    ("duration: soon\n", "duration", "float"),
    ("time_step: 1.0e-7\n", "time_step", "[0.0001, 0.01]"),
    ("time_step: 0.05\n", "time_step", "[0.0001, 0.01]"),
    ("random_seed: 1.5\n", "random_seed", "int"),
    ("random_seed: -1\n", "random_seed", "[0, 4294967295]"),
    ("initial_pose: {xyz: [0, 0, -0.7]}\n", "initial_pose", "not in the pool's water"),
    ("initial_pose: {xyz: [8, 0, -0.2]}\n", "initial_pose", "not in the pool's water"),
    ("initial_pose: {xyz: [7.4, 0, -0.2]}\n", "initial_pose", "beyond a wall"),
    ("initial_pose: {xyz: [0, 0.9, -0.2]}\n", "initial_pose", "beyond a wall"),
    ("initial_pose: {xyz: [0, 0, 0.3]}\n", "initial_pose", "not in the pool's water"),
    ("initial_pose: {xyz: [0, 0, -0.45]}\n", "initial_pose", "below the floor"),
    ("initial_pose: {rpy_deg: [0, 0, 1000]}\n", "initial_pose.rpy_deg", "magnitude"),
    ("initial_pose: {xyz: [0, 0]}\n", "initial_pose.xyz", "3 finite numbers"),
    ("initial_stance: gallop\n", "initial_stance", "swim, trot"),
    ("controller: {mode: dance}\n", "controller.mode", "hold, gait, transition"),
    ("cpg: {frequency_hz: 0}\n", "cpg.frequency_hz", "(0, 5]"),
    ("cpg: {a: .inf}\n", "cpg.a", "not finite"),
    ("transition: {g: 1.0, T: 1.0, alpha: 2.0}\n", "transition.alpha * g * T", "overshoot"),
    ("transition: {period: 0.0001}\n", "transition.period", "[time_step"),
    ("contact: {friction: 0}\n", "contact.friction", "(0, 2]"),
    (
        "depth_estimator: {surface_depth: 0.25}\n",
        "depth_estimator.surface_depth",
        "[0, floor_distance = 0.2)",
    ),
    (
        "depth_estimator: {surface_depth: 0.2}\n",
        "depth_estimator.surface_depth",
        "[0, floor_distance = 0.2)",
    ),
    ("camera: {min_range: 0.8, max_range: 0.8}\n", "camera.min_range", "max_range = 0.8)"),
    ("water: {current: [100, 0, 0]}\n", "water.current", "1.0 m/s"),
    ("water: {current: [.nan, 0, 0]}\n", "water.current[0]", "not finite"),
    ("water: {update_period: -0.004}\n", "water.update_period", "[0, 0.02]"),
    ("water: {coefficients: nope.yaml}\n", "water.coefficients", "not found"),
    (
        "water: {coefficient_scales: {body.linear_damping: -1}}\n",
        "water.coefficient_scales.body.linear_damping",
        ">= 0",
    ),
    (
        "water: {coefficient_scales: {body.dampin: 2}}\n",
        "water.coefficient_scales.body.dampin",
        "unknown coefficient",
    ),
    ("balloon: {initial_fill: 2}\n", "balloon.initial_fill", "[0, 1]"),
    (
        "balloon: {schedule: [{time: 5, fill: 0}, {time: 2, fill: 1}]}\n",
        "balloon.schedule[1].time",
        "must not decrease",
    ),
    ("pressure_sensor: {rate_hz: 5000}\n", "pressure_sensor.rate_hz", "1/time_step"),
    ("pressure_sensor: {noise_std: 1.0}\n", "pressure_sensor.noise_std", "[0, 0.1]"),
    ("camera: {depth_noise_std: 0.1}\n", "camera.depth_noise_std", "[0, 0.03]"),
    ("camera: {width: 100.5}\n", "camera.width", "int"),
    ("camera: {min_range: 1.0, max_range: 0.8}\n", "camera.min_range", "max_range"),
    (
        "wall_detector: {normal_max_neighbors: 0}\n",
        "wall_detector.normal_max_neighbors",
        "[3, 200]",
    ),
    ("wall_detector: {planarity: .nan}\n", "wall_detector.planarity", "(0, 1]"),
    ("wall_detector: {min_cluster_size: 2.5}\n", "wall_detector.min_cluster_size", "int"),
    ("wall_detector: {c_min: 80}\n", "wall_detector.c_min", "below c_max"),
    ("simulator: {accuracy: .nan}\n", "simulator.accuracy", "not finite"),
    ("simulator: {target_realtime_rate: -1}\n", "simulator.target_realtime_rate", "[0, 100]"),
    ("simulator: {start_time: 100}\n", "simulator.start_time", "[0, 0]"),
    ("log_period: 0.00001\n", "log_period", "[time_step"),
    ("steady_after: -1\n", "steady_after", "[0, 3600]"),
    ("duration: 1\nduration: 2\n", "duplicate key 'duration'", "line 2"),
    ("- 1\n- 2\n", "root", "must be a mapping"),
    ("duraton: 3\n", "scenario.duraton", "allowed keys"),
]


def _cli_error(capsys, *argv):
    """Runs the CLI in-process; returns its one-line error message."""
    status = main(list(argv))
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2, err
    assert len(err) == 1, err  # one line, no traceback
    return err[0]


@pytest.mark.parametrize(
    "text, field, more",
    BAD_SCENARIOS,
    ids=[f"{i:02d}-{case[1]}" for i, case in enumerate(BAD_SCENARIOS)],
)
def test_bad_scenario_is_one_line_naming_the_field(tmp_path, capsys, text, field, more):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    message = _cli_error(capsys, "run", str(path), "--out", str(tmp_path / "out"), "--no-meshcat")
    assert field in message and more in message and str(path) in message
    assert not (tmp_path / "out").exists()  # nothing was started


def _file(path, content: bytes):
    path.write_bytes(content)
    return path


def _coefficients_with(tmp_path, old, new):
    text = (MODELS_DIR / "hydrodynamics.yaml").read_text()
    assert old in text
    coeffs = tmp_path / "h.yaml"
    coeffs.write_text(text.replace(old, new))
    return coeffs


@pytest.mark.parametrize(
    "make, field",
    [
        (
            lambda p: _coefficients_with(
                p, "strips_per_plate:\n    value: 4", "strips_per_plate:\n    value: 2.5"
            ),
            "fins.strips_per_plate = 2.5 must be a whole number",
        ),
        (
            lambda p: _coefficients_with(
                p, "sealed_volume:\n    value: 0.004784", "sealed_volume:\n    value: 0.0"
            ),
            "body.sealed_volume = 0.0 must be > 0",
        ),
        # The buoyancy comes from the semi-axes: a volume edited alone would have no effect.
        (
            lambda p: _coefficients_with(
                p, "sealed_volume:\n    value: 0.004784", "sealed_volume:\n    value: 0.0061"
            ),
            "body.sealed_volume = 0.0061 m^3 disagrees with body.sealed_semi_axes "
            "(4/3 pi abc = 0.00478401 m^3",
        ),
        (
            lambda p: _coefficients_with(
                p, "water_density:\n  value: 1000.0", "water_density:\n  value: 1.0e9"
            ),
            "water_density = 1000000000.0 is outside the allowed range [900, 1300] kg/m^3",
        ),
        (
            lambda p: _coefficients_with(p, "gravity:\n  value: 9.81", "gravity:\n  value: 98.1"),
            "gravity = 98.1 is outside the allowed range [9.7, 9.9] m/s^2",
        ),
        (lambda p: _file(p / "empty.yaml", b""), "must be a mapping"),
        (lambda p: _file(p / "bin.yaml", b"\xff\xfe\x00\x81binary"), "not a UTF-8 text"),
    ],
)
def test_bad_coefficients_file_named_at_load_time(tmp_path, capsys, make, field):
    coeffs = make(tmp_path)
    scenario = tmp_path / "s.yaml"
    scenario.write_text(f"duration: 0.1\nwater: {{coefficients: {coeffs}}}\n")
    message = _cli_error(capsys, "run", str(scenario), "--out", str(tmp_path / "o"))
    assert "water.coefficients" in message and str(coeffs) in message and field in message


def test_binary_scenario_and_duration_zero_on_the_command_line(tmp_path, capsys):
    binary = tmp_path / "b.yaml"
    binary.write_bytes(bytes(range(256)))
    message = _cli_error(capsys, "run", str(binary), "--out", str(tmp_path / "o"))
    assert str(binary) in message and "not a UTF-8 text" in message
    message = _cli_error(capsys, "run", "stand", "--out", str(tmp_path / "o"), "--duration", "0")
    assert "duration: 0.0 is outside the allowed range (0, 3600]" in message


def test_bad_python_calls_name_the_argument():
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake import (
        BalloonBuoyancy,
        CpgOscillators,
        FuzzyDepthEstimator,
        PotentialTransition,
        WallDetector,
    )
    from manta_drake.control.depth_image_filter import DepthImageFilter
    from manta_drake.control.vision import WallDetectorParams
    from manta_drake.model.plant import add_plant
    from manta_drake.simulate import seed_context

    cases = [
        (lambda: PotentialTransition(initial_params=np.zeros(10)), "initial_params"),
        (
            lambda: WallDetector(period=0.2, params=WallDetectorParams(normal_max_neighbors=0)),
            "normal_max_neighbors: 0 is outside the allowed range [3, 200]",
        ),
        (lambda: WallDetector(period=0.0), "period"),
        (lambda: FuzzyDepthEstimator(math.nan, period=0.02), "floor_distance"),
        (lambda: BalloonBuoyancy(-1.0, 1e-4, 0.01), "max_volume"),
        (lambda: CpgOscillators(frequency_hz=0.0), "frequency_hz"),
        (lambda: CpgOscillators(initial_state=np.zeros(3)), "initial_state"),
        (
            lambda: CpgOscillators(frequency_hz=1e9),
            "CpgOscillators.frequency_hz: 1000000000.0 is outside the allowed range (0, 5] Hz",
        ),
        (lambda: CpgOscillators(chain_weight=-1.0), "chain_weight: -1.0 is outside"),
        (
            lambda: FuzzyDepthEstimator(0.2, period=0.02, initial_depth=math.nan),
            "FuzzyDepthEstimator.initial_depth: nan is not finite",
        ),
        (lambda: seed_context(None, None, 1.7), "seed: 1.7 is not an integer"),
        (lambda: add_plant(DiagramBuilder(), time_step=0.0), "time_step"),
        (lambda: DepthImageFilter(160, 120, size=20), "size"),
    ]
    for make, needle in cases:
        with pytest.raises(ValueError) as info:
            make()
        message = str(info.value)
        assert needle in message and "\n" not in message


def test_recording_frame_rate_is_checked_only_with_meshcat_on():
    """A 30 fps recording is off the 1 ms step grid: refused with Meshcat on (it would add
    integrator steps), accepted when the run records nothing."""
    from manta_drake.config_io import ScenarioError
    from manta_drake.scenario import load_scenario

    with pytest.raises(ScenarioError, match=r"visualization\.recording_fps.*not a multiple"):
        load_scenario("stand", overrides={"visualization.recording_fps": 30.0})
    s = load_scenario(
        "stand", overrides={"visualization.recording_fps": 30.0, "visualization.meshcat": False}
    )
    assert s.visualization.recording_fps == 30.0 and not s.visualization.meshcat


# --- the options of `manta-drake study NAME` (manta_drake/studies/*.py) ----------------------

STUDY_DATA = MODELS_DIR.parent / "diagrams" / "sweeps" / "data"  # the shipped tables


def _table(path, text: str):
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--duration", "0.2"], "--duration: 0.2 is outside the allowed range [0.3, 3600] s"),
        (["--duration", "nan"], "--duration: nan is not finite"),
        (["--seed", "-1"], "--seed: -1 is outside the allowed range [0, 4294967295]"),
        (["--run-timeout", "0"], "--run-timeout: 0.0 is outside the allowed range [30, 86400] s"),
        (["--strict"], "--strict needs --check"),
        (["--runs", "0"], "--runs: 0 is outside the allowed range [1, 10000]"),
        (
            ["--runs", "3", "--inject-crash", "3"],
            "--inject-crash (a run index of --runs 3): 3 is outside the allowed range [0, 2]",
        ),
        (["--runs", "abc"], "argument --runs: invalid int value: 'abc'"),
        (["--workers", "-1"], "--workers: -1 is outside the allowed range [0, 256]"),
    ],
)
def test_study_faults_option_out_of_range_is_one_line(tmp_path, capsys, argv, needle):
    out = tmp_path / "fc"
    message = _cli_error(capsys, "study", "faults", "--runs-dir", str(out), "--workers", "0", *argv)
    assert needle in message
    assert not out.exists()  # nothing was drawn or written


@pytest.mark.slow
def test_study_faults_runs_dir_is_a_file_and_the_duration_floor_is_the_drawn_interval(
    tmp_path, capsys
):
    """--runs-dir naming a file is one line; the floor of --duration is where a drawn balloon
    command's interval [BALLOON_COMMAND_AFTER_S, duration] stays valid: at it the draws work
    (and draw balloon commands), just below it numpy would refuse them."""
    from manta_drake.studies import faults as fc

    a_file = tmp_path / "a_file"
    a_file.write_text("")
    assert _cli_error(capsys, "study", "faults", "--runs-dir", str(a_file)) == (
        f"manta-drake: error: --runs-dir {a_file}: is a file, not a folder (--debug shows the "
        "traceback)"
    )
    floor = fc.BALLOON_COMMAND_AFTER_S
    specs = fc.draw_specs(60, 0, floor)
    balloons = [
        s["overrides"]["balloon.schedule"][0]["time"] for s in specs if "balloon" in s["faults"]
    ]
    assert balloons and all(t == floor for t in balloons)
    with pytest.raises(ValueError, match="high - low < 0"):
        fc.draw_specs(60, 0, floor - 0.01)
    assert f"[{floor:g}, 3600] s" in _cli_error(
        capsys,
        "study",
        "faults",
        "--duration",
        f"{floor - 0.01:g}",
        "--runs-dir",
        str(tmp_path / "o"),
    )


FINDINGS_HEADER = (
    "run_id,base,contact.friction,hull_damping,net_weight_kg,status,u,v,"
    "yaw_rate_deg_s,steady_start_s,steady_end_s\n"
)


@pytest.mark.parametrize(
    "study, text, needle",
    [
        ("findings", "", "an empty file"),
        ("findings", FINDINGS_HEADER, "a header but no rows"),
        ("findings", FINDINGS_HEADER + "\n\n", "a header but no rows"),
        (
            "findings",
            FINDINGS_HEADER.replace("contact.friction,", "") + "r,locomotion_walk,1,1,ok,"
            "0.1,0,0,6,20\n",
            "no column contact.friction in its header",
        ),
        (
            "findings",
            "run_id,u\nr,0.1\n",
            "no columns base, contact.friction, hull_damping, "
            "net_weight_kg, status, v, yaw_rate_deg_s, steady_start_s, steady_end_s in its header",
        ),
        ("findings", "x" * 70000 + "\n", "its first line is longer than 65536 characters"),
        ("energy", "", "an empty file"),
        (
            "energy",
            FINDINGS_HEADER.replace("base,", "") + "r,0.8,1,0.8,ok,0.1,0,0,6,20\n",
            "no columns base, standby_current",
        ),
    ],
)
def test_study_results_table_without_rows_or_columns_is_one_line(
    tmp_path, capsys, study, text, needle
):
    results = _table(tmp_path / "results.csv", text)
    out = str(tmp_path / "out")
    message = _cli_error(capsys, "study", study, "--results", results, "--out", out)
    assert f"--results {results}: {needle}" in message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.csv"]  # nothing was written


def test_study_results_table_that_is_missing_binary_or_a_folder(tmp_path, capsys):
    binary = tmp_path / "b.csv"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    for study in ("findings", "energy"):
        assert f"--results {binary}: not a UTF-8 text (CSV) file" in _cli_error(
            capsys, "study", study, "--results", str(binary)
        )
        assert f"--results {tmp_path}: is a folder" in _cli_error(
            capsys, "study", study, "--results", str(tmp_path)
        )
        message = _cli_error(capsys, "study", study, "--results", str(tmp_path / "no.csv"))
        assert (
            f"--results {tmp_path / 'no.csv'}: file not found; run `manta-drake sweep "
            f"diagrams/sweeps/{study}.yaml" in message
        )


def test_study_shipped_tables_have_the_columns_their_studies_read():
    from manta_drake.studies import energy, findings, stance
    from manta_drake.studies.options import check_results_csv

    for name in ("findings_results.csv", "findings_mirrored_results.csv"):
        check_results_csv("--results", STUDY_DATA / name, findings.RESULTS_COLUMNS)
    check_results_csv("--results", STUDY_DATA / "energy_results.csv", energy.RESULTS_COLUMNS)
    check_results_csv("--table", STUDY_DATA / "stance_table.csv", stance.COLUMNS)


def test_study_findings_energy_stance_outputs_and_options(tmp_path, capsys):
    shipped = str(STUDY_DATA / "findings_results.csv")
    cases = [
        (("findings", "--only", "swim"), "--only needs --diagnose: it chooses the diagnostic runs"),
        (
            ("findings", "--diagnose", str(tmp_path / "d"), "--only", "swim", "gallop"),
            "--only: 'gallop' is not one of swim, swim_stall_10deg",
        ),
        (("findings", "--diagnose", str(tmp_path / "d"), "--only"), "--only: name at least one"),
        (
            ("findings", "--results", shipped, "--out", shipped),
            f"--out {shipped}: is a file, not a folder",
        ),
        (
            ("findings", "--results", shipped, "--out", str(tmp_path), "--page", "docs/x"),
            "--page 'docs/x': a file name without folder or ending (letters, digits, _ . -), "
            "e.g. findings",
        ),
        (
            ("findings", "--results", shipped, "--out", str(tmp_path), "--page", "folder"),
            f"--page {tmp_path / 'folder.md'}: is a folder, not a file",
        ),
        (
            ("energy", "--check-logs", str(tmp_path)),
            f"--check-logs {tmp_path / 'results.csv'}: file not found",
        ),
        (
            ("energy", "--results", str(STUDY_DATA / "energy_results.csv"), "--out", shipped),
            f"--out {shipped}: is a file, not a folder",
        ),
        (
            ("stance", "--out", shipped),
            f"--out {shipped}: is a file, not a folder",
        ),
        (
            ("stance", "--table", _table(tmp_path / "t.csv", "gait_reading,gait\n")),
            f"--table {tmp_path / 't.csv'}: no columns fin_sweep_deg, u, v",
        ),
        (
            ("stance", "--sweep-out", str(tmp_path)),
            f"--sweep-out {tmp_path / 'results.csv'}: file not found",
        ),
    ]
    (tmp_path / "folder.md").mkdir()
    for argv, needle in cases:
        assert needle in _cli_error(capsys, "study", *argv), argv
    assert not (tmp_path / "d").exists() and not (tmp_path / "figures").exists()


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["wall-noise", "--seeds", "0"], "--seeds: 0 is outside the allowed range [1, 1000]"),
        (["wall-noise", "--out", "{tmp}/a_file"], "--out {tmp}/a_file: is a file, not a folder"),
        (
            ["readings", "--duration", "1"],
            "--duration: 1.0 is outside the allowed range [2, 3600] s",
        ),
        (
            ["readings", "--readings", "printed,sideways"],
            "--readings: 'sideways' is not one of printed, shipped",
        ),
        (["readings", "--gaits", "swim,swim"], "--gaits: 'swim' is given twice"),
        (["readings", "--fin-sweep", "70"], "--fin-sweep 70: "),
        (["readings", "--runs", "{tmp}/a_file"], "--runs {tmp}/a_file: is a file, not a folder"),
        (["readings", "--out", "{tmp}/a_file"], "--out {tmp}/a_file: is a file, not a folder"),
        (
            ["transitions", "--duration", "5"],
            "--duration: 5.0 is outside the allowed range [20, 3600] s",
        ),
        (
            ["transitions", "--reuse", "--runs", "{tmp}"],
            "--runs {tmp}: no potential_descent/log.npz to reuse",
        ),
        (["behaviours", "--out", "{tmp}/a_file"], "--out {tmp}/a_file: is a file, not a folder"),
        (["behaviours", "--runs", "{tmp}/a_file"], "--runs {tmp}/a_file: is a file, not a folder"),
        (["behaviours", "--scheduler", "nowhere"], "--scheduler 'nowhere': expected an address"),
    ],
)
def test_study_run_options_out_of_range_are_one_line(tmp_path, capsys, argv, needle):
    (tmp_path / "a_file").write_text("")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    message = _cli_error(capsys, "study", *argv)
    assert needle.replace("{tmp}", str(tmp_path)) in message
    if "--fin-sweep" in argv:
        assert "robot.fin_sweep_deg: 70.0 is outside the allowed range [-60, 60] deg" in message
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]  # nothing was started


# --- settings accepted without a word: cross-field checks, scale ranges, package URLs, --------
# --- sensor constructors (manta_drake/scenario.py, model/actuators.py, model/__init__.py, ------
# --- station/pressure.py, station/depth_image_noise.py, control/balloon_rule.py, ---------------
# --- control/behaviour_tree.py) ---------------------------------------------------------------

SILENT_SETTINGS = [
    # (YAML text, the field the message must name, a further text it must contain)
    (
        "imu: {enabled: true}\ncontroller: {mode: gait, gait: swim}\n"
        "heading_hold: {enabled: true, behaviours: [swimm]}\n",
        "heading_hold.behaviours[0]",
        "'swimm' is not a gait; allowed: swim, trot",
    ),
    (
        "imu: {enabled: true}\ncontroller: {mode: transition, gait: swim}\n"
        "heading_hold: {enabled: true, behaviours: [walk]}\n",
        "heading_hold.behaviours",
        "would never engage; allowed: swim, trot, turning",
    ),
    (
        "water: {current: [0.05, 0, 0], current_schedule: [{time: 0, velocity: [0, 0.05, 0]}]}\n",
        "water.current",
        "is set beside water.current_schedule; they are exclusive",
    ),
    (
        "controller: {mode: transition}\ntransition:\n  tree:\n"
        "    root: {modality: s_hat, weight: cosine, children: [trot, turning]}\n",
        "transition.tree",
        "reads s_hat, which needs camera.enabled: true",
    ),
    (
        "water: {enabled: false}\nimu: {enabled: true}\nballoon: {rule: {modality: posture}}\n",
        "balloon.rule.modality",
        "'posture' needs water.enabled: true",
    ),
    (
        "water: {enabled: false}\nflow_sensor: {enabled: true}\n",
        "flow_sensor.enabled",
        "needs water.enabled: true",
    ),
    (
        "water: {enabled: false}\naltimeter: {enabled: true}\n",
        "altimeter.enabled",
        "needs water.enabled: true",
    ),
    (
        "controller: {mode: transition}\ntransition:\n  tree:\n"
        "    root: {modality: floor_hat, weight: potential, children: [swim, trot]}\n",
        "transition.tree",
        "reads floor_hat, which needs altimeter.enabled: true",
    ),
    (
        "altimeter: {enabled: true}\nballoon: {rule: {modality: altitud}}\n",
        "balloon.rule.modality",
        "'altitud' is not an estimate's name",
    ),
    (
        "controller: {mode: transition}\ntransition:\n  tree:\n"
        "    root: {modality: z_hat, weight: potential, threshold: 0.3, children: [swim, trot]}\n",
        "transition.tree.root.threshold",
        "0.3 is set on a potential node, which ignores it",
    ),
    (
        "controller: {mode: transition}\ntransition:\n  tree:\n"
        "    root: {modality: z_hat, weight: cosine, hysteresis: 0.1, children: [swim, trot]}\n",
        "transition.tree.root.hysteresis",
        "0.1 is set on a cosine node, which ignores it",
    ),
    (
        "balloon: {rule: {threshold: 0.3}}\n",
        "balloon.rule.threshold",
        "0.3 is set but the rule's modality is empty",
    ),
    (
        "balloon: {rule: {fill_above: 1.0}}\n",
        "balloon.rule.fill_above",
        "the rule's modality is empty",
    ),
    (
        "actuators: {scales: {servo.gear_ratio: 1.0e9}}\n",
        "actuators.scales.servo.gear_ratio",
        "1000000000.0 is outside the allowed range [0, 10]",
    ),
    (
        "actuators: {scales: {battery.ocv_cell_voltage: 2.0}}\n",
        "actuators.scales.battery.ocv_cell_voltage",
        "outside the allowed range [0.5, 1.5]",
    ),
    (
        "actuators: {file: 'package://manta_drake/../../../etc/hostname'}\n",
        "actuators.file",
        "'package://manta_drake/../../../etc/hostname' leaves the package manta_drake",
    ),
    (
        "water: {coefficients: 'package://manta_drake/../../../etc/hostname'}\n",
        "water.coefficients",
        "leaves the package manta_drake",
    ),
    (
        "water: {enabled: false, coefficients: 'package://manta_drake//etc/hostname'}\n",
        "water.coefficients",
        "leaves the package manta_drake",
    ),
    (
        "controller: {gait_files: ['package://manta_drake/scenarios/../../../etc/hostname']}\n",
        "controller.gait_files[0]",
        "leaves the package manta_drake",
    ),
    (
        "actuators: {file: 'package://manta_drake/nope.yaml'}\n",
        "actuators.file",
        "actuators file not found",
    ),
]


@pytest.mark.parametrize(
    "text, field, more",
    SILENT_SETTINGS,
    ids=[f"{i:02d}-{case[1]}" for i, case in enumerate(SILENT_SETTINGS)],
)
def test_silent_setting_is_refused_naming_the_field(tmp_path, capsys, text, field, more):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    message = _cli_error(capsys, "run", str(path), "--out", str(tmp_path / "out"), "--no-meshcat")
    assert f"{path}: {field}" in message and more in message
    assert not (tmp_path / "out").exists()  # nothing was started


@pytest.mark.parametrize(
    "scenario, setting, needle",
    [
        (
            "four_behaviors",
            "transition.tree.root.threshold=0.3",
            "transition.tree.root.threshold: 0.3 is set on a cosine node, which ignores it",
        ),
        (
            "four_behaviors",
            "transition.tree.active.hysteresis=0.2",
            "transition.tree.active.hysteresis: 0.2 is set on a potential node",
        ),
        (
            "four_behaviors",
            "water.current=[0.05, 0, 0]",
            "water.current: [0.05, 0.0, 0.0] is set "
            "beside water.current_schedule; they are exclusive",
        ),
        (
            "two_behaviors",
            "balloon.rule.hysteresis=0.3",
            "balloon.rule.hysteresis: 0.3 is set but the rule's modality is empty",
        ),
        (
            "two_behaviors",
            "actuators.scales.servo.gear_ratio=1.0e9",
            "actuators.scales.servo.gear_ratio: 1000000000.0 is outside the allowed range [0, 10]",
        ),
        ("three_behaviors", "camera.enabled=false", None),  # Eq. (12)'s default tree: accepted
    ],
)
def test_silent_setting_through_set_is_refused_the_same(
    tmp_path, capsys, scenario, setting, needle
):
    """``--set`` layers before validation: the same checks refuse the same settings."""
    from manta_drake.scenario import load_scenario, parse_set

    if needle is None:
        s = load_scenario(scenario, overrides=parse_set([setting]))
        assert not s.camera.enabled and "s_hat" in s.behaviour_tree().modalities
        return
    message = _cli_error(
        capsys, "run", scenario, "--out", str(tmp_path / "out"), "--no-meshcat", "--set", setting
    )
    assert needle in message
    assert not (tmp_path / "out").exists()


def test_a_written_tree_on_s_hat_needs_the_camera_eq12s_trees_do_not():
    """Eq. (12)'s trees (``default_tree(blend, z_t)``: the default, or written out, or read
    from the deprecated blend and z_t) read s_hat = 0 without a camera (the paper's
    two-behaviour run); any other tree that reads s_hat is refused without the camera, in
    the wording of the other sensors' refusals, and accepted with it."""
    from manta_drake.config_io import ScenarioError
    from manta_drake.control.behaviour_tree import default_tree
    from manta_drake.scenario import load_scenario

    assert "s_hat" in load_scenario("two_behaviors").behaviour_tree().modalities
    for blend in ("potential", "switch"):
        written = {name: vars(node) for name, node in default_tree(blend, 0.8).items()}
        s = load_scenario("two_behaviors", data={"transition": {"tree": written}})
        assert not s.camera.enabled and "s_hat" in s.behaviour_tree().modalities
    tree = {name: vars(node) for name, node in default_tree().items()}
    tree["gait"] = {**tree["gait"], "weight": "linear"}  # no longer Eq. (12)'s
    with pytest.raises(
        ScenarioError,
        match=r"two_behaviors\.yaml: transition\.tree: reads "
        r"s_hat, which needs camera\.enabled: true$",
    ):
        load_scenario("two_behaviors", data={"transition": {"tree": tree}})
    s = load_scenario(
        "two_behaviors", data={"transition": {"tree": tree}, "camera": {"enabled": True}}
    )
    assert set(s.transition.tree) == {"root", "gait"}


def test_switch_fields_unset_read_their_defaults_and_round_trip():
    """A switch that leaves threshold and hysteresis out switches at 0.5 without memory; a
    scenario with a tree writes only the fields a node sets, and reads back the same."""
    from manta_drake.control.behaviour_tree import BlendNode, compile_tree
    from manta_drake.scenario import load_scenario, scenario_yaml

    gaits = {"A": np.zeros(64), "B": np.ones(64)}
    tree = compile_tree({"root": BlendNode("z_hat", "switch", ["A", "B"])}, gaits)
    assert tree.leaf_weights({"z_hat": 0.49})[0].tolist() == [1.0, 0.0]
    assert tree.leaf_weights({"z_hat": 0.5})[0].tolist() == [0.0, 1.0]
    four = load_scenario("four_behaviors")
    text = scenario_yaml(four)
    assert four.transition.tree["root"].threshold is None
    assert load_scenario(data=text).transition.tree == four.transition.tree


@pytest.mark.parametrize(
    "url, inside",
    [
        ("package://manta_drake/actuators.yaml", "actuators.yaml"),
        ("package://manta_drake/scenarios/../gaits.yaml", "gaits.yaml"),
        ("package://manta_drake/scenarios/stand.yaml", "scenarios/stand.yaml"),
    ],
)
def test_package_urls_inside_the_package_resolve(url, inside):
    from manta_drake.model import MODELS_DIR, resolve_path

    assert resolve_path(url) == (MODELS_DIR / inside).resolve()


@pytest.mark.parametrize(
    "url",
    [
        "package://manta_drake/../../../etc/hostname",
        "package://manta_drake//etc/hostname",
        "package://manta_drake/scenarios/../../pyproject.toml",
        "package://manta_drake/..",
    ],
)
def test_package_urls_leaving_the_package_are_refused(url):
    from manta_drake.config_io import ScenarioError
    from manta_drake.model import resolve_path

    with pytest.raises(ScenarioError) as info:
        resolve_path(url, "actuators.file")
    message = str(info.value)
    assert message.startswith(f"actuators.file: {url!r} leaves the package manta_drake")
    assert "\n" not in message


def test_bad_sensor_constructor_arguments_name_the_argument():
    """PressureSensor and DepthImageNoise check their arguments before any allocation: one
    line naming the argument and what is allowed (no reshape or port-size message)."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant
    from manta_drake.station.depth_image_noise import DepthImageNoise
    from manta_drake.station.pressure import PressureSensor

    h = add_plant(DiagramBuilder(), with_pool=False)
    p = [0.19, 0.0, 0.03]
    cases = [
        (
            lambda: PressureSensor(h.plant, h.body, [0.19, 0], 0.02),
            "PressureSensor.p_BS: [0.19, 0] must be 3 finite numbers",
        ),
        (
            lambda: PressureSensor(h.plant, h.body, [0.19, 0.0, math.nan], 0.02),
            "PressureSensor.p_BS: [0.19, 0.0, nan] must be 3 finite numbers",
        ),
        (lambda: PressureSensor(h.plant, h.body, "head", 0.02), "PressureSensor.p_BS: 'head'"),
        (
            lambda: PressureSensor(None, h.body, p, 0.02),
            "PressureSensor.plant: expected a MultibodyPlant, got NoneType",
        ),
        (
            lambda: PressureSensor(h.plant, "body", p, 0.02),
            "PressureSensor.body: expected a RigidBody, got str",
        ),
        (
            lambda: PressureSensor(h.plant, h.body, p, "fast"),
            "PressureSensor.period: 'fast' is not a number",
        ),
        (
            lambda: PressureSensor(h.plant, h.body, p, 0.02, noise_std=-1.0),
            "PressureSensor.noise_std: -1.0 is outside the allowed range [0, inf) m",
        ),
        (
            lambda: PressureSensor(h.plant, h.body, p, 0.02, dropout_rate=1.5),
            "PressureSensor.dropout_rate: 1.5 is outside the allowed range [0, 1]",
        ),
        (
            lambda: DepthImageNoise(width=-1, height=120),
            "DepthImageNoise.width: -1 is outside the allowed range [1, 4096]",
        ),
        (
            lambda: DepthImageNoise(160, 10**6),
            "DepthImageNoise.height: 1000000 is outside the allowed range [1, 4096]",
        ),
        (
            lambda: DepthImageNoise(160.5, 120),
            "DepthImageNoise.width: 160.5 is not an integer (allowed: 1 to 4096)",
        ),
        (
            lambda: DepthImageNoise(160, 120, noise_std=math.inf),
            "DepthImageNoise.noise_std: inf is not finite",
        ),
        (
            lambda: DepthImageNoise(160, 120, dropout_rate=-0.1),
            "DepthImageNoise.dropout_rate: -0.1 is outside the allowed range [0, 1]",
        ),
        (
            lambda: DepthImageNoise(160, 120, max_range=0.0, camera_info=object()),
            "DepthImageNoise.max_range: 0.0 is outside the allowed range (0, inf) m",
        ),
        (
            lambda: DepthImageNoise(160, 120, max_range=0.8, camera_info="camera"),
            "DepthImageNoise.camera_info: expected a CameraInfo, got str",
        ),
    ]
    for make, needle in cases:
        with pytest.raises(ValueError) as info:
            make()
        message = str(info.value)
        assert needle in message and "\n" not in message


# --- `manta-drake run`'s --set values: each one checked, also one an option replaces ---------
# --- (manta_drake/cli.py, scenario.parse_set) ---------------------------------------------------


@pytest.mark.parametrize(
    "argv, needle",
    [
        (
            ["--duration", "0.3", "--set", "duration={a: 1}"],
            "--set duration: scenario.duration: expected a float, got {'a': 1} (checked although "
            "--duration replaces it)",
        ),
        (
            ["--duration", "0.3", "--set", "duration=-4"],
            "--set duration: duration: -4.0 is outside the allowed range (0, 3600] s (checked "
            "although --duration replaces it)",
        ),
        (
            ["--no-meshcat", "--set", "visualization={meshcat: maybe}"],
            "--set visualization: scenario.visualization.meshcat: expected a bool, got 'maybe' "
            "(checked although --no-meshcat replaces it)",
        ),
        (
            ["--set", "duration=1", "--set", " duration=2"],
            "--set duration: given twice; give each key once",
        ),
    ],
)
def test_set_value_is_checked_even_when_an_option_replaces_it(tmp_path, capsys, argv, needle):
    message = _cli_error(capsys, "run", "stand", "--out", str(tmp_path / "o"), *argv)
    assert message == f"manta-drake: error: {needle} (--debug shows the traceback)"
    assert not (tmp_path / "o").exists()


def test_set_error_of_another_value_is_not_blamed_on_the_replaced_one(tmp_path, capsys):
    """With --duration replacing a good --set duration, a bad --set contact.friction is told
    as it always is (the file and the field), not as the replaced value's."""
    message = _cli_error(
        capsys,
        "run",
        "stand",
        "--out",
        str(tmp_path / "o"),
        "--duration",
        "0.3",
        "--set",
        "duration=2",
        "--set",
        "contact.friction=9",
    )
    assert "contact.friction: 9.0 is outside the allowed range (0, 2]" in message
    assert "--set duration" not in message and "replaces" not in message


# --- input limits: sizes, nesting, YAML aliases, tree depth, bounded messages ----------------
# --- (manta_drake/config_io.py, control/gait_files.py, control/behaviour_tree.py, ------------
# --- calibrate/measured.py, sweep/results.py, sweep/loading.py) ------------------------------


def _alias_bomb(indent: str = "", n: int = 9) -> str:
    """A list of ``n`` anchors of ``n`` references each: ``n ** n`` leaves once expanded
    (387 M for 9), a few hundred bytes as text."""
    lines = [f"{indent}- &a0 [{', '.join(['R_deg'] * n)}]"]
    lines += [f"{indent}- &a{i} [{', '.join([f'*a{i - 1}'] * n)}]" for i in range(1, n)]
    return "\n".join(lines) + "\n"


def _sparse(path, size: int = 100 * 10**6):
    """A file of ``size`` bytes that takes no disk (and whose size is all a check sees)."""
    with open(path, "wb") as f:
        f.truncate(size)
    return path


def _bounded_cli_error(capsys, *argv, seconds: float = 5.0, mb: float = 200.0):
    """The CLI's one-line error, within ``seconds`` and ``mb`` more peak memory."""
    import resource
    import time

    # The commands' imports are not what is timed.
    import manta_drake.calibrate
    import manta_drake.optimize
    import manta_drake.simulate
    import manta_drake.sweep  # noqa: F401

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    start = time.perf_counter()
    message = _cli_error(capsys, *argv)
    assert time.perf_counter() - start < seconds, message
    assert (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak) / 1024 < mb, message
    return message


def _kinds(tmp_path, text: str):
    """(kind, argv) running each of the 7 YAML file kinds holding ``text`` (the scenario
    naming the coefficients, actuators and gait file)."""
    files = {
        kind: tmp_path / f"{kind}.yaml"
        for kind in (
            "scenario",
            "coefficients",
            "actuators",
            "gaits",
            "sweep",
            "calibration",
            "optimisation",
        )
    }
    for path in files.values():
        path.write_text(text)
    run = ["--out", str(tmp_path / "out")]
    for kind, field in (
        ("coefficients", "water: {coefficients: %s}"),
        ("actuators", "actuators: {file: %s}"),
        ("gaits", "controller: {gait_files: [%s]}"),
    ):
        (tmp_path / f"s_{kind}.yaml").write_text(field % files[kind] + "\n")
    return [
        ("scenario", files["scenario"], ["run", str(files["scenario"]), *run, "--no-meshcat"]),
        *[
            (kind, files[kind], ["run", str(tmp_path / f"s_{kind}.yaml"), *run, "--no-meshcat"])
            for kind in ("coefficients", "actuators", "gaits")
        ],
        ("sweep", files["sweep"], ["sweep", str(files["sweep"]), *run]),
        ("calibration", files["calibration"], ["calibrate", str(files["calibration"]), *run]),
        ("optimisation", files["optimisation"], ["optimize", str(files["optimisation"]), *run]),
    ]


def test_limits_gait_file_alias_bomb_is_refused_at_once(tmp_path, capsys):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("gaits:\n  wide:\n    base: trot\n    mirror_keep:\n" + _alias_bomb("    "))
    scenario = tmp_path / "scen.yaml"
    scenario.write_text(f"controller: {{gait_files: [{bomb}]}}\n")
    message = _bounded_cli_error(
        capsys, "run", str(scenario), "--out", str(tmp_path / "x"), "--no-meshcat"
    )
    assert (
        f"{scenario}: {bomb}: line 9: gaits.wide.mirror_keep[4][6]: more than 50000 "
        "values with its aliases expanded (an alias bomb?)" in message
    )
    assert "R_deg" not in message  # no value is printed
    assert not (tmp_path / "x").exists()


def test_limits_sweep_grid_alias_bomb_is_refused_at_once(tmp_path, capsys):
    sweep = tmp_path / "bomb_sweep.yaml"
    sweep.write_text("base: [stand]\ngrid:\n  duration:\n" + _alias_bomb("  "))
    message = _bounded_cli_error(capsys, "sweep", str(sweep), "--out", str(tmp_path / "y"))
    assert f"{sweep}: line 8: grid.duration[4][6]: more than 50000 values" in message
    assert not (tmp_path / "y").exists()


def test_limits_recursive_alias_is_refused_naming_the_line(tmp_path, capsys):
    scenario = tmp_path / "r.yaml"
    scenario.write_text("duration: 1\nwater: &w {current: [0, 0, 0], self: *w}\n")
    message = _bounded_cli_error(capsys, "run", str(scenario), "--out", str(tmp_path / "o"))
    assert f"{scenario}: line 2: water.self: the alias *w is inside the value it names" in message


def test_limits_aliases_within_the_limits_still_read():
    from manta_drake.config_io import parse_yaml

    data = parse_yaml("a: &p [1, 2]\nb: *p\nc: {d: *p, e: &s text}\nf: *s\n")
    assert data == {"a": [1, 2], "b": [1, 2], "c": {"d": [1, 2], "e": "text"}, "f": "text"}


def test_limits_100_mb_files_of_every_kind_are_refused_before_reading(tmp_path, capsys):
    for kind, path, argv in _kinds(tmp_path, "duration: 1\n"):
        _sparse(path)
        message = _bounded_cli_error(capsys, *argv, seconds=3.0, mb=50.0)
        assert f"{path}: the file is 100 MB, larger than the 1 MB limit for" in message, kind
        assert not (tmp_path / "out").exists(), kind


def test_limits_100_mb_measured_csv_is_refused_before_reading(tmp_path, capsys):
    csv = _sparse(tmp_path / "m.csv")
    calibration = tmp_path / "c.yaml"
    calibration.write_text(
        "name: t\nparameters:\n  - {name: hull, coefficients: [body.linear_damping], "
        "bounds: [0.3, 3]}\nexperiments:\n  - {name: swim, scenario: locomotion_swim, "
        "overrides: {duration: 2.0}, measured: m.csv, columns: [x, y, yaw]}\n"
    )
    message = _bounded_cli_error(
        capsys, "calibrate", str(calibration), "--out", str(tmp_path / "o"), seconds=3.0, mb=50.0
    )
    assert (
        f"calibration.experiments[0].measured: {csv}: the file is 100 MB, larger than the "
        "50 MB limit for measured CSV files"
    ) in message


def test_limits_big_results_table_and_long_csv_field_are_one_line(tmp_path):
    from manta_drake.calibrate import load_measured
    from manta_drake.sweep import SweepError, read_table

    table = _sparse(tmp_path / "results.csv")
    with pytest.raises(
        SweepError,
        match=f"^{table}: the file is 100 MB, larger than the 16 MB limit for results CSV files$",
    ):
        read_table(table)
    long = tmp_path / "long.csv"
    long.write_text("t,x,y,z,yaw\n0,0,0,0," + "1" * 200_000 + "\n")
    with pytest.raises(SweepError, match=r"^m: .*long.csv: line 2: not valid CSV: field larger"):
        load_measured(long, where="m")


@pytest.mark.slow
def test_limits_20000_deep_nesting_of_every_kind_names_the_file_and_line(tmp_path, capsys):
    deep = "deep: " + "[" * 20000 + "]" * 20000 + "\n"
    kinds = _kinds(tmp_path, deep)
    assert len(kinds) == 7
    for kind, path, argv in kinds:
        message = _bounded_cli_error(capsys, *argv)
        assert f"{path}: line 1: deep[0][0]" in message, kind
        assert "nested more than 64 levels deep (mappings and lists)" in message, kind
        assert "recursion" not in message, kind
    message = _bounded_cli_error(
        capsys,
        "run",
        "stand",
        "--out",
        str(tmp_path / "o"),
        "--set",
        "water.current=" + "[" * 20000 + "]" * 20000,
    )
    assert "--set water.current: line 1: [0][0]" in message and "64 levels" in message


@pytest.mark.slow
def test_limits_3000_deep_behaviour_tree_names_the_field(tmp_path, capsys):
    nodes = "".join(f"    n{i}: {{children: [n{i + 1}, swim]}}\n" for i in range(1, 2999))
    scenario = tmp_path / "deep_tree.yaml"
    scenario.write_text(
        "controller: {mode: transition}\ntransition:\n  tree:\n"
        "    root: {children: [n1, swim]}\n" + nodes + "    n2999: {children: [trot, swim]}\n"
    )
    # 36 000 values: the scenario's layers read them three times (~1.5 s on an idle machine)
    message = _bounded_cli_error(
        capsys, "run", str(scenario), "--out", str(tmp_path / "o"), seconds=60.0
    )
    assert (
        f"{scenario}: transition.tree.n32: 33 nodes deep from root (root -> n1 -> n2 -> "
        "...); a tree may be at most 32 nodes deep"
    ) in message


def test_limits_shared_subtrees_are_walked_once():
    """A 32-deep tree whose every node has one child twice: 2^31 paths, compiled at once."""
    import time

    from manta_drake.control.behaviour_tree import BlendNode, compile_tree

    nodes = {
        "root" if i == 0 else f"n{i}": BlendNode(children=[f"n{i + 1}"] * 2) for i in range(31)
    }
    nodes["n31"] = BlendNode(children=["a", "b"])
    start = time.perf_counter()
    tree = compile_tree(nodes, {"a": np.zeros(64), "b": np.ones(64)})
    assert tree.leaves == ("a", "b") and time.perf_counter() - start < 1.0


def test_limits_gait_base_that_is_not_a_name(tmp_path, capsys):
    gaits = tmp_path / "g.yaml"
    gaits.write_text("gaits:\n  wide: {base: [trot]}\n")
    scenario = tmp_path / "s.yaml"
    scenario.write_text(f"controller: {{gait_files: [{gaits}]}}\n")
    message = _cli_error(capsys, "run", str(scenario), "--out", str(tmp_path / "o"))
    assert (
        f"{gaits}: gaits.wide.base: ['trot']: expected the name of a gait defined before it"
        in message
        and "unhashable" not in message
    )


def test_limits_messages_show_a_bounded_value():
    from manta_drake.config_io import ScenarioError, check_keys, check_vector, short_repr
    from manta_drake.scenario import Scenario

    huge = [1.0] * 9
    for _ in range(8):
        huge = [huge] * 9  # 387 M leaves, shared
    assert len(short_repr(huge)) <= 80 and short_repr("x" * 10**6, 20) == "'" + "x" * 16 + "..."
    assert short_repr(10**5000) == "<int too large to print>"
    with pytest.raises(ScenarioError) as info:
        check_vector("water.current", huge, 3)
    assert str(info.value).startswith("water.current: expected 3 finite numbers, got [[[[")
    assert len(str(info.value)) < 150
    with pytest.raises(ScenarioError) as info:
        check_keys({"duration": huge}, Scenario)
    assert str(info.value).startswith("scenario.duration: expected a float, got [[[[")
    assert len(str(info.value)) < 150


def test_limits_the_readme_gives_are_the_codes():
    from manta_drake import config_io as io
    from manta_drake.control.behaviour_tree import MAX_TREE_DEPTH

    text = " ".join((MODELS_DIR.parent / "README.md").read_text().split())
    paragraph = text.split("Every input is bounded before it is parsed")[1].split("## ")[0]
    for shown in (
        f"is at most {io.MAX_YAML_BYTES / io.MB:g} MB",
        f"at most {io.MAX_YAML_DEPTH} deep",
        f"at most {io.MAX_YAML_NODES:,} values".replace(",", " "),
        f"CSV is at most {io.MAX_MEASURED_CSV_BYTES / io.MB:g} MB",
        f"CSV at most {io.MAX_TABLE_CSV_BYTES / io.MB:g} MB",
        f"at most {MAX_TREE_DEPTH} nodes deep",
    ):
        assert shown in paragraph, shown


@pytest.mark.parametrize(
    "text, needle",
    [
        ("duration: 2020-02-30\n", "a value cannot be read: day is out of range for month"),
        (
            "random_seed: 1" + "0" * 5000 + "\n",
            "a value cannot be read: Exceeds the limit (4300 digits) for integer string conversion",
        ),
        ("? [duration]\n: 1\n", "not valid YAML: a list as a mapping key"),
    ],
)
def test_limits_values_yaml_cannot_build_name_the_file(tmp_path, capsys, text, needle):
    path = tmp_path / "v.yaml"
    path.write_text(text)
    message = _cli_error(capsys, "run", str(path), "--out", str(tmp_path / "o"))
    assert f"{path}: {needle}" in message and len(message) < 250 + len(str(path))


# --- ranges declared once (config_io.Range in the System's module) ---------------------------


def _system_with(name, value):
    """The System (or function) whose argument a shared range bounds, given ``value``."""
    from manta_drake.control.cpg import CpgOscillators
    from manta_drake.control.depth import FuzzyDepthEstimator
    from manta_drake.model.plant import add_plant, set_contact_friction
    from manta_drake.station.pressure import PressureSensor

    if name in ("frequency_hz", "chain_weight", "fcs_weight", "a", "b"):
        return CpgOscillators(**{name: value})
    if name == "floor_distance":
        return FuzzyDepthEstimator(value, period=0.02)
    if name == "surface_depth":
        return FuzzyDepthEstimator(0.2, period=0.02, surface_depth=value)
    if name == "dropout_rate":
        from pydrake.systems.framework import DiagramBuilder

        h = add_plant(DiagramBuilder())
        return PressureSensor(h.plant, h.body, [0, 0, 0], 0.02, 0.0, value)
    if name == "mu":
        return set_contact_friction(None, value)  # checked before the plant is touched
    raise AssertionError(name)


# (scenario field, System argument as its messages name it, the range, the value just
# outside it): each range is declared once, in the System's module, and both sides check it.
SHARED_RANGES = [
    ("cpg.frequency_hz", "CpgOscillators.frequency_hz", "(0, 5] Hz", 5.000001),
    ("cpg.frequency_hz", "CpgOscillators.frequency_hz", "(0, 5] Hz", 0.0),
    ("cpg.chain_weight", "CpgOscillators.chain_weight", "[0, 100] rad/s", 100.000001),
    ("cpg.fcs_weight", "CpgOscillators.fcs_weight", "[0, 100] rad/s", -1e-09),
    ("cpg.a", "CpgOscillators.a", "(0, 200] 1/s", 0.0),
    ("cpg.b", "CpgOscillators.b", "(0, 200] 1/s", 200.000001),
    (
        "depth_estimator.floor_distance",
        "FuzzyDepthEstimator.floor_distance",
        "(0, 10] m",
        10.000001,
    ),
    (
        "depth_estimator.surface_depth",
        "FuzzyDepthEstimator.surface_depth",
        "[0, floor_distance = 0.2) m",
        0.2,
    ),
    ("pressure_sensor.dropout_rate", "PressureSensor.dropout_rate", "[0, 1]", 1.000001),
    ("contact.friction", "set_contact_friction.mu", "(0, 2]", 2.000001),
]


@pytest.mark.parametrize("field, argument, allowed, value", SHARED_RANGES)
def test_a_range_declared_once_refuses_the_same_value_on_both_sides(
    field, argument, allowed, value
):
    """A value just outside a shared range is refused by the scenario (naming the dotted
    field) and by the System's constructor (naming its argument), with the same range."""
    from manta_drake.config_io import ScenarioError
    from manta_drake.scenario import load_scenario

    overrides = {field: value}
    if field == "depth_estimator.surface_depth":
        overrides["depth_estimator.floor_distance"] = 0.2
    base = load_scenario("two_behaviors")
    with pytest.raises(ScenarioError) as scenario_error:
        load_scenario(defaults=base, overrides=overrides)
    assert str(scenario_error.value) == f"{field}: {value!r} is outside the allowed range {allowed}"
    with pytest.raises(ValueError) as system_error:
        _system_with(argument.split(".")[-1], value)
    message = str(system_error.value)
    assert message.startswith(f"{argument}: {value!r} is outside the allowed range {allowed}")
    # Just inside, both accept it.
    inside = {5.000001: 5.0, 0.0: 1e-06, 100.000001: 100.0, -1e-09: 0.0, 200.000001: 200.0}
    inside |= {10.000001: 10.0, 0.2: 0.19, 1.000001: 1.0, 2.000001: 2.0}
    overrides[field] = inside[value]
    section, name = field.split(".")
    loaded = load_scenario(defaults=base, overrides=overrides)
    assert getattr(getattr(loaded, section), name) == inside[value]
    if argument != "set_contact_friction.mu":  # which then needs a plant
        _system_with(argument.split(".")[-1], inside[value])


def test_range_text_states_open_and_closed_ends_and_the_note():
    from manta_drake.config_io import Range, ScenarioError

    assert Range(0.0, 10.0, "m", open_low=True).text() == "(0, 10] m"
    assert Range(0.0, 1.0).text("a probability") == "[0, 1] (a probability)"
    assert Range(-1.0, 0.5, "s", open_high=True).text() == "[-1, 0.5) s"
    with pytest.raises(
        ScenarioError, match=r"^x\.y: 0\.5 is outside the allowed range \[-1, 0\.5\) s$"
    ):
        Range(-1.0, 0.5, "s", open_high=True).check("x.y", 0.5)


def test_the_pressure_rate_is_refused_where_the_depth_estimators_period_would_be():
    """With the water on, the depth estimator updates at the pressure sensor's rate: a rate
    whose period 1/rate_hz leaves the estimator's range (control.depth.PERIOD, (0, 1] s) is
    refused at load time, as the estimator refuses the period; with the water off (no
    estimator) only the rate's own range applies."""
    from manta_drake.config_io import ScenarioError
    from manta_drake.control.depth import FuzzyDepthEstimator
    from manta_drake.scenario import load_scenario

    base = load_scenario("two_behaviors")
    with pytest.raises(ScenarioError) as error:
        load_scenario(defaults=base, overrides={"pressure_sensor.rate_hz": 0.999})
    assert str(error.value) == (
        "pressure_sensor.rate_hz: 0.999 is outside the allowed range [1, 1/time_step = 1000] "
        "Hz (the depth estimator's period, 1/rate_hz, is in (0, 1] s)"
    )
    with pytest.raises(ScenarioError, match=r"^FuzzyDepthEstimator\.period: 1\.001.* is outside "):
        FuzzyDepthEstimator(0.2, period=1.0 / 0.999)
    edge = load_scenario(defaults=base, overrides={"pressure_sensor.rate_hz": 1.0})
    assert edge.pressure_sensor.rate_hz == 1.0
    FuzzyDepthEstimator(0.2, period=1.0)
    dry = load_scenario(
        "stand", overrides={"pressure_sensor.rate_hz": 0.5, "controller.mode": "hold"}
    )
    assert not dry.water.enabled and dry.pressure_sensor.rate_hz == 0.5
