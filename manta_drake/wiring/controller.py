"""The controller: what runs on the robot, as one Diagram with the station's port names.

``build_controller(scenario)`` returns a Diagram that consumes only what the real
robot's sensors give (the station's ``depth``, ``depth_image``, ``camera_pose``, the
modalities' sensors and the ``battery``) and commands the joints and the balloon.

.. pydrake_system::

    name: controller
    input_ports:
    - depth (water on)
    - depth_image (camera on)
    - camera_pose (camera on)
    - <sensor ports>
    - battery (charge estimate read)
    output_ports:
    - desired_state
    - balloon_command
    - cpg_params (gait, transition)
    - joint_angles (gait, transition)
    - behaviour_weights (transition)
    - heading_trim (heading hold on)
    - h_hat (water on)
    - z_hat (water on)
    - s_hat (camera on or transition)
    - <estimate ports>
    - detector_status (camera on)
    - clusters (camera on)
    - best_clusters (camera on)

By ``scenario.controller.mode``:

* ``hold``: the joints hold the stance X of ``controller.gait`` (no oscillation).
* ``gait``: the CPG (Eq. 5) runs ``controller.gait`` for the whole run.
* ``transition``: the multifunctional controller of section 3: the pressure depth goes
  through ``FuzzyDepthEstimator`` (Eq. 9) to z_hat; the depth image through
  ``DepthImageFilter`` (a median filter), ``DepthImageToPointCloud`` and
  ``WallDetector`` (Eq. 10) to s_hat (0 without a
  camera); ``PotentialTransition`` (Eqs. 11-15) blends the behaviour tree's gaits
  (``transition.tree``; by default Eq. 12's swim, trot and turning) by the estimates and
  descends to the blend.

The modalities' estimators (``manta_drake.modalities``, each a ``FilteredEstimator``) run
whenever their sensor is on, those marked "estimate read" only when a tree, the balloon
rule or the heading hold reads their estimate:

  * <estimators>

``HeadingHold`` (``heading_hold.enabled``) trims the CPG's parameters from the attitude
estimate while the swim's leaves carry weight (``cpg_params`` is the behaviour's, before the
trim). The balloon follows the scenario's schedule (``balloon_command``, fill in [0, 1]), or
``balloon.rule`` on an estimate; with water on, the depth estimator runs (and is logged) in
every mode.

The scenario's start is the default context: the CPG starts from rest at the lock of
its initial gait with its biases at the initial stance, the transition at the target
for the initial depth, the estimator at the initial depth.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.perception import BaseField, DepthImageToPointCloud
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, MatrixGain, TrajectorySource
from pydrake.systems.sensors import PixelType
from pydrake.trajectories import PiecewisePolynomial

from manta_drake.control.balloon_rule import BalloonRule
from manta_drake.control.cpg import CpgOscillators, initial_state
from manta_drake.control.depth import FuzzyDepthEstimator
from manta_drake.control.depth_image_filter import DepthImageFilter
from manta_drake.control.heading_hold import HeadingHold
from manta_drake.control.transition import PotentialTransition
from manta_drake.control.vision import WallDetector
from manta_drake.modalities import (
    MODALITIES,
    MODALITY_BY_ESTIMATE,
    NAMES,
    fill_docstring,
    initial_sensor_depth,
)
from manta_drake.model.camera import camera_info
from manta_drake.scenario import Scenario

# The modalities' ports and parts in the docstring come from their registry.
__doc__ = fill_docstring(__doc__)


@dc.dataclass
class ControllerHandles:
    """Every system of a built controller by name."""

    systems: dict = dc.field(default_factory=dict)
    # The 0-1 estimates a behaviour tree, the balloon rule or the heading hold may read:
    # modality -> port (z_hat with the water on, s_hat with the camera or a transition).
    estimates: dict = dc.field(default_factory=dict)


def initial_estimates(scenario: Scenario, tree) -> dict[str, float]:
    """Each estimate ``tree`` (the scenario's behaviour tree) reads, at the start pose
    (``Modality.initial``; 0, nothing seen yet, where the pose says nothing)."""
    return {m: MODALITY_BY_ESTIMATE[m].initial(scenario) for m in tree.modalities}


def initial_cpg_params(scenario: Scenario, tree=None) -> np.ndarray:
    """The CPG parameters at t = 0: the fixed gait, or the transition's target for the
    estimates at the start pose (``initial_estimates``); ``tree``: the scenario's behaviour
    tree when the caller has it compiled (None: compiled here)."""
    if scenario.controller.mode == "transition":
        tree = tree or scenario.behaviour_tree()
        values = initial_estimates(scenario, tree)
        return tree.target(values, tree.initial_switch_state(values))[0]
    return scenario.gait(scenario.controller.gait).to_vector()


def balloon_schedule(scenario: Scenario) -> TrajectorySource:
    """A piecewise-constant source of the balloon's fill command in [0, 1]."""
    times = [0.0] + [c.time for c in scenario.balloon.schedule]
    fills = [scenario.balloon.initial_fill] + [c.fill for c in scenario.balloon.schedule]
    # Zero-order hold needs increasing breaks: keep the last command given at a time.
    breaks: list[float] = []
    values: list[float] = []
    for t, fill in zip(times, fills):
        if breaks and t <= breaks[-1] + 1e-9:
            values[-1] = fill
        else:
            breaks.append(t)
            values.append(fill)
    breaks.append(max(breaks[-1], scenario.duration) + 1.0)
    values.append(values[-1])
    return TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(np.array(breaks), np.array(values)[None, :])
    )


