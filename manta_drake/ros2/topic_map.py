"""The topic map: per signal of ``signals.SIGNALS`` a topic, a message type, a QoS profile
and a rate, and the world's and the hull's frame ids. The shipped file
(``models/ros2_topics.yaml``, ``DEFAULT_TOPIC_MAP``) holds every entry; a user's file
changes some of them (each field it gives replaces the shipped one), so topics are renamed
to a robot's driver's without code. Read with the project's strict YAML reader; a bad value
is refused in one line naming the file, the field and what is allowed."""

from __future__ import annotations

import dataclasses as dc
import pathlib
import re
from typing import TypedDict

from manta_drake.config_io import (
    ScenarioError,
    check_keys,
    load_yaml_mapping,
    short_repr,
)
from manta_drake.model import MODELS_DIR
from manta_drake.ros2.signals import SIGNALS

DEFAULT_TOPIC_MAP = MODELS_DIR / "ros2_topics.yaml"

# The QoS profiles a topic may name, as rclcpp's presets (rmw_qos_profile_default and
# rmw_qos_profile_sensor_data) in the integer enums a Humble bag's metadata records:
# history 1 keep last, reliability 1 reliable / 2 best effort, durability 2 volatile,
# liveliness 1 automatic; durations 0 (unspecified).
_UNSPECIFIED = {"sec": 0, "nsec": 0}


class QosProfile(TypedDict):
    """One QoS profile, as a bag's ``offered_qos_profiles`` records it."""

    history: int
    depth: int
    reliability: int
    durability: int
    deadline: dict[str, int]
    lifespan: dict[str, int]
    liveliness: int
    liveliness_lease_duration: dict[str, int]
    avoid_ros_namespace_conventions: bool


QOS_PROFILES: dict[str, QosProfile] = {
    name: {
        "history": 1,
        "depth": depth,
        "reliability": reliability,
        "durability": 2,
        "deadline": _UNSPECIFIED,
        "lifespan": _UNSPECIFIED,
        "liveliness": 1,
        "liveliness_lease_duration": _UNSPECIFIED,
        "avoid_ros_namespace_conventions": False,
    }
    for name, depth, reliability in (("default", 10, 1), ("sensor_data", 5, 2))
}
MAX_RATE_HZ = 1000.0  # the plant's step at its default 1 ms: no signal changes faster

# A ROS 2 topic name, absolute: tokens of letters, digits and _, none starting with a digit.
_TOPIC = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+")
# A tf2 frame id: the same tokens, no leading slash.
_FRAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")


class TopicMapError(ScenarioError):
    """A topic map is invalid; the message is one line naming the file and the field."""


@dc.dataclass
class TopicEntry:
    """One signal's topic (see ``models/ros2_topics.yaml``)."""

    topic: str = ""
    type: str = ""
    qos: str = ""
    rate_hz: float = 0.0
    enabled: bool = True


@dc.dataclass
class Frames:
    """The frame ids: Drake's world, the hull and the depth camera (its optical frame: z
    forward, x right, y down, as Drake's and ROS's cameras have it)."""

    world: str = "world"
    base: str = "base_link"
    camera: str = "camera_depth_optical_frame"


@dc.dataclass
class TopicMap:
    """A whole topic map: the frames and an entry for every signal."""

    frames: Frames = dc.field(default_factory=Frames)
    topics: dict[str, TopicEntry] = dc.field(default_factory=dict)

    def enabled(self) -> dict[str, TopicEntry]:
        """Signal name -> entry, of the entries written."""
        return {name: e for name, e in self.topics.items() if e.enabled}


def load_topic_map(path=None) -> TopicMap:
    """The shipped topic map, with the fields of ``path`` (a user's file; None: none) laid
    over it, checked.

    Raises:
        TopicMapError: one line naming the file and the field: an unknown key or signal, a
            wrong type, a topic name that is not an absolute ROS 2 name or is used twice,
            a message type the signal cannot be written as, an unknown QoS profile, a
            rate outside (0, 1000] Hz, a bad frame id.
    """
    shipped = _read(DEFAULT_TOPIC_MAP)
    if path is None:
        return _checked(shipped, DEFAULT_TOPIC_MAP)
    return _checked(_laid_over(shipped, _read(pathlib.Path(path))), pathlib.Path(path))


def _read(path: pathlib.Path) -> dict:
    """The file's mapping, its keys checked against ``TopicMap``."""
    data, _ = load_yaml_mapping(path, "topic map", TopicMapError)
    try:
        check_keys(data, TopicMap, "topic_map")
    except ScenarioError as e:
        raise TopicMapError(f"{path}: {e}") from None
    for name in data.get("topics") or {}:
        if name not in SIGNALS:
            raise TopicMapError(
                f"{path}: topic_map.topics.{name}: not a signal; allowed: {', '.join(SIGNALS)}"
            )
    return data


