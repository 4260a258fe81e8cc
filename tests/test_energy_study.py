"""The energy study (manta_drake.studies.energy): its criteria and reductions on small tables
with known answers, its sweep file, and the page it regenerates from the shipped table."""

import csv
import dataclasses as dc
import math
import pathlib

import numpy as np
import pytest

from manta_drake.studies import energy as E

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHIPPED = ROOT / "diagrams" / "sweeps" / "data" / "energy_results.csv"
SWEEP = ROOT / "diagrams" / "sweeps" / "energy.yaml"
INF = math.inf


def run(**kw):
    return E.GaitEnergy(**kw)


# A point where both findings hold: the walk fastest and cheapest.
GOOD = {
    "swim": run(u=0.05, cot=6.0, cot_mech=1.0),
    "trot": run(u=0.06, cot=5.0, cot_mech=0.3),
    "walk": run(u=0.07, cot=4.0, cot_mech=0.2),
    "crab": run(u=0.01, cot=25.0, cot_mech=1.4),
    "turning": run(u=0.001, cot=INF, cot_mech=INF),
}


def test_swim_slower_than_walk():
    assert E.swim_slower_than_walk(GOOD) is True
    assert E.swim_slower_than_walk({**GOOD, "swim": run(u=0.088)}) is False
    assert E.swim_slower_than_walk({**GOOD, "swim": run(u=0.07)}) is False  # strict
    assert E.swim_slower_than_walk({**GOOD, "walk": E.UNDETERMINED}) is None
    assert E.swim_slower_than_walk({g: r for g, r in GOOD.items() if g != "swim"}) is None


def test_walk_most_efficient_strict_with_infinite_and_undetermined_costs():
    assert E.walk_most_efficient(GOOD) is True
    # The shipped point's numbers: the swim's 3.60 beats the walk's 4.49.
    fast_swim = {**GOOD, "swim": run(u=0.088, cot=3.60, cot_mech=0.53)}
    assert E.walk_most_efficient(fast_swim) is False
    assert E.walk_most_efficient(fast_swim, ("trot", "crab", "turning")) is True
    assert E.walk_most_efficient(fast_swim, field="cot_mech") is True  # 0.2 < 0.53
    assert E.walk_most_efficient({**GOOD, "trot": run(cot=4.0)}) is False  # a tie fails
    # A gait that does not travel (infinite cost) is beaten; a walk that does not travel
    # beats nothing, not even another infinite cost.
    assert E.walk_most_efficient({**GOOD, "crab": run(cot=INF)}) is True
    assert E.walk_most_efficient({**GOOD, "walk": run(cot=INF)}) is False
    # Kleene: an unknown gait leaves it undetermined, unless another comparison fails.
    assert E.walk_most_efficient({**GOOD, "crab": E.UNDETERMINED}) is None
    assert E.walk_most_efficient({**GOOD, "crab": E.UNDETERMINED, "swim": run(cot=3.0)}) is False
    assert E.walk_most_efficient({**GOOD, "walk": E.UNDETERMINED}) is None


def test_table1_agreement_and_steady_window():
    assert E.agrees_with_table1(1.0) is True
    assert E.agrees_with_table1(1.25) is True and E.agrees_with_table1(0.75) is True
    assert E.agrees_with_table1(1.26) is False and E.agrees_with_table1(0.74) is False
    assert E.agrees_with_table1(2.31) is False
    assert E.agrees_with_table1(None) is None
    assert E.steady_free_water(run(power_w=26.0, window_s=(6.0, 14.6))) is True
    assert E.steady_free_water(run(power_w=26.0, window_s=(6.0, 9.9))) is False
    assert E.steady_free_water(run(power_w=26.0, window_s=None)) is None


