"""HydrodynamicForces: the water's forces on the robot as one Drake system (Eqs. 2-3).

A thin wrapper: it reads the plant's body poses and velocities (no algebraic loop)
and the balloon's volume, and sums the terms computed by the pure functions of
``manta_drake.station.water`` (buoyancy, balloon, damping, fin blade elements,
residual added mass), plus the cancellation of the weight of the added-mass body that
``manta_drake.model.plant`` welds to the hull (added mass adds inertia, not weight).
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import LeafSystem

from manta_drake.model.coefficients import HydroCoefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT, RobotParams
from manta_drake.station.water import (
    balloon_wrench,
    build_elements,
    buoyancy_wrenches,
    check_explicit_added_mass,
    cross,
    damping_wrenches,
    fin_strip_forces,
    hydro_body_names,
    residual_added_mass_wrench,
    split_added_inertia,
    split_added_mass,
)


def effective_inertia(plant, robot) -> tuple[float, np.ndarray]:
    """Mass [kg] and the diagonal of the rotational inertia about the centre of mass, in
    the hull's axes [kg m^2], of the robot moving as one rigid body at its default pose,
    with the implicit added mass (model instance ``manta_added_mass``) included: what
    the hull's explicit added-mass residual acts against, axis by axis."""
    context = plant.CreateDefaultContext()
    bodies = list(plant.GetBodyIndices(robot))
    if plant.HasModelInstanceNamed("manta_added_mass"):
        bodies += plant.GetBodyIndices(plant.GetModelInstanceByName("manta_added_mass"))
    hull = plant.GetBodyByName("body", robot)
    M = plant.CalcSpatialInertia(context, hull.body_frame(), bodies)
    I = M.Shift(M.get_com()).CalcRotationalInertia().CopyToFullMatrix3()
    return float(M.get_mass()), np.diag(I).copy()


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
        if added_mass_iso is None:
            added_mass_iso, self.residual_added_mass = split_added_mass(
                b.added_mass.value, plant.GetBodyByName("body", robot).default_mass())
        else:
            self.residual_added_mass = np.asarray(b.added_mass.value) - added_mass_iso
        self.added_mass_iso = added_mass_iso
        _, self.residual_added_inertia = split_added_inertia(b.added_inertia.value)
        # The explicit residual acts on the hull's acceleration, which every body held by
        # the servos shares: compare it, axis by axis, with the whole robot's effective
        # mass and inertia (implicit added mass included) along that axis.
        self.effective_mass, self.effective_inertia = effective_inertia(plant, robot)
        check_explicit_added_mass(self.residual_added_mass, self.effective_mass)
        check_explicit_added_mass(self.residual_added_inertia, self.effective_inertia,
                                  ("roll", "pitch", "yaw"), "kg m^2")
        # Sums of element rows into body rows as matrix products (faster than np.add.at).
        self.el["elem_to_body"] = np.eye(nb)[:, self.el["body"]]
        self._strip_to_body = np.eye(nb)[:, self.el["strip_body"]]
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
        F, frac, body_frac = buoyancy_wrenches(R, p, self.el, self.rho, self.g)
        F[0] += balloon_wrench(R[0], p[0], self.balloon_mount, balloon_volume, self.rho, self.g)
        F += damping_wrenches(R, w, v, self.current, self.d_lin, self.d_quad, body_frac)
        r_s, fs = fin_strip_forces(R, w, v, self.current, self.el, frac, self.rho,
                                   self.c_normal, self.c_friction, self.pitch_max,
                                   self.pitch_pressure)
        F += self._strip_to_body @ np.concatenate([cross(r_s, fs), fs], axis=1)
        # The isotropic added mass is in the mass matrix: cancel its weight.
        F[0, 5] += self.added_mass_iso * self.g
        if hull_accel_W is not None:
            F[0] += residual_added_mass_wrench(R[0], hull_accel_W, hull_alpha_W,
                                               self.residual_added_mass,
                                               self.residual_added_inertia, body_frac[0])
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
