"""``manta-drake optimize SPEC.yaml --out DIR`` (``manta_drake.cli`` dispatches here).

Exit status: 0 when ``best_gait.yaml`` is written and the best gait meets every constraint at
every search point, in its re-run and at every held-out point; 3 when the gait is written but
breaks a constraint somewhere (``infeasible``: a line on stderr, ``status`` in summary.json,
``feasible: false`` and the violations in the gait file's provenance); 1 when the search ran
but no candidate's simulations all ran (every candidate refused or failed: no gait file;
``history.csv`` says why); 2 when the input is refused (one line naming the file or option
and the field; nothing simulated)."""

from __future__ import annotations

import sys

from manta_drake.cluster import cluster_client
from manta_drake.optimize.loading import load_problem
from manta_drake.optimize.run import FOLDERS, OUTPUTS, run_optimization
from manta_drake.sweep.options import add_many_run_options, check_many_run_options

# Exit status of a search that gives no gait, and of one whose gait breaks a constraint.
NO_GAIT = 1
INFEASIBLE = 3


def add_optimize_parser(subparsers) -> None:
    """Adds ``manta-drake optimize``."""
    p = subparsers.add_parser(
        "optimize",
        help="design a gait by CMA-ES on a Dask cluster (docs/optimize.md)",
        description="Searches the spec's free gait entries with CMA-ES, every generation's "
        "simulations in parallel on Dask; writes DIR/best_gait.yaml, "
        "DIR/history.csv, DIR/convergence.png, DIR/summary.json and the best "
        "gait's re-run in DIR/best_run/. The same command again continues from "
        "DIR/state.json. Exit status 1 when no candidate ran, 2 when the input "
        "is refused, 3 when the best gait breaks a constraint (it is written, "
        "marked infeasible). A spec with a front section runs one search per "
        "level into DIR/level_NN/ and writes DIR/front.png, front.csv and "
        "front.json.",
    )
    p.add_argument("spec", help="optimisation spec YAML file (docs/optimize.md)")
    add_many_run_options(
        p,
        out_help="output folder (the same command again continues there)",
        set_help="layered on the spec's scenario and its overrides",
        seed_help="CMA-ES's seed (replaces the spec's seed)",
    )
    p.add_argument(
        "--generations",
        type=int,
        metavar="G",
        help="generations in all (replaces budget.generations; may be raised on a restart)",
    )
    p.add_argument(
        "--population",
        type=int,
        metavar="P",
        help="candidates per generation (replaces budget.population)",
    )
    p.add_argument(
        "--duration",
        type=float,
        metavar="S",
        help="simulated seconds per evaluation (replaces budget.duration)",
    )
    p.add_argument(
        "--steady-after",
        type=float,
        metavar="S",
        help="where the metrics' steady window starts [s] (replaces "
        "budget.steady_after; at most half of the duration)",
    )


def optimize_main(args) -> int:
    """``manta-drake optimize``: check the options, load (errors are one line), search,
    print the result; the exit status as the module says."""
    # Before the load and the search: a search never ends by finding it cannot write.
    sets = check_many_run_options(args, OUTPUTS, [args.spec], folders=FOLDERS)
    problem = load_problem(
        args.spec,
        sets,
        generations=args.generations,
        population=args.population,
        duration=args.duration,
        seed=args.seed,
        steady_after=args.steady_after,
    )
    if problem.spec.front:
        with cluster_client(args) as client:
            return _front(problem, args, client)
    with cluster_client(args) as client:
        result = run_optimization(problem, args.out, client, progress=not args.quiet)
    print(
        f"\n  {result.name}: {result.status}, cost {result.start_cost:.4g} (start) -> "
        f"{result.best_cost:.4g} "
        f"(generation {result.best_generation}, candidate {result.best_candidate}); "
        f"stopped: {result.stop}"
    )
    for name, x0, x in zip(result.names, result.start_degrees, result.best_degrees):
        print(f"  {name:<28} {x0:9.3f} -> {x:9.3f} deg")
    n = result.generations
    print(
        f"  {n} generation{'s' if n != 1 else ''}, {result.evaluations} simulations in the "
        f"history ({result.simulated} run now, {result.reused} reused), "
        f"{result.wall_time_s:.1f} s"
    )
    if result.best_run is not None:
        r = result.best_run
        print(
            f"  best gait re-run: {r['status']}, u {_f(r.get('u'))} m/s, v {_f(r.get('v'))} "
            f"m/s, yaw rate {_f(r.get('yaw_rate'))} deg/s, cost {r['cost']:.4g}"
        )
    for r in result.held_out:
        print(f"  held out {r['overrides']} seed {r['seed']}: {r['status']}, cost {r['cost']:.4g}")
    print(f"  gait:    {result.best_gait_file or 'none written'}")
    print(f"  history: {result.history_file}")
    print(f"  figure:  {result.figure}")
    print(f"  summary: {result.summary_file}")
    if result.best_gait_file is None:
        print(
            f"manta-drake: optimize {result.name}: no candidate's simulations all ran; "
            f"see {result.history_file}",
            file=sys.stderr,
        )
        return NO_GAIT
    if not result.feasible:
        print(
            f"manta-drake: optimize {result.name}: INFEASIBLE: the best gait breaks its "
            f"constraints in {len(result.violations)} simulation(s), first "
            f"{result.violations[0]}; see {result.summary_file}",
            file=sys.stderr,
        )
        return INFEASIBLE
    return 0


def _front(problem, args, client) -> int:
    """A spec with a front: one search per level, then the front (``optimize.front``)."""
    from manta_drake.optimize.front import run_front

    summary = run_front(problem, args.out, client, progress=not args.quiet, run=run_optimization)
    f = problem.spec.front
    print(
        f"\n  {summary['name']}: front of {f.minimise} against {f.maximise}, "
        f"{summary['candidates']} candidates, {summary['meeting_constraints']} within the "
        "constraints"
    )
    for level in summary["levels"]:
        print(
            f"  level {f.maximise} >= {level['level']:g}: {level['status']}, best cost "
            f"{level['best_cost']:.4g} ({level['folder']})"
        )
    for p in summary["front"]:
        print(
            f"  on the front: {f.maximise} {p[f.maximise]:.4g}, {f.minimise} "
            f"{p[f.minimise]:.4g} (level {p['level']}, generation {p['generation']}, "
            f"candidate {p['candidate']})"
        )
    print(f"  front: {args.out}/front.png, front.csv, front.json")
    if not summary["front"]:
        print(
            f"manta-drake: optimize {summary['name']}: no candidate met the constraints; no front",
            file=sys.stderr,
        )
        return NO_GAIT
    return 0


def _f(value) -> str:
    return "-" if value is None else f"{value:.4g}"
