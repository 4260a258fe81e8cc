"""Typed scenarios: the dataclasses a scenario YAML file is loaded into.

A scenario says everything one run needs: how long, the plant's time step, the
robot's initial pose, the random seed, the controller, and the simulator
settings. ``load_scenario(path)`` loads it with Drake's ``yaml_load_typed``
after checking every key against the schema (a misspelt key fails at load time,
naming its full path and the allowed keys), then ``Scenario.validate()`` checks
every value's range (naming the field and the allowed range).

The shipped scenarios are package data in ``manta_drake/scenarios/`` (``manta-drake
list``); ``find_scenario`` accepts a path or a shipped scenario's name.

Example (``manta_drake/scenarios/stand.yaml``)::

    name: stand
    duration: 5.0
    initial_pose: {xyz: [0, 0, -0.22], rpy_deg: [0, 0, 0]}
    controller: {mode: hold, gait: trot}
"""


import dataclasses as dc
import functools
import math
import pathlib
import types
import typing

import yaml
from pydrake.common.yaml import yaml_load_typed
from pydrake.systems.analysis import SimulatorConfig

from manta_drake.control.vision import WallDetectorParams


class ScenarioError(ValueError):
    """A scenario file or value is invalid; the message names the field."""


def _default_simulator_config() -> SimulatorConfig:
    # The CPG's continuous state beside a 1 ms discrete plant: fixed-step RK2 at
    # the plant period costs two derivative evaluations a step; error-controlled
    # RK3 costs three and gains nothing (the plant's step bounds the accuracy).
    return SimulatorConfig(
        integration_scheme="runge_kutta2",
        max_step_size=1e-3,
        use_error_control=False,
        target_realtime_rate=0.0,
        publish_every_time_step=False,
    )


@dc.dataclass
class InitialPose:
    """Initial pose of the robot's body in the world (z up, water surface at z = 0)."""

    xyz: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, -0.22])
    rpy_deg: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])


@dc.dataclass
class ControllerConfig:
    """What drives the joints' desired state.

    mode:
      ``hold``  the joints hold the stance (X) of ``gait``; no oscillation.
      ``gait``  the CPG runs ``gait`` for the whole run.
      ``transition``  the multifunctional controller chooses (later issues).
    """

    mode: str = "hold"
    gait: str = "trot"
    # How Eqs. (6)-(8) are read (manta_drake.control.gaits.READINGS): ``paper`` (the
    # legged gaits as printed, the swim mirrored) or ``mirrored`` (one mirror rule for
    # every gait; its stance needs robot.fin_sweep_deg 30, its default then; docs/stance.md).
    gait_reading: str = "paper"


@dc.dataclass
class RobotConfig:
    """The robot's geometry that the paper leaves open (manta_drake.model.robot_params)."""

    # Table 2's theta_offset: each leg-fin swept back by this at theta_1 = 0 [deg]. None: the
    # sweep that balances the stance of controller.gait_reading (gaits.BALANCED_FIN_SWEEP_DEG:
    # paper 10, which also keeps Table 1's size at the zero pose; mirrored 30), resolved where
    # it is used (Scenario.fin_sweep_deg) so that a later override of the reading moves it.
    # docs/stance.md.
    fin_sweep_deg: float | None = None


def resolve_fin_sweep_deg(fin_sweep_deg: float | None, gait_reading: str) -> float:
    """``fin_sweep_deg``, or if None the sweep that balances ``gait_reading``'s stance
    (gaits.BALANCED_FIN_SWEEP_DEG)."""
    from manta_drake.control.gaits import BALANCED_FIN_SWEEP_DEG

    if fin_sweep_deg is not None:
        return float(fin_sweep_deg)
    try:
        return BALANCED_FIN_SWEEP_DEG[gait_reading]
    except KeyError:
        raise ScenarioError(f"controller.gait_reading: {gait_reading!r} is not one of "
                            f"{', '.join(BALANCED_FIN_SWEEP_DEG)}") from None


@dc.dataclass
class CpgConfig:
    """Parameters of the CPG (Eq. 5); see ``manta_drake.control.cpg`` for why these defaults."""

    frequency_hz: float = 0.5
    chain_weight: float = 4.0
    fcs_weight: float = 4.0
    a: float = 20.0
    b: float = 20.0


