"""The one place that runs a Simulator.

``run(scenario, out_dir)`` builds the diagram, simulates with a progress bar,
and writes into ``out_dir``:

* ``recording.html``: self-contained Meshcat recording (if visualisation is on);
* ``log.npz``: time series (see ``LOG_KEYS``);
* ``metrics.json``: the run's metrics (see ``compute_metrics`` and docs/design.md);
* ``joints.png``, ``states.png``, ``trajectory.png``;
* ``run.mcap`` and ``metadata.yaml``: the log as a ROS 2 bag (with a topic map,
  ``manta_drake.ros2.bag``).

If the simulation fails part-way, the log up to the failure and a
``metrics.json`` with ``status: failed``, the time and the reason are still
written, and the exception is re-raised as ``SimulationError``.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import os
import pathlib
import sys
import time

import numpy as np
from pydrake.common import RandomGenerator
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorStatus
from pydrake.systems.framework import Diagram, EventStatus
from pydrake.systems.primitives import RandomSource

from manta_drake import metrics as M
from manta_drake import plots
from manta_drake.config_io import check_integer
from manta_drake.interrupts import (
    RunInterrupted,
    interruption,
    interrupts_as_exceptions,
    signals_deferred,
    signals_flagged,
    stop_if_signalled,
)
from manta_drake.model.robot_params import DEFAULT_POOL, DEFAULT_ROBOT, NUM_JOINTS
from manta_drake.run_folder import (  # noqa: F401 (also the names callers import from here)
    OUTPUT_FILES,
    SCENARIO_HEADER,
    OutputFolderError,
    SimulationError,
    check_output_folder,
    interrupted_failure,
    remove_outputs,
    running_metrics,
    write_atomic,
    write_interrupted_start,
    write_metrics,
)
from manta_drake.scenario import Scenario, scenario_yaml
from manta_drake.station.foot_contacts import CARRIERS as FOOT_CARRIERS
from manta_drake.station.servo_power import servo_power_terms
from manta_drake.station.water import deflated_net_weight_kg
from manta_drake.wiring.diagram import DiagramHandles, build_diagram, logger_data

LOG_KEYS = (
    "t",
    "joint_angles",
    "joint_velocities",
    "commanded_joint_angles",
    "body_xyz",
    "body_quat_wxyz",
    "body_rpy",
    "body_v_world",
    "body_w_world",
)


# Shortest steady window [s] over which a mean velocity is reported.
MIN_STEADY_WINDOW = 1.0


@dc.dataclass
class RunResult:
    """What ``run`` returns."""

    metrics: dict
    out_dir: pathlib.Path
    log: dict
    handles: DiagramHandles | None = None
    context: object = None  # the root context at the end of the run
    bag: object = None  # the bag's ros2.bag.BagSummary, if one was written


def _progress(total: float, enabled: bool):
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(
        total=total,
        unit="sim s",
        desc="simulating",
        file=sys.stderr,
        bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]",
    )


def extract_log(handles: DiagramHandles, root_context) -> dict:
    """Turns the loggers' records into named numpy arrays (see ``LOG_KEYS``)."""
    plant, body = handles.plant, handles.plant_handles.body
    t, x = logger_data(handles.loggers["plant_state"], root_context)
    nq = plant.num_positions()
    joints = [
        plant.GetJointByName(n, handles.plant_handles.robot)
        for n in handles.plant_handles.joint_names
    ]
    qi = np.array([j.position_start() for j in joints])
    vi = np.array([nq + j.velocity_start() for j in joints])
    log = {"t": t, "joint_angles": x[:, qi], "joint_velocities": x[:, vi]}
    if body.is_floating_base_body():
        q0 = body.floating_positions_start()
        v0 = nq + body.floating_velocities_start_in_v()
        log["body_quat_wxyz"] = x[:, q0 : q0 + 4]
        log["body_xyz"] = x[:, q0 + 4 : q0 + 7]
        log["body_w_world"] = x[:, v0 : v0 + 3]
        log["body_v_world"] = x[:, v0 + 3 : v0 + 6]
        log["body_rpy"] = M.euler_rpy(log["body_quat_wxyz"]) if len(t) else np.zeros((0, 3))
    tc, xc = logger_data(handles.loggers["desired_state"], root_context)
    log["t_command"] = tc
    log["commanded_joint_angles"] = xc[:, :NUM_JOINTS]
    for name in handles.loggers:
        if name not in ("plant_state", "desired_state"):
            ts, xs = logger_data(handles.loggers[name], root_context)
            log[f"t_{name}"], log[name] = ts, xs
    return log


