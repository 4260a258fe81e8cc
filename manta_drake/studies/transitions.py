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
docs/transitions.md and a figure to docs/figures/transition_baselines.png.

Usage::

    manta-drake study transitions               # 4 runs of 70 s, then the table
    manta-drake study transitions --reuse       # the table from the existing runs
    manta-drake study transitions --duration 20 # a quick check (writes into --out)

Every number in the table is computed here from the runs; none is typed in.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import pathlib
import time

import numpy as np

from manta_drake.control.transition import wrap  # angles to (-pi, pi]
from manta_drake.metrics import at_behaviour
from manta_drake.studies import REPO as ROOT

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
DEFAULT_OUT = "out/transition_baselines"
DOC = ROOT / "docs" / "transitions.md"
FIGURE = ROOT / "docs" / "figures" / "transition_baselines.png"
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
    p_lo, p_hi = gaits.min(axis=0), gaits.max(axis=0)
    envelopes = [gait_envelope(g) for g in gaits]
    j_lo = np.min([lo for lo, _ in envelopes], axis=0)
    j_hi = np.max([hi for _, hi in envelopes], axis=0)
    best = {
        "params_rad": 0.0,
        "params_at": None,
        "param": None,
        "joints_rad": 0.0,
        "joints_at": None,
        "joint": None,
    }
    for zi in z:
        for si in s:
            psi_d = target_params(zi, si, *gaits, z_t, blend)
            ex = np.maximum(np.maximum(p_lo - psi_d, psi_d - p_hi), 0.0)
            k = int(ex.argmax())
            if ex[k] > best["params_rad"]:
                best.update(params_rad=float(ex[k]), params_at=(float(zi), float(si)), param=k)
            lo, hi = gait_envelope(psi_d)
            ex = np.maximum(np.maximum(j_lo - lo, hi - j_hi), 0.0)
            k = int(ex.argmax())
            if ex[k] > best["joints_rad"]:
                best.update(joints_rad=float(ex[k]), joints_at=(float(zi), float(si)), joint=k)
    return best


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

    gaits = [GAITS[b].to_vector() for b in BEHAVIOURS]
    return np.array([target_params(z, 0.0, *gaits, z_t, blend) for z in np.ravel(z_hat)])


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
        "effort": f"{effort.min():g}"
        if np.ptp(effort) == 0
        else f"{effort.min():g}-{effort.max():g}",
        "velocity": f"{velocity.min():g}"
        if np.ptp(velocity) == 0
        else f"{velocity.min():g}-{velocity.max():g}",
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
    from manta_drake.control.gaits import DEFAULT_FREQUENCY_HZ, GAITS

    if np.any(np.asarray(log.get("s_hat", 0.0)) != 0.0):
        raise NotImplementedError("a wall was seen: psi_d would need the filtered s_hat")
    tr = scenario.transition
    t_end = float(log["t"][-1])
    blend, z_t = eq12_parameters(scenario)
    t_z, psi_d = log["t_z_hat"], target_series(log["z_hat"], blend, z_t)
    t_p, psi = log["t_cpg_params"], log["cpg_params"]
    tc, qc = log["t_command"], log["commanded_joint_angles"]
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
        t0 = transition_event(t_z, psi_d, source, target, tr.arrival_tolerance, after=t_cmd)
        row["event_s"] = t0
        if t0 is None:
            row["note"] = "psi_d never reached the target gait in this run"
            continue
        ta, t1 = t0 - LEAD_S, min(t0 + HORIZON_S, t_end)
        row["window_s"] = [ta, t1]
        row.update(motion_metrics(log, [(ta, t1)]))
        wc = window_mask(tc, ta, t1)
        # Settling: psi (the CPG's parameters) within 1 % of the largest parameter change.
        tol = SETTLE_FRACTION * np.abs(wrap(target - source)).max()
        row["settle_tol_rad"] = float(tol)
        s = settle_time(t_p, psi, target, tol, t0, t1)
        row["settle_params_s"] = None if s is None else s - t0
        # ... and the commanded joints: their range over each 1/f window within 2 deg of the
        # target gait's X -+ |R|.
        lo_g, hi_g = gait_envelope(target)
        s = joint_settle_time(
            tc, qc, lo_g, hi_g, np.radians(SETTLE_JOINT_DEG), 1.0 / DEFAULT_FREQUENCY_HZ, t0, t1
        )
        row["settle_joints_s"] = None if s is None else s - t0
        # Unexpected values: the commanded joints outside the range they span in the steady
        # parts of the two gaits: the STEADY_S s before the balloon command that causes the
        # transition and the STEADY_S s before the next command (or the run's end).
        steady = window_mask(tc, t_cmd - STEADY_S, t_cmd) | window_mask(
            tc, t_next - STEADY_S, t_next
        )
        lo_a, hi_a = gait_envelope(source)
        lo_b, hi_b = gait_envelope(target)
        if t_next - STEADY_S > t1 and window_mask(tc, t_cmd - STEADY_S, t_cmd).any():
            lo, hi = envelope(qc[steady])
            row["outside_steady_deg"] = float(np.degrees(outside(qc[wc], lo, hi)))
            # The joint of that excursion: its steady range, the gaits' X -+ |R| and the
            # window's range (the steady range can be narrower than X -+ |R|).
            ex = np.maximum(np.maximum(lo - qc[wc], qc[wc] - hi), 0.0).max(axis=0)
            j = int(ex.argmax())
            row["worst_steady"] = {
                "joint": j,
                "steady": [float(lo[j]), float(hi[j])],
                "gaits": [float(min(lo_a[j], lo_b[j])), float(max(hi_a[j], hi_b[j]))],
                "window": [float(qc[wc][:, j].min()), float(qc[wc][:, j].max())],
            }
        else:
            row["outside_steady_deg"] = float("nan")
        row["outside_gaits_deg"] = float(
            np.degrees(outside(qc[wc], np.minimum(lo_a, lo_b), np.maximum(hi_a, hi_b)))
        )
        row["worst_joint"] = int(
            np.argmax(
                np.maximum(
                    np.maximum(np.minimum(lo_a, lo_b) - qc[wc], qc[wc] - np.maximum(hi_a, hi_b)), 0
                ).max(axis=0)
            )
        )
        # z_hat at the surface, in the steady swim windows: the noise floor the blends see.
        zs = [
            log["z_hat"][window_mask(t_z, a, b), 0]
            for a, b in ((t_cmd - STEADY_S, t_cmd), (t_next - STEADY_S, t_next))
        ]
        row["z_hat_steady_range"] = [
            [float(z.min()), float(z.max())] if len(z) else None for z in zs
        ]
        # How often psi (the CPG's parameters) changed between the two gaits in the window
        # (a chattering switch changes more than once).
        from manta_drake import metrics as M

        wp = window_mask(t_p, ta, t1)
        row["psi_gait_changes"] = gait_changes(
            M.behaviour_at(psi[wp], {src: source, dst: target}, tr.arrival_tolerance), src
        )
        # First arrival of psi at the new gait (metrics.json's rule), up to the run's end.
        arrived = np.flatnonzero((t_p >= t0) & at_behaviour(psi, target, tr.arrival_tolerance))
        row["arrival_s"] = float(t_p[arrived[0]] - t0) if len(arrived) else None
        # Where the commanded joints leave the two gaits' range the most, and why: the CPG
        # parameters (amplitude R, bias X of that joint) and z_hat at that moment.
        ex = np.maximum(
            np.maximum(np.minimum(lo_a, lo_b) - qc[wc], qc[wc] - np.maximum(hi_a, hi_b)), 0.0
        )
        i, j = np.unravel_index(int(ex.argmax()), ex.shape)
        if ex[i, j] > 1e-4:  # rad; below that it is round-off at a gait's own extreme
            tw = float(tc[wc][i])
            p = psi[min(np.searchsorted(t_p, tw, side="right") - 1, len(psi) - 1)]
            n = p.size // 4
            zi = float(log["z_hat"][max(np.searchsorted(t_z, tw, side="right") - 1, 0), 0])
            row["worst"] = {
                "t_s": tw,
                "joint": j,
                "q_rad": float(qc[wc][i, j]),
                "R": float(p[j]),
                "X": float(p[n + j]),
                "z_hat": zi,
                "lo": float(min(lo_a[j], lo_b[j])),
                "hi": float(max(hi_a[j], hi_b[j])),
            }
        # The same motion metrics over the steady parts of the two gaits, for reference.
        row["steady"] = motion_metrics(
            log, [(t_cmd - STEADY_S, t_cmd), (t_next - STEADY_S, t_next)]
        )
        # Transitions as metrics.json names them (psi at a behaviour, 0.05 rad).
        row["metrics_json"] = [
            x for x in metrics.get("transitions", []) if x["from"] == src and x["to"] == dst
        ]
    return rows


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
# Outputs
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
            ref = {"method": f"*steady {src} and {dst} (ref.)*", "transition": name}
            for key in steady[0]:
                values = [x[key] for x in steady if np.isfinite(x[key])]
                ref[key] = max(values) if values else float("nan")
            out.append(ref)
    return out


