#!/usr/bin/env python3
"""Real-time factors of the simulator, as interleaved rounds in one process (docs/performance.md).

Cases (no Meshcat, progress bars off):

  (a)       the plant alone: the ``stand`` scenario (the robot holding its gait stance on
            the pool floor, constant joint targets, no water: no Python system);
  LB        the physical limit of (b): the same plant as (b) (water's added inertia, the
            force input connected) with C++ sources replaying what (b)'s Python systems
            gave it (the CPG's desired state and the water's generalized forces, recorded
            from a (b) run), so only the plant and Drake's C++ are left;
  (b)       the closed loop without camera: ``two_behaviors`` (plant, water with forces
            held 4 ms as shipped, balloon, pressure sensor, fuzzy depth, potential
            transition, CPG);
  (b exact) the same with the water's forces at every step (``water.update_period: 0``);
  (c)       the closed loop with the camera: ``three_behaviors``;
  (b ref)   optional (``--reference``): (b) on the reference paths that
            ``build_diagram`` offers beside the compiled ones: the water's
            contract ports (per-body poses and velocities in, the force list out) and the
            CPG's numpy functions (``hydro_plant_state=False, compiled_cpg=False``); the
            water's maths stay compiled there (``build_diagram`` takes no choice of the
            water's backend: ``scripts/benchmark_hydro.py`` times the numpy maths);
  (c) plant SG  optional (``--camera-in-plant-scene``): (c) with the camera rendering in
            the plant's SceneGraph (its VTK poses move at every plant step);
  (b) 2 ms, (c) 2 ms  optional (``--two-ms``): the plant and integrator at 2 ms.
  (b) cross-flow  optional (``--cross-flow``): (b) with the earlier cross-flow fins, so
            (b) / (b) cross-flow is what the foil fins' terms cost.

Every case's diagram is built once. A round makes a fresh context for every case at its
scenario's start, advances each ``--warmup`` s untimed (the first camera frame and the
first kernel calls happen there), then times the next ``--duration`` s of every case in
chunks of ``--chunk`` s taken in turn (the order rotates), so a change of load from other
processes on the machine hits every case alike, within the round too. Each case reports
the median and the range over the rounds of its real-time factor (simulated s per wall
s) and of its ratio to (a) in the same round. Startup (imports, kernel compilation or
cache load, building the diagrams, the first rendered frame) is measured separately and
not in the ratios.

Then a per-step cost table: (b) and (c) once more with every Python system's callbacks
timed (outermost call only); what is left of the step is the plant and Drake's C++ with
the crossings into Python.

Goals (reported, not tested): (b) >= 0.7 (a), (c) >= 0.5 (a).

Usage: python scripts/benchmark.py [--duration 10] [--rounds 5] [--warmup 0.3]
       [--chunk 0.25] [--reference] [--camera-in-plant-scene] [--two-ms] [--no-table]
       [--no-startup]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

T_IMPORT_START = time.perf_counter()

import numpy as np  # noqa: E402

from manta_drake.scenario import load_scenario  # noqa: E402
from manta_drake.simulate import make_simulator  # noqa: E402
from manta_drake.wiring.diagram import build_diagram  # noqa: E402

T_IMPORTED = time.perf_counter()

GOALS = {"(b)": 0.7, "(c)": 0.5}


def scenario(name: str, time_step: float | None = None, **water):
    """A shipped scenario without Meshcat; ``time_step`` also sets the integrator's step
    (and the log period, which may not be shorter)."""
    s = load_scenario(name)
    s.visualization.meshcat = False
    for key, value in water.items():
        setattr(s.water, key, value)
    if time_step is not None:
        s.time_step = s.simulator.max_step_size = time_step
        s.log_period = max(s.log_period, time_step)
    return s.validate()


class Case:
    """One diagram, timed from a fresh context at its start."""

    def __init__(self, label: str, scenario_, diagram, handles=None):
        self.label, self.scenario, self.diagram, self.handles = label, scenario_, diagram, handles
        self.rtf: list[float] = []

    def simulator(self):
        return make_simulator(self.diagram, self.scenario)


def run_round(cases, warmup: float, duration: float, chunk: float, first: int = 0) -> None:
    """One round: every case from a fresh context at its start, ``warmup`` s untimed, then
    ``duration`` s timed in chunks of ``chunk`` s taken in turn (case ``first`` first), so
    that all cases run under the same load; appends each case's real-time factor."""
    simulators = []
    for case in cases:
        simulator = case.simulator()
        simulator.Initialize()
        simulator.AdvanceTo(warmup)
        simulators.append(simulator)
    wall = [0.0] * len(cases)
    n_chunks = max(1, round(duration / chunk))
    order = list(range(first, len(cases))) + list(range(first))
    for k in range(1, n_chunks + 1):
        t_end = warmup + duration * k / n_chunks
        for i in order:
            start = time.perf_counter()
            simulators[i].AdvanceTo(t_end)
            wall[i] += time.perf_counter() - start
        order = order[1:] + order[:1]
    for case, seconds in zip(cases, wall):
        case.rtf.append(duration / seconds)