def test_spearman():
    assert E.spearman([1, 2, 3, 4], [10, 20, 30, 40]) == pytest.approx(1.0)
    assert E.spearman([1, 2, 3, 4], [4, 1, 0, -7]) == pytest.approx(-1.0)
    assert E.spearman([1, 2, 3, 4], [1, 8, 27, 64]) == pytest.approx(1.0)  # monotone
    assert E.spearman([1, 2], [1, 2]) is None
    assert E.spearman([1, 1, 1], [1, 2, 3]) is None  # constant
    # Ties get their average rank (a binary parameter such as the Jetson mode): the
    # Pearson correlation of the ranks (1.5, 1.5, 3.5, 3.5) and (1, 2, 3, 4).
    assert E.spearman([5, 5, 10, 10], [1, 2, 3, 4]) == pytest.approx(
        np.corrcoef([1.5, 1.5, 3.5, 3.5], [1, 2, 3, 4])[0, 1]
    )
    with pytest.raises(ValueError):
        E.spearman([1, 2, 3], [1, 2])


def test_power_budget_is_the_runs_own_breakdown_and_checks_it():
    """The parts are the run's power_breakdown; the closure is the logged draw less their
    sum; the 5W run's step is measured against the file's electronics (10.5 and 5.5 W over
    the regulator's 0.9)."""
    parts = {"computers_w": 10.5 / 0.9, "standby_w": 9.0, "copper_w": 2.0, "shaft_w": 3.0}
    shipped = dc.replace(run(power_w=sum(parts.values()) + 0.01), breakdown=parts)
    oat = {("actuators.electronics_mode", "5W"): run(power_w=sum(parts.values()) - 5.5)}
    b = E.power_budget(shipped, oat)
    assert (b["electronics"], b["standby"], b["copper"], b["conversion"]) == pytest.approx(
        (10.5 / 0.9, 9.0, 2.0, 3.0)
    )
    assert b["closure"] == pytest.approx(0.01)
    assert b["mode_step_measured"] == pytest.approx(5.51)
    assert b["mode_step_file"] == pytest.approx(5 / 0.9)
    assert E.power_budget(shipped, {}) is None  # no 5W run
    assert E.power_budget(dc.replace(shipped, breakdown={**parts, "copper_w": None}), oat) is None


def test_needed_for_table1():
    budget = {"total": 25.0, "standby": 10.0, "copper": 2.0}
    need = E.needed_for_table1(budget, usable_wh=60.0)
    assert need["power_w"] == 60.0 and need["extra_w"] == 35.0
    assert need["standby_factor"] == pytest.approx(4.5)  # 10 W x 4.5 = 10 + 35
    assert need["copper_factor"] == pytest.approx(18.5)
    assert need["torque_factor"] == pytest.approx(math.sqrt(18.5))  # copper goes with tau^2
    assert E.needed_for_table1(budget, 60.0, hours=2.0)["extra_w"] == 5.0


# Rows of a results.csv.


def _row(
    gait,
    params=None,
    status="ok",
    u=0.07,
    v=0.0,
    power=25.0,
    mean_power=26.0,
    hours=2.4,
    cot=4.3,
    speed=None,
):
    row = {
        "run_id": f"locomotion_{gait}-x",
        "base": f"locomotion_{gait}",
        "status": status,
        "u": repr(u),
        "v": repr(v),
        "steady_start_s": "6.0",
        "steady_end_s": "20.0",
        "near_wall_at_s": "",
        "touched_wall": "False",
        "energy.steady_electrical_power_w": repr(power),
        "energy.steady_mechanical_power_w": "1.5",
        "energy.mean_electrical_power_w": repr(mean_power),
        "energy.operation_time_h": repr(hours),
        "energy.cot_electrical_dry_weight": "" if cot is None else repr(cot),
        "energy.cot_mechanical_dry_weight": "" if cot is None else "0.25",
        "energy.cot_net_of_hotel_dry_weight": "" if cot is None else "1.9",
        "energy.transport_speed_m_s": repr(math.hypot(u, v) if speed is None else speed),
    }
    for name in E.PARAMS:
        row[name] = ""
    row.update({k: str(x) for k, x in (params or {}).items()})
    return row


