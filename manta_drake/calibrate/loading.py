"""Reading a calibration file: ``load_calibration`` checks its names, ranges, coefficients,
scenarios and measured files before any simulation."""

from __future__ import annotations

import dataclasses as dc
import math
import pathlib

from manta_drake.calibrate.config import (
    MAX_EVALUATIONS,
    TARGET_KEYS,
    CalibrationConfig,
    CalibrationParameter,
    Experiment,
    OptimizerConfig,
    Sigma,
)
from manta_drake.calibrate.measured import (
    BAG_TOPICS,
    TRAJECTORY_COLUMNS,
    load_measured,
    load_measured_bag,
)
from manta_drake.calibrate.scenarios import base_scenario, experiment_scenario
from manta_drake.config_io import check_in_range, check_integer, check_number
from manta_drake.model import resolve_path
from manta_drake.model.coefficients import load_coefficients
from manta_drake.scenario import ScenarioError, coefficient_names
from manta_drake.sweep.config import (
    SweepError,
    check_config_keys,
    check_parameter_name,
    read_yaml_mapping,
)


def load_calibration(path, require_data: bool = True) -> CalibrationConfig:
    """Loads and checks a calibration file and its measured CSVs; simulates nothing.

    Args:
        path: the calibration YAML file.
        require_data: check the measured CSVs (False: they may not exist yet, as when
            ``synthesize_measurements`` is about to make them).

    Raises:
        SweepError: an unknown or duplicated key, a wrong type or range, a coefficient or
            scenario key that does not exist, an override value the scenario refuses, a
            target that is not a finite number, or a measured file that is missing, not a
            text file, malformed or longer than its run; the message names the path in the
            file (``calibration.experiments[0].measured``).
    """
    path = pathlib.Path(path)
    data = read_yaml_mapping(path, "calibration")
    check_config_keys(data, CalibrationConfig, "calibration")
    config = CalibrationConfig(
        name=data.get("name") or path.stem,
        description=data.get("description", ""),
        coefficients=data.get("coefficients", CalibrationConfig.coefficients),
        seed=data.get("seed", 0),
        parameters=[CalibrationParameter(**p) for p in data.get("parameters") or []],
        experiments=[Experiment(**e) for e in data.get("experiments") or []],
        sigma=Sigma(**(data.get("sigma") or {})),
        optimizer=OptimizerConfig(**(data.get("optimizer") or {})),
        folder=path.resolve().parent,
    )
    validate_calibration(config, require_data)
    return config


def measured_columns(
    config: CalibrationConfig, e: Experiment, where: str = "calibration.experiment"
) -> tuple:
    """The columns experiment ``e``'s measurement can give: a CSV's are x, y, z and yaw (its
    header says which it holds); a bag's, those of its ``topics`` (``BAG_TOPICS``), which
    are checked here: a bag names ``pose`` or ``depth`` (not both), a CSV no topics."""
    from manta_drake.ros2.reading import is_bag

    if not is_bag(config.folder / e.measured):
        if e.topics:
            raise SweepError(
                f"{where}.topics: only for a measured ROS 2 bag (a folder or an "
                f".mcap file); {e.measured} is a CSV"
            )
        return TRAJECTORY_COLUMNS
    for key, topic in e.topics.items():
        if key not in BAG_TOPICS:
            raise SweepError(f"{where}.topics.{key}: not one of {', '.join(BAG_TOPICS)}")
        if not (isinstance(topic, str) and topic.startswith("/")):
            raise SweepError(f"{where}.topics.{key}: {topic!r} is not a topic name (/a/b)")
    if ("pose" in e.topics) == ("depth" in e.topics):
        raise SweepError(
            f"{where}.topics: name the bag's pose or depth topic (one of them), "
            f"e.g. {{pose: /manta/pose}}; got {sorted(e.topics) or 'none'}"
        )
    return BAG_TOPICS["pose" if "pose" in e.topics else "depth"]


def experiment_measured(
    config: CalibrationConfig, e: Experiment, scenario=None, where: str = "measured"
) -> dict:
    """Experiment ``e``'s measurement (its ``columns``): a CSV by ``load_measured``, a bag by
    ``load_measured_bag``, checked against its run's duration. ``scenario``: the
    experiment's (None: made here)."""
    from manta_drake.ros2.reading import is_bag

    scenario = scenario or experiment_scenario(config, e, {})
    path = config.folder / e.measured
    if is_bag(path):
        return load_measured_bag(path, e.topics, e.columns, where, scenario.duration, scenario)
    return load_measured(path, e.columns, where, duration=scenario.duration)


