"""The signals a run's bag carries: for each, the log arrays it is made of (``log.npz``'s
names), the ROS 2 message types it may be written as (the first is the default) and the
conversion of one logged sample into each (``SIGNALS``). The topic map names a topic, a
type, a QoS profile and a rate per signal (``topic_map``); ``bag`` writes them.

A signal whose arrays a run did not log (a sensor the scenario lacks) is not written.
The station's ports and the controller's commands each have a signal. Some are carried
only live, by the seam over ROS 2 (``manta_drake.seam.ros2_link``; no log arrays, never in
a bag): the depth image with its camera info and the camera pose (``log.npz`` holds
neither), the altimeter's range, the balloon volume and the electrical power as
``std_msgs/Float64`` (``sensor_msgs/Range`` gained a ``variance`` field in Jazzy, so one
type cannot carry it for Humble and Jazzy alike, and no standard message is a power
reading), and the seam's handshake.
"""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Callable

import numpy as np

from manta_drake.ros2 import messages as m


@dc.dataclass(frozen=True)
class Constants:
    """What the conversions take from the scenario (``bag.bag_constants``).

    Attributes:
        joint_names: the plant's 16 joint names, the log's joint columns' order.
        world, base, camera: the world's, the hull's and the depth camera's frame ids.
        imu_covariances: the IMU's three (9,) covariances (``messages.imu_msg``), or None.
        density, gravity: the water's [kg/m^3] and gravity [m/s^2] (the pressure).
        depth_std: the pressure sensor's noise [m].
        capacity_ah, cells: the battery pack's capacity and cells in series.
        fin_links: q (16,) -> [(parent, child, xyz, quat_wxyz)], the fin links' transforms
            (``tf.FinLinks``), or None: the hull only.
        camera_intrinsics: the depth camera's (width, height, fx, fy, cx, cy) [px], or None.
    """

    joint_names: tuple
    world: str = "world"
    base: str = "base_link"
    camera: str = "camera_depth_optical_frame"
    imu_covariances: tuple | None = None
    density: float = 1000.0
    gravity: float = 9.81
    depth_std: float = 0.0
    capacity_ah: float = 1.0
    cells: int = 1
    fin_links: Callable | None = None
    # (width, height, fx, fy, cx, cy) [px]
    camera_intrinsics: tuple[int, int, float, float, float, float] | None = None


# A conversion: (log, sample index, stamp [ns], constants) -> message.
Convert = Callable[[dict, int, int, Constants], object]


@dc.dataclass(frozen=True)
class Signal:
    """One signal of the bag.

    Attributes:
        name: its key in the topic map.
        times: the log array of its sample times.
        arrays: the log arrays it is made of (all present, or the signal is not written).
        types: ROS 2 type -> conversion from a log (None: the live seam only); the first is
            the default.
        what: one line for the docs.
    """

    name: str
    times: str
    arrays: tuple[str, ...]
    types: dict[str, Convert | None]
    what: str

    @property
    def bagged(self) -> bool:
        """Whether a bag may carry it (it has log arrays); else the live seam only."""
        return bool(self.times)

    def present(self, log) -> bool:
        return self.bagged and all(k in log and len(log[k]) for k in (self.times, *self.arrays))


def held(t_samples, values, t: float):
    """The sample of ``values`` logged last at or before ``t`` (a zero-order hold; the
    first sample before the first time); 1 ns of slack for float round-off."""
    i = int(np.searchsorted(t_samples, t + 1e-9, side="right")) - 1
    return values[max(i, 0)]


def _effort(log, t):
    if "joint_torque" not in log or not len(log["joint_torque"]):
        return None
    return held(log["t_joint_torque"], log["joint_torque"], t)


def _joint_states(log, i, t_ns, c):
    return m.joint_state_msg(
        t_ns,
        c.joint_names,
        log["joint_angles"][i],
        log["joint_velocities"][i],
        _effort(log, log["t"][i]),
    )


def _joint_commands(log, i, t_ns, c):
    return m.joint_state_msg(t_ns, c.joint_names, log["commanded_joint_angles"][i])


def _pose(log, i, t_ns, c):
    return m.pose_stamped_msg(t_ns, c.world, log["body_xyz"][i], log["body_quat_wxyz"][i])


def _tf(log, i, t_ns, c):
    hull = m.transform_stamped(t_ns, c.world, c.base, log["body_xyz"][i], log["body_quat_wxyz"][i])
    links = c.fin_links(log["joint_angles"][i]) if c.fin_links is not None else []
    return m.tf_msg(
        [hull]
        + [
            m.transform_stamped(t_ns, parent, child, xyz, quat)
            for parent, child, xyz, quat in links
        ]
    )


def _imu(log, i, t_ns, c):
    return m.imu_msg(t_ns, c.base, log["imu"][i], c.imu_covariances)


