"""The scenario's sections: what a scenario file may say, with each field's default and unit,
and each section's own checks.

Every section here has ``validate(self, where)``: it checks the fields it owns alone (type,
finite, range) and raises ScenarioError, one line naming the full dotted field
(``where`` is the section's dotted name, ``cpg`` or ``transition``), the value and the
allowed range. A range that a System's constructor checks too is declared once, in the
System's module (``control.cpg.FREQUENCY_HZ``, ``control.depth.FLOOR_DISTANCE``, ...), and
both use it. Checks that need several sections (a period against ``time_step``, a gait name
against the library) are the Scenario's (``manta_drake.scenario.checks``).

The balloon's, the sensors', the camera's, the actuators' and the simulator's sections are
in ``manta_drake.scenario.devices``; the sections of the modalities come from their registry
(``manta_drake.modalities.SECTIONS``); the top level's own fields are in
``manta_drake.scenario.top``.
"""

import dataclasses as dc
import math

from manta_drake.config_io import (
    ScenarioError,
    check_boolean,
    check_in_range,
    check_number,
    check_one_of,
    check_text,
    check_vector,
)
from manta_drake.control.behaviour_tree import BlendNode
from manta_drake.control.cpg import COUPLING_WEIGHT, FREQUENCY_HZ, GAIN
from manta_drake.control.gaits import BALANCED_FIN_SWEEP_DEG, READINGS
from manta_drake.control.transition import check_parameters
from manta_drake.model import resolve_path
from manta_drake.model.coefficients import load_coefficients, scale_coefficients
from manta_drake.model.plant import FRICTION
from manta_drake.station.current import CurrentPoint, CurrentSchedule, check_current_schedule
from manta_drake.station.foil import FIN_MODELS

CONTROLLER_MODES = ("hold", "gait", "transition")


@dc.dataclass
class InitialPose:
    """Initial pose of the robot's body in the world (z up, water surface at z = 0)."""

    xyz: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, -0.22])
    rpy_deg: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])

    def validate(self, where: str = "initial_pose") -> None:
        check_vector(f"{where}.xyz", self.xyz, 3)
        check_vector(f"{where}.rpy_deg", self.rpy_deg, 3, bound=360.0)


@dc.dataclass
class ControllerConfig:
    """What drives the joints' desired state.

    mode:
      ``hold``  the joints hold the stance (X) of ``gait``; no oscillation.
      ``gait``  the CPG runs ``gait`` for the whole run.
      ``transition``  the multifunctional controller chooses the behaviour (Eqs. 9-15).
    """

    mode: str = "hold"
    gait: str = "trot"
    # How Eqs. (6)-(8) are read (manta_drake.control.gaits.READINGS): ``paper`` (the
    # legged gaits as printed, the swim mirrored) or ``mirrored`` (one mirror rule for
    # every gait; its stance needs robot.fin_sweep_deg 30, its default then; docs/stance.md).
    gait_reading: str = "paper"
    # Gait files (manta_drake.control.gait_files) whose gaits join the shipped
    # models/gaits.yaml, in order: paths relative to the scenario file that names them (to
    # the working directory for --set and data), absolute, or package://manta_drake/...
    # Loading makes them absolute. A name defined twice is an error naming both files.
    gait_files: list[str] = dc.field(default_factory=list)

    def validate(self, where: str = "controller") -> None:
        """The reading, the gait files (each a string naming an existing file) and the mode;
        that ``gait`` names a gait of the library they make is the Scenario's check."""
        check_one_of(f"{where}.gait_reading", self.gait_reading, tuple(READINGS))
        check_one_of(f"{where}.mode", self.mode, CONTROLLER_MODES)
        files = self.gait_files
        if not isinstance(files, list):
            raise ScenarioError(f"{where}.gait_files: expected a list of paths, got {files!r}")
        for i, f in enumerate(files):
            check_text(f"{where}.gait_files[{i}]", f)
            if not resolve_path(f, f"{where}.gait_files[{i}]").is_file():
                raise ScenarioError(f"{where}.gait_files[{i}]: gait file not found: {f}")


