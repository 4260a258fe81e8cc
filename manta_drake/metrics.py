"""Metrics of a run, as plain functions of the logged time series.

All inputs are numpy arrays sampled at the log period: time ``t`` (N,),
body quaternion ``quat_wxyz`` (N, 4), body position ``xyz`` (N, 3), body
velocity in the world ``v_world`` (N, 3), commanded joint angles (N, 16).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def rotations(quat_wxyz: np.ndarray) -> Rotation:
    """scipy Rotations (body -> world) from Drake's (w, x, y, z) quaternions."""
    q = np.asarray(quat_wxyz, dtype=float)
    return Rotation.from_quat(q[:, [1, 2, 3, 0]])


def euler_rpy(quat_wxyz: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw [rad] of Drake's RollPitchYaw (R = Rz(yaw) Ry(pitch) Rx(roll)), (N, 3),
    defined for every orientation, the pitch in [-pi/2, pi/2], roll and yaw in [-pi, pi].

    Drake's algorithm (``math/roll_pitch_yaw.cc``, after Mitiguy), vectorised: the pitch from
    the rotation matrix, atan2(-R20, sqrt((R00^2 + R10^2 + R21^2 + R22^2) / 2)); roll and yaw
    from the quaternion's half angles, roll = zA - zB and yaw = zA + zB with
    zA = atan2(x + z, w - y) and zB = atan2(z - x, w + y), which stay accurate up to the
    gimbal lock. At the lock (pitch +-90 deg) only yaw - roll (pitch +90) or yaw + roll
    (pitch -90) is determined (mod 2 pi); the half angle that vanishes there counts as 0,
    which splits it evenly: yaw = -roll at +90 deg, yaw = roll at -90 deg (as Drake's
    ``RollPitchYaw``). No angle there is a 0/0.
    """
    q = np.asarray(quat_wxyz, dtype=float).reshape(-1, 4)
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    r00 = 1 - 2 * (y * y + z * z)
    r10 = 2 * (x * y + w * z)
    r20 = 2 * (x * z - w * y)
    r21 = 2 * (y * z + w * x)
    r22 = 1 - 2 * (x * x + y * y)
    pitch = np.arctan2(-r20, np.sqrt((r00**2 + r10**2 + r21**2 + r22**2) / 2))
    eps = np.finfo(float).eps

    def half(sine, cosine):
        singular = (np.abs(sine) <= eps) & (np.abs(cosine) <= eps)
        return np.where(singular, 0.0, np.arctan2(sine, cosine))

    z_a, z_b = half(x + z, w - y), half(z - x, w + y)  # each in [-pi, pi]
    return np.stack([_wrap_once(z_a - z_b), pitch, _wrap_once(z_a + z_b)], axis=1)


def _wrap_once(angle: np.ndarray) -> np.ndarray:
    """An angle in [-2 pi, 2 pi] moved into [-pi, pi]."""
    return np.where(
        angle > np.pi, angle - 2 * np.pi, np.where(angle < -np.pi, angle + 2 * np.pi, angle)
    )


def velocity_in_body(quat_wxyz: np.ndarray, v_world: np.ndarray) -> np.ndarray:
    """Body-frame translational velocity [u, v, w] (Drake body axes: x fwd, y left, z up)."""
    return rotations(quat_wxyz).inv().apply(np.asarray(v_world, dtype=float))


def steady_mask(t: np.ndarray, steady_after: float, until: float = np.inf) -> np.ndarray:
    """Samples in [steady_after, until] (all samples if that leaves fewer than two)."""
    mask = (t >= steady_after) & (t <= until)
    return mask if mask.sum() >= 2 else np.ones_like(t, dtype=bool)


def wall_clearance(xyz, quat_wxyz, semi_axes, half_length: float, half_width: float):
    """Per sample, the distance [m] from the hull (an ellipsoid with ``semi_axes`` in the
    body frame) to the nearest of the pool's four walls (x = +-half_length,
    y = +-half_width); negative inside a wall."""
    R = rotations(quat_wxyz).as_matrix()  # (N, 3, 3)
    # An ellipsoid's half-extent along world axis k: sqrt(sum_i (R[k, i] a_i)^2).
    extent = np.sqrt(((R * np.asarray(semi_axes, dtype=float)) ** 2).sum(axis=2))
    p = np.asarray(xyz, dtype=float)
    return np.minimum(
        half_length - np.abs(p[:, 0]) - extent[:, 0], half_width - np.abs(p[:, 1]) - extent[:, 1]
    )


def free_water_end(t, clearance, margin: float) -> float | None:
    """The first time the clearance drops below ``margin``, or None if it never does."""
    near = np.flatnonzero(np.asarray(clearance) < margin)
    return float(t[near[0]]) if len(near) else None


def short_window_note(
    start: float,
    end: float,
    min_window: float,
    sim_time: float,
    near_wall_at: float | None,
    margin: float,
) -> str:
    """Why a run's steady window [start, end] [s] (shorter than ``min_window``) gives no
    mean velocity, naming only the causes that happened: the hull came within ``margin``
    [m] of a wall at ``near_wall_at`` [s] (None: it never did; the window ends there), and
    the run ended at ``sim_time`` [s], less than ``min_window`` after the window's start."""
    causes = []
    if near_wall_at is not None:
        causes.append(f"the hull came within {margin} m of a wall at {near_wall_at:.2f} s")
    if sim_time - start < min_window:
        causes.append(f"the run ended at {sim_time:.2f} s")
    why = f" ({'; '.join(causes)})" if causes else ""
    return (
        f"steady window {start:.2f}-{end:.2f} s is shorter than {min_window} s{why}: "
        "no mean velocity"
    )


