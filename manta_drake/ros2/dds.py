"""ROS 2 topics over DDS without ROS 2: Cyclone DDS (the ``cyclonedds`` wheel, its own
``libddsc``) writing and reading what an rmw (rmw_cyclonedds_cpp, rmw_fastrtps_cpp) writes
and reads.

The conventions (ROS 2's design article on topic name mapping, rmw_cyclonedds'
``serdata.cpp`` and ``rmw_node.cpp``, rmw_dds_common's ``qos.cpp``):

* topic ``/a/b`` is the DDS topic ``rt/a/b`` (``dds_topic_name``);
* type ``pkg/msg/T`` is the DDS type ``pkg::msg::dds_::T_`` (``dds_type_name``), without
  keys; its IDL struct is generated from rosbags' Humble type store (``idl_type``), the same
  definitions the bytes are made with;
* payloads are plain CDR (XCDR1), little endian, with the 4-byte header ``00 01 00 00``;
  the endpoints offer and accept XCDR1 only (rmw readers refuse a writer offering XCDR2);
* QoS: the topic map's profiles (``QOS_PROFILES``: reliable or best effort, volatile,
  keep last 10 or 5);
* every endpoint's USER_DATA is ``typehash=RIHS01_<sha256>;`` (REP-2011, Iron and later),
  the hash rosbags computes from Jazzy's definitions (``user_data``).

The payload written is the bytes rosbags serialized (``messages.serialize``), handed to
Cyclone's C layer as they are (``Participant.write``): the bag, the live view and DDS carry
the very same bytes, and no second serializer can differ. Samples are read as raw bytes too
and decoded with rosbags. Both use the binding's ``_clayer`` calls that its own
``DataWriter.write`` and ``DataReader.take`` make after and before (de)serializing; they are
internal, so the ``cyclonedds`` version is pinned.

Discovery and transport follow the Cyclone XML given (``LOOPBACK_CONFIG`` by default:
127.0.0.1 only, no multicast).
"""

from __future__ import annotations

import functools
import pathlib
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from manta_drake.model import MODELS_DIR
from manta_drake.ros2 import messages as m
from manta_drake.ros2.topic_map import QOS_PROFILES

if TYPE_CHECKING:  # the ros2 extra's (x86_64 only); imported where a participant starts
    from cyclonedds.domain import DomainParticipant
    from cyclonedds.pub import DataWriter
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic

LOOPBACK_CONFIG = MODELS_DIR / "cyclonedds_loopback.xml"
# DDS domain ids: RTPS ports are 7400 + 250 x domain + offsets, below 65536.
MAX_DOMAIN_ID = 232
# DDS samples taken from one reader per call.
TAKE_BATCH = 256
# The hashes of USER_DATA come from the distributions that read them (Iron and later).
HASH_STORE = "ROS2_JAZZY"
RELIABLE, BEST_EFFORT = 1, 2  # QOS_PROFILES' reliability enum (rmw's)


class DdsError(ValueError):
    """The DDS side cannot start (a bad domain id or configuration); one line."""


def dds_topic_name(topic: str) -> str:
    """ROS 2 topic ``/a/b`` -> DDS topic ``rt/a/b``."""
    return "rt" + topic


def dds_type_name(typename: str) -> str:
    """ROS 2 type ``pkg/msg/T`` -> DDS type ``pkg::msg::dds_::T_``."""
    pkg, kind, name = typename.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


@functools.cache
def type_hash(typename: str) -> str:
    """``RIHS01_<hex>`` of ``typename``, from rosbags' Jazzy definitions."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(getattr(Stores, HASH_STORE)).hash_rihs01(typename)


def user_data(typename: str) -> bytes:
    """An endpoint's USER_DATA: ``typehash=RIHS01_<hex>;``."""
    return f"typehash={type_hash(typename)};".encode()


def check_domain(domain) -> int:
    """The domain id, or DdsError naming ``--domain`` and its range."""
    if isinstance(domain, bool) or not isinstance(domain, int) or not 0 <= domain <= MAX_DOMAIN_ID:
        raise DdsError(
            f"--domain {domain!r}: a ROS 2 (DDS) domain id is an integer in 0-{MAX_DOMAIN_ID}"
        )
    return domain


