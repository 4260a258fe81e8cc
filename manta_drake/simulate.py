"""The one place that runs a Simulator.

``run(scenario, out_dir)`` builds the diagram, simulates with a progress bar,
and writes into ``out_dir``:

* ``recording.html``: self-contained Meshcat recording (if visualisation is on);
* ``log.npz``: time series (see ``LOG_KEYS``);
* ``metrics.json``: the run's metrics (see ``compute_metrics`` and docs/design.md);
* ``joints.png``, ``states.png``, ``trajectory.png``.

If the simulation fails part-way, the log up to the failure and a
``metrics.json`` with ``status: failed``, the time and the reason are still
written, and the exception is re-raised as ``SimulationError``.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
import json
import math
import os
import pathlib
import signal
import sys
import threading
import time

import numpy as np
from pydrake.common import RandomGenerator
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorStatus
from pydrake.systems.framework import Diagram, EventStatus
from pydrake.systems.primitives import RandomSource

from manta_drake import metrics as M
from manta_drake import plots
from manta_drake.config_io import check_integer, check_writable_folder
from manta_drake.model.robot_params import DEFAULT_POOL, DEFAULT_ROBOT, NUM_JOINTS
from manta_drake.scenario import Scenario, scenario_yaml
from manta_drake.wiring.diagram import DiagramHandles, build_diagram, logger_data

LOG_KEYS = (
    "t", "joint_angles", "joint_velocities", "commanded_joint_angles",
    "body_xyz", "body_quat_wxyz", "body_rpy", "body_v_world", "body_w_world",
)


# Shortest steady window [s] over which a mean velocity is reported.
MIN_STEADY_WINDOW = 1.0


class SimulationError(RuntimeError):
    """The simulation failed; ``out_dir`` still holds the log up to the failure."""


@dc.dataclass
class RunResult:
    """What ``run`` returns."""

    metrics: dict
    out_dir: pathlib.Path
    log: dict
    handles: DiagramHandles | None = None
    context: object = None  # the root context at the end of the run


def _progress(total: float, enabled: bool):
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, unit="sim s", desc="simulating", file=sys.stderr,
                bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]")


def extract_log(handles: DiagramHandles, root_context) -> dict:
    """Turns the loggers' records into named numpy arrays (see ``LOG_KEYS``)."""
    plant, body = handles.plant, handles.plant_handles.body
    t, x = logger_data(handles.loggers["plant_state"], root_context)
    nq = plant.num_positions()
    joints = [plant.GetJointByName(n, handles.plant_handles.robot)
              for n in handles.plant_handles.joint_names]
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
        clearance = M.wall_clearance(xyz, q, DEFAULT_ROBOT.body_semi_axes,
                                     DEFAULT_POOL.length / 2, DEFAULT_POOL.width / 2)
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
            m["note"] = (f"steady window {start:.1f}-{end:.1f} s is shorter than "
                         f"{MIN_STEADY_WINDOW} s (the hull came within "
                         f"{scenario.free_water_margin} m of a wall): no mean velocity")
        m["distance_m"] = M.horizontal_distance(xyz)
        m["final_body_xyz"] = xyz[-1].tolist()
        m["final_body_rpy_deg"] = np.degrees(log["body_rpy"][-1]).tolist()
    if scenario.controller.mode == "transition" and len(log.get("cpg_params", [])):
        behaviours = scenario.behaviour_tree().gait_vectors
        m["transitions"] = M.behaviour_transitions(
            log["t_cpg_params"], log["cpg_params"], behaviours,
            scenario.transition.arrival_tolerance)
    if len(log.get("commanded_joint_angles", [])) >= 2:
        m["max_joint_step_rad"] = M.max_joint_step(log["commanded_joint_angles"])
        n = min(len(log["joint_angles"]), len(log["commanded_joint_angles"]))
        err = log["joint_angles"][:n] - log["commanded_joint_angles"][:n]
        m["final_max_joint_error_rad"] = float(np.abs(err[-1]).max())
    if "electrical_power" in log:  # the energy model is on (actuators.enabled)
        from manta_drake.model.actuators import load_energy_model

        a = scenario.actuators
        pack = load_energy_model(a.file, a.scales, a.electronics_mode).pack
        m["energy"] = M.energy_metrics(
            log, scenario.robot_params().total_mass, pack.usable_energy_wh(), pack.cutoff_soc,
            m.get("steady_window_s"), m.get("mean_velocity_body"))
    return m


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
    seed_context(diagram, simulator.get_mutable_context(),
                 scenario.random_seed if seed is None else seed)
    return simulator


