"""The scenario's top level: its own fields (name, duration, time step, seed, ...) and its
sections, as ``ScenarioFields``; ``Scenario`` (``manta_drake.scenario.checks``) adds the
derived views (``manta_drake.scenario.views``) and the checks across sections."""

import dataclasses as dc

from pydrake.systems.analysis import SimulatorConfig

from manta_drake.config_io import check_in_range, check_integer, check_one_of, check_text
from manta_drake.control.heading_hold import HeadingHoldParams
from manta_drake.control.vision import WallDetectorParams
from manta_drake.modalities import SECTIONS
from manta_drake.scenario.devices import (
    ActuatorsConfig,
    BalloonConfig,
    CameraConfig,
    DepthEstimatorConfig,
    PressureSensorConfig,
    VisualizationConfig,
    default_simulator_config,
)
from manta_drake.scenario.schema import (
    ContactConfig,
    ControllerConfig,
    CpgConfig,
    InitialPose,
    RobotConfig,
    TransitionConfig,
    WaterConfig,
)

# The longest run [s] and the largest random seed a scenario takes (the studies' options
# that set them are checked against the same bounds).
MAX_DURATION_S = 3600.0
MAX_RANDOM_SEED = 2**32 - 1
CONTACT_APPROXIMATIONS = ("sap", "lagged", "similar", "tamsi")


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
class ScenarioFields:
    """The scenario's top level: its fields and sections. Besides the fields below, one per
    section of the modalities' sensors and estimators (``manta_drake.modalities.SECTIONS``:
    ``imu``, ``posture_estimator``, ``flow_sensor``, ``flow_estimator`` and the rest)."""

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
    simulator: SimulatorConfig = dc.field(default_factory=default_simulator_config)
    visualization: VisualizationConfig = dc.field(default_factory=VisualizationConfig)
    actuators: ActuatorsConfig = dc.field(default_factory=ActuatorsConfig)
    log_period: float = 1e-3  # s, sample period of log.npz
    # Metrics average over t >= steady_after (capped at half the run) ...
    steady_after: float = 2.0
    # ... until the hull first comes within this distance of a wall [m] (free water only).
    free_water_margin: float = 0.3

    def validate_top(self) -> None:
        """The top-level fields that need no section: name, description, duration, time
        step, contact approximation, seed, log period, steady window and free-water margin."""
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
            CONTACT_APPROXIMATIONS,
        )
        check_integer("random_seed", self.random_seed, 0, MAX_RANDOM_SEED)
        check_in_range(
            "log_period",
            self.log_period,
            self.time_step,
            1.0,
            f"[time_step = {self.time_step}, 1] s",
        )
        check_in_range("steady_after", self.steady_after, 0.0, 3600.0, "[0, 3600] s")
        check_in_range("free_water_margin", self.free_water_margin, 0.0, 1.0, "[0, 1] m")
