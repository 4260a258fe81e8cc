"""The controller's failsafe on link loss, over either transport: when the station has been
silent too long the controller stops commanding the gait and commands the safe state
instead of holding its last command: every fin to the start stance at rest
(``wiring.station.start_command``, what the servos hold before the first command) and the
balloon full, so a robot in the water surfaces.

* Wall clock (as on the robot): after ``--failsafe-after`` seconds of silence (default
  ``DEFAULT_FAILSAFE_AFTER_S``), stamped with the controller's time, which stops meanwhile.
* Lockstep: at the seam's existing link-loss point (``STALE_AFTER_S`` of silence while it
  waits), stamped ``FAILSAFE_UTIME``: 2 us before t = 0, a stamp no lockstep station waits
  for, so a station that was only slow still gets the run's own commands (they were sent
  before) and the run stays the single diagram; a listener that takes the newest message,
  as a driver does, gets the safe state.

Meanwhile the controller re-sends the safe state every ``RESEND_PERIOD_S``, and says so in
one line on stderr. When the station is heard again it says so and resumes where it
stopped; after ``--timeout`` s of silence it exits with status 2 (its metrics record the
failsafe either way: ``Failsafe.events``).
"""

from __future__ import annotations

import dataclasses as dc
import time

import numpy as np

from manta_drake.seam.errors import warn
from manta_drake.seam.messages import to_utime
from manta_drake.seam.schedule import BEFORE_START_UTIME

DEFAULT_FAILSAFE_AFTER_S = 0.5  # s of silence from the station (wall clock)
SAFE_BALLOON_FILL = 1.0  # full: the robot floats up
FAILSAFE_UTIME = BEFORE_START_UTIME - 1  # lockstep: stamped where no exchange waits


def safe_commands(scenario) -> dict[str, np.ndarray]:
    """The safe state by command port: the start stance at rest, the balloon full."""
    from manta_drake.wiring.station import start_command

    return {
        "desired_state": start_command(scenario),
        "balloon_command": np.array([SAFE_BALLOON_FILL]),
    }


@dc.dataclass
class FailsafeEvent:
    """One stretch of failsafe: from the controller's time ``t`` [s], entered after
    ``silent_s`` of silence, for ``lasted_s`` wall seconds; ``ended`` how it ended
    ("resumed", "gave up", or "" while it lasts)."""

    t: float
    silent_s: float
    lasted_s: float = 0.0
    ended: str = ""
    commands_sent: int = 0


class Failsafe:
    """One controller's failsafe: ``engage`` when the station falls silent, ``send`` the safe
    state (every re-send period), ``release`` when it is heard again or the run gives up.

    Args:
        scenario: the controller's scenario (the safe state).
        link: the controller's Link (``publish``, ``message``).
        sends: the command channels it publishes.
        lockstep: lockstep (stamps ``FAILSAFE_UTIME``) or wall clock (its own time).
    """

    def __init__(self, scenario, link, sends, lockstep: bool):
        commands = safe_commands(scenario)
        self.link, self.lockstep = link, lockstep
        self.channels = [(c, commands[c.port]) for c in sends if c.port in commands]
        self.events: list[FailsafeEvent] = []
        self._since: float | None = None

    @property
    def active(self) -> bool:
        return self._since is not None

    def engage(self, t: float, silent_s: float, timeout: float) -> None:
        """Enters the failsafe at the controller's time ``t`` (once: again only after a
        ``release``), says so, and sends the safe state."""
        if self.active:
            return
        self._since = time.monotonic()
        self.events.append(FailsafeEvent(t, silent_s))
        warn(
            f"controller: no message from the station for {silent_s:.1f} s (last command "
            f"stamped t = {t:.3f} s): failsafe, commanding the safe state (the start stance "
            f"at rest, the balloon full) until it is back (gives up after {timeout:g} s)"
        )
        self.send(t)

    def send(self, t: float) -> None:
        """Publishes the safe state, stamped as the module docstring says."""
        utime = FAILSAFE_UTIME if self.lockstep else to_utime(t)
        for channel, value in self.channels:
            self.link.publish(channel.name, self.link.message(channel, utime / 1e6, value), utime)
        if not self.lockstep:
            self.link.acknowledge_all()  # nothing of the gait is re-sent after it
        self.events[-1].commands_sent += 1

    def hold(self) -> bool:
        """What the lockstep controller's Link does instead of a re-send while engaged (its
        ``holding``): True, the safe state sent again; False, the station has been heard
        since the failsafe began: released, and the Link re-sends the run's commands."""
        arrived = self.link.last_arrival
        if arrived is not None and arrived > self._since:
            self.release("resumed")
            self.link.holding = None
            return False
        self.send(self.events[-1].t)
        return True

    def release(self, ended: str) -> None:
        """Leaves the failsafe (``ended``: "resumed" or "gave up"), saying so on resuming."""
        since = self._since
        if since is None:  # not active
            return
        event = self.events[-1]
        event.lasted_s, event.ended = time.monotonic() - since, ended
        self._since = None
        if ended == "resumed":
            warn(
                f"controller: the station is back after {event.lasted_s:.1f} s of failsafe; "
                f"resuming at t = {event.t:.3f} s"
            )

    def metrics(self) -> list[dict]:
        """The events as ``<side>_metrics.json`` holds them (``failsafe``)."""
        return [dc.asdict(e) for e in self.events]
