#!/usr/bin/env python3
"""Plots every joint's (rate, torque) samples of run folders over the servo's torque-speed
envelope at the runs' bus voltages (``manta_drake.model.servo``; the battery's logged
terminal voltage, or the servo file's supply voltage without the energy model), the lowest
and the highest seen: the figure of docs/design.md, section 3.

Each run folder is a ``manta-drake run`` output (its ``log.npz`` and ``scenario.yaml``); the
envelope is the run's own servo (its ``actuators`` section). Prints, per run, the largest
|rate| and |torque| and the worst envelope ratio of ``metrics.json``.

Usage: python scripts/plot_servo_envelope.py RUN [RUN ...] [--out docs/figures/servo_envelope.png]
"""

import argparse
import json
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from manta_drake.model import servo as S
from manta_drake.scenario import load_scenario


def run_samples(folder: pathlib.Path):
    """(scenario, joint rates (N, 16), joint torques at those times (N, 16), the bus
    voltages over the run [V]) of a run."""
    scenario = load_scenario(folder / "scenario.yaml")
    log = np.load(folder / "log.npz")
    t, qdot = log["t"], log["joint_velocities"]
    tau = np.stack([np.interp(t, log["t_joint_torque"], c) for c in log["joint_torque"].T], 1)
    volts = (
        log["battery"][:, 1]
        if "battery" in log
        else np.array([scenario.energy_model().servo.supply_voltage])
    )
    return scenario, qdot, tau, volts


def envelope_lines(servo, voltage: float, speed: float):
    """The envelope's two edges tau = +-tau_s d_max - b qdot over |qdot| <= speed."""
    _, limit, b = S.joint_gains(servo, voltage)
    w = np.linspace(-speed, speed, 2)
    return w, limit - b * w, -limit - b * w


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=pathlib.Path, help="run output folders")
    parser.add_argument(
        "--out", type=pathlib.Path, default=pathlib.Path("docs/figures/servo_envelope.png")
    )
    args = parser.parse_args(argv)
    for folder in args.runs:
        if not (folder / "log.npz").is_file() or not (folder / "scenario.yaml").is_file():
            print(f"{folder}: not a run folder (log.npz and scenario.yaml)", file=sys.stderr)
            return 2
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    speed, low, high = 0.0, np.inf, 0.0
    for folder in args.runs:
        scenario, qdot, tau, volts = run_samples(folder)
        low, high = min(low, volts.min()), max(high, volts.max())
        envelope = json.loads((folder / "metrics.json").read_text()).get("actuator_envelope", {})
        print(
            f"{folder}: |qdot| <= {np.abs(qdot).max():.2f} rad/s, |tau| <= "
            f"{np.abs(tau).max():.2f} N m, worst envelope ratio "
            f"{envelope.get('worst_ratio', float('nan')):.2f}"
        )
        ax.plot(qdot.ravel(), tau.ravel(), ".", ms=1, alpha=0.3, label=folder.name)
        speed = max(speed, np.abs(qdot).max())
    servo = scenario.energy_model().servo
    for volts, style in ((high, "k-"), (low, "k--")):
        w, upper, lower = envelope_lines(servo, volts, max(speed, S.no_load_speed(servo, volts)))
        ax.plot(w, upper, style, lw=1.2, label=f"envelope at {volts:.2f} V")
        ax.plot(w, lower, style, lw=1.2)
        if high - low < 1e-9:
            break
    ax.set_xlabel("joint rate qdot [rad/s]")
    ax.set_ylabel("joint torque tau [N m]")
    ax.set_title("Every joint's samples against the servo's torque-speed envelope")
    ax.grid(alpha=0.3)
    ax.legend(markerscale=8, fontsize=8)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
