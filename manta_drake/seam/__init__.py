"""The seam over LCM: the station and the controller in two processes.

``build_station`` and ``build_controller`` meet at ports of the same names; here each
half runs alone, in its own process, and the ports cross the seam as LCM messages::

    manta-drake station SCENARIO --lcm URL       # the simulated robot (or: the robot)
    manta-drake controller SCENARIO --lcm URL    # what runs on the robot

``CHANNELS`` is the one table of what crosses the seam: channel, port, sender,
message type and period (docs/lcm.md prints it, ``channel_table_markdown``).
Drake's lcmtypes are used where they fit (``lcmt_scope`` for short double vectors,
``lcmt_image_array`` for the depth image); the two project types are in
``manta_drake.lcmtypes`` (``.lcm`` sources beside the generated Python; regenerate with
``lcm-gen -p --ppath DIR manta_drake/lcmtypes/*.lcm`` and copy ``DIR/manta_drake/lcmtypes/*.py``).

Two ways to run:

* **lockstep** (default): the station's time is the clock, and the split run is
  the single diagram bit for bit. Both sides walk the same ``exchange_schedule``:
  every plant step t_k = k h and every sample time j P of a sensor channel (the
  consumer's periodic event, computed as Drake computes it: a camera sample at
  3 x 0.2 = 0.6000000000000001 s falls just *after* the plant step at 0.6 s and sees
  its result, as in the single diagram). The station advances to tau (tau's events
  stay pending: its outputs are what the single diagram's updates at tau read),
  publishes the sensors due, and at a plant step waits for the commands stamped tau,
  fixes them on its inputs and goes on. The controller advances to tau, publishes
  its commands for tau (the CPG's state and the transition's pre-update parameters:
  what the plant's step at tau reads; no sensor at tau feeds them directly), then
  waits for the sensors stamped tau and fixes them before it advances past tau. So
  the controller runs up to ``MAX_LEAD_STEPS`` steps ahead (it watches the station's
  clock channel) and the two processes work at the same time. A ``PlantStepTick``
  gives the controller's RK2 steps the single diagram's end points.
* **wall clock** (``--wall-clock``, both sides): the station runs paced to real time
  with the latest command (from the first one on), the controller on its own wall
  clock with the latest sensor messages, as on the robot.

Either side re-sends what the other may not have received while it waits (lost
UDP datagrams, a peer that starts later), warns on stderr when its peer has been
silent for ``STALE_AFTER_S`` (the controller then holds its last command: it stops and
re-sends it) and gives up with a one-line error after ``--timeout`` seconds: nothing
waits forever. docs/lcm.md has the whole story.
"""

from __future__ import annotations

import collections
import dataclasses as dc
import functools
import json
import pathlib
import sys
import time
import zlib
from collections.abc import Callable

import numpy as np
from drake import lcmt_image, lcmt_image_array, lcmt_scope
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.sensors import ImageDepth32F

from manta_drake.lcmtypes import lcmt_manta_joint_state, lcmt_manta_pose
from manta_drake.model.robot_params import JOINT_NAMES, NUM_JOINTS

# LCM's default group; ttl=0: this machine only; a 2 MB receive buffer (capped by the
# kernel's net.core.rmem_max) holds a few depth images (77 kB each) while a side computes.
DEFAULT_URL = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=2097152"
QUEUE_CAPACITY = 1000  # messages per subscription waiting to be handled
STALE_AFTER_S = 1.0  # s of silence from the peer before saying so on stderr
RESEND_PERIOD_S = 0.1  # s between re-sends while waiting
DEFAULT_TIMEOUT_S = 10.0  # s of silence before giving up
DEFAULT_STARTUP_TIMEOUT_S = 120.0  # s for the first message: the peer may still be building
# How far (plant steps) the lockstep controller may run ahead of the station: enough to
# overlap the two processes' work, few enough messages in flight for the sockets.
MAX_LEAD_STEPS = 4


class SeamError(RuntimeError):
    """The seam failed: a peer is silent, a message is malformed, a URL cannot open."""


# ---------------------------------------------------------------------------------------
# Message codecs: pure conversions between port values and LCM messages.


def to_utime(t: float) -> int:
    """Simulation time [s] -> an LCM ``utime`` [us]."""
    return round(t * 1e6)


