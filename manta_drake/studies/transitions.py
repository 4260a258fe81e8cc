"""Behaviour transitions measured against baselines.

Runs the ``two_behaviors`` scenario (swim at the surface; the balloon deflates at 8 s, the
robot sinks and the controller goes swim -> trot; it inflates at 38 s, trot -> swim) with
four transition methods,

* ``potential/descent``: the paper's, Eq. (12) target and Eqs. (14)-(15) descent;
* ``normalised/descent``: Eq. (12)'s weights divided by their sum (a convex blend), the same
  descent;
* ``linear/direct``: Eq. (11)'s linear blend of the gaits by z_hat, followed at once;
* ``switch/direct``: the gait changes abruptly when z_hat crosses 1/2 (z_t / 2),

computes per method and per transition the metrics defined below from each run's log.npz,
measures how far each blend's target psi_d leaves the gaits' range over every estimate
(``target_outside``, no run needed), and writes the tables and their explanation to
``OUT/transitions.md`` and a figure to ``OUT/figures/transition_baselines.png`` (``--out
OUT``, default the checkout's docs/). The runs go to ``--runs DIR`` (default
``out/transitions``), with the rows as ``DIR/transition_baselines.json``.

Usage::

    manta-drake study transitions               # 4 runs of 70 s, then the page
    manta-drake study transitions --reuse       # the page from the existing runs
    manta-drake study transitions --duration 20 # a quick check (its page goes into --runs)

Every number on the page is computed here from the runs; none is typed in. The page's
prose is ``templates/transitions.md.j2`` (with ``transitions_macros.md.j2``).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import numpy as np

from manta_drake.control.transition import wrap  # angles to (-pi, pi]
from manta_drake.metrics import at_behaviour

SCENARIO = "two_behaviors"
# (label, transition.blend, transition.follow, folder)
METHODS = (
    ("potential/descent", "potential", "descent", "potential_descent"),
    ("normalised/descent", "normalised", "descent", "normalised_descent"),
    ("linear/direct", "linear", "direct", "linear_direct"),
    ("switch/direct", "switch", "direct", "switch_direct"),
)
TRANSITIONS = (("swim", "trot"), ("trot", "swim"))
HORIZON_S = 12.0  # the window: [event - LEAD_S, event + HORIZON_S], the same for every method
LEAD_S = 2.0
STEADY_S = 5.0  # length of the steady-gait windows that give the joint envelope
SETTLE_FRACTION = 0.01  # settled: every CPG parameter within 1 % of the largest change
SETTLE_JOINT_DEG = 2.0  # settled joints: one-period envelope within 2 deg of X -+ |R|
DEFAULT_RUNS = "out/transitions"  # the runs folder (--runs)
PAGE = "transitions.md"  # the page and the figure in the report folder (--out)
FIGURE = "figures/transition_baselines.png"
COMMAND = "manta-drake study transitions"
COLOURS = {
    "potential/descent": "C0",
    "normalised/descent": "C2",
    "linear/direct": "C1",
    "switch/direct": "C3",
}
NUMBER_WORDS = {2: "two", 3: "three", 4: "four", 5: "five"}


# ----------------------------------------------------------------------------------------
# Metric functions: plain numpy, tested on synthetic signals (tests/test_transition_baselines.py)
# ----------------------------------------------------------------------------------------


def window_mask(t, start: float, end: float) -> np.ndarray:
    """Samples with start <= t <= end."""
    t = np.asarray(t, dtype=float)
    return (t >= start) & (t <= end)


def max_step(x) -> float:
    """Largest change of any column between consecutive samples (x: (N,) or (N, n))."""
    x = np.asarray(x, dtype=float)
    if len(x) < 2:
        return float("nan")
    return float(np.abs(np.diff(x, axis=0)).max())


def max_rate(t, x) -> float:
    """Largest |dx/dt| of any column, by differences between consecutive samples."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    if len(t) < 2:
        return float("nan")
    dt = np.diff(t)
    d = np.diff(x, axis=0)
    if d.ndim > 1:
        dt = dt[:, None]
    return float(np.abs(d / dt).max())


def peak_abs(x) -> float:
    """Largest |x| over all samples and columns (NaN if empty)."""
    x = np.asarray(x, dtype=float)
    return float(np.abs(x).max()) if x.size else float("nan")


def excursion_deg(angle_rad) -> float:
    """max - min of an angle signal [rad], in degrees (NaN if empty)."""
    a = np.asarray(angle_rad, dtype=float)
    return float(np.degrees(a.max() - a.min())) if a.size else float("nan")


def envelope(x):
    """Per column (lo, hi): the range of x over its samples."""
    x = np.asarray(x, dtype=float)
    return x.min(axis=0), x.max(axis=0)


def outside(x, lo, hi) -> float:
    """Largest distance of any sample of any column outside [lo, hi] (0 inside)."""
    x = np.asarray(x, dtype=float)
    if not x.size:
        return float("nan")
    return float(np.maximum(np.maximum(lo - x, x - hi), 0.0).max())


def gait_envelope(params):
    """The range [X - |R|, X + |R|] per joint that a CPG locked to ``params`` (64-vector:
    R, X, Phi, Phi') commands: theta = chi + r sin(phi) with r -> R, chi -> X."""
    p = np.asarray(params, dtype=float)
    n = p.size // 4
    R, X = np.abs(p[:n]), p[n : 2 * n]
    return X - R, X + R


