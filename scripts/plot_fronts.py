"""The gait families' fronts in one figure, each with the paper's gait of the family on it.

    .venv/bin/python scripts/plot_fronts.py [--fronts DIR] [--figure PNG]

``--fronts DIR`` holds one front per family, as ``manta-drake optimize`` writes it for each
spec of diagrams/optimize/fronts/ with ``--out DIR/<family>`` (default ``out/fronts``, e.g.
``out/fronts/swim``); each family found there is a panel: every
candidate (grey: breaks a constraint; blue: meets them), the front (red) and the family's
paper gait (the search's start, generation 1's candidate 0) as a star. The start is read
from its own run's ``metrics.json``, so it is drawn even where its window is shorter than
the spec's ``min_window`` (a swim that reaches a side wall early): its window is printed
beside it. Prints each front's points and the start's.
"""

from __future__ import annotations

import argparse
import csv
import json
import pathlib

import numpy as np

FAMILIES = ("swim", "walk", "trot", "crab")


def start_point(folder: pathlib.Path, front: dict) -> dict | None:
    """The start gait's metrics at the scenario: its run of level 0, generation 1."""
    from manta_drake.optimize.front import level_folder
    from manta_drake.optimize.history import evaluation_folder

    run = evaluation_folder("search", generation=1, candidate=0, point=0, seed=0)
    path = level_folder(folder, 0) / run / "metrics.json"
    if not path.is_file():
        return None
    m = json.loads(path.read_text())
    u, v = m.get("mean_velocity_body") or (np.nan, np.nan)
    speed = {"u": u, "abs_v": abs(v)}[front["maximise"]]
    cot = (m.get("energy") or {}).get("cot_net_of_hotel_dry_weight", np.nan)
    return {
        "speed": speed,
        "cot": cot,
        "yaw": m.get("yaw_rate_deg_s"),
        "window": m.get("steady_window_s"),
    }


def panel(ax, name: str, folder: pathlib.Path) -> None:
    front = json.loads((folder / "front.json").read_text())
    x, y = front["maximise"], front["minimise"]
    with open(folder / "front.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r[x] not in ("", "nan")]
    ok = [r for r in rows if r["meets_constraints"] == "True"]
    bad = [r for r in rows if r["meets_constraints"] != "True"]
    ax.scatter([float(r[x]) for r in bad], [float(r[y]) for r in bad], s=6, color="0.8")
    ax.scatter([float(r[x]) for r in ok], [float(r[y]) for r in ok], s=9, color="tab:blue")
    on = sorted(front["front"], key=lambda p: p[x])
    ax.plot([p[x] for p in on], [p[y] for p in on], "o-", color="tab:red", label="front")
    print(f"{name}: {len(rows)} points, {len(ok)} meet the constraints; front:")
    for p in on:
        print(f"  {x} {p[x]:.4f}  {y} {p[y]:.4f}  (level {p['level']}, g{p['generation']})")
    start = start_point(folder, front)
    if start and np.isfinite(start["speed"]):
        w = start["window"]
        ax.scatter([start["speed"]], [start["cot"]], marker="*", s=200, color="k", zorder=5)
        ax.annotate(
            f"{front['start_gait']} (window {w[0]:g}-{w[1]:.1f} s)",
            (start["speed"], start["cot"]),
            textcoords="offset points",
            xytext=(6, 6),
            fontsize=8,
        )
        print(
            f"  {front['start_gait']}: {x} {start['speed']:.4f} {y} {start['cot']:.4f} "
            f"yaw {start['yaw']:+.2f} deg/s, window {w[0]:g}-{w[1]:.2f} s"
        )
    ax.set_title(f"{name} family")
    ax.set_xlabel(f"{x} [m/s]")
    ax.set_ylabel("electrical CoT net of hotel")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fronts", default="out/fronts", type=pathlib.Path)
    ap.add_argument("--figure", default="docs/figures/optimize_fronts.png", type=pathlib.Path)
    args = ap.parse_args()
    found = [f for f in FAMILIES if (args.fronts / f / "front.json").is_file()]
    if not found:
        raise SystemExit(f"--fronts {args.fronts}: no front.json of {', '.join(FAMILIES)}")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.5 * len(found), 4.5))
    axes = np.atleast_1d(fig.subplots(1, len(found)))
    for ax, name in zip(axes, found):
        panel(ax, name, args.fronts / name)
    fig.tight_layout()
    fig.savefig(args.figure, dpi=110)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
