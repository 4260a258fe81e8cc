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


@pytest.mark.slow
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
    s = load_scenario(
        _write(
            tmp_path,
            "duration: 3\ninitial_pose: {xyz: [1, 0, -0.2]}\n"
            "simulator: {integration_scheme: explicit_euler}\n",
        )
    )
    assert s.duration == 3.0 and isinstance(s.duration, float)
    assert s.initial_pose.xyz == [1.0, 0.0, -0.2]
    assert s.simulator.integration_scheme == "explicit_euler"
    assert s.simulator.max_step_size == pytest.approx(1e-3)  # default kept


@pytest.mark.parametrize(
    "text, needle",
    [
        ("duraton: 3\n", "scenario.duraton"),
        ("initial_pose: {xyzz: [0, 0, 0]}\n", "scenario.initial_pose.xyzz"),
        ("controller: {mdoe: gait}\n", "scenario.controller.mdoe"),
        ("robot: {fin_sweep: 30}\n", "scenario.robot.fin_sweep"),
        ("simulator: {max_stepsize: 0.001}\n", "scenario.simulator.max_stepsize"),
    ],
)
def test_misspelt_key_fails_naming_the_key(tmp_path, text, needle):
    with pytest.raises(ScenarioError, match=needle.replace(".", r"\.")) as info:
        load_scenario(_write(tmp_path, text))
    assert "allowed keys" in str(info.value)


@pytest.mark.parametrize(
    "text, field, allowed",
    [
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
        ("actuators: {servo_model: dynamixel}\n", "actuators.servo_model", "ideal, datasheet"),
        (
            "actuators: {bus_period: 0.0005}\n",
            "actuators.bus_period",
            "0 or [time_step = 0.001, 0.1] s",
        ),
        (
            "actuators: {bus_period: 0.5}\n",
            "actuators.bus_period",
            "0 or [time_step = 0.001, 0.1] s",
        ),
    ],
)
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


def test_defaults_are_consistent_with_each_other():
    """The defaults' relations that the runs rely on: the integrator steps on the plant's
    grid, the recording, the log and the transition on whole steps, the start clear of the
    pool (validate runs the collision query) and the sensor's rate within one step."""
    s = Scenario().validate()
    assert s.simulator.max_step_size == s.time_step
    assert not s.simulator.use_error_control
    steps = 1.0 / s.visualization.recording_fps / s.time_step
    assert steps == pytest.approx(round(steps)) and round(steps) >= 1
    for period in (s.log_period, s.transition.period, 1.0 / s.pressure_sensor.rate_hz):
        assert period / s.time_step == pytest.approx(round(period / s.time_step))
    assert s.depth_estimator.surface_depth < s.depth_estimator.floor_distance
    assert s.camera.min_range < s.camera.max_range


def test_transition_parameters_checked_at_load_time(tmp_path):
    with pytest.raises(
        ScenarioError, match=r"transition\.alpha \* g \* T = 4.75 > 1 would overshoot"
    ):
        load_scenario(_write(tmp_path, "transition: {g: 5.0, T: 1.0}\n"))
    with pytest.raises(ScenarioError, match=r"transition\.z_t: 1.5 is outside \(0, 1\]"):
        load_scenario(_write(tmp_path, "transition: {z_t: 1.5}\n"))


def test_layers_apply_in_order_and_keep_what_they_do_not_name(tmp_path):
    """defaults <- file <- data <- overrides, as the manipulation course's LoadScenario."""
    from manta_drake.scenario import Scenario as S

    base = S(duration=3.0, random_seed=5)
    base.water.coefficient_scales = {"body.linear_damping": 1.1}
    path = _write(
        tmp_path,
        "name: layered\ncontact: {friction: 0.7}\n"
        "water: {coefficient_scales: {body.quadratic_damping: 0.9}}\n",
    )
    s = load_scenario(
        path,
        data={"contact": {"friction": 0.6}, "random_seed": 9},
        defaults=base,
        overrides={
            "random_seed": 11,
            "duration": 2.0,
            "water.coefficient_scales.fins.normal_force_coefficient": 1.2,
        },
    )
    assert s.name == "layered" and s.duration == 2.0 and s.random_seed == 11
    assert s.contact.friction == 0.6
    # Maps merge across the layers; a field no layer names keeps the dataclass default.
    assert s.water.coefficient_scales == {
        "body.linear_damping": 1.1,
        "body.quadratic_damping": 0.9,
        "fins.normal_force_coefficient": 1.2,
    }
    assert s.camera.width == S().camera.width
    assert base.duration == 3.0 and base.random_seed == 5  # the defaults are not changed


