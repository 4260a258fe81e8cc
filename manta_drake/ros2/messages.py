"""Port and log values as standard ROS 2 messages: pure conversions into rosbags' message
classes (``TYPESTORE``, ROS 2 Humble's interfaces, whose layout Jazzy's shares for every
type here), serialized as CDR (``serialize``). The bag writes these bytes; a DDS seam
publishes the same ones.

Units are SI as ROS (REP-103) has them: rad, rad/s, m, m/s, m/s^2, N m, Pa, V, A, Ah.
Frames: the world is Drake's (z up, x and y the pool's axes; ENU-like, not geo-referenced);
the hull's frame is x forward, y left, z up, which is REP-103's body frame as it is.
Quaternions are Drake's (w, x, y, z) on input and ROS's (x, y, z, w) in the messages.
A stamp is an integer count of nanoseconds of simulated time (``to_nanoseconds``).
"""

from __future__ import annotations

import math

import numpy as np
from rosbags.typesys import Stores, get_typestore

# The type store the bytes are made with (and the definitions a bag embeds).
STORE = Stores.ROS2_HUMBLE
TYPESTORE = get_typestore(STORE)
T = TYPESTORE.types

# An IMU covariance whose element 0 is -1: "no estimate" (sensor_msgs/Imu, REP-145).
UNKNOWN_COVARIANCE = np.array([-1.0] + [0.0] * 8)
# The water surface's absolute pressure [Pa] the pressure message adds to rho g depth: one
# standard atmosphere (a pool's varies by about +-3 kPa, 0.3 m of water, with the weather).
SURFACE_PRESSURE_PA = 101325.0

# sensor_msgs/BatteryState constants (the message's own values).
BATTERY_STATUS_CHARGING, BATTERY_STATUS_DISCHARGING, BATTERY_STATUS_NOT_CHARGING = 1, 2, 3
BATTERY_HEALTH_UNKNOWN = 0
BATTERY_TECHNOLOGY_LIPO = 3


def to_nanoseconds(t: float) -> int:
    """Simulated time [s] as whole nanoseconds (a bag's log time, a stamp)."""
    return round(float(t) * 1e9)


def time_msg(t_ns: int):
    """``builtin_interfaces/Time`` of ``t_ns`` >= 0 nanoseconds."""
    return T["builtin_interfaces/msg/Time"](
        sec=int(t_ns // 1_000_000_000), nanosec=int(t_ns % 1_000_000_000)
    )


def header(t_ns: int, frame_id: str):
    """``std_msgs/Header``."""
    return T["std_msgs/msg/Header"](stamp=time_msg(t_ns), frame_id=frame_id)


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(w, x, y, z) of R = Rz(yaw) Ry(pitch) Rx(roll) (Drake's ``RollPitchYaw``, tf2's
    ``setRPY``): the product of the three half-angle quaternions."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def yaw_of_quaternion(w: float, x: float, y: float, z: float) -> float:
    """The yaw [rad] of (w, x, y, z) in the roll-pitch-yaw convention above: atan2(R10,
    R00) in the form that holds for a quaternion of any norm (a simulator's state, a
    driver's float round-off)."""
    return math.atan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)


def rpy_of_quaternion(w: float, x: float, y: float, z: float) -> np.ndarray:
    """(roll, pitch, yaw) [rad] of a unit quaternion, the inverse of ``quaternion_from_rpy``
    (R = Rz(yaw) Ry(pitch) Rx(roll)): roll and yaw in (-pi, pi], pitch in [-pi/2, pi/2]
    (clipped at the poles, where roll and yaw share one angle). NaN in: NaN out."""
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    sine = 2.0 * (w * y - z * x)
    pitch = math.asin(min(1.0, max(-1.0, sine))) if not math.isnan(sine) else math.nan
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return np.array([roll, pitch, yaw])