def read_config(path) -> str:
    """The Cyclone XML text of ``path`` (checked as XML), or DdsError naming the file."""
    import xml.dom.minidom

    path = pathlib.Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise DdsError(f"--dds-config {path}: cannot be read ({e.strerror or e})") from None
    try:
        root = xml.dom.minidom.parseString(text).documentElement
    except Exception as e:  # noqa: BLE001 (expat's errors: one line, whatever their class)
        raise DdsError(f"--dds-config {path}: not XML ({e})") from None
    assert root is not None  # a parsed document has its root element
    if root.tagName != "CycloneDDS":
        raise DdsError(
            f"--dds-config {path}: the root element is <{root.tagName}>; a Cyclone "
            "DDS configuration's is <CycloneDDS>"
        )
    return text


_BASE_TYPES = (
    "float64",
    "float32",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
)


@functools.cache
def idl_type(typename: str):
    """The Cyclone IDL struct of ROS 2 type ``typename``, named ``pkg::msg::dds_::T_``, its
    fields as rosbags' Humble store lists them (nested types likewise)."""
    from cyclonedds.idl import make_idl_struct

    _, fields = m.TYPESTORE.fielddefs[typename]
    return make_idl_struct(
        typename.split("/")[-1] + "_",
        dds_type_name(typename),
        {name: _idl_field(node) for name, node in fields},
    )


def _idl_field(node):
    # cyclonedds' IDL types are indexed through their __class_getitem__ (types.array[T, n]),
    # which its typing does not declare: mypy reads the classes as not indexable.
    from cyclonedds.idl import types

    kind, detail = node
    kind = int(kind)
    if kind == 1:  # a base type (rosbags' names)
        name, bound = detail
        if name == "string":
            return types.bounded_str[bound] if bound else str  # type: ignore[misc]
        if name == "bool":
            return bool
        if name in ("byte", "char", "octet"):
            return types.uint8
        if name in _BASE_TYPES:
            return getattr(types, name)
        raise DdsError(f"no IDL for the ROS 2 base type {name!r}")
    if kind == 2:  # a message type
        return idl_type(detail)
    inner, size = detail
    if kind == 3:  # a fixed array
        return types.array[_idl_field(inner), size]  # type: ignore[misc]
    if size:
        return types.sequence[_idl_field(inner), size]  # type: ignore[misc]
    return types.sequence[_idl_field(inner)]  # type: ignore[misc]


def qos(profile: str, typename: str):
    """The Cyclone QoS of a topic-map ``profile`` for an endpoint of ``typename``: its
    reliability, volatile durability, keep-last history of its depth, XCDR1 only, and the
    USER_DATA type hash."""
    from cyclonedds.core import Policy, Qos
    from cyclonedds.util import duration

    p = QOS_PROFILES[profile]
    reliability = (
        Policy.Reliability.Reliable(duration(milliseconds=100))
        if p["reliability"] == RELIABLE
        else Policy.Reliability.BestEffort
    )
    return Qos(
        reliability,
        Policy.Durability.Volatile,
        Policy.History.KeepLast(p["depth"]),
        Policy.DataRepresentation(use_cdrv0_representation=True),
        Policy.Userdata(user_data(typename)),
    )


_DOMAINS: dict[int, tuple[str, object]] = {}


def _domain(domain: int, config: str):
    """The process's Cyclone domain ``domain`` with ``config`` (Cyclone makes each domain
    once per process: every participant of it shares the first one's configuration)."""
    from cyclonedds.domain import Domain

    if domain not in _DOMAINS:
        _DOMAINS[domain] = (config, Domain(domain, config))
    elif _DOMAINS[domain][0] != config:
        raise DdsError(
            f"domain {domain} already runs in this process with another Cyclone configuration"
        )
    return _DOMAINS[domain][1]


