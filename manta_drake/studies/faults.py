"""Fault campaign: many seeded random scenarios with faults, each in its own process.

Every run starts from a shipped scenario chosen at random (camera runs are slower and
kept to a small share) and draws faults from a seeded numpy Generator:

* water currents up to 0.3 m/s in random 3-D directions, and a few above the 1 m/s the
  scenario allows (they must be refused, naming ``water.current_schedule``);
* hydrodynamic coefficient scales x0.5-1.5 on random subsets of the coefficient file's
  entries (``water.coefficient_scales``), and a few bad ones (a negative factor, an
  unknown name: must be refused); a scale that leaves ``fins.strips_per_plate`` a
  fraction is also expected to be refused (the coefficient file itself refuses it);
* pressure-sensor noise (up to 0.02 m) and dropouts (up to 0.5), depth-camera range noise
  (up to 0.03 m; a few above it must be refused) and pixel dropouts; the camera switched
  on in a few runs that have none;
* starts: tilted (roll, pitch up to 45 deg, any yaw), upside down, near a wall (0.45-0.9 m
  from it, may be refused if a fin reaches it), and starts that must be refused: inside a
  wall, below the floor, above the water surface;
* plant time steps 0.5-2 ms (``simulator.max_step_size`` and ``log_period`` matched), a few
  out of range (must be refused); contact friction 0.3-1.2; water update periods 0-8 ms;
  random balloon fills and commands; swapped gaits and stances;
* short durations (2-4 s).

Each run is one ``dask.distributed`` task on the cluster of ``manta_drake.cluster``
(``--workers N``: a local cluster of N single-threaded worker processes; ``--scheduler
ADDRESS``: a running one, whose scheduler must allow no retry,
``distributed.scheduler.allowed-failures: 0``, and whose workers must see ``--runs-dir``).
A worker that dies (segfault, abort, out of memory) is recorded as a *crash* of the run it
was executing (the scheduler allows no retry, so the death surfaces as ``KilledWorker`` on
that future); a run that exceeds ``--run-timeout`` is killed and recorded as a *timeout*.
Neither stops the campaign: the nanny starts a fresh worker.

Outcomes per run:

  ok            the run finished (``simulate.run`` returned)
  refused       the scenario raised ``ScenarioError`` (the field it names is the cause)
  build_failed  ``simulate.run`` raised ``SimulationError`` at the build stage
  sim_failed    ``simulate.run`` raised ``SimulationError`` part-way (the reason is the cause)
  exception     any other exception (its type is the cause): a bug
  crashed       the worker process died during the run: a bug
  timeout       the run exceeded ``--run-timeout``: a hang, a bug

Per run it records the drawn faults, the outcome and its cause and message, whether any
logged state is NaN/inf, the deepest contact penetration, whether the hull's origin left
the pool's volume (beyond a wall, below the floor, or more than 0.2 m above the surface),
the largest joint-limit violation [rad] and joint speed [rad/s], mean and largest body
speed, largest body angular rate, and wall time. Into the runs folder ``DIR``
(``--runs-dir``, default ``out/faults``) it writes ``DIR/specs.json`` (the drawn specs),
``DIR/runs.csv`` (one row per run), ``DIR/summary.json`` (the summary as data), and per run
``DIR/runs/run_NNNN/scenario.yaml`` (the base scenario's YAML with the faults merged in:
``manta-drake run DIR/runs/run_NNNN/scenario.yaml`` reproduces it) and its
``metrics.json`` (``log.npz`` kept only for runs that did not end ``ok`` / ``refused`` or
showed NaN, a pool exit or a limit violation). It prints the summary as text
(``templates/faults_summary.txt.j2``) and writes no page: docs/fault_campaign.md's results
are read from the summary.

Usage (``--runs N`` is how many runs, ``--runs-dir DIR`` where they go):
  manta-drake study faults --runs 300 --seed 1 --runs-dir out/faults --workers 2
  manta-drake study faults --runs 20 --seed 3 --runs-dir /tmp/fc --duration 1 --check

Exit status: 1 if any run crashed, timed out, produced NaN without failing, or raised an
unexpected exception type (with ``--strict`` also: a fault that must be refused was
accepted, or an accepted start already had a fin or the hull > 2.5 mm inside the floor or a
wall); 0 otherwise. docs/fault_campaign.md describes the summary.
"""

from __future__ import annotations

import collections
import contextlib
import copy
import csv
import dataclasses
import json
import os
import pathlib
import re
import shutil
import socket
import sys
import time
import traceback

import numpy as np

from manta_drake.config_io import check_in_range, check_integer, check_writable_folder
from manta_drake.model.coefficients import RANGES, load_coefficients
from manta_drake.scenario import MAX_DURATION_S, MAX_RANDOM_SEED, coefficient_names
from manta_drake.studies.options import StudyParser, needs

# --- what is drawn -------------------------------------------------------------------------

# Base scenarios and their weights. three_behaviors has the camera (VTK rendering, point
# clouds): ~2x slower, so its share is small.
BASES = {
    "locomotion_swim": 0.18,
    "locomotion_trot": 0.13,
    "locomotion_walk": 0.12,
    "locomotion_crab": 0.10,
    "locomotion_turning": 0.10,
    "two_behaviors": 0.13,
    "float_sink": 0.10,
    "stand": 0.08,
    "three_behaviors": 0.05,
}
CAMERA_BASES = ("three_behaviors",)
NO_WATER_BASES = ("stand",)
GAIT_NAMES = ("swim", "trot", "walk", "turning", "crab")

# Fault probabilities (independent per run).
P = {
    "current": 0.45,
    "current_over": 0.04,
    "coeff_scales": 0.5,
    "coeff_scale_bad": 0.05,
    "pressure_noise": 0.4,
    "depth_noise": 0.3,
    "depth_noise_over": 0.04,
    "camera_on": 0.02,
    "time_step": 0.35,
    "time_step_bad": 0.02,
    "friction": 0.15,
    "update_period": 0.2,
    "balloon": 0.15,
    "gait_swap": 0.1,
}
# Each run's duration [s] when --duration does not fix it, and the earliest time of a drawn
# balloon command (the command's time is drawn in [BALLOON_COMMAND_AFTER_S, duration], so a
# duration below it leaves no time to draw from).
DURATION_RANGE_S = (2.0, 4.0)
BALLOON_COMMAND_AFTER_S = 0.3
STARTS = {
    "none": 0.50,
    "tilted": 0.18,
    "upside_down": 0.08,
    "near_wall": 0.12,
    "inside_wall": 0.04,
    "below_floor": 0.04,
    "above_surface": 0.04,
}

# Pool (manta_drake.model.robot_params.DEFAULT_POOL; repeated here so drawing needs no
# Drake import) and the "far above the surface" bound for the hull's origin.
HALF_X, HALF_Y, FLOOR_Z = 7.5, 1.0, -0.5
ABOVE_SURFACE_Z = 0.2  # m: the walls' height above the water

# Thresholds the summary counts against.
PENETRATION_FLAG = 0.005  # m
# The start-pose check allows a resting contact within 2 mm; deeper at t = 0 is a start that
# should have been refused.
START_CONTACT_FLAG = 0.0025  # m
JOINT_LIMIT_FLAG = 0.01  # rad
JOINT_SPEED_LIMIT = 8.0  # rad/s (DEFAULT_ROBOT.velocity_limit)

