"""Transport: one end of the seam (``Link``): a transport (LCM here, ``LcmTransport``; ROS 2
in ``manta_drake.seam.ros2_link``), the messages received (decoded as they arrive; what
does not decode is counted and skipped), the handshake, what to re-send; the URL check;
and how long a side waits for its peer."""

from __future__ import annotations

import collections
import contextlib
import functools
import ipaddress
import math
import os
import struct
import tempfile
import time
import urllib.parse
import zlib
from collections.abc import Callable

from manta_drake.lcmtypes import lcmt_manta_handshake
from manta_drake.seam.channels import Channel
from manta_drake.seam.errors import Incidents, SeamError, warn
from manta_drake.seam.handshake import (
    HANDSHAKE_CHANNEL,
    LCM_MEDIUM,
    Greeting,
    Handshake,
    Hello,
    greeting_from_message,
    greeting_message,
)
from manta_drake.seam.messages import CODECS

# LCM's default group; ttl=0: this machine only; a 2 MB receive buffer (capped by the
# kernel's net.core.rmem_max) holds a few depth images (77 kB each) while a side computes.
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152"
QUEUE_CAPACITY = 1000  # messages per subscription waiting to be handled
STALE_AFTER_S = 1.0  # s of silence from the peer before saying so on stderr
RESEND_PERIOD_S = 0.1  # s between re-sends while waiting
DEFAULT_TIMEOUT_S = 10.0  # s of silence before giving up
DEFAULT_STARTUP_TIMEOUT_S = 120.0  # s for the first message: the peer may still be building

# What decoding a truncated, foreign or inconsistent message raises: struct.error (too few
# bytes), ValueError (a wrong fingerprint, bad UTF-8, a reshape), SeamError (a codec's own
# checks), zlib.error; IndexError, TypeError, OverflowError for lengths that do not add up.
DECODE_ERRORS = (
    struct.error,
    ValueError,
    SeamError,
    zlib.error,
    IndexError,
    TypeError,
    OverflowError,
)
# liblcm's udpm provider options and their ranges; it ignores any other (and its obsolete
# transmit_only) with a warning on a line of its own.
UDPM_OPTIONS = {"ttl": (0, 255), "recv_buf_size": (1, 2**31 - 1)}
URL_FORM = (
    "udpm://GROUP:PORT[?ttl=N&recv_buf_size=BYTES] (e.g. udpm://239.255.76.67:7667?ttl=0) "
    "or tcpq://HOST:PORT"
)


def check_url(url: str, in_process: bool = False) -> None:
    """Refuses, in one line, an LCM URL the seam cannot use, before liblcm sees it (liblcm
    prints its own reason on stderr and raises "Couldn't create LCM").

    Args:
        url: the ``--lcm`` URL.
        in_process: also accept ``memq://`` (one process only: the unit tests' transport).

    Raises:
        SeamError: the URL and what is wrong with it.
    """

    def refuse(why: str):
        return SeamError(f"--lcm {url!r}: {why}; expected {URL_FORM}")

    if not isinstance(url, str) or not url.strip():
        raise refuse("an empty URL")
    scheme, sep, rest = url.partition("://")
    if not sep:
        raise refuse("not a URL (no PROVIDER://)")
    if scheme == "memq":
        if in_process:
            return
        raise refuse("memq:// reaches this process only, and the other side runs in another")
    if scheme not in ("udpm", "tcpq"):
        raise refuse(
            "file:// is a log file, not a peer"
            if scheme == "file"
            else f"unknown LCM provider {scheme!r}"
        )
    address, _, query = rest.partition("?")
    host, colon, port = address.rpartition(":")
    if not colon:
        raise refuse(f"no port in {address!r}")
    if not host:
        raise refuse(f"no host in {address!r}")
    if not (port.isdigit() and 1 <= int(port) <= 65535):
        raise refuse(f"port {port!r} is not a number in 1-65535")
    if scheme == "tcpq":
        if query:
            raise refuse("tcpq:// takes no options")
        return
    try:
        group = ipaddress.IPv4Address(host)
    except ValueError:
        raise refuse(
            f"{host!r} is not an IPv4 multicast group (224.0.0.0-239.255.255.255)"
        ) from None
    if not group.is_multicast:
        raise refuse(f"{host} is not a multicast group (224.0.0.0-239.255.255.255)")
    for key, value in urllib.parse.parse_qsl(query, keep_blank_values=True):
        if key not in UDPM_OPTIONS:
            raise refuse(f"unknown option {key!r} (known: {', '.join(UDPM_OPTIONS)})")
        bounds = UDPM_OPTIONS[key]
        if not (value.isdigit() and bounds[0] <= int(value) <= bounds[1]):
            raise refuse(f"{key}={value!r}: expected an integer in {bounds[0]}-{bounds[1]}")


