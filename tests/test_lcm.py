"""The seam over LCM (manta_drake.seam): messages, schedule, transport, and the split
run in two processes against the single diagram."""

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
    shuffled = seam.joint_state_message(0.5, np.r_[x[:16][order], x[16:][order]],
                                        names=[JOINT_NAMES[i] for i in order])
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
    assert [p.stem for p in sources] == ["lcmt_manta_joint_state", "lcmt_manta_pose"]
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


def test_channel_table_matches_the_ports_and_the_docs():
    from manta_drake.wiring.controller import build_controller
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.station import build_station

    scenario = load_scenario("three_behaviors", {"duration": 1.0})
    station, _ = build_station(scenario)
    controller, _ = build_controller(scenario)
    for channel in seam.CHANNELS:  # every channel is a port of its sender
        sender = station if channel.sender == "station" else controller
        assert sender.HasOutputPort(channel.port), channel.name
    sends, reads = seam.controller_channels(controller)
    assert {c.port for c in reads} == {"measured_joint_state", "depth", "depth_image",
                                       "camera_pose"}
    assert {c.port for c in sends} == {"desired_state", "balloon_command"}
    docs = (REPO / "docs" / "lcm.md").read_text()
    assert seam.channel_table_markdown() in docs, "docs/lcm.md: paste channel_table_markdown()"


def test_controller_commands_do_not_depend_directly_on_the_sensors():
    """Why the lockstep controller may publish its commands for t before t's sensors."""
    from manta_drake.wiring.controller import build_controller
    from manta_drake.scenario import load_scenario

    controller, _ = build_controller(load_scenario("three_behaviors"))
    sends, reads = seam.controller_channels(controller)
    assert not seam.has_feedthrough(controller, reads, sends)


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
        station.lcm.subscribe(name, functools.partial(lambda box, _, data: box.append(data),
                                                      box))
    station.publish(clock.name, seam.joint_state_message(0.0, np.zeros(32)), 0)
    station.publish(depth.name, seam.vector_message(0.0, [0.1]), 0)
    station.publish(depth.name, seam.vector_message(0.02, [0.2]), 20000)
    station.drain()
    assert [len(sent[clock.name]), len(sent[depth.name])] == [1, 2]
    # A command stamped 0.02 s says the controller has what was sent before 0.02 s:
    # only the depth of 0.02 s and the newest clock message are sent again.
    station.lcm.publish(desired.name, seam.joint_state_message(0.02, np.ones(32)).encode())
    station.drain()
    assert station.newest[desired.name] == 20000
    station.resend()
    station.drain()
    assert [len(sent[clock.name]), len(sent[depth.name])] == [2, 3]
    assert lcmt_scope.decode(sent[depth.name][-1]).utime == 20000
    got = station.take({desired.name: 20000})
    np.testing.assert_array_equal(seam.joint_state_from_message(got[desired.name]),
                                  np.ones(32))
    # Nothing comes: a warning after STALE_AFTER_S, re-sends meanwhile, then the error.
    stale = []
    start = time.monotonic()
    with pytest.raises(seam.SeamError, match="silent"):
        station.wait_for(lambda: station.take({desired.name: 21000}), 1.3, stale.append,
                         lambda waited: seam.SeamError(f"silent for {waited:.1f} s"))
    assert 1.3 <= time.monotonic() - start < 3.0
    assert len(stale) == 1 and stale[0] >= seam.STALE_AFTER_S
    station.drain()
    assert len(sent[clock.name]) >= 2 + 10  # the clock again every 0.1 s while waiting


