#!/usr/bin/env python3
"""The start of a run, by stage: what ``manta-drake run`` spends before and after its loop.

Each repetition is a fresh Python process (imports and numba's cache loading are per
process). Stages: ``manta-drake --help`` (the CLI alone); importing the package's running
layer (pydrake, numba kernels from their cache, scipy); ``load_scenario`` (the strict
reader, the coefficient file, the start-pose collision query); ``build_diagram``;
the first 10 ms of simulation (for a camera scenario this includes open3d's import at the
wall detector's first frame); and writing the outputs (log, metrics, three figures).

Usage: python scripts/benchmark_startup.py [--scenario three_behaviors] [--repeats 5]
Prints the median and the range of each stage in seconds.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

STAGES = r"""
import json, sys, time, tempfile
t0 = time.perf_counter()
from manta_drake.simulate import make_simulator, run
from manta_drake.scenario import load_scenario
from manta_drake.wiring.diagram import build_diagram
t1 = time.perf_counter()
s = load_scenario(sys.argv[1], overrides={"duration": 0.01, "visualization.meshcat": False})
t2 = time.perf_counter()
diagram, handles = build_diagram(s)
t3 = time.perf_counter()
simulator = make_simulator(diagram, s)
simulator.Initialize()
simulator.AdvanceTo(0.01)
t4 = time.perf_counter()
with tempfile.TemporaryDirectory() as out:
    start = time.perf_counter()
    result = run(s, out, progress=False)
    total = time.perf_counter() - start
    write = total - result.metrics["wall_time_s"]
print(json.dumps({"import": t1 - t0, "load_scenario": t2 - t1, "build_diagram": t3 - t2,
                  "first_10_ms": t4 - t3, "run_0.01_s_outside_the_loop": write}))
"""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="three_behaviors")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    rows = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "manta_drake.cli", "--help"], check=True, capture_output=True
        )
        helped = time.perf_counter() - start
        out = subprocess.run(
            [sys.executable, "-c", STAGES, args.scenario],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        rows.append({"manta-drake --help": helped, **json.loads(out.strip().splitlines()[-1])})
    print(
        f"{args.scenario}, {args.repeats} fresh processes; machine: {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    for stage in rows[0]:
        values = [r[stage] for r in rows]
        print(
            f"  {stage:<30} {statistics.median(values):6.2f} s  "
            f"({min(values):.2f}-{max(values):.2f})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
