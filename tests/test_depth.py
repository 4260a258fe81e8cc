"""FuzzyDepthEstimator and its membership functions (Eq. 9)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from manta_drake.control.depth import (
    FuzzyDepthEstimator,
    fuzzy_depth,
    layer_centres,
    memberships,
)

D = 0.25


def test_membership_shapes():
    mu = memberships([0.0, D / 6, D / 3, D / 2, 2 * D / 3, 5 * D / 6, D], D)
    np.testing.assert_allclose(mu[:, 0], [1, 1, 0.5, 0, 0, 0, 0])  # trapezoid (surface)
    np.testing.assert_allclose(mu[:, 1], [0, 0, 0.5, 1, 0.5, 0, 0])  # triangle (mid)
    np.testing.assert_allclose(mu[:, 2], [0, 0, 0, 0, 0.5, 1, 1])  # trapezoid (deep)
    # the layers are evenly divided: each membership peaks in its own third
    h = np.linspace(0, D, 3001)
    peaks = [
        h[np.argmax(memberships(h, D)[:, i] - 1e-9 * np.abs(h - c))]
        for i, c in enumerate((D / 6, D / 2, 5 * D / 6))
    ]
    assert D / 6 <= peaks[0] + 1e-9 and abs(peaks[1] - D / 2) < 1e-3
    assert peaks[2] >= 5 * D / 6 - 1e-9


def test_partition_of_unity_where_layers_overlap():
    h = np.linspace(0, D, 1001)
    np.testing.assert_allclose(memberships(h, D).sum(axis=1), 1.0, atol=1e-12)


def test_centroid_equals_the_closed_form(rng):
    """Worked by hand from the membership shapes (not through ``memberships``): with
    x = h / D, on [1/6, 1/2] only surface = 3 (1/2 - x) and mid = 1 - surface are non-zero
    and the centroid is mid * D/2; on [1/2, 5/6] mid = 1 - 3 (x - 1/2), deep = 3 (x - 1/2)
    and the centroid is mid D/2 + deep D. Both give z_hat = 1.5 x - 0.25, so
    z_hat = clip(1.5 x - 0.25, 0, 1) on all of [0, D]."""
    h = np.concatenate([rng.uniform(0, D, 200), [0, D / 6, D / 3, D / 2, 2 * D / 3, 5 * D / 6, D]])
    h_hat, z_hat = fuzzy_depth(h, D)
    expected = np.clip(1.5 * h / D - 0.25, 0.0, 1.0)
    np.testing.assert_allclose(z_hat, expected, atol=1e-12)
    np.testing.assert_allclose(h_hat, expected * D, atol=1e-12)
    np.testing.assert_array_equal(layer_centres(D), [0, D / 2, D])


def test_depth_counted_from_the_surface_float():
    """With surface_depth h_s the closed form becomes z_hat = clip(1.5 (h - h_s) / (D - h_s)
    - 0.25, 0, 1): 0 while floating at the surface, 1 on the floor, and h_hat an absolute
    depth in [h_s, D]."""
    hs = 0.03
    h = np.linspace(-0.05, D + 0.05, 2001)
    h_hat, z_hat = fuzzy_depth(h, D, hs)
    expected = np.clip(1.5 * (h - hs) / (D - hs) - 0.25, 0.0, 1.0)
    np.testing.assert_allclose(z_hat, expected, atol=1e-12)
    np.testing.assert_allclose(h_hat, hs + expected * (D - hs), atol=1e-12)
    # A robot bobbing 2.5 cm about its float reads the surface, without the offset it did not.
    assert fuzzy_depth(hs + 0.025, D, hs)[1] == 0.0 and fuzzy_depth(hs + 0.025, D)[1] > 0.05
    with pytest.raises(ValueError, match="surface_depth: 0.3 is outside the allowed range"):
        FuzzyDepthEstimator(D, 0.02, surface_depth=0.3)


@pytest.mark.slow
def test_default_surface_depth_is_the_sensors_depth_floating_at_rest(tmp_path):
    """The default surface_depth is what the pressure sensor reads (noise-free mean) with the
    robot floating at rest at the surface, balloon full (float_sink before it deflates)."""
    from manta_drake.scenario import Scenario, load_scenario
    from manta_drake.simulate import run

    s = load_scenario("float_sink", {"duration": 4.5})
    s.visualization.meshcat = False
    s.pressure_sensor.noise_std = 0.0
    log = run(s.validate(), tmp_path, progress=False, write_outputs=False).log
    at_rest = log["t_depth"] > 1.5
    assert np.nanmean(log["depth"][at_rest, 0]) == pytest.approx(
        Scenario().depth_estimator.surface_depth, abs=0.002
    )


def test_z_hat_spans_0_to_1_continuous_and_monotone():
    h = np.linspace(-0.1, D + 0.1, 20001)
    _, z = fuzzy_depth(h, D)
    assert z[0] == 0.0 and z[-1] == 1.0  # and out of range clamps
    assert fuzzy_depth(0.0, D)[1] == 0.0 and fuzzy_depth(D, D)[1] == 1.0
    assert np.all(np.diff(z) >= 0)  # monotone
    assert np.abs(np.diff(z)).max() < 1e-3  # continuous on a fine grid
    assert fuzzy_depth(D / 2, D)[1] == pytest.approx(0.5)


@given(st.floats(0.01, 10.0), st.floats(-5.0, 15.0))
def test_estimate_stays_in_range_for_any_depth(D_, h):
    h_hat, z_hat = fuzzy_depth(h, D_)
    assert 0.0 <= z_hat <= 1.0 and 0.0 <= h_hat <= D_ + 1e-12


def _step(system, context, depth):
    system.GetInputPort("depth").FixValue(context, [depth])
    context.SetDiscreteState(
        system.EvalUniquePeriodicDiscreteUpdate(context).get_vector().CopyToVector()
    )
    return (
        system.GetOutputPort("h_hat").Eval(context)[0],
        system.GetOutputPort("z_hat").Eval(context)[0],
    )


def test_system_holds_last_valid_estimate_on_nan_and_clamps():
    system = FuzzyDepthEstimator(D, period=0.02)
    context = system.CreateDefaultContext()
    h_hat, z_hat = _step(system, context, 0.15)
    assert z_hat == pytest.approx(fuzzy_depth(0.15, D)[1])
    assert _step(system, context, np.nan) == (h_hat, z_hat)  # held
    assert _step(system, context, np.inf) == (h_hat, z_hat)
    assert _step(system, context, 3.0)[1] == 1.0  # below the floor: clamps
    assert _step(system, context, -0.3)[1] == 0.0  # above the surface: clamps


def test_floor_distance_must_be_positive():
    with pytest.raises(ValueError, match="floor_distance"):
        FuzzyDepthEstimator(0.0, 0.02)
    with pytest.raises(ValueError, match="floor_distance"):
        FuzzyDepthEstimator(-1.0, 0.02)