def mean_velocity_from_displacement(
    t, quat_wxyz, xyz, steady_after: float, until: float = np.inf
) -> list:
    """Mean [u, v] from the displacement over [steady_after, until], in the mean-heading
    frame.

    Robust to the oscillating velocity of a gait: (x_end - x_start) / duration,
    rotated into the body frame at the mean yaw.
    """
    mask = steady_mask(t, steady_after, until)
    tt, p = t[mask], xyz[mask]
    yaw = np.unwrap(euler_rpy(quat_wxyz[mask])[:, 2])
    d = (p[-1, :2] - p[0, :2]) / max(tt[-1] - tt[0], 1e-9)
    c, s = np.cos(yaw.mean()), np.sin(yaw.mean())
    return [float(c * d[0] + s * d[1]), float(-s * d[0] + c * d[1])]


def yaw_rate_deg_s(t, quat_wxyz, steady_after: float, until: float = np.inf) -> float:
    """Mean yaw rate [deg/s] over [steady_after, until] (slope of the unwrapped yaw)."""
    mask = steady_mask(t, steady_after, until)
    yaw = np.unwrap(euler_rpy(quat_wxyz[mask])[:, 2])
    return float(np.degrees(np.polyfit(t[mask], yaw, 1)[0]))


def horizontal_distance(xyz: np.ndarray) -> float:
    """Straight-line horizontal displacement from the first to the last sample [m]."""
    return float(np.linalg.norm(xyz[-1, :2] - xyz[0, :2]))


def max_joint_step(joint_angles: np.ndarray) -> float:
    """Largest change of any commanded joint angle between consecutive samples [rad]."""
    if len(joint_angles) < 2:
        return 0.0
    return float(np.abs(np.diff(joint_angles, axis=0)).max())


def _wrapped_difference(params, target) -> np.ndarray:
    """params - target with every angle wrapped to (-pi, pi] (parameters on the torus)."""
    return np.angle(np.exp(1j * (np.atleast_2d(params) - np.asarray(target))))


def at_behaviour(params, target, tolerance: float) -> np.ndarray:
    """Per sample, whether every parameter is within ``tolerance`` of ``target`` (wrapped)."""
    return np.abs(_wrapped_difference(params, target)).max(axis=1) < tolerance


