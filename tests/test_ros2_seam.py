"""The seam over ROS 2 (manta_drake.ros2.dds, ros2.ports, seam.ros2_link): DDS names, types,
QoS and type hashes read back from DDS discovery; payloads decoded with rosbags' Humble and
Jazzy stores; the station and the controller in two processes over DDS on loopback against
the single diagram; the handshake's refusals; what is skipped and clipped; the controller's
failsafe over ROS 2 and over LCM. No ROS 2 installation: real DDS traffic on 127.0.0.1
(the shipped loopback configuration, multicast off) in a domain of this test run's own."""

import json
import math
import os
import pathlib
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.sensors import ImageDepth32F
from rosbags.typesys import Stores, get_typestore

from manta_drake import seam
from manta_drake.model.robot_params import JOINT_NAMES
from manta_drake.ros2 import dds
from manta_drake.ros2 import messages as m
from manta_drake.ros2.bag import bag_constants
from manta_drake.ros2.ports import PORT_CODECS, PORT_SIGNALS, stamp_ns
from manta_drake.ros2.topic_map import QOS_PROFILES, load_topic_map
from manta_drake.scenario import load_scenario
from manta_drake.seam.ros2_link import SOURCE_EPOCH_NS, Ros2Transport, channel_signals

REPO = pathlib.Path(__file__).resolve().parents[1]
STORES = {name: get_typestore(getattr(Stores, name)) for name in ("ROS2_HUMBLE", "ROS2_JAZZY")}
TOPICS = load_topic_map()
_DOMAINS = iter(range(20))


def domain_free() -> int:
    """A number new for each use (an LCM port offset)."""
    return next(_DOMAINS)


def fresh_domain() -> int:
    """A DDS domain of this test run's own (from the pid), new for each use: concurrent runs
    and earlier tests' participants do not meet."""
    return 100 + (os.getpid() * 7 + next(_DOMAINS)) % 130


def _scenario(name="four_behaviors", duration=1.0):
    s = load_scenario(name, {"duration": duration})
    s.visualization.meshcat = False
    return s


def _transport(who, domain, scenario=None):
    scenario = scenario or _scenario()
    return Ros2Transport(who, domain, TOPICS, bag_constants(scenario, TOPICS, fin_links=False))


# ---------------------------------------------------------------------------------------
# Names, types and the port conversions (pure)


def test_ros2_names_map_to_dds_names_as_rmw_maps_them():
    assert dds.dds_topic_name("/manta/joint_states") == "rt/manta/joint_states"
    assert dds.dds_type_name("sensor_msgs/msg/JointState") == "sensor_msgs::msg::dds_::JointState_"
    assert dds.user_data("std_msgs/msg/Float64") == (
        b"typehash=" + STORES["ROS2_JAZZY"].hash_rihs01("std_msgs/msg/Float64").encode() + b";"
    )
    with pytest.raises(dds.DdsError, match=r"--domain 233: .* integer in 0-232"):
        dds.check_domain(233)


SEAM_TYPES = sorted(
    {t for codecs in PORT_CODECS.values() for t in codecs} | {TOPICS.topics["seam_handshake"].type}
)


@pytest.mark.slow
@pytest.mark.parametrize("typename", SEAM_TYPES)
def test_types_are_laid_out_alike_in_humble_and_jazzy_and_cyclones_idl(typename):
    """Each type the seam carries: the same hash in Humble's and Jazzy's stores, and the IDL
    struct generated for Cyclone names itself as rmw does and reads rosbags' bytes back to
    the very same bytes (Cyclone's own serializer, independent of rosbags')."""
    humble, jazzy = (s.hash_rihs01(typename) for s in STORES.values())
    assert humble == jazzy
    idl = dds.idl_type(typename)
    assert idl.__idl_typename__ == dds.dds_type_name(typename)
    raw = m.serialize(_sample(typename))
    assert raw[:4] == b"\x00\x01\x00\x00"  # CDR little endian (XCDR1)
    assert idl.deserialize(raw).serialize(use_version_2=False) == raw


