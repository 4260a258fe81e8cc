"""The station/controller seam: defaults are the scenario's start, every state is in the
Context (two contexts of one diagram do not share anything), Drake randomness."""

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.systems.analysis import MonteCarloSimulation, Simulator
from pydrake.systems.framework import DiagramBuilder

from manta_drake import build_controller, build_diagram, build_station, load_scenario
from manta_drake.control.gaits import GAITS
from manta_drake.model.plant import body_pose
from manta_drake.simulate import make_simulator
from manta_drake.wiring.diagram import connect_by_name


def _scenario(name, **changes):
    s = load_scenario(name)
    s.visualization.meshcat = False
    for key, value in changes.items():
        setattr(s, key, value)
    return s.validate()


def _camera_scenario(duration=0.7):
    """Transition controller on the floor in trot, the end wall in the camera's view."""
    s = _scenario("three_behaviors", duration=duration)
    s.initial_pose.xyz = [7.5 - 0.19 - 0.55, 0.0, -0.25]
    s.initial_stance = "trot"
    s.balloon.initial_fill = 0.0
    s.balloon.schedule = []
    return s.validate()


def test_default_context_is_the_scenario_start():
    s = _scenario("three_behaviors")
    diagram, h = build_diagram(s)
    context = diagram.CreateDefaultContext()
    plant = h.plant
    pc = plant.GetMyContextFromRoot(context)
    X_WB = plant.EvalBodyPoseInWorld(pc, h.plant_handles.body)
    expected = body_pose(s.initial_pose.xyz, s.initial_pose.rpy_deg)
    np.testing.assert_allclose(X_WB.GetAsMatrix34(), expected.GetAsMatrix34(), atol=1e-12)
    q = np.array(
        [
            plant.GetJointByName(n, h.plant_handles.robot).get_angle(pc)
            for n in h.plant_handles.joint_names
        ]
    )
    np.testing.assert_allclose(q, GAITS["swim"].X.ravel())  # initial_stance: swim
    # The CPG starts at the lock of its initial gait (not at the unstable phi = 0), from
    # rest (r = 0), with its biases at the stance; the transition at the swim target.
    cpg = h.systems["cpg"]
    x = cpg.GetMyContextFromRoot(context).get_continuous_state_vector().CopyToVector()
    phi, r, _, chi, _ = x.reshape(5, 16)
    transition = h.systems["transition"]
    psi = transition.GetOutputPort("cpg_params").Eval(transition.GetMyContextFromRoot(context))
    np.testing.assert_allclose(psi, GAITS["swim"].to_vector(), atol=1e-12)
    # A lock of Eq. (5), read from the CPG's own derivatives: the couplings cancel, so every
    # oscillator turns at 2 pi f; along each leg-fin phi_{j+1} - phi_j is the gait's Phi[k, j].
    phi_dot = cpg.EvalTimeDerivatives(cpg.GetMyContextFromRoot(context)).CopyToVector()[:16]
    np.testing.assert_allclose(phi_dot, 2 * np.pi * s.cpg.frequency_hz, rtol=0, atol=1e-6)
    chain = np.diff(phi.reshape(4, 4), axis=1) - GAITS["swim"].Phi[:, :-1]
    np.testing.assert_allclose(np.angle(np.exp(1j * chain)), 0.0, atol=1e-12)
    assert phi[0] == 0.0 and np.any(np.abs(phi) > 1.0)  # leg 1's base at 0; not in phase
    np.testing.assert_array_equal(r, 0.0)
    np.testing.assert_allclose(chi, q)
    # and the balloon is full, the depth estimate at the initial head depth
    station = h.station
    sc = station.GetMyContextFromRoot(context)
    full = h.station_handles.coefficients.balloon.max_volume.value
    assert station.GetOutputPort("balloon_volume").Eval(sc)[0] == pytest.approx(full)


@pytest.mark.slow
def test_station_and_controller_alone_make_the_closed_loop():
    """What the README shows: the two builders and a by-name connection, nothing else."""
    s = _scenario("locomotion_swim", duration=0.3)
    builder = DiagramBuilder()
    station = builder.AddSystem(build_station(s)[0])
    controller = builder.AddSystem(build_controller(s)[0])
    assert sorted(connect_by_name(builder, station, controller)) == ["depth"]
    assert sorted(connect_by_name(builder, controller, station)) == [
        "balloon_command",
        "desired_state",
    ]
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.3)
    joints = station.GetOutputPort("measured_joint_state").Eval(
        station.GetMyContextFromRoot(simulator.get_context())
    )[:16]
    command = controller.GetOutputPort("desired_state").Eval(
        controller.GetMyContextFromRoot(simulator.get_context())
    )[:16]
    # The servos follow the CPG, behind it by the bus's 10-20 ms and their P loop's
    # b qdot / kp (~0.06 rad at the swim's 2.5 rad/s): 0.12 rad measured.
    assert np.abs(joints - command).max() < 0.2
    assert np.abs(command - GAITS["swim"].X.ravel()).max() > 0.05  # and it flaps