def behaviour_at(params: np.ndarray, behaviours: dict, tolerance: float) -> list:
    """Per sample, the behaviour whose parameters are all within ``tolerance`` (angles on
    the torus, wrapped), or None while between behaviours."""
    params = np.atleast_2d(params)
    labels = [None] * len(params)
    for name, target in behaviours.items():
        for i in np.flatnonzero(at_behaviour(params, target, tolerance)):
            labels[i] = name
    return labels


# A leaf's share of the behaviour tree's weights (w_leaf / sum of the weights) below which a
# change toward it has not begun, and how long a leaf must lead to count as a change [s].
TRANSITION_ONSET_SHARE = 0.1
TRANSITION_MIN_LEAD = 2.0  # one cycle of the shipped gaits (0.5 Hz)


def dominant_leaves(t, weights, min_lead: float = 0.0) -> np.ndarray:
    """Per sample, the index of the leaf with the largest weight (the first on a tie); a
    lead shorter than ``min_lead`` [s] (an estimate that flickers about a threshold) is
    given to the leaf that led before it."""
    t = np.asarray(t, dtype=float)
    lead = np.argmax(np.atleast_2d(weights), axis=1)
    starts = np.r_[0, np.flatnonzero(np.diff(lead)) + 1]
    ends = np.r_[starts[1:], len(lead)]
    for a, b in zip(starts[1:], ends[1:]):
        until = t[b] if b < len(t) else np.inf
        if until - t[a] < min_lead:
            lead[a:b] = lead[a - 1]
    return lead


def leaf_transitions(
    t_weights,
    weights,
    leaves,
    t_params,
    params,
    gait_vectors: dict,
    tolerance: float,
    onset: float = TRANSITION_ONSET_SHARE,
    min_lead: float = TRANSITION_MIN_LEAD,
) -> list:
    """Every change of the behaviour tree's dominant leaf (the gait with the largest weight,
    ``behaviour_weights``, leading for at least ``min_lead`` s: ``dominant_leaves``), as
    ``{from, to, start_s, dominant_s, end_s}``:

    * ``start_s``: the last weight sample since the change before at which the new leaf's
      share of the weights was at most ``onset`` (the target began moving toward it; the
      change before, if the share never fell that low since);
    * ``dominant_s``: the first sample at which it led;
    * ``end_s``: the first time from ``start_s`` on at which the CPG's parameters (the
      ``t_params``, ``params`` samples) are within ``tolerance`` rad of its gait on every
      entry (wrapped), before the dominant leaf changes again; None if they never get there.

    Args:
        t_weights, weights: (N,), (N, L) the tree's leaf weights over time.
        leaves: the L leaf (gait) names.
        t_params, params: (M,), (M, 64) the CPG parameters psi over time.
        gait_vectors: leaf name -> its 64-vector.
    """
    t_w, t_p = np.asarray(t_weights, dtype=float), np.asarray(t_params, dtype=float)
    w = np.atleast_2d(np.asarray(weights, dtype=float))
    if len(t_w) == 0:
        return []
    share = w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)
    lead = dominant_leaves(t_w, w, min_lead)
    changes = np.flatnonzero(np.diff(lead)) + 1
    out = []
    for n, i in enumerate(changes):
        new, since = lead[i], changes[n - 1] if n else 0
        before = since + np.flatnonzero(share[since:i, new] <= onset)
        start = t_w[before[-1]] if len(before) else t_w[since]
        until = t_w[changes[n + 1]] if n + 1 < len(changes) else np.inf
        window = (t_p >= start) & (t_p < until)
        there = np.flatnonzero(window & at_behaviour(params, gait_vectors[leaves[new]], tolerance))
        out.append(
            {
                "from": leaves[lead[i - 1]],
                "to": leaves[new],
                "start_s": float(start),
                "dominant_s": float(t_w[i]),
                "end_s": float(t_p[there[0]]) if len(there) else None,
            }
        )
    return out


