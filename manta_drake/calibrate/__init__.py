"""Sim2Real calibration on Dask: ``manta-drake calibrate CALIBRATION.yaml --out DIR``.

The paper tuned Webots' damping by running the simulator again and again until it moved like
the robot. This is that loop, automated: named *parameters*, each a factor on one or more
hydrodynamic coefficients (``body.linear_damping``, or a lumped hull damping that multiplies
``body.linear_damping`` and ``body.quadratic_damping`` together), are fitted with
``scipy.optimize.least_squares`` so that simulated runs match measured ones:

* a trajectory: a CSV with columns ``t, x, y, z, yaw`` (s, m in the pool's world frame of
  the scenario, yaw in rad), compared sample by sample; or
* target mean velocities (``u``, ``v`` [m/s], ``yaw_rate_deg_s``), compared with the run's
  metrics.

Residuals are divided by ``sigma`` (the measurement's standard deviation), so the cost is a
sum of squared standard scores. The Jacobian is by forward differences, its n + 1
simulations per experiment submitted together: every point of an iteration is simulated in
parallel on the Dask cluster (one task per simulation, ``Client.submit``).

Outputs in ``--out DIR``: ``coefficients.yaml`` (the whole coefficients file, same format as
``models/hydrodynamics.yaml``; the calibrated entries' ``source`` says what they were fitted
to), ``calibration.png`` (measured against simulated before and after) and
``calibration.json`` (every evaluation, the iterations, the result). Use the file with
``water: {coefficients: DIR/coefficients.yaml}``.

Example (diagrams/sweeps/calibration.yaml)::

    name: hull_damping
    coefficients: package://manta_drake/hydrodynamics.yaml   # the prior
    parameters:
      - {name: hull_linear, coefficients: [body.linear_damping], bounds: [0.3, 3.0]}
      - {name: hull_quadratic, coefficients: [body.quadratic_damping], bounds: [0.3, 3.0]}
    experiments:
      - {name: swim, scenario: locomotion_swim, overrides: {duration: 8.0},
         measured: data/swim.csv}
      - {name: walk, scenario: locomotion_walk, target: {u: 0.07}}
    sigma: {position_m: 0.003, yaw_deg: 0.3}
    optimizer: {max_evaluations: 12, diff_step: 0.05}
"""

from __future__ import annotations

import dataclasses as dc
import functools
import hashlib
import json
import math
import pathlib
import sys
import tempfile
import time
from typing import Any

import numpy as np
import yaml

from manta_drake.model import resolve_path
from manta_drake.scenario import Scenario, ScenarioError, coefficient_names, load_scenario
from manta_drake.sweep import (
    SweepError,
    add_cluster_arguments,
    apply_overrides,
    cluster_client,
    check_config_keys,
    check_parameter_name,
    read_yaml_mapping,
)

TRAJECTORY_COLUMNS = ("x", "y", "z", "yaw")
TARGET_KEYS = ("u", "v", "yaw_rate_deg_s")
# Residual (in standard scores) of a sample a failed simulation did not reach: large, so the
# optimiser steps away, but finite, so least_squares keeps going.
FAILED_RESIDUAL = 100.0


# --- configuration ---------------------------------------------------------------------------

@dc.dataclass
class CalibrationParameter:
    """A fitted factor that multiplies the named coefficients (all by the same factor)."""

    name: str = ""
    coefficients: list[str] = dc.field(default_factory=list)
    initial: float = 1.0
    bounds: list[float] = dc.field(default_factory=lambda: [0.2, 5.0])


@dc.dataclass
class Experiment:
    """One measured run: a scenario (with overrides) and its measurement.

    ``measured``: a CSV (t, x, y, z, yaw) relative to the calibration file; ``columns``
    says which of x, y, z, yaw enter the fit. ``target``: mean velocities instead (or too).
    """

    name: str = ""
    scenario: str = ""
    overrides: dict[str, Any] = dc.field(default_factory=dict)
    measured: str = ""
    columns: list[str] = dc.field(default_factory=lambda: list(TRAJECTORY_COLUMNS))
    target: dict[str, float] = dc.field(default_factory=dict)
    weight: float = 1.0


@dc.dataclass
class Sigma:
    """Standard deviations that turn residuals into standard scores."""

    position_m: float = 0.005
    yaw_deg: float = 0.5
    velocity_m_s: float = 0.002
    yaw_rate_deg_s: float = 0.2


