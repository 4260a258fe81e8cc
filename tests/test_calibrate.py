"""Sim2Real calibration (manta_drake.calibrate): residuals, the file format, the written
coefficients, and the recovery of a known perturbation on a Dask LocalCluster."""

import math
import pathlib

import numpy as np
import pytest
import yaml

from manta_drake import calibrate as C
from manta_drake.cluster import dask_client
from manta_drake.model.coefficients import load_coefficients
from manta_drake.sweep import SweepError

ROOT = pathlib.Path(__file__).resolve().parent.parent
SWEEPS = ROOT / "diagrams" / "sweeps"
SIGMA = C.Sigma(position_m=0.005, yaw_deg=0.5, velocity_m_s=0.002, yaw_rate_deg_s=0.2)


def write(path: pathlib.Path, text: str) -> pathlib.Path:
    path.write_text(text)
    return path


def measured_csv(path: pathlib.Path, n: int = 5) -> pathlib.Path:
    t = np.arange(n) * 0.1
    C.write_measured(path, {"t": t, "x": t, "y": 0 * t, "z": -0.1 + 0 * t, "yaw": 0 * t})
    return path


# --- residuals -------------------------------------------------------------------------------


def test_trajectory_residuals_are_standard_scores():
    t = np.linspace(0.0, 1.0, 11)
    measured = {"t": t, "x": t.copy(), "yaw": np.zeros_like(t)}
    sim_t = np.linspace(0.0, 1.0, 101)
    same = {"t": sim_t, "x": sim_t.copy(), "yaw": np.zeros_like(sim_t)}
    assert np.allclose(C.trajectory_residuals(measured, same, ["x", "yaw"], SIGMA), 0.0)
    off = dict(same, x=sim_t + 0.01, yaw=np.full_like(sim_t, 2 * np.pi + math.radians(1.0)))
    r = C.trajectory_residuals(measured, off, ["x", "yaw"], SIGMA)
    assert np.allclose(r[:11], 2.0)  # 0.01 m / 0.005 m
    assert np.allclose(r[11:], 2.0)  # 1 deg (a turn wrapped away) / 0.5 deg
    # A run that stopped at 0.5 s scores the samples it did not reach as failures.
    short = {k: v[:51] for k, v in same.items()}
    r = C.trajectory_residuals(measured, short, ["x"], SIGMA)
    assert np.allclose(r[:6], 0.0) and np.all(r[6:] == C.FAILED_RESIDUAL)
    assert np.all(
        C.trajectory_residuals(measured, {"status": "error"}, ["x"], SIGMA) == C.FAILED_RESIDUAL
    )


def test_target_residuals():
    r = C.target_residuals(
        {"u": 0.05, "yaw_rate_deg_s": -3.0}, {"u": 0.056, "yaw_rate_deg_s": -2.0}, SIGMA
    )
    assert r == pytest.approx([3.0, 5.0])
    r = C.target_residuals({"u": 0.05}, {"u": math.nan}, SIGMA)  # no mean velocity
    assert r.tolist() == [C.FAILED_RESIDUAL]


def test_standard_errors_of_a_linear_model():
    rng = np.random.default_rng(3)
    J = np.column_stack([np.ones(200), np.linspace(-1, 1, 200)])
    residuals = rng.normal(0.0, 1.0, 200)
    s2 = residuals @ residuals / 198
    expected = np.sqrt(np.diag(np.linalg.inv(J.T @ J)) * s2)
    assert C.standard_errors(J, residuals) == pytest.approx(expected)
    singular = np.column_stack([np.ones(5), np.ones(5)])
    assert np.all(np.isnan(C.standard_errors(singular, np.ones(5))))


def test_fd_points_turn_back_at_the_upper_bound():
    steps, points = C.fd_points([1.0, 2.95], ([0.3, 0.3], [3.0, 3.0]), 0.05)
    assert steps == pytest.approx([0.05, -0.1475])
    assert points[0] == pytest.approx([1.05, 2.95]) and points[1] == pytest.approx([1.0, 2.8025])


# --- the calibration file --------------------------------------------------------------------

GOOD = """\
name: t
parameters:
  - {name: hull, coefficients: [body.linear_damping, body.quadratic_damping], bounds: [0.3, 3]}
experiments:
  - {name: swim, scenario: locomotion_swim, overrides: {duration: 2.0}, measured: m.csv,
     columns: [x, y, yaw]}
  - {name: walk, scenario: locomotion_walk, target: {u: 0.07}}
"""


