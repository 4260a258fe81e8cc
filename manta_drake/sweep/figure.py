"""A sweep's ``summary.png``: the spread of the mean velocities and yaw rate per base
scenario, and each against each varied parameter, titled with what was swept."""

from __future__ import annotations

import math
import pathlib

METRICS = (("u", "u [m/s]"), ("v", "v [m/s]"), ("yaw_rate_deg_s", "yaw rate [deg/s]"))
# Shortened on the axes (the title keeps the full names).
_PREFIXES = ("water.coefficient_scales.",)


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _short(param: str) -> str:
    for prefix in _PREFIXES:
        if param.startswith(prefix):
            return param[len(prefix) :]
    return param


def _listing(values, limit: int = 4) -> str:
    values = [str(v) for v in values]
    if len(values) > limit:
        return ", ".join(values[: limit - 1]) + f", ... ({len(values)} in all)"
    return ", ".join(values)


def categories(rows: list[dict], param: str) -> list[str] | None:
    """The distinct values of ``param`` in ``rows`` as text, in first-appearance order, when
    any is not a finite number (a categorical axis: gait names, readings); None when all
    are numbers."""
    values = [row.get(param) for row in rows]
    if all(math.isfinite(_number(v)) for v in values):
        return None
    return list(dict.fromkeys(str(v) for v in values))


def swept_text(rows: list[dict], parameters: list[str]) -> str:
    """What the sweep varied, for the title: each parameter with its values (or its range),
    the base scenarios and the seeds."""
    parts = []
    for param in parameters:
        cats = categories(rows, param)
        if cats is not None:
            parts.append(f"{param} in {{{_listing(cats)}}}")
        else:
            values = sorted({_number(r.get(param)) for r in rows})
            if len(values) <= 4:
                parts.append(f"{param} in {{{', '.join(f'{v:g}' for v in values)}}}")
            else:
                parts.append(f"{param} {values[0]:g}-{values[-1]:g} ({len(values)} values)")
    bases = list(dict.fromkeys(str(r["base"]) for r in rows))
    seeds = sorted({str(r.get("seed")) for r in rows})
    parts.append(f"base {_listing(bases)}")
    parts.append(f"seed{'s' if len(seeds) > 1 else ''} {_listing(seeds)}")
    return "; ".join(parts)


def summary_figure(rows: list[dict], parameters: list[str], title: str):
    """The summary figure (a matplotlib Figure; the caller closes it).

    Column 0: per base scenario (x labels: the bases' names) the spread (box: quartiles,
    whiskers: min-max) of u, v and the yaw rate over its ok runs. One column per varied
    parameter (or the seed, when nothing is varied): each metric against the parameter, a
    colour per base; a parameter with values that are not numbers (gait names, readings) is
    a categorical axis with one labelled position per value. The title says what was swept
    and how many runs were ok (failed runs are left out of the axes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    bases = list(dict.fromkeys(r["base"] for r in rows))
    colours = {b: plt.cm.tab10(i % 10) for i, b in enumerate(bases)}
    xs = parameters or ["seed"]
    cats = {param: categories(rows, param) for param in xs}
    fig, axes = plt.subplots(
        len(METRICS),
        1 + len(xs),
        squeeze=False,
        figsize=(3.2 * (1 + len(xs)), 2.4 * len(METRICS) + 0.9),
    )
    for i, (key, label) in enumerate(METRICS):
        ax = axes[i, 0]
        data = [[_number(r.get(key)) for r in ok if r["base"] == b] for b in bases]
        data = [[v for v in d if math.isfinite(v)] or [math.nan] for d in data]
        ax.boxplot(data, whis=(0, 100))  # whiskers at min and max: the whole band
        ax.set_xticks(
            range(1, len(bases) + 1),
            [pathlib.PurePath(str(b)).stem for b in bases],
            rotation=30,
            fontsize=8,
        )
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if i == 0:
            ax.set_title("per base scenario", fontsize=9)
        for j, param in enumerate(xs, start=1):
            _plot_against(axes[i, j], ok, bases, colours, key, param, cats[param])
            if i == 0:
                axes[i, j].set_title(f"against {_short(param)}", fontsize=9)
            if i == len(METRICS) - 1:
                axes[i, j].set_xlabel(_short(param), fontsize=8)
    handles = [plt.Line2D([], [], marker="o", ls="", color=colours[b], label=b) for b in bases]
    fig.legend(handles=handles, loc="upper right", fontsize=7, ncol=min(5, len(bases)))
    n_bad = len(rows) - len(ok)
    fig.suptitle(
        f"{title}: {len(ok)} runs ok, {n_bad} not ok\nswept: {swept_text(rows, parameters)}",
        x=0.02,
        ha="left",
        fontsize=9,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    return fig


def _plot_against(ax, ok, bases, colours, key, param, cats) -> None:
    """One metric against one parameter, a colour per base; ``cats``: the categorical
    axis's values (None: a numeric axis)."""
    for b in bases:
        pts = [(r.get(param), _number(r.get(key))) for r in ok if r["base"] == b]
        if not pts:
            continue
        xv = (
            [cats.index(str(x)) for x, _ in pts]
            if cats is not None
            else [_number(x) for x, _ in pts]
        )
        ax.plot(xv, [y for _, y in pts], "o", ms=3, alpha=0.7, color=colours[b])
    if cats is not None:
        ax.set_xticks(range(len(cats)), cats, rotation=30, fontsize=8)
        ax.set_xlim(-0.5, len(cats) - 0.5)
    ax.grid(alpha=0.3)


def write_summary_figure(
    path: pathlib.Path, rows: list[dict], parameters: list[str], title: str
) -> pathlib.Path:
    """Writes ``summary_figure(rows, parameters, title)`` to ``path`` (summary.png)."""
    fig = summary_figure(rows, parameters, title)
    import matplotlib.pyplot as plt  # after summary_figure chose the file backend

    try:
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)
    return path