@dc.dataclass
class OptimizerConfig:
    """scipy.optimize.least_squares settings."""

    method: str = "trf"  # trf or dogbox (both take bounds)
    max_evaluations: int = 12  # least_squares' max_nfev: points, not counting the Jacobian's
    diff_step: float = 0.05  # forward-difference step, relative to the parameter
    xtol: float = 1e-3
    ftol: float = 1e-4
    gtol: float = 1e-6
    # Simulate a new point's finite-difference neighbours in the same batch as the point: the
    # Jacobian is needed whenever the step is accepted, and the batch keeps more workers busy
    # (wasted only when least_squares rejects the step).
    speculative_jacobian: bool = True


@dc.dataclass
class CalibrationConfig:
    """A calibration file (see the module docstring and docs/sweeps.md)."""

    name: str = ""
    description: str = ""
    coefficients: str = "package://manta_drake/hydrodynamics.yaml"  # the prior
    seed: int = 0  # random_seed of every simulation
    parameters: list[CalibrationParameter] = dc.field(default_factory=list)
    experiments: list[Experiment] = dc.field(default_factory=list)
    sigma: Sigma = dc.field(default_factory=Sigma)
    optimizer: OptimizerConfig = dc.field(default_factory=OptimizerConfig)
    folder: pathlib.Path = dc.field(default=pathlib.Path("."), repr=False)  # not in the file

    def coefficients_path(self) -> str:
        """The prior coefficients file as a scenario names it (package URL or absolute)."""
        if self.coefficients.startswith("package://"):
            return self.coefficients
        return str((self.folder / self.coefficients).resolve())


def load_calibration(path, require_data: bool = True) -> CalibrationConfig:
    """Loads and checks a calibration file and its measured CSVs; simulates nothing.

    Args:
        path: the calibration YAML file.
        require_data: check the measured CSVs (False: they may not exist yet, as when
            ``synthesize_measurements`` is about to make them).

    Raises:
        SweepError: an unknown key, a wrong type or range, a coefficient or scenario key that
            does not exist, or a measured file that is missing or malformed; the message
            names the path in the file (``calibration.experiments[0].measured``).
    """
    path = pathlib.Path(path)
    data = read_yaml_mapping(path, "calibration")
    check_config_keys(data, CalibrationConfig, "calibration")
    config = CalibrationConfig(
        name=data.get("name") or path.stem,
        description=data.get("description", ""),
        coefficients=data.get("coefficients", CalibrationConfig.coefficients),
        seed=data.get("seed", 0),
        parameters=[CalibrationParameter(**p) for p in data.get("parameters") or []],
        experiments=[Experiment(**e) for e in data.get("experiments") or []],
        sigma=Sigma(**(data.get("sigma") or {})),
        optimizer=OptimizerConfig(**(data.get("optimizer") or {})),
        folder=path.resolve().parent,
    )
    validate_calibration(config, require_data)
    return config


def _positive(where: str, value) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise SweepError(f"{where}: {value!r} must be a finite number > 0")