def markdown_table(rows: list[dict], columns=COLUMNS) -> str:
    head = "| " + " | ".join(h for _, h, _ in columns) + " |"
    rule = "| " + " | ".join("---" for _ in columns) + " |"
    body = ["| " + " | ".join(fmt(r, k, s) for k, _, s in columns) + " |" for r in rows]
    return "\n".join([head, rule, *body])


def figure(runs: dict, rows: list[dict], path: pathlib.Path, joint_names) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from manta_drake.control.gaits import GAITS

    # The joint shown: the one that leaves the two gaits' range the most in any run.
    worst = [r for r in rows if "outside_gaits_deg" in r]
    j = max(worst, key=lambda r: r["outside_gaits_deg"])["worst_joint"] if worst else 2
    fig, axes = plt.subplots(4, len(TRANSITIONS), figsize=(13, 11), sharex="col", squeeze=False)
    lead = LEAD_S
    for c, (src, dst) in enumerate(TRANSITIONS):
        name = f"{src}->{dst}"
        for label, (log, _) in runs.items():
            row = next(r for r in rows if r["method"] == label and r["transition"] == name)
            t0 = row.get("event_s")
            if t0 is None:
                continue
            col = COLOURS[label]
            m = window_mask(log["t_command"], t0 - lead, t0 + HORIZON_S)
            tt = log["t_command"][m] - t0
            axes[0, c].plot(tt, log["commanded_joint_angles"][m, j], color=col, lw=0.8, label=label)
            m = window_mask(log["t"], t0 - lead, t0 + HORIZON_S)
            tt = log["t"][m] - t0
            axes[1, c].plot(tt, np.degrees(log["body_rpy"][m, 1]), color=col, lw=0.8, label=label)
            if "joint_torque" in log:
                mt = window_mask(log["t_joint_torque"], t0 - lead, t0 + HORIZON_S)
                # The largest |torque| of the 16 joints over each 50 ms (the raw 1 ms
                # signal is too dense to read).
                ttq = log["t_joint_torque"][mt] - t0
                tq = np.abs(log["joint_torque"][mt]).max(axis=1)
                n = 50
                k = len(tq) // n
                if k:
                    axes[2, c].plot(
                        ttq[: k * n].reshape(k, n)[:, 0],
                        tq[: k * n].reshape(k, n).max(axis=1),
                        color=col,
                        lw=0.8,
                        label=f"{label} (peak {row['peak_torque_nm']:.2f})",
                    )
            mz = window_mask(log["t_z_hat"], t0 - lead, t0 + HORIZON_S)
            axes[3, c].plot(
                log["t_z_hat"][mz] - t0, log["z_hat"][mz, 0], color=col, lw=0.8, label=label
            )
        lo_a, hi_a = gait_envelope(GAITS[src].to_vector())
        lo_b, hi_b = gait_envelope(GAITS[dst].to_vector())
        axes[0, c].axhspan(
            min(lo_a[j], lo_b[j]),
            max(hi_a[j], hi_b[j]),
            color="0.9",
            zorder=0,
            label="range of the two gaits (X -+ |R|)",
        )
        axes[0, c].set_title(f"{name}: commanded {joint_names[j]}")
        axes[0, c].set_ylabel("rad")
        axes[1, c].set_title("body pitch")
        axes[1, c].set_ylabel("deg")
        axes[2, c].set_title("largest joint |torque| (max over 50 ms)")
        axes[2, c].set_ylabel("N m")
        axes[3, c].set_title("z_hat (drives psi_d)")
        axes[3, c].set_xlabel("t - t0 (s): t0 = the target psi_d leaves the old gait")
        for ax in axes[:, c]:
            ax.axvline(0.0, color="k", lw=0.5)
            ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.legend(fontsize=7, loc="best")
    axes[2, 1].legend(fontsize=7, loc="best")
    fig.suptitle(f"{SCENARIO}: the transitions of {NUMBER_WORDS[len(runs)]} methods", fontsize=12)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def reading(rows: list[dict]) -> list[str]:
    """Statements about the rows, computed from them (no number typed in)."""
    from manta_drake.control.gaits import GAITS
    from manta_drake.control.transition import BEHAVIOURS, target_params
    from manta_drake.model.robot_params import JOINT_NAMES

    out = ["", "### What the numbers show (computed from the runs)", ""]
    for r in rows:
        if r.get("psi_gait_changes", 0) > 1:
            out.append(
                f"* {r['method']}, {r['transition']}: psi went between the two gaits "
                f"{r['psi_gait_changes']} times within the window (the target chattered "
                "as z_hat crossed the threshold back and forth)."
            )
    for r in rows:
        w = r.get("worst")
        if not w:
            continue
        text = (
            f"* {r['method']}, {r['transition']}: {JOINT_NAMES[w['joint']]} was commanded "
            f"{w['q_rad']:.3f} rad at t = {w['t_s']:.2f} s, {r['outside_gaits_deg']:.1f} deg "
            f"outside the two gaits' range [{w['lo']:.3f}, {w['hi']:.3f}] rad; there psi "
            f"had that joint's amplitude R = {w['R']:.3f} and bias X = {w['X']:.3f} "
            f"(X - |R| = {w['X'] - abs(w['R']):.3f}, X + |R| = {w['X'] + abs(w['R']):.3f}) "
            f"with z_hat = {w['z_hat']:.2f}."
        )
        descent = (
            " psi is still on its way, off the straight line between the gaits: "
            "Eq. (15)'s descent moves every parameter by at most alpha g T per update, "
            "so the parameters with the larger changes (the phases, up to pi) arrive "
            "last and meanwhile amplitude and bias combine as in neither gait."
        )
        if r.get("blend") == "potential":
            z = min(max(w["z_hat"], 0.0), 1.0)
            weights = np.cos(np.pi * z / 2) + np.sin(np.pi * z / 2)
            if weights > 1.01:
                text += (
                    f" At that z_hat Eq. (12)'s weights on the two gaits, cos(pi z/2) and "
                    f"sin(pi z/2), sum to {weights:.2f} (Eq. 11's always to 1): the blend "
                    "is not convex, so a joint can keep most of the swimming amplitude "
                    "while its bias already moves toward the trot's."
                )
            else:
                text += (
                    f" At that z_hat the target is a gait (Eq. (12)'s weights sum to "
                    f"{weights:.2f});" + descent
                )
        elif r.get("blend") == "normalised":
            text += (
                " The target psi_d is a convex blend, inside the gaits' range at every "
                "z_hat (below);" + descent
            )
        out.append(text)
    for r in rows:
        w = r.get("worst_steady")
        if not w or not r.get("outside_steady_deg", 0.0) >= 0.05:
            continue
        if r.get("outside_gaits_deg", np.inf) < 0.05:
            out.append(
                f"* {r['method']}, {r['transition']}: its {r['outside_steady_deg']:.1f} deg "
                f"outside the steady envelope ({JOINT_NAMES[w['joint']]}, commanded "
                f"[{w['window'][0]:.3f}, {w['window'][1]:.3f}] rad in the window) are inside "
                f"the two gaits' X -+ |R| ([{w['gaits'][0]:.3f}, {w['gaits'][1]:.3f}] rad): "
                f"in the steady windows that joint's commands span only "
                f"[{w['steady'][0]:.3f}, {w['steady'][1]:.3f}] rad, narrower than "
                "X -+ |R|."
            )
    surface = [
        r["z_hat_steady_range"][0]
        for r in rows
        if r["transition"] == "swim->trot" and "z_hat_steady_range" in r
    ]
    surface += [
        r["z_hat_steady_range"][1]
        for r in rows
        if r["transition"] == "trot->swim" and "z_hat_steady_range" in r
    ]
    surface = [x for x in surface if x]
    if surface:
        z_hi = max(x[1] for x in surface)
        z_lo = min(x[0] for x in surface)
        gaits = [GAITS[b].to_vector() for b in BEHAVIOURS]
        dev = {
            blend: float(
                np.abs(wrap(target_params(z_hi, 0.0, *gaits, 1.0, blend) - gaits[0])).max()
            )
            for blend in ("potential", "normalised", "linear", "switch")
        }
        varies = (
            " (the sensor's depth varies as the robot swims)"
            if f"{z_lo:.2f}" != f"{z_hi:.2f}"
            else ""
        )
        text = (
            f"* In steady swimming at the surface (the {STEADY_S:g} s windows) z_hat spans "
            f"[{z_lo:.2f}, {z_hi:.2f}]{varies}. "
            f"At z_hat = {z_hi:.2f} the target psi_d is up to {dev['potential']:.2f} rad "
            f"from the swim gait with Eq. (12), {dev['normalised']:.2f} rad with the "
            f"normalised blend, {dev['linear']:.2f} rad with Eq. (11) and "
            f"{dev['switch']:.2f} rad with the switch (threshold 1/2)."
        )
        tol = SETTLE_FRACTION * np.abs(wrap(gaits[1] - gaits[0])).max()
        if min(dev["potential"], dev["linear"]) > tol:
            text += (
                f" Both blends' targets leave the {SETTLE_FRACTION:.0%} band "
                f"({tol:.3f} rad) at the surface, so after trot -> swim their CPG "
                "parameters cannot settle in it; the first arrival shows when they "
                "first reach the swim gait."
            )
        out.append(text)
    return out


