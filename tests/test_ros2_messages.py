"""The ROS 2 messages (manta_drake.ros2.messages, signals): every message type a bag holds,
made from known values by the signals' own conversions, decoded by three decoders the
project does not write (rosbags' ROS 2 Humble and Jazzy type stores, and mcap-ros2-support
reading the definition text the bag embeds), equals the values sent and their closed
forms (the quaternion from its rotation matrix, the pressure p0 + rho g h)."""

import math

import numpy as np
import pytest
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_typestore

from manta_drake.model.robot_params import JOINT_NAMES
from manta_drake.ros2 import messages as m
from manta_drake.ros2.signals import SIGNALS, Constants, held

STORES = {name: get_typestore(getattr(Stores, name)) for name in ("ROS2_HUMBLE", "ROS2_JAZZY")}
RNG = np.random.default_rng(20260501)
T_S = 12.3456789012  # s: a stamp with sec and nanosec parts
T_NS = m.to_nanoseconds(T_S)


def _rotation(rpy) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll) as matrices."""
    r, p, y = rpy
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _matrix_of(q) -> np.ndarray:
    """The rotation matrix of a decoded geometry_msgs/Quaternion (x, y, z, w)."""
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _unit_quaternion_wxyz() -> np.ndarray:
    q = RNG.normal(size=4)
    return q / np.linalg.norm(q)


LOG = {  # one sample of every array a bag reads, with its times
    "t": np.array([T_S]),
    "t_command": np.array([T_S]),
    "joint_angles": RNG.uniform(-1, 1, (1, 16)),
    "joint_velocities": RNG.uniform(-3, 3, (1, 16)),
    "commanded_joint_angles": RNG.uniform(-1, 1, (1, 16)),
    "t_joint_torque": np.array([T_S - 0.001, T_S]),
    "joint_torque": RNG.uniform(-2, 2, (2, 16)),
    "body_xyz": np.array([[-3.2, 0.4, -0.12]]),
    "body_quat_wxyz": _unit_quaternion_wxyz()[None],
    "t_imu": np.array([T_S]),
    "imu": np.array([[0.1, -0.2, 2.5, 0.01, -0.3, 0.2, 0.4, -0.1, 9.6]]),
    "t_depth": np.array([T_S]),
    "depth": np.array([[0.1234]]),
    "t_flow_velocity": np.array([T_S]),
    "flow_velocity": np.array([[-0.08, 0.01, 0.002]]),
    "t_battery": np.array([T_S]),
    "battery": np.array([[0.83, 16.1, 1.7]]),
    "t_balloon_command": np.array([T_S]),
    "balloon_command": np.array([[0.35]]),
}
LINK = ("base_link", "fl_link1", np.array([0.1, 0.1, 0.0]), _unit_quaternion_wxyz())
CONSTANTS = Constants(
    joint_names=JOINT_NAMES,
    world="pool",
    base="hull",
    imu_covariances=tuple(np.diag(v).ravel() for v in ([1e-4] * 3, [2e-4] * 3, [3e-3] * 3)),
    density=997.0,
    gravity=9.80665,
    depth_std=0.002,
    capacity_ah=5.0,
    cells=4,
    fin_links=lambda q: [LINK],
)
CASES = [(name, ros_type) for name, s in SIGNALS.items() if s.bagged for ros_type in s.types]


def _decoders(ros_type: str) -> dict:
    """Decoders of ``ros_type``'s CDR: rosbags' Humble and Jazzy stores, and
    mcap-ros2-support from the definition text a bag's schema holds."""
    out = {
        name: (lambda raw, s=store: s.deserialize_cdr(raw, ros_type))
        for name, store in STORES.items()
    }
    schema = Schema(id=1, name=ros_type, encoding="ros2msg", data=m.msgdef(ros_type).encode())
    out["mcap-ros2-support"] = DecoderFactory().decoder_for("cdr", schema)
    return out


def _stamp_ok(header, frame: str) -> None:
    assert (header.stamp.sec, header.stamp.nanosec) == (12, 345678901)
    assert header.frame_id == frame


def _check_pose(msg) -> None:
    np.testing.assert_array_equal(
        [msg.position.x, msg.position.y, msg.position.z], LOG["body_xyz"][0]
    )
    w, x, y, z = LOG["body_quat_wxyz"][0]
    assert (msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w) == (
        x,
        y,
        z,
        w,
    )