def validate_calibration(config: CalibrationConfig, require_data: bool = True) -> None:
    """Checks names, ranges and files of a calibration (values of overrides per scenario)."""
    from manta_drake.model.coefficients import load_coefficients

    try:
        load_coefficients(resolve_path(config.coefficients_path()))
    except ScenarioError as e:
        raise SweepError(f"calibration.coefficients: {e}") from None
    if not 0 <= config.seed < 2**32:
        raise SweepError(f"calibration.seed: {config.seed} is outside [0, 2^32)")
    if not config.parameters:
        raise SweepError("calibration.parameters: name at least one parameter")
    seen_params, seen_coeffs = set(), {}
    for i, p in enumerate(config.parameters):
        where = f"calibration.parameters[{i}]"
        if not p.name or p.name in seen_params:
            raise SweepError(f"{where}.name: {p.name!r} is empty or used twice")
        seen_params.add(p.name)
        if not p.coefficients:
            raise SweepError(f"{where}.coefficients: name at least one coefficient")
        for c in p.coefficients:
            if c not in coefficient_names():
                raise SweepError(f"{where}.coefficients: unknown coefficient {c!r}; allowed: "
                                 f"{', '.join(coefficient_names())}")
            if c in seen_coeffs:
                raise SweepError(f"{where}.coefficients: {c} is also fitted by "
                                 f"{seen_coeffs[c]}")
            seen_coeffs[c] = p.name
        if len(p.bounds) != 2 or not 0 <= p.bounds[0] < p.bounds[1] \
                or not math.isfinite(p.bounds[1]):
            raise SweepError(f"{where}.bounds: expected [low, high] with 0 <= low < high, "
                             f"got {p.bounds}")
        if not p.bounds[0] < p.initial < p.bounds[1]:
            raise SweepError(f"{where}.initial: {p.initial} must be strictly inside the "
                             f"bounds {p.bounds}")
    if not config.experiments:
        raise SweepError("calibration.experiments: name at least one experiment")
    names = set()
    for i, e in enumerate(config.experiments):
        where = f"calibration.experiments[{i}]"
        if not e.name or e.name in names:
            raise SweepError(f"{where}.name: {e.name!r} is empty or used twice")
        names.add(e.name)
        try:
            _base_scenario(config.folder, e.scenario)
        except ScenarioError as err:
            raise SweepError(f"{where}.scenario: {err}") from None
        for key in e.overrides:
            check_parameter_name(key, {}, f"{where}.overrides.{key}")
            if key in ("random_seed", "water.coefficients"):
                raise SweepError(f"{where}.overrides.{key}: set by the calibration file "
                                 "(seed, coefficients)")
        if not e.measured and not e.target:
            raise SweepError(f"{where}: give `measured` (a CSV) or `target` (mean velocities)")
        if e.measured:
            bad = [c for c in e.columns if c not in TRAJECTORY_COLUMNS]
            if bad or not e.columns:
                raise SweepError(f"{where}.columns: {e.columns} must be some of "
                                 f"{', '.join(TRAJECTORY_COLUMNS)}")
            if require_data:
                load_measured(config.folder / e.measured, e.columns, f"{where}.measured")
        for key in e.target:
            if key not in TARGET_KEYS:
                raise SweepError(f"{where}.target.{key}: not one of {', '.join(TARGET_KEYS)}")
        _positive(f"{where}.weight", e.weight)
    for f in dc.fields(Sigma):
        _positive(f"calibration.sigma.{f.name}", getattr(config.sigma, f.name))
    o = config.optimizer
    if o.method not in ("trf", "dogbox"):
        raise SweepError(f"calibration.optimizer.method: {o.method!r} is not one of trf, dogbox")
    if o.max_evaluations < 1:
        raise SweepError(f"calibration.optimizer.max_evaluations: {o.max_evaluations} must be "
                         ">= 1")
    if not 0 < o.diff_step < 0.5:
        raise SweepError(f"calibration.optimizer.diff_step: {o.diff_step} must be in (0, 0.5)")
    for name in ("xtol", "ftol", "gtol"):
        _positive(f"calibration.optimizer.{name}", getattr(o, name))


def load_measured(path, columns=TRAJECTORY_COLUMNS, where: str = "measured") -> dict:
    """A measured trajectory CSV as arrays ``t`` and the named columns.

    Raises:
        SweepError: missing file or column, non-numeric or non-finite values, or times that
            do not increase.
    """
    path = pathlib.Path(path)
    if not path.is_file():
        raise SweepError(f"{where}: file not found: {path}")
    import csv

    with open(path, newline="") as f:
        lines = [line for line in f if line.strip() and not line.lstrip().startswith("#")]
    rows = list(csv.reader(lines))
    header = [c.strip() for c in rows[0]] if rows else []
    for col in ("t", *columns):
        if col not in header:
            raise SweepError(f"{where}: {path} has no column {col!r} (header: "
                             f"{', '.join(header) or 'none'})")
    out = {}
    for col in ("t", *columns):
        j = header.index(col)
        try:
            out[col] = np.array([float(r[j]) for r in rows[1:]], dtype=float)
        except (ValueError, IndexError):
            bad = next(i for i, r in enumerate(rows[1:]) if not _is_number(r, j))
            raise SweepError(f"{where}: {path}: data row {bad + 1}: column {col} is missing "
                             "or not a number") from None
    for col, values in out.items():
        if not np.all(np.isfinite(values)):
            raise SweepError(f"{where}: {path}: column {col} has empty or non-finite values")
    if len(out["t"]) < 2 or np.any(np.diff(out["t"]) <= 0):
        raise SweepError(f"{where}: {path}: t must increase, with at least two samples")
    return out


# --- from parameters to scenarios ------------------------------------------------------------

def _is_number(row, j) -> bool:
    try:
        float(row[j])
        return True
    except (ValueError, IndexError):
        return False


def parameter_scales(config: CalibrationConfig, x) -> dict[str, float]:
    """Coefficient name -> factor for a parameter vector ``x`` (in the order of the file)."""
    return {c: float(v) for p, v in zip(config.parameters, x) for c in p.coefficients}


@functools.lru_cache(maxsize=32)
def _base_scenario(folder: pathlib.Path, name: str) -> Scenario:
    candidate = folder / name
    return load_scenario(candidate if candidate.is_file() else name)


