"""The station alone, in its own process (``manta-drake station``): ``run_station``
shakes hands with the controller, publishes the sensors and reads the controller's
commands over LCM (clipped to what the servos and the pump can do), in lockstep or on the
wall clock."""

from __future__ import annotations

import time

import numpy as np

from manta_drake.model.robot_params import NUM_JOINTS
from manta_drake.seam.channels import (
    CHANNEL_BY_NAME,
    CLOCK,
    fix_inputs,
    station_channels,
)
from manta_drake.seam.errors import Incidents, PeerStopped, SeamError, warn
from manta_drake.seam.handshake import failure_status, hello_for
from manta_drake.seam.limits import Guard
from manta_drake.seam.link import (
    DEFAULT_STARTUP_TIMEOUT_S,
    DEFAULT_TIMEOUT_S,
    DEFAULT_URL,
    STALE_AFTER_S,
    Link,
)
from manta_drake.seam.result import SeamResult
from manta_drake.seam.schedule import (
    BEFORE_START_TIME,
    BEFORE_START_UTIME,
    advance_to,
    exchange_schedule,
)
from manta_drake.simulate import make_simulator
from manta_drake.wiring.station import build_station, start_command


def initial_commands(scenario) -> dict[str, np.ndarray]:
    """What the station holds before the first command: the start stance at rest and the
    initial balloon fill (a robot's servos hold their pose until commanded)."""
    return {
        "desired_state": start_command(scenario),
        "balloon_command": np.array([scenario.balloon.initial_fill]),
    }


def _body_indices(handles):
    """Where the body's quaternion and position start in the plant state (None: welded)."""
    body = handles.plant_handles.body
    if not body.is_floating_base_body():
        return None
    q0 = body.floating_positions_start()
    return q0, q0 + 4


def run_station(
    scenario,
    url: str = DEFAULT_URL,
    wall_clock: bool = False,
    timeout: float = DEFAULT_TIMEOUT_S,
    startup_timeout: float = DEFAULT_STARTUP_TIMEOUT_S,
    progress: bool = False,
) -> SeamResult:
    """Runs the station of ``scenario`` alone against a controller over LCM.

    It first shakes hands with the controller (``manta_drake.seam.handshake``: the same
    duration and clock mode, one station and one controller on the URL). The commands it
    receives pass ``Guard.for_station`` before they reach the servos and the pump: angles
    and rates beyond the plant's joint limits are clipped, a non-finite value is replaced
    by the last good command; each kind is named once per channel on stderr and all are
    counted in the result (``incidents``). In lockstep it first sends each sensor's value
    from before its ``Simulator.Initialize`` (stamped ``BEFORE_START_UTIME``), what the
    single diagram's initialization events read.

    Args:
        scenario: a validated Scenario (its duration is the run's).
        url: the LCM URL (the controller must use the same), or a transport (``Link``).
        wall_clock: paced to real time with the latest command, instead of lockstep.
        timeout: lockstep: give up after this long without the awaited command [s].
        startup_timeout: the same for the handshake and the first command (the controller
            may start later).
        progress: print the simulated time on stderr every second of it.

    Returns:
        SeamResult; its log has ``t``, ``joint_angles``, ``joint_velocities`` (every
        plant step and the end, as the single diagram logs them), ``body_xyz``,
        ``body_quat_wxyz``, and ``t_<port>``/``<port>`` for every vector sensor as
        published (``depth``, ``balloon_volume``, ``battery``, ``electrical_power``).
        ``stopped`` says why it ended early when the scenario ended it (the battery at its
        cut-off).

    Raises:
        SeamError: the handshake failed, or the controller was silent for ``timeout`` s
            (lockstep).
    """
    station, handles = build_station(scenario)
    sends, reads = station_channels(station)
    incidents = Incidents("station")
    hello = hello_for("station", scenario, wall_clock, sends)
    link = Link(
        url,
        reads,
        "station",
        lockstep=not wall_clock,
        sticky=(CLOCK.name,),
        incidents=incidents,
        hello=hello,
    )
    simulator = make_simulator(station, scenario)
    guard = _hold_initial_commands(scenario, simulator, handles, reads, incidents)
    # Lockstep: the sensors before initialization, encoded now (the messages copy the values),
    # for the controller's initialization events (``BEFORE_START_UTIME``).
    before_start = {} if wall_clock else _sensors_before_start(simulator, link, sends)
    simulator.Initialize()
    if progress:
        warn(
            f"station: {scenario.name}, {_mode(wall_clock)}, run {hello.run_id}, waiting for "
            f"the controller on {link.url}"
        )
    try:
        peer = _shake_hands(link, reads, startup_timeout)
        loop = _StationLoop(
            scenario,
            simulator,
            handles,
            link,
            guard,
            sends,
            reads,
            wall_clock=wall_clock,
            timeout=timeout,
            startup_timeout=startup_timeout,
        )
        result = loop.run(progress, before_start)
    except PeerStopped as e:
        raise SeamError(f"station: {e}") from None  # a controller has no reason to stop early
    except BaseException as e:
        link.say_goodbye(failure_status(e))
        raise
    link.say_goodbye(f"stopped {result.stopped}" if result.stopped else "finished")
    result.run_id, result.peer_run_id = hello.run_id, peer.run_id
    result.incidents = incidents.counts
    return result


