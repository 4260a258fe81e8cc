"""The water's forces as pure maths (Eqs. 2-3 of the paper), one function per term.

Every function takes numpy arrays (world-frame kinematics of the hydro bodies or of
their volume elements and strips) and returns forces or wrenches; none needs a plant,
so the tests check each term against closed forms directly. ``HydrodynamicForces``
(``manta_drake.station.hydro``) is the thin Drake wrapper that feeds them the plant's
poses and velocities and sums them. Wrenches are rows ``[tau_W, f_W]`` about each
body's origin, expressed in the world.

The terms:

* ``buoyancy_wrenches``: restoring forces, Eq. (3) generalised to any attitude. Each
  body's sealed volume is a set of ellipsoids (hull, servo cases, one small ellipsoid
  per fin strip). ``ellipsoid_submersion`` maps an ellipsoid to the unit ball, where the
  free surface z = 0 is a plane, so the submerged volume and its centroid (the centre of
  buoyancy) are spherical-cap formulas: exact and continuous. Gravity stays in the plant.
* ``balloon_wrench``: the BVBS balloon, a sphere of the current volume at its mount.
* ``damping_wrenches``: Eq. (2)'s D, -(d_lin + d_quad |nu|) nu per axis of each body's
  frame, on the velocity relative to the water, scaled by the submerged fraction, plus
  the hull's body lift and moment at incidence (``body_lift``).
* ``fin_strip_forces``: quasi-steady blade elements. Each strip sees the velocity of
  its centre relative to the water and feels the flat-plate normal force
  -1/2 rho C_N A |v_n| v_n n (cross-flow principle, with ``passive_pitch``) and skin
  friction -1/2 rho C_f A |v_t| v_t. This is what makes flapping produce thrust.
* ``residual_added_mass_wrench``: the part of the hull's added mass that is not in the
  mass matrix, applied explicitly as -M_res a from the previous step's acceleration.
  The isotropic part of the added mass and the rigid-body-valid part of the added
  rotational inertia are in the mass matrix (a massive body welded to the hull, see
  ``manta_drake.model.plant``), the fins' added inertia about their hinges is the
  actuators' reflected inertia; ``manta_drake.model.added_mass`` decides the split and
  refuses an explicit part that would make the explicit scheme diverge.
"""

import dataclasses as dc

import numpy as np

from manta_drake.model.added_mass import (  # noqa: F401  (the water model's terms, one place)
    check_explicit_added_mass,
    split_added_inertia,
    split_added_mass,
)
from manta_drake.model.bill_of_materials import NACA4_SECTION_AREA
from manta_drake.model.coefficients import HydroCoefficients
from manta_drake.model.kinematics import link_poses_at_zero
from manta_drake.model.robot_params import DEFAULT_ROBOT, LEGS, RobotParams

E_Z = np.array([0.0, 0.0, 1.0])
# An ellipsoid with semi-axes k * (box half-sizes) has the box's volume.
BOX_TO_ELLIPSOID = (6.0 / np.pi) ** (1.0 / 3.0)


# --- pure maths ------------------------------------------------------------------------------


def cross(a, b):
    """Row-wise cross product of (N, 3) arrays (np.cross is slow on small arrays)."""
    return np.stack(
        [
            a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
            a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
            a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
        ],
        axis=1,
    )


def _rotate(R, x):
    """(N, 3, 3) @ (N, 3) -> (N, 3)."""
    return np.matmul(R, x[:, :, None])[:, :, 0]


