"""The energy model in the whole diagram: with the ideal servo it changes no force (with
the datasheet servo the battery's voltage drives the servos: tests/test_servo.py and
tests/test_joint_torque.py), its battery counts the current, a standing robot draws its
holding current, and every kind of shipped scenario gets a consistent ``energy`` block in
its metrics."""

import numpy as np
import pytest

from manta_drake import simulate
from manta_drake.metrics import COT_KEYS, MIN_TRANSPORT_SPEED, STANDARD_GRAVITY
from manta_drake.model.actuators import load_energy_model
from manta_drake.model.robot_params import DEFAULT_ROBOT, NUM_JOINTS
from manta_drake.scenario import load_scenario
from manta_drake.station.servo_power import motor_current
from manta_drake.station.water import build_elements

ENERGY_KEYS = (
    "mechanical_energy_j",
    "electrical_energy_j",
    "mean_electrical_power_w",
    "hotel_power_w",
    "dry_weight_n",
    "weight_in_water_n",
    *COT_KEYS,
    "battery_soc_end",
    "operation_time_h",
)
MODEL = load_energy_model("package://manta_drake/actuators.yaml")
IDLE_W = NUM_JOINTS * MODEL.servo.standby_power + MODEL.electronics_power


def _run(tmp_path, name, duration, **overrides):
    scenario = load_scenario(
        name, overrides={"duration": duration, "visualization.meshcat": False, **overrides}
    )
    folder = tmp_path / f"{name}_{len(overrides)}"
    return scenario, simulate.run(scenario, folder, progress=False, write_outputs=False)


@pytest.fixture(scope="module")
def trot_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("trot")
    return {
        on: _run(
            tmp,
            "locomotion_trot",
            2.0,
            **{"actuators.enabled": on, "actuators.servo_model": "ideal"},
        )
        for on in (True, False)
    }


@pytest.mark.slow
def test_with_the_ideal_servo_the_energy_model_changes_no_force(trot_runs):
    with_model, without = trot_runs[True][1], trot_runs[False][1]
    shared = set(without.log) & set(with_model.log)
    assert {"joint_angles", "body_xyz", "joint_torque", "body_quat_wxyz"} <= shared
    for key in shared:
        np.testing.assert_array_equal(with_model.log[key], without.log[key], err_msg=key)
    assert "electrical_power" in with_model.log and "electrical_power" not in without.log
    # Every existing metric is the same (the wall clock aside, and the envelope, measured at
    # the battery's voltage when there is one); only the energy blocks are new.
    clock = {"wall_time_s", "real_time_factor", "actuator_envelope"}
    new = {"energy", "power_breakdown"}
    a = {k: v for k, v in with_model.metrics.items() if k not in clock | new}
    b = {k: v for k, v in without.metrics.items() if k not in clock}
    assert a == b
    assert new <= set(with_model.metrics) and not new & set(without.metrics)


@pytest.mark.slow
def test_the_battery_counts_the_logged_current(trot_runs):
    log = trot_runs[True][1].log
    soc, volts, amps = np.asarray(log["battery"]).T
    dt = np.diff(log["t_battery"])
    assert np.allclose(dt, 1e-3, rtol=0, atol=1e-12)  # one sample per plant step
    per_coulomb = 1e-3 / (3600.0 * MODEL.pack.capacity_ah)
    # Each sample holds the charge now and the current of the step that ended there.
    expected = np.empty_like(soc)
    expected[0] = 1.0
    for k in range(1, len(soc)):
        expected[k] = expected[k - 1] - amps[k] * per_coulomb
    np.testing.assert_array_equal(soc, expected)
    # P = V I of every step, the power the servo model logged at its start.
    np.testing.assert_allclose(volts[1:] * amps[1:], log["electrical_power"][:-1, 0], rtol=1e-12)
    assert amps[0] == 0.0 and volts[0] == pytest.approx(MODEL.pack.open_circuit_voltage(1.0))


@pytest.mark.slow
def test_mechanical_power_is_the_work_of_each_plant_step(trot_runs):
    log = trot_runs[True][1].log
    tau, v, p = log["joint_torque"], log["joint_velocities"], log["joint_mechanical_power"]
    q = log["joint_angles"]
    # The station's joint_torque at t_k is the torque of the step that ended at t_k (the
    # implicit PD at that step's end, held, less the servo's braking at the same rate): it
    # meets the rate at the end of its step.
    np.testing.assert_array_equal(p[0], 0.0)
    np.testing.assert_array_equal(tau[0], 0.0)  # no step taken yet
    np.testing.assert_allclose(p[1:], tau[1:] * v[1:], rtol=1e-15, atol=0)
    # So p dt sums to the work tau . (q_k+1 - q_k) of the plant's symplectic steps.
    work = np.sum(tau[1:] * (q[1:] - q[:-1]))
    assert np.sum(p[1:]) * 1e-3 == pytest.approx(work, rel=1e-9)


