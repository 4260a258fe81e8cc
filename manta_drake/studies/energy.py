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

It reports, in ``docs/energy.md`` between ``<!-- energy-report:begin -->`` and
``<!-- energy-report:end -->`` (the hand-written text around the block is kept):

* per gait at the shipped point and over the band (median and 10-90 % range): speed,
  electrical and mechanical power, both costs of transport, operation time;
* the shipped point's power budget (electronics, servo standby, copper loss, the motors'
  conversion of mechanical power), from each run's own ``power_breakdown`` (the metrics'),
  checked against its logged draw and against the 5W run;
* the predicted operation time against Table 1's "approx. 1.0 h", and which parameter moves
  it most (one at a time, and Spearman rank correlations over the band);
* whether "swimming is slower than walking" and "the walk is the most efficient gait" hold
  over the band, per stall angle;

and the figures ``docs/figures/energy_speed_cot.png``, ``energy_operation_time.png`` and
``energy_findings.png``.

A gait's criterion value is *undetermined* at a point when its run is not ok or has no
free-water window (no mean velocity, no window power); the criteria are three-valued
(Kleene), as in ``manta_drake.studies.findings``. A run that has a window but travels slower
than the metric's 5 mm/s has no finite cost of transport: it counts as infinite (it spends
energy and does not travel), not as undetermined.

