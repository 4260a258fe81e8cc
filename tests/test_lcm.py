"""The seam over LCM (manta_drake.seam): messages, schedule, transport, the options, the
handshake, what passes (clipped commands, ignored readings, skipped malformed messages),
and the split run in two processes against the single diagram."""

import json
import os
import pathlib
import random
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from drake import lcmt_image, lcmt_image_array, lcmt_scope
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.sensors import ImageDepth32F

from manta_drake import seam
from manta_drake.lcmtypes import lcmt_manta_joint_state, lcmt_manta_pose
from manta_drake.model.robot_params import JOINT_NAMES

REPO = pathlib.Path(__file__).resolve().parents[1]


def unique_url() -> str:
    """A multicast port of its own, so concurrent runs on this machine do not mix."""
    port = random.Random(os.getpid() * 1_000_003 + time.time_ns()).randrange(20000, 60000)
    return f"udpm://239.255.76.67:{port}?ttl=0&recv_buf_size=2097152"


# ---------------------------------------------------------------------------------------
# Messages


def test_vector_round_trip_keeps_nan_and_every_bit(rng):
    values = np.r_[rng.normal(size=3), np.nan, 1e-300]
    msg = lcmt_scope.decode(seam.vector_message(1.234, values).encode())
    assert msg.utime == 1_234_000
    np.testing.assert_array_equal(seam.vector_from_message(msg), values)


def test_joint_state_round_trip_and_matching_by_name(rng):
    x = rng.normal(size=32)
    data = seam.joint_state_message(0.5, x).encode()
    msg = lcmt_manta_joint_state.decode(data)
    assert msg.utime == 500_000 and list(msg.joint_name) == list(JOINT_NAMES)
    np.testing.assert_array_equal(seam.joint_state_from_message(msg), x)
    # A driver may send its joints in another order: they are matched by name.
    order = rng.permutation(16)
    shuffled = seam.joint_state_message(
        0.5, np.r_[x[:16][order], x[16:][order]], names=[JOINT_NAMES[i] for i in order]
    )
    np.testing.assert_array_equal(seam.joint_state_from_message(shuffled), x)
    wrong = seam.joint_state_message(0.5, x[:32], names=list(JOINT_NAMES[:15]) + ["fl_knee"])
    with pytest.raises(seam.SeamError, match=r"missing \['rr_roll2'\], unknown \['fl_knee'\]"):
        seam.joint_state_from_message(wrong)


def test_depth_image_round_trip_is_exact(rng):
    image = ImageDepth32F(7, 5)
    pixels = rng.uniform(0.1, 0.8, size=(5, 7)).astype(np.float32)
    pixels[1, 2], pixels[3, 4] = np.nan, np.inf  # dropout, out of range
    image.mutable_data[:, :, 0] = pixels
    msg = lcmt_image_array.decode(seam.depth_image_message(2.0, image).encode())
    assert msg.header.utime == 2_000_000 and msg.images[0].pixel_format == 5
    back = seam.depth_image_from_message(msg)
    assert (back.width(), back.height()) == (7, 5)
    np.testing.assert_array_equal(back.data[:, :, 0], pixels)


def test_depth_image_accepts_zlib_and_rejects_other_pixels():
    import zlib

    image = ImageDepth32F(4, 3)
    image.mutable_data[:, :, 0] = np.arange(12, dtype=np.float32).reshape(3, 4)
    msg = seam.depth_image_message(0.0, image)
    msg.images[0].data = zlib.compress(msg.images[0].data)
    msg.images[0].size = len(msg.images[0].data)
    msg.images[0].compression_method = lcmt_image.COMPRESSION_METHOD_ZLIB
    np.testing.assert_array_equal(seam.depth_image_from_message(msg).data, image.data)
    msg.images[0].pixel_format = lcmt_image.PIXEL_FORMAT_RGB
    with pytest.raises(seam.SeamError, match="expected DEPTH"):
        seam.depth_image_from_message(msg)


def test_pose_round_trip_is_bit_exact(rng):
    for _ in range(20):
        X = RigidTransform(RollPitchYaw(rng.uniform(-3, 3, 3)), rng.normal(size=3))
        msg = lcmt_manta_pose.decode(seam.pose_message(0.2, X).encode())
        back = seam.pose_from_message(msg)
        np.testing.assert_array_equal(back.GetAsMatrix4(), X.GetAsMatrix4())


def test_project_lcmtypes_are_generated_from_their_sources(tmp_path):
    """The Python in manta_drake/lcmtypes is what lcm-gen makes of the .lcm files."""
    lcm_gen = shutil.which("lcm-gen") or str(pathlib.Path(sys.executable).parent / "lcm-gen")
    if not os.access(lcm_gen, os.X_OK):
        pytest.skip("lcm-gen (from the lcm package) is not installed")
    sources = sorted((REPO / "manta_drake" / "lcmtypes").glob("*.lcm"))
    assert [p.stem for p in sources] == [
        "lcmt_manta_handshake",
        "lcmt_manta_joint_state",
        "lcmt_manta_pose",
    ]
    subprocess.run([lcm_gen, "-p", "--ppath", str(tmp_path), *map(str, sources)], check=True)
    generated = tmp_path / "manta_drake" / "lcmtypes"
    for path in sorted(generated.glob("*.py")):
        committed = REPO / "manta_drake" / "lcmtypes" / path.name
        assert committed.read_text() == path.read_text(), f"{committed.name} is out of date"


def test_the_old_module_name_gives_the_seams_objects():
    """``manta_drake.lcm_seam`` (kept for one release) names what ``manta_drake.seam``
    exports, as the very same objects."""
    from manta_drake import lcm_seam

    assert sorted(lcm_seam.__all__) == sorted(seam.__all__)
    for name in seam.__all__:
        assert getattr(lcm_seam, name) is getattr(seam, name), name


# ---------------------------------------------------------------------------------------
# The channel table and the schedule


@pytest.mark.slow
def test_channel_table_matches_the_ports_and_the_docs():
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.controller import build_controller
    from manta_drake.wiring.station import build_station

    halves = {}
    for name in ("three_behaviors", "four_behaviors", "nose_up_trot"):
        scenario = load_scenario(name, {"duration": 1.0})
        halves[name] = build_station(scenario)[0], build_controller(scenario)[0]
    for channel in seam.CHANNELS:  # every channel is a port of its sender (camera or not)
        assert any(
            (station if channel.sender == "station" else controller).HasOutputPort(channel.port)
            for station, controller in halves.values()
        ), channel.name
    station, controller = halves["three_behaviors"]
    sends, reads = seam.controller_channels(controller)
    assert {c.port for c in reads} == {
        "measured_joint_state",
        "depth",
        "depth_image",
        "camera_pose",
    }
    assert {c.port for c in sends} == {"desired_state", "balloon_command"}
    # The new modalities: the IMU, the flow sensor and the battery are the controller's
    # inputs; every vector channel's size is its port's.
    station, controller = halves["four_behaviors"]
    sends, reads = seam.controller_channels(controller)
    assert {c.port for c in reads} == {
        "measured_joint_state",
        "depth",
        "imu",
        "flow_velocity",
        "battery",
    }
    for c in seam.station_channels(station)[0]:
        if c.codec == "vector":
            assert station.GetOutputPort(c.port).size() == c.size, c.name
            if controller.HasInputPort(c.port):
                assert controller.GetInputPort(c.port).size() == c.size, c.name
    docs = (REPO / "docs" / "lcm.md").read_text()
    assert seam.channel_table_markdown() in docs, "docs/lcm.md: paste channel_table_markdown()"