def _snapshot(diagram, h, context):
    """Everything that should be identical between equal runs."""
    plant_state = h.plant.GetPositionsAndVelocities(h.plant.GetMyContextFromRoot(context))
    ctrl = h.controller.GetMyContextFromRoot(context)
    status = h.controller.GetOutputPort("detector_status").Eval(ctrl)
    s_hat = h.controller.GetOutputPort("s_hat").Eval(ctrl)
    depth = h.station.GetOutputPort("depth").Eval(h.station.GetMyContextFromRoot(context))
    return np.concatenate([plant_state, status, s_hat, depth])


@pytest.mark.slow
def test_two_contexts_interleaved_equal_two_runs_one_after_the_other():
    """One diagram (with the camera and the wall detector), two contexts with different
    seeds, advanced alternately in small steps, end exactly where the same two runs end
    when simulated one after the other: no state is shared through the Systems."""
    s = _camera_scenario(duration=0.7)
    diagram, h = build_diagram(s)
    seeds = (3, 11)

    def new_simulator(seed):
        return make_simulator(diagram, s, diagram.CreateDefaultContext(), seed)

    times = np.arange(0.05, s.duration + 1e-9, 0.05)  # the same chunks in both: bit-exact
    sequential = []
    for seed in seeds:
        simulator = new_simulator(seed)
        for t in times:
            simulator.AdvanceTo(t)
        sequential.append(_snapshot(diagram, h, simulator.get_context()))
    a, b = (new_simulator(seed) for seed in seeds)
    for t in times:
        a.AdvanceTo(t)
        b.AdvanceTo(t)
    interleaved = [_snapshot(diagram, h, sim.get_context()) for sim in (a, b)]
    for x, y in zip(sequential, interleaved):
        np.testing.assert_array_equal(x, y)
    # the detector ran (4 frames at 5 Hz) and saw the wall, and the seeds differ
    status = sequential[0][-7:-2]  # detector_status (s_hat, wall_size, points, frames, failed)
    assert status[3] == 4 and status[1] > 0
    assert not np.array_equal(sequential[0], sequential[1])


@pytest.mark.slow
def test_monte_carlo_seeds_differ_and_repeat():
    """Drake's MonteCarloSimulation: the noise is drawn from the Context, so samples differ
    from one another and the same generator seed repeats them bit for bit."""
    s = _scenario("float_sink", duration=0.2)
    s.pressure_sensor.noise_std = 0.01
    diagram, h = build_diagram(s)
    station = h.station

    def make_simulator_(generator):
        return make_simulator(diagram, s)

    def output(system, context):
        # the last noisy pressure reading; the sensor's truth is smooth, so the sum of a
        # few readings differs between noise draws
        return float(station.GetOutputPort("depth").Eval(station.GetMyContextFromRoot(context))[0])

    def samples(seed):
        results = MonteCarloSimulation(
            make_simulator=make_simulator_,
            output=output,
            final_time=0.2,
            num_samples=3,
            generator=RandomGenerator(seed),
        )
        return np.array([r.output for r in results])

    first, again, other = samples(1), samples(1), samples(2)
    np.testing.assert_array_equal(first, again)
    assert len(np.unique(first)) == 3  # three different noise draws
    assert not np.any(np.isin(first, other))
    assert np.all(np.abs(first - first.mean()) < 0.05)  # noise, not a broken sensor


@pytest.mark.slow
def test_scenario_seed_gives_bit_identical_logs(tmp_path):
    from manta_drake.simulate import run

    logs = []
    for seed in (5, 5, 6):
        s = _scenario("float_sink", duration=0.5, random_seed=seed)
        s.pressure_sensor.noise_std = 0.01
        logs.append(run(s, tmp_path / str(len(logs)), progress=False, write_outputs=False).log)
    np.testing.assert_array_equal(logs[0]["depth"], logs[1]["depth"])
    np.testing.assert_array_equal(logs[0]["body_xyz"], logs[1]["body_xyz"])
    assert not np.array_equal(logs[0]["depth"], logs[2]["depth"])


