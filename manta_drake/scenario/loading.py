"""Loading a scenario: finding its file, layering files, data and dotted overrides onto
defaults with Drake's ``yaml_load_typed`` (every key checked against the schema first), the
``--set KEY=VALUE`` syntax, and writing a scenario back as YAML (``scenario_yaml``)."""

import copy
import dataclasses as dc
import functools
import pathlib
import types
import typing

import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from pydrake.systems.analysis import SimulatorConfig

from manta_drake.config_io import (
    ScenarioError,
    check_keys,
    load_yaml_mapping,
    parse_yaml,
    schema_fields,
    short_text,
)
from manta_drake.model import MODELS_DIR, PACKAGE_URL
from manta_drake.model.coefficients import HydroCoefficients
from manta_drake.scenario.checks import Scenario
from manta_drake.scenario.legacy import LEGACY_KEYS, translate

SCENARIOS_DIR = MODELS_DIR / "scenarios"


def shipped_scenarios() -> list[pathlib.Path]:
    """The scenario files shipped with the package, sorted by name."""
    return sorted(SCENARIOS_DIR.glob("*.yaml"))


def find_scenario(name_or_path) -> pathlib.Path:
    """A scenario file: an existing path, or the name of a shipped scenario (``stand``)."""
    path = pathlib.Path(name_or_path)
    if path.is_file():
        return path
    shipped = SCENARIOS_DIR / f"{path.stem}.yaml"
    if path.suffix in ("", ".yaml") and len(path.parts) == 1 and shipped.is_file():
        return shipped
    names = ", ".join(p.stem for p in shipped_scenarios())
    raise ScenarioError(f"scenario file not found: {name_or_path} (shipped scenarios: {names})")


# --- dotted keys and layered loading -----------------------------------------------------------

_COEFFICIENT_SCALES = "water.coefficient_scales"


@functools.lru_cache(maxsize=1)
def coefficient_names() -> tuple[str, ...]:
    """Dotted names of every hydrodynamic coefficient (keys of ``water.coefficient_scales``)."""
    return tuple(name for name, _ in HydroCoefficients().entries())


def _walk_key(dotted: str):
    """Resolves a dotted scenario key against the schema.

    Returns:
        (attribute path, field type, dict key or None): e.g. ``contact.friction`` ->
        (["contact", "friction"], float, None) and
        ``water.coefficient_scales.body.linear_damping`` ->
        (["water", "coefficient_scales"], dict[str, float], "body.linear_damping").

    Raises:
        ScenarioError: the key names no scenario field (the message names the first bad part).
    """
    if not dotted or not isinstance(dotted, str):
        raise ScenarioError(f"{dotted!r}: not a dotted scenario key")
    if dotted in LEGACY_KEYS:  # read as the key that replaced it (scenario.legacy)
        legacy_path, legacy_type = LEGACY_KEYS[dotted]
        return list(legacy_path), legacy_type, None
    parts = dotted.split(".")
    schema: type[typing.Any] = Scenario
    path: list[str] = []
    i = 0
    while i < len(parts):
        part = parts[i]
        fields = schema_fields(schema)
        if fields is None or part not in fields:
            where = ".".join(["scenario", *path])
            allowed = f"; allowed: {', '.join(sorted(fields))}" if fields else ""
            raise ScenarioError(f"{dotted}: {where} has no field {part!r}{allowed}")
        path.append(part)
        tp = fields[part]
        if typing.get_origin(tp) is dict and i + 1 < len(parts):
            value_type = typing.get_args(tp)[1]
            if isinstance(value_type, type) and dc.is_dataclass(value_type):
                # A mapping of named sections (transition.tree.NODE.FIELD): the next part
                # is the name, the rest a field of that section.
                path.append(parts[i + 1])
                if i + 2 == len(parts):
                    return path, value_type, None
                schema, i = value_type, i + 2
                continue
            key = ".".join(parts[i + 1 :])
            if ".".join(path) == _COEFFICIENT_SCALES and key not in coefficient_names():
                raise ScenarioError(
                    f"{dotted}: unknown coefficient {key!r}; allowed: "
                    f"{', '.join(coefficient_names())}"
                )
            return path, tp, key
        if typing.get_origin(tp) in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            tp = args[0] if len(args) == 1 else tp
        schema = tp
        i += 1
    return path, schema, None


