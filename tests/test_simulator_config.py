"""The scenario's simulator section under both Drakes pyproject.toml installs: Drake 1.51
(Python 3.11) binds SimulatorConfig.publish_every_time_step, Drake 1.58 (Python 3.12, 3.13)
has no such field. Each expectation that differs says which Drake it holds for."""

import importlib.metadata

import pytest
import yaml
from pydrake.systems.analysis import SimulatorConfig

from manta_drake.scenario import (
    Scenario,
    ScenarioError,
    load_scenario,
    scenario_yaml,
    set_override,
)

FIELD = "publish_every_time_step"
DRAKE = tuple(int(part) for part in importlib.metadata.version("drake").split(".")[:2])
# The Drake releases pyproject.toml pins, and whether each binds the field.
BINDS_FIELD = {(1, 51): True, (1, 58): False}


def test_the_installed_drake_is_a_pinned_one_and_binds_the_field_as_expected():
    assert DRAKE in BINDS_FIELD, f"drake {DRAKE} is not one of the pinned {sorted(BINDS_FIELD)}"
    bound = {f.name for f in SimulatorConfig.__fields__}
    assert (FIELD in bound) == BINDS_FIELD[DRAKE], sorted(bound)


def test_the_default_simulator_section_is_the_same_under_both_drakes():
    """RK2 at the plant's 1 ms step, no error control, as fast as possible; where the field
    exists it is False, the value the package always used."""
    sim = Scenario().simulator
    assert (
        sim.integration_scheme,
        sim.max_step_size,
        sim.use_error_control,
        sim.target_realtime_rate,
        sim.start_time,
    ) == ("runge_kutta2", 1e-3, False, 0.0, 0.0)
    dumped = yaml.safe_load(scenario_yaml(Scenario()))["simulator"]
    if BINDS_FIELD[DRAKE]:  # Drake 1.51
        assert sim.publish_every_time_step is False and dumped[FIELD] is False
    else:  # Drake 1.58
        assert not hasattr(sim, FIELD) and FIELD not in dumped
    # A run's scenario.yaml (every field) loads back under the Drake that wrote it.
    assert load_scenario(data=scenario_yaml(Scenario())).simulator.max_step_size == 1e-3


def test_a_scenario_file_setting_the_field(tmp_path):
    """Drake 1.51: a field like the others. Drake 1.58: true is refused in one line naming
    it and saying why (false, what 1.58 does anyway, is dropped: see the next test)."""
    path = tmp_path / "s.yaml"
    path.write_text(f"simulator: {{{FIELD}: true}}\n")
    if BINDS_FIELD[DRAKE]:  # Drake 1.51
        assert load_scenario(path).simulator.publish_every_time_step is True
        s = load_scenario("stand")
        set_override(s, f"simulator.{FIELD}", True)
        assert s.validate().simulator.publish_every_time_step is True
    else:  # Drake 1.58
        with pytest.raises(ScenarioError) as refused:
            load_scenario(path)
        message = str(refused.value)
        assert "\n" not in message
        assert message.startswith(
            f"{path}: simulator.{FIELD}: True: removed from Drake's SimulatorConfig in Drake 1.58"
        ), message
        with pytest.raises(
            ScenarioError,
            match=rf"^simulator\.{FIELD}: scenario\.simulator "
            rf"has no field '{FIELD}'",
        ):
            load_scenario("stand", overrides={f"simulator.{FIELD}": False})


def test_a_scenario_written_under_either_drake_loads_under_this_one():
    """scenario.yaml dumps every SimulatorConfig field; Drake 1.51's has
    publish_every_time_step: false. Under a Drake without the field that value (what the
    newer Drake does anyway) is dropped, and true is refused naming the field."""
    from manta_drake.config_io import ScenarioError
    from manta_drake.scenario import load_scenario

    has_field = hasattr(SimulatorConfig(), "publish_every_time_step")
    s = load_scenario("stand", data={"simulator": {"publish_every_time_step": False}})
    assert getattr(s.simulator, "publish_every_time_step", False) is False
    if has_field:
        on = load_scenario("stand", data={"simulator": {"publish_every_time_step": True}})
        assert on.simulator.publish_every_time_step is True
    else:
        with pytest.raises(
            ScenarioError,
            match=r"simulator\.publish_every_time_step: True: "
            r"removed from Drake's SimulatorConfig",
        ):
            load_scenario("stand", data={"simulator": {"publish_every_time_step": True}})