def max_penetration(handles: DiagramHandles, diagram, root_context, period: float = 0.01) -> float:
    """Deepest contact penetration [m] over the logged run, sampled every ``period`` s."""
    plant = handles.plant
    plant_context = plant.GetMyMutableContextFromRoot(diagram.CreateDefaultContext())
    log = handles.loggers["plant_state"].FindLog(root_context)
    t, data = log.sample_times(), log.data().T
    if len(t) == 0:
        return 0.0
    stride = max(1, int(round(period / (t[1] - t[0])))) if len(t) > 1 else 1
    deepest = 0.0
    for row in data[::stride]:
        plant.SetPositionsAndVelocities(plant_context, row)
        query = plant.get_geometry_query_input_port().Eval(plant_context)
        for pair in query.ComputePointPairPenetration():
            deepest = max(deepest, pair.depth)
    return float(deepest)


def compute_metrics(scenario: Scenario, log: dict, wall_time: float) -> dict:
    """The run's metrics (docs/design.md lists them) from a log."""
    t = log["t"]
    sim_time = float(log.get("sim_time", t[-1] if len(t) else 0.0))
    m = {
        "scenario": scenario.name,
        # How the gait matrices were read and on which fin sweep (docs/stance.md).
        "gait_reading": scenario.controller.gait_reading,
        "fin_sweep_deg": scenario.fin_sweep_deg(),
        "sim_time_s": sim_time,
        "wall_time_s": wall_time,
        "real_time_factor": sim_time / wall_time if wall_time > 0 else math.nan,
    }
    if len(t) >= 2 and "body_xyz" in log:
        q, xyz = log["body_quat_wxyz"], log["body_xyz"]
        # The steady window: from steady_after (at most half the run) until the hull first
        # comes within free_water_margin of a wall, so no speed is averaged over a robot
        # pressed against a wall.
        clearance = M.wall_clearance(
            xyz, q, DEFAULT_ROBOT.body_semi_axes, DEFAULT_POOL.length / 2, DEFAULT_POOL.width / 2
        )
        near = M.free_water_end(t, clearance, scenario.free_water_margin)
        start = min(scenario.steady_after, 0.5 * sim_time)
        end = sim_time if near is None else near
        m["steady_window_s"] = [float(start), float(end)]
        m["min_wall_clearance_m"] = float(clearance.min())
        m["near_wall_at_s"] = near
        m["touched_wall"] = bool(clearance.min() <= 0.01)
        if end - start >= MIN_STEADY_WINDOW:
            m["mean_velocity_body"] = M.mean_velocity_from_displacement(t, q, xyz, start, end)
            m["yaw_rate_deg_s"] = M.yaw_rate_deg_s(t, q, start, end)
        else:
            m["mean_velocity_body"] = None
            m["yaw_rate_deg_s"] = None
            m["note"] = M.short_window_note(
                start, end, MIN_STEADY_WINDOW, sim_time, near, scenario.free_water_margin
            )
        m["heading_change_deg"] = M.heading_change_deg(q)
        m["distance_m"] = M.horizontal_distance(xyz)
        m["final_body_xyz"] = xyz[-1].tolist()
        m["final_body_rpy_deg"] = np.degrees(log["body_rpy"][-1]).tolist()
    if len(log.get("behaviour_weights", [])) and len(log.get("cpg_params", [])):
        tree = scenario.behaviour_tree()
        m["transitions"] = M.leaf_transitions(
            log["t_behaviour_weights"],
            log["behaviour_weights"],
            tree.leaves,
            log["t_cpg_params"],
            log["cpg_params"],
            tree.gait_vectors,
            scenario.transition.arrival_tolerance,
        )
    if len(log.get("commanded_joint_angles", [])) >= 2:
        m["max_joint_step_rad"] = M.max_joint_step(log["commanded_joint_angles"])
        n = min(len(log["joint_angles"]), len(log["commanded_joint_angles"]))
        err = log["joint_angles"][:n] - log["commanded_joint_angles"][:n]
        m["final_max_joint_error_rad"] = float(np.abs(err[-1]).max())
    if len(log.get("joint_torque", [])) and len(log.get("joint_velocities", [])):
        m["actuator_envelope"] = actuator_envelope(scenario, log)
    if len(log.get("foot_contacts", [])) and "body_quat_wxyz" in log:
        m["feet"] = feet(log, m["steady_window_s"] if m.get("mean_velocity_body") else None)
    if "electrical_power" in log:  # the energy model is on (actuators.enabled)
        model, params, coeffs = (
            scenario.energy_model(),
            scenario.robot_params(),
            scenario.hydro_coefficients(),
        )
        m["energy"] = M.energy_metrics(
            log,
            params.total_mass,
            model.pack.usable_energy_wh(),
            model.pack.cutoff_soc,
            m.get("steady_window_s"),
            m.get("mean_velocity_body"),
            weight_in_water_kg=None if coeffs is None else deflated_net_weight_kg(coeffs, params),
            hotel_power_w=model.electronics_power + NUM_JOINTS * model.servo.standby_power,
        )
        if len(log.get("joint_torque", [])):
            window = m["steady_window_s"] if m.get("mean_velocity_body") else None
            m["power_breakdown"] = power_breakdown(scenario, log, window)
    return m


