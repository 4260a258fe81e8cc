"""A run's ROS 2 bag (manta_drake.ros2.bag; ``manta-drake run --bag``, ``manta-drake bag``),
read back by readers the project does not write: rosbags' AnyReader, and mcap's reader with
its CRC checks and mcap-ros2-support's decoder. One real 1 s run of four_behaviors (the
IMU, the flow probe, the energy model) with its bag; its messages against its log.npz, its
fin links against the SDFormat model's joint poses, its metadata.yaml against its
messages; and the topic map's checks."""

import math
import pathlib
import shutil
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from manta_drake.cli import main
from manta_drake.ros2.bag import decimate
from manta_drake.ros2.signals import SIGNALS
from manta_drake.ros2.topic_map import load_topic_map
from manta_drake.run_folder import remove_outputs

DURATION = 1.0
TOPICS = load_topic_map()


@pytest.fixture(scope="module")
def bagged(tmp_path_factory):
    """(run folder, its log.npz arrays, its scenario) of a real run with --bag."""
    from manta_drake.scenario import load_scenario

    out = tmp_path_factory.mktemp("bag") / "run"
    assert (
        main(
            [
                "run",
                "four_behaviors",
                "--out",
                str(out),
                "--no-meshcat",
                "--quiet",
                "--set",
                f"duration={DURATION}",
                "--bag",
            ]
        )
        == 0
    )
    with np.load(out / "log.npz") as npz:
        log = {k: npz[k] for k in npz.files}
    return out, log, load_scenario(out / "scenario.yaml")


def _read(folder) -> dict:
    """topic -> [(log time ns, decoded message)] by rosbags' AnyReader."""
    out = {}
    with AnyReader([pathlib.Path(folder)]) as reader:
        for conn, t_ns, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t_ns, reader.deserialize(raw, conn.msgtype)))
    return out


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def _rows_at(times, stamps_ns) -> np.ndarray:
    """The log rows whose times are the stamps (to the nanosecond)."""
    times_ns = np.round(np.asarray(times) * 1e9).astype(np.int64)
    rows = np.searchsorted(times_ns, stamps_ns)
    assert np.array_equal(times_ns[rows], stamps_ns)
    return rows


@pytest.mark.slow
def test_each_topic_holds_duration_times_rate_messages_stamped_with_sim_time(bagged):
    out, log, _ = bagged
    topics = _read(out)
    expected = {TOPICS.topics[n].topic: TOPICS.topics[n] for n, s in SIGNALS.items() if s.bagged}
    assert set(topics) == set(expected)  # four_behaviors logs every signal a bag carries
    times_of = {TOPICS.topics[n].topic: log[s.times] for n, s in SIGNALS.items() if s.bagged}
    for topic, messages in topics.items():
        sampled = round(1.0 / np.median(np.diff(times_of[topic])))  # the signal's own rate
        rate = min(expected[topic].rate_hz, sampled)
        assert abs(len(messages) - DURATION * rate) <= 1, (topic, len(messages), rate)
        log_times = [t for t, _ in messages]
        assert log_times[0] == 0 and log_times[-1] == 1_000_000_000, topic
        assert np.all(np.diff(log_times) > 0), topic
        for t_ns, msg in messages:  # each header stamp is its log time
            stamp = (
                msg.clock
                if topic == "/clock"
                else (
                    msg.transforms[0].header.stamp
                    if topic == "/tf"
                    else None
                    if topic == "/manta/balloon_command"
                    else msg.header.stamp
                )
            )
            if stamp is not None:
                assert stamp.sec * 1_000_000_000 + stamp.nanosec == t_ns, topic


@pytest.mark.slow
def test_joint_states_are_the_logged_joints_at_their_times(bagged):
    out, log, _ = bagged
    messages = [msg for _, msg in _read(out)["/manta/joint_states"]]
    rows = _rows_at(log["t"], [_stamp(msg) for msg in messages])
    positions = np.array([msg.position for msg in messages])
    np.testing.assert_allclose(positions, log["joint_angles"][rows], rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        [msg.velocity for msg in messages], log["joint_velocities"][rows], rtol=0, atol=1e-12
    )
    torque_rows = _rows_at(log["t_joint_torque"], [_stamp(msg) for msg in messages])
    np.testing.assert_allclose(
        [msg.effort for msg in messages], log["joint_torque"][torque_rows], rtol=0, atol=1e-12
    )
    assert list(messages[0].name) == [
        f"{leg}_{j}" for leg in ("fl", "fr", "rl", "rr") for j in ("yaw", "roll1", "pitch", "roll2")
    ]
    commands = [msg for _, msg in _read(out)["/manta/joint_commands"]]
    rows = _rows_at(log["t_command"], [_stamp(msg) for msg in commands])
    np.testing.assert_allclose(
        [msg.position for msg in commands], log["commanded_joint_angles"][rows], rtol=0, atol=1e-12
    )