@contextlib.contextmanager
def _stderr_captured():
    """Collects what C code writes on file descriptor 2 meanwhile (liblcm prints its reasons
    there), so the seam can say it in its own one line. Yields a list that holds the text
    afterwards."""
    text: list[str] = []
    try:
        saved = os.dup(2)
    except OSError:  # no stderr to capture
        yield text
        return
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield text
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            text.append(" ".join(tmp.read().decode(errors="replace").split()))


def open_lcm(url: str, who: str):
    """An ``lcm.LCM`` on ``url``; liblcm's own complaint goes into one line.

    Raises:
        SeamError: liblcm cannot open it (with its reason).
    """
    import lcm

    with _stderr_captured() as said:
        try:
            instance = lcm.LCM(url)
        except RuntimeError:
            instance = None
    said = "".join(said)
    if instance is None:
        raise SeamError(f"{who}: cannot open the LCM URL {url!r}: {said or 'liblcm refused it'}")
    if said:
        warn(f"{who}: liblcm on {url!r}: {said}")
    return instance


class LcmTransport:
    """The LCM side of a ``Link``: an ``lcm.LCM`` on ``url``, the channels as LCM channels of
    their ``CODECS`` types, the handshake as ``lcmt_manta_handshake`` on
    ``HANDSHAKE_CHANNEL``.

    The transport is the ``lcm`` package rather than ``pydrake.lcm.DrakeLcm``: a
    DrakeLcm subscription keeps only the newest unhandled message and its Python
    ``Subscribe`` gives no handle to change that, while the lockstep controller runs a
    few steps ahead, so several messages per channel can wait to be handled.
    """

    medium = LCM_MEDIUM

    def __init__(self, url: str, who: str):
        check_url(url, in_process=True)
        self.url = url
        self.lcm = open_lcm(url, who)

    def message(self, channel: Channel, t: float, value):
        """The message of ``value`` at ``t`` on ``channel``."""
        return CODECS[channel.codec].encode(t, value)

    def pack(self, _name: str, msg) -> bytes:
        return msg.encode()

    def send(self, name: str, data: bytes) -> None:
        self.lcm.publish(name, data)

    def listen(self, channel: Channel, deliver: Callable) -> None:
        """``deliver(data, None)`` for every message on ``channel``."""
        self.lcm.subscribe(
            channel.name, lambda _name, data: deliver(data, None)
        ).set_queue_capacity(QUEUE_CAPACITY)

    def decode(self, channel: Channel, data: bytes, _meta) -> tuple[int, object]:
        """(stamp [us], port value) of a message; DECODE_ERRORS when it is not one."""
        codec = CODECS[channel.codec]
        msg = codec.lcm_type.decode(data)
        return int(codec.stamp(msg)), codec.decode(msg)

    def type_name(self, channel: Channel) -> str:
        lcm_type = CODECS[channel.codec].lcm_type
        return f"{lcm_type.__module__.rsplit('.', 1)[0]}.{lcm_type.__name__}"

    def why_malformed(self, channel: Channel | None, data: bytes, reason: str) -> str:
        """``reason``, or what a foreign fingerprint says instead."""
        lcm_type = lcmt_manta_handshake if channel is None else CODECS[channel.codec].lcm_type
        if data[:8] != lcm_type._get_packed_fingerprint():
            return "another type's fingerprint: another program on this URL?"
        return reason

    def listen_handshake(self, deliver: Callable) -> None:
        self.lcm.subscribe(HANDSHAKE_CHANNEL, lambda _name, data: deliver(data)).set_queue_capacity(
            QUEUE_CAPACITY
        )

    def send_greeting(self, greeting: Greeting) -> None:
        self.lcm.publish(HANDSHAKE_CHANNEL, greeting_message(greeting).encode())

    def decode_greeting(self, data: bytes) -> Greeting:
        return greeting_from_message(lcmt_manta_handshake.decode(data))

    handshake_type = "manta_drake.lcmtypes.lcmt_manta_handshake"
    handshake_name = HANDSHAKE_CHANNEL

    def handle(self, timeout_ms: int) -> int:
        """Handles one message, waiting up to ``timeout_ms``; returns how many."""
        return max(0, self.lcm.handle_timeout(int(timeout_ms)))

    def close(self) -> None:
        """Nothing to release (liblcm closes with the object)."""


