"""Many runs on Dask: ``manta-drake sweep SWEEP.yaml --out DIR``.

A sweep file names one or more base scenarios, the parameters to vary and the random seeds;
every (base, parameter set, seed) is one run, a task on a Dask cluster (a
``distributed.LocalCluster`` of ``--workers`` processes with one thread each, or a running
cluster at ``--scheduler ADDRESS``). docs/sweeps.md has the full format; in short::

    name: findings
    base: [locomotion_swim, locomotion_walk]      # a name, a path, or a list (one more axis)
    seeds: [0, 1]                                 # scenario.random_seed of every run
    fixed: {duration: 20.0}                       # set on every run
    links:                                        # one parameter that sets several keys
      hull_damping: [water.coefficient_scales.body.linear_damping,
                     water.coefficient_scales.body.quadratic_damping]
    grid:                                         # full factorial; or `rows:` or `random:`
      contact.friction: [0.5, 0.65, 0.8]
      hull_damping: [0.7, 1.0, 1.3]
      net_weight_kg: [0.6, 0.85, 1.1]             # derived: see net_weight_scales

A parameter is a dotted scenario key (``contact.friction``,
``water.coefficient_scales.body.linear_damping``, ``initial_pose.xyz``), a name from
``links``, or ``net_weight_kg`` (the robot's deflated net weight, turned into a scale of the
hull's sealed volume). Instead of ``grid``: ``rows`` (a list of explicit parameter sets) or
``random`` (``{n, seed, uniform: {parameter: [low, high]}}``, drawn with
``numpy.random.default_rng(seed)``).

Outputs in ``--out DIR``: ``results.csv`` (one row per run: its parameters, status, reason and
flattened metrics, the ``energy`` block as ``energy.<key>`` columns), ``summary.png``, and
``runs/<run_id>/`` with ``scenario.yaml`` (the resolved scenario: ``manta-drake run`` it to
reproduce the run), ``log.npz`` and ``metrics.json`` (written last: a run is done when it
holds a final status and the log it says it wrote is there; a restarted sweep skips done
runs). Run ids hash the base, the resolved overrides and the seed, so they are
the same on every machine and every restart.

Where things can go wrong: an unknown or duplicated key anywhere in the sweep file, a
parameter that names no scenario field, a value given twice (``1`` and ``1.0`` of a float
field are one value), more than ``MAX_RUNS`` runs (counted, never expanded), a ``fixed``
value no base accepts, or an output folder that cannot take the results fails at once
(before any run) with one line naming the path or option. A bad varied *value*
(``contact.friction: -1``), a simulation failure or any other exception makes that run a
row with ``status`` (``invalid``, ``failed``, ``error``) and ``reason``; the sweep goes on.
A run the cluster lost (its worker died) is submitted again; lost every time, its row says
``lost`` and a restart runs it again.

The package, one module per step: ``config`` (the file's dataclasses, ``SweepError`` and
the checks shared with calibration files), ``loading`` (``load_sweep``), ``net_weight``
(the derived parameter), ``plan`` (parameter sets, run ids, ``plan_runs``), ``run`` (one
run on a worker), ``results`` (run folders and ``results.csv``), ``figure``
(``summary.png``), ``runner`` (``run_sweep``) and ``cli``. The Dask cluster helper is
``manta_drake.cluster``; its names are given here too.
"""

from manta_drake.cluster import (
    ClusterError,
    add_cluster_arguments,
    check_cluster_arguments,
    check_workers,
    cluster_client,
    dask_client,
    default_workers,
)

# The scenario and model helpers the sweep works with, importable from here as well
# (``sweep.check_override_key``, ``sweep.load_scenario``, ...).
from manta_drake.config_io import (  # noqa: F401
    ScenarioError,
    check_keys,
    load_yaml_mapping,
    schema_fields,
)
from manta_drake.model import resolve_path  # noqa: F401
from manta_drake.model.coefficients import load_coefficients, scale_coefficients  # noqa: F401
from manta_drake.model.robot_params import DEFAULT_ROBOT  # noqa: F401
from manta_drake.scenario import (  # noqa: F401
    Scenario,
    check_override_key,
    find_scenario,
    load_scenario,
    parse_set,
    scenario_yaml,
)
from manta_drake.station.water import build_elements  # noqa: F401
from manta_drake.sweep.cli import add_sweep_parser, sweep_main
from manta_drake.sweep.config import (
    DERIVED,
    MAX_RUNS,
    RandomSample,
    RunSpec,
    SweepConfig,
    SweepError,
    check_config_keys,
    check_out_folder,
    check_parameter_name,
    read_yaml_mapping,
    typed_parameter,
)
from manta_drake.sweep.figure import write_summary_figure
from manta_drake.sweep.loading import check_fixed_values, load_sweep, validate_sweep
from manta_drake.sweep.net_weight import (
    apply_net_weight,
    deflated_net_weight_kg,
    hull_scale_for_net_weight,
    net_weight_scales,
)
from manta_drake.sweep.plan import (
    apply_overrides,
    count_parameter_sets,
    count_runs,
    expand_overrides,
    iter_parameter_sets,
    make_run_id,
    parameter_names,
    parameter_sets,
    plan_runs,
    resolve_run,
    run_specs,
)
from manta_drake.sweep.results import (
    DONE_STATUSES,
    INFRASTRUCTURE_ERRORS,
    LOST,
    METRIC_COLUMNS,
    NAMED_VECTORS,
    flatten_metrics,
    format_transitions,
    is_infrastructure_error,
    read_done,
    read_table,
    table_rows,
    write_run,
    write_table,
)
from manta_drake.sweep.run import failure_reason, simulate_run
from manta_drake.sweep.runner import ATTEMPTS, SweepResult, run_sweep

__all__ = [
    # the sweep file
    "SweepError",
    "RandomSample",
    "SweepConfig",
    "RunSpec",
    "DERIVED",
    "MAX_RUNS",
    "load_sweep",
    "validate_sweep",
    "check_fixed_values",
    "check_config_keys",
    "read_yaml_mapping",
    "check_parameter_name",
    "typed_parameter",
    "check_out_folder",
    # the derived parameter net_weight_kg
    "hull_scale_for_net_weight",
    "deflated_net_weight_kg",
    "net_weight_scales",
    "apply_net_weight",
    # from a sweep to its runs
    "expand_overrides",
    "apply_overrides",
    "make_run_id",
    "count_parameter_sets",
    "count_runs",
    "iter_parameter_sets",
    "parameter_sets",
    "parameter_names",
    "run_specs",
    "resolve_run",
    "plan_runs",
    # one run, the results, the sweep
    "simulate_run",
    "failure_reason",
    "write_run",
    "read_done",
    "DONE_STATUSES",
    "LOST",
    "INFRASTRUCTURE_ERRORS",
    "is_infrastructure_error",
    "format_transitions",
    "NAMED_VECTORS",
    "METRIC_COLUMNS",
    "flatten_metrics",
    "table_rows",
    "write_table",
    "read_table",
    "write_summary_figure",
    "ATTEMPTS",
    "SweepResult",
    "run_sweep",
    # the command line
    "add_sweep_parser",
    "sweep_main",
    # the Dask cluster helper (manta_drake.cluster)
    "ClusterError",
    "add_cluster_arguments",
    "check_cluster_arguments",
    "check_workers",
    "cluster_client",
    "dask_client",
    "default_workers",
]