def transition_span(tr: dict, digits: int = 1) -> str:
    """A ``leaf_transitions`` entry's times as text: ``start-end`` in s, the end ``never``
    when the parameters did not arrive."""
    end = "never" if tr["end_s"] is None else f"{tr['end_s']:.{digits}f}"
    return f"{tr['start_s']:.{digits}f}-{end}"


def heading_change_deg(quat_wxyz) -> float:
    """The hull's heading change over the whole log [deg]: the unwrapped yaw's last value
    less its first (counter-clockwise from above positive)."""
    yaw = np.unwrap(euler_rpy(np.atleast_2d(quat_wxyz))[:, 2])
    return float(np.degrees(yaw[-1] - yaw[0])) if len(yaw) else 0.0


# --- energy --------------------------------------------------------------------------------

# Below this speed of travel [m/s] no cost of transport is reported. 5 mm/s is 1.3 % of a
# body length (0.38 m) per second, 7 cm over a 14 s steady window: the size of the hull's
# sway within a gait cycle and of a standing robot's settling drift, which the
# displacement-based mean speed cannot tell from travel; and there P / (m g u) exceeds ~50,
# a number that says the robot is not going anywhere rather than how dearly.
MIN_TRANSPORT_SPEED = 0.005
STANDARD_GRAVITY = 9.81  # m/s^2


def _step_integral(t, values, start: float = -np.inf, end: float = np.inf) -> tuple:
    """(integral, duration) of a logged per-step signal over (start, end]: each sample k >= 1
    holds the value over (t[k-1], t[k]] (the energy model's outputs are the last step's),
    so the integral is sum values[k] (t[k] - t[k-1]), exact when the log period is the
    plant's step."""
    t = np.asarray(t, dtype=float)
    values = np.asarray(values, dtype=float).reshape(len(t), -1).sum(axis=1)
    if len(t) < 2:
        return 0.0, 0.0
    dt = np.diff(t)
    inside = (t[1:] > start) & (t[1:] <= end)
    return float(np.sum(values[1:][inside] * dt[inside])), float(np.sum(dt[inside]))


# The costs of transport the energy block reports: (name, the steady power it divides).
# "net_of_hotel" leaves out the draw the robot has whatever its joints do (computers and
# servo standby), so it compares locomotion rather than speed; each is divided by the dry
# weight m g and by the weight in water (m - rho V_sealed) g of the deflated robot.
COT_POWERS = ("electrical", "net_of_hotel", "mechanical")
COT_WEIGHTS = ("dry_weight", "weight_in_water")
COT_KEYS = tuple(f"cot_{p}_{w}" for p in COT_POWERS for w in COT_WEIGHTS)
# The energy block's two original names, kept for the tools that read them: each is the
# same number as the named cost it stands for (by the dry weight, as they always were).
COT_ALIASES = {
    "cost_of_transport": "cot_electrical_dry_weight",
    "cost_of_transport_mechanical": "cot_mechanical_dry_weight",
}


def costs_of_transport(
    electrical_w: float,
    mechanical_w: float,
    hotel_w: float,
    dry_weight_n: float,
    weight_in_water_n: float | None,
    speed: float,
) -> dict:
    """P / (W u) for every entry of ``COT_KEYS``: the steady electrical power, the same less
    the hotel load, and the joints' mechanical power sum |tau qdot|, each over the dry weight
    and over the weight in water [N] (None where that weight is None or not positive: a
    deflated robot that floats has no weight in water to carry)."""
    powers = {
        "electrical": electrical_w,
        "net_of_hotel": electrical_w - hotel_w,
        "mechanical": mechanical_w,
    }
    weights = {"dry_weight": dry_weight_n, "weight_in_water": weight_in_water_n}
    out: dict[str, float | None] = {}
    for p in COT_POWERS:
        for w in COT_WEIGHTS:
            weight = weights[w]
            out[f"cot_{p}_{w}"] = (
                powers[p] / (weight * speed) if weight is not None and weight > 0 else None
            )
    return out


