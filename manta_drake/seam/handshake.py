"""The handshake: the first exchange of a split run, on its own channel
(``HANDSHAKE_CHANNEL``, ``lcmt_manta_handshake``).

Each side says who it is (role, a run id new for every run, host and pid, the scenario's
name) and how it runs (duration, plant step, clock mode, the channels it publishes). It
sends that as a request every ``RESEND_PERIOD_S`` until its peer names it back; every side
answers each request it hears with a reply (replies are never answered, so nothing
bounces). So, as soon as both are up:

* a station and a controller that match pair, and both go on;
* a peer that runs another duration, plant step or clock mode is named in one line on
  both sides, which stop (rather than one waiting for the other until its timeout);
* a second station (or controller) on the URL hears the first one's answer and stops with
  one line naming it; the running pair says once that it turned it away, and goes on.

When a side stops it sends its status once more (``finished``, ``stopped: ...`` for an end
the scenario asks for, ``failed: ...``), so its peer names the reason at once.

A message of the handshake is a ``Greeting`` (a Hello, the peer it names, request or
reply, status); the transport carries it as its own type (over LCM an
``lcmt_manta_handshake``: ``hello_message``, ``greeting_from_message``; over ROS 2 a
``diagnostic_msgs/DiagnosticStatus``: ``manta_drake.seam.ros2_link``).
"""

from __future__ import annotations

import dataclasses as dc
import math
import os
import secrets
import socket
import time

from manta_drake.lcmtypes import lcmt_manta_handshake
from manta_drake.seam.errors import PeerStopped, SeamError, warn

HANDSHAKE_CHANNEL = "MANTA_SEAM_HANDSHAKE"
ROLES = ("station", "controller")
CLOCK_MODES = ("lockstep", "wall-clock")


@dc.dataclass(frozen=True)
class Medium:
    """What a transport's meeting place is called in the handshake's lines."""

    name: str  # "URL"
    one: str  # "an LCM URL"
    remedy: str  # how to keep two runs apart
    option: str  # the option both sides must give alike


LCM_MEDIUM = Medium(
    "URL", "an LCM URL", "give each run a URL of its own (another port)", "--lcm URL"
)


def new_run_id() -> str:
    """A run id: 8 random hex digits, new for every run of a side."""
    return secrets.token_hex(4)


@dc.dataclass(frozen=True)
class Hello:
    """What one side says about itself in the handshake.

    Attributes:
        role: "station" or "controller".
        run_id: this run's id (``new_run_id``).
        scenario: the scenario's name.
        duration: the run's length [s]; 0: not fixed (a hardware driver).
        time_step: the plant step [s]; 0: not fixed.
        clock_mode: "lockstep" or "wall-clock".
        channels: the channels this side publishes.
        host, pid: where it runs (so an operator can find the other process).
    """

    role: str
    run_id: str
    scenario: str
    duration: float
    time_step: float
    clock_mode: str
    channels: tuple[str, ...] = ()
    host: str = dc.field(default_factory=socket.gethostname)
    pid: int = dc.field(default_factory=os.getpid)

    @property
    def peer_role(self) -> str:
        return ROLES[1 - ROLES.index(self.role)]

    def describe(self) -> str:
        """``the controller 1a2b3c4d (pid 42 on host, scenario swim)``."""
        return (
            f"the {self.role} {self.run_id} (pid {self.pid} on {self.host}, scenario "
            f"{self.scenario or '-'})"
        )


def hello_for(role: str, scenario, wall_clock: bool, channels) -> Hello:
    """This side's Hello for ``scenario``."""
    return Hello(
        role,
        new_run_id(),
        scenario.name,
        float(scenario.duration),
        float(scenario.time_step),
        CLOCK_MODES[bool(wall_clock)],
        tuple(c.name for c in channels),
    )


def failure_status(e: BaseException) -> str:
    """The status a side sends its peer when it fails: ``failed: <its one line>``."""
    if isinstance(e, KeyboardInterrupt):
        return "failed: interrupted"
    text = " ".join(str(e).split()) or type(e).__name__
    for role in ROLES:
        text = text.removeprefix(f"{role}: ")
    return f"failed: {text}"


@dc.dataclass(frozen=True)
class Greeting:
    """One handshake message: ``hello`` (who sends it), the peer's run id it names ("" before
    pairing), a reply or a request, and the sender's end ("" while it runs)."""

    hello: Hello
    peer_run_id: str = ""
    reply: bool = False
    status: str = ""


def hello_message(
    hello: Hello, peer_run_id: str = "", reply: bool = False, status: str = ""
) -> lcmt_manta_handshake:
    """``hello`` as an ``lcmt_manta_handshake``."""
    msg = lcmt_manta_handshake()
    msg.utime = int(time.time() * 1e6)
    msg.role, msg.run_id, msg.peer_run_id, msg.reply = (
        hello.role,
        hello.run_id,
        peer_run_id,
        bool(reply),
    )
    msg.host, msg.pid, msg.scenario = hello.host, int(hello.pid), hello.scenario
    msg.duration, msg.time_step, msg.clock_mode = hello.duration, hello.time_step, hello.clock_mode
    msg.channels = list(hello.channels)
    msg.num_channels = len(msg.channels)
    msg.status = status
    return msg


def hello_from_message(msg: lcmt_manta_handshake) -> Hello:
    """The Hello of an ``lcmt_manta_handshake``.

    Raises:
        SeamError: an unknown role or clock mode, a negative or non-finite duration or step.
    """
    return check_hello(
        Hello(
            msg.role,
            msg.run_id,
            msg.scenario,
            msg.duration,
            msg.time_step,
            msg.clock_mode,
            tuple(msg.channels),
            msg.host,
            msg.pid,
        )
    )


