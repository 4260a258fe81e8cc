"""Added mass of the robot's shapes in potential flow, in closed form (pure maths).

* ``ellipsoid_added_mass``: Lamb's exact added mass and added inertia of a solid
  ellipsoid translating and rotating in an unbounded ideal fluid (Lamb 1932,
  Hydrodynamics, arts. 114-115; Newman 2018, Marine Hydrodynamics, sec. 4.12; Fossen 2011
  eq. 6.53 for the spheroid), with Lamb's integrals

      alpha0 = a b c int_0^inf dl / ((a^2 + l) D(l)),  D = sqrt((a^2+l)(b^2+l)(c^2+l)),

  and beta0, gamma0 likewise, evaluated as Carlson's symmetric integral
  alpha0 = 2/3 a b c R_D(b^2, c^2, a^2) (DLMF 19.20.5); alpha0 + beta0 + gamma0 = 2:

      m_11 = alpha0 / (2 - alpha0) rho V,
      I_11 = rho V (b^2 - c^2)^2 (gamma0 - beta0)
             / (5 (2 (b^2 - c^2) + (b^2 + c^2) (beta0 - gamma0))),

  the others by cycling (a, alpha0) -> (b, beta0) -> (c, gamma0).
"""

import numpy as np


def lamb_integrals(a: float, b: float, c: float) -> np.ndarray:
    """(alpha0, beta0, gamma0) of the ellipsoid with semi-axes a, b, c along x, y, z."""
    from scipy.special import elliprd

    abc = a * b * c
    a2, b2, c2 = a * a, b * b, c * c
    return (
        (2.0 / 3.0)
        * abc
        * np.array([elliprd(b2, c2, a2), elliprd(c2, a2, b2), elliprd(a2, b2, c2)])
    )


def ellipsoid_added_mass(semi_axes, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Lamb's added mass (surge, sway, heave) [kg] and added inertia (roll, pitch, yaw)
    [kg m^2] of an ellipsoid with ``semi_axes`` (a, b, c) [m] along its x, y, z axes in a
    fluid of density ``rho``; the matrix is diagonal in those axes, about the centre."""
    a, b, c = (float(s) for s in semi_axes)
    if not min(a, b, c) > 0.0:
        raise ValueError(f"ellipsoid_added_mass: semi_axes {semi_axes!r} must be positive")
    al = lamb_integrals(a, b, c)
    volume = 4.0 / 3.0 * np.pi * a * b * c
    mass = al / (2.0 - al) * rho * volume
    sq = np.array([a, b, c]) ** 2
    inertia = np.zeros(3)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        d = sq[j] - sq[k]
        if d == 0.0:  # a body of revolution about this axis: no fluid is moved
            continue
        inertia[i] = (
            rho
            * volume
            * d
            * d
            * (al[k] - al[j])
            / (5.0 * (2.0 * d + (sq[j] + sq[k]) * (al[j] - al[k])))
        )
    return mass, inertia
