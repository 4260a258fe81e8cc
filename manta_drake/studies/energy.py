"""The energy findings of the five locomotion gaits over the uncertainty band.

Reads the table of the sweep ``diagrams/sweeps/energy.yaml``: the five gaits of section 4.1
at the shipped point, one parameter at a time at each end of its band, and at a Latin
hypercube of band points (foot-floor friction, hull damping, deflated net weight, servo
standby current, winding resistance, gearbox efficiency and position gain, the foil fins'
lift slope, leading-edge suction and added mass shared with the hull, the Jetson's power
mode), each at four stall angles of the fins' strips (10, 15 = shipped, 20, 25 deg: the
foil parameter that moves the thrust most, docs/validation.md). Each run's metrics give its
free-water window's mean velocity, electrical and mechanical power, every cost of transport
and, with the pack's usable energy, an operation time.

It reports, in ``OUT/energy.md`` between ``<!-- energy-report:begin -->`` and
``<!-- energy-report:end -->`` (the hand-written text around the block is kept; the prose is
the template ``templates/energy.md.j2``):

* per gait at the shipped point and over the band (median and 10-90 % range): speed,
  electrical and mechanical power, both costs of transport, operation time;
* the shipped point's power budget (electronics, servo standby, copper loss, the motors'
  conversion of mechanical power), from each run's own ``power_breakdown`` (the metrics'),
  checked against its logged draw and against the 5W run;
* the predicted operation time against Table 1's "approx. 1.0 h", and which parameter moves
  it most (one at a time, and Spearman rank correlations over the band);
* whether "swimming is slower than walking" and "the walk is the most efficient gait" hold
  over the band, per stall angle;

and the figures ``OUT/figures/energy_speed_cot.png``, ``energy_operation_time.png`` and
``energy_findings.png``. ``OUT`` is ``--out DIR``, by default the checkout's ``docs/``
(``studies.report.output_folder``).

A gait's criterion value is *undetermined* at a point when its run is not ok or has no
free-water window (no mean velocity, no window power); the criteria are three-valued
(Kleene), as in ``manta_drake.studies.findings``. A run that has a window but travels slower
than the metric's 5 mm/s has no finite cost of transport: it counts as infinite (it spends
energy and does not travel), not as undetermined.

Usage:

    manta-drake sweep diagrams/sweeps/energy.yaml --out out/energy
    manta-drake study energy                    # reads out/energy/results.csv
    manta-drake study energy --results diagrams/sweeps/data/energy_results.csv
    manta-drake study energy --results ... --out out/report    # the page elsewhere

``--check-logs DIR`` instead reads the sweep's run folders (``DIR/runs/<id>/log.npz``) and
prints how steady each run's electrical power is over its free-water window (whole gait
cycles: the mean of the window's first and second halves).
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import math
import pathlib

import numpy as np

from manta_drake.metrics import COT_KEYS
from manta_drake.studies.findings import Tally, _and, gait_of, read_results

# ---------------------------------------------------------------------------------------------
# The band (diagrams/sweeps/energy.yaml is ``band_rows()``)

# The band's parameters by the sweep's names (links in diagrams/sweeps/energy.yaml), in the
# table's order, and their shipped values.
PARAMS = (
    "contact.friction",
    "hull_damping",
    "net_weight_kg",
    "standby_current",
    "winding_resistance",
    "gearbox_efficiency",
    "position_gain",
    "lift_slope",
    "suction_efficiency",
    "fin_hull_added_mass",
    "actuators.electronics_mode",
    "stall_angle",
)
SHIPPED_NET_WEIGHT_KG = 0.845  # the shipped coefficients' deflated net weight, 3 decimals
STALL_ANGLE_DEG = 15.0  # models/hydrodynamics.yaml fins.stall_angle_deg
SHIPPED: dict[str, float | str] = {
    "contact.friction": 0.8,
    "hull_damping": 1.0,
    "net_weight_kg": SHIPPED_NET_WEIGHT_KG,
    "standby_current": 1.0,
    "winding_resistance": 1.0,
    "gearbox_efficiency": 1.0,
    "position_gain": 1.0,
    "lift_slope": 1.0,
    "suction_efficiency": 1.0,
    "fin_hull_added_mass": 1.0,
    "actuators.electronics_mode": "10W",
    "stall_angle": 1.0,
}
LABELS = {
    "contact.friction": "friction",
    "hull_damping": "hull damping",
    "net_weight_kg": "net weight",
    "standby_current": "standby current",
    "winding_resistance": "winding resistance",
    "gearbox_efficiency": "gearbox efficiency",
    "position_gain": "servo position gain",
    "lift_slope": "fin lift slope",
    "suction_efficiency": "leading-edge suction",
    "fin_hull_added_mass": "fin-hull added mass",
    "actuators.electronics_mode": "Jetson mode",
    "stall_angle": "stall angle",
}
FACTORS = (
    "hull_damping",
    "standby_current",
    "winding_resistance",
    "gearbox_efficiency",
    "position_gain",
    "lift_slope",
    "suction_efficiency",
    "fin_hull_added_mass",
)
CONTINUOUS = {
    "contact.friction": (0.5, 0.8),
    "hull_damping": (0.7, 1.3),
    "net_weight_kg": (0.6, 1.1),
    "standby_current": (0.8, 1.2),
    "winding_resistance": (0.8, 1.2),
    "gearbox_efficiency": (0.8, 1.1),
    "position_gain": (0.5, 2.0),
    "lift_slope": (1.0, 1.39),
    "suction_efficiency": (0.5, 1.0),
    "fin_hull_added_mass": (0.28, 1.0),
}
MODES = ("5W", "10W")
MODE_WATTS = {"5W": 5.0, "10W": 10.0}  # the Jetson's budget in each mode
STALL_FACTORS = (0.667, 1.0, 1.333, 1.667)  # x 15 deg: 10, 15 (shipped), 20, 25 deg
ONE_AT_A_TIME = (
    ("contact.friction", 0.5),
    ("contact.friction", 0.65),
    ("hull_damping", 0.7),
    ("hull_damping", 1.3),
    ("net_weight_kg", 0.6),
    ("net_weight_kg", 1.1),
    ("standby_current", 0.8),
    ("standby_current", 1.2),
    ("winding_resistance", 0.8),
    ("winding_resistance", 1.2),
    ("gearbox_efficiency", 0.8),
    ("gearbox_efficiency", 1.1),
    ("position_gain", 0.5),
    ("position_gain", 2.0),
    ("lift_slope", 1.39),
    ("suction_efficiency", 0.5),
    ("fin_hull_added_mass", 0.28),
    ("actuators.electronics_mode", "5W"),
    ("stall_angle", 0.667),
    ("stall_angle", 1.333),
    ("stall_angle", 1.667),
)
SAMPLE_SEED = 2026
SAMPLE_POINTS = 12


def band_rows(n: int = SAMPLE_POINTS, seed: int = SAMPLE_SEED) -> list[dict]:
    """The sweep's parameter sets: the shipped point ({}), one parameter at a time at each
    end of its band (ONE_AT_A_TIME), then ``n`` points over the whole band
    (``band_sample``), each at the four stall angles of STALL_FACTORS."""
    rows: list[dict] = [{}]
    rows += [{name: value} for name, value in ONE_AT_A_TIME]
    for point in band_sample(n, seed):
        rows += [{**point, "stall_angle": f} for f in STALL_FACTORS]
    return rows


def band_sample(n: int = SAMPLE_POINTS, seed: int = SAMPLE_SEED) -> list[dict]:
    """``n`` points of a Latin hypercube over the band, decorrelated.

    Drawn with ``numpy.random.default_rng(seed)``: for each continuous parameter in
    CONTINUOUS's order, a permutation of the ``n`` equal strata of its range and a uniform
    draw within each (rounded to 3 decimals); then the Jetson modes, each of MODES on an
    equal share of the points, in a random order. A random pairing of the columns leaves
    chance rank correlations between parameters (up to 0.6 with 12 points), which would
    lend one parameter another's effect; so the values are then swapped between points
    within each column (``decorrelate``)."""
    rng = np.random.default_rng(seed)
    columns: list[list[float | str]] = []
    for lo, hi in CONTINUOUS.values():
        strata = (rng.permutation(n) + rng.uniform(size=n)) / n
        columns.append([round(float(lo + (hi - lo) * x), 3) for x in strata])
    columns.append([MODES[i % len(MODES)] for i in rng.permutation(n)])
    decorrelate(columns)
    names = list(CONTINUOUS) + ["actuators.electronics_mode"]
    return [{name: columns[k][i] for k, name in enumerate(names)} for i in range(n)]


def decorrelate(columns: list[list]) -> None:
    """Swaps values between points within each column but the first (in place) wherever a
    swap lowers the sum of the squared rank correlations of all pairs of columns, until no
    swap does; every column keeps its values (hence a hypercube stays one, and the modes
    their shares)."""
    ranks = np.array([_ranks(np.asarray([_number(v) for v in col])) for col in columns]).T
    n = ranks.shape[0]
    best = _correlation_cost(ranks)
    improved = True
    while improved:
        improved = False
        for c in range(1, len(columns)):
            for i in range(n):
                for j in range(i + 1, n):
                    ranks[[i, j], c] = ranks[[j, i], c]
                    trial = _correlation_cost(ranks)
                    if trial < best - 1e-12:
                        best, improved = trial, True
                        columns[c][i], columns[c][j] = columns[c][j], columns[c][i]
                    else:
                        ranks[[i, j], c] = ranks[[j, i], c]


def _correlation_cost(ranks: np.ndarray) -> float:
    c = np.corrcoef(ranks, rowvar=False)
    return float(np.sum(np.triu(c, 1) ** 2))


def _number(value) -> float:
    """A parameter's value as a number (the Jetson mode as its watts)."""
    return MODE_WATTS[value] if isinstance(value, str) else float(value)