def check_hello(hello: Hello) -> Hello:
    """``hello`` if its role, clock mode, duration and step can be; else SeamError (what a
    transport's decoder raises for a greeting that is not one)."""
    if hello.role not in ROLES or hello.clock_mode not in CLOCK_MODES:
        raise SeamError(
            f"role {hello.role!r}, clock_mode {hello.clock_mode!r}; expected one of "
            f"{ROLES} and of {CLOCK_MODES}"
        )
    for name in ("duration", "time_step"):
        value = getattr(hello, name)
        if not (math.isfinite(value) and value >= 0):
            raise SeamError(f"{name} {value}; expected a finite number >= 0")
    return hello


def greeting_message(greeting: Greeting) -> lcmt_manta_handshake:
    """``greeting`` as an ``lcmt_manta_handshake`` (the LCM seam's)."""
    return hello_message(greeting.hello, greeting.peer_run_id, greeting.reply, greeting.status)


def greeting_from_message(msg: lcmt_manta_handshake) -> Greeting:
    """The Greeting of an ``lcmt_manta_handshake``; SeamError as ``hello_from_message``."""
    return Greeting(hello_from_message(msg), msg.peer_run_id, bool(msg.reply), msg.status)


def mismatches(mine: Hello, theirs: Hello) -> list[str]:
    """How ``theirs`` does not match ``mine`` (a 0 duration or step is not fixed: matches)."""
    problems = []
    if mine.duration and theirs.duration and mine.duration != theirs.duration:
        problems.append(
            f"duration {theirs.duration:g} s there, {mine.duration:g} s here (--duration)"
        )
    if mine.clock_mode != theirs.clock_mode:
        problems.append(f"clock {theirs.clock_mode} there, {mine.clock_mode} here (--wall-clock)")
    elif (
        mine.clock_mode == "lockstep"
        and mine.time_step
        and theirs.time_step
        and mine.time_step != theirs.time_step
    ):
        problems.append(
            f"time_step {theirs.time_step:g} s there, {mine.time_step:g} s here "
            "(the lockstep clock)"
        )
    return problems


class Handshake:
    """One side's part of the handshake (its ``Link`` feeds it every handshake message).

    Attributes:
        mine: this side's Hello.
        peer: the peer's Hello once paired, else None.
        confirmed: the peer has named this side back (the handshake is done when both
            ``peer`` and ``confirmed``).
        error: set when the handshake cannot go on (the Link raises it).
    """

    def __init__(self, mine: Hello, publish, url: str, medium: Medium = LCM_MEDIUM):
        """``publish(greeting)`` sends a Greeting; ``url`` names where it runs and ``medium``
        what kind of place that is, in messages."""
        self.mine, self._publish, self.url, self.medium = mine, publish, url, medium
        self.peer: Hello | None = None
        self.confirmed = False
        self.error: SeamError | None = None
        self.peer_status = ""
        self._turned_away: set[str] = set()

    @property
    def done(self) -> bool:
        return self.peer is not None and self.confirmed

    def send(self, reply: bool = False, status: str = "") -> None:
        """Publishes this side's Hello (a request, a reply, or with ``status`` its end)."""
        peer = self.peer.run_id if self.peer is not None else ""
        self._publish(Greeting(self.mine, peer, reply or bool(status), status))

    def _fail(self, text: str) -> None:
        if self.error is None:
            self.error = SeamError(f"{self.mine.role}: {text}")

    def receive(self, msg: Greeting) -> None:
        """Handles one handshake message and answers it if it is a request (after pairing, so
        that the answer names the new peer)."""
        theirs = msg.hello
        if theirs.run_id == self.mine.run_id:  # our own, looped back by udpm
            return
        try:
            self._handle(msg, theirs)
        finally:
            if not msg.reply:  # every request gets an answer: the sender learns of us
                self.send(reply=True)

    def _handle(self, msg, theirs: Hello) -> None:
        mine = self.mine
        if self.peer is not None and theirs.run_id == self.peer.run_id:
            self._from_peer(msg, theirs)
            return
        if msg.status:  # the end of a side that is not ours
            return
        if self.peer is not None:  # paired: anyone else is turned away
            if theirs.run_id not in self._turned_away:
                self._turned_away.add(theirs.run_id)
                warn(
                    f"{mine.role}: a second {theirs.role} on {self.url}: {theirs.describe()}; "
                    f"it is turned away, this run goes on with {self.peer.describe()}"
                )
            return
        if theirs.role == mine.role:
            self._fail(
                f"another {mine.role} is on {self.url}: {theirs.describe()}; two "
                f"{mine.role}s cannot share {self.medium.one}: {self.medium.remedy}"
            )
            return
        if msg.peer_run_id not in ("", mine.run_id):
            self._fail(
                f"{theirs.describe()} on {self.url} is paired with the {mine.role} "
                f"{msg.peer_run_id} already: a second {mine.role} on this "
                f"{self.medium.name}? {self.medium.remedy}"
            )
            return
        problems = mismatches(mine, theirs)
        if problems:
            self._fail(
                f"{theirs.describe()} does not match this {mine.role}: "
                f"{'; '.join(problems)}; start both sides with the same scenario, "
                "--duration and --wall-clock setting"
            )
            return
        self.peer = theirs
        self._from_peer(msg, theirs)

    def _from_peer(self, msg, theirs: Hello) -> None:
        if msg.peer_run_id == self.mine.run_id:
            self.confirmed = True
        if msg.status and not self.peer_status:
            self.peer_status = msg.status
            if msg.status.startswith("failed"):
                self._fail(f"the {theirs.role} {theirs.run_id} {msg.status}")
            elif msg.status.startswith("stopped") and self.error is None:
                self.error = PeerStopped(f"the {theirs.role} {msg.status}")