def ellipsoid_submersion(p_WE, R_WE, semi_axes):
    """Submerged fraction and submerged centroid of ellipsoids under the plane z = 0.

    Args:
        p_WE: (N, 3) centres in the world.
        R_WE: (N, 3, 3) orientations (columns: the ellipsoid's axes in the world).
        semi_axes: (N, 3) semi-axes along the ellipsoid's own axes.

    Returns:
        (fraction (N,), centroid (N, 3)): the fraction of each volume below z = 0
        and the centroid of that part (the centre of buoyancy), world frame.
    """
    p_WE = np.asarray(p_WE, dtype=float)
    A = np.asarray(semi_axes, dtype=float)
    # Point x = p + R diag(A) u, |u| <= 1. Its height: p_z + m . u with m = A * R[2, :].
    m = A * R_WE[:, 2, :]
    norm = np.linalg.norm(m, axis=1)
    s = -p_WE[:, 2] / norm  # submerged where (m/|m|) . u < s
    h = np.clip(1.0 + s, 0.0, 2.0)  # height of the submerged cap of the unit ball
    fraction = h * h * (3.0 - h) / 4.0
    # Centroid of the cap {u_n < s}: u_n = -3 (2 - h)^2 / (4 (3 - h)) along m/|m|.
    u_n = -3.0 * (2.0 - h) ** 2 / (4.0 * (3.0 - h))
    u = (u_n / norm)[:, None] * m
    centroid = p_WE + _rotate(R_WE, A * u)
    return fraction, centroid


def passive_pitch(v_rel, normal, chord, rho, c_normal, pitch_max, reference_pressure):
    """Effective normals of chordwise-flexible strips (passive pitching).

    Under the normal pressure p = 1/2 rho C_N v_n^2 a flexible plate's trailing edge
    bends away from the flow by beta = pitch_max tanh(p / reference_pressure); the
    effective normal tilts towards the leading edge, n' = n cos(beta) - sign(v_n)
    c sin(beta), so the normal force gets a component along the leading edge on
    both strokes. This is how flexible flapping fins make thrust from reciprocal
    (time-reversible) joint motion, which rigid quasi-steady plates cannot.

    Args:
        v_rel: (N, 3) strip velocities relative to the water.
        normal, chord: (N, 3) unit normals and unit chord directions (to the leading edge).
        pitch_max: largest deflection [rad]; 0 gives rigid plates.
        reference_pressure: pressure at which beta = 0.76 pitch_max [Pa].
    """
    if pitch_max <= 0.0:
        return normal
    v_n = (v_rel * normal).sum(axis=1)
    beta = pitch_max * np.tanh(0.5 * rho * c_normal * v_n * v_n / reference_pressure)
    return np.cos(beta)[:, None] * normal - (np.sign(v_n) * np.sin(beta))[:, None] * chord


def plate_forces(v_rel, normal, area, rho, c_normal, c_friction):
    """Quasi-steady flat-plate forces on strips.

    Args:
        v_rel: (N, 3) velocity of each strip's centre relative to the water.
        normal: (N, 3) unit plate normals.
        area: (N,) strip areas.

    Returns:
        (N, 3) forces: normal pressure -1/2 rho C_N A |v_n| v_n n plus skin friction
        -1/2 rho C_f A |v_t| v_t.
    """
    v_n = (v_rel * normal).sum(axis=1)
    v_t = v_rel - v_n[:, None] * normal
    half_rho_area = 0.5 * rho * np.asarray(area)
    f_normal = -(half_rho_area * c_normal * np.abs(v_n) * v_n)[:, None] * normal
    f_friction = -(half_rho_area * c_friction * np.linalg.norm(v_t, axis=1))[:, None] * v_t
    return f_normal + f_friction


@dc.dataclass
class _Elements:
    """Ellipsoid volume elements and blade-element strips of the robot."""

    body: list = dc.field(default_factory=list)  # local hydro-body index of each element
    p: list = dc.field(default_factory=list)  # centre in the body frame
    axes: list = dc.field(default_factory=list)  # semi-axes (aligned with the body frame)
    strip_body: list = dc.field(default_factory=list)
    strip_p: list = dc.field(default_factory=list)
    strip_n: list = dc.field(default_factory=list)
    strip_area: list = dc.field(default_factory=list)
    strip_c: list = dc.field(default_factory=list)  # unit chord direction, to the leading edge
    strip_s: list = dc.field(default_factory=list)  # unit span direction, outward
    strip_chord: list = dc.field(default_factory=list)  # chord length [m]
    strip_element: list = dc.field(default_factory=list)  # its volume element


