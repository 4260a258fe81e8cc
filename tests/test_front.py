"""A front of two metrics by the epsilon-constraint method (``manta_drake.optimize.front``):
the non-dominated set against its definition, and a front spec run through the command with a
cheap evaluator whose front is known."""

import csv
import json
import pathlib
import re

import numpy as np
import pytest

from manta_drake.cli import main
from manta_drake.control.gait_files import load_gait_file
from manta_drake.optimize import OptimizeError, load_problem, read_history, run_optimization

FRONT_SPEC = """\
scenario: locomotion_walk
gait: walk
name: quadratic
free:
  - {entry: "R_deg[fl, yaw]", low: 0, high: 30,
     tie: ["R_deg[fr, yaw]", "R_deg[rl, yaw]", "R_deg[rr, yaw]"], tie_signs: [-1, 1, -1]}
  - {entry: "Phi_prime_deg[fl, fr]", low: 180, high: 360}
objective:
  constraints: [{metric: abs_v, max: 0.01}]
front: {maximise: u, minimise: cot_net_of_hotel, levels: [0.02, 0.05, 0.08]}
robustness:
  points: [{}, {contact.friction: 0.6}]
budget: {generations: 3, population: 6, sigma0: 0.3}
seed: 3
"""


def write(path: pathlib.Path, text: str) -> pathlib.Path:
    path.write_text(text)
    return path


def test_pareto_mask_is_the_non_dominated_set_by_brute_force(rng):
    """Random points with ties and NaNs: on the front exactly when no other finite point is
    at least as good in both and better in one (the definition, O(n^2))."""
    from manta_drake.optimize.front import pareto_mask

    up = np.round(rng.uniform(0, 1, 300), 1)  # many ties
    down = np.round(rng.uniform(0, 1, 300), 1)
    up[::37] = np.nan
    mask = pareto_mask(up, down)
    finite = np.isfinite(up) & np.isfinite(down)
    for i in range(up.size):
        dominated = np.any(
            finite & (up >= up[i]) & (down <= down[i]) & ((up > up[i]) | (down < down[i]))
        )
        assert mask[i] == (bool(finite[i]) and not dominated), i
    assert pareto_mask([1.0, 2.0], [1.0, 1.0]).tolist() == [False, True]
    assert pareto_mask([], []).size == 0


def cost_speed(task):
    """u grows with the yaw amplitude (0.1 m/s at 30 deg); the cost is 1 + 2 u at the best
    phase (300 deg) and more away from it: the front is cot = 1 + 2 u. Above 27 deg the
    run sideslips (|v| 0.02 m/s, breaking the constraint)."""
    x = task["parameters"]
    u = 0.1 * x["R_deg.fl.yaw"] / 30.0
    cot = 1.0 + 2.0 * u + ((x["Phi_prime_deg.fl.fr"] - 300.0) / 180.0) ** 2
    v = 0.02 if x["R_deg.fl.yaw"] > 27.0 else 0.0
    return {
        "status": "ok",
        "metrics": {"u": u, "v": v, "abs_u": u, "abs_v": v, "cot_net_of_hotel": cot},
        "run": {  # the run's metrics.json, as far as the front reads it
            "mean_velocity_body": [u, v],
            "yaw_rate_deg_s": 0.5,
            "energy": {"cot_net_of_hotel_dry_weight": cot},
            "steady_window_s": [6.0, 20.0],
        },
    }