def _sample(typename):
    """A message of ``typename`` with values in every field the seam fills."""
    c = bag_constants(_scenario("three_behaviors"), TOPICS, fin_links=False)
    image = ImageDepth32F(4, 3)
    image.mutable_data[:, :, 0] = np.arange(12, dtype=np.float32).reshape(3, 4) / 7
    values = {
        "sensor_msgs/msg/JointState": np.linspace(-1, 1, 32),
        "sensor_msgs/msg/FluidPressure": [0.37],
        "std_msgs/msg/Float64": [0.25],
        "sensor_msgs/msg/Imu": [0.1, -0.2, 2.5, 0.01, -0.3, 0.2, 0.4, -0.1, 9.6],
        "geometry_msgs/msg/Vector3Stamped": [0.1, 0.2, -0.3],
        "geometry_msgs/msg/TwistStamped": [0.1, 0.2, -0.3],
        "sensor_msgs/msg/BatteryState": [0.8, 16.2, 1.5],
        "sensor_msgs/msg/Image": image,
        "sensor_msgs/msg/CameraInfo": image,
        "geometry_msgs/msg/PoseStamped": RigidTransform(
            RollPitchYaw(0.1, 0.2, 0.3), [1.0, 2.0, -0.5]
        ),
        "rosgraph_msgs/msg/Clock": None,
    }
    if typename == "diagnostic_msgs/msg/DiagnosticStatus":
        return m.diagnostic_status_msg(0, "n", "m", "h", {"k": "v"})
    signal = next(s for s, codecs in PORT_CODECS.items() if typename in codecs)
    return PORT_CODECS[signal][typename].to_msg(1_234_567_891, values[typename], c)


def test_port_values_cross_exactly_or_within_the_documented_rounding(rng):
    """Each port's value -> message -> CDR -> rosbags (Humble and Jazzy) -> value: exact for
    the joint states, the flow, the Float64s and the depth image; the IMU's attitude within
    1e-15 rad of the one Drake's RollPitchYaw gives; the depth within 1e-12 m; the battery
    within float32."""
    c = bag_constants(_scenario("four_behaviors"), TOPICS, fin_links=False)

    def cross(signal, typename, value, store):
        raw = m.serialize(PORT_CODECS[signal][typename].to_msg(5_000_000, value, c))
        msg = STORES[store].deserialize_cdr(raw, typename)
        assert stamp_ns(msg) == 5_000_000 or typename == "std_msgs/msg/Float64"
        return PORT_CODECS[signal][typename].from_msg(msg, c)

    for store in STORES:
        x = rng.uniform(-1, 1, 32)
        order = rng.permutation(16)  # a driver's other order: matched by name
        shuffled = m.joint_state_msg(
            0, [JOINT_NAMES[i] for i in order], x[:16][order], x[16:][order]
        )
        back = PORT_CODECS["joint_states"]["sensor_msgs/msg/JointState"].from_msg(shuffled, c)
        np.testing.assert_array_equal(back, x)
        np.testing.assert_array_equal(
            cross("joint_commands", "sensor_msgs/msg/JointState", x, store), x
        )
        flow = rng.normal(size=3)
        np.testing.assert_array_equal(
            cross("flow_velocity", "geometry_msgs/msg/Vector3Stamped", flow, store), flow
        )
        for signal in ("balloon_command", "altitude", "balloon_volume", "electrical_power"):
            assert cross(signal, "std_msgs/msg/Float64", [0.1234], store)[0] == 0.1234
        rpy = np.array([0.3, -1.1, 2.9])
        imu = np.r_[rpy, rng.normal(size=6)]
        got = cross("imu", "sensor_msgs/msg/Imu", imu, store)
        np.testing.assert_array_equal(got[3:], imu[3:])
        R = RollPitchYaw(got[:3]).ToRotationMatrix().matrix()
        np.testing.assert_allclose(R, RollPitchYaw(rpy).ToRotationMatrix().matrix(), atol=1e-15)
        assert np.abs(got[:3] - rpy).max() < 1e-15
        assert cross("pressure", "sensor_msgs/msg/FluidPressure", [0.4321], store)[
            0
        ] == pytest.approx(0.4321, abs=1e-12)
        soc, volts, amps = cross("battery", "sensor_msgs/msg/BatteryState", [0.8, 16.2, 1.5], store)
        assert (soc, volts, amps) == pytest.approx((0.8, 16.2, 1.5), rel=1e-7)
        image = ImageDepth32F(5, 2)
        image.mutable_data[:, :, 0] = rng.uniform(0, 1, (2, 5)).astype(np.float32)
        image.mutable_data[0, 1, 0] = np.nan
        back = cross("depth_image", "sensor_msgs/msg/Image", image, store)
        np.testing.assert_array_equal(back.data, image.data)
        X = RigidTransform(RollPitchYaw(0.2, -0.4, 1.3), [0.5, -0.1, -0.3])
        back = cross("camera_pose", "geometry_msgs/msg/PoseStamped", X, store)
        np.testing.assert_allclose(back.GetAsMatrix4(), X.GetAsMatrix4(), atol=1e-15)


