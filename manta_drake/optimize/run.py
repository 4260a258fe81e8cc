"""``run_optimization``: CMA-ES over the free parameters, each generation's simulations run
in parallel on Dask (one task per candidate and robustness point and seed), restartable.

The loop, per generation: ask CMA-ES for the population (generation 1's first candidate is
the start gait itself, injected), save the state (``state.json``, module ``state``: the
candidates and costs told so far and the asked ones), simulate every (candidate, point,
seed) not already in ``history.csv``, write each result as it comes (its folder and the
table, atomically), aggregate each candidate's costs, tell CMA-ES, keep the logs of the
best candidate so far only, save the state again. Then the best gait is re-run at the
scenario as it is (``best_run/``, with its figures) and at the held-out points
(``held_out/``), and ``best_gait.yaml``, ``convergence.png`` and ``summary.json`` are
written.

A restart (the same spec and options, the same ``--out``) loads ``state.json``, rebuilds
CMA-ES by replaying its asks and tells (each replayed candidate checked against the saved
one, bit for bit) and goes on: an interrupted generation asks nothing new (its candidates
are in the state) and reuses every simulation the table holds; a finished one goes to the
next generation, up to the (possibly raised) ``--generations``. The random numbers CMA-ES
draws are its own (``numpy.random.default_rng(seed)``, replayed with it), so a run
interrupted and restarted asks exactly the candidates of one that was not.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
import datetime
import io
import json
import math
import pathlib
import subprocess
import sys
import time
import uuid

import numpy as np

from manta_drake.cluster import TaskFailure, completed_resubmitting_lost
from manta_drake.interrupts import interrupts_as_exceptions
from manta_drake.optimize.evaluate import simulate_candidate
from manta_drake.optimize.history import (
    HISTORY,
    HISTORY_SLACK_BYTES,
    MAX_ROW_BYTES,
    evaluation_folder,
    evaluation_key,
    finite_or_none,
    read_history,
    short_reason,
    write_evaluation,
    write_history,
)
from manta_drake.optimize.loading import Problem, load_problem
from manta_drake.optimize.objective import (
    METRICS,
    STEADY_METRICS,
    aggregate,
    constraint_violation,
    score,
    short_window_cost,
)
from manta_drake.optimize.parameters import candidate_gait_text
from manta_drake.optimize.state import (
    STATE,
    SearchState,
    load_state,
    new_search,
    save_state,
)
from manta_drake.run_folder import write_atomic
from manta_drake.sweep.config import check_out_folder

# What run_optimization writes in its output folder (files, then folders).
OUTPUTS = ("best_gait.yaml", HISTORY, "convergence.png", "summary.json", STATE)
FOLDERS = ("evaluations", "best_run", "held_out")
# Status of a simulation that ran to its end without a metric the objective needs (no steady
# window for a mean velocity, no speed for a cost of transport): costed failed_cost.
UNSCORED = "unscored"


@dc.dataclass
class OptimizationResult:
    """What ``run_optimization`` returns."""

    name: str
    names: list[str]  # the free parameters
    start_degrees: np.ndarray
    best_degrees: np.ndarray
    start_cost: float
    best_cost: float
    best_generation: int
    best_candidate: int
    best_ok: bool  # every simulation of the best candidate ran (its gait file is written)
    generations: int  # generations told
    evaluations: int  # search simulations in the history
    simulated: int  # simulations run by this call (search and final)
    reused: int  # search simulations taken from the history
    stop: str  # why the search ended
    wall_time_s: float  # this call
    out_dir: pathlib.Path
    best_gait_file: pathlib.Path | None = None
    history_file: pathlib.Path | None = None
    figure: pathlib.Path | None = None
    summary_file: pathlib.Path | None = None
    held_out: list = dc.field(default_factory=list)  # rows of the held-out re-check
    # Per generation run by any call: its wall time (ask to saved state), simulations run
    # and reused, the longest and the summed simulation wall times (on the workers).
    timings: list = dc.field(default_factory=list)
    best_run: dict | None = None  # the row of the best gait's re-run
    source: str = ""  # source_version() when this call started
    # Where the best gait breaks a constraint or does not run: one line per simulation
    # (search points, its re-run, held-out points); empty: feasible everywhere.
    violations: list = dc.field(default_factory=list)

    @property
    def feasible(self) -> bool:
        return not self.violations

    @property
    def status(self) -> str:
        """``ok``, ``infeasible`` (a gait is written, marked so) or ``no_gait``."""
        if not self.best_ok:
            return "no_gait"
        return "ok" if self.feasible else "infeasible"


def check_optimize_out(problem: Problem, out_dir) -> pathlib.Path:
    """Checks the output folder before anything runs: writable, none of ``OUTPUTS`` a
    folder or over the spec or its scenario, none of ``FOLDERS`` a file."""
    inputs = [problem.spec.path]
    return check_out_folder(out_dir, OUTPUTS, inputs, folders=FOLDERS)


REPO = pathlib.Path(__file__).resolve().parents[2]  # the checkout this package runs from


def source_version() -> str:
    """``git <HEAD>`` of the checkout this package runs from (``+ modified`` when a tracked
    file differs from it), else ``manta_drake <version>``. Taken when a run starts."""
    from manta_drake.version import __version__

    try:
        top = subprocess.run(
            ["git", "-C", str(REPO), "rev-parse", "--show-toplevel"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
        if top.returncode == 0 and pathlib.Path(top.stdout.strip()).resolve() == REPO:
            head = subprocess.run(
                ["git", "-C", str(REPO), "rev-parse", "HEAD"],
                capture_output=True,
                text=True,
                timeout=10,
                check=False,
            )
            if head.returncode == 0 and head.stdout.strip():
                dirty = subprocess.run(
                    [
                        "git",
                        "-C",
                        str(REPO),
                        "diff",
                        "--quiet",
                        "HEAD",
                        "--",
                        "manta_drake",
                        "models",
                    ],
                    capture_output=True,
                    timeout=10,
                    check=False,
                )
                return f"git {head.stdout.strip()}" + (" + modified" if dirty.returncode else "")
    except (OSError, subprocess.SubprocessError):
        pass
    return f"manta_drake {__version__}"


def spec_path_text(path) -> str:
    """The spec's path as provenance says it: relative to the checkout when inside it."""
    path = pathlib.Path(path).resolve()
    try:
        return str(path.relative_to(REPO))
    except ValueError:
        return str(path)


