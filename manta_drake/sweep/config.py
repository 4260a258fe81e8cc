"""What a sweep file holds (``SweepConfig``, ``RunSpec``) and the checks every file of the
many-run commands shares: its keys against its dataclass, the strict YAML reader, and the
names a parameter may have. ``SweepError`` is their error (sweep and calibration files)."""

from __future__ import annotations

import dataclasses as dc
import pathlib
from typing import Any

from manta_drake.config_io import ScenarioError, check_keys, load_yaml_mapping
from manta_drake.scenario import check_override_key


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