def rank_correlations(points: list[dict], names=None) -> dict:
    """{(a, b): Spearman rho} between every pair of the points' parameters (the Jetson mode
    as its watts)."""
    names = list(names or [k for k in PARAMS if k != "stall_angle"])
    values = {k: [_number(p[k]) for p in points] for k in names}
    return {
        (a, b): spearman(values[a], values[b]) for i, a in enumerate(names) for b in names[i + 1 :]
    }


# ---------------------------------------------------------------------------------------------
# Criteria (thresholds and what they mean)

GAITS = ("swim", "trot", "walk", "crab", "turning")
FORWARD_GAITS = ("swim", "trot", "walk")
TABLE1_HOURS = 1.0  # paper Table 1: "Operation time: approx. 1.0h"
# "Approx. 1.0 h" agrees with a prediction within +-25 %: the table gives one figure to one
# decimal with "approx.", no conditions (gait, duty, charge used), so a quarter either way.
TABLE1_TOLERANCE = 0.25
# A run's window power is a steady, free-water figure when its free-water window holds at
# least two whole cycles of the 0.5 Hz gaits.
MIN_WINDOW_S = 4.0
MARK_BEGIN = "<!-- energy-report:begin -->"
MARK_END = "<!-- energy-report:end -->"
DEFAULT_RESULTS = "out/energy/results.csv"
SHIPPED_RESULTS = "diagrams/sweeps/data/energy_results.csv"


@dc.dataclass(frozen=True)
class GaitEnergy:
    """One run's energy figures; None = undetermined.

    ``cot`` and ``cot_mech`` are inf when the run has a window but travels slower than the
    metric's minimum speed (it spends energy without travelling)."""

    u: float | None = None  # mean forward velocity over the free-water window [m/s]
    v: float | None = None  # mean leftward velocity [m/s]
    speed: float | None = None  # speed of travel |(u, v)| [m/s]
    power_w: float | None = None  # mean electrical power over the window [W]
    mech_w: float | None = None  # mean sum |tau qdot| over the window [W]
    cot: float | None = None  # electrical cost of transport P / (m g |u, v|)
    cot_mech: float | None = None  # mechanical cost of transport
    # The metrics' every convention (manta_drake.metrics.COT_KEYS): {key: value}, inf as above.
    cots: dict = dc.field(default_factory=dict)
    hours: float | None = None  # operation time at the window's power [h]
    run_hours: float | None = None  # the metrics' operation_time_h (the whole run's power)
    window_s: tuple | None = None  # (start, end) of the free-water window [s]
    near_wall_at_s: float | None = None
    touched_wall: bool | None = None
    # The metrics' power_breakdown over the window: {column: W} (BUDGET_PARTS' columns).
    breakdown: dict = dc.field(default_factory=dict)

    @property
    def cot_net(self) -> float | None:
        """The electrical cost of transport net of the hotel load, by the dry weight."""
        return self.cots.get("cot_net_of_hotel_dry_weight")


UNDETERMINED = GaitEnergy()


def _get(point: dict, gait: str) -> GaitEnergy:
    return point.get(gait) or UNDETERMINED


def swim_slower_than_walk(point: dict) -> bool | None:
    """u_swim < u_walk."""
    u_swim, u_walk = _get(point, "swim").u, _get(point, "walk").u
    if u_swim is None or u_walk is None:
        return None
    return u_swim < u_walk


def walk_most_efficient(
    point: dict, others=("swim", "trot", "crab", "turning"), field: str = "cot"
) -> bool | None:
    """The walk's cost of transport (``field``: ``cot`` electrical, ``cot_mech``
    mechanical) strictly below that of every gait in ``others`` (an infinite cost, a gait
    that does not travel, is above any finite one; two infinite costs are not below each
    other)."""
    walk = getattr(_get(point, "walk"), field)
    if walk is None:
        return None
    return _and(
        None if getattr(_get(point, g), field) is None else walk < getattr(_get(point, g), field)
        for g in others
    )


