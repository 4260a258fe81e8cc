"""The robot, the pool and their data, installed as the package ``manta_drake.models``.

``manta.sdf`` and ``pool.sdf`` (generated from ``manta_drake/model/robot_params.py``),
``package.xml`` (so ``package://manta_drake/...`` URLs resolve through Drake's
``PackageMap``), the hydrodynamic coefficients ``hydrodynamics.yaml``, the CFD samples
``cfd/*.csv`` and the shipped scenarios ``scenarios/*.yaml``: data with their
provenance, no code.
"""
