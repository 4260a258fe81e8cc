"""From parameters to scenarios: an experiment's scenario with the prior coefficients, the
calibration's seed and the parameters' coefficient scales, and its text for a worker."""

from __future__ import annotations

import functools
import pathlib

from pydrake.common.yaml import yaml_dump_typed

from manta_drake.calibrate.config import CalibrationConfig, Experiment
from manta_drake.scenario import Scenario, load_scenario
from manta_drake.sweep.plan import apply_overrides


def parameter_scales(config: CalibrationConfig, x) -> dict[str, float]:
    """Coefficient name -> factor for a parameter vector ``x`` (in the order of the file)."""
    return {c: float(v) for p, v in zip(config.parameters, x) for c in p.coefficients}


@functools.lru_cache(maxsize=32)
def base_scenario(folder: pathlib.Path, name: str) -> Scenario:
    """An experiment's scenario as the file names it: a file relative to the calibration
    file, else a path or a shipped name. Loaded once per (folder, name); callers change
    copies (``apply_overrides``)."""
    candidate = folder / name
    return load_scenario(candidate if candidate.is_file() else name)


def experiment_scenario(
    config: CalibrationConfig, experiment: Experiment, scales: dict[str, float]
) -> Scenario:
    """The experiment's scenario with the prior coefficients file, the calibration's seed and
    the coefficient ``scales`` (multiplying any the experiment sets itself)."""
    overrides = {
        **experiment.overrides,
        "water.coefficients": config.coefficients_path(),
        "random_seed": config.seed,
    }
    scenario = apply_overrides(base_scenario(config.folder, experiment.scenario), overrides)
    merged = dict(scenario.water.coefficient_scales)
    for name, factor in scales.items():
        merged[name] = merged.get(name, 1.0) * factor
    scenario.water.coefficient_scales = merged
    scenario.visualization.meshcat = False
    return scenario.validate()


def scenario_text(scenario: Scenario) -> str:
    """The scenario as the YAML text a worker simulates."""
    return yaml_dump_typed(scenario)