# Entries the coefficient file requires to be > 0 (manta_drake.model.coefficients.POSITIVE).
POSITIVE_ENTRIES = (
    "water_density",
    "gravity",
    "body.sealed_volume",
    "body.sealed_semi_axes",
    "fins.strips_per_plate",
    "fins.normal_force_coefficient",
    "fins.passive_pitch_reference_pressure",
    "balloon.max_volume",
    "balloon.pump_rate",
)

OUTCOMES = ("ok", "refused", "build_failed", "sim_failed", "exception", "crashed", "timeout")
EXPECTED_EXCEPTIONS = ("ScenarioError", "SimulationError")


# The shipped coefficient file's constants that have physical ranges (coefficients.RANGES).
_SHIPPED_CONSTANTS = {name: float(getattr(load_coefficients(), name).value) for name in RANGES}


def _unit_vector(rng) -> list[float]:
    v = rng.normal(size=3)
    return (v / np.linalg.norm(v)).tolist()


def _r(x, nd=6):
    return float(round(float(x), nd))


def _weights(table: dict) -> np.ndarray:
    """The probabilities of a weight table (``BASES``, ``STARTS``) for ``rng.choice``."""
    return np.array(list(table.values())) / sum(table.values())


@dataclasses.dataclass
class _Drawn:
    """One run's draws so far: the overrides (dotted field -> value), the fault tags and the
    fields that must be refused."""

    o: dict
    faults: list[str] = dataclasses.field(default_factory=list)
    expect: list[str] = dataclasses.field(default_factory=list)


def draw_spec(rng, run: int, duration: float | None, coeff_names, bases: dict) -> dict:
    """One run's scenario: a base scenario name, the overrides (dotted field -> value), the
    fault tags, and the fields that must be refused (empty: the run must be accepted).

    Args:
        rng: the campaign's numpy Generator (every draw comes from it, in a fixed order).
        run: the run's index.
        duration: every run's duration [s] (at least ``BALLOON_COMMAND_AFTER_S``); None:
            drawn in ``DURATION_RANGE_S``.
        coeff_names: the dotted coefficient names a scale may name.
        bases: the loaded base Scenario of each name in ``BASES``.
    """
    base = str(rng.choice(list(BASES), p=_weights(BASES)))
    data = bases[base]
    water = base not in NO_WATER_BASES
    dur = _r(duration if duration is not None else rng.uniform(*DURATION_RANGE_S), 3)
    d = _Drawn(
        {
            "name": f"fault_{run:04d}_{base}",
            "duration": dur,
            "random_seed": int(rng.integers(0, 2**31 - 1)),
            "visualization.meshcat": False,
        }
    )
    _draw_current(rng, d, water)
    if water and rng.random() < P["coeff_scales"]:
        _draw_scales(rng, d, coeff_names)
    if rng.random() < P["coeff_scale_bad"]:
        _draw_bad_scale(rng, d, coeff_names)
    camera = _draw_sensors(rng, d, water, bool(data.camera.enabled))
    if data.controller.mode != "transition" and rng.random() < P["gait_swap"]:
        d.o["controller.gait"] = str(rng.choice(GAIT_NAMES))
        d.o["initial_stance"] = str(rng.choice(GAIT_NAMES + ("zero",)))
        d.faults.append("gait_swap")
    _draw_start(rng, d, data)
    _draw_steps(rng, d)
    _draw_contact_water_balloon(rng, d, water, dur)
    return {
        "run": run,
        "base": base,
        "faults": d.faults,
        "expect_refused": d.expect,
        "camera": camera,
        "overrides": d.o,
    }


def _constant_current(velocity) -> list[dict]:
    """A constant current as the schedule's one key (``water.current_schedule``)."""
    return [{"time": 0.0, "velocity": [_r(c) for c in velocity]}]


def _draw_current(rng, d: _Drawn, water: bool) -> None:
    """A current up to 0.3 m/s (with water), and sometimes one beyond the allowed 1 m/s."""
    if water and rng.random() < P["current"]:
        velocity = rng.uniform(0.0, 0.3) * np.array(_unit_vector(rng))
        d.o["water.current_schedule"] = _constant_current(velocity)
        d.faults.append("current")
    if rng.random() < P["current_over"]:
        velocity = rng.uniform(1.05, 3.0) * np.array(_unit_vector(rng))
        d.o["water.current_schedule"] = _constant_current(velocity)
        d.faults.append("current_over")
        d.expect.append("water.current_schedule")


def _draw_scales(rng, d: _Drawn, coeff_names) -> None:
    """Scales x0.5-1.5 on 1-4 coefficient entries; those the coefficient checks refuse are
    must-refuse (``scales_refused``)."""
    k = int(rng.integers(1, 5))
    names = rng.choice(coeff_names, size=k, replace=False)
    scales = {str(n): _r(rng.uniform(0.5, 1.5), 4) for n in names}
    d.o["water.coefficient_scales"] = scales
    d.faults.append("coeff_scales")
    d.expect.extend(scales_refused(scales))


def scales_refused(scales: dict) -> list[str]:
    """The fields of ``water.coefficient_scales`` the coefficient file's checks refuse: a
    fractional strip count, a sealed volume scaled apart from its semi-axes' cube, a physical
    constant scaled out of its range (``coefficients.RANGES``)."""
    refused = []
    if "fins.strips_per_plate" in scales:
        strips = 4.0 * scales["fins.strips_per_plate"]  # the shipped file: 4 strips
        if abs(strips - round(strips)) > 1e-9:
            refused.append("water.coefficient_scales.fins.strips_per_plate")
    # The sealed volume must stay the semi-axes' ellipsoid volume (coefficients.py): scaling
    # one without the other's cube is refused.
    volume = scales.get("body.sealed_volume", 1.0)
    axes = scales.get("body.sealed_semi_axes", 1.0)
    if abs(volume - axes**3) > 0.01 * volume:
        refused.append("water.coefficient_scales.body.sealed_volume")
    # The physical constants have ranges (a pool of water on Earth).
    for name, (lo, hi, _) in RANGES.items():
        if name in scales and not lo <= _SHIPPED_CONSTANTS[name] * scales[name] <= hi:
            refused.append(f"water.coefficient_scales.{name}")
    return refused


def _draw_bad_scale(rng, d: _Drawn, coeff_names) -> None:
    """A must-refuse scale: a negative factor, zero on a positive entry, or a misspelt name."""
    scales = dict(d.o.get("water.coefficient_scales", {}))
    kind = rng.random()
    if kind < 1 / 3:  # a negative factor
        name = str(rng.choice(coeff_names))
        scales[name] = _r(-rng.uniform(0.1, 1.0), 4)
    elif kind < 2 / 3:  # zero on an entry the coefficient file requires to be > 0
        name = str(rng.choice(POSITIVE_ENTRIES))
        scales[name] = 0.0
    else:
        name = "body.linear_dampnig"  # a typo
        scales[name] = 1.2
    d.o["water.coefficient_scales"] = scales
    d.faults.append("coeff_scale_bad")
    d.expect.append(f"water.coefficient_scales.{name}")


def _draw_sensors(rng, d: _Drawn, water: bool, camera: bool) -> bool:
    """Pressure noise and dropouts, the camera switched on, depth-image noise (sometimes
    beyond its range); returns whether the run has the camera."""
    if water and rng.random() < P["pressure_noise"]:
        d.o["pressure_sensor.noise_std"] = _r(rng.uniform(0.0, 0.02))
        d.o["pressure_sensor.dropout_rate"] = _r(rng.uniform(0.0, 0.5), 4)
        d.faults.append("pressure_noise")
    if water and not camera and rng.random() < P["camera_on"]:
        d.o["camera.enabled"] = True
        camera = True
        d.faults.append("camera_on")
    if rng.random() < P["depth_noise"]:
        d.o["camera.depth_noise_std"] = _r(rng.uniform(0.0, 0.03))
        d.o["camera.pixel_dropout"] = _r(rng.uniform(0.0, 0.3), 4)
        d.faults.append("depth_noise")
    if rng.random() < P["depth_noise_over"]:
        d.o["camera.depth_noise_std"] = _r(rng.uniform(0.031, 0.1))
        d.faults.append("depth_noise_over")
        d.expect.append("camera.depth_noise_std")
    return camera