@dc.dataclass
class RobotConfig:
    """The robot's geometry that the paper leaves open (manta_drake.model.robot_params)."""

    # Table 2's theta_offset: each leg-fin swept back by this at theta_1 = 0 [deg]. None: the
    # sweep that balances the stance of controller.gait_reading (gaits.BALANCED_FIN_SWEEP_DEG:
    # paper 10, which also keeps Table 1's size at the zero pose; mirrored 30), resolved where
    # it is used (Scenario.fin_sweep_deg) so that a later override of the reading moves it.
    # docs/stance.md.
    fin_sweep_deg: float | None = None

    def validate(self, where: str = "robot") -> None:
        if self.fin_sweep_deg is not None:
            # Beyond +-60 deg the yaw joint's +-60 deg range cannot bring a fin to the side.
            check_in_range(
                f"{where}.fin_sweep_deg",
                self.fin_sweep_deg,
                -60.0,
                60.0,
                "[-60, 60] deg (or null: the gait reading's balanced sweep)",
            )


def resolve_fin_sweep_deg(fin_sweep_deg: float | None, gait_reading: str) -> float:
    """``fin_sweep_deg``, or if None the sweep that balances ``gait_reading``'s stance
    (gaits.BALANCED_FIN_SWEEP_DEG)."""
    if fin_sweep_deg is not None:
        return float(fin_sweep_deg)
    try:
        return BALANCED_FIN_SWEEP_DEG[gait_reading]
    except KeyError:
        raise ScenarioError(
            f"controller.gait_reading: {gait_reading!r} is not one of "
            f"{', '.join(BALANCED_FIN_SWEEP_DEG)}"
        ) from None


@dc.dataclass
class CpgConfig:
    """Parameters of the CPG (Eq. 5); see ``manta_drake.control.cpg`` for why these defaults."""

    frequency_hz: float = 0.5
    chain_weight: float = 4.0
    fcs_weight: float = 4.0
    a: float = 20.0
    b: float = 20.0

    def validate(self, where: str = "cpg") -> None:
        """The ranges ``CpgOscillators`` checks too (declared in ``control.cpg``)."""
        FREQUENCY_HZ.check(f"{where}.frequency_hz", self.frequency_hz)
        for name in ("chain_weight", "fcs_weight"):
            COUPLING_WEIGHT.check(f"{where}.{name}", getattr(self, name))
        for name in ("a", "b"):
            GAIN.check(f"{where}.{name}", getattr(self, name))


@dc.dataclass
class TransitionConfig:
    """PotentialTransition (Eqs. 11-15); see ``manta_drake.control.transition`` for the defaults."""

    period: float = 0.02  # s
    g: float = 0.125
    T: float = 0.5
    alpha: float = 0.95
    follow: str = "descent"  # Eqs. (14)-(15); "direct": psi = psi_d at once (baselines)
    s_hat_time_constant: float = 1.0  # s, low-pass of the camera's step signal (0: none)
    # A behaviour counts as reached when every parameter is within this of it [rad].
    arrival_tolerance: float = 0.05
    # The behaviours as a tree (manta_drake.control.behaviour_tree): node name -> BlendNode,
    # the top node named root, each blending its children (nodes or gait names) by one
    # modality. Empty: the default tree, Eq. (12) exactly (behaviour_tree.default_tree():
    # swim, trot, turning; Scenario.behaviour_nodes()). Eq. (11), Eq. (12) normalised, a
    # switch or another z_t are default_tree(blend, z_t), as which the deprecated keys
    # transition.blend and transition.z_t are read (manta_drake.scenario.legacy).
    tree: dict[str, BlendNode] = dc.field(default_factory=dict)

    def validate(self, where: str = "transition") -> None:
        """The descent's parameters (``control.transition.check_parameters``, which
        ``PotentialTransition`` checks too) and the tree's shape; the tree's nodes against
        the gait library and ``period`` against ``time_step`` are the Scenario's checks."""
        for name in ("period", "g", "T", "alpha", "s_hat_time_constant"):
            check_number(f"{where}.{name}", getattr(self, name))
        check_text(f"{where}.follow", self.follow)
        check_parameters(
            self.period,
            self.g,
            self.T,
            self.alpha,
            1.0,  # z_t and blend: each tree node's own (checked with the tree)
            "potential",
            self.s_hat_time_constant,
            self.follow,
            where,
        )
        check_in_range(
            f"{where}.arrival_tolerance",
            self.arrival_tolerance,
            0.0,
            math.pi,
            "(0, pi] rad",
            open_low=True,
        )
        if not isinstance(self.tree, dict):
            raise ScenarioError(
                f"{where}.tree: expected a mapping of node names to nodes, got {self.tree!r}"
            )


