"""The channel table: the one place that says what crosses the seam, in which message type
and how often (``CHANNELS``; docs/lcm.md prints it), which channels each side sends and
reads, and how a received message reaches its input port."""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable

from pydrake.systems.framework import Diagram

from manta_drake.modalities import MODALITY_BY_ESTIMATE, READINGS
from manta_drake.seam.messages import CODECS, LcmMessage
from manta_drake.seam.schedule import sample_times

# The period of the controller's EnergyEstimator, the battery's only reader (a test reads
# the built controller's and compares).
_ENERGY_ESTIMATION = MODALITY_BY_ESTIMATE["energy_hat"].estimation
assert _ENERGY_ESTIMATION is not None  # the energy modality is an estimator's
ENERGY_ESTIMATOR_PERIOD_S = _ENERGY_ESTIMATION.period


@dc.dataclass(frozen=True)
class Channel:
    """One LCM channel of the seam.

    Attributes:
        name: the LCM channel.
        port: the station's and the controller's port of that name.
        sender: "station" (a sensor) or "controller" (a command).
        codec: a key of ``CODECS``.
        period: the scenario -> the publishing period [s]: the period of the periodic
            event that reads it on the other side (a sensor's value between those
            events is never read), or the plant step.
        period_text: ``period`` for people (docs/lcm.md).
        clock: the lockstep clock: published at every plant step; the controller
            reads none of its values but its stamps (how far ahead it may run), and
            waits for it at t = 0 (the station is there).
        what: one line for the docs.
        size: a vector channel's length (a message of another length is malformed);
            None for the other codecs, whose decoders check their own shape.
    """

    name: str
    port: str
    sender: str
    codec: str
    period: Callable
    period_text: str
    what: str
    clock: bool = False
    size: int | None = None

    @property
    def lcm_type(self) -> type[LcmMessage]:
        return CODECS[self.codec].lcm_type


def reads_battery(scenario) -> bool:
    """Whether the controller of ``scenario`` has a ``battery`` input: the energy model is on
    and the behaviour tree or the balloon rule reads the charge estimate ``energy_hat``
    (``Scenario.reads_charge_estimate``, the condition build_controller uses)."""
    return scenario.reads_charge_estimate()


def battery_period(scenario) -> float:
    """The battery channel's period: the energy estimator's (100 ms) when the controller reads
    the battery; else max(``time_step``, 10 ms), for monitoring. Why not always 10 ms: the
    estimator's events at j x 0.1 s are not all on the 10 ms grid (3 x 0.1 =
    0.30000000000000004 s, after the plant's step at 0.3 s), so it would read a sample one
    plant step old there."""
    if reads_battery(scenario):
        return ENERGY_ESTIMATOR_PERIOD_S
    return max(scenario.time_step, 0.01)


CHANNELS = (
    Channel(
        "MANTA_MEASURED_JOINT_STATE",
        "measured_joint_state",
        "station",
        "joint_state",
        lambda s: s.time_step,
        "every plant step (`time_step`, 1 ms)",
        "the 16 servos' angles [rad] and rates [rad/s]; the lockstep clock",
        clock=True,
    ),
    Channel(
        "MANTA_DEPTH",
        "depth",
        "station",
        "vector",
        lambda s: 1.0 / s.pressure_sensor.rate_hz,
        "1 / `pressure_sensor.rate_hz` (20 ms)",
        "pressure depth [m] below the surface (1 value, NaN on a dropout); water on",
        size=1,
    ),
    Channel(
        "MANTA_DEPTH_IMAGE",
        "depth_image",
        "station",
        "depth_image",
        lambda s: 1.0 / s.camera.rate_hz,
        "1 / `camera.rate_hz` (200 ms)",
        "the head camera's noisy depth image [m], float32; camera on",
    ),
    Channel(
        "MANTA_CAMERA_POSE",
        "camera_pose",
        "station",
        "pose",
        lambda s: 1.0 / s.camera.rate_hz,
        "1 / `camera.rate_hz` (200 ms)",
        "the camera's pose X_WC (on the robot: IMU attitude + pressure depth); camera on",
    ),
    # The modalities' sensors (manta_drake.modalities), each read at its sample period.
    *(
        Channel(
            r.channel, r.port, "station", "vector", r.period, r.period_text(), r.what, size=r.size
        )
        for r in READINGS
    ),
    Channel(
        "MANTA_BALLOON_VOLUME",
        "balloon_volume",
        "station",
        "vector",
        lambda s: max(s.time_step, 0.01),
        "max(`time_step`, 10 ms)",
        "balloon volume [m^3], for monitoring (the controller logs it); water on",
        size=1,
    ),
    Channel(
        "MANTA_BATTERY",
        "battery",
        "station",
        "vector",
        battery_period,
        "the energy estimator's (100 ms) where the controller reads it, "
        "else max(`time_step`, 10 ms)",
        "the pack's state of charge (0-1), terminal voltage [V] and current [A] (3 values): "
        "the energy estimator's input where a behaviour tree or the balloon rule reads "
        "`energy_hat`, else for monitoring (the controller logs it); actuators on",
        size=3,
    ),
    Channel(
        "MANTA_ELECTRICAL_POWER",
        "electrical_power",
        "station",
        "vector",
        lambda s: max(s.time_step, 0.01),
        "max(`time_step`, 10 ms)",
        "what the servos and the computers draw [W] (1 value), for monitoring (the "
        "controller logs it); actuators on",
        size=1,
    ),
    Channel(
        "MANTA_DESIRED_JOINT_STATE",
        "desired_state",
        "controller",
        "joint_state",
        lambda s: s.time_step,
        "every plant step (`time_step`, 1 ms)",
        "the servos' desired angles [rad] and rates [rad/s] (their PD's set point)",
    ),
    Channel(
        "MANTA_BALLOON_COMMAND",
        "balloon_command",
        "controller",
        "vector",
        lambda s: s.time_step,
        "every plant step (`time_step`, 1 ms)",
        "balloon fill command in [0, 1] (1 value); the station reads it with water on",
        size=1,
    ),
)
CHANNEL_BY_NAME = {c.name: c for c in CHANNELS}
CLOCK = next(c for c in CHANNELS if c.clock)


