"""Runs of a gait given as data: a study's variant of a library gait (another reading of the
printed matrices, a phase bias removed) that has no name in the package's gait library.

A scenario names its gait (``controller.gait``, ``initial_stance``), and its diagram is
built for that one. ``start_with_gait`` makes a context of that diagram the start of the
same run with another ``GaitParams``: the controller's fixed CPG targets (the numeric
parameter of its ``gait_params`` source), the CPG's state at the new gait's lock with its
biases at the stance, and the plant's joints at the stance. The stance's start pose is
checked as ``Scenario.validate`` checks the scenario's. A Simulator on that context
(``simulate.make_simulator`` keeps a caller's context) then runs what a diagram built for
the gait would run: the package's gait library is read, never changed.
"""

from __future__ import annotations

import json
import pathlib
import time

import numpy as np

from manta_drake.control.cpg import initial_state
from manta_drake.model.start_pose import start_pose_problem
from manta_drake.scenario import ScenarioError


def check_start(scenario, stance, stance_name: str = "given") -> None:
    """Raises ScenarioError if the scenario's start pose does not fit the joint angles
    ``stance`` (4x4), as ``Scenario.validate`` checks the stance it names."""
    problem = start_pose_problem(scenario.initial_pose.xyz, scenario.initial_pose.rpy_deg,
                                 stance, scenario.fin_sweep_deg(), stance_name)
    if problem:
        raise ScenarioError(f"initial_pose: {problem}")


def start_with_gait(handles, context, gait, stance=None) -> None:
    """Makes ``context`` the start of a run with ``gait`` instead of the scenario's gait.

    Args:
        handles: the DiagramHandles of ``build_diagram`` for a scenario whose
            ``controller.mode`` is ``gait``.
        context: a root context of that diagram (changed in place).
        gait: the GaitParams the CPG runs.
        stance: the joint angles at the start (4x4; default ``gait.X``).

    Raises:
        ValueError: the diagram's controller runs no fixed gait.
    """
    controller = handles.controller
    if "cpg" not in handles.systems or not controller.HasSubsystemNamed("gait_params"):
        raise ValueError("start_with_gait: the controller runs no fixed gait "
                         "(controller.mode must be gait)")
    params = gait.to_vector()
    q0 = np.ravel(gait.X if stance is None else stance)
    source = controller.GetSubsystemByName("gait_params")
    source.get_mutable_source_value(source.GetMyMutableContextFromRoot(context)) \
        .SetFromVector(params)
    cpg = handles.systems["cpg"]
    cpg.GetMyMutableContextFromRoot(context).SetContinuousState(initial_state(params, q0))
    plant, robot = handles.plant, handles.plant_handles.robot
    plant_context = plant.GetMyMutableContextFromRoot(context)
    for name, q in zip(handles.plant_handles.joint_names, q0):
        plant.GetJointByName(name, robot).set_angle(plant_context, q)


def run_with_gait(scenario, gait, out_dir, stance=None, gait_name: str = "given") -> dict:
    """Simulates ``scenario`` with ``gait`` (see ``start_with_gait``) and writes the run's
    ``log.npz``, ``metrics.json`` and plots into ``out_dir`` (no ``scenario.yaml``: the
    scenario names another gait).

    Returns:
        the metrics (``simulate.compute_metrics``, with ``status`` and, for a finished run,
        ``max_penetration_m``).

    Raises:
        ScenarioError: the start pose does not fit the gait's stance.
        SimulationError: the simulation failed (the log and metrics.json are written first).
    """
    from manta_drake import plots
    from manta_drake.simulate import (
        SimulationError,
        compute_metrics,
        extract_log,
        make_simulator,
        max_penetration,
    )
    from manta_drake.wiring.diagram import build_diagram

    stance = np.asarray(gait.X if stance is None else stance, dtype=float)
    check_start(scenario, stance, gait_name)
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    diagram, handles = build_diagram(scenario)
    context = diagram.CreateDefaultContext()
    start_with_gait(handles, context, gait, stance)
    simulator = make_simulator(diagram, scenario, context)
    failure = None
    wall_start = time.perf_counter()
    try:
        simulator.Initialize()
        simulator.AdvanceTo(scenario.duration)
    except Exception as e:  # noqa: BLE001 - the log up to the failure is still written
        failure = {"time_s": float(context.get_time()), "reason": f"{type(e).__name__}: {e}"}
    wall_time = time.perf_counter() - wall_start
    log = extract_log(handles, context)
    log["sim_time"] = np.array(context.get_time())
    metrics = compute_metrics(scenario, log, wall_time)
    if failure is None and "body_xyz" in log and not np.all(np.isfinite(log["body_xyz"])):
        failure = {"time_s": float(log["t"][np.argmax(~np.isfinite(log["body_xyz"]).any(1))]),
                   "reason": "non-finite body state"}
    metrics["status"] = "failed" if failure else "ok"
    if failure:
        metrics["failure"] = {"stage": "simulation", **failure}
    else:
        metrics["max_penetration_m"] = max_penetration(handles, diagram, context)
    np.savez_compressed(out_dir / "log.npz", **log)
    plots.write_run_plots(log, out_dir, title=f"{scenario.name} ({gait_name})")
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    if failure:
        raise SimulationError(f"{scenario.name} with {gait_name}: simulation failed at t = "
                              f"{failure['time_s']:.3f} s: {failure['reason']} "
                              f"(partial log in {out_dir})")
    return metrics
