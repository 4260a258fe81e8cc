"""The station alone, in its own process (``manta-drake station``): ``run_station``
publishes the sensors and reads the controller's commands over LCM, in lockstep or on
the wall clock."""

from __future__ import annotations

import time

import numpy as np

from manta_drake.model.robot_params import NUM_JOINTS
from manta_drake.seam.channels import CHANNEL_BY_NAME, CLOCK, fix_inputs, station_channels
from manta_drake.seam.errors import SeamError, warn
from manta_drake.seam.link import (
    DEFAULT_STARTUP_TIMEOUT_S,
    DEFAULT_TIMEOUT_S,
    DEFAULT_URL,
    STALE_AFTER_S,
    Link,
)
from manta_drake.seam.messages import CODECS
from manta_drake.seam.result import SeamResult
from manta_drake.seam.schedule import advance_to, exchange_schedule
from manta_drake.simulate import make_simulator
from manta_drake.wiring.station import build_station


def initial_commands(scenario) -> dict[str, np.ndarray]:
    """What the station holds before the first command: the start stance at rest and the
    initial balloon fill (a robot's servos hold their pose until commanded)."""
    return {"desired_state": np.concatenate([scenario.initial_joint_angles(),
                                             np.zeros(NUM_JOINTS)]),
            "balloon_command": np.array([scenario.balloon.initial_fill])}


def _body_indices(handles):
    """Where the body's quaternion and position start in the plant state (None: welded)."""
    body = handles.plant_handles.body
    if not body.is_floating_base_body():
        return None
    q0 = body.floating_positions_start()
    return q0, q0 + 4


def run_station(scenario, url: str = DEFAULT_URL, wall_clock: bool = False,
                timeout: float = DEFAULT_TIMEOUT_S,
                startup_timeout: float = DEFAULT_STARTUP_TIMEOUT_S,
                progress: bool = False) -> SeamResult:
    """Runs the station of ``scenario`` alone against a controller over LCM.

    Args:
        scenario: a validated Scenario (its duration is the run's).
        url: the LCM URL (the controller must use the same).
        wall_clock: paced to real time with the latest command, instead of lockstep.
        timeout: lockstep: give up after this long without the awaited command [s].
        startup_timeout: the same for the first command (the controller may start later).
        progress: print the simulated time on stderr every second of it.

    Returns:
        SeamResult; its log has ``t``, ``joint_angles``, ``joint_velocities`` (every
        plant step and the end, as the single diagram logs them), ``body_xyz``,
        ``body_quat_wxyz``, and ``t_depth``/``depth`` as published.

    Raises:
        SeamError: the controller was silent for ``timeout`` s (lockstep).
    """
    station, handles = build_station(scenario)
    sends, reads = station_channels(station)
    link = Link(url, reads, "station", lockstep=not wall_clock, sticky=(CLOCK.name,))
    simulator = make_simulator(station, scenario)
    context = simulator.get_mutable_context()
    held = initial_commands(scenario)
    for channel in reads:
        station.GetInputPort(channel.port).FixValue(context, held[channel.port])
    simulator.Initialize()

    schedule = exchange_schedule(scenario.duration,
                                 {c.name: c.period(scenario) for c in sends + reads})
    sending = {c.name for c in sends}
    reading = {c.name for c in reads}
    body = _body_indices(handles)
    joint_port = station.GetOutputPort("measured_joint_state")
    state_port = station.GetOutputPort("plant_state")
    log = {"t": [], "joint_angles": [], "joint_velocities": [], "body_xyz": [],
           "body_quat_wxyz": [], "t_depth": [], "depth": []}

    def record(t):
        x = joint_port.Eval(context)
        log["t"].append(t)
        log["joint_angles"].append(x[:NUM_JOINTS].copy())
        log["joint_velocities"].append(x[NUM_JOINTS:].copy())
        if body is not None:
            s = state_port.Eval(context)
            log["body_quat_wxyz"].append(s[body[0]:body[1]].copy())
            log["body_xyz"].append(s[body[1]:body[1] + 3].copy())

    def on_stale(waited):
        warn(f"station: no command from the controller for {waited:.1f} s at "
             f"t = {context.get_time():.3f} s; waiting (gives up after {timeout:g} s)")

    def on_timeout(waited):
        return SeamError(
            f"station: no command for t = {context.get_time():.3f} s within {waited:.1f} s; "
            "is `manta-drake controller` running with the same scenario, --lcm URL and "
            "--wall-clock setting?")

    mode = "wall-clock" if wall_clock else "lockstep"
    if progress:
        warn(f"station: {scenario.name}, {mode}, waiting for the controller on {url}")
    wall_start = None
    last_command = time.monotonic()
    silent_warned = False
    next_progress = 1.0
    for ex in schedule:
        advance_to(simulator, ex.time)
        if not wall_clock:
            link.advance_floor(ex.utime)
        for name in ex.channels:
            if name in sending:
                channel = CHANNEL_BY_NAME[name]
                value = station.GetOutputPort(channel.port).Eval(context)
                link.publish(name, CODECS[channel.codec].encode(ex.time, value), ex.utime)
                if channel.port == "depth":
                    log["t_depth"].append(ex.time)
                    log["depth"].append(float(value[0]))
        if CLOCK.name in ex.channels:
            record(ex.time)
        wanted = {name: ex.utime for name in ex.channels if name in reading}
        if wanted and not wall_clock:
            started = wall_start is not None  # else the controller may still be building
            got = link.wait_for(lambda wanted=wanted: link.take(wanted),
                                timeout if started else startup_timeout,
                                on_stale if started else (lambda waited: None), on_timeout)
            fix_inputs(station, context, got)
        elif wanted:  # wall clock: the newest command, whatever its stamp
            if wall_start is None:  # hold t = 0 until a controller is there
                link.wait_for(lambda wanted=wanted: any(link.inbox[n] for n in wanted) or None,
                              startup_timeout, lambda waited: None, on_timeout)
            link.drain()
            link.acknowledge_all()  # nothing is re-sent on the wall clock
            got = {name: msg for name in wanted if (msg := link.latest(name)) is not None}
            fix_inputs(station, context, got)
            if got:
                last_command, silent_warned = time.monotonic(), False
            elif time.monotonic() - last_command > STALE_AFTER_S and not silent_warned:
                silent_warned = True
                warn(f"station: no command from the controller for {STALE_AFTER_S:g} s at "
                     f"t = {ex.time:.3f} s; holding the last one")
        if wall_start is None:
            wall_start = time.monotonic() - (ex.time if wall_clock else 0.0)
        if wall_clock:  # paced: sleep while ahead of the wall clock
            ahead = wall_start + ex.time - time.monotonic()
            if ahead > 1e-3:
                time.sleep(ahead)
        if progress and ex.time >= next_progress:
            warn(f"station: t = {ex.time:.1f} s")
            next_progress += 1.0
    simulator.AdvanceTo(scenario.duration)
    record(scenario.duration)
    wall = time.monotonic() - wall_start if wall_start is not None else 0.0
    arrays = {k: np.array(v) for k, v in log.items() if len(v)}
    return SeamResult("station", mode, url, float(context.get_time()), wall, len(schedule),
                      link.resends, arrays)