# The files a run writes (and the only ones it removes from an old output folder).
OUTPUT_FILES = ("scenario.yaml", "recording.html", "log.npz", "metrics.json", "joints.png",
                "states.png", "trajectory.png")
SCENARIO_HEADER = ("# The resolved scenario of this run (every field, overrides applied); run it "
                   "again\n# with: manta-drake run scenario.yaml --out DIR\n")


class OutputFolderError(SimulationError):
    """The output folder cannot take a run's files; raised before anything is built."""


def check_output_folder(out_dir, inputs=(), create: bool = True) -> pathlib.Path:
    """Checks that a run can write its files into ``out_dir`` without losing anything, before
    anything expensive starts; creates the folder if ``create``.

    Refused: an empty path; a path that is a file, or under one; a folder that cannot be
    created or written; a folder holding one of ``inputs`` (a run never overwrites its own
    input) or a ``scenario.yaml`` that no run wrote (a user's own file).

    Raises:
        OutputFolderError: one line naming the folder and why.
    """
    out_dir = check_writable_folder(out_dir, "--out", "out/run", OutputFolderError, create)
    ours = {(out_dir / name).resolve() for name in OUTPUT_FILES}
    for path in inputs:
        if path is not None and pathlib.Path(path).resolve() in ours:
            raise OutputFolderError(
                f"--out {out_dir}: the run would overwrite its own input {path}; choose "
                "another output folder")
    existing = out_dir / "scenario.yaml"
    if existing.is_file():
        try:
            head = existing.read_text(encoding="utf-8", errors="replace")[:len(SCENARIO_HEADER)]
        except OSError:
            head = ""
        if head != SCENARIO_HEADER:
            raise OutputFolderError(
                f"--out {out_dir}: holds a scenario.yaml that no run wrote; a run would "
                "replace it: choose another output folder")
    return out_dir


def _write_scenario(scenario: Scenario, folder: pathlib.Path) -> None:
    """The run's resolved scenario (every field, overrides applied): ``load_scenario`` on it
    runs the same simulation again."""
    _write_atomic(folder / "scenario.yaml", SCENARIO_HEADER + scenario_yaml(scenario))


