"""The live view: a run's ROS 2 signals served while it runs, for the Foxglove app
(``manta-drake run SCENARIO --foxglove [HOST:PORT]``; docs/ros2.md).

A foxglove-sdk WebSocket server (subprotocol ``foxglove.sdk.v1``; the SDK's version is
pinned, older ``foxglove.websocket.v1`` clients are refused) with one channel per enabled
signal of the topic map that the run logs: the bag's topics, ``ros2msg`` schemas from
rosbags' Humble store, ``cdr`` messages, the very bytes a bag of the run holds
(``bag.bag_messages``' conversions), decimated to each topic's rate, ``/tf`` with the fin
links. Each message's log time is its simulated time [ns], as in the bag. The simulation
hands it its log after every chunk it simulates (``update``); it publishes what is new.

Local by default (127.0.0.1:8765): nothing listens beyond this machine unless a host is
given. Port 0 takes any free port (``LiveView.port`` says which).
"""

from __future__ import annotations

import dataclasses as dc
from typing import TYPE_CHECKING

from manta_drake.ros2 import messages as m
from manta_drake.ros2.bag import bag_constants, decimate
from manta_drake.ros2.signals import SIGNALS
from manta_drake.ros2.topic_map import TopicMap

if TYPE_CHECKING:  # the ros2 extra's; imported where a live view starts
    import foxglove

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8765
SUBPROTOCOL = "foxglove.sdk.v1"  # what foxglove-sdk 0.30 speaks (docs/ros2.md)


class LiveViewError(ValueError):
    """``--foxglove`` cannot be served; one line naming the option."""


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT``, ``HOST`` or ``:PORT`` -> (host, port); LiveViewError naming
    ``--foxglove`` and the allowed form."""
    host, sep, port = (text or "").rpartition(":")
    if not sep:
        host, port = text, str(DEFAULT_PORT)
    host = host.strip("[]") or DEFAULT_HOST
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise LiveViewError(
            f"--foxglove {text!r}: expected HOST:PORT with a port in 0-65535 "
            f"(0: any free port), e.g. {DEFAULT_HOST}:{DEFAULT_PORT}"
        )
    return host, int(port)


@dc.dataclass
class _Stream:
    signal: str
    channel: foxglove.Channel
    rate_hz: float
    sent: int = -1  # the last log row published


class LiveView:
    """A foxglove-sdk server publishing a run's signals as it runs.

    Args:
        scenario: the run's scenario (the conversions' constants, the fin links).
        topic_map: the topics, types and rates.
        host, port: where to listen (port 0: any free one).
    """

    def __init__(
        self, scenario, topic_map: TopicMap, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT
    ):
        import foxglove

        self.topic_map = topic_map
        self.constants = bag_constants(scenario, topic_map)
        self._context = foxglove.Context()
        try:
            self.server = foxglove.start_server(
                name="manta_drake", host=host, port=port, context=self._context
            )
        except Exception as e:  # noqa: BLE001 (the SDK's own error class: one line)
            raise LiveViewError(f"--foxglove {host}:{port}: cannot listen ({e})") from None
        self.host, self.port = host, self.server.port
        self._streams: dict[str, _Stream] = {}

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def _stream(self, name: str) -> _Stream:
        import foxglove

        if name not in self._streams:
            entry = self.topic_map.topics[name]
            schema = foxglove.Schema(
                name=entry.type, encoding="ros2msg", data=m.msgdef(entry.type).encode()
            )
            channel = foxglove.Channel(
                entry.topic, schema=schema, message_encoding="cdr", context=self._context
            )
            self._streams[name] = _Stream(name, channel, entry.rate_hz)
        return self._streams[name]

    def update(self, log: dict) -> int:
        """Publishes the samples of ``log`` (the run's log so far) not yet published, each
        signal at its topic's rate, in time order within a signal; returns how many."""
        n = 0
        for name, entry in self.topic_map.enabled().items():
            signal = SIGNALS[name]
            if not signal.present(log):
                continue
            stream = self._stream(name)
            convert, times = signal.types[entry.type], log[signal.times]
            assert convert is not None  # present(): a signal with log arrays has conversions
            for i in decimate(times, stream.rate_hz):
                if i <= stream.sent:
                    continue
                t_ns = m.to_nanoseconds(times[i])
                stream.channel.log(
                    m.serialize(convert(log, i, t_ns, self.constants)), log_time=t_ns
                )
                stream.sent = i
                n += 1
        return n

    def close(self) -> None:
        """Stops the server (its clients see it close)."""
        for stream in self._streams.values():
            stream.channel.close()
        self.server.stop()
