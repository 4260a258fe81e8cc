"""Measured trajectories: the CSV files (``t, x, y, z, yaw``; ``#`` lines are comments) a
calibration fits, read strictly (``load_measured``) and written (``write_measured``), and
measured ROS 2 bags (``load_measured_bag``: a pose or a depth topic, and joint states)."""

from __future__ import annotations

import array
import csv
import math
import pathlib

import numpy as np

from manta_drake.config_io import (
    MAX_MEASURED_CSV_BYTES,
    MB,
    check_file_size,
    short_repr,
    short_text,
)
from manta_drake.sweep.config import SweepError

TRAJECTORY_COLUMNS = ("x", "y", "z", "yaw")
# What an experiment's ``topics`` may name in a measured bag, and the columns each gives.
BAG_TOPICS = {"pose": TRAJECTORY_COLUMNS, "depth": ("z",), "joint_states": ()}


def load_measured(
    path, columns=TRAJECTORY_COLUMNS, where: str = "measured", duration: float | None = None
) -> dict:
    """A measured trajectory CSV as arrays ``t`` and the named columns.

    The file is at most ``config_io.MAX_MEASURED_CSV_BYTES`` (checked before reading) and
    is read row by row into arrays: the memory is the arrays' (8 bytes a value), not the
    text's.

    Args:
        path: the CSV file (UTF-8 text; ``#`` lines are comments).
        columns: the columns besides ``t`` that must be there.
        where: the field that names the file, for the messages.
        duration: the experiment's run duration [s]: the samples must lie within it (the
            simulation cannot be compared where it does not reach); None: not checked.

    Raises:
        SweepError: one line naming ``where`` and the file: missing, too large, not a text
            file, a missing or repeated column, a row of the wrong length, non-numeric or
            non-finite values, times that are negative, do not increase or go beyond
            ``duration``.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise SweepError(f"{where}: file not found: {path}")
    try:
        check_file_size(path, MAX_MEASURED_CSV_BYTES, "measured CSV", SweepError)
        with open(path, encoding="utf-8", newline="") as f:
            out = _read_columns(f, path, ("t", *columns))
    except SweepError as e:
        raise SweepError(f"{where}: {e}") from None
    except UnicodeDecodeError:
        raise SweepError(f"{where}: {path}: not a UTF-8 text (CSV) file") from None
    except OSError as e:
        raise SweepError(f"{where}: {path}: cannot be read: {e.strerror}") from None
    check_times(out["t"], path, where, duration)
    return out


def check_times(t, path, where: str, duration: float | None) -> None:
    """Measured times [s]: at least two, increasing, from t >= 0 and within ``duration``
    (None: not checked); SweepError naming ``where`` and ``path`` otherwise."""
    if len(t) < 2:
        raise SweepError(
            f"{where}: {path}: t must increase, with at least two samples (got {len(t)})"
        )
    if np.any(np.diff(t) <= 0):
        bad = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise SweepError(
            f"{where}: {path}: t must increase, with at least two samples "
            f"(data row {bad + 1}: {float(t[bad])!r} s after "
            f"{float(t[bad - 1])!r} s)"
        )
    if t[0] < 0:
        raise SweepError(
            f"{where}: {path}: t starts at {float(t[0])!r} s; times are seconds "
            "from the start of the run (allowed: t >= 0)"
        )
    if duration is not None and t[-1] > duration + 1e-9:
        raise SweepError(
            f"{where}: {path}: t ends at {float(t[-1])!r} s, after the run's end "
            f"(duration {duration!r} s; allowed: 0 <= t <= {duration!r}); "
            "shorten the data or set the experiment's overrides: {duration: ...}"
        )


def load_measured_bag(
    path,
    topics: dict,
    columns=TRAJECTORY_COLUMNS,
    where: str = "measured",
    duration: float | None = None,
    scenario=None,
) -> dict:
    """A measured trajectory from a ROS 2 bag, as ``load_measured`` gives a CSV's: ``t`` and
    the named columns, from the ``pose`` topic (x, y, z [m] and the heading yaw [rad] of its
    quaternion) or the ``depth`` topic (z = -depth - the pressure sensor's height in the
    hull, the hull taken level; a FluidPressure's depth with the scenario's water density
    and gravity); with ``joint_states``, ``joint_t`` and ``joint_positions`` (N, 16) too, in
    the plant's joint order, checked but not fitted.

    Args:
        path: the bag: a rosbag2 folder or an ``.mcap`` file (``ros2.reading``).
        topics: ``BAG_TOPICS`` key -> topic name.
        columns: the columns that must be there.
        where: the field that names the bag, for the messages.
        duration: as ``load_measured``'s.
        scenario: the experiment's Scenario (a depth topic needs it).

    Raises:
        SweepError: one line naming ``where`` and the bag: unreadable, a topic missing or
            of another type, non-finite values, times as ``check_times`` refuses.
    """
    from manta_drake.ros2.reading import BagReadError, read_topics

    try:
        read = read_topics(path, {topics[k]: _topic_types(k) for k in BAG_TOPICS if k in topics})
        out = _bag_columns(read, topics, scenario)
    except BagReadError as e:
        raise SweepError(f"{where}: {e}") from None
    for key in ("t", *columns, "joint_positions"):
        if key in out and not np.all(np.isfinite(out[key])):
            bad = int(
                np.flatnonzero(~np.isfinite(out[key]).reshape(len(out[key]), -1).all(axis=1))[0]
            )
            raise SweepError(
                f"{where}: {path}: {key} is not finite at message {bad + 1} "
                "(a dropped reading?); the fit needs finite samples"
            )
    check_times(out["t"], path, where, duration)
    if "joint_t" in out:
        check_times(out["joint_t"], path, f"{where} (joint states)", duration)
    return out


def _topic_types(key: str) -> tuple:
    from manta_drake.ros2.reading import DEPTH_TYPES, JOINT_TYPES, POSE_TYPES

    return {"pose": tuple(POSE_TYPES), "depth": DEPTH_TYPES, "joint_states": JOINT_TYPES}[key]


def _bag_columns(read: dict, topics: dict, scenario) -> dict:
    """``t``, the trajectory columns and the joint arrays of a bag's topics."""
    from manta_drake.model.robot_params import JOINT_NAMES
    from manta_drake.ros2.reading import depth_track, joint_track, pose_track

    if "pose" in topics:
        out = pose_track(read[topics["pose"]])
    else:
        hydro = scenario.hydro_coefficients()
        depth = depth_track(read[topics["depth"]], hydro.water_density.value, hydro.gravity.value)
        out = {"t": depth["t"], "z": -depth["depth"] - scenario.pressure_sensor.position[2]}
    if "joint_states" in topics:
        joints = joint_track(read[topics["joint_states"]], JOINT_NAMES)
        out.update(joint_t=joints["t"], joint_positions=joints["position"])
    return out


