"""Reading a sweep file: ``load_sweep`` checks its keys, types, names, structure, size and
``fixed`` values before any run (the varied values are checked per run, by
``plan.resolve_run``)."""

from __future__ import annotations

import json
import math
import pathlib

from manta_drake.config_io import ScenarioError, check_integer, schema_fields, short_repr
from manta_drake.scenario import Scenario, check_override_key
from manta_drake.sweep.config import (
    DERIVED,
    MAX_RUNS,
    RandomSample,
    SweepConfig,
    SweepError,
    canonical,
    check_config_keys,
    check_parameter_name,
    read_yaml_mapping,
    typed_parameter,
)
from manta_drake.sweep.plan import (
    apply_overrides,
    base_scenario_path,
    count_parameter_sets,
    count_runs,
    expand_overrides,
    load_base,
    parameter_names,
    parameter_sets,
)


def load_sweep(path, extra_fixed: dict | None = None) -> SweepConfig:
    """Loads and checks a sweep file; no run is simulated and no parameter set is drawn.

    Args:
        path: the sweep YAML file.
        extra_fixed: more ``fixed`` overrides (the command line's ``--set``), added last.

    Raises:
        SweepError: an unknown or duplicated key, a wrong type, a bad range, a parameter
            that names no scenario field, a value given twice, more than ``MAX_RUNS`` runs,
            or a ``fixed`` value (or ``--set``) that no base scenario accepts; the message
            names the path in the file (``sweep.grid.x``) or the option.
    """
    path = pathlib.Path(path)
    data = read_yaml_mapping(path, "sweep")
    if isinstance(data.get("base"), str):
        data["base"] = [data["base"]]
    if isinstance(data.get("random"), dict):  # before the type check: name the range too
        for key, hi in (("n", MAX_RUNS), ("seed", 2**32 - 1)):
            if key in data["random"]:
                check_integer(
                    f"sweep.random.{key}",
                    data["random"][key],
                    1 if key == "n" else 0,
                    hi,
                    error=SweepError,
                )
    check_config_keys(data, SweepConfig, "sweep")
    random = data.pop("random", None)
    config = SweepConfig(**data, folder=path.resolve().parent)
    if random is not None:
        config.random = RandomSample(**random)
    if not config.name:
        config.name = path.stem
    validate_sweep(config)
    extra = dict(extra_fixed or {})
    varied = set(parameter_names(config))
    for name in extra:
        check_parameter_name(name, config.links, f"--set {name}")
        if name in varied:
            raise SweepError(f"--set {name}: the sweep varies it; set it in one place")
    file_fixed = dict(config.fixed)
    if extra:
        config.fixed = {**config.fixed, **extra}
        validate_sweep(config)
    check_fixed_values(config, file_fixed)
    return config


def validate_sweep(config: SweepConfig) -> None:
    """Checks a sweep's structure, names, size and duplicates (nothing is drawn; values are
    checked per run, ``fixed`` by ``check_fixed_values``)."""
    if not config.base:
        raise SweepError("sweep.base: name at least one base scenario")
    if len(set(config.base)) != len(config.base):
        raise SweepError(f"sweep.base: duplicate base scenarios in {short_repr(config.base)}")
    files: dict[pathlib.Path, str] = {}
    for base in config.base:
        try:
            file = base_scenario_path(config, base).resolve()
        except ScenarioError as e:
            raise SweepError(f"sweep.base: {e}") from None
        if file in files:  # two spellings of one file: one run under two ids
            raise SweepError(
                f"sweep.base: {base} and {files[file]} are the same scenario "
                f"file ({file}); name it once"
            )
        files[file] = base
    if not config.seeds:
        raise SweepError("sweep.seeds: name at least one seed")
    for i, seed in enumerate(config.seeds):
        check_integer(f"sweep.seeds[{i}]", seed, 0, 2**32 - 1, error=SweepError)
    if len(set(config.seeds)) != len(config.seeds):
        raise SweepError(f"sweep.seeds: duplicate seeds in {short_repr(config.seeds)}")
    for name, keys in config.links.items():
        if "." in name or name in DERIVED or name in (schema_fields(Scenario) or {}):
            raise SweepError(
                f"sweep.links.{name}: a link's name must not contain '.' nor be "
                "a scenario field or a derived parameter"
            )
        if not keys:
            raise SweepError(f"sweep.links.{name}: name at least one scenario key")
        for i, key in enumerate(keys):
            try:
                check_override_key(key)
            except ScenarioError as e:
                raise SweepError(f"sweep.links.{name}[{i}]: {e}") from None
    modes = [m for m in ("grid", "rows", "random") if getattr(config, m) not in ({}, [], None)]
    if len(modes) > 1:
        raise SweepError(f"sweep: give one of grid, rows or random, not {' and '.join(modes)}")
    for name in config.fixed:
        check_parameter_name(name, config.links, f"sweep.fixed.{name}")
    for name, values in config.grid.items():
        check_parameter_name(name, config.links, f"sweep.grid.{name}")
        if not values:
            raise SweepError(f"sweep.grid.{name}: give at least one value")
    if config.random is not None:
        r = config.random
        check_integer("sweep.random.n", r.n, 1, MAX_RUNS, error=SweepError)
        check_integer("sweep.random.seed", r.seed, 0, 2**32 - 1, error=SweepError)
    _check_size(config)
    for name, values in config.grid.items():
        _check_distinct_values(name, values, config.links)
    for i, row in enumerate(config.rows):
        for name in row:
            check_parameter_name(name, config.links, f"sweep.rows[{i}].{name}")
    _check_distinct_rows(config)
    if config.random is not None:
        r = config.random
        if not r.uniform:
            raise SweepError("sweep.random.uniform: give at least one parameter: [low, high]")
        for name, bounds in r.uniform.items():
            check_parameter_name(name, config.links, f"sweep.random.uniform.{name}")
            if (
                len(bounds) != 2
                or not all(math.isfinite(b) for b in bounds)
                or bounds[0] > bounds[1]
            ):
                raise SweepError(
                    f"sweep.random.uniform.{name}: expected [low, high] with "
                    f"low <= high, got {short_repr(bounds)}"
                )
    varied = set(parameter_names(config))
    for name in config.fixed:
        if name in varied:
            raise SweepError(f"sweep.fixed.{name}: also varied; set it in one place")
    fixed_keys = list(expand_overrides(dict.fromkeys(config.fixed), config.links))
    # Grid and random sets all have the same names: one set is enough to check.
    sets = config.rows if config.rows else parameter_sets(config, 1)
    for i, params in enumerate(sets):
        keys = [k for name in params for k in config.links.get(name, [name])]
        if "random_seed" in keys + fixed_keys:
            raise SweepError("sweep: random_seed is set by sweep.seeds, not as a parameter")
        clash = {k for k in keys if keys.count(k) > 1} | (set(keys) & set(fixed_keys))
        if clash:
            where = f"sweep.rows[{i}]" if config.rows else "sweep"
            raise SweepError(f"{where}: {', '.join(sorted(clash))} is set by two parameters")


