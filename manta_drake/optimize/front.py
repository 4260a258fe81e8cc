"""A front of two metrics (speed against cost of transport) by the epsilon-constraint method.

A spec with a ``front`` section (``Front``: ``maximise``, ``minimise``, ``levels``) is one
search per level: minimise ``minimise`` subject to ``maximise >= level`` and the spec's own
constraints (Haimes, Lasdon and Wismer 1971; Miettinen, *Nonlinear Multiobjective
Optimization*, 1999, section 3.2). Unlike a weighted sum, which finds only the convex hull
of the front, each level finds the front's point at that speed wherever the front bends.
Every level is an ordinary ``run_optimization`` in ``<out>/level_NN/`` (restartable as any),
and every candidate of every level is a point: the front is the non-dominated set of the
candidates that meet the spec's constraints (its joint limits, its straightness...) at every
robustness point, whatever level they were searched at.

Outputs in ``<out>``: ``front.csv`` (every candidate: its level, generation and number, the
parameters, the two metrics' means over its points, whether it meets the constraints and
whether it is on the front), ``front.json`` (the front's points with their parameters, the
start gait's point as the search scored it and its own run's metrics, each level's
result), ``front.png`` and ``front_gaits.yaml`` (the
front's points as a gait file, slowest first, named ``<name>_0``, ``<name>_1``...: usable with
``controller.gait_files``, and as another spec's start gait through its ``overrides``).
"""

from __future__ import annotations

import copy
import csv
import dataclasses as dc
import json
import os
import pathlib
import sys

import numpy as np

from manta_drake.optimize.loading import Problem, validate
from manta_drake.optimize.objective import constraint_violation
from manta_drake.optimize.spec import Constraint, Term
from manta_drake.run_folder import write_atomic

FRONT_OUTPUTS = ("front.csv", "front.json", "front.png", "front_gaits.yaml")


def pareto_mask(maximise, minimise) -> np.ndarray:
    """Which points are non-dominated: no other point has ``maximise`` at least as large and
    ``minimise`` at least as small with one of them strictly better. Points with a
    non-finite value are never on the front. O(n log n): sorted by ``maximise`` falling
    (``minimise`` rising on ties), a point is on the front when its ``minimise`` is below
    every earlier point's."""
    up = np.asarray(maximise, dtype=float)
    down = np.asarray(minimise, dtype=float)
    on = np.zeros(up.size, dtype=bool)
    finite = np.flatnonzero(np.isfinite(up) & np.isfinite(down))
    order = finite[np.lexsort((down[finite], -up[finite]))]
    best = np.inf
    previous = None
    for i in order:
        if down[i] < best:
            on[i] = True
            best = down[i]
        elif previous is not None and (up[i], down[i]) == previous:
            on[i] = True  # a duplicate of a front point is no worse than it
        if on[i]:
            previous = (up[i], down[i])
    return on


def level_problem(problem: Problem, level: float, k: int = 0) -> Problem:
    """The search at level ``k``, ``level``: the spec's constraints, ``maximise >= level``,
    and the one term ``minimise`` (weight 1). Its CMA-ES seed is the spec's plus ``k``, so
    the levels do not all ask the same first generation (the start gait aside)."""
    spec = copy.deepcopy(problem.spec)
    spec.seed = problem.spec.seed + k
    f = spec.front
    spec.objective.terms = [Term(f.minimise, 1.0)]
    spec.objective.constraints = [*spec.objective.constraints, Constraint(f.maximise, min=level)]
    spec.front = dc.replace(f, levels=[])
    return validate(spec, problem.sets)


def level_folder(out_dir: pathlib.Path, k: int) -> pathlib.Path:
    return pathlib.Path(out_dir) / f"level_{k:02d}"


def candidate_points(problem: Problem, rows: list[dict], level: int) -> list[dict]:
    """Each searched candidate of one level as a point: the means of the two metrics over
    its simulations, and whether it meets the spec's own constraints (not the level's) at
    every one without touching a wall."""
    f, names = problem.spec.front, problem.space.names
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["kind"] == "search":
            groups.setdefault((r["generation"], r["candidate"]), []).append(r)
    points = []
    for (generation, candidate), mine in sorted(groups.items()):
        ran = all(r["status"] == "ok" for r in mine)
        values = {
            m: float(np.mean([r[m] for r in mine]))
            if ran and all(r.get(m) is not None for r in mine)
            else float("nan")
            for m in (f.maximise, f.minimise)
        }
        meets = (
            ran
            and not any(r["touched_wall"] for r in mine)
            and all(
                constraint_violation(c, r)[0] == 0
                for c in problem.spec.objective.constraints
                for r in mine
            )
        )
        points.append(
            {
                "level": level,
                "generation": generation,
                "candidate": candidate,
                **{n: mine[0][n] for n in names},
                **values,
                "meets_constraints": bool(meets and np.all(np.isfinite(list(values.values())))),
            }
        )
    return points


