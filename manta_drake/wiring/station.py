"""The station: the simulated robot and its world, as one Diagram with hardware ports.

As the manipulation course's ``MakeHardwareStation``, ``build_station(scenario)``
returns a Diagram whose exported ports are exactly what the real robot's hardware
takes and gives, so a controller written against them can drive this simulation, a
station in another process (over LCM) or the robot itself.

.. pydrake_system::

    name: station
    input_ports:
    - desired_state
    - balloon_command (water on)
    output_ports:
    - depth (water on)
    - depth_image (camera on)
    - camera_pose (camera on)
    - measured_joint_state
    - battery (actuators on)
    - electrical_power (actuators on)
    - joint_torque
    - joint_mechanical_power (actuators on)
    - balloon_volume (water on)
    - <sensor ports>
    - plant_state
    - query_object
    - foot_contacts (pool on)

Inputs:

* ``desired_state`` (32): joint angles and rates for the servos' PD (the plant's
  implicit PD, ``<drake:controller_gains>``: RobotParams' chosen gains, or with
  ``actuators.servo_model: datasheet`` the servo's firmware loop of ``model.servo``, which
  ignores the rates, at the battery's terminal voltage through ``ServoSupply``'s
  feed-forward when the energy model is on), in the plant's joint order; with
  ``actuators.bus_period`` > 0 through a ``ServoBus`` (taken up one bus period after it
  was written).
* ``balloon_command`` (1): wanted balloon fill in [0, 1] (0 empty, 1 ``max_volume``).

Outputs, what the robot's sensors give:

* ``depth`` (1): the head's pressure sensor [m below the surface], noisy, may be NaN.
* ``depth_image``: the head's RGB-D camera's depth image (ImageDepth32F, with range
  noise and pixel dropout), rendered by VTK.
* ``camera_pose``: the camera's pose in the world (RigidTransform). On the robot this
  is the IMU attitude and the pressure depth; the detector uses only its height and
  its horizontal viewing direction.
* ``measured_joint_state`` (32): the servos' angles and rates (with a bus: its last sync
  read, in whole encoder pulses and velocity units).
* ``battery`` (3): [state of charge 0-1, terminal voltage V, current A] of the pack: the
  charge now, the voltage and current of the last step (``Battery``; the run stops when
  the charge reaches the file's cut-off, see ``actuators.stop_when_empty``).
* ``electrical_power`` (1) [W]: what the servos and the computers draw (``ServoPower``,
  parameters in ``models/actuators.yaml``).

* the modalities' sensors (``manta_drake.modalities``), each when its section is enabled,
  with its Drake noise sources:

  * <sensors>

and, for logging and visualisation only (a controller must not read them):

* ``joint_torque`` (16) [N m]: the torque each joint's actuator applied over the last
  plant step, in the plant's joint order (that of ``measured_joint_state``): the plant's
  net actuation of that step, which includes the implicit PD's contribution (SAP
  evaluates the PD at the step's end state, u = Kp (q_d - q_next) + Kd (v_d - v_next)
  + u_ff, clamped to the effort limit, u_ff ``ServoSupply``'s feed-forward), i.e. what the
  servos deliver, not the PD law at the logged state; with the ``datasheet`` servo less
  its back-EMF braking b qdot_next, which the plant applies as joint damping.
* ``joint_mechanical_power`` (16) [W]: tau qdot of each joint over the last step.
* ``balloon_volume`` (1) [m^3], ``plant_state`` (the full MultibodyPlant state),
  ``query_object`` (SceneGraph's, for visualisers).
* ``foot_contacts`` (15): the floor's normal load [N] on each leg-fin (fl, fr, rl, rr)
  and the hull, and the load-weighted horizontal slip velocity of their contacts [m/s]
  (``FootContacts``; evaluated only when read, and reading the plant's contact results
  only when the robot touches something).

Inside: MultibodyPlant + SceneGraph (robot and pool), ``ServoBus`` and ``ServoSupply``
(the datasheet servos' bus and their supply voltage), ``FootContacts``,
``HydrodynamicForces`` (its
compiled path: the plant's state vector in; held spatial forces or, computed at every
step, generalized forces out),
``BalloonBuoyancy``, ``PressureSensor``, ``RgbdSensor`` (rendering from a SceneGraph of
its own, ``add_camera_scene``), ``DepthImageNoise`` and the
Drake ``RandomSource`` systems that feed the noise (their state is in the Context, so
``SetRandomContext`` draws new noise; ``simulate`` seeds it from the scenario).
The scenario's initial pose and stance are the plant's defaults, so the station's
default context is the scenario's start.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.common import RandomDistribution
from pydrake.geometry import (
    ClippingRange,
    DepthRange,
    DepthRenderCamera,
    MakeRenderEngineVtk,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    RenderCameraCore,
    RenderEngineVtkParams,
)
from pydrake.math import RigidTransform
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import (
    Adder,
    Gain,
    MatrixGain,
    Multiplexer,
    RandomSource,
    ZeroOrderHold,
)
from pydrake.systems.sensors import RgbdSensor

from manta_drake.modalities import MODALITIES, fill_docstring
from manta_drake.model.camera import camera_info
from manta_drake.model.coefficients import HydroCoefficients
from manta_drake.model.plant import (
    PlantHandles,
    add_plant,
    body_pose,
    floor_geometries,
    joint_state_selector,
    joint_torque_port,
    set_contact_friction,
)
from manta_drake.model.servo import joint_gains, saturation_angle
from manta_drake.scenario import Scenario
from manta_drake.station.battery import Battery
from manta_drake.station.buoyancy import BalloonBuoyancy
from manta_drake.station.depth_image_noise import DepthImageNoise
from manta_drake.station.foot_contacts import FootContacts
from manta_drake.station.hydro import HydrodynamicForces
from manta_drake.station.pressure import PressureSensor
from manta_drake.station.render_poses import add_camera_scene
from manta_drake.station.servo_bus import ServoBus
from manta_drake.station.servo_power import ServoPower
from manta_drake.station.servo_supply import ServoSupply

# The modalities' ports and parts in the docstring come from their registry.
__doc__ = fill_docstring(__doc__)


@dc.dataclass
class StationHandles:
    """Handles into a built station: the plant and every system by name."""

    plant_handles: PlantHandles
    systems: dict = dc.field(default_factory=dict)
    coefficients: HydroCoefficients | None = None

    @property
    def plant(self):
        return self.plant_handles.plant


def fin_added_mass(scenario: Scenario) -> str:
    """``add_plant``'s ``fin_added_mass`` for the scenario's fin model: the foil fins' added
    mass rides the plates as bodies, the cross-flow fins' is the hinges' reflected inertia."""
    return "bodies" if scenario.water.fin_model == "foil" else "hinge"


def _set_default_start(handles: PlantHandles, scenario: Scenario) -> None:
    """The scenario's initial pose and stance as the plant's defaults."""
    plant = handles.plant
    if handles.body.is_floating_base_body():
        plant.SetDefaultFloatingBaseBodyPose(
            handles.body, body_pose(scenario.initial_pose.xyz, scenario.initial_pose.rpy_deg)
        )
    for name, q in zip(handles.joint_names, scenario.initial_joint_angles()):
        plant.GetJointByName(name, handles.robot).set_default_angle(q)


def start_command(scenario: Scenario) -> np.ndarray:
    """The servos' command before the controller's first: the start stance at rest (a
    robot's servos hold the pose they were switched on in)."""
    q = scenario.initial_joint_angles()
    return np.concatenate([q, np.zeros_like(q)])


def _add_servo_bus(builder, scenario: Scenario, handles: PlantHandles, selector):
    """``desired_state`` into the plant's PD and the joints' state out as
    ``measured_joint_state``: directly, or with ``actuators.bus_period`` > 0 through a
    ``ServoBus`` (commands taken up one period after the controller wrote them, readings
    sampled every period in the servos' encoder and velocity units). Returns the bus, or
    None."""
    port = handles.plant.get_desired_state_input_port(handles.robot)
    period = scenario.actuators.bus_period
    if period == 0.0:
        builder.ExportInput(port, "desired_state")
        builder.ExportOutput(selector.get_output_port(), "measured_joint_state")
        return None
    bus = builder.AddNamedSystem(
        "servo_bus",
        ServoBus(
            len(handles.joint_names),
            period,
            scenario.energy_model().servo.encoder_resolution,
            start_command(scenario),
        ),
    )
    builder.ExportInput(bus.GetInputPort("command"), "desired_state")
    builder.Connect(bus.GetOutputPort("applied_command"), port)
    builder.Connect(selector.get_output_port(), bus.GetInputPort("joint_state"))
    builder.ExportOutput(bus.GetOutputPort("measured_joint_state"), "measured_joint_state")
    return bus


def _add_servo_supply(builder, scenario: Scenario, handles: StationHandles) -> None:
    """The datasheet servos at the battery's terminal voltage: ``ServoSupply``'s
    feed-forward into the plant's actuation input (the plant's PD is set at
    ``Scenario.bus_reference_voltage``), from the servos' goal (the bus's applied command,
    or the controller's ``desired_state``), the joints' state and the battery."""
    ph, servo = handles.plant_handles, scenario.energy_model().servo
    reference = scenario.bus_reference_voltage()
    kp, _, _ = joint_gains(servo, reference)
    supply = builder.AddNamedSystem(
        "servo_supply",
        ServoSupply(
            len(ph.joint_names), kp, saturation_angle(servo), reference, scenario.time_step
        ),
    )
    bus = handles.systems.get("servo_bus")
    if bus is None:
        builder.ConnectInput("desired_state", supply.GetInputPort("servo_goal"))
    else:
        builder.Connect(bus.GetOutputPort("applied_command"), supply.GetInputPort("servo_goal"))
    builder.Connect(
        handles.systems["joint_state_selector"].get_output_port(),
        supply.GetInputPort("joint_state"),
    )
    builder.Connect(
        handles.systems["battery"].GetOutputPort("battery"), supply.GetInputPort("battery")
    )
    builder.Connect(supply.get_output_port(), ph.plant.get_actuation_input_port(ph.robot))
    handles.systems["servo_supply"] = supply


def _motor_torque(builder, scenario: Scenario, handles: PlantHandles):
    """The system whose output is each joint's servo torque over the last plant step (16,
    N m), from C++ primitives: the plant's net actuation (the implicit PD's torque of the
    step about to be taken) held for one step, so that it meets the joint rate at that
    step's end; with ``actuators.servo_model: datasheet`` less the back-EMF braking
    b qdot that the plant applied as joint damping over the step (``model.servo``; the gear
    train's own friction stays out)."""
    plant, n = handles.plant, len(handles.joint_names)
    hold = builder.AddNamedSystem("joint_torque_hold", ZeroOrderHold(scenario.time_step, n))
    builder.Connect(joint_torque_port(handles), hold.get_input_port())
    b = scenario.servo_braking()
    if b == 0.0:
        return hold
    braking = builder.AddNamedSystem(
        "back_emf_braking", MatrixGain(-b * joint_state_selector(handles)[n:])
    )
    builder.Connect(plant.get_state_output_port(), braking.get_input_port())
    total = builder.AddNamedSystem("joint_torque", Adder(2, n))
    builder.Connect(hold.get_output_port(), total.get_input_port(0))
    builder.Connect(braking.get_output_port(), total.get_input_port(1))
    return total


def _random_source(builder, name: str, distribution, size: int, period: float):
    return builder.AddNamedSystem(name, RandomSource(distribution, size, period))


def _add_water(
    builder, scenario: Scenario, handles: StationHandles, hydro_plant_state: bool
) -> None:
    """Balloon, hydrodynamic forces and the pressure sensor with its noise sources."""
    plant, ph, coeffs = handles.plant, handles.plant_handles, handles.coefficients
    assert coeffs is not None  # the water is added only with its coefficients
    b = coeffs.balloon
    # The pump moves ~3 mL per 10 ms: a 10 ms update is exact enough and 10x cheaper.
    balloon = builder.AddNamedSystem(
        "balloon",
        BalloonBuoyancy(
            b.max_volume.value,
            b.pump_rate.value,
            max(scenario.time_step, 0.01),
            scenario.balloon.initial_fill * b.max_volume.value,
        ),
    )
    fill_to_volume = builder.AddNamedSystem("balloon_fill_to_volume", Gain(b.max_volume.value, 1))
    builder.Connect(fill_to_volume.get_output_port(), balloon.GetInputPort("volume_command"))
    builder.ExportInput(fill_to_volume.get_input_port(), "balloon_command")
    builder.ExportOutput(balloon.GetOutputPort("balloon_volume"), "balloon_volume")
    # AddToBuilder's default force port: generalized forces when they are computed at every
    # step (one vector instead of 17 force objects), the held list otherwise (cached between
    # updates, mapped to joint torques in C++ at each step).
    current = scenario.current_schedule()
    hydro = HydrodynamicForces.AddToBuilder(
        builder,
        plant,
        ph.robot,
        coeffs,
        scenario.time_step,
        params=scenario.robot_params(),
        # A schedule that never changes is its one current (packed once, no per-step lookup).
        current=current.at(0.0) if current.is_constant else current.constant,
        added_mass_iso=ph.added_mass_iso,
        current_schedule=None if current.is_constant else current,
        update_period=scenario.water.update_period,
        inputs="plant_state" if hydro_plant_state else "contract",
        name="hydro",
        fin_model=scenario.water.fin_model,
    )
    builder.Connect(balloon.GetOutputPort("balloon_volume"), hydro.GetInputPort("balloon_volume"))

    ps = scenario.pressure_sensor
    period = 1.0 / ps.rate_hz
    sensor = builder.AddNamedSystem(
        "pressure_sensor",
        PressureSensor(plant, ph.body, ps.position, period, ps.noise_std, ps.dropout_rate),
    )
    builder.Connect(plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    normal = _random_source(
        builder, "pressure_noise_normal", RandomDistribution.kGaussian, 1, period
    )
    uniform = _random_source(
        builder, "pressure_noise_uniform", RandomDistribution.kUniform, 1, period
    )
    mux = builder.AddNamedSystem("pressure_noise", Multiplexer([1, 1]))
    builder.Connect(normal.get_output_port(), mux.get_input_port(0))
    builder.Connect(uniform.get_output_port(), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(), sensor.GetInputPort("noise"))
    builder.ExportOutput(sensor.GetOutputPort("depth"), "depth")
    handles.systems.update(balloon=balloon, hydro=hydro, pressure_sensor=sensor)


def _add_camera(
    builder, scenario: Scenario, handles: StationHandles, camera_own_scene: bool
) -> None:
    """RGB-D camera on the head (VTK, in its own SceneGraph), its depth noise and the
    noise sources."""
    plant, ph = handles.plant, handles.plant_handles
    cam = scenario.camera
    if camera_own_scene:
        scene, poses, frames = add_camera_scene(builder, ph)
        camera_frame = frames[int(ph.body.index())]
        handles.systems.update(camera_scene_graph=scene, camera_render_poses=poses)
    else:
        scene = ph.scene_graph
        if not scene.HasRenderer("vtk"):
            scene.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
        camera_frame = plant.GetBodyFrameIdOrThrow(ph.body.index())
    core = RenderCameraCore(
        "vtk",
        camera_info(cam.width, cam.height, cam.fov_y_deg),
        ClippingRange(0.5 * cam.min_range, 2.0 * cam.max_range),
        RigidTransform(),
    )
    X_BC = plant.GetFrameByName("camera", ph.robot).GetFixedPoseInBodyFrame()
    camera = builder.AddNamedSystem(
        "camera",
        RgbdSensor(
            camera_frame,
            X_BC,
            DepthRenderCamera(core, DepthRange(cam.min_range, cam.max_range)),
            False,
        ),
    )
    builder.Connect(scene.get_query_output_port(), camera.query_object_input_port())
    # The range limit is the sensor's (light absorbed along each ray), applied with the noise.
    noise = builder.AddNamedSystem(
        "depth_noise",
        DepthImageNoise(
            cam.width,
            cam.height,
            cam.depth_noise_std,
            cam.pixel_dropout,
            max_range=cam.max_range,
            camera_info=camera_info(cam.width, cam.height, cam.fov_y_deg),
        ),
    )
    builder.Connect(camera.depth_image_32F_output_port(), noise.GetInputPort("depth_image"))
    n_pixels, period = cam.width * cam.height, 1.0 / cam.rate_hz
    for port, distribution in (
        ("range_noise", RandomDistribution.kGaussian),
        ("dropout_sample", RandomDistribution.kUniform),
    ):
        source = _random_source(builder, f"depth_{port}", distribution, n_pixels, period)
        builder.Connect(source.get_output_port(), noise.GetInputPort(port))
    builder.ExportOutput(noise.GetOutputPort("noisy_depth_image"), "depth_image")
    builder.ExportOutput(camera.body_pose_in_world_output_port(), "camera_pose")
    handles.systems.update(camera=camera, depth_noise=noise)


def _add_power(builder, scenario: Scenario, handles: StationHandles) -> None:
    """The energy model: the servos' and computers' electrical power and the battery. It
    reads the plant; the datasheet servos take the battery's voltage (``_add_servo_supply``),
    so only with the ideal servo is the run's motion the same without it."""
    a, ph = scenario.actuators, handles.plant_handles
    model = scenario.energy_model()
    n = len(ph.joint_names)
    # The station's joint torque is the last step's (``_motor_torque``), so it meets the
    # joint rate at that step's end and tau qdot dt is the step's work.
    servos = builder.AddNamedSystem(
        "servo_power", ServoPower(model.servo, model.electronics_power, n)
    )
    builder.Connect(
        handles.systems["joint_torque"].get_output_port(), servos.GetInputPort("joint_torque")
    )
    builder.Connect(
        handles.systems["joint_state_selector"].get_output_port(),
        servos.GetInputPort("measured_joint_state"),
    )
    battery = builder.AddNamedSystem(
        "battery",
        Battery(model.pack, scenario.time_step, a.initial_soc, stop_at_cutoff=a.stop_when_empty),
    )
    builder.Connect(
        servos.GetOutputPort("electrical_power"), battery.GetInputPort("electrical_power")
    )
    builder.ExportOutput(servos.GetOutputPort("electrical_power"), "electrical_power")
    builder.ExportOutput(battery.GetOutputPort("battery"), "battery")
    builder.ExportOutput(servos.GetOutputPort("joint_mechanical_power"), "joint_mechanical_power")
    handles.systems.update(servo_power=servos, battery=battery)


def _add_modalities(builder, scenario: Scenario, handles: StationHandles) -> None:
    """The modalities' sensors on the hull (``manta_drake.modalities``), each with its Drake
    noise sources, in the table's order (added after every other random source, so that a
    scenario without them draws the same noise as before they existed)."""
    for m in MODALITIES:
        if m.reading is not None and m.available(scenario):
            sensor = m.reading.add(builder, handles.plant_handles, scenario)
            builder.ExportOutput(sensor.GetOutputPort(m.reading.port), m.reading.port)
            handles.systems[m.reading.section] = sensor


def _add_foot_contacts(builder: DiagramBuilder, handles: StationHandles) -> None:
    """The floor's load and slip per leg-fin (``FootContacts``), exported as
    ``foot_contacts``."""
    plant_handles = handles.plant_handles
    system = FootContacts.AddToBuilder(
        builder,
        plant_handles.plant,
        plant_handles.scene_graph,
        plant_handles.robot,
        floor_geometries(plant_handles),
    )
    handles.systems["foot_contacts"] = system
    builder.ExportOutput(system.get_output_port(), "foot_contacts")


def build_station(
    scenario: Scenario,
    meshcat=None,
    *,
    hydro_plant_state: bool = True,
    camera_own_scene: bool = True,
) -> tuple[Diagram, StationHandles]:
    """Builds the station of ``scenario`` (see the module docstring for its ports).

    Args:
        scenario: a validated Scenario (``time_step``, ``water``, ``balloon``,
            ``pressure_sensor``, ``camera``, ``initial_pose``, ``initial_stance``).
        meshcat: if given, a MeshcatVisualizer inside the station draws the plant
            (as in ``MakeHardwareStation``).
        hydro_plant_state: True (the default) feeds ``HydrodynamicForces`` the plant's
            state vector and applies its generalized forces (forces at every step) or its
            held spatial forces (``water.update_period`` > 0); False wires the contract's
            ports (body poses and spatial velocities in, spatial forces out), the reference
            path (the same forces to 1e-12; the per-body objects cost more than the maths,
            docs/performance.md).
        camera_own_scene: True (the default) renders the camera in a SceneGraph of its own
            (``add_camera_scene``); False in the plant's SceneGraph (a VTK pose update at
            every plant step; the benchmark measures the difference).

    Returns:
        (station diagram, StationHandles).
    """
    builder = DiagramBuilder()
    coeffs = scenario.hydro_coefficients()
    plant_handles = add_plant(
        builder,
        time_step=scenario.time_step,
        discrete_contact_approximation=scenario.discrete_contact_approximation,
        hydro=coeffs,
        robot_params=scenario.robot_params(),
        fin_added_mass=fin_added_mass(scenario),
    )
    set_contact_friction(plant_handles, scenario.contact.friction)
    handles = StationHandles(plant_handles, coefficients=coeffs)
    plant = plant_handles.plant
    _set_default_start(plant_handles, scenario)
    selector = builder.AddNamedSystem(
        "joint_state_selector", MatrixGain(joint_state_selector(plant_handles))
    )
    builder.Connect(plant.get_state_output_port(), selector.get_input_port())
    handles.systems["joint_state_selector"] = selector  # the joints' true [q, qdot]
    bus = _add_servo_bus(builder, scenario, plant_handles, selector)
    if bus is not None:
        handles.systems["servo_bus"] = bus
    handles.systems["joint_torque"] = _motor_torque(builder, scenario, plant_handles)
    builder.ExportOutput(handles.systems["joint_torque"].get_output_port(), "joint_torque")
    builder.ExportOutput(plant.get_state_output_port(), "plant_state")
    builder.ExportOutput(plant_handles.scene_graph.get_query_output_port(), "query_object")
    if plant_handles.pool is not None:
        _add_foot_contacts(builder, handles)
    if coeffs is not None:
        _add_water(builder, scenario, handles, hydro_plant_state)
    if scenario.camera.enabled:
        _add_camera(builder, scenario, handles, camera_own_scene)
    if scenario.actuators.enabled:
        _add_power(builder, scenario, handles)
        if scenario.actuators.servo_model == "datasheet":
            _add_servo_supply(builder, scenario, handles)
    _add_modalities(builder, scenario, handles)
    if meshcat is not None:
        params = MeshcatVisualizerParams(publish_period=1.0 / scenario.visualization.recording_fps)
        handles.systems["visualizer"] = MeshcatVisualizer.AddToBuilder(
            builder, plant_handles.scene_graph, meshcat, params
        )
    station = builder.Build()
    station.set_name("station")
    handles.systems.update(plant=plant, scene_graph=plant_handles.scene_graph)
    return station, handles
