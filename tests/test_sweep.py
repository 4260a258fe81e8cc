"""Sweeps (manta_drake.sweep): the file format, the pure helpers, and runs on a Dask
LocalCluster against the same runs in series."""

import hashlib
import json
import pathlib

import numpy as np
import pytest

from manta_drake import sweep as S
from manta_drake.model.coefficients import load_coefficients, scale_coefficients
from manta_drake.model.robot_params import DEFAULT_ROBOT, NUM_LEGS
from manta_drake.scenario import ScenarioError, load_scenario

ROOT = pathlib.Path(__file__).resolve().parent.parent
SWEEPS = ROOT / "diagrams" / "sweeps"
# Columns that measure the machine, not the simulation.
TIMING = ("wall_time_s", "real_time_factor")


def write(path: pathlib.Path, text: str) -> pathlib.Path:
    path.write_text(text)
    return path


# --- net weight ------------------------------------------------------------------------------

def test_hull_scale_for_net_weight_closed_form():
    # M = 8.4 kg, rho = 1000: W = M - rho (V_hull s^3 + V_other).
    s = S.hull_scale_for_net_weight(0.6, 8.4, 1000.0, 0.005, 0.0025)
    assert 8.4 - 1000.0 * (0.005 * s**3 + 0.0025) == pytest.approx(0.6, abs=1e-12)
    # Heavier robot, smaller hull; the current weight gives 1.
    assert S.hull_scale_for_net_weight(1.1, 8.4, 1000.0, 0.005, 0.0025) < s
    assert S.hull_scale_for_net_weight(0.9, 8.4, 1000.0, 0.005, 0.0025) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="net_weight_kg"):
        S.hull_scale_for_net_weight(6.0, 8.4, 1000.0, 0.005, 0.0025)  # no hull left
    with pytest.raises(ValueError, match="finite"):
        S.hull_scale_for_net_weight(float("nan"), 8.4, 1000.0, 0.005, 0.0025)


def _net_weight_by_hand(coeffs, robot=DEFAULT_ROBOT) -> float:
    """W = M - rho V with the sealed volume V added up from the robot's parts, apart from the
    water model: the hull ellipsoid 4/3 pi abc, two servo cases per leg-fin, and the two fin
    plates of each leg-fin (thickness x chord x span)."""
    a, b, c = coeffs.body.sealed_semi_axes.value
    hull = 4.0 / 3.0 * np.pi * a * b * c
    servos = 2 * NUM_LEGS * coeffs.links.servo_volume.value
    plates = NUM_LEGS * robot.fin_thickness * (robot.proximal_chord * robot.d3
                                               + robot.distal_chord * robot.dE)
    return robot.total_mass - coeffs.water_density.value * (hull + servos + plates)


@pytest.mark.parametrize("target", [0.6, 0.85, 1.1])
def test_net_weight_scales_give_the_target_weight_of_the_robots_volumes(target):
    coeffs = load_coefficients()
    assert _net_weight_by_hand(coeffs) == pytest.approx(0.844, abs=0.002)  # the shipped robot
    # The water model's volume elements hold the same volume as the parts.
    assert S.deflated_net_weight_kg(coeffs) == pytest.approx(_net_weight_by_hand(coeffs),
                                                             abs=1e-9)
    scales = S.net_weight_scales(target, coeffs)
    scaled = scale_coefficients(coeffs, scales)
    assert _net_weight_by_hand(scaled) == pytest.approx(target, abs=1e-9)
    # The hull keeps its shape (every semi-axis times s) and the documented sealed volume
    # stays the ellipsoid's (times s^3).
    s = scales["body.sealed_semi_axes"]
    np.testing.assert_allclose(scaled.body.sealed_semi_axes.value,
                               s * np.asarray(coeffs.body.sealed_semi_axes.value), rtol=1e-12)
    assert scales["body.sealed_volume"] == pytest.approx(s**3, rel=1e-12)
    a, b, c = scaled.body.sealed_semi_axes.value
    assert scaled.body.sealed_volume.value == pytest.approx(4 / 3 * np.pi * a * b * c, rel=1e-5)