def front_of(problem: Problem, points: list[dict]) -> list[dict]:
    """``points`` with ``on_front`` set: the non-dominated ones among those that meet the
    constraints."""
    f = problem.spec.front
    ok = [p for p in points if p["meets_constraints"]]
    mask = pareto_mask([p[f.maximise] for p in ok], [p[f.minimise] for p in ok])
    on = {id(p) for p, m in zip(ok, mask) if m}
    return [{**p, "on_front": id(p) in on} for p in points]


def write_front(
    problem: Problem, out_dir: pathlib.Path, points: list[dict], levels: list[dict]
) -> dict:
    """front.csv, front.json and front.png; returns front.json's content."""
    f, names = problem.spec.front, problem.space.names
    out_dir = pathlib.Path(out_dir)
    columns = [
        "level",
        "generation",
        "candidate",
        *names,
        f.maximise,
        f.minimise,
        "meets_constraints",
        "on_front",
    ]
    tmp = out_dir / ".front.csv.tmp"
    with open(tmp, "w", newline="") as fh:
        writer = csv.DictWriter(fh, columns)
        writer.writeheader()
        writer.writerows(points)
    os.replace(tmp, out_dir / "front.csv")
    front = sorted((p for p in points if p["on_front"]), key=lambda p: p[f.maximise])
    start = next((p for p in points if (p["generation"], p["candidate"]) == (1, 0)), None)
    summary = {
        "name": problem.spec.name,
        "start_gait": problem.spec.gait,
        "maximise": f.maximise,
        "minimise": f.minimise,
        "levels": levels,
        "start": start,
        "start_run": start_run(problem, out_dir),
        "front": front,
        "candidates": len(points),
        "meeting_constraints": sum(p["meets_constraints"] for p in points),
    }
    write_atomic(out_dir / "front.json", json.dumps(summary, indent=2, default=str) + "\n")
    _figure(problem, out_dir / "front.png", summary, points)
    write_front_gaits(problem, out_dir / "front_gaits.yaml", front)
    return summary


def write_front_gaits(problem: Problem, path: pathlib.Path, front: list[dict]) -> pathlib.Path:
    """front_gaits.yaml: the front's points (``front``, slowest first) as gaits named
    ``<name>_<i>``, each described by its two metrics, with the spec in the provenance."""
    from manta_drake.control.gait_files import gait_file_data, gait_file_text
    from manta_drake.optimize.run import source_version, spec_path_text

    spec, space, f = problem.spec, problem.space, problem.spec.front
    names = [f"{spec.name}_{i}" for i in range(len(front))]
    gaits = {n: space.gait([p[k] for k in space.names]) for n, p in zip(names, front)}
    descriptions = {
        n: f"{f.maximise} {p[f.maximise]:.4g}, {f.minimise} {p[f.minimise]:.4g} (level "
        f"{p['level']}, generation {p['generation']}, candidate {p['candidate']})"
        for n, p in zip(names, front)
    }
    provenance = {
        "made_by": "manta-drake optimize (front)",
        "spec": spec_path_text(spec.path) if spec.path else "",
        "spec_sha256": spec.text_sha256,
        "source": source_version(),
        "scenario": spec.scenario,
        "start_gait": spec.gait,
    }
    data = gait_file_data(
        gaits,
        f"The {spec.name} front's points, slowest first",
        provenance,
        mirror_keep={n: ["R_deg", "X_deg"] for n in names},
        descriptions=descriptions,
    )
    header = (
        f"The front of {spec.name} found by `manta-drake optimize`: each gait is a point of "
        f"it; use them with controller.gait_files: [this file]."
    )
    write_atomic(path, gait_file_text(data, header))
    return path


def start_run(problem: Problem, out_dir: pathlib.Path) -> dict | None:
    """The start gait's own run at the scenario as it is (level 0, generation 1, candidate 0,
    its first point and seed), from its metrics.json: the two metrics, the yaw rate, the
    status and the steady window. Read from the run itself, so it is there also when a wall
    cut the window under ``min_window`` and the search left it unscored (the paper's swim).
    None when the run's folder is gone (a level continued from its state alone: ``run_front``
    then simulates it again)."""
    from manta_drake.optimize.history import evaluation_folder
    from manta_drake.optimize.objective import run_metrics

    seed = problem.spec.robustness.seeds[0] if problem.spec.robustness.seeds else 0
    folder = evaluation_folder("search", 1, 0, 0, seed)
    path = level_folder(out_dir, 0) / folder / "metrics.json"
    if not path.is_file():
        return None
    run = json.loads(path.read_text())
    f, metrics = problem.spec.front, run_metrics(run)
    return {
        f.maximise: metrics[f.maximise],
        f.minimise: metrics[f.minimise],
        "yaw_rate": metrics["yaw_rate"],
        "status": run.get("status"),
        "reason": run.get("reason", ""),
        "steady_window_s": run.get("steady_window_s"),
    }