@pytest.mark.slow
@pytest.mark.parametrize(
    "change, message",
    [
        (("name: t", "nme: t"), "calibration.nme: unknown key"),
        (("body.quadratic_damping]", "body.quadratic]"), "unknown coefficient 'body.quadratic'"),
        (("bounds: [0.3, 3]", "bounds: [0.3, 3], initial: 4.0"), "parameters\\[0\\].initial"),
        (("measured: m.csv", "measured: none.csv"), "experiments\\[0\\].measured: file not found"),
        (("columns: [x, y, yaw]", "columns: [x, roll]"), "experiments\\[0\\].columns"),
        (("target: {u: 0.07}", "target: {speed: 0.07}"), "experiments\\[1\\].target.speed"),
        (
            ("overrides: {duration: 2.0}", "overrides: {duraton: 2.0}"),
            "experiments\\[0\\].overrides.duraton",
        ),
        (("scenario: locomotion_walk", "scenario: no_such"), "experiments\\[1\\].scenario"),
        (("target: {u: 0.07}", "weight: 2.0"), "experiments\\[1\\]: give `measured`"),
    ],
)
def test_bad_calibration_files_fail_at_load_naming_the_path(tmp_path, change, message):
    measured_csv(tmp_path / "m.csv")
    assert C.load_calibration(write(tmp_path / "c.yaml", GOOD)).parameters[0].name == "hull"
    with pytest.raises(SweepError, match=message):
        C.load_calibration(write(tmp_path / "c.yaml", GOOD.replace(*change)))


def test_two_parameters_may_not_scale_one_coefficient(tmp_path):
    measured_csv(tmp_path / "m.csv")
    text = GOOD.replace(
        "bounds: [0.3, 3]}",
        "bounds: [0.3, 3]}\n  - {name: lin, coefficients: [body.linear_damping]}",
    )
    with pytest.raises(SweepError, match="body.linear_damping is also fitted by hull"):
        C.load_calibration(write(tmp_path / "c.yaml", text))


@pytest.mark.parametrize(
    "text, message",
    [
        ("t,x\n0,1\n1,2\n", "no column 'y'"),
        ("t,x,y\n0,1,2\n0,1,2\n", "t must increase"),
        ("t,x,y\n0,1,2\n1,a,2\n", "data row 2: column x"),
    ],
)
def test_bad_measured_files(tmp_path, text, message):
    with pytest.raises(SweepError, match=message):
        C.load_measured(write(tmp_path / "m.csv", text), ["x", "y"])


def test_experiment_scenario_multiplies_scales_and_sets_seed_and_prior(tmp_path):
    measured_csv(tmp_path / "m.csv")
    config = C.load_calibration(
        write(
            tmp_path / "c.yaml",
            GOOD.replace(
                "overrides: {duration: 2.0}",
                "overrides: {duration: 2.0, water.coefficient_scales.body.linear_damping: 2.0}",
            )
            + "seed: 5\n",
        )
    )
    scenario = C.experiment_scenario(
        config, config.experiments[0], C.parameter_scales(config, [1.5])
    )
    assert scenario.water.coefficient_scales == {
        "body.linear_damping": 3.0,
        "body.quadratic_damping": 1.5,
    }
    assert scenario.random_seed == 5 and scenario.duration == 2.0
    assert scenario.water.coefficients == "package://manta_drake/hydrodynamics.yaml"
    assert scenario.visualization.meshcat is False


def test_written_coefficients_are_a_loadable_coefficients_file(tmp_path):
    measured_csv(tmp_path / "m.csv")
    config = C.load_calibration(write(tmp_path / "c.yaml", GOOD))
    result = C.CalibrationResult(
        x=np.array([1.2]),
        x0=np.array([1.0]),
        names=["hull"],
        cost=1.0,
        initial_cost=9.0,
        standard_error=np.array([0.01]),
        success=True,
        message="ok",
        evaluations=3,
        simulations=6,
        wall_time_s=1.0,
    )
    path = C.write_calibrated_coefficients(tmp_path / "coefficients.yaml", config, result)
    prior, fitted = dict(load_coefficients().entries()), dict(load_coefficients(path).entries())
    assert fitted.keys() == prior.keys()
    for name in prior:
        if name in ("body.linear_damping", "body.quadratic_damping"):
            assert fitted[name].value == pytest.approx([1.2 * v for v in prior[name].value])
            assert fitted[name].source.startswith("calibrated (Sim2Real")
            assert "swim (m.csv)" in fitted[name].source and "x1.2 " in fitted[name].source
            assert prior[name].source in fitted[name].source  # the prior's source is kept
        else:
            assert fitted[name].value == prior[name].value
            assert fitted[name].source == prior[name].source


