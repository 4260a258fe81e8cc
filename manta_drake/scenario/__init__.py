"""Typed scenarios: the dataclasses a scenario YAML file is loaded into.

A scenario says everything one run needs: how long, the plant's time step, the
robot's initial pose, the random seed, the controller, and the simulator
settings. ``load_scenario(name_or_path, data=..., defaults=..., overrides=...)`` loads
it in layers with Drake's ``yaml_load_typed`` after checking every key against the
schema (a misspelt key fails at load time, naming its full path and the allowed keys),
then ``Scenario.validate()`` checks every value's range (naming the field and the
allowed range). ``--set KEY=VALUE``, sweeps and the fault campaign all go through it.

The package's modules:

* ``schema``: the sections of the robot, the controller and the water, each with its
  fields and its own checks (``validate(where)``); ``devices``: the sections of the
  balloon, the sensors, the camera, the actuators, the recording and the simulator;
* ``top``: the top level's own fields and its sections (``ScenarioFields``);
* ``views``: what the fields mean for the rest of the package (``robot_params``,
  ``hydro_coefficients``, ``gaits``, ``behaviour_tree``, ``current_schedule``, ...);
* ``checks``: ``Scenario`` itself, whose ``validate`` runs every section's check and then
  the checks across sections;
* ``loading``: finding, loading and layering scenarios, dotted overrides, ``--set`` and
  ``scenario_yaml``.

The shipped scenarios are in ``models/scenarios/`` (installed as package data of
``manta_drake.models``; ``manta-drake list``); ``find_scenario`` accepts a path or a
shipped scenario's name.

Example (``models/scenarios/stand.yaml``)::

    name: stand
    duration: 5.0
    initial_pose: {xyz: [0, 0, -0.22], rpy_deg: [0, 0, 0]}
    controller: {mode: hold, gait: trot}
"""

from manta_drake.config_io import ScenarioError
from manta_drake.model import resolve_path
from manta_drake.scenario.checks import Scenario
from manta_drake.scenario.devices import (
    MAX_DEPTH_NOISE,
    ActuatorsConfig,
    BalloonCommand,
    BalloonConfig,
    CameraConfig,
    DepthEstimatorConfig,
    PressureSensorConfig,
    VisualizationConfig,
)
from manta_drake.scenario.loading import (
    SCENARIOS_DIR,
    anchored_gait_files,
    check_override_key,
    coefficient_names,
    find_scenario,
    load_scenario,
    overrides_data,
    parse_set,
    scenario_yaml,
    set_override,
    shipped_scenarios,
    with_overrides,
)
from manta_drake.scenario.schema import (
    ContactConfig,
    ControllerConfig,
    CpgConfig,
    InitialPose,
    RobotConfig,
    TransitionConfig,
    WaterConfig,
    resolve_fin_sweep_deg,
)
from manta_drake.scenario.top import MAX_DURATION_S, MAX_RANDOM_SEED, with_modality_sections

__all__ = [
    "Scenario",
    "ScenarioError",
    "load_scenario",
    "find_scenario",
    "shipped_scenarios",
    "resolve_path",
    "set_override",
    "check_override_key",
    "scenario_yaml",
    "with_overrides",
    "parse_set",
    "overrides_data",
    "anchored_gait_files",
    "coefficient_names",
    "SCENARIOS_DIR",
    "MAX_DURATION_S",
    "MAX_RANDOM_SEED",
    "MAX_DEPTH_NOISE",
    "resolve_fin_sweep_deg",
    "with_modality_sections",
    "InitialPose",
    "ControllerConfig",
    "RobotConfig",
    "CpgConfig",
    "TransitionConfig",
    "WaterConfig",
    "ContactConfig",
    "BalloonCommand",
    "BalloonConfig",
    "PressureSensorConfig",
    "DepthEstimatorConfig",
    "CameraConfig",
    "ActuatorsConfig",
    "VisualizationConfig",
]
