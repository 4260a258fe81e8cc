"""HydrodynamicForces: the water's forces on the robot as one Drake system (Eqs. 2-3).

A thin wrapper: it reads the robot's kinematics (no algebraic loop) and the balloon's
volume, and sums the water's terms (buoyancy, balloon, damping, fin blade elements,
residual added mass), plus the cancellation of the weight of the added-mass body that
``manta_drake.model.plant`` welds to the hull (added mass adds inertia, not weight).

As Drake's ``multibody/plant/wing.h``: every parameter is fixed at construction (the
kernels' arrays are packed once, in the constructor, and the parameters are read-only
attributes), the only state is the Context's, and ``AddToBuilder`` adds the system and
connects it to its plant. The water's current is fixed too, or, given a time-varying
``CurrentSchedule`` (``manta_drake.station.current``), a fixed function of the Context's
time, evaluated at each force evaluation.

Two choices, both constructor arguments, none changing the forces (the tests hold every
combination equal to 1e-12):

* ``backend``: ``"compiled"`` (the default) runs the maths in the numba kernels of
  ``manta_drake.station.water_kernels``; ``"numpy"`` in the pure numpy functions of
  ``manta_drake.station.water``, the reference the kernels are held to. Both are
  available on every instance as ``compute_compiled`` and ``compute_reference``.
* ``inputs``: the port set.

  - ``"contract"`` (the default, the design's contract): inputs ``body_poses`` and
    ``body_spatial_velocities`` (the plant's per-body outputs), output ``spatial_forces``
    (a list of ExternallyAppliedSpatialForce for the plant's ``applied_spatial_force``).
    Works with any plant.
  - ``"plant_state"`` (what the station uses): input ``plant_state`` (the plant's state
    vector [q, v]) instead of the two per-body inputs, and outputs ``spatial_forces`` and
    ``generalized_forces`` (J^T F at the current configuration, for the plant's
    ``applied_generalized_force``). Why: the per-body inputs are Python lists of 20
    RigidTransform / SpatialVelocity objects built and converted at every evaluation; one
    state vector costs ~1 us and the kernels compute the bodies' kinematics from it (the
    forward kinematics and J^T F are compiled with either backend: they have no numpy
    twin, and the tests hold them to the plant's own poses, velocities and Jacobians).
    docs/performance.md has the measurements.
"""

import math
import types

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.multibody.math import SpatialForce
from pydrake.multibody.plant import ExternallyAppliedSpatialForce
from pydrake.systems.framework import BasicVector, LeafSystem

from manta_drake.model.added_mass import heave_body_inertia, split_hull_added_mass
from manta_drake.model.coefficients import HydroCoefficients
from manta_drake.model.plant import FIN_ADDED_MASS_INSTANCE
from manta_drake.model.robot_params import DEFAULT_ROBOT, RobotParams
from manta_drake.station import foil
from manta_drake.station import foil_kernels as FK
from manta_drake.station import water_kernels as K
from manta_drake.station.current import CurrentSchedule
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

INPUTS = ("contract", "plant_state")
FIN_MODELS = foil.FIN_MODELS
BACKENDS = ("compiled", "numpy")
APPLY_AS = ("spatial_forces", "generalized_forces")


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
    I_com = M.Shift(M.get_com()).CalcRotationalInertia().CopyToFullMatrix3()
    return float(M.get_mass()), np.diag(I_com).copy()


def _fixed(name: str, doc: str) -> property:
    """A read-only attribute: the value the constructor fixed (and packed the kernels'
    arrays from), so assigning one fails instead of leaving the kernels behind."""
    return property(lambda self: self._fixed_values[name], doc=doc)


def _frozen(value):
    """``value`` as a read-only numpy array (an in-place change raises)."""
    array = np.array(value)
    array.setflags(write=False)
    return array


