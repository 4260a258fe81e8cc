"""The one place that wires the diagram (see the arrow picture in DESIGN.md).

``build_diagram(scenario)`` returns the built Diagram and a ``DiagramHandles``
with the plant, every system by name, the loggers, and Meshcat (if on).
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import (
    DepthRenderCamera,
    Meshcat,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
)
from pydrake.math import RigidTransform
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import (
    ConstantVectorSource,
    LogVectorOutput,
    TrajectorySource,
    VectorLogSink,
)
from pydrake.trajectories import PiecewisePolynomial

from manta_drake.buoyancy import BalloonBuoyancy
from manta_drake.coefficients import load_coefficients
from manta_drake.cpg import CpgOscillators, locked_phases
from manta_drake.depth import FuzzyDepthEstimator, fuzzy_depth
from manta_drake.depth_image_noise import DepthImageNoise
from manta_drake.gaits import get_gait
from manta_drake.hydro import HydrodynamicForces
from manta_drake.plant import PlantHandles, add_plant
from manta_drake.pressure import PressureSensor
from manta_drake.scenario import Scenario, resolve_path
from manta_drake.transition import PotentialTransition
from manta_drake.vision import WallDetector


@dc.dataclass
class DiagramHandles:
    """Handles into a built diagram."""

    plant_handles: PlantHandles
    systems: dict = dc.field(default_factory=dict)
    loggers: dict = dc.field(default_factory=dict)
    meshcat: Meshcat | None = None
    visualizer: MeshcatVisualizer | None = None

    @property
    def plant(self):
        return self.plant_handles.plant


def initial_joint_angles(scenario: Scenario) -> np.ndarray:
    """The 16 initial joint angles: the stance X of ``scenario.initial_stance``, or zeros."""
    if scenario.initial_stance == "zero":
        return np.zeros(16)
    return get_gait(scenario.initial_stance).X.ravel().copy()


def _add_transition(builder, scenario: Scenario, handles: DiagramHandles):
    """PotentialTransition fed by z_hat and s_hat (0 when there is no camera)."""
    tr = scenario.transition
    transition = builder.AddNamedSystem("transition", PotentialTransition(
        tr.period, tr.g, tr.T, tr.alpha, tr.z_t, tr.blend,
        s_hat_time_constant=tr.s_hat_time_constant))
    builder.Connect(handles.systems["depth_estimator"].GetOutputPort("z_hat"),
                    transition.GetInputPort("z_hat"))
    if "wall_detector" in handles.systems:
        s_hat = handles.systems["wall_detector"].GetOutputPort("s_hat")
    else:
        s_hat = builder.AddNamedSystem("no_camera", ConstantVectorSource([0.0])).get_output_port()
    builder.Connect(s_hat, transition.GetInputPort("s_hat"))
    handles.systems["transition"] = transition
    return transition


def initial_sensor_depth(scenario: Scenario) -> float:
    """Depth of the pressure sensor at t = 0, taking the start as level [m, >= 0]."""
    return max(0.0, -(scenario.initial_pose.xyz[2] + scenario.pressure_sensor.position[2]))


def initial_cpg_params(scenario: Scenario, handles: DiagramHandles) -> np.ndarray:
    """The CPG parameters at t = 0: the fixed gait, or the transition's target for the
    initial depth (no wall seen)."""
    if scenario.controller.mode == "transition":
        D = scenario.depth_estimator.floor_distance
        z0 = float(fuzzy_depth(initial_sensor_depth(scenario), D)[1])
        return handles.systems["transition"].target(z0, 0.0)
    return get_gait(scenario.controller.gait).to_vector()


def _add_controller(builder, scenario: Scenario, handles: DiagramHandles) -> None:
    """Connects a desired-state source to the plant's PD and logs the commands."""
    plant, robot = handles.plant, handles.plant_handles.robot
    mode = scenario.controller.mode
    if mode == "hold":
        X = get_gait(scenario.controller.gait).X.ravel()
        source = builder.AddNamedSystem(
            "hold_stance", ConstantVectorSource(np.concatenate([X, np.zeros(16)]))
        )
        desired_state = source.get_output_port()
    elif mode in ("gait", "transition"):
        if mode == "gait":
            params = builder.AddNamedSystem(
                "gait_params", ConstantVectorSource(get_gait(scenario.controller.gait).to_vector()))
        else:
            params = _add_transition(builder, scenario, handles)
        c = scenario.cpg
        cpg = builder.AddNamedSystem("cpg", CpgOscillators(
            frequency_hz=c.frequency_hz, chain_weight=c.chain_weight, fcs_weight=c.fcs_weight,
            a=c.a, b=c.b))
        builder.Connect(params.get_output_port(), cpg.GetInputPort("cpg_params"))
        handles.systems["cpg"] = cpg
        handles.loggers["cpg_params"] = LogVectorOutput(
            params.get_output_port(), builder,
            scenario.transition.period if mode == "transition" else max(scenario.log_period, 0.01))
        desired_state = cpg.GetOutputPort("desired_state")
    else:
        raise NotImplementedError(f"controller.mode '{mode}' is not available yet")
    builder.Connect(desired_state, plant.get_desired_state_input_port(robot))
    handles.loggers["desired_state"] = LogVectorOutput(
        desired_state, builder, scenario.log_period
    )


