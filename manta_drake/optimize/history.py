"""An optimisation's records on disk: ``history.csv`` (one row per simulation), each
evaluation's folder, and the evaluations' keys that let a restart reuse what is done.

A key hashes what defines a simulation: the resolved base scenario, the free parameters'
values (12 significant digits), the robustness point and the seed. The same candidate at
the same point in the same folder is the same simulation, whichever generation asks it.

A restart reads the table back with a bound on its size and checks every row: its columns
those of this spec, its numbers numbers, its kind one of ``KINDS``, its key a key and its
folder the one its place names (the search deletes logs in the folders the table names:
never one outside the output folder); anything else is refused with one line naming the
file, the line and the column."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import pathlib
import re
import stat

from manta_drake.config_io import short_repr
from manta_drake.optimize.objective import METRICS
from manta_drake.optimize.spec import OptimizeError
from manta_drake.sweep.results import write_table

HISTORY = "history.csv"
# Kinds of row: a simulation of the search, the best gait's re-run at the scenario as it
# is, and its re-check at a held-out point.
KINDS = ("search", "best", "held_out")
LEADING = ("key", "kind", "generation", "candidate", "point", "seed")
TRAILING = (
    "objective",
    "penalty",
    "cost",
    "candidate_cost",
    "status",
    "reason",
    "touched_wall",
    "wall_time_s",
    "worker",
    "overrides",
    "folder",
)
INTEGER_COLUMNS = ("generation", "candidate", "point", "seed")
TEXT_COLUMNS = ("key", "kind", "status", "reason", "worker", "overrides", "folder")
# A row's reason is cut to this many characters; a row (but its overrides) takes at most
# MAX_ROW_BYTES; the table at most HISTORY_SLACK_BYTES more than its rows (run.history_limit).
MAX_REASON = 2000
MAX_ROW_BYTES = 16 * 1024
HISTORY_SLACK_BYTES = 1 << 20
_KEY = re.compile(r"[0-9a-f]{16}\Z")


def evaluation_key(scenario_sha: str, names, degrees, point: dict, seed: int) -> str:
    """The id of one simulation (module docstring): 16 hex digits of a SHA-256."""
    payload = json.dumps(
        {
            "scenario": scenario_sha,
            "names": list(names),
            "x": [f"{float(v):.12g}" for v in degrees],
            "point": point,
            "seed": int(seed),
        },
        sort_keys=True,
        separators=(",", ":"),
        default=str,
    )
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def history_columns(names) -> list[str]:
    """The table's columns: the row's place, each free parameter [deg], each metric, the
    cost and its parts, the status."""
    return [*LEADING, *names, *METRICS, *TRAILING]


def _sort_key(row: dict):
    return (
        KINDS.index(row["kind"]),
        row["generation"],
        row["candidate"],
        row["point"],
        row["seed"],
    )


def write_history(path: pathlib.Path, names, rows) -> None:
    """Writes history.csv (atomically: a kill leaves the old table or the new one)."""
    rows = sorted(rows, key=_sort_key)
    write_table(path, history_columns(names), rows)


def short_reason(text) -> str:
    """A reason as the table holds it: one line of at most ``MAX_REASON`` characters."""
    text = " ".join(str(text or "").split())
    return text if len(text) <= MAX_REASON else text[: MAX_REASON - 3] + "..."


def _value(column: str, text: str):
    """A cell typed; ValueError for a cell that is not of its column's type."""
    if text == "":
        return None
    if column in INTEGER_COLUMNS:
        value = int(text)
        if value < 0:
            raise ValueError("a negative integer")
        return value
    if column in TEXT_COLUMNS:
        return text
    if column == "touched_wall":
        if text not in ("True", "False"):
            raise ValueError("not True or False")
        return text == "True"
    return float(text)


