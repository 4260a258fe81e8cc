"""Lamb's ellipsoid added mass against closed forms of its special cases."""

import numpy as np
import pytest
from scipy.integrate import quad

from manta_drake.model.potential_flow import ellipsoid_added_mass, lamb_integrals

RHO = 1000.0


def test_lamb_integrals_by_quadrature_and_their_sum_is_two():
    a, b, c = 0.19, 0.12, 0.07

    def integral(s2):
        def f(lam):
            return 1.0 / ((s2 + lam) * np.sqrt((a * a + lam) * (b * b + lam) * (c * c + lam)))

        return a * b * c * quad(f, 0.0, np.inf, limit=200)[0]

    expected = [integral(a * a), integral(b * b), integral(c * c)]
    got = lamb_integrals(a, b, c)
    np.testing.assert_allclose(got, expected, rtol=1e-8)
    assert got.sum() == pytest.approx(2.0, abs=1e-12)


def test_sphere_has_half_its_displaced_mass_and_no_added_inertia():
    r = 0.1
    mass, inertia = ellipsoid_added_mass((r, r, r), RHO)
    np.testing.assert_allclose(mass, 0.5 * RHO * 4 / 3 * np.pi * r**3, rtol=1e-12)
    np.testing.assert_array_equal(inertia, 0.0)


def test_prolate_spheroid_against_its_elementary_closed_form():
    """a > b = c: alpha0 = 2 (1 - e^2) / e^3 (atanh(e) - e), beta0 = gamma0 =
    1/e^2 - (1 - e^2) atanh(e) / e^3 (Lamb art. 115; Fossen 2011 eq. 6.54)."""
    a, b = 0.3, 0.1
    e = np.sqrt(1 - (b / a) ** 2)
    alpha0 = 2 * (1 - e * e) / e**3 * (np.arctanh(e) - e)
    beta0 = 1 / e**2 - (1 - e * e) / e**3 * np.arctanh(e)
    volume = 4 / 3 * np.pi * a * b * b
    mass, inertia = ellipsoid_added_mass((a, b, b), RHO)
    np.testing.assert_allclose(
        mass,
        RHO * volume * np.array([alpha0 / (2 - alpha0), beta0 / (2 - beta0), beta0 / (2 - beta0)]),
        rtol=1e-10,
    )
    pitch = (
        RHO
        * volume
        / 5
        * (b * b - a * a) ** 2
        * (alpha0 - beta0)
        / (2 * (b * b - a * a) + (b * b + a * a) * (beta0 - alpha0))
    )
    np.testing.assert_allclose(inertia, [0.0, pitch, pitch], rtol=1e-10)


def test_thin_oblate_spheroid_tends_to_the_circular_disk():
    """A disk of radius a moving broadside: 8/3 rho a^3 (Lamb art. 108); the edgewise
    motion moves no fluid."""
    a = 0.1
    mass, _ = ellipsoid_added_mass((a, a, 1e-6 * a), RHO)
    assert mass[2] == pytest.approx(8 / 3 * RHO * a**3, rel=1e-5)
    assert mass[0] < 1e-5 * mass[2]


def test_bad_semi_axes_are_refused():
    with pytest.raises(ValueError, match="semi_axes"):
        ellipsoid_added_mass((0.1, 0.0, 0.1), RHO)
