#!/usr/bin/env python3
"""Runs the CPG alone for each gait and plots its joint angles (the paper's Fig. 9).

For each gait writes ``<out>/gait_<name>.png``: the four joints of the left-front
leg-fin (top) and the four base (yaw) oscillators, one per leg-fin (bottom), from
rest (r = 0, chi = 0) with random initial phases, so the plots also show the
amplitude build-up and the phase locking. Prints the cost of the CPG alone per
simulated second.

Usage: python scripts/plot_gaits.py [--out out/gaits] [--duration 8] [--seed 0]
"""

import argparse
import pathlib
import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from manta_drake.control.cpg import CpgOscillators
from manta_drake.control.gaits import GAITS
from manta_drake.model.robot_params import JOINTS
from manta_drake.scenario import Scenario

LEGS = ("front-left", "front-right", "rear-left", "rear-right")


def run_cpg(name: str, duration: float, seed: int):
    """Simulates the CPG alone; returns (t, theta (N,16), phi (N,16), wall seconds)."""
    config = Scenario().cpg
    builder = DiagramBuilder()
    cpg = builder.AddSystem(
        CpgOscillators(
            config.frequency_hz, config.chain_weight, config.fcs_weight, config.a, config.b
        )
    )
    src = builder.AddSystem(ConstantVectorSource(GAITS[name].to_vector()))
    builder.Connect(src.get_output_port(), cpg.GetInputPort("cpg_params"))
    angles = LogVectorOutput(cpg.GetOutputPort("joint_angles"), builder, 1e-3)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ApplySimulatorConfig(Scenario().simulator, sim)
    context = sim.get_mutable_context()
    cpg_context = cpg.GetMyMutableContextFromRoot(context)
    cpg.set_state(cpg_context, phi=np.random.default_rng(seed).uniform(-np.pi, np.pi, 16))
    phis = []
    t_grid = np.arange(0.0, duration + 1e-9, 0.01)
    start = time.perf_counter()
    for t in t_grid:
        sim.AdvanceTo(t)
        phis.append(cpg_context.get_continuous_state_vector().CopyToVector()[:16].copy())
    wall = time.perf_counter() - start
    log = angles.FindLog(context)
    return log.sample_times(), log.data().T, t_grid, np.array(phis), wall


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/gaits")
    parser.add_argument("--duration", type=float, default=8.0)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    costs = []
    # Each distinct gait once (trot_printed and the like are trot's matrices in this reading).
    for name in [n for n in GAITS if not n.endswith("_printed")] + ["swim_printed"]:
        t, theta, tp, phi, wall = run_cpg(name, args.duration, args.seed)
        costs.append(wall / args.duration)
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
        for j, joint in enumerate(JOINTS):
            ax1.plot(t, np.degrees(theta[:, j]), label=joint)
        ax1.set_ylabel("left-front joint angle [deg]")
        ax1.legend(ncol=4, fontsize=8, loc="upper right")
        ax1.grid(alpha=0.3)
        for k, leg in enumerate(LEGS):
            ax2.plot(
                tp,
                np.degrees(np.angle(np.exp(1j * (phi[:, 4 * k] - phi[:, 0])))),
                label=f"{leg} - front-left",
            )
        ax2.set_ylabel("base phase difference [deg]")
        ax2.set_yticks([-180, -90, 0, 90, 180])
        ax2.set_xlabel("time [s]")
        ax2.legend(ncol=2, fontsize=8)
        ax2.grid(alpha=0.3)
        fig.suptitle(f"CPG alone, gait '{name}' (from rest, random initial phases)")
        fig.tight_layout()
        path = out / f"gait_{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        print(f"{name:8s} wrote {path}   cost {wall / args.duration * 1e3:6.1f} ms per simulated s")
    print(
        f"CPG alone: {np.mean(costs) * 1e3:.1f} ms wall per simulated second "
        f"({1 / np.mean(costs):.0f}x real time)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
