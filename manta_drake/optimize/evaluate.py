"""One simulation of a candidate gait, on a Dask worker or in this process:
``simulate_candidate(task)``.

A task is a plain dict (it crosses to the worker by pickle)::

    key            the evaluation's id (history.evaluation_key)
    scenario_yaml  the resolved base scenario (the spec's scenario, overrides, budget)
    gait_name      the result gait's name
    gait_text      the candidate as a gait file's text
    overrides      the robustness point (dotted keys, or net_weight_kg)
    seed           the run's random_seed
    set_stance     start in the candidate's stance (its X matrix is free)
    keep_log       return the log's bytes
    parameters     {name: degrees} of the free parameters

The worker writes the gait file into a temporary folder of its own (workers need no file
system shared with the client), sets ``controller.gait_files`` (the scenario's own plus
that file), ``controller.gait``, ``initial_stance`` if ``set_stance``, ``random_seed`` and
the point's overrides, and runs ``simulate.run``. Every failure is a result, never a raise:
status ``refused`` (the scenario's checks refused the candidate, e.g. its stance puts a fin
into the floor), ``failed`` (the simulation failed part-way; its metrics are kept) or
``error`` (any other exception).

An evaluator given to ``run_optimization(evaluate=...)`` in its place takes the same dict
and returns at least ``{"status": ..., "metrics": {short name: value}}``.
"""

from __future__ import annotations

import json
import os
import pathlib
import socket
import tempfile
import time
from typing import Any

import numpy as np

from manta_drake.config_io import ScenarioError
from manta_drake.optimize.objective import run_metrics
from manta_drake.scenario import load_scenario
from manta_drake.simulate import SimulationError, run
from manta_drake.sweep.plan import apply_overrides
from manta_drake.sweep.run import failure_reason


def worker_name() -> str:
    """The Dask worker's address, or ``host:pid`` outside a worker."""
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:{os.getpid()}"


def candidate_overrides(task: dict, gait_path: str | os.PathLike[str], gait_files) -> dict:
    """The overrides that make the base scenario run the candidate at the task's point."""
    overrides = dict(task.get("overrides") or {})
    overrides.update(
        {
            "controller.gait_files": [*gait_files, str(gait_path)],
            "controller.gait": task["gait_name"],
            "random_seed": int(task["seed"]),
        }
    )
    if task.get("set_stance"):
        overrides["initial_stance"] = task["gait_name"]
    return overrides


def joint_limits(scenario) -> np.ndarray:
    """(16, 2) joint limits [rad] in the plant's joint order (leg-major)."""
    per_type = np.asarray(scenario.robot_params().position_limits, dtype=float)
    return np.tile(per_type, (4, 1))


def simulate_candidate(task: dict) -> dict:
    """Simulates the task's candidate at its point (module docstring).

    Returns:
        ``{status, reason, metrics, run, log_npz, wall_time_s, worker}``: ``metrics`` the
        short metrics (``objective.run_metrics``), ``run`` the run's metrics.json, ``log_npz``
        the log's bytes (if ``keep_log`` and the run wrote one).
    """
    start = time.perf_counter()
    out: dict[str, Any] = {
        "status": "ok",
        "reason": "",
        "metrics": {},
        "run": {},
        "log_npz": None,
        "worker": worker_name(),
    }
    with tempfile.TemporaryDirectory(prefix="manta_opt_") as tmp_name:
        tmp = pathlib.Path(tmp_name)
        gait_path = tmp / "gait.yaml"
        gait_path.write_text(task["gait_text"])
        folder = tmp / "run"  # run() stages its files beside it: inside tmp too
        try:
            base = load_scenario(data=task["scenario_yaml"], validate=False)
            scenario = apply_overrides(
                base, candidate_overrides(task, gait_path, base.controller.gait_files)
            )
            scenario.visualization.meshcat = False
        except ScenarioError as e:
            out.update(status="refused", reason=" ".join(str(e).split()))
            scenario = None
        if scenario is not None:
            try:
                result = run(scenario, folder, progress=False, write_outputs=False)
                out["run"] = result.metrics
                out["metrics"] = run_metrics(result.metrics, result.log, joint_limits(scenario))
            except SimulationError as e:
                metrics: dict = (
                    json.loads((folder / "metrics.json").read_text())
                    if (folder / "metrics.json").is_file()
                    else {"status": "failed"}
                )
                out["run"] = metrics
                out["metrics"] = run_metrics(metrics)
                out.update(
                    status="failed",
                    reason=failure_reason(metrics.get("failure")) or " ".join(str(e).split()),
                )
            except Exception as e:  # noqa: BLE001 - a result, never a lost optimisation
                out.update(status="error", reason=f"{type(e).__name__}: {' '.join(str(e).split())}")
        if task.get("keep_log") and (folder / "log.npz").is_file():
            out["log_npz"] = (folder / "log.npz").read_bytes()
    out["touched_wall"] = bool(out["run"].get("touched_wall", False))
    out["wall_time_s"] = time.perf_counter() - start
    return out
