"""Sweeps (manta_drake.sweep): the file format, the pure helpers, and runs on a Dask
LocalCluster against the same runs in series."""

import hashlib
import json
import pathlib
import re

import numpy as np
import pytest

from manta_drake import sweep as S
from manta_drake.model.bill_of_materials import NACA4_SECTION_AREA
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
    water model: the hull ellipsoid 4/3 pi abc, four XW540 cases per leg-fin (33.5 x 58.5 x
    45.9 mm), and the two NACA0012 fin plates of each leg-fin (0.68508 t c x span,
    NACA4_SECTION_AREA)."""
    a, b, c = coeffs.body.sealed_semi_axes.value
    hull = 4.0 / 3.0 * np.pi * a * b * c
    servos = 4 * NUM_LEGS * 0.0335 * 0.0585 * 0.0459
    plates = (
        NUM_LEGS
        * NACA4_SECTION_AREA
        * robot.fin_thickness
        * (robot.proximal_chord * robot.d3 + robot.distal_chord * robot.dE)
    )
    return robot.total_mass - coeffs.water_density.value * (hull + servos + plates)


@pytest.mark.parametrize("target", [0.6, 0.85, 1.1])
def test_net_weight_scales_give_the_target_weight_of_the_robots_volumes(target):
    coeffs = load_coefficients()
    assert _net_weight_by_hand(coeffs) == pytest.approx(0.845, abs=0.002)  # the shipped robot
    # The water model's volume elements hold the same volume as the parts.
    assert S.deflated_net_weight_kg(coeffs) == pytest.approx(_net_weight_by_hand(coeffs), abs=1e-9)
    scales = S.net_weight_scales(target, coeffs)
    scaled = scale_coefficients(coeffs, scales)
    assert _net_weight_by_hand(scaled) == pytest.approx(target, abs=1e-9)
    # The hull keeps its shape (every semi-axis times s) and the documented sealed volume
    # stays the ellipsoid's (times s^3).
    s = scales["body.sealed_semi_axes"]
    np.testing.assert_allclose(
        scaled.body.sealed_semi_axes.value,
        s * np.asarray(coeffs.body.sealed_semi_axes.value),
        rtol=1e-12,
    )
    assert scales["body.sealed_volume"] == pytest.approx(s**3, rel=1e-12)
    a, b, c = scaled.body.sealed_semi_axes.value
    assert scaled.body.sealed_volume.value == pytest.approx(4 / 3 * np.pi * a * b * c, rel=1e-5)


def test_a_scale_of_the_sealed_volume_alone_is_refused():
    """It would change nothing (the buoyancy integrates the semi-axes): refused by name."""
    scenario = load_scenario("locomotion_swim")
    scenario.water.coefficient_scales = {"body.sealed_volume": 1.2}
    with pytest.raises(
        ScenarioError, match="body.sealed_volume = .* disagrees with body.sealed_semi_axes"
    ):
        scenario.validate()


def test_net_weight_parameter_refuses_a_conflicting_scale():
    scenario = load_scenario("locomotion_swim")
    scenario.water.coefficient_scales = {"body.sealed_semi_axes": 1.1}
    with pytest.raises(ScenarioError, match="body.sealed_semi_axes"):
        S.apply_net_weight(scenario, 0.7)


@pytest.mark.parametrize(
    "value, message",
    [
        ("heavy", "net_weight_kg: 'heavy' is not a number"),
        (True, "net_weight_kg: True is not a number"),
        (float("nan"), "net_weight_kg: nan is not finite"),
    ],
)
def test_net_weight_parameter_is_a_finite_number(value, message):
    scenario = load_scenario("locomotion_swim")
    with pytest.raises(ScenarioError) as info:
        S.apply_net_weight(scenario, value)
    assert str(info.value) == message
    assert scenario.water.coefficient_scales == {}  # nothing set


# --- keys, ids, parameter sets ---------------------------------------------------------------


def test_set_override_dotted_keys_dicts_and_nested_values():
    base = load_scenario("locomotion_swim")
    out = S.apply_overrides(
        base,
        {
            "contact.friction": 1,  # an int for a float field is converted
            "water.coefficient_scales.body.linear_damping": 1.3,
            "balloon.schedule": [{"time": 1.0, "fill": 0.5}],
            "simulator.max_step_size": 0.0005,
        },
    )
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


@pytest.mark.parametrize(
    "key, message",
    [
        ("contact.frction", "has no field 'frction'"),
        ("duration.x", "has no field 'x'"),
        ("water.coefficient_scales.body.damping", "unknown coefficient 'body.damping'"),
    ],
)
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
    payload = json.dumps(
        {"base": "stand", "overrides": {"duration": 2.0}, "seed": 0},
        sort_keys=True,
        separators=(",", ":"),
    )
    digest = hashlib.sha256(payload.encode()).hexdigest()[:10]
    assert (
        S.make_run_id("stand", {"duration": 2.0}, 0)
        == f"stand-s0-{digest}"
        == "stand-s0-0d8e1927df"
    )
    # A base given as a path is named by its stem.
    assert S.make_run_id("diagrams/my swim.yaml", {}, 1).startswith("my_swim-s1-")


def test_parameter_sets_grid_rows_random():
    grid = S.SweepConfig(base=["stand"], grid={"a": [1, 2], "b": [3, 4, 5]})
    sets = S.parameter_sets(grid)
    assert len(sets) == 6 and sets[0] == {"a": 1, "b": 3} and sets[-1] == {"a": 2, "b": 5}
    rows = S.SweepConfig(base=["stand"], rows=[{"a": 1}, {"b": 2}])
    assert S.parameter_sets(rows) == [{"a": 1}, {"b": 2}]
    assert S.parameter_names(rows) == ["a", "b"]
    rand = S.SweepConfig(
        base=["stand"],
        random=S.RandomSample(n=50, seed=7, uniform={"a": [0.5, 0.8], "b": [-1.0, 1.0]}),
    )
    one, two = S.parameter_sets(rand), S.parameter_sets(rand)
    assert one == two and len(one) == 50  # seeded
    a = np.array([s["a"] for s in one])
    assert a.min() >= 0.5 and a.max() <= 0.8 and a.std() > 0.05
    rand.random.seed = 8
    assert S.parameter_sets(rand) != one
    assert S.parameter_sets(S.SweepConfig(base=["stand"])) == [{}]


def test_flatten_metrics_and_transitions():
    metrics = {
        "scenario": "x",
        "status": "ok",
        "reason": "",
        "sim_time_s": 2.0,
        "mean_velocity_body": [0.05, -0.01],
        "yaw_rate_deg_s": -3.0,
        "final_body_xyz": [1.0, 2.0, 3.0],
        "other": [7, 8],
        "steady_window_s": [1.0, 2.0],
        "transitions": [
            {"from": "swim", "to": "trot", "start_s": 8.04, "end_s": 16.2},
            {"from": "trot", "to": "turning", "start_s": 30.0, "end_s": 31.5},
        ],
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


@pytest.mark.parametrize(
    "text, message",
    [
        ("base: stand\ngird: {contact.friction: [0.5]}\n", "sweep.gird: unknown key"),
        ("base: stand\ngrid: {contact.frction: [0.5]}\n", "sweep.grid.contact.frction"),
        (
            "base: stand\nrandom: {n: 3, seed: 1, uniform: {contact.friction: [0.8, 0.5]}}\n",
            "sweep.random.uniform.contact.friction: expected \\[low, high\\]",
        ),
        ("base: stand\nrandom: {n: 3, seed: 1, unifrom: {}}\n", "sweep.random.unifrom"),
        ("base: stand\ngrid: {contact.friction: [0.5]}\nrows: [{duration: 1}]\n", "one of grid"),
        (
            "base: stand\nlinks: {hull: [water.coefficient_scales.body.lin]}\n",
            "sweep.links.hull\\[0\\]",
        ),
        ("base: stand\ngrid: {contact.friction: [0.5, 0.5]}\n", "duplicate values"),
        ("base: no_such_scenario\n", "sweep.base"),
        ("base: stand\nseeds: []\n", "sweep.seeds"),
        ("base: stand\nfixed: {duration: 1}\ngrid: {duration: [1, 2]}\n", "also varied"),
        ("base: stand\nrows: [{random_seed: 3}]\n", "random_seed is set by sweep.seeds"),
        (
            "base: stand\nlinks: {d: [duration]}\nrows: [{d: 1, duration: 2}]\n",
            "sweep.rows\\[0\\]: duration is set by two parameters",
        ),
    ],
)
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


@pytest.mark.slow
def test_shipped_findings_sweep_plans_every_run():
    config = S.load_sweep(SWEEPS / "findings.yaml")
    assert [b.replace("locomotion_", "") for b in config.base] == [
        "swim",
        "trot",
        "walk",
        "crab",
        "turning",
    ]
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
    for key in (
        "body.linear_damping: 1.3",
        "body.quadratic_damping: 1.3",
        "body.sealed_semi_axes:",
        "body.sealed_volume:",
    ):
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
  - {water.coefficient_scales.body.quadratic_damping: 1.0e6}   # the simulation diverges
  - {water.coefficient_scales.fins.strips_per_plate: 0.0}      # the water model refuses it
"""


