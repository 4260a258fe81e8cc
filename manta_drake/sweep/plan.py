"""From a sweep to its runs: the parameter sets (grid, rows or random sample), the scenario
keys they set, the deterministic run ids, and every run's resolved scenario
(``plan_runs``)."""

from __future__ import annotations

import hashlib
import itertools
import json
import pathlib
import re

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
    payload = json.dumps({"base": base, "overrides": overrides, "seed": seed}, sort_keys=True,
                         separators=(",", ":"), default=str)
    digest = hashlib.sha256(payload.encode()).hexdigest()[:10]
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", pathlib.PurePath(base).stem) or "run"
    return f"{stem}-s{seed}-{digest}"


def parameter_sets(config: SweepConfig) -> list[dict]:
    """The sweep's parameter sets (one dict each) from its grid, rows or random sample."""
    if config.grid:
        names = list(config.grid)
        return [dict(zip(names, combo)) for combo in itertools.product(*config.grid.values())]
    if config.rows:
        return [dict(row) for row in config.rows]
    if config.random is not None:
        r = config.random
        names = list(r.uniform)
        low = np.array([r.uniform[k][0] for k in names], dtype=float)
        high = np.array([r.uniform[k][1] for k in names], dtype=float)
        # One draw of the whole (n, k) table: the sample depends on seed, n and the ranges only.
        values = np.random.default_rng(r.seed).uniform(low, high, size=(r.n, len(names)))
        return [{k: float(v) for k, v in zip(names, row)} for row in values]
    return [{}]


def parameter_names(config: SweepConfig) -> list[str]:
    """The varied parameters in first-appearance order (the table's parameter columns)."""
    names: dict[str, None] = {}
    for params in parameter_sets(config):
        names.update(dict.fromkeys(params))
    return list(names)


def base_scenario_path(config: SweepConfig, base: str) -> pathlib.Path:
    """A base scenario: a file relative to the sweep file, else a path or shipped name."""
    candidate = config.folder / base
    return candidate if candidate.is_file() else find_scenario(base)


def plan_runs(config: SweepConfig, limit: int | None = None) -> list[RunSpec]:
    """Every run of the sweep (or the first ``limit``), in order (base, parameter set, seed),
    each with its resolved scenario or the reason its values are invalid.

    Raises:
        SweepError: a key names no field, or two runs are the same run.
    """
    specs, seen = [], {}
    sets = parameter_sets(config)
    for base in config.base:
        try:
            scenario = load_scenario(base_scenario_path(config, base))
        except ScenarioError as e:
            raise SweepError(f"sweep.base: {base}: {e}") from None
        for params, seed in itertools.product(sets, config.seeds):
            if limit is not None and len(specs) >= limit:
                return specs  # resolving a scenario costs ~50 ms: not for runs left out
            overrides = {**expand_overrides(config.fixed, config.links),
                         **expand_overrides(params, config.links), "random_seed": seed}
            run_id = make_run_id(base, overrides, seed)
            if run_id in seen:
                raise SweepError(f"sweep: run {len(specs)} ({base}, {params}, seed {seed}) is "
                                 f"the same as run {seen[run_id]}; remove the duplicate value")
            seen[run_id] = len(specs)
            text, reason = "", ""
            try:
                resolved = apply_overrides(scenario, overrides)
                resolved.visualization.meshcat = False  # no Meshcat per run: speed, no ports
                text = _dump_scenario(resolved)
            except ScenarioError as e:
                reason = " ".join(str(e).split())
            specs.append(RunSpec(len(specs), run_id, base, seed, params, overrides, text, reason))
    return specs


def _dump_scenario(scenario: Scenario) -> str:
    return scenario_yaml(scenario)