def test_the_gait_reading_and_its_fin_sweep_reach_the_station_and_the_controller():
    """controller.gait_reading: mirrored builds the robot on its balanced sweep (30 deg: the
    plant's tips equal Eq. (1) with that sweep) and runs the mirrored gaits (the controller's
    first CPG parameters and the start stance are MIRRORED's trot)."""
    from manta_drake.control.gaits import MIRRORED
    from manta_drake.model.kinematics import fin_tip_pose
    from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS
    from manta_drake.wiring.controller import initial_cpg_params

    s = _scenario("locomotion_trot", duration=0.1)
    s.controller.gait_reading = "mirrored"
    s.validate()
    station, sh = build_station(s)
    plant, robot = sh.plant_handles.plant, sh.plant_handles.robot
    context = station.CreateDefaultContext()
    pc = plant.GetMyContextFromRoot(context)
    q = plant.GetPositions(pc, robot)[7:].reshape(4, 4)  # after the floating base
    np.testing.assert_allclose(q, MIRRORED["trot"].X, atol=1e-12)  # the start stance
    swept = DEFAULT_ROBOT.with_fin_sweep(np.radians(30.0))
    body = sh.plant_handles.body.body_frame()
    for k, leg in enumerate(LEGS):
        X = plant.GetFrameByName(f"{leg}_tip", robot).CalcPose(pc, body).GetAsMatrix4()
        np.testing.assert_allclose(X, fin_tip_pose(leg, q[k], swept), atol=1e-9)
        assert not np.allclose(X, fin_tip_pose(leg, q[k], DEFAULT_ROBOT), atol=1e-3)
    np.testing.assert_array_equal(initial_cpg_params(s), MIRRORED["trot"].to_vector())


# ---------------------------------------------------------------------------------------
# What the seam lets through (manta_drake.seam.limits)


def test_the_stations_limits_are_the_plants_joints_and_the_robots_parameters():
    """The station clips to its plant's joint limits; the controller, which has no plant,
    takes the same numbers from the robot's parameters the model is generated from."""
    from manta_drake.seam import JointLimits

    s = _scenario("locomotion_swim", duration=0.1)
    _, handles = build_station(s)
    plant, params = (
        JointLimits.from_plant(handles.plant_handles),
        JointLimits.from_params(s.robot_params()),
    )
    assert plant.names == params.names
    for field in ("lower", "upper", "velocity"):
        np.testing.assert_allclose(getattr(plant, field), getattr(params, field), rtol=1e-12)
    assert np.degrees(plant.upper[[0, 1, 2, 3]]).round(6).tolist() == [60, 90, 90, 100]
    assert np.all(plant.velocity == 8.0)


def test_joint_commands_are_clipped_and_a_nan_keeps_the_last_good_one():
    from manta_drake.model.robot_params import DEFAULT_ROBOT
    from manta_drake.seam import JointLimits, screen_joint_command

    limits = JointLimits.from_params(DEFAULT_ROBOT)
    last = np.r_[np.full(16, 0.1), np.full(16, 0.2)]
    good = np.r_[np.full(16, 0.5), np.full(16, -1.0)]
    same, problems = screen_joint_command(good, last, limits)
    assert same is good and problems == []  # nothing wrong: the very same array, bit for bit
    x = good.copy()
    x[0], x[16] = 1e6, 3.0  # fl_yaw far beyond +60 deg, moving further out
    x[1], x[17] = -2.0, -1.0  # fl_roll1 below -90 deg, moving further out
    x[18] = 50.0  # fl_pitch rate beyond 8 rad/s
    x[3], x[19] = np.nan, 0.0  # fl_roll2 angle NaN
    x[20] = np.inf  # fr_yaw rate inf
    safe, problems = screen_joint_command(x, last, limits)
    assert safe[0] == limits.upper[0] and safe[16] == 0.0  # at the stop, not pushing on
    assert safe[1] == limits.lower[1] and safe[17] == 0.0
    assert safe[18] == 8.0
    assert (safe[3], safe[19]) == (0.1, 0.2) and (safe[4], safe[20]) == (0.1, 0.2)  # held
    np.testing.assert_array_equal(
        np.delete(safe, [0, 1, 3, 4, 16, 17, 18, 19, 20]),
        np.delete(good, [0, 1, 3, 4, 16, 17, 18, 19, 20]),
    )
    assert [kind for kind, _ in problems] == ["clipped", "held"]
    assert problems[0][1] == (
        "fl_yaw angle 1e+06 rad outside [-1.047, 1.047], fl_roll1 angle "
        "-2 rad outside [-1.571, 1.571], fl_pitch rate 50 rad/s beyond "
        "+-8: clipped to the servos' limits"
    )
    assert problems[1][1] == (
        "fl_roll2 (nan rad, 0 rad/s), fr_yaw (0.5 rad, inf rad/s) not "
        "finite: those servos hold their last good command"
    )
    assert np.all(np.isfinite(safe))


