"""From a sweep to its runs: the parameter sets (grid, rows or random sample), counted
without drawing them and drawn only as far as they are needed, the scenario keys they set,
the deterministic run ids (``run_specs``), and each run's resolved scenario
(``resolve_run``; ``plan_runs`` does both)."""

from __future__ import annotations

import dataclasses as dc
import functools
import hashlib
import itertools
import json
import math
import pathlib
import re
from collections.abc import Iterator

import numpy as np

from manta_drake.config_io import ScenarioError
from manta_drake.scenario import Scenario, find_scenario, load_scenario, scenario_yaml
from manta_drake.sweep.config import DERIVED, RunSpec, SweepConfig, SweepError
from manta_drake.sweep.net_weight import apply_net_weight


def expand_overrides(parameters: dict, links: dict) -> dict:
    """The dotted scenario keys a parameter set sets: links expanded, derived kept."""
    out = {}
    for name, value in parameters.items():
        for key in links.get(name, [name]):
            out[key] = value
    return out


def apply_overrides(scenario: Scenario, overrides: dict) -> Scenario:
    """Sets ``overrides`` (dotted keys and derived parameters) on a copy of ``scenario`` and
    validates it. Derived parameters go last (they depend on the other settings).

    Raises:
        SweepError: a key names no field.
        ScenarioError: a value is invalid (the message names the field).
    """
    plain = {k: v for k, v in overrides.items() if k not in DERIVED}
    scenario = load_scenario(defaults=scenario, overrides=plain, validate=False)
    if "net_weight_kg" in overrides:
        apply_net_weight(scenario, overrides["net_weight_kg"])
    return scenario.validate()


def make_run_id(base: str, overrides: dict, seed: int) -> str:
    """A run id from what defines the run: ``<base>-s<seed>-<10 hex digits>``.

    The digest is SHA-256 of the canonical JSON of (base, overrides, seed), so it does not
    depend on the order of keys, the machine, or the Python process.
    """
    payload = json.dumps(
        {"base": base, "overrides": overrides, "seed": seed},
        sort_keys=True,
        separators=(",", ":"),
        default=str,
    )
    digest = hashlib.sha256(payload.encode()).hexdigest()[:10]
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", pathlib.PurePath(base).stem) or "run"
    return f"{stem}-s{seed}-{digest}"


def count_parameter_sets(config: SweepConfig) -> int:
    """How many parameter sets the sweep has, without making them: the product of the
    grid's lengths, the number of rows, the sample's ``n``, or 1 (each base once)."""
    if config.grid:
        return math.prod(len(values) for values in config.grid.values())
    if config.rows:
        return len(config.rows)
    if config.random is not None:
        return config.random.n
    return 1


def count_runs(config: SweepConfig) -> int:
    """How many runs the sweep has: bases x parameter sets x seeds (nothing is drawn)."""
    return len(config.base) * count_parameter_sets(config) * len(config.seeds)


def iter_parameter_sets(config: SweepConfig, limit: int | None = None) -> Iterator[dict]:
    """The sweep's parameter sets (one dict each), or the first ``limit``, made one at a
    time: a grid walks ``itertools.product`` (last parameter fastest) and stops after
    ``limit``; a random sample draws only ``limit`` rows.

    The random sample is ``numpy.random.default_rng(seed).uniform(low, high, size=(n, k))``.
    The generator fills that table row by row, so a draw of ``(limit, k)`` from the same
    seed is exactly its first ``limit`` rows: the sets of a ``--limit`` are those of the
    whole sweep.
    """
    if config.grid:
        names = list(config.grid)
        combos = itertools.islice(itertools.product(*config.grid.values()), limit)
        return (dict(zip(names, combo)) for combo in combos)
    if config.rows:
        return (dict(row) for row in config.rows[:limit])
    if config.random is not None:
        r = config.random
        names = list(r.uniform)
        low = np.array([r.uniform[k][0] for k in names], dtype=float)
        high = np.array([r.uniform[k][1] for k in names], dtype=float)
        n = r.n if limit is None else min(r.n, limit)
        values = np.random.default_rng(r.seed).uniform(low, high, size=(n, len(names)))
        return ({k: float(v) for k, v in zip(names, row)} for row in values)
    return iter([{}][:limit])


