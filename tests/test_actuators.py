"""The energy model's parameters (models/actuators.yaml) and the servos' power.

The servo maths is held to closed forms: at zero speed (stall, a held torque) the power is
R i^2 + standby with i = tau / (k_t N eta); at zero torque (a dry joint, no load) only the
standby; moving against a constant torque, R i^2 + tau qdot / eta + standby; back-driven,
the gearbox's efficiency divides the other way and the negative work is lost unless
recovered. The file's derived constants are held to the datasheet they come from.
"""

import dataclasses as dc
import math

import numpy as np
import pytest

from manta_drake.config_io import ScenarioError
from manta_drake.model.actuators import (
    DEFAULT_ACTUATORS_FILE,
    PackConstants,
    electronics_power,
    energy_model,
    load_actuators,
    pack_constants,
    scalable_names,
    scale_actuators,
)
from manta_drake.model.robot_params import DEFAULT_ROBOT, NUM_JOINTS
from manta_drake.station.servo_power import (
    ServoPower,
    back_emf,
    joint_mechanical_power,
    motor_current,
    servo_electrical_power,
    servo_power_terms,
    total_electrical_power,
    total_electrical_power_kernel,
    voltage_demand,
)

# The servo class's datasheet (ROBOTIS e-Manual, XW540-T140-R) at 14.8 V.
STALL_TORQUE, STALL_CURRENT, NO_LOAD_RPM, VOLTS = 8.3, 5.9, 88.0, 14.8


@pytest.fixture(scope="module")
def params():
    return load_actuators()


@pytest.fixture(scope="module")
def servo(params):
    return energy_model(params).servo


# --- the file -------------------------------------------------------------------------------


def _sourced_paths(data, prefix: str = "") -> list[str]:
    """The dotted paths of a YAML mapping's ``{value, source}`` leaves, read from the file
    itself (not through the package's dataclasses)."""
    paths = []
    for key, item in data.items():
        if isinstance(item, dict) and set(item) == {"value", "source"}:
            paths.append(f"{prefix}{key}")
        elif isinstance(item, dict):
            paths += _sourced_paths(item, f"{prefix}{key}.")
    return paths


def test_the_data_files_entries_are_one_value_with_source_type(params):
    """hydrodynamics.yaml, actuators.yaml and bill_of_materials.yaml hold their values as
    ``{value, source}`` and load into the same types: every such leaf of each file, found by
    reading the YAML directly, is an entry of the loaded file under its dotted name, of one
    of the shared types (a number, a list, a name, a flag, a table)."""
    import yaml

    from manta_drake.model import bill_of_materials as bom
    from manta_drake.model.coefficients import DEFAULT_COEFFICIENTS_FILE, load_coefficients
    from manta_drake.model.sourced import SOURCED, Number, Numbers, sourced_entries

    loaded = {
        DEFAULT_COEFFICIENTS_FILE: load_coefficients(),
        DEFAULT_ACTUATORS_FILE: params,
        bom.DEFAULT_BILL_OF_MATERIALS_FILE: bom.load_bill_of_materials(),
    }
    for path, value in loaded.items():
        entries = dict(sourced_entries(value))
        raw = yaml.safe_load(path.read_text())
        raw.pop("hull_parts", None)  # the bill's parts carry their own source, not entries
        assert sorted(entries) == sorted(_sourced_paths(raw)), path.name
        assert all(isinstance(e, SOURCED) for e in entries.values())
    coefficients, bill = (
        loaded[DEFAULT_COEFFICIENTS_FILE],
        loaded[bom.DEFAULT_BILL_OF_MATERIALS_FILE],
    )
    assert type(coefficients.water_density) is type(params.servo.gear_ratio) is Number
    assert type(coefficients.body.linear_damping) is type(params.battery.ocv_soc) is Numbers
    assert type(bill.total_mass) is Number and bill.total_mass.value == 8.4


def test_every_entry_has_a_source_and_the_servo_is_said_to_be_chosen(params):
    for name, entry in params.entries():
        assert entry.source.strip(), name
    # The paper names no servo: the file must say the class is this package's choice.
    assert "paper names no servo" in params.servo.model.source
    assert "DOES NOT NAME ITS SERVOS" in DEFAULT_ACTUATORS_FILE.read_text()