class HydrodynamicForces(LeafSystem):
    """Hydrostatic, damping, blade-element and residual added-mass forces (Eqs. 2-3).

    .. pydrake_system::

        name: HydrodynamicForces
        input_ports:
        - body_poses (inputs="contract")
        - body_spatial_velocities (inputs="contract")
        - plant_state (inputs="plant_state")
        - balloon_volume
        output_ports:
        - spatial_forces
        - generalized_forces (inputs="plant_state")

    * ``body_poses``, ``body_spatial_velocities``: the plant's outputs of the same names.
    * ``plant_state`` (nq + nv): the plant's ``state`` output.
    * ``balloon_volume`` (1): balloon volume [m^3] (from BalloonBuoyancy).
    * ``spatial_forces``: a list of ExternallyAppliedSpatialForce, one per robot body,
      for the plant's ``applied_spatial_force`` input.
    * ``generalized_forces`` (nv): the same forces as generalized forces (J^T F at the
      current configuration), for the plant's ``applied_generalized_force`` input.

    Per body, as [torque about its origin, force] in the world, the sum of: the lift
    rho g V_e s_e e_z of each volume element applied at its centre of buoyancy (s_e its
    submerged fraction: Eq. 3 at any attitude), the balloon's likewise, the damping
    ``-(D_lin + D_quad |nu|) nu s_b`` per body axis on the velocity nu relative to the water
    (Eq. 2), the fin strips' blade-element forces, and on the hull m_iso g e_z (the
    added-mass body's weight cancelled) and -M_res a_prev, -I_res alpha_prev per hull axis
    (the residual added mass, from the hull's finite-difference acceleration).

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
        current_schedule: None (the current is ``current`` at all times) or a
            ``CurrentSchedule``: the current as a function of the Context's time. A
            constant schedule is packed once as the fixed current; a time-varying one is
            evaluated at every force evaluation (``context.get_time()``; with
            ``update_period`` > 0 at each update). ``current`` must then be left at its
            default or equal the schedule's ``constant``.
        added_mass_iso: the isotropic added mass [kg] the plant carries in its mass matrix
            (None: split here from the coefficients).
        update_period: 0 (forces at every step) or the hold period [s], finite and >= 0.
        inputs: the port set, ``"contract"`` or ``"plant_state"`` (see the module
            docstring).
        backend: the force maths, ``"compiled"`` (numba kernels) or ``"numpy"`` (the
            reference functions of ``manta_drake.station.water``).
        fin_model: the fins' terms, ``"cross_flow"`` (the default here, as it works on any
            plant: blade elements with passive pitch, the hinges' reflected inertia) or
            ``"foil"`` (``manta_drake.station.foil``'s strips, with the added-mass bodies
            ``model.plant.add_plant(..., fin_added_mass="bodies")`` adds; the scenario's
            default, ``water.fin_model``, which the station builds that way).

    Raises:
        ValueError: naming the argument and its allowed values or range.
    """

    MAX_CURRENT = 2.0  # m/s: far above any pool's current; larger is a units mistake
    # The added-mass bodies' centring (omega_c [rad/s], zeta): a numerical choice that acts
    # on those bodies alone, so it moves none of the robot's forces; fast enough that a
    # body stays within millimetres of its plate's centre, slow against 1/time_step.
    CENTRING = (20.0, 1.0)

    rho = _fixed("rho", "Water density [kg/m^3].")
    g = _fixed("g", "Gravity [m/s^2].")
    current = _fixed(
        "current",
        "The water's velocity in the world (3,) [m/s]: at all "
        "times without a time-varying ``current_schedule``, else at t = 0.",
    )
    current_schedule = _fixed(
        "current_schedule", "The CurrentSchedule given (or None): the current over time."
    )
    time_step = _fixed("time_step", "The plant's period [s].")
    update_period = _fixed("update_period", "0 (forces at every step) or the hold period [s].")
    inputs = _fixed("inputs", "The port set: 'contract' or 'plant_state'.")
    backend = _fixed("backend", "The force maths: 'compiled' or 'numpy'.")
    body_indices = _fixed("body_indices", "The hydro bodies' BodyIndex values (ints).")
    el = _fixed("el", "Volume elements and strips (``water.build_elements``), read-only.")
    d_lin = _fixed("d_lin", "Linear damping per body and axis (nb, 6).")
    d_quad = _fixed("d_quad", "Quadratic damping per body and axis (nb, 6).")
    d_lift = _fixed("d_lift", "Body lift Y_uv, Z_uw, M_uw, N_uv per body (nb, 4).")
    c_normal = _fixed("c_normal", "Flat-plate normal-force coefficient.")
    c_friction = _fixed("c_friction", "Skin-friction coefficient.")
    pitch_max = _fixed("pitch_max", "Largest passive pitch of the fin plates [rad].")
    pitch_pressure = _fixed("pitch_pressure", "Passive pitch's reference pressure [Pa].")
    balloon_mount = _fixed("balloon_mount", "The balloon's centre on the hull (3,) [m].")
    added_mass_iso = _fixed("added_mass_iso", "Isotropic added mass in the mass matrix [kg].")
    residual_added_mass = _fixed(
        "residual_added_mass", "Explicit added mass (surge, sway, heave) [kg]."
    )
    residual_added_inertia = _fixed(
        "residual_added_inertia", "Explicit added inertia (roll, pitch, yaw) [kg m^2]."
    )
    effective_mass = _fixed("effective_mass", "The robot's mass with the implicit added mass [kg].")
    effective_inertia = _fixed(
        "effective_inertia",
        "The robot's inertia per hull axis with the implicit added inertia (3,) [kg m^2].",
    )

    def __init__(
        self,
        plant,
        robot,
        coeffs: HydroCoefficients,
        time_step: float,
        params: RobotParams = DEFAULT_ROBOT,
        current=(0.0, 0.0, 0.0),
        added_mass_iso: float | None = None,
        update_period: float = 0.0,
        *,
        inputs: str = "contract",
        backend: str = "compiled",
        current_schedule: CurrentSchedule | None = None,
        fin_model: str = "cross_flow",
    ):
        super().__init__()
        _check_choices(plant, time_step, update_period, inputs, backend, fin_model)
        self._foil = fin_model == "foil"
        current_array = _checked_current(current, current_schedule, self.MAX_CURRENT)
        # A time-varying schedule: the current is written, per evaluation, into a copy of
        # the kernels' parameter vector (see ``_current_now``).
        self._varying = current_schedule is not None and not current_schedule.is_constant
        self._plant_state = inputs == "plant_state"
        self._compiled = backend == "compiled"
        self._nq, self._nv = plant.num_positions(), plant.num_velocities()
        self._fixed_values, body_index, added, el = self._fix_parameters(
            plant,
            robot,
            coeffs,
            params,
            added_mass_iso,
            fin_model,
            current=_frozen(current_array),
            current_schedule=current_schedule,
            time_step=float(time_step),
            update_period=float(update_period),
            inputs=inputs,
            backend=backend,
        )
        self._strip_to_body = _frozen(np.eye(len(body_index))[:, el["strip_body"]])
        self._foil_reference_args, self._foil_packed = (
            self._pack_foil(coeffs, el, added) if self._foil else (None, None)
        )
        self._packed = self._pack_kernels(el)
        # The per-evaluation parameter vector of a time-varying current, and a view of its
        # current's slot: ``current_at`` writes three floats into it, nothing is allocated.
        self._prm_now = self._packed[3].copy()
        self._current_slot = self._prm_now[K.P_CURRENT : K.P_CURRENT + 3]
        self._make_scratch_forces(body_index)
        self._declare_state()
        self._declare_kinematics_inputs(plant, body_index)
        self._balloon = self.DeclareVectorInputPort("balloon_volume", 1)
        if self.update_period == 0.0:
            self._declare_force_outputs()
        else:
            self._declare_held_force_outputs(len(body_index))

    # -- construction ---------------------------------------------------------------------------

    def _fix_parameters(
        self, plant, robot, coeffs, params, added_mass_iso, fin_model, **choices
    ) -> tuple:
        """Every read-only parameter (``_fixed``): the checked ``choices`` and the water's,
        from the coefficients and the plant. Returns (those parameters, the bodies'
        BodyIndex values, the fins' added-mass bodies or None, the elements as built)."""
        body_index, added = _force_bodies(plant, robot, self._foil)
        nb = len(body_index)  # the hydro bodies, then the fins' added-mass bodies
        el = build_elements(coeffs, params)
        # Sums of element rows into body rows as matrix products (faster than np.add.at).
        el["elem_to_body"] = np.eye(nb)[:, el["body"]]
        d_lin, d_quad, d_lift = _damping(coeffs, nb)
        added_mass_iso, residual_added_mass, residual_added_inertia = _split_hull_added_mass(
            plant, robot, coeffs, added_mass_iso, self._foil
        )
        # The explicit residual acts on the hull's acceleration, which every body held by
        # the servos shares: compare it, axis by axis, with the whole robot's effective
        # mass and inertia (implicit added mass included) along that axis.
        mass, inertia = effective_inertia(plant, robot)
        check_explicit_added_mass(residual_added_mass, mass)
        check_explicit_added_mass(
            residual_added_inertia, inertia, ("roll", "pitch", "yaw"), "kg m^2"
        )
        fins = coeffs.fins
        fixed = {
            "rho": float(coeffs.water_density.value),
            "g": float(coeffs.gravity.value),
            **choices,  # current, current_schedule, time_step, update_period, inputs, backend
            "body_indices": tuple(int(i) for i in body_index),
            "el": types.MappingProxyType({k: _frozen(v) for k, v in el.items()}),
            "d_lin": _frozen(d_lin),
            "d_quad": _frozen(d_quad),
            "d_lift": _frozen(d_lift),
            "c_normal": float(fins.normal_force_coefficient.value),
            "c_friction": float(fins.skin_friction_coefficient.value),
            "pitch_max": float(np.radians(fins.passive_pitch_max_deg.value)),
            "pitch_pressure": float(fins.passive_pitch_reference_pressure.value),
            "balloon_mount": _frozen(np.asarray(coeffs.balloon.mount_point.value, dtype=float)),
            "added_mass_iso": float(added_mass_iso),
            "residual_added_mass": _frozen(residual_added_mass),
            "residual_added_inertia": _frozen(residual_added_inertia),
            "effective_mass": mass,
            "effective_inertia": _frozen(inertia),
            "fin_model": fin_model,
        }
        return fixed, body_index, added, el

    def _pack_kernels(self, el: dict) -> tuple:
        """The kernels' arrays, once: (elements, strips, damping, parameters)."""
        elements, strips = K.pack_elements(el)
        if self._foil:  # the strips are the foil model's: none for the cross-flow terms
            strips = np.zeros((0, strips.shape[1]))
        return (
            elements,
            strips,
            np.ascontiguousarray(np.hstack([self.d_lin, self.d_quad, self.d_lift]), dtype=float),
            K.pack_params(
                self.rho,
                self.g,
                self.c_normal,
                self.c_friction,
                self.pitch_max,
                self.pitch_pressure,
                self.added_mass_iso,
                self.current,
                self.balloon_mount,
                self.residual_added_mass,
                self.residual_added_inertia,
            ),
        )

    def _make_scratch_forces(self, body_index) -> None:
        """Scratch force objects for the outputs (body and point fixed here): each output
        calculation overwrites every force and set_value copies the list into the output
        (a C++ vector), so nothing of one evaluation outlives it. Reusing them halves the
        output's cost (measured: 19 against 38 us for 17 new objects per call)."""
        self._forces = [ExternallyAppliedSpatialForce() for _ in body_index]
        for force, index in zip(self._forces, body_index):
            force.body_index = index
            force.p_BoBq_B = np.zeros(3)

    def _declare_state(self) -> None:
        """The hull's velocity samples and, for the foil model, the fins' states."""
        # The hull's (v_W, w_W, t) at the last two updates; t = -1 marks "none yet".
        self._v_prev = self.DeclareDiscreteState(np.tile(np.r_[np.zeros(6), -1.0], 2))
        if self._foil:  # the strips' Wagner lag and attached share; the bodies' [v . n, t]
            self._lag = self.DeclareDiscreteState(self._foil_packed["lag0"].ravel())
            self._am_prev = self.DeclareDiscreteState(self._foil_packed["prev0"])
            self._attached = self.DeclareDiscreteState(self._foil_packed["attached0"])
        self._fin_period = self.time_step if self.update_period == 0.0 else self.update_period

    def _declare_kinematics_inputs(self, plant, body_index) -> None:
        """``plant_state`` (with the kernels' tree of the bodies), or ``body_poses`` and
        ``body_spatial_velocities``, as ``inputs`` says."""
        if self._plant_state:
            self._tree_i, self._tree_f = K.pack_tree(plant, body_index)
            # Where the hull's [w_W, v_W] sit in the state (a floating hull), else None.
            self._hull_v = (
                self._nq + int(self._tree_i[0, 3])
                if self._tree_i[0, 1] == K.QUATERNION_FLOATING
                else None
            )
            self._state = self.DeclareVectorInputPort("plant_state", self._nq + self._nv)
        else:
            self._poses = self.DeclareAbstractInputPort(
                "body_poses", plant.get_body_poses_output_port().Allocate()
            )
            self._velocities = self.DeclareAbstractInputPort(
                "body_spatial_velocities",
                plant.get_body_spatial_velocities_output_port().Allocate(),
            )

    def _forces_model(self) -> AbstractValue:
        return AbstractValue.Make(list(self._forces))

    def _declare_force_outputs(self) -> None:
        """The forces computed whenever the plant asks, and the hull's velocity sampled
        every ``time_step`` (for the residual added mass)."""
        self.DeclareAbstractOutputPort("spatial_forces", self._forces_model, self._calc_forces)
        if self._plant_state:
            self.DeclareVectorOutputPort("generalized_forces", self._nv, self._calc_generalized)
        self.DeclarePeriodicDiscreteUpdateEvent(self.time_step, 0.0, self._store_velocity)

    def _declare_held_force_outputs(self, nb: int) -> None:
        """The forces computed every ``update_period`` and held (a discrete state), from
        the initial state on."""
        self._held = self.DeclareDiscreteState(6 * nb)  # held [tau_W, f_W] per body
        self.DeclareAbstractOutputPort(
            "spatial_forces",
            self._forces_model,
            self._output_held,
            prerequisites_of_calc={self.xd_ticket()},
        )
        if self._plant_state:
            self.DeclareVectorOutputPort(
                "generalized_forces",
                self._nv,
                self._output_held_generalized,
                prerequisites_of_calc={
                    self.xd_ticket(),
                    self.input_port_ticket(self._state.get_index()),
                },
            )
        self.DeclarePeriodicDiscreteUpdateEvent(self.update_period, 0.0, self._update_held)
        # Held forces start from the initial state, not from zero.
        self.DeclareInitializationDiscreteUpdateEvent(self._update_held)

    def _pack_foil(self, coeffs: HydroCoefficients, el: dict, added: dict) -> tuple:
        """The foil model's arrays, once: (the numpy reference's strips, parameters and
        added-mass bodies; the kernels' tables of them with the plates' fraction weights and
        the discrete state at rest), both read-only mappings."""
        fins = coeffs.fins
        params = {
            "rho": self.rho,
            "lift_slope": float(fins.lift_slope.value),
            "suction_efficiency": float(fins.suction_efficiency.value),
            "cross_flow_coefficient": self.c_normal,
            "friction_coefficient": self.c_friction,
            "stall_angle": float(np.radians(fins.stall_angle_deg.value)),
            "stall_width": float(np.radians(fins.stall_width_deg.value)),
            "separation_lag": float(fins.separation_lag.value),
        }
        strips = {
            "body": el["strip_body"],
            "element": el["strip_element"],
            "p": el["strip_p"],
            "normal": el["strip_n"],
            "chord_dir": el["strip_c"],
            "span_dir": el["strip_s"],
            "area": el["strip_area"],
            "chord": el["strip_chord"],
        }
        bodies = {k: added[k] for k in ("body", "plate", "mass", "inertia_normal", "R_PF", "p_PF")}
        # A plate's submerged fraction: the mean of its strips' elements' (equal volumes).
        weights = np.zeros((len(bodies["body"]), len(el["volume"])))
        for j, plate in enumerate(bodies["plate"]):
            elements = el["strip_element"][el["strip_body"] == plate]
            if len(elements):
                weights[j, elements] = 1.0 / len(elements)
            else:  # the hull's heave body: the hull's elements' volume-weighted mean
                elements = np.flatnonzero(el["body"] == plate)
                weights[j, elements] = el["volume"][elements] / el["volume"][elements].sum()
        reference = types.MappingProxyType({"strips": strips, "params": params, "bodies": bodies})
        return reference, types.MappingProxyType(
            {
                "strips": FK.pack_strips(*strips.values()),
                "params": FK.pack_foil_params(**params, current=self.current),
                "bodies": FK.pack_added_mass_bodies(*bodies.values()),
                "weights": np.ascontiguousarray(weights),
                "lag0": _frozen(np.zeros((len(el["strip_body"]), 2))),
                "prev0": _frozen(np.r_[np.zeros(len(bodies["body"])), -1.0]),
                "attached0": _frozen(np.ones(len(el["strip_body"]))),
            }
        )

    @staticmethod
    def AddToBuilder(
        builder,
        plant,
        robot,
        coeffs: HydroCoefficients,
        time_step: float,
        params: RobotParams = DEFAULT_ROBOT,
        current=(0.0, 0.0, 0.0),
        added_mass_iso: float | None = None,
        update_period: float = 0.0,
        *,
        inputs: str = "contract",
        backend: str = "compiled",
        current_schedule: CurrentSchedule | None = None,
        apply_as: str | None = None,
        name: str = "hydro",
        fin_model: str = "cross_flow",
    ) -> "HydrodynamicForces":
        """Adds a HydrodynamicForces to ``builder`` and connects it to ``plant``, as Drake's
        ``Wing.AddToBuilder``: its kinematics inputs from the plant's outputs (the state
        vector, or the body poses and spatial velocities, as ``inputs`` says) and its forces
        into the plant's applied-force input. ``balloon_volume`` is left to the caller.

        Args:
            builder: the DiagramBuilder holding ``plant``.
            plant, robot, coeffs, time_step, params, current, added_mass_iso: the
                constructor's arguments.
            update_period, inputs, backend, current_schedule: the constructor's arguments.
            apply_as: ``"generalized_forces"`` (needs ``inputs="plant_state"``) into the
                plant's ``applied_generalized_force``, ``"spatial_forces"`` into its
                ``applied_spatial_force``, or None: generalized forces with the state
                input and forces at every step, spatial forces otherwise. Why: at every
                step one vector out is cheaper than 17 force objects; held forces are
                cheaper as the list, which changes only at the updates, so Drake's cache
                keeps it in between and the plant maps it to joint torques in C++ (a held
                generalized-force vector depends on q and needs a Python call per step:
                measured slower, 0.65 against 0.69 of the plant alone's speed, median of 5
                interleaved rounds of scripts/benchmark.py).
            name: the system's name in the diagram.

        Returns:
            The system, owned by the builder.

        Raises:
            ValueError: naming the argument and its allowed values.
        """
        _check_apply_as(apply_as, inputs)
        hydro = builder.AddNamedSystem(
            name,
            HydrodynamicForces(
                plant,
                robot,
                coeffs,
                time_step,
                params,
                current,
                added_mass_iso,
                update_period,
                inputs=inputs,
                backend=backend,
                current_schedule=current_schedule,
                fin_model=fin_model,
            ),
        )
        if apply_as is None:
            apply_as = _default_apply_as(inputs, update_period)
        _connect_to_plant(builder, plant, hydro, apply_as)
        return hydro

    # -- the maths ------------------------------------------------------------------------------

    def compute(
        self,
        R,
        p,
        w,
        v,
        balloon_volume: float,
        hull_accel_W=None,
        hull_alpha_W=None,
        *,
        current=None,
        t: float = 0.0,
        fin_state=None,
    ) -> np.ndarray:
        """Spatial forces [tau_W, f_W] (per hydro body, about its origin) from kinematics,
        by this system's ``backend`` (``compute_compiled`` or ``compute_reference``).

        Args:
            R, p: (nb, 3, 3), (nb, 3) body orientations and origins in the world.
            w, v: (nb, 3) angular and origin velocities in the world.
            balloon_volume: [m^3].
            hull_accel_W, hull_alpha_W: (3,) hull translational and angular acceleration
                estimates for the residual added mass and inertia (None: not yet known).
            current: (3,) the water's velocity in the world for this evaluation [m/s]
                (None: the fixed ``current``).
            t: the time [s] (the foil model's added-mass bodies difference their velocity
                against the state's sample).
            fin_state: the foil model's discrete state (``lag`` (ns, 2), ``prev`` (nm + 1)
                and ``attached`` (ns,), which may be left out: attached), None: at rest,
                nothing known yet.
        """
        if self._compiled:
            return self.compute_compiled(
                R,
                p,
                w,
                v,
                balloon_volume,
                hull_accel_W,
                hull_alpha_W,
                current=current,
                t=t,
                fin_state=fin_state,
            )
        return self.compute_reference(
            R,
            p,
            w,
            v,
            balloon_volume,
            hull_accel_W,
            hull_alpha_W,
            current=current,
            t=t,
            fin_state=fin_state,
        )

    def compute_compiled(
        self,
        R,
        p,
        w,
        v,
        balloon_volume: float,
        hull_accel_W=None,
        hull_alpha_W=None,
        *,
        current=None,
        t: float = 0.0,
        fin_state=None,
    ) -> np.ndarray:
        """``compute`` by the numba kernels (``water_kernels.spatial_wrenches``, and
        ``foil_kernels.add_foil_forces`` for the foil model)."""
        elements, strips, damping, _ = self._packed
        prm = self._params_with(current)
        has_accel = hull_accel_W is not None
        accel = np.zeros(6)
        if has_accel:
            accel[:3], accel[3:] = hull_accel_W, hull_alpha_W
        R, p, w, v = (np.ascontiguousarray(a, dtype=float) for a in (R, p, w, v))
        frac = np.empty(len(elements))
        F = K.spatial_wrenches(
            R,
            p,
            w,
            v,
            float(balloon_volume),
            accel,
            has_accel,
            elements,
            strips,
            damping,
            prm,
            frac,
        )
        return self._add_foil_compiled(F, R, p, w, v, frac, prm, t, fin_state)

    def _add_foil_compiled(self, F, R, p, w, v, frac, prm, t: float, fin_state):
        if not self._foil:
            return F
        lag, prev, attached = self._fin_state_or_rest(fin_state)
        f = self._foil_packed
        return FK.add_foil_forces(
            F,
            R,
            p,
            w,
            v,
            frac,
            prm[K.P_CURRENT : K.P_CURRENT + 3],
            float(t),
            f["strips"],
            f["params"],
            lag,
            attached,
            f["bodies"],
            f["weights"],
            prev,
            *self.CENTRING,
        )

    def compute_reference(
        self,
        R,
        p,
        w,
        v,
        balloon_volume: float,
        hull_accel_W=None,
        hull_alpha_W=None,
        *,
        current=None,
        t: float = 0.0,
        fin_state=None,
    ) -> np.ndarray:
        """``compute`` by the pure numpy functions of ``manta_drake.station.water`` (and
        ``manta_drake.station.foil`` for the foil model)."""
        if current is None:
            current = self.current
        F, frac, body_frac = buoyancy_wrenches(R, p, self.el, self.rho, self.g)
        F[0] += balloon_wrench(R[0], p[0], self.balloon_mount, balloon_volume, self.rho, self.g)
        F += damping_wrenches(R, w, v, current, self.d_lin, self.d_quad, body_frac, self.d_lift)
        if self._foil:
            F += self._foil_reference(R, p, w, v, current, frac, t, fin_state)
        else:
            r_s, fs = fin_strip_forces(
                R,
                w,
                v,
                current,
                self.el,
                frac,
                self.rho,
                self.c_normal,
                self.c_friction,
                self.pitch_max,
                self.pitch_pressure,
            )
            F += self._strip_to_body @ np.concatenate([cross(r_s, fs), fs], axis=1)
        # The isotropic added mass is in the mass matrix: cancel its weight.
        F[0, 5] += self.added_mass_iso * self.g
        if hull_accel_W is not None:
            F[0] += residual_added_mass_wrench(
                R[0],
                hull_accel_W,
                hull_alpha_W,
                self.residual_added_mass,
                self.residual_added_inertia,
                body_frac[0],
            )
        return F

    def _foil_reference(self, R, p, w, v, current, frac, t: float, fin_state) -> np.ndarray:
        """The foil model's strip and added-mass-body forces by the numpy functions."""
        lag, prev, attached = self._fin_state_or_rest(fin_state)
        f = self._foil_reference_args
        S, _, _, _ = foil.strip_wrenches(
            R, w, v, current, f["strips"], frac, lag, f["params"], attached
        )
        bodies = f["bodies"]
        nm = len(bodies["body"])
        a_n = foil.added_mass_normal_acceleration(R, w, v, bodies, prev[:nm], prev[nm], t)
        A, _ = foil.added_mass_body_wrenches(
            R, p, w, v, current, bodies, self._foil_packed["weights"] @ frac, a_n, *self.CENTRING
        )
        return S + A

    def _fin_state_or_rest(self, fin_state):
        """(lag, prev, attached) of ``fin_state``, or at rest (zero lag, no earlier sample,
        attached flow)."""
        f = self._foil_packed
        if fin_state is None:
            return f["lag0"], f["prev0"], f["attached0"]
        lag, prev, *rest = fin_state
        attached = rest[0] if rest else f["attached0"]
        return (
            np.ascontiguousarray(lag, dtype=float).reshape(-1, 2),
            np.ascontiguousarray(prev, dtype=float),
            np.ascontiguousarray(attached, dtype=float),
        )

    def compute_from_state(
        self, x, balloon_volume: float, t: float, v_prev, fin_state=None
    ) -> np.ndarray:
        """The spatial forces the system outputs at the plant state ``x`` = [q, v] and time
        ``t`` (needs ``inputs="plant_state"``), by its ``backend``; a time-varying
        ``current_schedule`` is read at ``t``.

        Args:
            x: (nq + nv,) the plant's state.
            balloon_volume: [m^3], finite.
            t: the time [s].
            v_prev: (14,) the velocity samples of the discrete state: two [v_W (3),
                w_W (3), t] of the hull, newest first (t < 0: none).
            fin_state: the foil model's discrete state, as ``compute``'s.
        """
        self._require_plant_state("compute_from_state")
        return self._from_state(
            np.ascontiguousarray(x, dtype=float),
            float(balloon_volume),
            float(t),
            np.ascontiguousarray(v_prev, dtype=float),
            self._current_now(float(t)),
            fin_state,
        )

    def generalized_forces(self, x, F) -> np.ndarray:
        """J^T F at the plant state ``x`` (needs ``inputs="plant_state"``): the generalized
        forces of the spatial forces F (nb, 6) [tau_W, f_W] at the body origins."""
        self._require_plant_state("generalized_forces")
        return K.generalized_forces_from_state(
            np.ascontiguousarray(x, dtype=float),
            self._nq,
            self._nv,
            np.ascontiguousarray(F, dtype=float).ravel(),
            self._tree_i,
            self._tree_f,
        )

    def _require_plant_state(self, what: str) -> None:
        if not self._plant_state:
            raise ValueError(
                f"HydrodynamicForces.{what}: needs inputs='plant_state' (the "
                f"packed kinematic tree), this system has inputs={self.inputs!r}"
            )

    def _current_now(self, t: float):
        """The current at time ``t`` when it varies (a view of the per-evaluation
        parameter vector's slot, valid until the next call), else None: the fixed one."""
        if not self._varying:
            return None
        return self.current_schedule.at(t, out=self._current_slot)

    def _params_with(self, current) -> np.ndarray:
        """The kernels' parameter vector with ``current`` (None: the packed one, as it is)."""
        if current is None:
            return self._packed[3]
        if current is not self._current_slot:
            self._current_slot[:] = current
        return self._prm_now

    def _from_state(
        self, x, balloon_volume: float, t: float, v_prev, current=None, fin_state=None
    ) -> np.ndarray:
        if self._compiled:  # one kernel call: kinematics, acceleration estimate, forces
            elements, strips, damping, _ = self._packed
            prm = self._params_with(current)
            frac = np.empty(len(elements))
            F, R, p, w, v = K.forces_from_state(
                x,
                self._nq,
                balloon_volume,
                t,
                v_prev,
                self._tree_i,
                self._tree_f,
                elements,
                strips,
                damping,
                prm,
                frac,
            )
            return self._add_foil_compiled(F, R, p, w, v, frac, prm, t, fin_state)
        R, p, w, v, _, _ = K.body_kinematics(x, self._nq, self._tree_i, self._tree_f)
        return self.compute_reference(
            R,
            p,
            w,
            v,
            balloon_volume,
            *_hull_acceleration(v[0], w[0], t, v_prev),
            current=current,
            t=t,
            fin_state=fin_state,
        )

    # -- evaluation -----------------------------------------------------------------------------

    def _kinematics(self, context):
        """(R, p, w, v) of the hydro bodies in the world, from the input ports."""
        if self._plant_state:
            R, p, w, v, _, _ = K.body_kinematics(
                self._state.Eval(context), self._nq, self._tree_i, self._tree_f
            )
            return R, p, w, v
        poses = self._poses.Eval(context)
        velocities = self._velocities.Eval(context)
        X = np.array([poses[i].GetAsMatrix34() for i in self.body_indices])
        V = np.array([velocities[i].get_coeffs() for i in self.body_indices])
        return X[:, :, :3], X[:, :, 3], V[:, :3], V[:, 3:]

    def _forces_now(self, context) -> np.ndarray:
        balloon = float(self._balloon.Eval(context)[0])
        if not math.isfinite(balloon):
            balloon = 0.0
        t = context.get_time()
        v_prev = context.get_discrete_state(self._v_prev).get_value()
        current = self._current_now(t)
        fin_state = self._fin_state(context)
        if self._plant_state:
            F = self._from_state(self._state.Eval(context), balloon, t, v_prev, current, fin_state)
        else:
            R, p, w, v = self._kinematics(context)
            F = self.compute(
                R,
                p,
                w,
                v,
                balloon,
                *_hull_acceleration(v[0], w[0], t, v_prev),
                current=current,
                t=t,
                fin_state=fin_state,
            )
        if not math.isfinite(F.sum()):  # a NaN or inf anywhere makes the sum non-finite
            raise RuntimeError(
                f"HydrodynamicForces: non-finite force at t = {t:.4f} s "
                "(the body state is no longer finite)"
            )
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
        output.SetFromVector(
            K.generalized_forces_from_state(
                self._state.Eval(context),
                self._nq,
                self._nv,
                context.get_discrete_state(self._held).get_value(),
                self._tree_i,
                self._tree_f,
            )
        )

    def _update_held(self, context, discrete_state):
        F = self._forces_now(context)
        discrete_state.get_mutable_vector(self._held).SetFromVector(F.ravel())
        self._store_velocity(context, discrete_state)

    def _fin_state(self, context):
        """The foil model's (lag, prev, attached) in ``context``, or None (cross-flow)."""
        if not self._foil:
            return None
        return tuple(
            context.get_discrete_state(i).get_value()
            for i in (self._lag, self._am_prev, self._attached)
        )

    def _step_fin_state(self, context, discrete_state, dt: float) -> None:
        """Advances the foil model's discrete state by one period ``dt`` from the state in
        ``context``: the strips' Wagner lag and the added-mass bodies' normal velocity."""
        if not self._foil:
            return
        R, p, w, v = (np.ascontiguousarray(a) for a in self._kinematics(context))
        lag, _, attached = self._fin_state(context)
        t = context.get_time()
        current = self._current_now(t)
        current = self.current if current is None else current
        f = self._foil_packed
        lag = np.ascontiguousarray(lag).reshape(-1, 2)
        attached = np.ascontiguousarray(attached)
        if self._compiled:
            lag_next, attached_next, q = FK.foil_state_step(
                R,
                w,
                v,
                np.ascontiguousarray(current, dtype=float),
                f["strips"],
                f["params"],
                lag,
                attached,
                f["bodies"],
                dt,
            )
        else:
            ref = self._foil_reference_args
            prm = ref["params"]
            _, w34, speed, alpha = foil.strip_wrenches(
                R, w, v, current, ref["strips"], np.ones(len(self.el["volume"])), lag, prm, attached
            )
            chord = ref["strips"]["chord"]
            lag_next = foil.wagner_step(lag, w34, speed, chord, dt)
            attached_next = foil.separation_step(
                attached,
                alpha,
                speed,
                chord,
                dt,
                prm["stall_angle"],
                prm["stall_width"],
                prm["separation_lag"],
            )
            body = ref["bodies"]["body"]
            q = (v[body] * R[body][:, :, 2]).sum(axis=1)
        discrete_state.get_mutable_vector(self._lag).SetFromVector(lag_next.ravel())
        discrete_state.get_mutable_vector(self._attached).SetFromVector(attached_next)
        discrete_state.get_mutable_vector(self._am_prev).SetFromVector(np.r_[q, t])

    def _store_velocity(self, context, discrete_state):
        """Shifts the hull's velocity samples: [now, the newest before]."""
        samples = discrete_state.get_mutable_vector(self._v_prev).get_mutable_value()
        # The older slot first, from the context (safe even if the two were one buffer).
        samples[7:] = context.get_discrete_state(self._v_prev).get_value()[:7]
        if self._plant_state and self._hull_v is not None:  # floating hull: [w, v] in x
            x, h = self._state.Eval(context), self._hull_v
            samples[:3], samples[3:6] = x[h + 3 : h + 6], x[h : h + 3]
        elif self._plant_state:
            _, _, w, v = self._kinematics(context)
            samples[:3], samples[3:6] = v[0], w[0]
        else:
            V = self._velocities.Eval(context)[self.body_indices[0]]
            samples[:3], samples[3:6] = V.translational(), V.rotational()
        samples[6] = context.get_time()
        self._step_fin_state(context, discrete_state, self._fin_period)