def vector_message(t: float, values) -> lcmt_scope:
    """A double vector (a port's value) as Drake's ``lcmt_scope``."""
    msg = lcmt_scope()
    msg.utime = to_utime(t)
    msg.value = [float(v) for v in np.atleast_1d(values)]
    msg.size = len(msg.value)
    return msg


def vector_from_message(msg: lcmt_scope) -> np.ndarray:
    """The double vector of an ``lcmt_scope``."""
    return np.array(msg.value, dtype=float)


def joint_state_message(t: float, x, names=JOINT_NAMES) -> lcmt_manta_joint_state:
    """Joint state x = [q (n), v (n)] in ``names`` order as ``lcmt_manta_joint_state``."""
    x = np.asarray(x, dtype=float)
    n = len(names)
    if x.shape != (2 * n,):
        raise SeamError(f"joint state: expected {2 * n} values [q, v], got shape {x.shape}")
    msg = lcmt_manta_joint_state()
    msg.utime = to_utime(t)
    msg.num_joints = n
    msg.joint_name = list(names)
    msg.position = x[:n].tolist()
    msg.velocity = x[n:].tolist()
    return msg


def joint_state_from_message(msg: lcmt_manta_joint_state, names=JOINT_NAMES) -> np.ndarray:
    """[q, v] in ``names`` order, matched by joint name (a driver may send another order).

    Raises:
        SeamError: the message's joints are not exactly ``names``.
    """
    index = {name: i for i, name in enumerate(msg.joint_name)}
    if sorted(index) != sorted(names) or len(index) != len(msg.joint_name):
        missing = sorted(set(names) - set(index))
        extra = sorted(set(index) - set(names))
        raise SeamError(f"joint state: joints differ from the robot's (missing {missing}, "
                        f"unknown {extra})")
    order = [index[name] for name in names]
    return np.concatenate([np.asarray(msg.position, dtype=float)[order],
                           np.asarray(msg.velocity, dtype=float)[order]])


def depth_image_message(t: float, image: ImageDepth32F,
                        frame_name: str = "camera") -> lcmt_image_array:
    """A 32-bit float depth image [m] as Drake's ``lcmt_image_array`` (one image,
    ``PIXEL_FORMAT_DEPTH``, ``CHANNEL_TYPE_FLOAT32``, uncompressed: noisy depth does
    not compress, and zlib would cost more than the datagrams it saves)."""
    data = np.ascontiguousarray(image.data[:, :, 0], dtype=np.float32)
    img = lcmt_image()
    img.header.utime = to_utime(t)
    img.header.frame_name = frame_name
    img.width, img.height = image.width(), image.height()
    img.row_stride = 4 * img.width
    img.data = data.tobytes()
    img.size = len(img.data)
    img.bigendian = sys.byteorder == "big"
    img.pixel_format = lcmt_image.PIXEL_FORMAT_DEPTH
    img.channel_type = lcmt_image.CHANNEL_TYPE_FLOAT32
    img.compression_method = lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED
    msg = lcmt_image_array()
    msg.header.utime = img.header.utime
    msg.header.frame_name = frame_name
    msg.num_images = 1
    msg.images = [img]
    return msg


def depth_image_from_message(msg: lcmt_image_array) -> ImageDepth32F:
    """The depth image of an ``lcmt_image_array`` (its first image; float32 depth,
    uncompressed or zlib, either byte order: what Drake's ``ImageToLcmImageArrayT``
    or a camera driver sends).

    Raises:
        SeamError: no image, not float32 depth, or a size that does not add up.
    """
    if msg.num_images < 1:
        raise SeamError("depth image: the lcmt_image_array holds no image")
    img = msg.images[0]
    if (img.pixel_format != lcmt_image.PIXEL_FORMAT_DEPTH
            or img.channel_type != lcmt_image.CHANNEL_TYPE_FLOAT32):
        raise SeamError(f"depth image: pixel_format {img.pixel_format}, channel_type "
                        f"{img.channel_type}; expected DEPTH ({lcmt_image.PIXEL_FORMAT_DEPTH}) "
                        f"FLOAT32 ({lcmt_image.CHANNEL_TYPE_FLOAT32})")
    data = img.data
    if img.compression_method == lcmt_image.COMPRESSION_METHOD_ZLIB:
        data = zlib.decompress(data)
    elif img.compression_method != lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED:
        raise SeamError(f"depth image: compression_method {img.compression_method} is not "
                        "supported (send it uncompressed or zlib)")
    if img.row_stride != 4 * img.width or len(data) != img.row_stride * img.height:
        raise SeamError(f"depth image: {len(data)} bytes, row_stride {img.row_stride} for "
                        f"{img.width} x {img.height} float32 pixels")
    pixels = np.frombuffer(data, dtype=">f4" if img.bigendian else "<f4")
    image = ImageDepth32F(img.width, img.height)
    image.mutable_data[:, :, 0] = pixels.reshape(img.height, img.width)
    return image