def agrees_with_table1(
    hours: float | None, claim: float = TABLE1_HOURS, tolerance: float = TABLE1_TOLERANCE
) -> bool | None:
    """A predicted operation time within ``tolerance`` (relative) of Table 1's figure."""
    if hours is None:
        return None
    return abs(hours - claim) <= tolerance * claim


def steady_free_water(run: GaitEnergy, min_window_s: float = MIN_WINDOW_S) -> bool | None:
    """The run's window power is a free-water, steady figure: it has a window (which by
    construction ends before the hull comes within the free-water margin of a wall) of at
    least ``min_window_s``. None: no window at all."""
    if run.window_s is None or run.power_w is None:
        return None
    return run.window_s[1] - run.window_s[0] >= min_window_s


# (key, label, criterion text, function); the key is the column's name in the tables.
FINDINGS = (
    ("A", "A. swimming is slower than walking", "u_swim < u_walk", swim_slower_than_walk),
    (
        "B",
        "B. the walk is the most efficient gait",
        "CoT_walk < CoT of swim, trot, crab and turning (electrical)",
        walk_most_efficient,
    ),
)
VARIANTS = (
    (
        "B-forward",
        "B-forward. walk most efficient of the forward gaits",
        "CoT_walk < CoT_swim and CoT_trot (electrical)",
        lambda p: walk_most_efficient(p, ("swim", "trot")),
    ),
    (
        "B-floor",
        "B-floor. walk most efficient of the floor gaits",
        "CoT_walk < CoT of trot, crab and turning (electrical; swim left out)",
        lambda p: walk_most_efficient(p, ("trot", "crab", "turning")),
    ),
    (
        "B-mech",
        "B-mech. walk most efficient by the mechanical CoT",
        "CoT_mech,walk < CoT_mech of the other four",
        lambda p: walk_most_efficient(p, field="cot_mech"),
    ),
)


def spearman(x, y) -> float | None:
    """Spearman's rank correlation of two equal-length sequences (ties get their average
    rank); None with fewer than 3 pairs or a constant sequence."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) != len(y):
        raise ValueError(f"spearman: {len(x)} and {len(y)} values")
    if len(x) < 3:
        return None
    rx, ry = _ranks(x), _ranks(y)
    if np.ptp(rx) == 0 or np.ptp(ry) == 0:
        return None
    return float(np.corrcoef(rx, ry)[0, 1])


def _ranks(x: np.ndarray) -> np.ndarray:
    order = np.argsort(x, kind="mergesort")
    ranks = np.empty(len(x))
    ranks[order] = np.arange(1, len(x) + 1)
    for value in np.unique(x):  # ties: the average of their ranks
        tied = x == value
        ranks[tied] = ranks[tied].mean()
    return ranks


# The parts of the electrical draw each run's metrics give (``power_breakdown``): name in the
# budget -> its column.
BUDGET_PARTS = {
    "electronics": "computers_w",
    "standby": "standby_w",
    "copper": "copper_w",
    "conversion": "shaft_w",
}


def power_budget(shipped: GaitEnergy, oat: dict) -> dict | None:
    """The shipped point's window power split into its parts, from the run's own
    ``power_breakdown`` (the computers' draw, the servos' standby I_standby V, their copper
    loss R i^2 and the power converted to the motors' shafts: the joints' work and the
    gearbox's loss; ``manta_drake.metrics``), with two checks: ``closure``, the logged draw
    less the parts' sum [W], and the 5W run's draw below the shipped one
    (``mode_step_measured``) against the file's electronics (``mode_step_file``). The
    one-at-a-time runs cannot split the draw by differences: the servos' standby and
    winding resistance move the battery's terminal voltage, and with it the servos and the
    motion. Returns None without the breakdown or the 5W run."""
    mode5 = oat.get(("actuators.electronics_mode", "5W"), UNDETERMINED)
    found = {name: shipped.breakdown.get(column) for name, column in BUDGET_PARTS.items()}
    parts = {name: w for name, w in found.items() if w is not None}
    if shipped.power_w is None or mode5.power_w is None or len(parts) < len(found):
        return None
    from manta_drake.model.actuators import (
        DEFAULT_ACTUATORS_FILE,
        electronics_power,
        load_actuators,
    )

    params = load_actuators(DEFAULT_ACTUATORS_FILE)
    mode_step = electronics_power(params, "10W") - electronics_power(params, "5W")
    return {
        "total": shipped.power_w,
        **parts,
        "closure": shipped.power_w - sum(parts.values()),
        "mode_step_measured": shipped.power_w - mode5.power_w,
        "mode_step_file": mode_step,
    }


def needed_for_table1(budget: dict, usable_wh: float, hours: float = TABLE1_HOURS) -> dict:
    """What a draw that empties the pack in ``hours`` would take, one part at a time: the
    mean power, the extra over the model, and the factor on the standby current, on the
    copper loss and on the joint torques (the copper loss goes with the square of the torque)
    that alone would give that extra."""
    need = usable_wh / hours
    extra = need - budget["total"]
    copper = extra / budget["copper"] + 1.0 if budget["copper"] > 0 else math.inf
    return {
        "power_w": need,
        "extra_w": extra,
        "standby_factor": extra / budget["standby"] + 1.0 if budget["standby"] > 0 else math.inf,
        "copper_factor": copper,
        "torque_factor": math.sqrt(copper),
    }


# ---------------------------------------------------------------------------------------------
# Reading the table


def _float(cell) -> float | None:
    if cell is None or str(cell).strip() == "":
        return None
    x = float(cell)
    return x if math.isfinite(x) else None


def _bool(cell) -> bool | None:
    text = str(cell or "").strip().lower()
    return {"true": True, "false": False}.get(text)


def energy_of(row: dict) -> GaitEnergy:
    """A results.csv row -> GaitEnergy; a run that is not ok, or has no mean velocity or no
    window power, is undetermined."""
    if row.get("status", "ok") != "ok":
        return UNDETERMINED
    u, v = _float(row.get("u")), _float(row.get("v"))
    power = _float(row.get("energy.steady_electrical_power_w"))
    if u is None or v is None or power is None:
        return UNDETERMINED
    speed = _float(row.get("energy.transport_speed_m_s"))
    run_hours = _float(row.get("energy.operation_time_h"))
    mean_power = _float(row.get("energy.mean_electrical_power_w"))
    usable = run_hours * mean_power if run_hours is not None and mean_power else None
    start, end = _float(row.get("steady_start_s")), _float(row.get("steady_end_s"))
    return GaitEnergy(
        u=u,
        v=v,
        speed=math.hypot(u, v) if speed is None else speed,
        power_w=power,
        mech_w=_float(row.get("energy.steady_mechanical_power_w")),
        **costs_of(row),
        hours=usable / power if usable is not None else None,
        run_hours=run_hours,
        window_s=None if start is None or end is None else (start, end),
        near_wall_at_s=_float(row.get("near_wall_at_s")),
        touched_wall=_bool(row.get("touched_wall")),
        breakdown={
            column: _float(row.get(f"power_breakdown.{column}")) for column in BUDGET_PARTS.values()
        },
    )


def costs_of(row: dict) -> dict:
    """The costs of transport of a row that has a window (``cot``, ``cot_mech`` and every
    convention ``cots``): all inf when the row has no electrical cost (too slow for one: it
    does not travel)."""
    cot = _float(row.get("energy.cot_electrical_dry_weight"))
    if cot is None:
        return {"cot": math.inf, "cot_mech": math.inf, "cots": dict.fromkeys(COT_KEYS, math.inf)}
    return {
        "cot": cot,
        "cot_mech": _float(row.get("energy.cot_mechanical_dry_weight")),
        "cots": {key: _float(row.get(f"energy.{key}")) for key in COT_KEYS},
    }


def parameters_of(row: dict) -> dict:
    """The row's band parameters, each empty cell its shipped value; numbers as floats, the
    Jetson mode as text."""
    out = {}
    for name in PARAMS:
        cell = str(row.get(name) or "").strip()
        if not cell:
            out[name] = SHIPPED[name]
        elif name == "actuators.electronics_mode":
            out[name] = cell
        else:
            out[name] = float(cell)
    return out


def block_of(row: dict) -> str:
    """``shipped`` (no band parameter set), ``oat`` (one set), ``band`` (all set) or
    ``other``."""
    n = sum(1 for name in PARAMS if str(row.get(name) or "").strip())
    return {0: "shipped", 1: "oat", len(PARAMS): "band"}.get(n, "other")


@dc.dataclass
class Table:
    """The sweep's runs by block: ``shipped`` {gait: GaitEnergy}; ``oat`` {(parameter,
    value): {gait: GaitEnergy}}; ``band`` {parameter values (PARAMS order): {gait:
    GaitEnergy}}; ``usable_wh`` the pack's usable energy the runs used."""

    shipped: dict
    oat: dict
    band: dict
    usable_wh: float | None
    runs: int


