"""The objective: the metrics a spec may name (``METRICS``), their values from a run
(``run_metrics``, ``joint_limit_margin_deg``), one simulation's cost (``score``) and a
candidate's cost over its simulations (``aggregate``).

One simulation's cost is

    cost = sum_i weight_i * metric_i
           + penalty_weight * sum_c (violation_c / scale_c)^2      (constraints violated)
           + wall_cost                                             (the hull touched a wall)

and ``failed_cost`` (large, finite: CMA-ES ranks it last and goes on) when the run was
refused by the scenario's checks, failed, or lacks a metric the objective needs (e.g. no
steady window for a mean velocity)."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from manta_drake.optimize.spec import Constraint, Objective

# Short name -> what it is. The values come from the run's metrics.json (simulate.
# compute_metrics) and its log; docs/optimize.md lists them.
METRICS = {
    "u": "mean forward velocity over the steady window, body frame [m/s] "
    "(metrics.json mean_velocity_body[0])",
    "v": "mean lateral velocity (to the left) over the steady window [m/s] (mean_velocity_body[1])",
    "abs_u": "|u| [m/s]",
    "abs_v": "|v| [m/s]",
    "speed": "sqrt(u^2 + v^2) [m/s]",
    "yaw_rate": "mean yaw rate over the steady window [deg/s] (yaw_rate_deg_s; + to the left)",
    "abs_yaw_rate": "|yaw_rate| [deg/s]",
    "cot_electrical": "electrical cost of transport over the steady window, by the dry "
    "weight (energy.cot_electrical_dry_weight)",
    "cot_net_of_hotel": "the same less the hotel load: computers and servo standby "
    "(energy.cot_net_of_hotel_dry_weight)",
    "cot_mechanical": "mechanical cost of transport, by the dry weight "
    "(energy.cot_mechanical_dry_weight)",
    "mean_power_w": "mean electrical power over the run [W] (energy.mean_electrical_power_w)",
    "joint_limit_margin_deg": "smallest distance of any joint angle, measured or commanded, "
    "from its joint limit over the run [deg] (negative: beyond it)",
    "max_penetration_m": "deepest contact penetration over the run [m] (max_penetration_m)",
    "distance_from_start_gait": "RMS change [deg] of the entries the free parameters set "
    "(entries, ties, Phi_prime partners) from the start gait",
}

# The metrics of the run's steady window (simulate.MIN_STEADY_WINDOW long at least): a run
# without one gives none of them.
STEADY_METRICS = (
    "u",
    "v",
    "abs_u",
    "abs_v",
    "speed",
    "yaw_rate",
    "abs_yaw_rate",
    "cot_electrical",
    "cot_net_of_hotel",
    "cot_mechanical",
)

# Status of a simulation that ran to its end; anything else costs failed_cost.
OK = "ok"


def run_metrics(metrics: dict, log: dict | None = None, limits=None) -> dict:
    """The short metrics (``METRICS``, but ``distance_from_start_gait``, which the client
    adds) of one run: ``metrics`` is its metrics.json, ``log`` its log (for the joint-limit
    margin) and ``limits`` the (16, 2) joint limits [rad]. A value the run does not give
    (no steady window, no energy model, no speed for a cost of transport) is None."""
    u_v = metrics.get("mean_velocity_body") or [None, None]
    u, v = (None if x is None else float(x) for x in u_v)
    yaw = metrics.get("yaw_rate_deg_s")
    energy = metrics.get("energy") or {}

    def num(x):
        return None if x is None or not math.isfinite(float(x)) else float(x)

    out = {
        "u": num(u),
        "v": num(v),
        "abs_u": None if u is None else abs(u),
        "abs_v": None if v is None else abs(v),
        "speed": None if u is None or v is None else math.hypot(u, v),
        "yaw_rate": num(yaw),
        "abs_yaw_rate": None if yaw is None else abs(float(yaw)),
        "cot_electrical": num(energy.get("cot_electrical_dry_weight")),
        "cot_net_of_hotel": num(energy.get("cot_net_of_hotel_dry_weight")),
        "cot_mechanical": num(energy.get("cot_mechanical_dry_weight")),
        "mean_power_w": num(energy.get("mean_electrical_power_w")),
        "joint_limit_margin_deg": None,
        "max_penetration_m": num(metrics.get("max_penetration_m")),
    }
    if log is not None and limits is not None:
        out["joint_limit_margin_deg"] = joint_limit_margin_deg(log, limits)
    return out


def joint_limit_margin_deg(log: dict, limits) -> float | None:
    """Smallest ``min(q - lower, upper - q)`` [deg] over every sample and joint of the
    measured (``joint_angles``) and commanded (``commanded_joint_angles``) angles; the
    commanded ones count because the plant's limits clip what a gait asks beyond them."""
    limits = np.asarray(limits, dtype=float)
    margins = []
    for key in ("joint_angles", "commanded_joint_angles"):
        q = np.asarray(log.get(key, np.zeros((0, len(limits)))), dtype=float)
        if q.size:
            margins.append(np.minimum(q - limits[:, 0], limits[:, 1] - q).min())
    return float(np.degrees(min(margins))) if margins else None