def pose_message(t: float, X: RigidTransform, frame_name: str = "camera") -> lcmt_manta_pose:
    """A RigidTransform X_WF as ``lcmt_manta_pose`` (rotation matrix: bit-exact)."""
    msg = lcmt_manta_pose()
    msg.utime = to_utime(t)
    msg.frame_name = frame_name
    msg.translation = [float(v) for v in X.translation()]
    msg.rotation = [[float(v) for v in row] for row in X.rotation().matrix()]
    return msg


def pose_from_message(msg: lcmt_manta_pose) -> RigidTransform:
    """The RigidTransform of an ``lcmt_manta_pose``."""
    return RigidTransform(RotationMatrix(np.array(msg.rotation, dtype=float)),
                          np.array(msg.translation, dtype=float))


@dc.dataclass(frozen=True)
class Codec:
    """How one kind of port value crosses the seam."""

    lcm_type: type
    encode: Callable  # (t, value) -> message
    decode: Callable  # message -> value
    stamp: Callable  # message -> utime


def _utime(msg) -> int:
    return msg.utime


CODECS = {
    "vector": Codec(lcmt_scope, vector_message, vector_from_message, _utime),
    "joint_state": Codec(lcmt_manta_joint_state, joint_state_message,
                         joint_state_from_message, _utime),
    "depth_image": Codec(lcmt_image_array, depth_image_message, depth_image_from_message,
                         lambda msg: msg.header.utime),
    "pose": Codec(lcmt_manta_pose, pose_message, pose_from_message, _utime),
}


