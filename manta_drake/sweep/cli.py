"""``manta-drake sweep SWEEP.yaml --out DIR`` (``manta_drake.cli`` dispatches here).

Exit status: 0 when at least one run is ok and none was lost to the cluster; 1 when no run
is ok (every run invalid, failed or in error: the table tells no result) or a run was lost
(the sweep is incomplete: the same command again runs what is missing); 2 when the input is
refused (one line naming the file or option, the field and the allowed range; nothing
ran)."""

from __future__ import annotations

import json
import pathlib
import sys
import time

from manta_drake.cluster import cluster_client
from manta_drake.config_io import check_integer
from manta_drake.sweep.config import MAX_RUNS, SweepError
from manta_drake.sweep.loading import load_sweep
from manta_drake.sweep.options import add_many_run_options, check_many_run_options
from manta_drake.sweep.plan import plan_runs
from manta_drake.sweep.results import LOST
from manta_drake.sweep.runner import OUTPUTS, run_sweep

# Exit status of a sweep that ran but gives no result or an incomplete one.
NO_RESULT = 1


def add_sweep_parser(subparsers) -> None:
    """Adds ``manta-drake sweep``."""
    p = subparsers.add_parser(
        "sweep",
        help="many runs on a Dask cluster: grids, rows, Monte Carlo (docs/sweeps.md)",
        description="Runs every (base scenario, parameter set, seed) of a sweep file as a "
        "Dask task; writes DIR/results.csv, DIR/summary.png and DIR/runs/<id>/. "
        "Restarted with the same --out, it skips the runs already done. Exit "
        "status 1 when no run is ok or a run was lost to the cluster, 2 when "
        "the input is refused.",
    )
    p.add_argument("sweep", help="sweep YAML file (docs/sweeps.md)")
    add_many_run_options(
        p,
        out_help="output folder (the same command again skips the runs done there)",
        set_help="added to the file's `fixed` overrides (changes the run ids)",
    )
    p.add_argument(
        "--limit",
        type=int,
        metavar="N",
        help=f"only the first N runs (1 to {MAX_RUNS}); only their parameter sets are drawn",
    )
    p.add_argument(
        "--rerun-failed", action="store_true", help="run again the runs whose status is not ok"
    )
    p.add_argument(
        "--dry-run", action="store_true", help="check the file and list the runs; simulate nothing"
    )


def sweep_main(args) -> int:
    """``manta-drake sweep``: check the options, load (errors are one line), run, print a
    summary; the exit status as the module says."""
    if args.limit is not None:
        check_integer("--limit", args.limit, 1, MAX_RUNS, error=SweepError)
    # Before the load and any run: a sweep never ends by finding it cannot write.
    sets = check_many_run_options(args, OUTPUTS, [args.sweep], folders=("runs",))
    try:
        return _sweep(args, sets)
    except MemoryError:  # its message is empty: say what ran out
        raise SweepError(
            f"{args.sweep}: out of memory while planning or running the sweep; "
            "use --limit or a smaller sweep"
        ) from None


def _sweep(args, sets: dict) -> int:
    config = load_sweep(args.sweep, sets)
    if args.dry_run:
        specs = plan_runs(config, args.limit)
        for spec in specs:
            state = f"invalid: {spec.invalid_reason}" if spec.invalid_reason else ""
            print(f"{spec.run_id:<40} {json.dumps(spec.parameters)} {state}")
        invalid = sum(bool(s.invalid_reason) for s in specs)
        print(f"\n{len(specs)} runs; {invalid} invalid")
        if invalid == len(specs):
            print(f"manta-drake: sweep {config.name}: no run is valid", file=sys.stderr)
            return NO_RESULT
        return 0
    start = time.perf_counter()
    with cluster_client(args) as client:
        result = run_sweep(
            config,
            args.out,
            client,
            progress=not args.quiet,
            limit=args.limit,
            rerun_failed=args.rerun_failed,
        )
    counts = ", ".join(f"{n} {status}" for status, n in sorted(result.counts.items()))
    print(
        f"\n  {config.name}: {len(result.rows)} runs ({counts}); simulated now "
        f"{len(result.simulated)} in {time.perf_counter() - start:.1f} s"
    )
    print(f"  table:  {result.table}")
    if result.figure:
        print(f"  figure: {result.figure}")
    print(f"  runs:   {pathlib.Path(args.out) / 'runs'}/<run_id>/")
    if not result.counts.get("ok"):
        print(
            f"manta-drake: sweep {config.name}: no run is ok ({counts}); see {result.table}",
            file=sys.stderr,
        )
        return NO_RESULT
    if result.counts.get(LOST):
        print(
            f"manta-drake: sweep {config.name}: {result.counts[LOST]} runs lost to the "
            "cluster; run the same command again to finish them",
            file=sys.stderr,
        )
        return NO_RESULT
    return 0
