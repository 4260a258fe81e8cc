"""The modalities: each sensor-to-estimate chain of the robot, declared once.

A modality is a 0-1 estimate the controller makes from one of the station's sensors. Its
entry in ``MODALITIES`` says everything the rest of the package needs of it:

* ``estimate``: the estimate's name (``posture_hat``): the controller's output port, the
  name behaviour trees, the balloon rule and the heading hold's changes read, its log
  array; ``alias`` a short name the balloon rule accepts too (``posture``; None: none);
  ``meaning`` what 1 means (plots);
* ``needs``: the scenario switch the modality needs (``imu.enabled``), ``available`` the
  condition itself; ``initial`` the estimate at the start pose (the behaviour tree's first
  target; 0, "not seen yet", unless the start pose says otherwise);
* ``reading`` (a ``Reading``): the station's sensor: the scenario section of its parameters,
  the function that adds it (and its noise sources) to the station, its output port, its
  LCM channel and each value's name, unit and physical range (the seam's screen);
* ``estimation`` (an ``Estimation``): the controller's estimator (a ``FilteredEstimator``):
  the scenario section of its parameters, its class, its period and the outputs it
  exports (the estimate last).

From this table come the scenario's sections (``Scenario`` has a field per section), the
check that what a scenario reads has its sensor, the station's sensors, the controller's
estimators, the seam's channels and screens, the diagram's loggers, the controller
process's monitored outputs and the plots' estimate panel.

Depth (``z_hat``, Eq. 9 from the pressure sensor) and wall (``s_hat``, Eq. 10 from the
rendered camera) are the paper's own pipelines, with their own sections and wiring in the
station and the controller; their entries give their names and switches only. The energy
estimate's sensor is the battery monitor of the energy model (``actuators``).

Adding a modality: its sensor (a System in ``station/`` with an ``add_*`` function), its
estimator (a ``FilteredEstimator`` in ``control/``) and one entry here.
"""

from __future__ import annotations

import dataclasses as dc
import math
from collections.abc import Callable

from manta_drake.control.altimeter_estimator import (
    AltimeterEstimator,
    AltimeterEstimatorParams,
    floor_membership,
)
from manta_drake.control.depth import fuzzy_depth
from manta_drake.control.energy_estimator import EnergyEstimator, EnergyEstimatorParams
from manta_drake.control.flow_estimator import FlowEstimator, FlowEstimatorParams
from manta_drake.control.posture import PostureEstimator, PostureEstimatorParams
from manta_drake.model.robot_params import DEFAULT_POOL
from manta_drake.station.altimeter import AltimeterParams, add_altimeter
from manta_drake.station.flow_sensor import FlowSensorParams, add_flow_sensor
from manta_drake.station.imu import ImuParams, add_imu


@dc.dataclass(frozen=True)
class Reading:
    """A sensor of the station that one modality's estimator reads.

    Attributes:
        port: the station's output and the controller's input of that name.
        section: the scenario section of its parameters (a dataclass with ``enabled``,
            ``rate_hz`` and ``validate(section)``).
        params: that dataclass.
        add: ``add(builder, plant_handles, scenario)`` adds the sensor and its noise
            sources to the station's builder and returns the sensor (output ``port``).
        channel: its LCM channel.
        names, units, bounds: per value, its name, unit and the largest magnitude the
            part can report (beyond it a reading is corrupt: the seam drops it).
        what: one line for the channel table (docs/lcm.md).
        needs_water: the sensor reads the water (off without it).
    """

    port: str
    section: str
    params: type
    add: Callable
    channel: str
    names: tuple[str, ...]
    units: tuple[str, ...]
    bounds: tuple[float, ...]
    what: str
    needs_water: bool = False

    @property
    def size(self) -> int:
        return len(self.names)

    def period(self, scenario) -> float:
        """The sensor's sample period [s] in ``scenario``."""
        return 1.0 / getattr(scenario, self.section).rate_hz

    def period_text(self) -> str:
        """The period for people, with its default."""
        return f"1 / `{self.section}.rate_hz` ({1e3 / self.params().rate_hz:g} ms)"


@dc.dataclass(frozen=True)
class Estimation:
    """The controller's estimator of one modality.

    Attributes:
        section: the scenario section of its parameters (a dataclass with ``validate()``).
        params: that dataclass.
        system: the estimator's class, built as ``system(params, period)``.
        period: its update period [s].
        outputs: the ports it exports (the estimate last).
        when_read: built only when a tree, the balloon rule or the heading hold reads the
            estimate (else whenever its sensor is on).
        start: ``start(scenario)``, the keyword arguments that start the estimator from
            the start pose (its sensor's reading there), as the depth estimator starts from
            the pressure sensor's depth; the estimate is the same function of them as
            ``Modality.initial``, so the tree's first target and its first input agree.
    """

    section: str
    params: type
    system: type
    period: float
    outputs: tuple[str, ...]
    when_read: bool = False
    start: Callable = lambda scenario: {}


