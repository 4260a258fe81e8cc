#!/usr/bin/env python3
"""Real-time factors of the simulator, in one run (no Meshcat, progress bars off).

  (a) the plant alone: the robot holding its gait stance on the pool floor with constant
      joint targets, no Python systems (no water: the hydrodynamics are a Python system);
  (b) the full closed loop without the camera: plant, water (forces held 4 ms, as in the
      shipped scenarios), balloon, pressure sensor, fuzzy depth, potential transition, CPG
      (the two-behaviour scenario); also with exact per-step forces (update_period 0);
  (c) the full closed loop with the camera at its scenario rate (the three-behaviour scenario).

Prints each real-time factor (simulated seconds per wall second) and (b)/(a).
Goals (reported, not tested): (b) >= 3x real time and >= half of (a); (c) >= 1x.

Usage: python scripts/benchmark.py [--duration 10]
"""

import argparse
import pathlib
import sys
import tempfile

from manta_drake.scenario import load_scenario
from manta_drake.simulate import run

DIAGRAMS = pathlib.Path(__file__).resolve().parent.parent / "diagrams"


def rtf(name: str, duration: float, **changes) -> float:
    scenario = load_scenario(DIAGRAMS / f"{name}.yaml", {"duration": duration})
    scenario.visualization.meshcat = False
    for path, value in changes.items():
        obj = scenario
        *parents, leaf = path.split("__")
        for p in parents:
            obj = getattr(obj, p)
        setattr(obj, leaf, value)
    with tempfile.TemporaryDirectory() as out:
        result = run(scenario.validate(), out, progress=False, write_outputs=False)
    return result.metrics["real_time_factor"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0, help="simulated seconds per case")
    args = parser.parse_args()
    d = args.duration
    a = rtf("stand", d)
    b = rtf("two_behaviors", d)
    b_exact = rtf("two_behaviors", d, water__update_period=0.0)
    c = rtf("three_behaviors", d)
    print(f"(a) plant alone, constant targets        {a:6.2f}x real time")
    print(f"(b) closed loop, no camera (4 ms forces)  {b:6.2f}x real time   (b)/(a) = {b / a:.2f}")
    print(f"    closed loop, no camera (exact forces) {b_exact:6.2f}x real time")
    print(f"(c) closed loop with the camera           {c:6.2f}x real time")
    print("goals: (b) >= 3x and >= 0.5 (a); (c) >= 1x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
