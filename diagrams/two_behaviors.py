#!/usr/bin/env python3
"""Section 4.2: swim -> sink -> trot -> rise -> swim, driven by depth; the paper's Fig. 10.

Writes the run's outputs and fig10_two_behaviors.png (joint outputs, Euler angles, depth,
z_hat, with the behaviour phases shaded) into --out.

Usage: python diagrams/two_behaviors.py [--out out/two_behaviors] [--duration S] [--no-meshcat]
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
    parser.add_argument("--scenario", default=HERE / "two_behaviors.yaml")
    parser.add_argument("--out", default="out/two_behaviors")
    parser.add_argument("--duration", type=float)
    parser.add_argument("--no-meshcat", action="store_true")
    args = parser.parse_args()
    scenario = load_scenario(args.scenario, {"duration": args.duration} if args.duration else {})
    if args.no_meshcat:
        scenario.visualization.meshcat = False
    result = run(scenario, args.out)
    path = result.out_dir / "fig10_two_behaviors.png"
    plots.fig_transition_run(result.log, result.metrics, path,
                             "Two behaviours: swim <-> trot by depth (cf. paper Fig. 10)")
    print_metrics(result.metrics, result.out_dir)
    print(f"  figure: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