@pytest.mark.slow
def test_a_front_spec_runs_one_search_per_level_and_writes_the_front(tmp_path, capsys, monkeypatch):
    import manta_drake.optimize.cli as cli
    from manta_drake.optimize.front import pareto_mask

    spec = write(tmp_path / "front.yaml", FRONT_SPEC)
    monkeypatch.setattr(
        cli,
        "run_optimization",
        lambda problem, out, client, evaluate=None, progress=False: run_optimization(
            problem, out, client, evaluate=cost_speed, progress=progress
        ),
    )
    out = tmp_path / "out"
    assert (
        main(
            [
                "optimize",
                str(spec),
                "--out",
                str(out),
                "--workers",
                "0",
                "--quiet",
                "--generations",
                "4",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    printed = captured.out
    assert "level u >= 0.05" in printed and "on the front: u" in printed
    # A line as each level starts and ends (live, on stderr; a front runs for hours)
    assert "quadratic: level_01 (u >= 0.05; 2 of 3) in " + str(out / "level_01") in captured.err
    assert re.search(
        r"level_02 \(u >= 0\.08; 3 of 3\): ok, lowest cot_net_of_hotel cost", captured.err
    )
    summary = json.loads((out / "front.json").read_text())
    assert [x["folder"] for x in summary["levels"]] == ["level_00", "level_01", "level_02"]
    for k, level in enumerate((0.02, 0.05, 0.08)):  # each level searched under its bound
        rows = read_history(out / f"level_{k:02d}" / "history.csv")
        assert {r["generation"] for r in rows if r["kind"] == "search"} == {1, 2, 3, 4}
        assert any(
            f"u {r['u']:.4g} < {level:g}" in r["reason"]
            for r in rows
            if r["u"] is not None and r["u"] < level and r["status"] == "ok"
        )
    with open(out / "front.csv") as fh:
        points = list(csv.DictReader(fh))
    # every candidate of every level (each level its own seed), the start gait once
    assert (
        len(
            {
                json.loads((out / f"level_{k:02d}" / "state.json").read_text())["identity"]["seed"]
                for k in range(3)
            }
        )
        == 3
    )
    assert len(points) == summary["candidates"] <= 3 * 4 * 6 - 2
    assert len(
        {tuple(p[n] for n in ("R_deg.fl.yaw", "Phi_prime_deg.fl.fr")) for p in points}
    ) == len(points)
    ok = [p for p in points if p["meets_constraints"] == "True"]
    assert all(float(p["R_deg.fl.yaw"]) <= 27.0 for p in ok)  # sideslip breaks the rest
    u = np.array([float(p["u"]) for p in ok])
    cot = np.array([float(p["cot_net_of_hotel"]) for p in ok])
    on = pareto_mask(u, cot)
    assert [p["on_front"] == "True" for p in ok] == on.tolist()
    assert all(p["on_front"] == "False" for p in points if p["meets_constraints"] == "False")
    front = summary["front"]
    assert len(front) == on.sum() >= 3
    assert all(f["cot_net_of_hotel"] - (1 + 2 * f["u"]) < 0.1 for f in front)  # near the line
    assert summary["start"]["generation"] == 1 and summary["start"]["candidate"] == 0
    run = summary["start_run"]  # the start's own run, read back from its metrics.json
    assert run["u"] == pytest.approx(0.1 * 20.0 / 30.0)  # the walk's 20 deg yaw amplitude
    assert run["u"] == pytest.approx(summary["start"]["u"])
    assert run["steady_window_s"] == [6.0, 20.0] and run["status"] == "ok"
    assert (out / "front.png").read_bytes()[:4] == b"\x89PNG"
    # the front's points as gaits, and a spec elsewhere starting from one of them
    gaits = load_gait_file(out / "front_gaits.yaml")
    assert list(gaits) == [f"quadratic_{i}" for i in range(len(front))]
    later = tmp_path / "later"
    later.mkdir()
    start = FRONT_SPEC.replace("gait: walk", "gait: quadratic_1").replace(
        "objective:", "overrides: {controller.gait_files: [../out/front_gaits.yaml]}\nobjective:"
    )
    space = load_problem(write(later / "from_front.yaml", start)).space
    wanted = [front[1]["R_deg.fl.yaw"], front[1]["Phi_prime_deg.fl.fr"]]
    np.testing.assert_allclose(space.start_vector(), wanted, atol=1e-9)


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            lambda s: s.replace("levels: [0.02, 0.05, 0.08]", "levels: [0.05, 0.02]"),
            "optimize.front.levels[1]: 0.02 is not above the level before it (0.05)",
        ),
        (
            lambda s: s.replace("maximise: u,", "maximise: speeed,"),
            "optimize.front.maximise: 'speeed' is not a metric",
        ),
        (
            lambda s: s.replace("objective:\n", "objective:\n  terms: [{metric: u, weight: -1}]\n"),
            "optimize.objective.terms: a front minimises cot_net_of_hotel at each level of u; "
            "leave "
            "the terms out",
        ),
    ],
)
def test_a_bad_front_is_refused_in_one_line(tmp_path, edit, message):
    spec = write(tmp_path / "front.yaml", edit(FRONT_SPEC))
    with pytest.raises(OptimizeError, match=re.escape(message)):
        load_problem(spec)


def test_the_start_is_drawn_from_its_own_run_even_when_unscored():
    """A swim whose window a wall cut is unscored (no u in the search's point), but its own
    run has a speed and a window: that is what is drawn, labelled with the window."""
    from manta_drake.optimize.front import start_label

    summary = {
        "start_gait": "swim_printed",
        "maximise": "u",
        "minimise": "cot_net_of_hotel",
        "start": {"u": float("nan"), "cot_net_of_hotel": float("nan")},
        "start_run": {
            "u": 0.114,
            "cot_net_of_hotel": 0.716,
            "yaw_rate": None,
            "status": "unscored",
            "steady_window_s": [6.0, 8.43],
        },
    }
    point, label = start_label(summary)
    assert (point["u"], point["cot_net_of_hotel"]) == (0.114, 0.716)
    assert np.isnan(point["yaw_rate"])
    assert label == "swim_printed (the start, window 6-8.4 s)"
    summary["start_run"] = None  # a level continued from its state alone
    point, label = start_label(summary)
    assert np.isnan(point["u"]) and label == "swim_printed (the start)"


@pytest.mark.slow
def test_a_front_kept_without_its_folders_runs_its_start_again(tmp_path):
    """A front continued from its levels' state and history alone (no evaluation folders,
    as diagrams/optimize/searches/ keeps them) simulates the start gait once more, so its
    own run is in front.json again; nothing else is simulated."""
    import shutil

    from manta_drake.optimize.front import run_front

    calls = []

    def counted(task):
        calls.append(task["parameters"])
        return cost_speed(task)

    problem = load_problem(write(tmp_path / "front.yaml", FRONT_SPEC), generations=2)
    out = tmp_path / "out"
    first = run_front(problem, out, evaluate=counted, progress=False)
    assert first["start_run"]["u"] == pytest.approx(0.1 * 20.0 / 30.0)  # the walk's yaw 20 deg
    for k in range(3):
        shutil.rmtree(out / f"level_{k:02d}" / "evaluations")
        shutil.rmtree(out / f"level_{k:02d}" / "best_run", ignore_errors=True)
    calls.clear()
    again = run_front(problem, out, evaluate=counted, progress=False)
    assert again["start_run"] == first["start_run"]
    assert again["front"] == first["front"]
    # each level re-runs its best gait (and its held-out points: none here); the start once
    start = {"R_deg.fl.yaw": 20.0, "Phi_prime_deg.fl.fr": first["start"]["Phi_prime_deg.fl.fr"]}
    assert calls.count(start) == 1 and len(calls) == 3 + 1, calls