@dc.dataclass
class WaterConfig:
    """The pool's water. ``coefficients``: ``package://manta_drake/<file>`` (the package's
    model folder), an absolute path, or a path relative to the working directory."""

    enabled: bool = True
    coefficients: str = "package://manta_drake/hydrodynamics.yaml"
    # The water's current [m/s, world] over time, as keys, e.g. [{time: 10, velocity: [0,
    # 0.06, 0]}, ...]: linear between keys, the first key's before it and the last's after
    # it; one key: a constant current; none: still water. The deprecated water.current: V
    # is read as the one key {time: 0, velocity: V} (manta_drake.scenario.legacy).
    current_schedule: list[CurrentPoint] = dc.field(default_factory=list)
    # 0: forces from the current state at every plant step (exact, no delay). > 0: computed
    # every update_period seconds and held (faster; one period of delay).
    update_period: float = 0.0
    # Multipliers of named coefficients of the file, e.g. {body.linear_damping: 1.3}
    # (sweeps and calibration; see manta_drake.model.coefficients.scale_coefficients).
    coefficient_scales: dict[str, float] = dc.field(default_factory=dict)
    # The fins' hydrodynamics (docs/design.md, section 4): "foil" (the default), the
    # flapping-foil strip model (circulation, suction, Wagner lag, stall) with the fins' and
    # the hull's added mass as bodies (manta_drake.station.foil); "cross_flow", the earlier
    # quasi-steady normal force with a chosen passive pitch and the hinges' zero-pose added
    # inertia, kept to compare against.
    fin_model: str = "foil"

    def schedule(self) -> CurrentSchedule:
        """The water's current over time (``current_schedule``; no key: still water)."""
        return CurrentSchedule((0.0, 0.0, 0.0), self.current_schedule)

    def validate(self, where: str = "water") -> None:
        """The switch, the current (``station.current``'s checks, which the Systems that read
        the current use too), the update period, the fin model, and the coefficient file
        with its scales (read even with the water off when there are scales)."""
        check_boolean(f"{where}.enabled", self.enabled)
        # A pool's current: station.current's checks (MAX_SPEED: beyond ~1 m/s the robot's
        # 0.1 m/s swim means nothing and the quadratic damping needs a smaller step).
        check_current_schedule(self.current_schedule, (0.0, 0.0, 0.0), f"{where}.current_schedule")
        check_in_range(f"{where}.update_period", self.update_period, 0.0, 0.02, "[0, 0.02] s")
        check_one_of(f"{where}.fin_model", self.fin_model, FIN_MODELS)
        check_text(f"{where}.coefficients", self.coefficients)
        # The URL is checked with the water off too (the file is read only with it on).
        coefficients = resolve_path(self.coefficients, f"{where}.coefficients")
        scales = self.coefficient_scales
        if not isinstance(scales, dict):
            raise ScenarioError(f"{where}.coefficient_scales: expected a mapping, got {scales!r}")
        if self.enabled or scales:  # scales are checked even with water off
            coeffs = load_coefficients(coefficients, f"{where}.coefficients")
            try:
                scale_coefficients(coeffs, scales)
            except ValueError as e:
                message = str(e)
                if message.startswith("coefficient_scales: "):  # a scaled value refused
                    message = "coefficient_scales." + message[len("coefficient_scales: ") :]
                raise ScenarioError(f"{where}.{message}") from None


@dc.dataclass
class ContactConfig:
    """Contact between the robot and the pool (point contact, SAP)."""

    # Coulomb friction of the foot-floor pair (static = dynamic). 0.8: rubber-tipped fins on
    # the rough painted concrete of an outdoor pool, the top of the wet range 0.5-0.8.
    friction: float = 0.8

    def validate(self, where: str = "contact") -> None:
        """The range ``model.plant.set_contact_friction`` checks too."""
        FRICTION.check(f"{where}.friction", self.friction)