def test_constants_reproduce_the_datasheet(servo):
    # Stall at the supply: i = V / R, tau = k_t N eta i.
    assert VOLTS / servo.winding_resistance == pytest.approx(STALL_CURRENT, rel=1e-3)
    stall = (
        servo.torque_constant
        * servo.gear_ratio
        * servo.gearbox_efficiency
        * VOLTS
        / servo.winding_resistance
    )
    assert stall == pytest.approx(STALL_TORQUE, rel=2e-3)
    # No load: the back-EMF equals the supply at the no-load speed.
    no_load = VOLTS / (servo.torque_constant * servo.gear_ratio)
    assert no_load == pytest.approx(NO_LOAD_RPM * 2 * math.pi / 60, rel=1e-3)
    assert servo.supply_voltage == VOLTS
    # The same through the power model's own functions: the driver's voltage demand is the
    # supply at the stall torque (zero speed) and at the no-load speed (zero torque).
    assert voltage_demand(STALL_TORQUE, 0.0, servo) == pytest.approx(VOLTS, rel=2e-3)
    assert voltage_demand(0.0, no_load, servo) == pytest.approx(VOLTS, rel=1e-12)


def test_the_servo_class_covers_the_plants_limits(servo, robot_plant):
    _, handles = robot_plant
    plant, robot = handles.plant, handles.robot
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(robot)]
    assert len(actuators) == NUM_JOINTS
    effort = max(a.effort_limit() for a in actuators)
    rate = max(float(a.joint().velocity_upper_limits()[0]) for a in actuators)
    assert effort == DEFAULT_ROBOT.effort_limit and rate == DEFAULT_ROBOT.velocity_limit
    stall = (
        servo.torque_constant
        * servo.gear_ratio
        * servo.gearbox_efficiency
        * servo.supply_voltage
        / servo.winding_resistance
    )
    no_load = servo.supply_voltage / (servo.torque_constant * servo.gear_ratio)
    assert stall > effort and no_load > rate


def test_electronics_modes(params):
    assert electronics_power(params) == pytest.approx((10.0 + 0.5) / 0.9)  # the default: 10 W
    assert electronics_power(params, "5W") == pytest.approx((5.0 + 0.5) / 0.9)
    with pytest.raises(ValueError, match="electronics_mode"):
        electronics_power(params, "20W")


def test_pack_in_series_and_in_parallel(params):
    series = pack_constants(params)
    assert (series.cells_in_series, series.capacity_ah) == (4, 5.0)
    assert series.internal_resistance == pytest.approx(4 * 0.0127)
    assert series.open_circuit_voltage(1.0) == pytest.approx(4 * 4.1029)
    parallel = dc.replace(
        params,
        battery=dc.replace(
            params.battery, connection=dc.replace(params.battery.connection, value="parallel")
        ),
    )
    p = pack_constants(parallel)
    assert (p.cells_in_series, p.capacity_ah) == (2, 10.0)
    assert p.internal_resistance == pytest.approx(2 * 0.0127 / 2)
    # The same stored energy either way (74 Wh nominal): twice the charge at half the voltage.
    assert p.usable_energy_wh() == pytest.approx(series.usable_energy_wh(), rel=1e-12)


def test_usable_energy_closed_form():
    # A linear cell curve V = 3.0 + 1.2 s: the energy above a cut-off c is
    # cells Q (3.0 (1 - c) + 0.6 (1 - c^2)); the cut-off falls between table points.
    pack = PackConstants(
        cells_in_series=4,
        capacity_ah=5.0,
        ocv_soc=(0.0, 0.5, 1.0),
        ocv_cell_voltage=(3.0, 3.6, 4.2),
        internal_resistance=0.05,
        cutoff_soc=0.3,
    )
    c = 0.3
    assert pack.usable_energy_wh() == pytest.approx(
        4 * 5.0 * (3.0 * (1 - c) + 0.6 * (1 - c * c)), rel=1e-12
    )
    # The shipped curve against a fine numerical integral of its interpolation.
    shipped = pack_constants(load_actuators())
    s = np.linspace(shipped.cutoff_soc, 1.0, 200_001)
    v = shipped.open_circuit_voltage(s)
    fine = shipped.capacity_ah * np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(s))
    assert shipped.usable_energy_wh() == pytest.approx(fine, rel=1e-9)
    assert 55 < shipped.usable_energy_wh() < 74  # below the 74 Wh nominal: the cut-off


# --- loader errors ---------------------------------------------------------------------------