def _check_apply_as(apply_as: str | None, inputs: str) -> None:
    """Raises ValueError unless ``apply_as`` is None or one of APPLY_AS, and
    ``generalized_forces`` comes with ``inputs="plant_state"``."""
    if apply_as is not None and apply_as not in APPLY_AS:
        raise ValueError(
            f"HydrodynamicForces.AddToBuilder.apply_as: {apply_as!r} must be "
            f"None or one of {', '.join(map(repr, APPLY_AS))}"
        )
    if apply_as == "generalized_forces" and inputs != "plant_state":
        raise ValueError(
            "HydrodynamicForces.AddToBuilder.apply_as: 'generalized_forces' "
            f"needs inputs='plant_state', got inputs={inputs!r}"
        )


def _default_apply_as(inputs: str, update_period: float) -> str:
    """AddToBuilder's ``apply_as=None``: generalized forces with the state input and forces
    at every step, spatial forces otherwise (AddToBuilder says why)."""
    return (
        "generalized_forces" if inputs == "plant_state" and update_period == 0 else "spatial_forces"
    )


def _connect_to_plant(builder, plant, hydro: HydrodynamicForces, apply_as: str) -> None:
    """Connects ``hydro``'s kinematics inputs from ``plant``'s outputs and its forces, as
    ``apply_as`` says, into the plant's applied-force input."""
    if hydro.inputs == "plant_state":
        builder.Connect(plant.get_state_output_port(), hydro.GetInputPort("plant_state"))
    else:
        builder.Connect(plant.get_body_poses_output_port(), hydro.GetInputPort("body_poses"))
        builder.Connect(
            plant.get_body_spatial_velocities_output_port(),
            hydro.GetInputPort("body_spatial_velocities"),
        )
    if apply_as == "generalized_forces":
        builder.Connect(
            hydro.GetOutputPort("generalized_forces"),
            plant.get_applied_generalized_force_input_port(),
        )
    else:
        builder.Connect(
            hydro.GetOutputPort("spatial_forces"), plant.get_applied_spatial_force_input_port()
        )


