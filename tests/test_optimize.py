"""manta-drake optimize: the spec's checks, free entries to gaits, the cost, CMA-ES through
the run loop on a real Dask cluster (a cheap quadratic with a known minimum injected as the
evaluator), restarts, failed candidates, a tiny real optimisation of a shipped spec and the
command against a separately started scheduler and worker."""

import csv
import io
import json
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml

from manta_drake.cli import main
from manta_drake.cluster import dask_client
from manta_drake.config_io import short_repr
from manta_drake.control.gait_files import load_gait_file
from manta_drake.optimize import (
    METRICS,
    Constraint,
    Objective,
    OptimizeError,
    Term,
    aggregate,
    build_parameters,
    evaluation_key,
    joint_limit_margin_deg,
    load_problem,
    read_history,
    run_optimization,
    score,
    simulate_candidate,
)
from manta_drake.optimize.evaluate import worker_name
from manta_drake.optimize.parameters import (
    ParameterSpace,
    candidate_gait_text,
    parse_entry,
)
from manta_drake.optimize.spec import FreeEntry
from manta_drake.scenario import load_scenario
from manta_drake.simulate import run
from manta_drake.sweep.config import SweepError

REPO = pathlib.Path(__file__).resolve().parents[1]
SHIPPED = sorted((REPO / "diagrams" / "optimize").glob("*.yaml"))
FRONTS = sorted((REPO / "diagrams" / "optimize" / "fronts").glob("*.yaml"))
VENV_BIN = pathlib.Path(sys.executable).parent

# A spec over the walk: the four yaw amplitudes tied (the right fins' with sign -1, as the
# walk has them: 20, -20, 20, -20) and one layer-2 phase bias (its partner follows as the
# negative). The quadratic's minimum (TARGET) is inside the bounds and away from the start
# (20, 270).
QUADRATIC_SPEC = """\
scenario: locomotion_walk
gait: walk
name: quadratic
free:
  - {entry: "R_deg[fl, yaw]", low: 0, high: 30,
     tie: ["R_deg[fr, yaw]", "R_deg[rl, yaw]", "R_deg[rr, yaw]"], tie_signs: [-1, 1, -1]}
  - {entry: "Phi_prime_deg[fl, fr]", low: 180, high: 360}
objective:
  terms: [{metric: u, weight: -1.0}]
robustness:
  points: [{}, {contact.friction: 0.6}]
budget: {generations: 3, population: 6, sigma0: 0.3}
seed: 3
"""
TARGET = {"R_deg.fl.yaw": 7.5, "Phi_prime_deg.fl.fr": 300.0}
WIDTH = {"R_deg.fl.yaw": 30.0, "Phi_prime_deg.fl.fr": 180.0}


def quadratic(task, fail_above=None, raise_below=None):
    """The cheap evaluator: u = -sum(((x - target) / width)^2), the same at every point;
    status failed above ``fail_above`` (yaw amplitude), a raise below ``raise_below``
    (phase)."""
    x = task["parameters"]
    if raise_below is not None and x["Phi_prime_deg.fl.fr"] < raise_below:
        raise ValueError(f"phase {x['Phi_prime_deg.fl.fr']:.1f} below {raise_below}")
    if fail_above is not None and x["R_deg.fl.yaw"] > fail_above:
        return {
            "status": "failed",
            "reason": "simulation failed at t = 0.5 s: diverged",
            "metrics": {},
            "worker": worker_name(),
        }
    u = -sum(((x[k] - TARGET[k]) / WIDTH[k]) ** 2 for k in TARGET)
    return {
        "status": "ok",
        "metrics": {"u": u},
        "worker": worker_name(),
        "wall_time_s": time.time(),
    }  # a stamp: a row simulated again would differ


def quadratic_evaluator(**kwargs):
    """A closure (pickled by value to the workers, which cannot import this module)."""

    def evaluate(task):
        return quadratic(task, **kwargs)

    return evaluate


def write(path: pathlib.Path, text: str) -> pathlib.Path:
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def client():
    """A real LocalCluster of two worker processes (the cluster helper's --workers 2)."""
    with dask_client(workers=2) as c:
        yield c


# --- the spec ---------------------------------------------------------------------------------

BASE = """\
scenario: locomotion_walk
gait: walk
free:
  - {entry: "R_deg[fl, pitch]", low: 0, high: 30}
objective:
  terms: [{metric: u, weight: -1.0}]
"""


@pytest.mark.slow
@pytest.mark.parametrize(
    "edit, message",
    [
        (
            lambda s: s + "budgit: {generations: 2}\n",
            "optimize.budgit: unknown key (a typo?); allowed keys: budget,",
        ),
        (
            lambda s: s.replace("R_deg[fl, pitch]", "R_deg[fx, pitch]"),
            "optimize.free[0].entry: 'R_deg[fx, pitch]': row 'fx' is not one of fl, fr, rl, rr",
        ),
        (
            lambda s: s.replace("R_deg[fl, pitch]", "R_deg[fl, twist]"),
            "optimize.free[0].entry: 'R_deg[fl, twist]': column 'twist' is not a joint",
        ),
        (
            lambda s: s.replace("R_deg[fl, pitch]", "R_deg fl pitch"),
            "optimize.free[0].entry: 'R_deg fl pitch' is not an entry; expected MATRIX[row, "
            "column]",
        ),
        (
            lambda s: s.replace("low: 0, high: 30", "low: 30, high: 0"),
            "optimize.free[0].low: 30.0 must be below high (0.0)",
        ),
        (
            lambda s: s.replace("low: 0, high: 30", "low: 20, high: 30"),
            "optimize.free[0].low: the start gait has R_deg[fl, pitch] = 15 deg, outside",
        ),
        (
            lambda s: s.replace("metric: u,", "metric: speeed,"),
            "optimize.objective.terms[0].metric: 'speeed' is not a metric; allowed: u, v,",
        ),
        (
            lambda s: s.replace("high: 30}", "high: 30, tie: ['R_deg[fl, pitch]']}"),
            "optimize.free[0].tie[0]: 'R_deg[fl, pitch]' is the entry itself",
        ),
        (
            lambda s: s.replace(
                "high: 30}", "high: 30, tie: ['R_deg[fr, pitch]'], tie_signs: [2]}"
            ),
            "optimize.free[0].tie_signs[0]: 2 is not +1 or -1",
        ),
        (
            lambda s: s.replace(
                '"R_deg[fl, pitch]", low: 0, high: 30',
                '"Phi_prime_deg[fl, fr]", low: 0, high: 300, tie: ["Phi_prime_deg[fr, fl]"]',
            ),
            (
                "optimize.free[0].tie: Phi_prime_deg[fr, fl] follows Phi_prime_deg[fl, fr] as its "
                "negative automatically"
            ),
        ),
        (
            lambda s: s.replace(
                "objective:",
                '  - {entry: "R_deg[rr, yaw]", low: -30, high: 0, '
                'tie: ["R_deg[fl, pitch]"]}\nobjective:',
            ),
            "optimize.free[1].tie: R_deg[fl, pitch] is already set by optimize.free[0]",
        ),
        (
            lambda s: s.replace(
                "high: 30}", "high: 30, tie: ['R_deg[fr, pitch]'], tie_signs: [-1]}"
            ),
            "optimize.free[0].tie[0]: the start gait has R_deg[fr, pitch] = 15 deg, not -1 x",
        ),
        (
            lambda s: s + "robustness: {points: [{contact.friction: -1}]}\n",
            "optimize.robustness.points[0]: contact.friction: -1.0 is outside the allowed range",
        ),
        (
            lambda s: s + "robustness: {points: [{random_seed: 4}]}\n",
            "optimize.robustness.points[0].random_seed: set by the optimiser",
        ),
        (
            lambda s: s.replace(
                "terms:", "constraints: [{metric: abs_v, min: 2, relative_to: abs_v}]\n  terms:"
            ),
            "optimize.objective.constraints[0].relative_to: 'abs_v' is the metric itself",
        ),
        (
            lambda s: s + "budget: {population: 1}\n",
            "optimize.budget.population: 1 is outside the allowed range [2, 10000]",
        ),
        (lambda s: s + "name: walk\n", "optimize.name: 'walk' is already a gait of the scenario"),
    ],
)
def test_spec_errors_are_one_line_naming_the_field(tmp_path, edit, message):
    path = write(tmp_path / "spec.yaml", edit(BASE))
    with pytest.raises(OptimizeError) as info:
        load_problem(path)
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith(f"{path}: {message}"), text