def draw_front(ax, maximise: str, minimise: str, points: list[dict], start, label: str) -> None:
    """Draws on ``ax`` every point (grey: breaks a constraint; blue: meets them), the front
    (red, the points ``on_front``) and ``start`` (a star labelled ``label``; None: none)."""
    finite = [p for p in points if np.isfinite(p[maximise]) and np.isfinite(p[minimise])]
    for meets, style in (
        (False, dict(s=8, color="0.8", label="breaks a constraint")),
        (True, dict(s=10, color="tab:blue", alpha=0.5, label="meets the constraints")),
    ):
        mine = [p for p in finite if p["meets_constraints"] == meets]
        ax.scatter([p[maximise] for p in mine], [p[minimise] for p in mine], **style)
    front = sorted((p for p in points if p["on_front"]), key=lambda p: p[maximise])
    ax.plot(
        [p[maximise] for p in front],
        [p[minimise] for p in front],
        "o-",
        color="tab:red",
        label="front",
    )
    if start is not None and np.isfinite(start[maximise]) and np.isfinite(start[minimise]):
        ax.scatter([start[maximise]], [start[minimise]], marker="*", s=180, color="k", zorder=5)
        ax.annotate(
            label,
            (start[maximise], start[minimise]),
            textcoords="offset points",
            xytext=(6, 6),
            fontsize=8,
        )


def start_label(summary: dict) -> tuple[dict | None, str]:
    """The start's point to draw from front.json's content, and its label: its own run
    (with its steady window) when the summary has it, else the search's score of it."""
    run, name = summary.get("start_run"), summary["start_gait"]
    if run is None or run.get(summary["maximise"]) is None:
        return summary.get("start"), f"{name} (the start)"
    window = run.get("steady_window_s")
    span = f", window {window[0]:g}-{window[1]:.1f} s" if window else ""
    point = {k: (np.nan if v is None else v) for k, v in run.items()}
    return point, f"{name} (the start{span})"


def _figure(problem: Problem, path: pathlib.Path, summary: dict, points: list[dict]) -> None:
    from matplotlib.figure import Figure

    f = problem.spec.front
    fig = Figure(figsize=(7, 5))
    ax = fig.subplots()
    draw_front(ax, f.maximise, f.minimise, points, *start_label(summary))
    for level in f.levels:
        ax.axvline(level, color="0.6", lw=0.6, ls=":")
    ax.set_xlabel(f.maximise)
    ax.set_ylabel(f.minimise)
    ax.set_title(f"{problem.spec.name}: {f.minimise} against {f.maximise}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def run_front(
    problem: Problem, out_dir, client=None, evaluate=None, progress: bool = True, run=None
) -> dict:
    """Runs (or continues) every level's search and writes the front (module docstring).

    ``run`` is ``run_optimization`` (its ``evaluate``, ``client`` and ``progress`` as
    there). Returns front.json's content."""
    from manta_drake.optimize.history import read_history
    from manta_drake.optimize.run import rerun_start, run_optimization

    run = run or run_optimization
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    points, levels = [], []
    f = problem.spec.front
    for k, level in enumerate(f.levels):
        folder = level_folder(out_dir, k)
        where = (
            f"{problem.spec.name}: {folder.name} ({f.maximise} >= {level:g}; "
            f"{k + 1} of {len(f.levels)})"
        )
        print(f"{where} in {folder}", file=sys.stderr, flush=True)
        result = run(
            level_problem(problem, level, k), folder, client, evaluate=evaluate, progress=progress
        )
        print(
            f"{where}: {result.status}, lowest {f.minimise} cost {result.best_cost:.4g}; "
            f"{result.stop}",
            file=sys.stderr,
            flush=True,
        )
        levels.append(
            {
                "level": level,
                "folder": folder.name,
                "status": result.status,
                "best_cost": result.best_cost,
                "stop": result.stop,
            }
        )
        rows = read_history(folder / "history.csv", problem.space.names)
        points += candidate_points(problem, rows, k)
    if start_run(problem, out_dir) is None:  # level 0 kept without its folders
        print(f"{problem.spec.name}: the start gait's own run again", file=sys.stderr)
        rerun_start(
            level_problem(problem, f.levels[0], 0), level_folder(out_dir, 0), client, evaluate
        )
    return write_front(problem, out_dir, front_of(problem, distinct(problem, points)), levels)


def distinct(problem: Problem, points: list[dict]) -> list[dict]:
    """One point per gait: the start gait begins every level's search, and a level may ask
    a candidate another has; the first kept."""
    seen, out = set(), []
    for p in points:
        key = tuple(p[n] for n in problem.space.names)
        if key not in seen:
            seen.add(key)
            out.append(p)
    return out
