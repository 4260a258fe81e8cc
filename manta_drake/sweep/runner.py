"""``run_sweep``: every run of a sweep not done yet, one Dask task each (or one after another
in this process), then the table and the figure."""

from __future__ import annotations

import dataclasses as dc
import pathlib
import sys

from manta_drake.sweep.config import RunSpec, SweepConfig
from manta_drake.sweep.figure import write_summary_figure
from manta_drake.sweep.plan import parameter_names, plan_runs
from manta_drake.sweep.results import read_done, table_rows, write_run, write_table
from manta_drake.sweep.run import simulate_run


@dc.dataclass
class SweepResult:
    """What ``run_sweep`` returns."""

    rows: list[dict]
    columns: list[str]
    table: pathlib.Path
    figure: pathlib.Path | None
    simulated: list[str]  # run ids simulated by this call (not skipped)
    counts: dict  # status -> number of runs


def run_sweep(config: SweepConfig, out_dir, client=None, progress: bool = True,
              limit: int | None = None, rerun_failed: bool = False) -> SweepResult:
    """Runs every run of the sweep not done yet and writes the table and the figure.

    Args:
        config: a loaded sweep.
        out_dir: output folder; runs already done in it are skipped.
        client: a ``distributed.Client``: each run is one task (``Client.submit``),
            collected with ``as_completed``. None: one run after another in this process
            (debugging, and the reference the tests compare the cluster with).
        progress: a tqdm bar counting finished runs.
        limit: only the first ``limit`` runs.
        rerun_failed: run again the runs done with a status other than ``ok``.
    """
    out_dir = pathlib.Path(out_dir)
    runs_dir = out_dir / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    specs = plan_runs(config, limit)
    records: dict[str, dict] = {}
    for spec in specs:
        record = read_done(runs_dir / spec.run_id)
        if record is not None and not (rerun_failed and record["status"] != "ok"):
            records[spec.run_id] = record
    todo = [s for s in specs if s.run_id not in records]
    simulated: list[str] = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(specs), initial=len(specs) - len(todo), unit="run",
                   desc=config.name, file=sys.stderr, dynamic_ncols=True)

    def finish(spec: RunSpec, outcome: dict) -> None:
        records[spec.run_id] = write_run(runs_dir / spec.run_id, spec, outcome)
        columns, rows = table_rows(specs, records)
        write_table(out_dir / "results.csv", columns, rows)  # partial table if interrupted
        if bar is not None:
            bad = sum(r["status"] != "ok" for r in records.values())
            bar.set_postfix_str(f"not ok: {bad}" if bad else "", refresh=False)
            bar.update(1)

    try:
        for spec in [s for s in todo if s.invalid_reason]:  # nothing to simulate
            finish(spec, {"metrics": {"status": "invalid", "reason": spec.invalid_reason}})
        todo = [s for s in todo if not s.invalid_reason]
        if client is None:
            for spec in todo:
                finish(spec, simulate_run(spec.scenario_yaml))
                simulated.append(spec.run_id)
        else:
            from distributed import as_completed

            # Deterministic keys: a resubmitted run is recognised by the scheduler.
            futures = {client.submit(simulate_run, s.scenario_yaml, key=f"manta-run-{s.run_id}",
                                     pure=False): s for s in todo}
            for future in as_completed(futures):
                spec = futures[future]
                try:
                    outcome = future.result()
                except Exception as e:  # e.g. KilledWorker: the worker process died
                    outcome = {"metrics": {"status": "error", "reason":
                                           f"{type(e).__name__}: {' '.join(str(e).split())}"}}
                future.release()
                finish(spec, outcome)
                simulated.append(spec.run_id)
    finally:
        if bar is not None:
            bar.close()
    columns, rows = table_rows(specs, records)
    table = out_dir / "results.csv"
    write_table(table, columns, rows)
    figure = write_summary_figure(out_dir / "summary.png", rows, parameter_names(config),
                                  config.name) if rows else None
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    return SweepResult(rows, columns, table, figure, simulated, counts)