def _pressure(log, i, t_ns, c):
    return m.fluid_pressure_msg(t_ns, c.base, log["depth"][i][0], c.density, c.gravity, c.depth_std)


def _battery(log, i, t_ns, c):
    soc, volts, amps = log["battery"][i]
    return m.battery_state_msg(t_ns, "", soc, volts, amps, c.capacity_ah, c.cells)


SIGNALS = {
    s.name: s
    for s in (
        Signal(
            "clock",
            "t",
            (),
            {"rosgraph_msgs/msg/Clock": lambda log, i, t_ns, c: m.clock_msg(t_ns)},
            "the simulated time (for nodes with `use_sim_time`)",
        ),
        Signal(
            "joint_states",
            "t",
            ("joint_angles", "joint_velocities"),
            {"sensor_msgs/msg/JointState": _joint_states},
            "the 16 servos' measured angles [rad], rates [rad/s] and torques [N m] (the last "
            "`joint_torque` at or before each sample)",
        ),
        Signal(
            "joint_commands",
            "t_command",
            ("commanded_joint_angles",),
            {"sensor_msgs/msg/JointState": _joint_commands},
            "the controller's desired angles [rad] (log.npz keeps no desired rates)",
        ),
        Signal(
            "pose",
            "t",
            ("body_xyz", "body_quat_wxyz"),
            {"geometry_msgs/msg/PoseStamped": _pose},
            "the hull's pose in the world (ground truth)",
        ),
        Signal(
            "tf",
            "t",
            ("body_xyz", "body_quat_wxyz", "joint_angles"),
            {"tf2_msgs/msg/TFMessage": _tf},
            "world -> hull, and each joint's parent link -> child link",
        ),
        Signal(
            "imu",
            "t_imu",
            ("imu",),
            {"sensor_msgs/msg/Imu": _imu},
            "the AHRS's attitude, body rates and specific force, hull axes",
        ),
        Signal(
            "pressure",
            "t_depth",
            ("depth",),
            {
                "sensor_msgs/msg/FluidPressure": _pressure,
                "std_msgs/msg/Float64": lambda log, i, t_ns, c: m.float64_msg(log["depth"][i][0]),
            },
            "the pressure sensor: absolute pressure [Pa] (Float64: its depth [m])",
        ),
        Signal(
            "flow_velocity",
            "t_flow_velocity",
            ("flow_velocity",),
            {
                "geometry_msgs/msg/Vector3Stamped": lambda log, i, t_ns, c: m.vector3_stamped_msg(
                    t_ns, c.base, log["flow_velocity"][i]
                ),
                "geometry_msgs/msg/TwistStamped": lambda log, i, t_ns, c: m.twist_stamped_msg(
                    t_ns, c.base, log["flow_velocity"][i]
                ),
            },
            "the water's velocity past the head probe, hull axes [m/s]",
        ),
        Signal(
            "battery",
            "t_battery",
            ("battery",),
            {"sensor_msgs/msg/BatteryState": _battery},
            "the pack's charge, terminal voltage and current",
        ),
        Signal(
            "balloon_command",
            "t_balloon_command",
            ("balloon_command",),
            {
                "std_msgs/msg/Float64": lambda log, i, t_ns, c: m.float64_msg(
                    log["balloon_command"][i][0]
                )
            },
            "the commanded balloon fill, 0 (empty) to 1 (full)",
        ),
        # The seam over ROS 2 only: no log arrays, no conversion from a log.
        Signal(
            "depth_image",
            "",
            (),
            {"sensor_msgs/msg/Image": None},
            "the head camera's noisy depth image [m], `32FC1`",
        ),
        Signal(
            "camera_info",
            "",
            (),
            {"sensor_msgs/msg/CameraInfo": None},
            "the depth camera's intrinsics, with every image",
        ),
        Signal(
            "camera_pose",
            "",
            (),
            {"geometry_msgs/msg/PoseStamped": None},
            "the camera's pose X_WC (on the robot: IMU attitude + pressure depth)",
        ),
        Signal(
            "altitude",
            "",
            (),
            {"std_msgs/msg/Float64": None},
            "the echo sounder's range to the floor [m] (NaN without an echo)",
        ),
        Signal(
            "balloon_volume", "", (), {"std_msgs/msg/Float64": None}, "the balloon's volume [m^3]"
        ),
        Signal(
            "electrical_power",
            "",
            (),
            {"std_msgs/msg/Float64": None},
            "what the servos and the computers draw [W]",
        ),
        Signal(
            "seam_handshake",
            "",
            (),
            {"diagnostic_msgs/msg/DiagnosticStatus": None},
            "the seam's handshake: who runs, how, and its end",
        ),
    )
}
