"""Transport: one end of the seam (``Link``): an LCM instance, the messages received, what
to re-send; and how long a side waits for its peer."""

from __future__ import annotations

import collections
import functools
import time
from collections.abc import Callable

from manta_drake.seam.channels import Channel
from manta_drake.seam.errors import SeamError
from manta_drake.seam.messages import CODECS

# LCM's default group; ttl=0: this machine only; a 2 MB receive buffer (capped by the
# kernel's net.core.rmem_max) holds a few depth images (77 kB each) while a side computes.
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152"
QUEUE_CAPACITY = 1000  # messages per subscription waiting to be handled
STALE_AFTER_S = 1.0  # s of silence from the peer before saying so on stderr
RESEND_PERIOD_S = 0.1  # s between re-sends while waiting
DEFAULT_TIMEOUT_S = 10.0  # s of silence before giving up
DEFAULT_STARTUP_TIMEOUT_S = 120.0  # s for the first message: the peer may still be building


class Link:
    """One end of the seam: an LCM instance, the messages received, what to re-send.

    The transport is the ``lcm`` package rather than ``pydrake.lcm.DrakeLcm``: a
    DrakeLcm subscription keeps only the newest unhandled message and its Python
    ``Subscribe`` gives no handle to change that, while the lockstep controller runs a
    few steps ahead, so several messages per channel can wait to be handled.

    Messages are decoded as they arrive and kept by channel and stamp; those stamped
    before ``floor_utime`` (re-sent duplicates) are dropped, but each channel's newest
    stamp is kept in ``newest``. What is published stays "unacknowledged" until a
    message from the peer stamped later arrives (lockstep: the peer sends a message
    stamped u only after it has everything it reads stamped before u) or, on the wall
    clock, until ``acknowledge_all``; ``resend`` publishes it again, and always the
    newest message of a ``sticky`` channel (the clock, which the peer watches but
    does not read, so no stamp acknowledges it).
    """

    def __init__(self, url: str, subscribe, who: str, lockstep: bool = True,
                 sticky: tuple[str, ...] = ()):
        import lcm

        self.who, self.url, self.lockstep = who, url, lockstep
        try:
            self.lcm = lcm.LCM(url)
        except RuntimeError as e:  # with the provider's reason
            raise SeamError(f"{who}: cannot open the LCM URL {url!r}: {e}") from None
        self.inbox: dict[str, dict[int, object]] = {}
        self.newest: dict[str, int] = {}
        self.floor_utime = -1
        self.last_arrival = None  # monotonic time of the last message received
        self.resends = 0
        self._acked_below = -1  # the peer has what we sent stamped before this
        self._error: Exception | None = None
        self._unacked: collections.deque[tuple[int, str, bytes]] = collections.deque()
        self._sticky = {name: None for name in sticky}
        for channel in subscribe:
            self.inbox[channel.name] = {}
            subscription = self.lcm.subscribe(channel.name,
                                              functools.partial(self._receive, channel))
            subscription.set_queue_capacity(QUEUE_CAPACITY)

    def _receive(self, channel: Channel, _name: str, data: bytes) -> None:
        codec = CODECS[channel.codec]
        try:
            msg = codec.lcm_type.decode(data)
        except ValueError:  # another program's type on our channel
            self._error = SeamError(f"{self.who}: a message on {channel.name} is not "
                                    f"{codec.lcm_type.__name__} (another program on {self.url}?)")
            return
        self.last_arrival = time.monotonic()
        stamp = codec.stamp(msg)
        self.newest[channel.name] = max(stamp, self.newest.get(channel.name, stamp))
        if self.lockstep:
            self._acked_below = max(self._acked_below, stamp)
        if stamp >= self.floor_utime:
            self.inbox[channel.name][stamp] = msg

    def poll(self, timeout_ms: int = 0) -> int:
        """Handles one message, waiting up to ``timeout_ms`` for it; returns 1 or 0."""
        n = self.lcm.handle_timeout(int(timeout_ms))
        if self._error is not None:
            raise self._error
        return int(n > 0)

    def drain(self) -> None:
        """Handles everything that has arrived, without waiting."""
        while self.poll(0):
            pass

    def publish(self, name: str, msg, utime: int) -> None:
        """Publishes ``msg`` (stamped ``utime``) and keeps it for ``resend``."""
        data = msg.encode()
        self.lcm.publish(name, data)
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
        """Publishes again what the peer may not have."""
        self._forget_acknowledged()
        again = [(name, data) for _, name, data in self._unacked]
        again += [(name, data) for name, data in self._sticky.items() if data is not None]
        for name, data in again:
            self.lcm.publish(name, data)
        self.resends += bool(again)

    def take(self, wanted: dict[str, int]) -> dict | None:
        """The messages ``{channel: stamp}`` if all have arrived (removed), else None."""
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
        """The newest message on ``name`` not yet taken (older ones dropped), or None."""
        box = self.inbox[name]
        if not box:
            return None
        msg = box[max(box)]
        box.clear()
        return msg

    def wait_for(self, ready: Callable[[], object], timeout: float,
                 on_stale: Callable[[float], None], on_timeout: Callable[[float], Exception]):
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
