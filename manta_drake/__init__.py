"""manta_drake: a Drake simulation of the multi-jointed manta-ray robot of Asada et al. (2026).

The public API (stable across restructurings; README's "API" section documents it):

* the systems: ``CpgOscillators``, ``FuzzyDepthEstimator``, ``WallDetector``,
  ``PotentialTransition``, ``HydrodynamicForces``, ``BalloonBuoyancy``, ``PressureSensor``;
* the gait library: ``GAITS``, ``GaitParams``;
* scenarios and runs: ``Scenario``, ``load_scenario``, ``build_diagram``, ``run``;
* the seam: ``build_station`` (the simulated robot) and ``build_controller`` (what runs
  on the robot), which ``build_diagram`` connects by port name.
"""

from manta_drake.version import __version__

from manta_drake.control.cpg import CpgOscillators
from manta_drake.control.depth import FuzzyDepthEstimator
from manta_drake.control.gaits import GAITS, GaitParams
from manta_drake.control.transition import PotentialTransition
from manta_drake.control.vision import WallDetector
from manta_drake.scenario import Scenario, load_scenario
from manta_drake.simulate import run
from manta_drake.station.buoyancy import BalloonBuoyancy
from manta_drake.station.hydro import HydrodynamicForces
from manta_drake.station.pressure import PressureSensor
from manta_drake.wiring import build_controller, build_diagram, build_station

__all__ = [
    "BalloonBuoyancy", "CpgOscillators", "FuzzyDepthEstimator", "GAITS", "GaitParams",
    "HydrodynamicForces", "PotentialTransition", "PressureSensor", "Scenario", "WallDetector",
    "build_controller", "build_diagram", "build_station", "load_scenario", "run",
]
