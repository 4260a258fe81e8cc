"""The released-robot measurement of the simulator's effective inertia in water."""

import numpy as np
import pytest

from manta_drake.model.added_mass import fin_plates, plate_added_mass
from manta_drake.model.coefficients import load_coefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS
from manta_drake.studies.validation import released as R


def test_fit_recovers_a_motion_from_rest():
    t = np.linspace(0.0, 0.03, 31)
    assert R.fit_acceleration(t, -0.25 + 1e-3 * t - 0.5 * 0.3 * t * t, 2) == pytest.approx(-0.3)
    assert R.fit_acceleration(t, 0.01 + 0.7 * t, 1) == pytest.approx(0.7)


def test_the_release_scenario_is_what_it_says():
    s = R.released_scenario("roll", "foil")
    assert s.initial_pose.xyz == [0.0, 0.0, R.DEPTH_M]
    assert s.initial_pose.rpy_deg == [R.ROLL_DEG, 0.0, 0.0]
    assert s.balloon.initial_fill == 0.0 and s.balloon.schedule == []
    assert s.water.fin_model == "foil" and s.duration == R.DURATION_S
    with pytest.raises(ValueError, match="kind"):
        R.released_scenario("pitch", "foil")


@pytest.mark.slow
def test_released_heave_mass_is_the_robot_with_its_water(tmp_path):
    """Heave: the rigid robot plus the hull's added mass (cross_flow, within 3 %), plus
    every plate's added-mass body along its (vertical) normal and the fins' interaction
    with the hull on the hull's heave body (foil). The foil model's heave comes out 2-5 %
    short of the plant's implicit plus explicit mass, a shortfall not yet explained; held
    within 6 %."""
    coeffs = load_coefficients()
    hull = coeffs.body.added_mass.value[2]
    bodies = len(LEGS) * sum(
        plate_added_mass(p.chord, p.span, coeffs.water_density.value, k)[0]
        for p, k in zip(fin_plates(DEFAULT_ROBOT), coeffs.fins.added_mass_factor.value)
    )
    cross = R.measure("heave", "cross_flow", tmp_path / "cross")
    foil = R.measure("heave", "foil", tmp_path / "foil")
    assert cross["rigid"] == pytest.approx(DEFAULT_ROBOT.total_mass)
    assert cross["force"] == pytest.approx(foil["force"]) and cross["force"] < 0  # it sinks
    assert cross["effective"] == pytest.approx(cross["rigid"] + hull, rel=0.03)
    interaction = coeffs.fins.hull_interaction_added_mass.value
    assert foil["effective"] - cross["effective"] == pytest.approx(bodies + interaction, rel=0.06)
