"""Matplotlib figures of a run (headless, Agg backend)."""

from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from manta_drake.robot_params import JOINTS, LEGS  # noqa: E402

LEG_TITLES = {"fl": "front-left", "fr": "front-right", "rl": "rear-left", "rr": "rear-right"}


def plot_joints(t, q, t_cmd, q_cmd, path, title="", shade=None):
    """Joint angles (measured solid, commanded dashed) in a 4x1 grid, one panel per leg-fin.

    Args:
        shade: optional list of (start, end, label) spans to shade (behaviour phases).
    """
    fig, axes = plt.subplots(4, 1, figsize=(10, 9), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (ax, leg) in enumerate(zip(axes, LEGS)):
        for j, joint in enumerate(JOINTS):
            i = 4 * k + j
            if len(t):
                ax.plot(t, np.degrees(q[:, i]), color=colors[j], lw=1.2, label=joint)
            if t_cmd is not None and len(t_cmd):
                ax.plot(t_cmd, np.degrees(q_cmd[:, i]), color=colors[j], lw=0.8, ls="--")
        for start, end, label in shade or []:
            ax.axvspan(start, end, alpha=0.12, color="gray")
            if k == 0:
                ax.text((start + end) / 2, 1.02, label, transform=ax.get_xaxis_transform(),
                        ha="center", va="bottom", fontsize=8)
        ax.set_ylabel(f"{LEG_TITLES[leg]}\n[deg]")
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=4, fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"{title} joint angles (solid: measured, dashed: commanded)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_states(log: dict, path, title=""):
    """Body Euler angles, depth and (if logged) z_hat, s_hat and balloon volume over time."""
    t = log["t"]
    panels = [("Euler angles [deg]", [(np.degrees(log["body_rpy"][:, i]), n)
                                      for i, n in enumerate(("roll", "pitch", "yaw"))])]
    panels.append(("body depth below surface [m]", [(-log["body_xyz"][:, 2], "depth")]))
    for key, label in (("z_hat", "z_hat"), ("s_hat", "s_hat"), ("balloon_volume", "balloon [L]")):
        if key in log and len(log[key]):
            scale = 1000.0 if key == "balloon_volume" else 1.0
            panels.append((label, [(log[key][:, 0] * scale, key, log[f"t_{key}"])]))
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 2.2 * len(panels) + 1), sharex=True)
    axes = np.atleast_1d(axes)
    for ax, (ylabel, series) in zip(axes, panels):
        for s in series:
            ax.plot(s[2] if len(s) > 2 else t, s[0], label=s[1])
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if len(series) > 1:
            ax.legend(fontsize=8, ncol=3)
    axes[0].set_title(f"{title} body state")
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_trajectory(log: dict, path, title="", pool=(15.0, 2.0)):
    """Top view of the body's path in the pool."""
    xyz = log["body_xyz"]
    fig, ax = plt.subplots(figsize=(10, 3.2))
    L, W = pool
    ax.add_patch(plt.Rectangle((-L / 2, -W / 2), L, W, fill=False, lw=1.5, color="gray"))
    ax.plot(xyz[:, 0], xyz[:, 1], lw=1.5)
    ax.plot(*xyz[0, :2], "go", label="start")
    ax.plot(*xyz[-1, :2], "rs", label="end")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8)
    ax.set_title(f"{title} trajectory (top view)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_run_plots(log: dict, out_dir, title="", shade=None) -> None:
    """joints.png, states.png and trajectory.png of one run."""
    out_dir = pathlib.Path(out_dir)
    if len(log["t"]) == 0:
        return
    plot_joints(log["t"], log["joint_angles"], log.get("t_command"),
                log.get("commanded_joint_angles"), out_dir / "joints.png", title, shade)
    if "body_xyz" in log:
        plot_states(log, out_dir / "states.png", title)
        plot_trajectory(log, out_dir / "trajectory.png", title)
