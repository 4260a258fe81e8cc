"""The manta-drake command line: clear one-line errors, list, run."""

import json
import pathlib
import subprocess
import sys

import pytest

from manta_drake.model import MODELS_DIR

ROOT = pathlib.Path(__file__).resolve().parent.parent


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "manta_drake.cli", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.mark.slow
def test_list_names_every_shipped_scenario():
    result = cli("list")
    assert result.returncode == 0
    for name in ("stand", "float_sink", "two_behaviors", "three_behaviors", "locomotion_walk"):
        assert any(line.split()[0] == name for line in result.stdout.splitlines() if line)


@pytest.mark.slow
def test_typo_is_one_clear_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("duration: 1\ncontroler: {mode: gait}\n")
    result = cli("run", str(bad), "--out", str(tmp_path / "o"))
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "scenario.controler" in lines[0] and "Traceback" not in result.stderr


@pytest.mark.slow
def test_run_writes_outputs(tmp_path):
    out = tmp_path / "o"
    result = cli("run", "stand", "--out", str(out), "--duration", "0.5", "--no-meshcat", "--quiet")
    assert result.returncode == 0, result.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["sim_time_s"] == 0.5 and metrics["status"] == "ok"
    assert not (out / "recording.html").exists()  # --no-meshcat
    assert (out / "joints.png").exists() and (out / "log.npz").exists()


@pytest.mark.slow
def test_error_while_building_is_one_line_too(tmp_path):
    """A coefficients file that breaks the model fails with one line, not a traceback."""
    import shutil

    coeffs = tmp_path / "h.yaml"
    shutil.copy(MODELS_DIR / "hydrodynamics.yaml", coeffs)
    coeffs.write_text(
        coeffs.read_text().replace(
            "sealed_volume:\n    value: 0.004784", "sealed_volume:\n    value: -1.0"
        )
    )
    scenario = tmp_path / "s.yaml"
    scenario.write_text(f"duration: 0.1\nwater: {{coefficients: {coeffs}}}\n")
    result = cli("run", str(scenario), "--out", str(tmp_path / "o"), "--no-meshcat")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "sealed_volume" in lines[0] and "Traceback" not in result.stderr


@pytest.mark.slow
def test_diagram_script_errors_are_one_line_too(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("duration: 1\nballoon: {initial_fill: 2.0}\n")
    result = subprocess.run(
        [
            sys.executable,
            "diagrams/two_behaviors.py",
            "--scenario",
            str(bad),
            "--out",
            str(tmp_path / "o"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "balloon.initial_fill" in lines[0] and "[0, 1]" in lines[0]


@pytest.mark.slow
def test_set_overrides_a_field_and_the_run_writes_its_resolved_scenario(tmp_path):
    """--set KEY=VALUE reaches the simulation (the resolved scenario.yaml has it) and the
    written scenario.yaml loads back to the same scenario, field for field."""
    from pydrake.common.yaml import yaml_dump_typed

    from manta_drake.scenario import load_scenario

    out = tmp_path / "o"
    result = cli(
        "run",
        "stand",
        "--out",
        str(out),
        "--duration",
        "0.2",
        "--no-meshcat",
        "--quiet",
        "--set",
        "contact.friction=0.55",
        "--set",
        "water.coefficient_scales.body.linear_damping=1.2",
    )
    assert result.returncode == 0, result.stderr
    again = load_scenario(out / "scenario.yaml")
    assert again.contact.friction == 0.55 and again.duration == 0.2
    assert again.water.coefficient_scales == {"body.linear_damping": 1.2}
    # The same scenario built without the layering: the file, then plain attribute writes.
    expected = load_scenario("stand", overrides={"duration": 0.2})
    expected.contact.friction = 0.55
    expected.water.coefficient_scales = {"body.linear_damping": 1.2}
    expected.visualization.meshcat = False
    assert yaml_dump_typed(again) == yaml_dump_typed(expected.validate())


@pytest.mark.slow
def test_set_with_a_misspelt_or_out_of_range_field_is_one_line(tmp_path):
    for setting, words in (
        ("contact.frction=0.6", "contact.frction"),
        ("contact.friction=7", "contact.friction: 7.0 is outside"),
    ):
        result = cli("run", "stand", "--out", str(tmp_path / "o"), "--set", setting)
        assert result.returncode == 2
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and words in lines[0], result.stderr


def test_the_summary_prints_walls_energy_and_a_failure(capsys, tmp_path):
    from manta_drake.cli import print_metrics

    print_metrics(
        {
            "scenario": "x",
            "status": "failed",
            "touched_wall": True,
            "min_wall_clearance_m": 0.004,
            "near_wall_at_s": None,
            "energy": {
                "mean_electrical_power_w": 26.84,
                "cot_electrical_dry_weight": None,
                "cost_of_transport_note": "u below 0.005 m/s",
                "operation_time_h": 2.3102,
            },
            "failure": {"stage": "simulation", "time_s": 1.25, "reason": "battery empty"},
        },
        tmp_path,
    )
    lines = {
        line.split()[0]: line.split(None, 1)[1]
        for line in capsys.readouterr().out.splitlines()
        if line.strip() and len(line.split()) > 1
    }
    assert lines["touched_wall"] == "yes" and lines["min_wall_clearance_m"] == "0.004"
    assert lines["near_wall_at_s"] == "-"
    assert lines["mean_electrical_power_w"] == "26.84" and lines["operation_time_h"] == "2.31"
    assert lines["cot_electrical_dry_weight"] == "-"
    assert lines["failure"] == "simulation at 1.250 s: battery empty"


def test_help_and_run_import_only_what_they_need():
    """`manta-drake --help` lists every command without importing Drake or any command's
    module; the parser of `run` imports none of the other commands' modules."""
    code = (
        "import sys; from manta_drake.cli import _parser; _parser(sys.argv[1:]); "
        "print(' '.join(m for m in ('pydrake', 'manta_drake.seam', 'manta_drake.sweep', "
        "'manta_drake.calibrate', 'manta_drake.studies', 'distributed', 'lcm') "
        "if m in sys.modules))"
    )
    import subprocess
    import sys as _sys

    for argv in (["--help"], ["run", "stand", "--out", "x"]):
        out = subprocess.run(
            [_sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120
        )
        assert out.stdout.strip() == "", (argv, out.stdout, out.stderr)
    listed = subprocess.run(
        [_sys.executable, "-m", "manta_drake.cli", "--help"],
        capture_output=True,
        text=True,
        timeout=120,
    ).stdout
    for command in ("run", "list", "station", "controller", "sweep", "calibrate", "study"):
        assert command in listed


def test_an_option_replaces_a_checked_set_value_and_keeps_its_other_fields():
    """--duration and --no-meshcat are layered after the --set values: they win over them,
    and a --set of the whole section keeps its other fields."""
    from manta_drake.cli import _scenario
    from manta_drake.scenario import find_scenario

    s = _scenario(
        find_scenario("stand"),
        ["visualization={meshcat: true, recording_fps: 20}", "duration=5"],
        {"duration": 0.3, "visualization.meshcat": False},
    )
    assert s.duration == 0.3 and s.visualization.meshcat is False
    assert s.visualization.recording_fps == 20.0
