"""The energy model's parameters: the servos, the electronics and the battery.

``models/actuators.yaml`` holds every number with its source (the paper gives only the
battery and the computers; it names no servo). :func:`load_actuators` reads it through the
strict reader (duplicate and unknown keys refused) into the dataclasses below and checks
every value; :func:`scale_actuators` multiplies named entries (a scenario's
``actuators.scales``, sweeps and sensitivity studies) the way
``coefficients.scale_coefficients`` does for the water. :func:`energy_model` resolves them
into the plain numbers the station's systems take (:class:`ServoConstants`,
:class:`PackConstants` and the electronics' draw).

The pack's open-circuit voltage is the per-cell table ``battery.ocv_cell_voltage`` on
``battery.ocv_soc``, interpolated linearly, times the cells in series; its usable energy is
that voltage integrated over the charge from ``cutoff_soc`` to full (exact for the
piecewise-linear curve).
"""

import copy
import dataclasses as dc
import functools
import pathlib

import numpy as np
from pydrake.common.yaml import yaml_load_typed

from manta_drake.config_io import ScenarioError, check_keys, load_yaml_mapping, short_repr
from manta_drake.model import MODELS_DIR, resolve_path
from manta_drake.model.sourced import Flag, Number, Numbers, Table, Text, sourced_entries

DEFAULT_ACTUATORS_FILE = MODELS_DIR / "actuators.yaml"
CONNECTIONS = ("series", "parallel")


@dc.dataclass
class ServoParams:
    """One joint's geared DC servo (all 16 joints use the same class)."""

    model: Text = dc.field(default_factory=Text)
    gear_ratio: Number = dc.field(default_factory=Number)
    torque_constant: Number = dc.field(default_factory=Number)  # N m/A at the motor
    gearbox_efficiency: Number = dc.field(default_factory=Number)  # (0, 1]
    backdrive_speed: Number = dc.field(default_factory=Number)  # rad/s, >= 0
    winding_resistance: Number = dc.field(default_factory=Number)  # ohm
    standby_current: Number = dc.field(default_factory=Number)  # A
    supply_voltage: Number = dc.field(default_factory=Number)  # V
    position_p_gain: Number = dc.field(default_factory=Number)  # control-table units
    encoder_resolution: Number = dc.field(default_factory=Number)  # pulses per revolution
    pwm_unit: Number = dc.field(default_factory=Number)  # duty per PWM unit
    pwm_limit: Number = dc.field(default_factory=Number)  # PWM units
    recover_negative_work: Flag = dc.field(default_factory=Flag)


@dc.dataclass
class ElectronicsParams:
    """The on-board computers' constant draw."""

    jetson_power: Table = dc.field(default_factory=Table)  # W per mode
    jetson_mode: Text = dc.field(default_factory=Text)  # the default mode
    teensy_power: Number = dc.field(default_factory=Number)  # W
    regulator_efficiency: Number = dc.field(default_factory=Number)  # (0, 1]


@dc.dataclass
class BatteryParams:
    """The LiPo packs and how they are connected."""

    packs: Number = dc.field(default_factory=Number)
    cells_per_pack: Number = dc.field(default_factory=Number)
    pack_capacity: Number = dc.field(default_factory=Number)  # Ah
    connection: Text = dc.field(default_factory=Text)  # series | parallel
    ocv_soc: Numbers = dc.field(default_factory=Numbers)
    ocv_cell_voltage: Numbers = dc.field(default_factory=Numbers)  # V
    cell_internal_resistance: Number = dc.field(default_factory=Number)  # ohm
    cutoff_soc: Number = dc.field(default_factory=Number)


@dc.dataclass
class ActuatorParams:
    """Contents of ``models/actuators.yaml``: every value with its source."""

    servo: ServoParams = dc.field(default_factory=ServoParams)
    electronics: ElectronicsParams = dc.field(default_factory=ElectronicsParams)
    battery: BatteryParams = dc.field(default_factory=BatteryParams)

    def entries(self) -> list:
        """(dotted name, entry) for every entry of the file."""
        return list(sourced_entries(self))