Usage:

    manta-drake sweep diagrams/sweeps/energy.yaml --out out/energy
    manta-drake study energy                    # reads out/energy/results.csv
    manta-drake study energy --results diagrams/sweeps/data/energy_results.csv

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
SHIPPED = {
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
    within each column (which keeps every column's values, hence the hypercube and the
    modes' shares) wherever a swap lowers the sum of the squared rank correlations of all
    pairs of columns, until no swap does (``rank_correlations`` of the result)."""
    rng = np.random.default_rng(seed)
    columns = []
    for lo, hi in CONTINUOUS.values():
        strata = (rng.permutation(n) + rng.uniform(size=n)) / n
        columns.append([round(float(lo + (hi - lo) * x), 3) for x in strata])
    columns.append([MODES[i % len(MODES)] for i in rng.permutation(n)])
    ranks = np.array(
        [
            _ranks(
                np.asarray([MODE_WATTS[v] if isinstance(v, str) else v for v in col], dtype=float)
            )
            for col in columns
        ]
    ).T

    def cost(r):
        c = np.corrcoef(r, rowvar=False)
        return float(np.sum(np.triu(c, 1) ** 2))

    best = cost(ranks)
    improved = True
    while improved:
        improved = False
        for c in range(1, len(columns)):
            for i in range(n):
                for j in range(i + 1, n):
                    ranks[[i, j], c] = ranks[[j, i], c]
                    trial = cost(ranks)
                    if trial < best - 1e-12:
                        best, improved = trial, True
                        columns[c][i], columns[c][j] = columns[c][j], columns[c][i]
                    else:
                        ranks[[i, j], c] = ranks[[j, i], c]
    names = list(CONTINUOUS) + ["actuators.electronics_mode"]
    return [{name: columns[k][i] for k, name in enumerate(names)} for i in range(n)]


def rank_correlations(points: list[dict], names=None) -> dict:
    """{(a, b): Spearman rho} between every pair of the points' parameters (the Jetson mode
    as its watts)."""
    names = list(names or [k for k in PARAMS if k != "stall_angle"])
    values = {
        k: [MODE_WATTS[p[k]] if isinstance(p[k], str) else float(p[k]) for p in points]
        for k in names
    }
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
    parts = {name: shipped.breakdown.get(column) for name, column in BUDGET_PARTS.items()}
    if shipped.power_w is None or mode5.power_w is None or None in parts.values():
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
    speed = math.hypot(u, v) if speed is None else speed
    cot, cot_mech = (
        _float(row.get("energy.cot_electrical_dry_weight")),
        _float(row.get("energy.cot_mechanical_dry_weight")),
    )
    cots = {key: _float(row.get(f"energy.{key}")) for key in COT_KEYS}
    if cot is None:  # a window but too slow for a cost of transport: it does not travel
        cot = cot_mech = math.inf
        cots = {key: math.inf for key in COT_KEYS}
    run_hours = _float(row.get("energy.operation_time_h"))
    mean_power = _float(row.get("energy.mean_electrical_power_w"))
    usable = run_hours * mean_power if run_hours is not None and mean_power else None
    start, end = _float(row.get("steady_start_s")), _float(row.get("steady_end_s"))
    return GaitEnergy(
        u=u,
        v=v,
        speed=speed,
        power_w=power,
        mech_w=_float(row.get("energy.steady_mechanical_power_w")),
        cot=cot,
        cot_mech=cot_mech,
        cots=cots,
        hours=usable / power if usable is not None else None,
        run_hours=run_hours,
        window_s=None if start is None or end is None else (start, end),
        near_wall_at_s=_float(row.get("near_wall_at_s")),
        touched_wall=_bool(row.get("touched_wall")),
        breakdown={
            column: _float(row.get(f"power_breakdown.{column}")) for column in BUDGET_PARTS.values()
        },
    )


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


def read_table(rows) -> Table:
    """The sweep's rows (dicts of strings) sorted into its blocks.

    Raises ValueError on a gait twice at one point, or a row that is neither the shipped
    point, a one-at-a-time row nor a band point."""
    shipped, oat, band, usable = {}, {}, {}, set()
    for row in rows:
        gait, block = gait_of(row["base"]), block_of(row)
        if block == "shipped":
            point = shipped
            key = "shipped point"
        elif block == "oat":
            name = next(n for n in PARAMS if str(row.get(n) or "").strip())
            key = (name, _value(name, row[name].strip()))
            point = oat.setdefault(key, {})
        elif block == "band":
            params = parameters_of(row)
            key = tuple(params[n] for n in PARAMS)
            point = band.setdefault(key, {})
        else:
            raise ValueError(
                f"row {row.get('run_id')}: sets some but not all of the band's "
                f"parameters; expected the shipped point, one parameter, or all"
            )
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
        shipped,
        dict(sorted(oat.items(), key=lambda kv: _oat_order(kv[0]))),
        dict(sorted(band.items(), key=lambda kv: _band_order(kv[0]))),
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
        entry = {
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
                value = key[PARAMS.index(name)]
                xs.append(MODE_WATTS[value] if isinstance(value, str) else float(value))
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
# Output


def _fmt(x, digits: int) -> str:
    if x is None:
        return "-"
    if math.isinf(x):
        return "inf"
    return f"{x:.{digits}f}"


def _fmt_q(q, digits: int) -> str:
    if q is None:
        return "-"
    med, lo, hi = q
    return f"{med:.{digits}f} ({lo:.{digits}f} to {hi:.{digits}f})"


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


def _row(t: Tally) -> str:
    return (
        f"| {t.label} | {t.criterion} | {t.holds}/{t.total} | {t.fails} | "
        f"{t.undetermined} | {100 * t.fraction:.0f} % |"
        if t.total
        else f"| {t.label} | {t.criterion} | 0/0 | 0 | 0 | - |"
    )


def markdown_block(table: Table, source: str) -> str:
    """The generated block of docs/energy.md."""
    lines = [
        MARK_BEGIN,
        f"<!-- generated by manta-drake study energy from {source}; do not edit by hand -->",
        "",
    ]
    band = list(table.band.values())
    n_band, n_oat = len(band), len(table.oat)
    lines += [
        (
            f"The table: {table.runs} runs; the shipped point, {n_oat} one-at-a-time sets "
            f"and {n_band} band points ({len(by_stall(table.band))} stall angles), each "
            f"with the five gaits. Usable energy of the pack (full to the cut-off, at "
            f"open circuit): {_fmt(table.usable_wh, 2)} Wh."
        ),
        "",
    ]
    sample = [dict(zip(PARAMS, key)) for key in table.band if stall_deg(key) == STALL_ANGLE_DEG]
    corr = [abs(r) for r in rank_correlations(sample).values() if r is not None]
    if corr:
        lines[-2] += (
            f" The band's {len(sample)} points (each at every stall angle): the largest "
            f"rank correlation between two of their parameters is {max(corr):.2f}."
        )

    # The shipped point.
    lines += [
        (
            "**At the shipped point** (free-water window means; operation time = usable "
            "energy / window power, in brackets with the whole run's mean power, the "
            "metrics' `operation_time_h`):"
        ),
        "",
        (
            "| gait | u m/s | speed m/s | P el W | P mech W | CoT el | CoT mech | "
            "operation h | window s |"
        ),
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for gait in GAITS:
        r = _get(table.shipped, gait)
        window = "-" if r.window_s is None else f"{r.window_s[0]:.1f}-{r.window_s[1]:.1f}"
        lines.append(
            f"| {gait} | {_fmt(r.u, 3)} | {_fmt(r.speed, 3)} | {_fmt(r.power_w, 1)} | "
            f"{_fmt(r.mech_w, 2)} | {_fmt(r.cot, 2)} | {_fmt(r.cot_mech, 2)} | "
            f"{_fmt(r.hours, 2)} ({_fmt(r.run_hours, 2)}) | {window} |"
        )

    lines += [
        "",
        (
            "Every cost of transport the metrics give, at the shipped point (P / (W "
            "|(u, v)|): the electrical power, the same net of the hotel load (the "
            "computers and the servos' standby, drawn whatever the joints do) and the "
            "joints' mechanical power, each over the dry weight W = m g and over the "
            "deflated robot's weight in water):"
        ),
        "",
        "| gait | " + " | ".join(COT_LABELS[k] for k in COT_KEYS) + " |",
        "| --- | " + " | ".join("---" for _ in COT_KEYS) + " |",
    ]
    for gait in GAITS:
        r = _get(table.shipped, gait)
        lines.append(f"| {gait} | " + " | ".join(_fmt(r.cots.get(k), 2) for k in COT_KEYS) + " |")

    # Over the band.
    stats = band_stats(band)
    lines += [
        "",
        (
            f"**Over the band** ({n_band} points): median (10 % to 90 %). A run slower "
            "than 5 mm/s has no finite cost of transport (counted in 'no travel'; the "
            "quantiles of the costs are over the others)."
        ),
        "",
        "| gait | runs | undetermined | no travel | "
        + " | ".join(label for _, label, _ in FIELDS)
        + " |",
        "| --- | --- | --- | --- | " + " | ".join("---" for _ in FIELDS) + " |",
    ]
    for gait, s in stats.items():
        lines.append(
            f"| {gait} | {s['n']} | {s['undetermined']} | {s['no_travel']} | "
            + " | ".join(_fmt_q(s[f], d) for f, _, d in FIELDS)
            + " |"
        )

    # Power budget and Table 1.
    lines += [
        "",
        (
            "**The shipped point's power budget** (W, window means, from each run's "
            "`power_breakdown`: the computers, the servos' standby, their copper loss and the "
            "power converted to the motors' shafts, i.e. the joints' work and the gearbox's "
            "loss), and what 1.0 h would take:"
        ),
        "",
        (
            "| gait | total | electronics | servo standby | copper loss | conversion | "
            "constant share | 1.0 h needs W | or standby x | or copper x | = torques x |"
        ),
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    budgets = {}
    for gait in GAITS:
        oat = {k: _get(p, gait) for k, p in table.oat.items()}
        b = power_budget(_get(table.shipped, gait), oat)
        budgets[gait] = b
        if b is None or table.usable_wh is None:
            lines.append(f"| {gait} | - | - | - | - | - | - | - | - | - | - |")
            continue
        need = needed_for_table1(b, table.usable_wh)
        const = (b["electronics"] + b["standby"]) / b["total"]
        lines.append(
            f"| {gait} | {b['total']:.1f} | {b['electronics']:.2f} | "
            f"{b['standby']:.2f} | {b['copper']:.2f} | {b['conversion']:.2f} | "
            f"{100 * const:.0f} % | {need['power_w']:.1f} | "
            f"{need['standby_factor']:.1f} | {need['copper_factor']:.0f} | "
            f"{need['torque_factor']:.1f} |"
        )
    checks = [b for b in budgets.values() if b is not None]
    if checks:
        closure = max(abs(b["closure"]) for b in checks)
        steps = [b["mode_step_measured"] for b in checks]
        lines += [
            "",
            (
                f"Checks of the budget: the parts add up to the logged draw within "
                f"{closure:.1e} W; the 5W run draws {min(steps):.3f} to {max(steps):.3f} W "
                f"less (the file's electronics: {checks[0]['mode_step_file']:.3f} W; the "
                "rest is the battery's and the servos' response to the lower current)."
            ),
        ]

    # Operation time.
    all_hours = [
        r.hours
        for pt in [table.shipped, *table.oat.values(), *band]
        for r in pt.values()
        if r.hours is not None
    ]
    agree = [agrees_with_table1(h) for h in all_hours]
    lines += [
        "",
        (
            f"**Operation time against Table 1** ({TABLE1_HOURS:.1f} h; a prediction "
            f"agrees within {100 * TABLE1_TOLERANCE:.0f} %): over all {len(all_hours)} runs "
            f"{_fmt(min(all_hours) if all_hours else None, 2)} to "
            f"{_fmt(max(all_hours) if all_hours else None, 2)} h; "
            f"{sum(1 for a in agree if a)} of them agree."
        ),
    ]
    ship_budgets = [(g, b) for g, b in budgets.items() if b is not None]
    if ship_budgets and table.usable_wh is not None:
        half = table.usable_wh / 2
        lines += [
            "",
            "Were each pack to feed one load (one pack the 16 servos, the other the "
            f"computers; {half:.2f} Wh usable each), the servos' pack would last "
            + ", ".join(
                f"{half / (b['total'] - b['electronics']):.2f} h ({g})" for g, b in ship_budgets
            )
            + f" and the computers' {half / ship_budgets[0][1]['electronics']:.2f} h, "
            "at the shipped point.",
        ]
    lines += [
        "",
        (
            "What moves it, per gait: the one-at-a-time change from the shipped run "
            "(h, at each end of the band) and Spearman's rho over the band points (the "
            "Jetson mode as its watts, the stall angle as its factor):"
        ),
        "",
    ]
    drv = drivers(table, "hours")
    header = "| parameter | band end | " + " | ".join(GAITS) + " |"
    lines += [header, "| --- | --- | " + " | ".join("---" for _ in GAITS) + " |"]
    for name in PARAMS:
        values = sorted(
            {v for (n, v) in table.oat if n == name},
            key=lambda v: MODE_WATTS.get(v, 0) if isinstance(v, str) else v,
        )
        for value in values:
            cells = [_fmt(drv[g][name]["oat"].get(value), 3) for g in GAITS]
            lines.append(
                f"| {LABELS[name]} | {_fmt_value(name, value)} | " + " | ".join(cells) + " |"
            )
        cells = [_fmt(drv[g][name]["rho"], 2) for g in GAITS]
        lines.append(f"| {LABELS[name]} | rho over the band | " + " | ".join(cells) + " |")

    def driver_text(d, by, unit):
        found = largest_driver(d, by)
        if found is None:
            return "-"
        name, size = found
        return f"{LABELS[name]} ({'rho ' if by == 'rho' else ''}{size:.2f}{unit})"

    lines += [
        "",
        "The parameter that moves the operation time most, one at a time (the span "
        "of its runs) and over the band (largest \\|rho\\|): "
        + "; ".join(
            f"{g}: {driver_text(drv[g], 'oat', ' h')}, {driver_text(drv[g], 'rho', '')}"
            for g in GAITS
        )
        + ".",
    ]
    cot = drivers(table, "cot")
    lines += [
        "",
        "The same for the electrical cost of transport: "
        + "; ".join(
            f"{g}: {driver_text(cot[g], 'oat', '')}, {driver_text(cot[g], 'rho', '')}"
            for g in GAITS
        )
        + ".",
    ]

    # Findings.
    lines += [
        "",
        "**The findings over the band** (holds / band points):",
        "",
        "| finding | criterion | holds | fails | undetermined | fraction of the band |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    lines += [_row(t) for t in tally(band)]
    lines += [_row(t) for t in tally(band, VARIANTS)]
    stalls = by_stall(table.band)
    oat_stall = {stall_of(float(v)): p for (n, v), p in table.oat.items() if n == "stall_angle"}
    oat_stall[stall_of(SHIPPED["stall_angle"])] = table.shipped
    everything = FINDINGS + VARIANTS
    lines += [
        "",
        "Per stall angle: the band points where each holds, the swim's and the "
        "walk's speed and the swim's cost (median, 10 % to 90 %), and at the shipped "
        "point with that stall angle (the one-at-a-time runs; yes / **no** / ?, in the order "
        + ", ".join(key for key, _, _, _ in everything)
        + "):",
        "",
        "| stall angle deg | points | swim u m/s | walk u m/s | swim CoT el | "
        + " | ".join(key for key, _, _, _ in everything)
        + " | at the shipped point |",
        "| --- | --- | --- | --- | --- | " + " | ".join("---" for _ in everything) + " | --- |",
    ]
    for deg, points in stalls.items():
        ts = tally(points, everything)
        ref = oat_stall.get(deg)
        marks = (
            "-"
            if ref is None
            else ", ".join(
                {True: "yes", False: "**no**", None: "?"}[fn(ref)] for _, _, _, fn in everything
            )
        )
        lines.append(
            f"| {deg:g} | {len(points)} | "
            f"{_fmt_q(quantiles(_get(p, 'swim').u for p in points), 3)} | "
            f"{_fmt_q(quantiles(_get(p, 'walk').u for p in points), 3)} | "
            f"{_fmt_q(quantiles(_get(p, 'swim').cot for p in points), 2)} | "
            + " | ".join(f"{t.holds}/{t.total}" for t in ts)
            + f" | {marks} |"
        )

    # Free water and steady state.
    runs = [r for pt in [table.shipped, *table.oat.values(), *band] for r in pt.values()]
    det = [r for r in runs if r.power_w is not None]
    short = [r for r in det if steady_free_water(r) is False]
    windows = [r.window_s[1] - r.window_s[0] for r in det]
    walled = [r for r in det if r.near_wall_at_s is not None]
    touched = [r for r in det if r.touched_wall]
    lines += [
        "",
        f"**Free water and steady state**: {len(det)} of {len(runs)} runs have a "
        f"free-water window (from {min(r.window_s[0] for r in det):g} s, after the "
        f"start's transient, until the run's end or the hull's first approach within "
        f"0.3 m of a wall), {min(windows):.1f} to {max(windows):.1f} s long; "
        f"{len(short)} shorter than {MIN_WINDOW_S:g} s (two gait cycles). "
        f"{len(walled)} runs come near a wall before 20 s (their window ends there) and "
        f"{len(touched)} touch one after it; every power, cost of transport and "
        f"operation time above is a window figure, before any wall."
        if det
        else "**Free water and steady state**: no run has a window.",
    ]
    lines += ["", MARK_END]
    return "\n".join(lines)


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


def plot_speed_cot(table: Table, path: pathlib.Path) -> None:
    """Speed of travel against the electrical (top) and mechanical (bottom) cost of transport,
    per gait: every band point a dot coloured by stall angle (a circle in the Jetson's 10W
    mode, a triangle in its 5W mode), the shipped point a star, curves of constant window
    power through the band's lowest and highest."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from manta_drake.model.robot_params import DEFAULT_ROBOT

    weight = DEFAULT_ROBOT.total_mass * 9.80665
    fig, axes = plt.subplots(2, 5, figsize=(17, 7.5), sharex="col")
    for c, gait in enumerate(GAITS):
        mode_i = PARAMS.index("actuators.electronics_mode")
        runs = [(stall_deg(k), k[mode_i], _get(p, gait)) for k, p in table.band.items()]
        marker = {"10W": "o", "5W": "^"}
        runs = [(d, m, r) for d, m, r in runs if r.power_w is not None]
        ship = _get(table.shipped, gait)
        speeds = [r.speed for _, _, r in runs] + ([ship.speed] if ship.speed else [])
        smax = max(speeds) * 1.15 if speeds else 0.1
        for row, (field, power) in enumerate((("cot", "power_w"), ("cot_mech", "mech_w"))):
            ax = axes[row, c]
            for deg, mode, r in runs:
                y = getattr(r, field)
                if y is None or not math.isfinite(y):
                    ax.plot(r.speed, 0, marker="x", color=_colour(deg), ms=5, ls="none")
                    continue
                ax.plot(
                    r.speed,
                    y,
                    marker=marker.get(mode, "o"),
                    ms=5,
                    ls="none",
                    color=_colour(deg),
                    mec="k",
                    mew=0.3,
                    alpha=0.85,
                )
            ys = [
                getattr(r, field)
                for _, _, r in runs
                if getattr(r, field) is not None and math.isfinite(getattr(r, field))
            ]
            powers = [getattr(r, power) for _, _, r in runs if getattr(r, power) is not None]
            s = np.linspace(max(smax / 60, 1e-3), smax, 200)
            for p, ls in ((min(powers), ":"), (max(powers), "--")) if powers else ():
                ax.plot(s, p / (weight * s), color="0.5", lw=0.8, ls=ls)
            y_ship = getattr(ship, field)
            if y_ship is not None and math.isfinite(y_ship):
                ax.plot(
                    ship.speed,
                    y_ship,
                    marker="*",
                    ms=15,
                    color="k",
                    mfc="gold",
                    ls="none",
                    zorder=5,
                )
            top = max(ys + ([y_ship] if y_ship and math.isfinite(y_ship) else [])) if ys else 1
            ax.set_ylim(0, top * 1.25)
            ax.set_xlim(0, smax)
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=8)
            if row == 0:
                ax.set_title(gait, fontsize=10)
            else:
                ax.set_xlabel("speed of travel |(u, v)|  [m/s]", fontsize=9)
            if c == 0:
                ax.set_ylabel(
                    ("electrical" if row == 0 else "mechanical") + " cost of transport", fontsize=9
                )
    handles = [
        Line2D(
            [],
            [],
            ls="none",
            marker="o",
            color=col,
            mec="k",
            mew=0.3,
            label=f"stall angle {deg:g} deg",
        )
        for deg, col in STALL_COLOURS.items()
    ]
    handles += [
        Line2D([], [], ls="none", marker=m, color="0.6", mec="k", mew=0.3, label=f"Jetson {mode}")
        for mode, m in (("10W", "o"), ("5W", "^"))
    ]
    handles += [
        Line2D(
            [],
            [],
            ls="none",
            marker="*",
            ms=12,
            color="k",
            mfc="gold",
            label="shipped point (15 deg)",
        ),
        Line2D([], [], color="0.5", ls=":", label="constant power: the band's lowest"),
        Line2D([], [], color="0.5", ls="--", label="... and highest (per gait)"),
    ]
    fig.legend(handles=handles, loc="upper center", ncol=9, fontsize=8, frameon=False)
    fig.suptitle(
        "Speed against cost of transport, per gait, over the band "
        "(x at 0: slower than 5 mm/s, no finite cost)",
        y=0.96,
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_operation_time(table: Table, path: pathlib.Path) -> None:
    """Left: each gait's operation time over the band (dots, coloured by Jetson mode) and at
    the shipped point (star) against Table 1's 1.0 h. Right: the one-at-a-time changes of
    the swim's and the walk's operation time per parameter end."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(14, 5.5), gridspec_kw={"width_ratios": [1, 1.3]})
    mode_i = PARAMS.index("actuators.electronics_mode")
    rng = np.random.default_rng(0)  # horizontal jitter only
    for i, gait in enumerate(GAITS):
        for key, point in table.band.items():
            r = _get(point, gait)
            if r.hours is None:
                continue
            ax.plot(
                i + rng.uniform(-0.18, 0.18),
                r.hours,
                marker="o",
                ms=4,
                ls="none",
                color="tab:blue" if key[mode_i] == "5W" else "tab:purple",
                alpha=0.7,
            )
        h = _get(table.shipped, gait).hours
        if h is not None:
            ax.plot(i, h, marker="*", ms=16, color="k", mfc="gold", ls="none", zorder=5)
    ax.axhspan(
        TABLE1_HOURS * (1 - TABLE1_TOLERANCE),
        TABLE1_HOURS * (1 + TABLE1_TOLERANCE),
        color="tab:red",
        alpha=0.12,
    )
    ax.axhline(TABLE1_HOURS, color="tab:red", lw=1.2)
    ax.text(
        len(GAITS) - 0.55,
        TABLE1_HOURS,
        "Table 1: approx. 1.0 h (+-25 %)",
        color="tab:red",
        fontsize=8,
        va="bottom",
        ha="right",
    )
    ax.set_xticks(range(len(GAITS)), GAITS)
    ax.set_xlim(-0.5, len(GAITS) - 0.5)
    ax.set_ylim(0, None)
    ax.set_ylabel("operation time [h] (usable energy / window power)", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    ax.legend(
        handles=[
            Line2D(
                [], [], ls="none", marker="o", color="tab:purple", label="band point, Jetson 10W"
            ),
            Line2D([], [], ls="none", marker="o", color="tab:blue", label="band point, Jetson 5W"),
            Line2D(
                [], [], ls="none", marker="*", ms=12, color="k", mfc="gold", label="shipped point"
            ),
        ],
        fontsize=8,
        loc="lower left",
    )
    ax.set_title("Predicted operation time per gait", fontsize=10)

    drv = drivers(table, "hours")
    labels, width = [], 0.38
    items = [(n, v) for (n, v) in table.oat]
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
    bx.legend(
        handles=[
            Line2D([], [], color="tab:cyan", lw=6, label="swim"),
            Line2D([], [], color="tab:brown", lw=6, label="walk"),
        ],
        fontsize=8,
    )
    bx.set_title("One parameter at a time (the rest shipped)", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_findings(table: Table, path: pathlib.Path) -> None:
    """Left: u_swim against u_walk at every band point; right: the swim's electrical cost of
    transport against the walk's; colour: stall angle; the diagonal: where a finding
    turns."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
    for ax, field, label in ((axes[0], "u", "u  [m/s]"), (axes[1], "cot", "electrical CoT")):
        xs, ys = [], []
        for key, point in table.band.items():
            x, y = getattr(_get(point, "walk"), field), getattr(_get(point, "swim"), field)
            if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)):
                continue
            xs.append(x)
            ys.append(y)
            ax.plot(
                x, y, marker="o", ms=6, ls="none", color=_colour(stall_deg(key)), mec="k", mew=0.3
            )
        x, y = (
            getattr(_get(table.shipped, "walk"), field),
            getattr(_get(table.shipped, "swim"), field),
        )
        if x is not None and y is not None:
            ax.plot(x, y, marker="*", ms=16, color="k", mfc="gold", ls="none", zorder=5)
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
    axes[0].set_title("swimming slower than walking: below the diagonal", fontsize=10)
    axes[1].set_title("the walk more efficient than the swim: above the diagonal", fontsize=10)
    handles = [
        Line2D(
            [],
            [],
            ls="none",
            marker="o",
            color=col,
            mec="k",
            mew=0.3,
            label=f"stall angle {deg:g} deg",
        )
        for deg, col in STALL_COLOURS.items()
    ]
    handles.append(
        Line2D([], [], ls="none", marker="*", ms=12, color="k", mfc="gold", label="shipped point")
    )
    fig.legend(handles=handles, loc="lower center", ncol=5, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)


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