def target_outside(blend: str, z_t: float = 1.0, z=None, s=None) -> dict:
    """How far the target psi_d of ``blend`` (``transition.target_params``) leaves the range of
    the behaviours it blends (swim, trot, turning), over the grid of estimates z_hat x s_hat
    (default 401 x 21 points of [0, 1] each).

    Returns a dict: ``params_rad``, the largest distance of any of the 64 entries of psi_d
    outside [min, max] of that entry over the three gaits (raw values, phases not wrapped: a
    blend mixes them raw); ``joints_rad``, the largest distance of the target's joint envelope
    [X - |R|, X + |R|] (what a CPG locked to psi_d commands) outside [min (X - |R|),
    max (X + |R|)] over the three gaits, per joint; with the (z_hat, s_hat) and the entry or
    joint of each maximum (``params_at``, ``param``, ``joints_at``, ``joint``).
    """
    from manta_drake.control.gaits import GAITS
    from manta_drake.control.transition import BEHAVIOURS, target_params

    z = np.linspace(0.0, 1.0, 401) if z is None else np.asarray(z, dtype=float)
    s = np.linspace(0.0, 1.0, 21) if s is None else np.asarray(s, dtype=float)
    gaits = np.array([GAITS[b].to_vector() for b in BEHAVIOURS])
    swim, trot, turning = gaits
    p_lo, p_hi = gaits.min(axis=0), gaits.max(axis=0)
    envelopes = [gait_envelope(g) for g in gaits]
    j_lo = np.min([lo for lo, _ in envelopes], axis=0)
    j_hi = np.max([hi for _, hi in envelopes], axis=0)
    params_rad, joints_rad = 0.0, 0.0
    params_at: tuple[float, float] | None = None
    joints_at: tuple[float, float] | None = None
    param: int | None = None
    joint: int | None = None
    for zi in z:
        for si in s:
            psi_d = target_params(zi, si, swim, trot, turning, z_t, blend)
            ex = np.maximum(np.maximum(p_lo - psi_d, psi_d - p_hi), 0.0)
            k = int(ex.argmax())
            if ex[k] > params_rad:
                params_rad, params_at, param = float(ex[k]), (float(zi), float(si)), k
            lo, hi = gait_envelope(psi_d)
            ex = np.maximum(np.maximum(j_lo - lo, hi - j_hi), 0.0)
            k = int(ex.argmax())
            if ex[k] > joints_rad:
                joints_rad, joints_at, joint = float(ex[k]), (float(zi), float(si)), k
    return {
        "params_rad": params_rad,
        "params_at": params_at,
        "param": param,
        "joints_rad": joints_rad,
        "joints_at": joints_at,
        "joint": joint,
    }


def settle_time(t, x, target, tol: float, start: float, end: float, angles: bool = True):
    """The first time s in [start, end] from which every sample of x (N, n) up to ``end``
    stays within ``tol`` of ``target`` (wrapped to the torus if ``angles``); None if the
    last sample of the window is still outside."""
    t = np.asarray(t, dtype=float)
    m = window_mask(t, start, end)
    if not m.any():
        return None
    err = np.asarray(x, dtype=float)[m] - np.asarray(target, dtype=float)
    err = np.abs(wrap(err) if angles else err)
    bad = err.reshape(len(err), -1).max(axis=1) > tol
    if bad[-1]:
        return None
    idx = np.flatnonzero(bad)
    return float(t[m][idx[-1] + 1] if len(idx) else t[m][0])


def running_envelope(t, x, width: float):
    """Per sample i, (lo, hi) of x over the samples in [t_i, t_i + width] (uniform sampling
    assumed; the window is rounded to an even number of sample intervals); the last
    samples, whose window would run past the end, are NaN."""
    from scipy.ndimage import maximum_filter1d, minimum_filter1d

    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    x2 = x.reshape(len(x), -1)
    n = len(t)
    lo = np.full_like(x2, np.nan)
    hi = np.full_like(x2, np.nan)
    if n < 2:
        return lo, hi
    k = 2 * int(round(0.5 * width / np.median(np.diff(t))))
    if k < 2 or k >= n:
        return lo, hi
    # A centred filter of k + 1 samples at i + k/2 covers [i, i + k].
    h = k // 2
    lo[: n - k] = minimum_filter1d(x2, k + 1, axis=0, mode="nearest")[h : n - h]
    hi[: n - k] = maximum_filter1d(x2, k + 1, axis=0, mode="nearest")[h : n - h]
    return lo, hi


def joint_settle_time(
    t, q, lo_target, hi_target, tol: float, period: float, start: float, end: float
):
    """The first time s in [start, end - period] from which the commanded joints' range over
    every following period-long window stays within ``tol`` of [lo_target, hi_target] (both
    ends, every joint); None if the last full window is still off."""
    t = np.asarray(t, dtype=float)
    m = window_mask(t, start, end)
    if m.sum() < 2:
        return None
    lo, hi = running_envelope(t[m], np.asarray(q)[m], period)
    ok = np.isfinite(lo).all(axis=1)
    tt = t[m][ok]
    if not len(tt):
        return None
    err = np.maximum(np.abs(lo[ok] - lo_target), np.abs(hi[ok] - hi_target)).max(axis=1)
    bad = err > tol
    if bad[-1]:
        return None
    idx = np.flatnonzero(bad)
    return float(tt[idx[-1] + 1] if len(idx) else tt[0])


def gait_changes(labels, start) -> int:
    """How many times a sequence of behaviour labels (None: between behaviours) changes
    behaviour, starting from ``start``."""
    seq = [start] + [label for label in labels if label is not None]
    return int(sum(a != b for a, b in zip(seq[:-1], seq[1:])))


def transition_event(t, psi_d, source, target, tol: float, after: float = -np.inf):
    """The start of a transition of the target psi_d from ``source`` to ``target``: the last
    sample at which psi_d was at ``source`` (every parameter within ``tol``) before the first
    sample, at or after ``after``, at which it is at ``target``. None if it never gets there
    (or was never at the source before)."""
    t = np.asarray(t, dtype=float)
    at_src, at_dst = at_behaviour(psi_d, source, tol), at_behaviour(psi_d, target, tol)
    arrivals = np.flatnonzero(at_dst & (t >= after))
    if not len(arrivals):
        return None
    before = np.flatnonzero(at_src[: arrivals[0]])
    return float(t[before[-1]]) if len(before) else None


# ----------------------------------------------------------------------------------------
# The runs
# ----------------------------------------------------------------------------------------


def make_scenario(blend: str, follow: str, duration: float | None):
    from manta_drake.control.behaviour_tree import default_tree
    from manta_drake.scenario import load_scenario

    scenario = load_scenario(SCENARIO)
    scenario.transition.tree = default_tree(blend)
    scenario.transition.follow = follow
    scenario.visualization.meshcat = False
    if duration is not None:
        scenario.duration = float(duration)
    return scenario.validate()


def simulate_all(out: pathlib.Path, duration: float | None) -> None:
    from manta_drake import simulate

    for label, blend, follow, folder in METHODS:
        scenario = make_scenario(blend, follow, duration)
        print(
            f"[{label}] simulating {scenario.duration:g} s of {SCENARIO} "
            f"(blend={blend}, follow={follow}) -> {out / folder}",
            flush=True,
        )
        start = time.perf_counter()
        result = simulate.run(scenario, out / folder, progress=True)
        print(
            f"[{label}] done in {time.perf_counter() - start:.0f} s wall, status "
            f"{result.metrics['status']}, transitions {result.metrics.get('transitions')}",
            flush=True,
        )