# Numeric entries no factor may scale: cell and pack counts are whole numbers, the
# state-of-charge grid must run from 0 to 1, and the encoder's count and the PWM's unit are
# the firmware's definitions, not uncertain quantities.
NOT_SCALABLE = (
    "battery.packs",
    "battery.cells_per_pack",
    "battery.ocv_soc",
    "servo.encoder_resolution",
    "servo.pwm_unit",
)

# The factors a scale may apply, [lo, hi]: a band about the file's value for sensitivity
# studies and calibration, not another robot (above 10 it is another servo, battery or
# computer: edit the file). 0 switches a term off where the entry may be 0 (the standby
# current, a resistance); where an entry must stay positive or at most 1 (an efficiency, the
# cut-off charge), check_actuators refuses the scaled value. Tighter for the voltages, which
# the cell chemistry fixes: x0.5-1.5 of a LiPo cell's 2.65-4.10 V spans the other lithium
# cells (LiFePO4 3.2 V, LTO 2.4 V nominal against LiPo's 3.7 V), and the servo's supply is
# that battery's bus.
SCALE_RANGE = (0.0, 10.0)
SCALE_RANGES = {"servo.supply_voltage": (0.5, 1.5), "battery.ocv_cell_voltage": (0.5, 1.5)}


def scale_range(name: str) -> tuple[float, float]:
    """The factors ``[lo, hi]`` a scale of entry ``name`` may apply."""
    return SCALE_RANGES.get(name, SCALE_RANGE)


def scalable_names() -> tuple[str, ...]:
    """Dotted names of the entries a scale may multiply (the numeric ones but
    ``NOT_SCALABLE``)."""
    return tuple(
        name
        for name, entry in ActuatorParams().entries()
        if isinstance(entry, (Number, Numbers, Table)) and name not in NOT_SCALABLE
    )


# --- checks --------------------------------------------------------------------------------

# Entries that must be > 0 (each divides something or is a physical size), and those that
# must lie in (0, 1] or [0, 1).
POSITIVE = (
    "servo.gear_ratio",
    "servo.torque_constant",
    "servo.gearbox_efficiency",
    "servo.supply_voltage",
    "servo.encoder_resolution",
    "servo.pwm_unit",
    "servo.pwm_limit",
    "electronics.regulator_efficiency",
    "battery.packs",
    "battery.cells_per_pack",
    "battery.pack_capacity",
    "battery.ocv_cell_voltage",
    "electronics.jetson_power",
)
AT_MOST_ONE = ("servo.gearbox_efficiency", "electronics.regulator_efficiency")
INTEGER = ("battery.packs", "battery.cells_per_pack")