def feet(log: dict, window=None) -> dict:
    """``metrics.foot_summary`` of the logged ``foot_contacts`` over ``window`` (None: the
    whole run), the slip's forward component along the hull's logged heading."""
    t = log["t_foot_contacts"]
    n = min(len(t), len(log["t"]))
    yaw = np.interp(t[:n], log["t"], np.unwrap(log["body_rpy"][:, 2]))
    return M.foot_summary(t[:n], log["foot_contacts"][:n], yaw, FOOT_CARRIERS, window)


def power_breakdown(scenario: Scenario, log: dict, window=None) -> dict:
    """``metrics.power_breakdown`` of the run's electrical draw over ``window`` (None: the
    whole run): ``computers`` (constant), and per servo ``standby``, ``copper`` and
    ``shaft`` (``station.servo_power.servo_power_terms`` of the logged joint torques and
    rates), with ``electrical_w`` the logged total over the same window (equal to
    ``total_w`` when the log period is the plant's step)."""
    model, t = scenario.energy_model(), log["t"]
    tau = _on_times(t, log["t_joint_torque"], log["joint_torque"])
    terms = servo_power_terms(tau, log["joint_velocities"][: len(tau)], model.servo)
    out = M.power_breakdown(
        t[: len(tau)], {"computers": np.full(len(tau), model.electronics_power), **terms}, window
    )
    start, end = out["window_s"] or (0.0, 0.0)
    out["electrical_w"] = M.step_mean(
        log["t_electrical_power"], log["electrical_power"], start, end
    )
    return out


def _on_times(t, t_samples, samples) -> np.ndarray:
    """``samples`` (N, k) logged at ``t_samples``, interpolated to the times ``t``."""
    n = min(len(t), len(t_samples))
    return np.stack(
        [np.interp(t[:n], t_samples, column) for column in np.asarray(samples, dtype=float).T],
        axis=1,
    )


