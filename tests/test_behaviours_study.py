"""The behaviours study's page (manta_drake.studies.behaviours) from small synthetic runs whose
numbers are known: each number in its place, each sentence's branch as the runs decide it,
and the page and figures written under --out."""

import json

import numpy as np
import pytest

from manta_drake.studies import behaviours

T = np.arange(0.0, 70.01, 0.5)  # s: the synthetic logs' samples


def _metrics(uv, yaw, window, near, clearance, touched=False, transitions=()):
    return {
        "mean_velocity_body": uv,
        "yaw_rate_deg_s": yaw,
        "steady_window_s": window,
        "near_wall_at_s": near,
        "min_wall_clearance_m": clearance,
        "touched_wall": touched,
        "transitions": list(transitions),
    }


def _change(a, b, start, end):
    return {"from": a, "to": b, "start_s": start, "end_s": end}


FOUR = {
    **_metrics(None, None, None, None, 0.38),
    "transitions": [
        _change("trot", "walk", 0.0, 1.6),
        _change("walk", "trot", 11.0, 12.5),  # before the current stops (12 s)
        _change("trot", "swim", 21.3, None),
    ],
    "energy": {"mean_electrical_power_w": 26.14, "battery_soc_end": 0.2221},
}
METRICS = {
    "locomotion_swim": _metrics([0.114, 0.066], -7.08, [6.0, 8.4], 8.4, 0.05),
    "swim_heading_hold": _metrics([0.095, 0.031], 0.5, [6.0, 9.7], None, 0.2),
    "swim_heading_hold_reversed": _metrics([0.063, 0.079], -9.62, [6.0, 9.8], 9.8, -0.01, True),
    "two_behaviors": _metrics(
        [0.016, 0.001],
        None,
        [6.0, 33.5],
        33.5,
        0.11,
        transitions=[_change("swim", "trot", 11.6, 16.0), _change("trot", "swim", 41.9, 45.0)],
    ),
    "two_behaviors_heading_hold": _metrics(None, -3.87, None, 65.1, 0.17),
    "three_behaviors": _metrics([0.010, -0.001], -4.5, [6.0, 40.0], None, 0.46),
    "four_behaviors": FOUR,
}


def _write_runs(folder):
    """Run folders with metrics.json and log.npz for every scenario of the study."""
    t_trim = np.arange(0.0, 20.01, 0.1)
    trims = {  # the hold's trim: 0.2 over the free-water window, 0.1 before it
        "swim_heading_hold": np.where(t_trim < 6.0, 0.1, 0.2),
        "swim_heading_hold_reversed": np.full(len(t_trim), -0.3),
    }
    for name, m in METRICS.items():
        run = folder / name
        run.mkdir(parents=True)
        (run / "metrics.json").write_text(json.dumps(m))
        log = {"t": T, "body_rpy": np.zeros((len(T), 3))}
        if name in trims:
            log.update(t_heading_trim=t_trim, heading_trim=trims[name][:, None])
        if name == "four_behaviors":
            log.update(_four_log())
        np.savez(run / "log.npz", **log)


def _four_log():
    z = np.where((T >= 2.0) & (T < 3.0), 0.9, np.where((T >= 20.0) & (T < 45.0), 0.0, 1.0))
    y = 0.02 * T  # drifting left at 0.02 m/s
    flow_speed = np.clip(0.01 + 0.005 * (T - 8.0), 0.0, None)  # 0.010-0.030 m/s over 8-12 s
    column = {
        "z_hat": z,
        "flow_hat": np.full(len(T), 0.5),
        "energy_hat": T / 70.0,
        "balloon_command": (T >= 18.0).astype(float),
        "flow_speed_hat": flow_speed,
    }
    log = {f"t_{k}": T for k in column}
    log.update({k: v[:, None] for k, v in column.items()})
    log["body_xyz"] = np.stack([0 * T, y, 0 * T], axis=1)
    return log


@pytest.fixture
def runs(tmp_path):
    _write_runs(tmp_path / "runs")
    return tmp_path / "runs"


def test_the_page_puts_each_run_s_numbers_in_their_place(runs):
    text = behaviours.page(METRICS, runs)
    lines = text.split("\n")
    assert lines[2] == (
        "Made unknown at commit unknown. Regenerate with `manta-drake study behaviours` (the "
        "runs: `manta-drake run NAME` for each scenario below; `python "
        "diagrams/four_behaviors.py`)."
    )
    assert (
        "with the opposite sign (`heading_hold.turn_sign: -1`) the same swim turns at -9.6 "
        "deg/s, faster than without the hold."
    ) in text
    assert (
        "| swim (printed Phi'_swim lag) | 0.114, 0.066 | -7.08 | 6.0-8.4 | within 0.3 m of a "
        "wall from 8.4 s; closest 0.05 m | - |"
    ) in lines
    assert (
        "| swim_heading_hold | 0.095, 0.031 | 0.50 | 6.0-9.7 | never within 0.3 m; closest "
        "0.20 m | +0.200 |"
    ) in lines
    assert (
        "| the hold with the opposite sign | 0.063, 0.079 | -9.62 | 6.0-9.8 | within 0.3 m of "
        "a wall from 9.8 s; closest 0.00 m; touched | -0.300 |"
    ) in lines
    assert (
        "The hold brings the swim's yaw rate from -7.1 to 0.50 deg/s (within 1 deg/s) at u = "
        "0.095 m/s (at least 0.07 m/s) over its free-water window; the swim without it leaves "
        "free water at 8.4 s. ![heading hold](figures/heading_hold.png)"
    ) in lines
    assert (
        "| two_behaviors | swim -> trot 11.6-16.0 s; trot -> swim 41.9-45.0 s | within 0.3 m "
        "of a wall from 33.5 s; closest 0.11 m | 0.016, 0.001 | - |"
    ) in lines
    assert (
        "| two_behaviors_heading_hold | none | within 0.3 m of a wall from 65.1 s; closest "
        "0.17 m | - | -3.87 |"
    ) in lines


