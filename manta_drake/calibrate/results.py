"""What a calibration gives: ``CalibrationResult``, the calibrated coefficients file (same
format as ``models/hydrodynamics.yaml``) and ``calibration.json`` (every evaluation)."""

from __future__ import annotations

import dataclasses as dc
import json
import pathlib

import numpy as np
import yaml

from manta_drake.calibrate.config import CalibrationConfig
from manta_drake.calibrate.evaluator import Evaluator
from manta_drake.calibrate.scenarios import parameter_scales
from manta_drake.model import resolve_path
from manta_drake.model.coefficients import load_coefficients, scale_coefficients


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


def calibrated_sources(config: CalibrationConfig, result: CalibrationResult) -> dict[str, str]:
    """The ``source`` text of each calibrated coefficient: what it was fitted to and how."""
    fitted_to = ", ".join(
        f"{e.name} ({e.measured or 'target ' + json.dumps(e.target)})" for e in config.experiments
    )
    out = {}
    for p, value, se in zip(config.parameters, result.x, result.standard_error):
        for c in p.coefficients:
            out[c] = (
                f"calibrated (Sim2Real, manta-drake calibrate {config.name}): x{value:.4g} "
                f"(+- {se:.2g}) of the prior by parameter {p.name}, fitted to {fitted_to} "
                f"with scipy least_squares, cost {result.initial_cost:.4g} -> "
                f"{result.cost:.4g}"
            )
    return out


def write_calibrated_coefficients(
    path: pathlib.Path, config: CalibrationConfig, result: CalibrationResult
) -> pathlib.Path:
    """The prior coefficients with the fitted scales, same format as hydrodynamics.yaml
    (every entry ``{value, source}``); calibrated sources say what they were fitted to and
    keep the prior's value and source."""
    prior = load_coefficients(resolve_path(config.coefficients_path()))
    coeffs = scale_coefficients(prior, parameter_scales(config, result.x))
    entries, prior_entries = dict(coeffs.entries()), dict(prior.entries())
    for name, text in calibrated_sources(config, result).items():
        prior_entry = prior_entries[name]
        entries[name].source = f"{text}; prior value {prior_entry.value}: {prior_entry.source}"
    header = (
        f"# Hydrodynamic coefficients calibrated by `manta-drake calibrate` "
        f"({config.name}) from {config.coefficients}.\n"
        "# Same format as models/hydrodynamics.yaml; use it with "
        "water: {coefficients: <this file>}.\n"
    )
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


def write_history(
    path: pathlib.Path,
    config: CalibrationConfig,
    result: CalibrationResult,
    evaluator: Evaluator,
    scipy_result,
) -> pathlib.Path:
    """calibration.json: the result, the parameters and every evaluation."""
    doc = {
        "name": config.name,
        "prior": config.coefficients,
        "experiments": [dc.asdict(e) for e in config.experiments],
        "parameters": [
            {
                "name": p.name,
                "coefficients": p.coefficients,
                "initial": p.initial,
                "bounds": p.bounds,
                "fitted": float(x),
                "standard_error": float(se),
            }
            for p, x, se in zip(config.parameters, result.x, result.standard_error)
        ],
        "initial_cost": result.initial_cost,
        "cost": result.cost,
        "success": result.success,
        "message": result.message,
        "optimizer": dc.asdict(config.optimizer),
        "scipy": {
            "nfev": int(scipy_result.nfev),
            "njev": int(scipy_result.njev or 0),
            "status": int(scipy_result.status),
        },
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