def actuator_envelope(scenario: Scenario, log: dict) -> dict:
    """``metrics.envelope_summary`` of the logged joint torques (interpolated to the joint
    rates' times) against the scenario's servo (``model.servo``) at the bus voltage of each
    sample: the battery's logged terminal voltage with the energy model on, else the servo
    file's supply voltage."""
    from manta_drake.model.robot_params import JOINT_NAMES
    from manta_drake.model.servo import envelope_ratio

    servo, t, qdot = scenario.energy_model().servo, log["t"], log["joint_velocities"]
    tau = _on_times(t[: len(qdot)], log["t_joint_torque"], log["joint_torque"])
    n = len(tau)
    volts = np.full(n, servo.supply_voltage)
    if len(log.get("battery", [])):
        volts = np.interp(t[:n], log["t_battery"], np.asarray(log["battery"])[:, 1])
    ratio = envelope_ratio(tau, qdot[:n], servo, volts[:, None])
    return M.envelope_summary(t[:n], ratio, JOINT_NAMES, volts)


def random_sources(system) -> list:
    """Every Drake ``RandomSource`` inside ``system``, depth first in the order the
    diagrams hold them (the order ``Diagram.SetRandomContext`` draws their seeds in)."""
    if isinstance(system, RandomSource):
        return [system]
    if isinstance(system, Diagram):
        return [s for child in system.GetSystems() for s in random_sources(child)]
    return []


def seed_context(diagram, context, seed: int) -> None:
    """Seeds every random source of ``diagram`` in ``context`` from
    ``RandomGenerator(seed)`` and changes nothing else in it: a pose, a CPG phase or a
    parameter the caller set on ``context`` stays. The sources draw their seeds in the
    order ``Diagram.SetRandomContext`` would, so a default context seeded here is the
    scenario's start with exactly the noise of that seed. Same seed, same run."""
    check_integer("seed", seed, 0, 2**32 - 1)
    generator = RandomGenerator(int(seed))
    for source in random_sources(diagram):
        source.SetRandomContext(source.GetMyMutableContextFromRoot(context), generator)


def make_simulator(diagram, scenario: Scenario, context=None, seed: int | None = None):
    """A Simulator of ``diagram`` with the scenario's integrator settings.

    Args:
        diagram: a diagram of ``build_diagram`` (or the station or controller alone).
        scenario: its scenario (the integrator settings and the seed).
        context: the root context to simulate from; None: a new default context, which is
            the scenario's start. A given context is kept as it is, only its random
            sources are seeded (``seed_context``).
        seed: the noise seed (default ``scenario.random_seed``).
    """
    simulator = Simulator(diagram) if context is None else Simulator(diagram, context)
    ApplySimulatorConfig(scenario.simulator, simulator)
    seed_context(
        diagram, simulator.get_mutable_context(), scenario.random_seed if seed is None else seed
    )
    return simulator


def _write_scenario(scenario: Scenario, folder: pathlib.Path) -> None:
    """The run's resolved scenario (every field, overrides applied): ``load_scenario`` on it
    runs the same simulation again."""
    write_atomic(folder / "scenario.yaml", SCENARIO_HEADER + scenario_yaml(scenario))


def _start_outputs(scenario: Scenario, out_dir: pathlib.Path, write_scenario: bool = True) -> None:
    """Removes our own outputs of an earlier run in ``out_dir`` (so no stale recording or
    metrics stays beside this run's) and writes this run's scenario and a ``metrics.json``
    that says it is running (``stage: build``): a run killed outright (SIGKILL, power)
    leaves that story, not the previous run's."""
    remove_outputs(out_dir)
    if write_scenario:
        _write_scenario(scenario, out_dir)
    write_metrics(out_dir, running_metrics(scenario.name, "build"))


def _write_failed_build(
    scenario: Scenario,
    out_dir: pathlib.Path,
    error: BaseException,
    stop: RunInterrupted | None = None,
) -> None:
    """The story of a run whose build failed, or was interrupted (``stop``)."""
    if stop is not None:
        write_metrics(
            out_dir,
            {
                "scenario": scenario.name,
                "status": "interrupted",
                "failure": interrupted_failure("build", 0.0, stop),
            },
        )
        return
    write_metrics(
        out_dir,
        {
            "scenario": scenario.name,
            "status": "failed",
            "failure": {
                "stage": "build",
                "time_s": 0.0,
                "reason": f"{type(error).__name__}: {error}",
            },
        },
    )


