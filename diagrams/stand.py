#!/usr/bin/env python3
"""The robot stands on the pool floor in the gait stance (gravity only).

Usage: python diagrams/stand.py [--scenario diagrams/stand.yaml] [--out out/stand]
Writes recording.html, joints.png, states.png, trajectory.png, log.npz, metrics.json.
"""

import argparse
import pathlib
import sys

from manta_drake.cli import print_metrics
from manta_drake.scenario import load_scenario
from manta_drake.simulate import run

HERE = pathlib.Path(__file__).resolve().parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=HERE / "stand.yaml")
    parser.add_argument("--out", default="out/stand")
    args = parser.parse_args()
    result = run(load_scenario(args.scenario), args.out)
    print_metrics(result.metrics, result.out_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