class Link:
    """One end of the seam: a transport (``LcmTransport``, or the ROS 2 one of
    ``manta_drake.seam.ros2_link``), the messages received, what to re-send.

    Messages are decoded into port values as they arrive (one that does not decode, or a
    vector of the wrong length, is counted and skipped: ``Incidents``, kind
    ``malformed``) and kept by channel and stamp; those stamped before ``floor_utime``
    (re-sent duplicates) are dropped, but each channel's newest stamp is kept in
    ``newest``. The ``monitor`` channels' values are kept apart, in ``monitored``, and
    never dropped (the controller logs them). What is published stays "unacknowledged"
    until a message from the peer stamped later arrives (lockstep: the peer sends a
    message stamped u only after it has everything it reads stamped before u) or, on the
    wall clock, until ``acknowledge_all``; ``resend`` publishes it again, and always the
    newest message of a ``sticky`` channel (the clock, which the peer watches but does
    not read, so no stamp acknowledges it).

    With a ``hello`` the Link takes part in the handshake (``manta_drake.seam.handshake``)
    for as long as it lives: ``shake_hands`` pairs it with its peer, and later requests
    (a second station, say) are answered and named.

    Args:
        transport: an LCM URL (an ``LcmTransport`` on it) or a transport object.
    """

    def __init__(
        self,
        transport,
        subscribe,
        who: str,
        lockstep: bool = True,
        sticky: tuple[str, ...] = (),
        incidents: Incidents | None = None,
        monitor=(),
        hello: Hello | None = None,
    ):
        if isinstance(transport, str):
            transport = LcmTransport(transport, who)
        self.transport = transport
        self.who, self.url, self.lockstep = who, transport.url, lockstep
        self.incidents = incidents if incidents is not None else Incidents(who)
        self.inbox: dict[str, dict[int, object]] = {}
        self.monitored: dict[str, dict[int, object]] = {}
        self.newest: dict[str, int] = {}
        self.floor_utime = -1
        self.last_arrival: float | None = None  # monotonic time of the last message received
        self.resends = 0
        self._acked_below = -1  # the peer has what we sent stamped before this
        self._error: Exception | None = None
        self._unacked: collections.deque[tuple[int, str, object]] = collections.deque()
        self._sticky = {name: None for name in sticky}
        self._channels: dict[str, Channel] = {}
        # While set, ``resend`` calls it first: True, it sent what is due instead (the
        # controller's failsafe); False, the re-send goes on.
        self.holding: Callable[[], bool] | None = None
        for channel in subscribe:
            self._subscribe(channel, channel.name in set(monitor))
        self.handshake: Handshake | None = None
        if hello is not None:
            self.handshake = Handshake(hello, transport.send_greeting, self.url, transport.medium)
            transport.listen_handshake(self._receive_hello)

    def _subscribe(self, channel: Channel, monitor: bool = False) -> None:
        if channel.name in self._channels:
            return
        self._channels[channel.name] = channel
        (self.monitored if monitor else self.inbox)[channel.name] = {}
        self.transport.listen(channel, functools.partial(self._receive, channel))

    def _malformed(self, channel_name: str, type_name: str, data: bytes, reason: str) -> None:
        self.incidents.report(
            channel_name,
            ["malformed"],
            f"a message ({len(data)} bytes) that is not a valid {type_name} ({reason}): skipped",
        )

    def _receive(self, channel: Channel, data: bytes, meta) -> None:
        try:
            stamp, value = self.transport.decode(channel, data, meta)
            if channel.size is not None and len(value) != channel.size:
                raise SeamError(f"{len(value)} values, expected {channel.size}")
        except DECODE_ERRORS as e:  # a truncated or foreign message must not stop the run
            reason = " ".join(str(e).split()) or type(e).__name__
            self._malformed(
                channel.name,
                self.transport.type_name(channel),
                data,
                self.transport.why_malformed(channel, data, reason),
            )
            return
        self.last_arrival = time.monotonic()
        self.newest[channel.name] = max(stamp, self.newest.get(channel.name, stamp))
        if self.lockstep:
            self._acked_below = max(self._acked_below, stamp)
        if channel.name in self.monitored:
            self.monitored[channel.name][stamp] = value
        elif stamp >= self.floor_utime:
            self.inbox[channel.name][stamp] = value

    def _receive_hello(self, data: bytes) -> None:
        try:
            greeting = self.transport.decode_greeting(data)
        except DECODE_ERRORS as e:  # skipped like any other malformed message
            reason = " ".join(str(e).split()) or type(e).__name__
            self._malformed(
                self.transport.handshake_name,
                self.transport.handshake_type,
                data,
                self.transport.why_malformed(None, data, reason),
            )
            return
        assert self.handshake is not None  # listened to only with a hello
        self.handshake.receive(greeting)
        if self.handshake.error is not None and self._error is None:
            self._error = self.handshake.error

    def message(self, channel: Channel, t: float, value):
        """The transport's message of ``value`` at ``t`` on ``channel`` (for ``publish``)."""
        return self.transport.message(channel, t, value)

    def shake_hands(self, timeout: float) -> Hello:
        """Sends this side's Hello every ``RESEND_PERIOD_S`` until a matching peer has named
        it back; returns the peer's Hello.

        Raises:
            SeamError: the handshake failed (a mismatch, a second station or controller), in
                one line, or nobody answered within ``timeout`` s.
        """
        hs = self.handshake
        assert hs is not None, "shake_hands needs a Link made with a hello"
        start, last_send = time.monotonic(), -math.inf
        while not hs.done:
            now = time.monotonic()
            if now - start >= timeout:
                peer = hs.mine.peer_role
                raise SeamError(
                    f"{self.who}: no {peer} answered on {self.url} within "
                    f"{now - start:.1f} s; is `manta-drake {peer}` running with the "
                    f"same {self.transport.medium.option}?"
                )
            if now - last_send >= RESEND_PERIOD_S:
                hs.send()
                last_send = now
            self.poll(20)
        assert hs.peer is not None  # done: paired
        return hs.peer

    def say_goodbye(self, status: str) -> None:
        """Tells the peer (and anyone listening) that this side stops, and why."""
        if self.handshake is not None:
            for _ in range(2):  # a datagram may be lost; the peer's timeout is the fallback
                self.handshake.send(status=status)

    def poll(self, timeout_ms: int = 0) -> int:
        """Handles one message, waiting up to ``timeout_ms`` for it; returns 1 or 0."""
        n = self.transport.handle(timeout_ms)
        if self._error is not None:
            raise self._error
        return int(n > 0)

    def drain(self) -> None:
        """Handles everything that has arrived, without waiting."""
        while self.poll(0):
            pass

    def publish(self, name: str, msg, utime: int) -> None:
        """Publishes ``msg`` (a transport's message, ``message``; stamped ``utime``) and keeps
        it for ``resend``."""
        data = self.transport.pack(name, msg)
        self.transport.send(name, data)
        if name in self._sticky:
            self._sticky[name] = data
        else:
            self._unacked.append((utime, name, data))
            self._forget_acknowledged()

    def _forget_acknowledged(self) -> None:
        # Published in time order, so the acknowledged ones are at the front.
        while self._unacked and self._unacked[0][0] < self._acked_below:
            self._unacked.popleft()

    def acknowledge_all(self) -> None:
        self._unacked.clear()

    def resend(self) -> None:
        """Publishes again what the peer may not have (or what ``holding`` sends instead)."""
        if self.holding is not None and self.holding():
            self.resends += 1
            return
        self._forget_acknowledged()
        again = [(name, data) for _, name, data in self._unacked]
        again += [(name, data) for name, data in self._sticky.items() if data is not None]
        for name, data in again:
            self.transport.send(name, data)
        self.resends += bool(again)

    def take(self, wanted: dict[str, int]) -> dict | None:
        """The values ``{channel: stamp}`` if all have arrived (removed), else None."""
        if any(stamp not in self.inbox[name] for name, stamp in wanted.items()):
            return None
        return {name: self.inbox[name].pop(stamp) for name, stamp in wanted.items()}

    def advance_floor(self, utime: int) -> None:
        """Drops what is stamped before ``utime``: it can no longer be wanted."""
        self.floor_utime = utime
        for box in self.inbox.values():
            for stamp in [s for s in box if s < utime]:
                del box[stamp]

    def latest(self, name: str):
        """The newest value on ``name`` not yet taken (older ones dropped), or None."""
        box = self.inbox[name]
        if not box:
            return None
        msg = box[max(box)]
        box.clear()
        return msg

    def newest_values(self, names) -> dict:
        """``{name: latest(name)}`` of the named channels that have something new (a value
        may be None: a ROS 2 clock tick, which carries only its stamp)."""
        return {name: self.latest(name) for name in names if self.inbox[name]}

    def wait_for(
        self,
        ready: Callable[[], object],
        timeout: float,
        on_stale: Callable[[float], None],
        on_timeout: Callable[[float], Exception],
    ):
        """Polls until ``ready()`` returns something other than None and returns it,
        re-sending what the peer may not have every ``RESEND_PERIOD_S``; calls
        ``on_stale(waited_s)`` once after ``STALE_AFTER_S``.

        Raises:
            the exception ``on_timeout(waited_s)`` returns, after ``timeout`` s.
        """
        start = last_resend = time.monotonic()
        stale = False
        while True:
            got = ready()
            if got is not None:
                return got
            now = time.monotonic()
            if now - start >= timeout:
                raise on_timeout(now - start)
            if not stale and now - start >= STALE_AFTER_S:
                stale = True
                on_stale(now - start)
            if now - last_resend >= RESEND_PERIOD_S:
                self.resend()
                last_resend = now
            self.poll(max(1, min(50, int(1000 * (start + timeout - now)))))