def _shake_hands(link: Link, reads, startup_timeout: float):
    """The controller's handshake (its peer), checked to publish every command read."""
    peer = link.shake_hands(startup_timeout)
    missing = [c.name for c in reads if c.name not in peer.channels]
    if missing:
        raise SeamError(
            f"station: {peer.describe()} does not publish {', '.join(missing)}, "
            "which this station reads (is the water on in its scenario?)"
        )
    return peer


def _mode(wall_clock: bool) -> str:
    return "wall-clock" if wall_clock else "lockstep"


def _hold_initial_commands(scenario, simulator, handles, reads, incidents: Incidents) -> Guard:
    """Fixes the station's command inputs at ``initial_commands`` (what it holds until the
    first command) and returns the guard that screens the commands against them."""
    station, context = simulator.get_system(), simulator.get_mutable_context()
    held = initial_commands(scenario)
    guard = Guard.for_station(handles.plant_handles, held, incidents)
    for channel in reads:
        station.GetInputPort(channel.port).FixValue(context, held[channel.port])
    return guard


def _sensors_before_start(simulator, link: Link, sends) -> dict:
    """Each sensor channel's message of its value before ``Simulator.Initialize``, stamped
    ``BEFORE_START_TIME``."""
    station, context = simulator.get_system(), simulator.get_mutable_context()
    return {
        c.name: link.message(c, BEFORE_START_TIME, station.GetOutputPort(c.port).Eval(context))
        for c in sends
        if not c.clock
    }


