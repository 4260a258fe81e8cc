"""The evaluator: the residuals of parameter vectors, each batch of points simulated in
parallel on Dask (one task per point and experiment), cached by point; and the
forward-difference points of the Jacobian."""

from __future__ import annotations

import hashlib
import math
import sys
import time

import numpy as np

from manta_drake.calibrate.config import CalibrationConfig
from manta_drake.calibrate.loading import experiment_measured
from manta_drake.calibrate.residuals import target_residuals, trajectory_residuals
from manta_drake.calibrate.run import simulate_trajectory
from manta_drake.calibrate.scenarios import experiment_scenario, parameter_scales, scenario_text
from manta_drake.cluster import TaskFailure, completed_resubmitting_lost


class Evaluator:
    """Residuals of parameter vectors; each batch of points is simulated in parallel.

    Every (point, experiment) is one task; results are cached by point, so the optimiser's
    repeated points cost nothing. A task the cluster lost (its worker died) is submitted
    again, up to ``cluster.ATTEMPTS`` times. ``history`` records every evaluated point.
    """

    def __init__(self, config: CalibrationConfig, client=None, progress: bool = True):
        self.config = config
        self.client = client
        self.cache: dict[tuple, dict] = {}
        self.history: list[dict] = []
        self.simulations = 0
        self.measured = {
            e.name: experiment_measured(config, e) for e in config.experiments if e.measured
        }
        self._bar = None
        if progress:
            from tqdm import tqdm

            self._bar = tqdm(
                unit="sim", desc=f"calibrating {config.name}", file=sys.stderr, dynamic_ncols=True
            )

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()

    @staticmethod
    def key(x) -> tuple:
        """The point as simulated and cached: 10 significant digits. Near convergence
        least_squares proposes steps of ~1e-12, which change nothing but would cost a batch."""
        return tuple(float(f"{v:.10g}") for v in np.asarray(x, dtype=float))

    def _tasks(self, x) -> list[str]:
        scales = parameter_scales(self.config, x)
        return [
            scenario_text(experiment_scenario(self.config, e, scales))
            for e in self.config.experiments
        ]

    def simulate(self, points, kinds) -> list[dict]:
        """Simulations of every experiment at every point not cached yet (one batch), then
        each point's ``{x, residuals, cost, experiment_cost, runs}``.

        Args:
            points: parameter vectors.
            kinds: per point, what it is for the history (``point``: one least_squares
                evaluates; ``difference``: a finite-difference neighbour).
        """
        kind_of: dict[tuple, str] = {}
        for p, kind in zip(points, kinds):
            kind_of.setdefault(self.key(p), kind)
        new = [x for x in kind_of if x not in self.cache]
        jobs = [(x, i, text) for x in new for i, text in enumerate(self._tasks(x))]
        results: dict[tuple, dict] = {}
        start = time.perf_counter()
        if self.client is None:
            for x, i, text in jobs:
                results[(x, i)] = simulate_trajectory(text)
                self._tick()
        else:
            # simulate_trajectory returns its failures: an exception is the cluster's.
            for job, outcome in completed_resubmitting_lost(
                self.client,
                simulate_trajectory,
                jobs,
                lambda job: job[2],
                lambda job: f"manta-cal-{_digest(job[2])}",
            ):
                if isinstance(outcome, TaskFailure):
                    outcome = {
                        "status": "error",
                        "reason": f"{type(outcome.error).__name__}: {outcome.error}",
                    }
                results[job[:2]] = outcome
                self._tick()
        self.simulations += len(jobs)
        wall = time.perf_counter() - start
        for x in new:
            runs = [results[(x, i)] for i in range(len(self.config.experiments))]
            self.cache[x] = self._score(x, runs)
            self.history.append(
                {
                    "evaluation": len(self.history),
                    "kind": kind_of[x],
                    "x": list(x),
                    "cost": self.cache[x]["cost"],
                    "experiment_cost": self.cache[x]["experiment_cost"],
                    "status": [r["status"] for r in runs],
                    "batch_wall_time_s": wall,
                    "batch_simulations": len(jobs),
                }
            )
        return [self.cache[self.key(p)] for p in points]

    def _tick(self) -> None:
        if self._bar is not None:
            self._bar.update(1)

    def _score(self, x: tuple, runs: list[dict]) -> dict:
        parts, costs = [], {}
        for e, sim in zip(self.config.experiments, runs):
            r = np.empty(0)
            if e.measured:
                r = trajectory_residuals(self.measured[e.name], sim, e.columns, self.config.sigma)
            if e.target:
                r = np.concatenate([r, target_residuals(e.target, sim, self.config.sigma)])
            r = math.sqrt(e.weight) * r
            costs[e.name] = 0.5 * float(r @ r)
            parts.append(r)
        residuals = np.concatenate(parts)
        return {
            "x": list(x),
            "residuals": residuals,
            "cost": 0.5 * float(residuals @ residuals),
            "experiment_cost": costs,
            "runs": runs,
        }

    def residuals(self, x, bounds=None, diff_step: float = 0.0) -> np.ndarray:
        """Residuals at x; with ``diff_step``, x's finite-difference points join the batch."""
        points = [x]
        if diff_step and self.key(x) not in self.cache:
            points += fd_points(x, bounds, diff_step)[1]
        return self.simulate(points, ["point"] + ["difference"] * (len(points) - 1))[0]["residuals"]

    def jacobian(self, x, bounds, diff_step: float) -> np.ndarray:
        """Forward differences; the n perturbed points (and x) form one parallel batch."""
        steps, points = fd_points(x, bounds, diff_step)
        evaluated = self.simulate([x] + points, ["point"] + ["difference"] * len(points))
        f0 = evaluated[0]["residuals"]
        return np.column_stack([(e["residuals"] - f0) / h for e, h in zip(evaluated[1:], steps)])


def fd_points(x, bounds, diff_step: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """Forward-difference steps and points of x: h_i = diff_step * max(|x_i|, 1e-3), turned
    backwards where x_i + h_i would leave the upper bound."""
    x = np.asarray(x, dtype=float)
    steps = diff_step * np.maximum(np.abs(x), 1e-3)
    if bounds is not None:
        steps = np.where(x + steps > bounds[1], -steps, steps)
    return steps, [x + np.eye(len(x))[i] * steps[i] for i in range(len(x))]


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]