def _check_size(config: SweepConfig) -> None:
    """At most ``MAX_RUNS`` runs, counted from the lengths (a grid of 10^8 combinations is
    refused in microseconds, not expanded)."""
    n = count_runs(config)
    if n > MAX_RUNS:
        bases, sets, seeds = len(config.base), count_parameter_sets(config), len(config.seeds)
        raise SweepError(
            f"sweep: {n} runs ({bases} base{'s' * (bases != 1)} x {sets} parameter "
            f"set{'s' * (sets != 1)} x {seeds} seed{'s' * (seeds != 1)}) is above the "
            f"maximum of {MAX_RUNS} runs; split the sweep into smaller ones"
        )


def _check_distinct_values(name: str, values: list, links: dict) -> None:
    """A grid's values, compared as the scenario holds them (``1`` and ``1.0`` of a float
    field are one value: two run ids for one run otherwise)."""
    seen: dict[str, object] = {}
    for value in values:
        key = canonical(typed_parameter(name, value, links))
        if key in seen:
            same = (
                "the same value"
                if json.dumps(seen[key]) == json.dumps(value)
                else "the same value once typed as the scenario field"
            )
            raise SweepError(
                f"sweep.grid.{name}: duplicate values in {short_repr(values)}: "
                f"{short_repr(seen[key])} and {short_repr(value)} are {same}; give "
                "each value once"
            )
        seen[key] = value


def _check_distinct_rows(config: SweepConfig) -> None:
    """Two rows with the same values (as the scenario holds them) would be one run twice."""
    seen: dict[str, int] = {}
    for i, row in enumerate(config.rows):
        key = canonical({k: typed_parameter(k, v, config.links) for k, v in row.items()})
        if key in seen:
            raise SweepError(
                f"sweep.rows[{i}]: the same values as sweep.rows[{seen[key]}] "
                "(compared as the scenario holds them); give each row once"
            )
        seen[key] = i


def check_fixed_values(config: SweepConfig, file_fixed: dict | None = None) -> None:
    """Sets ``fixed`` on every base scenario once, at load time: a value no run can take
    (``fixed: {contact.friction: -1}``) is refused here, not found in every run.

    Args:
        config: the sweep, its ``fixed`` holding the file's and the command line's values.
        file_fixed: the file's own ``fixed`` (checked first, so that the message says which
            of the file and ``--set`` holds the bad value); None: all from the file.

    Raises:
        SweepError: ``sweep.fixed: on base B: <the field, value and allowed range>`` (or
            ``--set: ...``).
    """
    file_fixed = config.fixed if file_fixed is None else file_fixed
    layers = [("sweep.fixed", file_fixed)]
    if config.fixed != file_fixed:
        layers.append(("--set", config.fixed))
    for base in config.base:
        scenario = load_base(config, base)
        for where, fixed in layers:
            try:
                apply_overrides(scenario, expand_overrides(fixed, config.links))
            except ScenarioError as e:
                raise SweepError(f"{where}: on base {base}: {' '.join(str(e).split())}") from None