def test_a_row_becomes_its_energy_figures():
    r = E.energy_of(_row("walk", hours=2.4, mean_power=26.0, power=25.0))
    assert r.hours == pytest.approx(2.4 * 26.0 / 25.0)  # usable energy / window power
    assert r.run_hours == 2.4 and r.cot == 4.3 and r.window_s == (6.0, 20.0)
    assert r.touched_wall is False
    # Every convention the metrics give is read; one the row lacks is undetermined.
    assert r.cot_net == 1.9 and r.cots["cot_mechanical_dry_weight"] == 0.25
    assert r.cots["cot_electrical_weight_in_water"] is None
    slow = E.energy_of(_row("crab", u=0.003, cot=None))
    assert slow.cot == INF and slow.cot_mech == INF and slow.power_w == 25.0
    assert slow.cot_net == INF
    assert E.energy_of(_row("walk", status="failed")) == E.UNDETERMINED
    no_window = _row("walk")
    no_window["u"] = no_window["v"] = ""
    assert E.energy_of(no_window) == E.UNDETERMINED


def test_the_table_is_sorted_into_its_blocks():
    band = {
        "contact.friction": 0.6,
        "hull_damping": 1.1,
        "net_weight_kg": 0.9,
        "standby_current": 1.0,
        "winding_resistance": 1.0,
        "gearbox_efficiency": 1.0,
        "position_gain": 1.5,
        "lift_slope": 1.2,
        "suction_efficiency": 0.7,
        "fin_hull_added_mass": 0.5,
        "actuators.electronics_mode": "5W",
        "stall_angle": 0.667,
    }
    rows = [
        _row("walk"),
        _row("swim"),
        _row("walk", {"stall_angle": 1.333}),
        _row("walk", {"actuators.electronics_mode": "5W"}),
        _row("walk", band),
        _row("swim", {**band, "stall_angle": 1.667}),
    ]
    t = E.read_table(rows)
    assert set(t.shipped) == {"walk", "swim"} and t.runs == 6
    assert set(t.oat) == {("stall_angle", 1.333), ("actuators.electronics_mode", "5W")}
    assert len(t.band) == 2 and t.usable_wh == pytest.approx(2.4 * 26.0)
    assert sorted(E.stall_deg(k) for k in t.band) == [10.0, 25.0]  # 15 deg x 0.667, 1.667
    assert E.parameters_of(rows[0]) == E.SHIPPED
    with pytest.raises(ValueError, match="twice"):
        E.read_table(rows + rows[:1])
    with pytest.raises(ValueError, match="some but not all"):
        E.read_table([_row("walk", {"stall_angle": 0.667, "hull_damping": 1.3})])
    with pytest.raises(ValueError, match="usable energies"):
        E.read_table([_row("walk"), _row("swim", hours=2.0)])


def test_drivers_rank_the_parameter_that_moves_a_field_most():
    shipped = {"walk": run(hours=2.4)}
    oat = {
        ("standby_current", 0.8): {"walk": run(hours=2.6)},
        ("standby_current", 1.2): {"walk": run(hours=2.2)},
        ("actuators.electronics_mode", "5W"): {"walk": run(hours=3.0)},
    }
    band = {}
    for mode, sb in [("5W", 0.9), ("10W", 1.1), ("5W", 1.0), ("10W", 0.8)]:
        key = (0.6, 1.0, 0.8, sb, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, mode, 1.0)
        band[key] = {"walk": run(hours={"5W": 3.0, "10W": 2.4}[mode] - 0.1 * sb)}
    t = E.Table(shipped, oat, band, 60.0, 4)
    d = E.drivers(t, "hours")["walk"]
    assert d["standby_current"]["oat"] == {0.8: pytest.approx(0.2), 1.2: pytest.approx(-0.2)}
    # Hours 2.91, 2.29, 2.90, 2.32: ranks 4, 1, 3, 2 against the modes' 1.5, 3.5, 1.5, 3.5.
    assert d["actuators.electronics_mode"]["rho"] == pytest.approx(
        np.corrcoef([1.5, 3.5, 1.5, 3.5], [4, 1, 3, 2])[0, 1]
    )
    assert d["contact.friction"]["rho"] is None  # constant over the band
    assert E.largest_driver(d, "oat") == ("actuators.electronics_mode", pytest.approx(0.6))
    name, rho = E.largest_driver(d, "rho")
    assert name == "actuators.electronics_mode" and rho < -0.8
    assert E.largest_driver(E.drivers(t, "hours")["swim"], "oat") is None