def build_elements(coeffs: HydroCoefficients, params: RobotParams = DEFAULT_ROBOT):
    """Volume elements and strips, per hydro body (0 = hull, then legs' links 1..4)."""
    e = _Elements()
    b = coeffs.body
    e.body.append(0)
    e.p.append(b.center_of_buoyancy.value)
    e.axes.append(b.sealed_semi_axes.value)
    # Each servo's case (model.bill_of_materials): on the link its joint hangs from, at the
    # joint's axis; a sphere of the case's volume.
    servo_radius = (3.0 * params.servo_volume / (4.0 * np.pi)) ** (1.0 / 3.0)
    n = int(coeffs.fins.strips_per_plate.value)
    if n < 1:
        raise ValueError(f"fins.strips_per_plate: {n} must be >= 1")
    t = params.fin_thickness
    for k, leg in enumerate(LEGS):
        base = 1 + 4 * k
        poses = link_poses_at_zero(leg, params)
        carriers = [(0, poses["X_Body_L1"])] + [
            (base + i, X) for i, X in enumerate(poses["X_Lprev_L"])
        ]
        for body, X_carrier_joint in carriers:
            e.body.append(body)
            e.p.append(X_carrier_joint[:3, 3])
            e.axes.append([servo_radius] * 3)
        # Link 3 (proximal plate): normal x, chord y, span +z on [0, d3].
        # Link 4 (distal plate): normal x, span -y on [0, dE], chord z.
        # The leading edge points forward at the zero pose: link 3's +y is the body's
        # +x on the left fins and -x on the right ones (link 4's +z likewise).
        lead = leading_edge_signs(params)[k]
        for link, span, chord, direction, chord_axis, chord_sign in (
            (2, params.d3, params.proximal_chord, np.array([0.0, 0.0, 1.0]), 1, lead[0]),
            (3, params.dE, params.distal_chord, np.array([0.0, -1.0, 0.0]), 2, lead[1]),
        ):
            ds = span / n
            for j in range(n):
                half = np.zeros(3)
                # Thickness scaled so the element holds the NACA0012 section's volume.
                half[0] = NACA4_SECTION_AREA * t / 2
                half[chord_axis] = chord / 2
                half[np.argmax(np.abs(direction))] = ds / 2
                e.strip_element.append(len(e.body))
                e.body.append(base + link)
                centre = (j + 0.5) * ds * direction
                e.p.append(centre)
                e.axes.append(BOX_TO_ELLIPSOID * half)
                e.strip_body.append(base + link)
                e.strip_p.append(centre)
                e.strip_n.append([1.0, 0.0, 0.0])
                e.strip_c.append(np.eye(3)[chord_axis] * chord_sign)
                e.strip_s.append(direction)
                e.strip_chord.append(chord)
                e.strip_area.append(chord * ds)
    arrays = {f.name: np.array(getattr(e, f.name), dtype=float) for f in dc.fields(e)}
    for name in ("body", "strip_body", "strip_element"):
        arrays[name] = arrays[name].astype(int)
    arrays["volume"] = 4.0 / 3.0 * np.pi * np.prod(arrays["axes"], axis=1)
    return arrays


def deflated_net_weight_kg(coeffs: HydroCoefficients, params: RobotParams = DEFAULT_ROBOT) -> float:
    """The robot's net weight [kg] with the balloon empty: its mass less the water displaced
    by the sealed volume elements the water model uses (``build_elements``); negative when
    the deflated robot floats."""
    volume = build_elements(coeffs, params)["volume"].sum()
    return float(params.total_mass - coeffs.water_density.value * volume)