def test_layered_errors_name_the_full_dotted_field(tmp_path):
    with pytest.raises(ScenarioError, match=r"contact\.frction: scenario\.contact has no field"):
        load_scenario("stand", overrides={"contact.frction": 0.5})
    with pytest.raises(ScenarioError, match=r"scenario\.contact\.friction: expected a float"):
        load_scenario("stand", overrides={"contact.friction": "high"})
    with pytest.raises(ScenarioError, match=r"contact\.friction: 7\.0 is outside"):
        load_scenario("stand", overrides={"contact.friction": 7})
    with pytest.raises(ScenarioError, match=r"scenario\.camera\.widht: unknown key"):
        load_scenario("stand", data={"camera": {"widht": 3}})
    with pytest.raises(ScenarioError, match="set twice"):
        load_scenario(
            "stand", overrides={"water.current": [0, 0, 0], "water": {"current": [0.1, 0, 0]}}
        )
    with pytest.raises(ScenarioError, match="duplicate key 'duration'"):
        load_scenario(_write(tmp_path, "duration: 1\nduration: 2\n"))


def test_set_items_parse_as_yaml_and_name_the_option():
    from manta_drake.scenario import parse_set

    assert parse_set(["a.b=0.5", "c=[1, 2]", "d=null", "e=text"]) == {
        "a.b": 0.5,
        "c": [1, 2],
        "d": None,
        "e": "text",
    }
    with pytest.raises(ScenarioError, match=r"--set duration: not valid YAML"):
        parse_set(["duration=[1"])
    with pytest.raises(ScenarioError, match=r"--set x: expected KEY=VALUE"):
        parse_set(["x"])


def test_tree_nodes_are_settable_and_sweepable_by_dotted_keys():
    """transition.tree.NODE.FIELD is a scenario key (sweeps and --set use these): a field of
    a node merges into the scenario's tree, a misspelt field is refused naming the node's
    fields, and the result is checked as a tree."""
    from manta_drake.scenario import check_override_key

    four = load_scenario("four_behaviors")
    check_override_key("transition.tree.floor.threshold")
    with pytest.raises(
        ScenarioError,
        match=r"scenario\.transition\.tree\.floor has no field "
        r"'thresold'; allowed: children, full_at",
    ):
        check_override_key("transition.tree.floor.thresold")
    s = load_scenario(
        defaults=four,
        overrides={
            "transition.tree.floor.threshold": 0.3,
            "transition.tree.floor.modality": "posture_hat",
        },
    )
    assert s.transition.tree["floor"].threshold == 0.3
    assert s.transition.tree["floor"].children == four.transition.tree["floor"].children
    assert s.transition.tree["root"] == four.transition.tree["root"]
    assert "posture_hat" in s.behaviour_tree().modalities
    with pytest.raises(ScenarioError, match=r"transition\.tree\.floor\.threshold: 1\.5"):
        load_scenario(defaults=four, overrides={"transition.tree.floor.threshold": 1.5})


def test_heading_hold_behaviours_are_gaits_and_one_is_a_leaf_of_the_tree():
    """The hold's behaviours name gaits of the scenario's library (its own gait files'
    too); in transition mode one must be a leaf of the tree or the hold never engages, and
    behaviours that are gaits but not leaves (swim_printed beside swim) are allowed."""
    four = load_scenario("four_behaviors")
    assert "swim_printed" not in four.behaviour_tree().leaves  # the default list still loads
    rest = load_scenario(defaults=four, overrides={"heading_hold.behaviours": ["rest"]})
    assert rest.heading_hold.behaviours == ["rest"]  # a gait of the scenario's own file
    with pytest.raises(
        ScenarioError,
        match=r"heading_hold\.behaviours: \['crab'\] names none "
        r"of the behaviour tree's gaits.*allowed: swim, "
        r"trot, walk, rest$",
    ):
        load_scenario(defaults=four, overrides={"heading_hold.behaviours": ["crab"]})
    with pytest.raises(
        ScenarioError,
        match=r"heading_hold\.behaviours\[1\]: 'rset' is not a "
        r"gait; allowed: .*, rest$",
    ):
        load_scenario(defaults=four, overrides={"heading_hold.behaviours": ["swim", "rset"]})
    # a fixed gait is trimmed whole: any gait of the library names it
    hold = load_scenario("swim_heading_hold", overrides={"heading_hold.behaviours": ["crab"]})
    assert hold.controller.mode == "gait"


def test_a_zero_current_beside_a_schedule_is_no_constant():
    """water.current and water.current_schedule are exclusive, and the zero current (the
    default) is no constant: a schedule with it loads, with any other current it is refused."""
    four = load_scenario("four_behaviors")
    zero = load_scenario(defaults=four, overrides={"water.current": [0.0, 0.0, 0.0]})
    assert not zero.current_schedule().is_constant
    with pytest.raises(
        ScenarioError,
        match=r"water\.current: \[0\.0, 0\.0, 0\.001\] is set "
        r"beside water\.current_schedule; they are "
        r"exclusive",
    ):
        load_scenario(defaults=four, overrides={"water.current": [0.0, 0.0, 0.001]})
    cleared = load_scenario(
        defaults=four, overrides={"water.current": [0.0, 0.05, 0.0], "water.current_schedule": []}
    )
    assert cleared.current_schedule().is_constant