def test_a_scale_of_the_sealed_volume_alone_is_refused():
    """It would change nothing (the buoyancy integrates the semi-axes): refused by name."""
    scenario = load_scenario("locomotion_swim")
    scenario.water.coefficient_scales = {"body.sealed_volume": 1.2}
    with pytest.raises(ScenarioError, match="body.sealed_volume = .* disagrees with "
                                            "body.sealed_semi_axes"):
        scenario.validate()


def test_net_weight_parameter_refuses_a_conflicting_scale():
    scenario = load_scenario("locomotion_swim")
    scenario.water.coefficient_scales = {"body.sealed_semi_axes": 1.1}
    with pytest.raises(ScenarioError, match="body.sealed_semi_axes"):
        S.apply_net_weight(scenario, 0.7)


# --- keys, ids, parameter sets ---------------------------------------------------------------

def test_set_override_dotted_keys_dicts_and_nested_values():
    base = load_scenario("locomotion_swim")
    out = S.apply_overrides(base, {
        "contact.friction": 1,  # an int for a float field is converted
        "water.coefficient_scales.body.linear_damping": 1.3,
        "balloon.schedule": [{"time": 1.0, "fill": 0.5}],
        "simulator.max_step_size": 0.0005,
    })
    assert out.contact.friction == 1.0 and isinstance(out.contact.friction, float)
    assert out.water.coefficient_scales == {"body.linear_damping": 1.3}
    assert out.balloon.schedule[0].time == 1.0 and out.balloon.schedule[0].fill == 0.5
    assert out.simulator.max_step_size == 0.0005
    # The base is untouched (every run starts from the same base).
    assert base.contact.friction == 0.8 and base.water.coefficient_scales == {}
    assert base.balloon.schedule == []
    with pytest.raises(ScenarioError, match="scenario.contact.friction: expected a float"):
        S.apply_overrides(base, {"contact.friction": "high"})
    with pytest.raises(ScenarioError, match="contact.friction"):
        S.apply_overrides(base, {"contact.friction": -1.0})  # range: Scenario.validate


@pytest.mark.parametrize("key, message", [
    ("contact.frction", "has no field 'frction'"),
    ("duration.x", "has no field 'x'"),
    ("water.coefficient_scales.body.damping", "unknown coefficient 'body.damping'"),
])
def test_bad_override_keys_are_named(key, message):
    with pytest.raises(ScenarioError, match=message):
        S.check_override_key(key)


def test_run_id_is_deterministic_and_order_free():
    a = S.make_run_id("locomotion_swim", {"contact.friction": 0.5, "duration": 2.0}, 3)
    b = S.make_run_id("locomotion_swim", {"duration": 2.0, "contact.friction": 0.5}, 3)
    assert a == b and a.startswith("locomotion_swim-s3-") and len(a.split("-")[-1]) == 10
    assert a != S.make_run_id("locomotion_swim", {"contact.friction": 0.5, "duration": 2.0}, 4)
    assert a != S.make_run_id("locomotion_swim", {"contact.friction": 0.6, "duration": 2.0}, 3)
    assert a != S.make_run_id("locomotion_walk", {"contact.friction": 0.5, "duration": 2.0}, 3)
    # The digest is SHA-256 of the canonical JSON of (base, overrides, seed), computed here
    # from that definition, and pinned: a change of the hash or the encoding breaks restarts.
    payload = json.dumps({"base": "stand", "overrides": {"duration": 2.0}, "seed": 0},
                         sort_keys=True, separators=(",", ":"))
    digest = hashlib.sha256(payload.encode()).hexdigest()[:10]
    assert S.make_run_id("stand", {"duration": 2.0}, 0) == f"stand-s0-{digest}" == \
        "stand-s0-0d8e1927df"
    # A base given as a path is named by its stem.
    assert S.make_run_id("diagrams/my swim.yaml", {}, 1).startswith("my_swim-s1-")


