"""HydrodynamicForces: the water's forces on the robot as one Drake system (Eqs. 2-3).

A thin wrapper: it reads the robot's kinematics (no algebraic loop) and the balloon's
volume, and sums the water's terms (buoyancy, balloon, damping, fin blade elements,
residual added mass), plus the cancellation of the weight of the added-mass body that
``manta_drake.model.plant`` welds to the hull (added mass adds inertia, not weight).

The maths runs in the numba kernels of ``manta_drake.station.water_kernels``; the pure
numpy functions of ``manta_drake.station.water`` stay the reference
(``compute_reference``), and the tests hold the two equal to 1e-12.

Two port sets (the constructor's ``plant_state`` flag):

* ``plant_state=False`` (the default, the design's contract): inputs ``body_poses`` and
  ``body_spatial_velocities`` (the plant's per-body outputs), output ``spatial_forces``
  (a list of ExternallyAppliedSpatialForce for the plant's ``applied_spatial_force``).
  Works with any plant.
* ``plant_state=True`` (what the station uses): input ``plant_state`` (the plant's state
  vector [q, v]) instead of the two per-body inputs, and outputs ``spatial_forces`` and
  ``generalized_forces`` (J^T F at the current configuration, for the plant's
  ``applied_generalized_force``). Why: the per-body inputs are Python lists of 20
  RigidTransform / SpatialVelocity objects built and converted at every evaluation; one
  state vector costs ~1 us and the kernels compute the bodies' kinematics from it. The
  station applies ``generalized_forces`` when the forces are computed at every step (one
  vector instead of 17 force objects per step) and ``spatial_forces`` when they are held
  (``update_period`` > 0): the held list changes only at the updates, Drake's cache keeps
  it in between and the plant maps it to joint torques in C++, so no Python runs between
  updates (a held generalized-force vector depends on q, so it would need a Python call
  at every step). docs/performance.md has the measurements. The forces are the same as
  with the contract's ports to 1e-12.
"""

import math

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, LeafSystem