def check_override_key(dotted: str) -> None:
    """Raises ScenarioError if ``dotted`` is not a settable scenario key (no value needed)."""
    _walk_key(dotted)


def overrides_data(overrides: dict) -> dict:
    """Dotted keys and values (``{"contact.friction": 0.6}``) as the nested mapping a
    scenario file would hold (``{"contact": {"friction": 0.6}}``); a dict-valued field's
    key may itself hold dots (``water.coefficient_scales.body.linear_damping``).

    Raises:
        ScenarioError: a key names no field, or two keys set the same field.
    """
    data: dict = {}
    for dotted, value in overrides.items():
        path, _, dict_key = _walk_key(dotted)
        parts = path + ([dict_key] if dict_key is not None else [])
        node = data
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ScenarioError(
                    f"{dotted}: sets a field inside one that another override sets whole"
                )
        if parts[-1] in node:
            raise ScenarioError(f"{dotted}: set twice (or with a field inside it)")
        node[parts[-1]] = value
    return data


def parse_set(items, option: str = "--set") -> dict:
    """``--set KEY=VALUE`` items as ``{dotted key: value}`` (each value parsed as YAML:
    numbers, lists, null, ...); one-line errors naming the option and the key. A key given
    twice is refused (no value is silently dropped unchecked)."""
    out = {}
    for item in items or []:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key:
            raise ScenarioError(
                f"{option} {short_text(str(item), 60)}: expected KEY=VALUE, e.g. duration=2"
            )
        if key in out:
            raise ScenarioError(f"{option} {short_text(key, 60)}: given twice; give each key once")
        out[key] = parse_yaml(value, f"{option} {short_text(key, 60)}")
    return out


# SimulatorConfig fields a newer Drake removed, with the value that means what the newer
# Drake does anyway: a scenario.yaml written under Drake 1.51 (every field dumped) loads
# under 1.58, and a file that asks for the removed behaviour is told so.
_REMOVED_SIMULATOR_FIELDS = {
    "publish_every_time_step": (
        False,
        "removed from Drake's "
        "SimulatorConfig in Drake 1.58, which this run uses: a run "
        "publishes at its publish periods only",
    )
}


def _without_removed_simulator_fields(data: dict) -> dict:
    simulator = data.get("simulator")
    if not isinstance(simulator, dict):
        return data
    fields = schema_fields(SimulatorConfig) or {}
    kept = dict(simulator)
    for name, (harmless, why) in _REMOVED_SIMULATOR_FIELDS.items():
        if name in kept and name not in fields:
            if kept[name] is not harmless:
                raise ScenarioError(f"simulator.{name}: {kept[name]!r}: {why}")
            del kept[name]
    return {**data, "simulator": kept}


def _layer(base: Scenario, data, where: str) -> Scenario:
    """``data`` (a mapping) layered onto ``base`` with ``yaml_load_typed`` (fields it names
    replace the base's, maps merge, lists are replaced); the deprecated keys are read as
    what replaced them (``scenario.legacy``), and the keys and types are checked first so
    that an error names the full dotted field."""
    if not data:
        return copy.deepcopy(base)
    data = _without_removed_simulator_fields(data)
    data, tree = translate(data, base)
    check_keys(data, Scenario)
    try:
        text = yaml.safe_dump(data, sort_keys=False)
    except yaml.YAMLError as e:
        raise ScenarioError(f"{where}: a value cannot be written as YAML ({e})") from None
    try:
        layered = yaml_load_typed(schema=Scenario, data=text, defaults=base)
    except (RuntimeError, ValueError, TypeError) as e:
        raise ScenarioError(" ".join(str(e).split())) from None
    if tree is not None:  # the tree blend and z_t shape replaces the base's whole
        layered.transition.tree = tree
    return layered