def test_window_halves():
    t = np.arange(0, 20, 0.001)
    power = np.where(t < 12.0, 25.0, 27.0)
    # Window 6-16.5 s: four whole 2 s cycles (6-14), halves 6-10 and 10-14.
    assert E.window_halves(t, power, (6.0, 16.5)) == (25.0, pytest.approx(26.0))
    assert E.window_halves(t, power, (6.0, 9.5)) is None  # one cycle only


# The page's block rendered from small tables (templates/energy.md.j2).

BAND_POINT = {
    "contact.friction": 0.6,
    "hull_damping": 1.1,
    "net_weight_kg": 0.9,
    "standby_current": 1.0,
    "winding_resistance": 1.0,
    "gearbox_efficiency": 1.0,
    "position_gain": 1.5,
    "lift_slope": 1.2,
    "suction_efficiency": 0.7,
    "fin_hull_added_mass": 0.5,
    "actuators.electronics_mode": "5W",
    "stall_angle": 0.667,
}


def _lines(table, source="t.csv"):
    return E.markdown_block(table, source).split("\n")


def test_the_block_shows_each_number_in_its_place():
    """Walk and swim at the shipped point, at the 20 deg stall angle and at one band point
    (10 deg): usable energy 2.4 h x 26 W = 62.4 Wh; the walk's 20 deg run draws 20 W, so it
    lasts 62.4 / 20 = 3.12 h against 62.4 / 25 = 2.496 h shipped."""
    rows = [
        _row("walk"),
        _row("swim", u=0.05),
        _row("walk", {"stall_angle": 1.333}, power=20.0),
        _row("swim", {"stall_angle": 1.333}, u=0.05),
        _row("walk", BAND_POINT),
        _row("swim", BAND_POINT, u=0.05),
    ]
    lines = _lines(E.read_table(rows))
    assert lines[:3] == [
        "<!-- energy-report:begin -->",
        "<!-- generated by manta-drake study energy from t.csv; do not edit by hand -->",
        "",
    ]
    # No band point at 15 deg: no sample to correlate, the sentence ends at the pack.
    assert lines[3] == (
        "The table: 6 runs; the shipped point, 1 one-at-a-time sets and 1 band points (1 stall "
        "angles), each with the five gaits. Usable energy of the pack (full to the cut-off, at "
        "open circuit): 62.40 Wh."
    )
    assert "| walk | 0.070 | 0.070 | 25.0 | 1.50 | 4.30 | 0.25 | 2.50 (2.40) | 6.0-20.0 |" in lines
    assert "| crab | - | - | - | - | - | - | - (-) | - |" in lines
    # The costs in COT_KEYS' order; the row gives three of the six.
    assert "| walk | 4.30 | - | 1.90 | - | 0.25 | - |" in lines
    assert (
        "| swim | 1 | 0 | 0 | 0.050 (0.050 to 0.050) | 25.0 (25.0 to 25.0) | 1.50 (1.50 to 1.50) "
        "| 4.30 (4.30 to 4.30) | 1.90 (1.90 to 1.90) | 0.25 (0.25 to 0.25) | 2.50 (2.50 to 2.50) |"
    ) in lines
    assert "| turning | 1 | 1 | 0 | - | - | - | - | - | - | - |" in lines
    # No power_breakdown: no budget, no checks, no two packs.
    assert "| walk | - | - | - | - | - | - | - | - | - | - |" in lines
    assert not any(line.startswith(("Checks of the budget", "Were each pack")) for line in lines)
    assert (
        "**Operation time against Table 1** (1.0 h; a prediction agrees within 25 %): over all "
        "6 runs 2.50 to 3.12 h; 0 of them agree."
    ) in lines
    assert "| stall angle | 20 deg | 0.000 | - | 0.624 | - | - |" in lines
    assert "| stall angle | rho over the band | - | - | - | - | - |" in lines
    assert lines.index("| friction | rho over the band | - | - | - | - | - |") < lines.index(
        "| stall angle | 20 deg | 0.000 | - | 0.624 | - | - |"
    )
    assert (
        "The parameter that moves the operation time most, one at a time (the span of its runs) "
        "and over the band (largest \\|rho\\|): swim: stall angle (0.00 h), -; trot: -, -; "
        "walk: stall angle (0.62 h), -; crab: -, -; turning: -, -."
    ) in lines
    assert "| A. swimming is slower than walking | u_swim < u_walk | 1/1 | 0 | 0 | 100 % |" in lines
    # The band point is at 10 deg, where no one-at-a-time run is: no verdicts there. A holds;
    # the walk's costs tie the swim's (B, B-forward, B-mech fail), B-floor lacks the others.
    assert lines[-5] == (
        "| 10 | 1 | 0.050 (0.050 to 0.050) | 0.070 (0.070 to 0.070) | 4.30 (4.30 to 4.30) | "
        "1/1 | 0/1 | 0/1 | 0/1 | 0/1 | - |"
    )
    assert lines[-3] == (
        "**Free water and steady state**: 6 of 6 runs have a free-water window (from 6 s, after "
        "the start's transient, until the run's end or the hull's first approach within 0.3 m "
        "of a wall), 14.0 to 14.0 s long; 0 shorter than 4 s (two gait cycles). 0 runs come "
        "near a wall before 20 s (their window ends there) and 0 touch one after it; every "
        "power, cost of transport and operation time above is a window figure, before any wall."
    )
    assert lines[-2:] == ["", "<!-- energy-report:end -->"]