def test_balloon_commands_are_clipped_to_the_pumps_range():
    from manta_drake.seam import screen_balloon_command

    fill = np.array([0.25])
    assert screen_balloon_command(fill, [0.5]) == (fill, [])
    for value, expected, kind in (
        (1.7, 1.0, "clipped"),
        (-0.2, 0.0, "clipped"),
        (np.nan, 0.5, "held"),
        (-np.inf, 0.5, "held"),
    ):
        safe, problems = screen_balloon_command(np.array([value]), np.array([0.5]))
        assert safe.tolist() == [expected] and [k for k, _ in problems] == [kind]


def test_sensor_ranges_come_from_the_robot_the_scenario_describes():
    """The battery's physical range is its pack's: n cells x 4.35 V, and at most the
    short-circuit current OCV / R_int."""
    from manta_drake.model.actuators import load_energy_model
    from manta_drake.seam import SensorRanges, screen_depth

    s = _scenario("locomotion_swim", duration=0.1)
    ranges = SensorRanges.for_scenario(s)
    pack = load_energy_model(s.actuators.file).pack
    assert pack.cells_in_series == 4 and ranges.battery_voltage == pytest.approx(4 * 4.35)
    ocv = 4 * max(pack.ocv_cell_voltage)
    assert ranges.battery_current == pytest.approx(ocv / pack.internal_resistance)
    assert ranges.image_size == (s.camera.width, s.camera.height)
    assert screen_depth(np.array([299.0]), ranges)[1] == []
    for bad in (-1e6, 301.0, np.inf, -np.inf):
        value, problems = screen_depth(np.array([bad]), ranges)
        assert np.isnan(value[0]) and [k for k, _ in problems] == ["ignored"]


def test_incidents_name_each_kind_once_per_channel_and_count_all(capsys):
    from manta_drake.seam import Incidents

    incidents = Incidents("station")
    for _ in range(1000):  # a NaN storm
        incidents.report("A", ["held"], "x not finite")
    incidents.report("A", ["clipped", "held"], "y too far; x not finite")
    incidents.report("B", ["held"], "z not finite")
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        "station: A: x not finite (further held messages on A are counted, not shown)",
        (
            "station: A: y too far; x not finite (further clipped/held messages on A are counted, "
            "not shown)"
        ),
        "station: B: z not finite (further held messages on B are counted, not shown)",
    ]
    assert incidents.counts == {"A": {"held": 1001, "clipped": 1}, "B": {"held": 1}}
    assert incidents.count(kind="held") == 1002 and incidents.count("A") == 1002


def test_imu_readings_outside_the_parts_full_scale_are_dropped_value_by_value():
    """Attitude within +-pi, body rates within 35 rad/s (2000 deg/s), specific force within
    160 m/s^2 (16 g), each value on its own: one beyond its bound (or +-inf) becomes NaN and
    is counted ``ignored``; a NaN passes (the sensor's dropout) and is counted ``dropout``;
    a good reading is passed on as the very same array."""
    from manta_drake.seam import SensorRanges, screen_reading

    ranges = SensorRanges()
    good = np.array([np.pi, -np.pi / 2, -np.pi, 35.0, -35.0, 0.1, 160.0, -160.0, 9.81])
    same, problems = screen_reading(good, "imu", ranges)
    assert same is good and problems == []  # the bounds themselves are readings
    x = good.copy()
    x[0] = np.nextafter(np.pi, 4.0)  # just past +pi
    x[4] = -35.001
    x[6] = np.inf
    x[2], x[8] = np.nan, np.nan
    safe, problems = screen_reading(x, "imu", ranges)
    expected = good.copy()
    expected[[0, 2, 4, 6, 8]] = np.nan
    np.testing.assert_array_equal(safe, expected)
    assert [kind for kind, _ in problems] == ["ignored", "dropout"]
    assert problems[0][1] == (
        "imu roll 3.142 rad beyond +-3.142, wy -35 rad/s beyond +-35, fx "
        "inf m/s^2 beyond +-160: ignored (read as dropped readings; the "
        "posture estimator holds them)"
    )
    assert problems[1][1] == (
        "imu yaw, fz NaN (dropped readings): the posture estimator holds them"
    )
    only_nan = np.r_[np.nan, good[1:]]
    value, problems = screen_reading(only_nan, "imu", ranges)
    assert value is only_nan and [kind for kind, _ in problems] == ["dropout"]


