#!/usr/bin/env python3
"""Section 4.3: swim -> sink -> trot -> wall seen -> turning; the paper's Figs. 11 and 12.

Writes the run's outputs, fig11_three_behaviors.png (joints, Euler angles, depth, z_hat and
s_hat with the behaviour phases shaded) and fig12_point_cloud.png (the labelled clusters of
the camera frame that saw the most wall) into --out.

Usage: python diagrams/three_behaviors.py [--out out/three_behaviors] [--duration S] [--no-meshcat]
"""

import argparse
import pathlib
import sys

from manta_drake import plots
from manta_drake.cli import print_metrics
from manta_drake.scenario import load_scenario
from manta_drake.simulate import run

HERE = pathlib.Path(__file__).resolve().parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=HERE / "three_behaviors.yaml")
    parser.add_argument("--out", default="out/three_behaviors")
    parser.add_argument("--duration", type=float)
    parser.add_argument("--no-meshcat", action="store_true")
    args = parser.parse_args()
    scenario = load_scenario(args.scenario, {"duration": args.duration} if args.duration else {})
    if args.no_meshcat:
        scenario.visualization.meshcat = False
    result = run(scenario, args.out)
    fig11 = result.out_dir / "fig11_three_behaviors.png"
    plots.fig_transition_run(result.log, result.metrics, fig11,
                             "Three behaviours: swim, trot, turning by depth and vision "
                             "(cf. paper Fig. 11)")
    fig12 = result.out_dir / "fig12_point_cloud.png"
    detector = result.handles.systems.get("wall_detector")
    plots.fig_point_cloud(detector.best_detection if detector else None, fig12)
    print_metrics(result.metrics, result.out_dir)
    print(f"  figures: {fig11}, {fig12}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