def _broken(tmp_path, old, new):
    text = DEFAULT_ACTUATORS_FILE.read_text()
    assert old in text, old
    path = tmp_path / "actuators.yaml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize(
    "old, new, match",
    [
        ("  gear_ratio:\n", "  gear_ration:\n", r"servo\.gear_ration: unknown key"),
        (
            "    value: 0.876",
            "    value: 1.2",
            r"servo\.gearbox_efficiency = 1\.2 must be in \(0, 1\]",
        ),
        (
            "    value: 2.508",
            "    value: -2.508",
            r"servo\.winding_resistance = -2\.508 must be >= 0",
        ),
        ("    value: series", "    value: diagonal", r"battery\.connection = 'diagonal'"),
        ("    value: 10W\n", "    value: 7W\n", r"electronics\.jetson_mode = '7W'"),
        ("[2.654, 3.5164", "[2.654, 2.5164", r"battery\.ocv_cell_voltage .* must rise"),
        ("    value: 0.2  #", "    value: 1.0  #", r"battery\.cutoff_soc = 1\.0 is outside"),
        (
            "    value: 2\n    source: 'a 7.4 V",
            "    value: 2.5\n    source: 'a 7.4 V",
            r"battery\.cells_per_pack = 2\.5 must be a whole number",
        ),
        (
            "    source: XW540-T140 datasheet (ROBOTIS e-Manual), standby current 40 mA",
            "    source: ''",
            r"servo\.standby_current has no source",
        ),
        ("  supply_voltage:\n", "  standby_current:\n", r"duplicate key 'standby_current'"),
    ],
)
def test_bad_files_give_one_line_errors_naming_file_and_entry(tmp_path, old, new, match):
    path = _broken(tmp_path, old, new)
    with pytest.raises(ScenarioError, match=match) as info:
        load_actuators(path, "actuators.file")
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"actuators.file = {path}")


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(ScenarioError, match="not found"):
        load_actuators(tmp_path / "none.yaml")


# --- scales ------------------------------------------------------------------------------------


def test_scales_multiply_and_say_so(params):
    scaled = scale_actuators(
        params,
        {
            "servo.winding_resistance": 1.2,
            "electronics.jetson_power": 0.5,
            "battery.ocv_cell_voltage": 1.01,
        },
    )
    assert scaled.servo.winding_resistance.value == pytest.approx(1.2 * 2.508)
    assert scaled.servo.winding_resistance.source.startswith("x1.2 of: ")
    assert scaled.electronics.jetson_power.value == {"10W": 5.0, "5W": 2.5}
    assert scaled.battery.ocv_cell_voltage.value[-1] == pytest.approx(1.01 * 4.1029)
    assert params.servo.winding_resistance.value == 2.508  # the original is untouched
    assert energy_model(scaled).servo.winding_resistance == pytest.approx(1.2 * 2.508)


@pytest.mark.parametrize(
    "scales, match",
    [
        ({"servo.resistance": 1.2}, r"scales\.servo\.resistance: unknown"),
        ({"servo.model": 1.2}, r"scales\.servo\.model: unknown or not a numeric entry"),
        ({"battery.ocv_soc": 0.5}, r"scales\.battery\.ocv_soc: unknown or not a numeric"),
        ({"servo.gear_ratio": -1.0}, r"must be a finite number >= 0"),
        ({"servo.gear_ratio": True}, r"must be a finite number >= 0"),
        ({"servo.gearbox_efficiency": 1.2}, r"servo\.gearbox_efficiency = 1\.05.* must be in"),
    ],
)
def test_bad_scales_are_refused(params, scales, match):
    with pytest.raises(ValueError, match=match):
        scale_actuators(params, scales)


def test_scalable_names_are_the_numeric_entries():
    names = scalable_names()
    assert "servo.winding_resistance" in names and "battery.pack_capacity" in names
    assert not {
        "servo.model",
        "servo.recover_negative_work",
        "battery.connection",
        "battery.packs",
        "battery.ocv_soc",
    } & set(names)


# --- the servo maths --------------------------------------------------------------------------


def _i_drive(tau, s):
    return tau / (s.torque_constant * s.gear_ratio * s.gearbox_efficiency)


def test_stall_and_holding_draw_copper_loss_and_standby(servo):
    tau = np.linspace(-6.0, 6.0, NUM_JOINTS)
    power = servo_electrical_power(tau, np.zeros(NUM_JOINTS), servo)
    expected = servo.winding_resistance * _i_drive(tau, servo) ** 2 + 0.040 * 14.8
    np.testing.assert_allclose(power, expected, rtol=1e-12)
    # At the plant's 6 N m effort limit a held joint draws R (6 / 1.407 A)^2 = 45.6 W.
    assert power[-1] == pytest.approx(2.508 * (6.0 / (0.01103 * 145.6 * 0.876)) ** 2 + 0.592)