def _hull_acceleration(v_hull, w_hull, t: float, v_prev):
    """Finite-difference hull accelerations (a_W, alpha_W) against the newest velocity
    sample taken strictly before ``t`` (whether this step's update has run yet depends on
    event order), or (None, None) when there is none; the numpy twin of
    ``water_kernels.hull_acceleration``.

    Args:
        v_hull, w_hull: (3,) the hull's velocity and angular velocity now (world).
        t: now [s].
        v_prev: (14,) two samples [v_W (3), w_W (3), t], newest first; t < 0: none.
    """
    for sample in np.reshape(v_prev, (2, 7)):
        if 0.0 <= sample[6] < t - 1e-12:
            dt = t - sample[6]
            return (v_hull - sample[:3]) / dt, (w_hull - sample[3:6]) / dt
    return None, None


def _is_real(value) -> bool:
    """A real number (not a bool, string or array)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _check_choices(
    plant, time_step: float, update_period: float, inputs: str, backend: str, fin_model: str
) -> None:
    """Raises ValueError naming the first of the constructor's choices outside its range
    (or the foil model without its bodies in ``plant``)."""
    if not (_is_real(time_step) and math.isfinite(time_step) and time_step > 0):
        raise ValueError(
            f"HydrodynamicForces.time_step: {time_step!r} must be a finite number > 0 [s]"
        )
    if not (_is_real(update_period) and math.isfinite(update_period) and update_period >= 0):
        raise ValueError(
            f"HydrodynamicForces.update_period: {update_period!r} must be a "
            "finite number >= 0 [s] (0: forces at every step)"
        )
    for name, value, allowed in (
        ("inputs", inputs, INPUTS),
        ("backend", backend, BACKENDS),
        ("fin_model", fin_model, FIN_MODELS),
    ):
        if not (isinstance(value, str) and value in allowed):
            raise ValueError(
                f"HydrodynamicForces.{name}: {value!r} must be one of "
                f"{', '.join(map(repr, allowed))}"
            )
    if fin_model == "foil" and not plant.HasModelInstanceNamed(FIN_ADDED_MASS_INSTANCE):
        raise ValueError(
            "HydrodynamicForces.fin_model: 'foil' needs the fins' added-mass "
            "bodies in the plant (add_plant(..., fin_added_mass='bodies'))"
        )


def _checked_current(current, current_schedule, max_current: float) -> np.ndarray:
    """The current at t = 0 [m/s] (3,): ``current``, checked, or the schedule's (which
    ``current`` must then leave at zero or equal)."""
    try:
        current_array = np.asarray(current, dtype=float)
    except (TypeError, ValueError):
        current_array = None
    if (
        current_array is None
        or current_array.shape != (3,)
        or not np.all(np.isfinite(current_array))
    ):
        raise ValueError(
            f"HydrodynamicForces.current: {current!r} must be 3 finite "
            "numbers (the water's velocity in the world, m/s)"
        )
    if np.linalg.norm(current_array) > max_current:
        raise ValueError(
            f"HydrodynamicForces.current: |{current!r}| = "
            f"{np.linalg.norm(current_array):.3g} m/s is outside the allowed "
            f"range [0, {max_current}] m/s"
        )
    if current_schedule is None:
        return current_array
    if not isinstance(current_schedule, CurrentSchedule):
        raise ValueError(
            f"HydrodynamicForces.current_schedule: {current_schedule!r} "
            "must be None or a CurrentSchedule"
        )
    if np.any(current_array != 0.0) and not np.array_equal(
        current_array, current_schedule.constant
    ):
        raise ValueError(
            f"HydrodynamicForces.current: {current!r} differs from the "
            "current_schedule's constant "
            f"{current_schedule.constant.tolist()}: give one of the two"
        )
    return current_schedule.at(0.0)


def _force_bodies(plant, robot, foil: bool) -> tuple[list, dict | None]:
    """The BodyIndex values the forces act on (the hydro bodies, then for the foil model
    the fins' added-mass bodies) and those added-mass bodies (``_added_mass_bodies``, or
    None)."""
    body_index = [plant.GetBodyByName(n, robot).index() for n in hydro_body_names()]
    added = _added_mass_bodies(plant, body_index) if foil else None
    if added is not None:
        body_index += added["index"]
    return body_index, added


def _damping(coeffs: HydroCoefficients, nb: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear and quadratic damping (nb, 6) and body lift (nb, 4) per body: the hull's,
    the links' for the other hydro bodies, none for the added-mass bodies."""
    b, links = coeffs.body, coeffs.links
    n_hydro = len(hydro_body_names())
    d_lin = np.zeros((nb, 6))
    d_quad = np.zeros((nb, 6))
    d_lin[:n_hydro] = links.linear_damping.value
    d_quad[:n_hydro] = links.quadratic_damping.value
    d_lin[0], d_quad[0] = b.linear_damping.value, b.quadratic_damping.value
    d_lift = np.zeros((nb, 4))
    d_lift[0] = b.body_lift.value
    return d_lin, d_quad, d_lift


