"""The seam over ROS 2: the transport a ``Link`` uses for ``manta-drake station|controller
SCENARIO --ros2`` (docs/ros2.md).

Each channel of ``CHANNELS`` crosses as its port's ROS 2 message (``ros2.ports``) on the
topic the topic map gives it (its name, type and QoS profile), over Cyclone DDS
(``ros2.dds``): the same bytes a bag of the run holds. The lockstep clock is ``/clock``
(``rosgraph_msgs/Clock``): the station publishes it at every plant step with the measured
joint states, and the controller watches it as the LCM controller watches
``MANTA_MEASURED_JOINT_STATE``. The handshake is a ``diagnostic_msgs/DiagnosticStatus`` on
the topic map's ``seam_handshake`` topic: the Hello's fields as key-value pairs (the floats
as Python's shortest exact text), the status as its message, the channels as topics.

Stamps: a message's stamp is its header's (the Clock's time); one without a header
(``std_msgs/Float64``: the balloon command, the altitude, ...) is stamped by its DDS source
timestamp, which the seam sets to ``SOURCE_EPOCH_NS`` + its simulated time (DDS refuses
negative source timestamps, and the station's first values are stamped 1 us before t = 0).
"""

from __future__ import annotations

from manta_drake.ros2 import messages as m
from manta_drake.ros2.dds import Participant
from manta_drake.ros2.ports import PORT_CODECS, PORT_SIGNALS, stamp_ns
from manta_drake.seam.channels import CHANNELS, Channel
from manta_drake.seam.errors import SeamError
from manta_drake.seam.handshake import Greeting, Hello, Medium, check_hello
from manta_drake.seam.messages import to_utime

SOURCE_EPOCH_NS = 1_000_000_000  # a headerless message's source timestamp - its stamp
HANDSHAKE_NAME = "manta_drake/seam"  # the DiagnosticStatus's name
ROS2_MEDIUM = Medium(
    "domain",
    "a ROS 2 domain",
    "give each run a domain of its own (--domain N, or ROS_DOMAIN_ID)",
    "--ros2 --domain N",
)
_HELLO_KEYS = (
    "role",
    "run_id",
    "peer_run_id",
    "reply",
    "pid",
    "scenario",
    "duration",
    "time_step",
    "clock_mode",
    "channels",
)


def channel_signals(channel: Channel, sending: bool) -> list[str]:
    """The topic-map signals ``channel`` crosses as: its port's; the lockstep clock channel
    also as ``clock``, which is all a receiver reads of it; a depth image also with its
    ``camera_info``."""
    if channel.port not in PORT_SIGNALS:
        raise SeamError(
            f"the port {channel.port} ({channel.name}) has no ROS 2 message; add "
            "one in manta_drake/ros2/ports.py"
        )
    if not sending:
        return ["clock"] if channel.clock else [PORT_SIGNALS[channel.port]]
    signals = [PORT_SIGNALS[channel.port]] + (["clock"] if channel.clock else [])
    return signals + (["camera_info"] if channel.port == "depth_image" else [])