def run(
    scenario: Scenario,
    out_dir,
    progress: bool = True,
    write_outputs: bool = True,
    inputs=(),
    prepare=None,
    bag=None,
    live=None,
) -> RunResult:
    """Simulates ``scenario`` and writes its outputs into ``out_dir``.

    The folder is checked before anything is built (``check_output_folder``). This
    function's own files of an earlier run there are removed first and a ``metrics.json``
    saying ``running`` is written, so a folder never mixes two runs. Whatever happens,
    ``out_dir`` ends with a metrics.json that says so: a build failure (``status: failed``,
    ``stage: build``), a failure part-way (the log up to it, the time and the reason),
    Ctrl-C, SIGTERM or SIGHUP (``status: interrupted``, the partial log, the ``signal`` and
    ``reason: interrupted (Ctrl-C)`` or ``terminated (SIGTERM)``, then ``RunInterrupted``, a
    KeyboardInterrupt, is re-raised). Every file is written whole (a temporary file and a
    rename), metrics.json last; a signal while they are written waits until they are.

    Args:
        scenario: a validated Scenario.
        out_dir: output folder (created).
        inputs: the files the run was made from (the scenario file): refused as outputs.
        prepare: a callable ``prepare(handles, context)`` that changes the diagram's default
            context (the scenario's start) before the run, e.g. a perturbed start state. The
            folder's ``scenario.yaml`` then does not describe the run alone: it is not
            written. (A gait given as data needs none: ``studies.explicit_gait`` writes it as
            a gait file the scenario names.)
        progress: show a progress bar on stderr (only when stderr is a terminal).
        write_outputs: write plots and the recording (tests may skip them).
        bag: a ``ros2.topic_map.TopicMap``: write the log as a ROS 2 bag too (``run.mcap``
            and ``metadata.yaml``, ``ros2.bag.write_run_bag``), unless interrupted; None: no
            bag.
        live: a live view (``ros2.live.LiveView``): given the log so far after every chunk
            simulated (``live.update(log)``) and at the end; None: none.

    Returns:
        RunResult with ``.metrics``, ``.log``, ``.handles`` and the final ``.context``.

    Raises:
        SimulationError: the build or the simulation failed; the outputs above are written
            first.
        OutputFolderError: ``out_dir`` cannot take the outputs (nothing was built).
        RunInterrupted: interrupted; the partial log and metrics.json are written first.
    """
    out_dir = check_output_folder(out_dir, inputs)
    with interrupts_as_exceptions() as received:
        try:
            return _run(scenario, out_dir, progress, write_outputs, prepare, received, bag, live)
        except RunInterrupted as stop:
            with signals_deferred():
                _story_of_a_signal_between_stages(scenario, out_dir, stop)
            raise


