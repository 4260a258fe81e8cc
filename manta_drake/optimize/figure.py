"""``convergence.png``: the cost per generation (best so far, the generation's best and
median) and every free parameter's trajectory (each candidate a dot, the best so far a
line), from the search rows of ``history.csv``."""

from __future__ import annotations

import pathlib

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator


def candidate_table(problem, rows: list[dict]) -> list[dict]:
    """One entry per told candidate: generation, candidate, cost, parameters [deg], failed
    (a simulation of it did not score: its cost includes ``failed_cost`` or, for a window a
    wall cut short, ``objective.short_window_cost``)."""
    seen: dict[tuple, dict] = {}
    for r in rows:
        if r.get("kind") != "search" or r.get("candidate_cost") is None:
            continue
        key = (r["generation"], r["candidate"])
        entry = seen.setdefault(
            key,
            {
                "generation": r["generation"],
                "candidate": r["candidate"],
                "cost": r["candidate_cost"],
                "failed": False,
                "degrees": [r[n] for n in problem.space.names],
            },
        )
        entry["failed"] |= r["status"] != "ok"
    return sorted(seen.values(), key=lambda e: (e["generation"], e["candidate"]))


def write_convergence_figure(path: pathlib.Path, problem, rows: list[dict]) -> pathlib.Path:
    """Writes convergence.png (module docstring); the parameters are drawn as the fraction
    of their bounds (0: low, 1: high) so that all share one axis."""
    table = candidate_table(problem, rows)
    space = problem.space
    fig = Figure(figsize=(10, 7.5))
    ax_cost, ax_x = fig.subplots(2, 1, sharex=True)
    if table:
        series = _generation_series(table, space)
        _draw_costs(ax_cost, series)
        _draw_parameters(ax_x, table, space, series["generation"], series["best_x"])
    ax_cost.set(
        ylabel="candidate cost",
        title=f"{problem.spec.name}: cost per generation "
        f"({problem.spec.robustness.aggregate} over each candidate's simulations)",
    )
    ax_x.set(
        xlabel="generation",
        ylabel="parameter, fraction of its bounds",
        ylim=(-0.05, 1.05),
        title="free parameters (dots: candidates; lines: the best so far)",
    )
    ax_x.xaxis.set_major_locator(MaxNLocator(integer=True))
    for ax in (ax_cost, ax_x):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return path


def _generation_series(table: list[dict], space) -> dict:
    """Per generation of ``candidate_table``'s ``table`` (in order): ``generation``,
    ``best_so_far`` (the lowest cost up to it, failed candidates included), ``best``
    and ``median`` of its candidates that did not fail (nan if all failed), ``failed``
    (how many failed) and ``best_x`` (the best so far's parameters as fractions of
    their bounds, one row per generation)."""
    gens = sorted({e["generation"] for e in table})
    best_so_far, gen_best, gen_median, failed = [], [], [], []
    running = np.inf
    best_x = []
    best_entry: dict | None = None
    for g in gens:
        mine = [e for e in table if e["generation"] == g]
        good = [e["cost"] for e in mine if not e["failed"]]
        failed.append(len(mine) - len(good))
        gen_best.append(min(good) if good else np.nan)
        gen_median.append(float(np.median(good)) if good else np.nan)
        top = min(mine, key=lambda e: e["cost"])
        if best_entry is None or top["cost"] < running:  # a nan cost still names a best
            running, best_entry = top["cost"], top
        best_so_far.append(running)
        best_x.append(space.to_unit(best_entry["degrees"]))
    return {
        "generation": gens,
        "best_so_far": best_so_far,
        "best": gen_best,
        "median": gen_median,
        "failed": failed,
        "best_x": np.array(best_x),
    }


def _draw_costs(ax, series: dict) -> None:
    """The cost panel: the best so far, each generation's best and median, the failures."""
    gens, best_so_far = series["generation"], series["best_so_far"]
    ax.plot(gens, best_so_far, "o-", color="tab:blue", label="best so far")
    ax.plot(gens, series["best"], ".", color="tab:green", label="generation's best")
    ax.plot(gens, series["median"], "s--", ms=3, color="tab:orange", label="generation's median")
    for g, n in zip(gens, series["failed"]):
        if n:
            ax.annotate(
                f"{n} failed",
                (g, 1.0),
                xycoords=("data", "axes fraction"),
                ha="center",
                va="top",
                fontsize=7,
                color="tab:red",
            )
    ax.legend(fontsize=8)
    # Penalties make costs span decades (a constraint met ends a 1e4 plateau): symlog
    # shows both the plateau and the last steps, linear within +-1.
    finite = np.abs(np.array([c for c in series["median"] + best_so_far if np.isfinite(c)]))
    if len(finite) and finite.max() > 100 * max(1.0, finite.min()):
        ax.set_yscale("symlog", linthresh=1.0)


def _draw_parameters(ax, table: list[dict], space, gens: list, best_x: np.ndarray) -> None:
    """The parameter panel: every candidate a dot, the best so far a line, per parameter."""
    colors = [f"C{i % 10}" for i in range(len(space.names))]
    for i, name in enumerate(space.names):
        xs = [e["generation"] for e in table]
        ys = [space.to_unit(e["degrees"])[i] for e in table]
        ax.plot(xs, ys, ".", ms=3, alpha=0.35, color=colors[i])
        ax.plot(
            gens,
            best_x[:, i],
            "o-",
            ms=3,
            lw=1.5,
            color=colors[i],
            label=f"{name} [{space.low[i]:g}, {space.high[i]:g}] deg",
        )
    ax.legend(fontsize=7, loc="best")