def leading_edge_signs(params: RobotParams = DEFAULT_ROBOT) -> list:
    """Per leg, the sign of link 3's +y and link 4's +z along the body's forward axis at
    the zero pose (so strip chord directions point to the leading edge)."""
    from manta_drake.model.kinematics import X_BODYDRAKE_BODYNED, leg_frames_ned

    signs = []
    for leg in LEGS:
        F = [X_BODYDRAKE_BODYNED @ X for X in leg_frames_ned(leg, np.zeros(4), params)]
        # Link 3's frame is F_2 (joint 3 at zero); link 4's is F_3.
        signs.append((float(np.sign(F[2][0, 1])), float(np.sign(F[3][0, 2]))))
    return signs


def hydro_body_names() -> list:
    """Names of the hydro bodies in local order (hull, then each leg's links 1..4)."""
    return ["body"] + [f"{leg}_link{i}" for leg in LEGS for i in range(1, 5)]


def buoyancy_wrenches(R, p, elements, rho: float, g: float):
    """Buoyancy of every volume element, summed per body.

    Args:
        R, p: (nb, 3, 3), (nb, 3) body orientations and origins in the world.
        elements: the arrays of ``build_elements`` (``body``, ``p``, ``axes``, ``volume``).
        rho, g: water density [kg/m^3] and gravity [m/s^2].

    Returns:
        (wrenches (nb, 6), element fractions (ne,), body fractions (nb,)): the lift
        rho g V_sub e_z of each element at its centre of buoyancy as [tau_W, f_W] about
        the body origin, the submerged fraction of each element, and each body's
        submerged volume fraction (which scales its damping).
    """
    el = elements
    rb = R[el["body"]]
    p_WE = p[el["body"]] + _rotate(rb, el["p"])
    frac, cob = ellipsoid_submersion(p_WE, rb, el["axes"])
    lift = rho * g * el["volume"] * frac
    r = cob - p[el["body"]]
    zero = np.zeros_like(lift)
    # lift e_z at the centre of buoyancy: torque r x (0, 0, lift).
    elem = np.stack([r[:, 1] * lift, -r[:, 0] * lift, zero, zero, zero, lift], axis=1)
    nb = len(p)
    to_body = el.get("elem_to_body")
    if to_body is None:
        to_body = np.eye(nb)[:, el["body"]]
    body_volume = to_body @ el["volume"]
    submerged = to_body @ (el["volume"] * frac)
    body_fraction = np.divide(
        submerged, body_volume, out=np.zeros_like(submerged), where=body_volume > 0
    )  # no volume (added-mass bodies): 0
    return to_body @ elem, frac, body_fraction


def balloon_wrench(R_hull, p_hull, mount_B, volume: float, rho: float, g: float):
    """Buoyancy of the balloon, a sphere of ``volume`` [m^3] centred at ``mount_B`` on the
    hull (hull frame), clipped at the free surface; (6,) [tau_W, f_W] about the hull origin."""
    F = np.zeros(6)
    if not volume > 1e-9:
        return F
    radius = (3.0 * volume / (4.0 * np.pi)) ** (1.0 / 3.0)
    centre = p_hull + R_hull @ mount_B
    frac, cob = ellipsoid_submersion(centre[None], R_hull[None], np.full((1, 3), radius))
    lift = rho * g * volume * frac[0]
    r = cob[0] - p_hull
    F[:2] = (r[1] * lift, -r[0] * lift)
    F[5] = lift
    return F