@dc.dataclass(frozen=True)
class Modality:
    """One modality (see the module docstring)."""

    estimate: str
    alias: str | None
    meaning: str
    needs: str
    available: Callable
    reading: Reading | None = None
    estimation: Estimation | None = None
    initial: Callable = lambda scenario: 0.0

    @property
    def label(self) -> str:
        return f"{self.estimate} ({self.meaning})"

    def built(self, scenario, read: bool) -> bool:
        """Whether the controller of ``scenario`` has this modality's estimator (``read``:
        the scenario reads the estimate)."""
        if self.estimation is None or not self.available(scenario):
            return False
        return read or not self.estimation.when_read


def _add_imu(builder, plant_handles, scenario):
    return add_imu(builder, plant_handles.plant, plant_handles.body, scenario.imu)


def _add_flow_sensor(builder, plant_handles, scenario):
    return add_flow_sensor(
        builder,
        plant_handles.plant,
        plant_handles.body,
        scenario.flow_sensor,
        scenario.current_schedule(),
    )


def _add_altimeter(builder, plant_handles, scenario):
    return add_altimeter(builder, plant_handles, scenario.altimeter)


def initial_sensor_depth(scenario) -> float:
    """Depth of the pressure sensor at t = 0, taking the start as level [m, >= 0]."""
    return max(0.0, -(scenario.initial_pose.xyz[2] + scenario.pressure_sensor.position[2]))


def _initial_depth_estimate(scenario) -> float:
    """z_hat of the pressure sensor's depth at the start pose (Eq. 9)."""
    de = scenario.depth_estimator
    return float(
        fuzzy_depth(initial_sensor_depth(scenario), de.floor_distance, de.surface_depth)[1]
    )


def initial_altitude(scenario) -> float:
    """The altimeter transducer's height above the pool's floor at t = 0, taking the start
    as level [m]."""
    return scenario.initial_pose.xyz[2] + scenario.altimeter.position[2] + DEFAULT_POOL.depth


def _initial_floor_estimate(scenario) -> float:
    """floor_hat of the transducer's height above the floor at the start pose."""
    return float(floor_membership(initial_altitude(scenario), scenario.altimeter_estimator))


def _sensor_on(section: str, needs_water: bool = False) -> Callable:
    def on(scenario) -> bool:
        return getattr(scenario, section).enabled and (scenario.water.enabled or not needs_water)

    return on


# The IMU's reported ranges: an AHRS reports roll and yaw in (-pi, pi] and pitch in
# [-pi/2, pi/2]; the widest full scales of MEMS parts (BNO055, BMI088, ICM-42688 class),
# 2000 deg/s = 34.9 rad/s and 16 g = 156.9 m/s^2, rounded up.
IMU_ATTITUDE_RANGE_RAD = math.pi
IMU_RATE_RANGE_RAD_S = 35.0
IMU_SPECIFIC_FORCE_RANGE_M_S2 = 160.0
# The flow probe's per-axis full scale [m/s]: the robot swims at about 0.1 m/s and a tank's
# or a harbour's current is well below 1 m/s; a small pitot or hot-film probe's range.
FLOW_RANGE_M_S = 5.0