def target_section(z_t: float) -> list[str]:
    """The table of ``target_outside`` for each method's blend: how far the target alone
    leaves the gaits' range, over every estimate."""
    out = [
        "",
        "### The targets over every estimate (computed from the blends, no run)",
        "",
        (
            f"psi_d of each blend (z_t = {z_t:g}) on a grid of 401 z_hat x 21 s_hat in [0, 1], "
            "against the range of the three gaits it blends (swim, trot, turning): the largest "
            "distance of any of its 64 entries outside [min, max] of that entry over the gaits, "
            "and of its joint envelope [X - |R|, X + |R|] (what a CPG locked to psi_d commands) "
            "outside [min (X - |R|), max (X + |R|)] over the gaits."
        ),
        "",
        (
            "| blend | psi_d entry outside (deg) | at z_hat, s_hat | joint envelope outside "
            "(deg) | at z_hat, s_hat |"
        ),
        "| --- | --- | --- | --- | --- |",
    ]
    for _, blend, _, _ in METHODS:
        r = target_outside(blend, z_t)
        # Below 1e-9 rad the distance is round-off of a convex blend at a gait's own extreme.
        at = {
            k: f"{r[k][0]:.2f}, {r[k][1]:.2f}"
            if r[k] and r[k.replace("_at", "_rad")] > 1e-9
            else "n/a"
            for k in ("params_at", "joints_at")
        }
        out.append(
            f"| {blend} | {np.degrees(r['params_rad']):.1f} | {at['params_at']} | "
            f"{np.degrees(r['joints_rad']):.1f} | {at['joints_at']} |"
        )
    return out


