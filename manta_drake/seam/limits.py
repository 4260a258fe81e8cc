"""What the seam lets through: the station clips commands to what its servos and pump can do
and never passes a non-finite one on (it holds the last good command instead, as a servo
driver does); the controller treats sensor readings outside their physical range as dropped
readings, which its estimators already hold through. Every such message is counted and
each kind is named once per channel (``Incidents``).

The limits: the joints' position and velocity limits of the station's plant (the SDFormat
model, generated from ``manta_drake.model.robot_params``), the balloon fill [0, 1]; the
physical ranges in ``SensorRanges`` (docs/lcm.md lists them).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from pydrake.math import RigidTransform
from pydrake.systems.sensors import ImageDepth32F

from manta_drake.modalities import MODALITIES, READINGS
from manta_drake.model.robot_params import JOINT_NAMES, JOINTS_PER_LEG, RobotParams
from manta_drake.seam.channels import CHANNEL_BY_NAME, reads_battery
from manta_drake.seam.errors import Incidents

# A measured angle this far past a mechanical stop, or a rate this many times the servos'
# velocity limit, is not a joint moving: it is a broken encoder or a corrupt message.
ANGLE_READING_MARGIN_RAD = math.radians(20.0)
RATE_READING_FACTOR = 5.0
# The pressure sensor's reading [m below the surface]: a 30 bar sensor's full scale is about
# 300 m of water; a metre above the surface leaves room for waves, noise and a robot lifted
# out of the water.
DEPTH_RANGE_M = (-1.0, 300.0)
# The highest charge voltage of any lithium cell (LiHV, 4.35 V): no pack of n cells reads more.
MAX_CELL_VOLTAGE_V = 4.35
ROTATION_TOLERANCE = 1e-6  # max |R^T R - I| of a rotation matrix read from a message


@dc.dataclass(frozen=True)
class JointLimits:
    """Per joint (in ``names`` order): position limits [rad] and velocity limit [rad/s]."""

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray

    @classmethod
    def from_plant(cls, plant_handles) -> JointLimits:
        """The limits of the station's plant: what its joints (the model's servos) have."""
        plant, robot = plant_handles.plant, plant_handles.robot
        joints = [plant.GetJointByName(n, robot) for n in plant_handles.joint_names]
        return cls(
            tuple(plant_handles.joint_names),
            np.array([j.position_lower_limits()[0] for j in joints]),
            np.array([j.position_upper_limits()[0] for j in joints]),
            np.array([j.velocity_upper_limits()[0] for j in joints]),
        )

    @classmethod
    def from_params(cls, params: RobotParams, names=JOINT_NAMES) -> JointLimits:
        """The same from the robot's parameters (what the plant's model is generated from),
        for the controller, which has no plant."""
        limits = [params.position_limits[i % JOINTS_PER_LEG] for i in range(len(names))]
        return cls(
            tuple(names),
            np.array([lo for lo, _ in limits]),
            np.array([hi for _, hi in limits]),
            np.full(len(names), float(params.velocity_limit)),
        )


def _listing(items: list[str], most: int = 6) -> str:
    shown = ", ".join(items[:most])
    return shown + (f" and {len(items) - most} more" if len(items) > most else "")


def screen_joint_command(x, last, limits: JointLimits):
    """A desired joint state [q, v] as the servos may take it.

    Angles beyond a joint's limits are clipped to them, and a clipped joint's rate toward
    its limit set to 0 (the servo holds at the stop); rates beyond the velocity limit are
    clipped to it; a joint with a non-finite angle or rate keeps its last good command
    (``last``): a NaN never reaches the servos.

    Returns:
        (the command to apply: ``x`` itself when nothing is wrong; a list of (kind, text)
        problems, empty when nothing is wrong).
    """
    x = np.asarray(x, dtype=float)
    n = len(limits.names)
    q, v = x[:n], x[n:]
    bad = ~(np.isfinite(q) & np.isfinite(v))
    low, high = q < limits.lower, q > limits.upper
    fast = np.abs(v) > limits.velocity
    if not (bad.any() or low.any() or high.any() or fast.any()):
        return x, []
    q_safe = np.clip(q, limits.lower, limits.upper)
    v_safe = np.clip(v, -limits.velocity, limits.velocity)
    v_safe = np.where((high & (v_safe > 0)) | (low & (v_safe < 0)), 0.0, v_safe)
    q_safe[bad], v_safe[bad] = last[:n][bad], last[n:][bad]
    problems, clipped = [], []
    for i in np.flatnonzero((low | high) & ~bad):
        clipped.append(
            f"{limits.names[i]} angle {q[i]:.4g} rad outside "
            f"[{limits.lower[i]:.3f}, {limits.upper[i]:.3f}]"
        )
    for i in np.flatnonzero(fast & ~bad):
        clipped.append(f"{limits.names[i]} rate {v[i]:.4g} rad/s beyond +-{limits.velocity[i]:g}")
    if clipped:
        problems.append(("clipped", f"{_listing(clipped)}: clipped to the servos' limits"))
    if bad.any():
        held = [
            f"{limits.names[i]} ({q[i]:.4g} rad, {v[i]:.4g} rad/s)" for i in np.flatnonzero(bad)
        ]
        text = f"{_listing(held)} not finite: those servos hold their last good command"
        problems.append(("held", text))
    return np.concatenate([q_safe, v_safe]), problems


def screen_balloon_command(value, last):
    """A balloon fill command as the pump may take it: clipped to [0, 1]; a non-finite one
    replaced by the last good command. Returns (command, problems) as
    ``screen_joint_command``."""
    fill = float(value[0])
    if not math.isfinite(fill):
        text = f"fill {fill} not finite: the pump holds the last good command {last[0]:g}"
        return np.array(last, dtype=float), [("held", text)]
    if 0.0 <= fill <= 1.0:
        return value, []
    return np.array([min(max(fill, 0.0), 1.0)]), [
        ("clipped", f"fill {fill:.4g} outside [0, 1]: clipped to the pump's range")
    ]


@dc.dataclass(frozen=True)
class SensorRanges:
    """The physical range of each reading the controller may receive.

    Attributes:
        depth: the pressure depth [m]: ``DEPTH_RANGE_M``.
        joints: the joints' limits; a reading may pass them by ``ANGLE_READING_MARGIN_RAD``
            and the velocity limit ``RATE_READING_FACTOR`` times.
        image_max: a depth pixel [m]: [0, 2 x the camera's max range] (0 is Drake's
            "too close", +inf "too far", NaN a dropped pixel: all legitimate).
        image_size: the camera's (width, height); None: any.
        battery_voltage: the pack's terminal voltage [V]: [0, cells x 4.35 V].
        battery_current: |current| [A]: the pack's short-circuit current OCV / R_int
            (inf without a resistance).
        power: |electrical power| [W]: OCV x the short-circuit current.
        readings: the modalities' sensors by port -> per value, the bound of its magnitude
            (``manta_drake.modalities``: e.g. the IMU's attitude, rates and specific force,
            the flow probe's axes).
        battery_read: the controller reads the battery (its energy estimator), rather than
            only logging it.
    """

    depth: tuple[float, float] = DEPTH_RANGE_M
    joints: JointLimits | None = None
    image_max: float = math.inf
    image_size: tuple[int, int] | None = None
    battery_voltage: float = math.inf
    battery_current: float = math.inf
    power: float = math.inf
    readings: dict = dc.field(default_factory=lambda: {r.port: r.bounds for r in READINGS})
    battery_read: bool = False

    @classmethod
    def for_scenario(cls, scenario) -> SensorRanges:
        """The ranges of the robot that ``scenario`` describes."""
        voltage = current = power = math.inf
        if scenario.actuators.enabled:
            pack = scenario.energy_model().pack
            ocv = pack.cells_in_series * float(np.max(pack.ocv_cell_voltage))
            voltage = pack.cells_in_series * MAX_CELL_VOLTAGE_V
            if pack.internal_resistance > 0:
                current = ocv / pack.internal_resistance
                power = ocv * current
        return cls(
            joints=JointLimits.from_params(scenario.robot_params()),
            image_max=2.0 * scenario.camera.max_range,
            image_size=(scenario.camera.width, scenario.camera.height),
            battery_voltage=voltage,
            battery_current=current,
            power=power,
            battery_read=reads_battery(scenario),
        )


def _outside(value: float, lo: float, hi: float) -> bool:
    return not lo <= value <= hi  # NaN too


def screen_depth(value, ranges: SensorRanges):
    """A pressure depth reading: NaN is the sensor's dropped reading (passed on, counted);
    +-inf or a value outside ``ranges.depth`` becomes NaN, which the depth estimator treats
    as a dropped reading (it holds its estimate)."""
    h = float(value[0])
    if math.isnan(h):
        text = "depth NaN (a dropped reading): the depth estimator holds its estimate"
        return value, [("dropout", text)]
    lo, hi = ranges.depth
    if _outside(h, lo, hi):
        text = (
            f"depth {h:.4g} m outside its physical range [{lo:g}, {hi:g}] m: ignored (read "
            "as a dropped reading; the depth estimator holds its estimate)"
        )
        return np.array([np.nan]), [("ignored", text)]
    return value, []


def screen_joint_reading(x, last, ranges: SensorRanges):
    """A measured joint state: a joint whose angle or rate is non-finite or outside its
    physical range keeps its last good reading."""
    limits = ranges.joints
    assert limits is not None, "screening joint readings needs the ranges' joint limits"
    x = np.asarray(x, dtype=float)
    n = len(limits.names)
    q, v = x[:n], x[n:]
    with np.errstate(invalid="ignore"):
        bad = ~(
            (q >= limits.lower - ANGLE_READING_MARGIN_RAD)
            & (q <= limits.upper + ANGLE_READING_MARGIN_RAD)
            & (np.abs(v) <= RATE_READING_FACTOR * limits.velocity)
        )
    if not bad.any():
        return x, []
    safe = x.copy()
    safe[:n][bad], safe[n:][bad] = last[:n][bad], last[n:][bad]
    names = [f"{limits.names[i]} ({q[i]:.4g} rad, {v[i]:.4g} rad/s)" for i in np.flatnonzero(bad)]
    text = (
        f"{_listing(names)} outside the physical range (the joint limits "
        f"+-{math.degrees(ANGLE_READING_MARGIN_RAD):g} deg, {RATE_READING_FACTOR:g} x the "
        "velocity limit) or not finite: the last good reading is held"
    )
    return safe, [("held", text)]


def screen_depth_image(image, ranges: SensorRanges):
    """A depth image: pixels that are negative, -inf or beyond ``ranges.image_max`` become
    NaN (dropped pixels, which the wall detector skips); an image of another size than the
    camera's is dropped whole (all NaN, of the camera's size)."""
    if ranges.image_size and (image.width(), image.height()) != ranges.image_size:
        width, height = ranges.image_size
        text = (
            f"a {image.width()} x {image.height()} depth image, the camera's is {width} x "
            f"{height}: ignored (read as a frame of dropped pixels)"
        )
        dropped = ImageDepth32F(width, height)
        dropped.mutable_data[:] = np.nan
        return dropped, [("ignored", text)]
    d = image.data[:, :, 0]
    with np.errstate(invalid="ignore"):
        wrong = (d < 0) | (np.isfinite(d) & (d > ranges.image_max))
    n = int(wrong.sum())
    if n == 0:
        return image, []
    example = float(d[wrong].flat[0])
    image.mutable_data[:, :, 0][wrong] = np.nan
    text = (
        f"{n} depth pixels outside [0, {ranges.image_max:g}] m (e.g. {example:.4g}): "
        "ignored (read as dropped pixels)"
    )
    return image, [("ignored", text)]


def screen_pose(X: RigidTransform, last):
    """A camera pose: a non-finite translation or a rotation matrix that is not one keeps the
    last good pose (``last``; None before the first, when this frame is dropped: returns
    None)."""
    R, p = X.rotation().matrix(), X.translation()
    finite = np.all(np.isfinite(R)) and np.all(np.isfinite(p))
    orthonormal = finite and (
        np.abs(R.T @ R - np.eye(3)).max() <= ROTATION_TOLERANCE and np.linalg.det(R) > 0
    )
    if finite and orthonormal:
        return X, []
    why = "not finite" if not finite else "a rotation matrix that is not a rotation"
    action = (
        "the last good pose is held"
        if last is not None
        else "no good pose yet: this camera frame is dropped"
    )
    return last, [("held", f"camera pose {why}: {action}")]


def _screen_components(value, bounds, names, units, what: str, holder: str):
    """A vector reading screened value by value, as ``screen_depth`` screens the depth: a NaN
    is the sensor's dropped value (passed on, counted as ``dropout``); +-inf or beyond its
    bound (|value| <= bound) becomes NaN (``ignored``), a dropped value too, through which
    ``holder`` holds that channel's estimate. Returns (value, problems)."""
    x = np.asarray(value, dtype=float)
    bounds = np.asarray(bounds, dtype=float)
    dropped = np.isnan(x)
    with np.errstate(invalid="ignore"):
        wrong = ~dropped & ~(np.abs(x) <= bounds)
    if not (dropped.any() or wrong.any()):
        return value, []
    problems = []
    if wrong.any():
        items = [
            f"{names[i]} {x[i]:.4g} {units[i]} beyond +-{bounds[i]:.4g}"
            for i in np.flatnonzero(wrong)
        ]
        text = f"{what} {_listing(items)}: ignored (read as dropped readings; {holder} holds them)"
        problems.append(("ignored", text))
        x = np.where(wrong, np.nan, x)
    if dropped.any():
        items = [names[i] for i in np.flatnonzero(dropped)]
        text = f"{what} {_listing(items)} NaN (dropped readings): {holder} holds them"
        problems.append(("dropout", text))
    return x, problems


