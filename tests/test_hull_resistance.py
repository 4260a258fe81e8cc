"""The hull's low-speed resistance law and its rotational cross-flow damping against closed
forms and independent quadratures."""

import math

import numpy as np
import pytest
from scipy import integrate

from manta_drake.model import hull_resistance as hr


@pytest.mark.parametrize(
    "axes, exact",
    [
        ((0.3, 0.3, 0.3), 4 * math.pi * 0.09),
        # prolate spheroid a > b = c: 2 pi b^2 (1 + a / (b e) asin e)
        ((2.0, 1.0, 1.0), 2 * math.pi * (1 + 2.0 / math.sqrt(0.75) * math.asin(math.sqrt(0.75)))),
        # oblate spheroid a = b > c: 2 pi a^2 (1 + (1 - e^2) / e atanh e)
        (
            (2.0, 2.0, 1.0),
            2 * math.pi * 4 * (1 + 0.25 / math.sqrt(0.75) * math.atanh(math.sqrt(0.75))),
        ),
    ],
)
def test_surface_area_of_spheroids_is_the_closed_form(axes, exact):
    assert hr.ellipsoid_surface_area(axes) == pytest.approx(exact, rel=1e-10)
    assert hr.ellipsoid_surface_area(axes[::-1]) == pytest.approx(exact, rel=1e-10)


def test_surface_area_of_the_hull_against_a_surface_quadrature():
    a, b, c = 0.19, 0.12, 0.07

    def element(theta, phi):  # |r_theta x r_phi| of the parametrisation
        st, ct, sp, cp = math.sin(theta), math.cos(theta), math.sin(phi), math.cos(phi)
        n = np.array([b * c * st * st * cp, a * c * st * st * sp, a * b * st * ct])
        return float(np.linalg.norm(n))

    area, _ = integrate.dblquad(element, 0, 2 * math.pi, 0, math.pi, epsabs=1e-10)
    assert hr.ellipsoid_surface_area((a, b, c)) == pytest.approx(area, rel=1e-7)


def test_blasius_mean_is_the_integral_of_the_local_wall_shear():
    # Local Blasius skin friction c_f(x) = 0.664 / sqrt(Re_x); the mean over the length.
    u, length, nu = 0.3, 0.38, 1e-6
    mean, _ = integrate.quad(lambda x: 0.664 / math.sqrt(u * x / nu), 0, length)
    assert hr.laminar_skin_friction(u * length / nu) == pytest.approx(mean / length, rel=1e-8)


def test_ittc_line_and_its_relation_to_the_laminar_one():
    assert hr.turbulent_skin_friction(1e6) == pytest.approx(0.075 / 16)
    assert hr.turbulent_skin_friction(1e5) == pytest.approx(0.075 / 9)
    assert hr.laminar_skin_friction(1e5) == pytest.approx(1.328 / math.sqrt(1e5))
    # Below transition the laminar coefficient is the smaller one all the way down.
    for re in (1e4, 3e4, 1e5, 5e5):
        assert hr.laminar_skin_friction(re) < 0.75 * hr.turbulent_skin_friction(re)


def test_surge_law_friction_grows_as_speed_to_the_three_halves_and_form_drag_as_squared():
    kw = dict(frontal_area=0.026, wetted_area=0.195, length=0.38, rho=1000.0)
    f1, f2 = (hr.hull_surge_resistance(u, 0.0, **kw) for u in (0.05, 0.2))
    assert math.log(f2 / f1) / math.log(4.0) == pytest.approx(1.5, rel=1e-12)
    only_form = hr.hull_surge_resistance(0.3, 0.1, **{**kw, "wetted_area": 0.0})
    assert only_form == pytest.approx(0.5 * 1000 * 0.09 * 0.1 * 0.026)
    assert hr.hull_surge_resistance(-0.2, 0.1, **kw) == pytest.approx(
        -hr.hull_surge_resistance(0.2, 0.1, **kw)
    )
    with pytest.raises(ValueError, match="laminar limit"):
        hr.hull_surge_resistance(2.0, 0.1, **kw)


def test_form_drag_coefficient_recovers_a_quadratic_drag():
    u = np.array([0.4, 0.8, 1.2])
    assert hr.hull_form_drag_coefficient(
        0.5 * 1000 * u**2 * 0.07 * 0.026, u, 0.026, 1000
    ) == pytest.approx(0.07)


def test_rotational_damping_is_the_strip_integral():
    a, b, c, rho = 0.19, 0.12, 0.07, 1000.0
    cd = (1.7, 1.6, 0.6)

    def strip(L, h, c_d):  # Integral of s * 1/2 rho C_D 2 h sqrt(1 - s^2/L^2) |s| s over s
        def f(s):
            return 0.5 * rho * c_d * 2 * h * math.sqrt(1 - (s / L) ** 2) * abs(s) ** 3

        return integrate.quad(f, -L, L)[0]

    expected = [strip(b, a, cd[0]), strip(a, b, cd[1]), strip(a, c, cd[2])]
    np.testing.assert_allclose(
        hr.cross_flow_rotational_damping((a, b, c), cd, rho), expected, rtol=1e-8
    )