def _compare(a: list[dict], b: list[dict]) -> None:
    assert [r["run_id"] for r in a] == [r["run_id"] for r in b]
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        assert {k: v for k, v in x.items() if k not in TIMING} == {
            k: v for k, v in y.items() if k not in TIMING
        }


@pytest.mark.slow
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


@pytest.mark.slow
def test_restart_skips_done_runs(tmp_path, monkeypatch):
    from manta_drake.sweep import runner

    calls = []
    real = S.simulate_run

    def counting(text):
        calls.append(text)
        return real(text)

    monkeypatch.setattr(runner, "simulate_run", counting)  # what run_sweep calls
    text = "base: stand\nfixed: {duration: 0.2}\ngrid: {contact.friction: [0.5, 0.8]}\n"
    out = tmp_path / "out"
    first = S.run_sweep(S.load_sweep(write(tmp_path / "s.yaml", text)), out, progress=False)
    assert len(calls) == 2 and len(first.simulated) == 2
    done = out / "runs" / first.rows[0]["run_id"] / "metrics.json"
    stamp = done.stat().st_mtime_ns
    # Interrupted before the third run: no metrics.json (a half-written run is not done).
    (out / "runs" / first.rows[1]["run_id"] / "metrics.json").unlink()
    text = text.replace("[0.5, 0.8]", "[0.5, 0.8, 1.0]")
    second = S.run_sweep(S.load_sweep(write(tmp_path / "s.yaml", text)), out, progress=False)
    assert len(calls) == 4 and second.simulated == [
        second.rows[1]["run_id"],
        second.rows[2]["run_id"],
    ]
    assert done.stat().st_mtime_ns == stamp
    assert [r["contact.friction"] for r in S.read_table(second.table)] == ["0.5", "0.8", "1.0"]
    third = S.run_sweep(S.load_sweep(tmp_path / "s.yaml"), out, progress=False)
    assert len(calls) == 4 and third.simulated == [] and len(third.rows) == 3