MODALITIES = (
    Modality(
        "z_hat",
        None,
        "depth",
        "water.enabled",
        lambda s: s.water.enabled,
        initial=_initial_depth_estimate,
    ),
    Modality("s_hat", None, "wall", "camera.enabled", lambda s: s.camera.enabled),
    Modality(
        "posture_hat",
        "posture",
        "tilt",
        "imu.enabled",
        _sensor_on("imu"),
        Reading(
            "imu",
            "imu",
            ImuParams,
            _add_imu,
            "MANTA_IMU",
            ("roll", "pitch", "yaw", "wx", "wy", "wz", "fx", "fy", "fz"),
            ("rad",) * 3 + ("rad/s",) * 3 + ("m/s^2",) * 3,
            (IMU_ATTITUDE_RANGE_RAD,) * 3
            + (IMU_RATE_RANGE_RAD_S,) * 3
            + (IMU_SPECIFIC_FORCE_RANGE_M_S2,) * 3,
            "the AHRS's roll, pitch, yaw [rad], body rates [rad/s] and body specific "
            "force [m/s^2] (9 values, NaN on a dropout); imu on",
        ),
        Estimation(
            "posture_estimator",
            PostureEstimatorParams,
            PostureEstimator,
            0.02,
            ("attitude_hat", "yaw_rate_hat", "posture_hat"),
        ),
    ),
    Modality(
        "flow_hat",
        "flow",
        "flow",
        "flow_sensor.enabled",
        _sensor_on("flow_sensor", True),
        Reading(
            "flow_velocity",
            "flow_sensor",
            FlowSensorParams,
            _add_flow_sensor,
            "MANTA_FLOW_VELOCITY",
            ("u", "v", "w"),
            ("m/s",) * 3,
            (FLOW_RANGE_M_S,) * 3,
            "the water's velocity past the head probe, body frame [m/s] (3 values, NaN "
            "on a dropout); flow sensor and water on",
            needs_water=True,
        ),
        Estimation(
            "flow_estimator",
            FlowEstimatorParams,
            FlowEstimator,
            0.02,
            ("flow_speed_hat", "flow_hat"),
        ),
    ),
    Modality(
        "energy_hat",
        "energy",
        "low charge",
        "actuators.enabled",
        lambda s: s.actuators.enabled,
        None,
        Estimation(
            "energy_estimator",
            EnergyEstimatorParams,
            EnergyEstimator,
            0.1,
            ("soc_hat", "energy_hat"),
            when_read=True,
        ),
    ),
    Modality(
        "floor_hat",
        "altitude",
        "on the floor",
        "altimeter.enabled",
        _sensor_on("altimeter", True),
        Reading(
            "altitude",
            "altimeter",
            AltimeterParams,
            _add_altimeter,
            "MANTA_ALTITUDE",
            ("range",),
            ("m",),
            (AltimeterParams.MAX_RANGE_M,),
            "the downward echo sounder's range to the floor [m] (1 value, NaN on a "
            "dropout or without an echo); altimeter and water on",
            needs_water=True,
        ),
        Estimation(
            "altimeter_estimator",
            AltimeterEstimatorParams,
            AltimeterEstimator,
            0.1,
            ("altitude_hat", "floor_hat"),
            start=lambda s: {"initial_range": initial_altitude(s)},
        ),
        _initial_floor_estimate,
    ),
)

MODALITY_BY_ESTIMATE = {m.estimate: m for m in MODALITIES}
# Every name a scenario may give an estimate by: its own and its alias.
NAMES = {
    **{m.estimate: m.estimate for m in MODALITIES},
    **{m.alias: m.estimate for m in MODALITIES if m.alias},
}
ESTIMATES = tuple(MODALITY_BY_ESTIMATE)
READINGS = tuple(m.reading for m in MODALITIES if m.reading is not None)
ESTIMATIONS = tuple(m.estimation for m in MODALITIES if m.estimation is not None)
# The scenario's sections, (name, parameter dataclass), in the table's order.
SECTIONS = tuple(
    (part.section, part.params)
    for m in MODALITIES
    for part in (m.reading, m.estimation)
    if part is not None
)


def estimator_outputs() -> tuple[str, ...]:
    """Every output port the modalities' estimators export, in the table's order."""
    return tuple(port for e in ESTIMATIONS for port in e.outputs)


def _note(m: Modality) -> str:
    """The switch note of a modality that has an estimator."""
    assert m.estimation is not None
    return f"{m.needs}, estimate read" if m.estimation.when_read else m.needs


def docstring_ports(kind: str) -> str:
    """The modalities' ports as ``.. pydrake_system::`` lines (each with its switch as the
    note), for the halves' docstrings: ``sensors`` (the station's outputs, the controller's
    inputs) or ``estimates`` (the controller's outputs)."""
    if kind == "sensors":
        lines = [f"- {m.reading.port} ({m.needs})" for m in MODALITIES if m.reading]
    else:
        lines = [
            f"- {port} ({_note(m)})"
            for m in MODALITIES
            if m.estimation
            for port in m.estimation.outputs
        ]
    return "".join(f"    {line}\n" for line in lines)


def docstring_sensors() -> str:
    """The modalities' sensors as a docstring's bullets: port, size and what it reads."""
    return "".join(f"  * ``{r.port}`` ({r.size}): {r.what}\n" for r in READINGS)


def docstring_estimators() -> str:
    """The modalities' estimators as a docstring's bullets: class, input and outputs."""
    return "".join(
        f"  * ``{m.estimation.system.__name__}`` ({m.reading.port if m.reading else 'battery'}"
        f" -> {', '.join(m.estimation.outputs)}; {_note(m)})\n"
        for m in MODALITIES
        if m.estimation
    )


def fill_docstring(doc: str) -> str:
    """``doc`` with its markers replaced by the registry's text: ``    - <sensor ports>``,
    ``    - <estimate ports>``, ``  * <sensors>``, ``  * <estimators>`` (each a whole
    line)."""
    for marker, text in (
        ("    - <sensor ports>\n", docstring_ports("sensors")),
        ("    - <estimate ports>\n", docstring_ports("estimates")),
        ("  * <sensors>\n", docstring_sensors()),
        ("  * <estimators>\n", docstring_estimators()),
    ):
        doc = doc.replace(marker, text)
    return doc
