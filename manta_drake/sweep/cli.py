"""``manta-drake sweep SWEEP.yaml --out DIR`` (``manta_drake.cli`` dispatches here)."""

from __future__ import annotations

import json
import pathlib
import time

from manta_drake.cluster import add_cluster_arguments, check_cluster_arguments, cluster_client
from manta_drake.scenario import parse_set
from manta_drake.sweep.config import SweepError
from manta_drake.sweep.loading import load_sweep
from manta_drake.sweep.plan import plan_runs
from manta_drake.sweep.runner import run_sweep


def add_sweep_parser(subparsers) -> None:
    """Adds ``manta-drake sweep``."""
    p = subparsers.add_parser(
        "sweep", help="many runs on a Dask cluster: grids, rows, Monte Carlo (docs/sweeps.md)",
        description="Runs every (base scenario, parameter set, seed) of a sweep file as a "
                    "Dask task; writes DIR/results.csv, DIR/summary.png and DIR/runs/<id>/. "
                    "Restarted with the same --out, it skips the runs already done.")
    p.add_argument("sweep", help="sweep YAML file (docs/sweeps.md)")
    p.add_argument("--out", required=True, help="output folder")
    add_cluster_arguments(p)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="add to the file's `fixed` overrides, e.g. --set duration=2 (changes "
                        "the run ids); repeatable")
    p.add_argument("--limit", type=int, metavar="N", help="only the first N runs")
    p.add_argument("--rerun-failed", action="store_true",
                   help="run again the runs whose status is not ok")
    p.add_argument("--dry-run", action="store_true",
                   help="check the file and list the runs; simulate nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def sweep_main(args) -> int:
    """``manta-drake sweep``: load (errors are one line), run, print a summary."""
    config = load_sweep(args.sweep, parse_set(args.set))
    if args.limit is not None and args.limit < 1:
        raise SweepError(f"--limit: {args.limit} must be >= 1")
    check_cluster_arguments(args)
    if args.dry_run:
        specs = plan_runs(config, args.limit)
        for spec in specs:
            state = f"invalid: {spec.invalid_reason}" if spec.invalid_reason else ""
            print(f"{spec.run_id:<40} {json.dumps(spec.parameters)} {state}")
        print(f"\n{len(specs)} runs; {sum(bool(s.invalid_reason) for s in specs)} invalid")
        return 0
    start = time.perf_counter()
    with cluster_client(args) as client:
        result = run_sweep(config, args.out, client, progress=not args.quiet,
                           limit=args.limit, rerun_failed=args.rerun_failed)
    counts = ", ".join(f"{n} {status}" for status, n in sorted(result.counts.items()))
    print(f"\n  {config.name}: {len(result.rows)} runs ({counts}); simulated now "
          f"{len(result.simulated)} in {time.perf_counter() - start:.1f} s")
    print(f"  table:  {result.table}")
    if result.figure:
        print(f"  figure: {result.figure}")
    print(f"  runs:   {pathlib.Path(args.out) / 'runs'}/<run_id>/")
    return 0