def test_every_seam_channel_has_an_enabled_topic_and_a_conversion():
    for channel in seam.CHANNELS:
        assert channel.port in PORT_SIGNALS, channel.name
        for sending in (True, False):
            for signal in channel_signals(channel, sending):
                entry = TOPICS.topics[signal]
                assert entry.enabled and entry.type in PORT_CODECS[signal], signal
    assert channel_signals(seam.CLOCK, sending=False) == ["clock"]  # lockstep on /clock


# ---------------------------------------------------------------------------------------
# Options: each refused in one line, before anything is built


@pytest.fixture
def nothing_built(monkeypatch):
    """Fails the test if a side builds its diagram."""
    from manta_drake.seam import controller_process, station_process

    def built(*_args, **_kwargs):
        raise AssertionError("a side was built before its options were checked")

    monkeypatch.setattr(station_process, "build_station", built)
    monkeypatch.setattr(controller_process, "build_controller", built)


@pytest.mark.parametrize("side", ["station", "controller"])
@pytest.mark.parametrize(
    "args, env, line",
    [
        (["--domain", "3"], {}, "--domain is an option of the seam over ROS 2: give --ros2 too"),
        (
            ["--ros2", "--domain", "233"],
            {},
            "--domain 233: a ROS 2 (DDS) domain id is an integer in 0-232",
        ),
        (
            ["--ros2"],
            {"ROS_DOMAIN_ID": "seven"},
            "ROS_DOMAIN_ID='seven': a ROS 2 domain id is an integer in 0-232 (or give --domain N)",
        ),
        (
            ["--ros2", "--lcm", "udpm://239.255.76.67:7667"],
            {},
            "--lcm and --ros2: the seam runs over one transport; give one",
        ),
        (
            ["--ros2", "--dds-config", "/nonexistent/cyclone.xml"],
            {},
            "--dds-config /nonexistent/cyclone.xml: cannot be read",
        ),
        (["--ros2", "--dds-config", str(REPO / "models" / "ros2_topics.yaml")], {}, "not XML"),
        (
            ["--ros2", "--topic-map", str(REPO / "models" / "cyclonedds_loopback.xml")],
            {},
            "cyclonedds_loopback.xml",
        ),
    ],
)
def test_bad_ros2_options_are_one_line_each_before_anything_is_built(
    capfd, nothing_built, monkeypatch, side, args, env, line
):
    from manta_drake.cli import main

    for key, value in env.items():
        monkeypatch.setenv(key, value)
    assert main([side, "stand", "--quiet", *args]) == 2
    err = [e for e in capfd.readouterr().err.splitlines() if e.strip()]
    assert len(err) == 1, err
    assert err[0].startswith("manta-drake: error: ") and line in err[0], err[0]


@pytest.mark.parametrize(
    "argv, line",
    [
        (["station", "stand", "--quiet", "--ros2"], "--ros2 needs the cyclonedds package"),
        (["controller", "stand", "--quiet", "--ros2"], "--ros2 needs the cyclonedds package"),
        (
            ["run", "stand", "--out", "unused", "--quiet", "--foxglove"],
            "--foxglove needs the foxglove-sdk package",
        ),
    ],
)
def test_without_the_ros2_extra_its_options_are_refused_in_one_line(
    capfd, nothing_built, monkeypatch, argv, line
):
    """The live ROS 2 packages are an optional extra: an install without them refuses
    --ros2 and --foxglove in one line that says what to install, before anything runs."""
    import importlib.util

    from manta_drake import simulate
    from manta_drake.cli import main

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name in ("cyclonedds", "foxglove") else real(name, *a),
    )
    monkeypatch.setattr(simulate, "run", lambda *a, **k: pytest.fail("the run started"))
    assert main(argv) == 2
    err = [e for e in capfd.readouterr().err.splitlines() if e.strip()]
    assert len(err) == 1 and line in err[0] and "pip install 'manta_drake[ros2]'" in err[0], err