def seam_topic_table_markdown(topic_map) -> str:
    """What crosses the seam over ROS 2 with ``topic_map`` (default: the shipped one), as a
    Markdown table: per channel, its port, sender, topics, types, QoS and period
    (docs/ros2.md holds the shipped map's; a test checks)."""
    from manta_drake.ros2.topic_map import QOS_PROFILES

    rows = [
        "| port | from | topic | type | QoS | period |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for c in CHANNELS:
        for signal in channel_signals(c, sending=True):
            e = topic_map.topics[signal]
            p = QOS_PROFILES[e.qos]
            qos = (
                f"`{e.qos}` ({'reliable' if p['reliability'] == 1 else 'best effort'}, "
                f"keep last {p['depth']})"
            )
            port = "(clock)" if signal == "clock" else f"`{c.port}`"
            rows.append(
                f"| {port} | {c.sender} | `{e.topic}` | `{e.type}` | {qos} | {c.period_text} |"
            )
    hs = topic_map.topics["seam_handshake"]
    rows.append(
        f"| (handshake) | both | `{hs.topic}` | `{hs.type}` | `{hs.qos}` | every 0.1 s "
        "until paired, then on a peer's request and at the end |"
    )
    return "\n".join(rows) + "\n"


def greeting_msg(greeting: Greeting, topics: list[str]):
    """A Greeting as ``diagnostic_msgs/DiagnosticStatus`` (``topics``: those it publishes)."""
    h = greeting.hello
    values = {
        "role": h.role,
        "run_id": h.run_id,
        "peer_run_id": greeting.peer_run_id,
        "reply": "true" if greeting.reply else "false",
        "pid": str(h.pid),
        "scenario": h.scenario,
        "duration": repr(float(h.duration)),
        "time_step": repr(float(h.time_step)),
        "clock_mode": h.clock_mode,
        "channels": " ".join(topics),
    }
    level = m.DIAGNOSTIC_ERROR if greeting.status.startswith("failed") else m.DIAGNOSTIC_OK
    return m.diagnostic_status_msg(level, HANDSHAKE_NAME, greeting.status, h.host, values)


def greeting_of(msg, channel_of_topic: dict[str, str]) -> Greeting:
    """The Greeting of a ``DiagnosticStatus`` (its topics named back as channels; unknown
    topics left out). Raises SeamError for a status that is not the seam's."""
    values = {kv.key: kv.value for kv in msg.values}
    missing = [k for k in _HELLO_KEYS if k not in values]
    if msg.name != HANDSHAKE_NAME or missing:
        raise SeamError(
            f"a DiagnosticStatus {msg.name!r} without the seam's {', '.join(missing) or 'name'}"
        )
    try:
        duration, step, pid = (
            float(values["duration"]),
            float(values["time_step"]),
            int(values["pid"]),
        )
    except ValueError as e:
        raise SeamError(f"handshake values: {e}") from None
    channels = tuple(
        dict.fromkeys(
            channel_of_topic[t] for t in values["channels"].split() if t in channel_of_topic
        )
    )
    hello = check_hello(
        Hello(
            values["role"],
            values["run_id"],
            values["scenario"],
            duration,
            step,
            values["clock_mode"],
            channels,
            msg.hardware_id,
            pid,
        )
    )
    return Greeting(hello, values["peer_run_id"], values["reply"] == "true", msg.message)


class Ros2Transport:
    """The ROS 2 side of a ``Link`` (see the module docstring).

    Args:
        who: "station" or "controller" (for messages).
        domain: the DDS domain (ROS_DOMAIN_ID).
        topic_map: the ``TopicMap`` (topics, types, QoS profiles, frames).
        constants: the conversions' constants (``ros2.bag.bag_constants``).
        config: a Cyclone XML file; None: the shipped loopback configuration.
    """

    medium = ROS2_MEDIUM

    def __init__(self, who: str, domain: int, topic_map, constants, config=None):
        self.who, self.topic_map, self.constants = who, topic_map, constants
        self.participant = Participant(domain, config)
        self.url = f"ROS 2 domain {domain}"
        self._receiving: dict[str, tuple[str, str]] = {}
        hs = self._entry("seam_handshake")
        self.handshake_name, self.handshake_type = hs.topic, hs.type
        self._channel_of_topic = {
            self._entry(s).topic: c.name
            for c in CHANNELS
            for s in channel_signals(c, sending=True)
            if self.topic_map.topics[s].enabled
        }

    def _entry(self, signal: str):
        entry = self.topic_map.topics[signal]
        if not entry.enabled:
            raise SeamError(
                f"{self.who}: the topic map's {signal} is not enabled, and the seam "
                f"over ROS 2 carries it (topics.{signal}.enabled)"
            )
        return entry

    def topics(self, channel_names) -> list[str]:
        """The topics the named channels are published on."""
        by_name = {c.name: c for c in CHANNELS}
        return [
            self._entry(s).topic
            for name in channel_names
            for s in channel_signals(by_name[name], sending=True)
            if self._sends(s)
        ]

    def _sends(self, signal: str) -> bool:
        if signal == "camera_info":  # an extra for ROS 2's tools, when it can be made
            return (
                self.topic_map.topics[signal].enabled
                and self.constants.camera_intrinsics is not None
            )
        return True

    def message(self, channel: Channel, t: float, value):
        """The serialized messages of ``value`` at ``t``: ((signal, CDR bytes, source
        timestamp [ns]), ...)."""
        t_ns, source = m.to_nanoseconds(t), SOURCE_EPOCH_NS + 1000 * to_utime(t)
        out = []
        for signal in channel_signals(channel, sending=True):
            if not self._sends(signal):
                continue
            codec = PORT_CODECS[signal][self._entry(signal).type]
            out.append((signal, m.serialize(codec.to_msg(t_ns, value, self.constants)), source))
        return tuple(out)

    def pack(self, _name: str, msg):
        return msg

    def send(self, _name: str, packets) -> None:
        for signal, data, source in packets:
            e = self._entry(signal)
            self.participant.write(self.participant.writer(e.topic, e.type, e.qos), data, source)

    def listen(self, channel: Channel, deliver) -> None:
        """``deliver(data, source timestamp)`` for every sample of the channel's topic."""
        (signal,) = channel_signals(channel, sending=False)
        e = self._entry(signal)
        self._receiving[channel.name] = (signal, e.type)
        self.participant.reader(e.topic, e.type, e.qos, deliver)

    def decode(self, channel: Channel, data: bytes, source_ns: int) -> tuple[int, object]:
        """(stamp [us], port value) of a sample; SeamError when it does not decode."""
        signal, typename = self._receiving[channel.name]
        msg = self._deserialize(data, typename)
        ns = stamp_ns(msg)
        if ns is None:
            ns = source_ns - SOURCE_EPOCH_NS
        codec = PORT_CODECS[signal][typename]
        return round(ns / 1000), (codec.from_msg(msg, self.constants) if codec.from_msg else None)

    @staticmethod
    def _deserialize(data: bytes, typename: str):
        from rosbags.serde import SerdeError

        try:
            return m.deserialize(data, typename)
        except SerdeError as e:
            raise SeamError(str(e)) from None

    def type_name(self, channel: Channel) -> str:
        signal, typename = self._receiving[channel.name]
        return f"{typename} on {self._entry(signal).topic}"

    def why_malformed(self, _channel, data: bytes, reason: str) -> str:
        if data[:2] != b"\x00\x01":
            return f"encapsulation {data[:2].hex() or 'missing'}, not little-endian CDR (0001)"
        return reason

    def listen_handshake(self, deliver) -> None:
        e = self._entry("seam_handshake")
        self.participant.reader(e.topic, e.type, e.qos, lambda data, _source: deliver(data))

    def send_greeting(self, greeting: Greeting) -> None:
        e = self._entry("seam_handshake")
        data = m.serialize(greeting_msg(greeting, self.topics(greeting.hello.channels)))
        self.participant.write(
            self.participant.writer(e.topic, e.type, e.qos), data, SOURCE_EPOCH_NS
        )

    def decode_greeting(self, data: bytes) -> Greeting:
        return greeting_of(self._deserialize(data, self.handshake_type), self._channel_of_topic)

    def handle(self, timeout_ms: int) -> int:
        return self.participant.handle(timeout_ms)

    def close(self) -> None:
        self.participant.close()