# ---------------------------------------------------------------------------------------
# The channel table: the one place that says what crosses the seam, in which message
# type and how often.


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
    """

    name: str
    port: str
    sender: str
    codec: str
    period: Callable
    period_text: str
    what: str
    clock: bool = False

    @property
    def lcm_type(self) -> type:
        return CODECS[self.codec].lcm_type


CHANNELS = (
    Channel("MANTA_MEASURED_JOINT_STATE", "measured_joint_state", "station", "joint_state",
            lambda s: s.time_step, "every plant step (`time_step`, 1 ms)",
            "the 16 servos' angles [rad] and rates [rad/s]; the lockstep clock", clock=True),
    Channel("MANTA_DEPTH", "depth", "station", "vector",
            lambda s: 1.0 / s.pressure_sensor.rate_hz, "1 / `pressure_sensor.rate_hz` (20 ms)",
            "pressure depth [m] below the surface (1 value, NaN on a dropout); water on"),
    Channel("MANTA_DEPTH_IMAGE", "depth_image", "station", "depth_image",
            lambda s: 1.0 / s.camera.rate_hz, "1 / `camera.rate_hz` (200 ms)",
            "the head camera's noisy depth image [m], float32; camera on"),
    Channel("MANTA_CAMERA_POSE", "camera_pose", "station", "pose",
            lambda s: 1.0 / s.camera.rate_hz, "1 / `camera.rate_hz` (200 ms)",
            "the camera's pose X_WC (on the robot: IMU attitude + pressure depth); camera on"),
    Channel("MANTA_BALLOON_VOLUME", "balloon_volume", "station", "vector",
            lambda s: max(s.time_step, 0.01), "max(`time_step`, 10 ms)",
            "balloon volume [m^3], for monitoring (the controller reads none); water on"),
    Channel("MANTA_DESIRED_JOINT_STATE", "desired_state", "controller", "joint_state",
            lambda s: s.time_step, "every plant step (`time_step`, 1 ms)",
            "the servos' desired angles [rad] and rates [rad/s] (their PD's set point)"),
    Channel("MANTA_BALLOON_COMMAND", "balloon_command", "controller", "vector",
            lambda s: s.time_step, "every plant step (`time_step`, 1 ms)",
            "balloon fill command in [0, 1] (1 value); the station reads it with water on"),
)
CHANNEL_BY_NAME = {c.name: c for c in CHANNELS}
CLOCK = next(c for c in CHANNELS if c.clock)


def channel_table_markdown() -> str:
    """``CHANNELS`` as a Markdown table (docs/lcm.md holds this text; a test checks)."""
    rows = ["| channel | port | from | message type | period | what |",
            "| --- | --- | --- | --- | --- | --- |"]
    for c in CHANNELS:
        module = c.lcm_type.__module__.rsplit(".", 1)[0]  # the package a driver imports
        rows.append(f"| `{c.name}` | `{c.port}` | {c.sender} | `{module}.{c.lcm_type.__name__}` "
                    f"| {c.period_text} | {c.what} |")
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
    reads = [c for c in CHANNELS if c.sender == "station"
             and (c.clock or controller.HasInputPort(c.port))]
    return sends, reads


# ---------------------------------------------------------------------------------------
# The exchange schedule: when the two sides meet.


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


# ---------------------------------------------------------------------------------------
# Transport: one end of the seam.


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


def _warn(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------
# The two halves.


@dc.dataclass
class SeamResult:
    """What one side of a run did."""

    who: str
    mode: str
    url: str
    sim_time_s: float
    wall_time_s: float  # from the first exchange with the peer to the end
    exchanges: int
    resends: int
    log: dict

    @property
    def real_time_factor(self) -> float:
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else float("nan")

    def metrics(self) -> dict:
        return {"who": self.who, "mode": self.mode, "url": self.url,
                "sim_time_s": self.sim_time_s, "wall_time_s": self.wall_time_s,
                "real_time_factor": self.real_time_factor, "exchanges": self.exchanges,
                "resends": self.resends}

    def write(self, out_dir) -> pathlib.Path:
        """Writes ``<who>_log.npz`` and ``<who>_metrics.json`` into ``out_dir``."""
        out = pathlib.Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out / f"{self.who}_log.npz",
                            **{k: np.asarray(v) for k, v in self.log.items()})
        (out / f"{self.who}_metrics.json").write_text(json.dumps(self.metrics(), indent=2) + "\n")
        return out

    def summary(self) -> str:
        return (f"{self.who}: {self.sim_time_s:.3f} s simulated in {self.wall_time_s:.2f} s "
                f"(real-time factor {self.real_time_factor:.2f}), {self.mode}, "
                f"{self.exchanges} exchanges, {self.resends} re-sends, over {self.url}")


def initial_commands(scenario) -> dict[str, np.ndarray]:
    """What the station holds before the first command: the start stance at rest and the
    initial balloon fill (a robot's servos hold their pose until commanded)."""
    return {"desired_state": np.concatenate([scenario.initial_joint_angles(),
                                             np.zeros(NUM_JOINTS)]),
            "balloon_command": np.array([scenario.balloon.initial_fill])}


def _advance_to(simulator, t: float) -> None:
    """``simulator.AdvanceTo(t)`` unless the context is already at ``t``: AdvanceTo
    first handles the update events pending at the current time, so calling it at
    ``t`` would run ``t``'s updates before the inputs for ``t`` are fixed."""
    if t > simulator.get_context().get_time():
        simulator.AdvanceTo(t)


class PlantStepTick(LeafSystem):
    """A periodic publish event that does nothing, every plant step.

    Why: Drake's integrator stretches a step by up to 1 % to land on an update or
    publish event, but never steps past an ``AdvanceTo`` boundary. In the single
    diagram the plant's update at (k+1) h is the CPG's RK2 target, so a step from
    k h is stretched onto it even when (k+1) h - k h is a rounding error more than
    h; in the controller alone only the boundary would be there, and the integrator
    would take h and then a ~1e-16 s step. With this event in the controller's
    diagram its RK2 steps are the single diagram's, bit for bit.
    """

    def __init__(self, period: float):
        super().__init__()
        self.DeclarePeriodicPublishEvent(period, 0.0, lambda context: None)


def controller_with_tick(controller, period: float):
    """``controller`` and a ``PlantStepTick(period)`` in one Diagram with the
    controller's port names."""
    builder = DiagramBuilder()
    builder.AddSystem(controller)
    builder.AddNamedSystem("plant_step_tick", PlantStepTick(period))
    for i in range(controller.num_input_ports()):
        port = controller.get_input_port(i)
        builder.ExportInput(port, port.get_name())
    for i in range(controller.num_output_ports()):
        port = controller.get_output_port(i)
        builder.ExportOutput(port, port.get_name())
    diagram = builder.Build()
    diagram.set_name("controller_alone")
    return diagram


def _body_indices(handles):
    """Where the body's quaternion and position start in the plant state (None: welded)."""
    body = handles.plant_handles.body
    if not body.is_floating_base_body():
        return None
    q0 = body.floating_positions_start()
    return q0, q0 + 4


def _fix(system, context, got: dict) -> None:
    """Fixes each received message's value on the system's input port of its channel."""
    for name, msg in got.items():
        channel = CHANNEL_BY_NAME[name]
        if system.HasInputPort(channel.port):
            system.GetInputPort(channel.port).FixValue(context, CODECS[channel.codec].decode(msg))


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
    from manta_drake.simulate import make_simulator
    from manta_drake.wiring.station import build_station

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
        _warn(f"station: no command from the controller for {waited:.1f} s at "
              f"t = {context.get_time():.3f} s; waiting (gives up after {timeout:g} s)")

    def on_timeout(waited):
        return SeamError(
            f"station: no command for t = {context.get_time():.3f} s within {waited:.1f} s; "
            "is `manta-drake controller` running with the same scenario, --lcm URL and "
            "--wall-clock setting?")

    mode = "wall-clock" if wall_clock else "lockstep"
    if progress:
        _warn(f"station: {scenario.name}, {mode}, waiting for the controller on {url}")
    wall_start = None
    last_command = time.monotonic()
    silent_warned = False
    next_progress = 1.0
    for ex in schedule:
        _advance_to(simulator, ex.time)
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
            _fix(station, context, got)
        elif wanted:  # wall clock: the newest command, whatever its stamp
            if wall_start is None:  # hold t = 0 until a controller is there
                link.wait_for(lambda wanted=wanted: any(link.inbox[n] for n in wanted) or None,
                              startup_timeout, lambda waited: None, on_timeout)
            link.drain()
            link.acknowledge_all()  # nothing is re-sent on the wall clock
            got = {name: msg for name in wanted if (msg := link.latest(name)) is not None}
            _fix(station, context, got)
            if got:
                last_command, silent_warned = time.monotonic(), False
            elif time.monotonic() - last_command > STALE_AFTER_S and not silent_warned:
                silent_warned = True
                _warn(f"station: no command from the controller for {STALE_AFTER_S:g} s at "
                      f"t = {ex.time:.3f} s; holding the last one")
        if wall_start is None:
            wall_start = time.monotonic() - (ex.time if wall_clock else 0.0)
        if wall_clock:  # paced: sleep while ahead of the wall clock
            ahead = wall_start + ex.time - time.monotonic()
            if ahead > 1e-3:
                time.sleep(ahead)
        if progress and ex.time >= next_progress:
            _warn(f"station: t = {ex.time:.1f} s")
            next_progress += 1.0
    simulator.AdvanceTo(scenario.duration)
    record(scenario.duration)
    wall = time.monotonic() - wall_start if wall_start is not None else 0.0
    arrays = {k: np.array(v) for k, v in log.items() if len(v)}
    return SeamResult("station", mode, url, float(context.get_time()), wall, len(schedule),
                      link.resends, arrays)


def run_controller(scenario, url: str = DEFAULT_URL, wall_clock: bool = False,
                   timeout: float = DEFAULT_TIMEOUT_S,
                   startup_timeout: float = DEFAULT_STARTUP_TIMEOUT_S,
                   progress: bool = False) -> SeamResult:
    """Runs the controller of ``scenario`` alone against a station over LCM.

    Lockstep: at each exchange time tau it publishes its commands for tau (they depend
    on its state at tau only, not on tau's sensors: ``build_controller`` has no direct
    feedthrough; with one it would wait first), then waits for the sensors due at tau
    and fixes them before advancing past tau. So it runs ahead of the station, at most
    ``MAX_LEAD_STEPS`` plant steps (it watches the station's clock channel), and the
    station rarely waits.

    Args:
        scenario: a validated Scenario (the station's).
        url: the LCM URL (the station's).
        wall_clock: run on this machine's clock with the latest sensor messages (as on
            the robot), instead of lockstep with the station's time.
        timeout: give up after the station has been silent this long [s]; meanwhile the
            last command is held (re-sent) and stderr says so.
        startup_timeout: the same for the first message (the station may start later).
        progress: print the controller's time on stderr every second of it.

    Returns:
        SeamResult; its log has ``t_command`` and ``commanded_joint_angles`` (the
        desired angles sent at every plant step) and, where the controller has them,
        ``cpg_params``, ``z_hat``, ``s_hat``, ``detector_status`` at the same times.

    Raises:
        SeamError: the station was silent for ``timeout`` s.
    """
    from manta_drake.wiring.controller import build_controller
    from manta_drake.simulate import make_simulator

    controller, _ = build_controller(scenario)
    controller = controller_with_tick(controller, scenario.time_step)
    sends, reads = controller_channels(controller)
    link = Link(url, reads, "controller", lockstep=not wall_clock)
    simulator = make_simulator(controller, scenario)
    context = simulator.get_mutable_context()
    monitors = [p for p in ("cpg_params", "z_hat", "s_hat", "detector_status")
                if controller.HasOutputPort(p)]
    log = {"t_command": [], "commanded_joint_angles": [], **{p: [] for p in monitors}}
    mode = "wall-clock" if wall_clock else "lockstep"
    state = {"last_t": 0.0}

    def command(t: float) -> None:
        for channel in sends:
            value = controller.GetOutputPort(channel.port).Eval(context)
            link.publish(channel.name, CODECS[channel.codec].encode(t, value), to_utime(t))
            if channel.port == "desired_state":
                log["t_command"].append(t)
                log["commanded_joint_angles"].append(value[:NUM_JOINTS].copy())
        for p in monitors:
            log[p].append(controller.GetOutputPort(p).Eval(context).copy())
        state["last_t"] = t

    def on_stale(waited):
        _warn(f"controller: no message from the station for {waited:.1f} s (last command "
              f"stamped t = {state['last_t']:.3f} s); holding the last command "
              f"(gives up after {timeout:g} s)")

    def on_timeout(waited):
        if link.last_arrival is None:
            return SeamError(f"controller: nothing from the station within {waited:.1f} s; is "
                             "`manta-drake station` running with the same scenario, --lcm URL "
                             "and --wall-clock setting?")
        return SeamError(f"controller: the station has been silent for {waited:.1f} s "
                         f"(last command stamped t = {state['last_t']:.3f} s, held until now); "
                         "stopped")

    if progress:
        _warn(f"controller: {scenario.name}, {mode}, waiting for the station on {url}")
    if wall_clock:
        wall_start, exchanges = _controller_wall_clock(
            scenario, simulator, link, reads, command, timeout, startup_timeout,
            on_stale, on_timeout, progress)
        wall = time.monotonic() - wall_start
    else:
        exchanges, wall = _controller_lockstep(scenario, simulator, link, sends, reads, command,
                                               timeout, startup_timeout, on_stale, on_timeout,
                                               progress)
        _linger(link)
    arrays = {k: np.array(v) for k, v in log.items() if len(v)}
    return SeamResult("controller", mode, url, float(context.get_time()), wall, exchanges,
                      link.resends, arrays)


def has_feedthrough(controller, inputs, outputs) -> bool:
    """Whether a command port depends directly on a sensor port (then a command for t
    must wait for t's sensors)."""
    return any(controller.HasDirectFeedthrough(controller.GetInputPort(i.port).get_index(),
                                               controller.GetOutputPort(o.port).get_index())
               for i in inputs if controller.HasInputPort(i.port) for o in outputs)


def _controller_lockstep(scenario, simulator, link, sends, reads, command, timeout,
                         startup_timeout, on_stale, on_timeout, progress):
    """The controller in lockstep with the station's time (see ``run_controller``).
    Returns (number of exchanges, wall time from the first exchange)."""
    controller, context = simulator.get_system(), simulator.get_mutable_context()
    schedule = exchange_schedule(scenario.duration,
                                 {c.name: c.period(scenario) for c in sends + reads})
    inputs = {c.name for c in reads if controller.HasInputPort(c.port)}
    sending = {c.name for c in sends}
    wait_first = has_feedthrough(controller, reads, sends)
    lead = MAX_LEAD_STEPS * to_utime(scenario.time_step)
    wall_start = None
    next_progress = 1.0

    def publish(ex) -> None:
        # Flow control: no further ahead of the station's clock than MAX_LEAD_STEPS.
        link.wait_for(lambda: True if link.newest.get(CLOCK.name, -1) >= ex.utime - lead
                      else None, timeout, on_stale, on_timeout)
        command(ex.time)

    for ex in schedule:
        first = wall_start is None
        if not first:
            _advance_to(simulator, ex.time)
        link.advance_floor(ex.utime)
        commands_due = any(name in sending for name in ex.channels)
        if commands_due and not (first or wait_first):
            publish(ex)
        wanted = {name: ex.utime for name in ex.channels if name in inputs}
        if first:  # the station is there: its clock at the start
            wanted[CLOCK.name] = ex.utime
        if wanted:
            got = link.wait_for(lambda wanted=wanted: link.take(wanted),
                                startup_timeout if first else timeout,
                                (lambda waited: None) if first else on_stale, on_timeout)
            _fix(controller, context, got)
        if first:  # every input has its value now
            simulator.Initialize()
            wall_start = time.monotonic()
        if commands_due and (first or wait_first):
            publish(ex)
        if progress and ex.time >= next_progress:
            _warn(f"controller: t = {ex.time:.1f} s")
            next_progress += 1.0
    if wall_start is None:
        return 0, 0.0
    simulator.AdvanceTo(scenario.duration)
    return len(schedule), time.monotonic() - wall_start


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


def _controller_wall_clock(scenario, simulator, link, reads, command, timeout,
                           startup_timeout, on_stale, on_timeout, progress):
    """The controller on this machine's clock: latest sensor values, a command after every
    plant step of its own time; holds (stops, re-sends its last command) while the
    station is silent. Returns (wall start, number of commands)."""
    controller, context = simulator.get_system(), simulator.get_mutable_context()
    h = scenario.time_step
    start = time.monotonic()
    latest: dict = {}
    while len(latest) < len(reads):  # every input once before starting
        link.poll(50)
        latest.update({c.name: m for c in reads if (m := link.latest(c.name)) is not None})
        if time.monotonic() - start > startup_timeout:
            missing = sorted(c.name for c in reads if c.name not in latest)
            raise SeamError(f"controller: nothing on {', '.join(missing)} within "
                            f"{startup_timeout:g} s; is `manta-drake station --wall-clock` "
                            "running with the same scenario and --lcm URL?")
    _fix(controller, context, latest)
    simulator.Initialize()
    command(0.0)
    wall_start = time.monotonic()
    held_for = 0.0  # wall time spent holding: the controller's clock stops meanwhile
    k, commands, next_progress = 0, 1, 1.0
    holding_since = None
    last_resend = 0.0
    n_steps = round(scenario.duration / h)
    while k < n_steps:
        link.poll(1)
        fresh = {c.name: m for c in reads if (m := link.latest(c.name)) is not None}
        _fix(controller, context, fresh)
        now = time.monotonic()
        silent = now - link.last_arrival
        if silent > STALE_AFTER_S:  # hold: stop the clock, re-send the last command
            if holding_since is None:
                holding_since = now - silent
                on_stale(silent)
            if silent > timeout:
                raise on_timeout(silent)
            if now - last_resend > RESEND_PERIOD_S:
                link.resend()
                last_resend = now
            continue
        if holding_since is not None:
            _warn(f"controller: the station is back after {now - holding_since:.1f} s; resuming")
            held_for += now - holding_since
            holding_since = None
        k_target = min(int((now - wall_start - held_for) / h), n_steps)
        if k_target > k:
            k = k_target
            simulator.AdvanceTo(k * h)
            link.acknowledge_all()  # re-send (hold) only the newest command
            command(k * h)
            commands += 1
            if progress and k * h >= next_progress:
                _warn(f"controller: t = {k * h:.1f} s")
                next_progress += 1.0
    return wall_start, commands


# ---------------------------------------------------------------------------------------
# The command line (manta_drake.cli dispatches here).


def _add_common(parser) -> None:
    parser.add_argument("scenario", help="scenario YAML file, or a shipped scenario's name; "
                        "the station and the controller must use the same")
    parser.add_argument("--lcm", default=DEFAULT_URL, metavar="URL",
                        help=f"LCM URL (default {DEFAULT_URL}; both sides the same)")
    parser.add_argument("--duration", type=float, metavar="S",
                        help="override the scenario's duration [s]")
    parser.add_argument("--wall-clock", action="store_true",
                        help="run on wall time with the latest messages (as on the robot) "
                        "instead of lockstep; give it to both sides")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                        help="give up when the other side is silent this long "
                        f"(default {DEFAULT_TIMEOUT_S:g} s)")
    parser.add_argument("--startup-timeout", type=float, default=DEFAULT_STARTUP_TIMEOUT_S,
                        metavar="S", help="the same for its first message "
                        f"(default {DEFAULT_STARTUP_TIMEOUT_S:g} s)")
    parser.add_argument("--out", metavar="DIR",
                        help="write <side>_log.npz and <side>_metrics.json here")
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def add_station_parser(subparsers) -> None:
    """Adds ``manta-drake station``."""
    p = subparsers.add_parser("station", help="run the simulated robot alone, over LCM",
                              description="Runs the station (the simulated robot) of a "
                              "scenario alone: publishes its sensors, reads the commands of "
                              "`manta-drake controller` over LCM (docs/lcm.md).")
    _add_common(p)