def read_history(path: pathlib.Path, names=None, max_bytes: int | None = None) -> list[dict]:
    """history.csv's rows, typed (numbers as numbers, empty cells None); [] if absent.

    Args:
        path: the table.
        names: the free parameters: every column of ``history_columns(names)`` must be there
            and every row's place valid (module docstring); None: not checked.
        max_bytes: refuse a larger file (None: no bound).

    Raises:
        OptimizeError: the file is not a regular file, larger than ``max_bytes``, not UTF-8
            CSV, or a cell or row is not what this version writes; one line naming it.
    """
    path = pathlib.Path(path)
    text = _read_text(path, max_bytes)
    if text is None:
        return []
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        header = reader.fieldnames or []
        if names is not None:
            missing = [c for c in history_columns(names) if c not in header]
            if missing:
                raise _refused(
                    path, f"no column {short_repr(missing[0])}: not the history of this spec"
                )
        rows = []
        for row in reader:
            line = reader.line_num
            if None in row or None in row.values():
                raise _refused(path, f"line {line}: not one cell per column")
            typed = {}
            for column, cell in row.items():
                try:
                    typed[column] = _value(column, cell)
                except ValueError as e:
                    raise _refused(
                        path,
                        f"line {line}: {column} {short_repr(cell)} is "
                        f"not valid ({short_reason(e)[:60]})",
                    ) from None
            if names is not None:
                _check_place(path, line, typed)
            rows.append(typed)
    except csv.Error as e:
        raise _refused(path, f"not CSV ({short_reason(e)[:80]})") from None
    return rows


def _refused(path, what: str) -> OptimizeError:
    return OptimizeError(
        f"{path}: {what}; not a history this version writes (use another "
        "--out, or delete the file to simulate again)"
    )


def read_bounded(path: pathlib.Path, limit: float, too_large) -> bytes | None:
    """A regular file's bytes (None if absent), at most ``limit`` of them read even if the
    file grows; ``too_large(size)`` is the OptimizeError for a file over the limit. The one
    reader of what a search reads back from its folder (history.csv, state.json)."""
    try:
        info = path.stat()
    except FileNotFoundError:
        return None
    except OSError as e:
        raise OptimizeError(f"{path}: cannot be read: {e.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        raise OptimizeError(f"{path}: not a regular file; use another --out")
    if info.st_size > limit:
        raise too_large(info.st_size)
    try:
        with open(path, "rb") as f:
            raw = f.read() if math.isinf(limit) else f.read(int(limit) + 1)
    except OSError as e:
        raise OptimizeError(f"{path}: cannot be read: {e.strerror}") from None
    if len(raw) > limit:
        raise too_large(len(raw))
    return raw


def _read_text(path: pathlib.Path, max_bytes: int | None) -> str | None:
    """A regular file's UTF-8 text (None if absent), read with at most ``max_bytes``."""
    limit = math.inf if max_bytes is None else max_bytes
    raw = read_bounded(
        path,
        limit,
        lambda size: _refused(
            path,
            f"{size} bytes, more than the {max_bytes} this spec's search writes in its "
            "generations (raise --generations to those it ran)",
        ),
    )
    if raw is None:
        return None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise _refused(path, "not UTF-8 text") from None
    if "\0" in text:
        raise _refused(path, "not text (it holds NUL bytes)")
    return text


def _check_place(path, line: int, row: dict) -> None:
    """A row's kind, key, place and status present, and its folder the one its place
    names."""
    if row["kind"] not in KINDS:
        raise _refused(
            path, f"line {line}: kind {short_repr(row['kind'])} is not one of {', '.join(KINDS)}"
        )
    if row["key"] is None or not _KEY.match(row["key"]):
        raise _refused(path, f"line {line}: key {short_repr(row['key'])} is not 16 hex digits")
    for column in (*INTEGER_COLUMNS, "status", "cost"):
        if row[column] is None:
            raise _refused(path, f"line {line}: no {column}")
    folder = evaluation_folder(
        row["kind"], row["generation"], row["candidate"], row["point"], row["seed"]
    )
    if row["folder"] != folder:
        raise _refused(
            path,
            f"line {line}: folder {short_repr(row['folder'])} is not "
            f"{folder!r}, the folder of its place",
        )


def evaluation_folder(kind: str, generation: int, candidate: int, point: int, seed: int) -> str:
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


def write_evaluation(
    folder: pathlib.Path, gait_text: str, record: dict, log_npz: bytes | None
) -> None:
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
    _atomic(
        folder / "metrics.json",
        (json.dumps(record, indent=2, default=_json_default) + "\n").encode(),
    )


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
