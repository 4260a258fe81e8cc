"""The robot and its world as data: numbers, kinematics, SDFormat, plant, coefficients.

``MODELS_DIR`` is the package data folder with ``manta.sdf``, ``pool.sdf``,
``package.xml`` (so ``package://manta_drake/...`` resolves) and the hydrodynamic
coefficients ``hydrodynamics.yaml``. It ships inside the package, so a wheel or a
non-editable install finds it.
"""

import pathlib

MODELS_DIR = pathlib.Path(__file__).resolve().parent / "models"