def add_controller_parser(subparsers) -> None:
    """Adds ``manta-drake controller``."""
    p = subparsers.add_parser("controller", help="run the controller alone, over LCM",
                              description="Runs the controller of a scenario alone against "
                              "`manta-drake station` (or the robot) over LCM (docs/lcm.md).")
    _add_common(p)


def _load(args):
    from manta_drake.scenario import load_scenario

    if args.timeout <= 0 or args.startup_timeout <= 0:
        raise SeamError("--timeout and --startup-timeout must be > 0 s")
    return load_scenario(args.scenario, {"duration": args.duration} if args.duration else {})


def _main(args, run) -> int:
    scenario = _load(args)
    result = run(scenario, args.lcm, wall_clock=args.wall_clock, timeout=args.timeout,
                 startup_timeout=args.startup_timeout, progress=not args.quiet)
    if args.out:
        result.write(args.out)
    print(result.summary(), flush=True)
    return 0


def station_main(args) -> int:
    """``manta-drake station SCENARIO --lcm URL``."""
    return _main(args, run_station)


def controller_main(args) -> int:
    """``manta-drake controller SCENARIO --lcm URL``."""
    return _main(args, run_controller)


__all__ = [
    "CHANNEL_BY_NAME", "CHANNELS", "CLOCK", "CODECS", "DEFAULT_STARTUP_TIMEOUT_S",
    "DEFAULT_TIMEOUT_S", "DEFAULT_URL", "MAX_LEAD_STEPS", "QUEUE_CAPACITY", "RESEND_PERIOD_S",
    "STALE_AFTER_S", "Channel", "Codec", "Exchange", "Link", "PlantStepTick", "SeamError",
    "SeamResult", "add_controller_parser", "add_station_parser", "channel_table_markdown",
    "controller_channels", "controller_main", "controller_with_tick",
    "depth_image_from_message", "depth_image_message", "exchange_schedule", "has_feedthrough",
    "initial_commands", "joint_state_from_message", "joint_state_message", "pose_from_message",
    "pose_message", "run_controller", "run_station", "sample_times", "station_channels",
    "station_main", "to_utime", "vector_from_message", "vector_message",
]
