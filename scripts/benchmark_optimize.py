#!/usr/bin/env python3
"""Parallel efficiency and fixed cost of one ``manta-drake optimize`` generation
(docs/optimize.md).

One generation of ``--candidates`` candidates of a shipped spec (one robustness point, no
held-out points), run through ``run_optimization`` three ways:

  serial     in this process, one simulation after another (``client=None``);
  parallel   on a LocalCluster of ``--workers`` single-threaded worker processes (the
             cluster helper's ``dask_client``), started and warmed before the clock starts;
  overhead   the same generation on the same cluster with an evaluator that returns at
             once: what a generation costs without simulations (ask/tell, writing the
             table, the evaluation folders and the state, one task round trip each).

Each generation's wall time is the search's own (from asking CMA-ES to the saved state:
``OptimizationResult.timings``), not the final re-run of the best gait nor the figures. It
prints

  efficiency = T_serial / (workers x T_parallel)
  fixed cost per generation = T_parallel - the longest simulation, T_parallel - the
                              simulations' sum / workers (what scheduling, transfers and
                              the records add to perfectly shared work), and T_serial - the
                              sum of the simulations (serial)

where a simulation's time is measured on its worker (building, simulating, the metrics;
not the transfer of its log). The ratio of a simulation's time in parallel to its time in
series shows whether the machine gave every worker a whole core.

    python scripts/benchmark_optimize.py                      # fast_walk, 8 x 10 s, 2 workers
    python scripts/benchmark_optimize.py --duration 2         # a quick check
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]


def _instant(task):
    """An evaluator that costs nothing: every candidate the same."""
    return {
        "status": "ok",
        "metrics": {
            m: 0.0
            for m in (
                "u",
                "v",
                "abs_u",
                "abs_v",
                "speed",
                "yaw_rate",
                "abs_yaw_rate",
                "cot_electrical",
                "cot_net_of_hotel",
                "cot_mechanical",
                "mean_power_w",
                "joint_limit_margin_deg",
                "max_penetration_m",
            )
        },
        "wall_time_s": 0.0,
    }


def _problem(spec: pathlib.Path, candidates: int, duration: float):
    from manta_drake.optimize import load_problem

    problem = load_problem(spec, generations=1, population=candidates, duration=duration)
    problem.spec.robustness.points = [problem.spec.points()[0]]
    problem.spec.robustness.seeds = problem.spec.robustness.seeds[:1]
    problem.spec.held_out.points = []
    return problem


def _generation(problem, client, evaluate=None) -> dict:
    from manta_drake.optimize import run_optimization

    with tempfile.TemporaryDirectory(prefix="bench_opt_") as tmp:
        result = run_optimization(
            problem, pathlib.Path(tmp) / "out", client=client, evaluate=evaluate, progress=False
        )
    (timing,) = result.timings
    return timing


def _warm(client, problem) -> None:
    """Every worker imports the package and simulates once (kernels compiled or loaded,
    the first diagram built) before anything is timed."""
    from manta_drake.optimize import simulate_candidate
    from manta_drake.optimize.parameters import candidate_gait_text
    from manta_drake.scenario import load_scenario, scenario_yaml

    space = problem.space
    task = {
        "key": "warm",
        "scenario_yaml": problem.base_yaml,
        "gait_name": problem.spec.name,
        "gait_text": candidate_gait_text(problem.spec.name, space.gait(space.start_vector())),
        "overrides": {},
        "seed": 0,
        "set_stance": problem.set_stance,
        "keep_log": False,
        "parameters": {},
    }
    short = dict(
        task,
        scenario_yaml=scenario_yaml(
            load_scenario(data=problem.base_yaml, overrides={"duration": 0.2})
        ),
    )
    if client is None:
        simulate_candidate(short)
        return
    workers = list(client.scheduler_info()["workers"])
    futures = [
        client.submit(
            simulate_candidate,
            short,
            pure=False,
            workers=[w],
            allow_other_workers=False,
            key=f"warm-{i}",
        )
        for i, w in enumerate(workers)
    ]
    for f in futures:
        f.result()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default=str(REPO / "diagrams" / "optimize" / "fast_walk.yaml"))
    parser.add_argument("--candidates", type=int, default=8)
    parser.add_argument(
        "--duration", type=float, default=10.0, help="simulated seconds per candidate (default 10)"
    )
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--rounds", type=int, default=1, help="serial/parallel pairs, alternated (default 1)"
    )
    args = parser.parse_args()

    from manta_drake.cluster import dask_client

    problem = _problem(pathlib.Path(args.spec), args.candidates, args.duration)
    print(
        f"{problem.spec.name}: one generation of {args.candidates} candidates x "
        f"{args.duration:g} s, {args.workers} workers, {args.rounds} round(s)"
    )
    _warm(None, problem)
    started = time.perf_counter()
    with dask_client(workers=args.workers) as client:
        print(f"cluster started in {time.perf_counter() - started:.1f} s")
        _warm(client, problem)
        overhead = _generation(problem, client, _instant)
        pairs = []
        for _ in range(args.rounds):
            serial = _generation(problem, None)
            parallel = _generation(problem, client)
            pairs.append((serial, parallel))
    for k, (serial, parallel) in enumerate(pairs, 1):
        t_s, t_p = serial["wall_s"], parallel["wall_s"]
        print(f"round {k}:")
        print(
            f"  serial    {t_s:7.2f} s  (simulations {serial['sum_simulation_s']:.2f} s summed; "
            f"fixed {t_s - serial['sum_simulation_s']:.2f} s)"
        )
        print(
            f"  parallel  {t_p:7.2f} s  (longest simulation "
            f"{parallel['longest_simulation_s']:.2f} s, summed "
            f"{parallel['sum_simulation_s']:.2f} s; T_parallel - longest "
            f"{t_p - parallel['longest_simulation_s']:.2f} s, T_parallel - summed / "
            f"{args.workers} {t_p - parallel['sum_simulation_s'] / args.workers:.2f} s)"
        )
        print(
            f"  slowdown of a simulation while {args.workers} run side by side: "
            f"{parallel['sum_simulation_s'] / serial['sum_simulation_s']:.2f}"
        )
        print(
            f"  efficiency {t_s / (args.workers * t_p):.3f}  "
            f"(T_serial / ({args.workers} x T_parallel))"
        )
    print(
        f"no-simulation generation on the cluster: {overhead['wall_s']:.3f} s for "
        f"{overhead['simulated']} tasks"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