def balloon_schedule(scenario: Scenario, max_volume: float) -> TrajectorySource:
    """A piecewise-constant source of the balloon's volume command [m^3]."""
    times = [0.0] + [c.time for c in scenario.balloon.schedule]
    fills = [scenario.balloon.initial_fill] + [c.fill for c in scenario.balloon.schedule]
    # Zero-order hold needs increasing breaks: keep the last command given at a time.
    breaks, values = [], []
    for t, fill in zip(times, fills):
        if breaks and t <= breaks[-1] + 1e-9:
            values[-1] = fill
        else:
            breaks.append(t)
            values.append(fill)
    end = max(breaks[-1], scenario.duration) + 1.0
    breaks.append(end)
    values.append(values[-1])
    traj = PiecewisePolynomial.ZeroOrderHold(
        np.array(breaks), np.array(values)[None, :] * max_volume)
    return TrajectorySource(traj)


def _add_water(builder, scenario: Scenario, handles: DiagramHandles, coeffs) -> None:
    """Balloon, its command schedule, and the hydrodynamic forces on the plant."""
    plant, robot = handles.plant, handles.plant_handles.robot
    b = coeffs.balloon
    # The pump moves ~3 mL per 10 ms: a 10 ms update is exact enough and 10x cheaper.
    balloon = builder.AddNamedSystem("balloon", BalloonBuoyancy(
        b.max_volume.value, b.pump_rate.value, max(scenario.time_step, 0.01),
        scenario.balloon.initial_fill * b.max_volume.value))
    command = builder.AddNamedSystem("balloon_schedule",
                                     balloon_schedule(scenario, b.max_volume.value))
    builder.Connect(command.get_output_port(), balloon.GetInputPort("volume_command"))
    hydro = builder.AddNamedSystem("hydro", HydrodynamicForces(
        plant, robot, coeffs, scenario.time_step, current=scenario.water.current,
        added_mass_iso=handles.plant_handles.added_mass_iso,
        update_period=scenario.water.update_period))
    builder.Connect(plant.get_body_poses_output_port(), hydro.GetInputPort("body_poses"))
    builder.Connect(plant.get_body_spatial_velocities_output_port(),
                    hydro.GetInputPort("body_spatial_velocities"))
    builder.Connect(balloon.GetOutputPort("balloon_volume"), hydro.GetInputPort("balloon_volume"))
    builder.Connect(hydro.GetOutputPort("spatial_forces"),
                    plant.get_applied_spatial_force_input_port())
    handles.systems.update(balloon=balloon, hydro=hydro, balloon_schedule=command)
    handles.loggers["balloon_volume"] = LogVectorOutput(
        balloon.GetOutputPort("balloon_volume"), builder, max(scenario.log_period, 0.01))