def test_the_failsafe_delay_is_checked(capfd, nothing_built):
    from manta_drake.cli import main

    assert main(["controller", "stand", "--quiet", "--failsafe-after", "0"]) == 2
    assert "--failsafe-after: 0.0 is outside the allowed range (0, inf) s" in capfd.readouterr().err


# ---------------------------------------------------------------------------------------
# Real DDS traffic, in this process


def _wait(predicate, timeout=10.0, poll=None):
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        if poll is not None:
            poll(20)
        else:
            time.sleep(0.02)
    return True


def test_discovery_sees_rmw_names_qos_xcdr1_and_typehash_and_payloads_decode():
    """A station-side transport publishes one message per channel it sends; a second
    participant reads each writer's topic, type, reliability, durability, history,
    data representation and USER_DATA from DCPSPublication (DDS discovery, not our own
    tables), and receives the payloads, which rosbags' Humble and Jazzy stores decode to
    the values sent."""
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication
    from cyclonedds.core import Policy

    domain = fresh_domain()
    scenario = _scenario("four_behaviors")
    station = _transport("station", domain, scenario)
    observer = dds.Participant(domain)
    received = {}
    sends = [
        seam.CHANNEL_BY_NAME[n]
        for n in (
            "MANTA_MEASURED_JOINT_STATE",
            "MANTA_DEPTH",
            "MANTA_IMU",
            "MANTA_BATTERY",
            "MANTA_BALLOON_VOLUME",
        )
    ]
    for channel in sends:
        for signal in channel_signals(channel, sending=True):
            e = TOPICS.topics[signal]
            observer.reader(
                e.topic,
                e.type,
                e.qos,
                lambda data, src, topic=e.topic: received.setdefault(topic, []).append((data, src)),
            )
    publications = BuiltinDataReader(observer.participant, BuiltinTopicDcpsPublication)
    seen = {}
    x = np.linspace(-0.5, 0.5, 32)
    values = {
        "MANTA_MEASURED_JOINT_STATE": x,
        "MANTA_DEPTH": np.array([0.2]),
        "MANTA_IMU": np.array([0.1, 0.2, 0.3, 0.01, 0.02, 0.03, 0.1, 0.2, 9.8]),
        "MANTA_BATTERY": np.array([0.9, 16.0, 1.2]),
        "MANTA_BALLOON_VOLUME": np.array([3.5e-4]),
    }
    topics = [TOPICS.topics[s].topic for c in sends for s in channel_signals(c, sending=True)]

    def discovered_and_received():
        for channel in sends:  # sent until the matched readers have it (discovery races)
            station.send(channel.name, station.message(channel, 0.25, values[channel.name]))
        observer.handle(50)
        for p in publications.take(N=100):
            seen[p.topic_name] = p
        return all(dds.dds_topic_name(t) in seen for t in topics) and all(
            t in received for t in topics
        )

    assert _wait(discovered_and_received), (sorted(seen), sorted(received))
    for channel in sends:
        for signal in channel_signals(channel, sending=True):
            e = TOPICS.topics[signal]
            pub = seen[dds.dds_topic_name(e.topic)]
            assert pub.type_name == dds.dds_type_name(e.type)
            reliability = pub.qos[Policy.Reliability]
            profile = QOS_PROFILES[e.qos]
            assert isinstance(reliability, Policy.Reliability.Reliable) == (
                profile["reliability"] == 1
            ), e.topic
            assert pub.qos[Policy.Durability] == Policy.Durability.Volatile
            assert pub.qos[Policy.History] == Policy.History.KeepLast(profile["depth"])
            representation = pub.qos[Policy.DataRepresentation]
            assert representation.use_cdrv0_representation
            assert not representation.use_xcdrv2_representation  # XCDR1 only
            hash_ = STORES["ROS2_JAZZY"].hash_rihs01(e.type)
            assert pub.qos[Policy.Userdata].data == f"typehash={hash_};".encode()
            data, source = received[e.topic][-1]
            assert data[:4] == b"\x00\x01\x00\x00"
            assert source == SOURCE_EPOCH_NS + 250_000_000
            for store in STORES.values():
                msg = store.deserialize_cdr(data, e.type)
                if signal == "clock":
                    assert (msg.clock.sec, msg.clock.nanosec) == (0, 250_000_000)
                elif signal == "joint_states":
                    assert list(msg.name) == list(JOINT_NAMES)
                    np.testing.assert_array_equal(np.r_[msg.position, msg.velocity], x)
                elif signal == "pressure":
                    assert msg.fluid_pressure == pytest.approx(101325 + 1000 * 9.81 * 0.2, rel=1e-3)
                elif signal == "imu":
                    assert msg.angular_velocity.z == 0.03 and msg.linear_acceleration.z == 9.8
                elif signal == "battery":
                    assert msg.percentage == pytest.approx(0.9) and msg.current < 0
                else:
                    assert msg.data == 3.5e-4
    station.close()
    observer.close()


