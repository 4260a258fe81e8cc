"""The added mass's split between the mass matrix and an explicit force (pure maths).

The plant carries the isotropic part of the hull's translational added mass and the
rigid-body-valid part of its added rotational inertia (a massive body welded to the hull,
``manta_drake.model.plant``); ``HydrodynamicForces`` applies the residual explicitly as
-M_res a from the previous step's acceleration. Both sides take the split from here, so
the model layer builds the plant without the station.

The fin plates' added mass rides each plate as a body on a planar joint
(``fin_plates``, ``plate_added_mass``): the joint locks the normal, so the body's mass
acts along the plate's normal only, in the mass matrix (stable at any ratio to the
plate's own mass, where an explicit -m a is not). With them the hull's heave added mass
(and the fins' interaction with the hull, which the plates alone do not carry) rides the
hull the same way (``split_hull_added_mass``): a body free in the hull's x-y plane.
"""

import dataclasses as dc

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


# The hull's heave added-mass body: a point mass needs a rotational inertia about the
# planar joint's free axis (the hull's z) for the mass matrix to stay regular; m r^2 at this
# radius, split half and half onto roll and pitch (1 % of the hull's own added roll).
HEAVE_BODY_RADIUS = 0.003  # m


def split_hull_added_mass(added_mass, interaction: float) -> tuple[float, np.ndarray, float]:
    """The hull's translational added mass for a plant with added-mass bodies: the isotropic
    part (the smaller of surge and sway) in the mass matrix, the heave beyond it plus the
    fins' interaction with the hull as a body free in the hull's x-y plane (so its mass acts
    along the hull's z only, implicitly, at any ratio to the hull's mass), and the sway's
    excess over surge as the explicit residual.

    Args:
        added_mass: (3,) surge, sway, heave added mass of the hull alone [kg].
        interaction: the heave added mass of the fins' interaction with the hull [kg].

    Returns:
        (isotropic mass, residual (3,) with heave 0, heave body's mass) [kg].
    """
    added_mass = np.asarray(added_mass, dtype=float)
    if added_mass.shape != (3,) or not np.all(added_mass >= 0) or not interaction >= 0:
        raise ValueError(
            f"split_hull_added_mass: added mass {added_mass.tolist()!r} and "
            f"interaction {interaction!r} must be >= 0"
        )
    iso = float(min(added_mass[0], added_mass[1]))
    residual = np.array([added_mass[0] - iso, added_mass[1] - iso, 0.0])
    return iso, residual, float(added_mass[2] - iso + interaction)


def heave_body_inertia(mass: float) -> tuple[float, float, float]:
    """The hull heave body's (roll, pitch, yaw) moments: m r^2 about its free z axis and
    half of it about x and y (the smallest a rigid body allows), ``HEAVE_BODY_RADIUS``."""
    i_z = mass * HEAVE_BODY_RADIUS**2
    return 0.5 * i_z, 0.5 * i_z, i_z


def split_added_inertia(added_inertia, carried=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Splits the hull's added rotational inertia (roll, pitch, yaw), less what another
    body already carries (``carried``: the heave body's ``heave_body_inertia``), into the
    largest part a rigid body can carry (principal moments obeying the triangle inequality,
    each <= the sum of the other two) and an explicit residual."""
    added = np.maximum(np.asarray(added_inertia, dtype=float) - np.asarray(carried), 0.0)
    implicit = added.copy()
    i = int(np.argmax(implicit))
    implicit[i] = min(implicit[i], implicit.sum() - implicit[i])
    return implicit, added - implicit


def check_explicit_added_mass(
    residual, effective, axes=("surge", "sway", "heave"), unit="kg"
) -> None:
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
                "mass into the mass matrix or reduce it."
            )


# --- the fin plates' added mass as bodies ------------------------------------------------------


@dc.dataclass(frozen=True)
class FinPlate:
    """One fin plate in its link's frame: where its added-mass body rides.

    The plate's normal is the link's x axis (``model_sdf.fin_plate_geometry``); the frame
    ``R_LF`` has columns (chord, span, normal): x along the chord, y along the span
    outward, z along the normal, so a planar joint in it leaves the plate's normal
    locked and its plane free.
    """

    name: str  # "proximal" | "distal"
    link: int  # the leg's link carrying it: 3 (after pitch) | 4 (after roll2)
    center: tuple  # in the link frame [m]
    chord: float  # [m]
    span: float  # [m]
    R_LF: tuple  # 3x3, rows of the rotation link <- plate frame

    @property
    def normal(self) -> np.ndarray:
        """The plate's normal in the link frame."""
        return np.asarray(self.R_LF)[:, 2]


def fin_plates(params) -> tuple[FinPlate, FinPlate]:
    """The proximal and distal plates of a leg-fin (the same on every leg)."""
    from manta_drake.model.model_sdf import fin_plate_geometry

    g = fin_plate_geometry(params)
    e = np.eye(3)
    # Link 3: chord y, span +z; link 4: chord z, span -y; normal x on both.
    proximal = FinPlate(
        "proximal",
        3,
        tuple(map(float, g["proximal"]["center"])),
        params.proximal_chord,
        params.d3,
        tuple(map(tuple, np.column_stack([e[1], e[2], e[0]]).tolist())),
    )
    distal = FinPlate(
        "distal",
        4,
        tuple(map(float, g["distal"]["center"])),
        params.distal_chord,
        params.dE,
        tuple(map(tuple, np.column_stack([e[2], -e[1], e[0]]).tolist())),
    )
    return proximal, distal


def plate_added_mass(chord: float, span: float, rho: float, factor: float) -> tuple:
    """A rectangular plate's added mass moving along its normal and its added inertia in
    its own frame (chord, span, normal axes) about its centre.

    m = K rho pi c^2 / 4 s (the 2-D strip of Lewis (PNA 1989) times the 3-D factor K);
    rotating about its chord line the strips' heave mass gives m s^2 / 12, about its span
    line (pitching about mid-chord) K rho pi c^4 / 128 s; about the normal a thin plate
    moves no water, but a rigid body's moments must satisfy the triangle inequality, so
    the normal moment is the sum of the two (it rides a free rotation of the planar joint
    and couples to nothing).

    Returns:
        (mass [kg], (I_chord, I_span, I_normal) [kg m^2]).
    """
    if not (chord > 0 and span > 0 and rho > 0 and factor > 0):
        raise ValueError(
            f"plate_added_mass: chord {chord!r}, span {span!r}, rho {rho!r} and "
            f"factor {factor!r} must be > 0"
        )
    mass = factor * rho * np.pi * chord**2 / 4.0 * span
    i_chord = mass * span**2 / 12.0
    i_span = factor * rho * np.pi * chord**4 / 128.0 * span
    return float(mass), (float(i_chord), float(i_span), float(i_chord + i_span))