@pytest.mark.slow
def test_rerun_failed_and_cli(tmp_path, capsys):
    from manta_drake.cli import main

    sweep = write(
        tmp_path / "s.yaml",
        "base: stand\nfixed: {duration: 0.2}\n"
        "rows: [{contact.friction: 0.6}, {contact.friction: -1.0}]\n",
    )
    out = tmp_path / "o"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0", "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "1 invalid, 1 ok" in printed and "results.csv" in printed
    assert [r["status"] for r in S.read_table(out / "results.csv")] == ["ok", "invalid"]
    again = S.run_sweep(S.load_sweep(sweep), out, progress=False, rerun_failed=True)
    assert again.simulated == []  # the invalid run was re-checked, not simulated
    assert main(["sweep", str(sweep), "--out", str(out), "--dry-run", "--set", "duration=0.1"]) == 0
    assert "2 runs; 1 invalid" in capsys.readouterr().out


@pytest.mark.slow
def test_progress_bar_counts_finished_runs(tmp_path, capsys):
    sweep = write(
        tmp_path / "s.yaml",
        "base: stand\nfixed: {duration: 0.1}\ngrid: {contact.friction: [0.5, 0.6]}\n",
    )
    S.run_sweep(S.load_sweep(sweep), tmp_path / "o", progress=True)
    err = capsys.readouterr().err
    assert "2/2" in err and "run" in err


# --- the size of a sweep: counted, bounded, drawn only as far as listed ----------------------


def _huge_grid(n_params: int = 8, n_values: int = 10) -> str:
    """A grid of n_values ** n_params combinations over coefficient scales."""
    from manta_drake.scenario import coefficient_names

    names = [
        n
        for n in coefficient_names()
        if n.endswith(("damping", "coefficient"))
        or n in ("body.added_mass", "body.added_inertia", "fins.hinge_added_inertia")
    ]
    values = "[" + ", ".join(f"{0.5 + 0.1 * i:.1f}" for i in range(n_values)) + "]"
    return "base: stand\ngrid:\n" + "".join(
        f"  water.coefficient_scales.{n}: {values}\n" for n in names[:n_params]
    )


def test_a_huge_grid_is_counted_and_refused_without_expanding(tmp_path, monkeypatch):
    """10^8 combinations: refused from the lengths of the lists, never drawn."""
    from manta_drake.sweep import plan

    def no_expansion(*args, **kwargs):
        raise AssertionError("the grid was expanded")

    monkeypatch.setattr(plan.itertools, "product", no_expansion)
    path = write(tmp_path / "huge.yaml", _huge_grid())
    with pytest.raises(S.SweepError) as e:
        S.load_sweep(path)
    assert str(e.value) == (
        "sweep: 100000000 runs (1 base x 100000000 parameter sets x 1 "
        "seed) is above the maximum of 100000 runs; split the sweep into "
        "smaller ones"
    )
    config = S.SweepConfig(
        base=["stand", "locomotion_swim"],
        seeds=[0, 1, 2],
        grid={"a": [1, 2, 3], "b": list(range(7))},
    )
    assert S.count_runs(config) == 2 * 21 * 3 and S.count_parameter_sets(config) == 21


@pytest.mark.parametrize(
    "n, message",
    [
        ("1000000000", "sweep.random.n: 1000000000 is outside the allowed range [1, 100000]"),
        ("1e9", "sweep.random.n: 1000000000.0 is not an integer (allowed: 1 to 100000)"),
        ("0", "sweep.random.n: 0 is outside the allowed range [1, 100000]"),
    ],
)
def test_a_huge_random_sample_is_refused_before_drawing(tmp_path, n, message):
    text = f"base: stand\nrandom: {{n: {n}, seed: 1, uniform: {{contact.friction: [0.5, 0.8]}}}}\n"
    with pytest.raises(S.SweepError) as e:
        S.load_sweep(write(tmp_path / "r.yaml", text))
    assert str(e.value) == message


@pytest.mark.slow
def test_the_refusal_is_one_line_under_a_memory_limit(tmp_path):
    """The command under a 1.5 GB address-space limit: the count and the maximum, not an
    empty out-of-memory line (expanding the grid needs ~3 GB)."""
    import resource
    import subprocess
    import sys

    path = write(tmp_path / "huge.yaml", _huge_grid())
    limit = 1536 * 2**20

    def cap():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "manta_drake.cli",
            "sweep",
            str(path),
            "--out",
            str(tmp_path / "o"),
            "--dry-run",
            "--limit",
            "1",
        ],
        capture_output=True,
        text=True,
        preexec_fn=cap,
        timeout=120,
        cwd=tmp_path,
    )
    err = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr
    assert err == [
        "manta-drake: error: sweep: 100000000 runs (1 base x 100000000 parameter "
        "sets x 1 seed) is above the maximum of 100000 runs; split the sweep into "
        "smaller ones (--debug shows the traceback)"
    ]