def _hello(role, duration=1.0, clock="lockstep", channels=()):
    import random

    return seam.Hello(
        role,
        f"{role[:4]}{random.randrange(16**4):04x}",
        "test",
        duration,
        1e-3,
        clock,
        tuple(channels),
    )


def _shake(link, timeout=8.0):
    box = {}

    def run():
        try:
            box["peer"] = link.shake_hands(timeout)
        except seam.SeamError as e:
            box["error"] = str(e)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread, box


@pytest.mark.slow
def test_handshake_over_ros2_refuses_a_mismatch_and_a_second_station():
    """Over DDS as over LCM: a controller of another duration is named on both sides at
    once; a second station on a paired domain stops at once with one line naming the
    first."""
    domain = fresh_domain()
    s_hello, c_hello = _hello("station"), _hello("controller", duration=2.0)
    links = [
        seam.Link(_transport("station", domain), [], "station", hello=s_hello),
        seam.Link(_transport("controller", domain), [], "controller", hello=c_hello),
    ]
    start = time.monotonic()
    threads = [_shake(link) for link in links]
    for thread, _ in threads:
        thread.join(15)
    assert time.monotonic() - start < 8.0
    (_, s_box), (_, c_box) = threads
    assert "duration 2 s there, 1 s here (--duration)" in s_box["error"], s_box
    assert "duration 1 s there, 2 s here (--duration)" in c_box["error"], c_box
    for link in links:
        link.transport.close()

    domain = fresh_domain()
    first, controller = _hello("station"), _hello("controller")
    links = [
        seam.Link(_transport("station", domain), [], "station", hello=first),
        seam.Link(_transport("controller", domain), [], "controller", hello=controller),
    ]
    threads = [_shake(link) for link in links]
    for thread, box in threads:
        thread.join(15)
        assert "peer" in box, box
    running = threading.Event()
    running.set()

    def keep_polling(link):
        while running.is_set():
            link.poll(10)

    pollers = [threading.Thread(target=keep_polling, args=(link,), daemon=True) for link in links]
    for poller in pollers:
        poller.start()
    second = seam.Link(_transport("station", domain), [], "station", hello=_hello("station"))
    with pytest.raises(seam.SeamError) as refused:
        second.shake_hands(8.0)
    running.clear()
    for poller in pollers:
        poller.join(2)
    line = str(refused.value)
    assert "\n" not in line and line.startswith("station: ")
    assert (
        f"another station is on ROS 2 domain {domain}: the station {first.run_id}" in line
        or f"is paired with the station {first.run_id} already" in line
    ), line
    assert "give each run a domain of its own" in line