def test_the_page_reads_four_behaviors_from_its_log(runs):
    lines = behaviours.page(METRICS, runs).split("\n")
    # The shipped scenario's current (0.1 m/s to 12 s, off at 14 s), rule and battery.
    assert lines[
        lines.index("## A fourth behaviour from new modalities: four_behaviors") + 2
    ].startswith(
        "The robot starts on the floor in a 0.1 m/s cross current (to its left; 0-12 s, then "
        "down to 0 by 14 s)."
    )
    table = lines.index("| change | s | driven by |")
    assert lines[table + 2 : table + 6] == [
        "| trot -> walk | 0.0-1.6 | flow (flow_hat rises: the cross current on the floor) |",
        "| walk -> trot | 11.0-12.5 | flow (flow_hat falls) |",
        "| trot -> swim | 21.3-never | depth (z_hat falls: the balloon rule on flow filled "
        "the balloon) |",
        "",
    ]
    assert lines[table + 6] == (
        "3 behaviours (swim, trot, walk); never within 0.3 m; closest 0.38 m. The estimates "
        "the decisions read (from the log):"
    )
    table = lines.index("| t s | z_hat | flow_hat | energy_hat | balloon command |")
    assert lines[table + 2 : table + 9] == [
        "| 4 | 1.00 | 0.50 | 0.06 | 0 |",
        "| 12 | 1.00 | 0.50 | 0.17 | 0 |",
        "| 18 | 1.00 | 0.50 | 0.26 | 1 |",
        "| 22 | 0.00 | 0.50 | 0.31 | 1 |",
        "| 30 | 0.00 | 0.50 | 0.43 | 1 |",
        "| 50 | 1.00 | 0.50 | 0.71 | 1 |",
        "| 65 | 1.00 | 0.50 | 0.93 | 1 |",
    ]
    drift = lines[table + 10]
    assert drift.startswith(
        "The current drags the walking robot along the floor at 0.020 m/s (8-12 s; its feet "
        "hold it only partly), so the filtered flow speed reads 0.010-0.030 m/s in the 0.1 "
        "m/s current, falling below the lower threshold (0.02 m/s; the band is 0.02-0.05 "
        "m/s) as the robot drifts with it; a 4 s filter"
    )
    assert drift.endswith(
        "not on its start. The walk gives way to the trot at 11.0 s, before the current stops "
        "at 12 s: drifting with it, the robot sees too little of it. While the robot settles "
        "on its feet (the first 5 s) z_hat dips to 0.90, which gives the swim a share of the "
        "target for a moment."
    )
    assert lines[table + 12] == "Energy: 26.1 W mean, the charge from 22.9 % to 22.21 %."
    assert lines[-2:] == ["![four_behaviors](figures/four_behaviors.png)", ""]


@pytest.mark.slow
def test_out_and_runs_choose_where_the_study_reads_and_writes(runs, tmp_path, monkeypatch):
    """With --reuse the study simulates nothing: it reads --runs, writes the page and the
    figures under --out, and its stamp names both folders."""

    def four_figure(_runs, metrics, path):  # the transition-run figure needs a whole log
        path.write_text(str(metrics["energy"]["battery_soc_end"]))

    monkeypatch.setattr(behaviours, "_four_figure", four_figure)
    monkeypatch.setattr(behaviours, "run_one", lambda *a: pytest.fail("simulated"))
    out = tmp_path / "report"
    argv = ["--reuse", "--runs", str(runs), "--out", str(out)]
    assert behaviours.main(argv, prog="manta-drake study behaviours") == 0
    page = (out / "behaviours.md").read_text()
    assert page.split("\n")[2].endswith(
        f"Regenerate with `manta-drake study behaviours --out {out} --runs {runs}` (the runs: "
        "`manta-drake run NAME` for each scenario below; `python diagrams/four_behaviors.py`)."
    )
    assert page == behaviours.page(METRICS, runs, page.split("\n")[2])
    assert (out / "figures" / "heading_hold.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "figures" / "four_behaviors.png").read_text() == "0.2221"
    assert sorted(p.name for p in out.rglob("*")) == [
        "behaviours.md",
        "figures",
        "four_behaviors.png",
        "heading_hold.png",
    ]
