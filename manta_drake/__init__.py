"""manta_drake: a Drake simulation of the multi-jointed manta-ray robot of Asada et al. (2026).

The public API (stable across restructurings; README's "API" section documents it):

* the systems: ``CpgOscillators``, ``FuzzyDepthEstimator``, ``WallDetector``,
  ``PotentialTransition``, ``HydrodynamicForces``, ``BalloonBuoyancy``, ``PressureSensor``;
* the gait library: ``GAITS``, ``GaitParams``;
* scenarios and runs: ``Scenario``, ``load_scenario``, ``build_diagram``, ``run``;
* the seam: ``build_station`` (the simulated robot) and ``build_controller`` (what runs
  on the robot), which ``build_diagram`` connects by port name.

The names are imported when first used (PEP 562), so ``import manta_drake.cli`` or
``manta-drake --help`` does not load Drake, numba and open3d.
"""

import importlib

from manta_drake.version import __version__

# name -> the module that defines it
_API = {
    "CpgOscillators": "manta_drake.control.cpg",
    "FuzzyDepthEstimator": "manta_drake.control.depth",
    "GAITS": "manta_drake.control.gaits",
    "GaitParams": "manta_drake.control.gaits",
    "PotentialTransition": "manta_drake.control.transition",
    "WallDetector": "manta_drake.control.vision",
    "Scenario": "manta_drake.scenario",
    "load_scenario": "manta_drake.scenario",
    "run": "manta_drake.simulate",
    "BalloonBuoyancy": "manta_drake.station.buoyancy",
    "HydrodynamicForces": "manta_drake.station.hydro",
    "PressureSensor": "manta_drake.station.pressure",
    "build_controller": "manta_drake.wiring.controller",
    "build_diagram": "manta_drake.wiring.diagram",
    "build_station": "manta_drake.wiring.station",
}

__all__ = sorted(_API) + ["__version__"]


def __getattr__(name: str):
    if name in _API:
        value = getattr(importlib.import_module(_API[name]), name)
        globals()[name] = value  # the next access skips this function
        return value
    raise AttributeError(f"module 'manta_drake' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