def _expect(name: str, ros_type: str, msg) -> None:
    """``msg`` (decoded) holds what signal ``name`` was given, by the message's rules."""
    if name == "clock":
        assert (msg.clock.sec, msg.clock.nanosec) == (12, 345678901)
    elif name == "joint_states":
        _stamp_ok(msg.header, "")
        assert list(msg.name) == list(JOINT_NAMES)
        np.testing.assert_array_equal(msg.position, LOG["joint_angles"][0])
        np.testing.assert_array_equal(msg.velocity, LOG["joint_velocities"][0])
        np.testing.assert_array_equal(msg.effort, LOG["joint_torque"][1])  # the one at t
    elif name == "joint_commands":
        np.testing.assert_array_equal(msg.position, LOG["commanded_joint_angles"][0])
        assert len(msg.velocity) == len(msg.effort) == 0  # not known: empty
    elif name == "pose":
        _stamp_ok(msg.header, "pool")
        _check_pose(msg.pose)
    elif name == "tf":
        hull, link = msg.transforms
        _stamp_ok(hull.header, "pool")
        assert hull.child_frame_id == "hull"
        t, r = hull.transform.translation, hull.transform.rotation
        _check_pose(type("P", (), {"position": t, "orientation": r}))
        assert (link.header.frame_id, link.child_frame_id) == LINK[:2]
        assert (link.transform.rotation.w, link.transform.rotation.x) == tuple(LINK[3][:2])
    elif name == "imu":
        _stamp_ok(msg.header, "hull")
        r = LOG["imu"][0]
        np.testing.assert_allclose(_matrix_of(msg.orientation), _rotation(r[:3]), atol=1e-15)
        v = msg.angular_velocity, msg.linear_acceleration
        np.testing.assert_array_equal([v[0].x, v[0].y, v[0].z, v[1].x, v[1].y, v[1].z], r[3:])
        np.testing.assert_array_equal(
            msg.linear_acceleration_covariance, CONSTANTS.imu_covariances[2]
        )
    elif ros_type == "sensor_msgs/msg/FluidPressure":
        _stamp_ok(msg.header, "hull")
        rho_g = 997.0 * 9.80665
        assert msg.fluid_pressure == pytest.approx(101325.0 + rho_g * 0.1234, rel=1e-15)
        assert msg.variance == pytest.approx((rho_g * 0.002) ** 2, rel=1e-15)
    elif name == "pressure":
        assert msg.data == 0.1234
    elif name == "flow_velocity":
        _stamp_ok(msg.header, "hull")
        v = msg.vector if ros_type.endswith("Vector3Stamped") else msg.twist.linear
        assert (v.x, v.y, v.z) == tuple(LOG["flow_velocity"][0])
    elif name == "battery":
        _stamp_ok(msg.header, "")
        assert msg.current == pytest.approx(-1.7)  # ROS: negative while discharging
        assert msg.percentage == pytest.approx(0.83) and msg.charge == pytest.approx(0.83 * 5)
        assert msg.power_supply_status == 2  # DISCHARGING, the message's own constant
        assert msg.voltage == pytest.approx(16.1) and len(msg.cell_voltage) == 4
        assert math.isnan(msg.temperature) and all(math.isnan(v) for v in msg.cell_voltage)
    elif name == "balloon_command":
        assert msg.data == 0.35
    else:
        raise AssertionError(f"no expectation for {name}")


@pytest.mark.parametrize("name, ros_type", CASES, ids=[f"{n}-{t}" for n, t in CASES])
def test_every_message_decodes_to_the_values_sent(name, ros_type):
    raw = m.serialize(SIGNALS[name].types[ros_type](LOG, 0, T_NS, CONSTANTS))
    assert raw[:4] == b"\x00\x01\x00\x00"  # CDR little endian, as rmw sends it
    for decoder, decode in _decoders(ros_type).items():
        msg = decode(raw)
        _expect(name, ros_type, msg)
        if decoder != "mcap-ros2-support":  # the same bytes again: nothing lost or added
            assert bytes(STORES[decoder].serialize_cdr(msg, ros_type)) == raw


def test_every_type_is_laid_out_alike_in_humble_and_jazzy():
    """A bag declares Humble's definitions; Jazzy's readers see the same layout."""
    for ros_type in {t for _, t in CASES}:
        humble, jazzy = (s.hash_rihs01(ros_type) for s in STORES.values())
        assert humble == jazzy, ros_type


@pytest.mark.parametrize("rpy", [(0.3, -0.7, 2.9), (-2.0, 1.2, -0.4), (0.0, 0.0, -math.pi)])
def test_quaternion_from_rpy_is_the_rotation_rz_ry_rx(rpy):
    w, x, y, z = m.quaternion_from_rpy(*rpy)
    q = type("Q", (), {"w": w, "x": x, "y": y, "z": z})
    np.testing.assert_allclose(_matrix_of(q), _rotation(rpy), atol=1e-15)
    yaw = math.atan2(_rotation(rpy)[1, 0], _rotation(rpy)[0, 0])
    assert m.yaw_of_quaternion(w, x, y, z) == pytest.approx(yaw, abs=1e-14)
    # A quaternion off unit norm (a simulator's state) has the same heading.
    assert m.yaw_of_quaternion(*(1.3 * np.array([w, x, y, z]))) == pytest.approx(yaw, abs=1e-14)


def test_pressure_and_depth_are_inverse_closed_forms():
    depth = np.array([0.0, 0.05, 0.5, 3.0])
    p = m.pressure_of_depth(depth, 1025.0, 9.81)
    np.testing.assert_allclose(p, 101325.0 + 1025.0 * 9.81 * depth, rtol=1e-15)
    np.testing.assert_allclose(m.depth_of_pressure(p, 1025.0, 9.81), depth, atol=1e-12)


def test_an_imu_without_covariances_says_unknown_in_element_0():
    msg = STORES["ROS2_JAZZY"].deserialize_cdr(
        m.serialize(m.imu_msg(0, "b", np.zeros(9))), "sensor_msgs/msg/Imu"
    )
    for cov in (
        msg.orientation_covariance,
        msg.angular_velocity_covariance,
        msg.linear_acceleration_covariance,
    ):
        assert cov[0] == -1.0 and not cov[1:].any()


def test_stamps_split_into_seconds_and_nanoseconds():
    for t, sec, ns in (
        (0.0, 0, 0),
        (0.001, 0, 1_000_000),
        (2.999999999, 2, 999_999_999),
        (0.30000000000000004, 0, 300_000_000),
    ):
        stamp = m.time_msg(m.to_nanoseconds(t))
        assert (stamp.sec, stamp.nanosec) == (sec, ns)


def test_held_is_the_last_sample_at_or_before():
    t, v = np.array([0.0, 0.1, 0.2]), np.array([10.0, 11.0, 12.0])
    assert [held(t, v, x) for x in (0.0, 0.05, 0.1, 0.30000000000000004 - 0.1, 9.0)] == [
        10.0,
        10.0,
        11.0,
        12.0,
        12.0,
    ]
