"""The added mass's split between the mass matrix and an explicit force (pure maths).

The plant carries the isotropic part of the hull's translational added mass and the
rigid-body-valid part of its added rotational inertia (a massive body welded to the hull,
``manta_drake.model.plant``); ``HydrodynamicForces`` applies the residual explicitly as
-M_res a from the previous step's acceleration. Both sides take the split from here, so
the model layer builds the plant without the station.
"""

import numpy as np


def split_added_mass(added_mass, rigid_mass: float) -> tuple[float, np.ndarray]:
    """Splits the hull's translational added mass into an isotropic part (for the mass
    matrix) and an explicit residual, and checks the residual is safe.

    The isotropic part is the midpoint of the smallest and largest added mass, which
    minimises the largest |residual| / (rigid + isotropic mass); with it the check
    always passes. An isotropic part given explicitly (``HydrodynamicForces``'s
    ``added_mass_iso``) is checked the same way.

    Args:
        added_mass: (3,) surge, sway, heave added mass [kg].
        rigid_mass: the hull's own rigid mass [kg].

    Returns:
        (isotropic mass, residual (3,)).

    Raises:
        ValueError naming the axis where |residual| >= rigid mass + isotropic mass:
        an explicit added-mass force that large oscillates and diverges.
    """
    added_mass = np.asarray(added_mass, dtype=float)
    iso = 0.5 * (added_mass.min() + added_mass.max())
    residual = added_mass - iso
    check_explicit_added_mass(residual, rigid_mass + iso)
    return float(iso), residual


def split_added_inertia(added_inertia) -> tuple[np.ndarray, np.ndarray]:
    """Splits the hull's added rotational inertia (roll, pitch, yaw) into the largest part
    a rigid body can carry (principal moments obeying the triangle inequality, each <= the
    sum of the other two) and an explicit residual."""
    added = np.asarray(added_inertia, dtype=float)
    implicit = added.copy()
    i = int(np.argmax(implicit))
    implicit[i] = min(implicit[i], implicit.sum() - implicit[i])
    return implicit, added - implicit


def check_explicit_added_mass(residual, effective, axes=("surge", "sway", "heave"),
                              unit="kg") -> None:
    """Raises ValueError naming the first axis whose explicit added mass is not below the
    effective mass (or inertia) on that axis that it acts against.

    The explicit force -M_res a_prev makes the step-to-step map of the acceleration
    a_k = -(M_res / M_eff) a_{k-1} + ..., so it is stable only for |M_res| < M_eff, with
    M_eff the rigid plus implicit (mass-matrix) part on that axis. Measured on the swim
    with exact per-step forces: 0.9 M_eff stays bounded, 1.2 diverges, at 0.5, 1 and 2 ms
    (tests/test_hydro.py).
    """
    limits = np.broadcast_to(np.asarray(effective, dtype=float), (3,))
    for axis, value, limit in zip(axes, np.asarray(residual, dtype=float), limits):
        if abs(value) >= limit:
            raise ValueError(
                f"explicit added mass on the {axis} axis is {abs(value):.3g} {unit}, not below "
                f"the robot's effective {unit} {limit:.3g} on that axis (rigid + implicit "
                "added): the explicit term would oscillate and diverge. Put more of the added "
                "mass into the mass matrix or reduce it.")
