"""An optimisation's records on disk: ``history.csv`` (one row per simulation), each
evaluation's folder, and the evaluations' keys that let a restart reuse what is done.

A key hashes what defines a simulation: the resolved base scenario, the free parameters'
values (12 significant digits), the robustness point and the seed. The same candidate at
the same point in the same folder is the same simulation, whichever generation asks it."""

from __future__ import annotations

import hashlib
import json
import math
import os
import pathlib

from manta_drake.optimize.objective import METRICS
from manta_drake.sweep.results import read_table, write_table

HISTORY = "history.csv"
# Kinds of row: a simulation of the search, the best gait's re-run at the scenario as it
# is, and its re-check at a held-out point.
KINDS = ("search", "best", "held_out")
LEADING = ("key", "kind", "generation", "candidate", "point", "seed")
TRAILING = ("objective", "penalty", "cost", "candidate_cost", "status", "reason",
            "touched_wall", "wall_time_s", "worker", "overrides", "folder")
INTEGER_COLUMNS = ("generation", "candidate", "point", "seed")
TEXT_COLUMNS = ("key", "kind", "status", "reason", "worker", "overrides", "folder")


def evaluation_key(scenario_sha: str, names, degrees, point: dict, seed: int) -> str:
    """The id of one simulation (module docstring): 16 hex digits of a SHA-256."""
    payload = json.dumps({"scenario": scenario_sha, "names": list(names),
                          "x": [f"{float(v):.12g}" for v in degrees],
                          "point": point, "seed": int(seed)},
                         sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def history_columns(names) -> list[str]:
    """The table's columns: the row's place, each free parameter [deg], each metric, the
    cost and its parts, the status."""
    return [*LEADING, *names, *METRICS, *TRAILING]


def _sort_key(row: dict):
    return (KINDS.index(row["kind"]), row["generation"], row["candidate"], row["point"],
            row["seed"])


def write_history(path: pathlib.Path, names, rows) -> None:
    """Writes history.csv (atomically: a kill leaves the old table or the new one)."""
    rows = sorted(rows, key=_sort_key)
    write_table(path, history_columns(names), rows)


def _value(column: str, text: str):
    if text == "":
        return None
    if column in INTEGER_COLUMNS:
        return int(text)
    if column in TEXT_COLUMNS:
        return text
    if column == "touched_wall":
        return text == "True"
    try:
        return float(text)
    except ValueError:
        return text


def read_history(path: pathlib.Path) -> list[dict]:
    """history.csv's rows, typed (numbers as numbers, empty cells None); [] if absent."""
    path = pathlib.Path(path)
    if not path.is_file():
        return []
    return [{k: _value(k, v or "") for k, v in row.items()} for row in read_table(path)]


def evaluation_folder(kind: str, generation: int, candidate: int, point: int,
                      seed: int) -> str:
    """An evaluation's folder, relative to the output folder."""
    if kind == "best":
        return "best_run"
    if kind == "held_out":
        return f"held_out/p{point}-s{seed}"
    return f"evaluations/g{generation:04d}/c{candidate:03d}-p{point}-s{seed}"


def _atomic(path: pathlib.Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def write_evaluation(folder: pathlib.Path, gait_text: str, record: dict,
                     log_npz: bytes | None) -> None:
    """An evaluation's folder: ``gait.yaml`` (the candidate), ``log.npz`` (if kept) and
    ``metrics.json`` (last: the run's metrics, the short metrics, the cost and where it
    was)."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "metrics.json").unlink(missing_ok=True)
    _atomic(folder / "gait.yaml", gait_text.encode())
    if log_npz:
        _atomic(folder / "log.npz", log_npz)
    else:
        (folder / "log.npz").unlink(missing_ok=True)
    _atomic(folder / "metrics.json",
            (json.dumps(record, indent=2, default=_json_default) + "\n").encode())


def _json_default(value):
    if hasattr(value, "item"):
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)


def finite_or_none(value):
    """A float for the table, None for a missing or non-finite value."""
    if value is None or isinstance(value, bool):
        return value
    value = float(value)
    return value if math.isfinite(value) else None