def test_the_block_shows_the_power_budget_its_checks_and_the_two_packs():
    """The walk's breakdown 11 + 9 + 3 + 2 = 25 W, its 5W run 5.5 W less; 62.4 Wh in 1 h
    needs 62.4 W: 37.4 W more, standby x (1 + 37.4 / 9), copper x (1 + 37.4 / 3), torques x
    its square root; half the pack lasts 31.2 / (25 - 11) h on the servos, 31.2 / 11 h on
    the computers."""
    parts = {"computers_w": 11.0, "standby_w": 9.0, "copper_w": 3.0, "shaft_w": 2.0}
    shipped = _row("walk")
    shipped.update({f"power_breakdown.{k}": repr(v) for k, v in parts.items()})
    five = _row("walk", {"actuators.electronics_mode": "5W"}, power=19.5)
    lines = _lines(E.read_table([shipped, five]))
    # 1 + 37.4 / 9 = 5.16, 1 + 37.4 / 3 = 13.47, its square root 3.67.
    assert "| walk | 25.0 | 11.00 | 9.00 | 3.00 | 2.00 | 80 % | 62.4 | 5.2 | 13 | 3.7 |" in lines
    assert (
        "Checks of the budget: the parts add up to the logged draw within 0.0e+00 W; the 5W "
        "run draws 5.500 to 5.500 W less (the file's electronics: 5.556 W; the rest is the "
        "battery's and the servos' response to the lower current)."
    ) in lines
    assert (
        "Were each pack to feed one load (one pack the 16 servos, the other the computers; "
        "31.20 Wh usable each), the servos' pack would last 2.23 h (walk) and the computers' "
        "2.84 h, at the shipped point."
    ) in lines
    assert "| Jetson mode | 5W | - | - | 0.704 | - | - |" in lines  # 62.4 / 19.5 - 2.496
    assert lines[-3] == "**Free water and steady state**: " + (
        "2 of 2 runs have a free-water window (from 6 s, after the start's transient, until "
        "the run's end or the hull's first approach within 0.3 m of a wall), 14.0 to 14.0 s "
        "long; 0 shorter than 4 s (two gait cycles). 0 runs come near a wall before 20 s "
        "(their window ends there) and 0 touch one after it; every power, cost of transport "
        "and operation time above is a window figure, before any wall."
    )


def test_the_block_of_runs_that_all_failed():
    lines = _lines(E.read_table([_row("walk", status="failed"), _row("swim", status="failed")]))
    assert "| walk | - | - | - | - | - | - | - (-) | - |" in lines
    assert (
        "**Operation time against Table 1** (1.0 h; a prediction agrees within 25 %): over all "
        "0 runs - to - h; 0 of them agree."
    ) in lines
    assert lines[-3] == "**Free water and steady state**: no run has a window."


