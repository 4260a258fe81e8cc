"""The wiring: the station and the controller built from a scenario, and the diagram that
connects them by port name (as the manipulation course's ``MakeHardwareStation``)."""

from manta_drake.wiring.controller import ControllerHandles, build_controller
from manta_drake.wiring.diagram import DiagramHandles, build_diagram, connect_by_name
from manta_drake.wiring.station import StationHandles, build_station

__all__ = [
    "ControllerHandles",
    "DiagramHandles",
    "StationHandles",
    "build_controller",
    "build_diagram",
    "build_station",
    "connect_by_name",
]
