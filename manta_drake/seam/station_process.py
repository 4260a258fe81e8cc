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
    context = simulator.get_mutable_context()
    held = initial_commands(scenario)
    guard = Guard.for_station(handles.plant_handles, held, incidents)
    for channel in reads:
        station.GetInputPort(channel.port).FixValue(context, held[channel.port])
    # Lockstep: the sensors before initialization, encoded now (the messages copy the values),
    # for the controller's initialization events (``BEFORE_START_UTIME``).
    before_start = (
        {}
        if wall_clock
        else {
            c.name: link.message(c, BEFORE_START_TIME, station.GetOutputPort(c.port).Eval(context))
            for c in sends
            if not c.clock
        }
    )
    simulator.Initialize()
    mode = "wall-clock" if wall_clock else "lockstep"
    if progress:
        warn(
            f"station: {scenario.name}, {mode}, run {hello.run_id}, waiting for the "
            f"controller on {link.url}"
        )
    try:
        peer = link.shake_hands(startup_timeout)
        missing = [c.name for c in reads if c.name not in peer.channels]
        if missing:
            raise SeamError(
                f"station: {peer.describe()} does not publish {', '.join(missing)}, "
                "which this station reads (is the water on in its scenario?)"
            )
        result = _station_loop(
            scenario,
            simulator,
            station,
            handles,
            link,
            guard,
            sends,
            reads,
            wall_clock,
            timeout,
            startup_timeout,
            progress,
            before_start,
        )
    except PeerStopped as e:
        raise SeamError(f"station: {e}") from None  # a controller has no reason to stop early
    except BaseException as e:
        link.say_goodbye(failure_status(e))
        raise
    link.say_goodbye(f"stopped {result.stopped}" if result.stopped else "finished")
    result.run_id, result.peer_run_id = hello.run_id, peer.run_id
    result.incidents = incidents.counts
    return result