def build_case(label: str, scenario_, **build) -> Case:
    """A case of the diagram ``build_diagram(scenario_, **build)`` builds (its keywords
    choose the reference implementations)."""
    diagram, handles = build_diagram(scenario_, **build)
    return Case(label, scenario_, diagram, handles)


def record_replay(case_b: Case, warmup: float, duration: float) -> dict:
    """What (b)'s Python systems gave its plant, recorded from a (b) run: the desired
    state and the water's generalized forces at every 1 ms step."""
    from manta_drake.wiring.diagram import logger_data

    simulator = case_b.simulator()
    simulator.AdvanceTo(warmup + duration + 0.01)
    context = simulator.get_context()
    handles = case_b.handles
    t, x = logger_data(handles.loggers["plant_state"], context)
    td, desired = logger_data(handles.loggers["desired_state"], context)
    tb, balloon = logger_data(handles.loggers["balloon_volume"], context)
    # The water's generalized forces at each logged state (exact per-step forces, the
    # hull's acceleration from the previous sample): close to what (b) applied.
    hydro = handles.systems["hydro"]
    plant = handles.plant
    tau = np.zeros((len(t), plant.num_velocities()))
    v_prev = np.tile(np.r_[np.zeros(6), -1.0], 2)  # the system's velocity samples: none yet
    # The floating hull's [w_W, v_W] in the state vector.
    hull = plant.num_positions() + handles.plant_handles.body.floating_velocities_start_in_v()
    for k in range(len(t)):
        volume = float(balloon[max(0, np.searchsorted(tb, t[k], "right") - 1), 0])
        F = hydro.compute_from_state(x[k], volume, t[k], v_prev)
        tau[k] = hydro.generalized_forces(x[k], F)
        v_prev = np.r_[x[k, hull + 3 : hull + 6], x[k, hull : hull + 3], t[k], v_prev[:7]]
    return {"t": t, "tau": tau, "t_desired": td, "desired": desired}