def energy_metrics(
    log: dict,
    mass: float,
    usable_energy_wh: float,
    cutoff_soc: float,
    steady_window=None,
    mean_velocity=None,
    weight_in_water_kg=None,
    hotel_power_w: float = 0.0,
    min_speed: float = MIN_TRANSPORT_SPEED,
    gravity: float = STANDARD_GRAVITY,
) -> dict:
    """The run's ``energy`` block from the logged energy model.

    Args:
        log: with ``t_electrical_power``, ``electrical_power`` (N, 1) [W],
            ``t_joint_mechanical_power``, ``joint_mechanical_power`` (N, 16) [W] (tau qdot of
            the last step per joint) and ``t_battery``, ``battery`` (N, 3) [SoC, V, A].
        mass: the robot's mass [kg] (the plant's total).
        usable_energy_wh: the pack's energy between full and the cut-off [Wh].
        cutoff_soc: the state of charge at which the battery counts as empty.
        steady_window: [start, end] [s], the free-water steady window of the run's metrics
            (None: none; no cost of transport).
        mean_velocity: the mean horizontal velocity [u, v] in the mean-heading frame over
            that window [m/s]; the speed of travel is its magnitude (so a crab's sideways
            travel counts).
        weight_in_water_kg: the deflated robot's net weight [kg] (None: no water model).
        hotel_power_w: the draw the robot has whatever its joints do [W] (the computers and
            every servo's standby).
        min_speed: below this speed of travel the costs of transport are None, with a note.
        gravity: [m/s^2].

    Returns:
        ``mechanical_energy_j`` (integral of sum_j |tau_j qdot_j| over the run),
        ``electrical_energy_j`` (integral of the electrical power), ``mean_electrical_power_w``
        (over the run), ``hotel_power_w``, ``dry_weight_n``, ``weight_in_water_n``, the six
        costs of transport of ``COT_KEYS`` (``costs_of_transport`` of the window's mean
        powers) and their ``COT_ALIASES``, ``battery_soc_end``, ``operation_time_h``
        (usable energy / mean electrical power), and ``steady_electrical_power_w``,
        ``steady_mechanical_power_w``, ``transport_speed_m_s``, ``battery_cutoff_at_s``
        (first time at the cut-off, or None) and ``cost_of_transport_note`` (why the costs
        of transport are None).
    """
    wet = None if weight_in_water_kg is None else float(weight_in_water_kg) * gravity
    out = _run_energy(log, mass * gravity, wet, usable_energy_wh, cutoff_soc, hotel_power_w)
    out["cost_of_transport_note"] = _add_costs_of_transport(
        out, log, steady_window, mean_velocity, hotel_power_w, min_speed
    )
    return out


def _run_energy(
    log: dict,
    dry_weight_n: float,
    wet: float | None,
    usable_energy_wh: float,
    cutoff_soc: float,
    hotel_power_w: float,
) -> dict:
    """``energy_metrics``' block over the whole run (energies, mean power, battery), its
    steady-window entries and costs of transport None."""
    t_p, power = log["t_electrical_power"], log["electrical_power"]
    t_m, mech = log["t_joint_mechanical_power"], np.abs(log["joint_mechanical_power"])
    t_b, battery = log["t_battery"], np.asarray(log["battery"], dtype=float)
    electrical, duration = _step_integral(t_p, power)
    mechanical, _ = _step_integral(t_m, mech)
    mean_power = electrical / duration if duration > 0 else None
    out = {
        "mechanical_energy_j": mechanical,
        "electrical_energy_j": electrical,
        "mean_electrical_power_w": mean_power,
        "hotel_power_w": float(hotel_power_w),
        "dry_weight_n": dry_weight_n,
        "weight_in_water_n": wet,
        **dict.fromkeys(COT_KEYS),
        **dict.fromkeys(COT_ALIASES),
        "battery_soc_end": float(battery[-1, 0]) if len(battery) else None,
        "operation_time_h": (
            usable_energy_wh / mean_power if mean_power is not None and mean_power > 0 else None
        ),
        "steady_electrical_power_w": None,
        "steady_mechanical_power_w": None,
        "transport_speed_m_s": None,
        "battery_cutoff_at_s": None,
        "cost_of_transport_note": None,
    }
    empty = np.flatnonzero(battery[:, 0] <= cutoff_soc) if len(battery) else np.empty(0, dtype=int)
    if len(empty):
        out["battery_cutoff_at_s"] = float(t_b[empty[0]])
    return out