def _draw_start(rng, d: _Drawn, data) -> None:
    """The start pose: one of ``STARTS`` (``none`` keeps the base scenario's)."""
    xyz = list(data.initial_pose.xyz)
    rpy = list(data.initial_pose.rpy_deg)
    start = str(rng.choice(list(STARTS), p=_weights(STARTS)))
    if start == "tilted":
        rpy = [rng.uniform(-45, 45), rng.uniform(-45, 45), rng.uniform(-180, 180)]
        xyz[2] = _raised_clear(xyz, rpy, data, d.o.get("initial_stance", data.initial_stance))
    elif start == "upside_down":
        rpy = [180.0 + rng.uniform(-10, 10), rng.uniform(-10, 10), rng.uniform(-180, 180)]
    elif start == "near_wall":
        side = rng.choice([-1.0, 1.0])
        if rng.random() < 0.5:
            xyz[0] = side * (HALF_X - rng.uniform(0.45, 0.9))
        else:
            xyz[0], xyz[1] = rng.uniform(-6.5, 6.5), side * (HALF_Y - rng.uniform(0.45, 0.8))
        rpy[2] = rng.uniform(-180, 180)
    elif start in ("inside_wall", "below_floor", "above_surface"):
        _refused_start(rng, start, xyz)
        d.expect.append("initial_pose")
    if start != "none":
        d.o["initial_pose.xyz"] = [_r(v) for v in xyz]
        d.o["initial_pose.rpy_deg"] = [_r(v, 3) for v in rpy]
        d.faults.append(f"start_{start}")


def _raised_clear(xyz, rpy, data, stance: str):
    """The start's height raised in 1 cm steps (a drop) until no fin is below the floor; the
    drawn height if no step up to the surface passes."""
    from manta_drake.control.gaits import get_gait
    from manta_drake.model.start_pose import start_pose_problem
    from manta_drake.scenario import resolve_fin_sweep_deg

    reading = data.controller.gait_reading
    q = np.zeros((4, 4)) if stance == "zero" else get_gait(stance, reading).X
    sweep = resolve_fin_sweep_deg(data.robot.fin_sweep_deg, reading)
    for z in np.arange(xyz[2], -0.02, 0.01):
        if not start_pose_problem([xyz[0], xyz[1], z], rpy, q, sweep, stance):
            return float(z)
    return xyz[2]


def _refused_start(rng, start: str, xyz: list) -> None:
    """Moves ``xyz`` inside a wall, below the floor or above the water (``start``)."""
    if start == "inside_wall":
        side = rng.choice([-1.0, 1.0])
        if rng.random() < 0.5:
            xyz[0] = side * rng.uniform(HALF_X - 0.05, HALF_X + 0.5)
        else:
            xyz[1] = side * rng.uniform(HALF_Y - 0.05, HALF_Y + 0.3)
    elif start == "below_floor":
        xyz[2] = rng.uniform(FLOOR_Z - 0.3, FLOOR_Z - 0.001)
    else:
        xyz[2] = rng.uniform(0.005, 0.3)


def _draw_steps(rng, d: _Drawn) -> None:
    """A plant time step of 0.5-2 ms, and sometimes one out of range (must be refused)."""
    if rng.random() < P["time_step"]:
        h = _r(rng.uniform(0.5e-3, 2e-3), 5)
        d.o["time_step"] = h
        d.o["simulator.max_step_size"] = h
        d.o["log_period"] = max(1e-3, h)
        d.faults.append("time_step")
    if rng.random() < P["time_step_bad"]:
        h = float(rng.choice([5e-5, 0.02, 0.05]))
        d.o["time_step"] = h
        d.o["simulator.max_step_size"] = min(h, 0.01)
        d.o["log_period"] = max(1e-3, h)
        d.faults.append("time_step_bad")
        d.expect.append("time_step")


def _draw_contact_water_balloon(rng, d: _Drawn, water: bool, dur: float) -> None:
    """Contact friction, the water's update period, a balloon fill and one command."""
    if rng.random() < P["friction"]:
        d.o["contact.friction"] = _r(rng.uniform(0.3, 1.2), 4)
        d.faults.append("friction")
    if water and rng.random() < P["update_period"]:
        d.o["water.update_period"] = float(rng.choice([0.0, 0.002, 0.004, 0.008]))
        d.faults.append("update_period")
    if water and rng.random() < P["balloon"]:
        d.o["balloon.initial_fill"] = _r(rng.uniform(0.0, 1.0), 4)
        d.o["balloon.schedule"] = [
            {
                "time": _r(rng.uniform(BALLOON_COMMAND_AFTER_S, dur), 3),
                "fill": _r(rng.uniform(0.0, 1.0), 4),
            }
        ]
        d.faults.append("balloon")


def make_spec(
    run: int, base: str, overrides: dict | None = None, faults=(), expect=(), duration: float = 0.3
) -> dict:
    """A hand-written spec (tests, reproducing one case): ``overrides`` are dotted fields."""
    o = {
        "name": f"fault_{run:04d}_{base}",
        "duration": duration,
        "random_seed": run,
        "visualization.meshcat": False,
        **(overrides or {}),
    }
    return {
        "run": run,
        "base": base,
        "faults": list(faults),
        "expect_refused": list(expect),
        "camera": bool(o.get("camera.enabled", base in CAMERA_BASES)),
        "overrides": o,
    }


def draw_specs(n: int, seed: int, duration: float | None = None) -> list[dict]:
    """``n`` run specs from ``numpy.random.default_rng(seed)`` (same seed, same specs)."""
    from manta_drake.scenario import load_scenario

    rng = np.random.default_rng(seed)
    names = list(coefficient_names())
    bases = {b: load_scenario(b) for b in BASES}
    return [draw_spec(rng, i, duration, names, bases) for i in range(n)]


# --- one run (executed in a worker process) --------------------------------------------------


def load_run_scenario(spec: dict):
    """The run's scenario: ``spec``'s base scenario with its overrides layered on
    (``load_scenario``), validated.

    Raises:
        ScenarioError: a fault the scenario refuses; the message starts with the field.
    """
    from manta_drake.scenario import load_scenario

    # Validated apart: load_scenario would put the base file's path before a refusal's
    # field, and refusals are grouped by the field.
    return load_scenario(spec["base"], overrides=spec["overrides"], validate=False).validate()


def scenario_yaml(spec: dict) -> str:
    """The base scenario's YAML with the overrides merged in (loads to the same scenario)."""
    import yaml

    from manta_drake.config_io import load_yaml_mapping
    from manta_drake.scenario import find_scenario

    data, _ = load_yaml_mapping(find_scenario(spec["base"]), "scenario")
    for path, value in spec["overrides"].items():
        *parents, leaf = path.split(".")
        node = data
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = copy.deepcopy(value)
    header = (
        f"# fault campaign run {spec['run']}: base {spec['base']}, faults: "
        f"{', '.join(spec['faults']) or 'none'}\n"
    )
    return header + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)