def physical_limit_builder(s, replay: dict):
    """(builder, PlantHandles, desired-state source) of LB: (b)'s plant (same model, added
    inertia, friction, start) with C++ TrajectorySources replaying ``replay``, and the
    same 1 ms loggers as the full diagram. Not built, so a caller can add to it."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import LogVectorOutput, TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    from manta_drake.model.coefficients import load_coefficients, scale_coefficients
    from manta_drake.model.plant import add_plant, set_contact_friction
    from manta_drake.scenario import resolve_path
    from manta_drake.wiring.station import _set_default_start, fin_added_mass

    builder = DiagramBuilder()
    coeffs = scale_coefficients(
        load_coefficients(resolve_path(s.water.coefficients)), s.water.coefficient_scales
    )
    ph = add_plant(
        builder,
        time_step=s.time_step,
        discrete_contact_approximation=s.discrete_contact_approximation,
        hydro=coeffs,
        robot_params=s.robot_params(),
        fin_added_mass=fin_added_mass(s),
    )
    set_contact_friction(ph, s.contact.friction)
    _set_default_start(ph, s)
    plant = ph.plant
    forces = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.ZeroOrderHold(replay["t"], replay["tau"].T))
    )
    targets = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.ZeroOrderHold(replay["t_desired"], replay["desired"].T)
        )
    )
    builder.Connect(forces.get_output_port(), plant.get_applied_generalized_force_input_port())
    builder.Connect(targets.get_output_port(), plant.get_desired_state_input_port(ph.robot))
    LogVectorOutput(plant.get_state_output_port(), builder, s.log_period)
    LogVectorOutput(targets.get_output_port(), builder, s.log_period)
    return builder, ph, targets


def build_physical_limit(case_b: Case, warmup: float, duration: float) -> Case:
    """LB: (b)'s plant with C++ sources replaying (b)'s desired state and water forces."""
    builder, _, _ = physical_limit_builder(case_b.scenario, record_replay(case_b, warmup, duration))
    return Case("LB", case_b.scenario, builder.Build())


# --- startup ---------------------------------------------------------------------------------

STARTUP_CODE = """
import time
t0 = time.perf_counter()
from manta_drake.wiring.diagram import build_diagram
from manta_drake.scenario import load_scenario
from manta_drake.simulate import make_simulator
t1 = time.perf_counter()
s = load_scenario("two_behaviors"); s.visualization.meshcat = False; s.validate()
diagram, _ = build_diagram(s)
simulator = make_simulator(diagram, s)
t2 = time.perf_counter()
simulator.AdvanceTo(0.01)  # the first calls of every kernel: compiled, or loaded from the cache
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2)
"""


def measure_startup() -> dict:
    """A fresh interpreter building (b) and taking its first 10 steps: with an empty
    numba cache (the kernels compile) and with the cache (they load)."""
    import tempfile

    out = {}
    with tempfile.TemporaryDirectory() as empty:
        for label, env in (("compile", {"NUMBA_CACHE_DIR": empty}), ("cached", {})):
            result = subprocess.run(
                [sys.executable, "-c", STARTUP_CODE],
                capture_output=True,
                text=True,
                env={**os.environ, **env},
                check=True,
            )
            out[label] = tuple(float(v) for v in result.stdout.split())
    return out


def first_frame_cost(case_c: Case) -> tuple[float, float]:
    """Wall time of the camera's first rendered frame in a new context, and of a later one."""
    camera = case_c.handles.systems["camera"]
    simulator = case_c.simulator()
    context = camera.GetMyContextFromRoot(simulator.get_context())
    port = camera.depth_image_32F_output_port()
    start = time.perf_counter()
    port.Eval(context)
    first = time.perf_counter() - start
    simulator.AdvanceTo(0.05)  # new poses: the next Eval renders again
    start = time.perf_counter()
    port.Eval(camera.GetMyContextFromRoot(simulator.get_context()))
    return first, time.perf_counter() - start


# --- per-step cost table ---------------------------------------------------------------------


class CallbackTimer:
    """Times the callbacks of this package's Python systems (outermost call only, so a
    helper called inside a callback is not counted twice). Installed on the classes
    before the diagrams are built, so the systems declare the timed methods."""

    def __init__(self):
        self.time: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._depth = 0
        self._patched = []

    def install(self, classes):
        for cls in classes:
            for name, value in list(vars(cls).items()):
                if (
                    callable(value)
                    and not name.startswith("__")
                    and not isinstance(value, (staticmethod, classmethod, type))
                ):
                    self._patched.append((cls, name, value))
                    setattr(cls, name, self._wrap(cls.__name__, value))

    def uninstall(self):
        for cls, name, value in reversed(self._patched):
            setattr(cls, name, value)
        self._patched.clear()

    def reset(self):
        self.time.clear()
        self.calls.clear()

    def _wrap(self, label, function):
        timer = self

        def timed(*args, **kwargs):
            if timer._depth:
                return function(*args, **kwargs)
            timer._depth += 1
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                timer.time[label] = timer.time.get(label, 0.0) + time.perf_counter() - start
                timer.calls[label] = timer.calls.get(label, 0) + 1
                timer._depth -= 1

        timed.__name__ = function.__name__
        return timed


def python_system_classes():
    """The LeafSystem classes of the two halves' packages (every module, so a new or
    renamed one is timed without editing this list)."""
    import importlib
    import pkgutil

    from pydrake.systems.framework import LeafSystem

    import manta_drake.control
    import manta_drake.station

    modules = [
        importlib.import_module(info.name)
        for package in (manta_drake.control, manta_drake.station)
        for info in pkgutil.iter_modules(package.__path__, package.__name__ + ".")
    ]
    return sorted(
        {
            obj
            for m in modules
            for obj in vars(m).values()
            if isinstance(obj, type)
            and issubclass(obj, LeafSystem)
            and obj.__module__.startswith("manta_drake")
        },
        key=lambda c: c.__name__,
    )


