"""Measured trajectories: the CSV files (``t, x, y, z, yaw``; ``#`` lines are comments) a
calibration fits, read strictly (``load_measured``) and written (``write_measured``)."""

from __future__ import annotations

import csv
import pathlib

import numpy as np

from manta_drake.sweep.config import SweepError

TRAJECTORY_COLUMNS = ("x", "y", "z", "yaw")


def load_measured(path, columns=TRAJECTORY_COLUMNS, where: str = "measured") -> dict:
    """A measured trajectory CSV as arrays ``t`` and the named columns.

    Raises:
        SweepError: missing file or column, non-numeric or non-finite values, or times that
            do not increase.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise SweepError(f"{where}: file not found: {path}")
    with open(path, newline="") as f:
        lines = [line for line in f if line.strip() and not line.lstrip().startswith("#")]
    rows = list(csv.reader(lines))
    header = [c.strip() for c in rows[0]] if rows else []
    for col in ("t", *columns):
        if col not in header:
            raise SweepError(f"{where}: {path} has no column {col!r} (header: "
                             f"{', '.join(header) or 'none'})")
    out = {}
    for col in ("t", *columns):
        j = header.index(col)
        try:
            out[col] = np.array([float(r[j]) for r in rows[1:]], dtype=float)
        except (ValueError, IndexError):
            bad = next(i for i, r in enumerate(rows[1:]) if not _is_number(r, j))
            raise SweepError(f"{where}: {path}: data row {bad + 1}: column {col} is missing "
                             "or not a number") from None
    for col, values in out.items():
        if not np.all(np.isfinite(values)):
            raise SweepError(f"{where}: {path}: column {col} has empty or non-finite values")
    if len(out["t"]) < 2 or np.any(np.diff(out["t"]) <= 0):
        raise SweepError(f"{where}: {path}: t must increase, with at least two samples")
    return out


def _is_number(row, j) -> bool:
    try:
        float(row[j])
        return True
    except (ValueError, IndexError):
        return False


def write_measured(path, data: dict, comment: str = "") -> None:
    """Writes a measured trajectory CSV (t, x, y, z, yaw)."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"# {line}" for line in comment.splitlines()] + ["t,x,y,z,yaw"]
    for row in zip(*(data[c] for c in ("t", *TRAJECTORY_COLUMNS))):
        lines.append(",".join(f"{v:.6f}" for v in row))
    path.write_text("\n".join(lines) + "\n")