def cause_of(message: str) -> str:
    """A short key for grouping failure messages: numbers replaced by #, first clause."""
    text = re.sub(r"[-+]?\d+(\.\d+)?([eE][-+]?\d+)?", "#", message.strip())
    text = re.sub(r"\[[^\]]*\]", "[...]", text)
    m = re.match(r"([^,(]{1,90})", text)
    return (m.group(1) if m else text[:90]).strip()


# A dotted field with optional list indices: ``time_step``, ``water.current[0]``,
# ``balloon.schedule[1].time``, ``water.coefficient_scales.fins.strips_per_plate``,
# ``BalloonBuoyancy.max_volume``.
_FIELD = r"[A-Za-z_]\w*(?:\[\d+\])*(?:\.[A-Za-z_]\w*(?:\[\d+\])*)*"
# The field, then what the package's messages put after it: ``: `` (``field: value is
# outside the allowed range ...``, ``field: unknown key``, ``System.arg: ...``,
# ``initial_pose: ...``), `` key: `` (a mapping's key of the wrong type) or `` = ``
# (``water.coefficient_scales.X = v must be ...``, and a file named by a scenario field,
# ``water.coefficients = PATH: name = v ...``, ``actuators.file = PATH: ...``).
_FIELD_AT_START = re.compile(rf"({_FIELD})(?: key)?(?::\s| = )")
# A scenario file's path before the field (``load_scenario`` with validation).
_FILE_PREFIX = re.compile(r"\S+\.ya?ml: ")


def refused_field(message: str) -> str:
    """The field a ScenarioError (or a System constructor's ValueError) names.

    The field is the dotted name the message starts with, up to ``: ``, `` key: `` or
    `` = ``; a leading scenario file path and the schema walk's ``scenario.`` root are
    dropped. A coefficient or actuator file's problem is filed under the scenario field that
    names the file (``water.coefficients``, ``actuators.file``). A message that starts with
    no field is grouped by ``cause_of``.
    """
    text = message.strip()
    m = _FILE_PREFIX.match(text)
    if m and _FIELD_AT_START.match(text, m.end()):
        text = text[m.end() :]
    m = _FIELD_AT_START.match(text)
    if not m:
        return cause_of(text)
    field = m.group(1)
    if field.startswith("scenario."):  # check_keys' path: scenario.water.curent
        field = field[len("scenario.") :]
    return field


STATE_KEYS = (
    "t",
    "joint_angles",
    "joint_velocities",
    "commanded_joint_angles",
    "body_xyz",
    "body_quat_wxyz",
    "body_rpy",
    "body_v_world",
    "body_w_world",
    "cpg_params",
    "z_hat",
    "s_hat",
    "balloon_volume",
    "h_hat",
)


def log_stats(log: dict, dropout: float) -> dict:
    """NaN, pool exits, joint limits and speeds, body speeds from a run's log."""
    nonfinite = _nonfinite_keys(log, dropout)
    t = np.asarray(log.get("t", []), dtype=float)
    out: dict = {
        "nan_in_log": bool(nonfinite),
        "nan_keys": ";".join(nonfinite),
        "sim_time_reached_s": float(t[-1]) if len(t) else 0.0,
    }
    out.update(pool_exits(_finite_rows(log.get("body_xyz", np.zeros((0, 3))))))
    out.update(joint_extremes(log))
    v = _finite_rows(log.get("body_v_world", np.zeros((0, 3))))
    if len(v):
        s = np.linalg.norm(v, axis=1)
        out["mean_speed_m_s"] = float(s.mean())
        out["max_speed_m_s"] = float(s.max())
    w = _finite_rows(log.get("body_w_world", np.zeros((0, 3))))
    if len(w):
        out["max_body_rate_rad_s"] = float(np.linalg.norm(w, axis=1).max())
    return out


def _nonfinite_keys(log: dict, dropout: float) -> list[str]:
    """The logged float arrays with a NaN or inf (``depth`` excepted under a dropout: its NaN
    readings are the modelled dropout)."""
    keys = []
    for key, value in log.items():
        arr = np.asarray(value)
        if not np.issubdtype(arr.dtype, np.floating) or arr.size == 0:
            continue
        if key == "depth" and dropout > 0:
            continue
        if not np.all(np.isfinite(arr)):
            keys.append(key)
    return keys


def _finite_rows(x) -> np.ndarray:
    """The rows of ``x`` (N, 3) whose every entry is finite."""
    x = np.asarray(x, dtype=float)
    return x[np.all(np.isfinite(x), axis=1)] if len(x) else x


def pool_exits(xyz) -> dict:
    """Where the hull's origin (finite samples ``xyz``, (N, 3)) left the pool: beyond an end
    or side wall, below the floor, more than ``ABOVE_SURFACE_Z`` above the surface."""
    out: dict = {}
    exits = []
    if len(xyz):
        if np.abs(xyz[:, 0]).max() > HALF_X:
            exits.append(f"x={xyz[np.abs(xyz[:, 0]).argmax(), 0]:.3f}")
        if np.abs(xyz[:, 1]).max() > HALF_Y:
            exits.append(f"y={xyz[np.abs(xyz[:, 1]).argmax(), 1]:.3f}")
        if xyz[:, 2].min() < FLOOR_Z:
            exits.append(f"z={xyz[:, 2].min():.3f}")
        if xyz[:, 2].max() > ABOVE_SURFACE_Z:
            exits.append(f"z={xyz[:, 2].max():.3f}")
        out["min_body_z"] = float(xyz[:, 2].min())
        out["max_body_z"] = float(xyz[:, 2].max())
    out["left_pool"] = bool(exits)
    out["pool_exit"] = ";".join(exits)
    return out


def joint_extremes(log: dict) -> dict:
    """The largest excess of a joint angle over its limit [rad] and the largest |joint
    speed| [rad/s] of a log (non-finite samples ignored)."""
    from manta_drake.model.robot_params import DEFAULT_ROBOT, JOINTS_PER_LEG

    out: dict = {}
    q = np.asarray(log.get("joint_angles", np.zeros((0, 16))), dtype=float)
    qd = np.asarray(log.get("joint_velocities", np.zeros((0, 16))), dtype=float)
    if q.size:
        limits = np.array(
            [DEFAULT_ROBOT.position_limits[j % JOINTS_PER_LEG] for j in range(q.shape[1])]
        )
        viol = np.maximum(q - limits[:, 1], limits[:, 0] - q)
        viol = np.where(np.isfinite(viol), viol, 0.0)
        out["max_joint_limit_violation_rad"] = float(max(0.0, viol.max()))
    if qd.size:
        speed = np.where(np.isfinite(qd), np.abs(qd), 0.0)
        out["max_joint_speed_rad_s"] = float(speed.max())
    return out


def initial_penetration(scenario) -> tuple[float, str]:
    """Deepest penetration [m] between the robot and the pool at the scenario's start
    pose and stance, and the pair's geometry names (the start-pose check's plant of robot
    and pool, one per fin sweep; geometry only, so the water's added-mass body does not
    matter)."""
    from manta_drake.model.start_pose import deepest_start_contact

    depth, names = deepest_start_contact(
        scenario.initial_pose.xyz,
        scenario.initial_pose.rpy_deg,
        scenario.initial_joint_angles(),
        scenario.fin_sweep_deg(),
    )
    return depth, "/".join(names)