class _StationLoop:
    """The station's exchanges, after the handshake (see ``run_station``): the schedule,
    the log and, on the wall clock, the pacing and the controller's silence."""

    def __init__(
        self,
        scenario,
        simulator,
        handles,
        link,
        guard,
        sends,
        reads,
        *,
        wall_clock: bool,
        timeout: float,
        startup_timeout: float,
    ):
        self.scenario, self.simulator, self.link, self.guard = scenario, simulator, link, guard
        self.sends, self.wall_clock = sends, wall_clock
        self.timeout, self.startup_timeout = timeout, startup_timeout
        self.station, self.context = simulator.get_system(), simulator.get_mutable_context()
        self.schedule = exchange_schedule(
            scenario.duration, {c.name: c.period(scenario) for c in sends + reads}
        )
        self.sending = {c.name for c in sends}
        self.reading = {c.name for c in reads}
        self.body = _body_indices(handles)
        # The joints' true state, as the single diagram logs it (``measured_joint_state`` is
        # the servo bus's quantized reading when the scenario has one).
        self.selector = handles.systems["joint_state_selector"]
        self.selector_context = self.selector.GetMyContextFromRoot(self.context)
        self.state_port = self.station.GetOutputPort("plant_state")
        logged = [c for c in sends if c.codec == "vector"]  # sensors logged as sent
        self.log: dict[str, list] = {
            "t": [],
            "joint_angles": [],
            "joint_velocities": [],
            "body_xyz": [],
            "body_quat_wxyz": [],
            **{k: [] for c in logged for k in (f"t_{c.port}", c.port)},
        }
        self.logged = {c.name for c in logged}
        self.wall_start: float | None = None  # the wall time of t = 0
        self.last_command = time.monotonic()  # wall clock: the newest command's arrival
        self.silent_warned = False

    def run(self, progress: bool, before_start: dict) -> SeamResult:
        """Every exchange of the schedule until the scenario ends (``before_start``:
        channel -> its message stamped ``BEFORE_START_UTIME``, sent first in lockstep)."""
        next_progress = 1.0
        stopped = ""
        exchanges = 0
        for ex in self.schedule:
            stopped = advance_to(self.simulator, ex.time)
            if stopped:  # the scenario's own end (the battery at its cut-off)
                break
            exchanges += 1
            self._exchange(ex, before_start)
            if progress and ex.time >= next_progress:
                warn(f"station: t = {ex.time:.1f} s")
                next_progress += 1.0
        return self._finish(stopped, exchanges)

    def _exchange(self, ex, before_start: dict) -> None:
        """One exchange time: the sensors due published, the state logged, the commands due
        taken (lockstep) or the newest ones (wall clock), paced to the wall clock."""
        if not self.wall_clock:
            self.link.advance_floor(ex.utime)
        if self.wall_start is None:  # before t = 0's samples, in stamp order
            for name, msg in before_start.items():
                self.link.publish(name, msg, BEFORE_START_UTIME)
        self._publish_sensors(ex)
        if CLOCK.name in ex.channels:
            self._record(ex.time)
        wanted = {name: ex.utime for name in ex.channels if name in self.reading}
        if wanted and not self.wall_clock:
            self._take_commands(ex, wanted)
        elif wanted:  # wall clock: the newest command, whatever its stamp
            self._take_newest_commands(ex, wanted)
        if self.wall_start is None:
            self.wall_start = time.monotonic() - (ex.time if self.wall_clock else 0.0)
        if self.wall_clock:  # paced: sleep while ahead of the wall clock
            ahead = self.wall_start + ex.time - time.monotonic()
            if ahead > 1e-3:
                time.sleep(ahead)

    def _publish_sensors(self, ex) -> None:
        """Publishes the sensors due at ``ex`` (and logs the logged ones as sent)."""
        for name in ex.channels:
            if name in self.sending:
                channel = CHANNEL_BY_NAME[name]
                value = self.station.GetOutputPort(channel.port).Eval(self.context)
                self.link.publish(name, self.link.message(channel, ex.time, value), ex.utime)
                if name in self.logged:
                    self.log[f"t_{channel.port}"].append(ex.time)
                    self.log[channel.port].append(np.array(value, dtype=float))

    def _record(self, t: float) -> None:
        """Logs the joints' true state and the body's pose at ``t``."""
        x = self.selector.get_output_port().Eval(self.selector_context)
        self.log["t"].append(t)
        self.log["joint_angles"].append(x[:NUM_JOINTS].copy())
        self.log["joint_velocities"].append(x[NUM_JOINTS:].copy())
        if self.body is not None:
            s = self.state_port.Eval(self.context)
            self.log["body_quat_wxyz"].append(s[self.body[0] : self.body[1]].copy())
            self.log["body_xyz"].append(s[self.body[1] : self.body[1] + 3].copy())

    def _take_commands(self, ex, wanted: dict) -> None:
        """Lockstep: waits for the commands stamped ``ex``'s time and fixes them."""
        started = self.wall_start is not None  # else the controller may still be building
        got = self.link.wait_for(
            lambda: self.link.take(wanted),
            self.timeout if started else self.startup_timeout,
            self._on_stale if started else (lambda waited: None),
            self._on_timeout,
        )
        fix_inputs(self.station, self.context, self.guard.screen(got, ex.time))

    def _take_newest_commands(self, ex, wanted: dict) -> None:
        """Wall clock: fixes the newest commands (t = 0 waits for a first one); says once
        when the controller has been silent for ``STALE_AFTER_S``."""
        link = self.link
        if self.wall_start is None:  # hold t = 0 until a controller is there
            link.wait_for(
                lambda: any(link.inbox[n] for n in wanted) or None,
                self.startup_timeout,
                lambda waited: None,
                self._on_timeout,
            )
        link.drain()
        link.acknowledge_all()  # nothing is re-sent on the wall clock
        got = {name: msg for name in wanted if (msg := link.latest(name)) is not None}
        fix_inputs(self.station, self.context, self.guard.screen(got, ex.time))
        if got:
            self.last_command, self.silent_warned = time.monotonic(), False
        elif time.monotonic() - self.last_command > STALE_AFTER_S and not self.silent_warned:
            self.silent_warned = True
            warn(
                f"station: no command from the controller for {STALE_AFTER_S:g} s at "
                f"t = {ex.time:.3f} s; holding the last one"
            )

    def _on_stale(self, waited) -> None:
        warn(
            f"station: no command from the controller for {waited:.1f} s at "
            f"t = {self.context.get_time():.3f} s; waiting (gives up after {self.timeout:g} s)"
        )

    def _on_timeout(self, waited) -> SeamError:
        skipped = self.link.incidents.count(kind="malformed")
        return SeamError(
            f"station: no command for t = {self.context.get_time():.3f} s within "
            f"{waited:.1f} s; is `manta-drake controller` running with the same scenario, "
            f"{self.link.transport.medium.option} and --wall-clock setting?"
            + (f" ({skipped} malformed messages skipped)" if skipped else "")
        )

    def _finish(self, stopped: str, exchanges: int) -> SeamResult:
        """Advances to the end (unless the scenario stopped it), logs the last state and
        returns the result."""
        if not stopped:
            stopped = advance_to(self.simulator, self.scenario.duration)
        t_end = float(self.context.get_time())
        if stopped:
            stopped = f"at t = {t_end:.3f} s: {stopped}"
            warn(f"station: stopped {stopped}")
        self._record(t_end)
        wall = time.monotonic() - self.wall_start if self.wall_start is not None else 0.0
        arrays = {k: np.array(v) for k, v in self.log.items() if len(v)}
        for c in self.sends:  # one value a sample: a 1-D array, as log.npz has the depth
            if c.size == 1 and c.port in arrays:
                arrays[c.port] = arrays[c.port].reshape(-1)
        return SeamResult(
            "station",
            _mode(self.wall_clock),
            self.link.url,
            t_end,
            wall,
            exchanges,
            self.link.resends,
            arrays,
            stopped=stopped,
        )
