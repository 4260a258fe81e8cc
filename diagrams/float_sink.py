#!/usr/bin/env python3
"""Float, sink and rise with the balloon (BVBS); writes the run's outputs and float_sink.png.

Usage: python diagrams/float_sink.py [--scenario models/scenarios/float_sink.yaml]
       [--out out/float_sink]
"""

import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from manta_drake.cli import run_experiment

HERE = pathlib.Path(__file__).resolve().parent


def plot(log, scenario, path):
    """Depth of the hull centre and balloon volume over time, commands marked."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    ax1.plot(log["t"], -log["body_xyz"][:, 2])
    ax1.axhline(0.5, color="saddlebrown", lw=1, ls="--", label="pool floor")
    ax1.axhline(0.0, color="tab:blue", lw=1, ls="--", label="water surface")
    ax1.invert_yaxis()
    ax1.set_ylabel("hull centre depth [m]")
    ax1.legend(fontsize=8)
    ax2.plot(log["t_balloon_volume"], log["balloon_volume"][:, 0] * 1e3, color="tab:orange")
    ax2.set_ylabel("balloon volume [L]")
    ax2.set_xlabel("time [s]")
    for ax in (ax1, ax2):
        for cmd in scenario.balloon.schedule:
            ax.axvline(cmd.time, color="gray", lw=0.8, ls=":")
        ax.grid(alpha=0.3)
    ax1.set_title("float -> deflate -> sink -> inflate -> rise")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def figures(result, scenario):
    path = result.out_dir / "float_sink.png"
    plot(result.log, scenario, path)
    return [path]


if __name__ == "__main__":
    sys.exit(run_experiment(__doc__, "float_sink", "out/float_sink", figures))
