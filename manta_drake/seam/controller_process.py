"""The controller alone, in its own process (``manta-drake controller``): ``run_controller``
commands a station (or the robot) over LCM, in lockstep with the station's time or on
this machine's clock."""

from __future__ import annotations

import functools
import time

import numpy as np

from manta_drake.modalities import estimator_outputs
from manta_drake.model.robot_params import NUM_JOINTS
from manta_drake.seam.channels import (
    CHANNELS,
    CLOCK,
    controller_channels,
    fix_inputs,
    monitor_channels,
    unexchanged_reads,
)
from manta_drake.seam.errors import Incidents, PeerStopped, SeamError, warn
from manta_drake.seam.failsafe import DEFAULT_FAILSAFE_AFTER_S, Failsafe
from manta_drake.seam.handshake import failure_status, hello_for
from manta_drake.seam.limits import Guard
from manta_drake.seam.link import (
    DEFAULT_STARTUP_TIMEOUT_S,
    DEFAULT_TIMEOUT_S,
    DEFAULT_URL,
    RESEND_PERIOD_S,
    Link,
)
from manta_drake.seam.messages import to_utime
from manta_drake.seam.plant_step_tick import controller_with_tick
from manta_drake.seam.result import SeamResult
from manta_drake.seam.schedule import (
    BEFORE_START_UTIME,
    advance_to,
    exchange_schedule,
    sample_times,
)
from manta_drake.simulate import make_simulator
from manta_drake.wiring.controller import build_controller

# How far (plant steps) the lockstep controller may run ahead of the station: enough to
# overlap the two processes' work, few enough messages in flight for the sockets.
MAX_LEAD_STEPS = 4
# The controller's outputs logged at every command (those it has): what it decided and the
# estimates it decided on.
MONITORED_OUTPUTS = (
    "cpg_params",
    "z_hat",
    "s_hat",
    "detector_status",
    "behaviour_weights",
    "heading_trim",
    *estimator_outputs(),
    "balloon_command",
)


class StationLog:
    """The station's channels the controller has no port for (the balloon volume, the
    battery, the electrical power), screened and logged as ``t_<port>`` and ``<port>``.

    In lockstep every sample is logged: before the controller publishes its commands for
    tau it has every sample stamped before tau (``complete_before``), so its commands still
    acknowledge only what it has. On the wall clock, what arrives.
    """

    def __init__(self, channels, link: Link, guard: Guard, scenario):
        self.channels, self.link, self.guard = list(channels), link, guard
        # The sample times as the station computes them (j * period), by stamp.
        self.expected = {
            c.name: {to_utime(t): t for t in sample_times(c.period(scenario), scenario.duration)}
            for c in self.channels
        }
        self._stamps = {name: sorted(times) for name, times in self.expected.items()}
        self._next = {c.name: 0 for c in self.channels}
        self.log: dict[str, tuple[list[float], list[np.ndarray]]] = {
            c.name: ([], []) for c in self.channels
        }

    def _take(self, channel, stamp) -> None:
        value = self.link.monitored[channel.name].pop(stamp)
        t = self.expected[channel.name].get(stamp, stamp / 1e6)
        value = self.guard.screen_one(channel, value, t)
        times, values = self.log[channel.name]
        times.append(t)
        values.append(np.array(value, dtype=float))

    def complete_before(self, utime: int) -> bool:
        """Logs the samples that have arrived in stamp order; True once every sample stamped
        before ``utime`` is logged."""
        complete = True
        for c in self.channels:
            stamps, box = self._stamps[c.name], self.link.monitored[c.name]
            i = self._next[c.name]
            while i < len(stamps) and stamps[i] < utime and stamps[i] in box:
                self._take(c, stamps[i])
                i += 1
            self._next[c.name] = i
            complete = complete and (i == len(stamps) or stamps[i] >= utime)
        return complete

    def take_arrived(self) -> None:
        """Logs whatever has arrived, in stamp order (the wall clock; the end of a lockstep
        run); a re-sent duplicate of a logged sample is dropped."""
        for c in self.channels:
            logged = self._stamps_logged(c)
            for stamp in sorted(self.link.monitored[c.name]):
                if stamp > BEFORE_START_UTIME and (logged is None or stamp > logged):
                    self._take(c, stamp)
                    logged = stamp
                else:
                    self.link.monitored[c.name].pop(stamp)

    def _stamps_logged(self, channel):
        times = self.log[channel.name][0]
        return to_utime(times[-1]) if times else None

    def arrays(self) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        for c in self.channels:
            times, values = self.log[c.name]
            if times:
                out[f"t_{c.port}"] = np.array(times)
                samples = np.array(values)
                out[c.port] = samples.reshape(-1) if c.size == 1 else samples
        return out