def test_parameter_sets_grid_rows_random():
    grid = S.SweepConfig(base=["stand"], grid={"a": [1, 2], "b": [3, 4, 5]})
    sets = S.parameter_sets(grid)
    assert len(sets) == 6 and sets[0] == {"a": 1, "b": 3} and sets[-1] == {"a": 2, "b": 5}
    rows = S.SweepConfig(base=["stand"], rows=[{"a": 1}, {"b": 2}])
    assert S.parameter_sets(rows) == [{"a": 1}, {"b": 2}]
    assert S.parameter_names(rows) == ["a", "b"]
    rand = S.SweepConfig(base=["stand"], random=S.RandomSample(
        n=50, seed=7, uniform={"a": [0.5, 0.8], "b": [-1.0, 1.0]}))
    one, two = S.parameter_sets(rand), S.parameter_sets(rand)
    assert one == two and len(one) == 50  # seeded
    a = np.array([s["a"] for s in one])
    assert a.min() >= 0.5 and a.max() <= 0.8 and a.std() > 0.05
    rand.random.seed = 8
    assert S.parameter_sets(rand) != one
    assert S.parameter_sets(S.SweepConfig(base=["stand"])) == [{}]


def test_flatten_metrics_and_transitions():
    metrics = {
        "scenario": "x", "status": "ok", "reason": "", "sim_time_s": 2.0,
        "mean_velocity_body": [0.05, -0.01], "yaw_rate_deg_s": -3.0,
        "final_body_xyz": [1.0, 2.0, 3.0], "other": [7, 8], "steady_window_s": [1.0, 2.0],
        "transitions": [{"from": "swim", "to": "trot", "start_s": 8.04, "end_s": 16.2},
                        {"from": "trot", "to": "turning", "start_s": 30.0, "end_s": 31.5}],
        "failure": {"time_s": 0.5, "reason": "boom"},
    }
    flat = S.flatten_metrics(metrics)
    assert flat["u"] == 0.05 and flat["v"] == -0.01
    assert (flat["final_x"], flat["final_z"]) == (1.0, 3.0)
    assert flat["other_0"] == 7 and flat["other_1"] == 8
    assert flat["transitions"] == "swim>trot@8.04-16.20;trot>turning@30.00-31.50"
    assert flat["failure_time_s"] == 0.5 and flat["steady_end_s"] == 2.0
    # No mean velocity (too short a steady window): empty u, v cells, not a new column.
    assert S.flatten_metrics({"mean_velocity_body": None}) == {"u": None, "v": None}
    assert "scenario" not in flat and "status" not in flat
    assert S.format_transitions([]) == ""


# --- the sweep file --------------------------------------------------------------------------

@pytest.mark.parametrize("text, message", [
    ("base: stand\ngird: {contact.friction: [0.5]}\n", "sweep.gird: unknown key"),
    ("base: stand\ngrid: {contact.frction: [0.5]}\n", "sweep.grid.contact.frction"),
    ("base: stand\nrandom: {n: 3, seed: 1, uniform: {contact.friction: [0.8, 0.5]}}\n",
     "sweep.random.uniform.contact.friction: expected \\[low, high\\]"),
    ("base: stand\nrandom: {n: 3, seed: 1, unifrom: {}}\n", "sweep.random.unifrom"),
    ("base: stand\ngrid: {contact.friction: [0.5]}\nrows: [{duration: 1}]\n", "one of grid"),
    ("base: stand\nlinks: {hull: [water.coefficient_scales.body.lin]}\n",
     "sweep.links.hull\\[0\\]"),
    ("base: stand\ngrid: {contact.friction: [0.5, 0.5]}\n", "duplicate values"),
    ("base: no_such_scenario\n", "sweep.base"),
    ("base: stand\nseeds: []\n", "sweep.seeds"),
    ("base: stand\nfixed: {duration: 1}\ngrid: {duration: [1, 2]}\n", "also varied"),
    ("base: stand\nrows: [{random_seed: 3}]\n", "random_seed is set by sweep.seeds"),
    ("base: stand\nlinks: {d: [duration]}\nrows: [{d: 1, duration: 2}]\n",
     "sweep.rows\\[0\\]: duration is set by two parameters"),
])
def test_bad_sweep_files_fail_at_load_naming_the_path(tmp_path, text, message):
    with pytest.raises(S.SweepError, match=message):
        S.load_sweep(write(tmp_path / "s.yaml", text))