@dc.dataclass
class TransitionConfig:
    """PotentialTransition (Eqs. 11-15); see ``manta_drake.control.transition`` for the defaults."""

    period: float = 0.02  # s
    g: float = 0.125
    T: float = 0.5
    alpha: float = 0.95
    z_t: float = 1.0
    blend: str = "potential"  # Eq. (12); "linear" is Eq. (11); "switch" an abrupt baseline
    follow: str = "descent"  # Eqs. (14)-(15); "direct": psi = psi_d at once (baselines)
    s_hat_time_constant: float = 1.0  # s, low-pass of the camera's step signal (0: none)
    # A behaviour counts as reached when every parameter is within this of it [rad].
    arrival_tolerance: float = 0.05


@dc.dataclass
class WaterConfig:
    """The pool's water. ``coefficients``: ``package://manta_drake/<file>`` (the package's
    model folder), an absolute path, or a path relative to the working directory."""

    enabled: bool = True
    coefficients: str = "package://manta_drake/hydrodynamics.yaml"
    current: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])  # m/s, world
    # 0: forces from the current state at every plant step (exact, no delay). > 0: computed
    # every update_period seconds and held (faster; one period of delay).
    update_period: float = 0.0
    # Multipliers of named coefficients of the file, e.g. {body.linear_damping: 1.3}
    # (sweeps and calibration; see manta_drake.model.coefficients.scale_coefficients).
    coefficient_scales: dict[str, float] = dc.field(default_factory=dict)


@dc.dataclass
class ContactConfig:
    """Contact between the robot and the pool (point contact, SAP)."""

    # Coulomb friction of the foot-floor pair (static = dynamic). 0.8: rubber-tipped fins on
    # the rough painted concrete of an outdoor pool, the top of the wet range 0.5-0.8.
    friction: float = 0.8


@dc.dataclass
class BalloonCommand:
    """From ``time`` [s] on, command the balloon to ``fill`` (0 = empty, 1 = max_volume)."""

    time: float = 0.0
    fill: float = 0.0


@dc.dataclass
class BalloonConfig:
    """The BVBS: initial fill and a schedule of fill commands (piecewise constant)."""

    initial_fill: float = 0.0
    schedule: list[BalloonCommand] = dc.field(default_factory=list)


@dc.dataclass
class PressureSensorConfig:
    """Depth sensor on the head: sample rate, noise, dropout (NaN readings), position."""

    rate_hz: float = 50.0
    noise_std: float = 0.002  # m
    dropout_rate: float = 0.0  # probability that a reading is NaN
    position: list[float] = dc.field(default_factory=lambda: [0.19, 0.0, 0.03])  # body frame


@dc.dataclass
class DepthEstimatorConfig:
    """Eq. (9). floor_distance is D: the pressure sensor's depth when the robot stands on
    the floor in the gait stance (0.21 m in the 0.5 m pool). Hovering just above the
    floor then already reads z_hat ~ 0.9, so the target is mostly the gait and the
    robot settles on the floor instead of being held up by swim-like flapping."""

    floor_distance: float = 0.20
    # The sensor's depth with the robot floating at rest at the surface, balloon full: the
    # zero of a pressure sensor zeroed at initial submersion (measured: float_sink, 1-5 s,
    # 0.030 m; tests/test_depth.py holds it). Depths are counted from it.
    surface_depth: float = 0.030


@dc.dataclass
class CameraConfig:
    """The RGB-D camera on the head (rendered with VTK) and its depth noise."""

    enabled: bool = False
    width: int = 160
    height: int = 120
    fov_y_deg: float = 58.0  # a RealSense D435's vertical field of view
    min_range: float = 0.1  # m
    # Underwater a depth camera's 850 nm infrared is absorbed within ~1 m (about 4 /m), so its
    # range is far shorter than in air: the wall is "seen" once it is within max_range.
    max_range: float = 0.8  # m
    rate_hz: float = 5.0
    depth_noise_std: float = 0.005  # m
    pixel_dropout: float = 0.01


@dc.dataclass
class VisualizationConfig:
    """Meshcat recording and logging."""

    meshcat: bool = True
    # 40 fps = a 25 ms publish period, on the 1 ms step grid: recording adds no extra
    # integrator steps, so a run with Meshcat matches one without, sample for sample.
    recording_fps: float = 40.0  # frames per second kept in recording.html