def _flags(row: dict) -> bool:
    """Whether a finished run shows something worth keeping its log for."""
    return bool(
        row.get("nan_in_log")
        or row.get("left_pool")
        or (row.get("max_joint_limit_violation_rad") or 0) > JOINT_LIMIT_FLAG
        or (row.get("max_joint_speed_rad_s") or 0) > JOINT_SPEED_LIMIT
        or (row.get("max_penetration_m") or 0) > PENETRATION_FLAG
    )


def _worker_address() -> str | None:
    """The address of the Dask worker running this process's task (None: no worker)."""
    try:
        from distributed import get_worker

        return get_worker().address
    except (ImportError, ValueError):
        return None


def run_one(spec: dict, out_root: str) -> dict:
    """Runs one spec and returns its row. Never raises for a run's own failure: every
    exception is classified into the row (so only a dying process escapes)."""
    run_dir = _run_dir(pathlib.Path(out_root), spec["run"])
    _mark_started(spec, run_dir)
    if spec.get("inject_crash"):  # harness self-test: a segfault in this process
        import ctypes

        ctypes.string_at(0)
    row: dict = {"outcome": None, "cause": "", "message": "", "worker_pid": os.getpid()}
    t0 = time.perf_counter()
    scenario = _load_classified(spec, row)
    if row["outcome"] is None:
        try:  # a start the pose check accepted may still put a fin into the floor or a wall
            row["initial_penetration_m"], row["initial_contact"] = initial_penetration(scenario)
        except Exception as e:  # noqa: BLE001 - the measurement, not the run
            row["initial_contact"] = f"not measured: {type(e).__name__}: {e}"
        log, metrics = _simulate_classified(scenario, run_dir / "out", row)
        row["status"] = metrics.get("status")
        row["max_penetration_m"] = metrics.get("max_penetration_m")
        mv = metrics.get("mean_velocity_body")
        if mv:
            row["mean_u_m_s"], row["mean_v_m_s"] = mv
        if log is not None:
            row.update(log_stats(log, scenario.pressure_sensor.dropout_rate))
    row["wall_time_s"] = time.perf_counter() - t0
    keep = row["outcome"] not in ("ok", "refused") or _flags(row)
    if not keep and (run_dir / "out" / "log.npz").is_file():
        (run_dir / "out" / "log.npz").unlink()
    (run_dir / "row.json").write_text(json.dumps(row, indent=1, default=str))
    return row


def _mark_started(spec: dict, run_dir: pathlib.Path) -> None:
    """The run's folder with its ``scenario.yaml`` and ``started.json`` (pid, host, worker,
    time: what the harness finds a crashed or hung run's worker by)."""
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "scenario.yaml").write_text(scenario_yaml(spec))
    started = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "worker": _worker_address(),
        "time": time.time(),
    }
    (run_dir / "started.json").write_text(json.dumps(started))


def _exception(e: Exception) -> dict:
    """A row's fields for an exception that is a bug (called while it is handled)."""
    return {
        "outcome": "exception",
        "cause": type(e).__name__,
        "message": str(e),
        "traceback": traceback.format_exc(),
    }


def _load_classified(spec: dict, row: dict):
    """The run's validated scenario, or None with the refusal (or the bug) in ``row``."""
    from manta_drake.scenario import ScenarioError

    try:
        return load_run_scenario(spec)
    except ScenarioError as e:
        row.update(outcome="refused", cause=refused_field(str(e)), message=str(e))
    except Exception as e:  # noqa: BLE001 - an unclear error from validation: a bug
        row.update(_exception(e))
    return None


def _simulate_classified(scenario, out: pathlib.Path, row: dict) -> tuple[dict | None, dict]:
    """Simulates the scenario into ``out``; returns its log (None: none) and metrics, with
    the outcome in ``row`` (a ``SimulationError``'s stage and reason, another exception's
    type)."""
    from manta_drake.simulate import SimulationError, run

    try:
        result = run(scenario, out, progress=False, write_outputs=False)
    except SimulationError as e:
        metrics = _read_json(out / "metrics.json")
        failure = metrics.get("failure", {})
        reason = failure.get("reason", str(e))
        row.update(
            outcome="build_failed" if failure.get("stage", "?") == "build" else "sim_failed",
            cause=cause_of(reason),
            message=reason,
            failure_time_s=failure.get("time_s"),
        )
        if not (out / "log.npz").is_file():
            return None, metrics
        with np.load(out / "log.npz") as z:
            return {k: z[k] for k in z.files}, metrics
    except Exception as e:  # noqa: BLE001 - anything but SimulationError: a bug
        row.update(_exception(e))
        return None, {}
    row["outcome"] = "ok"
    return result.log, result.metrics


def _read_json(path) -> dict:
    try:
        return json.loads(pathlib.Path(path).read_text())
    except (OSError, ValueError):
        return {}


# --- the campaign ----------------------------------------------------------------------------


def spec_columns(spec: dict) -> dict:
    """The drawn faults as flat CSV columns."""
    o = spec["overrides"]
    schedule = o.get("water.current_schedule")
    cur = schedule[0]["velocity"] if schedule else None
    return {
        "run": spec["run"],
        "base": spec["base"],
        "faults": ";".join(spec["faults"]),
        "expect_refused": ";".join(spec["expect_refused"]),
        "duration": o.get("duration"),
        "random_seed": o.get("random_seed"),
        "time_step": o.get("time_step"),
        "update_period": o.get("water.update_period"),
        "current": json.dumps(cur) if cur else "",
        "current_norm": float(np.linalg.norm(cur)) if cur else "",
        "coefficient_scales": json.dumps(o["water.coefficient_scales"], sort_keys=True)
        if "water.coefficient_scales" in o
        else "",
        "friction": o.get("contact.friction"),
        "pressure_noise_std": o.get("pressure_sensor.noise_std"),
        "pressure_dropout": o.get("pressure_sensor.dropout_rate"),
        "camera": spec["camera"],
        "depth_noise_std": o.get("camera.depth_noise_std"),
        "pixel_dropout": o.get("camera.pixel_dropout"),
        "initial_xyz": json.dumps(o["initial_pose.xyz"]) if "initial_pose.xyz" in o else "",
        "initial_rpy_deg": json.dumps(o["initial_pose.rpy_deg"])
        if "initial_pose.rpy_deg" in o
        else "",
        "gait": o.get("controller.gait"),
        "initial_stance": o.get("initial_stance"),
        "balloon": json.dumps([o["balloon.initial_fill"], o["balloon.schedule"]])
        if "balloon.initial_fill" in o
        else "",
    }


def expectation(spec: dict, row: dict) -> str:
    """as_expected | silently_accepted | refused_other_field | unexpected_refusal |
    unexpected_failure."""
    expect, outcome = spec["expect_refused"], row["outcome"]
    if expect:
        if outcome == "refused":
            field = row["cause"]
            if any(
                field == e or field.startswith((e + ".", e + "[")) or e.startswith(field + ".")
                for e in expect
            ):
                return "as_expected"
            return "refused_other_field"
        if outcome == "build_failed":
            return "refused_late"  # refused, but only when the diagram was built
        return "silently_accepted" if outcome in ("ok", "sim_failed") else "unexpected_failure"
    if outcome == "ok":
        return "as_expected"
    if outcome == "refused":
        return "unexpected_refusal"
    return "unexpected_failure"


