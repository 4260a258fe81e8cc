"""PressureSensor: depth of the head, noise and dropout from Drake RandomSources."""

import numpy as np
import pytest
from pydrake.common import RandomDistribution, RandomGenerator
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer, RandomSource

from manta_drake.model.plant import add_plant, body_pose
from manta_drake.station.pressure import PressureSensor, pressure_depth_sample

PERIOD = 0.02
X_WB = body_pose([0, 0, -0.3], [0, 20, 0])  # pitched 20 deg nose-down (+pitch about y)


def _samples(noise_std, dropout, seed, n=200):
    """n readings of a sensor on a robot welded at X_WB, noise drawn from ``seed``."""
    builder = DiagramBuilder()
    h = add_plant(builder, time_step=PERIOD, with_pool=False, weld_body=X_WB)
    sensor = builder.AddSystem(
        PressureSensor(h.plant, h.body, [0.19, 0.0, 0.03], PERIOD, noise_std, dropout)
    )
    builder.Connect(h.plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    mux = builder.AddSystem(Multiplexer([1, 1]))
    for i, dist in enumerate((RandomDistribution.kGaussian, RandomDistribution.kUniform)):
        source = builder.AddSystem(RandomSource(dist, 1, PERIOD))
        builder.Connect(source.get_output_port(), mux.get_input_port(i))
    builder.Connect(mux.get_output_port(), sensor.GetInputPort("noise"))
    logger = LogVectorOutput(sensor.GetOutputPort("depth"), builder, PERIOD)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    diagram.SetRandomContext(simulator.get_mutable_context(), RandomGenerator(seed))
    simulator.AdvanceTo(n * PERIOD)
    context = simulator.get_context()
    values = logger.FindLog(context).data()[0, 2:]  # from the second sample on: noisy
    return values, sensor.true_depth(sensor.GetMyContextFromRoot(context))


def test_noiseless_depth_is_the_head_depth():
    values, true = _samples(0.0, 0.0, 0, n=10)
    p = np.radians(20)
    expected = 0.3 - (-0.19 * np.sin(p) + 0.03 * np.cos(p))
    assert true == pytest.approx(expected, abs=1e-12)
    np.testing.assert_allclose(values, expected, atol=1e-12)


def test_noise_statistics_and_reproducibility():
    a, true = _samples(0.01, 0.0, seed=7)
    b, _ = _samples(0.01, 0.0, seed=7)
    c, _ = _samples(0.01, 0.0, seed=8)
    np.testing.assert_array_equal(a, b)  # same seed, same run
    assert not np.array_equal(a, c)  # another seed, other noise
    assert np.mean(a - true) == pytest.approx(0.0, abs=4 * 0.01 / np.sqrt(len(a)))
    assert np.std(a - true) == pytest.approx(0.01, rel=0.2)


def test_dropout_gives_nan_at_the_rate():
    values, _ = _samples(0.0, 0.25, seed=3, n=800)
    assert np.isnan(values).mean() == pytest.approx(0.25, abs=0.05)


def test_sample_function():
    assert pressure_depth_sample(0.3, 0.01, 0.1, 2.0, 0.5) == pytest.approx(0.32)
    assert np.isnan(pressure_depth_sample(0.3, 0.01, 0.1, 2.0, 0.05))
    assert pressure_depth_sample(0.3, 0.0, 0.0, 5.0, 0.0) == 0.3


def test_bad_parameters():
    builder = DiagramBuilder()
    h = add_plant(builder)
    with pytest.raises(ValueError, match="dropout_rate"):
        PressureSensor(h.plant, h.body, [0, 0, 0], 0.02, 0.0, 1.5)
    with pytest.raises(ValueError, match="period"):
        PressureSensor(h.plant, h.body, [0, 0, 0], 0.0)