def test_shipped_calibration_and_its_synthetic_data():
    config = C.load_calibration(SWEEPS / "calibration.yaml")
    coefficients = [c for p in config.parameters for c in p.coefficients]
    assert coefficients == ["body.linear_damping", "body.quadratic_damping"]
    truth = yaml.safe_load((SWEEPS / "data" / "truth.yaml").read_text())
    assert truth["coefficient_scales"] == {
        "body.linear_damping": 1.25,
        "body.quadratic_damping": 1.25,
    }
    for e in config.experiments:
        data = C.load_measured(config.folder / e.measured, C.TRAJECTORY_COLUMNS)
        assert len(data["t"]) > 20


def test_calibrate_cli_error_is_one_line(tmp_path, capsys):
    from manta_drake.cli import main

    bad = write(tmp_path / "c.yaml", GOOD.replace("body.quadratic_damping]", "body.quad]"))
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "calibration.parameters[0].coefficients" in err[0]


# --- recovery --------------------------------------------------------------------------------

RECOVER = """\
name: recover
parameters:
  - {name: hull_damping, coefficients: [body.linear_damping, body.quadratic_damping],
     initial: 1.0, bounds: [0.3, 3.0]}
experiments:
  - {name: swim, scenario: locomotion_swim, overrides: {duration: 6.0}, measured: swim.csv,
     columns: [x, z]}
sigma: {position_m: 0.001, yaw_deg: 0.1}
optimizer: {max_evaluations: 12, diff_step: 0.1}
"""


@pytest.mark.slow
def test_calibration_recovers_a_known_hull_damping_on_a_cluster(tmp_path):
    """Synthetic data from hull damping x1.25 plus noise; the fit from x1.0 must land within
    10 % (one parameter, a 6 s swim, two simulations per iteration on 2 workers). The
    noise is a motion-capture system's (1 mm): the hull's damping is a small part of a
    0.1 m/s swim's drag (the fins' and links' carry most), so its signal is small (x1.25
    moves x by 2 mm rms). The columns are x and z, which move monotonically with the
    scale; the sideways drift and the yaw do not (y by 1.0, 1.6, 2.0 mm rms at x1.05, 1.1,
    1.25). The forward difference steps 10 %: below that the simulated swim is not smooth
    (a 0.05 % change of the scale can move x by 0.4 mm)."""
    path = write(tmp_path / "c.yaml", RECOVER)
    config = C.load_calibration(path, require_data=False)
    truth = {"body.linear_damping": 1.25, "body.quadratic_damping": 1.25}
    with dask_client(workers=2) as client:
        data = C.synthesize_measurements(
            config,
            truth,
            C.Sigma(position_m=0.001, yaw_deg=0.1),
            seed=11,
            period=0.1,
            client=client,
        )
        C.write_measured(tmp_path / "swim.csv", data["swim"])
        config = C.load_calibration(path)
        result = C.calibrate(config, tmp_path / "out", client=client, progress=False)
    fitted = result.fitted()["hull_damping"]
    assert abs(fitted - 1.25) / 1.25 < 0.10, result
    # Residuals are standard scores of noise with the stated sigma: at the truth the cost
    # 0.5 sum r^2 is 0.5 chi^2_n (mean n/2, sd sqrt(n/2)). The fit must reach that floor
    # (within 3 sd) from a start well above it.
    n = 2 * len(data["swim"]["t"])
    assert result.cost < 0.5 * n + 3 * np.sqrt(0.5 * n), (result.cost, n)
    assert result.initial_cost > 2 * result.cost
    assert np.isfinite(result.standard_error[0]) and result.standard_error[0] < 0.1
    written = dict(load_coefficients(result.coefficients_file).entries())
    prior = dict(load_coefficients().entries())
    assert written["body.linear_damping"].value[0] == pytest.approx(
        fitted * prior["body.linear_damping"].value[0], rel=1e-6
    )
    assert result.figure.exists() and result.history_file.exists()
    import json

    history = json.loads(result.history_file.read_text())
    assert history["history"][0]["x"] == [1.0] and len(history["history"]) == result.evaluations


