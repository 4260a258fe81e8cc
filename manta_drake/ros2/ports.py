"""The station's and the controller's port values as ROS 2 messages, and back: what the seam
over ROS 2 (``manta_drake.seam.ros2_link``) publishes and decodes, made with the conversions
of ``messages``.

``PORT_SIGNALS`` names the topic-map signal of each port that crosses the seam;
``PORT_CODECS[signal][type]`` is a ``PortCodec``: ``to_msg(t_ns, value, constants)`` and
``from_msg(msg, constants) -> value`` (None where nothing reads it: the camera info, the
clock). A message's stamp is its header's (the clock's time for ``rosgraph_msgs/Clock``), or
None for a message without one (``std_msgs/Float64``): the seam then stamps it with the DDS
sample's source timestamp.

Exact in both directions: the joint states, the flow velocity, every ``Float64``, the depth
image (float32 as sent) and the stamps. Not exact: the pressure's depth ((p0 + rho g h - p0) /
(rho g) differs from h in the last bits), the IMU's attitude (roll, pitch, yaw -> quaternion
-> roll, pitch, yaw: ~1e-16 rad; a NaN among the three makes all three NaN), the battery
(``BatteryState`` holds float32) and the camera pose (rotation matrix -> quaternion ->
matrix: ~1e-16).
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable

import numpy as np

from manta_drake.ros2 import messages as m
from manta_drake.ros2.signals import Constants

# The topic-map signal of each port that crosses the seam (sensor ports from the station,
# command ports from the controller).
PORT_SIGNALS = {
    "measured_joint_state": "joint_states",
    "depth": "pressure",
    "depth_image": "depth_image",
    "camera_pose": "camera_pose",
    "imu": "imu",
    "flow_velocity": "flow_velocity",
    "altitude": "altitude",
    "balloon_volume": "balloon_volume",
    "battery": "battery",
    "electrical_power": "electrical_power",
    "desired_state": "joint_commands",
    "balloon_command": "balloon_command",
}


@dc.dataclass(frozen=True)
class PortCodec:
    """One message type of a port: ``to_msg(t_ns, value, c)``, ``from_msg(msg, c)`` (None:
    publish only)."""

    to_msg: Callable
    from_msg: Callable | None


def stamp_ns(msg) -> int | None:
    """The message's stamp [ns]: its header's, a Clock's time; None without either."""
    if hasattr(msg, "header"):
        return m.from_nanoseconds(msg.header.stamp)
    if hasattr(msg, "clock"):
        return m.from_nanoseconds(msg.clock)
    return None


def _joint_state_to(t_ns, x, c: Constants):
    n = len(c.joint_names)
    x = np.asarray(x, dtype=float)
    return m.joint_state_msg(t_ns, c.joint_names, x[:n], x[n:])


def _joint_state_from(msg, c: Constants) -> np.ndarray:
    return np.concatenate(m.joint_arrays(msg, c.joint_names))


def imu_reading(msg) -> np.ndarray:
    """The station's ``imu`` reading [roll, pitch, yaw, wx, wy, wz, fx, fy, fz] of a
    ``sensor_msgs/Imu`` (the inverse of ``messages.imu_msg``)."""
    q, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
    return np.concatenate(
        [m.rpy_of_quaternion(q.w, q.x, q.y, q.z), [w.x, w.y, w.z], [a.x, a.y, a.z]]
    )


def battery_reading(msg) -> np.ndarray:
    """[state of charge, voltage V, current drawn A] of a ``sensor_msgs/BatteryState`` (the
    inverse of ``messages.battery_state_msg``: ROS's current is negative while
    discharging)."""
    return np.array([float(msg.percentage), float(msg.voltage), -float(msg.current)])


def depth_image_to(t_ns, image, c: Constants):
    """An ``ImageDepth32F`` as ``sensor_msgs/Image`` (32FC1) in the camera's frame."""
    return m.depth_image_msg(t_ns, c.camera, image.data[:, :, 0])


