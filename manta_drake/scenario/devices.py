"""The scenario's sections for the robot's devices and the run: the balloon, the pressure
sensor and the depth estimator, the camera, the servos and battery (``actuators``), the
recording and Drake's simulator. Each has ``validate(self, where)`` as the sections of
``manta_drake.scenario.schema`` have, with the same one-line messages.
"""

import dataclasses as dc
import math

from pydrake.systems.analysis import SimulatorConfig

from manta_drake.config_io import (
    ScenarioError,
    check_boolean,
    check_in_range,
    check_integer,
    check_number,
    check_one_of,
    check_text,
    check_vector,
)
from manta_drake.control.balloon_rule import BalloonRuleParams
from manta_drake.control.depth import FLOOR_DISTANCE, check_surface_depth
from manta_drake.modalities import NAMES
from manta_drake.model import resolve_path
from manta_drake.model.actuators import load_actuators, scale_actuators
from manta_drake.model.servo import SERVO_MODELS
from manta_drake.station.pressure import DROPOUT_RATE

# Largest depth-image range noise the sensor model supports [m]: beyond ~30 mm at the 0.8 m
# underwater range the point cloud no longer resolves the 4 cm voxels the detector works on.
MAX_DEPTH_NOISE = 0.03


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

    def validate(self, where: str = "balloon") -> None:
        """The initial fill, the schedule (fills in [0, 1], times not decreasing) and the
        rule (``BalloonRuleParams.validate``, the ``BalloonRule``'s check)."""
        self.rule.validate(NAMES, where=f"{where}.rule")
        check_in_range(f"{where}.initial_fill", self.initial_fill, 0.0, 1.0, "[0, 1]")
        last = -math.inf
        for i, cmd in enumerate(self.schedule):
            at = f"{where}.schedule[{i}]"
            check_in_range(f"{at}.fill", cmd.fill, 0.0, 1.0, "[0, 1]")
            check_in_range(f"{at}.time", cmd.time, 0.0, 3600.0, "[0, 3600] s")
            if cmd.time < last:
                raise ScenarioError(
                    f"{at}.time: {cmd.time} is before the previous command's time "
                    f"{last}; times must not decrease"
                )
            last = cmd.time