def _station_loop(
    scenario,
    simulator,
    station,
    handles,
    link,
    guard,
    sends,
    reads,
    wall_clock,
    timeout,
    startup_timeout,
    progress,
    before_start,
) -> SeamResult:
    """The station's exchanges, after the handshake (see ``run_station``); ``before_start``:
    channel -> its message stamped ``BEFORE_START_UTIME``, sent first (lockstep)."""
    context = simulator.get_mutable_context()
    schedule = exchange_schedule(
        scenario.duration, {c.name: c.period(scenario) for c in sends + reads}
    )
    sending = {c.name for c in sends}
    reading = {c.name for c in reads}
    body = _body_indices(handles)
    # The joints' true state, as the single diagram logs it (``measured_joint_state`` is
    # the servo bus's quantized reading when the scenario has one).
    selector = handles.systems["joint_state_selector"]
    selector_context = selector.GetMyContextFromRoot(context)
    state_port = station.GetOutputPort("plant_state")
    logged = [c for c in sends if c.codec == "vector"]  # sensors logged as sent
    log = {
        "t": [],
        "joint_angles": [],
        "joint_velocities": [],
        "body_xyz": [],
        "body_quat_wxyz": [],
        **{k: [] for c in logged for k in (f"t_{c.port}", c.port)},
    }
    logged = {c.name for c in logged}

    def record(t):
        x = selector.get_output_port().Eval(selector_context)
        log["t"].append(t)
        log["joint_angles"].append(x[:NUM_JOINTS].copy())
        log["joint_velocities"].append(x[NUM_JOINTS:].copy())
        if body is not None:
            s = state_port.Eval(context)
            log["body_quat_wxyz"].append(s[body[0] : body[1]].copy())
            log["body_xyz"].append(s[body[1] : body[1] + 3].copy())

    def on_stale(waited):
        warn(
            f"station: no command from the controller for {waited:.1f} s at "
            f"t = {context.get_time():.3f} s; waiting (gives up after {timeout:g} s)"
        )

    def on_timeout(waited):
        skipped = link.incidents.count(kind="malformed")
        return SeamError(
            f"station: no command for t = {context.get_time():.3f} s within {waited:.1f} s; "
            f"is `manta-drake controller` running with the same scenario, "
            f"{link.transport.medium.option} and --wall-clock setting?"
            + (f" ({skipped} malformed messages skipped)" if skipped else "")
        )

    mode = "wall-clock" if wall_clock else "lockstep"
    wall_start = None
    last_command = time.monotonic()
    silent_warned = False
    next_progress = 1.0
    stopped = ""
    exchanges = 0
    for ex in schedule:
        stopped = advance_to(simulator, ex.time)
        if stopped:  # the scenario's own end (the battery at its cut-off)
            break
        exchanges += 1
        if not wall_clock:
            link.advance_floor(ex.utime)
        if wall_start is None:  # before t = 0's samples, in stamp order
            for name, msg in before_start.items():
                link.publish(name, msg, BEFORE_START_UTIME)
        for name in ex.channels:
            if name in sending:
                channel = CHANNEL_BY_NAME[name]
                value = station.GetOutputPort(channel.port).Eval(context)
                link.publish(name, link.message(channel, ex.time, value), ex.utime)
                if name in logged:
                    log[f"t_{channel.port}"].append(ex.time)
                    log[channel.port].append(np.array(value, dtype=float))
        if CLOCK.name in ex.channels:
            record(ex.time)
        wanted = {name: ex.utime for name in ex.channels if name in reading}
        if wanted and not wall_clock:
            started = wall_start is not None  # else the controller may still be building
            got = link.wait_for(
                lambda wanted=wanted: link.take(wanted),
                timeout if started else startup_timeout,
                on_stale if started else (lambda waited: None),
                on_timeout,
            )
            fix_inputs(station, context, guard.screen(got, ex.time))
        elif wanted:  # wall clock: the newest command, whatever its stamp
            if wall_start is None:  # hold t = 0 until a controller is there
                link.wait_for(
                    lambda wanted=wanted: any(link.inbox[n] for n in wanted) or None,
                    startup_timeout,
                    lambda waited: None,
                    on_timeout,
                )
            link.drain()
            link.acknowledge_all()  # nothing is re-sent on the wall clock
            got = {name: msg for name in wanted if (msg := link.latest(name)) is not None}
            fix_inputs(station, context, guard.screen(got, ex.time))
            if got:
                last_command, silent_warned = time.monotonic(), False
            elif time.monotonic() - last_command > STALE_AFTER_S and not silent_warned:
                silent_warned = True
                warn(
                    f"station: no command from the controller for {STALE_AFTER_S:g} s at "
                    f"t = {ex.time:.3f} s; holding the last one"
                )
        if wall_start is None:
            wall_start = time.monotonic() - (ex.time if wall_clock else 0.0)
        if wall_clock:  # paced: sleep while ahead of the wall clock
            ahead = wall_start + ex.time - time.monotonic()
            if ahead > 1e-3:
                time.sleep(ahead)
        if progress and ex.time >= next_progress:
            warn(f"station: t = {ex.time:.1f} s")
            next_progress += 1.0
    if not stopped:
        stopped = advance_to(simulator, scenario.duration)
    t_end = float(context.get_time())
    if stopped:
        stopped = f"at t = {t_end:.3f} s: {stopped}"
        warn(f"station: stopped {stopped}")
    record(t_end)
    wall = time.monotonic() - wall_start if wall_start is not None else 0.0
    arrays = {k: np.array(v) for k, v in log.items() if len(v)}
    for c in sends:  # one value a sample: a 1-D array, as log.npz has the depth
        if c.size == 1 and c.port in arrays:
            arrays[c.port] = arrays[c.port].reshape(-1)
    return SeamResult(
        "station", mode, link.url, t_end, wall, exchanges, link.resends, arrays, stopped=stopped
    )