def test_controller_commands_do_not_depend_directly_on_the_sensors():
    """Why the lockstep controller may publish its commands for t before t's sensors."""
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.controller import build_controller

    for name in ("three_behaviors", "four_behaviors", "swim_heading_hold"):
        controller, _ = build_controller(load_scenario(name))
        sends, reads = seam.controller_channels(controller)
        assert not seam.has_feedthrough(controller, reads, sends), name


@pytest.mark.slow
def test_the_battery_crosses_where_the_controller_reads_the_charge_at_its_estimators_period():
    """``reads_battery`` is build_controller's choice (the energy model on, and energy_hat
    read by the tree or the balloon rule); the channel then comes at the energy estimator's
    own period (its j x 0.1 s are not all on the 10 ms grid: 3 x 0.1 s is after the plant's
    step at 0.3 s), else every 10 ms for monitoring."""
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.controller import build_controller

    energy_rule = {"balloon.rule.modality": "energy", "balloon.rule.threshold": 0.5}
    cases = [
        ("four_behaviors", {}, True),
        ("swim_heading_hold", energy_rule, True),
        ("swim_heading_hold", {}, False),
        ("two_behaviors", {}, False),
        ("swim_heading_hold", {**energy_rule, "actuators.enabled": False}, None),
    ]
    battery = seam.CHANNEL_BY_NAME["MANTA_BATTERY"]
    for name, changes, expected in cases:
        try:
            scenario = load_scenario(name, {"duration": 1.0}, overrides=changes)
        except ValueError as e:  # energy_hat without the energy model is refused at load
            assert expected is None and "needs actuators.enabled: true" in str(e), e
            continue
        controller, handles = build_controller(scenario)
        assert seam.reads_battery(scenario) is controller.HasInputPort("battery") is expected
        if expected:
            period = handles.systems["energy_estimator"].period
            assert period == seam.ENERGY_ESTIMATOR_PERIOD_S == battery.period(scenario) == 0.1
        else:
            assert battery.period(scenario) == 0.01
    assert 3 * 0.1 not in seam.sample_times(0.01, 1.0) and 3 * 0.1 > 300 * 0.001
    assert all(j * 0.02 in seam.sample_times(0.01, 75.0) for j in range(3750))


@pytest.mark.slow
def test_every_periodic_reader_of_a_sensor_reads_at_exchange_times():
    """The posture, flow and energy estimators read at times the seam exchanges their
    channels, so in lockstep each reads the single diagram's value; an IMU at 30 Hz under a
    posture estimator at 20 ms would not (the controller says so when it starts)."""
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.controller import build_controller

    for name in (
        "four_behaviors",
        "swim_heading_hold",
        "two_behaviors_heading_hold",
        "three_behaviors",
        "nose_up_trot",
    ):
        scenario = load_scenario(name, {"duration": 75.0})
        controller = seam.controller_with_tick(build_controller(scenario)[0], scenario.time_step)
        assert seam.unexchanged_reads(controller, scenario) == [], name
    scenario = load_scenario(
        "swim_heading_hold", {"duration": 1.0}, overrides={"imu.rate_hz": 30.0}
    )
    lines = seam.unexchanged_reads(build_controller(scenario)[0], scenario)
    assert len(lines) == 1 and lines[0].startswith(
        "posture_estimator reads imu every 0.02 s, MANTA_IMU comes every 0.0333333 s: "
    ), lines
    missed = [j * 0.02 for j in range(50) if j * 0.02 not in seam.sample_times(1 / 30, 1.0)]
    assert lines[0].endswith(
        f"{len(missed)} of its reads (the first at t = {missed[0]!r} s) fall between the exchanges"
    )


class _Recorder(LeafSystem):
    """A 1 ms discrete counter beside a periodic event that records when it runs and
    which count it sees."""

    def __init__(self, period, records):
        super().__init__()
        self.records = records
        count = self.DeclareDiscreteState(1)
        self.DeclarePeriodicDiscreteUpdateEvent(1e-3, 0.0, self._count)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._record)
        self._count_index = count

    def _count(self, context, state):
        state.set_value(self._count_index, context.get_discrete_state(0).value() + 1)

    def _record(self, context):
        self.records.append((context.get_time(), context.get_discrete_state(0).value()[0]))


def test_sample_times_are_drakes_event_times():
    """3 x 0.2 = 0.6000000000000001 is when Drake runs the third 0.2 s event: after the
    plant's step at 0.6 s, whose result it sees (count 601, not 600)."""
    records = []
    builder = DiagramBuilder()
    builder.AddSystem(_Recorder(0.2, records))
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(1.5)
    times = [t for t, _ in records]
    assert times == seam.sample_times(0.2, 1.5 + 1e-9)
    assert times[3] == 0.6000000000000001 and records[3][1] == 601
    assert times[2] == 0.4 and records[2][1] == 400


def test_exchange_schedule_merges_equal_times_and_keeps_off_grid_ones():
    schedule = seam.exchange_schedule(1.0, {"STEP": 1e-3, "DEPTH": 0.02, "CAMERA": 0.2})
    times = [ex.time for ex in schedule]
    assert times == sorted(times) and len(times) == 1001  # 1000 steps + one camera sample
    by_time = {ex.time: ex.channels for ex in schedule}
    assert by_time[0.0] == ("CAMERA", "DEPTH", "STEP")
    assert by_time[0.6] == ("DEPTH", "STEP")
    assert by_time[0.6000000000000001] == ("CAMERA",)
    assert by_time[0.02] == ("DEPTH", "STEP")


# ---------------------------------------------------------------------------------------
# The transport (in one process, over memq://)