def check_arguments(args) -> None:
    """Every option before anything is read; raises ScenarioError naming it."""
    from manta_drake.config_io import check_writable_folder
    from manta_drake.studies.options import (
        check_output_file,
        check_results_csv,
        check_sweep_results,
    )

    if args.check_logs is not None:
        check_results_csv(
            "--check-logs",
            args.check_logs / "results.csv",
            LOGS_COLUMNS,
            hint=" (DIR is the output folder of `manta-drake sweep diagrams/sweeps/energy.yaml`)",
        )
        return
    check_sweep_results(args.results, RESULTS_COLUMNS, "energy", SHIPPED_RESULTS)
    check_output_file("--out-md", args.out_md)
    check_writable_folder(args.out_fig_dir, "--out-fig-dir", example="docs/figures")


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study energy``); returns the exit status."""
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
        "--out-md",
        default="docs/energy.md",
        help="markdown file whose generated block is (re)written",
    )
    p.add_argument(
        "--out-fig-dir",
        default="docs/figures",
        help="folder of the figures energy_speed_cot.png, energy_operation_time.png "
        "and energy_findings.png",
    )
    p.add_argument(
        "--check-logs",
        metavar="DIR",
        type=pathlib.Path,
        help="instead of the report: read DIR/runs/*/log.npz of the sweep and print "
        "how steady each run's window power is",
    )
    args = p.parse_args(argv)
    check_arguments(args)
    if args.check_logs is not None:
        check_logs(args.check_logs)
        return 0
    results = pathlib.Path(args.results)
    table = read_table(read_results(results))
    write_markdown(
        pathlib.Path(args.out_md),
        markdown_block(table, args.results),
        f"manta-drake study energy --results {args.results}",
    )
    figs = pathlib.Path(args.out_fig_dir)
    plot_speed_cot(table, figs / "energy_speed_cot.png")
    plot_operation_time(table, figs / "energy_operation_time.png")
    plot_findings(table, figs / "energy_findings.png")
    for t in tally(table.band.values(), FINDINGS + VARIANTS):
        print(
            f"{t.label:45s} {t.holds:3d}/{t.total:<3d} fails {t.fails:3d}  "
            f"undetermined {t.undetermined:3d}"
        )
    print(f"wrote {args.out_md} and the figures in {figs}")
    return 0