def load_run(folder: pathlib.Path) -> tuple[dict, dict]:
    log = dict(np.load(folder / "log.npz"))
    metrics = json.loads((folder / "metrics.json").read_text())
    return log, metrics


def target_series(z_hat, blend: str, z_t: float) -> np.ndarray:
    """psi_d (N, 64) of the transition system for each logged z_hat (no wall seen)."""
    from manta_drake.control.gaits import GAITS
    from manta_drake.control.transition import BEHAVIOURS, target_params

    swim, trot, turning = (GAITS[b].to_vector() for b in BEHAVIOURS)
    return np.array(
        [target_params(z, 0.0, swim, trot, turning, z_t, blend) for z in np.ravel(z_hat)]
    )


def joint_limits(params=None) -> tuple[np.ndarray, np.ndarray]:
    """The 16 joint actuators' effort limits [N m] and the joints' velocity limits [rad/s],
    read from the robot's model of RobotParams ``params`` (None: the shipped model)."""
    from pydrake.systems.framework import DiagramBuilder

    from manta_drake.model.plant import add_plant

    handles = add_plant(DiagramBuilder(), with_pool=False, robot_params=params)
    plant = handles.plant
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices(handles.robot)]
    return (
        np.array([a.effort_limit() for a in actuators]),
        np.array([a.joint().velocity_upper_limits()[0] for a in actuators]),
    )


def facts(scenario, effort, velocity) -> dict:
    """Numbers the page quotes, from the scenario, the gaits and the model."""
    from manta_drake.control.gaits import GAITS

    tr, c = scenario.transition, scenario.cpg
    change = np.abs(wrap(GAITS["trot"].to_vector() - GAITS["swim"].to_vector())).max()
    return {
        "max_descent_step": tr.alpha * tr.g * tr.T,
        "period_ms": 1e3 * tr.period,
        "a": c.a,
        "b": c.b,
        "effort": (effort.min(), effort.max()),  # over the 16 joints
        "velocity": (velocity.min(), velocity.max()),
        "change": change,
        "settle_tol": SETTLE_FRACTION * change,
        "tolerance": tr.arrival_tolerance,
        "frequency": c.frequency_hz,
        "log_ms": 1e3 * scenario.log_period,
        "z_t": eq12_parameters(scenario)[1],
        "commands": [(c.time, c.fill) for c in scenario.balloon.schedule],
    }


def eq12_parameters(scenario) -> tuple[str, float]:
    """(blend, z_t) of the scenario's behaviour tree, one of Eq. (12)'s family
    (``behaviour_tree.default_tree(blend, z_t)``), as this study's runs have."""
    from manta_drake.control.behaviour_tree import default_tree_parameters

    shaped = default_tree_parameters(scenario.behaviour_nodes())
    if shaped is None:
        raise ValueError(f"{scenario.name}: transition.tree is not one of Eq. (12)'s trees")
    return shaped


def balloon_times(scenario) -> list[float]:
    return [c.time for c in scenario.balloon.schedule]


def motion_metrics(log: dict, windows) -> dict:
    """Commanded step and rate, measured velocity, torque peak, roll and pitch excursion over
    the union of ``windows`` [(start, end)] (steps, rates and excursions within each)."""
    out = {
        "max_cmd_step_rad": np.nan,
        "max_cmd_rate_rad_s": np.nan,
        "max_meas_vel_rad_s": np.nan,
        "peak_torque_nm": np.nan,
        "roll_exc_deg": np.nan,
        "pitch_exc_deg": np.nan,
    }

    def put(key, value):
        if np.isfinite(value):
            out[key] = value if not np.isfinite(out[key]) else max(out[key], value)

    for a, b in windows:
        wc = window_mask(log["t_command"], a, b)
        if wc.sum() >= 2:
            put("max_cmd_step_rad", max_step(log["commanded_joint_angles"][wc]))
            put(
                "max_cmd_rate_rad_s",
                max_rate(log["t_command"][wc], log["commanded_joint_angles"][wc]),
            )
        w = window_mask(log["t"], a, b)
        if w.any():
            put("max_meas_vel_rad_s", peak_abs(log["joint_velocities"][w]))
            put("roll_exc_deg", excursion_deg(log["body_rpy"][w, 0]))
            put("pitch_exc_deg", excursion_deg(log["body_rpy"][w, 1]))
        if "joint_torque" in log:
            wt = window_mask(log["t_joint_torque"], a, b)
            if wt.any():
                put("peak_torque_nm", peak_abs(log["joint_torque"][wt]))
    return {k: float(v) for k, v in out.items()}


def analyse_method(log: dict, metrics: dict, scenario, label: str) -> list[dict]:
    """The metrics of both transitions of one run (a row per transition)."""
    from manta_drake.control.gaits import GAITS

    if np.any(np.asarray(log.get("s_hat", 0.0)) != 0.0):
        raise NotImplementedError("a wall was seen: psi_d would need the filtered s_hat")
    tr = scenario.transition
    t_end = float(log["t"][-1])
    blend, z_t = eq12_parameters(scenario)
    psi_d = target_series(log["z_hat"], blend, z_t)
    events = balloon_times(scenario) + [np.inf]
    rows = []
    for k, (src, dst) in enumerate(TRANSITIONS):
        source, target = GAITS[src].to_vector(), GAITS[dst].to_vector()
        t_cmd, t_next = events[k], min(events[k + 1], t_end)
        row = {
            "method": label,
            "transition": f"{src}->{dst}",
            "balloon_command_s": t_cmd,
            "blend": blend,
            "follow": tr.follow,
        }
        rows.append(row)
        t0 = transition_event(
            log["t_z_hat"], psi_d, source, target, tr.arrival_tolerance, after=t_cmd
        )
        row["event_s"] = t0
        if t0 is None:
            row["note"] = "psi_d never reached the target gait in this run"
            continue
        gaits = {src: source, dst: target}
        measure_transition(row, log, gaits, (t_cmd, t0, t_next, t_end), tr.arrival_tolerance)
        # Transitions as metrics.json names them (psi at a behaviour, 0.05 rad).
        row["metrics_json"] = [
            x for x in metrics.get("transitions", []) if x["from"] == src and x["to"] == dst
        ]
    return rows


