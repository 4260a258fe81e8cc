"""One simulation of a calibration, on a Dask worker or in this process:
``simulate_trajectory`` returns the body's trajectory and mean velocities."""

from __future__ import annotations

import math
import pathlib
import tempfile

import numpy as np
from pydrake.common.yaml import yaml_load_typed

from manta_drake.scenario import Scenario
from manta_drake.simulate import SimulationError, run


def simulate_trajectory(scenario_yaml: str, period: float = 0.01) -> dict:
    """Simulates a resolved scenario (on a worker) and returns its trajectory and metrics.

    Returns:
        ``{status, reason, t, x, y, z, yaw, u, v, yaw_rate_deg_s}``: the body's trajectory
        every ``period`` s (yaw unwrapped, rad) and the mean velocities; a failed run keeps
        its trajectory up to the failure.
    """
    out: dict[str, object] = {"status": "ok", "reason": ""}
    log, metrics = None, {}
    with tempfile.TemporaryDirectory(prefix="manta_cal_") as tmp:
        folder = pathlib.Path(tmp) / "run"  # run() stages its files beside it: inside tmp
        try:
            scenario = yaml_load_typed(schema=Scenario, data=scenario_yaml).validate()
            result = run(scenario, folder, progress=False, write_outputs=False)
            log, metrics = result.log, result.metrics
        except SimulationError as e:
            out.update(status="failed", reason=" ".join(str(e).split()))
            if (folder / "log.npz").is_file():  # not after a failed build
                with np.load(folder / "log.npz") as npz:
                    log = {k: npz[k] for k in ("t", "body_xyz", "body_rpy") if k in npz}
        except Exception as e:  # noqa: BLE001 - reported; the optimiser sees a large residual
            out.update(status="error", reason=f"{type(e).__name__}: {' '.join(str(e).split())}")
    if log is not None and len(log.get("t", [])) and "body_xyz" in log:
        t = np.asarray(log["t"])
        stride = max(1, int(round(period / (t[1] - t[0])))) if len(t) > 1 else 1
        idx = np.unique(np.r_[np.arange(0, len(t), stride), len(t) - 1])
        out.update(
            t=t[idx],
            x=log["body_xyz"][idx, 0],
            y=log["body_xyz"][idx, 1],
            z=log["body_xyz"][idx, 2],
            yaw=np.unwrap(log["body_rpy"][:, 2])[idx],
        )
    # None when the run has no steady window long enough for a mean (simulate.compute_metrics).
    u_v = metrics.get("mean_velocity_body") or [math.nan, math.nan]
    yaw_rate = metrics.get("yaw_rate_deg_s")
    out.update(u=u_v[0], v=u_v[1], yaw_rate_deg_s=math.nan if yaw_rate is None else yaw_rate)
    return out
