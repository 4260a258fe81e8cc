"""A sweep's results on disk: each run's folder (``scenario.yaml``, ``log.npz``,
``metrics.json`` last, so a run is done when it holds a final status and the files it says
it wrote) and ``results.csv``, one row per run with its metrics flattened into scalar
cells."""

from __future__ import annotations

import csv
import io
import json
import os
import pathlib

from manta_drake.cluster import INFRASTRUCTURE_ERRORS, is_infrastructure_error  # noqa: F401
from manta_drake.config_io import MAX_YAML_BYTES, read_csv_table
from manta_drake.metrics import COT_KEYS, transition_span
from manta_drake.sweep.config import RunSpec, SweepError

# Statuses of a run that is done: a restart skips it (``--rerun-failed`` runs the ones that
# are not ok again). ``lost``, a run the cluster lost (its worker died, the connection
# dropped) after every attempt, is not done: a restart runs it again.
DONE_STATUSES = ("ok", "invalid", "failed", "error")
LOST = "lost"


def _atomic_write(path: pathlib.Path, data: bytes) -> None:
    """Writes via a temporary file and a rename, so a file is whole or absent (restarts)."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def write_run(run_dir: pathlib.Path, spec: RunSpec, outcome: dict) -> dict:
    """Writes a run's folder (``scenario.yaml``, ``log.npz``, then ``metrics.json``) and
    returns its metrics record.

    An earlier attempt's ``metrics.json`` goes first and its other files are replaced or
    removed, so that an interruption part-way leaves a run that is not done rather than
    the old record beside new files. The record's ``run.log_npz`` says whether the run
    wrote a log (a done run whose log is missing is not done).
    """
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "metrics.json").unlink(missing_ok=True)
    if spec.scenario_yaml:
        _atomic_write(run_dir / "scenario.yaml", spec.scenario_yaml.encode())
    else:
        (run_dir / "scenario.yaml").unlink(missing_ok=True)
    if outcome.get("log_npz"):
        _atomic_write(run_dir / "log.npz", outcome["log_npz"])
    else:
        (run_dir / "log.npz").unlink(missing_ok=True)
    record = dict(outcome["metrics"])
    record["run"] = {
        "run_id": spec.run_id,
        "base": spec.base,
        "seed": spec.seed,
        "parameters": spec.parameters,
        "overrides": spec.overrides,
        "log_npz": bool(outcome.get("log_npz")),
    }
    _atomic_write(run_dir / "metrics.json", (json.dumps(record, indent=2) + "\n").encode())
    return record


def read_done(run_dir: pathlib.Path) -> dict | None:
    """A run's metrics record if the run is done, else None.

    Done: ``metrics.json`` holds one of ``DONE_STATUSES`` and the log it says the run wrote
    is there (a record written before ``run.log_npz`` existed: an ``ok`` run has a log).
    Not done: no or a broken ``metrics.json`` (or one larger than ``MAX_YAML_BYTES``: a
    record is a few kB), status ``lost`` (or ``error`` from one of ``INFRASTRUCTURE_ERRORS``:
    the cluster failed, not the run), or a missing log.
    """
    metrics = run_dir / "metrics.json"
    try:
        if metrics.stat().st_size > MAX_YAML_BYTES:  # not a record a run writes
            return None
        record = json.loads(metrics.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(record, dict) or record.get("status") not in DONE_STATUSES:
        return None
    if record["status"] == "error" and is_infrastructure_error(str(record.get("reason", ""))):
        return None
    run = record.get("run")
    if not isinstance(run, dict):
        run = {}
    if run.get("log_npz", record["status"] == "ok") and not (run_dir / "log.npz").is_file():
        return None
    return record


def format_transitions(transitions) -> str:
    """Behaviour transitions as one compact cell: ``swim>trot@8.10-16.20;trot>turning@...``
    (``never`` for an end the parameters did not reach)."""
    return ";".join(f"{t['from']}>{t['to']}@{transition_span(t, 2)}" for t in transitions or [])


NAMED_VECTORS = {
    "mean_velocity_body": ("u", "v"),
    "final_body_xyz": ("final_x", "final_y", "final_z"),
    "final_body_rpy_deg": ("final_roll_deg", "final_pitch_deg", "final_yaw_deg"),
    "steady_window_s": ("steady_start_s", "steady_end_s"),
}
METRIC_COLUMNS = (
    "u",
    "v",
    "yaw_rate_deg_s",
    "distance_m",
    "transitions",
    "sim_time_s",
    "wall_time_s",
    "real_time_factor",
    "max_penetration_m",
    "max_joint_step_rad",
    "final_max_joint_error_rad",
    "final_x",
    "final_y",
    "final_z",
    "final_roll_deg",
    "final_pitch_deg",
    "final_yaw_deg",
    "failure_time_s",
    "steady_start_s",
    "steady_end_s",
    # The run's energy block (metrics.json ``energy``), each key prefixed with ``energy.``.
    *(
        f"energy.{k}"
        for k in (
            "mechanical_energy_j",
            "electrical_energy_j",
            "mean_electrical_power_w",
            *COT_KEYS,
            "battery_soc_end",
            "operation_time_h",
        )
    ),
)


def flatten_metrics(metrics: dict) -> dict:
    """A run's metrics as scalar table cells.

    Named vectors become named columns (``mean_velocity_body`` -> ``u``, ``v``), other lists
    ``<name>_<i>``, transitions one compact string, the failure its time, a block of
    metrics (``energy``) one column per key, ``<block>.<key>``
    (``energy.cot_electrical_dry_weight``); ``scenario``, ``status``, ``reason`` and ``run`` are
    left out (the table has them elsewhere).
    """
    out: dict[str, object] = {}
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
        row = {
            "run_id": spec.run_id,
            "base": spec.base,
            "seed": spec.seed,
            **spec.parameters,
            "status": record.get("status", ""),
            "reason": record.get("reason", ""),
        }
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
    if isinstance(value, float):  # numpy's float64 too, whose own repr names its type
        return repr(float(value))  # shortest exact form: tables compare equal across machines
    if isinstance(value, (list, dict)):
        return json.dumps(value)
    return str(value)


def write_table(path: pathlib.Path, columns: list[str], rows: list[dict]) -> None:
    """Writes the results CSV (atomically)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in columns])
    _atomic_write(path, buffer.getvalue().encode())


def read_table(path) -> list[dict]:
    """The results CSV as a list of dicts of strings.

    Raises:
        SweepError: the file is missing, unreadable, larger than
            ``config_io.MAX_TABLE_CSV_BYTES`` or not UTF-8 CSV text (one line naming it).
    """
    return read_csv_table(path, SweepError, "results CSV")