def _story_of_a_signal_between_stages(
    scenario: Scenario, out_dir: pathlib.Path, stop: RunInterrupted
) -> None:
    """A signal that came between two stages (after the build's story was settled, before
    the run's own signal handling took over) left ``metrics.json`` saying ``running``: it
    now says ``interrupted`` at that stage."""
    try:
        metrics = json.loads((out_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        return
    if metrics.get("status") == "running":
        write_metrics(
            out_dir,
            {
                "scenario": scenario.name,
                "status": "interrupted",
                "failure": interrupted_failure(metrics.get("stage", "build"), 0.0, stop),
            },
        )


def _start_recording(handles: DiagramHandles, scenario: Scenario) -> None:
    """Meshcat's camera and the recording (if visualisation is on)."""
    if handles.meshcat is None:
        return
    # Look at the robot from inside the pool (the walls hide it from outside).
    p0 = np.asarray(scenario.initial_pose.xyz, dtype=float)
    handles.meshcat.SetCameraPose(camera_in_world=p0 + [-0.8, -0.75, 0.45], target_in_world=p0)
    handles.meshcat.SetProperty("/Grid", "visible", False)
    handles.visualizer.StartRecording(set_transforms_while_recording=False)


def _build(scenario: Scenario, out_dir: pathlib.Path, prepare, received):
    """The folder's earlier outputs replaced by this run's start, the diagram, its context
    and the Simulator; a failure or a signal here leaves the build's story."""
    try:
        with signals_deferred():
            _start_outputs(scenario, out_dir, write_scenario=prepare is None)
        diagram, handles = build_diagram(scenario)
        context = diagram.CreateDefaultContext()
        if prepare is not None:
            prepare(handles, context)
        simulator = make_simulator(diagram, scenario, context)
        _start_recording(handles, scenario)
    except (KeyboardInterrupt, Exception) as e:
        stop = interruption(e, received)  # a signal inside a pybind11 call: its TypeError
        with signals_deferred():
            _write_failed_build(scenario, out_dir, e, stop)
        if stop is e:
            raise
        if stop is not None:
            raise stop from e
        raise SimulationError(
            f"{scenario.name}: building the diagram failed: "
            f"{type(e).__name__}: {e} (metrics.json in {out_dir})"
        ) from e
    return diagram, handles, simulator


def _run(
    scenario: Scenario,
    out_dir: pathlib.Path,
    progress: bool,
    write_outputs: bool,
    prepare,
    received,
    bag=None,
    live=None,
) -> RunResult:
    diagram, handles, simulator = _build(scenario, out_dir, prepare, received)
    root_context = simulator.get_mutable_context()
    failure, interrupted = None, None
    bar = _progress(scenario.duration, progress and sys.stderr.isatty())
    wall_start = time.perf_counter()
    # From the first step until the story is written a signal only notes its name: while
    # the Simulator steps it ends the step loop (at the next step); afterwards it waits
    # until the files are written, then the interruption goes on.
    with signals_flagged() as signals:
        try:
            # Between steps: a signal noted while a step ran ends the loop here.
            simulator.set_monitor(
                lambda c: (
                    EventStatus.ReachedTermination(diagram, "signal")
                    if signals
                    else EventStatus.Succeeded()
                )
            )
            simulator.Initialize()
            # Chunk ends on the plant's step grid (an end between two steps would add a
            # tiny integrator step and change the run at round-off level); the last one is
            # exactly the duration.
            n_steps = max(1, int(round(scenario.duration / scenario.time_step)))
            n_chunks = max(1, min(200, int(np.ceil(scenario.duration / 0.05))))
            for k in range(1, n_chunks + 1):
                t_next = (
                    scenario.duration
                    if k == n_chunks
                    else round(k * n_steps / n_chunks) * scenario.time_step
                )
                status = simulator.AdvanceTo(t_next)
                stop_if_signalled(signals)
                if live is not None:  # outside the steps: it adds no event to the run
                    live.update(extract_log(handles, root_context))
                if bar is not None:
                    bar.update(root_context.get_time() - bar.n)
                if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
                    # A System ended the run (the battery at its cut-off): the run stops
                    # there and says why, rather than going on.
                    failure = {
                        "time_s": float(root_context.get_time()),
                        "reason": status.message() or "a system ended the run",
                    }
                    break
        except KeyboardInterrupt as e:
            interrupted = interruption(e)
            assert interrupted is not None  # a KeyboardInterrupt is always an interruption
            failure = interrupted_failure("simulation", root_context.get_time(), interrupted)
        except (Exception, SystemExit) as e:  # noqa: BLE001 - keep the log up to the failure
            # SystemExit: a Drake abort surfacing in Python; it must not end the process
            # without the log.
            failure = {
                "time_s": float(root_context.get_time()),
                "reason": f"{type(e).__name__}: {e}",
            }
        finally:
            if bar is not None:
                bar.close()
        wall_time = time.perf_counter() - wall_start
        try:
            log, metrics = _finish(
                scenario, handles, diagram, root_context, wall_time, failure, interrupted
            )
        except Exception as e:  # the story still says how the run ended
            _write_failed_metrics(scenario, out_dir, root_context.get_time(), e, interrupted)
            if interrupted:
                raise interrupted from e
            raise SimulationError(
                f"{scenario.name}: the run's log or metrics failed: "
                f"{type(e).__name__}: {e} (metrics.json in {out_dir})"
            ) from e
        summary = _write_outputs(
            scenario,
            out_dir,
            handles,
            log,
            metrics,
            write_outputs and not interrupted,
            None if interrupted else bag,
        )
    if interrupted:
        raise interrupted
    stop_if_signalled(signals)  # a signal after the last step: the story was written first
    if metrics["status"] == "failed":
        failure = metrics["failure"]
        raise SimulationError(
            f"{scenario.name}: simulation failed at t = {failure['time_s']:.3f} s: "
            f"{failure['reason']} (partial log in {out_dir})"
        )
    return RunResult(metrics, out_dir, log, handles, root_context, summary)


def _write_failed_metrics(
    scenario: Scenario, out_dir: pathlib.Path, time_s: float, error: Exception, interrupted
) -> None:
    """The story of a run whose log or metrics could not be computed (``stage: metrics``),
    or, if a signal had stopped it, of that interruption."""
    failure = (
        interrupted_failure("simulation", time_s, interrupted)
        if interrupted
        else {
            "stage": "metrics",
            "time_s": float(time_s),
            "reason": f"{type(error).__name__}: {error}",
        }
    )
    write_metrics(
        out_dir,
        {
            "scenario": scenario.name,
            "status": "interrupted" if interrupted else "failed",
            "failure": failure,
        },
    )


def _finish(
    scenario: Scenario,
    handles: DiagramHandles,
    diagram,
    root_context,
    wall_time: float,
    failure: dict | None,
    interrupted,
) -> tuple[dict, dict]:
    """The run's log and metrics, with its status (``ok``, ``failed`` or ``interrupted``)."""
    log = extract_log(handles, root_context)
    log["sim_time"] = np.array(root_context.get_time())
    metrics = compute_metrics(scenario, log, wall_time)
    if failure is None and "body_xyz" in log and not np.all(np.isfinite(log["body_xyz"])):
        failure = {
            "time_s": float(log["t"][np.argmax(~np.isfinite(log["body_xyz"]).any(1))]),
            "reason": "non-finite body state",
        }
    metrics["status"] = "interrupted" if interrupted else "failed" if failure else "ok"
    if failure:
        metrics["failure"] = {"stage": "simulation", **failure}
    else:
        metrics["max_penetration_m"] = max_penetration(handles, diagram, root_context)
    return log, metrics


def _write_outputs(
    scenario: Scenario,
    out_dir: pathlib.Path,
    handles: DiagramHandles,
    log: dict,
    metrics: dict,
    plots_and_recording: bool,
    bag=None,
):
    """The log, the plots and the recording, the bag (with a topic map ``bag``), then
    metrics.json (last: its presence says the others are complete). Returns the bag's
    summary (None: no bag)."""
    tmp_log = out_dir / ".log.npz.tmp.npz"
    np.savez_compressed(tmp_log, **log)
    os.replace(tmp_log, out_dir / "log.npz")
    if plots_and_recording:
        leaves = scenario.behaviour_tree().leaves if len(log.get("behaviour_weights", [])) else None
        plots.write_run_plots(
            log,
            out_dir,
            title=scenario.name,
            shade=plots.behaviour_spans(metrics.get("transitions", []), float(log["t"][-1]))
            if metrics.get("transitions")
            else None,
            leaves=leaves,
        )
        if handles.visualizer is not None:
            handles.visualizer.StopRecording()
            handles.visualizer.PublishRecording()
            assert handles.meshcat is not None  # the visualizer draws in it
            write_atomic(out_dir / "recording.html", handles.meshcat.StaticHtml())
    summary = None
    if bag is not None and len(log["t"]):
        from manta_drake.ros2.bag import write_run_bag

        summary = write_run_bag(out_dir, log, scenario, bag)
    write_metrics(out_dir, metrics)
    return summary