@pytest.mark.slow
def test_limit_draws_only_the_runs_it_lists(tmp_path, monkeypatch):
    # numpy's Generator fills the (n, k) table row by row: the first K rows of the whole
    # draw are a draw of (K, k) from the same seed.
    low, high = np.array([0.5, -1.0, 2.0]), np.array([0.8, 1.0, 3.0])
    whole = np.random.default_rng(7).uniform(low, high, size=(100_000, 3))
    np.testing.assert_array_equal(
        np.random.default_rng(7).uniform(low, high, size=(5, 3)), whole[:5]
    )
    rand = S.SweepConfig(
        base=["stand"],
        seeds=[0, 1],
        random=S.RandomSample(
            n=100_000, seed=7, uniform={"a": [0.5, 0.8], "b": [-1.0, 1.0], "c": [2.0, 3.0]}
        ),
    )
    sizes = []
    real = np.random.default_rng

    class Recording:
        def __init__(self, seed):
            self.rng = real(seed)

        def uniform(self, low, high, size):
            sizes.append(size)
            return self.rng.uniform(low, high, size)

    from manta_drake.sweep import plan

    monkeypatch.setattr(plan.np.random, "default_rng", Recording)
    specs = S.run_specs(rand, limit=5)  # 5 runs over 2 seeds: 3 parameter sets
    assert sizes == [(3, 3)]
    assert [s.parameters for s in specs] == [
        dict(zip("abc", map(float, whole[i]))) for i in (0, 0, 1, 1, 2)
    ]
    assert [s.seed for s in specs] == [0, 1, 0, 1, 0]
    assert S.parameter_sets(rand, 4) == S.parameter_sets(rand)[:4]
    # A grid of 100 000 combinations: the first runs, the same as the whole sweep's.
    grid = S.SweepConfig(
        base=["stand"],
        grid={
            "contact.friction": list(np.linspace(0.1, 1.0, 100)),
            "duration": [float(d) for d in range(1, 1001)],
        },
    )
    assert [s.run_id for s in S.run_specs(grid, 3)] == [s.run_id for s in S.run_specs(grid)[:3]]
    assert S.run_specs(grid, 3)[2].parameters == {"contact.friction": 0.1, "duration": 3.0}


def test_dry_run_with_limit_on_the_largest_sweep_lists_one_run(tmp_path, capsys):
    from manta_drake.cli import main

    path = write(tmp_path / "big.yaml", _huge_grid(5, 10))  # exactly the maximum
    assert S.count_runs(S.load_sweep(path)) == S.MAX_RUNS
    assert (
        main(["sweep", str(path), "--out", str(tmp_path / "o"), "--dry-run", "--limit", "1"]) == 0
    )
    assert capsys.readouterr().out.strip().endswith("1 runs; 0 invalid")


# --- inputs refused at once ------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, message",
    [
        ("base: stand\nseeds: [0]\nseeds: [1]\n", "duplicate key 'seeds'"),
        (
            "base: stand\ngrid:\n  contact.friction: [0.5]\n  contact.friction: [0.6]\n",
            "duplicate key 'contact.friction'",
        ),
        (
            "base: stand\ngrid: {duration: [1, 1.0]}\n",
            re.escape(
                "sweep.grid.duration: duplicate values in [1, 1.0]: 1 and 1.0 are the same "
                "value once "
                "typed as the scenario field; give each value once"
            ),
        ),
        (
            "base: stand\nlinks: {d: [duration]}\ngrid: {d: [2.0, 2]}\n",
            re.escape(
                "sweep.grid.d: duplicate values in [2.0, 2]: 2.0 and 2 are the same value "
                "once typed"
            ),
        ),
        ("base: stand\ngrid: {net_weight_kg: [1, 1.0]}\n", "sweep.grid.net_weight_kg: duplicate"),
        (
            "base: stand\nrows: [{duration: 1}, {contact.friction: 0.5}, {duration: 1.0}]\n",
            "sweep.rows\\[2\\]: the same values as sweep.rows\\[0\\]",
        ),
        ("base: [stand, stand.yaml]\n", "sweep.base: stand.yaml and stand are the same scenario"),
        (
            "base: stand\nfixed: {contact.friction: -1.0}\ngrid: {duration: [1.0, 2.0]}\n",
            "sweep.fixed: on base stand: .*contact.friction.*-1.0",
        ),
        ("base: stand\nfixed: {net_weight_kg: 9.0}\n", "sweep.fixed: on base stand: net_weight_kg"),
    ],
)
def test_more_bad_sweep_files_fail_at_load(tmp_path, text, message):
    with pytest.raises(S.SweepError, match=message):
        S.load_sweep(write(tmp_path / "s.yaml", text))


def test_values_are_typed_as_the_scenario_holds_them():
    """An int given for a float field is that float, in lists and nested records too; an int
    field keeps its ints (1.0 for it stays apart from 1: the run refuses it)."""
    assert S.typed_parameter("duration", 1, {}) == 1.0
    assert isinstance(S.typed_parameter("duration", 1, {}), float)
    assert S.typed_parameter("initial_pose.xyz", [0, 0, -1], {}) == [0.0, 0.0, -1.0]
    typed = S.typed_parameter("balloon.schedule", [{"time": 1, "fill": 1}], {})
    assert typed == [{"time": 1.0, "fill": 1.0}] and isinstance(typed[0]["time"], float)
    assert S.typed_parameter("water.coefficient_scales.body.linear_damping", 2, {}) == 2.0
    assert S.typed_parameter("simulator.max_step_size", 1, {}) == 1.0  # a pydrake struct
    assert type(S.typed_parameter("random_seed", 1, {})) is int
    assert type(S.typed_parameter("random_seed", 1.0, {})) is float
    assert S.typed_parameter("net_weight_kg", 1, {}) == 1.0
    assert S.typed_parameter("hull", 1, {"hull": ["duration", "random_seed"]}) == [1.0, 1]
    assert S.typed_parameter("contact.friction", True, {}) is True  # a bool is no number