# What normalised_section compares: key, what, unit, format.
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


def _shown(row: dict, key: str, spec: str):
    """The value as the tables show it (a float rounded to ``spec``), None when missing."""
    v = row.get(key)
    if v is None or not np.isfinite(v):
        return None
    return float(spec.format(v))


def normalised_section(rows: list[dict], z_t: float) -> list[str]:
    """The normalised blend against Eq. (12) (both followed by the descent), transition by
    transition, and what it costs or gains, all from the rows and ``target_outside``."""
    new, ref = "normalised/descent", "potential/descent"
    if not any(r["method"] == new for r in rows) or not any(r["method"] == ref for r in rows):
        return []
    out = ["", "### The normalised blend against Eq. (12) (computed from the runs)", ""]
    costs = {c: [] for c, _ in CATEGORIES}
    gains = {c: [] for c, _ in CATEGORIES}
    category = {k: c for c, keys in CATEGORIES for k in keys}
    for src, dst in TRANSITIONS:
        name = f"{src}->{dst}"
        n = next(r for r in rows if r["method"] == new and r["transition"] == name)
        p = next(r for r in rows if r["method"] == ref and r["transition"] == name)
        parts = []
        for key, what, unit, spec in COMPARED:
            a, b = _shown(n, key, spec), _shown(p, key, spec)
            parts.append(f"{what} {fmt(n, key, spec)} {unit} (Eq. 12: {fmt(p, key, spec)})")
            if key in TIME_KEYS and (a is None) != (b is None):
                # One of them is still off at the window's end.
                late = "normalised" if a is None else "Eq. (12)"
                (costs if a is None else gains)[category[key]].append(
                    f"{what} not within the window for {late} ({name})"
                )
                continue
            if a is None or b is None or a == b:
                continue
            d = spec.format(abs(a - b))
            kind = "later" if key in TIME_KEYS else "larger"
            better = "earlier" if key in TIME_KEYS else "smaller"
            (costs if a > b else gains)[category[key]].append(
                f"{what} {d} {unit} {kind if a > b else better} ({name})"
            )
        out.append(f"* {name}: " + "; ".join(parts) + ".")
    target = target_outside("normalised", z_t)
    paper = target_outside("potential", z_t)

    def largest(method):
        values = [
            r["outside_gaits_deg"]
            for r in rows
            if r["method"] == method and np.isfinite(r.get("outside_gaits_deg", np.nan))
        ]
        return max(values) if values else float("nan")

    run_n, run_p = largest(new), largest(ref)
    text = (
        f"* In range: the normalised target never leaves the gaits' range (at most "
        f"{np.degrees(target['params_rad']):.1f} deg on any entry and "
        f"{np.degrees(target['joints_rad']):.1f} deg on the joint envelope, over every "
        f"estimate; Eq. (12)'s target: {np.degrees(paper['params_rad']):.1f} and "
        f"{np.degrees(paper['joints_rad']):.1f} deg). In these runs its commanded joints "
        f"left the two gaits' range by at most {run_n:.1f} deg"
        + (f" ({run_n:.0e} deg: round-off)" if 0.0 < run_n < 1e-6 else "")
        + f", Eq. (12)'s by {run_p:.1f} deg"
    )
    if run_n >= 0.05:
        text += (
            "; what remains comes from the descent, not the target: psi follows a "
            "convex target off the straight line between the gaits (above)."
        )
    else:
        text += "."
    out.append(text)

    def listed(found: dict, none: str) -> str:
        return "; ".join(
            f"{c}, " + (", ".join(found[c]) if found[c] else none) for c, _ in CATEGORIES
        )

    out.append(
        "* What it costs against Eq. (12) (larger or later, to the digits shown): "
        + listed(costs, "nothing")
        + "."
    )
    out.append("* What it gains (smaller or earlier): " + listed(gains, "nothing") + ".")
    out.append(
        "* One run per method with the same seed: the robot's own motion (sinking, "
        "landing, rising) differs between the runs, and this page does not measure the "
        "spread over seeds, so small differences are not a ranking."
    )
    return out


