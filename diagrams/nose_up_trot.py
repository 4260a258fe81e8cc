#!/usr/bin/env python3
"""Floor detection independent of the hull's pitch (models/scenarios/nose_up_trot.yaml): a
trot that walks nose up, its tree's floor-or-water choice read from the altimeter's
floor_hat, and the same run with the tree on the pressure sensor's z_hat.

Writes both runs' outputs (the z_hat run in <out>/tree_on_z_hat) and fig_nose_up_trot.png:
the hull's pitch, the two estimates, the swim's weight in each run and the hull's height
above the floor, over time.

Usage: python diagrams/nose_up_trot.py [--out out/nose_up_trot] [--duration S] [--no-meshcat]
"""

import sys

import numpy as np
from matplotlib.figure import Figure

from manta_drake import simulate
from manta_drake.cli import run_experiment
from manta_drake.model.robot_params import DEFAULT_POOL
from manta_drake.scenario import with_overrides

RUNS = (("tree on floor_hat (altimeter)", "tab:green"), ("tree on z_hat (pressure)", "tab:red"))


def tree_on_z_hat(scenario):
    """The same scenario with the tree's root reading the depth estimate."""
    return with_overrides(scenario, {"transition.tree.root.modality": "z_hat"})


def plot(logs, path):
    fig = Figure(figsize=(10, 9))
    ax_pitch, ax_est, ax_w, ax_h = fig.subplots(4, 1, sharex=True)
    for log, (label, color) in zip(logs, RUNS):
        ax_pitch.plot(
            log["t"], -np.degrees(log["body_rpy"][:, 1]), color=color, lw=0.8, label=label
        )
        swim = log["behaviour_weights"][:, 0]
        ax_w.plot(log["t_behaviour_weights"], swim, color=color, label=label)
        ax_h.plot(
            log["t"], log["body_xyz"][:, 2] + DEFAULT_POOL.depth, color=color, lw=0.8, label=label
        )
    log = logs[1]  # both estimates, from the run whose tree reads z_hat
    ax_est.plot(log["t_z_hat"], log["z_hat"][:, 0], color="tab:red", label="z_hat (pressure)")
    ax_est.plot(
        log["t_floor_hat"], log["floor_hat"][:, 0], color="tab:green", label="floor_hat (altimeter)"
    )
    ax_pitch.set_ylabel("nose-up pitch [deg]")
    ax_est.set_ylabel("estimate (1: on the floor)")
    ax_w.set_ylabel("swim's weight")
    ax_h.set_ylabel("hull centre above\nthe floor [m]")
    ax_h.set_xlabel("time [s]")
    for ax in (ax_pitch, ax_est, ax_w, ax_h):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    ax_pitch.set_title(
        "A nose-up trot: the depth estimate follows the pitch, the altimeter's does not"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def figures(result, scenario):
    other = simulate.run(tree_on_z_hat(scenario), result.out_dir / "tree_on_z_hat", progress=False)
    path = result.out_dir / "fig_nose_up_trot.png"
    plot([result.log, other.log], path)
    return [path]


if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "nose_up_trot", "out/nose_up_trot", figures))