def test_flow_readings_beyond_5_m_s_per_axis_are_dropped():
    from manta_drake.seam import SensorRanges, screen_reading

    ranges = SensorRanges()
    good = np.array([-5.0, 5.0, 0.02])
    assert screen_reading(good, "flow_velocity", ranges) == (good, [])
    safe, problems = screen_reading(np.array([5.5, -np.inf, np.nan]), "flow_velocity", ranges)
    assert np.isnan(safe).all()
    ignored = (
        "flow velocity u 5.5 m/s beyond +-5, v -inf m/s beyond +-5: ignored (read as "
        "dropped readings; the flow estimator holds them)"
    )
    assert problems == [
        ("ignored", ignored),
        ("dropout", "flow velocity w NaN (dropped readings): the flow estimator holds them"),
    ]


def test_altimeter_ranges_beyond_the_longest_part_are_dropped():
    """The altimeter's range within 100 m (the longest-range part taken): 100.5 m or a
    negative range beyond it is corrupt; a NaN is the sounder's no-echo reading."""
    from manta_drake.seam import SensorRanges, screen_reading

    ranges = SensorRanges()
    good = np.array([0.21])
    assert screen_reading(good, "altitude", ranges) == (good, [])
    safe, problems = screen_reading(np.array([100.5]), "altitude", ranges)
    assert np.isnan(safe).all() and problems == [
        (
            "ignored",
            "altitude range 100.5 m beyond +-100: ignored (read as dropped readings; "
            "the altitude estimator holds them)",
        )
    ]
    assert screen_reading(np.array([np.nan]), "altitude", ranges)[1][0][0] == "dropout"


def test_a_battery_the_controller_reads_is_a_dropped_reading_when_out_of_range():
    """The same range as for the logged battery; the line says what becomes of it."""
    from manta_drake.seam import SensorRanges, screen_battery

    read = SensorRanges.for_scenario(load_scenario("four_behaviors"))
    logged = SensorRanges.for_scenario(_scenario("locomotion_swim", duration=0.1))
    assert read.battery_read and not logged.battery_read
    assert read.battery_voltage == logged.battery_voltage == pytest.approx(4 * 4.35)
    good = np.array([0.5, 15.0, 2.0])
    assert screen_battery(good, read) == (good, [])
    held = "read as a dropped reading; the energy estimator holds its estimate"
    for ranges, action in ((read, held), (logged, "logged as NaN")):
        value, problems = screen_battery(np.array([1.5, 15.0, 2.0]), ranges)
        assert np.isnan(value).all()
        assert problems == [("ignored", f"state of charge 1.5 outside [0, 1]: ignored ({action})")]


def test_the_stations_reading_before_its_first_sample_is_no_dropout(capsys):
    """The station sends the controller its sensors as they are before its initialization
    (what the single diagram's initialization events read): the pressure sensor has not
    sampled yet and holds NaN. Screened as such (``before_start``) it passes on unreported;
    the same NaN at a sample time is a dropped reading, named and counted, and a value out of
    range before the start is still ignored."""
    from manta_drake.seam import Incidents
    from manta_drake.seam.limits import Guard

    scenario = _scenario("two_behaviors")
    assert scenario.pressure_sensor.dropout_rate == 0.0
    station, _ = build_station(scenario)
    before = station.GetOutputPort("depth").Eval(station.CreateDefaultContext())
    assert np.isnan(before[0])  # what station_process sends stamped BEFORE_START_UTIME

    incidents = Incidents("controller")
    guard = Guard.for_controller(scenario, incidents)
    got = guard.screen({"MANTA_DEPTH": before}, 0.0, before_start=True)
    assert np.isnan(got["MANTA_DEPTH"][0])  # passed on: the estimator starts as in one diagram
    assert incidents.counts == {} and capsys.readouterr().err == ""
    guard.screen({"MANTA_DEPTH": np.array([np.nan])}, 0.02)
    assert incidents.counts == {"MANTA_DEPTH": {"dropout": 1}}
    assert "at t = 0.020 s: depth NaN (a dropped reading)" in capsys.readouterr().err
    got = guard.screen({"MANTA_DEPTH": np.array([-1e6])}, 0.0, before_start=True)
    assert np.isnan(got["MANTA_DEPTH"][0])
    assert incidents.counts == {"MANTA_DEPTH": {"dropout": 1, "ignored": 1}}