def _add_costs_of_transport(
    out: dict, log: dict, steady_window, mean_velocity, hotel_power_w: float, min_speed: float
) -> str | None:
    """Fills ``out``'s steady powers, speed of travel and costs of transport (with their
    aliases) as far as the run has them; returns the note on why they are None, if any."""
    if steady_window is None:
        return "no steady window: no cost of transport"
    start, end = steady_window
    if mean_velocity is None:
        return (
            f"no mean velocity over the steady window "
            f"{start:.2f}-{end:.2f} s (the run's note says why): "
            "no cost of transport"
        )
    t_p, power = log["t_electrical_power"], log["electrical_power"]
    t_m, mech = log["t_joint_mechanical_power"], np.abs(log["joint_mechanical_power"])
    e_steady, t_steady = _step_integral(t_p, power, start, end)
    m_steady, t_steady_m = _step_integral(t_m, mech, start, end)
    if t_steady <= 0 or t_steady_m <= 0:
        return "no energy samples in the steady window"
    out["steady_electrical_power_w"] = e_steady / t_steady
    out["steady_mechanical_power_w"] = m_steady / t_steady_m
    speed = float(np.hypot(*mean_velocity))
    out["transport_speed_m_s"] = speed
    if speed < min_speed:
        return f"speed of travel {speed:.4f} m/s is below {min_speed} m/s: no cost of transport"
    wet = out["weight_in_water_n"]
    out.update(
        costs_of_transport(
            out["steady_electrical_power_w"],
            out["steady_mechanical_power_w"],
            hotel_power_w,
            out["dry_weight_n"],
            wet,
            speed,
        )
    )
    out.update({alias: out[name] for alias, name in COT_ALIASES.items()})
    if wet is not None and wet <= 0:
        return (
            f"the deflated robot floats (weight in water {wet:.2f} N): no cost of transport by it"
        )
    return None


def step_mean(t, values, start: float = -np.inf, end: float = np.inf) -> float | None:
    """The time mean over (start, end] of a logged per-step signal (``_step_integral``),
    summed over its columns; None without samples there."""
    energy, duration = _step_integral(t, values, start, end)
    return energy / duration if duration > 0 else None


def power_breakdown(t, terms: dict, window=None) -> dict:
    """Mean power [W] of each of ``terms`` (name -> per-step samples (N,) or (N, joints),
    summed over joints) over ``window`` [start, end] (None: the whole run), as
    ``<name>_w``, with ``total_w`` their sum and ``window_s`` the window used."""
    start, end = (-np.inf, np.inf) if window is None else window
    means = {f"{name}_w": step_mean(t, values, start, end) for name, values in terms.items()}
    out: dict[str, float | list[float] | None] = dict(means)
    present = [m for m in means.values() if m is not None]
    out["total_w"] = float(sum(present)) if len(present) == len(means) else None
    if window is not None:
        out["window_s"] = [float(start), float(end)]
    else:
        out["window_s"] = [float(t[0]), float(t[-1])] if len(t) else None
    return out


# A sample is outside the actuator's envelope when the duty it needs exceeds full duty by
# more than rounding (the datasheet servo's own torque reaches exactly 1).
ENVELOPE_TOLERANCE = 1e-6