# The hold mode's move from the initial stance to the held one: well inside the servos'
# 8 rad/s, so the command never steps.
HOLD_RAMP_SPEED = 2.0  # rad/s, largest joint speed of the ramp


def stance_ramp(q_start, q_end, max_speed: float = HOLD_RAMP_SPEED) -> TrajectorySource:
    """desired_state (angles and rates) moving from ``q_start`` to ``q_end`` along a cubic
    with zero end rates, no joint faster than ``max_speed``, then holding ``q_end``."""
    q_start, q_end = (np.asarray(q, dtype=float).reshape(-1, 1) for q in (q_start, q_end))
    # A cubic with zero end rates peaks at 1.5 x the mean rate.
    T = max(1.5 * float(np.abs(q_end - q_start).max()) / max_speed, 1e-3)
    zero = np.zeros_like(q_start)
    traj = PiecewisePolynomial.CubicHermite(
        np.array([0.0, T]), np.hstack([q_start, q_end]), np.hstack([zero, zero])
    )
    return TrajectorySource(traj, output_derivative_order=1, zero_derivatives_beyond_limits=True)


def _add_sensing(builder, scenario: Scenario, handles: ControllerHandles) -> None:
    """depth -> FuzzyDepthEstimator (Eq. 9)."""
    ps = scenario.pressure_sensor
    estimator = builder.AddNamedSystem(
        "depth_estimator",
        FuzzyDepthEstimator(
            scenario.depth_estimator.floor_distance,
            period=1.0 / ps.rate_hz,
            initial_depth=initial_sensor_depth(scenario),
            surface_depth=scenario.depth_estimator.surface_depth,
        ),
    )
    builder.ExportInput(estimator.GetInputPort("depth"), "depth")
    for name in ("h_hat", "z_hat"):
        builder.ExportOutput(estimator.GetOutputPort(name), name)
    handles.systems["depth_estimator"] = estimator
    handles.estimates["z_hat"] = estimator.GetOutputPort("z_hat")


def _add_estimators(builder, scenario: Scenario, handles: ControllerHandles) -> None:
    """The modalities' estimators (``manta_drake.modalities``), each that the scenario has
    (``Scenario.has_estimator``), fed by the sensor of its name and started from the start
    pose (``Estimation.start``); their 0-1 estimates join ``handles.estimates``."""
    for m in MODALITIES:
        if m.estimation is None or not scenario.has_estimator(m.estimate):
            continue
        e = m.estimation
        system = builder.AddNamedSystem(
            e.section, e.system(getattr(scenario, e.section), e.period, **e.start(scenario))
        )
        sensor = system.get_input_port()
        builder.ExportInput(sensor, sensor.get_name())
        for port in e.outputs:
            builder.ExportOutput(system.GetOutputPort(port), port)
        handles.systems[e.section] = system
        handles.estimates[m.estimate] = system.GetOutputPort(m.estimate)


