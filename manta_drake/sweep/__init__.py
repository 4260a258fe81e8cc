"""Many runs on Dask: ``manta-drake sweep SWEEP.yaml --out DIR``.

A sweep file names one or more base scenarios, the parameters to vary and the random seeds;
every (base, parameter set, seed) is one run, a task on a Dask cluster (a
``distributed.LocalCluster`` of ``--workers`` processes with one thread each, or a running
cluster at ``--scheduler ADDRESS``). docs/sweeps.md has the full format; in short::

    name: findings
    base: [locomotion_swim, locomotion_walk]      # a name, a path, or a list (one more axis)
    seeds: [0, 1]                                 # scenario.random_seed of every run
    fixed: {duration: 20.0}                       # set on every run
    links:                                        # one parameter that sets several keys
      hull_damping: [water.coefficient_scales.body.linear_damping,
                     water.coefficient_scales.body.quadratic_damping]
    grid:                                         # full factorial; or `rows:` or `random:`
      contact.friction: [0.5, 0.65, 0.8]
      hull_damping: [0.7, 1.0, 1.3]
      net_weight_kg: [0.6, 0.85, 1.1]             # derived: see net_weight_scales

A parameter is a dotted scenario key (``contact.friction``,
``water.coefficient_scales.body.linear_damping``, ``initial_pose.xyz``), a name from
``links``, or ``net_weight_kg`` (the robot's deflated net weight, turned into a scale of the
hull's sealed volume). Instead of ``grid``: ``rows`` (a list of explicit parameter sets) or
``random`` (``{n, seed, uniform: {parameter: [low, high]}}``, drawn with
``numpy.random.default_rng(seed)``).

Outputs in ``--out DIR``: ``results.csv`` (one row per run: its parameters, status, reason and
flattened metrics), ``summary.png``, and ``runs/<run_id>/`` with ``scenario.yaml`` (the
resolved scenario: ``manta-drake run`` it to reproduce the run), ``log.npz`` and
``metrics.json`` (written last: a run is done when it holds a ``status``; a restarted sweep
skips done runs). Run ids hash the base, the resolved overrides and the seed, so they are
the same on every machine and every restart.

Where things can go wrong: an unknown key anywhere in the sweep file, or a parameter that
names no scenario field, fails at load time (before any run) with one line naming the
path. A bad *value* (``contact.friction: -1``), a simulation failure or any other exception
makes that run a row with ``status`` (``invalid``, ``failed``, ``error``) and ``reason``; the
sweep goes on.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses as dc
import functools
import hashlib
import itertools
import json
import math
import os
import pathlib
import re
import sys
import tempfile
import time
from typing import Any

import numpy as np

from manta_drake.cluster import (  # noqa: F401  (the cluster helper's names, as before)
    ClusterError,
    add_cluster_arguments,
    check_cluster_arguments,
    check_workers,
    cluster_client,
    dask_client,
    default_workers,
)
from manta_drake.config_io import ScenarioError, check_keys, load_yaml_mapping, schema_fields
from manta_drake.model import resolve_path
from manta_drake.model.coefficients import load_coefficients, scale_coefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT
from manta_drake.scenario import (
    Scenario,
    check_override_key,
    find_scenario,
    load_scenario,
    parse_set,
    scenario_yaml,
)
from manta_drake.station.water import build_elements


class SweepError(ScenarioError):
    """The sweep (or calibration) file is invalid; the message names the field."""


# --- configuration ---------------------------------------------------------------------------

@dc.dataclass
class RandomSample:
    """``n`` parameter sets drawn uniformly from ``uniform`` ranges with ``default_rng(seed)``."""

    n: int = 0
    seed: int = 0
    uniform: dict[str, list[float]] = dc.field(default_factory=dict)  # parameter: [low, high]


@dc.dataclass
class SweepConfig:
    """A sweep file (see the module docstring and docs/sweeps.md)."""

    name: str = ""
    description: str = ""
    base: list[str] = dc.field(default_factory=list)  # scenario names or paths
    seeds: list[int] = dc.field(default_factory=lambda: [0])
    fixed: dict[str, Any] = dc.field(default_factory=dict)
    links: dict[str, list[str]] = dc.field(default_factory=dict)
    grid: dict[str, list[Any]] = dc.field(default_factory=dict)
    rows: list[dict[str, Any]] = dc.field(default_factory=list)
    random: RandomSample | None = None
    # Not in the file: where it is (base paths are relative to it).
    folder: pathlib.Path = dc.field(default=pathlib.Path("."), repr=False)


# Parameters computed from a value instead of set directly.
DERIVED = ("net_weight_kg",)


@dc.dataclass(frozen=True)
class RunSpec:
    """One run of a sweep.

    Attributes:
        index: position in the sweep (the table's order).
        run_id: deterministic id (``run_id``), also the folder name under ``runs/``.
        base: the base scenario as written in the sweep file.
        seed: the run's ``random_seed``.
        parameters: the run's parameter values, by the sweep's names (table columns).
        overrides: the dotted scenario keys and values they set (links expanded; with
            ``fixed``); what the run id hashes.
        scenario_yaml: the resolved scenario, or "" if the values are invalid.
        invalid_reason: why the values are invalid ("" if they are not).
    """

    index: int
    run_id: str
    base: str
    seed: int
    parameters: dict
    overrides: dict
    scenario_yaml: str = ""
    invalid_reason: str = ""


# --- net weight ------------------------------------------------------------------------------

def hull_scale_for_net_weight(net_weight_kg: float, total_mass_kg: float, water_density: float,
                              hull_volume_m3: float, other_volume_m3: float) -> float:
    """Linear scale of the hull's sealed ellipsoid that gives a deflated net weight.

    The deflated robot's net weight is its mass minus the water displaced by its sealed
    volumes (hull, servo cases, fin plates) with the balloon empty:
    ``W = M - rho (V_hull + V_other)``. Scaling the hull's semi-axes by ``s`` scales its
    volume by ``s^3``, so ``s = cbrt(((M - W) / rho - V_other) / V_hull)``.

    Args:
        net_weight_kg: wanted net weight W [kg] (negative: the robot floats).
        total_mass_kg: robot mass M [kg].
        water_density: rho [kg/m^3].
        hull_volume_m3: the hull's current sealed volume [m^3].
        other_volume_m3: every other sealed volume [m^3].

    Raises:
        ValueError: W is not finite, or so large that the hull would need no volume.
    """
    if not math.isfinite(net_weight_kg):
        raise ValueError(f"net_weight_kg: {net_weight_kg!r} must be a finite number")
    target = (total_mass_kg - net_weight_kg) / water_density - other_volume_m3
    if target <= 0.0:
        raise ValueError(f"net_weight_kg: {net_weight_kg} kg leaves the hull no sealed volume "
                         f"(the robot weighs {total_mass_kg} kg; at most "
                         f"{total_mass_kg - water_density * other_volume_m3:.3f} kg)")
    return (target / hull_volume_m3) ** (1.0 / 3.0)


def deflated_net_weight_kg(coeffs, params=None) -> float:
    """The robot's net weight [kg] with the balloon empty, from the volume elements the water
    model really uses (``station.water.build_elements``)."""
    params = params or DEFAULT_ROBOT
    volume = build_elements(coeffs, params)["volume"].sum()
    return float(params.total_mass - coeffs.water_density.value * volume)


def net_weight_scales(net_weight_kg: float, coeffs, params=None) -> dict[str, float]:
    """Coefficient scales that give the deflated robot ``net_weight_kg``.

    The water model takes the hull's buoyancy from ``body.sealed_semi_axes`` (the ellipsoid
    also sets the waterline); ``body.sealed_volume`` is its documented volume. Both are
    scaled (by s and s^3) so the coefficients file stays consistent.
    """
    params = params or DEFAULT_ROBOT
    volumes = build_elements(coeffs, params)["volume"]
    s = hull_scale_for_net_weight(net_weight_kg, params.total_mass, coeffs.water_density.value,
                                  float(volumes[0]), float(volumes[1:].sum()))
    return {"body.sealed_semi_axes": s, "body.sealed_volume": s**3}


def _cached_coefficients(path: pathlib.Path):
    """load_coefficients, parsed once per file version (a sweep resolves hundreds of runs;
    the YAML parser takes ~40 ms a file). Callers get a copy from scale_coefficients."""
    path = pathlib.Path(path)
    stat = path.stat() if path.is_file() else None
    return _load_coefficients_once(str(path), stat.st_mtime_ns if stat else 0)


@functools.lru_cache(maxsize=8)
def _load_coefficients_once(path: str, mtime_ns: int):
    return load_coefficients(path)


def apply_net_weight(scenario: Scenario, net_weight_kg) -> None:
    """Adds the hull scales for ``net_weight_kg`` to the scenario's coefficient scales
    (after its other scales, e.g. of the servo volume). Raises ScenarioError."""
    if isinstance(net_weight_kg, bool) or not isinstance(net_weight_kg, (int, float)):
        raise ScenarioError(f"net_weight_kg: expected a number, got {net_weight_kg!r}")
    if not scenario.water.enabled:
        raise ScenarioError("net_weight_kg: needs water.enabled: true")
    scales = dict(scenario.water.coefficient_scales)
    for key in ("body.sealed_semi_axes", "body.sealed_volume"):
        if key in scales:
            raise ScenarioError(f"net_weight_kg: sets the scale of {key}, which is also set")
    try:
        coeffs = scale_coefficients(_cached_coefficients(resolve_path(scenario.water.coefficients)),
                                    scales)
        scales.update(net_weight_scales(float(net_weight_kg), coeffs))
    except ValueError as e:
        raise ScenarioError(str(e)) from None
    scenario.water.coefficient_scales = scales


# --- expanding a sweep into runs -------------------------------------------------------------

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


def _base_path(config: SweepConfig, base: str) -> pathlib.Path:
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
            scenario = load_scenario(_base_path(config, base))
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


def _load_scenario_text(text: str) -> Scenario:
    return load_scenario(data=text)


# --- loading a sweep file --------------------------------------------------------------------

def check_config_keys(data: dict, schema, root: str) -> None:
    """Checks a sweep or calibration file's keys and types against its dataclass; the
    ``folder`` field is set by the loader, never by the file. SweepError names the path."""
    allowed = sorted(f.name for f in dc.fields(schema) if f.name != "folder")
    for key in data:
        if key not in allowed:
            raise SweepError(f"{root}.{key}: unknown key (a typo?); allowed keys: "
                             f"{', '.join(allowed)}")
    try:
        check_keys(data, schema, root)
    except ScenarioError as e:
        raise SweepError(str(e)) from None


def read_yaml_mapping(path, what: str) -> dict:
    """A YAML file's top-level mapping, read strictly (a duplicated key is refused);
    SweepError naming the file otherwise."""
    return load_yaml_mapping(path, what, SweepError)[0]


def check_parameter_name(name: str, links: dict, where: str) -> None:
    """Raises SweepError (naming ``where``) unless ``name`` is a link, derived or a key."""
    if name in links or name in DERIVED:
        return
    try:
        check_override_key(name)
    except ScenarioError as e:
        raise SweepError(f"{where}: {e} (nor is it a link or one of {', '.join(DERIVED)})") \
            from None


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
            _base_path(config, base)
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


# --- one run (on a worker or in this process) ------------------------------------------------

def simulate_run(scenario_yaml: str) -> dict:
    """Simulates one resolved scenario and returns what the client writes.

    Runs in a temporary folder on the worker, so workers need no shared file system with the
    client; every exception is caught and reported.

    Returns:
        ``{"metrics": dict (with status and reason), "log_npz": bytes or None}``. Status
        ``ok``; ``failed`` (SimulationError: the partial log and failure time are kept);
        ``error`` (any other exception, e.g. while building the diagram).
    """
    from manta_drake.simulate import SimulationError, run

    with tempfile.TemporaryDirectory(prefix="manta_run_") as tmp:
        out = pathlib.Path(tmp) / "run"  # run() stages its files beside it: inside tmp too
        metrics: dict = {}
        try:
            scenario = _load_scenario_text(scenario_yaml)
            scenario.visualization.meshcat = False
            metrics = run(scenario, out, progress=False, write_outputs=False).metrics
            metrics["reason"] = ""
        except SimulationError as e:
            metrics = json.loads((out / "metrics.json").read_text()) \
                if (out / "metrics.json").is_file() else {"status": "failed"}
            metrics["reason"] = failure_reason(metrics.get("failure")) or " ".join(str(e).split())
        except Exception as e:  # any failure is a row, never a lost sweep
            metrics = {"status": "error",
                       "reason": f"{type(e).__name__}: {' '.join(str(e).split())}"}
        log = (out / "log.npz").read_bytes() if (out / "log.npz").is_file() else None
    metrics.setdefault("status", "error")
    return {"metrics": metrics, "log_npz": log}


def failure_reason(failure: dict | None) -> str:
    """One line from simulate's failure record (not from the exception's text, which names
    the worker's temporary folder)."""
    if not failure:
        return ""
    reason = " ".join(str(failure.get("reason", "")).split())
    if failure.get("stage") == "build":
        return f"building the diagram failed: {reason}"
    return f"simulation failed at t = {failure.get('time_s', math.nan):.3f} s: {reason}"