@dc.dataclass
class Scenario:
    """One run of the simulator."""

    name: str = "unnamed"
    description: str = ""
    duration: float = 5.0  # s
    time_step: float = 1e-3  # s, the discrete MultibodyPlant's period
    discrete_contact_approximation: str = "sap"
    contact: ContactConfig = dc.field(default_factory=ContactConfig)
    random_seed: int = 0
    robot: RobotConfig = dc.field(default_factory=RobotConfig)
    initial_pose: InitialPose = dc.field(default_factory=InitialPose)
    # Initial joint angles: the stance (X) of this gait, or "zero".
    initial_stance: str = "trot"
    controller: ControllerConfig = dc.field(default_factory=ControllerConfig)
    cpg: CpgConfig = dc.field(default_factory=CpgConfig)
    transition: TransitionConfig = dc.field(default_factory=TransitionConfig)
    water: WaterConfig = dc.field(default_factory=WaterConfig)
    balloon: BalloonConfig = dc.field(default_factory=BalloonConfig)
    pressure_sensor: PressureSensorConfig = dc.field(default_factory=PressureSensorConfig)
    depth_estimator: DepthEstimatorConfig = dc.field(default_factory=DepthEstimatorConfig)
    camera: CameraConfig = dc.field(default_factory=CameraConfig)
    wall_detector: WallDetectorParams = dc.field(default_factory=WallDetectorParams)
    simulator: SimulatorConfig = dc.field(default_factory=_default_simulator_config)
    visualization: VisualizationConfig = dc.field(default_factory=VisualizationConfig)
    log_period: float = 1e-3  # s, sample period of log.npz
    # Metrics average over t >= steady_after (capped at half the run) ...
    steady_after: float = 2.0
    # ... until the hull first comes within this distance of a wall [m] (free water only).
    free_water_margin: float = 0.3

    def fin_sweep_deg(self) -> float:
        """The fins' rest sweep [deg]: ``robot.fin_sweep_deg``, or if None the one that
        balances the stance of ``controller.gait_reading`` (gaits.BALANCED_FIN_SWEEP_DEG)."""
        return resolve_fin_sweep_deg(self.robot.fin_sweep_deg, self.controller.gait_reading)

    def robot_params(self):
        """The RobotParams of this scenario's geometry (model.robot_params)."""
        from manta_drake.model.robot_params import robot_with_fin_sweep_deg

        return robot_with_fin_sweep_deg(self.fin_sweep_deg())

    def validate(self) -> "Scenario":
        """Checks every value (type, finite, range, integer where it must be); raises
        ScenarioError naming the field, the value and the allowed range."""
        from manta_drake.control.gaits import READINGS  # late imports: they import scenario
        from manta_drake.control.transition import check_parameters

        _text("name", self.name)
        _text("description", self.description, allow_empty=True)
        _in_range("duration", self.duration, 0.0, 3600.0, "(0, 3600] s", open_low=True)
        # Below 0.1 ms a run takes hours (1e-7 s is an effective hang); above 10 ms the
        # contact and the CPG's RK2 lose accuracy.
        _in_range("time_step", self.time_step, 1e-4, 0.01, "[0.0001, 0.01] s")
        _one_of("discrete_contact_approximation", self.discrete_contact_approximation,
                ("sap", "lagged", "similar", "tamsi"))
        _in_range("contact.friction", self.contact.friction, 0.0, 2.0, "(0, 2]", open_low=True)
        _integer("random_seed", self.random_seed, 0, 2**32 - 1)
        _vector("initial_pose.xyz", self.initial_pose.xyz, 3)
        _vector("initial_pose.rpy_deg", self.initial_pose.rpy_deg, 3, bound=360.0)
        _one_of("controller.gait_reading", self.controller.gait_reading, tuple(READINGS))
        if self.robot.fin_sweep_deg is not None:
            # Beyond +-60 deg the yaw joint's +-60 deg range cannot bring a fin to the side.
            _in_range("robot.fin_sweep_deg", self.robot.fin_sweep_deg, -60.0, 60.0,
                      "[-60, 60] deg (or null: the gait reading's balanced sweep)")
        gaits = READINGS[self.controller.gait_reading]
        _one_of("initial_stance", self.initial_stance, ("zero",) + tuple(gaits))
        problem = initial_pose_problem(self.initial_pose.xyz, self.initial_pose.rpy_deg,
                                       self.initial_stance, self.controller.gait_reading,
                                       self.fin_sweep_deg())
        if problem:
            raise ScenarioError(f"initial_pose: {problem}")
        _one_of("controller.mode", self.controller.mode, ("hold", "gait", "transition"))
        _one_of("controller.gait", self.controller.gait, tuple(gaits))
        _in_range("cpg.frequency_hz", self.cpg.frequency_hz, 0.0, 5.0, "(0, 5] Hz", open_low=True)
        for name in ("chain_weight", "fcs_weight"):
            _in_range(f"cpg.{name}", getattr(self.cpg, name), 0.0, 100.0, "[0, 100] rad/s")
        for name in ("a", "b"):
            _in_range(f"cpg.{name}", getattr(self.cpg, name), 0.0, 200.0, "(0, 200] 1/s",
                      open_low=True)
        tr = self.transition
        for name in ("period", "g", "T", "alpha", "z_t", "s_hat_time_constant"):
            _number(f"transition.{name}", getattr(tr, name))
        _text("transition.blend", tr.blend)
        _text("transition.follow", tr.follow)
        try:
            check_parameters(tr.period, tr.g, tr.T, tr.alpha, tr.z_t, tr.blend,
                             tr.s_hat_time_constant, tr.follow)
        except ValueError as e:
            raise ScenarioError(f"transition.{e}") from None
        _in_range("transition.period", tr.period, self.time_step, 1.0,
                  f"[time_step = {self.time_step}, 1] s")
        _in_range("transition.arrival_tolerance", tr.arrival_tolerance, 0.0, math.pi,
                  "(0, pi] rad", open_low=True)
        w = self.water
        _boolean("water.enabled", w.enabled)
        if self.controller.mode == "transition" and not w.enabled:
            raise ScenarioError("controller.mode: 'transition' needs water.enabled: true "
                                "(z_hat comes from the pressure sensor)")
        # A pool's current; beyond ~1 m/s the robot's 0.1 m/s swim means nothing and the
        # quadratic damping's stiffness needs a smaller step.
        _vector("water.current", w.current, 3, bound=1.0, unit=" m/s")
        _in_range("water.update_period", w.update_period, 0.0, 0.02, "[0, 0.02] s")
        _text("water.coefficients", w.coefficients)
        if not isinstance(w.coefficient_scales, dict):
            raise ScenarioError(f"water.coefficient_scales: expected a mapping, got "
                                f"{w.coefficient_scales!r}")
        if w.enabled or w.coefficient_scales:  # scales are checked even with water off
            from manta_drake.model.coefficients import load_coefficients, scale_coefficients

            coeffs = load_coefficients(resolve_path(w.coefficients), "water.coefficients")
            try:
                scale_coefficients(coeffs, w.coefficient_scales)
            except ValueError as e:
                message = str(e)
                if message.startswith("coefficient_scales: "):  # a scaled value refused
                    message = "coefficient_scales." + message[len("coefficient_scales: "):]
                raise ScenarioError(f"water.{message}") from None
        _in_range("balloon.initial_fill", self.balloon.initial_fill, 0.0, 1.0, "[0, 1]")
        last = -math.inf
        for i, cmd in enumerate(self.balloon.schedule):
            _in_range(f"balloon.schedule[{i}].fill", cmd.fill, 0.0, 1.0, "[0, 1]")
            _in_range(f"balloon.schedule[{i}].time", cmd.time, 0.0, 3600.0, "[0, 3600] s")
            if cmd.time < last:
                raise ScenarioError(f"balloon.schedule[{i}].time: {cmd.time} is before the "
                                    f"previous command's time {last}; times must not decrease")
            last = cmd.time
        ps = self.pressure_sensor
        _in_range("pressure_sensor.rate_hz", ps.rate_hz, 0.0, 1.0 / self.time_step,
                  f"(0, 1/time_step = {1.0 / self.time_step:g}] Hz", open_low=True)
        _in_range("pressure_sensor.noise_std", ps.noise_std, 0.0, 0.1, "[0, 0.1] m")
        _in_range("pressure_sensor.dropout_rate", ps.dropout_rate, 0.0, 1.0, "[0, 1]")
        _vector("pressure_sensor.position", ps.position, 3, bound=0.5, unit=" m")
        _in_range("depth_estimator.floor_distance", self.depth_estimator.floor_distance, 0.0,
                  10.0, "(0, 10] m", open_low=True)
        _in_range("depth_estimator.surface_depth", self.depth_estimator.surface_depth, 0.0,
                  self.depth_estimator.floor_distance,
                  f"[0, floor_distance = {self.depth_estimator.floor_distance}) m",
                  open_high=True)
        cam = self.camera
        _boolean("camera.enabled", cam.enabled)
        for name in ("width", "height"):
            _integer(f"camera.{name}", getattr(cam, name), 8, 1024)
        _in_range("camera.fov_y_deg", cam.fov_y_deg, 0.0, 170.0, "(0, 170] deg", open_low=True)
        _in_range("camera.max_range", cam.max_range, 0.0, 10.0, "(0, 10] m", open_low=True)
        _in_range("camera.min_range", cam.min_range, 0.0, cam.max_range,
                  f"(0, max_range = {cam.max_range}) m", open_low=True, open_high=True)
        _in_range("camera.rate_hz", cam.rate_hz, 0.0, 60.0, "(0, 60] Hz", open_low=True)
        _in_range("camera.depth_noise_std", cam.depth_noise_std, 0.0, MAX_DEPTH_NOISE,
                  f"[0, {MAX_DEPTH_NOISE}] m (the depth-camera model: a RealSense-class "
                  "sensor's range noise within its 0.8 m underwater range)")
        _in_range("camera.pixel_dropout", cam.pixel_dropout, 0.0, 0.5, "[0, 0.5]")
        try:
            self.wall_detector.validate()
        except ValueError as e:
            raise ScenarioError(f"wall_detector.{e}") from None
        sim = self.simulator
        _one_of("simulator.integration_scheme", sim.integration_scheme,
                ("explicit_euler", "runge_kutta2", "runge_kutta3", "semi_explicit_euler"))
        _in_range("simulator.max_step_size", sim.max_step_size, 1e-5, 0.01, "[1e-05, 0.01] s")
        _in_range("simulator.accuracy", sim.accuracy, 0.0, 1.0, "(0, 1]", open_low=True)
        _boolean("simulator.use_error_control", sim.use_error_control)
        _in_range("simulator.start_time", sim.start_time, 0.0, 0.0,
                  "[0, 0] s (schedules and metrics count from t = 0)")
        _in_range("simulator.target_realtime_rate", sim.target_realtime_rate, 0.0, 100.0,
                  "[0, 100] (0: as fast as possible)")
        _boolean("simulator.publish_every_time_step", sim.publish_every_time_step)
        vis = self.visualization
        _boolean("visualization.meshcat", vis.meshcat)
        _in_range("visualization.recording_fps", vis.recording_fps, 0.0, 120.0, "(0, 120] fps",
                  open_low=True)
        steps = 1.0 / vis.recording_fps / self.time_step
        if vis.meshcat and abs(steps - round(steps)) > 1e-6:
            raise ScenarioError(
                f"visualization.recording_fps: {vis.recording_fps!r} gives a publish period "
                f"of {1e3 / vis.recording_fps:.4g} ms, not a multiple of time_step = "
                f"{self.time_step} s; recording would add integrator steps and change the run "
                "(40 fps = 25 ms is on a 1 ms grid)")
        _in_range("log_period", self.log_period, self.time_step, 1.0,
                  f"[time_step = {self.time_step}, 1] s")
        _in_range("steady_after", self.steady_after, 0.0, 3600.0, "[0, 3600] s")
        _in_range("free_water_margin", self.free_water_margin, 0.0, 1.0, "[0, 1] m")
        return self