def test_a_new_page_gets_its_title_and_stamp(tmp_path):
    page = tmp_path / "sub" / "energy.md"
    rows = [_row("walk"), _row("swim", u=0.05)]
    E.write_markdown(page, E.markdown_block(E.read_table(rows), "t.csv"), "manta-drake study x")
    lines = page.read_text().split("\n")
    assert lines[0] == "# Energy over the uncertainty band"
    assert lines[2].startswith("Made ") and lines[2].endswith(
        ". Regenerate with `manta-drake study x`."
    )
    assert lines[4] == E.MARK_BEGIN and lines[-2:] == [E.MARK_END, ""]


# The sweep file, the shipped table and the page.


def test_the_sweep_file_is_band_rows():
    from manta_drake.sweep import load_sweep

    config = load_sweep(SWEEP)
    assert [dict(r) for r in config.rows] == E.band_rows()
    assert [b.removeprefix("locomotion_") for b in config.base] == list(E.GAITS)
    assert set(config.links) >= {
        "hull_damping",
        "standby_current",
        "winding_resistance",
        "gearbox_efficiency",
        "position_gain",
        "lift_slope",
        "suction_efficiency",
        "fin_hull_added_mass",
        "stall_angle",
    }
    # Each link names the model entry the band's parameter is on.
    assert config.links["stall_angle"] == ["water.coefficient_scales.fins.stall_angle_deg"]
    assert config.links["fin_hull_added_mass"] == [
        "water.coefficient_scales.fins.hull_interaction_added_mass"
    ]


def test_band_rows_is_a_latin_hypercube_at_four_stall_angles():
    rows = E.band_rows()
    n_oat = len(E.ONE_AT_A_TIME)
    assert rows[0] == {} and len(rows) == 1 + n_oat + 4 * E.SAMPLE_POINTS
    assert rows[1 : 1 + n_oat] == [{k: v} for k, v in E.ONE_AT_A_TIME]
    # Every band parameter but the stall angle (the grouping) is in the hypercube.
    assert set(E.CONTINUOUS) | {"actuators.electronics_mode", "stall_angle"} == set(E.PARAMS)
    sample = rows[1 + n_oat :]
    points = sample[::4]
    for name, (lo, hi) in E.CONTINUOUS.items():
        # One value in each of the n equal strata (to the 3 decimals the values keep).
        width = (hi - lo) / E.SAMPLE_POINTS
        for k, x in enumerate(sorted(p[name] for p in points)):
            assert lo + k * width - 5e-4 <= x <= lo + (k + 1) * width + 5e-4, (name, k, x)
    modes = [p["actuators.electronics_mode"] for p in points]
    assert modes.count("5W") == modes.count("10W") == E.SAMPLE_POINTS // 2
    for i, p in enumerate(points):
        group = sample[4 * i : 4 * i + 4]
        assert [E.stall_of(g["stall_angle"]) for g in group] == [10.0, 15.0, 20.0, 25.0]
        assert all(
            {k: v for k, v in g.items() if k != "stall_angle"}
            == {k: v for k, v in p.items() if k != "stall_angle"}
            for g in group
        )
    assert E.band_rows() == rows  # seeded
    # Decorrelated: no two parameters of the sample rank-correlate by more than 0.2.
    assert max(abs(r) for r in E.rank_correlations(points).values()) < 0.2


def test_decorrelating_the_hypercube_keeps_each_columns_values():
    rng = np.random.default_rng(E.SAMPLE_SEED)  # the raw draw band_sample starts from
    n, raw = E.SAMPLE_POINTS, {}
    for name, (lo, hi) in E.CONTINUOUS.items():
        strata = (rng.permutation(n) + rng.uniform(size=n)) / n
        raw[name] = [round(float(lo + (hi - lo) * x), 3) for x in strata]
    raw_points = [{name: raw[name][i] for name in raw} for i in range(n)]
    # The raw pairing has chance correlations (why band_sample swaps) ...
    assert max(abs(r) for r in E.rank_correlations(raw_points, list(raw)).values()) > 0.5
    # ... the sample has the same values in every column, paired otherwise.
    points = E.band_sample()
    assert {k: sorted(p[k] for p in points) for k in raw} == {k: sorted(v) for k, v in raw.items()}
    assert max(abs(r) for r in E.rank_correlations(points, list(raw)).values()) < 0.2