# --- writing results -------------------------------------------------------------------------

def _atomic_write(path: pathlib.Path, data: bytes) -> None:
    """Writes via a temporary file and a rename, so a file is whole or absent (restarts)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def write_run(run_dir: pathlib.Path, spec: RunSpec, outcome: dict) -> dict:
    """Writes a run's folder (``scenario.yaml``, ``log.npz``, then ``metrics.json``) and
    returns its metrics record."""
    run_dir.mkdir(parents=True, exist_ok=True)
    if spec.scenario_yaml:
        (run_dir / "scenario.yaml").write_text(spec.scenario_yaml)
    if outcome.get("log_npz"):
        _atomic_write(run_dir / "log.npz", outcome["log_npz"])
    record = dict(outcome["metrics"])
    record["run"] = {"run_id": spec.run_id, "base": spec.base, "seed": spec.seed,
                     "parameters": spec.parameters, "overrides": spec.overrides}
    _atomic_write(run_dir / "metrics.json", (json.dumps(record, indent=2) + "\n").encode())
    return record


def read_done(run_dir: pathlib.Path) -> dict | None:
    """A run's metrics record if the run is done (metrics.json with a status), else None."""
    try:
        record = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) and record.get("status") else None


def format_transitions(transitions) -> str:
    """Behaviour transitions as one compact cell: ``swim>trot@8.10-16.20;trot>turning@...``."""
    return ";".join(f"{t['from']}>{t['to']}@{t['start_s']:.2f}-{t['end_s']:.2f}"
                    for t in transitions or [])