def test_malformed_samples_are_counted_and_skipped_and_commands_clipped(capsys):
    """Commands that are not the robot's (other joints, a position short, rates of another
    count) are counted and skipped; the good command after them arrives, and the station's
    screen clips its out-of-range angle as it does over LCM. (Cyclone's writer refuses
    bytes that are not CDR of the topic's type, so no broken CDR can be sent from here.)"""
    domain = fresh_domain()
    desired = seam.CHANNEL_BY_NAME["MANTA_DESIRED_JOINT_STATE"]
    station = seam.Link(_transport("station", domain), [desired], "station")
    sender = dds.Participant(domain)
    e = TOPICS.topics["joint_commands"]
    writer = sender.writer(e.topic, e.type, e.qos)
    x = np.zeros(32)
    x[0] = 1e6
    good = m.serialize(m.joint_state_msg(20_000_000, JOINT_NAMES, x[:16], x[16:]))
    bad = [
        m.joint_state_msg(10_000_000, list(JOINT_NAMES[:15]) + ["fl_knee"], x[:16]),
        m.joint_state_msg(10_000_000, JOINT_NAMES[:15], x[:15], x[16:31]),
        m.joint_state_msg(10_000_000, JOINT_NAMES, x[:16], x[:3]),
    ]
    bad = [m.serialize(msg) for msg in bad]

    def arrived():
        for data in (*bad, good):
            sender.write(writer, data, SOURCE_EPOCH_NS)
        station.poll(50)
        return 20000 in station.inbox[desired.name]

    assert _wait(arrived)
    assert 10000 not in station.inbox[desired.name]
    assert station.incidents.counts[desired.name]["malformed"] >= 3
    err = capsys.readouterr().err
    assert (
        f"station: MANTA_DESIRED_JOINT_STATE: a message ({len(bad[0])} bytes) that is not "
        "a valid sensor_msgs/msg/JointState on /manta/joint_commands (joint state: joints "
        "differ from the robot's (missing ['rr_roll2'], unknown ['fl_knee'])): skipped"
    ) in err, err
    from manta_drake.seam.limits import Guard
    from manta_drake.wiring.station import build_station

    _, handles = build_station(_scenario("locomotion_swim"))
    guard = Guard.for_station(
        handles.plant_handles,
        seam.initial_commands(_scenario("locomotion_swim")),
        seam.Incidents("station"),
    )
    got = guard.screen({desired.name: station.inbox[desired.name][20000]}, 0.02)
    assert got[desired.name][0] == pytest.approx(math.radians(60.0))
    assert guard.incidents.counts[desired.name] == {"clipped": 1}
    station.transport.close()
    sender.close()


# ---------------------------------------------------------------------------------------
# Two processes


SWIM_TO_TROT = (
    (REPO / "tests" / "test_lcm.py").read_text().split('SWIM_TO_TROT = """\\\n')[1].split('"""')[0]
)


def _scenario_file(tmp_path, duration) -> pathlib.Path:
    path = tmp_path / "swim_to_trot.yaml"
    path.write_text(SWIM_TO_TROT.format(duration=duration, extra=""))
    return path


def _start(side, path, out, *args):
    err = open(out / f"{side}.err", "w")  # noqa: SIM115 (closed by the caller)
    return subprocess.Popen(
        [sys.executable, "-m", "manta_drake.cli", side, str(path), "--out", str(out), *args],
        stdout=subprocess.PIPE,
        stderr=err,
        text=True,
        cwd=REPO,
    ), err


def _single(path):
    from manta_drake.simulate import extract_log, make_simulator
    from manta_drake.wiring.diagram import build_diagram

    scenario = load_scenario(path)
    diagram, handles = build_diagram(scenario)
    simulator = make_simulator(diagram, scenario)
    simulator.Initialize()
    simulator.AdvanceTo(scenario.duration)
    return extract_log(handles, simulator.get_context())


@pytest.mark.slow
def test_two_processes_over_ros2_in_lockstep_are_the_single_diagram(tmp_path):
    """1 s of swim -> trot (the balloon deflates at 0.2 s, the depth crosses as
    FluidPressure, the commands as JointState and Float64) with the station and the
    controller in two processes over DDS on loopback, lockstep on /clock: every joint angle
    and command equals the single diagram's."""
    path = _scenario_file(tmp_path, 1.0)
    args = ["--ros2", "--domain", str(fresh_domain()), "--startup-timeout", "90"]
    start = time.monotonic()
    procs = [_start(side, path, tmp_path, *args) for side in ("station", "controller")]
    try:
        for proc, _ in procs:
            proc.wait(timeout=120)
    finally:
        for proc, err in procs:
            if proc.poll() is None:
                proc.kill()
            err.close()
    wall = time.monotonic() - start
    for side, (proc, _) in zip(("station", "controller"), procs):
        assert proc.returncode == 0, (tmp_path / f"{side}.err").read_text()
    station = dict(np.load(tmp_path / "station_log.npz"))
    controller = dict(np.load(tmp_path / "controller_log.npz"))
    metrics = json.loads((tmp_path / "station_metrics.json").read_text())
    single = _single(path)
    np.testing.assert_array_equal(station["t"], single["t"])
    err = np.abs(station["joint_angles"] - single["joint_angles"]).max()
    n = len(controller["t_command"])
    assert n == 1000
    cmd = np.abs(controller["commanded_joint_angles"] - single["commanded_joint_angles"][:n])
    print(
        f"ROS 2 lockstep: largest joint difference {err:.3g} rad, command {cmd.max():.3g}; "
        f"real-time factor {metrics['real_time_factor']:.2f}, {metrics['resends']} re-sends, "
        f"{wall:.1f} s in all"
    )
    assert err == 0.0 and cmd.max() == 0.0
    assert metrics["incidents"] == {} and metrics["url"].startswith("ROS 2 domain")
    assert np.ptp(station["depth"]) > 0.01  # the depth crossed, and changed: the robot sank


