"""Measured trajectories: the CSV files (``t, x, y, z, yaw``; ``#`` lines are comments) a
calibration fits, read strictly (``load_measured``) and written (``write_measured``)."""

from __future__ import annotations

import csv
import pathlib

import numpy as np

from manta_drake.sweep.config import SweepError

TRAJECTORY_COLUMNS = ("x", "y", "z", "yaw")


def load_measured(path, columns=TRAJECTORY_COLUMNS, where: str = "measured",
                  duration: float | None = None) -> dict:
    """A measured trajectory CSV as arrays ``t`` and the named columns.

    Args:
        path: the CSV file (UTF-8 text; ``#`` lines are comments).
        columns: the columns besides ``t`` that must be there.
        where: the field that names the file, for the messages.
        duration: the experiment's run duration [s]: the samples must lie within it (the
            simulation cannot be compared where it does not reach); None: not checked.

    Raises:
        SweepError: one line naming ``where`` and the file: missing, not a text file, a
            missing or repeated column, a row of the wrong length, non-numeric or
            non-finite values, times that are negative, do not increase or go beyond
            ``duration``.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise SweepError(f"{where}: file not found: {path}")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise SweepError(f"{where}: {path}: not a UTF-8 text (CSV) file") from None
    except OSError as e:
        raise SweepError(f"{where}: {path}: cannot be read: {e.strerror}") from None
    if "\0" in text:
        raise SweepError(f"{where}: {path}: not a text (CSV) file (it holds NUL bytes)")
    lines = [line for line in text.splitlines() if line.strip()
             and not line.lstrip().startswith("#")]
    rows = list(csv.reader(lines))
    header = [c.strip() for c in rows[0]] if rows else []
    for col in ("t", *columns):
        if col not in header:
            raise SweepError(f"{where}: {path} has no column {col!r} (header: "
                             f"{', '.join(header) or 'none'})")
    repeated = sorted({c for c in header if header.count(c) > 1})
    if repeated:
        raise SweepError(f"{where}: {path}: column {repeated[0]!r} appears twice in the header")
    for i, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise SweepError(f"{where}: {path}: data row {i + 1} has {len(row)} fields, the "
                             f"header {len(header)}")
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
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise SweepError(f"{where}: {path}: data row {bad + 1}: column {col} is "
                             f"{float(values[bad])!r}, not a finite number")
    t = [float(v) for v in out["t"]]  # plain floats: the messages print them as written
    if len(t) < 2:
        raise SweepError(f"{where}: {path}: t must increase, with at least two samples "
                         f"(got {len(t)})")
    if np.any(np.diff(t) <= 0):
        bad = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise SweepError(f"{where}: {path}: t must increase, with at least two samples "
                         f"(data row {bad + 1}: {t[bad]!r} s after {t[bad - 1]!r} s)")
    if t[0] < 0:
        raise SweepError(f"{where}: {path}: t starts at {t[0]!r} s; times are seconds from "
                         "the start of the run (allowed: t >= 0)")
    if duration is not None and t[-1] > duration + 1e-9:
        raise SweepError(f"{where}: {path}: t ends at {t[-1]!r} s, after the run's end "
                         f"(duration {duration!r} s; allowed: 0 <= t <= {duration!r}); "
                         "shorten the data or set the experiment's overrides: {duration: ...}")
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
