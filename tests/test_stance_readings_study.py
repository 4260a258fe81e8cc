"""The stance and readings studies' pages (manta_drake.studies.stance, .readings): their
templates on small tables with known numbers, where ``--out`` and ``--runs`` put what they
write, and the refusal of an installed package without ``--out``."""

import numpy as np
import pytest

from manta_drake.config_io import ScenarioError
from manta_drake.studies import readings, report, stance


def _kin(sweep, reading, fl_rr, fr_rl, x, L=0.38, W=0.85):
    return {
        "reading": reading,
        "sweep": sweep,
        "fl_rr": fl_rr,
        "fr_rl": fr_rl,
        "centroid_x": x,
        "L": L,
        "W": W,
    }


def _dyn(reading, sweep, gait, u, yaw=-7.084, start=6.0, end=8.44):
    return {
        "gait_reading": reading,
        "fin_sweep_deg": sweep,
        "gait": gait,
        "u": u,
        "v": 0.0655,
        "yaw_rate_deg_s": yaw,
        "mean_roll_deg": 0.42,
        "mean_pitch_deg": -2.06,
        "steady_start_s": start,
        "steady_end_s": end,
    }


def test_the_stance_block_shows_each_number_in_its_place():
    kin = []
    for sweep in stance.SWEEPS_DEG:
        kin += [
            _kin(sweep, "paper", -0.0474, 0.0431, 0.0449 + sweep),
            _kin(sweep, "mirrored", -0.1071, 0.1069, 0.1141, L=0.404, W=0.8561),
        ]
    dyn = [
        _dyn("mirrored", 30.0, "walk", 0.0503, yaw=0.559, end=20.0),
        _dyn("paper", 10.0, "trot", 0.0268),
        _dyn("paper", 10.0, "swim", 0.1139),
        _dyn("paper", 10.0, "swim", 9.0),  # a second row of one run: the first is shown
        _dyn("other", 10.0, "swim", 9.0),  # not one of CONFIGS: not shown
    ]
    lines = stance.markdown(kin, dyn, "t.csv").split("\n")
    assert lines[:2] == ["<!-- stance-study:begin -->", ""]
    assert lines[2].startswith("**Kinematics** (Eq. 1; the trot's stance X_gait under each")
    assert lines[2].endswith("the robot's size at the zero pose (Table 1: L 0.38 m, W 0.85 m).")
    # Each sweep once, its paper row's size; diagonals and tips signed to the millimetre.
    assert lines[6] == "| 0 | 0.38 x 0.85 | -0.047 / +0.043 | +0.045 | -0.107 / +0.107 | +0.114 |"
    assert lines[10] == (
        "| 40 | 0.38 x 0.85 | -0.047 / +0.043 | +40.045 | -0.107 / +0.107 | +0.114 |"
    )
    assert lines[12].endswith("body pitch + is nose down). From `t.csv`:")
    # CONFIGS' order (paper 10 deg first), then GAITS' order (swim before trot).
    assert lines[16:19] == [
        "| paper, 10 deg | swim | +0.114 | +0.066 | -7.08 | +0.4 / -2.1 | 6-8.4 |",
        "| paper, 10 deg | trot | +0.027 | +0.066 | -7.08 | +0.4 / -2.1 | 6-8.4 |",
        "| mirrored, 30 deg | walk | +0.050 | +0.066 | +0.56 | +0.4 / -2.1 | 6-20.0 |",
    ]
    assert lines[19:] == ["", "<!-- stance-study:end -->"]


