"""What a calibration file holds: the fitted parameters, the experiments and their
measurements, the standard deviations and the optimiser's settings (``CalibrationConfig``)."""

from __future__ import annotations

import dataclasses as dc
import pathlib
from typing import Any

from manta_drake.calibrate.measured import TRAJECTORY_COLUMNS

TARGET_KEYS = ("u", "v", "yaw_rate_deg_s")


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

    ``measured``: a CSV (t, x, y, z, yaw) relative to the calibration file, or a ROS 2 bag
    (a rosbag2 folder or an ``.mcap`` file) whose ``topics`` name the ``pose`` (x, y, z,
    yaw) or the ``depth`` (z) and optionally the ``joint_states`` (read and checked);
    ``columns`` says which of x, y, z, yaw enter the fit. ``target``: mean velocities
    instead (or too).
    """

    name: str = ""
    scenario: str = ""
    overrides: dict[str, Any] = dc.field(default_factory=dict)
    measured: str = ""
    topics: dict[str, str] = dc.field(default_factory=dict)
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


# The most points (``optimizer.max_evaluations``) a fit may ask for: each point simulates every
# experiment (and, for the Jacobian, its n neighbours too), so a thousand is far beyond any
# fit's budget (the shipped one asks 12); the bound refuses a typo (1e9) before anything runs.
MAX_EVALUATIONS = 1000


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
