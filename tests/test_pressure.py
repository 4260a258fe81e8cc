"""PressureSensor: depth of the head, seeded noise and dropout."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder

from manta_drake.plant import add_plant, body_pose, set_initial_state
from manta_drake.pressure import PressureSensor


def _samples(noise_std, dropout, seed, z=-0.3, n=400):
    builder = DiagramBuilder()
    h = add_plant(builder)
    sensor = builder.AddSystem(PressureSensor(h.plant, h.body, [0.19, 0.0, 0.03], 0.02,
                                              noise_std, dropout, seed))
    builder.Connect(h.plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    set_initial_state(h, h.plant.GetMyMutableContextFromRoot(context),
                      body_pose([0, 0, z], [0, 20, 0]), np.zeros(16))
    sc = sensor.GetMyMutableContextFromRoot(context)
    out = []
    for _ in range(n):
        sc.SetDiscreteState(sensor.EvalUniquePeriodicDiscreteUpdate(sc).get_vector().CopyToVector())
        out.append(sensor.GetOutputPort("depth").Eval(sc)[0])
    return np.array(out), sensor.true_depth(sc)


def test_noiseless_depth_is_the_head_depth():
    values, true = _samples(0.0, 0.0, 0)
    # head at (0.19, 0, 0.03) in a body pitched 20 deg nose-down (+pitch about y) at z = -0.3
    p = np.radians(20)
    expected = 0.3 - (-0.19 * np.sin(p) + 0.03 * np.cos(p))
    assert true == pytest.approx(expected, abs=1e-12)
    np.testing.assert_allclose(values, expected)


def test_noise_statistics_and_reproducibility():
    a, true = _samples(0.01, 0.0, seed=7)
    b, _ = _samples(0.01, 0.0, seed=7)
    c, _ = _samples(0.01, 0.0, seed=8)
    np.testing.assert_array_equal(a, b)  # same seed, same run
    assert not np.array_equal(a, c)
    assert np.mean(a - true) == pytest.approx(0.0, abs=3 * 0.01 / np.sqrt(len(a)))
    assert np.std(a - true) == pytest.approx(0.01, rel=0.15)


def test_dropout_gives_nan_at_the_rate():
    values, _ = _samples(0.0, 0.25, seed=3, n=800)
    assert np.isnan(values).mean() == pytest.approx(0.25, abs=0.05)


def test_bad_parameters():
    builder = DiagramBuilder()
    h = add_plant(builder)
    with pytest.raises(ValueError, match="dropout_rate"):
        PressureSensor(h.plant, h.body, [0, 0, 0], 0.02, 0.0, 1.5)
    with pytest.raises(ValueError, match="period"):
        PressureSensor(h.plant, h.body, [0, 0, 0], 0.0)