def write_doc(
    rows: list[dict],
    checks: dict,
    path: pathlib.Path,
    figure_path: pathlib.Path,
    command: str,
    duration: float,
    f: dict,
) -> None:
    from manta_drake.studies.stamp import stamp_line, write_stamped

    rel_fig = pathlib.Path(figure_path).resolve()
    with contextlib.suppress(ValueError):
        rel_fig = rel_fig.relative_to(pathlib.Path(path).resolve().parent)

    def best(key, transition):
        """The method(s) with the largest value (all of them on a tie, to the shown digits)."""
        spec = next(s for k, _, s in COLUMNS if k == key)
        vals = [
            (float(spec.format(r[key])), r["method"])
            for r in rows
            if r["transition"] == transition and r.get(key) is not None and np.isfinite(r[key])
        ]
        if not vals:
            return "n/a"
        top = max(v for v, _ in vals)
        return " = ".join(m for v, m in vals if v == top)

    runs = NUMBER_WORDS[len(METHODS)]
    lines = [
        "# Transitions measured against baselines",
        "",
        stamp_line(
            f"`{command}` ({runs} runs of {duration:g} s, one after the other; "
            "`--reuse` recomputes this page from the existing runs in `--out`, "
            f"default `{DEFAULT_OUT}`)."
        ),
        "Generated by `manta-drake study transitions`; do not edit by hand.",
        "",
        f"The scenario `{SCENARIO}` (swim at the surface; the balloon is commanded to "
        + ", then ".join(f"fill {fill:g} at {time:g} s" for time, fill in f["commands"])
        + ": the robot sinks and the controller changes swim -> trot, then it rises, "
        f"trot -> swim) is run {NUMBER_WORDS[len(METHODS)]} times, changing only "
        "`transition.blend` and `transition.follow`:",
        "",
        "* **potential/descent** (the paper's): the target psi_d of Eq. (12), "
        "psi_d = cos(pi z/2) Theta_swim + sin(pi z/2) Theta_trot (for z_t = 1; here "
        f"z_t = {f['z_t']:g}), followed by the "
        "CPG parameters psi through the descent on Eq. (14)'s potential (Eq. 15), at most "
        f"{f['max_descent_step']:.3f} rad per {f['period_ms']:g} ms update. Its two weights "
        "sum to up to sqrt(2) = 1.41 (at z = 1/2), so the target is not a convex blend;",
        "* **normalised/descent**: Eq. (12)'s two weights divided by their sum, "
        "psi_d = (cos(pi z/2) Theta_swim + sin(pi z/2) Theta_trot) / (cos(pi z/2) + "
        "sin(pi z/2)), a convex blend (`transition.blend: normalised`), followed by the same "
        "descent;",
        "* **linear/direct**: Eq. (11), psi_d = (1 - z) Theta_swim + z Theta_trot, and "
        "psi = psi_d at once;",
        "* **switch/direct**: psi = Theta_trot when z_hat >= 1/2, Theta_swim below, at once.",
        "",
        f"In all {runs} the CPG (Eq. 5) sits between psi and the joints: its amplitudes and "
        f"biases follow R and X through critically damped second-order filters (a = {f['a']:g}, "
        f"b = {f['b']:g} 1/s) "
        "and its phases lock through the coupling, so even the switch does not step the joint "
        "commands. Same seed, same noise draws; the runs differ only by the method and what "
        "the method makes the robot do.",
        "",
        "## Metrics",
        "",
        f"Per method and transition, over the window [t0 - {LEAD_S:g} s, t0 + {HORIZON_S:g} s] "
        "(clipped at the run's end; the lead catches a blend's partial moves while z_hat "
        "hovers before it commits). The rows *steady ... (ref.)* give the same motion "
        f"metrics over the steady parts of the two gaits (the {STEADY_S:g} s windows below; "
        f"the largest of the {runs} runs): what the gaits themselves do, without a "
        "transition.",
        "",
        "* **event t0**: the start of the transition of the *target* psi_d, the same rule for "
        "every method: psi_d is recomputed from the logged z_hat with the method's blend, and "
        "t0 is the last sample at which it was at the old gait (every parameter within "
        f"`transition.arrival_tolerance` = {f['tolerance']:g} rad, as metrics.json's "
        "`transitions`) before it first reaches the new one, after the balloon command. "
        "For the switch that is the sample before the jump; for the blends it is the last "
        "time z_hat was ~0 (~1) before it reached ~1 (~0). metrics.json's own "
        "`transitions` time psi (the CPG parameters), which for the switch take a single "
        "update.",
        "* **max cmd step**: the largest change of any commanded joint angle (desired_state) "
        f"between consecutive command samples ({f['log_ms']:g} ms) [rad]; **max cmd rate**: "
        "the same divided by the sample interval [rad/s] (so, with a uniform log, the same "
        "ranking).",
        "* **max meas. vel**: the largest |joint velocity| measured [rad/s] (servo limit in "
        f"the model: {f['velocity']} rad/s).",
        "* **peak abs torque**: the largest |joint torque| the actuators apply (the station's "
        "`joint_torque`: the plant's net actuation including the PD, less the datasheet "
        "servo's back-EMF braking) [N m]; the PD's effort limit "
        f"is {f['effort']} N m.",
        "* **roll / pitch exc.**: max - min of the body's roll and pitch over the window [deg] "
        "(includes the sinking/rising and landing, which every method has).",
        "* **psi gait changes**: how many times psi went from one gait to the other within "
        f"the window (every parameter within {f['tolerance']:g} rad): 1 for a clean "
        "transition, more when it chatters back and forth.",
        "* **first arrival**: time from t0 until psi is first at the new gait (every "
        f"parameter within {f['tolerance']:g} rad, metrics.json's rule), looked for up to "
        "the run's end.",
        "* **settle, params**: time from t0 until psi (the logged CPG parameters) comes and "
        f"stays within {SETTLE_FRACTION:.0%} of the largest parameter change between the two "
        f"gaits ({f['change']:.3f} rad, so {f['settle_tol']:.3f} rad) of the new gait, on every "
        f"parameter (wrapped), to the end of the window; `> {HORIZON_S:g}` when still outside "
        "at the window's end.",
        "* **settle, joints**: time from t0 until the commanded joints' range over every "
        f"following oscillation period ({1.0 / f['frequency']:g} s) stays within "
        f"{SETTLE_JOINT_DEG:g} deg of the new gait's [X - |R|, X + |R|] on both ends, every "
        "joint (this sees the amplitudes and biases the CPG really produces, not the phases).",
        "* **outside steady env.**: the unexpected values: per joint, the envelope [min, max] "
        f"of the commanded angles in the steady parts of the two gaits of the same run (the "
        f"{STEADY_S:g} s before the balloon command that causes the transition and the "
        f"{STEADY_S:g} s before the next command or the run's end); reported is the largest "
        "excursion of any commanded joint outside its envelope during the window [deg].",
        "* **outside X-+abs(R)**: the same against the ideal envelope of the two gaits, "
        "[min(X - |R|), max(X + |R|)] over both gaits per joint (what a CPG locked to either "
        "gait commands), independent of the run.",
        "",
        "## Results",
        "",
        "How abrupt:",
        "",
        markdown_table(with_references(rows), MOTION_COLUMNS),
        "",
        "How long, and how far off the two gaits:",
        "",
        markdown_table([r for r in rows], TIMING_COLUMNS),
        "",
    ]
    for name in (f"{a}->{b}" for a, b in TRANSITIONS):
        lines.append(
            f"* {name}: largest commanded step: {best('max_cmd_step_rad', name)}; "
            f"largest torque peak: {best('peak_torque_nm', name)}; largest pitch excursion: "
            f"{best('pitch_exc_deg', name)}; largest excursion outside the steady envelope: "
            f"{best('outside_steady_deg', name)}."
        )
    lines += reading(rows)
    lines += target_section(f["z_t"])
    lines += normalised_section(rows, f["z_t"])
    lines += ["", "Checks made by the script on these runs:", ""]
    lines += [f"* {k}: {v}" for k, v in checks.items()]
    lines += [
        "",
        f"![transitions]({rel_fig})",
        "",
        "The figure: around each transition (t - t0), the commanded angle of the joint "
        "that leaves the two gaits' range the most (grey: that range), the body pitch, "
        f"the largest joint torque of the 16 and z_hat, for the {runs} methods.",
        "",
    ]
    write_stamped(path, "\n".join(lines))


