"""``Scenario``: the scenario's fields and views with its checks.

``Scenario.validate`` runs each section's own check (``validate(where)`` of the sections in
``manta_drake.scenario.schema`` and ``.devices``, and of the parameter sections the control
and station modules own), then the checks that need several sections, which are all here:
periods against ``time_step``, gait names against the library, the start pose, the
behaviour tree against the gaits and the estimates, and what the modalities need.
"""

import dataclasses as dc

from manta_drake.config_io import ScenarioError, check_in_range, check_one_of, short_repr
from manta_drake.control.depth import PERIOD as DEPTH_PERIOD
from manta_drake.modalities import ESTIMATES, MODALITIES, MODALITY_BY_ESTIMATE
from manta_drake.model.start_pose import start_pose_problem
from manta_drake.scenario.devices import validate_simulator
from manta_drake.scenario.views import ScenarioViews

# The sections whose own ``validate(where)`` checks them, in the order they are checked.
OWN_SECTIONS = (
    "contact",
    "robot",
    "initial_pose",
    "controller",
    "cpg",
    "transition",
    "water",
    "balloon",
    "pressure_sensor",
    "depth_estimator",
    "camera",
    "visualization",
    "actuators",
)


@dc.dataclass
class Scenario(ScenarioViews):
    """One run of the simulator: the fields of ``ScenarioFields`` (and a section per
    modality's sensor and estimator, ``manta_drake.modalities.SECTIONS``: ``imu``,
    ``posture_estimator``, ``flow_sensor``, ``flow_estimator`` and the rest), the views of
    ``ScenarioViews`` and ``validate``."""

    def validate(self) -> "Scenario":
        """Checks every value (type, finite, range, integer where it must be); raises
        ScenarioError naming the field, the value and the allowed range."""
        self.validate_top()
        for name in OWN_SECTIONS:
            getattr(self, name).validate(name)
        validate_simulator(self.simulator, "simulator")
        self._validate_parameter_sections()
        self._validate_periods()
        self._validate_gaits_and_pose()
        self._validate_tree()
        self._validate_modalities()
        return self

    def _validate_parameter_sections(self) -> None:
        """The sections whose dataclasses the control and station modules own (the wall
        detector, the heading hold, each modality's sensor and estimator): their own
        ``validate`` (the one their Systems run), naming the section's dotted fields."""
        self.wall_detector.validate("wall_detector")
        for m in MODALITIES:
            for part in (m.reading, m.estimation):
                if part is not None:
                    getattr(self, part.section).validate(part.section)
        self.heading_hold.validate(ESTIMATES, where="heading_hold")

    def _validate_periods(self) -> None:
        """Every period and rate against the plant's ``time_step``."""
        dt = self.time_step
        check_in_range(
            "transition.period",
            self.transition.period,
            dt,
            1.0,
            f"[time_step = {dt}, 1] s",
        )
        if self.actuators.bus_period != 0.0:
            check_in_range(
                "actuators.bus_period",
                self.actuators.bus_period,
                dt,
                0.1,
                f"0 or [time_step = {dt:g}, 0.1] s",
            )
        if self.water.enabled:  # the depth estimator updates at the sensor's rate
            check_in_range(
                "pressure_sensor.rate_hz",
                self.pressure_sensor.rate_hz,
                1.0 / DEPTH_PERIOD.hi,
                1.0 / dt,
                f"[{1.0 / DEPTH_PERIOD.hi:g}, 1/time_step = {1.0 / dt:g}] Hz (the depth "
                f"estimator's period, 1/rate_hz, is in {DEPTH_PERIOD.text()})",
            )
        check_in_range(
            "pressure_sensor.rate_hz",
            self.pressure_sensor.rate_hz,
            0.0,
            1.0 / dt,
            f"(0, 1/time_step = {1.0 / dt:g}] Hz",
            open_low=True,
        )
        vis = self.visualization
        steps = 1.0 / vis.recording_fps / dt
        if vis.meshcat and abs(steps - round(steps)) > 1e-6:
            raise ScenarioError(
                f"visualization.recording_fps: {vis.recording_fps!r} gives a publish period "
                f"of {1e3 / vis.recording_fps:.4g} ms, not a multiple of time_step = "
                f"{dt} s; recording would add integrator steps and change the run "
                "(40 fps = 25 ms is on a 1 ms grid)"
            )

    def _validate_gaits_and_pose(self) -> None:
        """The gait names against the library (``initial_stance``, ``controller.gait``) and
        the start pose (``model.start_pose``: inside the pool, the fins clear of it)."""
        gaits = self.gaits()
        check_one_of("initial_stance", self.initial_stance, ("zero",) + tuple(gaits))
        problem = start_pose_problem(
            self.initial_pose.xyz,
            self.initial_pose.rpy_deg,
            self.initial_joint_angles(),
            self.fin_sweep_deg(),
            self.initial_stance,
        )
        if problem:
            raise ScenarioError(f"initial_pose: {problem}")
        check_one_of("controller.gait", self.controller.gait, tuple(gaits))

    def _validate_tree(self) -> None:
        """The behaviour tree's nodes, children and gaits; and that the transition has the
        pressure sensor's depth to read."""
        self.behaviour_tree()
        if self.controller.mode == "transition" and not self.water.enabled:
            raise ScenarioError(
                "controller.mode: 'transition' needs water.enabled: true "
                "(z_hat comes from the pressure sensor)"
            )

    def _validate_modalities(self) -> None:
        """Every estimate the behaviour tree, the balloon rule or the heading hold reads has
        its sensor; the sensors that read through the water have it; the heading hold has a
        gait to trim."""
        self._validate_water_users()
        for estimate, where in self.estimates_read().items():
            m = MODALITY_BY_ESTIMATE[estimate]
            if not m.available(self):
                raise ScenarioError(f"{where}: reads {estimate}, which needs {m.needs}: true")
        if self.heading_hold.enabled and self.controller.mode == "hold":
            raise ScenarioError(
                "heading_hold.enabled: true trims a CPG gait; controller.mode "
                "hold runs none (use gait or transition)"
            )
        self._validate_heading_hold_behaviours()

    def _validate_water_users(self) -> None:
        """The balloon rule acts and some sensors (the modalities' that need water) read
        through the water: refused with the water off (the rule would command a balloon that
        lifts nothing, the sensor read water that is not there)."""
        if self.water.enabled:
            return
        if self.balloon.rule.modality:
            raise ScenarioError(
                f"balloon.rule.modality: {short_repr(self.balloon.rule.modality)}"
                " needs water.enabled: true (the balloon acts through the "
                "water's buoyancy)"
            )
        for m in MODALITIES:
            r = m.reading
            if r is not None and r.needs_water and getattr(self, r.section).enabled:
                raise ScenarioError(
                    f"{r.section}.enabled: true needs water.enabled: true (the "
                    "sensor reads through the water)"
                )

    def _validate_heading_hold_behaviours(self) -> None:
        """``heading_hold.behaviours`` are gaits of the library, and in transition mode with
        the hold on at least one is a gait of the behaviour tree (else it never engages)."""
        hold = self.heading_hold
        gaits = self.gaits()
        for i, name in enumerate(hold.behaviours):
            if name not in gaits:
                raise ScenarioError(
                    f"heading_hold.behaviours[{i}]: {short_repr(name)} is not a "
                    f"gait; allowed: {', '.join(gaits)}"
                )
        if hold.enabled and self.controller.mode == "transition":
            leaves = self.behaviour_tree().leaves
            if not any(name in leaves for name in hold.behaviours):
                raise ScenarioError(
                    f"heading_hold.behaviours: {short_repr(hold.behaviours)} "
                    "names none of the behaviour tree's gaits, so the hold "
                    f"would never engage; allowed: {', '.join(leaves)}"
                )