# --- measured data checked against the experiment, before any simulation ---------------------


def _csv(path: pathlib.Path, t) -> pathlib.Path:
    t = np.asarray(t, dtype=float)
    C.write_measured(path, {"t": t, "x": t, "y": 0 * t, "z": -0.1 + 0 * t, "yaw": 0 * t})
    return path


def _put(path: pathlib.Path, content) -> pathlib.Path:
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path


@pytest.fixture
def no_simulation(monkeypatch):
    """Fails the test if anything is simulated."""
    from manta_drake.calibrate import evaluator

    def refuse(*args, **kwargs):
        raise AssertionError("a simulation ran")

    monkeypatch.setattr(evaluator, "simulate_trajectory", refuse)


@pytest.mark.slow
@pytest.mark.parametrize(
    "data, change, message",
    [
        # GOOD's swim runs 2.0 s: samples up to 3 s cannot be compared with it.
        (
            lambda p: _csv(p, np.linspace(0.0, 3.0, 7)),
            None,
            "calibration.experiments[0].measured: {csv}: t ends at 3.0 s, after the run's end "
            "(duration 2.0 s; allowed: 0 <= t <= 2.0); shorten the data or set the experiment's "
            "overrides: {{duration: ...}}",
        ),
        (
            lambda p: _csv(p, [-0.5, 0.0, 0.5]),
            None,
            "calibration.experiments[0].measured: {csv}: t starts at -0.5 s; times are "
            "seconds from "
            "the start of the run (allowed: t >= 0)",
        ),
        (
            lambda p: _csv(p, [0.0, 0.5, 0.5, 1.0]),
            None,
            "calibration.experiments[0].measured: {csv}: t must increase, with at least two "
            "samples "
            "(data row 3: 0.5 s after 0.5 s)",
        ),
        (
            lambda p: _csv(p, [0.0, 0.5]),
            ("target: {u: 0.07}", "target: {u: .nan}"),
            "calibration.experiments[1].target.u: nan is not finite",
        ),
        (
            lambda p: _csv(p, [0.0, 0.5]),
            ("target: {u: 0.07}", "target: {u: 0.07, v: .inf}"),
            "calibration.experiments[1].target.v: inf is not finite",
        ),
        (
            lambda p: _put(p, b"\x89PNG\r\n\x1a\n\x00\xff\xfe"),
            None,
            "calibration.experiments[0].measured: {csv}: not a UTF-8 text (CSV) file",
        ),
        (
            lambda p: _put(p, b"t,x,y,z,yaw\n0,0,0,0,0\x00\n"),
            None,
            "calibration.experiments[0].measured: {csv}: not a text (CSV) file (it holds NUL "
            "bytes)",
        ),
        (
            lambda p: _put(p, "t,x,y,yaw\n0,0,0,0\n1,0,0,0\n"),
            ("columns: [x, y, yaw]", "columns: [x, z]"),
            "calibration.experiments[0].measured: {csv} has no column 'z' (header: t, x, y, yaw)",
        ),
        (
            lambda p: _put(p, "t,x,y,x,yaw\n0,0,0,0,0\n1,0,0,0,0\n"),
            None,
            "calibration.experiments[0].measured: {csv}: column 'x' appears twice in the header",
        ),
        (
            lambda p: _put(p, "t,x,y,yaw\n0,0,0,0\n1,0,0\n"),
            None,
            "calibration.experiments[0].measured: {csv}: data row 2 has 3 fields, the header 4",
        ),
        (
            lambda p: _put(p, "t,x,y,yaw\n0,0,0,0\n1,nan,0,0\n"),
            None,
            "calibration.experiments[0].measured: {csv}: data row 2: column x is nan, not a finite "
            "number",
        ),
        (
            lambda p: _csv(p, [0.0, 0.5]),
            ("overrides: {duration: 2.0}", "overrides: {duration: -2.0}"),
            "calibration.experiments[0].overrides: duration: -2.0 is outside the allowed range "
            "(0, 3600] s",
        ),
    ],
)
def test_measured_data_are_checked_against_the_experiment(
    tmp_path, no_simulation, data, change, message
):
    csv = data(tmp_path / "m.csv")
    text = GOOD.replace(*change) if change else GOOD
    with pytest.raises(SweepError) as e:
        C.load_calibration(write(tmp_path / "c.yaml", text))
    assert str(e.value) == message.format(csv=csv)