def _add_heading_hold(builder, scenario: Scenario, handles: ControllerHandles, params):
    """cpg_params -> HeadingHold (the IMU's attitude estimate; the swim's share) -> the
    trimmed parameters the CPG runs."""
    hold = builder.AddNamedSystem("heading_hold", HeadingHold(scenario.heading_hold))
    posture = handles.systems["posture_estimator"]
    builder.Connect(params, hold.GetInputPort("cpg_params"))
    builder.Connect(posture.GetOutputPort("attitude_hat"), hold.GetInputPort("attitude_hat"))
    builder.Connect(posture.GetOutputPort("yaw_rate_hat"), hold.GetInputPort("yaw_rate_hat"))
    for modality in scenario.heading_hold.read():  # Scenario.validate checked each is here
        builder.Connect(handles.estimates[modality], hold.GetInputPort(modality))
    if "transition" in handles.systems:
        transition = handles.systems["transition"]
        leaves = transition.tree.leaves
        selector = np.array(
            [[1.0 if leaf in scenario.heading_hold.behaviours else 0.0 for leaf in leaves]]
        )
        share = builder.AddNamedSystem("swim_share", MatrixGain(selector)).get_output_port()
        builder.Connect(
            transition.GetOutputPort("behaviour_weights"),
            builder.GetSubsystemByName("swim_share").get_input_port(),
        )
    else:  # a fixed gait: trimmed whole
        share = builder.AddNamedSystem("swim_share", ConstantVectorSource([1.0])).get_output_port()
    builder.Connect(share, hold.GetInputPort("swim_share"))
    builder.ExportOutput(hold.GetOutputPort("heading_trim"), "heading_trim")
    handles.systems["heading_hold"] = hold
    return hold.GetOutputPort("cpg_params")


def _add_balloon(builder, scenario: Scenario, handles: ControllerHandles) -> None:
    """The balloon's fill command: the schedule, or the rule on a modality's estimate."""
    schedule = builder.AddNamedSystem("balloon_schedule", balloon_schedule(scenario))
    rule = scenario.balloon.rule
    if not rule.modality:
        builder.ExportOutput(schedule.get_output_port(), "balloon_command")
        return
    system = builder.AddNamedSystem("balloon_rule", BalloonRule(rule))
    builder.Connect(schedule.get_output_port(), system.GetInputPort("scheduled_fill"))
    builder.Connect(handles.estimates[rule.estimate(NAMES)], system.GetInputPort("modality"))
    builder.ExportOutput(system.GetOutputPort("balloon_command"), "balloon_command")
    handles.systems["balloon_rule"] = system


def _add_wall_detector(builder, scenario: Scenario, handles: ControllerHandles, meshcat):
    """depth_image -> median filter -> point cloud (+ camera_pose) -> WallDetector (Eq. 10)."""
    cam = scenario.camera
    denoise = builder.AddNamedSystem(
        "depth_filter",
        DepthImageFilter(cam.width, cam.height, scenario.wall_detector.depth_median_filter_px),
    )
    to_cloud = builder.AddNamedSystem(
        "depth_to_cloud",
        DepthImageToPointCloud(
            camera_info(cam.width, cam.height, cam.fov_y_deg),
            PixelType.kDepth32F,
            1.0,
            BaseField.kXYZs,
        ),
    )
    detector = builder.AddNamedSystem(
        "wall_detector",
        WallDetector(period=1.0 / cam.rate_hz, params=scenario.wall_detector, meshcat=meshcat),
    )
    builder.ExportInput(denoise.GetInputPort("depth_image"), "depth_image")
    builder.Connect(
        denoise.GetOutputPort("filtered_depth_image"), to_cloud.depth_image_input_port()
    )
    builder.ConnectInput(
        builder.ExportInput(to_cloud.camera_pose_input_port(), "camera_pose"),
        detector.GetInputPort("camera_pose"),
    )
    builder.Connect(to_cloud.point_cloud_output_port(), detector.GetInputPort("point_cloud"))
    for name in ("s_hat", "detector_status", "clusters", "best_clusters"):
        builder.ExportOutput(detector.GetOutputPort(name), name)
    handles.systems.update(depth_to_cloud=to_cloud, wall_detector=detector)
    handles.estimates["s_hat"] = detector.GetOutputPort("s_hat")


