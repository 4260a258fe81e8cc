"""Hydrodynamic forces on the robot: Eq. (2) without Coriolis, plus blade elements.

What acts where (all computed from the plant's body poses and velocities, so
there is no algebraic loop):

* Restoring forces, Eq. (3) generalised to any attitude: each body's sealed
  volume is a set of ellipsoids (hull, servo cases, one small ellipsoid per fin
  strip). An affine map turns an ellipsoid into the unit ball and the free
  surface z = 0 into a plane, so the submerged volume and its centroid (the
  centre of buoyancy) are the spherical-cap formulas: exact, continuous, and
  half a body out of the water gets half its buoyancy. The balloon is a sphere
  of the volume ``balloon_volume`` at its mount. Gravity stays in the plant.
* Damping, Eq. (2)'s D: -(d_lin + d_quad |nu|) nu per axis of each body's frame,
  on the velocity relative to the water (optional uniform current), scaled by
  the body's submerged fraction.
* Fins: quasi-steady blade elements. Each fin plate is cut into spanwise strips;
  each strip sees the velocity of its own centre relative to the water and
  feels the flat-plate normal force -1/2 rho C_N A |v_n| v_n n (cross-flow
  principle) and skin friction -1/2 rho C_f A |v_t| v_t. This is what makes
  flapping produce thrust.
* Added mass: the isotropic part of the hull's added mass and its added
  rotational inertia are in the mass matrix (a massive body welded to the hull,
  see ``plant.add_plant``); this system cancels that body's weight exactly
  (added mass adds inertia, not weight). The fins' added inertia about each
  hinge is the actuators' reflected inertia. The residual, anisotropic part of
  the hull's added mass is applied explicitly, -M_res a, with a from the
  previous step's velocity change; ``split_added_mass`` checks at build time
  that it is smaller than the rigid mass on every axis, else the build fails.
"""

import dataclasses as dc

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from manta_drake.coefficients import HydroCoefficients
from manta_drake.robot_params import DEFAULT_ROBOT, LEGS, RobotParams

E_Z = np.array([0.0, 0.0, 1.0])
# An ellipsoid with semi-axes k * (box half-sizes) has the box's volume.
BOX_TO_ELLIPSOID = (6.0 / np.pi) ** (1.0 / 3.0)


# --- pure maths ------------------------------------------------------------------------------

