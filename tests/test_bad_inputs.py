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
    ("depth_estimator: {surface_depth: 0.25}\n", "depth_estimator.surface_depth",
     "[0, floor_distance = 0.2)"),
    ("depth_estimator: {surface_depth: 0.2}\n", "depth_estimator.surface_depth",
     "[0, floor_distance = 0.2)"),
    ("camera: {min_range: 0.8, max_range: 0.8}\n", "camera.min_range", "max_range = 0.8)"),
    ("water: {current: [100, 0, 0]}\n", "water.current", "1.0 m/s"),
    ("water: {current: [.nan, 0, 0]}\n", "water.current[0]", "not finite"),
    ("water: {update_period: -0.004}\n", "water.update_period", "[0, 0.02]"),
    ("water: {coefficients: nope.yaml}\n", "water.coefficients", "not found"),
    ("water: {coefficient_scales: {body.linear_damping: -1}}\n",
     "water.coefficient_scales.body.linear_damping", ">= 0"),
    ("water: {coefficient_scales: {body.dampin: 2}}\n", "water.coefficient_scales.body.dampin",
     "unknown coefficient"),
    ("balloon: {initial_fill: 2}\n", "balloon.initial_fill", "[0, 1]"),
    ("balloon: {schedule: [{time: 5, fill: 0}, {time: 2, fill: 1}]}\n",
     "balloon.schedule[1].time", "must not decrease"),
    ("pressure_sensor: {rate_hz: 5000}\n", "pressure_sensor.rate_hz", "1/time_step"),
    ("pressure_sensor: {noise_std: 1.0}\n", "pressure_sensor.noise_std", "[0, 0.1]"),
    ("camera: {depth_noise_std: 0.1}\n", "camera.depth_noise_std", "[0, 0.03]"),
    ("camera: {width: 100.5}\n", "camera.width", "int"),
    ("camera: {min_range: 1.0, max_range: 0.8}\n", "camera.min_range", "max_range"),
    ("wall_detector: {normal_max_neighbors: 0}\n", "wall_detector.normal_max_neighbors",
     "[3, 200]"),
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


@pytest.mark.parametrize("text, field, more", BAD_SCENARIOS,
                         ids=[f"{i:02d}-{case[1]}" for i, case in enumerate(BAD_SCENARIOS)])
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


@pytest.mark.parametrize("make, field", [
    (lambda p: _coefficients_with(p, "strips_per_plate:\n    value: 4", "strips_per_plate:\n    value: 2.5"),
     "fins.strips_per_plate = 2.5 must be a whole number"),
    (lambda p: _coefficients_with(p, "sealed_volume:\n    value: 0.0051", "sealed_volume:\n    value: 0.0"),
     "body.sealed_volume = 0.0 must be > 0"),
    # The buoyancy comes from the semi-axes: a volume edited alone would have no effect.
    (lambda p: _coefficients_with(p, "sealed_volume:\n    value: 0.0051", "sealed_volume:\n    value: 0.0061"),
     "body.sealed_volume = 0.0061 m^3 disagrees with body.sealed_semi_axes (4/3 pi abc = 0.0051 m^3"),
    (lambda p: _coefficients_with(p, "water_density:\n  value: 1000.0", "water_density:\n  value: 1.0e9"),
     "water_density = 1000000000.0 is outside the allowed range [900, 1300] kg/m^3"),
    (lambda p: _coefficients_with(p, "gravity:\n  value: 9.81", "gravity:\n  value: 98.1"),
     "gravity = 98.1 is outside the allowed range [9.7, 9.9] m/s^2"),
    (lambda p: _file(p / "empty.yaml", b""), "must be a mapping"),
    (lambda p: _file(p / "bin.yaml", b"\xff\xfe\x00\x81binary"), "not a UTF-8 text"),
])
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
        (lambda: WallDetector(period=0.2, params=WallDetectorParams(normal_max_neighbors=0)),
         "normal_max_neighbors: 0 is outside the allowed range [3, 200]"),
        (lambda: WallDetector(period=0.0), "period"),
        (lambda: FuzzyDepthEstimator(math.nan, period=0.02), "floor_distance"),
        (lambda: BalloonBuoyancy(-1.0, 1e-4, 0.01), "max_volume"),
        (lambda: CpgOscillators(frequency_hz=0.0), "frequency_hz"),
        (lambda: CpgOscillators(initial_state=np.zeros(3)), "initial_state"),
        (lambda: CpgOscillators(frequency_hz=1e9),
         "CpgOscillators.frequency_hz: 1000000000.0 is outside the allowed range (0, 5] Hz"),
        (lambda: CpgOscillators(chain_weight=-1.0), "chain_weight: -1.0 is outside"),
        (lambda: FuzzyDepthEstimator(0.2, period=0.02, initial_depth=math.nan),
         "FuzzyDepthEstimator.initial_depth: nan is not finite"),
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
    s = load_scenario("stand", overrides={"visualization.recording_fps": 30.0,
                                          "visualization.meshcat": False})
    assert s.visualization.recording_fps == 30.0 and not s.visualization.meshcat