def _split_hull_added_mass(
    plant, robot, coeffs: HydroCoefficients, added_mass_iso: float | None, foil: bool
) -> tuple:
    """The hull's added mass split into (the isotropic added mass in the mass matrix [kg],
    the explicit residual added mass (3,) [kg] and added inertia (3,) [kg m^2]); with the
    foil model the heave rides the hull's added-mass body (``model.plant``)."""
    b = coeffs.body
    carried = (0.0, 0.0, 0.0)
    if foil:
        iso, residual_added_mass, heave = split_hull_added_mass(
            b.added_mass.value, coeffs.fins.hull_interaction_added_mass.value
        )
        carried = heave_body_inertia(heave)
        added_mass_iso = iso if added_mass_iso is None else added_mass_iso
        residual_added_mass[:2] += iso - added_mass_iso
    elif added_mass_iso is None:
        added_mass_iso, residual_added_mass = split_added_mass(
            b.added_mass.value, plant.GetBodyByName("body", robot).default_mass()
        )
    else:
        residual_added_mass = np.asarray(b.added_mass.value) - added_mass_iso
    _, residual_added_inertia = split_added_inertia(b.added_inertia.value, carried)
    return added_mass_iso, residual_added_mass, residual_added_inertia


def _added_mass_bodies(plant, hydro_bodies) -> dict:
    """The fins' added-mass bodies of ``plant`` (``model.plant.add_fin_added_mass_bodies``):
    their BodyIndex values and, as rows of the force system's body list (the hydro bodies
    first, then these), each one's row, its plate's row, mass, moment about the plate's
    normal and joint frame on the plate."""
    instance = plant.GetModelInstanceByName(FIN_ADDED_MASS_INSTANCE)
    rows = {int(b): k for k, b in enumerate(hydro_bodies)}
    joints = [plant.get_joint(j) for j in plant.GetJointIndices(instance)]
    out: dict[str, list] = {
        "index": [],
        "body": [],
        "plate": [],
        "mass": [],
        "inertia_normal": [],
        "R_PF": [],
        "p_PF": [],
    }
    for k, joint in enumerate(joints):
        body = joint.child_body()
        X_PF = joint.frame_on_parent().GetFixedPoseInBodyFrame()
        out["index"].append(body.index())
        out["body"].append(len(hydro_bodies) + k)
        out["plate"].append(rows[int(joint.parent_body().index())])
        out["mass"].append(body.default_mass())
        out["inertia_normal"].append(body.default_rotational_inertia().CopyToFullMatrix3()[2, 2])
        out["R_PF"].append(X_PF.rotation().matrix())
        out["p_PF"].append(X_PF.translation())
    return {k: (v if k == "index" else np.array(v)) for k, v in out.items()}
