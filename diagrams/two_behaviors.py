#!/usr/bin/env python3
"""Section 4.2: swim -> sink -> trot -> rise -> swim, driven by depth; the paper's Fig. 10.

Writes the run's outputs and fig10_two_behaviors.png (joint outputs, Euler angles, depth,
z_hat, with the behaviour phases shaded and the time the hull is within the free-water margin
of a wall hatched, "at a side wall") into --out. The swim's yaw carries the robot to the right
side wall: within the margin from about 29.5 s, pressed against the wall from about 48 s to the
end (metrics.json: near_wall_at_s, touched_wall).

Usage: python diagrams/two_behaviors.py [--out out/two_behaviors] [--duration S] [--no-meshcat]
"""

import pathlib
import sys

from manta_drake import plots
from manta_drake.cli import run_experiment

HERE = pathlib.Path(__file__).resolve().parent
# The paper's transitions in Fig. 10 (section 4.2), marked on the figure.
PAPER_WINDOWS = (("swim -> trot", 13.0, 21.0), ("trot -> swim", 50.0, 63.0))


def figures(result, scenario):
    path = result.out_dir / "fig10_two_behaviors.png"
    plots.fig_transition_run(
        result.log,
        result.metrics,
        path,
        "Two behaviours: swim <-> trot by depth (cf. paper Fig. 10)",
        paper_windows=PAPER_WINDOWS,
        wall_margin=scenario.free_water_margin,
        wall_label="at a side wall",
    )
    return [path]


if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "two_behaviors", "out/two_behaviors", figures))