def test_a_dry_joint_draws_only_standby(servo):
    qdot = np.linspace(-8.0, 8.0, NUM_JOINTS)
    power = servo_electrical_power(np.zeros(NUM_JOINTS), qdot, servo)
    np.testing.assert_array_equal(power, np.full(NUM_JOINTS, servo.standby_power))
    assert servo.standby_power == pytest.approx(0.040 * 14.8)
    np.testing.assert_array_equal(motor_current(0.0, qdot, servo), 0.0)
    np.testing.assert_allclose(back_emf(qdot, servo), 0.01103 * 145.6 * qdot)


def test_driving_a_constant_torque(servo):
    tau, qdot = 2.0, 3.0  # the motor does positive work
    i = _i_drive(tau, servo)
    expected = (
        servo.winding_resistance * i**2
        + tau * qdot / servo.gearbox_efficiency
        + servo.standby_power
    )
    assert servo_electrical_power(tau, qdot, servo) == pytest.approx(expected, rel=1e-12)
    # The back-EMF times the current is the motor's shaft power tau qdot / eta.
    assert back_emf(qdot, servo) * i == pytest.approx(tau * qdot / servo.gearbox_efficiency)
    # Motor power at least the delivered mechanical power (efficiency below 1).
    assert servo_electrical_power(tau, qdot, servo) - servo.standby_power > tau * qdot