CSV_COLUMNS = [
    "run",
    "base",
    "faults",
    "expect_refused",
    "outcome",
    "expectation",
    "cause",
    "message",
    "nan_in_log",
    "nan_keys",
    "sim_time_reached_s",
    "failure_time_s",
    "max_penetration_m",
    "initial_penetration_m",
    "initial_contact",
    "left_pool",
    "pool_exit",
    "min_body_z",
    "max_body_z",
    "max_joint_limit_violation_rad",
    "max_joint_speed_rad_s",
    "mean_speed_m_s",
    "max_speed_m_s",
    "max_body_rate_rad_s",
    "mean_u_m_s",
    "mean_v_m_s",
    "wall_time_s",
    "worker_pid",
    "duration",
    "random_seed",
    "time_step",
    "update_period",
    "current",
    "current_norm",
    "coefficient_scales",
    "friction",
    "pressure_noise_std",
    "pressure_dropout",
    "camera",
    "depth_noise_std",
    "pixel_dropout",
    "initial_xyz",
    "initial_rpy_deg",
    "gait",
    "initial_stance",
    "balloon",
]


def finish_row(spec: dict, row: dict) -> dict:
    full = {**spec_columns(spec), **row}
    full["expectation"] = expectation(spec, full)
    return full


def _marker(out_dir: pathlib.Path, run: int) -> dict | None:
    return _read_json(_run_dir(out_dir, run) / "started.json") or None


def _end_worker(client, marker: dict) -> None:
    """Ends the worker process that wrote ``marker`` (a run past its timeout): by its pid when
    it runs on this machine, else through its nanny (a pid names another process here)."""
    if marker.get("host") == socket.gethostname():
        with contextlib.suppress(OSError):
            os.kill(int(marker["pid"]), 9)
    elif marker.get("worker"):
        client.restart_workers([marker["worker"]], timeout=60, raise_for_error=False)


def run_campaign(
    specs: list[dict],
    out_dir,
    workers: int = 2,
    run_timeout: float = 600.0,
    echo=print,
    scheduler: str | None = None,
    resume: bool = True,
) -> list[dict]:
    """Runs every spec and returns the rows in run order.

    Args:
        specs: the run specs (``draw_specs``, ``make_spec``).
        out_dir: the campaign's runs folder (every worker must see it).
        workers: worker processes of a local cluster (``manta_drake.cluster.dask_client``);
            0: one run after the other in this process, without crash isolation.
        run_timeout: wall seconds after which a run's worker is ended (a timeout).
        echo: prints one line per finished run.
        scheduler: a running Dask scheduler's address instead of a local cluster.
        resume: keep the rows of the runs an earlier call finished in ``out_dir``
            (``finished_rows``) and run the rest; False: run every spec again.
    """
    out_dir = pathlib.Path(out_dir)
    finished = finished_rows(specs, out_dir) if resume else {}
    for spec in specs:
        if spec["run"] not in finished:
            shutil.rmtree(_run_dir(out_dir, spec["run"]), ignore_errors=True)
    rows: dict[int, dict] = {}
    t_start = time.perf_counter()

    def done(spec, row, how=""):
        rows[spec["run"]] = r = finish_row(spec, row)
        echo(
            f"[{len(rows):4d}/{len(specs)}] run {spec['run']:4d} {spec['base']:<18} "
            f"{r['outcome']:<12} {r['wall_time_s']:6.1f} s{how}  {r['cause'][:70]}"
        )

    for spec in specs:
        if spec["run"] in finished:
            done(spec, {**finished[spec["run"]], "from_earlier_call": True}, " (earlier)")
    specs_left = [s for s in specs if s["run"] not in finished]
    if workers == 0 and not scheduler:
        for spec in specs_left:
            try:
                done(spec, run_one(spec, str(out_dir)))
            except Exception as e:  # noqa: BLE001 - the harness itself
                done(spec, _harness_row("exception", type(e).__name__, str(e)))
        return [rows[s["run"]] for s in specs]
    if specs_left:
        _run_on_cluster(specs_left, out_dir, workers, run_timeout, scheduler, done)
    echo(f"campaign wall time {time.perf_counter() - t_start:.0f} s")
    return [rows[s["run"]] for s in specs]


def _run_dir(out_dir: pathlib.Path, run: int) -> pathlib.Path:
    return out_dir / "runs" / f"run_{run:04d}"


def finished_rows(specs: list[dict], out_dir) -> dict[int, dict]:
    """The rows of the runs an earlier call of the same campaign finished in ``out_dir``:
    each run folder holding a ``row.json`` (the run's worker wrote it as the run ended)
    beside the ``scenario.yaml`` this spec writes, byte for byte (so another seed, count,
    duration or version of the draws runs again). Rows the harness made (a crash, a timeout)
    are not in a ``row.json``: those runs run again."""
    found: dict[int, dict] = {}
    for spec in specs:
        run_dir = _run_dir(pathlib.Path(out_dir), spec["run"])
        try:
            same = (run_dir / "scenario.yaml").read_text() == scenario_yaml(spec)
            row = json.loads((run_dir / "row.json").read_text()) if same else None
        except (OSError, ValueError):
            continue
        if isinstance(row, dict) and row.get("outcome") in OUTCOMES:
            found[spec["run"]] = row
    return found


def _harness_row(outcome: str, cause: str, message: str, wall: float = 0.0, **extra) -> dict:
    """The row of a run the harness ended (crashed, timed out, or its task raised)."""
    return {"outcome": outcome, "cause": cause, "message": message, "wall_time_s": wall, **extra}


def _run_on_cluster(specs, out_dir, workers, run_timeout, scheduler, done) -> None:
    """Every spec as one task of a Dask cluster; ``done(spec, row)`` as each one ends."""
    import dask

    from manta_drake.cluster import dask_client

    # No retries of a run whose worker died (it would crash again, and its death would be
    # blamed on nothing), and one task per worker at a time, so a worker's death is the
    # death of exactly the run it was executing. A local cluster's scheduler and nannies
    # take this configuration when they start; a running scheduler keeps its own.
    config = {
        "distributed.scheduler.allowed-failures": 0,
        "distributed.scheduler.worker-saturation": 1.0,
        "distributed.worker.daemon": False,
    }
    if not scheduler:  # the local workers inherit this process's environment
        os.environ.update(
            {
                "OMP_NUM_THREADS": "1",
                "MKL_NUM_THREADS": "1",
                "OPENBLAS_NUM_THREADS": "1",
                "NUMBA_NUM_THREADS": "1",
            }
        )
    with dask.config.set(config), dask_client(scheduler, workers) as client:
        _Tasks(client, specs, out_dir, run_timeout, done).run()