@pytest.mark.slow
def test_the_hull_pose_in_tf_and_pose_is_the_logged_body_pose(bagged):
    out, log, _ = bagged
    topics = _read(out)
    for topic in ("/tf", "/manta/pose"):
        frames, xyz, quat = [], [], []
        for _, msg in topics[topic]:
            stamped = msg.transforms[0] if topic == "/tf" else msg
            frames.append((stamped.header.frame_id, getattr(stamped, "child_frame_id", "")))
            if topic == "/tf":
                p, q = stamped.transform.translation, stamped.transform.rotation
            else:
                p, q = stamped.pose.position, stamped.pose.orientation
            xyz.append([p.x, p.y, p.z])
            quat.append([q.w, q.x, q.y, q.z])
        rows = _rows_at(
            log["t"], [_stamp(m.transforms[0] if topic == "/tf" else m) for _, m in topics[topic]]
        )
        np.testing.assert_allclose(xyz, log["body_xyz"][rows], rtol=0, atol=1e-12)
        np.testing.assert_allclose(quat, log["body_quat_wxyz"][rows], rtol=0, atol=1e-12)
        assert set(frames) == {("world", "base_link" if topic == "/tf" else "")}


def _rpy_matrix(r, p, y) -> np.ndarray:
    cx, sx, cy, sy, cz, sz = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return (
        np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        @ np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    )


def _sdf_joints(scenario) -> dict:
    """joint -> (parent, child, X_PC at q = 0 (4x4)) from the SDFormat text of the run's
    robot: each link's ``<pose relative_to=parent>``; the joints turn about their child's z."""
    from manta_drake.model.model_sdf import robot_sdf

    root = ET.fromstring(robot_sdf(scenario.robot_params()))
    poses = {}
    for link in root.iter("link"):
        pose = link.find("pose")
        X = np.eye(4)
        if pose is not None:
            v = [float(s) for s in pose.text.split()]
            X[:3, :3], X[:3, 3] = _rpy_matrix(*v[3:]), v[:3]
        poses[link.get("name")] = X
    return {
        j.get("name"): (j.find("parent").text, j.find("child").text, poses[j.find("child").text])
        for j in root.iter("joint")
    }