def test_link_waits_resends_and_gives_up():
    """Over memq:// (one LCM instance, in this process) a station-side Link sees what it
    publishes, and the test plays the controller on the same instance."""
    import functools

    clock, depth = seam.CLOCK, seam.CHANNEL_BY_NAME["MANTA_DEPTH"]
    desired = seam.CHANNEL_BY_NAME["MANTA_DESIRED_JOINT_STATE"]
    station = seam.Link("memq://", [desired], "station", sticky=(clock.name,))
    sent = {clock.name: [], depth.name: []}
    for name, box in sent.items():
        station.transport.lcm.subscribe(
            name, functools.partial(lambda box, _, data: box.append(data), box)
        )
    station.publish(clock.name, seam.joint_state_message(0.0, np.zeros(32)), 0)
    station.publish(depth.name, seam.vector_message(0.0, [0.1]), 0)
    station.publish(depth.name, seam.vector_message(0.02, [0.2]), 20000)
    station.drain()
    assert [len(sent[clock.name]), len(sent[depth.name])] == [1, 2]
    # A command stamped 0.02 s says the controller has what was sent before 0.02 s:
    # only the depth of 0.02 s and the newest clock message are sent again.
    station.transport.lcm.publish(
        desired.name, seam.joint_state_message(0.02, np.ones(32)).encode()
    )
    station.drain()
    assert station.newest[desired.name] == 20000
    station.resend()
    station.drain()
    assert [len(sent[clock.name]), len(sent[depth.name])] == [2, 3]
    assert lcmt_scope.decode(sent[depth.name][-1]).utime == 20000
    got = station.take({desired.name: 20000})  # decoded as it arrived
    np.testing.assert_array_equal(got[desired.name], np.ones(32))
    # Nothing comes: a warning after STALE_AFTER_S, re-sends meanwhile, then the error.
    stale = []
    start = time.monotonic()
    with pytest.raises(seam.SeamError, match="silent"):
        station.wait_for(
            lambda: station.take({desired.name: 21000}),
            1.3,
            stale.append,
            lambda waited: seam.SeamError(f"silent for {waited:.1f} s"),
        )
    assert 1.3 <= time.monotonic() - start < 3.0
    assert len(stale) == 1 and stale[0] >= seam.STALE_AFTER_S
    station.drain()
    assert len(sent[clock.name]) >= 2 + 10  # the clock again every 0.1 s while waiting


def test_station_without_controller_times_out():
    from manta_drake.scenario import load_scenario

    scenario = load_scenario("stand", {"duration": 0.1})
    start = time.monotonic()
    with pytest.raises(
        seam.SeamError,
        match=r"^station: no controller answered on memq:// "
        r"within 0\.5 s; is `manta-drake controller` running",
    ):
        seam.run_station(scenario, "memq://", timeout=0.5, startup_timeout=0.5)
    assert time.monotonic() - start < 30


def _err_lines(captured) -> list[str]:
    return [line for line in captured.err.splitlines() if line.strip()]


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
    "args, line",
    [
        (["--duration", "0"], "duration: 0.0 is outside the allowed range (0, 3600] s"),
        (["--duration", "nan"], "duration: nan is not finite"),
        (["--timeout", "nan"], "--timeout: nan is not finite"),
        (["--timeout", "inf"], "--timeout: inf is not finite"),
        (["--timeout", "0"], "--timeout: 0.0 is outside the allowed range (0, inf) s"),
        (["--timeout", "-3"], "--timeout: -3.0 is outside the allowed range (0, inf) s"),
        (["--startup-timeout", "nan"], "--startup-timeout: nan is not finite"),
        (
            ["--lcm", "bogus://nowhere"],
            ("--lcm 'bogus://nowhere': unknown LCM provider 'bogus'; expected udpm://GROUP:PORT"),
        ),
        (
            ["--lcm", "udpm://239.255.76.67"],
            ("--lcm 'udpm://239.255.76.67': no port in '239.255.76.67'"),
        ),
        (["--lcm", "udpm://239.255.76.67:"], "port '' is not a number in 1-65535"),
        (["--lcm", "garbage"], "--lcm 'garbage': not a URL (no PROVIDER://)"),
        (["--lcm", "udpm://10.1.2.3:7667"], "10.1.2.3 is not a multicast group"),
        (["--lcm", "udpm://239.255.76.67:7667?tll=0"], "unknown option 'tll'"),
        (["--lcm", "memq://"], "memq:// reaches this process only"),
        (["--lcm", "tcpq://127.0.0.1:1"], "cannot open the LCM URL 'tcpq://127.0.0.1:1': LCM tcpq"),
        (["--out", "/proc/manta_drake_out"], "--out /proc/manta_drake_out: cannot be created"),
        (["--out", "/proc/self"], "--out /proc/self: cannot be written"),
    ],
)
def test_bad_options_are_one_line_each_before_anything_is_built(
    capfd, nothing_built, side, args, line
):
    from manta_drake.cli import main

    assert main([side, "stand", "--quiet", *args]) == 2
    err = _err_lines(capfd.readouterr())  # file descriptor 2: liblcm's own lines too
    assert len(err) == 1, err
    assert err[0].startswith("manta-drake: error: ") and line in err[0], err[0]


def test_out_that_is_a_file_is_refused(capfd, nothing_built, tmp_path):
    from manta_drake.cli import main

    (tmp_path / "f").write_text("")
    for out, line in (
        (tmp_path / "f", "is a file, not a folder"),
        (tmp_path / "f" / "sub", "cannot be created"),
    ):
        assert main(["station", "stand", "--quiet", "--out", str(out)]) == 2
        err = _err_lines(capfd.readouterr())
        assert len(err) == 1 and f"--out {out}: {line}" in err[0], err


def test_duration_zero_is_refused_as_run_refuses_it(capfd, tmp_path):
    """The seam's sides and `manta-drake run` name the same range."""
    from manta_drake.cli import main

    messages = []
    for argv in (
        ["run", "stand", "--out", str(tmp_path / "run")],
        ["station", "stand", "--quiet", "--out", str(tmp_path / "station")],
        ["controller", "stand", "--quiet"],
    ):
        assert main([*argv, "--duration", "0"]) == 2
        messages.append(_err_lines(capfd.readouterr()))
    assert all(len(m) == 1 for m in messages), messages
    assert messages[0] == messages[1] == messages[2]
    assert not (tmp_path / "station").exists()  # a refused scenario leaves no folder


# ---------------------------------------------------------------------------------------
# The handshake (real udpm traffic, in this process: Links without diagrams)


def _hello(role, duration=1.0, clock="lockstep", channels=()):
    return seam.Hello(
        role,
        f"{role[:4]}{random.randrange(16**4):04x}",
        "test",
        duration,
        1e-3,
        clock,
        tuple(channels),
    )


def _shake(link, timeout=5.0):
    """Runs ``link.shake_hands`` in a thread; returns (thread, box with its result)."""
    import threading

    box = {}

    def run():
        try:
            box["peer"] = link.shake_hands(timeout)
        except seam.SeamError as e:
            box["error"] = str(e)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread, box