def screen_reading(value, port: str, ranges: SensorRanges):
    """A reading of a modality's sensor (``port``: ``imu``, ``flow_velocity``, ...): value by
    value, a NaN passes (a dropped value, counted); +-inf or beyond its bound in
    ``ranges.readings`` becomes NaN, which the modality's estimator holds through channel by
    channel."""
    m = _MODALITY_OF_PORT[port]
    r = m.reading
    assert r is not None  # _MODALITY_OF_PORT holds the modalities with a sensor
    return _screen_components(
        value,
        ranges.readings[port],
        r.names,
        r.units,
        r.port.replace("_", " "),
        f"the {m.alias} estimator",
    )


_MODALITY_OF_PORT = {m.reading.port: m for m in MODALITIES if m.reading is not None}


def screen_battery(value, ranges: SensorRanges):
    """[state of charge, voltage, current]: out of range or NaN -> NaN: logged as not read,
    or, where the controller reads it, a dropped reading its energy estimator holds through."""
    soc, volts, amps = (float(v) for v in value)
    wrong = []
    if _outside(soc, 0.0, 1.0):
        wrong.append(f"state of charge {soc:.4g} outside [0, 1]")
    if _outside(volts, 0.0, ranges.battery_voltage):
        wrong.append(f"voltage {volts:.4g} V outside [0, {ranges.battery_voltage:.4g}]")
    if _outside(amps, -ranges.battery_current, ranges.battery_current):
        wrong.append(f"current {amps:.4g} A beyond +-{ranges.battery_current:.4g}")
    if not wrong:
        return value, []
    action = (
        "read as a dropped reading; the energy estimator holds its estimate"
        if ranges.battery_read
        else "logged as NaN"
    )
    return np.full(3, np.nan), [("ignored", f"{'; '.join(wrong)}: ignored ({action})")]