def _add_depth_sensing(builder, scenario: Scenario, handles: DiagramHandles) -> None:
    """Pressure sensor on the head -> fuzzy depth estimator (Eq. 9)."""
    plant = handles.plant
    ps = scenario.pressure_sensor
    period = 1.0 / ps.rate_hz
    sensor = builder.AddNamedSystem("pressure_sensor", PressureSensor(
        plant, handles.plant_handles.body, ps.position, period, ps.noise_std, ps.dropout_rate,
        seed=scenario.random_seed))
    builder.Connect(plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    estimator = builder.AddNamedSystem("depth_estimator", FuzzyDepthEstimator(
        scenario.depth_estimator.floor_distance, period,
        initial_depth=initial_sensor_depth(scenario)))
    builder.Connect(sensor.GetOutputPort("depth"), estimator.GetInputPort("depth"))
    handles.systems.update(pressure_sensor=sensor, depth_estimator=estimator)
    for name, port in (("depth", sensor.GetOutputPort("depth")),
                       ("z_hat", estimator.GetOutputPort("z_hat"))):
        handles.loggers[name] = LogVectorOutput(port, builder, period)


def _add_camera(builder, scenario: Scenario, handles: DiagramHandles) -> None:
    """RGB-D camera on the head (VTK) -> noise -> point cloud -> wall detector (Eq. 10)."""
    from pydrake.geometry import (ClippingRange, DepthRange, MakeRenderEngineVtk,
                                  RenderCameraCore, RenderEngineVtkParams)
    from pydrake.perception import BaseField, DepthImageToPointCloud
    from pydrake.systems.sensors import CameraInfo, PixelType, RgbdSensor

    plant, ph = handles.plant, handles.plant_handles
    cam = scenario.camera
    scene_graph = ph.scene_graph
    if not scene_graph.HasRenderer("vtk"):
        scene_graph.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
    info = CameraInfo(cam.width, cam.height, np.radians(cam.fov_y_deg))
    core = RenderCameraCore("vtk", info, ClippingRange(0.5 * cam.min_range, 2.0 * cam.max_range),
                            RigidTransform())
    X_BC = plant.GetFrameByName("camera", ph.robot).GetFixedPoseInBodyFrame()
    sensor = builder.AddNamedSystem("camera", RgbdSensor(
        plant.GetBodyFrameIdOrThrow(ph.body.index()), X_BC,
        DepthRenderCamera(core, DepthRange(cam.min_range, cam.max_range)), False))
    builder.Connect(scene_graph.get_query_output_port(), sensor.query_object_input_port())
    noise = builder.AddNamedSystem("depth_noise", DepthImageNoise(
        cam.width, cam.height, cam.depth_noise_std, cam.pixel_dropout, seed=scenario.random_seed))
    builder.Connect(sensor.depth_image_32F_output_port(), noise.GetInputPort("depth_image"))
    to_cloud = builder.AddNamedSystem("depth_to_cloud", DepthImageToPointCloud(
        info, PixelType.kDepth32F, 1.0, BaseField.kXYZs))
    builder.Connect(noise.GetOutputPort("noisy_depth_image"), to_cloud.depth_image_input_port())
    builder.Connect(sensor.body_pose_in_world_output_port(), to_cloud.camera_pose_input_port())
    detector = builder.AddNamedSystem("wall_detector", WallDetector(
        1.0 / cam.rate_hz, scenario.wall_detector, meshcat=handles.meshcat))
    builder.Connect(to_cloud.point_cloud_output_port(), detector.GetInputPort("point_cloud"))
    builder.Connect(sensor.body_pose_in_world_output_port(), detector.GetInputPort("camera_pose"))
    handles.systems.update(camera=sensor, depth_noise=noise, depth_to_cloud=to_cloud,
                           wall_detector=detector)
    handles.loggers["s_hat"] = LogVectorOutput(detector.GetOutputPort("s_hat"), builder,
                                               1.0 / cam.rate_hz)


def build_diagram(scenario: Scenario) -> tuple[Diagram, DiagramHandles]:
    """Builds the diagram of ``scenario``.

    Returns:
        (diagram, handles). The robot's plant state is logged as ``plant_state``
        and the commanded desired state (32) as ``desired_state``.
    """
    builder = DiagramBuilder()
    coeffs = load_coefficients(resolve_path(scenario.water.coefficients)) \
        if scenario.water.enabled else None
    plant_handles = add_plant(
        builder,
        time_step=scenario.time_step,
        discrete_contact_approximation=scenario.discrete_contact_approximation,
        hydro=coeffs,
    )
    handles = DiagramHandles(plant_handles)
    plant = plant_handles.plant
    if scenario.visualization.meshcat:
        handles.meshcat = Meshcat(MeshcatParams(host="localhost", port=None))
    if coeffs is not None:
        _add_water(builder, scenario, handles, coeffs)
        _add_depth_sensing(builder, scenario, handles)
    if scenario.camera.enabled:
        _add_camera(builder, scenario, handles)
    _add_controller(builder, scenario, handles)
    handles.loggers["plant_state"] = LogVectorOutput(
        plant.get_state_output_port(), builder, scenario.log_period
    )
    if handles.meshcat is not None:
        params = MeshcatVisualizerParams(publish_period=1.0 / scenario.visualization.recording_fps)
        handles.visualizer = MeshcatVisualizer.AddToBuilder(
            builder, plant_handles.scene_graph, handles.meshcat, params
        )
    diagram = builder.Build()
    diagram.set_name(f"manta_drake:{scenario.name}")
    return diagram, handles


def initialize_context(scenario: Scenario, handles: DiagramHandles, root_context) -> None:
    """Initial conditions of the stateful systems other than the plant.

    The CPG starts from rest (r = 0) with its biases chi at the robot's initial
    joint angles, so nothing jumps at t = 0, and its phases at the lock of the
    commanded gait (the exact in-phase start is an unstable equilibrium of
    couplings with bias pi).
    """
    cpg = handles.systems.get("cpg")
    if cpg is None:
        return
    params = initial_cpg_params(scenario, handles)
    transition = handles.systems.get("transition")
    if transition is not None:
        transition.set_params(transition.GetMyMutableContextFromRoot(root_context), params)
    cpg.set_state(cpg.GetMyMutableContextFromRoot(root_context), phi=locked_phases(params),
                  r=0.0, dr=0.0, chi=initial_joint_angles(scenario), dchi=0.0)


def logger_data(logger: VectorLogSink, root_context) -> tuple[np.ndarray, np.ndarray]:
    """(times, data.T) of a logger in ``root_context``."""
    log = logger.FindLog(root_context)
    return log.sample_times().copy(), log.data().T.copy()