def depth_image_from(msg, c: Constants):
    """The ``ImageDepth32F`` of a 32FC1 ``sensor_msgs/Image``."""
    from pydrake.systems.sensors import ImageDepth32F

    pixels = m.depth_pixels(msg)
    image = ImageDepth32F(pixels.shape[1], pixels.shape[0])
    image.mutable_data[:, :, 0] = pixels
    return image


def camera_pose_to(t_ns, X, c: Constants):
    """A RigidTransform X_WC as ``geometry_msgs/PoseStamped`` in the world frame."""
    return m.pose_stamped_msg(t_ns, c.world, X.translation(), X.rotation().ToQuaternion().wxyz())


def camera_pose_from(msg, c: Constants):
    """The RigidTransform of a ``geometry_msgs/PoseStamped`` (a quaternion off unit norm
    gives a matrix that is no rotation: the seam's screen holds the last good pose)."""
    from pydrake.math import RigidTransform, RotationMatrix

    q, p = msg.pose.orientation, msg.pose.position
    return RigidTransform(
        RotationMatrix(m.rotation_of_quaternion(q.w, q.x, q.y, q.z)), np.array([p.x, p.y, p.z])
    )


def camera_info_to(t_ns, _image, c: Constants):
    """The depth camera's ``sensor_msgs/CameraInfo`` (published with each image)."""
    assert c.camera_intrinsics is not None  # sent only with the intrinsics (ros2_link)
    return m.camera_info_msg(t_ns, c.camera, *c.camera_intrinsics)


def _float64() -> dict:
    return {
        "std_msgs/msg/Float64": PortCodec(
            lambda t_ns, v, c: m.float64_msg(v[0]), lambda msg, c: np.array([msg.data])
        )
    }


PORT_CODECS = {
    "clock": {"rosgraph_msgs/msg/Clock": PortCodec(lambda t_ns, v, c: m.clock_msg(t_ns), None)},
    "joint_states": {"sensor_msgs/msg/JointState": PortCodec(_joint_state_to, _joint_state_from)},
    "joint_commands": {"sensor_msgs/msg/JointState": PortCodec(_joint_state_to, _joint_state_from)},
    "pressure": {
        "sensor_msgs/msg/FluidPressure": PortCodec(
            lambda t_ns, v, c: m.fluid_pressure_msg(
                t_ns, c.base, v[0], c.density, c.gravity, c.depth_std
            ),
            lambda msg, c: np.array(
                [m.depth_of_pressure(msg.fluid_pressure, c.density, c.gravity)]
            ),
        ),
        **_float64(),
    },
    "imu": {
        "sensor_msgs/msg/Imu": PortCodec(
            lambda t_ns, v, c: m.imu_msg(t_ns, c.base, v, c.imu_covariances),
            lambda msg, c: imu_reading(msg),
        )
    },
    "flow_velocity": {
        "geometry_msgs/msg/Vector3Stamped": PortCodec(
            lambda t_ns, v, c: m.vector3_stamped_msg(t_ns, c.base, v),
            lambda msg, c: np.array([msg.vector.x, msg.vector.y, msg.vector.z]),
        ),
        "geometry_msgs/msg/TwistStamped": PortCodec(
            lambda t_ns, v, c: m.twist_stamped_msg(t_ns, c.base, v),
            lambda msg, c: np.array([msg.twist.linear.x, msg.twist.linear.y, msg.twist.linear.z]),
        ),
    },
    "battery": {
        "sensor_msgs/msg/BatteryState": PortCodec(
            lambda t_ns, v, c: m.battery_state_msg(
                t_ns, "", v[0], v[1], v[2], c.capacity_ah, c.cells
            ),
            lambda msg, c: battery_reading(msg),
        )
    },
    "balloon_command": _float64(),
    "balloon_volume": _float64(),
    "electrical_power": _float64(),
    "altitude": _float64(),
    "depth_image": {"sensor_msgs/msg/Image": PortCodec(depth_image_to, depth_image_from)},
    "camera_info": {"sensor_msgs/msg/CameraInfo": PortCodec(camera_info_to, None)},
    "camera_pose": {"geometry_msgs/msg/PoseStamped": PortCodec(camera_pose_to, camera_pose_from)},
}