def test_cli_refuses_a_bad_spec_in_one_line_before_any_run(tmp_path, capsys):
    path = write(tmp_path / "spec.yaml", BASE.replace("R_deg[fl, pitch]", "R_deg[fx, pitch]"))
    assert main(["optimize", str(path), "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "optimize.free[0].entry" in err
    assert not (tmp_path / "o").exists()
    assert (
        main(
            [
                "optimize",
                str(write(tmp_path / "ok.yaml", BASE)),
                "--out",
                str(tmp_path / "o"),
                "--workers",
                "0",
                "--population",
                "1",
            ]
        )
        == 2
    )
    assert "--population: 1 is outside the allowed range [2, 10000]" in capsys.readouterr().err


@pytest.mark.slow
def test_every_shipped_spec_validates():
    names = {p.stem for p in SHIPPED}
    assert {"straight_swim", "true_crab", "fast_walk", "efficient_gait"} <= names
    for path in SHIPPED:
        problem = load_problem(path)
        assert problem.spec.name == path.stem
        assert problem.base.controller.mode == "gait"
        assert problem.space.outside_bounds() == []
    assert {p.stem for p in FRONTS} == {"walk", "trot", "swim", "crab"}
    for path in FRONTS:  # each family's front: its levels, its start the paper's gait
        problem = load_problem(path)
        assert problem.spec.front and problem.spec.gait == path.stem
        assert problem.space.outside_bounds() == [] and not problem.spec.objective.terms


# --- entries, ties and gaits ------------------------------------------------------------------


def test_parse_entry_rows_columns_and_phi_prime_legs():
    assert parse_entry("R_deg[fr, pitch]", "e") == ("R_deg", 1, 2)
    assert parse_entry(" X_deg[ rr ,yaw ] ", "e") == ("X_deg", 3, 0)
    assert parse_entry("Phi_prime_deg[rl, fl]", "e") == ("Phi_prime_deg", 2, 0)
    with pytest.raises(OptimizeError, match="column 'pitch' is not a leg-fin"):
        parse_entry("Phi_prime_deg[fl, pitch]", "e")
    with pytest.raises(OptimizeError, match="roll2 column is unused"):
        parse_entry("Phi_deg[fl, roll2]", "e")


def test_ties_signs_and_phi_prime_antisymmetry_set_the_gait():
    """Each parameter sets its entry, its ties times their signs and the transposed
    Phi_prime entries as negatives; everything else stays the start gait's to the bit."""
    start = load_scenario("locomotion_walk").gait("walk")  # R yaw 20, -20, 20, -20
    params = build_parameters(
        [
            FreeEntry("R_deg[fl, yaw]", 0, 30, ["R_deg[fr, yaw]", "R_deg[rl, yaw]"], [-1, 1]),
            FreeEntry("Phi_prime_deg[fl, rl]", 0, 360, ["Phi_prime_deg[fr, rr]"], [-1]),
        ]
    )
    space = ParameterSpace(params, start)
    np.testing.assert_array_equal(space.start_vector(), [20.0, 180.0])
    assert space.off_ties() == []
    gait = space.gait([12.0, 200.0])
    want_r = start.R.copy()
    want_r[0, 0], want_r[1, 0], want_r[2, 0] = np.radians([12.0, -12.0, 12.0])
    np.testing.assert_allclose(gait.R, want_r, rtol=0, atol=1e-15)
    assert gait.R[3, 0] == start.R[3, 0]  # rr not tied
    want_p = start.Phi_prime.copy()
    want_p[0, 2], want_p[2, 0] = np.radians([200.0, -200.0])
    want_p[1, 3], want_p[3, 1] = np.radians([-200.0, 200.0])
    np.testing.assert_allclose(gait.Phi_prime, want_p, rtol=0, atol=1e-15)
    assert np.array_equal(gait.X, start.X) and np.array_equal(gait.Phi, start.Phi)
    # RMS over the seven entries set: three yaw amplitudes 8 deg each, four phases 20 deg.
    assert space.distance_from_start([12.0, 200.0]) == pytest.approx(
        math.sqrt((3 * 8**2 + 4 * 20**2) / 7)
    )
    same = space.gait(space.start_vector())
    assert all(
        np.array_equal(getattr(same, f), getattr(start, f)) for f in ("R", "X", "Phi", "Phi_prime")
    )
    # A tie the start gait is not on (fr's yaw is -20, not +20) cannot start there.
    off = ParameterSpace(
        build_parameters([FreeEntry("R_deg[fl, yaw]", 0, 30, ["R_deg[fr, yaw]"])]), start
    )
    message = (
        "the start gait has R_deg[fr, yaw] = -20 deg, not +1 x R_deg[fl, yaw] = 20 "
        "deg; the search could not start at the start gait"
    )
    assert off.off_ties() == [(0, "tie[0]", message)]


@pytest.mark.parametrize("reading", ["paper", "mirrored"])
def test_left_and_right_fins_may_be_free_separately(tmp_path, reading):
    """A left pair and a right pair of roll1 amplitudes as two parameters: the candidate's
    gait file runs them as written under either reading (the mirrored reading would
    otherwise copy each left fin's R row to its right partner)."""
    start = load_scenario("locomotion_crab").gait("crab")
    space = ParameterSpace(
        build_parameters(
            [
                FreeEntry("R_deg[fl, roll1]", 0, 30, ["R_deg[rl, roll1]"]),
                FreeEntry("R_deg[fr, roll1]", 0, 30, ["R_deg[rr, roll1]"]),
            ]
        ),
        start,
    )
    path = write(tmp_path / "gait.yaml", candidate_gait_text("sided", space.gait([8.0, 22.0])))
    scenario = load_scenario(
        "locomotion_crab",
        overrides={
            "controller.gait_files": [str(path)],
            "controller.gait": "sided",
            "controller.gait_reading": reading,
        },
    )
    roll1 = np.degrees(scenario.gait("sided").R[:, 1])
    np.testing.assert_allclose(roll1, [8.0, 22.0, 8.0, 22.0], atol=1e-12)


# --- the cost ---------------------------------------------------------------------------------


def test_cost_terms_quadratic_penalties_wall_and_failures():
    o = Objective(
        terms=[Term("abs_v", -1.0), Term("distance_from_start_gait", 0.01)],
        constraints=[
            Constraint("abs_v", min=2.0, relative_to="abs_u", scale=0.01),
            Constraint("abs_yaw_rate", max=1.0),
        ],
        penalty_weight=100.0,
        wall_cost=50.0,
        failed_cost=1e6,
    )
    values = {"abs_v": 0.03, "abs_u": 0.02, "abs_yaw_rate": 1.5, "distance_from_start_gait": 4.0}
    s = score(o, "ok", values)
    # -0.03 + 0.04; |v| >= 2|u| short by 0.01 (scale 0.01): 100; yaw over by 0.5 (scale 1): 25
    assert s.objective == pytest.approx(0.01)
    assert s.penalty == pytest.approx(100.0 + 25.0)
    assert s.cost == pytest.approx(125.01)
    assert "abs_v 0.03 < 2 abs_u" in s.reason and "abs_yaw_rate 1.5 > 1" in s.reason
    assert score(o, "ok", values, touched_wall=True).cost == pytest.approx(175.01)
    assert score(o, "failed", values, reason="diverged").cost == 1e6
    missing = score(o, "ok", {**values, "abs_u": None})
    assert missing.cost == 1e6 and "no value of abs_u" in missing.reason
    assert aggregate([1.0, 3.0, 8.0], "mean") == 4.0
    assert aggregate([1.0, 3.0, 8.0], "worst") == 8.0


def test_joint_limit_margin_counts_measured_and_commanded_angles():
    limits = np.array([[-1.0, 1.0], [-0.5, 2.0]])
    log = {
        "joint_angles": np.array([[0.2, 0.0], [0.9, 1.0]]),
        "commanded_joint_angles": np.array([[0.0, 1.9], [0.0, 0.0]]),
    }
    # measured: 1 - 0.9 = 0.1; commanded: 2.0 - 1.9 = 0.1 ... the smallest of all is 0.1
    assert joint_limit_margin_deg(log, limits) == pytest.approx(math.degrees(0.1))
    log["commanded_joint_angles"][0, 0] = 1.2  # beyond the limit: negative
    assert joint_limit_margin_deg(log, limits) == pytest.approx(math.degrees(-0.2))


def test_evaluation_key_is_what_defines_a_simulation():
    k = evaluation_key("abc", ["a", "b"], [1.0, 2.0], {"x": 1, "y": 2}, 0)
    assert k == evaluation_key("abc", ["a", "b"], [1.0 + 1e-14, 2.0], {"y": 2, "x": 1}, 0)
    assert k != evaluation_key("abc", ["a", "b"], [1.0, 2.0], {"x": 1, "y": 2}, 1)
    assert k != evaluation_key("abd", ["a", "b"], [1.0, 2.0], {"x": 1, "y": 2}, 0)
    assert k != evaluation_key("abc", ["a", "b"], [1.0, 2.001], {"x": 1, "y": 2}, 0)


def test_a_candidate_the_scenario_refuses_is_a_result_not_a_raise(tmp_path):
    """X free: each run starts in the candidate's stance; one that puts the fins into the
    floor is refused by the scenario's start-pose check, before anything is built."""
    text = BASE.replace("R_deg[fl, pitch]", "X_deg[fl, roll1]").replace(
        "low: 0, high: 30", "low: -90, high: 0"
    )
    problem = load_problem(write(tmp_path / "s.yaml", text))
    assert problem.set_stance
    space = problem.space
    gait = space.gait([-90.0])
    task = {
        "key": "k",
        "scenario_yaml": problem.base_yaml,
        "gait_name": problem.spec.name,
        "gait_text": candidate_gait_text(problem.spec.name, gait),
        "overrides": {},
        "seed": 0,
        "set_stance": True,
        "keep_log": False,
        "parameters": {},
    }
    out = simulate_candidate(task)
    assert out["status"] == "refused"
    assert out["reason"].startswith("initial_pose:"), out["reason"]


# --- the search on a cluster ------------------------------------------------------------------


@pytest.mark.slow
def test_cma_es_finds_the_known_minimum_on_a_local_cluster(tmp_path, client):
    spec = write(tmp_path / "quadratic.yaml", QUADRATIC_SPEC)
    problem = load_problem(spec, generations=25, population=8)
    result = run_optimization(
        problem, tmp_path / "out", client=client, evaluate=quadratic_evaluator(), progress=False
    )
    best = dict(zip(result.names, result.best_degrees))
    assert best["R_deg.fl.yaw"] == pytest.approx(7.5, abs=0.3)
    assert best["Phi_prime_deg.fl.fr"] == pytest.approx(300.0, abs=2.0)
    assert result.best_cost < 1e-3 < result.start_cost
    # The start cost is the start gait's: ((20 - 7.5) / 30)^2 + ((270 - 300) / 180)^2.
    assert result.start_cost == pytest.approx((12.5 / 30) ** 2 + (1 / 6) ** 2)
    rows = read_history(tmp_path / "out" / "history.csv")
    search = [r for r in rows if r["kind"] == "search"]
    assert len(search) == 25 * 8 * 2
    workers = set(client.scheduler_info()["workers"])
    assert {r["worker"] for r in search} <= workers and len({r["worker"] for r in search}) == 2
    # The gait file holds the best gait: ties with their signs, Phi' antisymmetric.
    entry = load_gait_file(tmp_path / "out" / "best_gait.yaml")["quadratic"]
    yaw, phase = np.radians(best["R_deg.fl.yaw"]), np.radians(best["Phi_prime_deg.fl.fr"])
    np.testing.assert_allclose(entry.matrices["R"][:, 0], [yaw, -yaw, yaw, -yaw], atol=1e-10)
    np.testing.assert_allclose(
        [entry.matrices["Phi_prime"][0, 1], entry.matrices["Phi_prime"][1, 0]],
        [phase, -phase],
        atol=1e-10,
    )
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["best"]["cost"] == result.best_cost and summary["evaluations"] == 400
    assert (tmp_path / "out" / "convergence.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_restart_reuses_done_generations_and_an_interrupted_one(tmp_path):
    """2 generations, then the same folder with --generations 3: only generation 3 runs.
    Then a run interrupted inside generation 3 and restarted: the simulations done before
    the interrupt are reused, and the history equals the uninterrupted run's."""
    spec = write(tmp_path / "quadratic.yaml", QUADRATIC_SPEC)
    out = tmp_path / "out"
    first = run_optimization(
        load_problem(spec, generations=2), out, evaluate=quadratic_evaluator(), progress=False
    )
    assert first.simulated == 2 * 6 * 2 + 1  # the search, then the best gait's re-run
    rows2 = {r["key"]: r for r in read_history(out / "history.csv") if r["kind"] == "search"}
    second = run_optimization(
        load_problem(spec, generations=3), out, evaluate=quadratic_evaluator(), progress=False
    )
    assert second.simulated == 6 * 2 + 1 and second.reused == 0
    rows3 = [r for r in read_history(out / "history.csv") if r["kind"] == "search"]
    assert sorted({r["generation"] for r in rows3}) == [1, 2, 3]
    assert len(rows3) == 3 * 6 * 2
    for r in rows3:  # generations 1-2 not simulated again: their rows (and stamps) unchanged
        if r["generation"] <= 2:
            assert r == rows2[r["key"]]

    calls = []

    def interrupting(task):
        calls.append(1)
        if len(calls) == 2 * 6 * 2 + 5:
            raise KeyboardInterrupt
        return quadratic(task)

    broken = tmp_path / "broken"
    with pytest.raises(KeyboardInterrupt):
        run_optimization(
            load_problem(spec, generations=3), broken, evaluate=interrupting, progress=False
        )
    partial = read_history(broken / "history.csv")
    assert len(partial) == 2 * 6 * 2 + 4  # every finished simulation is in the table
    resumed = run_optimization(
        load_problem(spec, generations=3), broken, evaluate=quadratic_evaluator(), progress=False
    )
    assert resumed.reused == 4 and resumed.simulated == 6 * 2 - 4 + 1

    def place(path):
        return sorted(
            (
                r["generation"],
                r["candidate"],
                r["point"],
                r["R_deg.fl.yaw"],
                r["Phi_prime_deg.fl.fr"],
                r["cost"],
            )
            for r in read_history(path)
            if r["kind"] == "search"
        )

    assert place(broken / "history.csv") == place(out / "history.csv")
    np.testing.assert_array_equal(resumed.best_degrees, second.best_degrees)
    # The saved states (plain JSON: what CMA-ES was told) equal an uninterrupted run's.
    straight = tmp_path / "straight"
    run_optimization(
        load_problem(spec, generations=3), straight, evaluate=quadratic_evaluator(), progress=False
    )
    states = [json.loads((d / "state.json").read_text()) for d in (out, broken, straight)]
    assert len(states[2]["generations"]) == 3 and states[2]["pending"] is None
    for key in ("generations", "generator", "identity"):
        assert states[0][key] == states[1][key] == states[2][key], key
    assert place(straight / "history.csv") == place(out / "history.csv")
    assert not any((d / "state.pkl").exists() for d in (out, broken, straight))
    # Another population is another optimisation: refused, naming what differs.
    with pytest.raises(OptimizeError, match=r"different population \(6 there, 4 now\)"):
        run_optimization(
            load_problem(spec, population=4), out, evaluate=quadratic_evaluator(), progress=False
        )


@pytest.mark.slow
def test_failed_and_raising_candidates_are_penalised_rows(tmp_path, client):
    """Above 22 deg of yaw amplitude the evaluator returns status failed, below 240 deg of
    phase it raises: each such simulation is a row with its reason and the objective's
    failed_cost, and the search completes with a best outside both regions."""
    spec = write(tmp_path / "quadratic.yaml", QUADRATIC_SPEC.replace("sigma0: 0.3", "sigma0: 0.6"))
    result = run_optimization(
        load_problem(spec, generations=4),
        tmp_path / "out",
        client=client,
        progress=False,
        evaluate=quadratic_evaluator(fail_above=22.0, raise_below=240.0),
    )
    rows = [r for r in read_history(tmp_path / "out" / "history.csv") if r["kind"] == "search"]
    failed = [r for r in rows if r["R_deg.fl.yaw"] > 22 and r["Phi_prime_deg.fl.fr"] >= 240]
    raised = [r for r in rows if r["Phi_prime_deg.fl.fr"] < 240]
    assert failed and raised
    for r in failed:
        assert r["status"] == "failed" and r["reason"].endswith("diverged")
        assert r["cost"] == 1e6
    for r in raised:
        assert r["status"] == "error" and r["reason"].startswith("ValueError: phase")
        assert r["reason"].endswith("below 240.0")
        assert r["cost"] == 1e6
    assert all(r["status"] == "ok" for r in rows if r not in failed and r not in raised)
    assert result.best_ok and result.best_cost < 1e6
    best = dict(zip(result.names, result.best_degrees))
    assert best["R_deg.fl.yaw"] <= 22 and best["Phi_prime_deg.fl.fr"] >= 240
    assert result.generations == 4


@pytest.mark.slow
def test_runs_without_the_objectives_metric_give_no_gait(tmp_path):
    """Every simulation runs but gives no u (as a run too short for a steady window does):
    each is `unscored` at failed_cost, and no gait file is written."""
    spec = write(tmp_path / "quadratic.yaml", QUADRATIC_SPEC)
    (tmp_path / "out").mkdir()
    write(tmp_path / "out" / "best_gait.yaml", "an earlier run's\n")

    def no_u(task):
        return {"status": "ok", "metrics": {"v": 0.01}}

    result = run_optimization(
        load_problem(spec, generations=1), tmp_path / "out", evaluate=no_u, progress=False
    )
    rows = read_history(tmp_path / "out" / "history.csv")
    assert {r["status"] for r in rows} == {"unscored"}
    assert {r["reason"] for r in rows} == {"no value of u"}
    assert {r["cost"] for r in rows} == {1e6}
    assert not result.best_ok and result.best_gait_file is None
    assert not (tmp_path / "out" / "best_gait.yaml").exists()


@pytest.mark.slow
@pytest.mark.parametrize("bound, status, code", [(0.5, "infeasible", 3), (-10.0, "ok", 0)])
def test_an_infeasible_best_is_marked_everywhere_and_each_generation_is_a_line(
    tmp_path, capsys, monkeypatch, bound, status, code
):
    """u <= 0 everywhere (the quadratic), so `u >= 0.5` is broken by every candidate: the
    best gait is still written, but marked infeasible in its provenance, summary.json, the
    console and the exit status 3; `u >= -10` is met everywhere: status ok, exit 0."""
    import manta_drake.optimize.cli as cli

    spec = write(
        tmp_path / "quadratic.yaml",
        QUADRATIC_SPEC.replace(
            "  terms: [{metric: u, weight: -1.0}]\n",
            f"  terms: [{{metric: u, weight: -1.0}}]\n  constraints: [{{metric: u, min: "
            f"{bound}}}]\n",
        ),
    )
    monkeypatch.setattr(
        cli,
        "run_optimization",
        lambda problem, out, client, progress: run_optimization(
            problem, out, client, evaluate=quadratic_evaluator(), progress=progress
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
                "2",
            ]
        )
        == code
    )
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.startswith("generation ")]
    assert [x.split(":")[0] for x in lines] == ["generation 1/2", "generation 2/2"]
    within = "0/6" if status == "infeasible" else "6/6"
    assert all(f"{within} candidates within every constraint" in x for x in lines), lines
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == status and summary["best"]["feasible"] == (status == "ok")
    gait_text = (out / "best_gait.yaml").read_text()
    assert set(load_gait_file(out / "best_gait.yaml")) == {"quadratic"}  # a gait file
    provenance = yaml.safe_load(gait_text)["provenance"]
    if status == "infeasible":
        # the best candidate's 2 search points and its re-run, each below the bound
        assert len(summary["violations"]) == 3
        assert all("u -" in v and "< 0.5" in v for v in summary["violations"])
        assert "INFEASIBLE" in gait_text and provenance["feasible"] is False
        assert provenance["violations"] == summary["violations"]
        assert "manta-drake: optimize quadratic: INFEASIBLE: the best gait breaks" in err
    else:
        assert summary["violations"] == [] and provenance["feasible"] is True
        assert "INFEASIBLE" not in gait_text + err


# --- what a restart reads back: state.json, history.csv, never a pickle ------------------------


class _Planted:
    """A pickle whose loading creates ``marker`` (what a planted state.pkl could do)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _counting():
    calls = []

    def evaluate(task):
        calls.append(task["key"])
        return quadratic(task)

    return evaluate, calls


@pytest.mark.slow
def test_a_planted_state_pkl_is_refused_and_never_unpickled(tmp_path, capsys):
    import pickle

    payload = pickle.dumps(_Planted(tmp_path / "proof"))
    pickle.loads(payload)  # the payload is live: loading it runs its code
    assert (tmp_path / "proof").is_file()
    marker = tmp_path / "marker"
    out = tmp_path / "out"
    out.mkdir()
    (out / "state.pkl").write_bytes(pickle.dumps(_Planted(marker)))
    spec = write(tmp_path / "quadratic.yaml", QUADRATIC_SPEC)
    assert main(["optimize", str(spec), "--out", str(out), "--workers", "0", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert (
        f"{out / 'state.pkl'} is the restart state of an earlier version, a pickle, and "
        "is no longer read (unpickling runs whatever code the file names" in err
    )
    evaluate, calls = _counting()
    with pytest.raises(OptimizeError, match="no longer read"):
        run_optimization(load_problem(spec, generations=1), out, evaluate=evaluate, progress=False)
    assert not marker.exists() and calls == []
    assert sorted(p.name for p in out.iterdir()) == ["state.pkl"]  # nothing simulated


@pytest.mark.slow
def test_a_search_without_its_state_asks_again_what_the_table_holds(tmp_path):
    """The advice of the refusal above: with the state deleted, the search starts again,
    asks the same candidates and simulates none the table holds."""
    spec = write(tmp_path / "quadratic.yaml", QUADRATIC_SPEC)
    out = tmp_path / "out"
    run_optimization(
        load_problem(spec, generations=2), out, evaluate=quadratic_evaluator(), progress=False
    )
    (out / "state.json").unlink()
    again = run_optimization(
        load_problem(spec, generations=2), out, evaluate=quadratic_evaluator(), progress=False
    )
    assert again.reused == 2 * 6 * 2 and again.simulated == 1  # the best gait's re-run only


@pytest.fixture(scope="module")
def one_generation(tmp_path_factory):
    """A finished one-generation search of the quadratic: its folder's files."""
    folder = tmp_path_factory.mktemp("one")
    spec = write(folder / "quadratic.yaml", QUADRATIC_SPEC)
    run_optimization(
        load_problem(spec, generations=1),
        folder / "out",
        evaluate=quadratic_evaluator(),
        progress=False,
    )
    return {
        "spec": QUADRATIC_SPEC,
        "state": (folder / "out" / "state.json").read_text(),
        "history": (folder / "out" / "history.csv").read_text(),
    }


def _edit_state(edit):
    def apply(text):
        data = json.loads(text)
        edit(data)
        return json.dumps(data)

    return apply


def _first_candidate_nudged(data):
    x = data["generations"][0]["candidates"][1]
    x[0] = float(np.nextafter(x[0], 2.0))  # one bit


@pytest.mark.slow
@pytest.mark.parametrize(
    "make, message",
    [
        (lambda t: t[: len(t) // 2], "not an optimisation state (not JSON: "),
        (lambda t: "[1, 2]", "not an optimisation state this version writes (its root is a list"),
        (_edit_state(lambda d: d.update(format=1)), "(format 1; this version writes 2)"),
        (_edit_state(lambda d: d.update(kind="pickle")), "(kind 'pickle', not "),
        (_edit_state(lambda d: d.update(extra=1)), "(unknown key 'extra')"),
        (_edit_state(lambda d: d.pop("generator")), "(no generator)"),
        (
            _edit_state(lambda d: d["generations"][0]["candidates"].pop()),
            "(generations[0].candidates is not 6 lists of 2 finite numbers)",
        ),
        (
            _edit_state(lambda d: d["generations"][0]["costs"].__setitem__(0, "cheap")),
            "(generations[0].costs is not a list of 6 numbers)",
        ),
        (
            _edit_state(lambda d: d.update(timings=[{"generation": 1}])),
            "(timings[0] is not {generation, wall_s,",
        ),
        (_edit_state(lambda d: d.update(wall_time_s=-1)), "(wall_time_s -1 is not a time >= 0)"),
        (
            _edit_state(lambda d: d["identity"].update(population=8)),
            "holds an optimisation of another spec or options (different population (8 there, ",
        ),
        (
            _edit_state(_first_candidate_nudged),
            "does not replay: generation 1's candidates differ from the saved ones (written with "
            "cma ",
        ),
        (
            _edit_state(lambda d: d["generator"]["state"].update(state=1)),
            "does not replay: the normal generator ends in another state than the saved one",
        ),
    ],
)
def test_a_bad_state_json_is_refused_in_one_line_before_any_simulation(
    tmp_path, one_generation, make, message
):
    out = tmp_path / "out"
    out.mkdir()
    write(out / "state.json", make(one_generation["state"]))
    write(out / "history.csv", one_generation["history"])
    spec = write(tmp_path / "quadratic.yaml", one_generation["spec"])
    evaluate, calls = _counting()
    with pytest.raises(OptimizeError) as info:
        run_optimization(load_problem(spec, generations=2), out, evaluate=evaluate, progress=False)
    text = str(info.value)
    assert "\n" not in text and message in text, text
    assert str(out) in text
    assert calls == [] and not (out / "evaluations" / "g0002").exists()


@pytest.mark.slow
def test_a_state_json_too_large_or_not_a_file_is_never_read(tmp_path, one_generation):
    from manta_drake.optimize.state import state_limit

    spec = write(tmp_path / "quadratic.yaml", one_generation["spec"])
    problem = load_problem(spec, generations=2)
    out = tmp_path / "out"
    out.mkdir()
    limit = state_limit(problem)
    assert limit < 16 << 20  # the bound of this small spec
    with open(out / "state.json", "wb") as f:
        f.truncate(limit + 1)  # sparse: never read
    with pytest.raises(
        OptimizeError,
        match=rf"state.json: {limit + 1} bytes, more than the "
        rf"{limit} a state of this spec takes",
    ):
        run_optimization(problem, out, evaluate=quadratic_evaluator(), progress=False)
    (out / "state.json").unlink()
    os.mkfifo(out / "state.json")  # opening it would block: refused unopened
    with pytest.raises(SweepError, match=f"--out {out}: {out / 'state.json'} is a "):
        run_optimization(problem, out, evaluate=quadratic_evaluator(), progress=False)


def _history_with(text: str, line: int, column: str, value: str) -> str:
    rows = list(csv.reader(io.StringIO(text)))
    rows[line - 1][rows[0].index(column)] = value
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerows(rows)
    return buffer.getvalue()


@pytest.mark.slow
@pytest.mark.parametrize(
    "column, value, message",
    [
        (
            "folder",
            "../../victim",
            "line 2: folder '../../victim' is not "
            "'evaluations/g0001/c000-p0-s0', the folder of its place",
        ),
        ("cost", "cheap", "line 2: cost 'cheap' is not valid"),
        ("generation", "-1", "line 2: generation '-1' is not valid (a negative integer)"),
        ("kind", "mine", "line 2: kind 'mine' is not one of search, best, held_out"),
        ("key", "../x", "line 2: key '../x' is not 16 hex digits"),
    ],
)
def test_a_bad_history_row_is_refused_and_no_file_outside_is_touched(
    tmp_path, one_generation, column, value, message
):
    """The search deletes logs in the folders the table names: a planted row must not make
    it delete one outside the output folder."""
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "log.npz").write_bytes(b"a user's log")
    out = tmp_path / "a" / "out"
    out.mkdir(parents=True)
    write(out / "state.json", one_generation["state"])
    write(out / "history.csv", _history_with(one_generation["history"], 2, column, value))
    spec = write(tmp_path / "quadratic.yaml", one_generation["spec"])
    evaluate, calls = _counting()
    with pytest.raises(OptimizeError) as info:
        run_optimization(load_problem(spec, generations=2), out, evaluate=evaluate, progress=False)
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"{out / 'history.csv'}: {message}"), text
    assert calls == [] and (victim / "log.npz").read_bytes() == b"a user's log"


@pytest.mark.slow
def test_a_history_too_large_is_refused_unread(tmp_path, one_generation):
    from manta_drake.optimize.run import history_limit

    spec = write(tmp_path / "quadratic.yaml", one_generation["spec"])
    problem = load_problem(spec, generations=2)
    out = tmp_path / "out"
    out.mkdir()
    limit = history_limit(problem, 1)
    with open(out / "history.csv", "wb") as f:
        f.truncate(limit + 1)
    with pytest.raises(
        OptimizeError,
        match=rf"history.csv: {limit + 1} bytes, more than the "
        rf"{limit} this spec's search writes",
    ):
        run_optimization(problem, out, evaluate=quadratic_evaluator(), progress=False)


# --- budgets and scenarios refused at load ------------------------------------------------------


@pytest.mark.parametrize(
    "budget, message",
    [
        (
            "{duration: 1.5, steady_after: 1.0}",
            "optimize.budget: duration 1.5 s and steady_after 1 s: the run is under twice "
            "steady_after, so the objective's u would be averaged from half the run, 0.75 s, "
            "before "
            "the settling steady_after assumes; set duration to at least 2 s (or lower "
            "steady_after)",
        ),
        (
            "{duration: 1.2, steady_after: 0.5}",
            "optimize.budget: duration 1.2 s and steady_after 0.5 s leave a steady window of "
            "0.7 s, "
            "under the 1 s the objective's u needs: every simulation would be unscored; set "
            "duration to at least 2 s",
        ),
        (
            "{duration: 1.5}",
            "optimize.budget: duration 1.5 s and steady_after 6 s (the scenario's): the run is "
            "under twice steady_after",
        ),
        (
            "{duration: 8.0, steady_after: 5.0}",  # a 3 s window, but from 4 s, not 5 s
            "optimize.budget: duration 8 s and steady_after 5 s: the run is under twice "
            "steady_after, so the objective's u would be averaged from half the run, 4 s, before "
            "the settling steady_after assumes; set duration to at least 10 s",
        ),
    ],
)
def test_a_budget_without_a_steady_window_is_refused_before_any_simulation(
    tmp_path, capsys, budget, message
):
    from manta_drake.simulate import MIN_STEADY_WINDOW

    assert MIN_STEADY_WINDOW == 1.0  # the window the messages above quote
    spec = write(tmp_path / "spec.yaml", BASE + f"budget: {budget}\n")
    out = tmp_path / "out"
    start = time.perf_counter()
    assert main(["optimize", str(spec), "--out", str(out), "--workers", "0", "--quiet"]) == 2
    assert time.perf_counter() - start < 20  # refused at load: not one simulation
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"{spec}: {message}" in err, err
    assert not out.exists()


def test_a_steady_window_of_exactly_the_minimum_and_an_objective_without_one_pass(tmp_path):
    """duration 2 s after steady_after 1 s: the window is 1 s from steady_after; an
    objective of power alone needs no window at all."""
    ok = write(tmp_path / "ok.yaml", BASE + "budget: {duration: 2.0, steady_after: 1.0}\n")
    assert load_problem(ok).base.duration == 2.0
    power = write(
        tmp_path / "power.yaml",
        BASE.replace("metric: u,", "metric: mean_power_w,") + "budget: {duration: 0.5}\n",
    )
    assert load_problem(power).base.duration == 0.5


def _relative(target: pathlib.Path, folder: pathlib.Path) -> str:
    return os.path.relpath(target, folder)


@pytest.mark.parametrize(
    "make, message",
    [
        (
            lambda d: _relative(pathlib.Path("/etc/passwd"), d),
            "({}) is not a scenario file: the scenario file's root must be a mapping, got str",
        ),
        (
            lambda d: write(d / "broken.yaml", "duration: [\n").name,
            "({}) is not a scenario file: not valid YAML: ",
        ),
        (
            lambda d: write(d / "bad.yaml", "duration: -1\n").name,
            "({}): duration: -1.0 is outside the allowed range (0, 3600] s",
        ),
        (
            lambda d: "no_such_scenario",
            "is neither a file (relative to {}) nor a shipped scenario; shipped scenarios: ",
        ),
        (lambda d: "x" * 5000, "is not a path ("),
    ],
)
def test_the_scenario_line_names_the_spec_and_scenario_and_what_is_wrong(
    tmp_path, capsys, make, message
):
    if not pathlib.Path("/etc/passwd").is_file():
        pytest.skip("no /etc/passwd")
    folder = tmp_path / "a" / "b"
    folder.mkdir(parents=True)
    scenario = make(folder)
    spec = write(
        folder / "spec.yaml",
        BASE.replace("locomotion_walk", scenario) + "budget: {duration: 3.0}\n",
    )  # overrides present: not blamed
    assert main(["optimize", str(spec), "--out", str(tmp_path / "out"), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    named = f"{spec}: optimize.scenario: {short_repr(scenario)} "
    resolved = (folder / scenario).resolve() if "neither" not in message else folder
    assert named + message.format(resolved) in err, err
    assert "overrides, --set or budget" not in err and len(err) < 600


# --- real simulations ---------------------------------------------------------------------------


@pytest.mark.slow
def test_tiny_real_run_of_a_shipped_spec(tmp_path, capsys):
    """straight_swim with 4 candidates, 1 generation, 2 s simulations on --workers 2."""
    spec = REPO / "diagrams" / "optimize" / "straight_swim.yaml"
    out = tmp_path / "out"
    start = time.perf_counter()
    code = main(
        [
            "optimize",
            str(spec),
            "--out",
            str(out),
            "--workers",
            "2",
            "--population",
            "4",
            "--generations",
            "1",
            "--duration",
            "2",
            "--steady-after",
            "1",
            "--quiet",
        ]
    )
    wall = time.perf_counter() - start
    summary = json.loads((out / "summary.json").read_text())
    # 2 s runs rarely meet the spec's constraints: written either way, the status says which
    assert code == {"ok": 0, "infeasible": 3}[summary["status"]], capsys.readouterr().err
    problem = load_problem(spec)
    n_points = len(problem.spec.points())
    rows = read_history(out / "history.csv")
    search = [r for r in rows if r["kind"] == "search"]
    assert len(search) == 4 * n_points
    assert all(r["status"] == "ok" for r in rows), [r["reason"] for r in rows]
    assert all(r["u"] is not None and r["abs_yaw_rate"] is not None for r in rows)
    start_rows = [r for r in search if r["candidate"] == 0]
    assert all(r["distance_from_start_gait"] == 0.0 for r in start_rows)  # the start gait
    assert {r["kind"] for r in rows} == {"search", "best", "held_out"}
    # The logs of the best candidate only.
    logs = sorted(p.parent.name for p in (out / "evaluations").rglob("log.npz"))
    summary = json.loads((out / "summary.json").read_text())
    c = summary["best"]["candidate"]
    assert logs == [f"c{c:03d}-p{p}-s0" for p in range(n_points)]
    for name in ("joints.png", "trajectory.png", "log.npz", "metrics.json", "gait.yaml"):
        assert (out / "best_run" / name).is_file()
    assert (out / "convergence.png").read_bytes()[:4] == b"\x89PNG"
    # best_gait.yaml: a gait file whose gait runs.
    gait_file = out / "best_gait.yaml"
    entries = load_gait_file(gait_file)
    assert list(entries) == ["straight_swim"]
    best = summary["best"]["degrees"]
    np.testing.assert_allclose(
        np.degrees(entries["straight_swim"].matrices["Phi_prime"][0, 1]),
        best["Phi_prime_deg.fl.fr"],
        atol=1e-8,
    )
    scenario = load_scenario(
        "locomotion_swim",
        overrides={
            "controller.gait_files": [str(gait_file)],
            "controller.gait": "straight_swim",
            "duration": 0.3,
            "visualization.meshcat": False,
        },
    )
    assert (
        run(scenario, tmp_path / "rerun", progress=False, write_outputs=False).metrics["status"]
        == "ok"
    )
    print(f"tiny straight_swim run: {wall:.1f} s")


@pytest.mark.slow
def test_the_command_against_a_running_scheduler(tmp_path, capsys):
    """A `dask scheduler` and one `dask worker --nthreads 1` on 127.0.0.1 (random ports),
    then `manta-drake optimize --scheduler`: every simulation ran on that worker."""
    scheduler_file = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(
            subprocess.Popen(
                [
                    str(VENV_BIN / "dask"),
                    "scheduler",
                    "--host",
                    "127.0.0.1",
                    "--port",
                    "0",
                    "--no-dashboard",
                    "--scheduler-file",
                    str(scheduler_file),
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
        deadline = time.monotonic() + 60
        while not scheduler_file.is_file() and time.monotonic() < deadline:
            time.sleep(0.2)
        time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        procs.append(
            subprocess.Popen(
                [
                    str(VENV_BIN / "dask"),
                    "worker",
                    address,
                    "--nthreads",
                    "1",
                    "--host",
                    "127.0.0.1",
                    "--no-dashboard",
                    "--name",
                    "opt-test-worker",
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                cwd=REPO,
            )
        )
        from distributed import Client

        with Client(address, timeout="30s") as c:
            c.wait_for_workers(1, timeout=60)
            worker_address = next(iter(c.scheduler_info()["workers"]))
        spec = write(
            tmp_path / "remote_walk.yaml", BASE + "budget: {duration: 2.0, steady_after: 1.0}\n"
        )
        code = main(
            [
                "optimize",
                str(spec),
                "--out",
                str(tmp_path / "out"),
                "--scheduler",
                address,
                "--population",
                "2",
                "--generations",
                "1",
                "--quiet",
            ]
        )
        assert code == 0, capsys.readouterr().err
        rows = read_history(tmp_path / "out" / "history.csv")
        assert len([r for r in rows if r["kind"] == "search"]) == 2
        assert {r["worker"] for r in rows} == {worker_address}
        assert all(r["status"] == "ok" and r["cost"] < 0 for r in rows)  # cost -u: it walks
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_metric_names_are_documented():
    text = (REPO / "docs" / "optimize.md").read_text()
    for name in METRICS:
        assert f"`{name}`" in text, name


@pytest.mark.slow
def test_provenance_names_the_spec_inside_the_checkout_relatively(tmp_path):
    """A shipped result's provenance must mean the same file on another machine."""
    from manta_drake.optimize.run import REPO, spec_path_text

    assert (
        spec_path_text(REPO / "diagrams" / "optimize" / "true_crab.yaml")
        == "diagrams/optimize/true_crab.yaml"
    )
    outside = tmp_path / "spec.yaml"
    assert spec_path_text(outside) == str(outside.resolve())


def test_a_window_a_wall_cuts_under_min_window_is_unscored(tmp_path):
    """budget.min_window: a run whose steady window ends near a wall before it is unscored,
    with where its window ended, and costs between failed_cost (no window) and half of it (a
    window just short), so the search ranks such runs by how long they kept off the walls;
    a full window is scored."""
    spec = write(
        tmp_path / "q.yaml",
        QUADRATIC_SPEC.replace(
            "budget: {generations: 3, population: 6, sigma0: 0.3}",
            "budget: {generations: 1, population: 6, sigma0: 0.3, duration: 20, "
            "steady_after: 6, min_window: 10}",
        ),
    )

    def near_wall(x: dict) -> float | None:  # 6-9 s below a lag of 270 deg, none above
        lag = x["Phi_prime_deg.fl.fr"]
        return 6.0 + 3.0 * (lag - 180.0) / 90.0 if lag < 270.0 else None

    def evaluate(task):
        out = quadratic(task)
        near = near_wall(task["parameters"])
        out["run"] = {"steady_window_s": [6.0, near or 20.0], "near_wall_at_s": near}
        return out

    run_optimization(load_problem(spec), tmp_path / "out", evaluate=evaluate, progress=False)
    rows = read_history(tmp_path / "out" / "history.csv")
    short = [r for r in rows if r["Phi_prime_deg.fl.fr"] < 270.0]
    full = [r for r in rows if r["Phi_prime_deg.fl.fr"] >= 270.0]
    assert short and full
    for r in short:
        near = near_wall(r)
        assert r["status"] == "unscored" and r["u"] is None
        assert r["cost"] == pytest.approx(1e6 * (1.0 - 0.5 * (near - 6.0) / 10.0))
        assert r["reason"] == (
            f"no value of u (steady window 6-{near:.3g} s ({near - 6:.3g} s, ending near a "
            f"wall at {near:.3g} s) is under budget.min_window 10 s)"
        )
    assert all(r["status"] == "ok" and r["u"] is not None and r["cost"] < 5e5 for r in full)


def test_a_short_window_costs_less_the_longer_it_is():
    from manta_drake.optimize.objective import short_window_cost

    assert short_window_cost(1e6, 0.0, 20.0) == 1e6
    assert short_window_cost(1e6, 10.0, 20.0) == 7.5e5
    assert short_window_cost(1e6, 19.999, 20.0) == pytest.approx(5e5, rel=1e-4)
    assert short_window_cost(1e6, 25.0, 20.0) == 5e5 and short_window_cost(1e6, -1, 20) == 1e6


@pytest.mark.parametrize(
    "budget, message",
    [
        (
            "{duration: 20, steady_after: 6, min_window: 15}",
            "optimize.budget.min_window: 15 is outside the allowed range [1, 14] s (at most "
            "the runs' steady window, duration 20 s from steady_after 6 s)",
        ),
        ("{duration: 20, steady_after: 6, min_window: 0.5}", "min_window: 0.5 is outside"),
        ("{min_window: -1}", "optimize.budget.min_window: -1 is outside the allowed range"),
    ],
)
def test_a_min_window_no_run_can_give_is_refused(tmp_path, budget, message):
    spec = write(
        tmp_path / "q.yaml",
        QUADRATIC_SPEC.replace(
            "budget: {generations: 3, population: 6, sigma0: 0.3}", f"budget: {budget}"
        ),
    )
    with pytest.raises(OptimizeError, match=re.escape(message)):
        load_problem(spec)


def test_a_spec_starts_from_a_gait_in_a_file_beside_it(tmp_path, monkeypatch):
    """`overrides: {controller.gait_files: [...]}` is relative to the spec's folder, not the
    working directory, and its gaits may be the start: the search starts at their values."""
    import dataclasses

    from manta_drake.control.gait_files import write_gait_file
    from manta_drake.model.robot_params import JOINTS, LEGS

    walk = load_scenario("locomotion_walk").gait("walk")
    R = np.array(walk.R)
    R[LEGS.index("fl"), JOINTS.index("pitch")] = np.radians(22.0)  # 15 deg in the walk
    (tmp_path / "specs" / "gaits").mkdir(parents=True)
    gait_file = tmp_path / "specs" / "gaits" / "start.yaml"
    write_gait_file(gait_file, {"steeper": dataclasses.replace(walk, R=R)})
    steeper = BASE.replace("gait: walk", "gait: steeper")
    files = "overrides: {controller.gait_files: [gaits/start.yaml]}\n"
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    spec = write(tmp_path / "specs" / "from_file.yaml", steeper + files)
    problem = load_problem(spec)
    np.testing.assert_allclose(problem.space.start_vector(), [22.0], atol=1e-9)
    # a restart's identity follows the gait file's content, not where the checkout is
    identity = problem.identity()
    shutil.copytree(tmp_path / "specs", tmp_path / "moved")
    assert load_problem(tmp_path / "moved" / "from_file.yaml").identity() == identity
    assert "22" in gait_file.read_text()
    gait_file.write_text(gait_file.read_text().replace("22", "23"))
    assert load_problem(spec).identity()["scenario"] != identity["scenario"]
    with pytest.raises(OptimizeError, match="'steeper' is not a gait of the scenario's library"):
        load_problem(write(tmp_path / "specs" / "without.yaml", steeper))