def anchored_gait_files(files: list, base_dir: pathlib.Path) -> list:
    """``files`` (gait files as a layer names them) with each relative path made absolute
    from ``base_dir``; package URLs, absolute paths and non-strings are kept as they are."""
    return [
        f
        if not isinstance(f, str)
        or not f
        or f.startswith(PACKAGE_URL)
        or pathlib.Path(f).is_absolute()
        else str((base_dir / f).resolve())
        for f in files
    ]


def _anchor_gait_files(scenario: Scenario, data: dict, base_dir: pathlib.Path) -> None:
    """Makes the gait files a layer named absolute: relative to ``base_dir`` (the scenario
    file's folder, or the working directory), so the scenario means the same files wherever
    it is run or written (scenario.yaml)."""
    controller = data.get("controller") if isinstance(data, dict) else None
    if not isinstance(controller, dict) or "gait_files" not in controller:
        return
    files = scenario.controller.gait_files
    if isinstance(files, list):
        scenario.controller.gait_files = anchored_gait_files(files, base_dir)


def load_scenario(
    name_or_path=None,
    data=None,
    defaults: Scenario | None = None,
    overrides: dict | None = None,
    validate: bool = True,
) -> Scenario:
    """Loads a scenario in layers, as the manipulation course's ``LoadScenario``, and
    validates it.

    Layers, each on the one before with Drake's ``yaml_load_typed``: ``defaults`` (a
    Scenario; the dataclasses' defaults if None), the file ``name_or_path`` (a path or a
    shipped scenario's name), ``data`` (a mapping or YAML text: a scenario fragment) and
    ``overrides`` (dotted keys, ``{"contact.friction": 0.6}``, as ``--set`` and sweeps give
    them). Every key is checked against the schema before it is applied.

    Raises:
        ScenarioError: the file is missing, has an unknown or duplicate key, a value of the
            wrong type, or a value out of range: one line naming the file and the field.
    """
    scenario = copy.deepcopy(defaults) if defaults is not None else Scenario()
    path = None
    prefix = ""
    if name_or_path is not None:
        path = find_scenario(name_or_path)
        prefix = f"{path}: "
        file_data, _ = load_yaml_mapping(path, "scenario")
        try:
            scenario = _layer(scenario, file_data, str(path))
        except ScenarioError as e:
            raise ScenarioError(f"{prefix}{e}") from None
        _anchor_gait_files(scenario, file_data, path.parent)
        if scenario.name == "unnamed":
            scenario.name = path.stem
    if data is not None:
        if isinstance(data, str):
            data = parse_yaml(data, "scenario data")
        if not isinstance(data, dict):
            raise ScenarioError(
                f"scenario data: expected a mapping of scenario fields, got {type(data).__name__}"
            )
        scenario = _layer(scenario, data, "scenario data")
        _anchor_gait_files(scenario, data, pathlib.Path.cwd())
    if overrides:
        nested = overrides_data(overrides)
        scenario = _layer(scenario, nested, "overrides")
        _anchor_gait_files(scenario, nested, pathlib.Path.cwd())
    if not validate:
        return scenario
    try:
        return scenario.validate()
    except ScenarioError as e:
        raise ScenarioError(f"{prefix}{e}") from None


def with_overrides(scenario: Scenario, overrides: dict) -> Scenario:
    """A validated copy of ``scenario`` with dotted ``overrides`` layered on it."""
    return load_scenario(defaults=scenario, overrides=overrides)


def set_override(scenario: Scenario, dotted: str, value) -> None:
    """Sets one dotted key on ``scenario`` in place (through the same layering as
    ``load_scenario``; the value's range is checked by ``validate``)."""
    layered = load_scenario(defaults=scenario, overrides={dotted: value}, validate=False)
    for f in dc.fields(Scenario):
        setattr(scenario, f.name, getattr(layered, f.name))


def scenario_yaml(scenario: Scenario) -> str:
    """The scenario as YAML text (every field): ``load_scenario(data=...)`` reads it back."""
    return yaml_dump_typed(scenario)
