"""One run of a sweep, on a Dask worker or in this process: ``simulate_run`` takes the
resolved scenario's text and returns the metrics and the log; every failure is a record."""

from __future__ import annotations

import json
import math
import pathlib
import tempfile

from manta_drake.scenario import Scenario, load_scenario
from manta_drake.simulate import SimulationError, run


def simulate_run(scenario_yaml: str) -> dict:
    """Simulates one resolved scenario and returns what the client writes.

    Runs in a temporary folder on the worker, so workers need no shared file system with the
    client; every exception is caught and reported.

    Returns:
        ``{"metrics": dict (with status and reason), "log_npz": bytes or None}``. Status
        ``ok``; ``failed`` (SimulationError: the partial log and failure time are kept);
        ``error`` (any other exception, e.g. while building the diagram).
    """
    with tempfile.TemporaryDirectory(prefix="manta_run_") as tmp:
        out = pathlib.Path(tmp) / "run"  # run() stages its files beside it: inside tmp too
        metrics: dict = {}
        try:
            scenario = _load_scenario_text(scenario_yaml)
            scenario.visualization.meshcat = False
            metrics = run(scenario, out, progress=False, write_outputs=False).metrics
            metrics["reason"] = ""
        except SimulationError as e:
            metrics = (
                json.loads((out / "metrics.json").read_text())
                if (out / "metrics.json").is_file()
                else {"status": "failed"}
            )
            metrics["reason"] = failure_reason(metrics.get("failure")) or " ".join(str(e).split())
        except Exception as e:  # noqa: BLE001 - any failure is a row, never a lost sweep
            metrics = {
                "status": "error",
                "reason": f"{type(e).__name__}: {' '.join(str(e).split())}",
            }
        log = (out / "log.npz").read_bytes() if (out / "log.npz").is_file() else None
    metrics.setdefault("status", "error")
    return {"metrics": metrics, "log_npz": log}


def failure_reason(failure: dict | None) -> str:
    """One line from simulate's failure record (not from the exception's text, which names
    the worker's temporary folder)."""
    if not failure:
        return ""
    reason = " ".join(str(failure.get("reason", "")).split())
    if failure.get("stage") == "build":
        return f"building the diagram failed: {reason}"
    return f"simulation failed at t = {failure.get('time_s', math.nan):.3f} s: {reason}"


def _load_scenario_text(text: str) -> Scenario:
    return load_scenario(data=text)