def needed_metrics(objective: Objective) -> list[str]:
    """The metrics the objective reads (terms, constraints and their ``relative_to``)."""
    names = [t.metric for t in objective.terms]
    for c in objective.constraints:
        names.append(c.metric)
        if c.relative_to:
            names.append(c.relative_to)
    return list(dict.fromkeys(names))


@dc.dataclass
class Score:
    """One simulation's cost and its parts."""

    cost: float
    objective: float  # the terms' weighted sum (nan when failed)
    penalty: float  # the constraints' and the wall's
    reason: str  # why it failed or what it violated ("" if neither)
    failed: bool


def constraint_violation(c: Constraint, values: dict) -> tuple[float, str]:
    """How far ``values`` violate ``c`` (0 if not) and, if so, a short text."""
    value = values[c.metric]
    factor = values[c.relative_to] if c.relative_to else 1.0
    of = f" {c.relative_to}" if c.relative_to else ""
    if c.min is not None and value < c.min * factor:
        return c.min * factor - value, f"{c.metric} {value:.4g} < {c.min:g}{of}"
    if c.max is not None and value > c.max * factor:
        return value - c.max * factor, f"{c.metric} {value:.4g} > {c.max:g}{of}"
    return 0.0, ""


def constraint_scale(c: Constraint) -> float:
    if c.scale is not None:
        return float(c.scale)
    if c.relative_to:
        return 1.0
    bound = c.min if c.min is not None else c.max
    if c.min is not None and c.max is not None:
        bound = max(abs(c.min), abs(c.max))
    assert bound is not None  # the loader requires min or max
    return abs(bound) or 1.0


def score(
    objective: Objective, status: str, values: dict, touched_wall: bool = False, reason: str = ""
) -> Score:
    """One simulation's cost (module docstring).

    Args:
        objective: the spec's objective.
        status: the run's status (``ok`` or why not: refused, failed, error, lost).
        values: the short metrics (``run_metrics`` plus ``distance_from_start_gait``).
        touched_wall: the hull came within 1 cm of a wall.
        reason: the run's own reason, kept for a status other than ok.
    """
    if status != OK:
        return Score(objective.failed_cost, math.nan, 0.0, reason or status, True)
    missing = [
        m
        for m in needed_metrics(objective)
        if values.get(m) is None or not math.isfinite(values[m])
    ]
    if missing:
        why = f"no value of {', '.join(missing)}"
        return Score(
            objective.failed_cost, math.nan, 0.0, f"{why} ({reason})" if reason else why, True
        )
    total = float(sum(t.weight * values[t.metric] for t in objective.terms))
    penalty, notes = 0.0, []
    for c in objective.constraints:
        d, text = constraint_violation(c, values)
        if d > 0:
            penalty += objective.penalty_weight * (d / constraint_scale(c)) ** 2
            notes.append(text)
    if touched_wall:
        penalty += objective.wall_cost
        notes.append("touched a wall")
    return Score(total + penalty, total, penalty, "; ".join(notes), False)


def short_window_cost(failed_cost: float, length: float, min_window: float) -> float:
    """The cost of a run left unscored because a wall cut its steady window to ``length`` s,
    under ``budget.min_window``: from ``failed_cost`` (no window) down to half of it (a
    window just short). Above any scored run's cost, but graded, so CMA-ES (which ranks) still
    learns from a generation whose runs all meet a wall early: on the floor a gait that keeps
    off the side walls longer is one that turns and slips less."""
    fraction = min(max(length / min_window, 0.0), 1.0)
    return failed_cost * (1.0 - 0.5 * fraction)


def aggregate(costs, how: str) -> float:
    """A candidate's cost from its simulations' costs: ``mean`` or ``worst`` (largest)."""
    costs = np.asarray(list(costs), dtype=float)
    if how == "worst":
        return float(costs.max())
    return float(costs.mean())
