"""Measured ROS 2 bags read with rosbags: a rosbag2 folder (``metadata.yaml`` and its
storage files: MCAP or SQLite, any distribution rosbags reads) or a bare ``.mcap`` file
(indexed here from its summary, as ``ros2 bag reindex`` would). ``read_topics`` gives each
named topic's messages; ``pose_track``, ``depth_track`` and ``joint_track`` turn them into
arrays. Times are seconds from the bag's start: the header stamp where the message has
one, else the time it was logged."""

from __future__ import annotations

import contextlib
import dataclasses as dc
import pathlib
import tempfile

import numpy as np

from manta_drake.ros2 import METADATA_FILE
from manta_drake.ros2.messages import depth_of_pressure, yaw_of_quaternion

# Where each pose type keeps its geometry_msgs/Pose.
POSE_TYPES = {
    "geometry_msgs/msg/PoseStamped": lambda msg: msg.pose,
    "geometry_msgs/msg/PoseWithCovarianceStamped": lambda msg: msg.pose.pose,
    "nav_msgs/msg/Odometry": lambda msg: msg.pose.pose,
}
DEPTH_TYPES = ("sensor_msgs/msg/FluidPressure", "std_msgs/msg/Float64")
JOINT_TYPES = ("sensor_msgs/msg/JointState",)


class BagReadError(ValueError):
    """A measured bag cannot be read as asked; one line naming it."""


@dc.dataclass
class Topic:
    """One topic's messages: its type, and per message the time [s from the bag's start]
    and the decoded message."""

    type: str
    t: np.ndarray
    messages: list


def is_bag(path) -> bool:
    """Whether ``path`` names a bag (a folder or an ``.mcap`` file) rather than a CSV."""
    path = pathlib.Path(path)
    return path.is_dir() or path.suffix == ".mcap"


def read_topics(path, topics: dict[str, tuple]) -> dict[str, Topic]:
    """The messages of each topic of ``topics`` (topic -> the types it may have).

    Raises:
        BagReadError: one line naming the bag: missing, unreadable, a topic not in it or
            of another type, a topic without messages.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.rosbag2 import ReaderError

    path = pathlib.Path(path)
    try:
        with _as_folder(path) as folder, AnyReader([folder]) as reader:
            found = {c.topic: c for c in reader.connections}
            for topic, types in topics.items():
                _check_topic(path, topic, types, found)
            out = {topic: Topic(found[topic].msgtype, np.empty(0), []) for topic in topics}
            times: dict[str, list[float]] = {topic: [] for topic in topics}
            for conn, log_ns, raw in reader.messages([found[t] for t in topics]):
                msg = reader.deserialize(raw, conn.msgtype)
                stamp = _stamp_ns(msg, log_ns)
                times[conn.topic].append((stamp - reader.start_time) / 1e9)
                out[conn.topic].messages.append(msg)
    except (AnyReaderError, ReaderError, OSError) as e:
        raise BagReadError(
            f"{path}: cannot be read as a ROS 2 bag: {' '.join(str(e).split())}"
        ) from None
    for topic, read in out.items():
        if not read.messages:
            raise BagReadError(f"{path}: topic {topic} holds no messages")
        read.t = np.asarray(times[topic], dtype=float)
    return out


def _check_topic(path, topic: str, types: tuple, found: dict) -> None:
    if topic not in found:
        raise BagReadError(
            f"{path}: has no topic {topic} (its topics: {', '.join(sorted(found)) or 'none'})"
        )
    if found[topic].msgtype not in types:
        raise BagReadError(
            f"{path}: topic {topic} is {found[topic].msgtype}; allowed: {', '.join(types)}"
        )


def _stamp_ns(msg, log_ns: int) -> int:
    """The message's header stamp [ns], or ``log_ns`` if it has no header."""
    header = getattr(msg, "header", None)
    if header is None:
        return log_ns
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


@contextlib.contextmanager
def _as_folder(path: pathlib.Path):
    """A rosbag2 folder of ``path``: the folder itself, or for a bare ``.mcap`` a temporary
    one holding a link to it and a ``metadata.yaml`` made from its summary."""
    if path.is_dir():
        if not (path / METADATA_FILE).is_file():
            raise BagReadError(
                f"{path}: a folder without {METADATA_FILE} is no rosbag2 bag "
                "(name its .mcap file instead)"
            )
        yield path
        return
    if not path.is_file():
        raise BagReadError(f"{path}: no such bag (a rosbag2 folder or an .mcap file)")
    with tempfile.TemporaryDirectory(prefix="manta_bag_") as tmp:
        folder = pathlib.Path(tmp)
        (folder / path.name).symlink_to(path.resolve())
        from manta_drake.ros2.bag import write_metadata

        write_metadata(folder / METADATA_FILE, _mcap_metadata(path))
        yield folder


def _mcap_metadata(path: pathlib.Path) -> dict:
    """rosbag2 metadata of a bare MCAP file from its summary section."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    from manta_drake.ros2.bag import rosbag2_metadata

    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
    except (McapError, ValueError, EOFError) as e:
        raise BagReadError(
            f"{path}: not a readable MCAP file: {' '.join(str(e).split())}"
        ) from None
    if summary is None or summary.statistics is None:
        raise BagReadError(
            f"{path}: the MCAP file has no summary (a recording cut short?); "
            "recover it with `mcap recover` or `ros2 bag reindex`"
        )
    stats = summary.statistics
    topics = [
        {
            "name": c.topic,
            "type": summary.schemas[c.schema_id].name,
            "qos": c.metadata.get("offered_qos_profiles", ""),
            "count": stats.channel_message_counts.get(i, 0),
        }
        for i, c in summary.channels.items()
        if c.message_encoding == "cdr"
    ]
    return rosbag2_metadata(path.name, topics, stats.message_start_time, stats.message_end_time)


def pose_track(topic: Topic) -> dict:
    """``t, x, y, z, yaw``: the positions [m] and headings [rad] of a pose topic."""
    poses = [POSE_TYPES[topic.type](msg) for msg in topic.messages]
    out = {"t": topic.t}
    for axis in ("x", "y", "z"):
        out[axis] = np.array([getattr(p.position, axis) for p in poses], dtype=float)
    out["yaw"] = np.array(
        [
            yaw_of_quaternion(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)
            for p in poses
        ]
    )
    return out


def depth_track(topic: Topic, density: float, gravity: float) -> dict:
    """``t, depth`` [m below the surface]: a FluidPressure topic's absolute pressure through
    ``messages.depth_of_pressure``, a Float64 topic's values as they are."""
    if topic.type == "std_msgs/msg/Float64":
        depth = np.array([msg.data for msg in topic.messages], dtype=float)
    else:
        depth = depth_of_pressure([msg.fluid_pressure for msg in topic.messages], density, gravity)
    return {"t": topic.t, "depth": depth}


def joint_track(topic: Topic, names) -> dict:
    """``t, position`` (N, len(names)) [rad] of a JointState topic, in ``names`` order
    (matched by name: a driver may send another order).

    Raises:
        BagReadError: a message whose joints are not ``names`` or without positions.
    """
    rows = []
    for msg in topic.messages:
        index = {name: i for i, name in enumerate(msg.name)}
        if sorted(index) != sorted(names) or len(msg.position) != len(msg.name):
            missing = sorted(set(names) - set(index))
            raise BagReadError(
                f"joint states: a message's joints differ from the robot's "
                f"(missing {missing[:4]}, {len(msg.position)} positions for "
                f"{len(msg.name)} names)"
            )
        rows.append([msg.position[index[name]] for name in names])
    return {"t": topic.t, "position": np.array(rows, dtype=float)}
