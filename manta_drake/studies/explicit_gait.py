"""Runs of a gait given as data: a study's variant of a library gait (another reading of the
printed matrices, a phase bias removed) that has no name in the package's gait library.

A scenario names its gait (``controller.gait``, ``initial_stance``), and its diagram is
built for that one. ``start_with_gait`` makes a context of that diagram the start of the
same run with another ``GaitParams``: the controller's fixed CPG targets (the numeric
parameter of its ``gait_params`` source), the CPG's state at the new gait's lock with its
biases at the stance, and the plant's joints at the stance. The stance's start pose is
checked as ``Scenario.validate`` checks the scenario's. ``simulate.run`` (with
``prepare=``) then runs from that context what a diagram built for the gait would run: the
package's gait library is read, never changed.
"""

from __future__ import annotations

import numpy as np

from manta_drake.control.cpg import initial_state
from manta_drake.model.start_pose import start_pose_problem
from manta_drake.scenario import ScenarioError
from manta_drake.simulate import run


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
    """Simulates ``scenario`` with ``gait`` (see ``start_with_gait``) through
    ``simulate.run`` and returns its metrics; ``out_dir`` gets the run's ``log.npz``,
    ``metrics.json`` and plots (no ``scenario.yaml``: the scenario names another gait).

    Raises:
        ScenarioError: the start pose does not fit the gait's stance.
        SimulationError: the simulation failed (the log and metrics.json are written first).
    """
    stance = np.asarray(gait.X if stance is None else stance, dtype=float)
    check_start(scenario, stance, gait_name)
    result = run(scenario, out_dir, progress=False,
                 prepare=lambda handles, context: start_with_gait(handles, context, gait, stance))
    return result.metrics