def _value(name: str, cell: str):
    return cell if name == "actuators.electronics_mode" else float(cell)


def point_key(row: dict):
    """(block, key) of a row: ``shipped`` and "shipped point", ``oat`` and (parameter, value),
    ``band`` and the parameter values in PARAMS order.

    Raises ValueError on a row that is neither."""
    block = block_of(row)
    if block == "shipped":
        return block, "shipped point"
    if block == "oat":
        name = next(n for n in PARAMS if str(row.get(n) or "").strip())
        return block, (name, _value(name, row[name].strip()))
    if block == "band":
        params = parameters_of(row)
        return block, tuple(params[n] for n in PARAMS)
    raise ValueError(
        f"row {row.get('run_id')}: sets some but not all of the band's "
        f"parameters; expected the shipped point, one parameter, or all"
    )


def read_table(rows) -> Table:
    """The sweep's rows (dicts of strings) sorted into its blocks.

    Raises ValueError on a gait twice at one point, or a row that is neither the shipped
    point, a one-at-a-time row nor a band point."""
    blocks: dict = {"shipped": {}, "oat": {}, "band": {}}
    usable = set()
    for row in rows:
        block, key = point_key(row)
        point = blocks[block] if block == "shipped" else blocks[block].setdefault(key, {})
        gait = gait_of(row["base"])
        if gait in point:
            raise ValueError(f"{gait} appears twice at {key} (more than one seed?)")
        point[gait] = energy_of(row)
        hours, power = (
            _float(row.get("energy.operation_time_h")),
            _float(row.get("energy.mean_electrical_power_w")),
        )
        if hours is not None and power is not None:
            usable.add(round(hours * power, 6))
    if len(usable) > 1:
        raise ValueError(
            f"the runs used different usable energies {sorted(usable)} Wh; "
            "this study expects one pack"
        )
    return Table(
        blocks["shipped"],
        dict(sorted(blocks["oat"].items(), key=lambda kv: _oat_order(kv[0]))),
        dict(sorted(blocks["band"].items(), key=lambda kv: _band_order(kv[0]))),
        usable.pop() if usable else None,
        len(rows),
    )


def _oat_order(key):
    name, value = key
    return (PARAMS.index(name), str(value) if isinstance(value, str) else float(value))


def _band_order(key):
    return tuple(str(v) if isinstance(v, str) else float(v) for v in key)


# ---------------------------------------------------------------------------------------------
# Evaluation (the findings study's Tally and results reader)


def tally(points, findings=FINDINGS) -> list[Tally]:
    """Per finding: holds, fails, undetermined over ``points`` (an iterable of {gait:
    GaitEnergy})."""
    tallies = [Tally(key, label, text) for key, label, text, _ in findings]
    for point in points:
        for t, (_, _, _, fn) in zip(tallies, findings):
            result = fn(point)
            if result is True:
                t.holds += 1
            elif result is False:
                t.fails += 1
            else:
                t.undetermined += 1
    return tallies


def stall_deg(key) -> float:
    """A band point's stall angle [deg], to the degree."""
    return stall_of(float(key[PARAMS.index("stall_angle")]))


def stall_of(factor: float) -> float:
    """The stall angle [deg] a factor on the shipped one gives, to the degree."""
    return float(round(factor * STALL_ANGLE_DEG))


def by_stall(band: dict) -> dict:
    """{stall angle deg: [points]} of the band, in order of the angle."""
    out: dict = {}
    for key, point in band.items():
        out.setdefault(stall_deg(key), []).append(point)
    return dict(sorted(out.items()))


COT_LABELS = {
    f"cot_{p}_{w}": f"{pl}, {wl}"
    for p, pl in (
        ("electrical", "electrical"),
        ("net_of_hotel", "net of hotel"),
        ("mechanical", "mechanical"),
    )
    for w, wl in (("dry_weight", "dry weight"), ("weight_in_water", "in water"))
}
FIELDS = (
    ("speed", "speed m/s", 3),
    ("power_w", "P el W", 1),
    ("mech_w", "P mech W", 2),
    ("cot", "CoT el", 2),
    ("cot_net", "CoT net", 2),
    ("cot_mech", "CoT mech", 2),
    ("hours", "operation h", 2),
)


def quantiles(values) -> tuple | None:
    """(median, 10 %, 90 %) of the finite values (linear interpolation), or None."""
    xs = [x for x in values if x is not None and math.isfinite(x)]
    if not xs:
        return None
    q = np.percentile(xs, [50, 10, 90])
    return tuple(float(x) for x in q)


def band_stats(points) -> dict:
    """Per gait over ``points``: runs, undetermined, infinite costs of transport, and
    (median, 10 %, 90 %) of each of FIELDS."""
    out = {}
    points = list(points)
    for gait in GAITS:
        runs = [_get(p, gait) for p in points]
        det = [r for r in runs if r.power_w is not None]
        entry: dict[str, int | tuple | None] = {
            "n": len(runs),
            "undetermined": len(runs) - len(det),
            "no_travel": sum(1 for r in det if r.cot == math.inf),
        }
        for field, _, _ in FIELDS:
            entry[field] = quantiles(getattr(r, field) for r in det)
        out[gait] = entry
    return out