def cost_table(cases, warmup: float, duration: float, per_step_a: float, per_step_lb: float):
    timer = CallbackTimer()
    timer.install(python_system_classes())
    try:
        rows = {}
        for label, s in cases:
            case = build_case(label, s)
            simulator = case.simulator()
            simulator.Initialize()
            simulator.AdvanceTo(warmup)
            timer.reset()
            start = time.perf_counter()
            simulator.AdvanceTo(warmup + duration)
            wall = time.perf_counter() - start
            steps = duration / s.time_step
            rows[label] = (
                wall / steps,
                {k: (timer.time[k] / steps, timer.calls[k] / steps) for k in timer.time},
            )
    finally:
        timer.uninstall()
    labels = [label for label, _ in cases]
    systems = sorted(
        {k for _, per in rows.values() for k in per},
        key=lambda k: -max(rows[lab][1].get(k, (0, 0))[0] for lab in labels),
    )
    print(
        "\nPer-step cost (us per 1 ms step; Python callbacks timed, outermost call only;"
        " calls per step in brackets):"
    )
    print(f"  {'':38s}" + "".join(f"{lab:>20s}" for lab in labels))
    for k in systems:
        cells = []
        for lab in labels:
            cost, calls = rows[lab][1].get(k, (0.0, 0.0))
            cells.append(f"{cost * 1e6:9.1f} [{calls:5.2f}]  " if calls else f"{'-':>18s}  ")
        print(f"  {k:38s}" + "".join(cells))
    python = {lab: sum(c for c, _ in rows[lab][1].values()) for lab in labels}
    print(
        f"  {'Python systems, total':38s}"
        + "".join(f"{python[lab] * 1e6:9.1f}{'':11s}" for lab in labels)
    )
    print(
        f"  {'plant + Drake C++ + crossings (rest)':38s}"
        + "".join(f"{(rows[lab][0] - python[lab]) * 1e6:9.1f}{'':11s}" for lab in labels)
    )
    print(
        f"  {'step (timed run)':38s}"
        + "".join(f"{rows[lab][0] * 1e6:9.1f}{'':11s}" for lab in labels)
    )
    print(
        f"  for comparison: (a) plant alone {per_step_a * 1e6:.1f} us/step, LB (the plant "
        f"of (b) with C++ sources) {per_step_lb * 1e6:.1f} us/step (medians above)"
    )


# --- main ------------------------------------------------------------------------------------