NAMED_VECTORS = {
    "mean_velocity_body": ("u", "v"),
    "final_body_xyz": ("final_x", "final_y", "final_z"),
    "final_body_rpy_deg": ("final_roll_deg", "final_pitch_deg", "final_yaw_deg"),
    "steady_window_s": ("steady_start_s", "steady_end_s"),
}
METRIC_COLUMNS = (
    "u", "v", "yaw_rate_deg_s", "distance_m", "transitions", "sim_time_s", "wall_time_s",
    "real_time_factor", "max_penetration_m", "max_joint_step_rad", "final_max_joint_error_rad",
    "final_x", "final_y", "final_z", "final_roll_deg", "final_pitch_deg", "final_yaw_deg",
    "failure_time_s", "steady_start_s", "steady_end_s",
)


def flatten_metrics(metrics: dict) -> dict:
    """A run's metrics as scalar table cells.

    Named vectors become named columns (``mean_velocity_body`` -> ``u``, ``v``), other lists
    ``<name>_<i>``, transitions one compact string, the failure its time; ``scenario``,
    ``status``, ``reason`` and ``run`` are left out (the table has them elsewhere).
    """
    out = {}
    for key, value in metrics.items():
        if key in ("scenario", "status", "reason", "run"):
            continue
        if key == "transitions":
            out["transitions"] = format_transitions(value)
        elif key == "failure":
            out["failure_time_s"] = value.get("time_s") if isinstance(value, dict) else None
        elif key in NAMED_VECTORS and value is None:  # e.g. no mean velocity: empty cells
            out.update(dict.fromkeys(NAMED_VECTORS[key]))
        elif isinstance(value, (list, tuple)):
            names = NAMED_VECTORS.get(key) or [f"{key}_{i}" for i in range(len(value))]
            out.update(zip(names, value))
        elif isinstance(value, dict):
            out.update({f"{key}.{k}": v for k, v in value.items()})
        else:
            out[key] = value
    return out