@functools.lru_cache(maxsize=2)
def _collision_model(fin_sweep_deg: float):
    """A robot + pool plant (no water) and a context, built once per geometry, for
    start-pose checks."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant
    from manta_drake.model.robot_params import robot_with_fin_sweep_deg

    builder = DiagramBuilder()
    handles = add_plant(builder, robot_params=robot_with_fin_sweep_deg(fin_sweep_deg))
    diagram = builder.Build()
    return diagram, handles, diagram.CreateDefaultContext()


def deepest_start_contact(xyz, rpy_deg, q, fin_sweep_deg: float) -> tuple[float, tuple]:
    """The deepest penetration [m] between the robot's collision geometry (hull, fin plates,
    feet) and the pool's, with the body at ``xyz``, ``rpy_deg`` (world, deg), joint angles
    ``q`` and fins swept back ``fin_sweep_deg``; and the pair's geometry names (empty: no
    contact). One plant per sweep, built once per process."""
    from manta_drake.model.plant import body_pose, set_initial_state

    diagram, handles, context = _collision_model(fin_sweep_deg)
    pc = handles.plant.GetMyMutableContextFromRoot(context)
    set_initial_state(handles, pc, body_pose(xyz, rpy_deg), q)
    query = handles.plant.get_geometry_query_input_port().Eval(pc)
    deepest = max(query.ComputePointPairPenetration(), key=lambda pair: pair.depth, default=None)
    if deepest is None:
        return 0.0, ()
    inspector = query.inspector()
    return float(deepest.depth), tuple(inspector.GetName(g) for g in (deepest.id_A, deepest.id_B))


def _start_penetration(p, rpy_deg, q, fin_sweep_deg: float,
                       tolerance: float = 0.002) -> str | None:
    """Why the robot's collision geometry (hull, fin plates, feet) starts more than
    ``tolerance`` inside the pool's floor or walls, or None."""
    depth, names = deepest_start_contact(p, rpy_deg, q, fin_sweep_deg)
    if depth <= tolerance:
        return None
    return (f"the robot starts {depth * 1e3:.1f} mm inside the pool "
            f"({' and '.join(sorted(names))} overlap; at most {tolerance * 1e3:g} mm allowed)")


