"""Typed scenarios: the dataclasses a scenario YAML file is loaded into.

A scenario says everything one run needs: how long, the plant's time step, the
robot's initial pose, the random seed, the controller, and the simulator
settings. ``load_scenario(name_or_path, data=..., defaults=..., overrides=...)`` loads
it in layers with Drake's ``yaml_load_typed`` after checking every key against the
schema (a misspelt key fails at load time, naming its full path and the allowed keys),
then ``Scenario.validate()`` checks every value's range (naming the field and the
allowed range). ``--set KEY=VALUE``, sweeps and the fault campaign all go through it.

The shipped scenarios are in ``models/scenarios/`` (installed as package data of
``manta_drake.models``; ``manta-drake list``); ``find_scenario`` accepts a path or a
shipped scenario's name.

Example (``models/scenarios/stand.yaml``)::

    name: stand
    duration: 5.0
    initial_pose: {xyz: [0, 0, -0.22], rpy_deg: [0, 0, 0]}
    controller: {mode: hold, gait: trot}
"""

import copy
import dataclasses as dc
import functools
import math
import pathlib
import types
import typing

import numpy as np
import yaml
from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from pydrake.systems.analysis import SimulatorConfig

from manta_drake.config_io import (
    ScenarioError,
    check_boolean,
    check_in_range,
    check_integer,
    check_keys,
    check_number,
    check_one_of,
    check_text,
    check_vector,
    load_yaml_mapping,
    parse_yaml,
    schema_fields,
    short_repr,
)
from manta_drake.control.balloon_rule import BalloonRuleParams
from manta_drake.control.behaviour_tree import BlendNode, compile_tree, default_tree
from manta_drake.control.gait_files import gait_library
from manta_drake.control.gaits import BALANCED_FIN_SWEEP_DEG, READINGS
from manta_drake.control.heading_hold import HeadingHoldParams
from manta_drake.control.transition import check_parameters
from manta_drake.control.vision import WallDetectorParams
from manta_drake.modalities import ESTIMATES, MODALITIES, MODALITY_BY_ESTIMATE, NAMES, SECTIONS
from manta_drake.model import MODELS_DIR, PACKAGE_URL, resolve_path
from manta_drake.model.actuators import load_actuators, load_energy_model, scale_actuators
from manta_drake.model.coefficients import HydroCoefficients, load_coefficients, scale_coefficients
from manta_drake.model.robot_params import NUM_JOINTS, robot_with_fin_sweep_deg
from manta_drake.model.servo import SERVO_MODELS, back_emf_damping, servo_robot_params
from manta_drake.model.start_pose import start_pose_problem
from manta_drake.station.current import CurrentPoint, CurrentSchedule
from manta_drake.station.foil import FIN_MODELS

__all__ = [
    "Scenario",
    "ScenarioError",
    "load_scenario",
    "find_scenario",
    "shipped_scenarios",
    "resolve_path",
    "set_override",
    "check_override_key",
    "scenario_yaml",
]