def _data_lines(f, path: pathlib.Path):
    """The file's lines but blank and ``#`` ones; NUL bytes and a file grown past the limit
    (after its size was checked) are refused."""
    read = 0
    for line in f:
        read += len(line)
        if read > MAX_MEASURED_CSV_BYTES:
            raise SweepError(
                f"{path}: the file grew past the {MAX_MEASURED_CSV_BYTES / MB:g} MB "
                "limit for measured CSV files"
            )
        if "\0" in line:
            raise SweepError(f"{path}: not a text (CSV) file (it holds NUL bytes)")
        if line.strip() and not line.lstrip().startswith("#"):
            yield line


def _read_columns(f, path: pathlib.Path, names: tuple) -> dict:
    """The ``names`` columns of a measured CSV as float arrays, checked row by row."""
    reader = csv.reader(_data_lines(f, path))
    try:
        header = [c.strip() for c in next(reader, [])]
        for col in names:
            if col not in header:
                raise SweepError(
                    f"{path} has no column {short_repr(col)} (header: "
                    f"{short_text(', '.join(header), 80) or 'none'})"
                )
        repeated = sorted({c for c in header if header.count(c) > 1})
        if repeated:
            raise SweepError(
                f"{path}: column {short_repr(repeated[0])} appears twice in the header"
            )
        index = [header.index(col) for col in names]
        values = {col: array.array("d") for col in names}
        for i, row in enumerate(reader, start=1):
            if len(row) != len(header):
                raise SweepError(
                    f"{path}: data row {i} has {len(row)} fields, the header {len(header)}"
                )
            for col, j in zip(names, index):
                try:
                    v = float(row[j])
                except ValueError:
                    raise SweepError(
                        f"{path}: data row {i}: column {col} is missing or not a number"
                    ) from None
                if not math.isfinite(v):
                    raise SweepError(
                        f"{path}: data row {i}: column {col} is {v!r}, not a finite number"
                    )
                values[col].append(v)
    except csv.Error as e:
        raise SweepError(
            f"{path}: line {reader.line_num}: not valid CSV: {short_text(str(e), 80)}"
        ) from None
    return {col: np.frombuffer(a, dtype=float) for col, a in values.items()}


def write_measured(path, data: dict, comment: str = "") -> None:
    """Writes a measured trajectory CSV (t, x, y, z, yaw)."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"# {line}" for line in comment.splitlines()] + ["t,x,y,z,yaw"]
    for row in zip(*(data[c] for c in ("t", *TRAJECTORY_COLUMNS))):
        lines.append(",".join(f"{v:.6f}" for v in row))
    path.write_text("\n".join(lines) + "\n")