def test_data_beyond_the_run_fail_the_command_in_one_line(tmp_path, capsys, no_simulation):
    from manta_drake.cli import main

    _csv(tmp_path / "m.csv", np.linspace(0.0, 3.0, 7))
    out = tmp_path / "out"
    assert (
        main(
            [
                "calibrate",
                str(write(tmp_path / "c.yaml", GOOD)),
                "--out",
                str(out),
                "--workers",
                "0",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "t ends at 3.0 s, after the run's end (duration 2.0 s" in err[0]
    assert not out.exists()  # no coefficients file labelled calibrated


def test_the_shipped_data_lie_within_their_runs():
    config = C.load_calibration(SWEEPS / "calibration.yaml")
    for e in config.experiments:
        t = C.load_measured(config.folder / e.measured, e.columns)["t"]
        assert 0.0 <= t[0] and t[-1] <= C.experiment_scenario(config, e, {}).duration


# --- the output folder, checked before the fit -----------------------------------------------


@pytest.mark.parametrize("case", ["a file", "under a file", "the prior", "unwritable"])
def test_calibrate_out_is_checked_before_the_fit(tmp_path, capsys, no_simulation, case):
    import os

    from manta_drake.cli import main

    measured_csv(tmp_path / "m.csv")
    (tmp_path / "file").write_text("x")
    prior_dir = tmp_path / "earlier"
    prior_dir.mkdir()
    (prior_dir / "coefficients.yaml").write_text(
        (ROOT / "models" / "hydrodynamics.yaml").read_text()
    )
    text = GOOD + (
        f"coefficients: {prior_dir / 'coefficients.yaml'}\n" if case == "the prior" else ""
    )
    config_path = write(tmp_path / "c.yaml", text)
    if case == "unwritable":
        if os.geteuid() != 0:
            (tmp_path / "ro").mkdir(mode=0o555)
            out = tmp_path / "ro" / "out"
        elif pathlib.Path("/sys").is_dir():
            out = pathlib.Path("/sys/manta_drake_calibration")
        else:
            pytest.skip("no read-only folder for root here")
    else:
        out = {
            "a file": tmp_path / "file",
            "under a file": tmp_path / "file" / "out",
            "the prior": prior_dir,
        }[case]
    message = {
        "a file": f"--out {out}: is a file, not a folder",
        "under a file": f"--out {out}: cannot be created ({tmp_path / 'file'} is a file)",
        "the prior": f"--out {out}: writing coefficients.yaml would overwrite the input "
        f"{prior_dir / 'coefficients.yaml'}; choose another output folder",
        "unwritable": f"--out {out}: ",
    }[case]
    assert main(["calibrate", str(config_path), "--out", str(out), "--workers", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"manta-drake: error: {message}")
    with pytest.raises(SweepError, match=f"^--out {out}"):  # and from Python
        C.calibrate(C.load_calibration(config_path), out, progress=False)


@pytest.mark.slow
def test_a_fit_whose_simulations_fail_writes_no_coefficients(tmp_path, capsys, monkeypatch):
    """Every simulation fails: the cost is the failures' penalty, so nothing is calibrated;
    the history is written, no coefficients file (an earlier one is removed), exit 1."""
    from manta_drake.calibrate import evaluator
    from manta_drake.cli import main

    monkeypatch.setattr(
        evaluator,
        "simulate_trajectory",
        lambda text: {"status": "failed", "reason": "simulation failed at t = 0.1 s: diverged"},
    )
    measured_csv(tmp_path / "m.csv")
    out = tmp_path / "out"
    out.mkdir()
    (out / "coefficients.yaml").write_text("# an earlier fit's\n")
    assert (
        main(
            [
                "calibrate",
                str(write(tmp_path / "c.yaml", GOOD)),
                "--out",
                str(out),
                "--workers",
                "0",
                "--quiet",
            ]
        )
        == 1
    )
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == [
        "manta-drake: calibrate t: not calibrated: a simulation at the fitted point did not "
        "run to its end (swim: failed (simulation failed at t = 0.1 s: diverged); walk: "
        "failed (simulation failed at t = 0.1 s: diverged))"
    ]
    assert not (out / "coefficients.yaml").exists()
    assert "coefficients: none written" in captured.out
    import json

    history = json.loads((out / "calibration.json").read_text())
    assert history["success"] is False and history["message"].startswith("not calibrated")