class _Tasks:
    """The campaign's tasks on a Dask client: submitted, collected as they end, a worker
    that died recorded as the crash (or the timeout) of the run it was executing."""

    def __init__(self, client, specs, out_dir: pathlib.Path, run_timeout: float, done):
        self.client, self.out_dir, self.run_timeout, self.done = client, out_dir, run_timeout, done
        self.specs, self.by_spec = specs, {s["run"]: s for s in specs}
        self.attempts: collections.Counter = collections.Counter()
        self.killed: dict[int, str] = {}
        self.pending: dict = {}
        self.started: set[int] = set()
        self.last_progress = time.time()

    def submit(self, spec: dict) -> None:
        self.attempts[spec["run"]] += 1
        f = self.client.submit(
            run_one,
            spec,
            str(self.out_dir),
            pure=False,
            retries=0,
            key=f"fault-run-{spec['run']}-{self.attempts[spec['run']]}",
        )
        self.pending[f] = spec["run"]

    def run(self) -> None:
        for spec in self.specs:
            self.submit(spec)
        self.last_progress = time.time()
        while self.pending:
            finished = [f for f in self.pending if f.done()]
            if not finished:
                time.sleep(0.5)
                if self.stalled():
                    return
            else:
                self.last_progress = time.time()
            for f in finished:
                self.collect(f)
            self.watchdog()

    def stalled(self) -> bool:
        """Whether nothing started or finished for ``run_timeout`` + 60 s: the harness itself
        is stuck (e.g. workers that cannot take tasks); then the rest are given up (timeouts)
        rather than hang."""
        now = time.time()
        for run in self.pending.values():
            if run not in self.started and _marker(self.out_dir, run):
                self.started.add(run)
                self.last_progress = now
        if now - self.last_progress <= self.run_timeout + 60.0:
            return False
        message = f"no run started or finished for {now - self.last_progress:.0f} s"
        for f, run in list(self.pending.items()):
            self.done(self.by_spec[run], _harness_row("timeout", "harness stall", message))
            f.cancel()
        self.pending.clear()
        return True

    def collect(self, f) -> None:
        """The row of a finished task (its worker's death classified)."""
        import distributed

        run = self.pending.pop(f)
        spec = self.by_spec[run]
        marker = _marker(self.out_dir, run)
        try:
            self.done(spec, f.result())
        except distributed.KilledWorker:
            if run in self.killed:
                row = _harness_row("timeout", "timeout", self.killed[run], self.run_timeout)
                self.done(spec, row)
            elif marker is None and self.attempts[run] < 3:
                self.submit(spec)  # its worker died before it started: not its fault
            else:
                self.done(spec, _crashed_row(marker))
        except Exception as e:  # noqa: BLE001 - the task raised
            self.done(spec, _harness_row("exception", type(e).__name__, str(e)))
        f.release()

    def watchdog(self) -> None:
        """A run past the timeout gets its worker killed (recorded as a timeout when its
        KilledWorker arrives)."""
        now = time.time()
        for run in list(self.pending.values()):
            marker = _marker(self.out_dir, run)
            if (
                run not in self.killed
                and marker
                and now - marker["time"] > self.run_timeout
                and not (_run_dir(self.out_dir, run) / "row.json").exists()
            ):
                self.killed[run] = f"no result after {self.run_timeout:.0f} s; worker killed"
                _end_worker(self.client, marker)


def _crashed_row(marker: dict | None) -> dict:
    """The row of a run whose worker process died while executing it."""
    return _harness_row(
        "crashed",
        "worker process died",
        f"the worker process executing the run died (pid {marker and marker['pid']})",
        time.time() - marker["time"] if marker else 0.0,
        worker_pid=marker and marker["pid"],
    )


# --- summary ---------------------------------------------------------------------------------


def _stats(values) -> dict:
    v = np.array([x for x in values if x is not None and x != "" and np.isfinite(x)], float)
    if not len(v):
        return {"n": 0}
    return {
        "n": len(v),
        "median": float(np.median(v)),
        "p95": float(np.percentile(v, 95)),
        "max": float(v.max()),
    }


def _above(values, limit: float) -> int:
    """How many of ``values`` (None: not measured) exceed ``limit``."""
    return sum(1 for x in values if x is not None and x > limit)


def summarise(rows: list[dict], wall_time: float | None = None) -> dict:
    """Counts per outcome with every cause (most common first), NaN, penetration, pool exits,
    joint limits and speeds, expectation mismatches, and the bugs that fail --check."""
    summary = {
        **tally_outcomes(rows),
        **tally_expectations(rows),
        **safety_measures(rows),
        **motion_measures(rows, wall_time),
    }
    summary["check_failures"] = check_failures(rows)
    return summary


def tally_outcomes(rows: list[dict]) -> dict:
    """The runs, their count per outcome, every cause per outcome (most common first) and
    the outcomes per base scenario."""
    counts = collections.Counter(r["outcome"] for r in rows)
    causes = {
        o: collections.Counter(r["cause"] for r in rows if r["outcome"] == o).most_common()
        for o in OUTCOMES
        if counts.get(o)
    }
    return {
        "runs": len(rows),
        "outcomes": {o: counts.get(o, 0) for o in OUTCOMES},
        "causes": {o: [[c, n] for c, n in v] for o, v in causes.items()},
        "per_base": {
            b: dict(collections.Counter(r["outcome"] for r in rows if r["base"] == b))
            for b in sorted({r["base"] for r in rows})
        },
    }


def tally_expectations(rows: list[dict]) -> dict:
    """The count per expectation, and the runs whose must-refuse fault was accepted or
    refused naming another field, and the causes of refusals without one."""
    return {
        "expectation": dict(collections.Counter(r["expectation"] for r in rows)),
        "silently_accepted": [
            {"run": r["run"], "expected": r["expect_refused"], "outcome": r["outcome"]}
            for r in rows
            if r["expectation"] == "silently_accepted"
        ],
        "refused_other_field": [
            {"run": r["run"], "expected": r["expect_refused"], "cause": r["cause"]}
            for r in rows
            if r["expectation"] == "refused_other_field"
        ],
        "unexpected_refusals": collections.Counter(
            r["cause"] for r in rows if r["expectation"] == "unexpected_refusal"
        ).most_common(),
    }


def _simulated(rows: list[dict]) -> list[dict]:
    """The runs that were simulated (not refused, not lost with their worker)."""
    return [
        r
        for r in rows
        if r["outcome"] in ("ok", "sim_failed", "build_failed", "exception")
        and r.get("sim_time_reached_s") is not None
    ]


def safety_measures(rows: list[dict]) -> dict:
    """NaN, penetration (ok runs), accepted starts already in contact, pool exits, joint
    limits and speeds (simulated runs), each against its flag."""
    ok = [r for r in rows if r["outcome"] == "ok"]
    pen = [r.get("max_penetration_m") for r in ok]
    jl = [r.get("max_joint_limit_violation_rad") for r in _simulated(rows)]
    js = [r.get("max_joint_speed_rad_s") for r in _simulated(rows)]
    return {
        "nan": {
            "runs_with_nan": sum(1 for r in rows if r.get("nan_in_log")),
            "ok_runs_with_nan": [r["run"] for r in ok if r.get("nan_in_log")],
        },
        "penetration_m_ok_runs": {
            **_stats(pen),
            "above_flag": _above(pen, PENETRATION_FLAG),
            "flag": PENETRATION_FLAG,
        },
        "accepted_starts_in_contact": [
            {
                "run": r["run"],
                "depth_m": r["initial_penetration_m"],
                "pair": r.get("initial_contact", ""),
            }
            for r in rows
            if (r.get("initial_penetration_m") or 0) > START_CONTACT_FLAG
        ],
        "start_contact_flag_m": START_CONTACT_FLAG,
        "pool_exits": [
            {"run": r["run"], "outcome": r["outcome"], "exit": r["pool_exit"]}
            for r in rows
            if r.get("left_pool")
        ],
        "joint_limit_violation_rad": {
            **_stats(jl),
            "above_flag": _above(jl, JOINT_LIMIT_FLAG),
            "flag": JOINT_LIMIT_FLAG,
        },
        "joint_speed_rad_s": {
            **_stats(js),
            "above_limit": _above(js, JOINT_SPEED_LIMIT),
            "limit": JOINT_SPEED_LIMIT,
        },
    }


def motion_measures(rows: list[dict], wall_time: float | None) -> dict:
    """Body speeds and rates of the ok runs, and the wall times."""
    ok = [r for r in rows if r["outcome"] == "ok"]
    return {
        "mean_speed_m_s_ok_runs": _stats([r.get("mean_speed_m_s") for r in ok]),
        "max_speed_m_s_ok_runs": _stats([r.get("max_speed_m_s") for r in ok]),
        "max_body_rate_rad_s_ok_runs": _stats([r.get("max_body_rate_rad_s") for r in ok]),
        "wall_time_s": {
            "campaign": wall_time,
            "sum_of_runs": float(sum(r.get("wall_time_s") or 0.0 for r in rows)),
            "per_run": _stats([r.get("wall_time_s") for r in rows if r["outcome"] != "refused"]),
        },
    }


