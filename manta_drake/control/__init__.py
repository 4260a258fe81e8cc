"""The controller: what runs on the robot (depth estimator, wall detector, behaviour
transition, CPG and the gait library).

``build_controller`` (in ``manta_drake.control.controller``) assembles them into one
Diagram that consumes only the station's sensor ports and commands joints and balloon.
"""