def _default_simulator_config() -> SimulatorConfig:
    # The CPG's continuous state beside a 1 ms discrete plant: fixed-step RK2 at
    # the plant period costs two derivative evaluations a step; error-controlled
    # RK3 costs three and gains nothing (the plant's step bounds the accuracy).
    # publish_every_time_step is left out: False by default where it exists (Drake 1.51);
    # Drake 1.58 has no such field (a scenario setting it is refused as an unknown key).
    return SimulatorConfig(
        integration_scheme="runge_kutta2",
        max_step_size=1e-3,
        use_error_control=False,
        target_realtime_rate=0.0,
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
      ``transition``  the multifunctional controller chooses the behaviour (Eqs. 9-15).
    """

    mode: str = "hold"
    gait: str = "trot"
    # How Eqs. (6)-(8) are read (manta_drake.control.gaits.READINGS): ``paper`` (the
    # legged gaits as printed, the swim mirrored) or ``mirrored`` (one mirror rule for
    # every gait; its stance needs robot.fin_sweep_deg 30, its default then; docs/stance.md).
    gait_reading: str = "paper"
    # Gait files (manta_drake.control.gait_files) whose gaits join the shipped
    # models/gaits.yaml, in order: paths relative to the scenario file that names them (to
    # the working directory for --set and data), absolute, or package://manta_drake/...
    # Loading makes them absolute. A name defined twice is an error naming both files.
    gait_files: list[str] = dc.field(default_factory=list)


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
    if fin_sweep_deg is not None:
        return float(fin_sweep_deg)
    try:
        return BALANCED_FIN_SWEEP_DEG[gait_reading]
    except KeyError:
        raise ScenarioError(
            f"controller.gait_reading: {gait_reading!r} is not one of "
            f"{', '.join(BALANCED_FIN_SWEEP_DEG)}"
        ) from None


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
    # The behaviours as a tree (manta_drake.control.behaviour_tree): node name -> BlendNode,
    # the top node named root, each blending its children (nodes or gait names) by one
    # modality. Empty: Eq. (12)'s tree from blend and z_t (Scenario.behaviour_nodes()).
    tree: dict[str, BlendNode] = dc.field(default_factory=dict)


@dc.dataclass
class WaterConfig:
    """The pool's water. ``coefficients``: ``package://manta_drake/<file>`` (the package's
    model folder), an absolute path, or a path relative to the working directory."""

    enabled: bool = True
    coefficients: str = "package://manta_drake/hydrodynamics.yaml"
    current: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])  # m/s, world
    # Time-keyed currents, e.g. [{time: 10, velocity: [0, 0.06, 0]}, ...]: linear between
    # keys, the first key's before it and the last's after it; empty: ``current`` throughout.
    # Exclusive with a non-zero ``current`` (a schedule replaces the constant).
    current_schedule: list[CurrentPoint] = dc.field(default_factory=list)
    # 0: forces from the current state at every plant step (exact, no delay). > 0: computed
    # every update_period seconds and held (faster; one period of delay).
    update_period: float = 0.0
    # Multipliers of named coefficients of the file, e.g. {body.linear_damping: 1.3}
    # (sweeps and calibration; see manta_drake.model.coefficients.scale_coefficients).
    coefficient_scales: dict[str, float] = dc.field(default_factory=dict)
    # The fins' hydrodynamics (docs/design.md, section 4): "foil" (the default), the
    # flapping-foil strip model (circulation, suction, Wagner lag, stall) with the fins' and
    # the hull's added mass as bodies (manta_drake.station.foil); "cross_flow", the earlier
    # quasi-steady normal force with a chosen passive pitch and the hinges' zero-pose added
    # inertia, kept to compare against.
    fin_model: str = "foil"


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
    # The fill from a modality's estimate instead of the clock (``rule.modality``: posture,
    # flow or energy; empty: the schedule alone; manta_drake.control.balloon_rule).
    rule: BalloonRuleParams = dc.field(default_factory=BalloonRuleParams)


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
    # 0.027 m; tests/test_depth.py holds it). Depths are counted from it.
    surface_depth: float = 0.027


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
class ActuatorsConfig:
    """The energy model: servo power and battery (its battery's terminal voltage is the
    datasheet servos' bus; with the ideal servo it applies no force). ``file``:
    ``package://manta_drake/<file>``, an absolute path, or one relative to the working
    directory (see manta_drake.model.actuators)."""

    enabled: bool = True
    file: str = "package://manta_drake/actuators.yaml"
    # Multipliers of named numeric entries of the file, e.g. {servo.winding_resistance: 1.2},
    # each in [0, 10] (see manta_drake.model.actuators.scale_actuators and SCALE_RANGE).
    scales: dict[str, float] = dc.field(default_factory=dict)
    # The Jetson's power mode, one of the file's electronics.jetson_power modes; None: the
    # file's electronics.jetson_mode.
    electronics_mode: str | None = None
    initial_soc: float = 1.0  # state of charge at t = 0, above the file's cutoff_soc
    # Stop the run (Simulator termination) once the state of charge reaches cutoff_soc.
    stop_when_empty: bool = True
    # The joints' torque (model.servo): "datasheet", the file's servo in its firmware's
    # position mode at the bus voltage (stall torque, torque-speed line, back-EMF braking;
    # the bus is the battery's terminal voltage with the energy model on, else the file's
    # servo.supply_voltage); "ideal", the plant's PD with RobotParams' chosen gains and
    # +-6 N m clamp.
    servo_model: str = "datasheet"
    # The servo bus: the controller's commands reach the servos every bus_period s, one
    # period late (a sync write per period); 0: at every plant step, at once. 10 ms is
    # chosen (100 Hz, band 5-20 ms): the paper gives no rate; at 1 Mbps a sync write of 16
    # goals (~90 bytes) and a sync read of 16 positions and velocities (~330 bytes, the
    # servos' return delay set to 0) take ~4 ms, so 5 ms is about the fastest cycle.
    bus_period: float = 0.01


@dc.dataclass
class VisualizationConfig:
    """Meshcat recording and logging."""

    meshcat: bool = True
    # 40 fps = a 25 ms publish period, on the 1 ms step grid: recording adds no extra
    # integrator steps, so a run with Meshcat matches one without, sample for sample.
    recording_fps: float = 40.0  # frames per second kept in recording.html


def with_modality_sections(after: str):
    """A class decorator (under ``dc.dataclass``) adding a field per section of the
    modalities' sensors and estimators (``manta_drake.modalities.SECTIONS``), each
    defaulting to its dataclass's defaults, after the field ``after``."""

    def add(cls):
        fields = {}
        for name, tp in cls.__annotations__.items():
            fields[name] = tp
            if name == after:
                fields.update(SECTIONS)
        for name, params in SECTIONS:
            setattr(cls, name, dc.field(default_factory=params))
        cls.__annotations__ = fields
        return cls

    return add


@dc.dataclass
@with_modality_sections(after="wall_detector")
class Scenario:
    """One run of the simulator. Besides the fields below, one per section of the
    modalities' sensors and estimators (``manta_drake.modalities.SECTIONS``: ``imu``,
    ``posture_estimator``, ``flow_sensor``, ``flow_estimator`` and the rest)."""

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
    # Here ``with_modality_sections`` adds a field per section of the modalities' sensors
    # and estimators (manta_drake.modalities.SECTIONS: imu, posture_estimator, ...).
    # Feedback from posture: the swim's heading held from the IMU (control.heading_hold).
    heading_hold: HeadingHoldParams = dc.field(default_factory=HeadingHoldParams)
    simulator: SimulatorConfig = dc.field(default_factory=_default_simulator_config)
    visualization: VisualizationConfig = dc.field(default_factory=VisualizationConfig)
    actuators: ActuatorsConfig = dc.field(default_factory=ActuatorsConfig)
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
        """The RobotParams of this scenario's geometry (model.robot_params), with the joint
        gains, effort limit and damping of ``actuators.servo_model`` (model.servo)."""
        params = robot_with_fin_sweep_deg(self.fin_sweep_deg())
        if self.actuators.servo_model == "datasheet":
            params = servo_robot_params(
                params, self.energy_model().servo, self.bus_reference_voltage()
            )
        return params

    def bus_reference_voltage(self) -> float:
        """The bus voltage the plant's datasheet-servo gains are set at [V]: with the energy
        model on, the pack's full-charge open-circuit voltage (the station scales the
        servos' torque down to the battery's terminal voltage, ``station.servo_supply``);
        without it, the servo file's ``supply_voltage`` (a constant bus)."""
        model = self.energy_model()
        if self.actuators.enabled:
            return float(model.pack.open_circuit_voltage(1.0))
        return model.servo.supply_voltage

    def energy_model(self):
        """The resolved servos, electronics and battery (model.actuators.EnergyModel) of the
        ``actuators`` section: its file with its scales, the Jetson in its mode."""
        a = self.actuators
        return load_energy_model(a.file, a.scales, a.electronics_mode)

    def servo_braking(self) -> float:
        """The back-EMF braking b [N m s/rad] (model.servo) that the plant applies as joint
        damping and the station's ``joint_torque`` includes; 0 with the ideal PD."""
        if self.actuators.servo_model != "datasheet":
            return 0.0
        return back_emf_damping(self.energy_model().servo)

    def hydro_coefficients(self) -> HydroCoefficients | None:
        """The water model's coefficients: ``water.coefficients`` with
        ``water.coefficient_scales`` applied; None when ``water.enabled`` is false."""
        w = self.water
        if not w.enabled:
            return None
        return scale_coefficients(
            load_coefficients(resolve_path(w.coefficients)), w.coefficient_scales
        )

    def gaits(self):
        """The gait library of this scenario (name -> GaitParams, read-only): the shipped
        ``models/gaits.yaml`` and ``controller.gait_files`` under ``controller.gait_reading``."""
        return gait_library(tuple(self.controller.gait_files), self.controller.gait_reading)

    def gait(self, name: str):
        """The gait ``name`` of this scenario's library; ScenarioError lists the known ones."""
        library = self.gaits()
        try:
            return library[name]
        except KeyError:
            raise ScenarioError(
                f"unknown gait {name!r}; known gaits: {', '.join(library)}"
            ) from None

    def behaviour_nodes(self) -> dict:
        """The behaviour tree's nodes: ``transition.tree``, or if empty Eq. (12)'s tree
        for ``transition.blend`` and ``transition.z_t`` (swim, trot, turning)."""
        tr = self.transition
        return dict(tr.tree) if tr.tree else default_tree(tr.blend, tr.z_t)

    def behaviour_tree(self):
        """The compiled behaviour tree (``control.behaviour_tree.BehaviourTree``) over this
        scenario's gait library."""
        library = self.gaits()
        try:
            return compile_tree(
                self.behaviour_nodes(),
                {name: gait.to_vector() for name, gait in library.items()},
                ESTIMATES,
            )
        except ValueError as e:
            raise ScenarioError(f"transition.{e}") from None

    def current_schedule(self) -> CurrentSchedule:
        """The water's current over time (``water.current``, ``water.current_schedule``)."""
        return CurrentSchedule(self.water.current, self.water.current_schedule)

    def reads_charge_estimate(self) -> bool:
        """Whether the controller estimates the battery's charge (``EnergyEstimator``, a
        ``battery`` input): the energy model is on and the behaviour tree (transition mode),
        the balloon rule or the heading hold's changes read ``energy_hat``."""
        return self.has_estimator("energy_hat")

    def has_estimator(self, estimate: str) -> bool:
        """Whether the controller of this scenario builds the estimator of ``estimate`` (a
        modality with an estimator, ``manta_drake.modalities``): its sensor is on and,
        for one built only when read, something reads it."""
        return MODALITY_BY_ESTIMATE[estimate].built(self, estimate in self.estimates_read())

    def heading_changes_read(self) -> tuple[str, ...]:
        """The estimates ``heading_hold.changes`` read (when the hold is on)."""
        if not self.heading_hold.enabled:
            return ()
        return self.heading_hold.read()

    def estimates_read(self) -> dict[str, str]:
        """Every estimate the controller reads -> the field that reads it (the last of
        several): the behaviour tree (transition mode; the default tree's s_hat only with
        the camera, which it reads as 0 without), the balloon rule, the heading hold
        (``posture_hat``) and its changes."""
        used = {}
        if self.controller.mode == "transition":
            used.update(
                {
                    m: "transition.tree"
                    for m in self.behaviour_tree().modalities
                    if self.transition.tree or m != "s_hat" or self.camera.enabled
                }
            )
        rule = self.balloon.rule.estimate(NAMES)
        if rule:
            used[rule] = "balloon.rule.modality"
        if self.heading_hold.enabled:
            used["posture_hat"] = "heading_hold.enabled"
            used.update({m: "heading_hold.changes" for m in self.heading_changes_read()})
        return used

    def _validate_modality_sections(self) -> None:
        """Each modality's sensor and estimator section (``manta_drake.modalities``)."""
        for m in MODALITIES:
            if m.reading is not None:
                try:
                    getattr(self, m.reading.section).validate(m.reading.section)
                except ValueError as e:
                    raise ScenarioError(str(e)) from None
            if m.estimation is not None:
                try:
                    getattr(self, m.estimation.section).validate()
                except ValueError as e:
                    raise ScenarioError(f"{m.estimation.section}.{e}") from None

    def _validate_modalities(self) -> None:
        """The sensors, estimators, heading hold and balloon rule; and that every estimate
        the behaviour tree, the balloon rule or the heading hold reads has its sensor."""
        self._validate_modality_sections()
        for section, call in (
            ("heading_hold", lambda: self.heading_hold.validate(ESTIMATES)),
            ("balloon.rule", lambda: self.balloon.rule.validate(NAMES)),
        ):
            try:
                call()
            except ValueError as e:
                raise ScenarioError(f"{section}.{e}") from None
        self._validate_water_users()
        for estimate, where in self.estimates_read().items():
            m = MODALITY_BY_ESTIMATE[estimate]
            if not m.available(self):
                raise ScenarioError(f"{where}: reads {estimate}, which needs {m.needs}: true")
        if self.heading_hold.enabled and self.controller.mode == "hold":
            raise ScenarioError(
                "heading_hold.enabled: true trims a CPG gait; controller.mode "
                "hold runs none (use gait or transition)"
            )
        self._validate_heading_hold_behaviours()

    def _validate_water_users(self) -> None:
        """The balloon rule acts and some sensors (the modalities' that need water) read
        through the water: refused with the water off (the rule would command a balloon that lifts
        nothing, the sensor read water that is not there)."""
        if self.water.enabled:
            return
        if self.balloon.rule.modality:
            raise ScenarioError(
                f"balloon.rule.modality: {short_repr(self.balloon.rule.modality)}"
                " needs water.enabled: true (the balloon acts through the "
                "water's buoyancy)"
            )
        for m in MODALITIES:
            r = m.reading
            if r is not None and r.needs_water and getattr(self, r.section).enabled:
                raise ScenarioError(
                    f"{r.section}.enabled: true needs water.enabled: true (the "
                    "sensor reads through the water)"
                )

    def _validate_heading_hold_behaviours(self) -> None:
        """``heading_hold.behaviours`` are gaits of the library, and in transition mode with
        the hold on at least one is a gait of the behaviour tree (else it never engages)."""
        hold = self.heading_hold
        gaits = self.gaits()
        for i, name in enumerate(hold.behaviours):
            if name not in gaits:
                raise ScenarioError(
                    f"heading_hold.behaviours[{i}]: {short_repr(name)} is not a "
                    f"gait; allowed: {', '.join(gaits)}"
                )
        if hold.enabled and self.controller.mode == "transition":
            leaves = self.behaviour_tree().leaves
            if not any(name in leaves for name in hold.behaviours):
                raise ScenarioError(
                    f"heading_hold.behaviours: {short_repr(hold.behaviours)} "
                    "names none of the behaviour tree's gaits, so the hold "
                    f"would never engage; allowed: {', '.join(leaves)}"
                )

    def initial_joint_angles(self) -> np.ndarray:
        """The initial joint angles (16, the plant's order): the stance X of
        ``initial_stance`` under ``controller.gait_reading``, or zeros."""
        if self.initial_stance == "zero":
            return np.zeros(NUM_JOINTS)
        return self.gait(self.initial_stance).X.ravel().copy()

    def _validate_actuators(self) -> None:
        """The ``actuators`` section: its file loads, its scales apply, its mode exists and
        the initial charge lies above the file's cut-off."""
        a = self.actuators
        check_boolean("actuators.enabled", a.enabled)
        check_boolean("actuators.stop_when_empty", a.stop_when_empty)
        check_text("actuators.file", a.file)
        if not isinstance(a.scales, dict):
            raise ScenarioError(f"actuators.scales: expected a mapping, got {a.scales!r}")
        params = load_actuators(resolve_path(a.file, "actuators.file"), "actuators.file")
        try:
            params = scale_actuators(params, a.scales)
        except ValueError as e:
            message = str(e)
            if message.startswith("scales: "):  # a scaled value refused
                message = "scales." + message[len("scales: ") :]
            raise ScenarioError(f"actuators.{message}") from None
        modes = tuple(params.electronics.jetson_power.value)
        if a.electronics_mode is not None:
            check_one_of("actuators.electronics_mode", a.electronics_mode, modes)
        cutoff = params.battery.cutoff_soc.value
        check_in_range(
            "actuators.initial_soc",
            a.initial_soc,
            cutoff,
            1.0,
            f"(cutoff_soc = {cutoff:g}, 1]",
            open_low=True,
        )
        check_one_of("actuators.servo_model", a.servo_model, SERVO_MODELS)
        if a.bus_period != 0.0:
            check_in_range(
                "actuators.bus_period",
                a.bus_period,
                self.time_step,
                0.1,
                f"0 or [time_step = {self.time_step:g}, 0.1] s",
            )

    def validate(self) -> "Scenario":
        """Checks every value (type, finite, range, integer where it must be); raises
        ScenarioError naming the field, the value and the allowed range."""
        check_text("name", self.name)
        check_text("description", self.description, allow_empty=True)
        check_in_range(
            "duration",
            self.duration,
            0.0,
            MAX_DURATION_S,
            f"(0, {MAX_DURATION_S:g}] s",
            open_low=True,
        )
        # Below 0.1 ms a run takes hours (1e-7 s is an effective hang); above 10 ms the
        # contact and the CPG's RK2 lose accuracy.
        check_in_range("time_step", self.time_step, 1e-4, 0.01, "[0.0001, 0.01] s")
        check_one_of(
            "discrete_contact_approximation",
            self.discrete_contact_approximation,
            ("sap", "lagged", "similar", "tamsi"),
        )
        check_in_range("contact.friction", self.contact.friction, 0.0, 2.0, "(0, 2]", open_low=True)
        check_integer("random_seed", self.random_seed, 0, MAX_RANDOM_SEED)
        check_vector("initial_pose.xyz", self.initial_pose.xyz, 3)
        check_vector("initial_pose.rpy_deg", self.initial_pose.rpy_deg, 3, bound=360.0)
        check_one_of("controller.gait_reading", self.controller.gait_reading, tuple(READINGS))
        if self.robot.fin_sweep_deg is not None:
            # Beyond +-60 deg the yaw joint's +-60 deg range cannot bring a fin to the side.
            check_in_range(
                "robot.fin_sweep_deg",
                self.robot.fin_sweep_deg,
                -60.0,
                60.0,
                "[-60, 60] deg (or null: the gait reading's balanced sweep)",
            )
        files = self.controller.gait_files
        if not isinstance(files, list):
            raise ScenarioError(f"controller.gait_files: expected a list of paths, got {files!r}")
        for i, f in enumerate(files):
            check_text(f"controller.gait_files[{i}]", f)
            if not resolve_path(f, f"controller.gait_files[{i}]").is_file():
                raise ScenarioError(f"controller.gait_files[{i}]: gait file not found: {f}")
        gaits = self.gaits()
        check_one_of("initial_stance", self.initial_stance, ("zero",) + tuple(gaits))
        problem = start_pose_problem(
            self.initial_pose.xyz,
            self.initial_pose.rpy_deg,
            self.initial_joint_angles(),
            self.fin_sweep_deg(),
            self.initial_stance,
        )
        if problem:
            raise ScenarioError(f"initial_pose: {problem}")
        check_one_of("controller.mode", self.controller.mode, ("hold", "gait", "transition"))
        check_one_of("controller.gait", self.controller.gait, tuple(gaits))
        check_in_range(
            "cpg.frequency_hz", self.cpg.frequency_hz, 0.0, 5.0, "(0, 5] Hz", open_low=True
        )
        for name in ("chain_weight", "fcs_weight"):
            check_in_range(f"cpg.{name}", getattr(self.cpg, name), 0.0, 100.0, "[0, 100] rad/s")
        for name in ("a", "b"):
            check_in_range(
                f"cpg.{name}", getattr(self.cpg, name), 0.0, 200.0, "(0, 200] 1/s", open_low=True
            )
        tr = self.transition
        for name in ("period", "g", "T", "alpha", "z_t", "s_hat_time_constant"):
            check_number(f"transition.{name}", getattr(tr, name))
        check_text("transition.blend", tr.blend)
        check_text("transition.follow", tr.follow)
        try:
            check_parameters(
                tr.period, tr.g, tr.T, tr.alpha, tr.z_t, tr.blend, tr.s_hat_time_constant, tr.follow
            )
        except ValueError as e:
            raise ScenarioError(f"transition.{e}") from None
        check_in_range(
            "transition.period",
            tr.period,
            self.time_step,
            1.0,
            f"[time_step = {self.time_step}, 1] s",
        )
        check_in_range(
            "transition.arrival_tolerance",
            tr.arrival_tolerance,
            0.0,
            math.pi,
            "(0, pi] rad",
            open_low=True,
        )
        if not isinstance(tr.tree, dict):
            raise ScenarioError(
                f"transition.tree: expected a mapping of node names to nodes, got {tr.tree!r}"
            )
        if tr.tree and (tr.blend != "potential" or tr.z_t != 1.0):
            field = "blend" if tr.blend != "potential" else "z_t"
            raise ScenarioError(
                f"transition.{field}: {getattr(tr, field)!r} is set beside "
                "transition.tree; a tree gives each node's weight and full_at "
                "itself (blend and z_t shape the default tree only)"
            )
        self.behaviour_tree()  # every node's fields, children and gaits
        w = self.water
        check_boolean("water.enabled", w.enabled)
        if self.controller.mode == "transition" and not w.enabled:
            raise ScenarioError(
                "controller.mode: 'transition' needs water.enabled: true "
                "(z_hat comes from the pressure sensor)"
            )
        # A pool's current; beyond ~1 m/s the robot's 0.1 m/s swim means nothing and the
        # quadratic damping's stiffness needs a smaller step.
        check_vector("water.current", w.current, 3, bound=1.0, unit=" m/s")
        try:
            self.current_schedule()
        except ValueError as e:
            raise ScenarioError(str(e)) from None
        if w.current_schedule and any(v != 0.0 for v in w.current):
            raise ScenarioError(
                f"water.current: {short_repr(w.current)} is set beside "
                "water.current_schedule; they are exclusive (the schedule "
                "replaces the constant: make it a key of the schedule, or clear "
                "the schedule with water.current_schedule: [])"
            )
        check_in_range("water.update_period", w.update_period, 0.0, 0.02, "[0, 0.02] s")
        check_one_of("water.fin_model", w.fin_model, FIN_MODELS)
        check_text("water.coefficients", w.coefficients)
        # The URL is checked with the water off too (the file is read only with it on).
        coefficients = resolve_path(w.coefficients, "water.coefficients")
        if not isinstance(w.coefficient_scales, dict):
            raise ScenarioError(
                f"water.coefficient_scales: expected a mapping, got {w.coefficient_scales!r}"
            )
        if w.enabled or w.coefficient_scales:  # scales are checked even with water off
            coeffs = load_coefficients(coefficients, "water.coefficients")
            try:
                scale_coefficients(coeffs, w.coefficient_scales)
            except ValueError as e:
                message = str(e)
                if message.startswith("coefficient_scales: "):  # a scaled value refused
                    message = "coefficient_scales." + message[len("coefficient_scales: ") :]
                raise ScenarioError(f"water.{message}") from None
        self._validate_actuators()
        self._validate_modalities()
        check_in_range("balloon.initial_fill", self.balloon.initial_fill, 0.0, 1.0, "[0, 1]")
        last = -math.inf
        for i, cmd in enumerate(self.balloon.schedule):
            check_in_range(f"balloon.schedule[{i}].fill", cmd.fill, 0.0, 1.0, "[0, 1]")
            check_in_range(f"balloon.schedule[{i}].time", cmd.time, 0.0, 3600.0, "[0, 3600] s")
            if cmd.time < last:
                raise ScenarioError(
                    f"balloon.schedule[{i}].time: {cmd.time} is before the "
                    f"previous command's time {last}; times must not decrease"
                )
            last = cmd.time
        ps = self.pressure_sensor
        check_in_range(
            "pressure_sensor.rate_hz",
            ps.rate_hz,
            0.0,
            1.0 / self.time_step,
            f"(0, 1/time_step = {1.0 / self.time_step:g}] Hz",
            open_low=True,
        )
        check_in_range("pressure_sensor.noise_std", ps.noise_std, 0.0, 0.1, "[0, 0.1] m")
        check_in_range("pressure_sensor.dropout_rate", ps.dropout_rate, 0.0, 1.0, "[0, 1]")
        check_vector("pressure_sensor.position", ps.position, 3, bound=0.5, unit=" m")
        check_in_range(
            "depth_estimator.floor_distance",
            self.depth_estimator.floor_distance,
            0.0,
            10.0,
            "(0, 10] m",
            open_low=True,
        )
        check_in_range(
            "depth_estimator.surface_depth",
            self.depth_estimator.surface_depth,
            0.0,
            self.depth_estimator.floor_distance,
            f"[0, floor_distance = {self.depth_estimator.floor_distance}) m",
            open_high=True,
        )
        cam = self.camera
        check_boolean("camera.enabled", cam.enabled)
        for name in ("width", "height"):
            check_integer(f"camera.{name}", getattr(cam, name), 8, 1024)
        check_in_range("camera.fov_y_deg", cam.fov_y_deg, 0.0, 170.0, "(0, 170] deg", open_low=True)
        check_in_range("camera.max_range", cam.max_range, 0.0, 10.0, "(0, 10] m", open_low=True)
        check_in_range(
            "camera.min_range",
            cam.min_range,
            0.0,
            cam.max_range,
            f"(0, max_range = {cam.max_range}) m",
            open_low=True,
            open_high=True,
        )
        check_in_range("camera.rate_hz", cam.rate_hz, 0.0, 60.0, "(0, 60] Hz", open_low=True)
        check_in_range(
            "camera.depth_noise_std",
            cam.depth_noise_std,
            0.0,
            MAX_DEPTH_NOISE,
            f"[0, {MAX_DEPTH_NOISE}] m (the depth-camera model: a RealSense-class "
            "sensor's range noise within its 0.8 m underwater range)",
        )
        check_in_range("camera.pixel_dropout", cam.pixel_dropout, 0.0, 0.5, "[0, 0.5]")
        try:
            self.wall_detector.validate()
        except ValueError as e:
            raise ScenarioError(f"wall_detector.{e}") from None
        sim = self.simulator
        check_one_of(
            "simulator.integration_scheme",
            sim.integration_scheme,
            ("explicit_euler", "runge_kutta2", "runge_kutta3", "semi_explicit_euler"),
        )
        check_in_range("simulator.max_step_size", sim.max_step_size, 1e-5, 0.01, "[1e-05, 0.01] s")
        check_in_range("simulator.accuracy", sim.accuracy, 0.0, 1.0, "(0, 1]", open_low=True)
        check_boolean("simulator.use_error_control", sim.use_error_control)
        check_in_range(
            "simulator.start_time",
            sim.start_time,
            0.0,
            0.0,
            "[0, 0] s (schedules and metrics count from t = 0)",
        )
        check_in_range(
            "simulator.target_realtime_rate",
            sim.target_realtime_rate,
            0.0,
            100.0,
            "[0, 100] (0: as fast as possible)",
        )
        if hasattr(sim, "publish_every_time_step"):  # in Drake 1.51, gone in 1.58
            check_boolean("simulator.publish_every_time_step", sim.publish_every_time_step)
        vis = self.visualization
        check_boolean("visualization.meshcat", vis.meshcat)
        check_in_range(
            "visualization.recording_fps",
            vis.recording_fps,
            0.0,
            120.0,
            "(0, 120] fps",
            open_low=True,
        )
        steps = 1.0 / vis.recording_fps / self.time_step
        if vis.meshcat and abs(steps - round(steps)) > 1e-6:
            raise ScenarioError(
                f"visualization.recording_fps: {vis.recording_fps!r} gives a publish period "
                f"of {1e3 / vis.recording_fps:.4g} ms, not a multiple of time_step = "
                f"{self.time_step} s; recording would add integrator steps and change the run "
                "(40 fps = 25 ms is on a 1 ms grid)"
            )
        check_in_range(
            "log_period",
            self.log_period,
            self.time_step,
            1.0,
            f"[time_step = {self.time_step}, 1] s",
        )
        check_in_range("steady_after", self.steady_after, 0.0, 3600.0, "[0, 3600] s")
        check_in_range("free_water_margin", self.free_water_margin, 0.0, 1.0, "[0, 1] m")
        return self


# Largest depth-image range noise the sensor model supports [m]: beyond ~30 mm at the 0.8 m
# underwater range the point cloud no longer resolves the 4 cm voxels the detector works on.
MAX_DEPTH_NOISE = 0.03
# The longest run [s] and the largest random seed a scenario takes (the studies' options
# that set them are checked against the same bounds).
MAX_DURATION_S = 3600.0
MAX_RANDOM_SEED = 2**32 - 1

SCENARIOS_DIR = MODELS_DIR / "scenarios"


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


# --- dotted keys and layered loading -----------------------------------------------------------

_COEFFICIENT_SCALES = "water.coefficient_scales"


@functools.lru_cache(maxsize=1)
def coefficient_names() -> tuple[str, ...]:
    """Dotted names of every hydrodynamic coefficient (keys of ``water.coefficient_scales``)."""
    return tuple(name for name, _ in HydroCoefficients().entries())


def _walk_key(dotted: str):
    """Resolves a dotted scenario key against the schema.

    Returns:
        (attribute path, field type, dict key or None): e.g. ``contact.friction`` ->
        (["contact", "friction"], float, None) and
        ``water.coefficient_scales.body.linear_damping`` ->
        (["water", "coefficient_scales"], dict[str, float], "body.linear_damping").

    Raises:
        ScenarioError: the key names no scenario field (the message names the first bad part).
    """
    if not dotted or not isinstance(dotted, str):
        raise ScenarioError(f"{dotted!r}: not a dotted scenario key")
    parts = dotted.split(".")
    schema: type[typing.Any] = Scenario
    path: list[str] = []
    i = 0
    while i < len(parts):
        part = parts[i]
        fields = schema_fields(schema)
        if fields is None or part not in fields:
            where = ".".join(["scenario", *path])
            allowed = f"; allowed: {', '.join(sorted(fields))}" if fields else ""
            raise ScenarioError(f"{dotted}: {where} has no field {part!r}{allowed}")
        path.append(part)
        tp = fields[part]
        if typing.get_origin(tp) is dict and i + 1 < len(parts):
            value_type = typing.get_args(tp)[1]
            if isinstance(value_type, type) and dc.is_dataclass(value_type):
                # A mapping of named sections (transition.tree.NODE.FIELD): the next part
                # is the name, the rest a field of that section.
                path.append(parts[i + 1])
                if i + 2 == len(parts):
                    return path, value_type, None
                schema, i = value_type, i + 2
                continue
            key = ".".join(parts[i + 1 :])
            if ".".join(path) == _COEFFICIENT_SCALES and key not in coefficient_names():
                raise ScenarioError(
                    f"{dotted}: unknown coefficient {key!r}; allowed: "
                    f"{', '.join(coefficient_names())}"
                )
            return path, tp, key
        if typing.get_origin(tp) in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            tp = args[0] if len(args) == 1 else tp
        schema = tp
        i += 1
    return path, schema, None


def check_override_key(dotted: str) -> None:
    """Raises ScenarioError if ``dotted`` is not a settable scenario key (no value needed)."""
    _walk_key(dotted)


def overrides_data(overrides: dict) -> dict:
    """Dotted keys and values (``{"contact.friction": 0.6}``) as the nested mapping a
    scenario file would hold (``{"contact": {"friction": 0.6}}``); a dict-valued field's
    key may itself hold dots (``water.coefficient_scales.body.linear_damping``).

    Raises:
        ScenarioError: a key names no field, or two keys set the same field.
    """
    data: dict = {}
    for dotted, value in overrides.items():
        path, _, dict_key = _walk_key(dotted)
        parts = path + ([dict_key] if dict_key is not None else [])
        node = data
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ScenarioError(
                    f"{dotted}: sets a field inside one that another override sets whole"
                )
        if parts[-1] in node:
            raise ScenarioError(f"{dotted}: set twice (or with a field inside it)")
        node[parts[-1]] = value
    return data


def parse_set(items, option: str = "--set") -> dict:
    """``--set KEY=VALUE`` items as ``{dotted key: value}`` (each value parsed as YAML:
    numbers, lists, null, ...); one-line errors naming the option and the key. A key given
    twice is refused (no value is silently dropped unchecked)."""
    from manta_drake.config_io import short_text

    out = {}
    for item in items or []:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key:
            raise ScenarioError(
                f"{option} {short_text(str(item), 60)}: expected KEY=VALUE, e.g. duration=2"
            )
        if key in out:
            raise ScenarioError(f"{option} {short_text(key, 60)}: given twice; give each key once")
        out[key] = parse_yaml(value, f"{option} {short_text(key, 60)}")
    return out


# SimulatorConfig fields a newer Drake removed, with the value that means what the newer
# Drake does anyway: a scenario.yaml written under Drake 1.51 (every field dumped) loads
# under 1.58, and a file that asks for the removed behaviour is told so.
_REMOVED_SIMULATOR_FIELDS = {
    "publish_every_time_step": (
        False,
        "removed from Drake's "
        "SimulatorConfig in Drake 1.58, which this run uses: a run "
        "publishes at its publish periods only",
    )
}


def _without_removed_simulator_fields(data: dict) -> dict:
    simulator = data.get("simulator")
    if not isinstance(simulator, dict):
        return data
    fields = schema_fields(SimulatorConfig) or {}
    kept = dict(simulator)
    for name, (harmless, why) in _REMOVED_SIMULATOR_FIELDS.items():
        if name in kept and name not in fields:
            if kept[name] is not harmless:
                raise ScenarioError(f"simulator.{name}: {kept[name]!r}: {why}")
            del kept[name]
    return {**data, "simulator": kept}


def _layer(base: Scenario, data, where: str) -> Scenario:
    """``data`` (a mapping) layered onto ``base`` with ``yaml_load_typed`` (fields it names
    replace the base's, maps merge, lists are replaced); the keys and types are checked
    first so that an error names the full dotted field."""
    if not data:
        return copy.deepcopy(base)
    data = _without_removed_simulator_fields(data)
    check_keys(data, Scenario)
    try:
        text = yaml.safe_dump(data, sort_keys=False)
    except yaml.YAMLError as e:
        raise ScenarioError(f"{where}: a value cannot be written as YAML ({e})") from None
    try:
        return yaml_load_typed(schema=Scenario, data=text, defaults=base)
    except (RuntimeError, ValueError, TypeError) as e:
        raise ScenarioError(" ".join(str(e).split())) from None


def _anchor_gait_files(scenario: Scenario, data: dict, base_dir: pathlib.Path) -> None:
    """Makes the gait files a layer named absolute: relative to ``base_dir`` (the scenario
    file's folder, or the working directory), so the scenario means the same files wherever
    it is run or written (scenario.yaml)."""
    controller = data.get("controller") if isinstance(data, dict) else None
    if not isinstance(controller, dict) or "gait_files" not in controller:
        return
    files = scenario.controller.gait_files
    if isinstance(files, list):
        scenario.controller.gait_files = [
            f
            if not isinstance(f, str)
            or not f
            or f.startswith(PACKAGE_URL)
            or pathlib.Path(f).is_absolute()
            else str((base_dir / f).resolve())
            for f in files
        ]


def load_scenario(
    name_or_path=None,
    data=None,
    defaults: Scenario | None = None,
    overrides: dict | None = None,
    validate: bool = True,
) -> Scenario:
    """Loads a scenario in layers, as the manipulation course's ``LoadScenario``, and
    validates it.

    Layers, each on the one before with Drake's ``yaml_load_typed``: ``defaults`` (a
    Scenario; the dataclasses' defaults if None), the file ``name_or_path`` (a path or a
    shipped scenario's name), ``data`` (a mapping or YAML text: a scenario fragment) and
    ``overrides`` (dotted keys, ``{"contact.friction": 0.6}``, as ``--set`` and sweeps give
    them). Every key is checked against the schema before it is applied.

    Raises:
        ScenarioError: the file is missing, has an unknown or duplicate key, a value of the
            wrong type, or a value out of range: one line naming the file and the field.
    """
    scenario = copy.deepcopy(defaults) if defaults is not None else Scenario()
    path = None
    prefix = ""
    if name_or_path is not None:
        path = find_scenario(name_or_path)
        prefix = f"{path}: "
        file_data, _ = load_yaml_mapping(path, "scenario")
        try:
            scenario = _layer(scenario, file_data, str(path))
        except ScenarioError as e:
            raise ScenarioError(f"{prefix}{e}") from None
        _anchor_gait_files(scenario, file_data, path.parent)
        if scenario.name == "unnamed":
            scenario.name = path.stem
    if data is not None:
        if isinstance(data, str):
            data = parse_yaml(data, "scenario data")
        if not isinstance(data, dict):
            raise ScenarioError(
                f"scenario data: expected a mapping of scenario fields, got {type(data).__name__}"
            )
        scenario = _layer(scenario, data, "scenario data")
        _anchor_gait_files(scenario, data, pathlib.Path.cwd())
    if overrides:
        nested = overrides_data(overrides)
        scenario = _layer(scenario, nested, "overrides")
        _anchor_gait_files(scenario, nested, pathlib.Path.cwd())
    if not validate:
        return scenario
    try:
        return scenario.validate()
    except ScenarioError as e:
        raise ScenarioError(f"{prefix}{e}") from None


def with_overrides(scenario: Scenario, overrides: dict) -> Scenario:
    """A validated copy of ``scenario`` with dotted ``overrides`` layered on it."""
    return load_scenario(defaults=scenario, overrides=overrides)


def set_override(scenario: Scenario, dotted: str, value) -> None:
    """Sets one dotted key on ``scenario`` in place (through the same layering as
    ``load_scenario``; the value's range is checked by ``validate``)."""
    layered = load_scenario(defaults=scenario, overrides={dotted: value}, validate=False)
    for f in dc.fields(Scenario):
        setattr(scenario, f.name, getattr(layered, f.name))


def scenario_yaml(scenario: Scenario) -> str:
    """The scenario as YAML text (every field): ``load_scenario(data=...)`` reads it back."""
    return yaml_dump_typed(scenario)
