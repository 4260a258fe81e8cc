"""The exchange schedule: when the two sides meet (every plant step and every sample time
of a channel, as Drake computes them), and how a side steps up to a meeting."""

from __future__ import annotations

import dataclasses as dc

from pydrake.systems.analysis import SimulatorStatus

from manta_drake.seam.errors import SeamError
from manta_drake.seam.messages import to_utime

# Lockstep: the stamp of the station's sensor values from before its Simulator initializes,
# one microsecond before t = 0. In the single diagram every initialization event reads the
# state from before initialization (as all updates at a time read the state from before
# them), so an estimator that seeds itself from its sensor at initialization sees the
# sensor's output before the sensor's own initialization; the controller alone gets these
# values for its Initialize, and t = 0's for its first updates.
BEFORE_START_UTIME = -1
BEFORE_START_TIME = BEFORE_START_UTIME / 1e6


def sample_times(period: float, duration: float) -> list[float]:
    """The times of a periodic event (offset 0) in [0, duration), bit for bit as Drake's
    ``LeafSystem`` computes them: ``j * period`` in floating point. (3 * 0.2 is
    0.6000000000000001, not the plant's step 600 * 0.001 = 0.6.)"""
    if not period > 0:
        raise SeamError(f"a channel's period must be > 0, got {period}")
    times, j = [], 0
    while j * period < duration:
        times.append(j * period)
        j += 1
    return times


@dc.dataclass(frozen=True)
class Exchange:
    """One meeting of the two sides: at ``time`` the channels ``channels`` are due."""

    time: float
    channels: tuple[str, ...]

    @property
    def utime(self) -> int:
        return to_utime(self.time)


def exchange_schedule(duration: float, periods: dict[str, float]) -> list[Exchange]:
    """Every time in [0, duration) at which some channel is due, with the due channels.

    Args:
        duration: the run's length [s] (events at ``duration`` are not handled, as in
            ``Simulator.AdvanceTo(duration)``).
        periods: channel name -> period [s].

    Returns:
        Exchanges in increasing time; times equal as floats are one exchange.
    """
    due: dict[float, list[str]] = {}
    for name, period in periods.items():
        for t in sample_times(period, duration):
            due.setdefault(t, []).append(name)
    return [Exchange(t, tuple(sorted(due[t]))) for t in sorted(due)]


def advance_to(simulator, t: float) -> str:
    """``simulator.AdvanceTo(t)`` unless the context is already at ``t``: AdvanceTo
    first handles the update events pending at the current time, so calling it at
    ``t`` would run ``t``'s updates before the inputs for ``t`` are fixed.

    Returns:
        "" or, when a System ended the run before ``t`` (the battery at its cut-off),
        its reason.
    """
    if t > simulator.get_context().get_time():
        status = simulator.AdvanceTo(t)
        if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
            return status.message() or "a system ended the run"
    return ""