def channel_table_markdown() -> str:
    """``CHANNELS`` as a Markdown table (docs/lcm.md holds this text; a test checks)."""
    rows = [
        "| channel | port | from | message type | period | what |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for c in CHANNELS:
        module = c.lcm_type.__module__.rsplit(".", 1)[0]  # the package a driver imports
        rows.append(
            f"| `{c.name}` | `{c.port}` | {c.sender} | `{module}.{c.lcm_type.__name__}` "
            f"| {c.period_text} | {c.what} |"
        )
    return "\n".join(rows) + "\n"


def station_channels(station) -> tuple[list[Channel], list[Channel]]:
    """(what the station publishes, what it reads): the channels whose port it has."""
    sends = [c for c in CHANNELS if c.sender == "station" and station.HasOutputPort(c.port)]
    reads = [c for c in CHANNELS if c.sender == "controller" and station.HasInputPort(c.port)]
    return sends, reads


def controller_channels(controller) -> tuple[list[Channel], list[Channel]]:
    """(what the controller publishes, what it waits for): its commands, and the sensors
    it reads plus the clock."""
    sends = [c for c in CHANNELS if c.sender == "controller" and controller.HasOutputPort(c.port)]
    reads = [
        c
        for c in CHANNELS
        if c.sender == "station" and (c.clock or controller.HasInputPort(c.port))
    ]
    return sends, reads


def monitor_channels(controller, published) -> list[Channel]:
    """The station's channels the controller has no port for but logs (the balloon volume,
    the battery, the electrical power): of ``published`` (the channel names the station
    said it sends, in its handshake), the sensor channels that are neither the clock nor
    one of the controller's inputs."""
    return [
        c
        for c in CHANNELS
        if c.sender == "station"
        and c.name in set(published)
        and not c.clock
        and not controller.HasInputPort(c.port)
    ]


def _readers(system, port_index) -> list:
    """The leaf systems that the input port ``port_index`` of ``system`` feeds."""
    if not isinstance(system, Diagram):
        return [system]
    return [leaf for sub, i in system.GetInputPortLocators(port_index) for leaf in _readers(sub, i)]


def unexchanged_reads(controller, scenario) -> list[str]:
    """The controller's periodic readers of a sensor channel (a leaf system with a ``period``
    attribute, as the estimators have) whose event times in [0, duration) are not all sample
    times of the channel: in lockstep each would read, at those times, the sample of the last
    exchange before them, not the single diagram's. One line each; empty: none.

    A reader at 20 ms on a 10 ms channel is fine (2 x 0.01 is 0.02 to the bit, so every
    j x 0.02 is a 2j x 0.01); one at 100 ms on a 10 ms channel is not (3 x 0.1 is
    0.30000000000000004, 30 x 0.01 is 0.3)."""
    lines = []
    for c in CHANNELS:
        if c.sender != "station" or c.clock or not controller.HasInputPort(c.port):
            continue
        period = c.period(scenario)
        exchanged = set(sample_times(period, scenario.duration))
        index = controller.GetInputPort(c.port).get_index()
        for leaf in _readers(controller, index):
            every = getattr(leaf, "period", None)
            if not isinstance(every, float):
                continue
            missing = [t for t in sample_times(every, scenario.duration) if t not in exchanged]
            if missing:
                lines.append(
                    f"{leaf.get_name()} reads {c.port} every {every:g} s, {c.name} "
                    f"comes every {period:g} s: {len(missing)} of its reads (the "
                    f"first at t = {missing[0]!r} s) fall between the exchanges"
                )
    return lines


def fix_inputs(system, context, got: dict) -> None:
    """Fixes each received value (already decoded and screened) on the system's input port
    of its channel."""
    for name, value in got.items():
        channel = CHANNEL_BY_NAME[name]
        if system.HasInputPort(channel.port):
            system.GetInputPort(channel.port).FixValue(context, value)
