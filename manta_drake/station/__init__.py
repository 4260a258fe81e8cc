"""The station's systems: the simulated robot's world (water, balloon, sensors, noise).

Each module is one Drake System with its maths as plain functions. They import only
``manta_drake.model`` and ``manta_drake.config_io``; ``manta_drake.wiring.station``
assembles them with the plant into the station Diagram from a scenario.
"""