def measure_transition(row: dict, log: dict, gaits: dict, times, tolerance: float) -> None:
    """Adds to ``row`` the metrics of one transition between ``gaits`` (source, then target:
    name -> 64-vector), ``times`` = (balloon command, event t0, next command or the run's
    end, the run's end) [s]; ``tolerance`` [rad]: at a gait (``transition.arrival_tolerance``)."""
    from manta_drake import metrics as M

    (src, source), (dst, target) = gaits.items()
    t_cmd, t0, t_next, t_end = times
    ta, t1 = t0 - LEAD_S, min(t0 + HORIZON_S, t_end)
    row["window_s"] = [ta, t1]
    row.update(motion_metrics(log, [(ta, t1)]))
    row.update(settling(log, source, target, t0, t1))
    row.update(unexpected_values(log, source, target, (t_cmd, t_next), (ta, t1)))
    # z_hat at the surface, in the steady swim windows: the noise floor the blends see.
    t_z = log["t_z_hat"]
    zs = [
        log["z_hat"][window_mask(t_z, a, b), 0]
        for a, b in ((t_cmd - STEADY_S, t_cmd), (t_next - STEADY_S, t_next))
    ]
    row["z_hat_steady_range"] = [[float(z.min()), float(z.max())] if len(z) else None for z in zs]
    # How often psi (the CPG's parameters) changed between the two gaits in the window
    # (a chattering switch changes more than once).
    t_p, psi = log["t_cpg_params"], log["cpg_params"]
    wp = window_mask(t_p, ta, t1)
    row["psi_gait_changes"] = gait_changes(M.behaviour_at(psi[wp], gaits, tolerance), src)
    # First arrival of psi at the new gait (metrics.json's rule), up to the run's end.
    arrived = np.flatnonzero((t_p >= t0) & at_behaviour(psi, target, tolerance))
    row["arrival_s"] = float(t_p[arrived[0]] - t0) if len(arrived) else None
    worst = worst_command(log, source, target, (ta, t1))
    if worst is not None:
        row["worst"] = worst
    # The same motion metrics over the steady parts of the two gaits, for reference.
    row["steady"] = motion_metrics(log, [(t_cmd - STEADY_S, t_cmd), (t_next - STEADY_S, t_next)])


def settling(log: dict, source, target, t0: float, t1: float) -> dict:
    """Settling times from ``t0`` [s] in the window ending at ``t1``: psi (the CPG's
    parameters) within ``SETTLE_FRACTION`` of the largest parameter change, and the
    commanded joints' range over each 1/f window within ``SETTLE_JOINT_DEG`` of the target
    gait's X -+ |R| (None: not within the window)."""
    from manta_drake.control.gaits import DEFAULT_FREQUENCY_HZ

    tol = SETTLE_FRACTION * np.abs(wrap(target - source)).max()
    s = settle_time(log["t_cpg_params"], log["cpg_params"], target, tol, t0, t1)
    lo_g, hi_g = gait_envelope(target)
    j = joint_settle_time(
        log["t_command"],
        log["commanded_joint_angles"],
        lo_g,
        hi_g,
        np.radians(SETTLE_JOINT_DEG),
        1.0 / DEFAULT_FREQUENCY_HZ,
        t0,
        t1,
    )
    return {
        "settle_tol_rad": float(tol),
        "settle_params_s": None if s is None else s - t0,
        "settle_joints_s": None if j is None else j - t0,
    }


def _two_gaits(source, target):
    """Per joint, the range [min(X - |R|), max(X + |R|)] of the two gaits."""
    lo_a, hi_a = gait_envelope(source)
    lo_b, hi_b = gait_envelope(target)
    return np.minimum(lo_a, lo_b), np.maximum(hi_a, hi_b)


def unexpected_values(log: dict, source, target, commands, window) -> dict:
    """How far the commanded joints leave, in ``window`` (start, end) [s], the range they
    span in the steady parts of the two gaits (the ``STEADY_S`` s before each of
    ``commands``: the balloon command of the transition, the next one or the run's end) and
    the two gaits' X -+ |R|; the joint of each largest excursion."""
    tc, qc = log["t_command"], log["commanded_joint_angles"]
    (t_cmd, t_next), (ta, t1) = commands, window
    wc = window_mask(tc, ta, t1)
    lo_g, hi_g = _two_gaits(source, target)
    out: dict = {"outside_steady_deg": float("nan")}
    if t_next - STEADY_S > t1 and window_mask(tc, t_cmd - STEADY_S, t_cmd).any():
        steady = window_mask(tc, t_cmd - STEADY_S, t_cmd) | window_mask(
            tc, t_next - STEADY_S, t_next
        )
        lo, hi = envelope(qc[steady])
        out["outside_steady_deg"] = float(np.degrees(outside(qc[wc], lo, hi)))
        # The joint of that excursion: its steady range, the gaits' X -+ |R| and the
        # window's range (the steady range can be narrower than X -+ |R|).
        j = int(np.maximum(np.maximum(lo - qc[wc], qc[wc] - hi), 0.0).max(axis=0).argmax())
        out["worst_steady"] = {
            "joint": j,
            "steady": [float(lo[j]), float(hi[j])],
            "gaits": [float(lo_g[j]), float(hi_g[j])],
            "window": [float(qc[wc][:, j].min()), float(qc[wc][:, j].max())],
        }
    out["outside_gaits_deg"] = float(np.degrees(outside(qc[wc], lo_g, hi_g)))
    out["worst_joint"] = int(
        np.argmax(np.maximum(np.maximum(lo_g - qc[wc], qc[wc] - hi_g), 0).max(axis=0))
    )
    return out