def envelope_summary(t: np.ndarray, ratio: np.ndarray, joint_names, voltage) -> dict:
    """How far the joints left the servo's torque-speed envelope: ``ratio`` (N, joints) is
    the duty each (rate, torque) sample needs over the most the servo has
    (``model.servo.envelope_ratio``; > 1 is outside) at the bus ``voltage`` [V] of each
    sample (N,) (or one for all). Returns the bus voltage at the worst sample and the
    range over the run, the count and fraction of samples outside, the worst ratio and
    where."""
    ratio = np.asarray(ratio, dtype=float)
    volts = np.broadcast_to(np.asarray(voltage, dtype=float), ratio.shape[:1])
    outside = ratio > 1.0 + ENVELOPE_TOLERANCE
    i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    return {
        "voltage_V": float(volts[i]),
        "voltage_range_V": [float(volts.min()), float(volts.max())],
        "samples_outside": int(outside.sum()),
        "fraction_outside": float(outside.mean()),
        "worst_ratio": float(ratio[i, j]),
        "worst_joint": str(joint_names[j]),
        "worst_time_s": float(t[i]),
    }


# A carrier bearing more of the floor's normal force than this stands on it [N].
LOADED_N = 0.1


def foot_summary(t, loads, yaw, carriers, window=None, loaded: float = LOADED_N) -> dict:
    """Each carrier's stance on the floor over ``window`` [start, end] (None: the run).

    Args:
        t: (N,) sample times [s].
        loads: (N, 3 k) per carrier [N, s_x, s_y] (``station.foot_contacts``): the normal
            load [N] and the load-weighted horizontal slip velocity of its contacts [m/s].
        yaw: (N,) the hull's heading at each sample [rad] (the slip's forward component is
            along it).
        carriers: the k carrier names.

    Returns per carrier: ``duty`` (the share of samples with N > ``loaded``),
    ``normal_force_n`` (mean N over the window), ``stance_force_n`` (mean N over its loaded
    samples, None without any), ``load_share`` (its share of the total normal load),
    ``slip_speed_m_s`` = sum N |s| / sum N and ``slip_forward_m_s`` = sum N (s . heading) /
    sum N (None without load); and ``legs_down_mean``: the mean number of loaded carriers
    other than ``hull``, and ``window_s``."""
    t = np.asarray(t, dtype=float)
    start, end = (-np.inf, np.inf) if window is None else window
    inside = (t >= start) & (t <= end)
    L = np.asarray(loads, dtype=float)[inside].reshape(int(inside.sum()), len(carriers), 3)
    heading = np.stack([np.cos(yaw), np.sin(yaw)], axis=-1)[inside]
    fn, slip = L[:, :, 0], L[:, :, 1:]
    total = fn.sum()
    out: dict[str, dict[str, float | None] | float | list[float] | None] = {}
    for k, name in enumerate(carriers):
        down = fn[:, k] > loaded
        weight = fn[:, k].sum()
        out[name] = {
            "duty": float(down.mean()) if len(down) else None,
            "normal_force_n": float(fn[:, k].mean()) if len(down) else None,
            "stance_force_n": float(fn[down, k].mean()) if down.any() else None,
            "load_share": float(weight / total) if total > 0 else None,
            "slip_speed_m_s": (
                float(fn[:, k] @ np.linalg.norm(slip[:, k], axis=1) / weight)
                if weight > 0
                else None
            ),
            "slip_forward_m_s": (
                float(fn[:, k] @ np.einsum("ij,ij->i", slip[:, k], heading) / weight)
                if weight > 0
                else None
            ),
        }
    legs = [k for k, name in enumerate(carriers) if name != "hull"]
    out["legs_down_mean"] = float((fn[:, legs] > loaded).sum(axis=1).mean()) if len(fn) else None
    out["window_s"] = [float(t[inside][0]), float(t[inside][-1])] if inside.any() else None
    return out