def _write_atomic(path: pathlib.Path, text: str) -> None:
    """Writes ``text`` to ``path`` through a temporary file in the same folder and a rename,
    so a reader (or a kill) never sees half a file."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def _write_metrics(out_dir: pathlib.Path, metrics: dict) -> None:
    _write_atomic(out_dir / "metrics.json", json.dumps(metrics, indent=2) + "\n")


def _start_outputs(scenario: Scenario, out_dir: pathlib.Path,
                   write_scenario: bool = True) -> None:
    """Removes our own outputs of an earlier run in ``out_dir`` (so no stale recording or
    metrics stays beside this run's) and writes this run's scenario and a ``metrics.json``
    that says it is running: a run killed outright (SIGKILL, power) leaves that story, not
    the previous run's."""
    for name in OUTPUT_FILES:
        (out_dir / name).unlink(missing_ok=True)
    if write_scenario:
        _write_scenario(scenario, out_dir)
    _write_metrics(out_dir, {
        "scenario": scenario.name, "status": "running",
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "note": "written when the run started; a run that ends replaces it, so this one is "
                "still running or was killed"})


def _write_failed_build(scenario: Scenario, out_dir: pathlib.Path, error: BaseException,
                        reason: str | None = None) -> None:
    _write_metrics(out_dir, {"scenario": scenario.name, "status": "failed",
                             "failure": {"stage": "build", "time_s": 0.0,
                                         "reason": reason or f"{type(error).__name__}: {error}"}})


def write_interrupted_start(out_dir: pathlib.Path, name: str, error: KeyboardInterrupt) -> None:
    """A run interrupted while its scenario was loaded (before ``run``): the folder's earlier
    outputs go and a metrics.json says the run never started and why."""
    for file in OUTPUT_FILES:
        (out_dir / file).unlink(missing_ok=True)
    reason = error.reason if isinstance(error, RunInterrupted) else "interrupted (Ctrl-C)"
    _write_metrics(out_dir, {"scenario": name, "status": "failed",
                             "failure": {"stage": "load", "time_s": 0.0, "reason": reason}})


class RunInterrupted(KeyboardInterrupt):
    """The run was interrupted by a signal: Ctrl-C (SIGINT), SIGTERM or SIGHUP."""

    def __init__(self, signal_name: str = "SIGINT"):
        super().__init__(signal_name)
        self.signal_name = signal_name

    @property
    def reason(self) -> str:
        return "interrupted (Ctrl-C)" if self.signal_name == "SIGINT" else \
            f"terminated ({self.signal_name})"


@contextlib.contextmanager
def interrupts_as_exceptions():
    """While inside: SIGTERM and SIGHUP raise ``RunInterrupted`` like Ctrl-C does, so a run
    stopped by a service manager, ``kill`` or a closed terminal still writes its partial log
    and a metrics.json saying why. Only in the main thread (signals go there); restored on
    exit."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise RunInterrupted(signal.Signals(signum).name)

    previous = {}
    for sig in (signal.SIGTERM, signal.SIGHUP):
        previous[sig] = signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


@contextlib.contextmanager
def _signals_flagged():
    """While inside, SIGINT, SIGTERM and SIGHUP only append their name to the yielded list.
    An exception raised by a handler in the middle of a pybind11 call (converting an argument,
    say) comes out as that call's TypeError, not as the interruption, so while the Simulator
    steps Python systems the signal is noted and acted on between steps (a monitor ends the
    step loop, the caller raises ``RunInterrupted``)."""
    pending: list = []
    if threading.current_thread() is not threading.main_thread():
        yield pending
        return

    def note(signum, frame):
        pending.append(signal.Signals(signum).name)

    previous = {sig: signal.signal(sig, note)
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        yield pending
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


@contextlib.contextmanager
def _signals_deferred():
    """While inside, SIGINT, SIGTERM and SIGHUP are held; the first one is raised on exit."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending = []

    def hold(signum, frame):
        pending.append(signal.Signals(signum).name)

    previous = {sig: signal.signal(sig, hold)
                for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
    if pending:
        raise RunInterrupted(pending[0])


def run(scenario: Scenario, out_dir, progress: bool = True, write_outputs: bool = True,
        inputs=(), prepare=None) -> RunResult:
    """Simulates ``scenario`` and writes its outputs into ``out_dir``.

    The folder is checked before anything is built (``check_output_folder``). This
    function's own files of an earlier run there are removed first and a ``metrics.json``
    saying ``running`` is written, so a folder never mixes two runs. Whatever happens,
    ``out_dir`` ends with a metrics.json that says so: a build failure (``status: failed``,
    ``stage: build``), a failure part-way (the log up to it, the time and the reason),
    Ctrl-C, SIGTERM or SIGHUP (the partial log, ``reason: interrupted (Ctrl-C)`` or
    ``terminated (SIGTERM)``, then ``RunInterrupted``, a KeyboardInterrupt, is re-raised).
    Every file is written whole (a temporary file and a rename), metrics.json last.

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

    Returns:
        RunResult with ``.metrics``, ``.log``, ``.handles`` and the final ``.context``.

    Raises:
        SimulationError: the build or the simulation failed; the outputs above are written
            first.
        OutputFolderError: ``out_dir`` cannot take the outputs (nothing was built).
        RunInterrupted: interrupted; the partial log and metrics.json are written first.
    """
    out_dir = check_output_folder(out_dir, inputs)
    with interrupts_as_exceptions():
        return _run(scenario, out_dir, progress, write_outputs, prepare)


def _run(scenario: Scenario, out_dir: pathlib.Path, progress: bool,
         write_outputs: bool, prepare) -> RunResult:
    _start_outputs(scenario, out_dir, write_scenario=prepare is None)
    try:
        diagram, handles = build_diagram(scenario)
        context = diagram.CreateDefaultContext()
        if prepare is not None:
            prepare(handles, context)
        simulator = make_simulator(diagram, scenario, context)
    except KeyboardInterrupt as e:
        reason = e.reason if isinstance(e, RunInterrupted) else "interrupted (Ctrl-C)"
        _write_failed_build(scenario, out_dir, e, reason)
        raise
    except Exception as e:
        _write_failed_build(scenario, out_dir, e)
        raise SimulationError(f"{scenario.name}: building the diagram failed: "
                              f"{type(e).__name__}: {e} (metrics.json in {out_dir})") from e
    root_context = simulator.get_mutable_context()
    if handles.meshcat is not None:
        # Look at the robot from inside the pool (the walls hide it from outside).
        p0 = np.asarray(scenario.initial_pose.xyz, dtype=float)
        handles.meshcat.SetCameraPose(camera_in_world=p0 + [-0.8, -0.75, 0.45], target_in_world=p0)
        handles.meshcat.SetProperty("/Grid", "visible", False)
        handles.visualizer.StartRecording(set_transforms_while_recording=False)

    failure, interrupted = None, False
    bar = _progress(scenario.duration, progress and sys.stderr.isatty())
    wall_start = time.perf_counter()
    try:
        with _signals_flagged() as signals:
            # Between steps: a signal noted while a step ran ends the loop here.
            simulator.set_monitor(lambda c: EventStatus.ReachedTermination(diagram, "signal")
                                  if signals else EventStatus.Succeeded())
            simulator.Initialize()
            # Chunk ends on the plant's step grid (an end between two steps would add a
            # tiny integrator step and change the run at round-off level); the last one is
            # exactly the duration.
            n_steps = max(1, int(round(scenario.duration / scenario.time_step)))
            n_chunks = max(1, min(200, int(np.ceil(scenario.duration / 0.05))))
            for k in range(1, n_chunks + 1):
                t_next = (scenario.duration if k == n_chunks
                          else round(k * n_steps / n_chunks) * scenario.time_step)
                status = simulator.AdvanceTo(t_next)
                if signals:
                    raise RunInterrupted(signals[0])
                if bar is not None:
                    bar.update(root_context.get_time() - bar.n)
                if status.reason() == \
                        SimulatorStatus.ReturnReason.kReachedTerminationCondition:
                    # A System ended the run (the battery at its cut-off): the run stops
                    # there and says why, rather than going on.
                    failure = {"time_s": float(root_context.get_time()),
                               "reason": status.message() or "a system ended the run"}
                    break
    except KeyboardInterrupt as e:
        interrupted = e if isinstance(e, RunInterrupted) else RunInterrupted("SIGINT")
        failure = {"time_s": float(root_context.get_time()), "reason": interrupted.reason}
    except (Exception, SystemExit) as e:  # keep the log of what happened up to the failure
        # SystemExit: a Drake abort surfacing in Python; it must not end the process
        # without the log.
        failure = {"time_s": float(root_context.get_time()), "reason": f"{type(e).__name__}: {e}"}
    finally:
        if bar is not None:
            bar.close()
    wall_time = time.perf_counter() - wall_start

    log = extract_log(handles, root_context)
    log["sim_time"] = np.array(root_context.get_time())
    metrics = compute_metrics(scenario, log, wall_time)
    if failure is None and "body_xyz" in log and not np.all(np.isfinite(log["body_xyz"])):
        failure = {"time_s": float(log["t"][np.argmax(~np.isfinite(log["body_xyz"]).any(1))]),
                   "reason": "non-finite body state"}
    metrics["status"] = "failed" if failure else "ok"
    if failure:
        metrics["failure"] = {"stage": "simulation", **failure}
    elif not interrupted:
        metrics["max_penetration_m"] = max_penetration(handles, diagram, root_context)

    # A second signal while the files are written must not cut them short: the story is
    # written whole, then the interruption goes on.
    with _signals_deferred():
        tmp_log = out_dir / ".log.npz.tmp.npz"
        np.savez_compressed(tmp_log, **log)
        os.replace(tmp_log, out_dir / "log.npz")
        if write_outputs and not interrupted:
            plots.write_run_plots(log, out_dir, title=scenario.name)
            if handles.visualizer is not None:
                handles.visualizer.StopRecording()
                handles.visualizer.PublishRecording()
                _write_atomic(out_dir / "recording.html", handles.meshcat.StaticHtml())
        _write_metrics(out_dir, metrics)  # last: its presence says the others are complete
    if interrupted:
        raise interrupted
    if failure:
        raise SimulationError(
            f"{scenario.name}: simulation failed at t = {failure['time_s']:.3f} s: "
            f"{failure['reason']} (partial log in {out_dir})"
        )
    return RunResult(metrics, out_dir, log, handles, root_context)