def _positive(where: str, value) -> None:
    check_in_range(where, value, 0.0, math.inf, "(0, inf)", open_low=True, error=SweepError)


def validate_calibration(config: CalibrationConfig, require_data: bool = True) -> None:
    """Checks names, ranges and files of a calibration (values of overrides per scenario)."""
    try:
        load_coefficients(resolve_path(config.coefficients_path()))
    except ScenarioError as err:
        raise SweepError(f"calibration.coefficients: {err}") from None
    check_integer("calibration.seed", config.seed, 0, 2**32 - 1, error=SweepError)
    if not config.parameters:
        raise SweepError("calibration.parameters: name at least one parameter")
    seen_params: set[str] = set()
    seen_coeffs: dict[str, str] = {}
    for i, p in enumerate(config.parameters):
        where = f"calibration.parameters[{i}]"
        if not p.name or p.name in seen_params:
            raise SweepError(f"{where}.name: {p.name!r} is empty or used twice")
        seen_params.add(p.name)
        if not p.coefficients:
            raise SweepError(f"{where}.coefficients: name at least one coefficient")
        for c in p.coefficients:
            if c not in coefficient_names():
                raise SweepError(
                    f"{where}.coefficients: unknown coefficient {c!r}; allowed: "
                    f"{', '.join(coefficient_names())}"
                )
            if c in seen_coeffs:
                raise SweepError(f"{where}.coefficients: {c} is also fitted by {seen_coeffs[c]}")
            seen_coeffs[c] = p.name
        if (
            len(p.bounds) != 2
            or not 0 <= p.bounds[0] < p.bounds[1]
            or not math.isfinite(p.bounds[1])
        ):
            raise SweepError(
                f"{where}.bounds: expected [low, high] with 0 <= low < high, got {p.bounds}"
            )
        if not p.bounds[0] < p.initial < p.bounds[1]:
            raise SweepError(
                f"{where}.initial: {p.initial} must be strictly inside the bounds {p.bounds}"
            )
    if not config.experiments:
        raise SweepError("calibration.experiments: name at least one experiment")
    names = set()
    for i, e in enumerate(config.experiments):
        where = f"calibration.experiments[{i}]"
        if not e.name or e.name in names:
            raise SweepError(f"{where}.name: {e.name!r} is empty or used twice")
        names.add(e.name)
        try:
            base_scenario(config.folder, e.scenario)
        except ScenarioError as err:
            raise SweepError(f"{where}.scenario: {err}") from None
        for key in e.overrides:
            check_parameter_name(key, {}, f"{where}.overrides.{key}")
            if key in ("random_seed", "water.coefficients"):
                raise SweepError(
                    f"{where}.overrides.{key}: set by the calibration file (seed, coefficients)"
                )
        try:  # the values too, once: every simulation of the fit starts from this scenario
            scenario = experiment_scenario(config, e, {})
        except ScenarioError as err:
            raise SweepError(f"{where}.overrides: {' '.join(str(err).split())}") from None
        if not e.measured and not e.target:
            raise SweepError(f"{where}: give `measured` (a CSV) or `target` (mean velocities)")
        if e.measured:
            allowed = measured_columns(config, e, where)
            bad = [c for c in e.columns if c not in allowed]
            if bad or not e.columns or len(set(e.columns)) != len(e.columns):
                raise SweepError(
                    f"{where}.columns: {e.columns} must be some of {', '.join(allowed)}, each once"
                )
            if require_data:
                experiment_measured(config, e, scenario, f"{where}.measured")
        for key, value in e.target.items():
            if key not in TARGET_KEYS:
                raise SweepError(f"{where}.target.{key}: not one of {', '.join(TARGET_KEYS)}")
            check_number(f"{where}.target.{key}", value, error=SweepError)
        _positive(f"{where}.weight", e.weight)
    for f in dc.fields(Sigma):
        _positive(f"calibration.sigma.{f.name}", getattr(config.sigma, f.name))
    o = config.optimizer
    if o.method not in ("trf", "dogbox"):
        raise SweepError(f"calibration.optimizer.method: {o.method!r} is not one of trf, dogbox")
    check_integer(
        "calibration.optimizer.max_evaluations",
        o.max_evaluations,
        1,
        MAX_EVALUATIONS,
        error=SweepError,
    )
    check_in_range(
        "calibration.optimizer.diff_step",
        o.diff_step,
        0.0,
        0.5,
        "(0, 0.5)",
        open_low=True,
        open_high=True,
        error=SweepError,
    )
    for name in ("xtol", "ftol", "gtol"):
        _positive(f"calibration.optimizer.{name}", getattr(o, name))