def _listen_commands(domain, heard):
    """A DDS participant that records (arrival, stamp [us], positions, fill) of every
    command the controller sends."""
    listener = dds.Participant(domain)
    for signal in ("joint_commands", "balloon_command"):
        e = TOPICS.topics[signal]

        def deliver(data, source, e=e, signal=signal):
            msg = STORES["ROS2_HUMBLE"].deserialize_cdr(data, e.type)
            ns = stamp_ns(msg)
            stamp = round((source - SOURCE_EPOCH_NS if ns is None else ns) / 1000)
            value = np.array(msg.position) if signal == "joint_commands" else msg.data
            heard.append((time.monotonic(), signal, stamp, value))

        listener.reader(e.topic, e.type, e.qos, deliver)
    return listener


@pytest.mark.slow
@pytest.mark.parametrize(
    "transport, mode",
    [("ros2", "wall-clock"), ("ros2", "lockstep"), ("lcm", "wall-clock"), ("lcm", "lockstep")],
)
def test_failsafe_commands_the_safe_state_when_the_station_dies(tmp_path, transport, mode):
    """The station is killed at t = 0.5 s: the controller stops commanding the gait and
    commands the safe state (every joint at the start stance, the balloon full), says so in
    one line, exits with status 2 after --timeout and records the failsafe in its metrics;
    on the wall clock within --failsafe-after (0.3 s) of the silence."""
    from manta_drake.wiring.station import start_command

    path = _scenario_file(tmp_path, 3.0)
    stance = start_command(load_scenario(path))[:16]
    heard = []
    if transport == "ros2":
        domain = fresh_domain()
        args = ["--ros2", "--domain", str(domain)]
        listener = _listen_commands(domain, heard)
        poll = listener.handle
    else:
        import lcm

        from manta_drake.lcmtypes import lcmt_manta_joint_state

        url = f"udpm://239.255.76.67:{20000 + (os.getpid() * 13 + domain_free()) % 40000}?ttl=0"
        args = ["--lcm", url]
        listener = lcm.LCM(url)
        listener.subscribe(
            "MANTA_DESIRED_JOINT_STATE",
            lambda _, data: heard.append(
                (
                    time.monotonic(),
                    "joint_commands",
                    (msg := lcmt_manta_joint_state.decode(data)).utime,
                    np.array(msg.position),
                )
            ),
        )
        listener.subscribe(
            "MANTA_BALLOON_COMMAND",
            lambda _, data: heard.append(
                (
                    time.monotonic(),
                    "balloon_command",
                    (msg := seam.CODECS["vector"].lcm_type.decode(data)).utime,
                    msg.value[0],
                )
            ),
        )

        def poll(ms):
            while listener.handle_timeout(0) > 0:
                pass
            listener.handle_timeout(ms)

    args += ["--timeout", "2.5", "--startup-timeout", "90"] + (
        ["--wall-clock"] if mode == "wall-clock" else []
    )
    station, serr = _start("station", path, tmp_path, *args)
    controller, cerr = _start("controller", path, tmp_path, *args, "--failsafe-after", "0.3")
    try:
        err_file = tmp_path / "station.err"
        assert _wait(
            lambda: (
                station.poll() is not None
                or any(s == "joint_commands" and stamp >= 500_000 for _, s, stamp, _ in heard)
            ),
            120,
            poll,
        )
        assert station.poll() is None, err_file.read_text()
        station.kill()
        killed = time.monotonic()
        _wait(lambda: controller.poll() is not None, 30, poll)
        exited = time.monotonic() - killed
    finally:
        for proc in (station, controller):
            if proc.poll() is None:
                proc.kill()
        serr.close()
        cerr.close()
    err = (tmp_path / "controller.err").read_text()
    assert controller.returncode == 2, err
    assert 2.5 <= exited < 10.0
    assert (
        "failsafe, commanding the safe state (the start stance at rest, the balloon full)" in err
    ), err
    assert "the safe state commanded since" in err
    after = [(t, s, stamp, v) for t, s, stamp, v in heard if t > killed]
    safe = [
        (t, s, stamp, v)
        for t, s, stamp, v in after
        if (s == "joint_commands" and np.array_equal(v, stance))
        or (s == "balloon_command" and v == 1.0)
    ]
    gait = [
        t for t, s, stamp, v in after if s == "joint_commands" and not np.array_equal(v, stance)
    ] or [killed]
    first_safe = min(t for t, s, *_ in safe if s == "joint_commands")
    assert max(gait) < first_safe  # the safe state replaced the gait for good
    assert sum(s == "balloon_command" for _, s, *_ in safe) >= 3  # re-sent while silent
    reaction = first_safe - killed  # the station's last message came a moment before
    if mode == "lockstep":  # at the link-loss point, STALE_AFTER_S
        assert {stamp for _, s, stamp, _ in safe} == {seam.FAILSAFE_UTIME}
        assert seam.STALE_AFTER_S - 0.1 < reaction < seam.STALE_AFTER_S + 1.0
    else:  # --failsafe-after 0.3
        assert 0.25 < reaction < 1.0
    metrics = json.loads((tmp_path / "controller_metrics.json").read_text())
    assert metrics["status"] == "failed" and len(metrics["failsafe"]) == 1
    event = metrics["failsafe"][0]
    assert event["ended"] == "gave up" and event["commands_sent"] >= 3
    print(
        f"{transport} {mode}: safe state {reaction:.3f} s after the kill, exit "
        f"{exited:.1f} s after it"
    )