def test_fixed_and_set_are_checked_once_at_load(tmp_path, capsys):
    from manta_drake.cli import main

    good = write(
        tmp_path / "s.yaml",
        "base: [stand, locomotion_swim]\nfixed: {duration: 0.2}\n"
        "grid: {contact.friction: [0.5, 0.6]}\n",
    )
    with pytest.raises(S.SweepError, match="^--set: on base stand: .*duration"):
        S.load_sweep(good, {"duration": -1.0})
    with pytest.raises(S.SweepError, match="^--set contact.friction: the sweep varies it"):
        S.load_sweep(good, {"contact.friction": 0.7})
    with pytest.raises(S.SweepError, match="^--set contact.frction: "):
        S.load_sweep(good, {"contact.frction": 0.7})
    bad = write(
        tmp_path / "b.yaml",
        "base: stand\nfixed: {contact.friction: -1.0}\ngrid: {duration: [1.0, 2.0]}\n",
    )
    assert main(["sweep", str(bad), "--out", str(tmp_path / "o"), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1
        and err[0].startswith("manta-drake: error: sweep.fixed: on base stand: ")
        and "contact.friction" in err[0]
    )
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_a_sweep_with_no_valid_run_exits_1(tmp_path, capsys):
    from manta_drake.cli import main

    sweep = write(
        tmp_path / "s.yaml",
        "base: stand\nfixed: {duration: 0.2}\n"
        "rows: [{contact.friction: -1.0}, {contact.friction: -2.0}]\n",
    )
    out = tmp_path / "o"
    assert main(["sweep", str(sweep), "--out", str(out), "--dry-run"]) == 1
    assert capsys.readouterr().err.strip() == "manta-drake: sweep s: no run is valid"
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0", "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"manta-drake: sweep s: no run is ok (2 invalid); see {out / 'results.csv'}"]
    assert [r["status"] for r in S.read_table(out / "results.csv")] == ["invalid", "invalid"]