# Largest depth-image range noise the sensor model supports [m]: beyond ~30 mm at the 0.8 m
# underwater range the point cloud no longer resolves the 4 cm voxels the detector works on.
MAX_DEPTH_NOISE = 0.03


def initial_pose_problem(xyz, rpy_deg, stance: str, gait_reading: str = "paper",
                         fin_sweep_deg: float | None = None) -> str | None:
    """Why a start pose is not inside the pool's water clear of its floor and walls, or None.

    Checked at the start's stance: the hull's centre in the water (below the surface, above
    the floor); the hull (an ellipsoid) and the four fin tips (with their foot spheres, from
    the kinematics of Eq. 1) inside the walls and above the floor; and then every collision
    geometry of the robot (fin plates included) overlapping the pool's by at most 2 mm (a
    resting contact). The stance is ``stance``'s X under ``gait_reading``, on the fins' rest
    sweep ``fin_sweep_deg`` (None: the reading's balanced sweep, as ``Scenario.fin_sweep_deg``).
    """
    import numpy as np
    from pydrake.math import RollPitchYaw

    from manta_drake.control.gaits import get_gait
    from manta_drake.model.kinematics import fin_tip_pose
    from manta_drake.model.robot_params import DEFAULT_POOL, LEGS, robot_with_fin_sweep_deg

    fin_sweep_deg = resolve_fin_sweep_deg(fin_sweep_deg, gait_reading)
    pool, robot = DEFAULT_POOL, robot_with_fin_sweep_deg(fin_sweep_deg)
    p = np.asarray(xyz, dtype=float)
    R = RollPitchYaw(np.radians(rpy_deg)).ToRotationMatrix().matrix()
    floor, half_x, half_y = -pool.depth, pool.length / 2, pool.width / 2
    if not (floor < p[2] <= 0.0 and abs(p[0]) < half_x and abs(p[1]) < half_y):
        return (f"the body at {list(map(float, p))} m is not in the pool's water "
                f"(x in (-{half_x}, {half_x}), y in (-{half_y}, {half_y}), z in ({floor}, 0])")
    q = np.zeros((len(LEGS), 4)) if stance == "zero" else get_gait(stance, gait_reading).X
    # Hull: an ellipsoid's extent along world axis k is sqrt(sum_i (R[k, i] a_i)^2).
    extent = np.sqrt(((R * np.asarray(robot.body_semi_axes)) ** 2).sum(axis=1))
    points = [("hull", p - extent, p + extent)]
    for leg, q_leg in zip(LEGS, q):
        tip = p + R @ fin_tip_pose(leg, q_leg, robot)[:3, 3]
        r = robot.foot_radius
        points.append((f"{leg} fin tip", tip - r, tip + r))
    for name, low, high in points:
        if low[2] < floor - 0.002:
            return (f"the {name} reaches z = {low[2]:.3f} m, below the floor at {floor} m "
                    f"(body z = {p[2]} m with the '{stance}' stance)")
        if max(abs(low[0]), abs(high[0])) > half_x or max(abs(low[1]), abs(high[1])) > half_y:
            return (f"the {name} at x, y = {0.5 * (low[0] + high[0]):.3f}, "
                    f"{0.5 * (low[1] + high[1]):.3f} m is inside or beyond a wall (the walls "
                    f"are at x = +-{half_x}, y = +-{half_y} m)")
    # The fin plates and feet as modelled (collision geometry), at the start's stance.
    return _start_penetration(p, rpy_deg, q, fin_sweep_deg)