def check_actuators(params: ActuatorParams, where: str = "actuators") -> None:
    """Raises ScenarioError naming the first entry with a missing source or a bad value
    (non-finite, negative, zero where it must be positive, an efficiency above 1, a
    fractional cell count, an unknown connection or default mode, an open-circuit table
    that is not increasing or a cut-off outside [0, 1))."""
    for name, entry in params.entries():
        if not entry.source.strip():
            raise ScenarioError(f"{where}: {name} has no source")
        if isinstance(entry, (Text, Flag)):
            continue
        raw = list(entry.value.values()) if isinstance(entry, Table) else entry.value
        values = np.atleast_1d(np.asarray(raw, dtype=float))
        if values.size == 0:
            raise ScenarioError(f"{where}: {name} has no values")
        if not np.all(np.isfinite(values)):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} has non-finite values")
        if np.any(values < 0):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be >= 0")
        if name in POSITIVE and np.any(values <= 0):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be > 0")
        if name in AT_MOST_ONE and np.any(values > 1):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be in (0, 1]")
        if name in INTEGER and np.any(values != np.round(values)):
            raise ScenarioError(f"{where}: {name} = {entry.value!r} must be a whole number")
    duty = params.servo.pwm_unit.value * params.servo.pwm_limit.value
    if duty > 1.0 + 1e-3:  # the datasheet's 885 x 0.113 % rounds to 100.005 %
        raise ScenarioError(
            f"{where}: servo.pwm_limit x servo.pwm_unit = {duty:g} must be at most 1 (full duty)"
        )
    if not params.servo.model.value.strip():
        raise ScenarioError(f"{where}: servo.model is empty (name the servo class)")
    e, b = params.electronics, params.battery
    if e.jetson_mode.value not in e.jetson_power.value:
        raise ScenarioError(
            f"{where}: electronics.jetson_mode = {e.jetson_mode.value!r} is not "
            f"one of the modes of electronics.jetson_power "
            f"({', '.join(e.jetson_power.value)})"
        )
    if b.connection.value not in CONNECTIONS:
        raise ScenarioError(
            f"{where}: battery.connection = {b.connection.value!r} is not one "
            f"of {', '.join(CONNECTIONS)}"
        )
    soc, ocv = np.asarray(b.ocv_soc.value, float), np.asarray(b.ocv_cell_voltage.value, float)
    if len(soc) != len(ocv) or len(soc) < 2:
        raise ScenarioError(
            f"{where}: battery.ocv_soc and battery.ocv_cell_voltage need the same "
            f"number (>= 2) of values, got {len(soc)} and {len(ocv)}"
        )
    if soc[0] != 0.0 or soc[-1] != 1.0 or np.any(np.diff(soc) <= 0):
        raise ScenarioError(
            f"{where}: battery.ocv_soc = {b.ocv_soc.value!r} must rise strictly from 0 to 1"
        )
    # A falling voltage would make the charge a voltage reading gives ambiguous, and it is
    # not what a cell does.
    if np.any(np.diff(ocv) <= 0):
        raise ScenarioError(
            f"{where}: battery.ocv_cell_voltage = {b.ocv_cell_voltage.value!r} "
            "must rise with the state of charge"
        )
    if not 0.0 <= b.cutoff_soc.value < 1.0:
        raise ScenarioError(
            f"{where}: battery.cutoff_soc = {b.cutoff_soc.value!r} is outside "
            "the allowed range [0, 1)"
        )


def load_actuators(path=DEFAULT_ACTUATORS_FILE, field: str | None = None) -> ActuatorParams:
    """Loads and checks ``actuators.yaml`` (duplicate and unknown keys, types, values,
    sources); errors are one line naming the file (and ``field``, the scenario field that
    named it) and the entry."""
    path = pathlib.Path(path)
    where = f"{field} = {path}" if field else str(path)
    try:
        data, text = load_yaml_mapping(path, "actuators")
        check_keys(data, ActuatorParams, path.name)
        params = yaml_load_typed(schema=ActuatorParams, data=text)
        check_actuators(params, path.name)
    except ScenarioError as e:
        message = str(e)
        prefix = f"{path}: "
        message = message[len(prefix) :] if message.startswith(prefix) else message
        raise ScenarioError(f"{where}: {message}") from None
    except (RuntimeError, ValueError, TypeError) as e:  # yaml_load_typed's own errors
        raise ScenarioError(f"{where}: {' '.join(str(e).split())}") from None
    return params


