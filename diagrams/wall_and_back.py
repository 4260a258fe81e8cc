#!/usr/bin/env python3
"""A mission from estimates alone (models/scenarios/wall_and_back.yaml): sink, walk the floor
until the camera sees a wall, rise on the wall estimate (the balloon rule reads s_hat) and
swim back on a heading the same estimate turned by 180 deg (heading_hold.changes).

Writes the run's outputs and fig_wall_and_back.png (joints, Euler angles with the yaw
unwrapped, depth, every estimate and the behaviour tree's weights, with the behaviour phases
shaded) into --out.

Usage: python diagrams/wall_and_back.py [--out out/wall_and_back] [--duration S] [--no-meshcat]
"""

import sys

from manta_drake import plots
from manta_drake.cli import run_experiment


def figures(result, scenario):
    path = result.out_dir / "fig_wall_and_back.png"
    plots.fig_transition_run(
        result.log,
        result.metrics,
        path,
        "Sink, walk to a wall, rise and swim back: a mission from estimates",
        leaves=scenario.behaviour_tree().leaves,
        wall_margin=scenario.free_water_margin,
    )
    return [path]


if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "wall_and_back", "out/wall_and_back", figures))