@pytest.mark.parametrize(
    "controller_duration, clock, station_line, controller_line",
    [
        (1.0, "lockstep", None, None),
        (
            2.0,
            "lockstep",
            "duration 2 s there, 1 s here (--duration)",
            "duration 1 s there, 2 s here (--duration)",
        ),
        (
            1.0,
            "wall-clock",
            "clock wall-clock there, lockstep here (--wall-clock)",
            "clock lockstep there, wall-clock here (--wall-clock)",
        ),
    ],
)
def test_handshake_pairs_or_names_the_mismatch_on_both_sides(
    controller_duration, clock, station_line, controller_line
):
    url = unique_url()
    s_hello = _hello("station")
    c_hello = _hello("controller", controller_duration, clock)
    station = seam.Link(url, [], "station", hello=s_hello)
    controller = seam.Link(url, [], "controller", hello=c_hello)
    start = time.monotonic()
    threads = [_shake(station), _shake(controller)]
    for thread, _ in threads:
        thread.join(10)
    assert time.monotonic() - start < 3.0  # at once, not after a timeout
    (_, s_box), (_, c_box) = threads
    if station_line is None:
        assert s_box["peer"].run_id == c_hello.run_id
        assert c_box["peer"].run_id == s_hello.run_id
        return
    for box, line, me, other in (
        (s_box, station_line, "station", c_hello),
        (c_box, controller_line, "controller", s_hello),
    ):
        assert box["error"].startswith(f"{me}: the {other.role} {other.run_id} (pid "), box
        assert f"does not match this {me}: {line}; start both sides" in box["error"]
        assert "\n" not in box["error"]


def test_a_second_station_is_named_at_once_on_both_sides(capsys):
    """A station and a controller are paired; a second station on their URL stops at once
    with one line naming the first; the pair names it once each and goes on."""
    import threading

    url = unique_url()
    first, controller = _hello("station"), _hello("controller")
    links = [
        seam.Link(url, [], "station", hello=first),
        seam.Link(url, [], "controller", hello=controller),
    ]
    threads = [_shake(link) for link in links]
    for thread, box in threads:
        thread.join(10)
        assert "peer" in box, box
    running = threading.Event()
    running.set()

    def keep_polling(link):  # the pair's run goes on: it polls as it exchanges
        while running.is_set():
            link.poll(10)

    pollers = [threading.Thread(target=keep_polling, args=(link,), daemon=True) for link in links]
    for poller in pollers:
        poller.start()
    second = _hello("station")
    start = time.monotonic()
    with pytest.raises(seam.SeamError) as refused:
        seam.Link(url, [], "station", hello=second).shake_hands(5.0)
    assert time.monotonic() - start < 2.0
    time.sleep(0.3)  # the pair handles the second station's last requests
    running.clear()
    for poller in pollers:
        poller.join(2)
    line = str(refused.value)
    assert "\n" not in line and line.startswith("station: ")
    assert (
        f"another station is on {url}: the station {first.run_id}" in line
        or f"is paired with the station {first.run_id} already" in line
    ), line
    assert "give each run a URL of its own" in line
    err = _err_lines(capsys.readouterr())
    for role, peer in (("station", controller), ("controller", first)):
        said = [e for e in err if e.startswith(f"{role}: a second station")]
        assert len(said) == 1, err  # once, though it heard several requests
        assert (
            f"the station {second.run_id}" in said[0]
            and f"this run goes on with the {peer.role} {peer.run_id}" in said[0]
        )


# ---------------------------------------------------------------------------------------
# Malformed messages


def test_a_malformed_message_is_named_once_counted_and_skipped(capsys):
    """A truncated message, another type on the channel and a vector of the wrong length:
    each skipped and counted; the first named in one line with channel and type; the good
    messages after them arrive."""
    import lcm

    url = unique_url()
    desired = seam.CHANNEL_BY_NAME["MANTA_DESIRED_JOINT_STATE"]
    balloon = seam.CHANNEL_BY_NAME["MANTA_BALLOON_COMMAND"]
    link = seam.Link(url, [desired, balloon], "station")
    sender = lcm.LCM(url)
    good = seam.joint_state_message(0.02, np.ones(32)).encode()
    sender.publish(desired.name, good[:20])  # the header, then no joint names
    sender.publish(desired.name, good[:-5])
    sender.publish(desired.name, seam.vector_message(0.0, [0.1]).encode())  # another type
    sender.publish(balloon.name, seam.vector_message(0.02, [0.1, 0.2]).encode())  # 2 values
    sender.publish(desired.name, good)
    sender.publish(balloon.name, seam.vector_message(0.02, [0.5]).encode())
    deadline = time.monotonic() + 5
    while (
        20000 not in link.inbox[balloon.name] or 20000 not in link.inbox[desired.name]
    ) and time.monotonic() < deadline:
        link.poll(20)
    np.testing.assert_array_equal(link.inbox[desired.name][20000], np.ones(32))
    np.testing.assert_array_equal(link.inbox[balloon.name][20000], [0.5])
    assert link.incidents.counts == {desired.name: {"malformed": 3}, balloon.name: {"malformed": 1}}
    err = _err_lines(capsys.readouterr())
    assert err == [
        (
            "station: MANTA_DESIRED_JOINT_STATE: a message (20 bytes) that is not a valid "
            "manta_drake.lcmtypes.lcmt_manta_joint_state (unpack requires a buffer of 4 bytes): "
            "skipped (further malformed messages on MANTA_DESIRED_JOINT_STATE are counted, not "
            "shown)"
        ),
        (
            "station: MANTA_BALLOON_COMMAND: a message (36 bytes) that is not a valid "
            "drake.lcmt_scope (2 values, expected 1): skipped (further malformed messages on "
            "MANTA_BALLOON_COMMAND are counted, not shown)"
        ),
    ], err


# ---------------------------------------------------------------------------------------
# What crosses: the station clips and holds commands, the controller ignores readings
# outside their range (each side in this process against a scripted peer over udpm)


class _ScriptedPeer:
    """The other side of a lockstep run, scripted, in a thread of this process: it shakes
    hands, then ``step(link, exchange)`` publishes what it has to and waits for what it
    needs, over the real transport."""

    def __init__(self, url, hello, subscribe, step, schedule, sticky=()):
        import threading

        self.link = seam.Link(url, subscribe, hello.role, hello=hello, sticky=sticky)
        self.error = None
        self._step, self._schedule = step, schedule
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        try:
            self.link.shake_hands(60)
            for ex in self._schedule:
                self._step(self.link, ex)
            self.link.say_goodbye("finished")
        except Exception as e:  # noqa: BLE001 (reported by the test)
            self.error = e


def _bad_commands():
    """Step -> (joint index, angle, rate) or balloon fill: what the scripted controller
    sends wrong."""
    return {
        5: ("joint", 0, 1e6, 0.0),
        6: ("joint", 0, np.nan, 0.0),
        7: ("joint", 5, None, 50.0),
        8: ("balloon", 1.7),
        9: ("balloon", np.nan),
        **{k: ("joint", 0, 1e6, 0.0) for k in range(10, 15)},
    }