def table_rows(specs: list[RunSpec], records: dict) -> tuple[list[str], list[dict]]:
    """The table's columns and rows (runs with a record, in sweep order)."""
    params: dict[str, None] = {}
    for spec in specs:
        params.update(dict.fromkeys(spec.parameters))
    rows, extra = [], {}
    for spec in specs:
        record = records.get(spec.run_id)
        if record is None:
            continue
        row = {"run_id": spec.run_id, "base": spec.base, "seed": spec.seed, **spec.parameters,
               "status": record.get("status", ""), "reason": record.get("reason", "")}
        flat = flatten_metrics(record)
        row.update(flat)
        extra.update(dict.fromkeys(k for k in flat if k not in METRIC_COLUMNS))
        rows.append(row)
    present = {k for row in rows for k in row}
    metric_cols = [c for c in METRIC_COLUMNS if c in present] + sorted(extra)
    return ["run_id", "base", "seed", *params, "status", "reason", *metric_cols], rows


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)  # shortest exact form: tables compare equal across machines
    if isinstance(value, (list, dict)):
        return json.dumps(value)
    return str(value)


def write_table(path: pathlib.Path, columns: list[str], rows: list[dict]) -> None:
    """Writes the results CSV (atomically)."""
    import io

    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in columns])
    _atomic_write(path, buffer.getvalue().encode())