def drivers(table: Table, field: str = "hours") -> dict:
    """Per gait, per parameter: the one-at-a-time change of ``field`` from the shipped run at
    each end of the band ({value: delta}) and the Spearman correlation over the band points
    (the Jetson mode as its watts, the stall angle as its factor)."""
    out = {}
    keys = list(table.band)
    for gait in GAITS:
        base = getattr(_get(table.shipped, gait), field)
        entry = {}
        for name in PARAMS:
            deltas = {}
            for (n, value), point in table.oat.items():
                x = getattr(_get(point, gait), field)
                if n == name and base is not None and x is not None:
                    deltas[value] = x - base
            xs, ys = [], []
            for key in keys:
                y = getattr(_get(table.band[key], gait), field)
                if y is None or not math.isfinite(y):
                    continue
                xs.append(_number(key[PARAMS.index(name)]))
                ys.append(y)
            entry[name] = {"oat": deltas, "rho": spearman(xs, ys), "n": len(ys)}
        out[gait] = entry
    return out


def largest_driver(gait_drivers: dict, by: str = "oat") -> tuple[str, float] | None:
    """The parameter that moves the field most, and by how much: by the largest
    one-at-a-time span (``oat``: the widest difference among its runs and the shipped
    run's, over the band's ends) or by the largest |Spearman rho| (``rho``, returned with
    its sign). None if no parameter has a value."""

    def size(d):
        if by == "rho":
            return abs(d["rho"]) if d["rho"] is not None else None
        if not d["oat"]:
            return None
        deltas = list(d["oat"].values()) + [0.0]
        return max(deltas) - min(deltas)

    sized = [(size(d), name) for name, d in gait_drivers.items() if size(d) is not None]
    if not sized:
        return None
    best = max(sized, key=lambda x: x[0])[1]  # first in PARAMS order on a tie
    d = gait_drivers[best]
    return best, (d["rho"] if by == "rho" else size(d))


# ---------------------------------------------------------------------------------------------
# The page: the numbers the template energy.md.j2 lays out

TEMPLATE = "energy.md.j2"


def _fmt_value(name: str, value) -> str:
    """A parameter's value as the tables and figures show it (factors as x1.2, the stall
    angle in degrees, the weight in kg)."""
    if name == "stall_angle":
        return f"{stall_of(float(value)):g} deg"
    if name == "actuators.electronics_mode":
        return str(value)
    if name == "net_weight_kg":
        return f"{value:g} kg"
    if name in FACTORS:
        return f"x{value:g}"
    return f"{value:g}"


def sample_correlation(table: Table) -> dict | None:
    """The band's points at the shipped stall angle (each is at every angle) and the largest
    |rank correlation| between two of their parameters; None without a correlation."""
    sample = [dict(zip(PARAMS, key)) for key in table.band if stall_deg(key) == STALL_ANGLE_DEG]
    corr = [abs(r) for r in rank_correlations(sample).values() if r is not None]
    return {"points": len(sample), "largest": max(corr)} if corr else None


def budget_rows(table: Table) -> list[dict]:
    """Per gait: the shipped point's ``power_budget`` (``budget``, None without one), what
    Table 1's hour needs (``need``, None without a budget or the pack's usable energy) and
    the constant share (electronics and standby) of the draw."""
    rows = []
    for gait in GAITS:
        oat = {k: _get(p, gait) for k, p in table.oat.items()}
        b = power_budget(_get(table.shipped, gait), oat)
        row = {"gait": gait, "budget": b, "need": None}
        if b is not None and table.usable_wh is not None:
            row["need"] = needed_for_table1(b, table.usable_wh)
            row["constant_share"] = (b["electronics"] + b["standby"]) / b["total"]
        rows.append(row)
    return rows


def budget_checks(rows: list[dict]) -> dict | None:
    """Over the gaits' budgets: the largest |closure| [W], the 5W run's step (least and
    most) and the file's; None without a budget."""
    checks = [r["budget"] for r in rows if r["budget"] is not None]
    if not checks:
        return None
    steps = [b["mode_step_measured"] for b in checks]
    return {
        "closure": max(abs(b["closure"]) for b in checks),
        "step_min": min(steps),
        "step_max": max(steps),
        "step_file": checks[0]["mode_step_file"],
    }


def two_packs(rows: list[dict], usable_wh: float | None) -> dict | None:
    """Each of the two packs feeding one load: half the usable energy [Wh], the hours the
    servos' pack lasts per gait (the draw less the electronics) and the computers' pack."""
    budgets = [(r["gait"], r["budget"]) for r in rows if r["budget"] is not None]
    if not budgets or usable_wh is None:
        return None
    half = usable_wh / 2
    return {
        "half": half,
        "servos": [(g, half / (b["total"] - b["electronics"])) for g, b in budgets],
        "computers": half / budgets[0][1]["electronics"],
    }


def _all_runs(table: Table) -> list[GaitEnergy]:
    points = [table.shipped, *table.oat.values(), *table.band.values()]
    return [r for point in points for r in point.values()]


def hours_against_table1(table: Table) -> dict:
    """Over every run with an operation time: how many, the least and most hours (None
    without any) and how many agree with Table 1."""
    hours = [r.hours for r in _all_runs(table) if r.hours is not None]
    return {
        "n": len(hours),
        "min": min(hours) if hours else None,
        "max": max(hours) if hours else None,
        "agree": sum(1 for h in hours if agrees_with_table1(h)),
    }


def driver_rows(table: Table, drv: dict) -> list[dict]:
    """The rows of the drivers' table: per parameter, its one-at-a-time ends (``end`` as
    shown, ``changes`` the change per gait) and then its rho over the band (``end`` None)."""
    rows: list[dict] = []
    for name in PARAMS:
        ends = sorted(
            {v for (n, v) in table.oat if n == name},
            key=lambda v: MODE_WATTS.get(v, 0) if isinstance(v, str) else v,
        )
        for value in ends:
            values = [drv[g][name]["oat"].get(value) for g in GAITS]
            rows.append({"label": LABELS[name], "end": _fmt_value(name, value), "changes": values})
        rho = [drv[g][name]["rho"] for g in GAITS]
        rows.append({"label": LABELS[name], "end": None, "changes": rho})
    return rows


def largest_drivers(drv: dict) -> list[tuple]:
    """Per gait: (gait, the largest driver one at a time, the largest by |rho|)."""
    return [(g, largest_driver(drv[g], "oat"), largest_driver(drv[g], "rho")) for g in GAITS]