@pytest.mark.parametrize(
    "content, message",
    [
        (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe", "not a UTF-8 text (YAML) file"),
        (b"base: stand\x00\x00\x00\n", "not valid YAML: unacceptable character #x0000"),
    ],
)
def test_a_binary_sweep_file_is_one_line(tmp_path, capsys, content, message):
    from manta_drake.cli import main

    path = tmp_path / "s.yaml"
    path.write_bytes(content)
    assert main(["sweep", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path}: {message}" in err[0]


def test_a_binary_results_table_is_one_line(tmp_path):
    path = tmp_path / "results.csv"
    path.write_bytes(b"run_id,status\n\xff\xfe\x00")
    with pytest.raises(S.SweepError, match=f"^{path}: not a UTF-8 text \\(CSV\\) file$"):
        S.read_table(path)
    path.write_bytes(b"run_id,status\nx,\x00ok\n")
    with pytest.raises(S.SweepError, match="not a text \\(CSV\\) file \\(it holds NUL bytes\\)"):
        S.read_table(path)


def _unwritable(tmp_path) -> pathlib.Path:
    """A folder this process cannot write (a read-only mount for root, else chmod 555)."""
    import os

    if os.geteuid() != 0:
        folder = tmp_path / "ro"
        folder.mkdir(mode=0o555)
        return folder / "out"
    sys_fs = pathlib.Path("/sys")
    if sys_fs.is_dir() and not os.access(sys_fs, os.W_OK):
        return sys_fs / "manta_drake_out"
    try:
        import tempfile

        with tempfile.TemporaryFile(dir=sys_fs):
            pass
    except OSError:
        return sys_fs / "manta_drake_out"
    pytest.skip("no read-only folder for root here")


@pytest.mark.parametrize("case", ["a file", "under a file", "unwritable", "empty"])
def test_sweep_out_is_checked_before_anything_runs(tmp_path, capsys, monkeypatch, case):
    from manta_drake.cli import main
    from manta_drake.sweep import loading

    sweep = write(tmp_path / "s.yaml", "base: stand\nfixed: {duration: 0.2}\n")
    (tmp_path / "file").write_text("x")
    out, message = {
        "a file": (tmp_path / "file", f"--out {tmp_path / 'file'}: is a file, not a folder"),
        "under a file": (
            tmp_path / "file" / "o",
            f"--out {tmp_path / 'file' / 'o'}: cannot be created ({tmp_path / 'file'} is a file)",
        ),
        "unwritable": (_unwritable(tmp_path), "--out "),
        "empty": ("", "--out: an empty path; name an output folder (e.g. out/sweep)"),
    }[case]
    loads = []
    monkeypatch.setattr(loading, "read_yaml_mapping", lambda *a: loads.append(a) or {})
    assert main(["sweep", str(sweep), "--out", str(out), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"manta-drake: error: {message}")
    if case == "unwritable":
        assert "not writable" in err[0] or "cannot be written" in err[0]
    assert loads == []  # refused before the file was read
    # run_sweep itself checks too (Python callers).
    if case != "empty":
        with pytest.raises(S.SweepError, match="^--out "):
            S.run_sweep(S.SweepConfig(base=["stand"]), out, progress=False)
    runs_file = tmp_path / "o2"
    runs_file.mkdir()
    (runs_file / "runs").write_text("not a folder")
    with pytest.raises(S.SweepError, match="runs is a file, not a folder"):
        S.check_out_folder(runs_file, ("results.csv",), folders=("runs",))


# --- restarts: what is done ------------------------------------------------------------------


def _record(
    run_dir: pathlib.Path,
    status: str,
    reason: str = "",
    log: bool | None = None,
    log_file: bool = False,
) -> pathlib.Path:
    run_dir.mkdir(parents=True, exist_ok=True)
    record = {"status": status, "reason": reason, "run": {"run_id": run_dir.name}}
    if log is not None:
        record["run"]["log_npz"] = log
    (run_dir / "metrics.json").write_text(json.dumps(record))
    if log_file:
        (run_dir / "log.npz").write_bytes(b"x")
    return run_dir


@pytest.mark.parametrize(
    "status, reason, log, log_file, done",
    [
        ("ok", "", True, True, True),
        ("ok", "", True, False, False),  # the log went missing
        ("ok", "", None, False, False),  # an ok record of before run.log_npz: has a log
        ("failed", "at t = 1", True, False, False),
        ("failed", "building", False, False, True),
        ("invalid", "x", False, False, True),
        ("error", "ValueError: boom", False, False, True),
        ("error", "KilledWorker: Attempted to run task", False, False, False),
        ("error", "CommClosedError: in <TCP>", None, False, False),
        ("lost", "lost to the cluster in 3 attempts: KilledWorker: x", False, False, False),
        ("running", "", None, False, False),
    ],
)
def test_read_done_infrastructure_and_missing_logs_are_not_done(
    tmp_path, status, reason, log, log_file, done
):
    run_dir = _record(tmp_path / "r", status, reason, log, log_file)
    assert (S.read_done(run_dir) is not None) == done


@pytest.mark.slow
def test_restart_reruns_a_run_whose_log_is_missing_or_lost(tmp_path, monkeypatch):
    from manta_drake.sweep import runner

    calls = []
    real = S.simulate_run
    monkeypatch.setattr(runner, "simulate_run", lambda text: calls.append(text) or real(text))
    sweep = S.load_sweep(
        write(
            tmp_path / "s.yaml",
            "base: stand\nfixed: {duration: 0.1}\ngrid: {contact.friction: [0.5, 0.6, 0.7]}\n",
        )
    )
    out = tmp_path / "o"
    first = S.run_sweep(sweep, out, progress=False)
    assert len(calls) == 3 and [r["status"] for r in first.rows] == ["ok"] * 3
    ids = [r["run_id"] for r in first.rows]
    (out / "runs" / ids[0] / "log.npz").unlink()
    record = json.loads((out / "runs" / ids[1] / "metrics.json").read_text())
    record.update(status="error", reason="KilledWorker: Attempted to run task on 4 workers")
    (out / "runs" / ids[1] / "metrics.json").write_text(json.dumps(record))
    second = S.run_sweep(sweep, out, progress=False)
    assert second.simulated == ids[:2] and len(calls) == 5
    assert [r["status"] for r in second.rows] == ["ok"] * 3
    assert (out / "runs" / ids[0] / "log.npz").is_file()


def _kill_once(marker: str):
    """A stand-in for simulate_run whose first call kills its worker process outright."""
    import os

    def run(text):
        if not os.path.exists(marker):
            with open(marker, "w"):
                pass
            os._exit(1)  # the worker process dies mid-task: no exception, no result
        return S.simulate_run(text)

    return run


@pytest.mark.slow
def test_a_run_lost_with_its_worker_is_run_again(tmp_path, monkeypatch):
    """A real LocalCluster; the first task kills its worker. With allowed-failures 0
    distributed gives up on every task that worker held (the killer and the run queued
    behind it); the sweep submits them again and every row says ok."""
    import dask.config

    from manta_drake.sweep import runner

    monkeypatch.setattr(runner, "simulate_run", _kill_once(str(tmp_path / "killed")))
    sweep = S.load_sweep(
        write(
            tmp_path / "s.yaml",
            "base: stand\nfixed: {duration: 0.1}\ngrid: {contact.friction: [0.5, 0.6, 0.7, 0.8]}\n",
        )
    )
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 0}),
        S.dask_client(workers=2) as client,
    ):
        result = S.run_sweep(sweep, tmp_path / "o", client=client, progress=False)
    assert (tmp_path / "killed").exists()  # a worker did die
    assert [r["status"] for r in result.rows] == ["ok"] * 4, [r["reason"] for r in result.rows]
    assert sorted(result.simulated) == sorted(r["run_id"] for r in result.rows)
    for row in result.rows:
        assert S.read_done(tmp_path / "o" / "runs" / row["run_id"])["status"] == "ok"