def cross(a, b):
    """Row-wise cross product of (N, 3) arrays (np.cross is slow on small arrays)."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


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


def check_explicit_added_mass(residual, rigid_mass, axes=("surge", "sway", "heave"),
                              unit="kg") -> None:
    """Raises ValueError naming the first axis whose explicit added mass is not below
    the rigid mass (the explicit -M a force from the previous step would diverge)."""
    rigid = np.broadcast_to(np.asarray(rigid_mass, dtype=float), (3,))
    for axis, value, limit in zip(axes, np.asarray(residual, dtype=float), rigid):
        if abs(value) >= limit:
            raise ValueError(
                f"explicit added mass on the {axis} axis is {abs(value):.3g} {unit}, not below the "
                f"rigid {unit} {limit:.3g}: the simulation would oscillate and diverge. "
                "Put more of the added mass into the mass matrix or reduce it.")


# --- the system ------------------------------------------------------------------------------

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
    strip_element: list = dc.field(default_factory=list)  # its volume element


def build_elements(coeffs: HydroCoefficients, params: RobotParams = DEFAULT_ROBOT):
    """Volume elements and strips, per hydro body (0 = hull, then legs' links 1..4)."""
    e = _Elements()
    b = coeffs.body
    e.body.append(0)
    e.p.append(b.center_of_buoyancy.value)
    e.axes.append(b.sealed_semi_axes.value)
    servo_radius = (3.0 * coeffs.links.servo_volume.value / (4.0 * np.pi)) ** (1.0 / 3.0)
    n = int(coeffs.fins.strips_per_plate.value)
    if n < 1:
        raise ValueError(f"fins.strips_per_plate: {n} must be >= 1")
    t = params.fin_thickness
    for k in range(len(LEGS)):
        base = 1 + 4 * k
        for i in (0, 1):  # servo brackets
            e.body.append(base + i)
            e.p.append([0.0, 0.0, 0.0])
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
                half[0] = t / 2
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
                e.strip_area.append(chord * ds)
    arrays = {f.name: np.array(getattr(e, f.name), dtype=float) for f in dc.fields(e)}
    for name in ("body", "strip_body", "strip_element"):
        arrays[name] = arrays[name].astype(int)
    arrays["volume"] = 4.0 / 3.0 * np.pi * np.prod(arrays["axes"], axis=1)
    return arrays


def leading_edge_signs(params: RobotParams = DEFAULT_ROBOT) -> list:
    """Per leg, the sign of link 3's +y and link 4's +z along the body's forward axis at
    the zero pose (so strip chord directions point to the leading edge)."""
    from manta_drake.kinematics import X_BODYDRAKE_BODYNED, leg_frames_ned

    signs = []
    for leg in LEGS:
        F = [X_BODYDRAKE_BODYNED @ X for X in leg_frames_ned(leg, np.zeros(4), params)]
        # Link 3's frame is F_2 (joint 3 at zero); link 4's is F_3.
        signs.append((float(np.sign(F[2][0, 1])), float(np.sign(F[3][0, 2]))))
    return signs


def hydro_body_names() -> list:
    """Names of the hydro bodies in local order (hull, then each leg's links 1..4)."""
    return ["body"] + [f"{leg}_link{i}" for leg in LEGS for i in range(1, 5)]


class HydrodynamicForces(LeafSystem):
    """Hydrostatic, damping, blade-element and residual added-mass forces (Eqs. 2-3).

    .. pydrake_system::

        name: HydrodynamicForces
        input_ports:
        - body_poses
        - body_spatial_velocities
        - balloon_volume
        output_ports:
        - spatial_forces

    * ``body_poses``, ``body_spatial_velocities``: the plant's outputs of the same names.
    * ``balloon_volume`` (1): balloon volume [m^3] (from BalloonBuoyancy).
    * ``spatial_forces``: a list of ExternallyAppliedSpatialForce, one per robot body,
      for the plant's ``applied_spatial_force`` input.

    Discrete state: the hull's world velocity at the last two steps (for the residual
    added-mass force), updated every ``time_step``. With ``update_period`` > 0 the forces
    are instead computed in a periodic update every ``update_period`` seconds and held
    (a zero-order hold: cheaper, one period late); with 0 (default) they are computed
    from the current poses and velocities whenever the plant asks.
    """

    def __init__(self, plant, robot, coeffs: HydroCoefficients, time_step: float,
                 params: RobotParams = DEFAULT_ROBOT, current=(0.0, 0.0, 0.0),
                 added_mass_iso: float | None = None, update_period: float = 0.0):
        super().__init__()
        self.rho = coeffs.water_density.value
        self.g = coeffs.gravity.value
        self.current = np.asarray(current, dtype=float).reshape(3)
        self.time_step = float(time_step)
        names = hydro_body_names()
        body_index = [plant.GetBodyByName(n, robot).index() for n in names]
        self.body_indices = [int(i) for i in body_index]
        self.el = build_elements(coeffs, params)
        b, links = coeffs.body, coeffs.links
        nb = len(names)
        self.d_lin = np.tile(links.linear_damping.value, (nb, 1))
        self.d_quad = np.tile(links.quadratic_damping.value, (nb, 1))
        self.d_lin[0], self.d_quad[0] = b.linear_damping.value, b.quadratic_damping.value
        self.c_normal = coeffs.fins.normal_force_coefficient.value
        self.c_friction = coeffs.fins.skin_friction_coefficient.value
        self.pitch_max = np.radians(coeffs.fins.passive_pitch_max_deg.value)
        self.pitch_pressure = coeffs.fins.passive_pitch_reference_pressure.value
        self.balloon_mount = np.asarray(coeffs.balloon.mount_point.value, dtype=float)
        hull = plant.GetBodyByName("body", robot)
        hull_mass = hull.default_mass()
        if added_mass_iso is None:
            added_mass_iso, self.residual_added_mass = split_added_mass(
                b.added_mass.value, hull_mass)
        else:
            self.residual_added_mass = np.asarray(b.added_mass.value) - added_mass_iso
            check_explicit_added_mass(self.residual_added_mass, hull_mass + added_mass_iso)
        self.added_mass_iso = added_mass_iso
        _, self.residual_added_inertia = split_added_inertia(b.added_inertia.value)
        hull_inertia = hull.default_rotational_inertia().CalcPrincipalMomentsOfInertia().min()
        check_explicit_added_mass(self.residual_added_inertia, hull_inertia,
                                  ("roll", "pitch", "yaw"), "kg m^2")
        # Per-body volume (for the submerged fraction that scales the damping).
        self.body_volume = np.bincount(self.el["body"], weights=self.el["volume"], minlength=nb)
        # Sums of element rows into body rows as matrix products (faster than np.add.at).
        self._elem_to_body = np.eye(nb)[:, self.el["body"]]
        self._strip_to_body = np.eye(nb)[:, self.el["strip_body"]]
        self._lift_per_frac = self.rho * self.g * self.el["volume"]
        self._forces = [ExternallyAppliedSpatialForce() for _ in names]
        for force, index in zip(self._forces, body_index):
            force.body_index = index
            force.p_BoBq_B = np.zeros(3)
        # The hull's (v_W, w_W, t) at the last two updates; t = -1 marks "none yet".
        self._v_prev = self.DeclareDiscreteState(np.tile(np.r_[np.zeros(6), -1.0], 2))
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate())
        self._velocities = self.DeclareAbstractInputPort(
            "body_spatial_velocities", plant.get_body_spatial_velocities_output_port().Allocate())
        self._balloon = self.DeclareVectorInputPort("balloon_volume", 1)
        if not (np.isfinite(update_period) and update_period >= 0):
            raise ValueError(f"HydrodynamicForces.update_period: {update_period} must be >= 0")
        self.update_period = float(update_period)
        if self.update_period == 0.0:
            self.DeclareAbstractOutputPort(
                "spatial_forces", lambda: AbstractValue.Make(list(self._forces)),
                self._calc_forces)
            self.DeclarePeriodicDiscreteUpdateEvent(self.time_step, 0.0, self._store_velocity)
        else:
            self._held = self.DeclareDiscreteState(6 * nb)  # held [tau_W, f_W] per body
            self.DeclareAbstractOutputPort(
                "spatial_forces", lambda: AbstractValue.Make(list(self._forces)),
                self._output_held, prerequisites_of_calc={self.xd_ticket()})
            self.DeclarePeriodicDiscreteUpdateEvent(self.update_period, 0.0, self._update_held)
            # Held forces start from the initial state, not from zero.
            self.DeclareInitializationDiscreteUpdateEvent(self._update_held)

    # -- evaluation ---------------------------------------------------------------------------

    def _kinematics(self, context):
        poses = self._poses.Eval(context)
        velocities = self._velocities.Eval(context)
        X = np.array([poses[i].GetAsMatrix34() for i in self.body_indices])
        V = np.array([velocities[i].get_coeffs() for i in self.body_indices])
        return X[:, :, :3], X[:, :, 3], V[:, :3], V[:, 3:]

    def compute(self, R, p, w, v, balloon_volume: float, hull_accel_W=None,
                hull_alpha_W=None) -> np.ndarray:
        """Spatial forces [tau_W, f_W] (per hydro body, about its origin) from kinematics.

        Args:
            R, p: (nb, 3, 3), (nb, 3) body orientations and origins in the world.
            w, v: (nb, 3) angular and origin velocities in the world.
            balloon_volume: [m^3].
            hull_accel_W, hull_alpha_W: (3,) hull translational and angular acceleration
                estimates for the residual added mass and inertia (None: not yet known).
        """
        el = self.el
        rb = R[el["body"]]
        p_WE = p[el["body"]] + _rotate(rb, el["p"])
        frac, cob = ellipsoid_submersion(p_WE, rb, el["axes"])
        lift = self._lift_per_frac * frac
        r = cob - p[el["body"]]
        # Buoyancy lift * e_z at the centre of buoyancy: torque r x (0, 0, lift).
        elem = np.stack([r[:, 1] * lift, -r[:, 0] * lift, np.zeros_like(lift), np.zeros_like(lift),
                         np.zeros_like(lift), lift], axis=1)
        F = self._elem_to_body @ elem  # (nb, 6): tau, f
        body_frac = (self._elem_to_body @ (el["volume"] * frac)) / self.body_volume

        # Balloon: a sphere at its mount on the hull.
        if balloon_volume > 1e-9:
            radius = (3.0 * balloon_volume / (4.0 * np.pi)) ** (1.0 / 3.0)
            centre = p[0] + R[0] @ self.balloon_mount
            bf, bc = ellipsoid_submersion(centre[None], R[:1], np.full((1, 3), radius))
            fb = self.rho * self.g * balloon_volume * bf[0]
            rb0 = bc[0] - p[0]
            F[0, :2] += (rb0[1] * fb, -rb0[0] * fb)
            F[0, 5] += fb

        # Damping per body axis, relative to the water (body frame, then back to world).
        Rt = np.swapaxes(R, 1, 2)
        nu_lin = _rotate(Rt, v - self.current)
        nu_ang = _rotate(Rt, w)
        nu = np.concatenate([nu_lin, nu_ang], axis=1)
        d = -(self.d_lin + self.d_quad * np.abs(nu)) * nu * body_frac[:, None]
        F[:, 3:] += _rotate(R, d[:, :3])
        F[:, :3] += _rotate(R, d[:, 3:])

        # Blade elements on the fin strips.
        sb = el["strip_body"]
        Rs = R[sb]
        r_s = _rotate(Rs, el["strip_p"])
        v_s = v[sb] + cross(w[sb], r_s) - self.current
        n_s = _rotate(Rs, el["strip_n"])
        c_s = _rotate(Rs, el["strip_c"])
        n_s = passive_pitch(v_s, n_s, c_s, self.rho, self.c_normal, self.pitch_max,
                            self.pitch_pressure)
        fs = plate_forces(v_s, n_s, el["strip_area"], self.rho, self.c_normal, self.c_friction)
        fs *= frac[el["strip_element"]][:, None]
        F += self._strip_to_body @ np.concatenate([cross(r_s, fs), fs], axis=1)

        # Added mass: cancel the weight of the isotropic part (it is in the mass matrix),
        # and apply the residual explicitly from the previous step's acceleration.
        F[0, 5] += self.added_mass_iso * self.g
        if hull_accel_W is not None:
            a_B = R[0].T @ hull_accel_W
            F[0, 3:] += R[0] @ (-self.residual_added_mass * a_B * body_frac[0])
            alpha_B = R[0].T @ hull_alpha_W
            F[0, :3] += R[0] @ (-self.residual_added_inertia * alpha_B * body_frac[0])
        return F

    def _hull_accel(self, context, v_hull, w_hull):
        """Finite-difference hull accelerations against the newest sample taken strictly
        before now (whether this step's update has run yet depends on event order)."""
        t = context.get_time()
        for sample in context.get_discrete_state(self._v_prev).get_value().reshape(2, 7):
            if 0.0 <= sample[6] < t - 1e-12:
                dt = t - sample[6]
                return (v_hull - sample[:3]) / dt, (w_hull - sample[3:6]) / dt
        return None, None

    def _forces_now(self, context) -> np.ndarray:
        R, p, w, v = self._kinematics(context)
        balloon = self._balloon.Eval(context)[0]
        if not np.isfinite(balloon):
            balloon = 0.0
        F = self.compute(R, p, w, v, balloon, *self._hull_accel(context, v[0], w[0]))
        if not np.all(np.isfinite(F)):
            raise RuntimeError(
                f"HydrodynamicForces: non-finite force at t = {context.get_time():.4f} s "
                "(the body state is no longer finite)")
        return F

    def _write(self, F, output):
        for force, row in zip(self._forces, F):
            force.F_Bq_W = SpatialForce(row[:3], row[3:])
        output.set_value(self._forces)

    def _calc_forces(self, context, output):
        self._write(self._forces_now(context), output)

    def _output_held(self, context, output):
        self._write(context.get_discrete_state(self._held).get_value().reshape(-1, 6), output)

    def _update_held(self, context, discrete_state):
        F = self._forces_now(context)
        discrete_state.get_mutable_vector(self._held).SetFromVector(F.ravel())
        self._store_velocity(context, discrete_state)

    def _store_velocity(self, context, discrete_state):
        velocities = self._velocities.Eval(context)
        V = velocities[self.body_indices[0]]
        newest = context.get_discrete_state(self._v_prev).get_value()[:7]
        discrete_state.get_mutable_vector(self._v_prev).SetFromVector(
            np.concatenate([V.translational(), V.rotational(), [context.get_time()], newest]))