def test_the_shipped_values_are_the_models():
    from manta_drake.model import MODELS_DIR
    from manta_drake.model.actuators import DEFAULT_ACTUATORS_FILE, load_actuators
    from manta_drake.model.coefficients import load_coefficients
    from manta_drake.sweep.net_weight import deflated_net_weight_kg

    coeffs = load_coefficients(MODELS_DIR / "hydrodynamics.yaml")
    assert round(deflated_net_weight_kg(coeffs), 3) == E.SHIPPED_NET_WEIGHT_KG
    assert coeffs.fins.stall_angle_deg.value == E.STALL_ANGLE_DEG
    params = load_actuators(DEFAULT_ACTUATORS_FILE)
    assert params.electronics.jetson_mode.value == E.SHIPPED["actuators.electronics_mode"]
    assert set(params.electronics.jetson_power.value) == set(E.MODES)
    assert {k: v * 1.0 for k, v in params.electronics.jetson_power.value.items()} == E.MODE_WATTS


@pytest.mark.slow
@pytest.mark.skipif(not SHIPPED.exists(), reason="no shipped sweep table")
def test_the_shipped_table_is_the_whole_sweep():
    with open(SHIPPED, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(E.GAITS) * len(E.band_rows())
    assert all(r["status"] == "ok" for r in rows)
    # Each gait at exactly the sweep file's parameter sets, in its order.
    for gait in E.GAITS:
        sets = [
            {k: r[k] for k in E.PARAMS if r[k] != ""}
            for r in rows
            if r["base"] == f"locomotion_{gait}"
        ]
        assert sets == [{k: str(v) for k, v in row.items()} for row in E.band_rows()], gait
    t = E.read_table(rows)
    assert set(t.shipped) == set(E.GAITS)
    assert len(t.oat) == len(E.ONE_AT_A_TIME) and len(t.band) == 4 * E.SAMPLE_POINTS
    assert all(set(p) == set(E.GAITS) for p in [*t.oat.values(), *t.band.values()])


@pytest.mark.slow
@pytest.mark.skipif(not SHIPPED.exists(), reason="no shipped sweep table")
def test_the_study_command_writes_the_committed_energy_page(tmp_path, monkeypatch):
    """``manta-drake study energy --out DIR`` on the shipped table reproduces docs/energy.md
    byte for byte in DIR, and writes its three figures in DIR/figures, nothing else."""
    from manta_drake.cli import main

    committed = (ROOT / "docs" / "energy.md").read_bytes()
    (tmp_path / "energy.md").write_bytes(committed)
    monkeypatch.chdir(ROOT)  # the page names the table by its path in the repository
    argv = ["study", "energy", "--results", str(SHIPPED.relative_to(ROOT)), "--out", str(tmp_path)]
    assert main(argv) == 0
    assert (tmp_path / "energy.md").read_bytes() == committed
    figures = ["energy_findings.png", "energy_operation_time.png", "energy_speed_cot.png"]
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == figures
    assert sorted(p.name for p in tmp_path.iterdir()) == ["energy.md", "figures"]


@pytest.mark.skipif(not SHIPPED.exists(), reason="no shipped sweep table")
def test_an_installed_package_must_name_the_pages_folder(tmp_path, monkeypatch):
    from manta_drake.config_io import ScenarioError
    from manta_drake.studies import report

    monkeypatch.setattr(report, "REPO", tmp_path)  # no checkout above the package
    with pytest.raises(ScenarioError, match=r"^manta-drake study energy: --out DIR is required: "):
        E.main(["--results", str(SHIPPED)], prog="manta-drake study energy")
    assert list(tmp_path.iterdir()) == []
