"""The altimeter: the first echo's range against its closed form, in the real plant's scene
(the range is the transducer's height above the pool's floor within the beam, and grows
as 1 / cos beyond it), and its noise and dropouts."""

import math

import numpy as np
import pytest
from pydrake.common import RandomGenerator
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from manta_drake.model.plant import add_plant
from manta_drake.station.altimeter import (
    Altimeter,
    AltimeterParams,
    add_altimeter,
    altimeter_sample,
    echo_range,
)

# The top of the pool's floor (models/pool.sdf: a 0.1 m box centred at z = -0.55).
FLOOR_Z = -0.5
P_BS = np.array([0.03, -0.02, -0.08])  # a transducer off the hull's centre line


def test_echo_range_is_the_distance_within_the_beam_and_grows_as_one_over_cos_beyond():
    beta = math.radians(15.0)
    assert echo_range(0.3, 0.0, beta) == 0.3
    assert echo_range(0.3, beta, beta) == 0.3  # the beam's edge still sees the normal
    for theta_deg in (20.0, 40.0, 80.0):
        theta = math.radians(theta_deg)
        assert echo_range(0.3, theta, beta) == pytest.approx(0.3 / math.cos(theta - beta))
    assert echo_range(0.3, beta + math.pi / 2, beta) == math.inf  # no ray meets the plane
    assert echo_range(0.3, math.pi, 0.0) == math.inf  # looking straight up
    # A 20 deg pitch with the 15 deg half-beam reads 0.4 % long (the module's claim).
    assert echo_range(1.0, math.radians(20.0), beta) == pytest.approx(1.0038, abs=1e-4)


def test_a_sample_is_nan_on_a_dropout_or_out_of_range_else_the_range_plus_noise():
    p = AltimeterParams(min_range=0.1, max_range=2.0, noise_std=0.01, dropout_rate=0.25)
    assert altimeter_sample(0.5, p, 1.5, 0.3) == pytest.approx(0.515)
    assert math.isnan(altimeter_sample(0.5, p, 0.0, 0.2))  # u < dropout_rate
    assert math.isnan(altimeter_sample(0.05, p, 0.0, 0.9))  # inside the blanking distance
    assert math.isnan(altimeter_sample(2.5, p, 0.0, 0.9))  # beyond max_range
    assert math.isnan(altimeter_sample(math.inf, p, 0.0, 0.9))  # no echo
    assert altimeter_sample(2.0, p, 0.0, 0.9) == 2.0  # the range's ends are readings


@pytest.mark.parametrize(
    "field, value, allowed",
    [
        ("rate_hz", 0.0, r"\(0, 100\] Hz"),
        ("beam_half_angle_deg", 70.0, r"\[0, 60\] deg"),
        ("max_range", 150.0, r"\(0, 100\] m"),
        ("min_range", 6.0, r"\[0, max_range = 5\) m"),
        ("noise_std", -0.1, r"\[0, 0.5\] m"),
        ("dropout_rate", 1.5, r"\[0, 1\]"),
    ],
)
def test_bad_parameters_name_the_field_and_the_range(field, value, allowed):
    with pytest.raises(ValueError, match=rf"altimeter\.{field}.*{allowed}"):
        AltimeterParams(**{field: value}).validate()
    with pytest.raises(ValueError, match=r"altimeter\.position"):
        AltimeterParams(position=[0.0, 0.0]).validate()


def _welded(xyz, rpy_deg, **params):
    """The robot welded at a pose over the real pool, with an altimeter at P_BS."""
    builder = DiagramBuilder()
    X_WB = RigidTransform(RollPitchYaw(np.radians(rpy_deg)), xyz)
    handles = add_plant(builder, weld_body=X_WB)
    sensor = add_altimeter(
        builder, handles, AltimeterParams(enabled=True, position=list(P_BS), **params)
    )
    diagram = builder.Build()
    return diagram, sensor, X_WB


def _height(X_WB) -> float:
    return float((X_WB @ P_BS)[2] - FLOOR_Z)


@pytest.mark.parametrize("rpy_deg", [(0, 0, 0), (0, 10, 30), (-12, 0, 0), (8, -9, 0)])
def test_within_the_beam_the_range_is_the_transducers_height_above_the_floor(rpy_deg):
    diagram, sensor, X_WB = _welded([1.0, 0.3, -0.22], rpy_deg)
    simulator = Simulator(diagram)
    simulator.Initialize()  # the first reading: the start pose's, noiseless
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    assert sensor.true_range(context) == pytest.approx(_height(X_WB), abs=1e-9)
    assert sensor.GetOutputPort("altitude").Eval(context)[0] == sensor.true_range(context)
    assert sensor.GetOutputPort("altitude_true").Eval(context)[0] == sensor.true_range(context)


@pytest.mark.parametrize("rpy_deg", [(0, 25, 0), (0, -40, 90), (30, 0, 0)])
def test_beyond_the_beam_the_range_is_the_height_over_cos_of_the_excess_tilt(rpy_deg):
    diagram, sensor, X_WB = _welded([-2.0, 0.0, -0.25], rpy_deg)
    context = sensor.GetMyContextFromRoot(diagram.CreateDefaultContext())
    tilt = math.acos(X_WB.rotation().matrix()[2, 2])  # body z from the vertical
    expected = _height(X_WB) / math.cos(tilt - math.radians(15.0))
    assert sensor.true_range(context) == pytest.approx(expected, rel=1e-9)
    assert expected > _height(X_WB) * 1.01


def test_beyond_max_range_there_is_no_echo_and_the_reading_is_nan():
    diagram, sensor, _ = _welded([0.0, 0.0, -0.1], (0, 0, 0), max_range=0.3)
    simulator = Simulator(diagram)
    simulator.Initialize()
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    assert sensor.true_range(context) == math.inf  # 0.48 m down, 0.3 m of range
    assert math.isnan(sensor.GetOutputPort("altitude").Eval(context)[0])
    assert sensor.GetOutputPort("altitude_true").Eval(context)[0] == math.inf


@pytest.mark.slow
def test_readings_scatter_by_noise_std_and_drop_out_at_dropout_rate():
    """200 pings at a fixed pose: the mean is the height within 4 standard errors, the
    spread is noise_std within 15 %, and the share of NaN is within 4 binomial sigmas."""
    std, rate = 0.01, 0.3
    diagram, sensor, X_WB = _welded([0.5, -0.2, -0.2], (0, 5, 0), noise_std=std, dropout_rate=rate)
    simulator = Simulator(diagram)
    diagram.SetRandomContext(simulator.get_mutable_context(), RandomGenerator(7))
    context = sensor.GetMyContextFromRoot(simulator.get_context())
    readings = []
    for k in range(1, 201):
        simulator.AdvanceTo(k * sensor.period + 1e-6)
        readings.append(sensor.GetOutputPort("altitude").Eval(context)[0])
    readings = np.array(readings)
    missing = np.isnan(readings)
    n = readings.size
    assert abs(missing.mean() - rate) < 4.0 * math.sqrt(rate * (1 - rate) / n)
    valid = readings[~missing]
    assert abs(valid.mean() - _height(X_WB)) < 4.0 * std / math.sqrt(valid.size)
    assert valid.std(ddof=1) == pytest.approx(std, rel=0.15)


def test_the_sensor_needs_a_floor_to_look_at():
    with pytest.raises(ValueError, match="Altimeter.floor_ids"):
        Altimeter(None, [], AltimeterParams())