class Participant:
    """A DDS domain participant that writes and reads ROS 2 topics as raw CDR bytes.

    Args:
        domain: the DDS domain id (ROS_DOMAIN_ID).
        config: a Cyclone XML file (default ``LOOPBACK_CONFIG``).
    """

    def __init__(self, domain: int, config=None):
        try:
            from cyclonedds.core import WaitSet
            from cyclonedds.domain import DomainParticipant
        except ImportError as e:
            raise DdsError(
                f"the seam over ROS 2 needs the cyclonedds package ({e}); PyPI has "
                "wheels for x86_64 only"
            ) from None

        self.domain = check_domain(domain)
        self.config = pathlib.Path(config or LOOPBACK_CONFIG)
        self._domain = _domain(self.domain, read_config(self.config))
        self.participant: DomainParticipant | None = DomainParticipant(self.domain)
        self._topics: dict[str, Topic] = {}
        self._writers: dict[str, DataWriter] = {}
        # Each reader and its deliver(data, source_timestamp_ns).
        self._readers: list[tuple[DataReader, Callable[[bytes, int], object]]] = []
        self._waitset = WaitSet(self.participant)

    def _open(self) -> DomainParticipant:
        """The participant, until ``close``."""
        assert self.participant is not None, "the DDS participant is closed"
        return self.participant

    def _topic(self, topic: str, typename: str) -> Topic:
        from cyclonedds.topic import Topic

        if topic not in self._topics:
            self._topics[topic] = Topic(self._open(), dds_topic_name(topic), idl_type(typename))
        return self._topics[topic]

    def writer(self, topic: str, typename: str, profile: str) -> DataWriter:
        """The writer of ``topic`` (one per topic)."""
        from cyclonedds.pub import DataWriter

        if topic not in self._writers:
            self._writers[topic] = DataWriter(
                self._open(), self._topic(topic, typename), qos(profile, typename)
            )
        return self._writers[topic]

    def reader(
        self, topic: str, typename: str, profile: str, deliver: Callable[[bytes, int], object]
    ) -> DataReader:
        """A reader of ``topic``: ``handle`` calls ``deliver(data, source_timestamp_ns)``
        for each sample it takes."""
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
        from cyclonedds.sub import DataReader

        reader = DataReader(self._open(), self._topic(topic, typename), qos(profile, typename))
        self._waitset.attach(
            ReadCondition(reader, SampleState.Any | ViewState.Any | InstanceState.Any)
        )
        self._readers.append((reader, deliver))
        return reader

    def write(self, writer: DataWriter, data: bytes, source_timestamp_ns: int) -> None:
        """Writes CDR bytes (with their encapsulation header) as one sample, with the given
        DDS source timestamp (>= 0), padded to a multiple of 4 bytes as the binding's
        ``DataWriter.write`` pads (CDR's padding: no reader sees it)."""
        from cyclonedds._clayer import ddspy_write_ts
        from cyclonedds.core import DDSException

        data = data.ljust((len(data) + 3) & ~3, b"\0")
        ret = ddspy_write_ts(writer._ref, data, int(source_timestamp_ns))
        if ret < 0:
            raise DDSException(ret, f"writing a sample of {writer.topic.name}")

    def take_all(self) -> int:
        """Takes every sample waiting in every reader and delivers it; returns how many."""
        from cyclonedds._clayer import ddspy_take
        from cyclonedds.core import InstanceState, SampleState, ViewState

        mask = SampleState.Any | ViewState.Any | InstanceState.Any
        n = 0
        for reader, deliver in self._readers:
            while True:
                samples = ddspy_take(reader._ref, mask, TAKE_BATCH)
                if isinstance(samples, int) or not samples:
                    break
                for data, info in samples:
                    if info.valid_data:
                        deliver(bytes(data), info.source_timestamp)
                        n += 1
                if len(samples) < TAKE_BATCH:
                    break
        return n

    def handle(self, timeout_ms: int) -> int:
        """Delivers what has arrived, waiting up to ``timeout_ms`` for something."""
        from cyclonedds.util import duration

        n = self.take_all()
        if n or timeout_ms <= 0:
            return n
        if not self._readers:
            time.sleep(timeout_ms / 1000)
            return 0
        self._waitset.wait(duration(milliseconds=int(timeout_ms)))
        return self.take_all()

    def close(self) -> None:
        """Deletes the participant and everything in it (its peers see it leave)."""
        self._readers.clear()
        self._writers.clear()
        self._topics.clear()
        self.participant = None
        self._domain = None
