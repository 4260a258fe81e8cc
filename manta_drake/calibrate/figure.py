"""A calibration's ``calibration.png``: each experiment measured against simulated before
and after, and the cost and parameters at every evaluation."""

from __future__ import annotations

import dataclasses as dc
import math
import pathlib

import numpy as np

from manta_drake.calibrate.config import CalibrationConfig
from manta_drake.calibrate.evaluator import Evaluator
from manta_drake.calibrate.loading import experiment_measured, measured_columns
from manta_drake.calibrate.results import CalibrationResult


def write_calibration_figure(
    path: pathlib.Path,
    config: CalibrationConfig,
    evaluator: Evaluator,
    initial: dict,
    final: dict,
    result: CalibrationResult,
) -> pathlib.Path:
    """calibration.png: per experiment the measured trajectory (or targets) against the
    simulated ones before and after; the last row the cost and parameters per evaluation."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(config.experiments)
    fig, axes = plt.subplots(n + 1, 3, figsize=(12, 3.0 * (n + 1)), squeeze=False)
    styles = (
        ("initial", initial, dict(color="tab:orange", ls="--")),
        ("calibrated", final, dict(color="tab:blue")),
    )
    for row, e in enumerate(config.experiments):
        _draw_experiment(
            axes[row], config, e, [(label, ev["runs"][row], style) for label, ev, style in styles]
        )
    ax_cost, ax_x, ax_text = axes[n]
    _draw_cost(ax_cost, evaluator.history)
    _draw_parameters(ax_x, evaluator.history, result.names)
    _write_result(ax_text, result)
    fig.suptitle(f"calibration {config.name}", x=0.02, ha="left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _draw_experiment(axes, config: CalibrationConfig, e, runs: list) -> None:
    """One experiment's row: top view, depth and heading measured against ``runs``
    ((label, simulated run, style), before and after), and its targets as bars."""
    ax_path, ax_z, ax_yaw = axes
    if e.measured:
        _draw_trajectories(axes, config, e, runs)
    else:
        for ax in (ax_z, ax_yaw):
            ax.axis("off")
    if e.target:
        _draw_targets(ax_path if not e.measured else ax_yaw.twinx(), e, runs)
    for ax in axes:
        if ax.has_data():
            ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)


def _draw_trajectories(axes, config: CalibrationConfig, e, runs: list) -> None:
    """The measured path, depth and heading of experiment ``e`` (dots) and the simulated."""
    ax_path, ax_z, ax_yaw = axes
    full = experiment_measured(config, dc.replace(e, columns=_available(config, e)))
    if "x" in full and "y" in full:
        ax_path.plot(full["x"], full["y"], "k.", ms=3, label="measured")
    if "z" in full:
        ax_z.plot(full["t"], full["z"], "k.", ms=3, label="measured")
    if "yaw" in full:
        ax_yaw.plot(full["t"], np.degrees(full["yaw"]), "k.", ms=3, label="measured")
    for label, sim, style in runs:
        if "t" not in sim:
            continue
        ax_path.plot(sim["x"], sim["y"], label=label, **style)
        ax_z.plot(sim["t"], sim["z"], label=label, **style)
        ax_yaw.plot(sim["t"], np.degrees(sim["yaw"]), label=label, **style)
    ax_path.set(xlabel="x [m]", ylabel="y [m]", title=f"{e.name}: top view")
    ax_path.axis("equal")
    ax_z.set(xlabel="t [s]", ylabel="z [m]", title=f"{e.name}: depth")
    ax_yaw.set(xlabel="t [s]", ylabel="yaw [deg]", title=f"{e.name}: heading")


def _draw_targets(ax, e, runs: list) -> None:
    """Experiment ``e``'s targets as bars beside the simulated values."""
    keys = list(e.target)
    pos = np.arange(len(keys))
    ax.bar(pos - 0.25, [e.target[k] for k in keys], 0.25, color="k", label="target")
    for k, (label, sim, style) in enumerate(runs):
        ax.bar(
            pos + 0.25 * k,
            [sim.get(key, math.nan) for key in keys],
            0.25,
            color=style["color"],
            label=label,
        )
    ax.set_xticks(pos, keys)
    ax.set_title(f"{e.name}: targets")


def _draw_cost(ax, hist: list) -> None:
    """The cost at the optimiser's points (log scale)."""
    centres = [h for h in hist if h["kind"] == "point"]
    ax.semilogy([h["evaluation"] for h in centres], [h["cost"] for h in centres], "o-", ms=3)
    ax.set(
        xlabel="evaluation",
        ylabel="cost (1/2 sum of squared scores)",
        title="cost at the optimiser's points",
    )
    ax.grid(alpha=0.3)


def _draw_parameters(ax, hist: list, names: list) -> None:
    """Each parameter at the optimiser's points (lines) and finite-difference points (dots)."""
    centres = [h for h in hist if h["kind"] == "point"]
    for i, name in enumerate(names):
        (line,) = ax.plot(
            [h["evaluation"] for h in centres], [h["x"][i] for h in centres], "o-", ms=3, label=name
        )
        ax.plot(
            [h["evaluation"] for h in hist if h["kind"] != "point"],
            [h["x"][i] for h in hist if h["kind"] != "point"],
            ".",
            ms=3,
            alpha=0.5,
            color=line.get_color(),
        )
    ax.set(
        xlabel="evaluation", ylabel="factor", title="parameters (dots: finite-difference points)"
    )
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)


def _write_result(ax, result: CalibrationResult) -> None:
    """The fitted parameters with their standard errors, the cost and the effort, as text."""
    ax.axis("off")
    lines = [
        f"{name}: {x0:.3f} -> {x:.3f} +- {se:.3f}"
        for name, x0, x, se in zip(result.names, result.x0, result.x, result.standard_error)
    ]
    lines += [
        f"cost {result.initial_cost:.4g} -> {result.cost:.4g}",
        f"{result.evaluations} points, {result.simulations} simulations",
        f"{result.wall_time_s:.0f} s wall",
    ]
    ax.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=9)


def _available(config: CalibrationConfig, e) -> list:
    """The columns experiment ``e``'s measurement holds: a CSV's header's, a bag's topics'."""
    allowed = measured_columns(config, e)
    path = config.folder / e.measured
    if path.is_file() and path.suffix != ".mcap":
        with open(path) as f:
            header = next((line for line in f if not line.startswith("#")), "")
        return [c for c in allowed if c in (h.strip() for h in header.split(","))]
    return list(allowed)