def run_controller(
    scenario,
    url: str = DEFAULT_URL,
    wall_clock: bool = False,
    timeout: float = DEFAULT_TIMEOUT_S,
    startup_timeout: float = DEFAULT_STARTUP_TIMEOUT_S,
    progress: bool = False,
    failsafe_after: float = DEFAULT_FAILSAFE_AFTER_S,
) -> SeamResult:
    """Runs the controller of ``scenario`` alone against a station over LCM (or ROS 2: a
    transport in ``url``).

    It first shakes hands with the station (``manta_drake.seam.handshake``), and checks
    that the station publishes every sensor it reads. Lockstep: at each exchange time tau
    it publishes its commands for tau (they depend on its state at tau only, not on tau's
    sensors: ``build_controller`` has no direct feedthrough; with one it would wait
    first), then waits for the sensors due at tau and fixes them before advancing past
    tau. So it runs ahead of the station, at most ``MAX_LEAD_STEPS`` plant steps (it
    watches the station's clock channel), and the station rarely waits. It initializes
    on the station's sensor values from before the station's initialization (stamped
    ``BEFORE_START_UTIME``), as the single diagram does, and says on stderr if one of its
    periodic readers reads a sensor between that sensor's exchanges
    (``unexchanged_reads``: the run would then differ from the single diagram).

    Every reading passes ``Guard.for_controller`` first: one outside its physical range
    is treated as a dropped reading (NaN depth: the estimator holds), a non-finite or
    impossible joint state or camera pose keeps the last good one; each kind is named
    once per channel on stderr, and all are counted (``incidents``).

    Args:
        scenario: a validated Scenario (the station's).
        url: the LCM URL (the station's), or a transport (``Link``).
        wall_clock: run on this machine's clock with the latest sensor messages (as on
            the robot), instead of lockstep with the station's time.
        timeout: give up after the station has been silent this long [s]; meanwhile it
            commands the safe state (``manta_drake.seam.failsafe``) and stderr says so.
        startup_timeout: the same for the handshake and the first message (the station
            may start later).
        progress: print the controller's time on stderr every second of it.
        failsafe_after: on the wall clock, the silence [s] after which it commands the safe
            state (lockstep: ``STALE_AFTER_S``).

    Returns:
        SeamResult; its log has ``t_command`` and ``commanded_joint_angles`` (the
        desired angles sent at every plant step) and, where the controller has them, the
        ``MONITORED_OUTPUTS`` (``cpg_params``, ``z_hat``, ``s_hat``, ``detector_status``,
        ``behaviour_weights``, ``heading_trim``, the modalities' estimates,
        ``balloon_command``) at the same times; and
        ``t_<port>``, ``<port>`` of the station's channels it has no port for
        (``balloon_volume``, ``battery``, ``electrical_power``), as received.

    Raises:
        SeamError: the handshake failed, or the station was silent for ``timeout`` s (then
            with ``result``: what it did until then, its failsafe in its metrics).
    """
    run = _ControllerRun(scenario, url, wall_clock, timeout)
    if progress:
        warn(
            f"controller: {scenario.name}, {run.mode}, run {run.hello.run_id}, waiting for the "
            f"station on {run.link.url}"
        )
    return run.run(startup_timeout, progress, failsafe_after)