def check_failures(rows: list[dict]) -> dict:
    """The runs that fail --check, by kind (kinds without a run left out): crashed, timed
    out, NaN in a run that ended ok, an exception type the package does not raise."""
    bugs = {
        "crashed": [r["run"] for r in rows if r["outcome"] == "crashed"],
        "timeout": [r["run"] for r in rows if r["outcome"] == "timeout"],
        "nan_without_failing": [
            r["run"] for r in rows if r["outcome"] == "ok" and r.get("nan_in_log")
        ],
        "unexpected_exception": [r["run"] for r in rows if r["outcome"] == "exception"],
    }
    return {k: v for k, v in bugs.items() if v}


def format_summary(s: dict) -> str:
    """The summary as the study prints it (``templates/faults_summary.txt.j2``)."""
    from manta_drake.studies.report import render

    failures = json.dumps(s["check_failures"]) if s["check_failures"] else ""
    text = render("faults_summary.txt.j2", s=s, outcomes=OUTCOMES, failures=failures)
    return text.removesuffix("\n")


def write_outputs(rows: list[dict], summary: dict, out_dir) -> None:
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / "runs.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in CSV_COLUMNS})
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")


# The command line's ranges. Runs are numbered in four digits (run_NNNN). A run's worker
# imports Drake and builds the run's diagram before it simulates: the slowest run of the
# 1000-run campaign of docs/fault_campaign.md took 26 s, so a timeout below 30 s would kill
# healthy runs; a day is the longest a run may take.
MAX_RUNS = 10_000
RUN_TIMEOUT_RANGE_S = (30.0, 86400.0)
DEFAULT_RUNS_DIR = "out/faults"


def check_arguments(args) -> None:
    """Every option of the command line in its range (before anything is drawn or run);
    raises ScenarioError (ClusterError for the cluster's options) naming the option."""
    from manta_drake.cluster import check_cluster_arguments

    check_integer("--runs", args.runs, 1, MAX_RUNS)
    check_integer("--seed", args.seed, 0, MAX_RANDOM_SEED)
    if args.duration is not None:
        check_in_range(
            "--duration",
            args.duration,
            BALLOON_COMMAND_AFTER_S,
            MAX_DURATION_S,
            f"[{BALLOON_COMMAND_AFTER_S:g}, {MAX_DURATION_S:g}] s (a drawn balloon "
            f"command comes at {BALLOON_COMMAND_AFTER_S:g} s or later)",
        )
    lo, hi = RUN_TIMEOUT_RANGE_S
    check_in_range("--run-timeout", args.run_timeout, lo, hi, f"[{lo:g}, {hi:g}] s")
    needs(
        "--strict",
        args.strict,
        "--check",
        args.check,
        "it adds the must-refuse and start-contact checks to --check's",
    )
    for i in args.inject_crash:
        check_integer(f"--inject-crash (a run index of --runs {args.runs})", i, 0, args.runs - 1)
    check_cluster_arguments(args)
    check_writable_folder(args.runs_dir, "--runs-dir", example=DEFAULT_RUNS_DIR)


def _parser(prog):
    from manta_drake.cluster import add_cluster_arguments

    ap = StudyParser(prog=prog, description=__doc__.split("\n")[0])
    ap.add_argument(
        "--runs",
        type=int,
        default=300,
        metavar="N",
        help=f"how many runs (1 to {MAX_RUNS}; default 300)",
    )
    ap.add_argument(
        "--seed",
        type=int,
        default=0,
        help="the seed of numpy.random.default_rng the runs are drawn from",
    )
    ap.add_argument(
        "--runs-dir",
        default=DEFAULT_RUNS_DIR,
        metavar="DIR",
        help="the folder of the run folders, runs.csv, summary.json and specs.json "
        f"(default {DEFAULT_RUNS_DIR})",
    )
    add_cluster_arguments(ap)  # --workers 0: in this process, without crash isolation
    ap.add_argument(
        "--duration",
        type=float,
        default=None,
        help="every run's duration [s], at least "
        f"{BALLOON_COMMAND_AFTER_S:g} (default: drawn in "
        f"[{DURATION_RANGE_S[0]:g}, {DURATION_RANGE_S[1]:g}])",
    )
    ap.add_argument(
        "--run-timeout",
        type=float,
        default=600.0,
        help="kill a run after this many wall seconds (recorded as a timeout; "
        f"{RUN_TIMEOUT_RANGE_S[0]:g} to {RUN_TIMEOUT_RANGE_S[1]:g})",
    )
    ap.add_argument(
        "--fresh",
        action="store_true",
        help="run every run again (default: keep the runs an earlier call of the same "
        "campaign finished in --runs-dir)",
    )
    ap.add_argument(
        "--check",
        action="store_true",
        help="exit 1 on a crash, timeout, silent NaN or unexpected exception type",
    )
    ap.add_argument(
        "--strict",
        action="store_true",
        help="with --check: also exit 1 if a must-refuse fault was accepted",
    )
    ap.add_argument(
        "--inject-crash",
        type=int,
        action="append",
        default=[],
        help="(harness self-test) segfault the worker of this run index",
    )
    return ap


def strict_failures(summary: dict, strict: bool) -> dict:
    """The runs that fail the campaign: ``check_failures``, with ``strict`` also the
    must-refuse faults accepted and the accepted starts already in contact."""
    failures = dict(summary["check_failures"])
    if strict and summary["silently_accepted"]:
        failures["silently_accepted"] = [x["run"] for x in summary["silently_accepted"]]
    if strict and summary["accepted_starts_in_contact"]:
        failures["accepted_starts_in_contact"] = [
            x["run"] for x in summary["accepted_starts_in_contact"]
        ]
    return failures


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study faults``); returns the exit status."""
    args = _parser(prog).parse_args(argv)
    check_arguments(args)
    specs = draw_specs(args.runs, args.seed, args.duration)
    for i in args.inject_crash:
        specs[i]["inject_crash"] = True
    runs_dir = pathlib.Path(args.runs_dir)
    runs_dir.mkdir(parents=True, exist_ok=True)
    (runs_dir / "specs.json").write_text(json.dumps(specs, indent=1) + "\n")
    t0 = time.perf_counter()
    rows = run_campaign(
        specs,
        runs_dir,
        workers=args.workers,
        run_timeout=args.run_timeout,
        scheduler=args.scheduler,
        resume=not args.fresh,
    )
    summary = summarise(rows, time.perf_counter() - t0)
    summary["seed"], summary["workers"] = args.seed, args.workers
    summary["runs_from_earlier_call"] = sum(bool(r.get("from_earlier_call")) for r in rows)
    if args.scheduler:
        summary["scheduler"] = args.scheduler
    write_outputs(rows, summary, runs_dir)
    print()
    print(format_summary(summary))
    print(f"\nwrote {runs_dir / 'runs.csv'}, {runs_dir / 'summary.json'}")
    failures = strict_failures(summary, args.strict)
    # The exit status is the check: nonzero on a bug even without --check (--check only
    # adds the message).
    if failures:
        if args.check:
            print(f"check failed: {json.dumps(failures)}", file=sys.stderr)
        return 1
    return 0
