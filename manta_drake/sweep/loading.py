"""Reading a sweep file: ``load_sweep`` checks its keys, types, names and structure before
any run (values are checked per run, by ``plan.plan_runs``)."""

from __future__ import annotations

import json
import math
import pathlib

from manta_drake.config_io import ScenarioError, schema_fields
from manta_drake.scenario import Scenario, check_override_key
from manta_drake.sweep.config import (
    DERIVED,
    RandomSample,
    SweepConfig,
    SweepError,
    check_config_keys,
    check_parameter_name,
    read_yaml_mapping,
)
from manta_drake.sweep.plan import (
    base_scenario_path,
    expand_overrides,
    parameter_names,
    parameter_sets,
)


def load_sweep(path, extra_fixed: dict | None = None) -> SweepConfig:
    """Loads and checks a sweep file; no run is simulated.

    Args:
        path: the sweep YAML file.
        extra_fixed: more ``fixed`` overrides (the command line's ``--set``), added last.

    Raises:
        SweepError: an unknown key, a wrong type, a bad range, or a parameter that names no
            scenario field; the message names the path in the file (``sweep.grid.x``).
    """
    path = pathlib.Path(path)
    data = read_yaml_mapping(path, "sweep")
    if isinstance(data.get("base"), str):
        data["base"] = [data["base"]]
    check_config_keys(data, SweepConfig, "sweep")
    random = data.pop("random", None)
    config = SweepConfig(**data, folder=path.resolve().parent)
    if random is not None:
        config.random = RandomSample(**random)
    config.fixed = {**config.fixed, **(extra_fixed or {})}
    if not config.name:
        config.name = path.stem
    validate_sweep(config)
    return config


def validate_sweep(config: SweepConfig) -> None:
    """Checks a sweep's structure and names (values are checked per run)."""
    if not config.base:
        raise SweepError("sweep.base: name at least one base scenario")
    if len(set(config.base)) != len(config.base):
        raise SweepError(f"sweep.base: duplicate base scenarios in {config.base}")
    for base in config.base:
        try:
            base_scenario_path(config, base)
        except ScenarioError as e:
            raise SweepError(f"sweep.base: {e}") from None
    if not config.seeds:
        raise SweepError("sweep.seeds: name at least one seed")
    for i, seed in enumerate(config.seeds):
        if not 0 <= seed < 2**32:
            raise SweepError(f"sweep.seeds[{i}]: {seed} is outside [0, 2^32)")
    if len(set(config.seeds)) != len(config.seeds):
        raise SweepError(f"sweep.seeds: duplicate seeds in {config.seeds}")
    for name, keys in config.links.items():
        if "." in name or name in DERIVED or name in (schema_fields(Scenario) or {}):
            raise SweepError(f"sweep.links.{name}: a link's name must not contain '.' nor be "
                             "a scenario field or a derived parameter")
        if not keys:
            raise SweepError(f"sweep.links.{name}: name at least one scenario key")
        for i, key in enumerate(keys):
            try:
                check_override_key(key)
            except ScenarioError as e:
                raise SweepError(f"sweep.links.{name}[{i}]: {e}") from None
    modes = [m for m in ("grid", "rows", "random")
             if getattr(config, m) not in ({}, [], None)]
    if len(modes) > 1:
        raise SweepError(f"sweep: give one of grid, rows or random, not {' and '.join(modes)}")
    for name in config.fixed:
        check_parameter_name(name, config.links, f"sweep.fixed.{name}")
    for name, values in config.grid.items():
        check_parameter_name(name, config.links, f"sweep.grid.{name}")
        if not values:
            raise SweepError(f"sweep.grid.{name}: give at least one value")
        if len({json.dumps(v, sort_keys=True) for v in values}) != len(values):
            raise SweepError(f"sweep.grid.{name}: duplicate values in {values}")
    for i, row in enumerate(config.rows):
        for name in row:
            check_parameter_name(name, config.links, f"sweep.rows[{i}].{name}")
    if config.random is not None:
        r = config.random
        if r.n < 1:
            raise SweepError(f"sweep.random.n: {r.n} must be >= 1")
        if not 0 <= r.seed < 2**32:
            raise SweepError(f"sweep.random.seed: {r.seed} is outside [0, 2^32)")
        if not r.uniform:
            raise SweepError("sweep.random.uniform: give at least one parameter: [low, high]")
        for name, bounds in r.uniform.items():
            check_parameter_name(name, config.links, f"sweep.random.uniform.{name}")
            if len(bounds) != 2 or not all(math.isfinite(b) for b in bounds) \
                    or bounds[0] > bounds[1]:
                raise SweepError(f"sweep.random.uniform.{name}: expected [low, high] with "
                                 f"low <= high, got {bounds}")
    varied = set(parameter_names(config))
    for name in config.fixed:
        if name in varied:
            raise SweepError(f"sweep.fixed.{name}: also varied; set it in one place")
    fixed_keys = list(expand_overrides(dict.fromkeys(config.fixed), config.links))
    # Grid and random sets all have the same names: one set is enough to check.
    sets = config.rows if config.rows else parameter_sets(config)[:1]
    for i, params in enumerate(sets):
        keys = [k for name in params for k in config.links.get(name, [name])]
        if "random_seed" in keys + fixed_keys:
            raise SweepError("sweep: random_seed is set by sweep.seeds, not as a parameter")
        clash = {k for k in keys if keys.count(k) > 1} | (set(keys) & set(fixed_keys))
        if clash:
            where = f"sweep.rows[{i}]" if config.rows else "sweep"
            raise SweepError(f"{where}: {', '.join(sorted(clash))} is set by two parameters")
