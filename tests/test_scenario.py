"""Scenario loading: typos and out-of-range values fail at load time, naming the field."""


import numpy as np
import pytest

from manta_drake.scenario import (
    Scenario,
    ScenarioError,
    load_scenario,
    shipped_scenarios,
)


def _write(tmp_path, text):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("path", shipped_scenarios(), ids=lambda p: p.name)
def test_shipped_scenarios_load(path):
    scenario = load_scenario(path)
    assert scenario.duration > 0
    assert scenario.name == path.stem


def test_fin_sweep_defaults_to_the_readings_balanced_sweep(tmp_path):
    """robot.fin_sweep_deg left out: the sweep that balances the reading's stance, also when
    the reading is overridden after loading (--set, sweep rows); an explicit value wins."""
    from manta_drake.control.gaits import BALANCED_FIN_SWEEP_DEG
    from manta_drake.scenario import set_override

    for reading, sweep in BALANCED_FIN_SWEEP_DEG.items():
        s = load_scenario(_write(tmp_path, f"controller: {{gait_reading: {reading}}}\n"))
        assert s.fin_sweep_deg() == sweep
        assert s.robot_params().mounts[0].sweep == pytest.approx(np.radians(sweep))
    s = load_scenario("locomotion_trot")
    set_override(s, "controller.gait_reading", "mirrored")
    assert s.validate().fin_sweep_deg() == 30.0
    set_override(s, "robot.fin_sweep_deg", 12.5)
    assert s.validate().fin_sweep_deg() == 12.5
    assert s.robot_params().mounts[0].sweep == pytest.approx(np.radians(12.5))


def test_values_are_typed(tmp_path):
    s = load_scenario(_write(tmp_path, "duration: 3\ninitial_pose: {xyz: [1, 0, -0.2]}\n"
                                        "simulator: {integration_scheme: explicit_euler}\n"))
    assert s.duration == 3.0 and isinstance(s.duration, float)
    assert s.initial_pose.xyz == [1.0, 0.0, -0.2]
    assert s.simulator.integration_scheme == "explicit_euler"
    assert s.simulator.max_step_size == pytest.approx(1e-3)  # default kept


@pytest.mark.parametrize("text, needle", [
    ("duraton: 3\n", "scenario.duraton"),
    ("initial_pose: {xyzz: [0, 0, 0]}\n", "scenario.initial_pose.xyzz"),
    ("controller: {mdoe: gait}\n", "scenario.controller.mdoe"),
    ("robot: {fin_sweep: 30}\n", "scenario.robot.fin_sweep"),
    ("simulator: {max_stepsize: 0.001}\n", "scenario.simulator.max_stepsize"),
])
def test_misspelt_key_fails_naming_the_key(tmp_path, text, needle):
    with pytest.raises(ScenarioError, match=needle.replace(".", r"\.")) as info:
        load_scenario(_write(tmp_path, text))
    assert "allowed keys" in str(info.value)


@pytest.mark.parametrize("text, field, allowed", [
    ("duration: -1\n", "duration", "(0, 3600]"),
    ("duration: 0\n", "duration", "(0, 3600]"),
    ("time_step: 0\n", "time_step", "[0.0001, 0.01]"),
    ("time_step: -0.001\n", "time_step", "[0.0001, 0.01]"),
    ("controller: {mode: dance}\n", "controller.mode", "hold, gait, transition"),
    ("controller: {gait: gallop}\n", "controller.gait", "swim, trot, walk, turning, crab"),
    ("initial_pose: {xyz: [0, 0]}\n", "initial_pose.xyz", "3 finite numbers"),
    ("random_seed: -4\n", "random_seed", "[0, 4294967295]"),
    ("robot: {fin_sweep_deg: 75}\n", "robot.fin_sweep_deg", "[-60, 60] deg (or null"),
    ("controller: {gait_reading: mirror}\n", "controller.gait_reading", "paper, mirrored"),
])
def test_out_of_range_value_fails_naming_field_and_range(tmp_path, text, field, allowed):
    with pytest.raises(ScenarioError) as info:
        load_scenario(_write(tmp_path, text))
    message = str(info.value)
    assert f"{field}:" in message and allowed in message


def test_wrong_type_and_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="duration"):
        load_scenario(_write(tmp_path, "duration: soon\n"))
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "nope.yaml")


def test_defaults_validate():
    assert Scenario().validate().time_step == pytest.approx(1e-3)


def test_transition_parameters_checked_at_load_time(tmp_path):
    with pytest.raises(ScenarioError, match=r"transition\.alpha \* g \* T = 4.75 > 1 would overshoot"):
        load_scenario(_write(tmp_path, "transition: {g: 5.0, T: 1.0}\n"))
    with pytest.raises(ScenarioError, match=r"transition\.z_t: 1.5 is outside \(0, 1\]"):
        load_scenario(_write(tmp_path, "transition: {z_t: 1.5}\n"))