def stall_rows(table: Table) -> list[dict]:
    """Per stall angle of the band: its points, the swim's and the walk's u and the swim's
    cost (quantiles), the tallies of every finding and variant, and the verdicts at the
    shipped point with that stall angle (``marks``, None without that run)."""
    at_stall = {stall_of(float(v)): p for (n, v), p in table.oat.items() if n == "stall_angle"}
    at_stall[stall_of(float(SHIPPED["stall_angle"]))] = table.shipped
    everything = FINDINGS + VARIANTS
    rows = []
    for deg, points in by_stall(table.band).items():
        ref = at_stall.get(deg)
        rows.append(
            {
                "deg": deg,
                "points": len(points),
                "swim_u": quantiles(_get(p, "swim").u for p in points),
                "walk_u": quantiles(_get(p, "walk").u for p in points),
                "swim_cot": quantiles(_get(p, "swim").cot for p in points),
                "tallies": tally(points, everything),
                "marks": None if ref is None else [fn(ref) for _, _, _, fn in everything],
            }
        )
    return rows


def free_water(table: Table) -> dict | None:
    """Over the runs with a window: how many of all, the earliest start, the shortest and
    longest window, how many are short of MIN_WINDOW_S, came near a wall or touched one;
    None if no run has a window."""
    runs = _all_runs(table)
    det = [r for r in runs if r.power_w is not None]  # a window's power: a window
    spans = [r.window_s for r in det if r.window_s is not None]
    if not det:
        return None
    windows = [end - start for start, end in spans]
    return {
        "windowed": len(det),
        "runs": len(runs),
        "start": min(start for start, _ in spans),
        "shortest": min(windows),
        "longest": max(windows),
        "short": sum(1 for r in det if steady_free_water(r) is False),
        "near_wall": sum(1 for r in det if r.near_wall_at_s is not None),
        "touched": sum(1 for r in det if r.touched_wall),
    }


def page_context(table: Table, source: str) -> dict:
    """Everything the block of docs/energy.md shows (``templates/energy.md.j2``)."""
    band = list(table.band.values())
    budgets = budget_rows(table)
    hours_drivers = drivers(table, "hours")
    return {
        "begin": MARK_BEGIN,
        "end": MARK_END,
        "source": source,
        "table": table,
        "n_band": len(band),
        "n_stalls": len(by_stall(table.band)),
        "sample": sample_correlation(table),
        "gaits": GAITS,
        "shipped": {g: _get(table.shipped, g) for g in GAITS},
        "cot_labels": [COT_LABELS[k] for k in COT_KEYS],
        "shipped_cots": {g: [_get(table.shipped, g).cots.get(k) for k in COT_KEYS] for g in GAITS},
        "fields": FIELDS,
        "stats": band_stats(band),
        "budgets": budgets,
        "checks": budget_checks(budgets),
        "hours": hours_against_table1(table),
        "table1_hours": TABLE1_HOURS,
        "table1_tolerance": TABLE1_TOLERANCE,
        "two_packs": two_packs(budgets, table.usable_wh),
        "driver_rows": driver_rows(table, hours_drivers),
        "labels": LABELS,
        "largest_hours": largest_drivers(hours_drivers),
        "largest_cot": largest_drivers(drivers(table, "cot")),
        "tallies": tally(band) + tally(band, VARIANTS),
        "finding_keys": [key for key, _, _, _ in FINDINGS + VARIANTS],
        "stalls": stall_rows(table),
        "free_water": free_water(table),
        "min_window_s": MIN_WINDOW_S,
    }


def markdown_block(table: Table, source: str) -> str:
    """The generated block of docs/energy.md (its markers included)."""
    from manta_drake.studies.report import render

    return render(TEMPLATE, **page_context(table, source)).rstrip("\n")


def write_markdown(
    path: pathlib.Path, block: str, command: str = "manta-drake study energy"
) -> None:
    """Replaces the marked block of ``path`` (keeping the rest), or writes a new file; a
    changed page's stamp takes today's date and commit (``manta_drake.studies.stamp``)."""
    from manta_drake.studies.stamp import replace_marked_block

    replace_marked_block(
        path, block, MARK_BEGIN, MARK_END, new_page=("Energy over the uncertainty band", command)
    )


# ---------------------------------------------------------------------------------------------
# Figures

STALL_COLOURS = {10.0: "tab:red", 15.0: "tab:green", 20.0: "tab:orange", 25.0: "tab:blue"}


def _colour(deg):
    return STALL_COLOURS.get(deg, "0.4")


def _figure(*args, **kwargs):
    """``plt.subplots(*args, **kwargs)`` on matplotlib's Agg backend: (figure, axes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(*args, **kwargs)


def _save(fig, path: pathlib.Path) -> None:
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _star(ax, x, y, ms: float = 16) -> None:
    """The shipped point."""
    ax.plot(x, y, marker="*", ms=ms, color="k", mfc="gold", ls="none", zorder=5)


def _star_handle(label: str):
    from matplotlib.lines import Line2D

    return Line2D([], [], ls="none", marker="*", ms=12, color="k", mfc="gold", label=label)


def _stall_handles() -> list:
    from matplotlib.lines import Line2D

    return [
        Line2D(
            [], [], ls="none", marker="o", color=c, mec="k", mew=0.3, label=f"stall angle {d:g} deg"
        )
        for d, c in STALL_COLOURS.items()
    ]


def plot_speed_cot(table: Table, path: pathlib.Path) -> None:
    """Speed of travel against the electrical (top) and mechanical (bottom) cost of transport,
    per gait: every band point a dot coloured by stall angle (a circle in the Jetson's 10W
    mode, a triangle in its 5W mode), the shipped point a star, curves of constant window
    power through the band's lowest and highest."""
    from manta_drake.model.robot_params import DEFAULT_ROBOT

    weight = DEFAULT_ROBOT.total_mass * 9.80665
    fig, axes = _figure(2, 5, figsize=(17, 7.5), sharex="col")
    mode_i = PARAMS.index("actuators.electronics_mode")
    for c, gait in enumerate(GAITS):
        runs = [(stall_deg(k), k[mode_i], _get(p, gait)) for k, p in table.band.items()]
        runs = [(d, m, r) for d, m, r in runs if r.power_w is not None]
        ship = _get(table.shipped, gait)
        # A run with a window's power has a speed (energy_of).
        speeds = [r.speed for _, _, r in runs if r.speed is not None]
        speeds += [ship.speed] if ship.speed else []
        smax = max(speeds) * 1.15 if speeds else 0.1
        for row, (field, power) in enumerate((("cot", "power_w"), ("cot_mech", "mech_w"))):
            ax = axes[row, c]
            _speed_cot_panel(ax, runs, ship, (field, power), smax, weight)
            if row == 0:
                ax.set_title(gait, fontsize=10)
            else:
                ax.set_xlabel("speed of travel |(u, v)|  [m/s]", fontsize=9)
            if c == 0:
                kind = "electrical" if row == 0 else "mechanical"
                ax.set_ylabel(f"{kind} cost of transport", fontsize=9)
    fig.legend(handles=_speed_cot_handles(), loc="upper center", ncol=9, fontsize=8, frameon=False)
    fig.suptitle(
        "Speed against cost of transport, per gait, over the band "
        "(x at 0: slower than 5 mm/s, no finite cost)",
        y=0.96,
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    _save(fig, path)


def _speed_cot_panel(ax, runs, ship: GaitEnergy, fields, smax: float, weight: float) -> None:
    """One panel of ``plot_speed_cot``: the cost ``fields[0]`` against the speed of ``runs``
    ((stall angle, Jetson mode, GaitEnergy)) and ``ship``, the constant-power curves of the
    power ``fields[1]``; a run without a finite cost is an x at 0."""
    field, power = fields
    marker = {"10W": "o", "5W": "^"}
    for deg, mode, r in runs:
        y = getattr(r, field)
        if y is None or not math.isfinite(y):
            ax.plot(r.speed, 0, marker="x", color=_colour(deg), ms=5, ls="none")
            continue
        style = dict(ms=5, ls="none", color=_colour(deg), mec="k", mew=0.3, alpha=0.85)
        ax.plot(r.speed, y, marker=marker.get(mode, "o"), **style)
    ys = [getattr(r, field) for _, _, r in runs]
    ys = [y for y in ys if y is not None and math.isfinite(y)]
    powers = [getattr(r, power) for _, _, r in runs if getattr(r, power) is not None]
    s = np.linspace(max(smax / 60, 1e-3), smax, 200)
    for p, ls in ((min(powers), ":"), (max(powers), "--")) if powers else ():
        ax.plot(s, p / (weight * s), color="0.5", lw=0.8, ls=ls)
    y_ship = getattr(ship, field)
    if y_ship is not None and math.isfinite(y_ship):
        _star(ax, ship.speed, y_ship, ms=15)
    top = max(ys + ([y_ship] if y_ship and math.isfinite(y_ship) else [])) if ys else 1
    ax.set_ylim(0, top * 1.25)
    ax.set_xlim(0, smax)
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=8)