def worst_command(log: dict, source, target, window) -> dict | None:
    """Where in ``window`` (start, end) [s] the commanded joints leave the two gaits' range
    the most, and why: the CPG parameters (amplitude R, bias X of that joint) and z_hat at
    that moment; None within 1e-4 rad (round-off at a gait's own extreme)."""
    tc, qc = log["t_command"], log["commanded_joint_angles"]
    t_p, psi, t_z = log["t_cpg_params"], log["cpg_params"], log["t_z_hat"]
    wc = window_mask(tc, *window)
    lo_g, hi_g = _two_gaits(source, target)
    ex = np.maximum(np.maximum(lo_g - qc[wc], qc[wc] - hi_g), 0.0)
    i, j = np.unravel_index(int(ex.argmax()), ex.shape)
    if not ex[i, j] > 1e-4:
        return None
    tw = float(tc[wc][i])
    p = psi[min(np.searchsorted(t_p, tw, side="right") - 1, len(psi) - 1)]
    n = p.size // 4
    return {
        "t_s": tw,
        "joint": j,
        "q_rad": float(qc[wc][i, j]),
        "R": float(p[j]),
        "X": float(p[n + j]),
        "z_hat": float(log["z_hat"][max(np.searchsorted(t_z, tw, side="right") - 1, 0), 0]),
        "lo": float(lo_g[j]),
        "hi": float(hi_g[j]),
    }


def check_direct_follow(log: dict, scenario) -> float:
    """For a direct-follow run: max |psi(t_k+1) - psi_d(z_hat(t_k))|, which must be ~0
    (the logged cpg_params are the targets, one transition period late)."""
    tr = scenario.transition
    psi_d = target_series(log["z_hat"], *eq12_parameters(scenario))
    t_p, psi = log["t_cpg_params"], log["cpg_params"]
    idx = np.searchsorted(t_p, log["t_z_hat"] + tr.period - 1e-9)
    ok = (idx < len(t_p)) & np.isclose(
        t_p[np.minimum(idx, len(t_p) - 1)], log["t_z_hat"] + tr.period, atol=1e-9
    )
    return float(np.abs(wrap(psi[idx[ok]] - psi_d[ok])).max()) if ok.any() else float("nan")


# ----------------------------------------------------------------------------------------
# Outputs: the numbers the page shows; its prose is templates/transitions.md.j2
# ----------------------------------------------------------------------------------------

# Two tables: how abrupt (the motion), and how long / how far off (the timing and the
# unexpected values). Key, header, format.
MOTION_COLUMNS = (
    ("method", "method", "{}"),
    ("transition", "transition", "{}"),
    ("event_s", "event t0 (s)", "{:.2f}"),
    ("max_cmd_step_rad", "max cmd step (rad)", "{:.4f}"),
    ("max_cmd_rate_rad_s", "max cmd rate (rad/s)", "{:.2f}"),
    ("max_meas_vel_rad_s", "max meas. vel (rad/s)", "{:.2f}"),
    ("peak_torque_nm", "peak abs torque (N m)", "{:.2f}"),
    ("roll_exc_deg", "roll exc. (deg)", "{:.1f}"),
    ("pitch_exc_deg", "pitch exc. (deg)", "{:.1f}"),
)
TIMING_COLUMNS = (
    ("method", "method", "{}"),
    ("transition", "transition", "{}"),
    ("psi_gait_changes", "psi gait changes", "{}"),
    ("arrival_s", "first arrival (s)", "{:.2f}"),
    ("settle_params_s", "settle, params (s)", "{:.2f}"),
    ("settle_joints_s", "settle, joints (s)", "{:.2f}"),
    ("outside_steady_deg", "outside steady env. (deg)", "{:.1f}"),
    ("outside_gaits_deg", "outside X-+abs(R) (deg)", "{:.1f}"),
)
COLUMNS = MOTION_COLUMNS + TIMING_COLUMNS[2:]
# The keys of the sentence under the tables: the method(s) with the largest value.
LARGEST_KEYS = ("max_cmd_step_rad", "peak_torque_nm", "pitch_exc_deg", "outside_steady_deg")


def fmt(row: dict, key: str, spec: str) -> str:
    value = row.get(key)
    if key.startswith("settle") and value is None and "window_s" in row:
        return f"> {row['window_s'][1] - row['event_s']:.0f}"
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "n/a"
    return spec.format(value)


def with_references(rows: list[dict]) -> list[dict]:
    """The rows ordered by transition, each transition's methods followed by a reference row:
    the motion metrics over the steady parts of its two gaits (the largest of the runs)."""
    out = []
    for src, dst in TRANSITIONS:
        name = f"{src}->{dst}"
        group = [r for r in rows if r["transition"] == name]
        out += group
        steady = [r["steady"] for r in group if "steady" in r]
        if steady:
            ref: dict[str, str | float] = {
                "method": f"*steady {src} and {dst} (ref.)*",
                "transition": name,
            }
            for key in steady[0]:
                values = [x[key] for x in steady if np.isfinite(x[key])]
                ref[key] = max(values) if values else float("nan")
            out.append(ref)
    return out


def table(rows: list[dict], columns=COLUMNS) -> dict:
    """A table's header and cells (``fmt``) for the template's ``table`` macro."""
    return {
        "header": [h for _, h, _ in columns],
        "cells": [[fmt(r, k, s) for k, _, s in columns] for r in rows],
    }


def _macros():
    """The macros of ``templates/transitions_macros.md.j2``, callable from here."""
    from manta_drake.studies.report import template_env

    return template_env().get_template("transitions_macros.md.j2").module


def markdown_table(rows: list[dict], columns=COLUMNS) -> str:
    return str(_macros().table(table(rows, columns)))


def largest(rows: list[dict], key: str, transition: str) -> list[str]:
    """The method(s) of ``transition`` with the largest ``key`` to the digits the tables show
    (all of them on a tie; none without a value)."""
    spec = next(s for k, _, s in COLUMNS if k == key)
    vals = [
        (float(spec.format(r[key])), r["method"])
        for r in rows
        if r["transition"] == transition and r.get(key) is not None and np.isfinite(r[key])
    ]
    top = max((v for v, _ in vals), default=None)
    return [m for v, m in vals if v == top]


def largest_by_transition(rows: list[dict]) -> list[dict]:
    """Per transition, ``largest``'s methods of each of ``LARGEST_KEYS`` (" = " on a tie)."""
    return [
        {
            "transition": name,
            **{key: " = ".join(largest(rows, key, name)) or "n/a" for key in LARGEST_KEYS},
        }
        for name in (f"{a}->{b}" for a, b in TRANSITIONS)
    ]