def test_station_clips_commands_and_never_passes_a_nan_to_the_servos(capsys):
    from manta_drake.scenario import load_scenario

    scenario = load_scenario("float_sink", {"duration": 0.03})
    url = unique_url()
    held = seam.initial_commands(scenario)
    desired = seam.CHANNEL_BY_NAME["MANTA_DESIRED_JOINT_STATE"]
    balloon = seam.CHANNEL_BY_NAME["MANTA_BALLOON_COMMAND"]
    bad = _bad_commands()
    h = scenario.time_step

    def step(link, ex):  # the controller: wait for the station's clock, command
        link.wait_for(
            lambda: link.newest.get(seam.CLOCK.name, -1) >= ex.utime or None,
            30,
            lambda _: None,
            lambda _: seam.SeamError("no clock"),
        )
        x, fill = held["desired_state"].copy(), held["balloon_command"].copy()
        k = round(ex.time / h)
        what = bad.get(k, ("none",))
        if what[0] == "joint":
            _, i, angle, rate = what
            x[i] = x[i] if angle is None else angle
            x[16 + i] = rate
        elif what[0] == "balloon":
            fill[0] = what[1]
        link.publish(desired.name, seam.joint_state_message(ex.time, x), ex.utime)
        link.publish(balloon.name, seam.vector_message(ex.time, fill), ex.utime)

    hello = seam.Hello(
        "controller", "fakectrl", "float_sink", 0.03, h, "lockstep", (desired.name, balloon.name)
    )
    schedule = seam.exchange_schedule(0.03, {"STEP": h})
    peer = _ScriptedPeer(url, hello, [seam.CLOCK], step, schedule)
    result = seam.run_station(scenario, url, timeout=10, startup_timeout=60)
    peer.thread.join(10)
    assert peer.error is None, peer.error
    assert result.incidents == {
        desired.name: {"clipped": 7, "held": 1},
        balloon.name: {"clipped": 1, "held": 1},
    }
    assert result.metrics()["incidents"] == result.incidents
    assert "MANTA_DESIRED_JOINT_STATE: 7 clipped, 1 held" in result.summary()
    err = _err_lines(capsys.readouterr())
    assert err == [
        (
            "station: MANTA_DESIRED_JOINT_STATE: at t = 0.005 s: fl_yaw angle 1e+06 rad outside "
            "[-1.047, 1.047]: clipped to the servos' limits (further clipped messages on "
            "MANTA_DESIRED_JOINT_STATE are counted, not shown)"
        ),
        (
            "station: MANTA_DESIRED_JOINT_STATE: at t = 0.006 s: fl_yaw (nan rad, 0 rad/s) not "
            "finite: those servos hold their last good command (further held messages on "
            "MANTA_DESIRED_JOINT_STATE are counted, not shown)"
        ),
        (
            "station: MANTA_BALLOON_COMMAND: at t = 0.008 s: fill 1.7 outside [0, 1]: clipped to "
            "the pump's range (further clipped messages on MANTA_BALLOON_COMMAND are counted, "
            "not shown)"
        ),
        (
            "station: MANTA_BALLOON_COMMAND: at t = 0.009 s: fill nan not finite: the pump holds "
            "the last good command 1 (further held messages on MANTA_BALLOON_COMMAND are "
            "counted, not shown)"
        ),
    ], err
    q = result.log["joint_angles"]
    assert np.all(np.isfinite(q)) and np.all(np.isfinite(result.log["joint_velocities"]))
    lower, upper = (
        np.array([lim[i % 4] for i in range(16)])
        for lim in zip(*scenario.robot_params().position_limits)
    )
    assert np.all(q >= lower - 1e-6) and np.all(q <= upper + 1e-6)
    # The clipped command did move the yaw joint toward its limit: clipped, not dropped.
    assert q[-1, 0] - q[5, 0] > 1e-3


def test_controller_ignores_readings_outside_their_physical_range(capsys):
    """Depths of -1e6 m and 1e6 m are read as dropped readings (as NaN is): the depth
    estimator holds (1e6 m would read as the floor, z_hat = 1); a battery state of charge
    of 7 is logged as NaN. One line per channel and kind; all counted."""
    from manta_drake.scenario import load_scenario

    scenario = load_scenario("locomotion_swim", {"duration": 0.1})
    url = unique_url()
    h = scenario.time_step
    depth = seam.CHANNEL_BY_NAME["MANTA_DEPTH"]
    battery = seam.CHANNEL_BY_NAME["MANTA_BATTERY"]
    desired = seam.CHANNEL_BY_NAME["MANTA_DESIRED_JOINT_STATE"]
    readings = {0.0: 0.05, 0.02: -1e6, 0.04: np.nan, 0.06: 1e6, 0.08: 0.3}
    periods = {seam.CLOCK.name: h, depth.name: 0.02, battery.name: 0.01}
    schedule = seam.exchange_schedule(0.1, periods)

    def step(link, ex):  # the station: publish what is due, then wait for the command
        link.advance_floor(ex.utime)
        if ex.time == 0.0:  # first, what the controller's initialization reads
            link.publish(
                depth.name,
                seam.vector_message(seam.BEFORE_START_TIME, [0.05]),
                seam.BEFORE_START_UTIME,
            )
        for name in ex.channels:
            if name == seam.CLOCK.name:
                msg = seam.joint_state_message(ex.time, held["desired_state"])
            elif name == depth.name:
                msg = seam.vector_message(ex.time, [readings[round(ex.time, 3)]])
            else:
                soc = 7.0 if round(ex.time, 3) == 0.03 else 0.9
                msg = seam.vector_message(ex.time, [soc, 16.0, 3.0])
            link.publish(name, msg, ex.utime)
        if seam.CLOCK.name in ex.channels:
            link.wait_for(
                lambda: link.take({desired.name: ex.utime}),
                30,
                lambda _: None,
                lambda _: seam.SeamError(f"no command for {ex.time}"),
            )

    held = seam.initial_commands(scenario)
    hello = seam.Hello("station", "fakestat", "locomotion_swim", 0.1, h, "lockstep", tuple(periods))
    peer = _ScriptedPeer(url, hello, [desired], step, schedule, sticky=(seam.CLOCK.name,))
    result = seam.run_controller(scenario, url, timeout=10, startup_timeout=60)
    peer.thread.join(10)
    assert peer.error is None, peer.error
    assert result.incidents == {
        depth.name: {"ignored": 2, "dropout": 1},
        battery.name: {"ignored": 1},
    }
    err = _err_lines(capsys.readouterr())
    assert err == [  # in time order: lockstep logs the battery of 0.03 s before 0.031 s
        (
            "controller: MANTA_DEPTH: at t = 0.020 s: depth -1e+06 m outside its physical range "
            "[-1, 300] m: ignored (read as a dropped reading; the depth estimator holds its "
            "estimate) (further ignored messages on MANTA_DEPTH are counted, not shown)"
        ),
        (
            "controller: MANTA_BATTERY: at t = 0.030 s: state of charge 7 outside [0, 1]: ignored "
            "(logged as NaN) (further ignored messages on MANTA_BATTERY are counted, not shown)"
        ),
        (
            "controller: MANTA_DEPTH: at t = 0.040 s: depth NaN (a dropped reading): the depth "
            "estimator holds its estimate (further dropout messages on MANTA_DEPTH are counted, "
            "not shown)"
        ),
    ], err
    t, z_hat = result.log["t_command"], result.log["z_hat"][:, 0]
    held_span = (t > 0.021) & (t <= 0.08)
    assert np.all(z_hat[held_span] == z_hat[np.argmax(t > 0.0)])  # held from the 0 s reading
    assert z_hat[held_span][0] < 0.1 and z_hat[-1] == 1.0  # the 0.3 m of 0.08 s: the floor
    np.testing.assert_array_equal(result.log["t_battery"], np.arange(10) * 0.01)
    soc = result.log["battery"][:, 0]
    assert np.isnan(soc[3]) and np.all(soc[np.arange(10) != 3] == 0.9)


