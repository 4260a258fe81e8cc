#!/usr/bin/env python3
"""Section 4.3: swim -> sink -> trot -> wall seen -> turning; the paper's Figs. 11 and 12.

Writes the run's outputs, fig11_three_behaviors.png (joints, Euler angles, depth, z_hat and
s_hat with the behaviour phases shaded) and fig12_point_cloud.png (the labelled clusters of
the camera frame that saw the most wall) into --out.

Usage: python diagrams/three_behaviors.py [--out out/three_behaviors] [--duration S] [--no-meshcat]
"""

import pathlib
import sys

from manta_drake import plots
from manta_drake.cli import run_experiment

HERE = pathlib.Path(__file__).resolve().parent
# The paper's transitions in Fig. 11 (section 4.3), marked on the figure.
PAPER_WINDOWS = (("swim -> trot", 6.0, 14.0), ("trot -> turning", 20.0, 36.0))


def figures(result, scenario):
    fig11 = result.out_dir / "fig11_three_behaviors.png"
    plots.fig_transition_run(
        result.log,
        result.metrics,
        fig11,
        "Three behaviours: swim, trot, turning by depth and vision (cf. paper Fig. 11)",
        paper_windows=PAPER_WINDOWS,
    )
    fig12 = result.out_dir / "fig12_point_cloud.png"
    controller = result.handles.controller
    best = None
    if controller.HasOutputPort("best_clusters"):
        best = controller.GetOutputPort("best_clusters").Eval(
            controller.GetMyContextFromRoot(result.context)
        )
    plots.fig_point_cloud(best, fig12)
    return [fig11, fig12]


if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "three_behaviors", "out/three_behaviors", figures))