def test_cli_error_is_one_line(tmp_path, capsys):
    from manta_drake.cli import main

    bad = write(tmp_path / "s.yaml", "base: stand\ngrid: {contact.frction: [0.5]}\n")
    assert main(["sweep", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sweep.grid.contact.frction" in err[0]
    assert not (tmp_path / "o").exists()  # nothing ran


def test_shipped_findings_sweep_plans_every_run():
    config = S.load_sweep(SWEEPS / "findings.yaml")
    assert [b.replace("locomotion_", "") for b in config.base] == \
        ["swim", "trot", "walk", "crab", "turning"]
    grid = config.grid
    assert min(grid["contact.friction"]) == 0.5 and max(grid["contact.friction"]) == 0.8
    assert min(grid["hull_damping"]) == 0.7 and max(grid["hull_damping"]) == 1.3
    assert min(grid["net_weight_kg"]) == 0.6 and max(grid["net_weight_kg"]) == 1.1
    assert all(len(v) >= 3 for v in grid.values())
    specs = S.plan_runs(config)
    assert len(specs) == 5 * 27 and not [s for s in specs if s.invalid_reason]
    assert len({s.run_id for s in specs}) == len(specs)
    # The link sets both damping terms; the weight both hull entries.
    scales = specs[-1].scenario_yaml
    for key in ("body.linear_damping: 1.3", "body.quadratic_damping: 1.3",
                "body.sealed_semi_axes:", "body.sealed_volume:"):
        assert key in scales


# --- runs ------------------------------------------------------------------------------------

MIXED = """\
name: mixed
base: locomotion_swim
seeds: [0]
fixed: {duration: 2.0}   # the shortest run with a mean velocity (a 1 s steady window)
links:
  hull_damping: [water.coefficient_scales.body.linear_damping,
                 water.coefficient_scales.body.quadratic_damping]
rows:
  - {hull_damping: 0.8}
  - {hull_damping: 1.2, net_weight_kg: 1.1}
  - {contact.friction: -1.0}                                   # invalid value
  - {water.coefficient_scales.body.linear_damping: 100000.0}   # the simulation diverges
  - {water.coefficient_scales.fins.strips_per_plate: 0.0}      # the water model refuses it
"""


def _compare(a: list[dict], b: list[dict]) -> None:
    assert [r["run_id"] for r in a] == [r["run_id"] for r in b]
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        assert {k: v for k, v in x.items() if k not in TIMING} == \
            {k: v for k, v in y.items() if k not in TIMING}


def test_cluster_gives_the_rows_of_series_and_records_failures(tmp_path):
    config = S.load_sweep(write(tmp_path / "mixed.yaml", MIXED))
    series = S.run_sweep(config, tmp_path / "series", client=None, progress=False)
    with S.dask_client(workers=2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        parallel = S.run_sweep(config, tmp_path / "parallel", client=client, progress=False)
    status = [r["status"] for r in series.rows]
    # The last is refused when the scenario is validated (the scaled coefficients pass the
    # file's checks), or raises while building or at the first step; either way a row with
    # the reason.
    assert status[:4] == ["ok", "ok", "invalid", "failed"]
    assert status[4] in ("invalid", "error", "failed")
    reasons = [r["reason"] for r in series.rows]
    assert "contact.friction" in reasons[2] and "simulation failed at t =" in reasons[3]
    assert "strips_per_plate" in reasons[4] and "manta_run_" not in reasons[3]
    assert series.rows[3]["u"] is None and float(series.rows[3]["failure_time_s"]) < 2.0
    # The same rows from the cluster and from the CSV files.
    _compare(series.rows, parallel.rows)
    _compare(S.read_table(series.table), S.read_table(parallel.table))
    assert float(series.rows[0]["u"]) != float(series.rows[1]["u"])  # the overrides act
    for row in series.rows:
        run = tmp_path / "parallel" / "runs" / row["run_id"]
        record = json.loads((run / "metrics.json").read_text())
        assert record["status"] == row["status"] and record["run"]["run_id"] == row["run_id"]
        assert (run / "log.npz").exists() == (row["status"] == "ok" or "at t =" in row["reason"])
        assert (run / "scenario.yaml").exists() == (row["status"] != "invalid")
        assert not (run / "recording.html").exists() and not (run / "joints.png").exists()
    # A run folder's scenario.yaml reproduces the run.
    ok = tmp_path / "parallel" / "runs" / series.rows[1]["run_id"]
    again = S.simulate_run((ok / "scenario.yaml").read_text())["metrics"]
    assert again["mean_velocity_body"][0] == float(series.rows[1]["u"])
    assert series.figure.exists() and parallel.figure.exists()


def test_any_exception_is_a_record_not_a_raise():
    out = S.simulate_run("duration: [unterminated")
    assert out["metrics"]["status"] == "error" and out["log_npz"] is None
    assert out["metrics"]["reason"].startswith("ScenarioError: scenario data: not valid YAML")


def test_restart_skips_done_runs(tmp_path, monkeypatch):
    from manta_drake.sweep import runner

    calls = []
    real = S.simulate_run

    def counting(text):
        calls.append(text)
        return real(text)

    monkeypatch.setattr(runner, "simulate_run", counting)  # what run_sweep calls
    text = ("base: stand\nfixed: {duration: 0.2}\ngrid: {contact.friction: [0.5, 0.8]}\n")
    out = tmp_path / "out"
    first = S.run_sweep(S.load_sweep(write(tmp_path / "s.yaml", text)), out, progress=False)
    assert len(calls) == 2 and len(first.simulated) == 2
    done = out / "runs" / first.rows[0]["run_id"] / "metrics.json"
    stamp = done.stat().st_mtime_ns
    # Interrupted before the third run: no metrics.json (a half-written run is not done).
    (out / "runs" / first.rows[1]["run_id"] / "metrics.json").unlink()
    text = text.replace("[0.5, 0.8]", "[0.5, 0.8, 1.0]")
    second = S.run_sweep(S.load_sweep(write(tmp_path / "s.yaml", text)), out, progress=False)
    assert len(calls) == 4 and second.simulated == [second.rows[1]["run_id"],
                                                    second.rows[2]["run_id"]]
    assert done.stat().st_mtime_ns == stamp
    assert [r["contact.friction"] for r in S.read_table(second.table)] == ["0.5", "0.8", "1.0"]
    third = S.run_sweep(S.load_sweep(tmp_path / "s.yaml"), out, progress=False)
    assert len(calls) == 4 and third.simulated == [] and len(third.rows) == 3


def test_rerun_failed_and_cli(tmp_path, capsys):
    from manta_drake.cli import main

    sweep = write(tmp_path / "s.yaml", "base: stand\nfixed: {duration: 0.2}\n"
                  "rows: [{contact.friction: 0.6}, {contact.friction: -1.0}]\n")
    out = tmp_path / "o"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0", "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "1 invalid, 1 ok" in printed and "results.csv" in printed
    assert [r["status"] for r in S.read_table(out / "results.csv")] == ["ok", "invalid"]
    again = S.run_sweep(S.load_sweep(sweep), out, progress=False, rerun_failed=True)
    assert again.simulated == []  # the invalid run was re-checked, not simulated
    assert main(["sweep", str(sweep), "--out", str(out), "--dry-run", "--set",
                 "duration=0.1"]) == 0
    assert "2 runs; 1 invalid" in capsys.readouterr().out


def test_progress_bar_counts_finished_runs(tmp_path, capsys):
    sweep = write(tmp_path / "s.yaml", "base: stand\nfixed: {duration: 0.1}\n"
                  "grid: {contact.friction: [0.5, 0.6]}\n")
    S.run_sweep(S.load_sweep(sweep), tmp_path / "o", progress=True)
    err = capsys.readouterr().err
    assert "2/2" in err and "run" in err
