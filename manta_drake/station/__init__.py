"""The station: the simulated robot and its world (plant, water, balloon, sensors).

``build_station`` (in ``manta_drake.station.station``) assembles them into one
Diagram whose exported ports are what the real robot's hardware takes and gives.
"""