def test_bad_url_is_one_clear_line(capsys):
    from manta_drake.cli import main

    assert main(["controller", "stand", "--lcm", "bogus://nowhere", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot open the LCM URL 'bogus://nowhere'" in err[0]


def test_station_without_controller_times_out():
    from manta_drake.scenario import load_scenario

    scenario = load_scenario("stand", {"duration": 0.1})
    start = time.monotonic()
    with pytest.raises(seam.SeamError, match=r"no command for t = 0\.000 s within 0\.5 s"):
        seam.run_station(scenario, "memq://", timeout=0.5, startup_timeout=0.5)
    assert time.monotonic() - start < 30


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
    from manta_drake.wiring.diagram import build_diagram
    from manta_drake.scenario import load_scenario
    from manta_drake.simulate import extract_log, make_simulator

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
        [sys.executable, "-m", "manta_drake.cli", side, str(path), "--lcm", url,
         "--out", str(out), *args],
        stdout=subprocess.PIPE, stderr=err, text=True, cwd=REPO), err


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
    return (dict(np.load(out / "station_log.npz")), dict(np.load(out / "controller_log.npz")),
            json.loads((out / "station_metrics.json").read_text()))


@pytest.mark.slow
def test_split_run_matches_the_single_diagram(tmp_path):
    """5 s of swim -> trot with the station and the controller in two processes, lockstep
    over udpm: the same joint angles as the single diagram (the issue asks 1e-6 rad; the
    seam meets at Drake's own event times, so they are equal bit for bit)."""
    path = _scenario_file(tmp_path)
    single, single_rtf = _single_run(path)
    station, controller, metrics = _split_run(path, tmp_path)

    np.testing.assert_array_equal(station["t"], single["t"])  # every step, and t = 5 s
    err = np.abs(station["joint_angles"] - single["joint_angles"]).max()
    assert err <= 1e-6, f"joint angles differ by {err:.3g} rad"
    assert err == 0.0, f"joint angles differ by {err:.3g} rad (within 1e-6, but not exact)"
    n = len(controller["t_command"])
    assert n == 5000
    np.testing.assert_array_equal(controller["commanded_joint_angles"],
                                  single["commanded_joint_angles"][:n])
    np.testing.assert_array_equal(station["body_xyz"], single["body_xyz"])
    # The run did cross the seam's depth path: the robot sank and the transition moved.
    assert single["z_hat"].max() > 0.4
    assert np.abs(controller["cpg_params"][-1] - controller["cpg_params"][0]).max() > 1.0
    print(f"split real-time factor {metrics['real_time_factor']:.2f}, "
          f"single {single_rtf:.2f}, re-sends {metrics['resends']}")


@pytest.mark.slow
def test_split_run_with_camera_meets_drakes_off_grid_camera_times(tmp_path):
    """With the camera on, the third frame is taken at 0.6000000000000001 s, after the
    plant's step at 0.6 s: the split run sends that frame then, and the wall detector's
    statistics and the joints match the single diagram exactly."""
    extra = "camera: {enabled: true, rate_hz: 5.0}\n"
    path = _scenario_file(tmp_path, duration=1.0, extra=extra)
    path.write_text(path.read_text().replace("[-2.0, 0.0, -0.045]", "[6.9, 0.0, -0.22]")
                    .replace("initial_stance: swim", "initial_stance: trot")
                    .replace("fill: 1.0", "fill: 0.0"))
    single, _ = _single_run(path)
    station, controller, _ = _split_run(path, tmp_path)
    np.testing.assert_array_equal(station["joint_angles"], single["joint_angles"])
    # detector_status is logged at the camera times; the controller logs at every step
    # before that step's updates: the last step at or before each camera time.
    steps = np.floor(single["t_detector_status"] / 1e-3 + 1e-9).astype(int)
    ok = steps < len(controller["t_command"])
    np.testing.assert_array_equal(controller["detector_status"][steps[ok]],
                                  single["detector_status"][ok])
    assert single["s_hat"].max() > 0.9  # the wall was seen: the camera path was used


def _listen(listener, until, timeout: float) -> bool:
    """Handles the listener's messages as they come until ``until()`` or ``timeout``."""
    deadline = time.monotonic() + timeout
    while not until():
        if time.monotonic() > deadline:
            return False
        while listener.handle_timeout(0) > 0:
            pass
        listener.handle_timeout(20)
    return True


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["lockstep", "wall-clock"])
def test_controller_holds_its_last_command_when_the_station_stops(tmp_path, mode):
    """The station dies after 1 s: the controller sends nothing new, keeps re-sending its
    last command (in lockstep, with the few before it the station has not acknowledged),
    says so on stderr, and exits with status 2 after its --timeout."""
    import lcm

    path = _scenario_file(tmp_path, duration=5.0)
    url = unique_url()
    args = ["--timeout", "2"] + (["--wall-clock"] if mode == "wall-clock" else [])
    listener = lcm.LCM(url)
    heard = []
    listener.subscribe("MANTA_DESIRED_JOINT_STATE", lambda _, data: heard.append(
        (time.monotonic(), lcmt_manta_joint_state.decode(data)))).set_queue_capacity(10000)
    station, serr = _start("station", path, url, tmp_path, *args)
    controller, cerr = _start("controller", path, url, tmp_path, *args)
    try:
        station_err = tmp_path / "station.err"
        assert _listen(listener, lambda: station.poll() is not None
                       or "station: t = 1.0 s" in station_err.read_text(), 90)
        assert station.poll() is None, station_err.read_text()
        station.kill()
        killed = time.monotonic()
        _listen(listener, lambda: controller.poll() is not None, 30)
        exited = time.monotonic() - killed
    finally:
        for proc in (station, controller):
            if proc.poll() is None:
                proc.kill()
        serr.close()
        cerr.close()
    err = (tmp_path / "controller.err").read_text()
    assert controller.returncode == 2, err
    assert 2.0 <= exited < 10.0
    assert "holding the last command" in err
    assert "the station has been silent for" in err and err.strip().endswith("traceback)")
    # What it sent after the station had gone for good (the wall-clock controller runs on
    # for STALE_AFTER_S): what it had sent before, again.
    before = {m.utime: m for t, m in heard if t <= killed + 1.5}
    held = [m for t, m in heard if t > killed + 1.5]
    last = max(before)
    assert max(m.utime for m in held) == last
    assert sum(m.utime == last for m in held) >= 3
    for m in held:
        assert (m.position, m.velocity) == (before[m.utime].position, before[m.utime].velocity)
