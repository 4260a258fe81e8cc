"""The one place that wires the whole diagram: station + controller + loggers.

``build_diagram(scenario)`` builds the station (``manta_drake.wiring.station``) and
the controller (``manta_drake.wiring.controller``), connects every controller input
to the station output of the same name and the controller's commands to the station's
inputs of the same names, and logs the signals that ``simulate`` writes to log.npz.
See ``docs/design.md`` for the picture and the port lists.
"""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.geometry import Meshcat, MeshcatParams
from pydrake.systems.framework import Diagram, DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink

from manta_drake.modalities import MODALITIES
from manta_drake.model.plant import PlantHandles
from manta_drake.scenario import Scenario
from manta_drake.wiring.controller import ControllerHandles, build_controller
from manta_drake.wiring.station import StationHandles, build_station


def _modality_loggers() -> tuple:
    """(source, port, period) of each modality's sensor and estimator outputs."""
    out = []
    for m in MODALITIES:
        if m.reading is not None:
            out.append(
                ("station", m.reading.port, lambda s, r=m.reading: max(s.log_period, r.period(s)))
            )
        if m.estimation is not None:
            out += [
                ("controller", port, lambda s, e=m.estimation: max(s.log_period, e.period))
                for port in m.estimation.outputs
            ]
    return tuple(out)


# What the top-level diagram logs: (source, port, period) with the period a function of
# the scenario; a port the built halves do not have (e.g. no camera) is skipped.
_LOGGED = (
    ("station", "plant_state", lambda s: s.log_period),
    ("controller", "desired_state", lambda s: s.log_period),
    ("station", "joint_torque", lambda s: s.log_period),
    # The energy model's signals change at every plant step: logged with the joint state.
    ("station", "electrical_power", lambda s: s.log_period),
    ("station", "joint_mechanical_power", lambda s: s.log_period),
    ("station", "battery", lambda s: s.log_period),
    # Ground truth for the feet's summary. Reading the plant's contact results solves the
    # contact problem (~0.4 ms), so sampled at 100 Hz at most (the stances last 150-450
    # ms), on the other loggers' 10 ms grid (``FootContacts`` says why).
    ("station", "foot_contacts", lambda s: max(s.log_period, 0.01)),
    (
        "controller",
        "cpg_params",
        lambda s: (
            s.transition.period if s.controller.mode == "transition" else max(s.log_period, 0.01)
        ),
    ),
    ("station", "balloon_volume", lambda s: max(s.log_period, 0.01)),
    ("station", "depth", lambda s: 1.0 / s.pressure_sensor.rate_hz),
    ("controller", "z_hat", lambda s: 1.0 / s.pressure_sensor.rate_hz),
    (
        "controller",
        "s_hat",
        lambda s: 1.0 / s.camera.rate_hz if s.camera.enabled else max(s.log_period, 0.01),
    ),
    ("controller", "detector_status", lambda s: 1.0 / s.camera.rate_hz),
    # The modalities' sensors and estimates (manta_drake.modalities), each at its own
    # period (each only when its half has the port).
    *_modality_loggers(),
    ("controller", "behaviour_weights", lambda s: s.transition.period),
    ("controller", "heading_trim", lambda s: max(s.log_period, s.heading_hold.period)),
    ("controller", "balloon_command", lambda s: max(s.log_period, 0.01)),
)


@dc.dataclass
class DiagramHandles:
    """Handles into a built diagram: both halves, every system by name, the loggers."""

    station: Diagram
    controller: Diagram
    station_handles: StationHandles
    controller_handles: ControllerHandles
    systems: dict = dc.field(default_factory=dict)
    loggers: dict = dc.field(default_factory=dict)
    meshcat: Meshcat | None = None

    @property
    def plant_handles(self) -> PlantHandles:
        return self.station_handles.plant_handles

    @property
    def plant(self):
        return self.plant_handles.plant

    @property
    def visualizer(self):
        return self.systems.get("visualizer")


def connect_by_name(builder: DiagramBuilder, source, sink) -> list[str]:
    """Connects every input port of ``sink`` to the output port of ``source`` with the same
    name (the seam's convention); returns the connected names. An input without a
    same-named output is left for the caller."""
    names = []
    for i in range(sink.num_input_ports()):
        name = sink.get_input_port(i).get_name()
        if source.HasOutputPort(name):
            builder.Connect(source.GetOutputPort(name), sink.get_input_port(i))
            names.append(name)
    return names


def build_diagram(
    scenario: Scenario,
    *,
    hydro_plant_state: bool = True,
    camera_own_scene: bool = True,
    compiled_cpg: bool = True,
) -> tuple[Diagram, DiagramHandles]:
    """Builds the diagram of ``scenario``.

    The keyword arguments choose between equivalent implementations (the defaults are the
    fast ones; see ``build_station`` and ``build_controller``); tests and the benchmark
    pass them to compare against the reference paths.

    Returns:
        (diagram, handles). ``handles.loggers`` holds ``plant_state``, ``desired_state``
        and whichever of ``cpg_params``, ``balloon_volume``, ``depth``, ``z_hat``,
        ``s_hat`` and ``detector_status`` the two halves have.
    """
    meshcat = (
        Meshcat(MeshcatParams(host="localhost", port=None))
        if scenario.visualization.meshcat
        else None
    )
    station, station_handles = build_station(
        scenario, meshcat, hydro_plant_state=hydro_plant_state, camera_own_scene=camera_own_scene
    )
    controller, controller_handles = build_controller(scenario, meshcat, compiled_cpg=compiled_cpg)
    builder = DiagramBuilder()
    builder.AddSystem(station)
    builder.AddSystem(controller)
    connect_by_name(builder, station, controller)
    connect_by_name(builder, controller, station)
    for half in (station, controller):
        for i in range(half.num_input_ports()):
            port = half.get_input_port(i)
            if not builder.IsConnectedOrExported(port):
                raise RuntimeError(
                    f"{half.get_name()}.{port.get_name()}: nothing drives this "
                    "input (the two halves' port names do not match)"
                )
    handles = DiagramHandles(
        station, controller, station_handles, controller_handles, meshcat=meshcat
    )
    handles.systems.update(station_handles.systems)
    handles.systems.update(controller_handles.systems)
    halves = {"station": station, "controller": controller}
    for half, port, period in _LOGGED:
        if halves[half].HasOutputPort(port):
            handles.loggers[port] = LogVectorOutput(
                halves[half].GetOutputPort(port), builder, period(scenario)
            )
    diagram = builder.Build()
    diagram.set_name(f"manta_drake:{scenario.name}")
    return diagram, handles


def logger_data(logger: VectorLogSink, root_context) -> tuple[np.ndarray, np.ndarray]:
    """(times, data.T) of a logger in ``root_context``."""
    log = logger.FindLog(root_context)
    return log.sample_times().copy(), log.data().T.copy()