class _ControllerRun:
    """One run of the controller against a station (see ``run_controller``): its diagram,
    link, guard, failsafe and log, and the exchanges in lockstep or on the wall clock."""

    def __init__(self, scenario, url, wall_clock: bool, timeout: float):
        self.scenario, self.wall_clock, self.timeout = scenario, wall_clock, timeout
        controller, _ = build_controller(scenario)
        self.controller = controller_with_tick(controller, scenario.time_step)
        self.sends, self.reads = controller_channels(self.controller)
        self.incidents = Incidents("controller")
        self.hello = hello_for("controller", scenario, wall_clock, self.sends)
        self.link = self._open_link(url)
        self.guard = Guard.for_controller(scenario, self.incidents)
        self.simulator = make_simulator(self.controller, scenario)
        self.context = self.simulator.get_mutable_context()
        self.monitors = [p for p in MONITORED_OUTPUTS if self.controller.HasOutputPort(p)]
        self.log: dict[str, list] = {
            "t_command": [],
            "commanded_joint_angles": [],
            **{p: [] for p in self.monitors},
        }
        self.mode = "wall-clock" if wall_clock else "lockstep"
        self.last_t = 0.0  # the last command's time
        self.station_log: StationLog | None = None
        if not wall_clock:  # a reader between exchanges: the split run is not the single diagram
            for line in unexchanged_reads(self.controller, scenario):
                warn(f"controller: {line}; this lockstep run will differ from the single diagram")
        self.failsafe = Failsafe(scenario, self.link, self.sends, lockstep=not wall_clock)

    def _open_link(self, url) -> Link:
        """The link, subscribed to what the controller reads and to every station channel
        it might log: the station's first samples may arrive right after the handshake."""
        loggable = [c for c in CHANNELS if c.sender == "station" and c not in self.reads]
        return Link(
            url,
            self.reads + loggable,
            "controller",
            lockstep=not self.wall_clock,
            incidents=self.incidents,
            monitor=[c.name for c in loggable],
            hello=self.hello,
        )

    def run(self, startup_timeout: float, progress: bool, failsafe_after: float) -> SeamResult:
        """Shakes hands, runs every exchange and says goodbye; the result (a failure's
        SeamError carries what it did until then, when its failsafe acted)."""
        stopped = ""
        try:
            peer = self._shake_hands(startup_timeout)
            channels = monitor_channels(self.controller, peer.channels)
            self.station_log = StationLog(channels, self.link, self.guard, self.scenario)
            paired_at = time.monotonic()
            try:
                exchanges, wall = self._exchanges(startup_timeout, progress, failsafe_after)
            except PeerStopped as e:  # the station ended the run (its battery): so does this side
                stopped = str(e)
                warn(f"controller: {stopped}; stopping too")
                exchanges, wall = len(self.log["t_command"]), time.monotonic() - paired_at
            self.station_log.take_arrived()
        except BaseException as e:
            self.link.say_goodbye(failure_status(e))
            if isinstance(e, SeamError) and self.failsafe.events:  # what it did, for its metrics
                e.result = self.result(len(self.log["t_command"]), 0.0, failed=str(e))
            raise
        self.link.say_goodbye("finished")
        return self.result(exchanges, wall, stopped=stopped, peer_run_id=peer.run_id)

    def _shake_hands(self, startup_timeout: float):
        """The station's handshake (its peer), checked to publish every sensor read."""
        peer = self.link.shake_hands(startup_timeout)
        missing = [c.name for c in self.reads if c.name not in peer.channels]
        if missing:
            raise SeamError(
                f"controller: {peer.describe()} does not publish "
                f"{', '.join(missing)}, which this controller reads (has its "
                "scenario the same water and camera settings?)"
            )
        return peer

    def _exchanges(self, startup_timeout: float, progress: bool, failsafe_after: float):
        """(number of exchanges, wall time) of the run on the wall clock or in lockstep."""
        if self.wall_clock:
            wall_start, exchanges = self._run_wall_clock(startup_timeout, progress, failsafe_after)
            return exchanges, time.monotonic() - wall_start
        exchanges, wall = self._run_lockstep(startup_timeout, progress)
        _linger(self.link)
        return exchanges, wall

    def command(self, t: float) -> None:
        """Publishes the commands for ``t`` (releasing a failsafe) and logs them."""
        if self.failsafe.active:
            self.failsafe.release("resumed")
            self.link.holding = None
        for channel in self.sends:
            value = self.controller.GetOutputPort(channel.port).Eval(self.context)
            self.link.publish(channel.name, self.link.message(channel, t, value), to_utime(t))
            if channel.port == "desired_state":
                self.log["t_command"].append(t)
                self.log["commanded_joint_angles"].append(value[:NUM_JOINTS].copy())
        for p in self.monitors:
            self.log[p].append(self.controller.GetOutputPort(p).Eval(self.context).copy())
        self.last_t = t

    def on_stale(self, waited) -> None:
        """Lockstep: the failsafe at the link-loss point."""
        self.failsafe.engage(self.last_t, waited, self.timeout)
        self.link.holding = self.failsafe.hold

    def on_timeout(self, waited) -> SeamError:
        self.failsafe.release("gave up")
        malformed = self.incidents.count(kind="malformed")
        skipped = f" ({malformed} malformed messages skipped)" if malformed else ""
        if self.link.last_arrival is None:
            return SeamError(
                f"controller: nothing from the station within {waited:.1f} s; is "
                "`manta-drake station` running with the same scenario, "
                f"{self.link.transport.medium.option} and --wall-clock setting?"
                f"{skipped}"
            )
        return SeamError(
            f"controller: the station has been silent for {waited:.1f} s "
            f"(last command stamped t = {self.last_t:.3f} s; the safe state "
            f"commanded since); stopped{skipped}"
        )

    def result(self, exchanges, wall, peer_run_id="", **ended) -> SeamResult:
        arrays = {k: np.array(v) for k, v in self.log.items() if len(v)}
        if self.station_log is not None:
            arrays.update(self.station_log.arrays())
        return SeamResult(
            "controller",
            self.mode,
            self.link.url,
            float(self.context.get_time()),
            wall,
            exchanges,
            self.link.resends,
            arrays,
            incidents=self.incidents.counts,
            run_id=self.hello.run_id,
            peer_run_id=peer_run_id,
            failsafe=self.failsafe.metrics(),
            **ended,
        )

    def _run_lockstep(self, startup_timeout: float, progress: bool) -> tuple[int, float]:
        """The controller in lockstep with the station's time (see ``run_controller``).
        Returns (number of exchanges, wall time from the first exchange)."""
        scenario, simulator, controller = self.scenario, self.simulator, self.controller
        schedule = exchange_schedule(
            scenario.duration, {c.name: c.period(scenario) for c in self.sends + self.reads}
        )
        inputs = {c.name for c in self.reads if controller.HasInputPort(c.port)}
        sending = {c.name for c in self.sends}
        wait_first = has_feedthrough(controller, self.reads, self.sends)
        wall_start = None
        next_progress = 1.0
        self._fix_before_start(inputs, startup_timeout)
        for ex in schedule:
            first = wall_start is None
            if not first:
                advance_to(simulator, ex.time)
            self.link.advance_floor(ex.utime)
            commands_due = any(name in sending for name in ex.channels)
            if commands_due and not (first or wait_first):
                self._publish_when_acknowledged(ex)
            wanted = {name: ex.utime for name in ex.channels if name in inputs}
            if first:  # the station is there: its clock at the start
                wanted[CLOCK.name] = ex.utime
            if wanted:
                got = self.link.wait_for(
                    functools.partial(self.link.take, wanted),
                    startup_timeout if first else self.timeout,
                    (lambda waited: None) if first else self.on_stale,
                    self.on_timeout,
                )
            if first:  # on the values from before the station's initialization
                simulator.Initialize()
                wall_start = time.monotonic()
            if wanted:
                fix_inputs(controller, self.context, self.guard.screen(got, ex.time))
            if commands_due and (first or wait_first):
                self._publish_when_acknowledged(ex)
            if progress and ex.time >= next_progress:
                warn(f"controller: t = {ex.time:.1f} s")
                next_progress += 1.0
        if wall_start is None:
            return 0, 0.0
        simulator.AdvanceTo(scenario.duration)
        return len(schedule), time.monotonic() - wall_start

    def _fix_before_start(self, inputs: set, startup_timeout: float) -> None:
        """What its initialization events read: the station's sensors before its
        initialization (stamped ``BEFORE_START_UTIME``)."""
        before_start = {name: BEFORE_START_UTIME for name in inputs}
        if before_start:
            got = self.link.wait_for(
                lambda: self.link.take(before_start),
                startup_timeout,
                lambda waited: None,
                self.on_timeout,
            )
            fix_inputs(
                self.controller, self.context, self.guard.screen(got, 0.0, before_start=True)
            )

    def _publish_when_acknowledged(self, ex) -> None:
        """The commands for ``ex``, once the station's clock is no more than
        ``MAX_LEAD_STEPS`` behind and every logged sample stamped before it has arrived."""
        # Flow control: no further ahead of the station's clock than MAX_LEAD_STEPS; and a
        # command stamped tau says the controller has everything stamped before tau (the
        # station stops re-sending it), so the logged channels' samples come first.
        lead = MAX_LEAD_STEPS * to_utime(self.scenario.time_step)
        link, station_log = self.link, self.station_log
        assert station_log is not None  # made at the handshake
        link.wait_for(
            lambda: (
                True
                if link.newest.get(CLOCK.name, -1) >= ex.utime - lead
                and station_log.complete_before(ex.utime)
                else None
            ),
            self.timeout,
            self.on_stale,
            self.on_timeout,
        )
        self.command(ex.time)

    def _run_wall_clock(
        self, startup_timeout: float, progress: bool, failsafe_after: float
    ) -> tuple[float, int]:
        """The controller on this machine's clock: latest sensor values, a command after
        every plant step of its own time; after ``failsafe_after`` s of silence from the
        station its clock stops and it commands the safe state (``failsafe``) until the
        station is back. Returns (wall start, number of commands)."""
        simulator, link, failsafe = self.simulator, self.link, self.failsafe
        assert self.station_log is not None  # made at the handshake
        h = self.scenario.time_step
        self._fix_first_inputs(startup_timeout)
        simulator.Initialize()
        self.command(0.0)
        wall_start = time.monotonic()
        held_for = 0.0  # wall time spent holding: the controller's clock stops meanwhile
        k, commands, next_progress = 0, 1, 1.0
        holding_since = None
        last_resend = 0.0
        n_steps = round(self.scenario.duration / h)
        assert link.handshake is not None  # the Link is made with this side's hello
        while k < n_steps:
            link.poll(1)
            if link.handshake.peer_status == "finished":  # nothing more to command
                break
            fresh = link.newest_values(c.name for c in self.reads)
            fix_inputs(
                self.controller, self.context, self.guard.screen(fresh, self.context.get_time())
            )
            self.station_log.take_arrived()
            now = time.monotonic()
            assert link.last_arrival is not None  # every input has arrived once (above)
            silent = now - link.last_arrival
            if silent > failsafe_after:  # the clock stops; the safe state instead of the gait
                holding_since, last_resend = self._hold_safe_state(
                    k * h, now, silent, holding_since, last_resend
                )
                continue
            if holding_since is not None:
                failsafe.release("resumed")
                held_for += now - holding_since
                holding_since = None
            k_target = min(int((now - wall_start - held_for) / h), n_steps)
            if k_target > k:
                k = k_target
                simulator.AdvanceTo(k * h)
                link.acknowledge_all()  # re-send (hold) only the newest command
                self.command(k * h)
                commands += 1
                if progress and k * h >= next_progress:
                    warn(f"controller: t = {k * h:.1f} s")
                    next_progress += 1.0
        return wall_start, commands

    def _hold_safe_state(self, t: float, now: float, silent: float, holding_since, last_resend):
        """While the station is silent on the wall clock: the failsafe engaged at ``t`` (once),
        the safe state re-sent every ``RESEND_PERIOD_S``, the run given up after ``timeout``.
        Returns the updated (holding_since, last_resend)."""
        if holding_since is None:
            holding_since = now - silent
            self.failsafe.engage(t, silent, self.timeout)
            last_resend = now
        if silent > self.timeout:
            raise self.on_timeout(silent)
        if now - last_resend > RESEND_PERIOD_S:
            self.failsafe.send(t)
            last_resend = now
        return holding_since, last_resend

    def _fix_first_inputs(self, startup_timeout: float) -> None:
        """Waits for every input's first message and fixes them."""
        start = time.monotonic()
        latest: dict = {}
        while len(latest) < len(self.reads):  # every input once before starting
            self.link.poll(50)
            latest.update(self.link.newest_values(c.name for c in self.reads))
            if time.monotonic() - start > startup_timeout:
                missing = sorted(c.name for c in self.reads if c.name not in latest)
                raise SeamError(
                    f"controller: nothing on {', '.join(missing)} within "
                    f"{startup_timeout:g} s; is `manta-drake station --wall-clock` "
                    f"running with the same scenario and {self.link.transport.medium.option}?"
                )
        fix_inputs(self.controller, self.context, self.guard.screen(latest, 0.0))


def has_feedthrough(controller, inputs, outputs) -> bool:
    """Whether a command port depends directly on a sensor port (then a command for t
    must wait for t's sensors)."""
    return any(
        controller.HasDirectFeedthrough(
            controller.GetInputPort(i.port).get_index(),
            controller.GetOutputPort(o.port).get_index(),
        )
        for i in inputs
        if controller.HasInputPort(i.port)
        for o in outputs
    )


def _linger(link: Link, quiet_s: float = 0.3) -> None:
    """After the last command: while the station still sends (it re-sends while it waits
    for a command it did not get), re-send what it may not have; leave once it has
    been quiet for ``quiet_s``."""
    deadline = time.monotonic() + quiet_s
    last_resend = 0.0
    while time.monotonic() < deadline:
        if link.poll(20):
            deadline = time.monotonic() + quiet_s
            if time.monotonic() - last_resend > RESEND_PERIOD_S:
                link.resend()
                last_resend = time.monotonic()