def test_controller_screens_imu_readings_and_its_posture_estimator_holds_through_them(capsys):
    """A roll of 7 rad and a yaw rate of 100 rad/s are beyond the IMU's range: read as
    dropped values, as a NaN yaw is, through which the posture estimator holds those channels
    (unscreened, the roll would pull roll_hat toward wrap(7) = 0.72 rad); a specific force of
    1000 m/s^2 is dropped too; a good roll of 0.2 rad moves roll_hat as the lag's closed
    form says. One line per kind; all counted."""
    from manta_drake.scenario import load_scenario

    scenario = load_scenario("swim_heading_hold", {"duration": 0.1})
    url = unique_url()
    h = scenario.time_step
    depth = seam.CHANNEL_BY_NAME["MANTA_DEPTH"]
    imu = seam.CHANNEL_BY_NAME["MANTA_IMU"]
    desired = seam.CHANNEL_BY_NAME["MANTA_DESIRED_JOINT_STATE"]
    periods = {seam.CLOCK.name: h, depth.name: 0.02, imu.name: 0.01}
    schedule = seam.exchange_schedule(0.1, periods)
    base = np.array([0.1, 0.05, 0.3, 0.0, 0.0, 0.2, 0.0, 0.0, 9.81])

    def reading(t):  # what the scripted IMU sends at t (ms)
        x = base.copy()
        ms = round(t * 1000)
        if ms >= 60:
            x[0] = 0.2
        if ms == 20:
            x[0] = 7.0
        elif ms == 40:
            x[5], x[2] = 100.0, np.nan
        elif ms == 60:
            x[6] = 1e3
        return x

    def step(link, ex):  # the station: publish what is due, then wait for the command
        link.advance_floor(ex.utime)
        if ex.time == 0.0:  # first, what the controller's initialization reads
            link.publish(
                depth.name,
                seam.vector_message(seam.BEFORE_START_TIME, [0.05]),
                seam.BEFORE_START_UTIME,
            )
            link.publish(
                imu.name, seam.vector_message(seam.BEFORE_START_TIME, base), seam.BEFORE_START_UTIME
            )
        for name in ex.channels:
            if name == seam.CLOCK.name:
                msg = seam.joint_state_message(ex.time, held["desired_state"])
            elif name == depth.name:
                msg = seam.vector_message(ex.time, [0.05])
            else:
                msg = seam.vector_message(ex.time, reading(ex.time))
            link.publish(name, msg, ex.utime)
        if seam.CLOCK.name in ex.channels:
            link.wait_for(
                lambda: link.take({desired.name: ex.utime}),
                30,
                lambda _: None,
                lambda _: seam.SeamError(f"no command for {ex.time}"),
            )

    held = seam.initial_commands(scenario)
    hello = seam.Hello(
        "station", "fakeimu0", "swim_heading_hold", 0.1, h, "lockstep", tuple(periods)
    )
    peer = _ScriptedPeer(url, hello, [desired], step, schedule, sticky=(seam.CLOCK.name,))
    result = seam.run_controller(scenario, url, timeout=10, startup_timeout=60)
    peer.thread.join(10)
    assert peer.error is None, peer.error
    assert result.incidents == {imu.name: {"ignored": 3, "dropout": 1}}
    err = _err_lines(capsys.readouterr())
    assert err == [
        (
            "controller: MANTA_IMU: at t = 0.020 s: imu roll 7 rad beyond +-3.142: ignored (read "
            "as dropped readings; the posture estimator holds them) (further ignored messages on "
            "MANTA_IMU are counted, not shown)"
        ),
        (
            "controller: MANTA_IMU: at t = 0.040 s: imu wz 100 rad/s beyond +-35: ignored (read "
            "as dropped readings; the posture estimator holds them); imu yaw NaN (dropped "
            "readings): the posture estimator holds them (further ignored/dropout messages on "
            "MANTA_IMU are counted, not shown)"
        ),
    ], err
    # Logged before each step's updates: the estimator's update at 0.02 s shows from 0.021 s.
    t = result.log["t_command"]
    roll, pitch, yaw = result.log["attitude_hat"].T
    yaw_rate = result.log["yaw_rate_hat"][:, 0]
    # Seeded from the readings (the angles wrapped into (-pi, pi], to the last bit or so),
    # then unchanged: roll held through the 7 rad of 0.02 s, yaw through the NaN and the yaw
    # rate through the 100 rad/s of 0.04 s.
    for values, first, until in (
        (roll, 0.1, 0.06),
        (pitch, 0.05, 1.0),
        (yaw, 0.3, 1.0),
        (yaw_rate, 0.2, 1.0),
    ):
        assert values[0] == pytest.approx(first, abs=1e-15)
        np.testing.assert_array_equal(values[t <= until], values[0])
    tau = scenario.posture_estimator.time_constant
    for after, samples in ((0.06, 1), (0.08, 2)):  # a step of 0.1 rad, j samples later
        k = np.flatnonzero(t > after + 1e-9)[0]
        assert roll[k] == pytest.approx(0.2 - 0.1 * np.exp(-samples * 0.02 / tau), abs=1e-15)


# ---------------------------------------------------------------------------------------
# Two processes


SWIM_TO_TROT = """\
name: lcm_swim_to_trot
description: "two_behaviors, shorter: the balloon deflates at 0.2 s, the robot sinks, z_hat
  rises and the transition leaves the swim for the trot."
duration: {duration}
initial_pose: {{xyz: [-2.0, 0.0, -0.045]}}
initial_stance: swim
controller: {{mode: transition, gait: swim}}
balloon:
  initial_fill: 1.0
  schedule:
    - {{time: 0.2, fill: 0.0}}
water: {{update_period: 0.004}}
{extra}visualization: {{meshcat: false}}
steady_after: 0.0
"""


def _scenario_file(tmp_path, duration=5.0, extra="") -> pathlib.Path:
    path = tmp_path / "swim_to_trot.yaml"
    path.write_text(SWIM_TO_TROT.format(duration=duration, extra=extra))
    return path