def experiment_scenario(config: CalibrationConfig, experiment: Experiment,
                        scales: dict[str, float]) -> Scenario:
    """The experiment's scenario with the prior coefficients file, the calibration's seed and
    the coefficient ``scales`` (multiplying any the experiment sets itself)."""
    overrides = {**experiment.overrides, "water.coefficients": config.coefficients_path(),
                 "random_seed": config.seed}
    scenario = apply_overrides(_base_scenario(config.folder, experiment.scenario), overrides)
    merged = dict(scenario.water.coefficient_scales)
    for name, factor in scales.items():
        merged[name] = merged.get(name, 1.0) * factor
    scenario.water.coefficient_scales = merged
    scenario.visualization.meshcat = False
    return scenario.validate()


def simulate_trajectory(scenario_yaml: str, period: float = 0.01) -> dict:
    """Simulates a resolved scenario (on a worker) and returns its trajectory and metrics.

    Returns:
        ``{status, reason, t, x, y, z, yaw, u, v, yaw_rate_deg_s}``: the body's trajectory
        every ``period`` s (yaw unwrapped, rad) and the mean velocities; a failed run keeps
        its trajectory up to the failure.
    """
    from pydrake.common.yaml import yaml_load_typed

    from manta_drake.simulate import SimulationError, run

    out = {"status": "ok", "reason": ""}
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
        except Exception as e:  # reported; the optimiser sees a large residual
            out.update(status="error", reason=f"{type(e).__name__}: {' '.join(str(e).split())}")
    if log is not None and len(log.get("t", [])) and "body_xyz" in log:
        t = np.asarray(log["t"])
        stride = max(1, int(round(period / (t[1] - t[0])))) if len(t) > 1 else 1
        idx = np.unique(np.r_[np.arange(0, len(t), stride), len(t) - 1])
        out.update(t=t[idx], x=log["body_xyz"][idx, 0], y=log["body_xyz"][idx, 1],
                   z=log["body_xyz"][idx, 2], yaw=np.unwrap(log["body_rpy"][:, 2])[idx])
    # None when the run has no steady window long enough for a mean (simulate.compute_metrics).
    u_v = metrics.get("mean_velocity_body") or [math.nan, math.nan]
    yaw_rate = metrics.get("yaw_rate_deg_s")
    out.update(u=u_v[0], v=u_v[1], yaw_rate_deg_s=math.nan if yaw_rate is None else yaw_rate)
    return out


# --- residuals -------------------------------------------------------------------------------

def trajectory_residuals(measured: dict, simulated: dict, columns, sigma: Sigma) -> np.ndarray:
    """Standard scores (simulated - measured) / sigma at the measured times, column after
    column; yaw differences wrapped to (-pi, pi]. Samples the simulation did not reach (it
    failed, or was shorter) score ``FAILED_RESIDUAL``."""
    t = measured["t"]
    sim_t = np.asarray(simulated.get("t", []), dtype=float)
    reached = t <= (sim_t[-1] + 1e-9 if len(sim_t) else -np.inf)
    parts = []
    for col in columns:
        r = np.full(len(t), FAILED_RESIDUAL)
        if reached.any():
            sim = np.interp(t[reached], sim_t, simulated[col])
            diff = sim - measured[col][reached]
            if col == "yaw":
                r[reached] = np.angle(np.exp(1j * diff)) / math.radians(sigma.yaw_deg)
            else:
                r[reached] = diff / sigma.position_m
        parts.append(r)
    return np.concatenate(parts)


def target_residuals(target: dict, simulated: dict, sigma: Sigma) -> np.ndarray:
    """Standard scores of the mean-velocity targets (``FAILED_RESIDUAL`` where missing)."""
    scale = {"u": sigma.velocity_m_s, "v": sigma.velocity_m_s,
             "yaw_rate_deg_s": sigma.yaw_rate_deg_s}
    out = []
    for key, want in target.items():
        got = simulated.get(key, math.nan)
        out.append((got - want) / scale[key] if math.isfinite(got) else FAILED_RESIDUAL)
    return np.asarray(out, dtype=float)


# --- the evaluator: batches of simulations on Dask -------------------------------------------

