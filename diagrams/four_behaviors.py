#!/usr/bin/env python3
"""Behaviours from flow, depth and energy: walk in a cross current, trot when it drops, rise and
swim, rest at the battery's reserve (models/scenarios/four_behaviors.yaml), a Fig. 11-style
figure of it; the paper's own three-behaviour run is diagrams/three_behaviors.py, unchanged.

Writes the run's outputs and fig_four_behaviors.png (joints, Euler angles, depth, every
modality estimate and the behaviour tree's weights, with the behaviour phases shaded) into --out.

Usage: python diagrams/four_behaviors.py [--out out/four_behaviors] [--duration S] [--no-meshcat]
"""

import sys

from manta_drake import plots
from manta_drake.cli import run_experiment


def figures(result, scenario):
    path = result.out_dir / "fig_four_behaviors.png"
    plots.fig_transition_run(
        result.log,
        result.metrics,
        path,
        "Four behaviours from flow, depth and the battery (cf. paper Fig. 11)",
        leaves=scenario.behaviour_tree().leaves,
    )
    return [path]


if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "four_behaviors", "out/four_behaviors", figures))
