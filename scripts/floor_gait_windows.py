"""How long a floor gait must be measured: the shipped walk, trot and crab for 40 s each, their
mean velocity and yaw rate over consecutive windows of 6, 12 and 24 s from 6 s (``metrics``'
own means, each window cut where the hull first comes near a wall), printed as a table and
drawn as heading and distance from the start against time (docs/optimize.md, "Floor gaits
need long windows").

    .venv/bin/python scripts/floor_gait_windows.py [--runs DIR] [--figure PNG] [--duration S]

A gait's window means scatter with the window's length: the spread over the 6 s windows is
what a search on 6 s windows measures its candidates with. Runs already in ``--runs`` (a
``log.npz`` and ``metrics.json`` per gait, made with the same duration) are reused.
"""

from __future__ import annotations

import argparse
import json
import pathlib

import numpy as np

GAITS = ("walk", "trot", "crab")
WINDOWS_S = (6.0, 12.0, 24.0)
START_S = 6.0


def run_gait(gait: str, folder: pathlib.Path, duration: float) -> tuple[dict, dict]:
    """The shipped ``locomotion_<gait>`` scenario for ``duration`` s (its log and metrics)."""
    if not (folder / "log.npz").is_file():
        from manta_drake.scenario import load_scenario
        from manta_drake.simulate import run

        overrides = {"visualization.meshcat": False, "duration": duration}
        run(load_scenario(f"locomotion_{gait}", overrides=overrides), folder, progress=False)
    metrics = json.loads((folder / "metrics.json").read_text())
    if metrics["sim_time_s"] != duration:
        raise SystemExit(f"{folder}: a {metrics['sim_time_s']} s run, not {duration} s")
    with np.load(folder / "log.npz") as z:
        return {k: z[k] for k in ("t", "body_quat_wxyz", "body_xyz")}, metrics


def window_means(log: dict, end: float, length: float) -> list[tuple[float, ...]]:
    """(start, u, v, yaw rate) of each whole window of ``length`` s from START_S to ``end``."""
    from manta_drake import metrics as M

    t, q, xyz = log["t"], log["body_quat_wxyz"], log["body_xyz"]
    out = []
    for a in np.arange(START_S, end - length + 1e-9, length):
        u, v = M.mean_velocity_from_displacement(t, q, xyz, a, a + length)
        out.append((float(a), float(u), float(v), float(M.yaw_rate_deg_s(t, q, a, a + length))))
    return out


def figure(logs: dict, ends: dict, path: pathlib.Path) -> None:
    from matplotlib.figure import Figure

    from manta_drake import metrics as M

    fig = Figure(figsize=(9, 6))
    heading, distance = fig.subplots(2, 1, sharex=True)
    for gait, log in logs.items():
        t = log["t"]
        keep = t <= ends[gait]
        yaw = np.degrees(np.unwrap(M.euler_rpy(log["body_quat_wxyz"])[:, 2]))
        away = np.linalg.norm(log["body_xyz"][:, :2] - log["body_xyz"][0, :2], axis=1)
        heading.plot(t[keep], yaw[keep] - yaw[0], label=gait)
        distance.plot(t[keep], away[keep], label=gait)
    for ax in (heading, distance):
        for a in np.arange(START_S, max(ends.values()), WINDOWS_S[0]):
            ax.axvline(a, color="0.85", lw=0.6)
        ax.grid(alpha=0.3)
    heading.set_ylabel("heading change [deg]")
    distance.set_ylabel("distance from the start [m]")
    distance.set_xlabel("t [s] (grey: the 6 s windows from 6 s)")
    heading.legend(fontsize=8)
    heading.set_title("Shipped floor gaits over 40 s, until the hull nears a wall")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", default="out/floor_gait_windows", type=pathlib.Path)
    ap.add_argument("--figure", default="docs/figures/floor_gait_windows.png", type=pathlib.Path)
    ap.add_argument("--duration", default=40.0, type=float)
    args = ap.parse_args()
    logs, ends = {}, {}
    print("| gait | window s | windows | u m/s | v m/s | yaw rate deg/s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for gait in GAITS:
        logs[gait], metrics = run_gait(gait, args.runs / gait, args.duration)
        ends[gait] = metrics["steady_window_s"][1]
        for length in WINDOWS_S:
            rows = window_means(logs[gait], ends[gait], length)
            if not rows:
                continue
            _, u, v, yaw = np.array(rows).T
            print(
                f"| {gait} | {length:g} | {len(rows)} | {u.min():.4f} to {u.max():.4f} | "
                f"{v.min():+.4f} to {v.max():+.4f} | {yaw.min():+.2f} to {yaw.max():+.2f} |"
            )
        w = metrics["steady_window_s"]
        print(
            f"| {gait} | whole, {w[0]:g}-{w[1]:.1f} s | 1 | "
            f"{metrics['mean_velocity_body'][0]:.4f} | {metrics['mean_velocity_body'][1]:+.4f} | "
            f"{metrics['yaw_rate_deg_s']:+.2f} |"
        )
    figure(logs, ends, args.figure)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