@pytest.mark.slow
def test_standing_draws_the_holding_current(tmp_path):
    _, result = _run(tmp_path, "stand", 1.7)
    log = result.log
    rest = log["t"] >= 1.5
    assert np.abs(log["joint_velocities"][rest]).max() < 5e-3  # standing still
    power = log["electrical_power"][rest, 0]
    held = log["joint_torque"][rest]  # each step's torque, logged at the step's end
    copper = MODEL.servo.winding_resistance * motor_current(held, 0.0, MODEL.servo) ** 2
    # At rest: the stall closed form R i^2 + standby per servo, plus the computers (within
    # 1 %: the stance still creeps at up to 5e-3 rad/s, a few per cent of backdrive_speed).
    np.testing.assert_allclose(power, copper.sum(axis=1) + IDLE_W, rtol=1e-2)
    assert power.min() > IDLE_W + 3.0  # holding the stance costs watts over idling
    # Before the first step no torque has been applied: exactly the idle draw.
    assert log["electrical_power"][0, 0] == pytest.approx(IDLE_W, rel=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize(
    "name, duration",
    [("stand", 2.5), ("float_sink", 1.0), ("locomotion_swim", 2.5), ("two_behaviors", 1.0)],
)
def test_energy_block_of_each_kind_of_scenario(tmp_path, name, duration):
    scenario, result = _run(tmp_path, name, duration)
    e, log = result.metrics["energy"], result.log
    assert set(ENERGY_KEYS) <= set(e)
    t, p = log["t_electrical_power"], log["electrical_power"][:, 0]
    assert t[-1] == pytest.approx(duration)
    energy = np.sum(p[1:] * np.diff(t))
    assert e["electrical_energy_j"] == pytest.approx(energy, rel=1e-12)
    assert e["mean_electrical_power_w"] == pytest.approx(energy / duration, rel=1e-12)
    assert e["operation_time_h"] == pytest.approx(
        MODEL.pack.usable_energy_wh() / e["mean_electrical_power_w"], rel=1e-12
    )
    mech = np.abs(log["joint_mechanical_power"])
    assert e["mechanical_energy_j"] == pytest.approx(
        np.sum(mech[1:].sum(1) * np.diff(t)), rel=1e-12
    )
    # Idle draw plus the copper losses and the motors' share: above idle, and above the
    # positive work done (no servo converts better than its motor and gearbox).
    positive = np.sum(np.maximum(log["joint_mechanical_power"][1:], 0).sum(1) * np.diff(t))
    assert energy - IDLE_W * duration > positive > 0
    soc = log["battery"][:, 0]
    assert e["battery_soc_end"] == soc[-1]
    drawn = np.sum(log["battery"][1:, 2]) * 1e-3 / 3600.0  # each step's current, at its end
    assert 1.0 - soc[-1] == pytest.approx(drawn / MODEL.pack.capacity_ah, rel=1e-9)
    assert e["hotel_power_w"] == pytest.approx(IDLE_W, rel=1e-12)
    weight = DEFAULT_ROBOT.total_mass * STANDARD_GRAVITY
    assert e["dry_weight_n"] == pytest.approx(weight) and DEFAULT_ROBOT.total_mass == 8.4
    # The weight in water: the mass less the water the sealed volumes displace, balloon empty.
    coeffs, wet = scenario.hydro_coefficients(), None
    if coeffs is None:  # a dry run has no weight in water
        assert e["weight_in_water_n"] is None
    else:
        sealed = build_elements(coeffs, scenario.robot_params())["volume"].sum()
        wet = (DEFAULT_ROBOT.total_mass - coeffs.water_density.value * sealed) * STANDARD_GRAVITY
        assert e["weight_in_water_n"] == pytest.approx(wet, rel=1e-12) and 0 < wet < 0.2 * weight
    speed = e["transport_speed_m_s"]
    if speed is not None and speed >= MIN_TRANSPORT_SPEED:
        p_el, p_mech = e["steady_electrical_power_w"], e["steady_mechanical_power_w"]
        for w_name, w in (("dry_weight", weight), ("weight_in_water", wet)):
            for p_name, p_w in (
                ("electrical", p_el),
                ("net_of_hotel", p_el - IDLE_W),
                ("mechanical", p_mech),
            ):
                expected = None if w is None else pytest.approx(p_w / (w * speed), rel=1e-12)
                assert e[f"cot_{p_name}_{w_name}"] == expected
        assert speed == pytest.approx(np.hypot(*result.metrics["mean_velocity_body"]))
    else:
        assert all(e[k] is None for k in COT_KEYS)
        assert e["cost_of_transport_note"]
    if name == "locomotion_swim":  # it travels: a cost of transport is reported
        assert (
            e["cot_electrical_dry_weight"]
            > e["cot_net_of_hotel_dry_weight"]
            > e["cot_mechanical_dry_weight"]
            > 0
        )
    if name == "stand":  # it does not
        assert e["cot_electrical_dry_weight"] is None and "below" in e["cost_of_transport_note"]
    # The breakdown adds up to what the energy model drew over the same window (the log is
    # at the plant's step), every servo term recomputed here from the logged torques.
    b = result.metrics["power_breakdown"]
    assert b["total_w"] == pytest.approx(b["electrical_w"], rel=1e-9)
    assert b["computers_w"] == pytest.approx(MODEL.electronics_power)
    assert b["standby_w"] == pytest.approx(NUM_JOINTS * MODEL.servo.standby_power)
    assert b["copper_w"] > 0 and b["shaft_w"] >= 0