def _speed_cot_handles() -> list:
    from matplotlib.lines import Line2D

    jetson = [
        Line2D([], [], ls="none", marker=m, color="0.6", mec="k", mew=0.3, label=f"Jetson {mode}")
        for mode, m in (("10W", "o"), ("5W", "^"))
    ]
    return [
        *_stall_handles(),
        *jetson,
        _star_handle("shipped point (15 deg)"),
        Line2D([], [], color="0.5", ls=":", label="constant power: the band's lowest"),
        Line2D([], [], color="0.5", ls="--", label="... and highest (per gait)"),
    ]


def plot_operation_time(table: Table, path: pathlib.Path) -> None:
    """Left: each gait's operation time over the band (dots, coloured by Jetson mode) and at
    the shipped point (star) against Table 1's 1.0 h. Right: the one-at-a-time changes of
    the swim's and the walk's operation time per parameter end."""
    fig, (ax, bx) = _figure(1, 2, figsize=(14, 5.5), gridspec_kw={"width_ratios": [1, 1.3]})
    _hours_panel(ax, table)
    _one_at_a_time_panel(bx, table)
    fig.tight_layout()
    _save(fig, path)


def _hours_panel(ax, table: Table) -> None:
    """Each gait's operation time at the band points and the shipped point, against Table 1."""
    from matplotlib.lines import Line2D

    mode_i = PARAMS.index("actuators.electronics_mode")
    rng = np.random.default_rng(0)  # horizontal jitter only
    for i, gait in enumerate(GAITS):
        for key, point in table.band.items():
            r = _get(point, gait)
            if r.hours is None:
                continue
            colour = "tab:blue" if key[mode_i] == "5W" else "tab:purple"
            x = i + rng.uniform(-0.18, 0.18)
            ax.plot(x, r.hours, marker="o", ms=4, ls="none", color=colour, alpha=0.7)
        h = _get(table.shipped, gait).hours
        if h is not None:
            _star(ax, i, h)
    band = (TABLE1_HOURS * (1 - TABLE1_TOLERANCE), TABLE1_HOURS * (1 + TABLE1_TOLERANCE))
    ax.axhspan(*band, color="tab:red", alpha=0.12)
    ax.axhline(TABLE1_HOURS, color="tab:red", lw=1.2)
    label = "Table 1: approx. 1.0 h (+-25 %)"
    ax.text(
        len(GAITS) - 0.55, TABLE1_HOURS, label, color="tab:red", fontsize=8, va="bottom", ha="right"
    )
    ax.set_xticks(range(len(GAITS)), GAITS)
    ax.set_xlim(-0.5, len(GAITS) - 0.5)
    ax.set_ylim(0, None)
    ax.set_ylabel("operation time [h] (usable energy / window power)", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    dots = [
        Line2D([], [], ls="none", marker="o", color=c, label=f"band point, Jetson {mode}")
        for c, mode in (("tab:purple", "10W"), ("tab:blue", "5W"))
    ]
    ax.legend(handles=[*dots, _star_handle("shipped point")], fontsize=8, loc="lower left")
    ax.set_title("Predicted operation time per gait", fontsize=10)


def _one_at_a_time_panel(bx, table: Table) -> None:
    """The one-at-a-time changes of the swim's and the walk's operation time, per end."""
    from matplotlib.lines import Line2D

    drv = drivers(table, "hours")
    labels, width = [], 0.38
    items = list(table.oat)
    for j, (name, value) in enumerate(items):
        labels.append(f"{LABELS[name]} {_fmt_value(name, value)}")
        for k, (gait, colour) in enumerate((("swim", "tab:cyan"), ("walk", "tab:brown"))):
            d = drv[gait][name]["oat"].get(value)
            if d is not None:
                bx.barh(j + (k - 0.5) * width, d, height=width, color=colour)
    bx.axvline(0, color="k", lw=0.8)
    bx.set_yticks(range(len(items)), labels, fontsize=8)
    bx.invert_yaxis()
    bx.set_xlabel("change of the operation time from the shipped run [h]", fontsize=9)
    bx.grid(alpha=0.3, axis="x")
    bars = [
        Line2D([], [], color=c, lw=6, label=g)
        for g, c in (("swim", "tab:cyan"), ("walk", "tab:brown"))
    ]
    bx.legend(handles=bars, fontsize=8)
    bx.set_title("One parameter at a time (the rest shipped)", fontsize=10)


def plot_findings(table: Table, path: pathlib.Path) -> None:
    """Left: u_swim against u_walk at every band point; right: the swim's electrical cost of
    transport against the walk's; colour: stall angle; the diagonal: where a finding
    turns."""
    fig, axes = _figure(1, 2, figsize=(12, 5.5))
    _swim_against_walk(axes[0], table, "u", "u  [m/s]")
    _swim_against_walk(axes[1], table, "cot", "electrical CoT")
    axes[0].set_title("swimming slower than walking: below the diagonal", fontsize=10)
    axes[1].set_title("the walk more efficient than the swim: above the diagonal", fontsize=10)
    handles = [*_stall_handles(), _star_handle("shipped point")]
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    _save(fig, path)


def _swim_against_walk(ax, table: Table, field: str, label: str) -> None:
    """The swim's ``field`` against the walk's at every band point and the shipped point."""
    xs, ys = [], []
    for key, point in table.band.items():
        x, y = getattr(_get(point, "walk"), field), getattr(_get(point, "swim"), field)
        if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)):
            continue
        xs.append(x)
        ys.append(y)
        colour = _colour(stall_deg(key))
        ax.plot(x, y, marker="o", ms=6, ls="none", color=colour, mec="k", mew=0.3)
    x, y = getattr(_get(table.shipped, "walk"), field), getattr(_get(table.shipped, "swim"), field)
    if x is not None and y is not None:
        _star(ax, x, y)
        xs.append(x)
        ys.append(y)
    hi = max(xs + ys) * 1.1 if xs else 1.0
    ax.plot([0, hi], [0, hi], color="0.3", lw=0.8, ls="--")
    ax.set_xlim(0, hi)
    ax.set_ylim(0, hi)
    ax.set_aspect("equal")
    ax.set_xlabel(f"walk {label}", fontsize=9)
    ax.set_ylabel(f"swim {label}", fontsize=9)
    ax.grid(alpha=0.3)