@dc.dataclass
class PressureSensorConfig:
    """Depth sensor on the head: sample rate, noise, dropout (NaN readings), position."""

    rate_hz: float = 50.0
    noise_std: float = 0.002  # m
    dropout_rate: float = 0.0  # probability that a reading is NaN
    position: list[float] = dc.field(default_factory=lambda: [0.19, 0.0, 0.03])  # body frame

    def validate(self, where: str = "pressure_sensor") -> None:
        """The noise, the dropout (``station.pressure.DROPOUT_RATE``, the sensor's check
        too) and the position; ``rate_hz`` against ``time_step`` is the Scenario's check."""
        check_number(f"{where}.rate_hz", self.rate_hz)
        check_in_range(f"{where}.noise_std", self.noise_std, 0.0, 0.1, "[0, 0.1] m")
        DROPOUT_RATE.check(f"{where}.dropout_rate", self.dropout_rate)
        check_vector(f"{where}.position", self.position, 3, bound=0.5, unit=" m")


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

    def validate(self, where: str = "depth_estimator") -> None:
        """The ranges ``FuzzyDepthEstimator`` checks too (declared in ``control.depth``)."""
        FLOOR_DISTANCE.check(f"{where}.floor_distance", self.floor_distance)
        check_surface_depth(f"{where}.surface_depth", self.surface_depth, self.floor_distance)


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

    def validate(self, where: str = "camera") -> None:
        check_boolean(f"{where}.enabled", self.enabled)
        for name in ("width", "height"):
            check_integer(f"{where}.{name}", getattr(self, name), 8, 1024)
        check_in_range(
            f"{where}.fov_y_deg", self.fov_y_deg, 0.0, 170.0, "(0, 170] deg", open_low=True
        )
        check_in_range(f"{where}.max_range", self.max_range, 0.0, 10.0, "(0, 10] m", open_low=True)
        check_in_range(
            f"{where}.min_range",
            self.min_range,
            0.0,
            self.max_range,
            f"(0, max_range = {self.max_range}) m",
            open_low=True,
            open_high=True,
        )
        check_in_range(f"{where}.rate_hz", self.rate_hz, 0.0, 60.0, "(0, 60] Hz", open_low=True)
        check_in_range(
            f"{where}.depth_noise_std",
            self.depth_noise_std,
            0.0,
            MAX_DEPTH_NOISE,
            f"[0, {MAX_DEPTH_NOISE}] m (the depth-camera model: a RealSense-class "
            "sensor's range noise within its 0.8 m underwater range)",
        )
        check_in_range(f"{where}.pixel_dropout", self.pixel_dropout, 0.0, 0.5, "[0, 0.5]")


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

    def validate(self, where: str = "actuators") -> None:
        """The file loads, its scales apply, its mode exists and the initial charge lies
        above the file's cut-off; ``bus_period`` against ``time_step`` is the Scenario's."""
        check_boolean(f"{where}.enabled", self.enabled)
        check_boolean(f"{where}.stop_when_empty", self.stop_when_empty)
        check_text(f"{where}.file", self.file)
        if not isinstance(self.scales, dict):
            raise ScenarioError(f"{where}.scales: expected a mapping, got {self.scales!r}")
        params = load_actuators(resolve_path(self.file, f"{where}.file"), f"{where}.file")
        try:
            params = scale_actuators(params, self.scales)
        except ValueError as e:
            message = str(e)
            if message.startswith("scales: "):  # a scaled value refused
                message = "scales." + message[len("scales: ") :]
            raise ScenarioError(f"{where}.{message}") from None
        modes = tuple(params.electronics.jetson_power.value)
        if self.electronics_mode is not None:
            check_one_of(f"{where}.electronics_mode", self.electronics_mode, modes)
        cutoff = params.battery.cutoff_soc.value
        check_in_range(
            f"{where}.initial_soc",
            self.initial_soc,
            cutoff,
            1.0,
            f"(cutoff_soc = {cutoff:g}, 1]",
            open_low=True,
        )
        check_one_of(f"{where}.servo_model", self.servo_model, SERVO_MODELS)
        check_number(f"{where}.bus_period", self.bus_period)


@dc.dataclass
class VisualizationConfig:
    """Meshcat recording and logging."""

    meshcat: bool = True
    # 40 fps = a 25 ms publish period, on the 1 ms step grid: recording adds no extra
    # integrator steps, so a run with Meshcat matches one without, sample for sample.
    recording_fps: float = 40.0  # frames per second kept in recording.html

    def validate(self, where: str = "visualization") -> None:
        check_boolean(f"{where}.meshcat", self.meshcat)
        check_in_range(
            f"{where}.recording_fps",
            self.recording_fps,
            0.0,
            120.0,
            "(0, 120] fps",
            open_low=True,
        )


def default_simulator_config() -> SimulatorConfig:
    """The scenario's ``simulator`` section at its defaults."""
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


def validate_simulator(sim: SimulatorConfig, where: str = "simulator") -> None:
    """Drake's ``SimulatorConfig`` (a struct of Drake's, so checked here, not by a method)."""
    check_one_of(
        f"{where}.integration_scheme",
        sim.integration_scheme,
        ("explicit_euler", "runge_kutta2", "runge_kutta3", "semi_explicit_euler"),
    )
    check_in_range(f"{where}.max_step_size", sim.max_step_size, 1e-5, 0.01, "[1e-05, 0.01] s")
    check_in_range(f"{where}.accuracy", sim.accuracy, 0.0, 1.0, "(0, 1]", open_low=True)
    check_boolean(f"{where}.use_error_control", sim.use_error_control)
    check_in_range(
        f"{where}.start_time",
        sim.start_time,
        0.0,
        0.0,
        "[0, 0] s (schedules and metrics count from t = 0)",
    )
    check_in_range(
        f"{where}.target_realtime_rate",
        sim.target_realtime_rate,
        0.0,
        100.0,
        "[0, 100] (0: as fast as possible)",
    )
    if hasattr(sim, "publish_every_time_step"):  # in Drake 1.51, gone in 1.58
        check_boolean(f"{where}.publish_every_time_step", sim.publish_every_time_step)