@pytest.mark.slow
def test_the_fin_links_in_tf_are_the_sdformat_joints_turned_by_the_logged_angles(bagged):
    out, log, scenario = bagged
    joints = _sdf_joints(scenario)
    names = list(joints)
    for _, msg in _read(out)["/tf"][::10]:
        row = _rows_at(log["t"], [_stamp(msg.transforms[0])])[0]
        links = {tf.child_frame_id: tf for tf in msg.transforms[1:]}
        assert len(links) == 16
        for name, angle in zip(names, log["joint_angles"][row]):
            parent, child, X0 = joints[name]
            c, s = math.cos(angle), math.sin(angle)
            X = X0 @ np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
            tf = links[child]
            assert tf.header.frame_id == ("base_link" if parent == "body" else parent)
            q, p = tf.transform.rotation, tf.transform.translation
            w, x, y, z = q.w, q.x, q.y, q.z
            R = np.array(
                [
                    [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
                ]
            )
            np.testing.assert_allclose(R, X[:3, :3], atol=1e-12)
            np.testing.assert_allclose([p.x, p.y, p.z], X[:3, 3], atol=1e-12)


@pytest.mark.slow
def test_the_sensors_are_the_logged_readings(bagged):
    out, log, scenario = bagged
    topics = _read(out)
    imu = [msg for _, msg in topics["/manta/imu"]]
    rows = _rows_at(log["t_imu"], [_stamp(msg) for msg in imu])
    np.testing.assert_allclose(
        [[m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z] for m in imu],
        log["imu"][rows, 3:6],
        atol=1e-12,
    )
    gyro = (
        math.radians(scenario.imu.gyro_noise_std_deg_s) ** 2
        + math.radians(scenario.imu.gyro_bias_std_deg_s) ** 2
    )
    assert imu[0].angular_velocity_covariance[0] == pytest.approx(gyro, rel=1e-12)
    pressure = [msg for _, msg in topics["/manta/pressure"]]
    rows = _rows_at(log["t_depth"], [_stamp(msg) for msg in pressure])
    coeffs = scenario.hydro_coefficients()
    rho_g = coeffs.water_density.value * coeffs.gravity.value
    np.testing.assert_allclose(
        [m.fluid_pressure for m in pressure], 101325.0 + rho_g * log["depth"][rows, 0], rtol=1e-14
    )
    flow = [msg for _, msg in topics["/manta/flow_velocity"]]
    rows = _rows_at(log["t_flow_velocity"], [_stamp(msg) for msg in flow])
    np.testing.assert_allclose(
        [[m.vector.x, m.vector.y, m.vector.z] for m in flow], log["flow_velocity"][rows], atol=1e-12
    )
    battery = [msg for _, msg in topics["/manta/battery"]]
    rows = _rows_at(log["t_battery"], [_stamp(msg) for msg in battery])
    np.testing.assert_allclose(
        [m.percentage for m in battery], log["battery"][rows, 0], rtol=1e-6
    )  # float32 in the message
    np.testing.assert_allclose(
        [-m.current for m in battery], log["battery"][rows, 2], rtol=1e-6, atol=1e-6
    )


@pytest.mark.slow
def test_mcaps_crc_checked_reader_decodes_every_message(bagged):
    out, _, _ = bagged
    counts = {}
    with open(out / "run.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()], validate_crcs=True)
        header, summary = reader.get_header(), reader.get_summary()
        for schema, channel, _message, decoded in reader.iter_decoded_messages():
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/manta/joint_states":
                assert len(decoded.position) == 16
    assert header.profile == "ros2"
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    stats = {
        summary.channels[i].topic: n for i, n in summary.statistics.channel_message_counts.items()
    }
    assert counts == stats
    assert sum(counts.values()) == summary.statistics.message_count


@pytest.mark.slow
def test_metadata_yaml_is_rosbag2_version_5_and_counts_the_messages(bagged):
    out, _, _ = bagged
    info = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    topics = _read(out)
    assert info["version"] == 5 and info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["run.mcap"]
    assert info["starting_time"]["nanoseconds_since_epoch"] == 0
    assert info["duration"]["nanoseconds"] == 1_000_000_000
    listed = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert {name: t["message_count"] for name, t in listed.items()} == {
        name: len(msgs) for name, msgs in topics.items()
    }
    assert (
        info["message_count"]
        == info["files"][0]["message_count"]
        == sum(len(msgs) for msgs in topics.values())
    )
    for name, entry in TOPICS.topics.items():
        if not SIGNALS[name].bagged:  # the seam's only
            continue
        qos = yaml.safe_load(listed[entry.topic]["topic_metadata"]["offered_qos_profiles"])
        assert qos[0]["reliability"] == (2 if entry.qos == "sensor_data" else 1)
        assert listed[entry.topic]["topic_metadata"]["type"] == entry.type


@pytest.mark.slow
def test_the_bag_command_makes_the_same_bag_from_the_folder(bagged, tmp_path):
    out, _, _ = bagged
    again = tmp_path / "old_run"
    again.mkdir()
    for name in ("log.npz", "scenario.yaml"):
        shutil.copy(out / name, again / name)
    assert main(["bag", str(again)]) == 0
    first, second = _read(out), _read(again)
    assert first.keys() == second.keys()
    for topic in first:
        assert [t for t, _ in first[topic]] == [t for t, _ in second[topic]], topic
    assert (again / "metadata.yaml").read_text() == (out / "metadata.yaml").read_text()
    remove_outputs(again)  # a later run in the folder removes the bag with the rest
    assert not (again / "run.mcap").exists() and not (again / "metadata.yaml").exists()


@pytest.mark.slow
def test_a_users_topic_map_renames_and_drops_topics(bagged, tmp_path):
    out, _, _ = bagged
    folder = tmp_path / "renamed"
    folder.mkdir()
    for name in ("log.npz", "scenario.yaml"):
        shutil.copy(out / name, folder / name)
    user = tmp_path / "robot_topics.yaml"
    user.write_text(
        "frames: {base: body}\ntopics:\n"
        "  joint_states: {topic: /robot/joint_states, qos: sensor_data}\n"
        "  pressure: {type: std_msgs/msg/Float64}\n"
        "  tf: {enabled: false}\n  battery: {rate_hz: 2}\n"
    )
    assert main(["bag", str(folder), "--topic-map", str(user)]) == 0
    topics = _read(folder)
    assert "/tf" not in topics and "/robot/joint_states" in topics
    assert "/manta/joint_states" not in topics
    assert len(topics["/manta/battery"]) == 3  # 0, 0.5 and 1 s
    assert topics["/manta/imu"][0][1].header.frame_id == "body"
    depth = [msg.data for _, msg in topics["/manta/pressure"]]
    with np.load(folder / "log.npz") as npz:
        np.testing.assert_array_equal(depth, npz["depth"][:, 0])  # 50 Hz: every sample


@pytest.mark.parametrize(
    "text, words",
    [
        (
            "topics: {imu: {qos: fast}}",
            "topic_map.topics.imu.qos: 'fast' is not one of default, sensor_data",
        ),
        (
            "topics: {imu: {type: sensor_msgs/msg/Range}}",
            "topic_map.topics.imu.type: 'sensor_msgs/msg/Range' is not one of sensor_msgs/msg/Imu",
        ),
        (
            "topics: {imu: {rate_hz: 0}}",
            "topic_map.topics.imu.rate_hz: 0 is outside the allowed range (0, 1000] Hz",
        ),
        (
            "topics: {imu: {topic: manta/imu}}",
            "topic_map.topics.imu.topic: 'manta/imu' is not an absolute ROS 2 topic name",
        ),
        ("topics: {imu: {topic: /clock}}", "topic_map.topics.imu.topic: /clock is also clock's"),
        ("topics: {sonar: {topic: /s}}", "topic_map.topics.sonar: not a signal; allowed: clock"),
        ("topics: {imu: {rate: 5}}", "topic_map.topics.imu.rate: unknown key"),
        ("frames: {world: base_link}", "topic_map.frames: world and base are both 'base_link'"),
        ("topics: {imu: {qos: default}, imu: {qos: default}}", "duplicate key"),
    ],
)
def test_a_bad_topic_map_is_refused_in_one_line_before_the_run(tmp_path, capfd, text, words):
    bad = tmp_path / "topics.yaml"
    bad.write_text(text + "\n")
    out = tmp_path / "never"
    assert main(["run", "stand", "--out", str(out), "--topic-map", str(bad)]) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and words in err, err
    assert not out.exists()  # refused before the folder was touched


def test_decimate_keeps_the_first_sample_at_or_after_each_grid_time():
    t = np.arange(1001) * 0.001  # 1 kHz for 1 s
    np.testing.assert_array_equal(decimate(t, 100.0), np.arange(0, 1001, 10))
    assert len(decimate(t, 30.0)) == 31  # 0, 1/30, ..., 1 s
    slow = np.array([k * 0.1 for k in range(11)])  # 3 x 0.1 = 0.30000000000000004
    np.testing.assert_array_equal(decimate(slow, 100.0), np.arange(11))
    np.testing.assert_array_equal(decimate(slow, 10.0), np.arange(11))
    np.testing.assert_array_equal(decimate(slow, 5.0), np.arange(0, 11, 2))
    assert len(decimate(np.zeros(0), 10.0)) == 0


# --- a measured bag for calibrate ----------------------------------------------------------


def _calibration(folder, experiments: str) -> pathlib.Path:
    path = folder / "calibration.yaml"
    path.write_text(
        "parameters:\n  - {name: hull, coefficients: [body.linear_damping]}\n"
        "experiments:\n" + experiments
    )
    return path


def _experiment(name: str, measured, extra: str = "") -> str:
    return (
        f"  - {{name: {name}, scenario: four_behaviors, overrides: {{duration: {DURATION}}}, "
        f"measured: {measured}{extra}}}\n"
    )


@pytest.mark.slow
def test_calibrate_reads_the_same_trajectory_from_a_bag_as_from_its_csv(bagged, tmp_path):
    """The pose topic of a run's bag (a rosbag2 folder, or its bare .mcap) gives the arrays
    of a CSV written from the run's log.npz at the same times (yaw from Drake's rpy there,
    from the quaternion here); the depth topic gives z = -depth - the sensor's height."""
    from manta_drake.calibrate.loading import experiment_measured, load_calibration

    out, log, scenario = bagged
    rows = decimate(log["t"], TOPICS.topics["pose"].rate_hz)
    lines = ["t,x,y,z,yaw"] + [
        ",".join(repr(float(v)) for v in (log["t"][i], *log["body_xyz"][i], log["body_rpy"][i, 2]))
        for i in rows
    ]
    (tmp_path / "pose.csv").write_text("\n".join(lines) + "\n")
    config = load_calibration(
        _calibration(
            tmp_path,
            "".join(
                [
                    _experiment("csv", "pose.csv"),
                    _experiment(
                        "bag",
                        out,
                        ", topics: {pose: /manta/pose, joint_states: /manta/joint_states}",
                    ),
                    _experiment("mcap", out / "run.mcap", ", topics: {pose: /manta/pose}"),
                    _experiment("depth", out, ", topics: {depth: /manta/pressure}, columns: [z]"),
                ]
            ),
        )
    )
    csv, bag, mcap_file, depth = (experiment_measured(config, e) for e in config.experiments)
    for measured in (bag, mcap_file):
        for column in ("t", "x", "y", "z", "yaw"):
            np.testing.assert_allclose(measured[column], csv[column], rtol=0, atol=1e-12)
    joint_rows = _rows_at(log["t"], np.round(bag["joint_t"] * 1e9).astype(np.int64))
    np.testing.assert_array_equal(bag["joint_positions"], log["joint_angles"][joint_rows])
    depth_rows = _rows_at(log["t_depth"], np.round(depth["t"] * 1e9).astype(np.int64))
    expected = -log["depth"][depth_rows, 0] - scenario.pressure_sensor.position[2]
    np.testing.assert_allclose(depth["z"], expected, rtol=0, atol=1e-9)


@pytest.mark.slow
def test_calibrating_against_a_runs_own_bag_finds_that_run(bagged, tmp_path, capsys):
    """``manta-drake calibrate`` with the run's bag as the measurement: the simulation at the
    run's own coefficients is the measurement (stamps, positions and headings line up), so
    the cost there is zero to round-off and the fit stays at 1."""
    import json

    out = bagged[0]
    path = _calibration(
        tmp_path, _experiment("own", out / "run.mcap", ", topics: {pose: /manta/pose}")
    )
    path.write_text(path.read_text() + "optimizer: {max_evaluations: 2}\n")
    assert (
        main(["calibrate", str(path), "--out", str(tmp_path / "fit"), "--workers", "0", "--quiet"])
        == 0
    )
    history = json.loads((tmp_path / "fit" / "calibration.json").read_text())
    assert history["cost"] < 1e-20 and history["initial_cost"] < 1e-20
    assert [p["fitted"] for p in history["parameters"]] == [1.0]
    assert (tmp_path / "fit" / "calibration.png").stat().st_size > 0


@pytest.mark.slow
@pytest.mark.parametrize(
    "measured, extra, words",
    [
        ("BAG", ", topics: {pose: /manta/nowhere}", "has no topic /manta/nowhere (its topics: "),
        (
            "BAG",
            ", topics: {pose: /manta/imu}",
            "topic /manta/imu is sensor_msgs/msg/Imu; allowed: geometry_msgs/msg/PoseStamped",
        ),
        (
            "BAG",
            ", topics: {pose: /manta/pose, depth: /manta/pressure}",
            "topics: name the bag's pose or depth topic (one of them)",
        ),
        (
            "BAG",
            ", topics: {depth: /manta/pressure}",
            "columns: ['x', 'y', 'z', 'yaw'] must be some of z",
        ),
        ("BAG", ", topics: {sonar: /s}", "topics.sonar: not one of pose, depth, joint_states"),
        ("BAG", ", topics: {pose: /manta/pose, joint_states: /manta/joint_commands}", None),
        ("pose.csv", ", topics: {pose: /manta/pose}", "topics: only for a measured ROS 2 bag"),
        ("nothing.mcap", ", topics: {pose: /manta/pose}", "nothing.mcap: no such bag"),
    ],
)
def test_a_bad_measured_bag_is_refused_in_one_line(bagged, tmp_path, measured, extra, words):
    from manta_drake.calibrate.loading import load_calibration
    from manta_drake.sweep.config import SweepError

    out = bagged[0]
    (tmp_path / "pose.csv").write_text("t,x,y,z,yaw\n0,0,0,0,0\n1,0,0,0,0\n")
    path = _calibration(tmp_path, _experiment("e", out if measured == "BAG" else measured, extra))
    if words is None:  # joint commands are joint states: a bag may name them so
        load_calibration(path)
        return
    with pytest.raises(SweepError) as error:
        load_calibration(path)
    assert "calibration.experiments[0]" in str(error.value) and words in str(error.value)
    assert len(str(error.value).splitlines()) == 1


def test_docs_hold_the_shipped_topic_map_and_the_readme_points_to_them():
    from manta_drake.ros2.topic_map import topic_table_markdown

    root = pathlib.Path(__file__).resolve().parents[1]
    docs = (root / "docs" / "ros2.md").read_text()
    assert topic_table_markdown() in docs, "docs/ros2.md: paste topic_table_markdown()"
    readme = (root / "README.md").read_text()
    assert "docs/ros2.md" in readme and "`run.mcap`" in readme and "`metadata.yaml`" in readme
