"""The controller's systems: what runs on the robot (depth estimator, wall detector,
behaviour transition, CPG and the gait library).

Each module is one Drake System (or its pure maths). They import only
``manta_drake.model`` and ``manta_drake.config_io``, never the station;
``manta_drake.wiring.controller`` assembles them into the controller Diagram.
"""
