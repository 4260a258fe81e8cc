"""``run_sweep``: every run of a sweep not done yet, one Dask task each (or one after another
in this process), then the table and the figure.

A run lost to the cluster (its worker process died, the connection to it closed) is not a
result: it is submitted again, up to ``ATTEMPTS`` times in all, and if every attempt is
lost its row says ``lost`` and a restart runs it again."""

from __future__ import annotations

import dataclasses as dc
import pathlib
import sys
import time

from manta_drake.cluster import (
    ATTEMPTS,  # noqa: F401 (the sweep's API: sweep.ATTEMPTS)
    TaskFailure,
    completed_resubmitting_lost,
)
from manta_drake.sweep.config import RunSpec, SweepConfig, check_out_folder
from manta_drake.sweep.figure import write_summary_figure
from manta_drake.sweep.plan import load_base, parameter_names, resolve_run, run_specs
from manta_drake.sweep.results import (
    LOST,
    read_done,
    table_rows,
    write_run,
    write_table,
)
from manta_drake.sweep.run import simulate_run

# The files and folder a sweep writes in its --out folder.
OUTPUTS = ("results.csv", "summary.png")


@dc.dataclass
class SweepResult:
    """What ``run_sweep`` returns."""

    rows: list[dict]
    columns: list[str]
    table: pathlib.Path
    figure: pathlib.Path | None
    simulated: list[str]  # run ids simulated by this call (not skipped)
    counts: dict  # status -> number of runs


def check_sweep_out(config: SweepConfig, out_dir, inputs=()) -> pathlib.Path:
    """Checks the sweep's output folder before anything runs (``config.check_out_folder``;
    the sweep file and the base scenarios are inputs it may not overwrite)."""
    return check_out_folder(out_dir, OUTPUTS, inputs, folders=("runs",))


class _Table:
    """Rewrites ``results.csv`` while runs finish, as often as it is cheap: at most once per
    ``min_interval`` s and at most a tenth of the time (a table of many thousand rows takes
    a while to write; rewriting it after every run would cost the square of the runs)."""

    def __init__(
        self, path: pathlib.Path, specs: list[RunSpec], records: dict, min_interval: float = 1.0
    ):
        self.path, self.specs, self.records = path, specs, records
        self.min_interval = min_interval
        self.last = -float("inf")
        self.cost = 0.0

    def update(self, force: bool = False) -> tuple[list[str], list[dict]] | None:
        now = time.monotonic()
        if not force and now - self.last < max(self.min_interval, 10 * self.cost):
            return None
        columns, rows = table_rows(self.specs, self.records)
        write_table(self.path, columns, rows)
        self.last = time.monotonic()
        self.cost = self.last - now
        return columns, rows


def run_sweep(
    config: SweepConfig,
    out_dir,
    client=None,
    progress: bool = True,
    limit: int | None = None,
    rerun_failed: bool = False,
) -> SweepResult:
    """Runs every run of the sweep not done yet and writes the table and the figure.

    Args:
        config: a loaded sweep.
        out_dir: output folder; runs already done in it are skipped (``results.read_done``).
        client: a ``distributed.Client``: each run is one task (``Client.submit``), at most
            a few per worker thread in flight, collected with ``as_completed``; a run lost
            to the cluster is submitted again (``ATTEMPTS``). None: one run after another in
            this process (debugging, and the reference the tests compare the cluster with).
        progress: a tqdm bar counting finished runs.
        limit: only the first ``limit`` runs (only their parameter sets are drawn).
        rerun_failed: run again the runs done with a status other than ``ok``.

    Raises:
        SweepError: the output folder cannot take the results (before any run).
    """
    out_dir = check_sweep_out(config, out_dir)
    runs_dir = out_dir / "runs"
    runs_dir.mkdir(parents=True, exist_ok=True)
    specs = run_specs(config, limit)
    records: dict[str, dict] = {}
    for spec in specs:
        record = read_done(runs_dir / spec.run_id)
        if record is not None and not (rerun_failed and record["status"] != "ok"):
            records[spec.run_id] = _kept(record)
    todo = [s for s in specs if s.run_id not in records]
    simulated: list[str] = []
    table = _Table(out_dir / "results.csv", specs, records)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(
            total=len(specs),
            initial=len(specs) - len(todo),
            unit="run",
            desc=config.name,
            file=sys.stderr,
            dynamic_ncols=True,
        )

    def finish(spec: RunSpec, outcome: dict) -> None:
        records[spec.run_id] = _kept(write_run(runs_dir / spec.run_id, spec, outcome))
        table.update()  # a partial table if interrupted
        if bar is not None:
            bad = sum(r["status"] != "ok" for r in records.values())
            bar.set_postfix_str(f"not ok: {bad}" if bad else "", refresh=False)
            bar.update(1)

    def resolved():
        """The runs to simulate, each resolved when it is next (~50 ms each: a long sweep
        starts at once and holds only the scenarios in flight); invalid ones are finished
        on the way."""
        for spec in todo:
            spec = resolve_run(spec, load_base(config, spec.base))
            if spec.invalid_reason:
                finish(spec, {"metrics": {"status": "invalid", "reason": spec.invalid_reason}})
            else:
                yield spec

    try:
        if client is None:
            for spec in resolved():
                finish(spec, simulate_run(spec.scenario_yaml))
                simulated.append(spec.run_id)
        else:
            _run_on_cluster(client, resolved(), finish, simulated)
    finally:
        if bar is not None:
            bar.close()
    table_now = table.update(force=True)
    assert table_now is not None  # forced: always written
    columns, rows = table_now
    figure = (
        write_summary_figure(out_dir / "summary.png", rows, parameter_names(config), config.name)
        if rows
        else None
    )
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    return SweepResult(rows, columns, table.path, figure, simulated, counts)


def _kept(record: dict) -> dict:
    """What the table needs of a record (its ``run`` block repeats the spec)."""
    return {k: v for k, v in record.items() if k != "run"}


def _run_on_cluster(client, runs, finish, simulated: list[str]) -> None:
    """Submits the runs a window at a time (the scheduler holds each task's scenario text:
    a few per worker thread keep every worker busy without holding the whole sweep), and
    submits a run again when the cluster lost it."""
    # simulate_run returns every failure of a run: an exception is the cluster's.
    for spec, outcome in completed_resubmitting_lost(
        client,
        simulate_run,
        runs,
        lambda spec: spec.scenario_yaml,
        lambda spec: f"manta-run-{spec.run_id}",
        window=lambda: max(16, 4 * sum(client.nthreads().values())),
    ):
        if isinstance(outcome, TaskFailure):
            outcome = {
                "metrics": {"status": LOST if outcome.lost else "error", "reason": outcome.reason()}
            }
        finish(spec, outcome)
        simulated.append(spec.run_id)