def shortest_duration() -> float:
    """The shortest ``--duration`` [s] that measures a transition: the run reaches the first
    balloon command and the window of HORIZON_S after it."""
    from manta_drake.scenario import load_scenario

    return balloon_times(load_scenario(SCENARIO))[0] + HORIZON_S


def check_arguments(args, out: pathlib.Path, doc: pathlib.Path, fig_path: pathlib.Path) -> None:
    """Every option before anything is simulated; raises ScenarioError naming it."""
    from manta_drake.config_io import check_in_range, check_writable_folder
    from manta_drake.scenario import MAX_DURATION_S
    from manta_drake.studies.options import (
        check_figure_file,
        check_output_file,
        check_run_folders,
    )

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
    check_writable_folder(out, "--out", example=DEFAULT_OUT)
    if args.reuse:
        check_run_folders("--out", out, [folder for *_, folder in METHODS])
    check_output_file("--doc", doc)
    check_figure_file("--figure", fig_path)


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study transitions``); returns the exit status."""
    from manta_drake.studies.options import StudyParser

    parser = StudyParser(
        prog=prog,
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--out", default=None, help=f"folder of the runs (default {DEFAULT_OUT} in the repository)"
    )
    parser.add_argument(
        "--duration",
        type=float,
        default=None,
        help="simulate only this many seconds (a quick check; the table and "
        "figure then go into --out unless --doc/--figure say otherwise)",
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="do not simulate: recompute the table from the runs in --out",
    )
    parser.add_argument(
        "--doc", default=None, help=f"markdown output (default {DOC.relative_to(ROOT)})"
    )
    parser.add_argument(
        "--figure", default=None, help=f"figure output (default {FIGURE.relative_to(ROOT)})"
    )
    args = parser.parse_args(argv)
    out = pathlib.Path(args.out) if args.out else ROOT / DEFAULT_OUT
    quick = args.duration is not None
    doc = pathlib.Path(args.doc) if args.doc else (out / "transitions.md" if quick else DOC)
    fig_path = (
        pathlib.Path(args.figure)
        if args.figure
        else (out / "transition_baselines.png" if quick else FIGURE)
    )
    check_arguments(args, out, doc, fig_path)
    if not args.reuse:
        simulate_all(out, args.duration)

    from manta_drake.model.robot_params import JOINT_NAMES

    runs, rows, checks = {}, [], {}
    reference = make_scenario(*METHODS[0][1:3], None)  # the servos of every run
    effort, velocity = joint_limits(reference.robot_params())
    duration = None
    for label, blend, follow, folder in METHODS:
        print(f"[{label}] analysing {out / folder}", flush=True)
        log, metrics = load_run(out / folder)
        if metrics.get("status") != "ok":
            raise SystemExit(f"{out / folder}: the run did not finish: {metrics.get('failure')}")
        scenario = make_scenario(blend, follow, float(metrics["sim_time_s"]))
        duration = scenario.duration
        runs[label] = (log, metrics)
        rows += analyse_method(log, metrics, scenario, label)
        if follow == "direct":
            checks[
                f"{label}: logged cpg_params = psi_d(z_hat) one update later, max difference (rad)"
            ] = f"{check_direct_follow(log, scenario):.2e}"
        if "joint_torque" in log:  # the limit is the PD's, before the servo's braking
            pd = log["joint_torque"] + scenario.servo_braking() * log["joint_velocities"]
            at_limit = np.abs(pd) >= effort - 1e-9
            limit = (
                f"{effort.min():g}" if np.ptp(effort) == 0 else f"{effort.min():g}-{effort.max():g}"
            )
            checks[
                f"{label}: samples (1 ms) with a joint at its effort limit ({limit} N m), whole run"
            ] = int(at_limit.any(axis=1).sum())
    command = COMMAND if not quick else f"{COMMAND} --duration {args.duration:g} --out {out}"
    print()
    print(markdown_table(with_references(rows)))
    figure(runs, rows, fig_path, JOINT_NAMES)
    write_doc(rows, checks, doc, fig_path, command, duration, facts(scenario, effort, velocity))
    (out / "transition_baselines.json").write_text(json.dumps(rows, indent=2, default=float) + "\n")
    print(f"\nwrote {doc}, {fig_path} and {out / 'transition_baselines.json'}")
    return 0
