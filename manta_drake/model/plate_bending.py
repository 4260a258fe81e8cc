"""Chordwise bending of the fin plates under the water's pressure (pure maths): how far a
3-D printed NACA0012 plate is from rigid.

Each plate is an Euler-Bernoulli beam along its chord, per unit span, clamped at the spar that
carries its joint (a chordwise position ``clamp`` from the leading edge, as a fraction of the
chord) and loaded by a uniform normal pressure p over its aft part, length L = (1 - clamp) c.
With s the distance aft of the clamp, the bending moment and the section's second moment are

    M(s) = p (L - s)^2 / 2,    I(s) = t(x)^3 / 12  (per unit span),

and the deflection w obeys w'' = M / (E I), w(0) = w'(0) = 0 (Timoshenko & Gere 1972,
Mechanics of Materials, sec. 9.2). The thickness t(x) of the NACA 4-digit symmetric section
(Abbott & von Doenhoff 1959, Theory of Wing Sections, eq. 6.2) at x = X / c:

    t(x) = 10 tau c (0.2969 sqrt x - 0.1260 x - 0.3516 x^2 + 0.2843 x^3 - 0.1015 x^4),

tau the thickness ratio (0.12), with the trailing edge no thinner than ``min_thickness`` (the
thinnest wall a printer lays down). For a plate of constant thickness t the closed forms are
w(L) = p L^4 / (8 E I) and w'(L) = p L^3 / (6 E I) (Timoshenko & Gere, table G-1).

The equivalent passive pitch of the plate is the rotation of its chord line aft of the clamp,
beta = atan(w(L) / L): the angle the foil strip model would have to add to the plate's pitch.
"""

from __future__ import annotations

import math

import numpy as np

NACA_COEFFICIENTS = (0.2969, -0.1260, -0.3516, 0.2843, -0.1015)

# The band of the plates' stiffness. The paper states NACA0012 fins, "thicker and smaller" than
# its predecessor's, not their material; they bear the robot's weight on the floor, so they are
# a stiff printing polymer: printed PLA 1.8-3.3 GPa (Tymrak, Kreiger & Pearce 2014, Mater. Des.
# 58:242-246), ABS and PETG ~2 GPa, SLA resins 1.5-3 GPa, bulk PLA 3.5 GPa; the low end 0.5 GPa
# allows for a sparse infill under solid skins. The spar is at the leading edge (worst: the
# thin nose carries the whole aft plate) to 0.3 c (the section's thickest point). The pressure
# bound 1 kPa is 1/2 rho v^2 at 1.4 m/s, above the swim's strips (~150 Pa at 0.5 m/s, C_N 1.2).
YOUNGS_MODULUS_BAND = (0.5e9, 3.5e9)  # Pa
CLAMP_BAND = (0.0, 0.3)  # fraction of the chord from the leading edge
PRESSURE_BOUND = 1000.0  # Pa


def naca_thickness(x, thickness_ratio: float, chord: float):
    """Full thickness [m] of a NACA 4-digit symmetric section at chordwise fraction x."""
    x = np.asarray(x, dtype=float)
    a0, a1, a2, a3, a4 = NACA_COEFFICIENTS
    poly = a0 * np.sqrt(x) + x * (a1 + x * (a2 + x * (a3 + x * a4)))
    return 10.0 * thickness_ratio * chord * poly


def cantilever_deflection(
    pressure: float, length: float, youngs_modulus: float, thickness, n: int = 2001
) -> dict:
    """Tip deflection and slope of a cantilever per unit span under uniform pressure.

    Args:
        pressure: p [Pa] on one face.
        length: L [m] from the clamp to the free edge.
        youngs_modulus: E [Pa].
        thickness: t [m], a number (constant) or a function of s in [0, L] (s from the clamp).
        n: integration stations.

    Returns:
        ``tip_deflection`` w(L) [m], ``tip_slope`` w'(L) [rad] and ``chord_rotation``
        atan(w(L) / L) [rad].
    """
    from scipy.integrate import cumulative_trapezoid

    for name, v in (("pressure", pressure), ("length", length), ("youngs_modulus", youngs_modulus)):
        if not (math.isfinite(v) and v >= 0.0) or (name != "pressure" and v == 0.0):
            raise ValueError(f"cantilever_deflection: {name} {v!r} must be finite and > 0")
    s = np.linspace(0.0, length, n)
    t = thickness(s) if callable(thickness) else np.full_like(s, float(thickness))
    if not np.all(t > 0.0):
        raise ValueError("cantilever_deflection: the thickness must be > 0 everywhere")
    curvature = 0.5 * pressure * (length - s) ** 2 / (youngs_modulus * t**3 / 12.0)
    slope = cumulative_trapezoid(curvature, s, initial=0.0)
    w = cumulative_trapezoid(slope, s, initial=0.0)
    return {
        "tip_deflection": float(w[-1]),
        "tip_slope": float(slope[-1]),
        "chord_rotation": math.atan2(float(w[-1]), length),
    }


def plate_chordwise_bending(
    pressure: float,
    chord: float,
    youngs_modulus: float,
    thickness_ratio: float = 0.12,
    clamp: float = 0.25,
    min_thickness: float = 0.8e-3,
    n: int = 2001,
) -> dict:
    """The NACA00xx plate's aft part as a cantilever from ``clamp`` (fraction of the chord
    from the leading edge) to the trailing edge: ``cantilever_deflection``'s numbers, in
    radians and metres."""
    if not 0.0 <= clamp < 1.0:
        raise ValueError(f"plate_chordwise_bending: clamp {clamp!r} must be in [0, 1)")
    length = (1.0 - clamp) * chord

    def t(s):
        return np.maximum(naca_thickness(clamp + s / chord, thickness_ratio, chord), min_thickness)

    return cantilever_deflection(pressure, length, youngs_modulus, t, n)


def largest_chord_rotation(chords, pressure: float = PRESSURE_BOUND) -> float:
    """The largest chord rotation [rad] of plates of the given chords over the stiffness band
    (YOUNGS_MODULUS_BAND, CLAMP_BAND) at ``pressure``: it is largest at the softest modulus
    and, for the NACA section, the clamp at the leading edge; every corner is evaluated."""
    return max(
        plate_chordwise_bending(pressure, c, e, clamp=k)["chord_rotation"]
        for c in chords
        for e in YOUNGS_MODULUS_BAND
        for k in CLAMP_BAND
    )
