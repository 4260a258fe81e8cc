"""BalloonBuoyancy: pump-rate-limited volume toward the command."""

import numpy as np
import pytest

from manta_drake.station.buoyancy import BalloonBuoyancy, pump_step


def test_volume_ramps_at_the_pump_rate_and_stops_at_the_command():
    system = BalloonBuoyancy(max_volume=2.5e-3, pump_rate=3e-4, period=1e-3)
    context = system.CreateDefaultContext()
    system.GetInputPort("volume_command").FixValue(context, [2.0e-3])
    volumes = []
    for _ in range(10_000):
        state = system.EvalUniquePeriodicDiscreteUpdate(context)
        context.SetDiscreteState(state.get_vector().CopyToVector())
        volumes.append(system.GetOutputPort("balloon_volume").Eval(context)[0])
    volumes = np.array(volumes)
    t = np.arange(1, 10_001) * 1e-3
    ramp = t < 2.0e-3 / 3e-4 - 0.01
    np.testing.assert_allclose(volumes[ramp], 3e-4 * t[ramp], rtol=1e-9)  # rate-limited
    assert volumes[-1] == pytest.approx(2.0e-3)  # reaches the command, no overshoot
    assert volumes.max() <= 2.0e-3 + 1e-15


def test_command_is_clipped_and_nan_holds():
    assert pump_step(1e-3, 5e-3, 2.5e-3, 1.0, 1.0) == pytest.approx(2.5e-3)
    assert pump_step(1e-3, -1.0, 2.5e-3, 1.0, 1.0) == 0.0
    assert pump_step(1e-3, np.nan, 2.5e-3, 1.0, 1.0) == 1e-3
    assert pump_step(1e-3, 0.0, 2.5e-3, 2e-4, 1e-3) == pytest.approx(1e-3 - 2e-7)


def test_bad_parameters_are_rejected():
    with pytest.raises(ValueError, match="pump_rate"):
        BalloonBuoyancy(2.5e-3, 0.0, 1e-3)
    with pytest.raises(ValueError, match="initial_volume"):
        BalloonBuoyancy(2.5e-3, 1e-4, 1e-3, initial_volume=3e-3)