SCENARIOS_DIR = pathlib.Path(__file__).resolve().parent / "scenarios"
PACKAGE_URL = "package://manta_drake/"


def resolve_path(path: str) -> pathlib.Path:
    """A file named in a scenario: ``package://manta_drake/<file>`` is in the package's
    model folder; other paths are absolute or relative to the working directory."""
    from manta_drake.model import MODELS_DIR

    if path.startswith(PACKAGE_URL):
        return MODELS_DIR / path[len(PACKAGE_URL):]
    return pathlib.Path(path)


def shipped_scenarios() -> list[pathlib.Path]:
    """The scenario files shipped with the package, sorted by name."""
    return sorted(SCENARIOS_DIR.glob("*.yaml"))


def find_scenario(name_or_path) -> pathlib.Path:
    """A scenario file: an existing path, or the name of a shipped scenario (``stand``)."""
    path = pathlib.Path(name_or_path)
    if path.is_file():
        return path
    shipped = SCENARIOS_DIR / f"{path.stem}.yaml"
    if path.suffix in ("", ".yaml") and len(path.parts) == 1 and shipped.is_file():
        return shipped
    names = ", ".join(p.stem for p in shipped_scenarios())
    raise ScenarioError(f"scenario file not found: {name_or_path} (shipped scenarios: {names})")