def screen_power(value, ranges: SensorRanges):
    """Electrical power [W]: out of range -> NaN (logged as not read)."""
    watts = float(value[0])
    if not _outside(watts, -ranges.power, ranges.power):
        return value, []
    text = f"power {watts:.4g} W beyond +-{ranges.power:.4g}: ignored (logged as NaN)"
    return np.array([np.nan]), [("ignored", text)]


class Guard:
    """One side's screening of what it receives, by port: ``screen(got, t)`` returns the
    values to use and reports the problems to ``incidents``.

    Attributes:
        incidents: the side's ``Incidents`` (what was clipped, held, ignored, skipped).
        last: port -> the last good value (held when a new one is not).
    """

    def __init__(self, incidents: Incidents, screens: dict, last: dict):
        self.incidents = incidents
        self._screens = screens  # port -> (value, last) -> (value, problems)
        self.last = dict(last)

    @classmethod
    def for_station(cls, plant_handles, held: dict, incidents: Incidents) -> Guard:
        """What the station's servos and pump take (``held``: the commands before the first)."""
        limits = JointLimits.from_plant(plant_handles)
        return cls(
            incidents,
            {
                "desired_state": lambda x, last: screen_joint_command(x, last, limits),
                "balloon_command": screen_balloon_command,
            },
            held,
        )

    @classmethod
    def for_controller(cls, scenario, incidents: Incidents) -> Guard:
        """The physical ranges of the readings the controller receives (and logs)."""
        ranges = SensorRanges.for_scenario(scenario)
        return cls(
            incidents,
            {
                "depth": lambda x, last: screen_depth(x, ranges),
                "measured_joint_state": lambda x, last: screen_joint_reading(x, last, ranges),
                "depth_image": lambda x, last: screen_depth_image(x, ranges),
                "camera_pose": screen_pose,
                **{
                    port: lambda x, last, port=port: screen_reading(x, port, ranges)
                    for port in _MODALITY_OF_PORT
                },
                "battery": lambda x, last: screen_battery(x, ranges),
                "electrical_power": lambda x, last: screen_power(x, ranges),
            },
            {},
        )

    def screen_one(self, channel, value, t: float, before_start: bool = False):
        """The value of one message on ``channel`` to use (None: drop it); ``before_start``:
        see ``screen``."""
        screen = self._screens.get(channel.port)
        if screen is None or value is None:  # None: a clock tick (ROS 2's /clock), no value
            return value
        value, problems = screen(value, self.last.get(channel.port))
        if before_start:  # a sensor that has not sampled yet has dropped nothing
            problems = [p for p in problems if p[0] != "dropout"]
        if problems:
            self.incidents.report(
                channel.name,
                [kind for kind, _ in problems],
                f"at t = {t:.3f} s: " + "; ".join(text for _, text in problems),
            )
        if value is not None and not any(kind == "ignored" for kind, _ in problems):
            self.last[channel.port] = value
        return value

    def screen(self, got: dict, t: float, before_start: bool = False) -> dict:
        """``got`` (channel name -> value) with each value screened; a pose that cannot be
        used yet drops its camera frame (the depth image of the same exchange: all NaN).

        ``before_start``: ``got`` holds the station's sensors from before its initialization
        (lockstep's first values, stamped ``BEFORE_START_UTIME``). A NaN there is a sensor
        that has not taken its first sample (the pressure sensor's state before its
        initialization), not a dropped reading: passed on as it is, without a report. Values
        outside their range are still screened and reported."""
        out = {}
        for name, value in got.items():
            value = self.screen_one(CHANNEL_BY_NAME[name], value, t, before_start)
            if value is not None:
                out[name] = value
        if "MANTA_CAMERA_POSE" in got and "MANTA_CAMERA_POSE" not in out:
            image = out.get("MANTA_DEPTH_IMAGE")
            if image is not None:
                image.mutable_data[:, :, 0] = np.nan
            out["MANTA_CAMERA_POSE"] = RigidTransform()  # with an all-NaN image: unused
        return out