def _add_transition(builder, scenario: Scenario, handles: ControllerHandles):
    tr = scenario.transition
    tree = scenario.behaviour_tree()
    transition = builder.AddNamedSystem(
        "transition",
        PotentialTransition(
            tr.period,
            tr.g,
            tr.T,
            tr.alpha,
            follow=tr.follow,
            initial_params=initial_cpg_params(scenario, tree),
            tree=tree,
            s_hat_time_constant=tr.s_hat_time_constant,
            initial_values=initial_estimates(scenario, tree),
        ),
    )
    if "s_hat" not in handles.estimates:  # no camera: no wall is ever seen
        s_hat = builder.AddNamedSystem("no_camera", ConstantVectorSource([0.0])).get_output_port()
        builder.ExportOutput(s_hat, "s_hat")
        handles.estimates["s_hat"] = s_hat
    for modality in tree.modalities:  # Scenario.validate checked each has its sensor
        builder.Connect(handles.estimates[modality], transition.GetInputPort(modality))
    builder.ExportOutput(transition.GetOutputPort("behaviour_weights"), "behaviour_weights")
    handles.systems["transition"] = transition
    return transition.GetOutputPort("cpg_params")


def build_controller(
    scenario: Scenario, meshcat=None, *, compiled_cpg: bool = True
) -> tuple[Diagram, ControllerHandles]:
    """Builds the controller of ``scenario`` (see the module docstring for its ports).

    Args:
        scenario: a validated Scenario (``controller``, ``cpg``, ``transition``,
            ``depth_estimator``, ``camera``, ``wall_detector``, ``balloon``).
        meshcat: if given, the wall detector draws its labelled clusters there.
        compiled_cpg: False runs the CPG on its numpy reference maths (the tests and the
            benchmark's reference path); the default, its compiled kernels.

    Returns:
        (controller diagram, ControllerHandles).
    """
    builder = DiagramBuilder()
    handles = ControllerHandles()
    mode = scenario.controller.mode
    if scenario.water.enabled:
        _add_sensing(builder, scenario, handles)
    if scenario.camera.enabled:
        _add_wall_detector(builder, scenario, handles, meshcat)
    _add_estimators(builder, scenario, handles)
    if mode == "hold":
        stance = scenario.gait(scenario.controller.gait).X
        source = builder.AddNamedSystem(
            "hold_stance", stance_ramp(scenario.initial_joint_angles(), stance.ravel())
        )
        builder.ExportOutput(source.get_output_port(), "desired_state")
    elif mode in ("gait", "transition"):
        if mode == "gait":
            params = builder.AddNamedSystem(
                "gait_params", ConstantVectorSource(initial_cpg_params(scenario))
            ).get_output_port()  # the fixed gait
        else:
            params = _add_transition(builder, scenario, handles)
        builder.ExportOutput(params, "cpg_params")  # the behaviour's, before any trim
        if scenario.heading_hold.enabled:
            params = _add_heading_hold(builder, scenario, handles, params)
        c = scenario.cpg
        cpg = builder.AddNamedSystem(
            "cpg",
            CpgOscillators(
                frequency_hz=c.frequency_hz,
                chain_weight=c.chain_weight,
                fcs_weight=c.fcs_weight,
                a=c.a,
                b=c.b,
                compiled=compiled_cpg,
                initial_state=initial_state(
                    initial_cpg_params(scenario), scenario.initial_joint_angles()
                ),
            ),
        )
        builder.Connect(params, cpg.GetInputPort("cpg_params"))
        builder.ExportOutput(cpg.GetOutputPort("joint_angles"), "joint_angles")
        builder.ExportOutput(cpg.GetOutputPort("desired_state"), "desired_state")
        handles.systems["cpg"] = cpg
    else:
        raise ValueError(f"controller.mode: {mode!r} is not one of hold, gait, transition")
    _add_balloon(builder, scenario, handles)
    controller = builder.Build()
    controller.set_name("controller")
    return controller, handles