class _Table:
    """Rewrites history.csv while simulations finish, as often as it is cheap: at most once
    per ``min_interval`` s and at most a tenth of the time (``sweep.runner``'s rule: a table
    rewritten after every simulation would cost the square of the simulations); ``force``
    at the end of every generation and on the way out."""

    def __init__(self, path: pathlib.Path, names, min_interval: float = 1.0):
        self.path, self.names, self.min_interval = path, list(names), min_interval
        self.last, self.cost = -math.inf, 0.0

    def write(self, rows: list[dict], force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self.last < max(self.min_interval, 10 * self.cost):
            return
        write_history(self.path, self.names, rows)
        self.last = time.monotonic()
        self.cost = self.last - now


class _Runner:
    """Runs batches of simulations (one task each, or one after another in this process)
    and hands each result to ``done`` as it finishes; a task lost with its worker is
    submitted again up to ``cluster.ATTEMPTS`` times."""

    def __init__(self, client, evaluate, bar):
        self.client, self.evaluate, self.bar = client, evaluate, bar
        self.token = uuid.uuid4().hex[:8]  # task keys of this call only
        self.simulated = 0

    def run(self, jobs: list[dict], done) -> None:
        if self.client is None:
            for job in jobs:
                try:
                    outcome = self.evaluate(job["task"])
                except Exception as e:  # noqa: BLE001 - the evaluator's raise fails the candidate
                    outcome = {
                        "status": "error",
                        "reason": f"{type(e).__name__}: {' '.join(str(e).split())}",
                    }
                self._finish(job, outcome, done)
            return
        # Closed at once when interrupted: nothing of this call keeps running on the cluster.
        with contextlib.closing(
            completed_resubmitting_lost(
                self.client,
                self.evaluate,
                jobs,
                lambda job: job["task"],
                lambda job: f"manta-opt-{job['key']}-{self.token}",
            )
        ) as finished:
            for job, outcome in finished:
                if isinstance(outcome, TaskFailure):  # the evaluator's raise, or the cluster's
                    outcome = {
                        "status": "lost" if outcome.lost else "error",
                        "reason": outcome.reason(),
                    }
                self._finish(job, outcome, done)

    def _finish(self, job, outcome, done) -> None:
        if not isinstance(outcome, dict):
            outcome = {
                "status": "error",
                "reason": f"the evaluator returned {type(outcome).__name__}, not a dict",
            }
        self.simulated += 1
        done(job, outcome)
        if self.bar is not None:
            self.bar.update(1)


def run_optimization(
    problem, out_dir, client=None, evaluate=None, progress: bool = True
) -> OptimizationResult:
    """Runs (or continues) the optimisation and writes its outputs (module docstring).

    Args:
        problem: a ``Problem`` (``load_problem``) or the path of a spec file.
        out_dir: the output folder; an optimisation there is continued.
        client: a ``distributed.Client`` (each simulation a task), or None: in this process.
        evaluate: what simulates one task (``evaluate.simulate_candidate``, the default);
            another function of a task dict that returns ``{"status", "metrics", ...}``
            makes the same machinery optimise something cheaper (tests, benchmarks). On a
            cluster it must be picklable.
        progress: a tqdm bar counting simulations.

    Returns:
        The result; ``best_gait_file`` is None when the best candidate's simulations did not
        all run (every candidate failed).

    Raises:
        OptimizeError: the output folder cannot take the outputs, holds an optimisation of
            another spec, a ``state.json`` or ``history.csv`` that is malformed or does not
            replay, or an earlier version's ``state.pkl`` (never opened); before any
            simulation.
    """
    if not isinstance(problem, Problem):
        problem = load_problem(problem)
    out_dir = check_optimize_out(problem, out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    evaluate = evaluate or simulate_candidate
    started = time.perf_counter()
    source = source_version()  # the code this run is made with, not the code at its end
    search = _Search(problem, out_dir, started)
    bar = search.progress_bar() if progress else None
    runner = _Runner(client, evaluate, bar)
    try:
        with interrupts_as_exceptions():
            stop = search.run_generations(runner, bar)
            assert search.state.best is not None  # a generation was told
            search.final_rows = _final_stage(
                problem, out_dir, search.state.best, runner, search.scenario_sha
            )
    finally:
        # Every simulation finished so far is in the table, also after Ctrl-C.
        search.write_table(force=True)
        if bar is not None:
            bar.close()
    search.save()
    return _finish(search, runner.simulated, stop, time.perf_counter() - started, source)


def rerun_start(problem: Problem, out_dir, client=None, evaluate=None) -> None:
    """Simulates the search's start gait (generation 1, candidate 0) again at its first point
    and seed and writes its evaluation folder as the search wrote it (its metrics.json, no
    log): for a search continued from its state and history alone (as kept in
    ``diagrams/optimize/searches/``), whose evaluation folders are gone. Its history row is
    rewritten (the same simulation: the same key and metrics)."""
    search = _Search(problem, check_optimize_out(problem, out_dir), time.perf_counter())
    job = search.jobs_of(1, [None])[0]  # the start's degrees are its own, not a unit vector's
    job["task"]["keep_log"] = False
    _Runner(client, evaluate or simulate_candidate, None).run([job], search.record)
    search.write_table(force=True)


class _Search:
    """The CMA-ES search of one ``run_optimization`` call: its state (loaded or new, its
    told generations replayed), the history's rows, the table and the saved wall time."""

    def __init__(self, problem: Problem, out_dir: pathlib.Path, started: float):
        spec, space = problem.spec, problem.space
        self.problem, self.out_dir = problem, out_dir
        self.identity = problem.identity()
        self.points, self.seeds = spec.points(), list(spec.robustness.seeds)
        self.scenario_sha = self.identity["scenario"]
        self.state = load_state(out_dir, problem) or new_search(problem)
        for generation, (candidates, costs) in enumerate(self.state.told, start=1):
            jobs = self.jobs_of(generation, candidates)
            self.state.best = _better(self.state.best, generation, costs, jobs)
        history = read_history(
            out_dir / HISTORY, space.names, max_bytes=history_limit(problem, self.state.generation)
        )
        self.rows = {r["key"]: r for r in history if r["kind"] == "search"}
        self.final_rows: list[dict] = [r for r in history if r["kind"] != "search"]
        self.table = _Table(out_dir / HISTORY, space.names)
        self.reused = 0
        self.clock = started

    def jobs_of(self, generation: int, candidates) -> list[dict]:
        """The simulations of a generation's candidates: each at every point and seed."""
        spec, space = self.problem.spec, self.problem.space
        out = []
        for c, unit in enumerate(candidates):
            # The injected start (module docstring) in its exact degrees, not through the
            # unit cube's round-off: its entries are the start gait's to the bit.
            degrees = space.start_vector() if (generation, c) == (1, 0) else space.to_degrees(unit)
            gait_text = candidate_gait_text(spec.name, space.gait(degrees))
            for p, point in enumerate(self.points):
                for seed in self.seeds:
                    out.append(
                        _job(
                            self.problem,
                            self.scenario_sha,
                            "search",
                            generation,
                            c,
                            p,
                            point,
                            seed,
                            degrees,
                            gait_text,
                            keep_log=True,
                        )
                    )
        return out

    def progress_bar(self):
        """A tqdm bar over the search's simulations, then the best gait's re-run and its
        held-out re-checks, started at the simulations the history holds."""
        from tqdm import tqdm

        spec, budget = self.problem.spec, self.problem.spec.budget
        per_candidate = len(self.points) * len(self.seeds)
        total = (
            max(budget.generations, self.state.generation) * budget.population * per_candidate
            + 1
            + len(spec.held_out.points) * len(spec.held_out_seeds())
        )
        return tqdm(
            total=total,
            initial=min(len(self.rows), total),
            unit="sim",
            file=sys.stderr,
            desc=f"optimizing {spec.name}",
            dynamic_ncols=True,
        )

    def save(self) -> None:
        """Saves the state, its wall time brought up to now."""
        self.state.wall_time_s += time.perf_counter() - self.clock
        self.clock = time.perf_counter()
        save_state(self.out_dir, self.state, self.identity)

    def write_table(self, force: bool = False) -> None:
        self.table.write(list(self.rows.values()) + self.final_rows, force=force)

    def record(self, job: dict, outcome: dict) -> None:
        """Writes a finished simulation's folder and its row (the table when it is cheap)."""
        row = _row(self.problem, job, outcome)
        write_evaluation(
            self.out_dir / row["folder"],
            job["task"]["gait_text"],
            _record(row, outcome, self.problem.space),
            outcome.get("log_npz"),
        )
        self.rows[row["key"]] = row
        self.write_table()

    def run_generations(self, runner: _Runner, bar) -> str:
        """Asks, simulates and tells generations until the budget or CMA-ES stops the
        search (an interrupted generation first, asking nothing new); returns why."""
        while True:
            t_generation, resumed = time.perf_counter(), self.state.pending is not None
            if self.state.pending is None:
                stop = self._stop_reason()
                if stop:
                    return stop
                self.state.ask()
                self.save()
            self._run_generation(runner, bar, t_generation, resumed)

    def _stop_reason(self) -> str:
        """Why the search ends before asking another generation, or ""."""
        n = self.problem.spec.budget.generations
        if self.state.generation >= n:
            return f"{n} generation{'s' if n != 1 else ''}"
        cma_stop = self.state.stop()
        if cma_stop:
            return "CMA-ES: " + ", ".join(f"{k} {v}" for k, v in cma_stop.items())
        return ""

    def _run_generation(self, runner: _Runner, bar, t_generation: float, resumed: bool) -> None:
        """Simulates the pending generation (what the history lacks), tells its costs,
        keeps the best candidate's logs only, and saves the table and the state."""
        rows, generation = self.rows, self.state.generation
        jobs = self.jobs_of(generation, self.state.pending)
        todo = list(
            {
                j["key"]: j
                for j in jobs
                if j["key"] not in rows or rows[j["key"]]["status"] == "lost"
            }.values()
        )
        self.reused += sum(
            1 for j in jobs if j["key"] in rows and rows[j["key"]]["status"] != "lost"
        )
        runner.run(todo, self.record)
        costs = self._tell(generation, jobs)
        assert self.state.best is not None  # told: _tell set it
        _say(
            bar,
            generation_line(
                generation,
                self.problem.spec.budget.generations,
                costs,
                self.state.best,
                [[rows[j["key"]] for j in jobs if j["candidate"] == c] for c in range(len(costs))],
                len(todo),
                time.perf_counter() - t_generation,
            ),
        )
        _prune_logs(self.out_dir, rows, self.state.best)
        self.write_table(force=True)
        self.state.timings.append(self._timing(generation, jobs, todo, t_generation, resumed))
        self.save()

    def _tell(self, generation: int, jobs: list[dict]) -> list:
        """Each candidate's aggregated cost (also written into its rows), told to CMA-ES;
        the best candidate updated."""
        costs = []
        assert self.state.pending is not None  # the generation this tells
        for c in range(len(self.state.pending)):
            mine = [self.rows[j["key"]] for j in jobs if j["candidate"] == c]
            costs.append(
                aggregate([r["cost"] for r in mine], self.problem.spec.robustness.aggregate)
            )
            for r in mine:
                r["candidate_cost"] = costs[-1]
        self.state.tell(costs)
        self.state.best = _better(self.state.best, generation, costs, jobs)
        return costs

    def _timing(self, generation: int, jobs, todo, t_generation: float, resumed: bool) -> dict:
        """A generation's entry of ``timings`` (``OptimizationResult``)."""
        walls = [self.rows[j["key"]]["wall_time_s"] or 0.0 for j in todo]
        return {
            "generation": generation,
            "wall_s": time.perf_counter() - t_generation,
            "simulated": len(todo),
            "reused": len(jobs) - len(todo),
            "longest_simulation_s": max(walls, default=0.0),
            "sum_simulation_s": float(sum(walls)),
            "resumed": resumed,
        }


def _say(bar, line: str) -> None:
    """A line on stderr, above the progress bar when there is one."""
    if bar is not None:
        bar.write(line, file=sys.stderr)
    else:
        print(line, file=sys.stderr, flush=True)


def within_constraints(rows: list[dict]) -> bool:
    """Every simulation ran (``ok``) and none broke a constraint or touched a wall."""
    return bool(rows) and not violations(rows)


def generation_line(
    generation: int,
    generations: int,
    costs,
    best: dict,
    candidate_rows: list[list[dict]],
    simulated: int,
    wall_s: float,
) -> str:
    """One line per told generation: its best cost, the best so far, how many of its
    candidates met every constraint at every point, the simulations run and the time."""
    feasible = sum(within_constraints(rows) for rows in candidate_rows)
    return (
        f"generation {generation}/{generations}: cost {min(costs):.4g} (best so far "
        f"{best['cost']:.4g}, generation {best['generation']}), {feasible}/{len(costs)} "
        f"candidates within every constraint, {simulated} simulated, {wall_s:.0f} s"
    )


def violations(rows: list[dict]) -> list[str]:
    """Where these simulations (a candidate's search rows, its re-run, its held-out
    checks) break a constraint, touch a wall or did not run: one line each."""
    out = []
    for r in rows:
        where = f"{r['kind']} point {r['point']} {r['overrides']} seed {r['seed']}"
        if r["status"] != "ok":
            out.append(f"{where}: {r['status']}: {r['reason']}")
        elif r["penalty"]:
            out.append(f"{where}: {r['reason']}")
    return out


def _better(best: dict | None, generation: int, costs: list, jobs: list[dict]) -> dict:
    """The best candidate after a told generation: its best candidate if it costs less than
    ``best`` (the earlier one on a tie), else ``best``."""
    c_best = int(np.argmin(costs))
    if best is not None and not costs[c_best] < best["cost"]:
        return best
    mine = [j for j in jobs if j["candidate"] == c_best]
    return {
        "generation": generation,
        "candidate": c_best,
        "degrees": mine[0]["degrees"],
        "cost": float(costs[c_best]),
        "keys": [j["key"] for j in mine],
    }


def history_limit(problem: Problem, generations: int) -> int:
    """The largest history.csv the search of ``max(generations, budget.generations)``
    generations writes [bytes]: its rows (search, best re-run, held out), each at most
    ``MAX_ROW_BYTES`` and its point's overrides."""
    spec = problem.spec
    points = spec.points()
    search = (
        max(generations, spec.budget.generations)
        * spec.budget.population
        * len(points)
        * len(spec.robustness.seeds)
    )
    final = 1 + len(spec.held_out.points) * len(spec.held_out_seeds())
    longest = max(
        len(json.dumps(p, sort_keys=True, default=str)) for p in [*points, *spec.held_out.points]
    )
    return HISTORY_SLACK_BYTES + (search + final) * (MAX_ROW_BYTES + 2 * longest)


def _job(
    problem: Problem,
    scenario_sha: str,
    kind: str,
    generation: int,
    candidate: int,
    p: int,
    point: dict,
    seed: int,
    degrees,
    gait_text: str,
    keep_log: bool,
) -> dict:
    names = problem.space.names
    key = evaluation_key(scenario_sha, names, degrees, point, seed)
    parameters = {n: float(v) for n, v in zip(names, degrees)}
    task = {
        "key": key,
        "scenario_yaml": problem.base_yaml,
        "gait_name": problem.spec.name,
        "gait_text": gait_text,
        "overrides": point,
        "seed": int(seed),
        "set_stance": problem.set_stance,
        "keep_log": keep_log,
        "parameters": parameters,
    }
    return {
        "key": key,
        "kind": kind,
        "generation": generation,
        "candidate": candidate,
        "point": p,
        "seed": int(seed),
        "overrides": point,
        "degrees": list(map(float, degrees)),
        "task": task,
    }


def _row(problem: Problem, job: dict, outcome: dict) -> dict:
    """A history row of one finished simulation (the cost from its metrics)."""
    space, spec = problem.space, problem.spec
    values = {m: finite_or_none((outcome.get("metrics") or {}).get(m)) for m in METRICS}
    values["distance_from_start_gait"] = space.distance_from_start(job["degrees"])
    status = short_reason(outcome.get("status", "error"))[:80]
    reason = short_reason(outcome.get("reason", ""))
    touched = bool(outcome.get("touched_wall", False))
    run = outcome.get("run") or {}
    short = short_window(run, spec.budget.min_window)
    if status == "ok" and short:
        values.update(dict.fromkeys(STEADY_METRICS))
        reason = short
    s = score(spec.objective, status, values, touched, reason)
    if s.failed and status == "ok":
        # The run ran, but without a metric the objective needs: no score, no gait.
        status, reason = UNSCORED, s.reason
        if short and spec.budget.min_window:  # ranked by how long it kept off the walls
            start, end = run["steady_window_s"]
            cost = short_window_cost(
                spec.objective.failed_cost, end - start, spec.budget.min_window
            )
            s = dc.replace(s, cost=cost)
    row = {k: job[k] for k in ("key", "kind", "generation", "candidate", "point", "seed")}
    row.update(zip(space.names, job["degrees"]))
    row.update(values)
    row.update(
        objective=finite_or_none(s.objective),
        penalty=s.penalty,
        cost=s.cost,
        candidate_cost=None,
        status=status,
        reason=short_reason(s.reason) if status == "ok" else reason,
        touched_wall=touched,
        wall_time_s=finite_or_none(outcome.get("wall_time_s")),
        worker=short_reason(outcome.get("worker", ""))[:200],
        overrides=json.dumps(job["overrides"], sort_keys=True),
        folder=evaluation_folder(
            job["kind"], job["generation"], job["candidate"], job["point"], job["seed"]
        ),
    )
    return row


def short_window(run: dict, min_window: float | None) -> str:
    """Why a run's steady window is too short to score (``budget.min_window``), or ''.

    ``run`` is the run's metrics.json: its ``steady_window_s`` ends where the hull first
    came near a wall (``near_wall_at_s``) or at the run's end."""
    window = run.get("steady_window_s")
    if min_window is None or not window:
        return ""
    length = float(window[1]) - float(window[0])
    if length >= min_window:
        return ""
    near = run.get("near_wall_at_s")
    where = f"near a wall at {near:.3g} s" if near is not None else "at the run's end"
    return (
        f"steady window {window[0]:.3g}-{window[1]:.3g} s ({length:.3g} s, ending {where}) is "
        f"under budget.min_window {min_window:g} s"
    )


def _record(row: dict, outcome: dict, space) -> dict:
    """An evaluation's metrics.json: the run's own metrics, then what the optimiser made
    of them."""
    record = dict(outcome.get("run") or {})
    record.update(status=row["status"], reason=row["reason"])
    record["optimize"] = {
        k: row[k]
        for k in (
            "key",
            "kind",
            "generation",
            "candidate",
            "point",
            "seed",
            "objective",
            "penalty",
            "cost",
            "worker",
        )
    }
    record["optimize"]["parameters_deg"] = {n: row[n] for n in space.names}
    record["optimize"]["overrides"] = json.loads(row["overrides"])
    record["optimize"]["metrics"] = {m: row[m] for m in METRICS}
    return record


def _prune_logs(out_dir: pathlib.Path, rows: dict, best: dict | None) -> None:
    """Removes the log of every search simulation but the best candidate's (the logs are
    the bulk of the folder: megabytes a simulation)."""
    keep = set(best["keys"]) if best else set()
    for key, row in rows.items():
        if key not in keep:
            (out_dir / row["folder"] / "log.npz").unlink(missing_ok=True)


def _final_stage(
    problem: Problem, out_dir: pathlib.Path, best: dict, runner: _Runner, scenario_sha: str
) -> list[dict]:
    """The best gait re-run at the scenario as it is (with its figures) and at every
    held-out point and seed; their rows."""
    from manta_drake import plots

    spec, space = problem.spec, problem.space
    degrees = np.asarray(best["degrees"])
    gait_text = candidate_gait_text(spec.name, space.gait(degrees))
    jobs = [
        _job(
            problem,
            scenario_sha,
            "best",
            best["generation"],
            best["candidate"],
            0,
            {},
            spec.robustness.seeds[0],
            degrees,
            gait_text,
            keep_log=True,
        )
    ]
    for p, point in enumerate(spec.held_out.points):
        for seed in spec.held_out_seeds():
            jobs.append(
                _job(
                    problem,
                    scenario_sha,
                    "held_out",
                    best["generation"],
                    best["candidate"],
                    p,
                    dict(point),
                    seed,
                    degrees,
                    gait_text,
                    keep_log=False,
                )
            )
    out: list[dict] = []

    def done(job, outcome) -> None:
        row = _row(problem, job, outcome)
        folder = out_dir / row["folder"]
        write_evaluation(folder, gait_text, _record(row, outcome, space), outcome.get("log_npz"))
        if job["kind"] == "best" and outcome.get("log_npz"):
            with np.load(io.BytesIO(outcome["log_npz"])) as npz:
                log = {k: npz[k] for k in npz.files}
            plots.write_run_plots(log, folder, title=f"{spec.name} (best)")
        out.append(row)

    for name in ("joints.png", "states.png", "trajectory.png"):
        (out_dir / "best_run" / name).unlink(missing_ok=True)  # never an earlier best's
    runner.run(jobs, done)
    return out


def _candidate_rows(rows: dict, generation: int, candidate: int) -> list[dict]:
    return [
        r for r in rows.values() if (r["generation"], r["candidate"]) == (generation, candidate)
    ]


def term_values(problem: Problem, rows: list[dict]) -> dict:
    """Each term's and constraint's mean value over a candidate's simulations that ran."""
    o = problem.spec.objective
    ok = [r for r in rows if r["status"] == "ok"]

    def mean(metric):
        vals = [r[metric] for r in ok if r.get(metric) is not None]
        return float(np.mean(vals)) if vals else None

    terms = [
        {
            "metric": t.metric,
            "weight": t.weight,
            "value": mean(t.metric),
            "contribution": None if mean(t.metric) is None else t.weight * mean(t.metric),
        }
        for t in o.terms
    ]
    constraints = []
    for c in o.constraints:
        violated = sum(
            1
            for r in ok
            if r.get(c.metric) is not None
            and (not c.relative_to or r.get(c.relative_to) is not None)
            and constraint_violation(c, r)[0] > 0
        )
        constraints.append(
            {
                "metric": c.metric,
                "min": c.min,
                "max": c.max,
                "relative_to": c.relative_to or None,
                "value": mean(c.metric),
                "violated_in": violated,
                "simulations": len(ok),
            }
        )
    return {
        "terms": terms,
        "constraints": constraints,
        "mean_penalty": float(np.mean([r["penalty"] for r in ok])) if ok else None,
        "simulations": len(rows),
        "ok": len(ok),
    }


def _finish(
    search: _Search, simulated: int, stop: str, wall_time: float, source: str
) -> OptimizationResult:
    """The result of ``search`` (``simulated`` simulations run by this call, which took
    ``wall_time`` s with the code ``source``), with best_gait.yaml (when the best candidate's
    simulations all ran), convergence.png and summary.json written."""
    from manta_drake.optimize.figure import write_convergence_figure

    problem, out_dir, state, rows = search.problem, search.out_dir, search.state, search.rows
    result = _result(search, simulated, stop, wall_time, source)
    (out_dir / "best_gait.yaml").unlink(missing_ok=True)  # never an earlier run's
    if result.best_ok:
        result.best_gait_file = write_best_gait(out_dir / "best_gait.yaml", problem, result)
    result.history_file = out_dir / HISTORY
    result.figure = write_convergence_figure(
        out_dir / "convergence.png", problem, list(rows.values())
    )
    summary = _summary(problem, result, state, rows)
    result.summary_file = out_dir / "summary.json"
    write_atomic(result.summary_file, json.dumps(summary, indent=2, default=str) + "\n")
    return result


def _result(
    search: _Search, simulated: int, stop: str, wall_time: float, source: str
) -> OptimizationResult:
    """The search's result from its state and the history's rows (files not yet written)."""
    problem, state, rows, final_rows = search.problem, search.state, search.rows, search.final_rows
    spec, space = problem.spec, problem.space
    best = state.best
    assert best is not None  # a generation was told
    start_rows = _candidate_rows(rows, 1, 0)
    start_cost = start_rows[0]["candidate_cost"] if start_rows else math.nan
    best_rows = _candidate_rows(rows, best["generation"], best["candidate"])
    return OptimizationResult(
        name=spec.name,
        names=space.names,
        start_degrees=space.start_vector(),
        best_degrees=np.asarray(best["degrees"]),
        start_cost=float(start_cost),
        best_cost=float(best["cost"]),
        best_generation=best["generation"],
        best_candidate=best["candidate"],
        best_ok=bool(best_rows) and all(r["status"] == "ok" for r in best_rows),
        generations=len(state.told),
        evaluations=len(rows),
        simulated=simulated,
        reused=search.reused,
        stop=stop or "done",
        wall_time_s=wall_time,
        out_dir=search.out_dir,
        held_out=[r for r in final_rows if r["kind"] == "held_out"],
        best_run=next((r for r in final_rows if r["kind"] == "best"), None),
        timings=list(state.timings),
        source=source,
        violations=violations(best_rows + final_rows),
    )


def _summary(problem: Problem, result: OptimizationResult, state: SearchState, rows: dict) -> dict:
    """summary.json: the spec and provenance, the start and the best with their terms, the
    final stage's rows and the search's effort."""
    spec, space = problem.spec, problem.space
    return {
        "name": spec.name,
        "status": result.status,
        "feasible": result.feasible,
        "violations": result.violations,
        "spec": spec_path_text(spec.path),
        "spec_sha256": spec.text_sha256,
        "scenario": spec.scenario,
        "start_gait": spec.gait,
        "source": result.source,
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "parameters": [
            {
                "name": p.name,
                "entry": p.entry,
                "low": p.low,
                "high": p.high,
                "sets": [t.label() for t in p.targets],
            }
            for p in space.parameters
        ],
        "start": {
            "cost": result.start_cost,
            "degrees": dict(zip(space.names, map(float, result.start_degrees))),
            **term_values(problem, _candidate_rows(rows, 1, 0)),
        },
        "best": _best_summary(problem, result, rows),
        "best_run": _final_summary(result.best_run),
        "held_out": [_final_summary(r) for r in result.held_out],
        "generations": result.generations,
        "population": spec.budget.population,
        "points": len(spec.points()),
        "seeds": list(spec.robustness.seeds),
        "aggregate": spec.robustness.aggregate,
        "evaluations": result.evaluations,
        "simulated_now": result.simulated,
        "reused_now": result.reused,
        "stop": result.stop,
        "wall_time_s": result.wall_time_s,
        "generation_timings": result.timings,
        "wall_time_total_s": state.wall_time_s,
        "best_gait": str(result.best_gait_file) if result.best_gait_file else None,
    }


def _best_summary(problem: Problem, result: OptimizationResult, rows: dict) -> dict:
    """summary.json's ``best``: the best candidate, its changed entries and its terms."""
    space = problem.space
    best_rows = _candidate_rows(rows, result.best_generation, result.best_candidate)
    return {
        "cost": result.best_cost,
        "generation": result.best_generation,
        "candidate": result.best_candidate,
        "ok": result.best_ok,
        "feasible": result.feasible,
        "degrees": dict(zip(space.names, map(float, result.best_degrees))),
        "entries": [
            {"entry": e, "start": s, "best": b}
            for e, s, b in space.changed_entries(result.best_degrees)
        ],
        **term_values(problem, best_rows),
    }


def _final_summary(row: dict | None) -> dict | None:
    if row is None:
        return None
    return {
        "overrides": json.loads(row["overrides"]),
        "seed": row["seed"],
        "status": row["status"],
        "reason": row["reason"],
        "cost": row["cost"],
        "metrics": {m: row[m] for m in METRICS},
        "folder": row["folder"],
    }


def write_best_gait(
    path: pathlib.Path, problem: Problem, result: OptimizationResult
) -> pathlib.Path:
    """best_gait.yaml: a gait file holding the best gait under the result's name, with its
    provenance."""
    spec, space = problem.spec, problem.space
    provenance = {
        "made_by": "manta-drake optimize",
        "spec": spec_path_text(spec.path),
        "spec_sha256": spec.text_sha256,
        "source": result.source,
        "scenario": spec.scenario,
        "start_gait": spec.gait,
        "objective_value": result.best_cost,
        "start_objective_value": result.start_cost,
        "generation": result.best_generation,
        "candidate": result.best_candidate,
        "evaluations": result.evaluations,
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "parameters_deg": {n: float(v) for n, v in zip(space.names, result.best_degrees)},
        "feasible": result.feasible,
        "violations": result.violations,
    }
    header = (
        f"The gait {spec.name} found by `manta-drake optimize` from {spec.gait} "
        f"({spec.scenario}); use it with controller.gait_files: [this file]."
    )
    if not result.feasible:
        header = (
            f"INFEASIBLE: this gait breaks its spec's constraints in "
            f"{len(result.violations)} simulation(s) (provenance.violations). " + header
        )
    text = candidate_gait_text(
        spec.name,
        space.gait(result.best_degrees),
        description=" ".join(spec.description.split()) or f"optimised from {spec.gait}",
        provenance=provenance,
        header=header,
    )
    write_atomic(path, text)
    return path
