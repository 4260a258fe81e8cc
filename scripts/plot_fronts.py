"""The gait families' fronts in one figure, each with the paper's gait of the family on it.

    .venv/bin/python scripts/plot_fronts.py [--fronts DIR] [--figure PNG]

``--fronts DIR`` holds one front per family (its front.csv and front.json), as ``manta-drake
optimize`` writes it for each spec of diagrams/optimize/fronts/ with ``--out DIR/<family>``
(e.g. ``out/fronts``), or as they are kept with their provenance (the default,
diagrams/optimize/fronts/results); each family found there is a panel: every
candidate (grey: breaks a constraint; blue: meets them), the front (red) and the family's
paper gait (the search's start, generation 1's candidate 0) as a star. The start is its own
run (front.json's ``start_run``), so it is drawn even where its window is shorter than the
spec's ``min_window`` (a swim that reaches a side wall early), with its window beside it;
else the search's score of it. Prints each front's points and the start's.
"""

from __future__ import annotations

import argparse
import csv
import json
import pathlib

import numpy as np

FAMILIES = ("swim", "walk", "trot", "crab")


def read_points(folder: pathlib.Path, x: str, y: str) -> list[dict]:
    """front.csv's rows with the two metrics as numbers and the flags as booleans."""
    with open(folder / "front.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return [
        {
            **r,
            x: float(r[x] or "nan"),
            y: float(r[y] or "nan"),
            "meets_constraints": r["meets_constraints"] == "True",
            "on_front": r["on_front"] == "True",
        }
        for r in rows
    ]


def panel(ax, name: str, folder: pathlib.Path) -> None:
    from manta_drake.optimize.front import draw_front, start_label

    front = json.loads((folder / "front.json").read_text())
    x, y = front["maximise"], front["minimise"]
    points = read_points(folder, x, y)
    start, label = start_label(front)
    draw_front(ax, x, y, points, start, label)
    ok = sum(p["meets_constraints"] for p in points)
    print(f"{name}: {len(points)} points, {ok} meet the constraints; front:")
    for p in sorted(front["front"], key=lambda p: p[x]):
        print(f"  {x} {p[x]:.4f}  {y} {p[y]:.4f}  (level {p['level']}, g{p['generation']})")
    if start is not None and np.isfinite(start[x]):
        print(f"  {label}: {x} {start[x]:.4f} {y} {start[y]:.4f}")
    ax.set_title(f"{name} family")
    ax.set_xlabel(f"{x} [m/s]")
    ax.set_ylabel("electrical CoT net of hotel")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fronts", default="diagrams/optimize/fronts/results", type=pathlib.Path)
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
