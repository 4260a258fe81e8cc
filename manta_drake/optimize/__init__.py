"""Gait design by CMA-ES on Dask: ``manta-drake optimize SPEC.yaml --out DIR``.

A spec names a scenario, a starting gait and the gait entries free to move; CMA-ES
(``cma.CMAEvolutionStrategy``, ask/tell, on the unit cube of the entries' bounds) searches
them, every generation's candidates simulated in parallel on the Dask cluster (one task per
candidate, robustness point and seed), to minimise a weighted sum of run metrics under
constraints. docs/optimize.md has the full format; in short::

    scenario: locomotion_swim           # a shipped name or a path relative to this file
    gait: swim_printed                  # the starting gait
    name: straight_swim                 # the result's gait name (default: the file's stem)
    free:
      - {entry: "Phi_prime_deg[fl, fr]", low: -30, high: 30}    # [fr, fl] follows as -x
      - {entry: "R_deg[fr, pitch]", low: -45, high: 45, tie: ["R_deg[rr, pitch]"]}
    objective:
      terms: [{metric: distance_from_start_gait, weight: 1.0},
              {metric: abs_yaw_rate, weight: 1.0}]
      constraints: [{metric: abs_yaw_rate, max: 1.0}, {metric: u, min: 0.08}]
    robustness: {points: [{}, {water.coefficient_scales.body.linear_damping: 1.3}],
                 seeds: [0], aggregate: mean}
    held_out: {points: [{net_weight_kg: 1.1}]}
    budget: {generations: 12, population: 8, sigma0: 0.25, duration: 12.0, steady_after: 4.0}
    seed: 0

Outputs in ``--out DIR``: ``best_gait.yaml`` (a gait file with the best gait under the
result's name and its provenance), ``history.csv`` (every simulation: where it was, the
parameters in degrees, the metrics, the cost and its parts, the status and reason, the wall
time and worker), ``convergence.png``, ``summary.json``, ``state.json`` (what CMA-ES was
told, as plain JSON: a restart rebuilds CMA-ES from it), ``evaluations/gNNNN/cCCC-pP-sS/``
(each simulation's candidate gait file and metrics.json; the log only for the best
candidate so far), ``best_run/`` (the best gait re-run at the scenario as it is, with its
joints, states and trajectory figures) and ``held_out/`` (its re-check at the held-out
points).

Checked before any simulation, each refused with one line naming the field: the spec's keys
and types, the entries (``R_deg[fx, pitch]``: no row fx), bounds (low < high, the start
value inside), ties (not to the entry itself, one sign each, no entry set twice), the
metrics, the constraints, the points (each resolved on the scenario), the budget (its runs'
steady window long enough for the objective's metrics) and the output folder (with the
``state.json`` and ``history.csv`` a restart reads back). A candidate the scenario refuses,
a failed simulation or a missing metric is a row with its status and reason, costed
``objective.failed_cost``; the search goes on.

The package, one module per step: ``spec`` (the file's dataclasses, ``OptimizeError``),
``loading`` (``load_problem``), ``parameters`` (entries, ties, the unit cube and gaits),
``objective`` (the metrics, the cost), ``evaluate`` (one simulation on a worker),
``history`` (``history.csv``, keys, evaluation folders), ``state`` (``state.json``, the
restart state, replayed), ``run`` (``run_optimization``), ``figure`` (``convergence.png``),
``front`` (a ``front`` section: one search per level of one metric, the other minimised,
and the non-dominated set of every candidate: ``run_front``, ``pareto_mask``) and ``cli``.
"""

from manta_drake.optimize.cli import add_optimize_parser, optimize_main
from manta_drake.optimize.evaluate import simulate_candidate
from manta_drake.optimize.front import pareto_mask, run_front
from manta_drake.optimize.history import (
    HISTORY,
    evaluation_key,
    history_columns,
    read_history,
)
from manta_drake.optimize.loading import Problem, load_problem, validate
from manta_drake.optimize.objective import (
    METRICS,
    aggregate,
    joint_limit_margin_deg,
    run_metrics,
    score,
)
from manta_drake.optimize.parameters import (
    Parameter,
    ParameterSpace,
    build_parameters,
    candidate_gait_text,
    parse_entry,
)
from manta_drake.optimize.run import (
    FOLDERS,
    OUTPUTS,
    OptimizationResult,
    run_optimization,
    write_best_gait,
)
from manta_drake.optimize.spec import (
    Budget,
    Constraint,
    FreeEntry,
    Front,
    HeldOut,
    Objective,
    OptimizeError,
    OptimizeSpec,
    Robustness,
    Term,
)
from manta_drake.optimize.state import STATE, load_state

__all__ = [
    # the spec
    "OptimizeSpec",
    "FreeEntry",
    "Term",
    "Constraint",
    "Objective",
    "Robustness",
    "HeldOut",
    "Budget",
    "Front",
    "OptimizeError",
    "Problem",
    "load_problem",
    "validate",
    # parameters and gaits
    "Parameter",
    "ParameterSpace",
    "build_parameters",
    "parse_entry",
    "candidate_gait_text",
    # the objective
    "METRICS",
    "run_metrics",
    "joint_limit_margin_deg",
    "score",
    "aggregate",
    # simulations and records
    "simulate_candidate",
    "HISTORY",
    "evaluation_key",
    "history_columns",
    "read_history",
    # the search
    "run_optimization",
    "OptimizationResult",
    "load_state",
    "STATE",
    "write_best_gait",
    # a front of two metrics
    "run_front",
    "pareto_mask",
    "OUTPUTS",
    "FOLDERS",
    # the command line
    "add_optimize_parser",
    "optimize_main",
]