def test_power_terms_split_the_draw_by_where_it_goes(servo):
    tau, qdot = np.array([2.0, 2.0, 0.0]), np.array([3.0, -3.0, 5.0])  # drive, back-driven, dry
    terms = servo_power_terms(tau, qdot, servo)
    eta, kn, r = (
        servo.gearbox_efficiency,
        servo.torque_constant * servo.gear_ratio,
        servo.winding_resistance,
    )
    np.testing.assert_allclose(
        terms["copper"], r * np.array([(2 / (kn * eta)) ** 2, (2 * eta / kn) ** 2, 0.0])
    )
    # Driving: the shaft takes tau qdot / eta; back-driven work is lost; a dry joint takes none.
    np.testing.assert_allclose(terms["shaft"], [6.0 / eta, 0.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(terms["standby"], np.full(3, 0.040 * 14.8))
    np.testing.assert_allclose(
        sum(terms.values()), servo_electrical_power(tau, qdot, servo), rtol=1e-12
    )


def test_back_driven_work_is_lost_unless_recovered(servo):
    tau, qdot = 2.0, -3.0  # the load drives the motor: negative work
    eta, kn, r = (
        servo.gearbox_efficiency,
        servo.torque_constant * servo.gear_ratio,
        servo.winding_resistance,
    )
    i = tau * eta / kn
    assert motor_current(tau, qdot, servo) == pytest.approx(i, rel=1e-12)
    lost = servo_electrical_power(tau, qdot, servo)
    assert lost == pytest.approx(r * i**2 + servo.standby_power, rel=1e-12)
    recovering = dc.replace(servo, recover_negative_work=True)
    back = servo_electrical_power(tau, qdot, recovering)
    assert back == pytest.approx(r * i**2 + tau * qdot * eta + servo.standby_power, rel=1e-12)
    assert back < servo.standby_power  # the battery gets some of it back


def test_back_driving_sets_in_over_backdrive_speed(servo):
    assert servo.backdrive_speed == 0.1
    tau, kn, eta = 2.0, servo.torque_constant * servo.gear_ratio, servo.gearbox_efficiency
    # Creeping backwards at rest (1e-3 rad/s) still draws about the holding current ...
    assert motor_current(tau, -1e-3, servo) == pytest.approx(tau / (kn * eta), rel=3e-3)
    # ... halfway up the ramp eta^0, and from backdrive_speed on the back-driven current.
    assert motor_current(tau, -0.05, servo) == pytest.approx(tau / kn, rel=1e-12)
    assert motor_current(tau, -0.1, servo) == pytest.approx(tau * eta / kn, rel=1e-12)
    assert motor_current(-tau, 0.3, servo) == pytest.approx(-tau * eta / kn, rel=1e-12)
    # Driving forwards is never back-driven, however fast.
    assert motor_current(tau, 5.0, servo) == pytest.approx(tau / (kn * eta), rel=1e-12)
    # Continuous through rest (the sharp switch jumps by eta^-2 in current).
    near = motor_current(tau, np.array([-1e-9, 1e-9]), servo)
    assert near[0] == pytest.approx(near[1], rel=1e-6)
    sharp = dc.replace(servo, backdrive_speed=0.0)
    assert motor_current(tau, -1e-9, sharp) == pytest.approx(tau * eta / kn, rel=1e-12)


def test_shapes_and_total(servo, rng):
    tau, qdot = rng.normal(0, 2, (50, NUM_JOINTS)), rng.normal(0, 3, (50, NUM_JOINTS))
    assert servo_electrical_power(tau, qdot, servo).shape == (50, NUM_JOINTS)
    np.testing.assert_array_equal(joint_mechanical_power(tau, qdot), tau * qdot)
    total = total_electrical_power(tau[0], qdot[0], servo, 11.0)
    assert total == pytest.approx(
        np.sum(servo_electrical_power(tau[0], qdot[0], servo)) + 11.0, rel=1e-12
    )


@pytest.mark.parametrize("recover, backdrive_speed", [(False, 0.1), (True, 0.1), (False, 0.0)])
def test_compiled_total_equals_the_reference(servo, rng, recover, backdrive_speed):
    s = dc.replace(servo, recover_negative_work=recover, backdrive_speed=backdrive_speed)
    for _ in range(200):
        tau, qdot = rng.normal(0, 3, NUM_JOINTS), rng.normal(0, 4, NUM_JOINTS)
        qdot[rng.random(NUM_JOINTS) < 0.3] *= 0.02  # inside the back-driving ramp
        tau[rng.random(NUM_JOINTS) < 0.2] = 0.0
        qdot[rng.random(NUM_JOINTS) < 0.2] = 0.0
        compiled = total_electrical_power_kernel(
            tau,
            qdot,
            s.gear_ratio,
            s.gearbox_efficiency,
            s.torque_constant,
            s.winding_resistance,
            s.standby_power,
            s.recover_negative_work,
            s.backdrive_speed,
            11.0,
        )
        assert compiled == pytest.approx(total_electrical_power(tau, qdot, s, 11.0), rel=1e-12)


# --- the System --------------------------------------------------------------------------------


def _evaluated(servo, tau, qdot, electronics=11.0):
    system = ServoPower(servo, electronics, NUM_JOINTS)
    context = system.CreateDefaultContext()
    system.GetInputPort("joint_torque").FixValue(context, tau)
    system.GetInputPort("measured_joint_state").FixValue(
        context, np.concatenate([np.full(NUM_JOINTS, 0.3), qdot])
    )  # angles do not matter
    return {
        name: system.GetOutputPort(name).Eval(context)
        for name in ("electrical_power", "servo_power", "joint_mechanical_power")
    }


def test_system_dry_joints_draw_standby_and_electronics(servo):
    out = _evaluated(servo, np.zeros(NUM_JOINTS), np.linspace(-5, 5, NUM_JOINTS))
    assert out["electrical_power"][0] == pytest.approx(NUM_JOINTS * 0.040 * 14.8 + 11.0, rel=1e-12)
    np.testing.assert_array_equal(out["joint_mechanical_power"], 0.0)


def test_system_holding_torque_closed_form(servo):
    tau = np.linspace(-3.0, 3.0, NUM_JOINTS)
    out = _evaluated(servo, tau, np.zeros(NUM_JOINTS))
    copper = servo.winding_resistance * _i_drive(tau, servo) ** 2
    assert out["electrical_power"][0] == pytest.approx(
        copper.sum() + NUM_JOINTS * servo.standby_power + 11.0, rel=1e-12
    )
    np.testing.assert_allclose(out["servo_power"], copper + servo.standby_power, rtol=1e-12)


def test_system_reads_rates_not_angles(servo):
    tau, qdot = np.full(NUM_JOINTS, 1.5), np.linspace(-2, 2, NUM_JOINTS)
    out = _evaluated(servo, tau, qdot)
    np.testing.assert_allclose(out["joint_mechanical_power"], tau * qdot, rtol=1e-15)
    np.testing.assert_allclose(
        out["servo_power"], servo_electrical_power(tau, qdot, servo), rtol=1e-12
    )


def test_system_bad_parameters(servo):
    with pytest.raises(ValueError, match="gearbox_efficiency"):
        ServoPower(dc.replace(servo, gearbox_efficiency=1.5), 11.0, NUM_JOINTS)
    with pytest.raises(ValueError, match="winding_resistance"):
        ServoPower(dc.replace(servo, winding_resistance=-1.0), 11.0, NUM_JOINTS)
    with pytest.raises(ValueError, match="electronics_power"):
        ServoPower(servo, float("nan"), NUM_JOINTS)
