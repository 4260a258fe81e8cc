"""What a sweep file holds (``SweepConfig``, ``RunSpec``) and the checks every file of the
many-run commands shares: its keys against its dataclass, the strict YAML reader, the names
a parameter may have, the values as the scenario types them, and the output folder.
``SweepError`` is their error (sweep and calibration files)."""

from __future__ import annotations

import dataclasses as dc
import json
import pathlib
import types
import typing
from typing import Any

from manta_drake.config_io import (
    ScenarioError,
    check_keys,
    check_writable_folder,
    load_yaml_mapping,
    schema_fields,
)
from manta_drake.scenario import Scenario, check_override_key


class SweepError(ScenarioError):
    """The sweep (or calibration) file is invalid; the message names the field."""


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

# The most runs one sweep may have (base scenarios x parameter sets x seeds). Each run's
# scenario is resolved on this machine (~50 ms) and its row kept in memory (a few kB), so
# 100 000 runs take about an hour and a few hundred MB before the cluster's share; beyond
# that, split the sweep into several files (or --out folders).
MAX_RUNS = 100_000


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


def check_config_keys(
    data: dict, schema, root: str, not_in_file=("folder",), error=SweepError
) -> None:
    """Checks a many-run file's keys and types against its dataclass (a sweep, calibration
    or optimisation spec); the ``not_in_file`` fields are set by the loader, never by the
    file. ``error`` (SweepError) names the path."""
    allowed = sorted(f.name for f in dc.fields(schema) if f.name not in not_in_file)
    for key in data:
        if key not in allowed:
            raise error(f"{root}.{key}: unknown key (a typo?); allowed keys: {', '.join(allowed)}")
    try:
        check_keys(data, schema, root)
    except ScenarioError as e:
        raise error(str(e)) from None


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
        raise SweepError(
            f"{where}: {e} (nor is it a link or one of {', '.join(DERIVED)})"
        ) from None


def _unwrap_optional(tp):
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0]
    return tp


def field_type(dotted: str):
    """The type of the value a dotted scenario key sets (for a dictionary field such as
    ``water.coefficient_scales.body.linear_damping``, the dictionary's value type). The key
    must be valid (``check_override_key``)."""
    schema, parts = Scenario, dotted.split(".")
    for i, part in enumerate(parts):
        tp = (schema_fields(schema) or {})[part]
        if typing.get_origin(tp) is dict and i + 1 < len(parts):
            return typing.get_args(tp)[1]
        schema = _unwrap_optional(tp)
    return schema


def typed_value(value, tp):
    """``value`` as a field of type ``tp`` holds it: an int given for a float is that float
    (YAML reads ``1`` as an int, the scenario holds 1.0), inside lists, dictionaries and
    nested dataclasses too; anything else unchanged (its check comes when the run is
    resolved)."""
    tp = _unwrap_optional(tp)
    origin = typing.get_origin(tp)
    if tp is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if origin is list and isinstance(value, list):
        (item,) = typing.get_args(tp) or (None,)
        return [typed_value(v, item) for v in value]
    if origin is dict and isinstance(value, dict):
        _, item = typing.get_args(tp)
        return {k: typed_value(v, item) for k, v in value.items()}
    fields = schema_fields(tp) if tp is not None else None
    if fields and isinstance(value, dict):
        return {k: typed_value(v, fields[k]) if k in fields else v for k, v in value.items()}
    return value


def typed_parameter(name: str, value, links: dict):
    """A parameter's value as the run's scenario holds it, for comparing runs: a link's
    value typed per key it sets, ``net_weight_kg`` as a float."""
    if name in DERIVED:
        return typed_value(value, float)
    keys = links.get(name, [name])
    typed = [typed_value(value, field_type(k)) for k in keys]
    return typed[0] if len(typed) == 1 else typed


def canonical(value) -> str:
    """A value's canonical JSON (equal values, equal text)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=str)


def check_out_folder(
    out_dir, outputs=(), inputs=(), folders=(), option: str = "--out"
) -> pathlib.Path:
    """Checks, before anything is loaded or simulated, that a many-run command can write its
    outputs into ``out_dir`` (nothing is created here).

    The checks of ``simulate.check_output_folder``: refused are an empty path, a path that is
    a file or under one, a folder that cannot be created or written (permission bits and a
    real write, for read-only mounts), a folder where one of ``outputs`` (file names inside
    it) is a folder or would overwrite one of ``inputs``, or one of ``folders`` (folder names
    inside it) is a file.

    Raises:
        SweepError: one line naming the option, the folder and why.
    """
    out_dir = check_writable_folder(out_dir, option, "out/sweep", SweepError)
    for name in outputs:
        target = out_dir / name
        if target.exists() and not target.is_file():
            raise SweepError(f"{option} {out_dir}: {target} is a folder, not a file")
    for name in folders:
        target = out_dir / name
        if target.exists() and not target.is_dir():
            raise SweepError(f"{option} {out_dir}: {target} is a file, not a folder")
    ours = {(out_dir / name).resolve(): name for name in outputs}
    for path in inputs:
        if path is not None and pathlib.Path(path).resolve() in ours:
            raise SweepError(
                f"{option} {out_dir}: writing {ours[pathlib.Path(path).resolve()]} "
                f"would overwrite the input {path}; choose another output folder"
            )
    return out_dir