# ---------------------------------------------------------------------------------------------
# The log check (--check-logs DIR): how steady the window power is


def window_halves(t, power, window, period_s: float = 2.0) -> tuple[float, float] | None:
    """The mean power over the first and the second half of the window's whole gait cycles
    (an even number of ``period_s`` cycles from its start); None if it holds fewer than 2."""
    t, power = np.asarray(t, dtype=float), np.asarray(power, dtype=float).reshape(-1)
    cycles = math.floor((window[1] - window[0]) / period_s + 1e-9) // 2 * 2
    if cycles < 2:
        return None
    mid = window[0] + cycles / 2 * period_s
    end = window[0] + cycles * period_s
    first = power[(t >= window[0]) & (t < mid)]
    second = power[(t >= mid) & (t < end)]
    return float(first.mean()), float(second.mean())


def check_logs(sweep_dir: pathlib.Path) -> dict:
    """Per run of the sweep's table (``sweep_dir/results.csv``; its folders in
    ``sweep_dir/runs``): the relative difference of the window's two halves' mean power
    (``window_halves``). Returns {run_id: difference} and prints a summary."""
    import json

    out = {}
    for row in read_results(sweep_dir / "results.csv"):
        run = sweep_dir / "runs" / row["run_id"]
        metrics, log = run / "metrics.json", run / "log.npz"
        if not (metrics.exists() and log.exists()):
            continue
        m = json.loads(metrics.read_text())
        window = m.get("steady_window_s")
        if m.get("status") != "ok" or window is None or m.get("mean_velocity_body") is None:
            continue
        with np.load(log) as data:
            halves = window_halves(data["t_electrical_power"], data["electrical_power"], window)
        if halves is not None:
            out[run.name] = (halves[1] - halves[0]) / (0.5 * (halves[0] + halves[1]))
    if out:
        worst = max(out, key=lambda k: abs(out[k]))
        diffs = np.abs(list(out.values()))
        print(
            f"{len(out)} runs: |second half - first half| / mean of the window power: "
            f"median {100 * np.median(diffs):.2f} %, 90 % {100 * np.percentile(diffs, 90):.2f}"
            f" %, max {100 * diffs.max():.2f} % ({worst}: {out[worst]:+.4f})"
        )
    return out


# The columns of the sweep's results.csv the report reads (``energy.transport_speed_m_s``
# may be missing: |(u, v)| stands in), and the one ``--check-logs`` reads.
RESULTS_COLUMNS = (
    "base",
    *PARAMS,
    "status",
    "u",
    "v",
    "steady_start_s",
    "steady_end_s",
    "near_wall_at_s",
    "touched_wall",
    "energy.steady_electrical_power_w",
    "energy.steady_mechanical_power_w",
    "energy.cot_electrical_dry_weight",
    "energy.cot_mechanical_dry_weight",
    "energy.operation_time_h",
    "energy.mean_electrical_power_w",
)
LOGS_COLUMNS = ("run_id",)
FIGURES = ("energy_speed_cot.png", "energy_operation_time.png", "energy_findings.png")


def check_arguments(args, prog: str) -> pathlib.Path | None:
    """Every option before anything is read; returns the output folder (None with
    ``--check-logs``); raises ScenarioError naming the option."""
    from manta_drake.studies.options import check_results_csv, check_sweep_results
    from manta_drake.studies.report import output_folder

    if args.check_logs is not None:
        check_results_csv(
            "--check-logs",
            args.check_logs / "results.csv",
            LOGS_COLUMNS,
            hint=" (DIR is the output folder of `manta-drake sweep diagrams/sweeps/energy.yaml`)",
        )
        return None
    check_sweep_results(args.results, RESULTS_COLUMNS, "energy", SHIPPED_RESULTS)
    return output_folder(args.out, prog)


def write_report(table: Table, results: str, out: pathlib.Path) -> None:
    """The page ``out/energy.md`` (its block) and the figures in ``out/figures``."""
    write_markdown(
        out / "energy.md",
        markdown_block(table, results),
        f"manta-drake study energy --results {results}",
    )
    for plot, name in zip((plot_speed_cot, plot_operation_time, plot_findings), FIGURES):
        plot(table, out / "figures" / name)


def parser(prog: str):
    from manta_drake.studies.options import StudyParser

    p = StudyParser(
        prog=prog,
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Without a fresh sweep, use the table shipped in the "
        f"repository: --results {SHIPPED_RESULTS}",
    )
    p.add_argument(
        "--results",
        default=DEFAULT_RESULTS,
        help=f"results.csv of the energy sweep (default {DEFAULT_RESULTS}; the "
        f"shipped copy: {SHIPPED_RESULTS})",
    )
    p.add_argument(
        "--out",
        metavar="DIR",
        help="the report's folder: DIR/energy.md (its generated block is rewritten) and "
        f"DIR/figures/ ({', '.join(FIGURES)}); default the checkout's docs/",
    )
    p.add_argument(
        "--check-logs",
        metavar="DIR",
        type=pathlib.Path,
        help="instead of the report: read DIR/runs/*/log.npz of the sweep and print "
        "how steady each run's window power is",
    )
    return p


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study energy``); returns the exit status."""
    prog = prog or "manta-drake study energy"
    args = parser(prog).parse_args(argv)
    out = check_arguments(args, prog)
    if out is None:
        check_logs(args.check_logs)
        return 0
    table = read_table(read_results(pathlib.Path(args.results)))
    write_report(table, args.results, out)
    for t in tally(table.band.values(), FINDINGS + VARIANTS):
        print(
            f"{t.label:45s} {t.holds:3d}/{t.total:<3d} fails {t.fails:3d}  "
            f"undetermined {t.undetermined:3d}"
        )
    print(f"wrote {out / 'energy.md'} and the figures in {out / 'figures'}")
    return 0