def observations(rows: list[dict]) -> dict:
    """What the numbers show, computed from the rows: the chattering transitions, where
    each method commanded a joint furthest outside the two gaits, the excursions outside the
    steady envelope that stay inside the gaits' X -+ |R|, z_hat at the surface."""
    from manta_drake.model.robot_params import JOINT_NAMES

    steady_inside = [
        {
            "method": r["method"],
            "transition": r["transition"],
            "outside_steady_deg": r["outside_steady_deg"],
            **r["worst_steady"],
            "joint": JOINT_NAMES[r["worst_steady"]["joint"]],
        }
        for r in rows
        if r.get("worst_steady")
        and r.get("outside_steady_deg", 0.0) >= 0.05
        and r.get("outside_gaits_deg", np.inf) < 0.05
    ]
    return {
        "chatter": [
            {"method": r["method"], "transition": r["transition"], "changes": r["psi_gait_changes"]}
            for r in rows
            if r.get("psi_gait_changes", 0) > 1
        ],
        "worst": [_worst_observed(r) for r in rows if r.get("worst")],
        "steady_inside": steady_inside,
        "surface": surface_targets(rows),
    }


def _worst_observed(r: dict) -> dict:
    """A row's ``worst`` command with the joint's name, its envelope, and for Eq. (12) the
    sum of the two weights at that z_hat (above 1.01: not a convex blend)."""
    from manta_drake.model.robot_params import JOINT_NAMES

    w = r["worst"]
    z = min(max(w["z_hat"], 0.0), 1.0)
    weights = np.cos(np.pi * z / 2) + np.sin(np.pi * z / 2)
    return {
        **w,
        "method": r["method"],
        "transition": r["transition"],
        "blend": r.get("blend"),
        "outside_gaits_deg": r["outside_gaits_deg"],
        "joint": JOINT_NAMES[w["joint"]],
        "low": w["X"] - abs(w["R"]),
        "high": w["X"] + abs(w["R"]),
        "weights": weights,
        "not_convex": bool(weights > 1.01),
    }


def surface_targets(rows: list[dict]) -> dict | None:
    """z_hat's range in steady swimming at the surface (the swim windows of both
    transitions), how far each blend's target is from the swim gait at its top, and whether
    both blends' targets leave the settling band there (None without a steady window)."""
    from manta_drake.control.gaits import GAITS
    from manta_drake.control.transition import BEHAVIOURS, target_params

    surface = [
        r["z_hat_steady_range"][0 if r["transition"] == "swim->trot" else 1]
        for r in rows
        if r["transition"] in ("swim->trot", "trot->swim") and "z_hat_steady_range" in r
    ]
    surface = [x for x in surface if x]
    if not surface:
        return None
    z_hi = max(x[1] for x in surface)
    z_lo = min(x[0] for x in surface)
    swim, trot, turning = (GAITS[b].to_vector() for b in BEHAVIOURS)
    dev = {
        blend: float(
            np.abs(wrap(target_params(z_hi, 0.0, swim, trot, turning, 1.0, blend) - swim)).max()
        )
        for blend in ("potential", "normalised", "linear", "switch")
    }
    tol = SETTLE_FRACTION * np.abs(wrap(trot - swim)).max()
    return {
        "z_lo": z_lo,
        "z_hi": z_hi,
        "varies": f"{z_lo:.2f}" != f"{z_hi:.2f}",
        "dev": dev,
        "tol": tol,
        "off_band": bool(min(dev["potential"], dev["linear"]) > tol),
    }


def target_rows(z_t: float) -> list[dict]:
    """``target_outside`` of each method's blend in degrees, with the (z_hat, s_hat) of each
    maximum (None below 1e-9 rad: round-off of a convex blend at a gait's own extreme)."""
    out = []
    for _, blend, _, _ in METHODS:
        r = target_outside(blend, z_t)
        out.append(
            {
                "blend": blend,
                "params_deg": np.degrees(r["params_rad"]),
                "params_at": r["params_at"] if r["params_rad"] > 1e-9 else None,
                "joints_deg": np.degrees(r["joints_rad"]),
                "joints_at": r["joints_at"] if r["joints_rad"] > 1e-9 else None,
            }
        )
    return out


# What normalised_comparison compares: key, what, unit, format.
COMPARED = (
    ("outside_gaits_deg", "outside the two gaits' range (X -+ |R|)", "deg", "{:.1f}"),
    ("outside_steady_deg", "outside the steady envelope", "deg", "{:.1f}"),
    ("arrival_s", "first arrival", "s", "{:.2f}"),
    ("settle_params_s", "settle, params", "s", "{:.2f}"),
    ("settle_joints_s", "settle, joints", "s", "{:.2f}"),
    ("max_cmd_rate_rad_s", "max cmd rate", "rad/s", "{:.2f}"),
    ("max_meas_vel_rad_s", "max meas. vel", "rad/s", "{:.2f}"),
    ("peak_torque_nm", "peak abs torque", "N m", "{:.2f}"),
    ("pitch_exc_deg", "pitch exc.", "deg", "{:.1f}"),
    ("roll_exc_deg", "roll exc.", "deg", "{:.1f}"),
)
TIME_KEYS = ("arrival_s", "settle_params_s", "settle_joints_s")
SMOOTH_KEYS = (
    "max_cmd_rate_rad_s",
    "max_meas_vel_rad_s",
    "peak_torque_nm",
    "pitch_exc_deg",
    "roll_exc_deg",
)
RANGE_KEYS = ("outside_gaits_deg", "outside_steady_deg")
CATEGORIES = (("in time", TIME_KEYS), ("in smoothness", SMOOTH_KEYS), ("in range", RANGE_KEYS))
NEW, REF = "normalised/descent", "potential/descent"


def _shown(row: dict, key: str, spec: str):
    """The value as the tables show it (a float rounded to ``spec``), None when missing."""
    v = row.get(key)
    if v is None or not np.isfinite(v):
        return None
    return float(spec.format(v))


def compare(n: dict, p: dict, transition: str) -> tuple[list[dict], list[dict], list[dict]]:
    """The normalised blend's row ``n`` against Eq. (12)'s ``p`` of one transition, on each
    of ``COMPARED`` to the digits shown: the values side by side, and its costs and gains
    (for the template's ``change``: a difference, or a time one of them does not reach)."""
    parts: list[dict] = []
    costs: list[dict] = []
    gains: list[dict] = []
    for key, what, unit, spec in COMPARED:
        a, b = _shown(n, key, spec), _shown(p, key, spec)
        shown = {"normalised": fmt(n, key, spec), "paper": fmt(p, key, spec)}
        parts.append({"what": what, "unit": unit, **shown})
        change = {"key": key, "what": what, "transition": transition, "time": key in TIME_KEYS}
        if key in TIME_KEYS and (a is None) != (b is None):  # one still off at the end
            (costs if a is None else gains).append({**change, "late": a is None})
        elif not (a is None or b is None or a == b):
            change.update(late=None, diff=spec.format(abs(a - b)), unit=unit, worse=a > b)
            (costs if a > b else gains).append(change)
    return parts, costs, gains