def parameter_sets(config: SweepConfig, limit: int | None = None) -> list[dict]:
    """The sweep's parameter sets (or the first ``limit``) as a list (``iter_parameter_sets``)."""
    return list(iter_parameter_sets(config, limit))


def parameter_names(config: SweepConfig) -> list[str]:
    """The varied parameters in first-appearance order (the table's parameter columns); read
    from the file, not from the drawn sets."""
    if config.grid:
        return list(config.grid)
    if config.random is not None:
        return list(config.random.uniform)
    names: dict[str, None] = {}
    for row in config.rows:
        names.update(dict.fromkeys(row))
    return list(names)


def base_scenario_path(config: SweepConfig, base: str) -> pathlib.Path:
    """A base scenario: a file relative to the sweep file, else a path or shipped name."""
    candidate = config.folder / base
    return candidate if candidate.is_file() else find_scenario(base)


def load_base(config: SweepConfig, base: str) -> Scenario:
    """A base scenario, loaded once per file version (the load and every run's resolution
    start from it; ``apply_overrides`` changes copies only).

    Raises:
        SweepError: the base is missing or invalid, naming it.
    """
    try:
        path = base_scenario_path(config, base).resolve()
        return _load_base_once(str(path), path.stat().st_mtime_ns)
    except ScenarioError as e:
        raise SweepError(f"sweep.base: {base}: {e}") from None


@functools.lru_cache(maxsize=32)
def _load_base_once(path: str, mtime_ns: int) -> Scenario:
    return load_scenario(path)


def run_specs(config: SweepConfig, limit: int | None = None) -> list[RunSpec]:
    """Every run of the sweep (or the first ``limit``), in order (base, parameter set, seed),
    with its id, parameters and overrides; not resolved (``resolve_run``), so this costs
    microseconds a run. A ``limit`` draws only the parameter sets its runs use.

    Raises:
        SweepError: two runs are the same run.
    """
    n_sets = count_parameter_sets(config)
    if limit is not None:
        n_sets = min(n_sets, -(-limit // len(config.seeds)))  # the first base's share
    sets = parameter_sets(config, n_sets)
    fixed = expand_overrides(config.fixed, config.links)
    runs = (
        (base, params, seed)
        for base in config.base
        for params, seed in itertools.product(sets, config.seeds)
    )
    specs: list[RunSpec] = []
    seen: dict[str, int] = {}
    for base, params, seed in itertools.islice(runs, limit):
        overrides = {**fixed, **expand_overrides(params, config.links), "random_seed": seed}
        run_id = make_run_id(base, overrides, seed)
        if run_id in seen:
            raise SweepError(
                f"sweep: run {len(specs)} ({base}, {params}, seed {seed}) is "
                f"the same as run {seen[run_id]}; remove the duplicate value"
            )
        seen[run_id] = len(specs)
        specs.append(RunSpec(len(specs), run_id, base, seed, params, overrides))
    return specs


def resolve_run(spec: RunSpec, scenario: Scenario) -> RunSpec:
    """``spec`` with its resolved scenario (overrides set on its base ``scenario`` and
    validated), or with the reason its values are invalid."""
    try:
        resolved = apply_overrides(scenario, spec.overrides)
    except ScenarioError as e:
        return dc.replace(spec, scenario_yaml="", invalid_reason=" ".join(str(e).split()))
    resolved.visualization.meshcat = False  # no Meshcat per run: speed, no ports
    return dc.replace(spec, scenario_yaml=_dump_scenario(resolved), invalid_reason="")


def plan_runs(config: SweepConfig, limit: int | None = None) -> list[RunSpec]:
    """Every run of the sweep (or the first ``limit``), in order (base, parameter set, seed),
    each with its resolved scenario or the reason its values are invalid. Resolving costs
    ~50 ms a run: only the runs listed are resolved.

    Raises:
        SweepError: a base is invalid, or two runs are the same run.
    """
    return [resolve_run(spec, load_base(config, spec.base)) for spec in run_specs(config, limit)]


def _dump_scenario(scenario: Scenario) -> str:
    return scenario_yaml(scenario)