def scale_actuators(params: ActuatorParams, scales: dict) -> ActuatorParams:
    """A copy of ``params`` with named numeric entries multiplied, e.g.
    ``{"servo.winding_resistance": 1.2}``; each scaled entry's ``source`` says so. Unknown
    names, non-numeric entries, non-finite or negative factors and factors outside the
    entry's ``scale_range`` raise ValueError naming the entry; a scaled set that breaks a
    check (an efficiency above 1) is refused."""
    result = copy.deepcopy(params)
    entries = dict(result.entries())
    allowed = scalable_names()
    for name, factor in (scales or {}).items():
        if name not in allowed:
            raise ValueError(
                f"scales.{name}: unknown or not a numeric entry; allowed: {', '.join(allowed)}"
            )
        if isinstance(factor, bool) or not (
            isinstance(factor, (int, float)) and np.isfinite(factor) and factor >= 0
        ):
            raise ValueError(f"scales.{name}: {short_repr(factor)} must be a finite number >= 0")
        lo, hi = scale_range(name)
        if not lo <= factor <= hi:
            raise ValueError(
                f"scales.{name}: {short_repr(factor)} is outside the allowed range "
                f"[{lo:g}, {hi:g}] (a factor on the file's value)"
            )
        entry = entries[name]
        if isinstance(entry, Table):
            entry.value = {k: float(v) * factor for k, v in entry.value.items()}
        elif isinstance(entry, Numbers):
            entry.value = [float(v) * factor for v in entry.value]
        else:
            entry.value = float(entry.value) * factor
        entry.source = f"x{factor:g} of: {entry.source}"
    try:
        check_actuators(result, "scales")
    except ScenarioError as e:
        raise ValueError(str(e)) from None
    return result


# --- resolved numbers ------------------------------------------------------------------------


@dc.dataclass(frozen=True)
class ServoConstants:
    """One servo's constants (SI units), as the power model uses them."""

    gear_ratio: float
    torque_constant: float  # N m/A at the motor = back-EMF constant V s/rad
    gearbox_efficiency: float
    winding_resistance: float  # ohm
    standby_current: float  # A
    supply_voltage: float  # V
    recover_negative_work: bool = False
    # Joint rate against the torque at which the load fully back-drives the motor [rad/s];
    # 0: the sign of tau qdot alone decides.
    backdrive_speed: float = 0.0
    # The firmware's position loop (model.servo): Position P Gain in control-table units,
    # the encoder's pulses per revolution, duty per PWM unit and the PWM limit in units.
    position_p_gain: float = 800.0
    encoder_resolution: float = 4096.0
    pwm_unit: float = 0.00113
    pwm_limit: float = 885.0

    @property
    def standby_power(self) -> float:
        """What one servo draws whatever its load [W]."""
        return self.standby_current * self.supply_voltage


@dc.dataclass(frozen=True)
class PackConstants:
    """The battery as one string of cells: open-circuit voltage table, resistance, charge."""

    cells_in_series: int
    capacity_ah: float
    ocv_soc: tuple
    ocv_cell_voltage: tuple
    internal_resistance: float  # ohm, the whole pack
    cutoff_soc: float

    def open_circuit_voltage(self, soc):
        """The pack's open-circuit voltage [V] at state of charge ``soc`` (clipped to [0, 1])."""
        # np.interp holds the table's end values outside it: the same as clipping to [0, 1].
        return self.cells_in_series * np.interp(soc, self.ocv_soc, self.ocv_cell_voltage)

    def usable_energy_wh(self) -> float:
        """The energy between full and ``cutoff_soc`` at open circuit [Wh]: the capacity
        times the integral of the voltage over the state of charge (the trapezoid rule on
        the table's points and the cut-off is exact for the linear interpolation)."""
        soc = np.asarray(self.ocv_soc, dtype=float)
        inside = soc[soc > self.cutoff_soc]
        grid = np.concatenate([[self.cutoff_soc], inside])
        volts = self.open_circuit_voltage(grid)
        return float(self.capacity_ah * np.sum(0.5 * (volts[1:] + volts[:-1]) * np.diff(grid)))


@dc.dataclass(frozen=True)
class EnergyModel:
    """The resolved energy model: the servo class, the electronics' draw, the pack."""

    servo: ServoConstants
    electronics_power: float  # W drawn from the battery by the computers (after the regulator)
    pack: PackConstants
    electronics_mode: str
    servo_model: str