def _single_run(path):
    """The single diagram, advanced in one call (simulate.run's 50 ms chunk ends are not
    on the plant's step grid, which adds ~1e-16 s integrator steps)."""
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import extract_log, make_simulator
    from manta_drake.wiring.diagram import build_diagram

    scenario = load_scenario(path)
    diagram, handles = build_diagram(scenario)
    simulator = make_simulator(diagram, scenario)
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(scenario.duration)
    wall = time.perf_counter() - start
    return extract_log(handles, simulator.get_context()), scenario.duration / wall


def _start(side, path, url, out, *args):
    err = open(out / f"{side}.err", "w")  # noqa: SIM115 (the caller closes it after the run)
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "manta_drake.cli",
            side,
            str(path),
            "--lcm",
            url,
            "--out",
            str(out),
            *args,
        ],
        stdout=subprocess.PIPE,
        stderr=err,
        text=True,
        cwd=REPO,
    ), err


def _split_run(path, out, *args, wall_timeout=90.0):
    url = unique_url()
    station, serr = _start("station", path, url, out, *args)
    controller, cerr = _start("controller", path, url, out, *args)
    try:
        for proc in (station, controller):
            proc.wait(timeout=wall_timeout)
    finally:
        for proc in (station, controller):
            if proc.poll() is None:
                proc.kill()
        serr.close()
        cerr.close()
    for side, proc in (("station", station), ("controller", controller)):
        assert proc.returncode == 0, f"{side}: {(out / f'{side}.err').read_text()}"
    return (
        dict(np.load(out / "station_log.npz")),
        dict(np.load(out / "controller_log.npz")),
        json.loads((out / "station_metrics.json").read_text()),
    )


@pytest.mark.slow
def test_a_lockstep_run_without_dropouts_reports_none(tmp_path):
    """0.1 s of the station and the controller in two processes, lockstep over udpm, with a
    pressure sensor that drops nothing: the controller names and counts no dropout (the
    station's depth from before its first sample, NaN, is no dropped reading), and its depth
    estimate is finite from the first command on."""
    path = _scenario_file(tmp_path, duration=0.1)
    _, controller, _ = _split_run(path, tmp_path)
    err = (tmp_path / "controller.err").read_text()
    assert "dropout" not in err and "MANTA_DEPTH" not in err, err
    assert json.loads((tmp_path / "controller_metrics.json").read_text())["incidents"] == {}
    assert len(controller["z_hat"]) == len(controller["t_command"]) == 100
    assert np.all(np.isfinite(controller["z_hat"]))


@pytest.mark.slow
def test_split_run_matches_the_single_diagram(tmp_path):
    """5 s of swim -> trot with the station and the controller in two processes, lockstep
    over udpm: the same joint angles as the single diagram, bit for bit (the seam meets at
    Drake's own event times, so nothing is rounded or resampled)."""
    path = _scenario_file(tmp_path)
    single, single_rtf = _single_run(path)
    station, controller, metrics = _split_run(path, tmp_path)

    np.testing.assert_array_equal(station["t"], single["t"])  # every step, and t = 5 s
    err = np.abs(station["joint_angles"] - single["joint_angles"]).max()
    assert err <= 1e-6, f"joint angles differ by {err:.3g} rad"
    assert err == 0.0, f"joint angles differ by {err:.3g} rad (within 1e-6, but not exact)"
    n = len(controller["t_command"])
    assert n == 5000
    np.testing.assert_array_equal(
        controller["commanded_joint_angles"], single["commanded_joint_angles"][:n]
    )
    np.testing.assert_array_equal(station["body_xyz"], single["body_xyz"])
    # The run did cross the seam's depth path: the robot sank and the transition moved.
    assert single["z_hat"].max() > 0.4
    assert np.abs(controller["cpg_params"][-1] - controller["cpg_params"][0]).max() > 1.0
    # The station's monitoring ports cross too: what it sent at u is the single diagram's
    # signal (logged before the updates at each log time: the first log time >= u), and the
    # controller logged every sample exactly as sent.
    for port, size in (("battery", 3), ("electrical_power", 1), ("balloon_volume", 1)):
        t_sent, sent = station[f"t_{port}"], station[port]
        assert len(t_sent) == 500, port  # every 10 ms
        k = np.searchsorted(single[f"t_{port}"], t_sent, side="left")
        np.testing.assert_array_equal(sent.reshape(-1, size), single[port][k], err_msg=port)
        np.testing.assert_array_equal(controller[f"t_{port}"], t_sent, err_msg=port)
        np.testing.assert_array_equal(controller[port], sent, err_msg=port)
    assert np.ptp(station["battery"][:, 0]) > 0 and np.ptp(station["electrical_power"]) > 1.0
    assert metrics["incidents"] == {} and metrics["peer_run_id"]
    print(
        f"split real-time factor {metrics['real_time_factor']:.2f}, "
        f"single {single_rtf:.2f}, re-sends {metrics['resends']}"
    )


@pytest.mark.slow
def test_split_run_with_camera_meets_drakes_off_grid_camera_times(tmp_path):
    """With the camera on, the third frame is taken at 0.6000000000000001 s, after the
    plant's step at 0.6 s: the split run sends that frame then, and the wall detector's
    statistics and the joints match the single diagram exactly."""
    extra = "camera: {enabled: true, rate_hz: 5.0}\n"
    path = _scenario_file(tmp_path, duration=1.0, extra=extra)
    path.write_text(
        path.read_text()
        .replace("[-2.0, 0.0, -0.045]", "[6.9, 0.0, -0.22]")
        .replace("initial_stance: swim", "initial_stance: trot")
        .replace("fill: 1.0", "fill: 0.0")
    )
    single, _ = _single_run(path)
    station, controller, _ = _split_run(path, tmp_path)
    np.testing.assert_array_equal(station["joint_angles"], single["joint_angles"])
    # detector_status is logged at the camera times; the controller logs at every step
    # before that step's updates: the last step at or before each camera time.
    steps = np.floor(single["t_detector_status"] / 1e-3 + 1e-9).astype(int)
    ok = steps < len(controller["t_command"])
    np.testing.assert_array_equal(
        controller["detector_status"][steps[ok]], single["detector_status"][ok]
    )
    assert single["s_hat"].max() > 0.9  # the wall was seen: the camera path was used


def _shipped_single_run(name, duration):
    """``_single_run`` of a shipped scenario, shortened, without its Meshcat (a visualizer's
    publish events every 1/64 s split the CPG's integration steps: ~1e-15 rad)."""
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import extract_log, make_simulator
    from manta_drake.wiring.diagram import build_diagram

    scenario = load_scenario(name, {"duration": duration})
    scenario.visualization.meshcat = False
    diagram, handles = build_diagram(scenario)
    simulator = make_simulator(diagram, scenario)
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(scenario.duration)
    wall = time.perf_counter() - start
    return extract_log(handles, simulator.get_context()), scenario.duration / wall