def test_stance_out_writes_a_new_page_and_its_figure_there(tmp_path):
    out = tmp_path / "report"
    assert stance.main(["--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["figures", "stance.md"]
    assert [p.name for p in (out / "figures").iterdir()] == ["stance.png"]
    lines = (out / "stance.md").read_text().split("\n")
    assert lines[0] == "# The stance behind each reading of the gait matrices"
    assert lines[2].endswith("Regenerate with `manta-drake study stance`.")
    assert lines[4] == stance.MARK_BEGIN and lines[-2:] == [stance.MARK_END, ""]
    assert any(line.endswith("From `diagrams/sweeps/data/stance_table.csv`:") for line in lines)


def test_the_readings_page_shows_each_number_in_its_place():
    rows = [
        {
            "reading": "shipped",
            "gait": "swim",
            "u": 0.1136,
            "v": 0.0655,
            "yaw_rate": -7.084,
            "clearance": 0.514,
        },
        {
            "reading": "printed",
            "gait": "trot",
            "u": float("nan"),
            "v": float("nan"),
            "yaw_rate": float("nan"),
            "clearance": 0.0,
        },
    ]
    assert readings.page(rows, 12.0) == (
        "Mean over 6-12 s of 12 s runs (`manta-drake study readings --duration 12`):\n"
        "\n"
        "| reading | gait | u m/s | v m/s | yaw rate deg/s | min wall clearance m |\n"
        "| --- | --- | --- | --- | --- | --- |\n"
        "| shipped | swim | +0.114 | +0.066 | -7.08 | 0.51 |\n"
        "| printed | trot | +nan | +nan | +nan | 0.00 |\n"
    )
    assert readings.page([], 5.0).startswith("Mean over 2.5-5 s of 5 s runs (")


def test_readings_runs_go_to_runs_and_the_page_to_out(tmp_path, monkeypatch, capsys):
    """The runs (here stand-ins that write a log and return metrics) in RUNS/<reading>_<gait>,
    the page in OUT/readings.md, the swims' paths in OUT/figures/swim_paths.png."""
    calls = []

    def fake_run(reading, gait, out, duration, fin_sweep_deg=None):
        calls.append((reading, gait, out, duration))
        out.mkdir(parents=True)
        xyz = np.column_stack([np.linspace(0, 1, 5), np.zeros(5), np.zeros(5)])
        np.savez(out / "log.npz", body_xyz=xyz)
        return {
            "mean_velocity_body": (0.1, -0.02),
            "yaw_rate_deg_s": 1.5,
            "min_wall_clearance_m": 2,
        }

    monkeypatch.setattr(readings, "run_reading", fake_run)
    runs, out = tmp_path / "runs", tmp_path / "out"
    argv = ["--runs", str(runs), "--out", str(out), "--readings", "shipped,swim_no_lag"]
    assert readings.main([*argv, "--gaits", "swim,walk", "--duration", "4"]) == 0
    assert [c[:2] for c in calls] == [
        ("shipped", "swim"),
        ("shipped", "walk"),
        ("swim_no_lag", "swim"),
    ]
    assert [c[2] for c in calls] == [
        runs / "shipped_swim",
        runs / "shipped_walk",
        runs / "swim_no_lag_swim",
    ]
    assert {c[3] for c in calls} == {4.0}
    assert sorted(p.name for p in out.iterdir()) == ["figures", "readings.md"]
    assert [p.name for p in (out / "figures").iterdir()] == ["swim_paths.png"]
    page = (out / "readings.md").read_text()
    assert page.startswith("Mean over 2-4 s of 4 s runs")
    assert "| swim_no_lag | swim | +0.100 | -0.020 | +1.50 | 2.00 |\n" in page
    assert "shipped       walk     u +0.100  v -0.020 m/s  yaw  +1.50 deg/s  clearance 2.00 m" in (
        capsys.readouterr().out
    )


@pytest.mark.parametrize(
    "module, argv, needle",
    [
        (stance, [], "--table FILE is required"),
        (
            stance,
            ["--table", str(stance.ROOT / "diagrams/sweeps/data/stance_table.csv")],
            "--out DIR is required",
        ),
        (readings, ["--gaits", "swim"], "--out DIR is required"),
    ],
)
def test_an_installed_package_is_told_to_name_its_folders(
    tmp_path, monkeypatch, module, argv, needle
):
    """An installed package (no checkout above it): the defaults into the checkout are
    refused in one line naming the option, before anything is read or run."""
    monkeypatch.setattr(report, "REPO", tmp_path)
    monkeypatch.chdir(tmp_path.parent)
    with pytest.raises(ScenarioError) as err:
        module.main(argv, prog="manta-drake study x")
    assert str(err.value).startswith(
        f"manta-drake study x: {needle}: this manta_drake is installed"
    )
    assert "\n" not in str(err.value)
