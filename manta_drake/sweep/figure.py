"""A sweep's ``summary.png``: the spread of the mean velocities and yaw rate per base
scenario, and each against each varied parameter."""

from __future__ import annotations

import math
import pathlib


def write_summary_figure(path: pathlib.Path, rows: list[dict], parameters: list[str],
                         title: str) -> pathlib.Path:
    """summary.png: per base scenario the spread (uncertainty band) of u, v and yaw rate,
    and each metric against each varied parameter (failed runs left out, counted in the
    title)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    metrics = [("u", "u [m/s]"), ("v", "v [m/s]"), ("yaw_rate_deg_s", "yaw rate [deg/s]")]
    ok = [r for r in rows if r.get("status") == "ok"]
    bases = list(dict.fromkeys(r["base"] for r in rows))
    colours = {b: plt.cm.tab10(i % 10) for i, b in enumerate(bases)}
    xs = parameters or ["seed"]
    fig, axes = plt.subplots(len(metrics), 1 + len(xs), squeeze=False,
                             figsize=(3.2 * (1 + len(xs)), 2.4 * len(metrics) + 0.6))

    def value(row, key):
        try:
            return float(row.get(key))
        except (TypeError, ValueError):
            return math.nan

    for i, (key, label) in enumerate(metrics):
        ax = axes[i, 0]
        data = [[value(r, key) for r in ok if r["base"] == b] for b in bases]
        data = [[v for v in d if math.isfinite(v)] or [math.nan] for d in data]
        ax.boxplot(data, whis=(0, 100))  # whiskers at min and max: the whole band
        ax.set_xticks(range(1, len(bases) + 1), [pathlib.PurePath(b).stem.replace(
            "locomotion_", "") for b in bases], rotation=30, fontsize=8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        for j, param in enumerate(xs, start=1):
            ax = axes[i, j]
            for b in bases:
                pts = [(r.get(param), value(r, key)) for r in ok if r["base"] == b]
                xv = [value({"x": x}, "x") for x, _ in pts]
                if pts and all(math.isfinite(x) for x in xv):
                    ax.plot(xv, [y for _, y in pts], "o", ms=3, alpha=0.7, color=colours[b])
                elif pts:  # not numbers: one position per distinct value
                    cats = sorted({str(x) for x, _ in pts})
                    ax.plot([cats.index(str(x)) for x, _ in pts], [y for _, y in pts], "o",
                            ms=3, alpha=0.7, color=colours[b])
            if i == len(metrics) - 1:
                ax.set_xlabel(param.replace("water.coefficient_scales.", ""), fontsize=8)
            ax.grid(alpha=0.3)
    handles = [plt.Line2D([], [], marker="o", ls="", color=colours[b], label=b) for b in bases]
    fig.legend(handles=handles, loc="upper right", fontsize=7, ncol=min(5, len(bases)))
    n_bad = len(rows) - len(ok)
    fig.suptitle(f"{title}: {len(ok)} runs ok, {n_bad} not ok", x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