def _assert_split_is_single(name, duration, tmp_path, estimates, sensors):
    """The split run of the shipped ``name`` for ``duration`` s against the single diagram:
    every joint angle, body position and command equal; the controller's ``estimates`` (at
    every command) equal the single diagram's at its log times; the station's ``sensors``,
    as sent, equal the single diagram's signals. Returns (station, controller, metrics,
    single)."""
    from manta_drake.scenario import find_scenario

    single, single_rtf = _shipped_single_run(name, duration)
    station, controller, metrics = _split_run(
        find_scenario(name), tmp_path, "--duration", str(duration)
    )
    np.testing.assert_array_equal(station["t"], single["t"])
    err = np.abs(station["joint_angles"] - single["joint_angles"]).max()
    assert err == 0.0, f"joint angles differ by {err:.3g} rad"
    np.testing.assert_array_equal(station["body_xyz"], single["body_xyz"])
    n = len(controller["t_command"])
    assert n == round(duration / 1e-3)
    np.testing.assert_array_equal(
        controller["commanded_joint_angles"], single["commanded_joint_angles"][:n]
    )
    for port in estimates:
        # Both logged before the updates at their times: the step at or before each log time.
        steps = np.floor(single[f"t_{port}"] / 1e-3 + 1e-9).astype(int)
        ok = steps < n
        np.testing.assert_array_equal(
            controller[port][steps[ok]].reshape(ok.sum(), -1),
            single[port][ok].reshape(ok.sum(), -1),
            err_msg=port,
        )
    for port in sensors:
        t_sent = station[f"t_{port}"]
        np.testing.assert_array_equal(
            t_sent,
            seam.sample_times(
                seam.CHANNEL_BY_NAME[f"MANTA_{port.upper()}"].period(_loaded(name, duration)),
                duration,
            ),
            err_msg=port,
        )
        k = np.searchsorted(single[f"t_{port}"], t_sent, side="left")  # the first log >= u
        np.testing.assert_array_equal(
            station[port].reshape(len(k), -1), single[port][k], err_msg=port
        )
    assert metrics["incidents"] == {}
    print(
        f"{name} {duration:g} s: split real-time factor {metrics['real_time_factor']:.2f}, "
        f"single {single_rtf:.2f}, re-sends {metrics['resends']}"
    )
    return station, controller, metrics, single


def _loaded(name, duration):
    from manta_drake.scenario import load_scenario

    return load_scenario(name, {"duration": duration})


@pytest.mark.slow
def test_split_run_with_the_imu_heading_hold_matches_the_single_diagram(tmp_path):
    """2 s of swim_heading_hold (the IMU's 9 values every 10 ms, the heading hold trimming
    the swim) in two processes: the single diagram bit for bit. The posture estimator seeds
    itself at initialization from what the single diagram's initialization reads, the IMU
    before its own initialization (all zeros): the station sends that first."""
    station, controller, _, single = _assert_split_is_single(
        "swim_heading_hold",
        2.0,
        tmp_path,
        ("attitude_hat", "posture_hat", "heading_trim", "cpg_params", "z_hat"),
        ("imu", "depth"),
    )
    assert np.abs(single["heading_trim"]).max() > 0.01  # the IMU's path steered the swim
    np.testing.assert_array_equal(controller["attitude_hat"][0], 0.0)
    assert np.abs(station["imu"][0, :3]).max() > 1e-3  # the first reading is not zero


@pytest.mark.slow
def test_split_run_of_four_behaviors_matches_the_single_diagram(tmp_path):
    """2 s of four_behaviors: the IMU, the flow sensor and the battery all cross (the battery
    at the energy estimator's 100 ms, off the 10 ms grid at 0.30000000000000004 s ...), the
    tree and the balloon rule read their estimates: the single diagram bit for bit."""
    station, controller, _, _ = _assert_split_is_single(
        "four_behaviors",
        2.0,
        tmp_path,
        (
            "attitude_hat",
            "heading_trim",
            "flow_speed_hat",
            "flow_hat",
            "soc_hat",
            "energy_hat",
            "behaviour_weights",
            "cpg_params",
            "balloon_command",
        ),
        ("imu", "flow_velocity", "battery", "depth"),
    )
    assert station["t_battery"][3] == 0.30000000000000004 and len(station["t_battery"]) == 20
    # Each path carried something: the charge fell, the flow estimate rose, the trim acted.
    assert np.ptp(controller["soc_hat"]) > 1e-5 and controller["flow_hat"].max() > 0.1
    assert np.abs(controller["heading_trim"]).max() > 0.01


@pytest.mark.slow
def test_split_run_with_the_altimeter_matches_the_single_diagram(tmp_path):
    """2 s of nose_up_trot: the altimeter's range every 100 ms crosses, the tree reads its
    floor_hat: the single diagram bit for bit."""
    station, controller, _, _ = _assert_split_is_single(
        "nose_up_trot",
        2.0,
        tmp_path,
        ("altitude_hat", "floor_hat", "behaviour_weights", "cpg_params"),
        ("altitude", "depth"),
    )
    assert len(station["t_altitude"]) == 20 and np.all(np.isfinite(station["altitude"]))
    assert np.ptp(controller["altitude_hat"]) > 1e-3  # the range moved with the gait


@pytest.mark.slow
def test_the_battery_cutoff_ends_both_sides_at_the_single_diagrams_time(tmp_path):
    """The battery reaches its cut-off a few steps in: the station stops where the single
    diagram stops, says why, and its controller stops too at once, naming the reason."""
    extra = "actuators: {initial_soc: 0.200004}\n"
    path = _scenario_file(tmp_path, duration=1.0, extra=extra)
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import make_simulator
    from manta_drake.wiring.diagram import build_diagram

    scenario = load_scenario(path)
    diagram, _ = build_diagram(scenario)
    simulator = make_simulator(diagram, scenario)
    simulator.Initialize()
    status = simulator.AdvanceTo(scenario.duration)
    t_stop = simulator.get_context().get_time()
    assert 0.0 < t_stop < 0.5 and "battery empty" in status.message()

    start = time.monotonic()
    _, controller, metrics = _split_run(path, tmp_path)
    assert time.monotonic() - start < 60
    assert metrics["sim_time_s"] == t_stop and metrics["status"] == "stopped"
    assert metrics["stopped"] == f"at t = {t_stop:.3f} s: {status.message()}"
    station_err = (tmp_path / "station.err").read_text()
    assert f"station: stopped at t = {t_stop:.3f} s: battery empty" in station_err
    controller_err = (tmp_path / "controller.err").read_text()
    assert (
        f"controller: the station stopped at t = {t_stop:.3f} s: battery empty" in controller_err
        and "stopping too" in controller_err
    )
    c_metrics = json.loads((tmp_path / "controller_metrics.json").read_text())
    assert c_metrics["status"] == "stopped"
    assert controller["t_command"][-1] <= t_stop + seam.MAX_LEAD_STEPS * 1e-3


# The controller's failsafe when the station stops: tests/test_ros2_seam.py, over LCM and
# over ROS 2.
