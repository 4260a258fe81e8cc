"""What a scenario's fields mean for the rest of the package: the derived views (the robot's
parameters, the water's coefficients and current, the gait library, the behaviour tree, the
energy model, the estimates the controller reads), as methods of ``ScenarioViews``, which
``Scenario`` extends with its checks."""

import numpy as np

from manta_drake.config_io import ScenarioError
from manta_drake.control.behaviour_tree import compile_tree, default_tree, default_tree_parameters
from manta_drake.control.gait_files import gait_library
from manta_drake.modalities import ESTIMATES, MODALITY_BY_ESTIMATE, NAMES
from manta_drake.model import resolve_path
from manta_drake.model.actuators import load_energy_model
from manta_drake.model.coefficients import HydroCoefficients, load_coefficients, scale_coefficients
from manta_drake.model.robot_params import NUM_JOINTS, robot_with_fin_sweep_deg
from manta_drake.model.servo import back_emf_damping, servo_robot_params
from manta_drake.scenario.schema import resolve_fin_sweep_deg
from manta_drake.scenario.top import ScenarioFields
from manta_drake.station.current import CurrentSchedule


class ScenarioViews(ScenarioFields):
    """The scenario's fields with the views derived from them (no check here: a view of an
    unchecked scenario may raise where ``Scenario.validate`` would name the field)."""

    def fin_sweep_deg(self) -> float:
        """The fins' rest sweep [deg]: ``robot.fin_sweep_deg``, or if None the one that
        balances the stance of ``controller.gait_reading`` (gaits.BALANCED_FIN_SWEEP_DEG)."""
        return resolve_fin_sweep_deg(self.robot.fin_sweep_deg, self.controller.gait_reading)

    def robot_params(self):
        """The RobotParams of this scenario's geometry (model.robot_params), with the joint
        gains, effort limit and damping of ``actuators.servo_model`` (model.servo)."""
        params = robot_with_fin_sweep_deg(self.fin_sweep_deg())
        if self.actuators.servo_model == "datasheet":
            params = servo_robot_params(
                params, self.energy_model().servo, self.bus_reference_voltage()
            )
        return params

    def bus_reference_voltage(self) -> float:
        """The bus voltage the plant's datasheet-servo gains are set at [V]: with the energy
        model on, the pack's full-charge open-circuit voltage (the station scales the
        servos' torque down to the battery's terminal voltage, ``station.servo_supply``);
        without it, the servo file's ``supply_voltage`` (a constant bus)."""
        model = self.energy_model()
        if self.actuators.enabled:
            return float(model.pack.open_circuit_voltage(1.0))
        return model.servo.supply_voltage

    def energy_model(self):
        """The resolved servos, electronics and battery (model.actuators.EnergyModel) of the
        ``actuators`` section: its file with its scales, the Jetson in its mode."""
        a = self.actuators
        return load_energy_model(a.file, a.scales, a.electronics_mode)

    def servo_braking(self) -> float:
        """The back-EMF braking b [N m s/rad] (model.servo) that the plant applies as joint
        damping and the station's ``joint_torque`` includes; 0 with the ideal PD."""
        if self.actuators.servo_model != "datasheet":
            return 0.0
        return back_emf_damping(self.energy_model().servo)

    def hydro_coefficients(self) -> HydroCoefficients | None:
        """The water model's coefficients: ``water.coefficients`` with
        ``water.coefficient_scales`` applied; None when ``water.enabled`` is false."""
        w = self.water
        if not w.enabled:
            return None
        return scale_coefficients(
            load_coefficients(resolve_path(w.coefficients)), w.coefficient_scales
        )

    def current_schedule(self) -> CurrentSchedule:
        """The water's current over time (``water.current_schedule``)."""
        return self.water.schedule()

    def gaits(self):
        """The gait library of this scenario (name -> GaitParams, read-only): the shipped
        ``models/gaits.yaml`` and ``controller.gait_files`` under ``controller.gait_reading``."""
        return gait_library(tuple(self.controller.gait_files), self.controller.gait_reading)

    def gait(self, name: str):
        """The gait ``name`` of this scenario's library; ScenarioError lists the known ones."""
        library = self.gaits()
        try:
            return library[name]
        except KeyError:
            raise ScenarioError(
                f"unknown gait {name!r}; known gaits: {', '.join(library)}"
            ) from None

    def initial_joint_angles(self) -> np.ndarray:
        """The initial joint angles (16, the plant's order): the stance X of
        ``initial_stance`` under ``controller.gait_reading``, or zeros."""
        if self.initial_stance == "zero":
            return np.zeros(NUM_JOINTS)
        return self.gait(self.initial_stance).X.ravel().copy()

    def behaviour_nodes(self) -> dict:
        """The behaviour tree's nodes: ``transition.tree``, or if empty the default tree,
        Eq. (12) exactly (swim, trot, turning)."""
        return dict(self.transition.tree) if self.transition.tree else default_tree()

    def behaviour_tree(self):
        """The compiled behaviour tree (``control.behaviour_tree.BehaviourTree``) over this
        scenario's gait library."""
        library = self.gaits()
        return compile_tree(
            self.behaviour_nodes(),
            {name: gait.to_vector() for name, gait in library.items()},
            ESTIMATES,
            "transition.tree",
        )

    def reads_charge_estimate(self) -> bool:
        """Whether the controller estimates the battery's charge (``EnergyEstimator``, a
        ``battery`` input): the energy model is on and the behaviour tree (transition mode),
        the balloon rule or the heading hold's changes read ``energy_hat``."""
        return self.has_estimator("energy_hat")

    def has_estimator(self, estimate: str) -> bool:
        """Whether the controller of this scenario builds the estimator of ``estimate`` (a
        modality with an estimator, ``manta_drake.modalities``): its sensor is on and,
        for one built only when read, something reads it."""
        return MODALITY_BY_ESTIMATE[estimate].built(self, estimate in self.estimates_read())

    def heading_changes_read(self) -> tuple[str, ...]:
        """The estimates ``heading_hold.changes`` read (when the hold is on)."""
        if not self.heading_hold.enabled:
            return ()
        return self.heading_hold.read()

    def estimates_read(self) -> dict[str, str]:
        """Every estimate the controller reads -> the field that reads it (the last of
        several): the behaviour tree (transition mode; the s_hat of Eq. (12)'s trees,
        ``default_tree(blend, z_t)``, only with the camera: they read it as 0 without), the
        balloon rule, the heading hold (``posture_hat``) and its changes."""
        used = {}
        if self.controller.mode == "transition":
            eq12 = default_tree_parameters(self.behaviour_nodes()) is not None
            used.update(
                {
                    m: "transition.tree"
                    for m in self.behaviour_tree().modalities
                    if not eq12 or m != "s_hat" or self.camera.enabled
                }
            )
        rule = self.balloon.rule.estimate(NAMES)
        if rule:
            used[rule] = "balloon.rule.modality"
        if self.heading_hold.enabled:
            used["posture_hat"] = "heading_hold.enabled"
            used.update({m: "heading_hold.changes" for m in self.heading_changes_read()})
        return used