def _laid_over(base: dict, top: dict) -> dict:
    """``top``'s frames and entries field by field over ``base``'s."""
    frames = {**(base.get("frames") or {}), **(top.get("frames") or {})}
    topics = {
        name: {**entry, **((top.get("topics") or {}).get(name) or {})}
        for name, entry in (base.get("topics") or {}).items()
    }
    return {"frames": frames, "topics": topics}


def _checked(data: dict, path: pathlib.Path) -> TopicMap:
    topic_map = TopicMap(
        Frames(**(data.get("frames") or {})),
        {name: TopicEntry(**(entry or {})) for name, entry in (data.get("topics") or {}).items()},
    )
    try:
        check_topic_map(topic_map)
    except TopicMapError as e:
        raise TopicMapError(f"{path}: {e}") from None
    return topic_map


def check_topic_map(topic_map: TopicMap) -> None:
    """Checks every value (``load_topic_map`` says what); TopicMapError naming the field."""
    for field in ("world", "base", "camera"):
        value = getattr(topic_map.frames, field)
        if not isinstance(value, str) or not _FRAME.fullmatch(value):
            raise TopicMapError(
                f"topic_map.frames.{field}: {short_repr(value)} is not a frame "
                "id (letters, digits, _ and /, not starting with / or a digit)"
            )
    frames = dc.asdict(topic_map.frames)
    for i, (a, frame) in enumerate(frames.items()):
        for b in list(frames)[i + 1 :]:
            if frames[b] == frame:
                raise TopicMapError(
                    f"topic_map.frames: {a} and {b} are both {frame!r}; they must differ"
                )
    missing = [name for name in SIGNALS if name not in topic_map.topics]
    if missing:
        raise TopicMapError(f"topic_map.topics: no entry for {', '.join(missing)}")
    seen: dict[str, str] = {}  # topic -> signal
    for name, entry in topic_map.topics.items():
        _check_entry(f"topic_map.topics.{name}", name, entry)
        if entry.enabled and entry.topic in seen:
            raise TopicMapError(
                f"topic_map.topics.{name}.topic: {entry.topic} is also "
                f"{seen[entry.topic]}'s topic; each topic carries one signal"
            )
        seen[entry.topic] = name


def _check_entry(where: str, name: str, entry: TopicEntry) -> None:
    if not isinstance(entry.topic, str) or not _TOPIC.fullmatch(entry.topic) or "__" in entry.topic:
        raise TopicMapError(
            f"{where}.topic: {short_repr(entry.topic)} is not an absolute ROS 2 "
            "topic name (/a/b: letters, digits and _, no token starting with "
            "a digit, no __)"
        )
    allowed = SIGNALS[name].types
    if entry.type not in allowed:
        raise TopicMapError(
            f"{where}.type: {short_repr(entry.type)} is not one of {', '.join(allowed)}"
        )
    if entry.qos not in QOS_PROFILES:
        raise TopicMapError(
            f"{where}.qos: {short_repr(entry.qos)} is not one of {', '.join(QOS_PROFILES)}"
        )
    rate = entry.rate_hz
    if isinstance(rate, bool) or not isinstance(rate, (int, float)) or not 0 < rate <= MAX_RATE_HZ:
        raise TopicMapError(
            f"{where}.rate_hz: {short_repr(rate)} is outside the allowed range "
            f"(0, {MAX_RATE_HZ:g}] Hz"
        )


def topic_table_markdown(topic_map: TopicMap | None = None) -> str:
    """The topic map (default: the shipped one) as a Markdown table: signal, topic, type
    (its alternatives after "or"), QoS, rate, the log arrays it is made of and what it is
    (docs/ros2.md holds the shipped map's; a test checks)."""
    topic_map = topic_map or load_topic_map()
    rows = [
        "| signal | topic | type | QoS | rate | from `log.npz` | what |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name, entry in topic_map.topics.items():
        signal = SIGNALS[name]
        others = [t for t in signal.types if t != entry.type]
        kind = f"`{entry.type}`" + "".join(f" (or `{t}`)" for t in others)
        arrays = (
            ", ".join(f"`{a}`" for a in (signal.times, *signal.arrays))
            if signal.bagged
            else "(seam only)"
        )
        rows.append(
            f"| `{name}` | `{entry.topic}` | {kind} | `{entry.qos}` | "
            f"{entry.rate_hz:g} Hz | {arrays} | {signal.what} |"
        )
    return "\n".join(rows) + "\n"
