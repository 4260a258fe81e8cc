"""Matplotlib figures of a run, written to files.

The figures are made with matplotlib's object API (``Figure``, no pyplot), so writing
them needs no display and leaves the caller's pyplot backend alone (a notebook keeps its
inline figures).
"""

from __future__ import annotations

import pathlib

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from manta_drake import metrics as M
from manta_drake.control.vision import LABEL_COLORS
from manta_drake.modalities import MODALITIES
from manta_drake.model.robot_params import DEFAULT_POOL, DEFAULT_ROBOT, JOINTS, LEGS

LEG_TITLES = {"fl": "front-left", "fr": "front-right", "rl": "rear-left", "rr": "rear-right"}


def plot_joints(t, q, t_cmd, q_cmd, path, title="", shade=None):
    """Joint angles (measured solid, commanded dashed) in a 4x1 grid, one panel per leg-fin.

    Args:
        shade: optional list of (start, end, label) spans to shade (behaviour phases).
    """
    fig = Figure(figsize=(10, 9))
    axes = fig.subplots(4, 1, sharex=True)
    colors = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
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
                ax.text(
                    (start + end) / 2,
                    1.02,
                    label,
                    transform=ax.get_xaxis_transform(),
                    ha="center",
                    va="bottom",
                    fontsize=8,
                )
        ax.set_ylabel(f"{LEG_TITLES[leg]}\n[deg]")
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=4, fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(f"{title} joint angles (solid: measured, dashed: commanded)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_states(log: dict, path, title="", leaves=None):
    """Body Euler angles (the yaw unwrapped), depth and (if logged) z_hat, s_hat, the
    balloon's volume and, given the behaviour tree's ``leaves``, their weights over time."""
    t = log["t"]
    rpy = log["body_rpy"].copy()
    rpy[:, 2] = np.unwrap(rpy[:, 2])
    # Each panel: its label and its series, (values, name) over t or (values, name, times).
    panels: list[tuple[str, list[tuple[np.ndarray, str] | tuple[np.ndarray, str, np.ndarray]]]] = [
        (
            "Euler angles [deg]\n(yaw unwrapped)",
            [(np.degrees(rpy[:, i]), n) for i, n in enumerate(("roll", "pitch", "yaw"))],
        )
    ]
    panels.append(("body depth below surface [m]", [(-log["body_xyz"][:, 2], "depth")]))
    for key, label in (("z_hat", "z_hat"), ("s_hat", "s_hat"), ("balloon_volume", "balloon [L]")):
        if key in log and len(log[key]):
            scale = 1000.0 if key == "balloon_volume" else 1.0
            panels.append((label, [(log[key][:, 0] * scale, key, log[f"t_{key}"])]))
    if leaves is not None and len(log.get("behaviour_weights", [])):
        panels.append(
            (
                "behaviour weights",
                [
                    (log["behaviour_weights"][:, i], leaf, log["t_behaviour_weights"])
                    for i, leaf in enumerate(leaves)
                ],
            )
        )
    fig = Figure(figsize=(10, 2.2 * len(panels) + 1))
    axes = fig.subplots(len(panels), 1, sharex=True)
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


# The margin [m] around the path that the trajectory's view keeps (a wall within it shows).
TRAJECTORY_MARGIN = 0.5


def trajectory_limits(xy, pool=(15.0, 2.0), margin: float = TRAJECTORY_MARGIN):
    """((x0, x1), (y0, y1)): the path's box grown by ``margin`` on every side, no larger
    than the pool grown by the same margin, and at least 1 m wide and high."""
    xy = np.asarray(xy, dtype=float)
    L, W = pool
    limits = []
    for k, half in enumerate((L / 2, W / 2)):
        lo = max(xy[:, k].min() - margin, -half - margin)
        hi = min(xy[:, k].max() + margin, half + margin)
        grow = max(0.0, 1.0 - (hi - lo)) / 2
        limits.append((lo - grow, hi + grow))
    return tuple(limits)


def plot_trajectory(log: dict, path, title="", pool=(15.0, 2.0)):
    """Top view of the body's path at its own scale (the pool's walls drawn, seen where
    they are within ``TRAJECTORY_MARGIN`` of the path), the heading marked along it."""
    xyz = log["body_xyz"]
    (x0, x1), (y0, y1) = trajectory_limits(xyz[:, :2], pool)
    fig = Figure(figsize=(8, max(3.0, min(8.0, 8 * (y1 - y0) / (x1 - x0)))))
    ax = fig.subplots()
    L, W = pool
    ax.add_patch(
        Rectangle((-L / 2, -W / 2), L, W, fill=False, lw=2.0, color="gray", label="pool walls")
    )
    ax.plot(xyz[:, 0], xyz[:, 1], lw=1.5)
    step = max(1, len(xyz) // 12)
    yaw = log["body_rpy"][::step, 2]
    ax.quiver(
        xyz[::step, 0],
        xyz[::step, 1],
        np.cos(yaw),
        np.sin(yaw),
        width=0.004,
        scale=25,
        color="tab:blue",
        alpha=0.6,
        label="heading",
    )
    ax.plot(*xyz[0, :2], "go", label="start")
    ax.plot(*xyz[-1, :2], "rs", label="end")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8)
    ax.set_title(f"{title} trajectory (top view)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def write_run_plots(log: dict, out_dir, title="", shade=None, leaves=None) -> None:
    """joints.png, states.png and trajectory.png of one run (``leaves``: the behaviour
    tree's gait names, for the weights panel)."""
    out_dir = pathlib.Path(out_dir)
    if len(log["t"]) == 0:
        return
    plot_joints(
        log["t"],
        log["joint_angles"],
        log.get("t_command"),
        log.get("commanded_joint_angles"),
        out_dir / "joints.png",
        title,
        shade,
    )
    if "body_xyz" in log:
        plot_states(log, out_dir / "states.png", title, leaves)
        plot_trajectory(log, out_dir / "trajectory.png", title)


# --- the paper's figures ----------------------------------------------------------------------


def behaviour_spans(transitions: list, end: float) -> list:
    """(start, end, label) spans for shading: each behaviour held, and each transition
    (from its start until the parameters arrived, or until the next change when they did
    not)."""
    spans, t0 = [], 0.0
    current = transitions[0]["from"] if transitions else None
    for k, tr in enumerate(transitions):
        spans.append((t0, tr["start_s"], tr["from"]))
        until = transitions[k + 1]["start_s"] if k + 1 < len(transitions) else end
        t0 = until if tr["end_s"] is None else tr["end_s"]
        spans.append((tr["start_s"], t0, f"{tr['from']}->{tr['to']}"))
        current = tr["to"]
    if current is not None:
        spans.append((t0, end, current))
    return spans


def wall_spans(log: dict, margin: float) -> list:
    """(start, end) of each stretch of the log where the hull is within ``margin`` [m] of a
    pool wall (``metrics.wall_clearance``, the rule of metrics.json's ``near_wall_at_s``)."""
    t = log["t"]
    near = (
        M.wall_clearance(
            log["body_xyz"],
            log["body_quat_wxyz"],
            DEFAULT_ROBOT.body_semi_axes,
            DEFAULT_POOL.length / 2,
            DEFAULT_POOL.width / 2,
        )
        < margin
    )
    edges = np.flatnonzero(np.diff(np.r_[0, near.astype(int), 0]))
    return [(float(t[a]), float(t[b - 1])) for a, b in zip(edges[::2], edges[1::2])]


# The 0-1 estimates a behaviour tree reads, as fig_transition_run labels them.
ESTIMATES = tuple((m.estimate, m.label) for m in MODALITIES)


def fig_transition_run(
    log: dict,
    metrics: dict,
    path,
    title: str,
    joints=("fl",),
    paper_windows=(),
    wall_margin=None,
    wall_label="near a wall",
    leaves=None,
):
    """Fig. 10 / 11 style: commanded joint outputs, Euler angles, depth and every modality
    estimate in the log (``ESTIMATES``: z_hat, s_hat, posture_hat, ...) over time, with the
    behaviour phases shaded (grey: a behaviour held, orange: a transition). ``leaves``: the
    behaviour tree's gait names; given, a last panel draws their weights
    (``behaviour_weights``).

    ``paper_windows``: (label, start_s, end_s) of the paper's transitions, drawn as dashed
    purple brackets on every panel so the run can be compared with the printed figure.
    ``wall_margin`` [m]: the time the hull is within it of a wall is hatched red on every
    panel, ``wall_label`` in the legends."""
    t = log["t"]
    spans = behaviour_spans(metrics.get("transitions", []), float(t[-1]) if len(t) else 0)
    walls = wall_spans(log, wall_margin) if wall_margin is not None and len(t) else []
    rows = [
        ("joint outputs [deg]", "joints"),
        ("Euler angles [deg]", "euler"),
        ("depth [m]", "depth"),
        ("estimates (0-1)", "sensing"),
    ]
    if leaves is not None and "behaviour_weights" in log:
        rows.append(("behaviour weights", "weights"))
    fig = Figure(figsize=(11, 2.5 * len(rows)))
    axes = fig.subplots(len(rows), 1, sharex=True)
    for ax, (ylabel, kind) in zip(axes, rows):
        _shade_behaviours(ax, spans, labelled=kind == "joints")
        _hatch_walls(ax, walls, wall_label)
        _mark_paper_windows(ax, paper_windows, annotated=kind == "sensing")
        _draw_transition_panel(ax, kind, log, joints, leaves)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _shade_behaviours(ax, spans: list, labelled: bool) -> None:
    """``behaviour_spans`` shaded (grey: a behaviour held, orange: a transition), each
    labelled above the panel when ``labelled``."""
    for start, end, label in spans:
        transition = "->" in label
        ax.axvspan(
            start,
            end,
            color="tab:orange" if transition else "gray",
            alpha=0.18 if transition else 0.07,
        )
        if labelled:
            ax.text(
                (start + end) / 2,
                1.01,
                label,
                transform=ax.get_xaxis_transform(),
                ha="center",
                va="bottom",
                fontsize=8,
            )


def _hatch_walls(ax, walls: list, wall_label: str) -> None:
    """The (start, end) stretches near a wall hatched red, labelled once in the legend."""
    for k, (start, end) in enumerate(walls):
        ax.axvspan(
            start,
            end,
            facecolor="none",
            edgecolor="tab:red",
            hatch="//",
            lw=0,
            alpha=0.35,
            label=wall_label if k == 0 else None,
        )


def _mark_paper_windows(ax, paper_windows, annotated: bool) -> None:
    """The paper's (label, start_s, end_s) transitions as dashed purple lines, with a
    labelled bracket when ``annotated``."""
    for label, start, end in paper_windows:
        for x in (start, end):
            ax.axvline(x, color="tab:purple", ls="--", lw=1.0, alpha=0.8)
        if annotated:
            ax.annotate(
                "",
                xy=(end, 0.5),
                xytext=(start, 0.5),
                xycoords=ax.get_xaxis_transform(),
                arrowprops=dict(arrowstyle="<->", color="tab:purple"),
            )
            ax.text(
                (start + end) / 2,
                0.53,
                f"paper: {label}",
                color="tab:purple",
                transform=ax.get_xaxis_transform(),
                ha="center",
                va="bottom",
                fontsize=8,
            )


def _draw_transition_panel(ax, kind: str, log: dict, joints, leaves) -> None:
    """One panel of ``fig_transition_run``'s: its curves and legend."""
    t = log["t"]
    if kind == "joints":
        for leg in joints:
            k = LEGS.index(leg)
            for j, joint in enumerate(JOINTS):
                ax.plot(
                    log["t_command"],
                    np.degrees(log["commanded_joint_angles"][:, 4 * k + j]),
                    lw=1.0,
                    label=f"{LEG_TITLES[leg]} {joint}",
                )
        ax.legend(ncol=4, fontsize=7, loc="lower left")
    elif kind == "euler":
        for i, name in enumerate(("roll", "pitch", "yaw")):
            ax.plot(t, np.degrees(np.unwrap(log["body_rpy"][:, i])), label=name)
        ax.legend(ncol=3, fontsize=8)
    elif kind == "depth":
        ax.plot(t, -log["body_xyz"][:, 2], label="hull centre")
        if "depth" in log:
            ax.plot(log["t_depth"], log["depth"][:, 0], lw=0.8, label="pressure sensor (head)")
        ax.invert_yaxis()
        ax.legend(fontsize=8)
    elif kind == "weights":
        for i, leaf in enumerate(leaves):
            ax.plot(log["t_behaviour_weights"], log["behaviour_weights"][:, i], label=leaf)
        ax.set_ylim(-0.05, 1.45)  # Eq. (12)'s weights sum to up to 1.41
        ax.legend(ncol=len(leaves), fontsize=8)
    else:
        _draw_estimates(ax, log)


def _draw_estimates(ax, log: dict) -> None:
    """Every modality estimate in the log (``ESTIMATES``) over time, 0 to 1."""
    estimates = [(key, label) for key, label in ESTIMATES if key in log]
    for key, label in estimates:
        if key == "s_hat":  # the camera's step signal
            ax.step(log["t_s_hat"], log["s_hat"][:, 0], where="post", label=label)
        else:
            ax.plot(log[f"t_{key}"], log[key][:, 0], label=label)
    ax.set_ylim(-0.05, 1.05)
    ax.legend(fontsize=8, ncol=len(estimates))


def fig_velocities(speeds: dict, path):
    """Fig. 7 style: mean body velocity (surge and sway) and yaw rate per gait."""
    names = list(speeds)
    # None (no free-water steady window) plots as a gap.
    vel = [speeds[n]["mean_velocity_body"] or [np.nan, np.nan] for n in names]
    u, v = [x[0] for x in vel], [x[1] for x in vel]
    yaw = [
        np.nan if speeds[n]["yaw_rate_deg_s"] is None else speeds[n]["yaw_rate_deg_s"]
        for n in names
    ]
    x = np.arange(len(names))
    fig = Figure(figsize=(11, 4))
    (ax1, ax2) = fig.subplots(1, 2)
    ax1.bar(x - 0.2, u, 0.4, label="surge u (forward)")
    ax1.bar(x + 0.2, v, 0.4, label="sway v (left)")
    ax1.set_xticks(x, names)
    ax1.set_ylabel("mean body velocity [m/s]")
    ax1.axhline(0, color="k", lw=0.8)
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3, axis="y")
    ax2.bar(x, yaw, 0.5, color="tab:green")
    ax2.set_xticks(x, names)
    ax2.set_ylabel("mean yaw rate [deg/s]")
    ax2.axhline(0, color="k", lw=0.8)
    ax2.grid(alpha=0.3, axis="y")
    fig.suptitle("Locomotion velocity per gait (cf. paper Fig. 7)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def fig_left_front_joints(logs: dict, path, window: float = 6.0):
    """Fig. 9 style: left-front joint angles (measured) per gait over the last ``window`` s."""
    fig = Figure(figsize=(9, 2.3 * len(logs) + 0.5))
    axes = fig.subplots(len(logs), 1, sharex=False)
    axes = np.atleast_1d(axes)
    for ax, (name, log) in zip(axes, logs.items()):
        t = log["t"]
        m = t >= t[-1] - window
        for j, joint in enumerate(JOINTS):
            ax.plot(t[m] - t[m][0], np.degrees(log["joint_angles"][m, j]), label=joint)
        ax.set_ylabel(f"{name}\n[deg]")
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=4, fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Left-front leg-fin joint angles per gait (cf. paper Fig. 9)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def fig_point_cloud(detection, path, title="Labelled point cloud (cf. paper Fig. 12)"):
    """Top and side views of the wall detector's labelled clusters."""
    fig = Figure(figsize=(11, 4.5))
    (ax1, ax2) = fig.subplots(1, 2)
    for c in detection.clusters if detection is not None else []:
        color = LABEL_COLORS[c.label]
        ax1.scatter(c.points[:, 0], c.points[:, 1], s=4, color=color)
        ax2.scatter(c.points[:, 0], c.points[:, 2], s=4, color=color)
    for label, color in LABEL_COLORS.items():
        ax1.scatter([], [], color=color, label=label)
    ax1.set_xlabel("x [m]")
    ax1.set_ylabel("y [m]")
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.legend(fontsize=8)
    ax1.set_title("top view")
    ax2.set_xlabel("x [m]")
    ax2.set_ylabel("z [m]")
    ax2.set_aspect("equal", adjustable="datalim")
    ax2.set_title("side view")
    s = f", s_hat = {detection.s_hat:.2f} at t = {detection.time:.1f} s" if detection else ""
    fig.suptitle(title + s)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
