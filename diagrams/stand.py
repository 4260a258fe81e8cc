#!/usr/bin/env python3
"""The robot stands on the pool floor in the gait stance (gravity only, no water).

Usage: python diagrams/stand.py [--scenario models/scenarios/stand.yaml] [--out out/stand]
Writes recording.html, joints.png, states.png, trajectory.png, log.npz, metrics.json.
"""

import pathlib
import sys

from manta_drake.cli import run_experiment

HERE = pathlib.Path(__file__).resolve().parent

if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "stand", "out/stand"))
