"""The hull's resistance at the robot's own speeds (pure maths): what the CFD of 0.4-1.2 m/s
says at 0.02-0.3 m/s, and the hull's rotational damping, which a static CFD case cannot see.

**Surge.** The hull's drag is its pressure (form) drag and its skin friction,

    X(U) = 1/2 rho U^2 (C_Dp A_f + C_f(Re_L) S_wet),    Re_L = U L / nu,

with A_f the frontal area, S_wet the wetted area, L the length. Below Re_L ~ 5e5 the
boundary layer of a smooth body in calm water stays laminar, so C_f is Blasius's flat-plate
value (Schlichting & Gersten 2017, Boundary-Layer Theory, eq. 6.59)

    C_f = 1.328 / sqrt(Re_L),

and the friction grows as U^1.5, not as U^2 and not as U; the ITTC 1957 line
0.075 / (log10 Re - 2)^2 is the turbulent value it is compared with. The robot's hull, L =
0.38 m, has Re_L = 7.6e3 at 0.02 m/s and 4.6e5 at 1.2 m/s: laminar over the whole range. C_Dp
is measured (the CFD's pressure drag on the hull's own patch, ``hull_form_drag_coefficient``).

**Rotation.** A steady translation has no angular rate, so the paper's static cases carry no
information on K_p, M_q, N_r. Strip theory gives them: a station at distance s from the axis
moves through the water at omega s, and its section's 2-D cross-flow drag 1/2 rho C_D w(s) |v| v
(w the section's width across the flow) integrates over the ellipsoid's planform outline
w(s) = 2 h sqrt(1 - s^2 / l^2) to

    M = -1/2 rho C_D omega |omega| Integral_{-l}^{l} 2 h sqrt(1 - s^2/l^2) |s|^3 ds
      = -(4/15) rho C_D h l^4 omega |omega|,

(Integral_0^1 sqrt(1 - t^2) t^3 dt = 2/15), with l the semi-axis along the strips and h the
semi-axis across them: roll l = b, h = a; pitch l = a, h = b; yaw l = a, h = c (Fossen 2011,
Handbook of Marine Craft Hydrodynamics, sec. 6.4.3, cross-flow drag; the same strip integral
as for a slender body's heave).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

WATER_VISCOSITY = 1.0e-6  # m^2/s, kinematic, fresh water at 20 C (ITTC 2011 fresh water table)
LAMINAR_LIMIT_RE = 5.0e5  # transition Reynolds number of a flat plate in calm water (Schlichting)


def ellipsoid_surface_area(semi_axes) -> float:
    """Exact surface area of the ellipsoid of ``semi_axes`` (Legendre's form with the
    incomplete elliptic integrals F, E; DLMF 19.33.2): for a >= b >= c,
    S = 2 pi c^2 + 2 pi a b (E(phi, m) sin^2 phi + F(phi, m) cos^2 phi) / sin phi,
    cos phi = c / a, m = a^2 (b^2 - c^2) / (b^2 (a^2 - c^2))."""
    a, b, c = sorted((float(x) for x in semi_axes), reverse=True)
    if not c > 0:
        raise ValueError(f"semi-axes {semi_axes}: must be > 0")
    if math.isclose(a, c):
        return 4.0 * math.pi * a * a
    phi = math.acos(c / a)
    m = a * a * (b * b - c * c) / (b * b * (a * a - c * c))
    e, f = special.ellipeinc(phi, m), special.ellipkinc(phi, m)
    s = math.sin(phi)
    return float(2 * math.pi * c * c + 2 * math.pi * a * b * (e * s * s + f * (1 - s * s)) / s)


def laminar_skin_friction(reynolds):
    """Blasius's mean skin-friction coefficient of one side of a flat plate, 1.328 / sqrt(Re)."""
    return 1.328 / np.sqrt(reynolds)


def turbulent_skin_friction(reynolds):
    """The ITTC 1957 model-ship correlation line, 0.075 / (log10 Re - 2)^2."""
    return 0.075 / (np.log10(reynolds) - 2.0) ** 2


def hull_surge_resistance(
    speed,
    form_drag_coefficient: float,
    frontal_area: float,
    wetted_area: float,
    length: float,
    rho: float,
    nu: float = WATER_VISCOSITY,
):
    """X(U) = 1/2 rho U |U| (C_Dp A_f + C_f S_wet), C_f laminar (Blasius) at Re_L = |U| L / nu;
    the drag's magnitude, signed with U. Raises where Re_L passes the laminar limit."""
    u = np.asarray(speed, dtype=float)
    re = np.maximum(np.abs(u), 1e-300) * length / nu
    if np.any(re > LAMINAR_LIMIT_RE):
        raise ValueError(
            f"speed up to {np.abs(u).max():.3g} m/s: Re_L {re.max():.3g} is past "
            f"the laminar limit {LAMINAR_LIMIT_RE:.0e} of this law"
        )
    cf = laminar_skin_friction(re)
    return 0.5 * rho * u * np.abs(u) * (form_drag_coefficient * frontal_area + cf * wetted_area)


def hull_form_drag_coefficient(pressure_drag, speed, frontal_area: float, rho: float):
    """C_Dp = D_p / (1/2 rho U^2 A_f), the mean over the samples given."""
    d, u = np.asarray(pressure_drag, float), np.asarray(speed, float)
    return float(np.mean(d / (0.5 * rho * u * u * frontal_area)))


def cross_flow_rotational_damping(semi_axes, drag_coefficients, rho: float) -> np.ndarray:
    """(K_p|p|, M_q|q|, N_r|r|) = (4/15) rho C_D h l^4 per axis (see the module), semi_axes
    (a, b, c) along body x, y, z and ``drag_coefficients`` the sections' 2-D cross-flow C_D in
    roll, pitch, yaw."""
    a, b, c = (float(x) for x in semi_axes)
    cd = np.asarray(drag_coefficients, dtype=float)
    h_l4 = np.array([a * b**4, b * a**4, c * a**4])
    return 4.0 / 15.0 * rho * cd * h_l4


def fit_errors(speeds, law, fitted) -> np.ndarray:
    """Relative error (fitted - law) / law of a fitted damping law at ``speeds``."""
    law_v, fit_v = np.asarray(law(speeds), float), np.asarray(fitted(speeds), float)
    return (fit_v - law_v) / law_v