def test_a_constant_current_is_the_schedules_one_key_case(tmp_path):
    """The deprecated water.current: V reads as the one-key schedule [{time: 0, velocity:
    V}] (zero: no key, still water), in a file and through --set; the written scenario has
    the schedule only, and reads back the same."""
    from manta_drake.scenario import scenario_yaml
    from manta_drake.station.current import CurrentPoint

    old = load_scenario(_write(tmp_path, "water: {current: [0.05, 0, -0.01]}\n"))
    assert old.water.current_schedule == [CurrentPoint(0.0, [0.05, 0.0, -0.01])]
    new = load_scenario(
        _write(tmp_path, "water: {current_schedule: [{time: 0, velocity: [0.05, 0, -0.01]}]}\n")
    )
    assert scenario_yaml(old) == scenario_yaml(new)
    schedule = old.current_schedule()
    assert schedule.is_constant and schedule.at(7.0).tolist() == [0.05, 0.0, -0.01]
    text = scenario_yaml(old)
    assert "\n  current:" not in text
    assert "\n  current_schedule:\n  - time: 0.0\n    velocity: [0.05, 0.0, -0.01]\n" in text
    assert scenario_yaml(load_scenario(data=text)) == text
    still = load_scenario(defaults=old, overrides={"water.current": [0, 0, 0]})
    assert still.water.current_schedule == [] and still.current_schedule().at(1.0).tolist() == [
        0.0,
        0.0,
        0.0,
    ]
    # A constant replaces a constant (the base's one key).
    faster = load_scenario(defaults=old, overrides={"water.current": [0.1, 0, 0]})
    assert faster.water.current_schedule == [CurrentPoint(0.0, [0.1, 0.0, 0.0])]
    with pytest.raises(ScenarioError, match=r"^water\.current: expected 3 finite numbers"):
        load_scenario(overrides={"water.current": [0.1, 0]})
    with pytest.raises(ScenarioError, match=r"^scenario\.water\.current: expected a list"):
        load_scenario(overrides={"water.current": "fast"})


def test_blend_and_z_t_read_as_eq12s_tree(tmp_path):
    """The deprecated transition.blend and transition.z_t read as the tree
    default_tree(blend, z_t) (potential and 1: the default tree, no tree written); a later
    layer naming one keeps the other; beside another tree they are refused."""
    from manta_drake.control.behaviour_tree import default_tree, default_tree_parameters
    from manta_drake.scenario import scenario_yaml

    linear = load_scenario(_write(tmp_path, "transition: {blend: normalised, z_t: 0.8}\n"))
    assert linear.transition.tree == default_tree("normalised", 0.8)
    assert default_tree_parameters(linear.behaviour_nodes()) == ("normalised", 0.8)
    moved = load_scenario(defaults=linear, overrides={"transition.z_t": 0.6})
    assert moved.transition.tree == default_tree("normalised", 0.6)
    switch = load_scenario(defaults=moved, overrides={"transition.blend": "switch"})
    assert switch.transition.tree["root"].threshold == 0.3  # z_t / 2, z_t kept
    back = load_scenario(defaults=moved, data={"transition": {"blend": "potential", "z_t": 1}})
    unnamed = scenario_yaml(load_scenario(overrides={"name": "s"}))
    assert back.transition.tree == {} and scenario_yaml(back) == unnamed
    eq12 = load_scenario(_write(tmp_path, "transition: {blend: potential, z_t: 1.0}\n"))
    assert scenario_yaml(eq12) == unnamed
    text = scenario_yaml(linear)
    assert "blend" not in text and "z_t" not in text
    assert load_scenario(data=text).transition.tree == linear.transition.tree
    four = load_scenario("four_behaviors")
    with pytest.raises(
        ScenarioError,
        match=r"^transition\.blend: 'linear' is set beside transition\.tree; a tree gives "
        r"each node's weight and full_at itself",
    ):
        load_scenario(defaults=four, overrides={"transition.blend": "linear"})
    # Saying Eq. (12) beside a tree changes nothing.
    same = load_scenario(defaults=four, overrides={"transition.z_t": 1.0})
    assert same.transition.tree == four.transition.tree
    with pytest.raises(
        ScenarioError, match=r"^transition\.blend: 'cubic' is not one of potential, normalised"
    ):
        load_scenario(overrides={"transition.blend": "cubic"})