def _number(field: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ScenarioError(f"{field}: {value!r} is not a number")
    if not math.isfinite(value):
        raise ScenarioError(f"{field}: {value!r} is not finite")


def _in_range(field, value, lo, hi, text, open_low=False, open_high=False) -> None:
    _number(field, value)
    above = value > lo if open_low else value >= lo
    below = value < hi if open_high else value <= hi
    if not (above and below):
        raise ScenarioError(f"{field}: {value!r} is outside the allowed range {text}")


def _integer(field: str, value, lo: int, hi: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ScenarioError(f"{field}: {value!r} is not an integer (allowed: {lo} to {hi})")
    if not lo <= value <= hi:
        raise ScenarioError(f"{field}: {value!r} is outside the allowed range [{lo}, {hi}]")


def _boolean(field: str, value) -> None:
    if not isinstance(value, bool):
        raise ScenarioError(f"{field}: {value!r} is not true or false")


def _text(field: str, value, allow_empty: bool = False) -> None:
    if not isinstance(value, str) or (not allow_empty and not value.strip()):
        raise ScenarioError(f"{field}: {value!r} is not a {'' if allow_empty else 'non-empty '}"
                            "string")


def _one_of(field: str, value, allowed) -> None:
    if not isinstance(value, str) or value not in allowed:
        raise ScenarioError(f"{field}: {value!r} is not one of {', '.join(map(str, allowed))}")


def _vector(field: str, value, n: int, bound: float = math.inf, unit: str = "") -> None:
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ScenarioError(f"{field}: expected {n} finite numbers, got {value!r}")
    for i, v in enumerate(value):
        _number(f"{field}[{i}]", v)
    if math.isfinite(bound) and math.sqrt(sum(v * v for v in value)) > bound:
        raise ScenarioError(f"{field}: {value!r} has magnitude above the allowed {bound}{unit}")


def _schema_fields(schema) -> dict | None:
    """Field name -> type of a dataclass or a pydrake config struct, else None."""
    if dc.is_dataclass(schema):
        hints = typing.get_type_hints(schema)
        return {f.name: hints[f.name] for f in dc.fields(schema)}
    if hasattr(schema, "__fields__"):  # pydrake-bound C++ structs (SimulatorConfig, ...)
        return {f.name: f.type for f in schema.__fields__}
    return None


def _type_name(tp) -> str:
    return getattr(tp, "__name__", str(tp))


def _check_scalar(value, tp, path: str) -> None:
    """Checks a YAML scalar against a float/int/str/bool field type."""
    ok = {
        float: lambda v: isinstance(v, (int, float)) and not isinstance(v, bool),
        int: lambda v: isinstance(v, int) and not isinstance(v, bool),
        str: lambda v: isinstance(v, str),
        bool: lambda v: isinstance(v, bool),
    }.get(tp)
    if ok is not None and not ok(value):
        raise ScenarioError(f"{path}: expected a {_type_name(tp)}, got {value!r}")


def check_keys(data, schema, path: str = "scenario") -> None:
    """Walks ``data`` against the schema; raises ScenarioError naming the first bad key.

    Unknown keys (typos) and values of the wrong type are reported with their full
    path, e.g. ``scenario.initial_pose.xyzz``.
    """
    origin = typing.get_origin(schema)
    if origin is dict:
        key_type, value_type = typing.get_args(schema)
        if not isinstance(data, dict):
            raise ScenarioError(f"{path}: expected a mapping, got {data!r}")
        for key, value in data.items():
            check_keys(key, key_type, f"{path} key")
            check_keys(value, value_type, f"{path}.{key}")
        return
    if origin is list:
        (item_type,) = typing.get_args(schema) or (None,)
        if not isinstance(data, list):
            raise ScenarioError(f"{path}: expected a list, got {data!r}")
        for i, item in enumerate(data):
            check_keys(item, item_type, f"{path}[{i}]")
        return
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(schema) if a is not type(None)]
        if data is None or len(args) != 1:
            return
        schema = args[0]
    fields = _schema_fields(schema)
    if fields is None:
        if data is not None:
            _check_scalar(data, schema, path)
        return
    if data is None:
        return
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: expected a mapping with keys {sorted(fields)}, got {data!r}")
    for key, value in data.items():
        if key not in fields:
            raise ScenarioError(
                f"{path}.{key}: unknown key (a typo?); allowed keys: {', '.join(sorted(fields))}"
            )
        check_keys(value, fields[key], f"{path}.{key}")


class UniqueKeyLoader(yaml.SafeLoader):
    """A safe YAML loader that refuses a key given twice in one mapping (plain YAML keeps
    the last silently)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep)


def read_text_file(path) -> str:
    """The text of a UTF-8 file; one-line ScenarioErrors naming the file otherwise."""
    path = pathlib.Path(path)
    if not path.is_file():
        raise ScenarioError(f"{path}: file not found")
    try:
        return path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ScenarioError(f"{path}: not a UTF-8 text (YAML) file") from None
    except OSError as e:
        raise ScenarioError(f"{path}: cannot be read: {e.strerror}") from None


def load_scenario(path, overrides: dict | None = None) -> Scenario:
    """Loads and validates a scenario YAML file.

    Args:
        path: the YAML file.
        overrides: top-level values to replace after loading (e.g. ``{"duration": 2}``).

    Raises:
        ScenarioError: the file is missing, has an unknown key, a value of the wrong
            type, or a value out of range. The message names the field.
    """
    path = find_scenario(path)
    text = read_text_file(path)
    try:
        data = yaml.load(text, Loader=UniqueKeyLoader) or {}
    except yaml.YAMLError as e:
        raise ScenarioError(f"{path}: not valid YAML: {' '.join(str(e).split())}") from None
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: the YAML root must be a mapping of scenario fields, "
                            f"got {type(data).__name__}")
    try:
        check_keys(data, Scenario)
    except ScenarioError as e:
        raise ScenarioError(f"{path}: {e}") from None
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text) if data else Scenario()
    except (RuntimeError, ValueError, TypeError) as e:
        raise ScenarioError(f"{path}: {e}") from None
    for key, value in (overrides or {}).items():
        if key not in _schema_fields(Scenario):
            raise ScenarioError(f"override {key}: unknown scenario field")
        setattr(scenario, key, value)
    if scenario.name == "unnamed":
        scenario.name = path.stem
    try:
        return scenario.validate()
    except ScenarioError as e:
        raise ScenarioError(f"{path}: {e}") from None