from manta_drake.model.coefficients import HydroCoefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT, RobotParams
from manta_drake.station import water_kernels as K
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
        - body_poses (plant_state=False)
        - body_spatial_velocities (plant_state=False)
        - plant_state (plant_state=True)
        - balloon_volume
        output_ports:
        - spatial_forces
        - generalized_forces (plant_state=True)

    * ``body_poses``, ``body_spatial_velocities``: the plant's outputs of the same names.
    * ``plant_state`` (nq + nv): the plant's ``state`` output.
    * ``balloon_volume`` (1): balloon volume [m^3] (from BalloonBuoyancy).
    * ``spatial_forces``: a list of ExternallyAppliedSpatialForce, one per robot body,
      for the plant's ``applied_spatial_force`` input.
    * ``generalized_forces`` (nv): the same forces as generalized forces (J^T F at the
      current configuration), for the plant's ``applied_generalized_force`` input.

    Discrete state: the hull's world velocity at the last two steps (for the residual
    added-mass force), updated every ``time_step``. With ``update_period`` > 0 the forces
    are instead computed in a periodic update every ``update_period`` seconds and held
    (a zero-order hold: cheaper, one period late); with 0 (default) they are computed
    from the current poses and velocities whenever the plant asks. Held forces are held
    as spatial forces: ``generalized_forces`` maps them at the current configuration at
    every step, exactly as the plant maps a held ``spatial_forces`` list.

    Args:
        plant, robot: the finalized MultibodyPlant and the robot's model instance.
        coeffs: the hydrodynamic coefficients.
        time_step: the plant's period [s], finite and > 0.
        params: the robot's geometry.
        current: the water's velocity in the world [m/s], 3 finite values of magnitude
            <= ``MAX_CURRENT``.
        added_mass_iso: the isotropic added mass [kg] the plant carries in its mass matrix
            (None: split here from the coefficients).
        update_period: 0 (forces at every step) or the hold period [s], finite and >= 0.
        plant_state: the port set (see the module docstring).

    Raises:
        ValueError: naming the argument and its allowed range.
    """

    MAX_CURRENT = 2.0  # m/s: far above any pool's current; larger is a units mistake

    # Attributes that the kernels read from packed arrays: assigning one (e.g. a test
    # setting residual_added_inertia) repacks them before the next evaluation. Assign a new
    # value; changing an array in place is not seen.
    _PACKED = frozenset({"rho", "g", "c_normal", "c_friction", "pitch_max", "pitch_pressure",
                         "added_mass_iso", "current", "balloon_mount", "residual_added_mass",
                         "residual_added_inertia", "d_lin", "d_quad", "el"})

    def __setattr__(self, name, value):
        if name in HydrodynamicForces._PACKED:
            self.__dict__["_packed"] = None
        super().__setattr__(name, value)

    def __init__(self, plant, robot, coeffs: HydroCoefficients, time_step: float,
                 params: RobotParams = DEFAULT_ROBOT, current=(0.0, 0.0, 0.0),
                 added_mass_iso: float | None = None, update_period: float = 0.0,
                 plant_state: bool = False):
        super().__init__()
        if not (_is_real(time_step) and math.isfinite(time_step) and time_step > 0):
            raise ValueError(f"HydrodynamicForces.time_step: {time_step!r} must be a finite "
                             "number > 0 [s]")
        if not (_is_real(update_period) and math.isfinite(update_period)
                and update_period >= 0):
            raise ValueError(f"HydrodynamicForces.update_period: {update_period!r} must be a "
                             "finite number >= 0 [s] (0: forces at every step)")
        try:
            current_array = np.asarray(current, dtype=float)
        except (TypeError, ValueError):
            current_array = None
        if current_array is None or current_array.shape != (3,) or not np.all(
                np.isfinite(current_array)):
            raise ValueError(f"HydrodynamicForces.current: {current!r} must be 3 finite "
                             "numbers (the water's velocity in the world, m/s)")
        if np.linalg.norm(current_array) > self.MAX_CURRENT:
            raise ValueError(f"HydrodynamicForces.current: |{current!r}| = "
                             f"{np.linalg.norm(current_array):.3g} m/s is outside the allowed "
                             f"range [0, {self.MAX_CURRENT}] m/s")
        self.rho = coeffs.water_density.value
        self.g = coeffs.gravity.value
        self.current = current_array
        self.time_step = float(time_step)
        self.update_period = float(update_period)
        self.plant_state = bool(plant_state)
        self._nq, self._nv = plant.num_positions(), plant.num_velocities()
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
        if self.plant_state:
            self._tree_i, self._tree_f = K.pack_tree(plant, body_index)
            # Where the hull's [w_W, v_W] sit in the state (a floating hull), else None.
            self._hull_v = (self._nq + int(self._tree_i[0, 3])
                            if self._tree_i[0, 1] == K.QUATERNION_FLOATING else None)
            self._sample = np.empty(14)  # _store_velocity's buffer
            self._state = self.DeclareVectorInputPort("plant_state", self._nq + self._nv)
        else:
            self._poses = self.DeclareAbstractInputPort(
                "body_poses", plant.get_body_poses_output_port().Allocate())
            self._velocities = self.DeclareAbstractInputPort(
                "body_spatial_velocities",
                plant.get_body_spatial_velocities_output_port().Allocate())
        self._balloon = self.DeclareVectorInputPort("balloon_volume", 1)
        forces_model = lambda: AbstractValue.Make(list(self._forces))  # noqa: E731
        if self.update_period == 0.0:
            self.DeclareAbstractOutputPort("spatial_forces", forces_model, self._calc_forces)
            if self.plant_state:
                self.DeclareVectorOutputPort("generalized_forces", self._nv,
                                             self._calc_generalized)
            self.DeclarePeriodicDiscreteUpdateEvent(self.time_step, 0.0, self._store_velocity)
        else:
            self._held = self.DeclareDiscreteState(6 * nb)  # held [tau_W, f_W] per body
            self.DeclareAbstractOutputPort(
                "spatial_forces", forces_model, self._output_held,
                prerequisites_of_calc={self.xd_ticket()})
            if self.plant_state:
                self.DeclareVectorOutputPort(
                    "generalized_forces", self._nv, self._output_held_generalized,
                    prerequisites_of_calc={self.xd_ticket(), self.input_port_ticket(
                        self._state.get_index())})
            self.DeclarePeriodicDiscreteUpdateEvent(self.update_period, 0.0, self._update_held)
            # Held forces start from the initial state, not from zero.
            self.DeclareInitializationDiscreteUpdateEvent(self._update_held)

    # -- evaluation ---------------------------------------------------------------------------

    def _pack(self):
        """The kernels' arrays, packed from the attributes (again after one is set)."""
        elements, strips = K.pack_elements(self.el)
        damping = np.ascontiguousarray(np.hstack([self.d_lin, self.d_quad]), dtype=float)
        prm = K.pack_params(self.rho, self.g, self.c_normal, self.c_friction, self.pitch_max,
                            self.pitch_pressure, self.added_mass_iso, self.current,
                            self.balloon_mount, self.residual_added_mass,
                            self.residual_added_inertia)
        self.__dict__["_packed"] = (elements, strips, damping, prm)
        return self._packed

    def _kinematics(self, context):
        """(R, p, w, v) of the hydro bodies in the world, from the input ports."""
        if self.plant_state:
            R, p, w, v, _, _ = K.body_kinematics(self._state.Eval(context), self._nq,
                                                 self._tree_i, self._tree_f)
            return R, p, w, v
        poses = self._poses.Eval(context)
        velocities = self._velocities.Eval(context)
        X = np.array([poses[i].GetAsMatrix34() for i in self.body_indices])
        V = np.array([velocities[i].get_coeffs() for i in self.body_indices])
        return X[:, :, :3], X[:, :, 3], V[:, :3], V[:, 3:]

    def compute(self, R, p, w, v, balloon_volume: float, hull_accel_W=None,
                hull_alpha_W=None) -> np.ndarray:
        """Spatial forces [tau_W, f_W] (per hydro body, about its origin) from kinematics,
        by the compiled kernel (``compute_reference`` is the numpy reference).

        Args:
            R, p: (nb, 3, 3), (nb, 3) body orientations and origins in the world.
            w, v: (nb, 3) angular and origin velocities in the world.
            balloon_volume: [m^3].
            hull_accel_W, hull_alpha_W: (3,) hull translational and angular acceleration
                estimates for the residual added mass and inertia (None: not yet known).
        """
        elements, strips, damping, prm = self._packed or self._pack()
        has_accel = hull_accel_W is not None
        accel = np.zeros(6)
        if has_accel:
            accel[:3], accel[3:] = hull_accel_W, hull_alpha_W
        return K.spatial_wrenches(
            np.ascontiguousarray(R, dtype=float), np.ascontiguousarray(p, dtype=float),
            np.ascontiguousarray(w, dtype=float), np.ascontiguousarray(v, dtype=float),
            float(balloon_volume), accel, has_accel, elements, strips, damping, prm)

    def compute_reference(self, R, p, w, v, balloon_volume: float, hull_accel_W=None,
                          hull_alpha_W=None) -> np.ndarray:
        """``compute`` by the pure numpy functions of ``manta_drake.station.water``."""
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

    def generalized_forces(self, x, F) -> np.ndarray:
        """J^T F at the plant state ``x`` (needs ``plant_state=True``): the generalized
        forces of the spatial forces F (nb, 6) [tau_W, f_W] at the body origins."""
        return K.generalized_forces_from_state(
            np.ascontiguousarray(x, dtype=float), self._nq, self._nv,
            np.ascontiguousarray(F, dtype=float).ravel(), self._tree_i, self._tree_f)

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
        balloon = float(self._balloon.Eval(context)[0])
        if not math.isfinite(balloon):
            balloon = 0.0
        if self.plant_state:  # one kernel call: kinematics, acceleration estimate, forces
            elements, strips, damping, prm = self._packed or self._pack()
            F = K.forces_from_state(
                self._state.Eval(context), self._nq, balloon, context.get_time(),
                context.get_discrete_state(self._v_prev).get_value(), self._tree_i,
                self._tree_f, elements, strips, damping, prm)
        else:
            R, p, w, v = self._kinematics(context)
            F = self.compute(R, p, w, v, balloon, *self._hull_accel(context, v[0], w[0]))
        if not math.isfinite(F.sum()):  # a NaN or inf anywhere makes the sum non-finite
            raise RuntimeError(
                f"HydrodynamicForces: non-finite force at t = {context.get_time():.4f} s "
                "(the body state is no longer finite)")
        return F

    def _write(self, F, output):
        # One SpatialForce per body from its 6-vector row [tau, f] (the cheapest pybind
        # path measured; these objects are most of the held path's cost).
        for force, row in zip(self._forces, F):
            force.F_Bq_W = SpatialForce(row)
        output.set_value(self._forces)

    def _calc_forces(self, context, output):
        self._write(self._forces_now(context), output)

    def _calc_generalized(self, context, output: BasicVector):
        F = self._forces_now(context)
        output.SetFromVector(self.generalized_forces(self._state.Eval(context), F))

    def _output_held(self, context, output):
        # Depends on the discrete state only: recomputed once per update, cached between.
        self._write(context.get_discrete_state(self._held).get_value().reshape(-1, 6), output)

    def _output_held_generalized(self, context, output: BasicVector):
        # At every plant step: keep it to one kernel call on the arrays as they come.
        output.SetFromVector(K.generalized_forces_from_state(
            self._state.Eval(context), self._nq, self._nv,
            context.get_discrete_state(self._held).get_value(), self._tree_i, self._tree_f))

    def _update_held(self, context, discrete_state):
        F = self._forces_now(context)
        discrete_state.get_mutable_vector(self._held).SetFromVector(F.ravel())
        self._store_velocity(context, discrete_state)

    def _store_velocity(self, context, discrete_state):
        if self.plant_state and self._hull_v is not None:  # floating hull: [w, v] in the state
            x, h, sample = self._state.Eval(context), self._hull_v, self._sample
            sample[:3], sample[3:6], sample[6] = x[h + 3:h + 6], x[h:h + 3], context.get_time()
            sample[7:] = context.get_discrete_state(self._v_prev).get_value()[:7]
            discrete_state.get_mutable_vector(self._v_prev).SetFromVector(sample)
            return
        if self.plant_state:
            _, _, w, v = self._kinematics(context)
            v_hull, w_hull = v[0], w[0]
        else:
            V = self._velocities.Eval(context)[self.body_indices[0]]
            v_hull, w_hull = V.translational(), V.rotational()
        newest = context.get_discrete_state(self._v_prev).get_value()[:7]
        discrete_state.get_mutable_vector(self._v_prev).SetFromVector(
            np.concatenate([v_hull, w_hull, [context.get_time()], newest]))


def _is_real(value) -> bool:
    """A real number (not a bool, string or array)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_))


def connect_hydro(builder, plant, hydro, generalized_forces: bool) -> None:
    """Wires a HydrodynamicForces to its plant: its inputs (the plant's state vector, or the
    body poses and spatial velocities of the contract ports, as ``hydro.plant_state`` says)
    and its forces to the plant, as generalized forces (``generalized_forces``, which needs
    ``hydro.plant_state``) or as the list of spatial forces."""
    if hydro.plant_state:
        builder.Connect(plant.get_state_output_port(), hydro.GetInputPort("plant_state"))
    else:
        if generalized_forces:
            raise ValueError("connect_hydro: generalized forces need plant_state=True")
        builder.Connect(plant.get_body_poses_output_port(), hydro.GetInputPort("body_poses"))
        builder.Connect(plant.get_body_spatial_velocities_output_port(),
                        hydro.GetInputPort("body_spatial_velocities"))
    if generalized_forces:
        builder.Connect(hydro.GetOutputPort("generalized_forces"),
                        plant.get_applied_generalized_force_input_port())
    else:
        builder.Connect(hydro.GetOutputPort("spatial_forces"),
                        plant.get_applied_spatial_force_input_port())