class Evaluator:
    """Residuals of parameter vectors; each batch of points is simulated in parallel.

    Every (point, experiment) is one task; results are cached by point, so the optimiser's
    repeated points cost nothing. ``history`` records every evaluated point.
    """

    def __init__(self, config: CalibrationConfig, client=None, progress: bool = True):
        self.config = config
        self.client = client
        self.cache: dict[tuple, dict] = {}
        self.history: list[dict] = []
        self.simulations = 0
        self.measured = {e.name: load_measured(config.folder / e.measured, e.columns)
                         for e in config.experiments if e.measured}
        self._bar = None
        if progress:
            from tqdm import tqdm

            self._bar = tqdm(unit="sim", desc=f"calibrating {config.name}", file=sys.stderr,
                             dynamic_ncols=True)

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
        return [_dump(experiment_scenario(self.config, e, scales))
                for e in self.config.experiments]

    def simulate(self, points, kinds) -> list[dict]:
        """Simulations of every experiment at every point not cached yet (one batch), then
        each point's ``{x, residuals, cost, experiment_cost, runs}``.

        Args:
            points: parameter vectors.
            kinds: per point, what it is for the history (``point``: one least_squares
                evaluates; ``difference``: a finite-difference neighbour).
        """
        kind_of = {}
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
            from distributed import as_completed

            futures = {self.client.submit(simulate_trajectory, text, pure=False,
                                          key=f"manta-cal-{_digest(text)}"): (x, i)
                       for x, i, text in jobs}
            for future in as_completed(futures):
                try:
                    results[futures[future]] = future.result()
                except Exception as e:  # e.g. the worker died: a failed simulation
                    results[futures[future]] = {"status": "error",
                                                "reason": f"{type(e).__name__}: {e}"}
                future.release()
                self._tick()
        self.simulations += len(jobs)
        wall = time.perf_counter() - start
        for x in new:
            runs = [results[(x, i)] for i in range(len(self.config.experiments))]
            self.cache[x] = self._score(x, runs)
            self.history.append({
                "evaluation": len(self.history), "kind": kind_of[x], "x": list(x),
                "cost": self.cache[x]["cost"], "experiment_cost": self.cache[x]["experiment_cost"],
                "status": [r["status"] for r in runs], "batch_wall_time_s": wall,
                "batch_simulations": len(jobs)})
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
        return {"x": list(x), "residuals": residuals, "cost": 0.5 * float(residuals @ residuals),
                "experiment_cost": costs, "runs": runs}

    def residuals(self, x, bounds=None, diff_step: float = 0.0) -> np.ndarray:
        """Residuals at x; with ``diff_step``, x's finite-difference points join the batch."""
        points = [x]
        if diff_step and self.key(x) not in self.cache:
            points += fd_points(x, bounds, diff_step)[1]
        return self.simulate(points, ["point"] + ["difference"] * (len(points) - 1))[0][
            "residuals"]

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


def _dump(scenario: Scenario) -> str:
    from pydrake.common.yaml import yaml_dump_typed

    return yaml_dump_typed(scenario)


