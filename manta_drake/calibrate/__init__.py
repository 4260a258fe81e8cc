"""Sim2Real calibration on Dask: ``manta-drake calibrate CALIBRATION.yaml --out DIR``.

The paper tuned Webots' damping by running the simulator again and again until it moved like
the robot. This is that loop, automated: named *parameters*, each a factor on one or more
hydrodynamic coefficients (``body.linear_damping``, or a lumped hull damping that multiplies
``body.linear_damping`` and ``body.quadratic_damping`` together), are fitted with
``scipy.optimize.least_squares`` so that simulated runs match measured ones:

* a trajectory: a CSV with columns ``t, x, y, z, yaw`` (s, m in the pool's world frame of
  the scenario, yaw in rad), or a ROS 2 bag (a rosbag2 folder or an ``.mcap`` file, read
  with rosbags) whose ``topics`` name its ``pose`` topic (PoseStamped,
  PoseWithCovarianceStamped or Odometry: x, y, z, yaw) or its ``depth`` topic
  (FluidPressure or Float64: z) and, read and checked, its ``joint_states``, compared
  sample by sample; or
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

Checked before any simulation, each refused with one line naming the field or option: the
file (keys, types, ranges, coefficients, scenarios and override values), every measured CSV
or bag against its experiment (a bag's topics and their types) (UTF-8 text, the columns,
finite numbers, times from 0 that increase and end within the run's duration), finite
targets, and the output folder. A fit whose
simulations at the fitted point did not all run to their end writes no coefficients file
(``calibrate`` exits 1).

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

The package, one module per step: ``config`` (the file's dataclasses), ``loading``
(``load_calibration``), ``measured`` (the trajectory CSVs and bags), ``scenarios`` (from parameters
to scenarios), ``run`` (one simulation on a worker), ``residuals``, ``evaluator`` (batches
of simulations on Dask), ``fit`` (``calibrate``), ``results`` (the result and its files),
``figure`` (``calibration.png``), ``synthetic`` (synthetic measurements) and ``cli``.
"""

from manta_drake.calibrate.cli import add_calibrate_parser, calibrate_main
from manta_drake.calibrate.config import (
    TARGET_KEYS,
    CalibrationConfig,
    CalibrationParameter,
    Experiment,
    OptimizerConfig,
    Sigma,
)
from manta_drake.calibrate.evaluator import Evaluator, fd_points
from manta_drake.calibrate.figure import write_calibration_figure
from manta_drake.calibrate.fit import (
    OUTPUTS,
    calibrate,
    calibration_inputs,
    check_calibration_out,
    standard_errors,
)
from manta_drake.calibrate.loading import (
    experiment_measured,
    load_calibration,
    validate_calibration,
)
from manta_drake.calibrate.measured import (
    BAG_TOPICS,
    TRAJECTORY_COLUMNS,
    load_measured,
    load_measured_bag,
    write_measured,
)
from manta_drake.calibrate.residuals import (
    FAILED_RESIDUAL,
    target_residuals,
    trajectory_residuals,
)
from manta_drake.calibrate.results import (
    CalibrationResult,
    calibrated_sources,
    write_calibrated_coefficients,
    write_history,
)
from manta_drake.calibrate.run import simulate_trajectory
from manta_drake.calibrate.scenarios import experiment_scenario, parameter_scales
from manta_drake.calibrate.synthetic import synthesize_measurements

# The cluster, scenario and sweep helpers the calibration works with, importable from here
# as well (``calibrate.SweepError``, ``calibrate.apply_overrides``, ...).
from manta_drake.cluster import add_cluster_arguments, cluster_client  # noqa: F401
from manta_drake.model import resolve_path  # noqa: F401
from manta_drake.scenario import (  # noqa: F401
    Scenario,
    ScenarioError,
    coefficient_names,
    load_scenario,
)
from manta_drake.sweep import (  # noqa: F401
    SweepError,
    apply_overrides,
    check_config_keys,
    check_parameter_name,
    read_yaml_mapping,
)

__all__ = [
    # the calibration file
    "CalibrationConfig",
    "CalibrationParameter",
    "Experiment",
    "Sigma",
    "OptimizerConfig",
    "TARGET_KEYS",
    "load_calibration",
    "validate_calibration",
    # measured trajectories
    "TRAJECTORY_COLUMNS",
    "load_measured",
    "write_measured",
    "synthesize_measurements",
    "BAG_TOPICS",
    "load_measured_bag",
    "experiment_measured",
    # from parameters to simulations and residuals
    "parameter_scales",
    "experiment_scenario",
    "simulate_trajectory",
    "FAILED_RESIDUAL",
    "trajectory_residuals",
    "target_residuals",
    "Evaluator",
    "fd_points",
    # the fit and its outputs
    "calibrate",
    "standard_errors",
    "OUTPUTS",
    "check_calibration_out",
    "calibration_inputs",
    "CalibrationResult",
    "calibrated_sources",
    "write_calibrated_coefficients",
    "write_history",
    "write_calibration_figure",
    # the command line
    "add_calibrate_parser",
    "calibrate_main",
]
