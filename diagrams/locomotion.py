#!/usr/bin/env python3
"""Section 4.1: each gait from rest; the paper's Fig. 7 (velocities) and Fig. 9 (joints).

Runs models/scenarios/locomotion_<gait>.yaml for swim, trot, walk, crab and turning (each into
<out>/<gait>/), then writes <out>/fig7_velocities.png, <out>/fig9_left_front_joints.png and
<out>/velocities.json, and prints the velocity table.

Usage: python diagrams/locomotion.py [--out out/locomotion] [--gaits swim trot ...]
                                     [--duration S] [--no-meshcat]
"""

import argparse
import json
import pathlib
import sys

from manta_drake import plots
from manta_drake.scenario import load_scenario
from manta_drake.simulate import run

HERE = pathlib.Path(__file__).resolve().parent
GAIT_NAMES = ("swim", "trot", "walk", "crab", "turning")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/locomotion")
    parser.add_argument("--gaits", nargs="+", default=list(GAIT_NAMES), choices=GAIT_NAMES)
    parser.add_argument("--duration", type=float, help="override each run's duration [s]")
    parser.add_argument("--no-meshcat", action="store_true")
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    speeds, logs = {}, {}
    for gait in args.gaits:
        overrides = {"duration": args.duration} if args.duration else {}
        scenario = load_scenario(f"locomotion_{gait}", overrides)
        if args.no_meshcat:
            scenario.visualization.meshcat = False
        print(f"--- {gait}", file=sys.stderr)
        result = run(scenario, out / gait)
        speeds[gait] = {
            k: result.metrics[k]
            for k in (
                "mean_velocity_body",
                "yaw_rate_deg_s",
                "distance_m",
                "real_time_factor",
                "steady_window_s",
                "near_wall_at_s",
            )
        }
        logs[gait] = result.log
    plots.fig_velocities(speeds, out / "fig7_velocities.png")
    plots.fig_left_front_joints(logs, out / "fig9_left_front_joints.png")
    (out / "velocities.json").write_text(json.dumps(speeds, indent=2) + "\n")
    print(
        f"\n{'gait':8s} {'u [m/s]':>9s} {'v [m/s]':>9s} {'yaw [deg/s]':>12s} "
        f"{'free-water window [s]':>22s}"
    )
    for gait, m in speeds.items():
        u, v = m["mean_velocity_body"] or (float("nan"), float("nan"))
        yaw = float("nan") if m["yaw_rate_deg_s"] is None else m["yaw_rate_deg_s"]
        t0, t1 = m["steady_window_s"]
        print(f"{gait:8s} {u:9.4f} {v:9.4f} {yaw:12.2f} {t0:10.1f} - {t1:5.1f}")
    print(f"\nfigures: {out / 'fig7_velocities.png'}, {out / 'fig9_left_front_joints.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