def _digest(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()[:16]


# --- the calibration -------------------------------------------------------------------------

@dc.dataclass
class CalibrationResult:
    """What ``calibrate`` returns."""

    x: np.ndarray  # fitted parameters, in the file's order
    x0: np.ndarray
    names: list[str]
    cost: float
    initial_cost: float
    standard_error: np.ndarray  # from the final Jacobian (nan where not identifiable)
    success: bool
    message: str
    evaluations: int  # points simulated (each = one run per experiment)
    simulations: int
    wall_time_s: float
    coefficients_file: pathlib.Path | None = None
    figure: pathlib.Path | None = None
    history_file: pathlib.Path | None = None

    def fitted(self) -> dict[str, float]:
        return dict(zip(self.names, map(float, self.x)))


def calibrate(config: CalibrationConfig, out_dir=None, client=None,
              progress: bool = True) -> CalibrationResult:
    """Fits the parameters with ``scipy.optimize.least_squares`` and writes the outputs.

    Args:
        config: a loaded calibration.
        out_dir: where to write coefficients.yaml, calibration.png and calibration.json
            (None: write nothing).
        client: a ``distributed.Client`` (each simulation a task), or None: in this process.
        progress: a tqdm bar counting simulations.
    """
    from scipy.optimize import least_squares

    start = time.perf_counter()
    evaluator = Evaluator(config, client, progress)
    x0 = np.array([p.initial for p in config.parameters], dtype=float)
    lower = np.array([p.bounds[0] for p in config.parameters], dtype=float)
    upper = np.array([p.bounds[1] for p in config.parameters], dtype=float)
    o = config.optimizer
    try:
        speculate = o.diff_step if o.speculative_jacobian else 0.0
        result = least_squares(
            lambda x: evaluator.residuals(x, (lower, upper), speculate), x0,
            jac=lambda x, *_: evaluator.jacobian(x, (lower, upper), o.diff_step),
            bounds=(lower, upper), method=o.method, max_nfev=o.max_evaluations,
            xtol=o.xtol, ftol=o.ftol, gtol=o.gtol)
    finally:
        evaluator.close()
    final = evaluator.cache[evaluator.key(result.x)] if evaluator.key(result.x) in \
        evaluator.cache else evaluator.simulate([result.x], ["point"])[0]
    initial = evaluator.cache[evaluator.key(x0)]
    out = CalibrationResult(
        x=np.asarray(result.x), x0=x0, names=[p.name for p in config.parameters],
        cost=final["cost"], initial_cost=initial["cost"],
        standard_error=standard_errors(result.jac, final["residuals"]),
        success=bool(result.success), message=str(result.message),
        evaluations=len(evaluator.history), simulations=evaluator.simulations,
        wall_time_s=time.perf_counter() - start)
    if out_dir is not None:
        out_dir = pathlib.Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        out.coefficients_file = write_calibrated_coefficients(
            out_dir / "coefficients.yaml", config, out)
        out.history_file = write_history(out_dir / "calibration.json", config, out, evaluator,
                                         result)
        out.figure = write_calibration_figure(out_dir / "calibration.png", config, evaluator,
                                              initial, final, out)
    return out


def standard_errors(jac, residuals) -> np.ndarray:
    """Standard errors of the fitted parameters from the Jacobian of standard scores:
    sqrt(diag((J^T J)^-1) * s^2), s^2 = the residuals' variance (m - n degrees of freedom);
    nan where J^T J is singular (a parameter the data do not determine)."""
    J = np.asarray(jac, dtype=float)
    m, n = J.shape
    s2 = float(residuals @ residuals) / max(m - n, 1)
    try:
        cov = np.linalg.inv(J.T @ J) * s2
    except np.linalg.LinAlgError:
        return np.full(n, math.nan)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def calibrated_sources(config: CalibrationConfig, result: CalibrationResult) -> dict[str, str]:
    """The ``source`` text of each calibrated coefficient: what it was fitted to and how."""
    fitted_to = ", ".join(f"{e.name} ({e.measured or 'target ' + json.dumps(e.target)})"
                          for e in config.experiments)
    out = {}
    for p, value, se in zip(config.parameters, result.x, result.standard_error):
        for c in p.coefficients:
            out[c] = (f"calibrated (Sim2Real, manta-drake calibrate {config.name}): x{value:.4g} "
                      f"(+- {se:.2g}) of the prior by parameter {p.name}, fitted to {fitted_to} "
                      f"with scipy least_squares, cost {result.initial_cost:.4g} -> "
                      f"{result.cost:.4g}")
    return out


def write_calibrated_coefficients(path: pathlib.Path, config: CalibrationConfig,
                                  result: CalibrationResult) -> pathlib.Path:
    """The prior coefficients with the fitted scales, same format as hydrodynamics.yaml
    (every entry ``{value, source}``); calibrated sources say what they were fitted to and
    keep the prior's value and source."""
    from manta_drake.model.coefficients import load_coefficients, scale_coefficients

    prior = load_coefficients(resolve_path(config.coefficients_path()))
    coeffs = scale_coefficients(prior, parameter_scales(config, result.x))
    entries, prior_entries = dict(coeffs.entries()), dict(prior.entries())
    for name, text in calibrated_sources(config, result).items():
        entries[name].source = f"{text}; prior value {prior_entries[name].value}: " \
                               f"{prior_entries[name].source}"
    header = (f"# Hydrodynamic coefficients calibrated by `manta-drake calibrate` "
              f"({config.name}) from {config.coefficients}.\n"
              "# Same format as models/hydrodynamics.yaml; use it with "
              "water: {coefficients: <this file>}.\n")
    text = yaml.safe_dump(_plain(dc.asdict(coeffs)), sort_keys=False, width=100)
    path.write_text(header + text)
    return path


def _plain(value):
    """Numpy scalars and tuples as plain YAML types."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_history(path: pathlib.Path, config: CalibrationConfig, result: CalibrationResult,
                  evaluator: Evaluator, scipy_result) -> pathlib.Path:
    """calibration.json: the result, the parameters and every evaluation."""
    doc = {
        "name": config.name,
        "prior": config.coefficients,
        "experiments": [dc.asdict(e) for e in config.experiments],
        "parameters": [{"name": p.name, "coefficients": p.coefficients, "initial": p.initial,
                        "bounds": p.bounds, "fitted": float(x), "standard_error": float(se)}
                       for p, x, se in zip(config.parameters, result.x, result.standard_error)],
        "initial_cost": result.initial_cost,
        "cost": result.cost,
        "success": result.success,
        "message": result.message,
        "optimizer": dc.asdict(config.optimizer),
        "scipy": {"nfev": int(scipy_result.nfev), "njev": int(scipy_result.njev or 0),
                  "status": int(scipy_result.status)},
        "evaluations": result.evaluations,
        "simulations": result.simulations,
        "wall_time_s": result.wall_time_s,
        "history": evaluator.history,
    }
    path.write_text(json.dumps(doc, indent=2, default=_json_default) + "\n")
    return path


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def write_calibration_figure(path: pathlib.Path, config: CalibrationConfig,
                             evaluator: Evaluator, initial: dict, final: dict,
                             result: CalibrationResult) -> pathlib.Path:
    """calibration.png: per experiment the measured trajectory (or targets) against the
    simulated ones before and after; the last row the cost and parameters per evaluation."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(config.experiments)
    fig, axes = plt.subplots(n + 1, 3, figsize=(12, 3.0 * (n + 1)), squeeze=False)
    styles = (("initial", initial, dict(color="tab:orange", ls="--")),
              ("calibrated", final, dict(color="tab:blue")))
    for row, e in enumerate(config.experiments):
        ax_path, ax_z, ax_yaw = axes[row]
        if e.measured:
            full = load_measured(config.folder / e.measured, [c for c in TRAJECTORY_COLUMNS
                                 if c in _header(config.folder / e.measured)])
            if "x" in full and "y" in full:
                ax_path.plot(full["x"], full["y"], "k.", ms=3, label="measured")
            if "z" in full:
                ax_z.plot(full["t"], full["z"], "k.", ms=3, label="measured")
            if "yaw" in full:
                ax_yaw.plot(full["t"], np.degrees(full["yaw"]), "k.", ms=3, label="measured")
            for label, ev, style in styles:
                sim = ev["runs"][row]
                if "t" not in sim:
                    continue
                ax_path.plot(sim["x"], sim["y"], label=label, **style)
                ax_z.plot(sim["t"], sim["z"], label=label, **style)
                ax_yaw.plot(sim["t"], np.degrees(sim["yaw"]), label=label, **style)
            ax_path.set(xlabel="x [m]", ylabel="y [m]", title=f"{e.name}: top view")
            ax_path.axis("equal")
            ax_z.set(xlabel="t [s]", ylabel="z [m]", title=f"{e.name}: depth")
            ax_yaw.set(xlabel="t [s]", ylabel="yaw [deg]", title=f"{e.name}: heading")
        else:
            for ax in (ax_z, ax_yaw):
                ax.axis("off")
        if e.target:
            ax = ax_path if not e.measured else ax_yaw.twinx()
            keys = list(e.target)
            pos = np.arange(len(keys))
            ax.bar(pos - 0.25, [e.target[k] for k in keys], 0.25, color="k", label="target")
            for k, (label, ev, style) in enumerate(styles):
                ax.bar(pos + 0.25 * k, [ev["runs"][row].get(key, math.nan) for key in keys],
                       0.25, color=style["color"], label=label)
            ax.set_xticks(pos, keys)
            ax.set_title(f"{e.name}: targets")
        for ax in axes[row]:
            if ax.has_data():
                ax.grid(alpha=0.3)
        axes[row, 0].legend(fontsize=7)
    ax_cost, ax_x, ax_text = axes[n]
    hist = evaluator.history
    centres = [h for h in hist if h["kind"] == "point"]
    ax_cost.semilogy([h["evaluation"] for h in centres], [h["cost"] for h in centres], "o-",
                     ms=3)
    ax_cost.set(xlabel="evaluation", ylabel="cost (1/2 sum of squared scores)",
                title="cost at the optimiser's points")
    for i, name in enumerate(result.names):
        line, = ax_x.plot([h["evaluation"] for h in centres], [h["x"][i] for h in centres],
                          "o-", ms=3, label=name)
        ax_x.plot([h["evaluation"] for h in hist if h["kind"] != "point"],
                  [h["x"][i] for h in hist if h["kind"] != "point"], ".", ms=3, alpha=0.5,
                  color=line.get_color())
    ax_x.set(xlabel="evaluation", ylabel="factor",
             title="parameters (dots: finite-difference points)")
    ax_x.legend(fontsize=7)
    for ax in (ax_cost, ax_x):
        ax.grid(alpha=0.3)
    ax_text.axis("off")
    lines = [f"{name}: {x0:.3f} -> {x:.3f} +- {se:.3f}" for name, x0, x, se in
             zip(result.names, result.x0, result.x, result.standard_error)]
    lines += [f"cost {result.initial_cost:.4g} -> {result.cost:.4g}",
              f"{result.evaluations} points, {result.simulations} simulations",
              f"{result.wall_time_s:.0f} s wall"]
    ax_text.text(0.0, 1.0, "\n".join(lines), va="top", family="monospace", fontsize=9)
    fig.suptitle(f"calibration {config.name}", x=0.02, ha="left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _header(path) -> tuple:
    with open(path) as f:
        for line in f:
            if not line.startswith("#"):
                return tuple(c.strip() for c in line.split(","))
    return ()


# --- synthetic measurements ------------------------------------------------------------------

def synthesize_measurements(config: CalibrationConfig, truth_scales: dict[str, float],
                            noise: Sigma, seed: int, period: float = 0.1,
                            client=None) -> dict[str, dict]:
    """Synthetic "measured" trajectories: every experiment with a ``measured`` file simulated
    with the coefficients scaled by ``truth_scales``, sampled every ``period`` s, plus
    Gaussian noise (``noise.position_m`` on x, y, z; ``noise.yaw_deg`` on yaw) from
    ``numpy.random.default_rng(seed)``.

    Returns:
        experiment name -> {t, x, y, z, yaw} arrays.
    """
    rng = np.random.default_rng(seed)
    texts = {e.name: _dump(experiment_scenario(config, e, truth_scales))
             for e in config.experiments if e.measured}
    if client is None:
        sims = {name: simulate_trajectory(text) for name, text in texts.items()}
    else:
        futures = {name: client.submit(simulate_trajectory, text, pure=False)
                   for name, text in texts.items()}
        sims = {name: f.result() for name, f in futures.items()}
    out = {}
    for name, sim in sims.items():  # in file order: the noise does not depend on timing
        if sim["status"] != "ok":
            raise RuntimeError(f"synthesizing {name}: {sim['reason']}")
        t = np.arange(0.0, sim["t"][-1] + 1e-9, period)
        data = {"t": t}
        for col in TRAJECTORY_COLUMNS:
            data[col] = np.interp(t, sim["t"], sim[col])
            sd = math.radians(noise.yaw_deg) if col == "yaw" else noise.position_m
            data[col] = data[col] + rng.normal(0.0, sd, len(t))
        out[name] = data
    return out


def write_measured(path, data: dict, comment: str = "") -> None:
    """Writes a measured trajectory CSV (t, x, y, z, yaw)."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"# {line}" for line in comment.splitlines()] + ["t,x,y,z,yaw"]
    for row in zip(*(data[c] for c in ("t", *TRAJECTORY_COLUMNS))):
        lines.append(",".join(f"{v:.6f}" for v in row))
    path.write_text("\n".join(lines) + "\n")


# --- command line ----------------------------------------------------------------------------

def add_calibrate_parser(subparsers) -> None:
    """Adds ``manta-drake calibrate``."""
    p = subparsers.add_parser(
        "calibrate", help="fit hydrodynamic coefficients to measured runs on Dask "
                          "(Sim2Real; docs/sweeps.md)",
        description="Fits the calibration file's parameters (factors on hydrodynamic "
                    "coefficients) so simulated runs match the measured ones; writes "
                    "DIR/coefficients.yaml, DIR/calibration.png and DIR/calibration.json.")
    p.add_argument("calibration", help="calibration YAML file (docs/sweeps.md)")
    p.add_argument("--out", required=True, help="output folder")
    add_cluster_arguments(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def calibrate_main(args) -> int:
    """``manta-drake calibrate``: load (errors are one line), fit, print the result."""
    config = load_calibration(args.calibration)
    with cluster_client(args) as client:
        result = calibrate(config, args.out, client, progress=not args.quiet)
    print(f"\n  {config.name}: {result.message}")
    for name, x0, x, se in zip(result.names, result.x0, result.x, result.standard_error):
        print(f"  {name:<28} {x0:.4g} -> {x:.4g} (+- {se:.2g})")
    print(f"  cost {result.initial_cost:.4g} -> {result.cost:.4g}; {result.evaluations} points, "
          f"{result.simulations} simulations, {result.wall_time_s:.1f} s")
    print(f"  coefficients: {result.coefficients_file}")
    print(f"  figure:       {result.figure}")
    print(f"  history:      {result.history_file}")
    return 0


__all__ = [
    "CalibrationConfig", "CalibrationParameter", "Experiment", "Sigma", "OptimizerConfig",
    "load_calibration", "calibrate", "synthesize_measurements", "trajectory_residuals",
    "target_residuals", "standard_errors", "experiment_scenario", "simulate_trajectory",
]
