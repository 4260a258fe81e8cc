#!/usr/bin/env python3
"""Float, sink and rise with the balloon (BVBS); writes the run's outputs and float_sink.png.

Usage: python diagrams/float_sink.py [--scenario diagrams/float_sink.yaml] [--out out/float_sink]
"""

import argparse
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from manta_drake.cli import print_metrics  # noqa: E402
from manta_drake.scenario import load_scenario  # noqa: E402
from manta_drake.simulate import run  # noqa: E402

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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=HERE / "float_sink.yaml")
    parser.add_argument("--out", default="out/float_sink")
    args = parser.parse_args()
    scenario = load_scenario(args.scenario)
    result = run(scenario, args.out)
    plot(result.log, scenario, result.out_dir / "float_sink.png")
    print_metrics(result.metrics, result.out_dir)
    print(f"  float_sink.png: depth and balloon volume over time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
