"""The calibration: ``calibrate`` fits the parameters with ``scipy.optimize.least_squares``
(residuals and Jacobian from the evaluator) and writes the outputs. The output folder is
checked before the first simulation; coefficients are written only when every simulation
at the fitted point ran to its end (a fit to failed runs' penalties is no calibration)."""

from __future__ import annotations

import math
import pathlib
import time

import numpy as np

from manta_drake.calibrate.config import CalibrationConfig
from manta_drake.calibrate.evaluator import Evaluator
from manta_drake.calibrate.figure import write_calibration_figure
from manta_drake.calibrate.results import (
    CalibrationResult,
    write_calibrated_coefficients,
    write_history,
)
from manta_drake.model import resolve_path
from manta_drake.sweep.config import check_out_folder

# What calibrate writes in its output folder.
OUTPUTS = ("coefficients.yaml", "calibration.json", "calibration.png")


def calibration_inputs(config: CalibrationConfig) -> list:
    """The files a calibration reads: its outputs may not overwrite them (a prior
    ``coefficients.yaml`` in the output folder, a measured CSV)."""
    inputs = [config.folder / e.measured for e in config.experiments if e.measured]
    if not config.coefficients.startswith("package://"):  # the shipped prior is no --out
        inputs.append(resolve_path(config.coefficients_path()))
    return inputs


def check_calibration_out(config: CalibrationConfig | None, out_dir, inputs=()) -> pathlib.Path:
    """Checks a calibration's output folder before any simulation (``check_out_folder``:
    not a file, creatable, writable; no output over an input). SweepError otherwise."""
    inputs = list(inputs) + (calibration_inputs(config) if config is not None else [])
    return check_out_folder(out_dir, OUTPUTS, inputs)


def calibrate(
    config: CalibrationConfig, out_dir=None, client=None, progress: bool = True
) -> CalibrationResult:
    """Fits the parameters with ``scipy.optimize.least_squares`` and writes the outputs.

    Args:
        config: a loaded calibration.
        out_dir: where to write coefficients.yaml, calibration.png and calibration.json
            (None: write nothing).
        client: a ``distributed.Client`` (each simulation a task), or None: in this process.
        progress: a tqdm bar counting simulations.

    Returns:
        The result; ``coefficients_file`` is None (and ``success`` False) when a simulation
        at the fitted point did not run to its end: ``calibration.json`` and the figure are
        written, no coefficients file.

    Raises:
        SweepError: ``out_dir`` cannot take the outputs (before any simulation).
    """
    from scipy.optimize import least_squares

    if out_dir is not None:
        out_dir = check_calibration_out(config, out_dir)
    start = time.perf_counter()
    evaluator = Evaluator(config, client, progress)
    x0 = np.array([p.initial for p in config.parameters], dtype=float)
    lower = np.array([p.bounds[0] for p in config.parameters], dtype=float)
    upper = np.array([p.bounds[1] for p in config.parameters], dtype=float)
    o = config.optimizer
    try:
        speculate = o.diff_step if o.speculative_jacobian else 0.0
        result = least_squares(
            lambda x: evaluator.residuals(x, (lower, upper), speculate),
            x0,
            jac=lambda x, *_: evaluator.jacobian(x, (lower, upper), o.diff_step),
            bounds=(lower, upper),
            method=o.method,
            max_nfev=o.max_evaluations,
            xtol=o.xtol,
            ftol=o.ftol,
            gtol=o.gtol,
        )
    finally:
        evaluator.close()
    final = (
        evaluator.cache[evaluator.key(result.x)]
        if evaluator.key(result.x) in evaluator.cache
        else evaluator.simulate([result.x], ["point"])[0]
    )
    initial = evaluator.cache[evaluator.key(x0)]
    out = CalibrationResult(
        x=np.asarray(result.x),
        x0=x0,
        names=[p.name for p in config.parameters],
        cost=final["cost"],
        initial_cost=initial["cost"],
        standard_error=standard_errors(result.jac, final["residuals"]),
        success=bool(result.success),
        message=str(result.message),
        evaluations=len(evaluator.history),
        simulations=evaluator.simulations,
        wall_time_s=time.perf_counter() - start,
    )
    not_ok = [
        f"{e.name}: {run['status']} ({run.get('reason') or 'no reason'})"
        for e, run in zip(config.experiments, final["runs"])
        if run["status"] != "ok"
    ]
    if not_ok:
        out.success = False
        out.message = (
            "not calibrated: a simulation at the fitted point did not run to its "
            f"end ({'; '.join(not_ok)})"
        )
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        (out_dir / "coefficients.yaml").unlink(missing_ok=True)  # never an earlier fit's
        if not not_ok:
            out.coefficients_file = write_calibrated_coefficients(
                out_dir / "coefficients.yaml", config, out
            )
        out.history_file = write_history(
            out_dir / "calibration.json", config, out, evaluator, result
        )
        out.figure = write_calibration_figure(
            out_dir / "calibration.png", config, evaluator, initial, final, out
        )
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