def rotation_of_quaternion(w: float, x: float, y: float, z: float) -> np.ndarray:
    """The 3x3 rotation matrix of a unit quaternion (w, x, y, z); one off unit norm gives a
    matrix that is not a rotation (the reader's check refuses it)."""
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def from_nanoseconds(stamp) -> int:
    """A ``builtin_interfaces/Time`` as a count of nanoseconds (negative before 0)."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _vector3(v):
    return T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))


def _quaternion(wxyz):
    return T["geometry_msgs/msg/Quaternion"](
        x=float(wxyz[1]), y=float(wxyz[2]), z=float(wxyz[3]), w=float(wxyz[0])
    )


def clock_msg(t_ns: int):
    """``rosgraph_msgs/Clock``: the simulated time."""
    return T["rosgraph_msgs/msg/Clock"](clock=time_msg(t_ns))


def float64_msg(value: float):
    """``std_msgs/Float64``."""
    return T["std_msgs/msg/Float64"](data=float(value))


def joint_state_msg(t_ns: int, names, position, velocity=None, effort=None):
    """``sensor_msgs/JointState``: positions [rad], velocities [rad/s] and efforts [N m] in
    ``names`` order; a quantity not known is an empty array (as the message says)."""

    def array(values):
        return np.empty(0) if values is None else np.ascontiguousarray(values, dtype=float)

    return T["sensor_msgs/msg/JointState"](
        header=header(t_ns, ""),
        name=list(names),
        position=array(position),
        velocity=array(velocity),
        effort=array(effort),
    )


def imu_msg(t_ns: int, frame_id: str, reading, covariances=None):
    """``sensor_msgs/Imu`` of the station's ``imu`` reading [roll, pitch, yaw (rad), wx, wy,
    wz (rad/s), fx, fy, fz (m/s^2, specific force)], all in the hull's axes; the orientation
    is the quaternion of roll, pitch and yaw. ``covariances``: three (9,) row-major 3x3
    matrices (orientation, angular velocity, linear acceleration); None: each unknown."""
    r = np.asarray(reading, dtype=float)
    cov = (UNKNOWN_COVARIANCE,) * 3 if covariances is None else covariances
    return T["sensor_msgs/msg/Imu"](
        header=header(t_ns, frame_id),
        orientation=_quaternion(quaternion_from_rpy(*r[:3])),
        orientation_covariance=np.ascontiguousarray(cov[0], dtype=float),
        angular_velocity=_vector3(r[3:6]),
        angular_velocity_covariance=np.ascontiguousarray(cov[1], dtype=float),
        linear_acceleration=_vector3(r[6:9]),
        linear_acceleration_covariance=np.ascontiguousarray(cov[2], dtype=float),
    )


def pressure_of_depth(depth, density: float, gravity: float, surface: float = SURFACE_PRESSURE_PA):
    """Absolute pressure [Pa] at ``depth`` [m] below the surface: p0 + rho g h."""
    return surface + density * gravity * np.asarray(depth, dtype=float)


def depth_of_pressure(
    pressure, density: float, gravity: float, surface: float = SURFACE_PRESSURE_PA
):
    """Depth [m] below the surface of an absolute ``pressure`` [Pa]: (p - p0) / (rho g)."""
    return (np.asarray(pressure, dtype=float) - surface) / (density * gravity)


def fluid_pressure_msg(
    t_ns: int, frame_id: str, depth: float, density: float, gravity: float, depth_std: float = 0.0
):
    """``sensor_msgs/FluidPressure`` of the pressure sensor's ``depth`` [m]: the absolute
    pressure [Pa] (``pressure_of_depth``), variance (rho g sigma)^2 [Pa^2] (0: unknown)."""
    return T["sensor_msgs/msg/FluidPressure"](
        header=header(t_ns, frame_id),
        fluid_pressure=float(pressure_of_depth(depth, density, gravity)),
        variance=float((density * gravity * depth_std) ** 2),
    )


def vector3_stamped_msg(t_ns: int, frame_id: str, v):
    """``geometry_msgs/Vector3Stamped``."""
    return T["geometry_msgs/msg/Vector3Stamped"](header=header(t_ns, frame_id), vector=_vector3(v))


def twist_stamped_msg(t_ns: int, frame_id: str, linear, angular=(0.0, 0.0, 0.0)):
    """``geometry_msgs/TwistStamped``."""
    return T["geometry_msgs/msg/TwistStamped"](
        header=header(t_ns, frame_id),
        twist=T["geometry_msgs/msg/Twist"](linear=_vector3(linear), angular=_vector3(angular)),
    )


def battery_status(current: float) -> int:
    """The BatteryState status of a pack drawing ``current`` [A] (> 0: discharging)."""
    if current > 0:
        return BATTERY_STATUS_DISCHARGING
    return BATTERY_STATUS_CHARGING if current < 0 else BATTERY_STATUS_NOT_CHARGING


def battery_state_msg(
    t_ns: int,
    frame_id: str,
    soc: float,
    voltage: float,
    current: float,
    capacity_ah: float,
    cells: int,
):
    """``sensor_msgs/BatteryState`` of the station's ``battery`` [state of charge 0-1,
    terminal voltage V, current drawn A]: ROS's current is negative when discharging, its
    percentage 0-1, charge soc x capacity [Ah]; temperature and the ``cells`` cell voltages
    are not measured (NaN, as the message asks); a LiPo pack."""
    return T["sensor_msgs/msg/BatteryState"](
        header=header(t_ns, frame_id),
        voltage=float(voltage),
        temperature=math.nan,
        current=0.0 - float(current),
        charge=float(soc) * capacity_ah,
        capacity=float(capacity_ah),
        design_capacity=float(capacity_ah),
        percentage=float(soc),
        power_supply_status=battery_status(current),
        power_supply_health=BATTERY_HEALTH_UNKNOWN,
        power_supply_technology=BATTERY_TECHNOLOGY_LIPO,
        present=True,
        cell_voltage=np.full(cells, math.nan, dtype=np.float32),
        cell_temperature=np.full(cells, math.nan, dtype=np.float32),
        location="",
        serial_number="",
    )


def joint_arrays(msg, names) -> tuple[np.ndarray, np.ndarray]:
    """(positions, velocities) of a ``sensor_msgs/JointState`` in ``names`` order, matched by
    joint name (a driver may send another order); no velocities (an empty array, the
    message's "not known") are zeros: a position-only command holds still at its angles.

    Raises:
        ValueError: the joints are not exactly ``names``, or position and velocity do not
            have one value per joint.
    """
    index = {name: i for i, name in enumerate(msg.name)}
    if sorted(index) != sorted(names) or len(index) != len(msg.name):
        missing = sorted(set(names) - set(index))
        extra = sorted(set(index) - set(names))
        raise ValueError(
            f"joint state: joints differ from the robot's (missing {missing}, unknown {extra})"
        )
    n = len(names)
    if len(msg.position) != n or len(msg.velocity) not in (0, n):
        raise ValueError(
            f"joint state: {len(msg.position)} positions and {len(msg.velocity)} "
            f"velocities for {n} joints"
        )
    order = [index[name] for name in names]
    velocity = np.asarray(msg.velocity, dtype=float)
    return (
        np.asarray(msg.position, dtype=float)[order],
        velocity[order] if len(velocity) else np.zeros(n),
    )


DEPTH_ENCODING = "32FC1"  # sensor_msgs/image_encodings: one float32 channel, metres


def depth_image_msg(t_ns: int, frame_id: str, pixels):
    """``sensor_msgs/Image`` of a depth image [m] (``pixels``: height x width, float32),
    encoding ``32FC1`` little endian, as ROS depth cameras publish it."""
    data = np.ascontiguousarray(pixels, dtype="<f4")
    height, width = data.shape
    return T["sensor_msgs/msg/Image"](
        header=header(t_ns, frame_id),
        height=height,
        width=width,
        encoding=DEPTH_ENCODING,
        is_bigendian=0,
        step=4 * width,
        data=np.frombuffer(data.tobytes(), dtype=np.uint8),
    )


def depth_pixels(msg) -> np.ndarray:
    """The float32 pixels (height x width) of a ``32FC1`` ``sensor_msgs/Image``.

    Raises:
        ValueError: another encoding, or a size that does not add up.
    """
    if msg.encoding != DEPTH_ENCODING:
        raise ValueError(f"depth image: encoding {msg.encoding!r}; expected {DEPTH_ENCODING}")
    if (
        msg.width < 1
        or msg.height < 1
        or msg.step != 4 * msg.width
        or len(msg.data) != msg.step * msg.height
    ):
        raise ValueError(
            f"depth image: {len(msg.data)} bytes, step {msg.step} for "
            f"{msg.width} x {msg.height} float32 pixels"
        )
    order = ">f4" if msg.is_bigendian else "<f4"
    return (
        np.frombuffer(bytes(msg.data), dtype=order)
        .astype(np.float32)
        .reshape(msg.height, msg.width)
    )


def camera_info_msg(
    t_ns: int, frame_id: str, width: int, height: int, fx: float, fy: float, cx: float, cy: float
):
    """``sensor_msgs/CameraInfo`` of a pinhole camera without distortion (``plumb_bob`` with
    zero coefficients): K, the identity R and P = [K | 0]."""
    k = np.array([fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0])
    p = np.array([fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0])
    return T["sensor_msgs/msg/CameraInfo"](
        header=header(t_ns, frame_id),
        height=int(height),
        width=int(width),
        distortion_model="plumb_bob",
        d=np.zeros(5),
        k=k,
        r=np.eye(3).ravel(),
        p=p,
        binning_x=0,
        binning_y=0,
        roi=T["sensor_msgs/msg/RegionOfInterest"](
            x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
        ),
    )


# diagnostic_msgs/DiagnosticStatus levels (the message's own constants).
DIAGNOSTIC_OK, DIAGNOSTIC_ERROR = 0, 2


def diagnostic_status_msg(
    level: int, name: str, message: str, hardware_id: str, values: dict[str, str]
):
    """``diagnostic_msgs/DiagnosticStatus`` with ``values`` as its key-value pairs."""
    pairs = [T["diagnostic_msgs/msg/KeyValue"](key=k, value=v) for k, v in values.items()]
    return T["diagnostic_msgs/msg/DiagnosticStatus"](
        level=int(level), name=name, message=message, hardware_id=hardware_id, values=pairs
    )


def pose_msg(xyz, quat_wxyz):
    """``geometry_msgs/Pose`` of a position [m] and a (w, x, y, z) quaternion."""
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
        orientation=_quaternion(quat_wxyz),
    )


def pose_stamped_msg(t_ns: int, frame_id: str, xyz, quat_wxyz):
    """``geometry_msgs/PoseStamped``."""
    return T["geometry_msgs/msg/PoseStamped"](
        header=header(t_ns, frame_id), pose=pose_msg(xyz, quat_wxyz)
    )


def transform_stamped(t_ns: int, parent: str, child: str, xyz, quat_wxyz):
    """``geometry_msgs/TransformStamped``: the pose of ``child`` in ``parent``."""
    return T["geometry_msgs/msg/TransformStamped"](
        header=header(t_ns, parent),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](
            translation=_vector3(xyz), rotation=_quaternion(quat_wxyz)
        ),
    )


def tf_msg(transforms):
    """``tf2_msgs/TFMessage`` of ``transform_stamped`` messages."""
    return T["tf2_msgs/msg/TFMessage"](transforms=list(transforms))


def deserialize(raw: bytes, typename: str):
    """The message of CDR bytes (with their encapsulation header); raises what rosbags'
    decoder raises on bytes that are not one (the seam counts and skips them)."""
    return TYPESTORE.deserialize_cdr(raw, typename)


def serialize(msg) -> bytes:
    """The message as CDR (little endian, with its 4-byte encapsulation header)."""
    return bytes(TYPESTORE.serialize_cdr(msg, msg.__msgtype__))


def msgdef(typename: str) -> str:
    """The ROS 2 message definition text of ``typename`` (``ros2msg``, its dependencies
    after ``=`` lines), as a bag's schema carries it."""
    return TYPESTORE.generate_msgdef(typename, ros_version=2)[0]