def _by_category(changes: list[dict]) -> list[tuple[str, list[dict]]]:
    return [(c, [x for x in changes if x["key"] in keys]) for c, keys in CATEGORIES]


def _largest_outside(rows: list[dict], method: str) -> float:
    values = [
        r["outside_gaits_deg"]
        for r in rows
        if r["method"] == method and np.isfinite(r.get("outside_gaits_deg", np.nan))
    ]
    return max(values) if values else float("nan")


def _degrees(outside: dict) -> dict:
    """``target_outside``'s two distances in degrees."""
    return {
        "params_deg": np.degrees(outside["params_rad"]),
        "joints_deg": np.degrees(outside["joints_rad"]),
    }


def normalised_comparison(rows: list[dict], z_t: float) -> dict | None:
    """The normalised blend against Eq. (12) (both followed by the descent), transition by
    transition, what it costs or gains, and how far each one's target and commands leave
    the gaits' range (``target_outside``); None without both runs."""
    if not any(r["method"] == NEW for r in rows) or not any(r["method"] == REF for r in rows):
        return None
    transitions, costs, gains = [], [], []
    for name in (f"{src}->{dst}" for src, dst in TRANSITIONS):
        n = next(r for r in rows if r["method"] == NEW and r["transition"] == name)
        p = next(r for r in rows if r["method"] == REF and r["transition"] == name)
        parts, c, g = compare(n, p, name)
        transitions.append({"name": name, "parts": parts})
        costs += c
        gains += g
    target, paper = target_outside("normalised", z_t), target_outside("potential", z_t)
    run_n = _largest_outside(rows, NEW)
    return {
        "transitions": transitions,
        "costs": _by_category(costs),
        "gains": _by_category(gains),
        "target": _degrees(target),
        "paper": _degrees(paper),
        "run_normalised": run_n,
        "run_paper": _largest_outside(rows, REF),
        "round_off": 0.0 < run_n < 1e-6,
        "descent_remains": run_n >= 0.05,
    }


def normalised_section(rows: list[dict], z_t: float) -> list[str]:
    """``normalised_comparison`` as the page's lines (a blank line first; none without it)."""
    comparison = normalised_comparison(rows, z_t)
    if comparison is None:
        return []
    return ["", *str(_macros().normalised(comparison)).splitlines()]


def page(rows: list[dict], checks: list[dict], f: dict, command: str, duration: float) -> str:
    """docs/transitions.md's text (``templates/transitions.md.j2``; its stamp undated)."""
    from manta_drake.studies.report import render
    from manta_drake.studies.stamp import stamp_line

    return render(
        "transitions.md.j2",
        stamp_line=stamp_line,
        command=command,
        duration=duration,
        default_runs=DEFAULT_RUNS,
        runs=NUMBER_WORDS[len(METHODS)],
        scenario=SCENARIO,
        f=f,
        lead=LEAD_S,
        horizon=HORIZON_S,
        steady_s=STEADY_S,
        settle_fraction=SETTLE_FRACTION,
        settle_joint_deg=SETTLE_JOINT_DEG,
        motion=table(with_references(rows), MOTION_COLUMNS),
        timing=table(rows, TIMING_COLUMNS),
        largest=largest_by_transition(rows),
        reading=observations(rows),
        targets=target_rows(f["z_t"]),
        comparison=normalised_comparison(rows, f["z_t"]),
        checks=checks,
        figure=FIGURE,
    )


def _window(log: dict, key: str, t0: float) -> np.ndarray:
    """The samples of ``log[key]`` (a time array) in the figure's window around ``t0``."""
    return window_mask(log[key], t0 - LEAD_S, t0 + HORIZON_S)


def _plot_run(axes, log: dict, row: dict, label: str, j: int) -> None:
    """One run around one transition, in one column of ``figure``'s four panels."""
    t0, col = row["event_s"], COLOURS[label]
    m = _window(log, "t_command", t0)
    tt = log["t_command"][m] - t0
    axes[0].plot(tt, log["commanded_joint_angles"][m, j], color=col, lw=0.8, label=label)
    m = _window(log, "t", t0)
    axes[1].plot(
        log["t"][m] - t0, np.degrees(log["body_rpy"][m, 1]), color=col, lw=0.8, label=label
    )
    if "joint_torque" in log:
        # The largest |torque| of the 16 joints over each 50 ms (the raw 1 ms signal is too
        # dense to read).
        mt = _window(log, "t_joint_torque", t0)
        ttq = log["t_joint_torque"][mt] - t0
        tq = np.abs(log["joint_torque"][mt]).max(axis=1)
        n = 50
        k = len(tq) // n
        if k:
            axes[2].plot(
                ttq[: k * n].reshape(k, n)[:, 0],
                tq[: k * n].reshape(k, n).max(axis=1),
                color=col,
                lw=0.8,
                label=f"{label} (peak {row['peak_torque_nm']:.2f})",
            )
    mz = _window(log, "t_z_hat", t0)
    axes[3].plot(log["t_z_hat"][mz] - t0, log["z_hat"][mz, 0], color=col, lw=0.8, label=label)


def _label_column(axes, src: str, dst: str, j: int, joint_name: str) -> None:
    """The two gaits' range of joint ``j``, the titles and units of one column."""
    from manta_drake.control.gaits import GAITS

    lo, hi = _two_gaits(GAITS[src].to_vector(), GAITS[dst].to_vector())
    axes[0].axhspan(lo[j], hi[j], color="0.9", zorder=0, label="range of the two gaits (X -+ |R|)")
    axes[0].set_title(f"{src}->{dst}: commanded {joint_name}")
    axes[0].set_ylabel("rad")
    axes[1].set_title("body pitch")
    axes[1].set_ylabel("deg")
    axes[2].set_title("largest joint |torque| (max over 50 ms)")
    axes[2].set_ylabel("N m")
    axes[3].set_title("z_hat (drives psi_d)")
    axes[3].set_xlabel("t - t0 (s): t0 = the target psi_d leaves the old gait")
    for ax in axes:
        ax.axvline(0.0, color="k", lw=0.5)
        ax.grid(alpha=0.3)