def read_table(path) -> list[dict]:
    """The results CSV as a list of dicts of strings."""
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_summary_figure(path: pathlib.Path, rows: list[dict], parameters: list[str],
                         title: str) -> pathlib.Path:
    """summary.png: per base scenario the spread (uncertainty band) of u, v and yaw rate,
    and each metric against each varied parameter (failed runs left out, counted in the
    title)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    metrics = [("u", "u [m/s]"), ("v", "v [m/s]"), ("yaw_rate_deg_s", "yaw rate [deg/s]")]
    ok = [r for r in rows if r.get("status") == "ok"]
    bases = list(dict.fromkeys(r["base"] for r in rows))
    colours = {b: plt.cm.tab10(i % 10) for i, b in enumerate(bases)}
    xs = parameters or ["seed"]
    fig, axes = plt.subplots(len(metrics), 1 + len(xs), squeeze=False,
                             figsize=(3.2 * (1 + len(xs)), 2.4 * len(metrics) + 0.6))

    def value(row, key):
        try:
            return float(row.get(key))
        except (TypeError, ValueError):
            return math.nan

    for i, (key, label) in enumerate(metrics):
        ax = axes[i, 0]
        data = [[value(r, key) for r in ok if r["base"] == b] for b in bases]
        data = [[v for v in d if math.isfinite(v)] or [math.nan] for d in data]
        ax.boxplot(data, whis=(0, 100))  # whiskers at min and max: the whole band
        ax.set_xticks(range(1, len(bases) + 1), [pathlib.PurePath(b).stem.replace(
            "locomotion_", "") for b in bases], rotation=30, fontsize=8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        for j, param in enumerate(xs, start=1):
            ax = axes[i, j]
            for b in bases:
                pts = [(r.get(param), value(r, key)) for r in ok if r["base"] == b]
                xv = [value({"x": x}, "x") for x, _ in pts]
                if pts and all(math.isfinite(x) for x in xv):
                    ax.plot(xv, [y for _, y in pts], "o", ms=3, alpha=0.7, color=colours[b])
                elif pts:  # not numbers: one position per distinct value
                    cats = sorted({str(x) for x, _ in pts})
                    ax.plot([cats.index(str(x)) for x, _ in pts], [y for _, y in pts], "o",
                            ms=3, alpha=0.7, color=colours[b])
            if i == len(metrics) - 1:
                ax.set_xlabel(param.replace("water.coefficient_scales.", ""), fontsize=8)
            ax.grid(alpha=0.3)
    handles = [plt.Line2D([], [], marker="o", ls="", color=colours[b], label=b) for b in bases]
    fig.legend(handles=handles, loc="upper right", fontsize=7, ncol=min(5, len(bases)))
    n_bad = len(rows) - len(ok)
    fig.suptitle(f"{title}: {len(ok)} runs ok, {n_bad} not ok", x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# --- the sweep -------------------------------------------------------------------------------

@dc.dataclass
class SweepResult:
    """What ``run_sweep`` returns."""

    rows: list[dict]
    columns: list[str]
    table: pathlib.Path
    figure: pathlib.Path | None
    simulated: list[str]  # run ids simulated by this call (not skipped)
    counts: dict  # status -> number of runs


def run_sweep(config: SweepConfig, out_dir, client=None, progress: bool = True,
              limit: int | None = None, rerun_failed: bool = False) -> SweepResult:
    """Runs every run of the sweep not done yet and writes the table and the figure.

    Args:
        config: a loaded sweep.
        out_dir: output folder; runs already done in it are skipped.
        client: a ``distributed.Client``: each run is one task (``Client.submit``),
            collected with ``as_completed``. None: one run after another in this process
            (debugging, and the reference the tests compare the cluster with).
        progress: a tqdm bar counting finished runs.
        limit: only the first ``limit`` runs.
        rerun_failed: run again the runs done with a status other than ``ok``.
    """
    out_dir = pathlib.Path(out_dir)
    runs_dir = out_dir / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    specs = plan_runs(config, limit)
    records: dict[str, dict] = {}
    for spec in specs:
        record = read_done(runs_dir / spec.run_id)
        if record is not None and not (rerun_failed and record["status"] != "ok"):
            records[spec.run_id] = record
    todo = [s for s in specs if s.run_id not in records]
    simulated: list[str] = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(specs), initial=len(specs) - len(todo), unit="run",
                   desc=config.name, file=sys.stderr, dynamic_ncols=True)

    def finish(spec: RunSpec, outcome: dict) -> None:
        records[spec.run_id] = write_run(runs_dir / spec.run_id, spec, outcome)
        columns, rows = table_rows(specs, records)
        write_table(out_dir / "results.csv", columns, rows)  # partial table if interrupted
        if bar is not None:
            bad = sum(r["status"] != "ok" for r in records.values())
            bar.set_postfix_str(f"not ok: {bad}" if bad else "", refresh=False)
            bar.update(1)

    try:
        for spec in [s for s in todo if s.invalid_reason]:  # nothing to simulate
            finish(spec, {"metrics": {"status": "invalid", "reason": spec.invalid_reason}})
        todo = [s for s in todo if not s.invalid_reason]
        if client is None:
            for spec in todo:
                finish(spec, simulate_run(spec.scenario_yaml))
                simulated.append(spec.run_id)
        else:
            from distributed import as_completed

            # Deterministic keys: a resubmitted run is recognised by the scheduler.
            futures = {client.submit(simulate_run, s.scenario_yaml, key=f"manta-run-{s.run_id}",
                                     pure=False): s for s in todo}
            for future in as_completed(futures):
                spec = futures[future]
                try:
                    outcome = future.result()
                except Exception as e:  # e.g. KilledWorker: the worker process died
                    outcome = {"metrics": {"status": "error", "reason":
                                           f"{type(e).__name__}: {' '.join(str(e).split())}"}}
                future.release()
                finish(spec, outcome)
                simulated.append(spec.run_id)
    finally:
        if bar is not None:
            bar.close()
    columns, rows = table_rows(specs, records)
    table = out_dir / "results.csv"
    write_table(table, columns, rows)
    figure = write_summary_figure(out_dir / "summary.png", rows, parameter_names(config),
                                  config.name) if rows else None
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    return SweepResult(rows, columns, table, figure, simulated, counts)


# --- command line ----------------------------------------------------------------------------

def add_sweep_parser(subparsers) -> None:
    """Adds ``manta-drake sweep``."""
    p = subparsers.add_parser(
        "sweep", help="many runs on a Dask cluster: grids, rows, Monte Carlo (docs/sweeps.md)",
        description="Runs every (base scenario, parameter set, seed) of a sweep file as a "
                    "Dask task; writes DIR/results.csv, DIR/summary.png and DIR/runs/<id>/. "
                    "Restarted with the same --out, it skips the runs already done.")
    p.add_argument("sweep", help="sweep YAML file (docs/sweeps.md)")
    p.add_argument("--out", required=True, help="output folder")
    add_cluster_arguments(p)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="add to the file's `fixed` overrides, e.g. --set duration=2 (changes "
                        "the run ids); repeatable")
    p.add_argument("--limit", type=int, metavar="N", help="only the first N runs")
    p.add_argument("--rerun-failed", action="store_true",
                   help="run again the runs whose status is not ok")
    p.add_argument("--dry-run", action="store_true",
                   help="check the file and list the runs; simulate nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def sweep_main(args) -> int:
    """``manta-drake sweep``: load (errors are one line), run, print a summary."""
    config = load_sweep(args.sweep, parse_set(args.set))
    if args.limit is not None and args.limit < 1:
        raise SweepError(f"--limit: {args.limit} must be >= 1")
    check_cluster_arguments(args)
    if args.dry_run:
        specs = plan_runs(config, args.limit)
        for spec in specs:
            state = f"invalid: {spec.invalid_reason}" if spec.invalid_reason else ""
            print(f"{spec.run_id:<40} {json.dumps(spec.parameters)} {state}")
        print(f"\n{len(specs)} runs; {sum(bool(s.invalid_reason) for s in specs)} invalid")
        return 0
    start = time.perf_counter()
    with cluster_client(args) as client:
        result = run_sweep(config, args.out, client, progress=not args.quiet,
                           limit=args.limit, rerun_failed=args.rerun_failed)
    counts = ", ".join(f"{n} {status}" for status, n in sorted(result.counts.items()))
    print(f"\n  {config.name}: {len(result.rows)} runs ({counts}); simulated now "
          f"{len(result.simulated)} in {time.perf_counter() - start:.1f} s")
    print(f"  table:  {result.table}")
    if result.figure:
        print(f"  figure: {result.figure}")
    print(f"  runs:   {pathlib.Path(args.out) / 'runs'}/<run_id>/")
    return 0