def electronics_power(params: ActuatorParams, mode: str | None = None) -> float:
    """The computers' draw at the battery [W]: (Jetson in ``mode`` + Teensy) / regulator
    efficiency; ``mode`` None is the file's ``jetson_mode``."""
    e = params.electronics
    mode = e.jetson_mode.value if mode is None else mode
    if mode not in e.jetson_power.value:
        raise ValueError(
            f"electronics_mode: {mode!r} is not one of {', '.join(e.jetson_power.value)}"
        )
    return (float(e.jetson_power.value[mode]) + float(e.teensy_power.value)) / float(
        e.regulator_efficiency.value
    )


def pack_constants(params: ActuatorParams) -> PackConstants:
    """The pack as one string: in series the packs' cells add up and the capacity is one
    pack's; in parallel the cells are one pack's and the capacities add."""
    b = params.battery
    packs, cells = int(round(b.packs.value)), int(round(b.cells_per_pack.value))
    series = b.connection.value == "series"
    in_series = packs * cells if series else cells
    strings = 1 if series else packs
    return PackConstants(
        cells_in_series=in_series,
        capacity_ah=float(b.pack_capacity.value) * strings,
        ocv_soc=tuple(float(v) for v in b.ocv_soc.value),
        ocv_cell_voltage=tuple(float(v) for v in b.ocv_cell_voltage.value),
        internal_resistance=float(b.cell_internal_resistance.value) * in_series / strings,
        cutoff_soc=float(b.cutoff_soc.value),
    )


def servo_constants(params: ActuatorParams) -> ServoConstants:
    s = params.servo
    return ServoConstants(
        gear_ratio=float(s.gear_ratio.value),
        torque_constant=float(s.torque_constant.value),
        gearbox_efficiency=float(s.gearbox_efficiency.value),
        winding_resistance=float(s.winding_resistance.value),
        standby_current=float(s.standby_current.value),
        supply_voltage=float(s.supply_voltage.value),
        recover_negative_work=bool(s.recover_negative_work.value),
        backdrive_speed=float(s.backdrive_speed.value),
        position_p_gain=float(s.position_p_gain.value),
        encoder_resolution=float(s.encoder_resolution.value),
        pwm_unit=float(s.pwm_unit.value),
        pwm_limit=float(s.pwm_limit.value),
    )


def energy_model(params: ActuatorParams, electronics_mode: str | None = None) -> EnergyModel:
    """The resolved model of ``params`` with the Jetson in ``electronics_mode`` (None: the
    file's default)."""
    mode = params.electronics.jetson_mode.value if electronics_mode is None else electronics_mode
    return EnergyModel(
        servo=servo_constants(params),
        electronics_power=electronics_power(params, mode),
        pack=pack_constants(params),
        electronics_mode=mode,
        servo_model=params.servo.model.value,
    )


def load_energy_model(
    file,
    scales: dict | None = None,
    electronics_mode: str | None = None,
    field: str = "actuators.file",
) -> EnergyModel:
    """The resolved model of a scenario's ``actuators`` section: ``file`` (a
    ``package://manta_drake/...`` URL or a path) loaded, ``scales`` applied, the Jetson in
    ``electronics_mode`` (None: the file's default). Errors name ``field``."""
    path = resolve_path(file)
    try:  # the file parsed once per version (~15 ms a parse; a build asks several times)
        key = (
            str(path),
            path.stat().st_mtime_ns if path.is_file() else None,
            tuple(sorted((scales or {}).items())),
            electronics_mode,
            field,
        )
        hash(key)
    except (TypeError, OSError):  # unhashable scales: the checks below name them
        return _energy_model(path, scales, electronics_mode, field)
    return _cached_energy_model(*key)


@functools.lru_cache(maxsize=32)
def _cached_energy_model(path: str, mtime_ns, scales: tuple, electronics_mode, field: str):
    return _energy_model(pathlib.Path(path), dict(scales), electronics_mode, field)


def _energy_model(path, scales, electronics_mode, field: str) -> EnergyModel:
    params = load_actuators(path, field)
    return energy_model(scale_actuators(params, scales or {}), electronics_mode)