def figure(runs: dict, rows: list[dict], path: pathlib.Path, joint_names) -> None:
    """Around each transition, every run's commanded angle of the joint that leaves the two
    gaits' range the most, body pitch, largest joint torque and z_hat."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # The joint shown: the one that leaves the two gaits' range the most in any run.
    worst = [r for r in rows if "outside_gaits_deg" in r]
    j = max(worst, key=lambda r: r["outside_gaits_deg"])["worst_joint"] if worst else 2
    fig, axes = plt.subplots(4, len(TRANSITIONS), figsize=(13, 11), sharex="col", squeeze=False)
    for c, (src, dst) in enumerate(TRANSITIONS):
        for label, (log, _) in runs.items():
            row = next(
                r for r in rows if r["method"] == label and r["transition"] == f"{src}->{dst}"
            )
            if row.get("event_s") is not None:
                _plot_run(axes[:, c], log, row, label, j)
        _label_column(axes[:, c], src, dst, j, joint_names[j])
    for ax in axes[:, 0]:
        ax.legend(fontsize=7, loc="best")
    axes[2, 1].legend(fontsize=7, loc="best")
    fig.suptitle(f"{SCENARIO}: the transitions of {NUMBER_WORDS[len(runs)]} methods", fontsize=12)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ----------------------------------------------------------------------------------------
# The command line
# ----------------------------------------------------------------------------------------


def run_checks(log: dict, scenario, label: str, effort) -> list[dict]:
    """The checks of one run the page lists: a direct follow's cpg_params against psi_d one
    update later (max difference, rad), and the 1 ms samples with a joint at its effort
    limit (the PD's torque, before the servo's braking)."""
    out = []
    if scenario.transition.follow == "direct":
        out.append({"method": label, "kind": "direct", "value": check_direct_follow(log, scenario)})
    if "joint_torque" in log:
        pd = log["joint_torque"] + scenario.servo_braking() * log["joint_velocities"]
        at_limit = np.abs(pd) >= effort - 1e-9
        out.append(
            {
                "method": label,
                "kind": "limit",
                "limit": (effort.min(), effort.max()),
                "value": int(at_limit.any(axis=1).sum()),
            }
        )
    return out


def analyse_runs(runs_dir: pathlib.Path):
    """The four runs of ``runs_dir`` analysed: (runs: label -> (log, metrics), rows, checks,
    facts, duration [s])."""
    reference = make_scenario(*METHODS[0][1:3], None)  # the servos of every run
    effort, velocity = joint_limits(reference.robot_params())
    runs, rows, checks = {}, [], []
    for label, blend, follow, folder in METHODS:
        print(f"[{label}] analysing {runs_dir / folder}", flush=True)
        log, metrics = load_run(runs_dir / folder)
        if metrics.get("status") != "ok":
            raise SystemExit(
                f"{runs_dir / folder}: the run did not finish: {metrics.get('failure')}"
            )
        scenario = make_scenario(blend, follow, float(metrics["sim_time_s"]))
        runs[label] = (log, metrics)
        rows += analyse_method(log, metrics, scenario, label)
        checks += run_checks(log, scenario, label, effort)
    return runs, rows, checks, facts(scenario, effort, velocity), scenario.duration


def shortest_duration() -> float:
    """The shortest ``--duration`` [s] that measures a transition: the run reaches the first
    balloon command and the window of HORIZON_S after it."""
    from manta_drake.scenario import load_scenario

    return balloon_times(load_scenario(SCENARIO))[0] + HORIZON_S


def check_arguments(args, prog) -> tuple[pathlib.Path, pathlib.Path]:
    """Every option before anything is simulated; returns the runs folder and the report
    folder. Raises ScenarioError naming the option."""
    from manta_drake.config_io import check_in_range, check_writable_folder
    from manta_drake.scenario import MAX_DURATION_S
    from manta_drake.studies.options import check_run_folders
    from manta_drake.studies.report import output_folder

    if args.duration is not None:
        lo = shortest_duration()
        check_in_range(
            "--duration",
            args.duration,
            lo,
            MAX_DURATION_S,
            f"[{lo:g}, {MAX_DURATION_S:g}] s (the first balloon command of "
            f"{SCENARIO} and the {HORIZON_S:g} s window after it)",
        )
    runs_dir = check_writable_folder(args.runs, "--runs", example=DEFAULT_RUNS)
    if args.reuse:
        check_run_folders("--runs", runs_dir, [folder for *_, folder in METHODS])
    # A shortened run's page goes beside its runs unless --out says otherwise.
    quick = args.out is None and args.duration is not None
    out = output_folder(runs_dir if quick else args.out, prog)
    check_writable_folder(out / pathlib.Path(FIGURE).parent, "--out", example="docs")
    return runs_dir, out


def _parser(prog):
    from manta_drake.studies.options import StudyParser

    parser = StudyParser(
        prog=prog,
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--runs",
        default=DEFAULT_RUNS,
        metavar="DIR",
        help=f"folder of the runs (default {DEFAULT_RUNS})",
    )
    parser.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help=f"where the report goes: DIR/{PAGE} and DIR/{FIGURE} (default: the checkout's "
        "docs/; with --duration, the --runs folder)",
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=None,
        help="simulate only this many seconds (a quick check)",
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="do not simulate: recompute the page from the runs in --runs",
    )
    return parser


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study transitions``); returns the exit status."""
    from manta_drake.model.robot_params import JOINT_NAMES
    from manta_drake.studies.stamp import write_stamped

    args = _parser(prog).parse_args(argv)
    runs_dir, out = check_arguments(args, prog)
    if not args.reuse:
        simulate_all(runs_dir, args.duration)
    runs, rows, checks, f, duration = analyse_runs(runs_dir)
    print()
    print(markdown_table(with_references(rows)))
    figure(runs, rows, out / FIGURE, JOINT_NAMES)
    command = COMMAND
    if args.duration is not None:
        command += f" --duration {args.duration:g} --runs {runs_dir}"
        command += f" --out {out}" if args.out is not None else ""
    write_stamped(out / PAGE, page(rows, checks, f, command, duration))
    table_path = runs_dir / "transition_baselines.json"
    table_path.write_text(json.dumps(rows, indent=2, default=float) + "\n")
    print(f"\nwrote {out / PAGE}, {out / FIGURE} and {table_path}")
    return 0