def body_lift(nu, d_lift):
    """The body lift and moment of a hull at incidence, in its own frame (Fossen 2011,
    Handbook of Marine Craft Hydrodynamics, sec. 7.5; Prestero 2001, REMUS, sec. 4.6, the
    body-lift and Munk terms Y_uv, Z_uw, M_uw, N_uv): with nu = (u, v, w, p, q, r),

        Y = -Y_uv |u| v,   Z = -Z_uw |u| w,   M = -M_uw u w,   N = -N_uv u v.

    A lift at small incidence is proportional to U^2 sin(2 alpha) / 2, i.e. to u w. Fossen's
    u w is the form about a forward speed; reflecting the body fore-aft (u -> -u) leaves a
    side or vertical force as it is and turns a pitch or yaw moment over, so the forces take
    |u| (a body reversing still has its heave and sway resisted) and the moments u. Both
    vanish in pure heave or sway, where Eq. (2)'s diagonal terms are the whole force.

    Args:
        nu: (nb, 6) body-frame velocities relative to the water.
        d_lift: (nb, 4) [Y_uv, Z_uw, M_uw, N_uv] per body.

    Returns:
        (nb, 6) body-frame generalized forces [X, Y, Z, K, M, N].
    """
    u, v, w = nu[:, 0], nu[:, 1], nu[:, 2]
    out = np.zeros_like(nu)
    out[:, 1], out[:, 2] = -d_lift[:, 0] * np.abs(u) * v, -d_lift[:, 1] * np.abs(u) * w
    out[:, 4], out[:, 5] = -d_lift[:, 2] * u * w, -d_lift[:, 3] * u * v
    return out


def damping_wrenches(R, w, v, current, d_lin, d_quad, submerged_fraction, d_lift=None):
    """Eq. (2)'s linear + quadratic damping per body axis, on the velocity relative to the
    water, plus the body lift (``body_lift``), scaled by each body's submerged fraction.

    Args:
        R: (nb, 3, 3) body orientations; w, v: (nb, 3) angular and origin velocities (world).
        current: (3,) water velocity in the world.
        d_lin, d_quad: (nb, 6) coefficients per body axis (surge, sway, heave, roll, pitch, yaw).
        submerged_fraction: (nb,).
        d_lift: (nb, 4) body-lift coefficients (``body_lift``); None for none.

    Returns:
        (nb, 6) wrenches [tau_W, f_W] about each body origin.
    """
    Rt = np.swapaxes(R, 1, 2)
    nu = np.concatenate([_rotate(Rt, v - current), _rotate(Rt, w)], axis=1)
    d = -(d_lin + d_quad * np.abs(nu)) * nu
    if d_lift is not None:
        d = d + body_lift(nu, d_lift)
    d = d * np.asarray(submerged_fraction)[:, None]
    return np.concatenate([_rotate(R, d[:, 3:]), _rotate(R, d[:, :3])], axis=1)


def fin_strip_forces(
    R,
    w,
    v,
    current,
    elements,
    element_fraction,
    rho,
    c_normal,
    c_friction,
    pitch_max,
    pitch_pressure,
):
    """Blade-element forces on the fin strips (flat-plate normal force with passive pitching,
    skin friction), each scaled by its strip's submerged fraction.

    Returns:
        (strip positions relative to their body origin (ns, 3), forces (ns, 3)), world frame.
    """
    el = elements
    sb = el["strip_body"]
    Rs = R[sb]
    r_s = _rotate(Rs, el["strip_p"])
    v_s = v[sb] + cross(w[sb], r_s) - current
    n_s = _rotate(Rs, el["strip_n"])
    c_s = _rotate(Rs, el["strip_c"])
    n_s = passive_pitch(v_s, n_s, c_s, rho, c_normal, pitch_max, pitch_pressure)
    fs = plate_forces(v_s, n_s, el["strip_area"], rho, c_normal, c_friction)
    return r_s, fs * element_fraction[el["strip_element"]][:, None]


def residual_added_mass_wrench(
    R_hull, accel_W, alpha_W, residual_mass, residual_inertia, submerged_fraction: float
):
    """-M_res a and -I_res alpha in the hull frame, scaled by the submerged fraction;
    (6,) [tau_W, f_W] on the hull."""
    a_B = R_hull.T @ accel_W
    alpha_B = R_hull.T @ alpha_W
    return (
        np.concatenate([R_hull @ (-residual_inertia * alpha_B), R_hull @ (-residual_mass * a_B)])
        * submerged_fraction
    )