@pytest.mark.slow
def test_a_run_lost_on_every_attempt_is_lost_not_done(tmp_path, monkeypatch):
    """The cluster's exceptions are retried ATTEMPTS times, then the row says lost and the
    run is not done; any other exception from a task is the run's error."""
    from manta_drake.sweep import runner

    class KilledWorker(Exception):
        pass

    class FakeFuture:
        def __init__(self, fn, arg):
            self.fn, self.arg = fn, arg

        def result(self):
            return self.fn(self.arg)

        def release(self):
            pass

    submitted = []

    class FakeClient:
        def nthreads(self):
            return {"w": 1}

        def submit(self, fn, arg, pure, key):
            submitted.append(key)
            return FakeFuture(fn, arg)

    def always_lost(text):
        raise KilledWorker("Attempted to run task on 4 different workers")

    import distributed

    monkeypatch.setattr(distributed, "as_completed", _FakeAsCompleted)
    monkeypatch.setattr(runner, "simulate_run", always_lost)
    sweep = S.load_sweep(write(tmp_path / "s.yaml", "base: stand\nfixed: {duration: 0.1}\n"))
    result = S.run_sweep(sweep, tmp_path / "o", client=FakeClient(), progress=False)
    (row,) = result.rows
    assert row["status"] == "lost" and submitted == [
        f"manta-run-{row['run_id']}-a{i}" for i in range(1, runner.ATTEMPTS + 1)
    ]
    assert row["reason"] == (
        "lost to the cluster in 3 attempts: KilledWorker: Attempted to "
        "run task on 4 different workers"
    )
    assert S.read_done(tmp_path / "o" / "runs" / row["run_id"]) is None


class _FakeAsCompleted:
    """distributed.as_completed over fake futures that are done at once."""

    def __init__(self):
        self.queue = []

    def add(self, future):
        self.queue.append(future)

    def __iter__(self):
        while self.queue:
            yield self.queue.pop(0)


# --- energy columns --------------------------------------------------------------------------

ENERGY = {
    "mechanical_energy_j": 12.5,
    "electrical_energy_j": 80.25,
    "mean_electrical_power_w": 4.0125,
    "cot_electrical_dry_weight": 3.1,
    "cot_electrical_weight_in_water": 31.0,
    "cot_net_of_hotel_dry_weight": 0.8,
    "cot_net_of_hotel_weight_in_water": 8.0,
    "cot_mechanical_dry_weight": 0.6,
    "cot_mechanical_weight_in_water": 6.0,
    "battery_soc_end": 0.97,
    "operation_time_h": 12.4,
    "steady_electrical_power_w": 4.1,
    "cost_of_transport_note": None,
}


def test_energy_block_becomes_energy_columns_in_the_documented_order(tmp_path):
    metrics = {
        "status": "ok",
        "reason": "",
        "mean_velocity_body": [0.05, 0.0],
        "sim_time_s": 20.0,
        "energy": ENERGY,
    }
    flat = S.flatten_metrics(metrics)
    for key, value in ENERGY.items():
        assert flat[f"energy.{key}"] == value
    spec = S.RunSpec(0, "stand-s0-0000000000", "stand", 0, {"contact.friction": 0.5}, {})
    failed = S.RunSpec(1, "stand-s0-1111111111", "stand", 0, {"contact.friction": -1.0}, {})
    columns, rows = S.table_rows(
        [spec, failed],
        {spec.run_id: metrics, failed.run_id: {"status": "invalid", "reason": "contact.friction"}},
    )
    contract = [
        "energy.mechanical_energy_j",
        "energy.electrical_energy_j",
        "energy.mean_electrical_power_w",
        "energy.cot_electrical_dry_weight",
        "energy.cot_electrical_weight_in_water",
        "energy.cot_net_of_hotel_dry_weight",
        "energy.cot_net_of_hotel_weight_in_water",
        "energy.cot_mechanical_dry_weight",
        "energy.cot_mechanical_weight_in_water",
        "energy.battery_soc_end",
        "energy.operation_time_h",
    ]
    energy_columns = [c for c in columns if c.startswith("energy.")]
    assert energy_columns[:11] == contract  # then the block's other keys, sorted
    assert energy_columns[11:] == [
        "energy.cost_of_transport_note",
        "energy.steady_electrical_power_w",
    ]
    S.write_table(tmp_path / "results.csv", columns, rows)
    table = S.read_table(tmp_path / "results.csv")
    assert table[0]["energy.cot_electrical_dry_weight"] == "3.1"
    assert table[0]["energy.electrical_energy_j"] == "80.25"
    assert table[1]["energy.cot_electrical_dry_weight"] == "" and table[1]["status"] == "invalid"


def test_numpy_floats_are_written_as_plain_numbers(tmp_path):
    """A metric computed with numpy (numpy 2's float64 is a float whose repr names its type)
    is written as the number, and reads back as it."""
    import numpy as np

    metrics = {
        "status": "ok",
        "reason": "",
        "sim_time_s": 20.0,
        "energy": {"dry_weight_n": np.float64(82.40400000000001)},
    }
    spec = S.RunSpec(0, "stand-s0-0000000000", "stand", 0, {}, {})
    columns, rows = S.table_rows([spec], {spec.run_id: metrics})
    S.write_table(tmp_path / "results.csv", columns, rows)
    cell = S.read_table(tmp_path / "results.csv")[0]["energy.dry_weight_n"]
    assert cell == "82.40400000000001" and float(cell) == 82.40400000000001


# --- the summary figure -----------------------------------------------------------------------


