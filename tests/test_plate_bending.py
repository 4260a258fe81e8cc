"""The fin plates' chordwise bending: Euler-Bernoulli against its closed forms, the NACA
thickness against the section's published ordinates."""

import math

import numpy as np
import pytest

from manta_drake.model import plate_bending as PB


def test_constant_thickness_cantilever_meets_the_closed_forms():
    """w(L) = p L^4 / (8 E I), w'(L) = p L^3 / (6 E I), I = t^3 / 12 per unit span."""
    p, L, E, t = 250.0, 0.1, 2.0e9, 0.004
    r = PB.cantilever_deflection(p, L, E, t)
    EI = E * t**3 / 12.0
    assert r["tip_deflection"] == pytest.approx(p * L**4 / (8.0 * EI), rel=1e-5)
    assert r["tip_slope"] == pytest.approx(p * L**3 / (6.0 * EI), rel=1e-5)
    assert r["chord_rotation"] == pytest.approx(math.atan(r["tip_deflection"] / L), rel=1e-12)


def test_linearly_tapered_cantilever_meets_its_integral():
    """t(s) = t0 (1 - s / (2 L)): w'(L) = int_0^L p (L-s)^2 / 2 / (E t^3 / 12) ds, computed by
    substitution u = L - s in closed form: 6 p / (E t0^3) int_0^L u^2 / (1/2 + u/(2L))^3 du."""
    p, L, E, t0 = 100.0, 0.08, 1.0e9, 0.01
    r = PB.cantilever_deflection(p, L, E, lambda s: t0 * (1.0 - s / (2.0 * L)))
    # With v = 1 + u / L on [1, 2]: int = 8 L^3 int_1^2 (v - 1)^2 / v^3 dv
    #                              = 8 L^3 [ln 2 - 2 (1 - 1/2) + (1/2)(1 - 1/4)].
    integral = 8.0 * L**3 * (math.log(2.0) - 1.0 + 0.375)
    assert r["tip_slope"] == pytest.approx(6.0 * p / (E * t0**3) * integral, rel=1e-5)


def test_naca0012_thickness_matches_the_published_ordinates():
    """Abbott & von Doenhoff, appendix I, NACA 0012: y_t / c = 0.06002 at x = 0.30, 0.05294 at
    0.50, 0.02623 at 0.80, 0.00126 at 1.00 (half-thickness)."""
    x = np.array([0.3, 0.5, 0.8, 1.0])
    half = PB.naca_thickness(x, 0.12, 1.0) / 2.0
    assert half == pytest.approx([0.06002, 0.05294, 0.02623, 0.00126], abs=2e-5)


def test_plate_bending_is_linear_in_pressure_and_inverse_in_modulus():
    a = PB.plate_chordwise_bending(150.0, 0.14, 2.0e9)
    b = PB.plate_chordwise_bending(300.0, 0.14, 1.0e9)
    assert b["tip_deflection"] == pytest.approx(4.0 * a["tip_deflection"], rel=1e-9)
    # Clamped further aft, the cantilever is shorter and thicker: stiffer.
    aft = PB.plate_chordwise_bending(150.0, 0.14, 2.0e9, clamp=0.3)
    assert aft["tip_deflection"] < a["tip_deflection"]


def test_the_robot_s_plates_are_rigid_over_the_band():
    """The robot's two plate chords over the stiffness band at the 1 kPa bound (several times
    the swim's pressure): the chord turns by under 3 deg, against the 25 deg the passive-pitch
    model assumed; the softest corner is the worst, and an independent constant-thickness bound
    (the plate no thinner than at 80 % chord, clamped at 0.3 c) is smaller."""
    from manta_drake.model.robot_params import RobotParams

    p = RobotParams()
    worst = PB.largest_chord_rotation((p.proximal_chord, p.distal_chord))
    assert 0.0 < math.degrees(worst) < 3.0
    soft = PB.plate_chordwise_bending(
        PB.PRESSURE_BOUND, p.proximal_chord, PB.YOUNGS_MODULUS_BAND[0], clamp=PB.CLAMP_BAND[0]
    )
    assert soft["chord_rotation"] == pytest.approx(worst, rel=1e-12)
    c, L = p.proximal_chord, 0.7 * p.proximal_chord
    t = PB.naca_thickness(0.8, 0.12, c)
    bound = PB.PRESSURE_BOUND * L**3 / (8.0 * PB.YOUNGS_MODULUS_BAND[0] * t**3 / 12.0)
    assert math.atan(bound) < worst


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match="youngs_modulus"):
        PB.cantilever_deflection(100.0, 0.1, 0.0, 0.01)
    with pytest.raises(ValueError, match="thickness"):
        PB.cantilever_deflection(100.0, 0.1, 1e9, lambda s: np.where(s < 0.05, 0.01, 0.0))
    with pytest.raises(ValueError, match="clamp"):
        PB.plate_chordwise_bending(100.0, 0.1, 1e9, clamp=1.0)