def test_the_docs_hold_the_seams_topic_table():
    from manta_drake.seam.ros2_link import seam_topic_table_markdown

    docs = (REPO / "docs" / "ros2.md").read_text()
    assert seam_topic_table_markdown(TOPICS) in docs, (
        "docs/ros2.md: paste seam_topic_table_markdown(load_topic_map())"
    )


@pytest.mark.slow
def test_a_station_that_pauses_gets_the_failsafe_then_the_run_resumes_unchanged(tmp_path):
    """The station is stopped (SIGSTOP) for 1.6 s mid-run, then goes on: the lockstep
    controller enters its failsafe at the link-loss point, says the station is back, resumes,
    and the run still equals the single diagram bit for bit (the safe state, stamped
    FAILSAFE_UTIME, never reached the lockstep station's servos; the pressure crosses as
    Float64, exactly); its metrics record the failsafe as resumed."""
    import signal

    path = _scenario_file(tmp_path, 2.0)
    topic_map = tmp_path / "topics.yaml"
    topic_map.write_text("topics:\n  pressure: {type: std_msgs/msg/Float64}\n")
    args = [
        "--ros2",
        "--domain",
        str(fresh_domain()),
        "--startup-timeout",
        "90",
        "--topic-map",
        str(topic_map),
    ]
    station, serr = _start("station", path, tmp_path, *args)
    controller, cerr = _start("controller", path, tmp_path, *args)
    try:
        assert _wait(
            lambda: (
                "t = 1.0 s" in (tmp_path / "controller.err").read_text()
                or controller.poll() is not None
            ),
            120,
        )
        station.send_signal(signal.SIGSTOP)
        time.sleep(1.6)
        station.send_signal(signal.SIGCONT)
        for proc in (station, controller):
            proc.wait(timeout=60)
    finally:
        for proc in (station, controller):
            if proc.poll() is None:
                proc.kill()
        serr.close()
        cerr.close()
    err = (tmp_path / "controller.err").read_text()
    assert station.returncode == 0 and controller.returncode == 0, err
    assert "failsafe, commanding the safe state" in err and "the station is back after" in err
    metrics = json.loads((tmp_path / "controller_metrics.json").read_text())
    assert metrics["failsafe"] and {e["ended"] for e in metrics["failsafe"]} == {"resumed"}
    station_log = dict(np.load(tmp_path / "station_log.npz"))
    single = _single(path)
    np.testing.assert_array_equal(station_log["joint_angles"], single["joint_angles"])