def summary(values):
    return statistics.median(values), min(values), max(values)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--duration", type=float, default=10.0, help="timed sim s per case and round"
    )
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--warmup", type=float, default=0.3, help="untimed sim s per round")
    parser.add_argument(
        "--chunk",
        type=float,
        default=0.25,
        help="sim s each case runs before the next takes its turn",
    )
    parser.add_argument(
        "--reference",
        action="store_true",
        help="also time (b) on the reference paths (the water's per-body "
        "ports, the CPG's numpy functions)",
    )
    parser.add_argument(
        "--camera-in-plant-scene",
        action="store_true",
        help="also time (c) with the camera rendering in the plant's SceneGraph",
    )
    parser.add_argument(
        "--two-ms",
        action="store_true",
        help="also time (b) and (c) with a 2 ms plant and integrator step",
    )
    parser.add_argument(
        "--cross-flow",
        action="store_true",
        help="also time (b) with the cross-flow fins (water.fin_model: "
        "cross_flow): what the foil fins' terms cost",
    )
    parser.add_argument("--no-table", action="store_true", help="skip the per-step table")
    parser.add_argument("--no-startup", action="store_true", help="skip the startup costs")
    args = parser.parse_args()
    w, d = args.warmup, args.duration
    print(
        f"machine: {os.cpu_count()} cores; load average before: "
        f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}"
    )

    t0 = time.perf_counter()
    s_b = scenario("two_behaviors")
    cases = [
        build_case("(a)", scenario("stand")),
        build_case("(b)", s_b),
        build_case("(b exact)", scenario("two_behaviors", update_period=0.0)),
        build_case("(c)", scenario("three_behaviors")),
    ]
    t_build = time.perf_counter() - t0
    if args.reference:
        cases.append(
            build_case(
                "(b ref)", scenario("two_behaviors"), hydro_plant_state=False, compiled_cpg=False
            )
        )
    if args.camera_in_plant_scene:
        cases.append(
            build_case("(c) plant SG", scenario("three_behaviors"), camera_own_scene=False)
        )
    if args.cross_flow:
        cases.append(
            build_case("(b) cross-flow", scenario("two_behaviors", fin_model="cross_flow"))
        )
    if args.two_ms:
        cases += [
            build_case("(b) 2 ms", scenario("two_behaviors", time_step=0.002)),
            build_case("(c) 2 ms", scenario("three_behaviors", time_step=0.002)),
        ]
    t0 = time.perf_counter()
    cases.insert(1, build_physical_limit(cases[1], w, d))
    t_lb = time.perf_counter() - t0

    ratios = {c.label: [] for c in cases}
    for r in range(args.rounds):
        run_round(cases, w, d, args.chunk, r % len(cases))
        a = cases[0].rtf[-1]
        for case in cases:
            ratios[case.label].append(case.rtf[-1] / a)
        print(
            f"round {r + 1}/{args.rounds}: "
            + ", ".join(f"{c.label} {c.rtf[-1]:.2f}x" for c in cases),
            flush=True,
        )

    print(
        f"\nReal-time factors over {args.rounds} interleaved rounds of {d:g} sim s each "
        f"(after {w:g} s untimed), median [min, max]; ratio to (a) in the same round:"
    )
    for case in cases:
        med, lo, hi = summary(case.rtf)
        rmed, rlo, rhi = summary(ratios[case.label])
        goal = GOALS.get(case.label)
        verdict = (
            ""
            if goal is None
            else (f"   goal >= {goal:.2f} (a): {'met' if rmed >= goal else 'NOT met'}")
        )
        print(
            f"  {case.label:10s} {med:6.2f}x real time [{lo:5.2f}, {hi:5.2f}]   "
            f"/(a) = {rmed:.2f} [{rlo:.2f}, {rhi:.2f}]{verdict}"
        )
    lb = statistics.median(ratios["LB"])
    b = statistics.median(ratios["(b)"])
    print(f"  (b) runs at {b / lb:.2f} of LB's speed (LB/(a) = {lb:.2f})")
    for label in ("(b)", "(c)"):
        if f"{label} 2 ms" in ratios:
            gain = statistics.median(
                r2 / r1 for r1, r2 in zip(ratios[label], ratios[f"{label} 2 ms"])
            )
            print(f"  {label} with a 2 ms step: {gain:.2f}x the speed of {label} at 1 ms")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")

    print("\nStartup (not in the ratios):")
    print(
        f"  imports (pydrake, manta_drake, numba kernels from cache) in this process: "
        f"{T_IMPORTED - T_IMPORT_START:.2f} s"
    )
    print(
        f"  building (a), (b), (b exact) and (c): {t_build:.2f} s; recording (b) and "
        f"building LB: {t_lb:.2f} s"
    )
    if not args.no_startup:
        startup = measure_startup()
        for label, (imports, build, first) in startup.items():
            what = (
                "empty numba cache, the kernels compile"
                if label == "compile"
                else "with the compile cache"
            )
            print(
                f"  fresh interpreter ({what}): imports {imports:.2f} s, building (b) "
                f"{build:.2f} s, its first 10 steps {first:.2f} s"
            )
        first, later = first_frame_cost(next(c for c in cases if c.label == "(c)"))
        print(
            f"  camera: first rendered frame in a new context {first * 1e3:.0f} ms, a later "
            f"frame {later * 1e3:.1f} ms"
        )
    if not args.no_table:
        per_step = {c.label: c.scenario.time_step / statistics.median(c.rtf) for c in cases}
        cost_table(
            [
                ("(b)", s_b),
                ("(b exact)", scenario("two_behaviors", update_period=0.0)),
                ("(c)", scenario("three_behaviors")),
            ],
            w,
            d,
            per_step["(a)"],
            per_step["LB"],
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