def _figure_rows():
    """A gait sweep over two bases (the second runs only the walk) and a numeric parameter;
    one failed run."""
    rows = []
    for base, gait, u in (
        ("locomotion_swim", "swim", 0.09),
        ("locomotion_swim", "trot", 0.06),
        ("locomotion_trot", "walk", 0.07),
    ):
        for seed in (0, 1):
            rows.append(
                {
                    "run_id": f"{base}-{gait}-{seed}",
                    "base": base,
                    "seed": seed,
                    "controller.gait": gait,
                    "cpg.frequency_hz": 0.4 + 0.2 * seed,
                    "status": "ok",
                    "u": u + 0.001 * seed,
                    "v": 0.0,
                    "yaw_rate_deg_s": 1.0,
                }
            )
    rows.append(
        {
            "run_id": "bad",
            "base": "locomotion_swim",
            "seed": 0,
            "controller.gait": "crab",
            "cpg.frequency_hz": 0.4,
            "status": "failed",
            "u": None,
            "v": None,
            "yaw_rate_deg_s": None,
        }
    )
    return rows


@pytest.mark.slow
def test_the_summary_figure_labels_categories_and_says_what_was_swept():
    import matplotlib.pyplot as plt

    from manta_drake.sweep.figure import summary_figure

    fig = summary_figure(_figure_rows(), ["controller.gait", "cpg.frequency_hz"], "gaits")
    try:
        axes = np.array(fig.axes[:9]).reshape(3, 3)
        title = fig._suptitle.get_text()
        assert title.startswith("gaits: 6 runs ok, 1 not ok")
        assert (
            "swept: controller.gait in {swim, trot, walk, crab}; cpg.frequency_hz in "
            "{0.4, 0.6}; base locomotion_swim, locomotion_trot; seeds 0, 1"
        ) in title
        # The box column: one box per base, named in full.
        assert [t.get_text() for t in axes[0, 0].get_xticklabels()] == [
            "locomotion_swim",
            "locomotion_trot",
        ]
        assert axes[0, 0].get_title() == "per base scenario"
        # The gait axis: every gait a labelled position, the same for every base.
        for row in axes:
            assert [t.get_text() for t in row[1].get_xticklabels()] == [
                "swim",
                "trot",
                "walk",
                "crab",
            ]
        assert axes[0, 1].get_title() == "against controller.gait"
        assert axes[2, 1].get_xlabel() == "controller.gait"
        swim_base, trot_base = axes[0, 1].get_lines()
        np.testing.assert_array_equal(swim_base.get_xdata(), [0, 0, 1, 1])
        np.testing.assert_allclose(swim_base.get_ydata(), [0.09, 0.091, 0.06, 0.061])
        np.testing.assert_array_equal(trot_base.get_xdata(), [2, 2])  # walk: position 2
        # A numeric parameter stays a numeric axis.
        np.testing.assert_allclose(axes[0, 2].get_lines()[0].get_xdata(), [0.4, 0.6, 0.4, 0.6])
        assert axes[2, 2].get_xlabel() == "cpg.frequency_hz"
    finally:
        plt.close(fig)


# --- the options every many-run command shares ---------------------------------------------

MANY_RUN_COMMANDS = ("sweep", "calibrate", "optimize")


@pytest.mark.parametrize("command", MANY_RUN_COMMANDS)
def test_the_many_run_commands_share_their_options_and_defaults(command):
    """sweep, calibrate and optimize take --out, the cluster's options and --quiet with the
    same defaults; --set where a command layers scenario overrides (sweep, optimize), --seed
    where it replaces the file's seed (optimize)."""
    from manta_drake.cli import _parser
    from manta_drake.cluster import DEFAULT_DASHBOARD, default_workers

    argv = [command, "file.yaml", "--out", "o"]
    args = _parser(argv).parse_args(argv)
    assert (args.out, args.scheduler, args.workers, args.dashboard, args.quiet) == (
        "o",
        None,
        default_workers(),
        DEFAULT_DASHBOARD,
        False,
    )
    assert getattr(args, "set", None) == ([] if command != "calibrate" else None)
    assert hasattr(args, "seed") == (command == "optimize")
    argv += ["--workers", "3", "--quiet"] + (
        ["--set", "duration=2"] if command != "calibrate" else []
    )
    args = _parser(argv).parse_args(argv)
    assert args.workers == 3 and args.quiet
    with pytest.raises(SystemExit):  # --out is required
        _parser([command, "file.yaml"]).parse_args([command, "file.yaml"])


@pytest.mark.parametrize(
    "command, argv, message",
    [
        ("sweep", ["--workers", "300"], "--workers: 300 is outside the allowed range [0, 256]"),
        ("calibrate", ["--workers", "-1"], "--workers: -1 is outside the allowed range [0, 256]"),
        (
            "optimize",
            ["--seed", "-1"],
            "--seed: -1 is outside the allowed range [0, 4294967295]",
        ),
        (
            "optimize",
            ["--dashboard", "8787"],
            "--dashboard '8787': expected HOST:PORT (e.g. 127.0.0.1:0) or '' for none",
        ),
        ("sweep", ["--set", "duration"], "--set duration: expected KEY=VALUE, e.g. duration=2"),
        ("sweep", ["--limit", "0"], "--limit: 0 is outside the allowed range [1, 100000]"),
    ],
)
def test_a_bad_shared_option_is_one_line_before_the_file_is_read(
    tmp_path, capsys, command, argv, message
):
    """The shared options are checked before the file is read (here it does not exist) and
    before the output folder is made."""
    from manta_drake.cli import main

    out = tmp_path / "o"
    assert main([command, str(tmp_path / "missing.yaml"), "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"manta-drake: error: {message} (--debug shows the traceback)"]
    assert not out.exists()
